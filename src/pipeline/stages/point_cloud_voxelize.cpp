// PointCloudFilter::voxelize: the voxel grid, by packed 64-bit position keys and a radix sort, or
// by sorting full 64-bit indices for extents beyond that.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <utility>

#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "point_cloud_filter_common.h"

namespace mvod {

using point_cloud_filter_detail::finitePoints;
using point_cloud_filter_detail::kMaxVoxelIndex;

namespace {

// The voxel grid by sorting the points' 64-bit indices: for any cloud (extents beyond 32-bit
// grid positions too).
PointCloud voxelizeBySorting(const PointCloud& points, double leaf_size_m);

// The common case of the voxel grid: each finite point's voxel position in the cloud's bounding
// grid (x major) and its index packed into one 64-bit word, position << 32 | index; *max_position
// the largest position. False (nothing useful in *keyed) where a voxel index exceeds 32 bits or
// the grid 4e9 cells.
bool packedPositionKeys(const PointCloud& points, double leaf_size_m,
                        std::vector<std::uint64_t>* keyed, std::uint64_t* max_position) {
  constexpr double kMaxIndex = 2.0e9;  // |index| below this fits a 32-bit int
  const double inv_leaf = 1.0 / leaf_size_m;
  const std::size_t n = points.size();
  std::vector<std::array<std::int32_t, 3>> cells;
  std::vector<std::uint32_t> source;  // the finite points' indices
  cells.reserve(n);
  source.reserve(n);
  std::array<std::int32_t, 3> lo = {std::numeric_limits<std::int32_t>::max(),
                                    std::numeric_limits<std::int32_t>::max(),
                                    std::numeric_limits<std::int32_t>::max()};
  std::array<std::int32_t, 3> hi = {std::numeric_limits<std::int32_t>::min(),
                                    std::numeric_limits<std::int32_t>::min(),
                                    std::numeric_limits<std::int32_t>::min()};
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    std::array<std::int32_t, 3> cell;
    for (int d = 0; d < 3; ++d) {
      const double index = std::floor(static_cast<double>(p[d]) * inv_leaf);
      if (!(std::abs(index) < kMaxIndex)) return false;
      cell[d] = static_cast<std::int32_t>(index);
      lo[d] = std::min(lo[d], cell[d]);
      hi[d] = std::max(hi[d], cell[d]);
    }
    cells.push_back(cell);
    source.push_back(static_cast<std::uint32_t>(i));
  }
  keyed->clear();
  *max_position = 0;
  if (cells.empty()) return true;
  std::array<std::uint64_t, 3> dims;
  double grid_cells = 1.0;
  for (int d = 0; d < 3; ++d) {
    dims[d] = static_cast<std::uint64_t>(static_cast<std::int64_t>(hi[d]) - lo[d]) + 1;
    grid_cells *= static_cast<double>(dims[d]);
  }
  if (!(grid_cells < 4.0e9)) return false;
  const std::size_t m = cells.size();
  keyed->resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint64_t x = static_cast<std::uint64_t>(cells[k][0] - lo[0]);
    const std::uint64_t y = static_cast<std::uint64_t>(cells[k][1] - lo[1]);
    const std::uint64_t z = static_cast<std::uint64_t>(cells[k][2] - lo[2]);
    const std::uint64_t position = (x * dims[1] + y) * dims[2] + z;
    *max_position = std::max(*max_position, position);
    (*keyed)[k] = (position << 32) | source[k];
  }
  return true;
}

// A stable LSD radix sort of the packed words on the position's digits only, so a voxel's points
// stay in input order. Half the memory traffic of sorting positions and indices apart.
void sortByPosition(std::uint64_t max_position, std::vector<std::uint64_t>* keyed_in) {
  std::vector<std::uint64_t>& keyed = *keyed_in;
  constexpr int kDigitBits = 11;
  constexpr std::uint64_t kDigitMask = (std::uint64_t{1} << kDigitBits) - 1;
  std::vector<std::uint64_t> buffer(keyed.size());
  std::vector<std::uint32_t> count(std::size_t{1} << kDigitBits);
  for (int shift = 32; shift < 64 && (max_position >> (shift - 32)) != 0; shift += kDigitBits) {
    std::fill(count.begin(), count.end(), 0u);
    for (const std::uint64_t key : keyed) ++count[(key >> shift) & kDigitMask];
    std::uint32_t total = 0;
    for (std::uint32_t& c : count) {
      const std::uint32_t here = c;
      c = total;
      total += here;
    }
    for (const std::uint64_t key : keyed) buffer[count[(key >> shift) & kDigitMask]++] = key;
    keyed.swap(buffer);
  }
}

}  // namespace

PointCloud PointCloudFilter::voxelize(const PointCloud& points, double leaf_size_m) {
  if (!(std::isfinite(leaf_size_m) && leaf_size_m > 0.0)) return finitePoints(points);
  // The common case, a cloud of fewer than 2^32 points whose voxels' positions in their bounding
  // grid fit in 32 bits: each point's position and index in one word, radix sorted on the
  // position. No hash table.
  if (points.size() >= std::numeric_limits<std::uint32_t>::max()) {
    return voxelizeBySorting(points, leaf_size_m);
  }
  std::vector<std::uint64_t> keyed;
  std::uint64_t max_position = 0;
  if (!packedPositionKeys(points, leaf_size_m, &keyed, &max_position)) {
    return voxelizeBySorting(points, leaf_size_m);
  }
  sortByPosition(max_position, &keyed);
  // One centroid per run of equal positions, summed in double in input order.
  const std::size_t m = keyed.size();
  PointCloud out;
  out.reserve(m / 2);
  std::size_t begin = 0;
  while (begin < m) {
    const std::uint64_t position = keyed[begin] >> 32;
    std::size_t end = begin;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    while (end < m && (keyed[end] >> 32) == position) {
      sum += points[keyed[end] & 0xffffffffu].cast<double>();
      ++end;
    }
    out.emplace_back((sum / static_cast<double>(end - begin)).cast<float>());
    begin = end;
  }
  return out;
}

