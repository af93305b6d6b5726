#include "core/capture/ParallelProbes.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <mutex>

#include "core/common/Error.h"

namespace ps {

void forEachProbeInParallel(size_t n, int threads, const ProgressFn& progress,
                            const std::function<void(size_t, const std::atomic<bool>&)>& work) {
  std::atomic<bool> cancelled{false};
  size_t done = 0;  // guarded by progressMutex
  std::mutex progressMutex;
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t i = r.begin(); i != r.end(); ++i) {
                          if (cancelled.load()) return;
                          work(i, cancelled);
                          if (!progress) continue;
                          std::lock_guard<std::mutex> lock(progressMutex);
                          const size_t finished = ++done;
                          if (!cancelled.load() &&
                              !progress(static_cast<double>(finished) / static_cast<double>(n)))
                            cancelled.store(true);
                        }
                      });
  };
  if (threads > 0) {
    tbb::task_arena arena(threads);
    arena.execute(run);
  } else {
    run();
  }
  if (cancelled.load()) throw Cancelled();
}

}  // namespace ps
