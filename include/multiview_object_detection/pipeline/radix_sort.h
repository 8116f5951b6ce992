// Stable LSD radix sort of (64-bit key, value) pairs: O(n) per 11-bit digit, and only digits that
// hold bits in which the keys differ (not the high bits of packed voxel keys, mostly).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace mvod {

// Sorts items by key, ascending; items with equal keys keep their order. Items pushed in index
// order with (key, index) therefore end in std::sort's order of the pairs.
template <typename Value>
void radixSortByKey(std::vector<std::pair<std::uint64_t, Value>>* items) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  const std::size_t n = items->size();
  if (n < 2) return;
  std::uint64_t any_set = 0;
  std::uint64_t all_set = ~std::uint64_t{0};
  for (const auto& item : *items) {
    any_set |= item.first;
    all_set &= item.first;
  }
  const std::uint64_t varying = any_set & ~all_set;  // bits that differ between keys
  std::vector<std::pair<std::uint64_t, Value>> buffer(n);
  std::array<std::size_t, kBuckets> count;
  // Each digit starts at the lowest varying bit not yet covered: packed voxel keys vary in a few
  // low bits of each 21-bit field, so three digits cover them where aligned digits take five.
  for (int shift = 0; shift < 64; shift += kDigitBits) {
    while (shift < 64 && ((varying >> shift) & 1u) == 0) ++shift;
    if (shift >= 64) break;
    count.fill(0);
    for (const auto& item : *items) ++count[(item.first >> shift) & (kBuckets - 1)];
    std::size_t total = 0;
    for (std::size_t& c : count) {
      const std::size_t here = c;
      c = total;
      total += here;
    }
    for (auto& item : *items) {
      buffer[count[(item.first >> shift) & (kBuckets - 1)]++] = std::move(item);
    }
    items->swap(buffer);
  }
}

}  // namespace mvod