namespace {

// The voxels' positions in the cloud's bounding grid (sortable integers), ordered by a stable LSD
// radix sort: O(n) instead of a comparison sort's O(n log n). order[k]: the key index of the k-th.
void radixSortPositions(std::vector<std::uint64_t>* order_key_in,
                        std::vector<std::uint32_t>* order_in) {
  std::vector<std::uint64_t>& order_key = *order_key_in;
  std::vector<std::uint32_t>& order = *order_in;
  const std::size_t n = order_key.size();
  std::uint64_t max_key = 0;
  for (const std::uint64_t key : order_key) max_key = std::max(max_key, key);
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  std::vector<std::uint64_t> next_key(n);
  std::vector<std::uint32_t> next(n);
  std::vector<std::uint32_t> count(kBuckets);
  for (int shift = 0; shift < 64 && (max_key >> shift) != 0; shift += kDigitBits) {
    std::fill(count.begin(), count.end(), 0u);
    for (std::size_t k = 0; k < n; ++k) ++count[(order_key[k] >> shift) & (kBuckets - 1)];
    std::uint32_t total = 0;
    for (std::uint32_t& c : count) {
      const std::uint32_t here = c;
      c = total;
      total += here;
    }
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint32_t slot = count[(order_key[k] >> shift) & (kBuckets - 1)]++;
      next_key[slot] = order_key[k];
      next[slot] = order[k];
    }
    order_key.swap(next_key);
    order.swap(next);
  }
}

using VoxelIndex = std::array<std::int64_t, 3>;

// Extents beyond 64-bit grid positions: a comparison sort on the indices themselves; order_key
// then holds each voxel's rank.
void sortVoxelIndices(const std::vector<VoxelIndex>& keys, std::vector<std::uint64_t>* order_key,
                      std::vector<std::uint32_t>* order) {
  const std::size_t n = keys.size();
  std::vector<std::pair<VoxelIndex, std::uint32_t>> keyed(n);
  for (std::size_t k = 0; k < n; ++k) keyed[k] = {keys[k], static_cast<std::uint32_t>(k)};
  std::sort(keyed.begin(), keyed.end());
  std::uint64_t rank = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (k > 0 && keyed[k].first != keyed[k - 1].first) ++rank;
    (*order_key)[k] = rank;
    (*order)[k] = keyed[k].second;
  }
}

PointCloud voxelizeBySorting(const PointCloud& points, double leaf_size_m) {
  // 64-bit integer voxel index per point, without PCL's 32-bit index limit for large extents.
  std::vector<VoxelIndex> keys;
  std::vector<std::uint32_t> source;
  keys.reserve(points.size());
  source.reserve(points.size());
  const double inv_leaf = 1.0 / leaf_size_m;
  VoxelIndex lo = {0, 0, 0};
  VoxelIndex hi = {0, 0, 0};
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    VoxelIndex key;
    bool representable = true;
    for (int d = 0; d < 3; ++d) {
      const double index = std::floor(static_cast<double>(p[d]) * inv_leaf);
      if (!(std::abs(index) < kMaxVoxelIndex)) {
        representable = false;
        break;
      }
      key[d] = static_cast<std::int64_t>(index);
    }
    if (!representable) continue;
    for (int d = 0; d < 3; ++d) {
      lo[d] = keys.empty() ? key[d] : std::min(lo[d], key[d]);
      hi[d] = keys.empty() ? key[d] : std::max(hi[d], key[d]);
    }
    keys.push_back(key);
    source.push_back(static_cast<std::uint32_t>(i));
  }
  const std::size_t n = keys.size();
  PointCloud out;
  if (n == 0) return out;

  // Output in ascending (x, y, z) voxel order, each voxel's points summed in input order: a
  // deterministic order that does not depend on a hash.
  std::array<std::uint64_t, 3> dims;
  double cells = 1.0;
  for (int d = 0; d < 3; ++d) {
    dims[d] = static_cast<std::uint64_t>(hi[d] - lo[d]) + 1;
    cells *= static_cast<double>(dims[d]);
  }
  std::vector<std::uint64_t> order_key(n);
  std::vector<std::uint32_t> order(n);
  if (cells < 9.0e18 && points.size() < std::numeric_limits<std::uint32_t>::max()) {
    for (std::size_t k = 0; k < n; ++k) {
      const std::uint64_t x = static_cast<std::uint64_t>(keys[k][0] - lo[0]);
      const std::uint64_t y = static_cast<std::uint64_t>(keys[k][1] - lo[1]);
      const std::uint64_t z = static_cast<std::uint64_t>(keys[k][2] - lo[2]);
      order_key[k] = (x * dims[1] + y) * dims[2] + z;
      order[k] = static_cast<std::uint32_t>(k);
    }
    radixSortPositions(&order_key, &order);
  } else {
    sortVoxelIndices(keys, &order_key, &order);
  }

  std::size_t begin = 0;
  while (begin < n) {
    std::size_t end = begin;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    while (end < n && order_key[end] == order_key[begin]) {
      sum += points[source[order[end]]].cast<double>();
      ++end;
    }
    out.emplace_back((sum / static_cast<double>(end - begin)).cast<float>());
    begin = end;
  }
  return out;
}
}  // namespace

}  // namespace mvod
