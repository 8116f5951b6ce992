// Voxel coordinates packed into one 64-bit hash key, 21 bits per axis: cells in [-2^20, 2^20), i.e.
// +-10 km at 1 cm. Used by the segment adjacency, the evidence fusion and its map files.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>

namespace mvod {

constexpr std::int64_t kVoxelFieldMask = 0x1FFFFF;

inline std::int64_t packVoxel(const Eigen::Vector3i& index) {
  return ((static_cast<std::int64_t>(index.x()) & kVoxelFieldMask) << 42) |
         ((static_cast<std::int64_t>(index.y()) & kVoxelFieldMask) << 21) |
         (static_cast<std::int64_t>(index.z()) & kVoxelFieldMask);
}

inline Eigen::Vector3i unpackVoxel(std::int64_t key) {
  const auto field = [key](int shift) {
    std::int64_t v = (key >> shift) & kVoxelFieldMask;
    if (v & (std::int64_t{1} << 20)) v -= std::int64_t{1} << 21;  // sign
    return static_cast<int>(v);
  };
  return Eigen::Vector3i(field(42), field(21), field(0));
}

// The key of the cell of size voxel_size_m (grid anchored at the origin) holding p.
inline std::int64_t voxelKeyOf(const Eigen::Vector3f& p, double voxel_size_m) {
  const double inv = 1.0 / voxel_size_m;
  return packVoxel(Eigen::Vector3i(static_cast<int>(std::floor(p.x() * inv)),
                                   static_cast<int>(std::floor(p.y() * inv)),
                                   static_cast<int>(std::floor(p.z() * inv))));
}

// The key of a neighbouring cell.
inline std::int64_t offsetVoxelKey(std::int64_t key, int dx, int dy, int dz) {
  return packVoxel(unpackVoxel(key) + Eigen::Vector3i(dx, dy, dz));
}

}  // namespace mvod
