// Frame time of the editor's viewport, which is to stay interactive with 10k probes and 100k
// glyphs. Needs a display with OpenGL 3.3: run under Xvfb with Mesa's software renderer, e.g.
//   LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s "-screen 0 1280x1024x24" build/tests/ui/bench_viewport
// Each frame is paintGL into the widget's framebuffer followed by glFinish (no readback).
// The probes are 10,000 captured-looking probes spread through two-rooms.gltf (random positions,
// SH of a constant plus a lobe, seeded); the glyph grid has the smallest resolution giving at
// least 100,000 cells over the scene's bounds.
#include <benchmark/benchmark.h>

#include <QApplication>
#include <QFile>
#include <QMouseEvent>
#include <QUndoStack>
#include <memory>
#include <random>

#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "ui/Document.h"
#include "ui/Viewport.h"

using namespace ps;
using namespace ps::ui;

namespace {

const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

struct Fixture {
  Document doc;
  std::unique_ptr<Viewport> vp;
  int glyphs = 0;

  Fixture(int probeCount, int minGlyphs) {
    doc.setAutoPropose(false);
    doc.openScene(kScene);
    const Bounds3 b = doc.scene()->bounds;
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Probe> probes;
    for (int i = 0; i < probeCount; ++i) {
      Probe p;
      p.position = b.lo + Vec3(u(rng) * b.extent().x, u(rng) * b.extent().y, u(rng) * b.extent().z);
      p.state = i % 4 == 0 ? ProbeState::Accepted : ProbeState::Candidate;
      ShRgb sh;
      sh.c[0] = Rgb(1, 0.9, 0.8) * (0.5 + 2 * u(rng));
      const Vec3 d = normalize(Vec3(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5));
      const auto y = shBasis(d);
      for (int k = 0; k < kShCoeffCount; ++k) sh.c[size_t(k)] += Rgb(1, 1, 1) * y[size_t(k)];
      p.sh = sh;
      probes.push_back(p);
    }
    doc.addProbes(std::move(probes), "Add");
    vp = std::make_unique<Viewport>(&doc);
    // Flat colours, without the lit view's background rebuilds: the cost of the probes and the
    // overlays themselves.
    vp->setFlatShading(true);
    vp->setPreviewLighting(false);
    vp->resize(1024, 768);
    vp->show();
    QApplication::processEvents();
    if (minGlyphs > 0) {
      int r = 8;
      for (;; ++r) {
        const double cell = std::max({b.extent().x, b.extent().y, b.extent().z}) / r;
        double n = 1;
        for (int a = 0; a < 3; ++a) n *= std::max(1.0, std::ceil(b.extent()[a] / cell - 1e-9));
        if (n >= minGlyphs) break;
      }
      vp->setGlyphResolution(r);
      vp->setOverlay(Viewport::Overlay::Glyphs, true);
      vp->setOverlay(Viewport::Overlay::Slice, true);
      glyphs = int(vp->glyphGrid().size());
    }
    vp->frameAll();
    vp->renderNow();  // uploads
  }
};

void frame(benchmark::State& state, int probes, int minGlyphs) {
  Fixture f(probes, minGlyphs);
  for (auto _ : state) {
    f.vp->camera().orbit(1.0f, 0.0f);  // a new view each frame, as while orbiting
    f.vp->renderNow();
  }
  state.counters["probes"] = double(f.doc.probes().size());
  state.counters["glyphs"] = f.glyphs;
}

void BM_ViewportFrameSceneOnly(benchmark::State& state) {
  frame(state, 0, 0);
}
void BM_ViewportFrame1kProbes(benchmark::State& state) {
  frame(state, 1000, 0);
}
void BM_ViewportFrame10kProbes(benchmark::State& state) {
  frame(state, 10000, 0);
}
void BM_ViewportFrame10kProbes100kGlyphs(benchmark::State& state) {
  frame(state, 10000, 100000);
}

/// One step of a drag of one probe along the move handle's X arm with 10k probes and the overlays
/// on, through real mouse events: the move command, the instance upload and the frame (the
/// fields are rebuilt when the drag ends, not per step).
void BM_ViewportDragStep10kProbes100kGlyphs(benchmark::State& state) {
  Fixture f(10000, 100000);
  Viewport* vp = f.vp.get();
  const uint64_t id = f.doc.probes()[0].id;
  vp->setSelection({id});
  vp->camera().target =
      QVector3D(float(f.doc.probes()[0].position.x), float(f.doc.probes()[0].position.y),
                float(f.doc.probes()[0].position.z));
  vp->renderNow();
  const QVector3D o = *vp->handleOrigin();
  const auto grab = vp->project(Vec3(o.x() + 0.6 * vp->handleArmMeters(), o.y(), o.z()));
  if (!grab || vp->handlePartAt(*grab) != HandlePart::AxisX) {
    state.SkipWithError("the handle is not under the cursor");
    return;
  }
  auto send = [&](QEvent::Type type, QPointF pos, Qt::MouseButtons buttons) {
    QMouseEvent e(type, pos, vp->mapToGlobal(pos), Qt::LeftButton, buttons, Qt::NoModifier);
    QCoreApplication::sendEvent(vp, &e);
  };
  send(QEvent::MouseButtonPress, *grab, Qt::LeftButton);
  int i = 0;
  for (auto _ : state) {
    send(QEvent::MouseMove, *grab + QPointF(5 + (++i % 40), 0), Qt::LeftButton);
    vp->renderNow();
  }
  send(QEvent::MouseButtonRelease, *grab, Qt::NoButton);
  if (f.doc.undoStack()->count() != 2) state.SkipWithError("the drag was not one undo step");
  state.counters["probes"] = double(f.doc.probes().size());
  state.counters["glyphs"] = f.glyphs;
}

/// Rebuilding the overlay data after an edit (preview volume of 10k probes, 100k-cell glyph grid,
/// 40-cell preview grid, edges and leak tests), uploading it and a frame. The editor does the
/// rebuild on a worker thread; here it is timed synchronously.
void BM_OverlayRebuild10kProbes100kGlyphs(benchmark::State& state) {
  Fixture f(10000, 100000);
  const uint64_t id = f.doc.probes()[1].id;
  const Vec3 start = f.doc.probes()[1].position;
  int i = 0;
  for (auto _ : state) {
    f.doc.moveProbe(id, start + Vec3(0.001 * (++i % 100), 0, 0), f.doc.newMergeKey());
    (void)
        f.vp->previewVolume();  // the rebuild, synchronously (the editor runs it in the background)
    f.vp->renderNow();
  }
  state.counters["probes"] = double(f.doc.probes().size());
  state.counters["glyphs"] = f.glyphs;
}

}  // namespace

