// Evidence fusion's per-voxel counts (VoxelEvidence) and the map that holds them per object
// (EvidenceMap): flat storage, so that a keyframe's pass over every voxel of an object (its signed
// distances, the supported voxels) reads one array instead of chasing hash-table nodes.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace mvod {

// Evidence fusion: how often a voxel of the object's grid was inside a view's cut, and how often a
// view saw surface there but left it out of its cut.
// normal_sum adds the cut's normals in the voxel (each turned towards its camera), so that the
// fused box's Manhattan yaw comes from the voxels' normals without a neighbour search over the
// object.
// sdf_sum / sdf_count: the mean truncated projective signed distance of the views that saw the
// voxel (DepthView): near 0 on the surface the views measured, larger in front of it where one
// noisy view left a voxel that the others saw through.
struct VoxelEvidence {
  std::uint16_t inside = 0;
  std::uint16_t outside = 0;
  Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
  std::uint16_t sdf_count = 0;
  float sdf_sum = 0.f;
};

// Voxel key (voxelKeyOf / packVoxel) -> VoxelEvidence. The entries lie in one vector in the order
// they were inserted (entries are never removed, only all at once by clear()); an open-addressing
// table of their positions finds them by key. The subset of std::unordered_map's interface that
// the package uses: operator[], find, count, iteration over (key, evidence) pairs, size, empty,
// clear and reserve; and entries by position (entry(i)), so that disjoint ranges of positions can
// be processed in parallel. Iterators and references stay valid until the next insertion.
class EvidenceMap {
 public:
  using value_type = std::pair<std::int64_t, VoxelEvidence>;  // do not change the key in place
  using iterator = std::vector<value_type>::iterator;
  using const_iterator = std::vector<value_type>::const_iterator;

  VoxelEvidence& operator[](std::int64_t key) {
    std::size_t slot = slotOf(key);
    if (slots_.empty() || slots_[slot] < 0) {
      if (2 * (entries_.size() + 1) > slots_.size()) {
        rehash(slots_.empty() ? 16 : 2 * slots_.size());
        slot = slotOf(key);
      }
      slots_[slot] = static_cast<std::int32_t>(entries_.size());
      entries_.emplace_back(key, VoxelEvidence());
      return entries_.back().second;
    }
    return entries_[slots_[slot]].second;
  }
  iterator find(std::int64_t key) {
    const std::int32_t position = positionOf(key);
    return position < 0 ? entries_.end() : entries_.begin() + position;
  }
  const_iterator find(std::int64_t key) const {
    const std::int32_t position = positionOf(key);
    return position < 0 ? entries_.end() : entries_.begin() + position;
  }
  std::size_t count(std::int64_t key) const { return positionOf(key) < 0 ? 0 : 1; }

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
  static std::uint64_t mix(std::int64_t key) {
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
  std::size_t slotOf(std::int64_t key) const {
    if (slots_.empty()) return 0;
    const std::size_t mask = slots_.size() - 1;
    std::size_t slot = static_cast<std::size_t>(mix(key)) & mask;
    while (slots_[slot] >= 0 && entries_[slots_[slot]].first != key) slot = (slot + 1) & mask;
    return slot;
  }
  std::int32_t positionOf(std::int64_t key) const {
    return slots_.empty() ? -1 : slots_[slotOf(key)];
  }
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
