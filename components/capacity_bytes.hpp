// Heap bytes of a component array (capacity based): the one measure behind every memory report
// (sheet arrays, solver state, batch.json's bytes per sheet).
#pragma once

#include <cstddef>
#include <vector>

namespace pt {

template <class T>
size_t capacity_bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

}  // namespace pt