// Real time: the GPU work (Mesa's llvmpipe runs it on its own threads) is in the frame.
/// The preview volume after one probe of 10k moves (keeping its SH): the editor's
/// PreviewVolumeMirror (a diff of the probes, then one local move in an EditableProbeVolume)
/// against buildPreviewVolume() from scratch. Arg 0: mirror, 1: rebuild. No GL.
void BM_PreviewVolumeAfterMove10k(benchmark::State& state) {
  const bool mirror = state.range(0) == 0;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Probe> probes;
  for (int i = 0; i < 10000; ++i) {
    Probe p;
    p.id = uint64_t(i + 1);
    p.position = Vec3(u(rng) * 10, u(rng) * 3, u(rng) * 8);
    ShRgb sh;
    sh.c[0] = Rgb(1, 1, 1) * (0.5 + u(rng));
    p.sh = sh;
    probes.push_back(p);
  }
  PreviewVolumeMirror m;
  m.sync(probes, PreviewSource::AllCaptured);
  double edits = 0;
  size_t tets = 0;
  for (auto _ : state) {
    Probe& p = probes[size_t(u(rng) * probes.size())];
    p.position = Vec3(u(rng) * 10, u(rng) * 3, u(rng) * 8);
    if (mirror) {
      const PreviewVolumeMirror::SyncReport r = m.sync(probes, PreviewSource::AllCaptured);
      if (r.rebuilt || r.moved != 1) state.SkipWithError("the mirror did not move one probe");
      edits += r.seconds;
      tets += r.tetsRewritten;
      benchmark::DoNotOptimize(m.volume());
    } else {
      const auto v = buildPreviewVolume(probes, PreviewSource::AllCaptured);
      benchmark::DoNotOptimize(v->tets.data());
    }
  }
  if (mirror) {
    state.counters["edit_us"] = 1e6 * edits / double(state.iterations());
    state.counters["tets_rewritten"] = double(tets) / double(state.iterations());
  }
}

BENCHMARK(BM_PreviewVolumeAfterMove10k)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ViewportFrameSceneOnly)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ViewportFrame1kProbes)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ViewportFrame10kProbes)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_ViewportFrame10kProbes100kGlyphs)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK(BM_ViewportDragStep10kProbes100kGlyphs)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK(BM_OverlayRebuild10kProbes100kGlyphs)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();

int main(int argc, char** argv) {
  QSurfaceFormat::setDefaultFormat(Viewport::surfaceFormat());
  QApplication app(argc, argv);
  if (!QFile::exists(kScene)) {
    std::fprintf(stderr, "bench_viewport: %s not found\n", qPrintable(kScene));
    return 1;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
