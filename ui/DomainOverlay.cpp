// The domain-of-interest overlay (View > Domain of interest): the shell of the space a player
// can reach (core/domain/ReachableSpace.h), the domain placement, the bake's fit and eval use
// by default when the set has no importance volume, as faint green cell faces. With importance
// volumes the domain is the boxes, which the viewport draws already, and nothing is added.
#include <QMatrix4x4>

#include "core/common/Error.h"
#include "core/domain/DomainPoints.h"
#include "ui/Document.h"
#include "ui/Viewport.h"

namespace ps::ui {

namespace {

/// Cell faces drawn at most (every k-th beyond it, ReachableSpace::shellFaces).
constexpr size_t kMaxShellFaces = 60000;

}  // namespace

void Viewport::drawDomain(const QMatrix4x4& vp) {
  const Tracer* tracer = doc_->tracer();
  if (!overlay(Overlay::Domain) || !tracer) return;
  const size_t volumes = doc_->probeSet().importanceVolumes.size();
  if (domainTracer_ != tracer || domainVolumes_ != volumes) {
    // Computed once per scene (0.1 to 4 s on the shared scenes, on this thread: a toggle).
    domainTracer_ = tracer;
    domainVolumes_ = volumes;
    domainLines_.clear();
    try {
      const Domain d = makeDomain(*tracer, importanceBoxes(doc_->probeSet().importanceVolumes), {});
      if (d.reachable)
        for (const auto& face : d.reachable->shellFaces(kMaxShellFaces))
          for (size_t e = 0; e < 4; ++e)
            for (const Vec3& p : {face[e], face[(e + 1) % 4]})
              domainLines_.insert(domainLines_.end(),
                                  {float(p.x), float(p.y), float(p.z), 0.25f, 0.9f, 0.55f, 0.3f});
    } catch (const ParameterError&) {
      // No reachable space (no walkable surface): nothing to draw.
    }
  }
  if (domainLines_.empty()) return;
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glDepthMask(GL_FALSE);
  drawLines(domainLines_, GL_LINES, vp);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
}

}  // namespace ps::ui
