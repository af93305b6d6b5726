#pragma once
// The loop every capture runs: one item per probe over TBB's workers, progress after each,
// cancellation through the progress callback.
#include <atomic>
#include <cstddef>
#include <functional>

#include "core/common/Progress.h"

namespace ps {

/// Runs work(i, cancelled) for every i in [0, n) on TBB's workers (`threads` of them when > 0,
/// else all). After each item, progress(fraction done) is called under a lock, so the
/// fractions it sees increase and end at exactly 1. When it returns false the flag is raised:
/// a long item may poll `cancelled` to stop early, no further item starts, and ps::Cancelled
/// is thrown once the running ones have returned.
void forEachProbeInParallel(size_t n, int threads, const ProgressFn& progress,
                            const std::function<void(size_t, const std::atomic<bool>&)>& work);

}  // namespace ps
