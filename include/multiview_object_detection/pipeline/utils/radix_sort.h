// Stable LSD radix sort of (64-bit key, value) pairs: O(n) per 11-bit digit, and only digits that
// hold bits in which the keys differ (not the high bits of packed voxel keys, mostly).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

namespace mvod {

namespace detail {

// The LSD radix passes shared by the sorts below: items ordered by key_of(item), a 64-bit key,
// ascending and stable. Each digit starts at the lowest varying bit not yet covered: packed voxel
// keys vary in a few low bits of each 21-bit field, so three digits cover them where aligned
// digits take five.
template <typename Item, typename KeyOf>
void radixSortBy(std::vector<Item>* items, KeyOf key_of) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  const std::size_t n = items->size();
  if (n < 2) return;
  std::uint64_t any_set = 0;
  std::uint64_t all_set = ~std::uint64_t{0};
  for (const Item& item : *items) {
    any_set |= key_of(item);
    all_set &= key_of(item);
  }
  const std::uint64_t varying = any_set & ~all_set;  // bits that differ between keys
  std::vector<Item> buffer(n);
  std::array<std::size_t, kBuckets> count;
  for (int shift = 0; shift < 64; shift += kDigitBits) {
    while (shift < 64 && ((varying >> shift) & 1u) == 0) ++shift;
    if (shift >= 64) break;
    count.fill(0);
    for (const Item& item : *items) ++count[(key_of(item) >> shift) & (kBuckets - 1)];
    std::size_t total = 0;
    for (std::size_t& c : count) {
      const std::size_t here = c;
      c = total;
      total += here;
    }
    for (Item& item : *items) {
      buffer[count[(key_of(item) >> shift) & (kBuckets - 1)]++] = std::move(item);
    }
    items->swap(buffer);
  }
}

}  // namespace detail

// Sorts items by key, ascending; items with equal keys keep their order. Items pushed in index
// order with (key, index) therefore end in std::sort's order of the pairs.
template <typename Value>
void radixSortByKey(std::vector<std::pair<std::uint64_t, Value>>* items) {
  detail::radixSortBy(items,
                      [](const std::pair<std::uint64_t, Value>& item) { return item.first; });
}

// Sorts 64-bit keys ascending (LSD radix over the bits in which they differ).
inline void radixSortKeys(std::vector<std::uint64_t>* keys) {
  detail::radixSortBy(keys, [](std::uint64_t key) { return key; });
}

// Sorts values ascending, as std::sort does: where every value is finite and non-negative, and
// none is -0.0, by an LSD radix sort of their bit patterns (whose unsigned order is then the
// values' order, and equal values have equal bits, so the result is std::sort's to the bit);
// otherwise by std::sort.
inline void sortNonNegative(std::vector<double>* values) {
  bool plain = true;
  for (const double v : *values) {
    plain = plain && v >= 0.0 && v <= std::numeric_limits<double>::max() && !std::signbit(v);
  }
  if (!plain || values->size() < 64) {
    std::sort(values->begin(), values->end());
    return;
  }
  const std::size_t n = values->size();
  std::vector<std::uint64_t> keys(n);
  std::memcpy(keys.data(), values->data(), n * sizeof(double));
  radixSortKeys(&keys);
  std::memcpy(values->data(), keys.data(), n * sizeof(double));
}

}  // namespace mvod
