// The voxel grid that LccpSegmenter's "voxel_grid" supervoxels grow on (lccp_grid.cpp): integer
// keys packed and in Morton order, octree origins placed by PCL's rules, a hash index of keys, the
// voxels with their occupied 27-neighbourhoods, and their normals. Private to the pipeline library.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {
namespace lccp_grid {

constexpr int kKeyBits = 21;  // per axis; LccpSegmenter refuses extents over 1e6 voxels
constexpr std::int64_t kKeyMax = (std::int64_t{1} << kKeyBits) - 1;

inline std::uint64_t packKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (static_cast<std::uint64_t>(x) << (2 * kKeyBits)) |
         (static_cast<std::uint64_t>(y) << kKeyBits) | static_cast<std::uint64_t>(z);
}
inline std::int64_t keyX(std::uint64_t key) {
  return static_cast<std::int64_t>(key >> (2 * kKeyBits));
}
inline std::int64_t keyY(std::uint64_t key) {
  return static_cast<std::int64_t>((key >> kKeyBits) & static_cast<std::uint64_t>(kKeyMax));
}
inline std::int64_t keyZ(std::uint64_t key) {
  return static_cast<std::int64_t>(key & static_cast<std::uint64_t>(kKeyMax));
}

// Morton code (x, y, z bits interleaved from the top, x first): an octree's depth-first order.
// Bit b of x goes to bit 3b + 2 of the code, of y to 3b + 1, of z to 3b (the low 21 bits of each),
// spread and gathered with shifts and masks rather than bit by bit.
inline std::uint64_t spreadBits(std::int64_t value) {
  std::uint64_t v = static_cast<std::uint64_t>(value) & 0x1fffffULL;
  v = (v | (v << 32)) & 0x1f00000000ffffULL;
  v = (v | (v << 16)) & 0x1f0000ff0000ffULL;
  v = (v | (v << 8)) & 0x100f00f00f00f00fULL;
  v = (v | (v << 4)) & 0x10c30c30c30c30c3ULL;
  v = (v | (v << 2)) & 0x1249249249249249ULL;
  return v;
}
inline std::int64_t gatherBits(std::uint64_t code) {
  std::uint64_t v = code & 0x1249249249249249ULL;
  v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
  v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
  v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
  v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
  v = (v ^ (v >> 32)) & 0x1fffffULL;
  return static_cast<std::int64_t>(v);
}
inline std::uint64_t morton(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (spreadBits(x) << 2) | (spreadBits(y) << 1) | spreadBits(z);
}
inline std::uint64_t unMorton(std::uint64_t code) {
  return packKey(gatherBits(code >> 2), gatherBits(code >> 1), gatherBits(code));
}

// The origin of an octree of leaf size `resolution` over [lower, upper] whose bounds are given
// up front: the bounds centred in a cube of a power-of-two number of leaves (PCL's rule).
Eigen::Vector3d centredOctreeOrigin(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                    double resolution);

// The origin of an octree of leaf size `resolution` that grows to take points one at a time: it
// starts as two leaves around the first point and doubles towards each point outside (PCL's rule).
// Only the origin's lattice and the resulting order of cells matter here.
Eigen::Vector3d growingOctreeOrigin(const std::vector<Eigen::Vector3f>& points, double resolution);

// Open addressing from packed keys (< 2^63) to indices; each key is inserted once.
class KeyIndex {
 public:
  explicit KeyIndex(std::size_t count) {
    int bits = 4;
    while ((std::size_t{1} << bits) < 2 * count) ++bits;
    shift_ = 64 - bits;
    mask_ = (std::size_t{1} << bits) - 1;
    keys_.assign(mask_ + 1, kEmpty);
    values_.assign(mask_ + 1, -1);
  }
  void insert(std::uint64_t key, int value) {
    std::size_t slot = slotOf(key);
    while (keys_[slot] != kEmpty) slot = (slot + 1) & mask_;
    keys_[slot] = key;
    values_[slot] = value;
  }
  int find(std::uint64_t key) const {
    for (std::size_t slot = slotOf(key);; slot = (slot + 1) & mask_) {
      if (keys_[slot] == key) return values_[slot];
      if (keys_[slot] == kEmpty) return -1;
    }
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slotOf(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  int shift_ = 60;
  std::size_t mask_ = 15;
  std::vector<std::uint64_t> keys_;
  std::vector<int> values_;
};

// The occupied cells among the 27 around `key` (itself included), as indices, in offset order.
template <typename Visit>
void forEachNeighbourKey(std::uint64_t key, const KeyIndex& index, Visit visit) {
  const std::int64_t x = keyX(key), y = keyY(key), z = keyZ(key);
  for (std::int64_t dx = -1; dx <= 1; ++dx) {
    if (x + dx < 0 || x + dx > kKeyMax) continue;
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      if (y + dy < 0 || y + dy > kKeyMax) continue;
      for (std::int64_t dz = -1; dz <= 1; ++dz) {
        if (z + dz < 0 || z + dz > kKeyMax) continue;
        const int found = index.find(packKey(x + dx, y + dy, z + dz));
        if (found >= 0) visit(found);
      }
    }
  }
}

// The voxels of the (log-depth) grid, placed as PCL's adjacency octree places them, in its
// leaf order (Morton order), with their centroids and their occupied 27-neighbourhoods.
struct VoxelGrid {
  std::vector<std::uint64_t> key;
  std::vector<Eigen::Vector3f> centroid;
  std::vector<int> voxel_of_point;   // per input point; -1: none
  std::vector<int> neighbour_begin;  // voxel v's neighbours: neighbours[begin[v] .. begin[v + 1])
  std::vector<int> neighbours;       // itself included (as PCL's adjacency octree)
  int size() const { return static_cast<int>(key.size()); }
};

// 1. The cloud's voxels (in the log-depth space when log_transform), placed as PCL's adjacency
// octree places them: the cloud's bounds centred in a power-of-two box of voxels.
Status buildVoxelGrid(const PointCloud& points, bool log_transform, double resolution,
                      VoxelGrid* grid);

// 2. Voxel normals. PCL fits each to its voxel, its neighbours and their neighbours, counted with
// multiplicity: moments(v) + sum over neighbours n of (moments(n) + neighbourhood moments(n)).
// Each voxel's moments depend on its own neighbourhood only: split over the threads (the same
// result). Turned towards the frame's origin.
std::vector<Eigen::Vector3f> voxelNormals(const VoxelGrid& grid, int threads);

}  // namespace lccp_grid
}  // namespace mvod
