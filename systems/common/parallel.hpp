// The only scheduling a system sees: a range runner supplied by the caller (Box2D's task interface).
// Systems split their loops into [begin, end) ranges whose results do not depend on how the ranges are
// grouped; tests run them with `run_serial`, the engine with oneTBB inside the sheet's task arena.
#pragma once

#include <cstdint>
#include <functional>

namespace pt {

using RangeTask = std::function<void(int32_t begin, int32_t end)>;
// Calls task on disjoint ranges covering [0, count), possibly concurrently, ranges of about `grain`.
using RangeRunner = std::function<void(int32_t count, int32_t grain, const RangeTask& task)>;

inline void run_serial(int32_t count, int32_t /*grain*/, const RangeTask& task) {
  if (count > 0) task(0, count);
}

}  // namespace pt
