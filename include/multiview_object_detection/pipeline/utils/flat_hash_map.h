// A flat hash map for 64-bit integer keys: the evidence voxels of an object (EvidenceMap) and the
// cells of a cloud's normals.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace mvod {

// A hash map from 64-bit integer keys (packed voxel or cell keys) stored flat. The entries lie in
// one vector in the order they were inserted (entries are never removed, only all at once by
// clear()); an open-addressing table of their positions finds them by key. The subset of
// std::unordered_map's interface that the package uses: operator[], find, count, iteration over
// (key, value) pairs, size, empty, clear and reserve; and entries by position (entry(i)), so that
// disjoint ranges of positions can be processed in parallel. Iterators and references stay valid
// until the next insertion. A pass over all entries reads one array instead of chasing hash-table
// nodes.
template <typename Key, typename Value>
class FlatHashMap {
 public:
  static_assert(sizeof(Key) == 8, "64-bit integer keys");
  using value_type = std::pair<Key, Value>;  // do not change the key in place
  using iterator = typename std::vector<value_type>::iterator;
  using const_iterator = typename std::vector<value_type>::const_iterator;

  Value& operator[](Key key) {
    std::size_t slot = slotOf(key);
    if (slots_.empty() || slots_[slot] < 0) {
      if (2 * (entries_.size() + 1) > slots_.size()) {
        rehash(slots_.empty() ? 16 : 2 * slots_.size());
        slot = slotOf(key);
      }
      slots_[slot] = static_cast<std::int32_t>(entries_.size());
      entries_.emplace_back(key, Value());
      return entries_.back().second;
    }
    return entries_[slots_[slot]].second;
  }
  iterator find(Key key) {
    const std::int32_t position = positionOf(key);
    return position < 0 ? entries_.end() : entries_.begin() + position;
  }
  const_iterator find(Key key) const {
    const std::int32_t position = positionOf(key);
    return position < 0 ? entries_.end() : entries_.begin() + position;
  }
  std::size_t count(Key key) const { return positionOf(key) < 0 ? 0 : 1; }

  iterator begin() { return entries_.begin(); }
  iterator end() { return entries_.end(); }
  const_iterator begin() const { return entries_.begin(); }
  const_iterator end() const { return entries_.end(); }
  value_type& entry(std::size_t position) { return entries_[position]; }
  const value_type& entry(std::size_t position) const { return entries_[position]; }

  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  void clear() {
    entries_.clear();
    slots_.clear();
  }
  void reserve(std::size_t count) {
    entries_.reserve(count);
    std::size_t slots = 16;
    while (slots < 2 * count) slots *= 2;
    if (slots > slots_.size()) rehash(slots);
  }

 private:
  // A mixing hash (the 64-bit finaliser of MurmurHash3): packed keys of neighbouring voxels differ
  // in a few low bits of each axis's field.
  static std::uint64_t mix(Key key) {
    std::uint64_t h = static_cast<std::uint64_t>(key);
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ULL;
    h ^= h >> 33;
    return h;
  }
  // The slot holding `key`, or the empty slot where it would go (linear probing; the table is at
  // most half full). Only with a non-empty table.
  std::size_t slotOf(Key key) const {
    if (slots_.empty()) return 0;
    const std::size_t mask = slots_.size() - 1;
    std::size_t slot = static_cast<std::size_t>(mix(key)) & mask;
    while (slots_[slot] >= 0 && entries_[slots_[slot]].first != key) slot = (slot + 1) & mask;
    return slot;
  }
  std::int32_t positionOf(Key key) const { return slots_.empty() ? -1 : slots_[slotOf(key)]; }
  void rehash(std::size_t slots) {
    slots_.assign(slots, -1);
    const std::size_t mask = slots - 1;
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      std::size_t slot = static_cast<std::size_t>(mix(entries_[i].first)) & mask;
      while (slots_[slot] >= 0) slot = (slot + 1) & mask;
      slots_[slot] = static_cast<std::int32_t>(i);
    }
  }

  std::vector<value_type> entries_;
  std::vector<std::int32_t> slots_;  // positions in entries_, -1 = empty; a power of two long
};

}  // namespace mvod
