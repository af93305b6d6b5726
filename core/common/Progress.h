#pragma once
#include <functional>

namespace ps {
/// Progress callback of a long-running stage: called with the fraction done in [0, 1]
/// (from any thread, serialized by the caller of the stage). Return false to cancel: the
/// stage then throws ps::Cancelled. An empty function means "no progress reporting".
using ProgressFn = std::function<bool(double fractionDone)>;
}  // namespace ps
