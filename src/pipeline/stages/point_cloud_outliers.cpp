// PointCloudFilter's outlier removals: sparse voxels (26-neighbourhood), the statistical outlier
// removal on voxel centres (occupancy bits, shells of offsets), and PCL's statistical outlier
// removal reproduced exactly on a grid of cells.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_set>

#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "point_cloud_filter_common.h"

namespace mvod {

using point_cloud_filter_detail::finitePoints;
using point_cloud_filter_detail::keepBelowStatisticalThreshold;
using point_cloud_filter_detail::VarianceSum;

namespace {

// keep[i] |= the cell of finite[i] (grid of cell_m, anchored at the origin) has at least
// min_neighbours occupied cells among its 26 neighbours.
void markDenseCells(const PointCloud& finite, double cell_m, int min_neighbours,
                    std::vector<char>* keep) {
  // The cells; a dense occupancy grid over the cloud's bounding box (one bit per cell, with a
  // margin of one) when it is small, else a hash set.
  const double inv_cell = 1.0 / cell_m;
  std::vector<Eigen::Array3i> cells;
  cells.reserve(finite.size());
  Eigen::Array3i lo = Eigen::Array3i::Constant(std::numeric_limits<int>::max());
  Eigen::Array3i hi = Eigen::Array3i::Constant(std::numeric_limits<int>::min());
  for (const Eigen::Vector3f& p : finite) {
    Eigen::Array3i c;
    for (int d = 0; d < 3; ++d) {
      const double index = std::floor(static_cast<double>(p[d]) * inv_cell);
      // Beyond +-1e9 cells (10 000 km at 1 cm) every point is its own speck.
      c[d] = static_cast<int>(std::max(-1e9, std::min(1e9, index)));
    }
    lo = lo.min(c);
    hi = hi.max(c);
    cells.push_back(c);
  }
  const Eigen::Array3i dims = hi - lo + 3;  // one cell of margin on either side
  const double num_cells = static_cast<double>(dims[0]) * dims[1] * static_cast<double>(dims[2]);
  const auto mark = [&](const auto& occupied) {
    for (std::size_t i = 0; i < finite.size(); ++i) {
      if ((*keep)[i]) continue;
      int count = -1;  // its own cell is counted below
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            count += occupied(cells[i] + Eigen::Array3i(dx, dy, dz)) ? 1 : 0;
          }
        }
      }
      if (count >= min_neighbours) (*keep)[i] = 1;
    }
  };
  if (num_cells <= 64.0 * 1024 * 1024) {
    std::vector<std::uint64_t> bits(static_cast<std::size_t>(num_cells) / 64 + 1, 0);
    const auto bit_of = [&](const Eigen::Array3i& c) {
      const Eigen::Array3i r = c - lo + 1;
      return (static_cast<std::size_t>(r[2]) * dims[1] + r[1]) * dims[0] + r[0];
    };
    for (const Eigen::Array3i& c : cells) {
      const std::size_t b = bit_of(c);
      bits[b / 64] |= std::uint64_t{1} << (b % 64);
    }
    mark([&](const Eigen::Array3i& c) {
      const std::size_t b = bit_of(c);
      return ((bits[b / 64] >> (b % 64)) & 1u) != 0;
    });
  } else {
    struct CellHash {
      std::size_t operator()(const std::array<int, 3>& c) const {
        return static_cast<std::size_t>(c[0]) * 73856093u ^
               static_cast<std::size_t>(c[1]) * 19349663u ^
               static_cast<std::size_t>(c[2]) * 83492791u;
      }
    };
    const auto key_of = [](const Eigen::Array3i& c) {
      return std::array<int, 3>{c[0], c[1], c[2]};
    };
    std::unordered_set<std::array<int, 3>, CellHash> occupied;
    occupied.reserve(2 * cells.size());
    for (const Eigen::Array3i& c : cells) occupied.insert(key_of(c));
    mark([&](const Eigen::Array3i& c) { return occupied.count(key_of(c)) != 0; });
  }
}

}  // namespace

PointCloud PointCloudFilter::removeSparseVoxels(const PointCloud& points, double leaf_size_m,
                                                int min_neighbours) {
  PointCloud finite = finitePoints(points);
  if (min_neighbours <= 0 || finite.empty() || !(std::isfinite(leaf_size_m) && leaf_size_m > 0.0)) {
    return finite;
  }
  std::vector<char> keep(finite.size(), 0);
  markDenseCells(finite, leaf_size_m, min_neighbours, &keep);
  PointCloud out;
  out.reserve(finite.size());
  for (std::size_t i = 0; i < finite.size(); ++i) {
    if (keep[i]) out.push_back(finite[i]);
  }
  return out;
}

namespace {

// Grid offsets (cells) within radius_cells of the origin, the origin excluded, by length (ties in
// a fixed order), with their lengths.
struct SortedOffsets {
  std::vector<Eigen::Array3i> offsets;
  std::vector<float> lengths;
};

SortedOffsets sortedOffsets(int radius_cells) {
  std::vector<std::pair<int, Eigen::Array3i>> all;
  for (int z = -radius_cells; z <= radius_cells; ++z) {
    for (int y = -radius_cells; y <= radius_cells; ++y) {
      for (int x = -radius_cells; x <= radius_cells; ++x) {
        const int squared = x * x + y * y + z * z;
        if (squared == 0 || squared > radius_cells * radius_cells) continue;
        all.emplace_back(squared, Eigen::Array3i(x, y, z));
      }
    }
  }
  std::stable_sort(all.begin(), all.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  SortedOffsets sorted;
  for (const auto& entry : all) {
    sorted.offsets.push_back(entry.second);
    sorted.lengths.push_back(std::sqrt(static_cast<float>(entry.first)));
  }
  return sorted;
}

// The 5 x 5 x 5 cells around a cell hold every offset of squared length 1 to 8 (92 offsets; no
// offset has squared length 7), grouped in shells of one squared length: 1, 2, 3, 4, 5, 6, 8. A
// row of the cube along x (dy, dz fixed) is five bits; row_counts[class][bits] holds how many of
// them are occupied per shell, as kCountBits-bit fields (shell s at bit kCountBits * s), so the
// counts of a cube are the sum of its 25 rows' entries. The class is the row's dy^2 + dz^2.
struct CubeShells {
  static constexpr int kRows = 25;
  static constexpr int kShells = 7;
  static constexpr int kMaxSquared = 8;
  static constexpr int kCountBits = 6;  // a shell holds at most 24 offsets
  static constexpr std::uint64_t kCountMask = (std::uint64_t{1} << kCountBits) - 1;
  static constexpr int kClasses = 6;
  std::array<int, kRows> row_dy;
  std::array<int, kRows> row_dz;
  std::array<int, kRows> row_class;
  std::array<std::array<std::uint64_t, 32>, kClasses> row_counts;
  std::array<float, kShells> shell_length;  // as sortedOffsets computes it
};

// Bits q .. q + 4 of a bitset (bit q % 64 of word q / 64), the next word readable.
inline std::uint64_t fiveBits(const std::vector<std::uint64_t>& bits, std::uint64_t q) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  // Little-endian words are a little-endian byte string: eight bytes from q's byte hold them.
  std::uint64_t eight_bytes;
  std::memcpy(&eight_bytes, reinterpret_cast<const unsigned char*>(bits.data()) + q / 8,
              sizeof(eight_bytes));
  return (eight_bytes >> (q % 8)) & std::uint64_t{0x1f};
#else
  // Across a word boundary: the second word shifted by 64 - shift, in two steps so that shift 0
  // stays defined.
  const std::uint64_t word = q / 64;
  const unsigned shift = static_cast<unsigned>(q % 64);
  return ((bits[word] >> shift) | ((bits[word + 1] << 1) << (63 - shift))) & std::uint64_t{0x1f};
#endif
}

const CubeShells& cubeShells() {
  static const CubeShells table = [] {
    CubeShells cube;
    constexpr std::array<int, 9> kShellOf = {-1, 0, 1, 2, 3, 4, 5, -1, 6};   // by squared length
    constexpr std::array<int, 9> kClassOf = {0, 1, 2, -1, 3, 4, -1, -1, 5};  // by dy^2 + dz^2
    constexpr std::array<int, CubeShells::kClasses> kClassSquared = {0, 1, 2, 4, 5, 8};
    for (int squared = 1; squared <= CubeShells::kMaxSquared; ++squared) {
      if (kShellOf[squared] >= 0) {
        cube.shell_length[kShellOf[squared]] = std::sqrt(static_cast<float>(squared));
      }
    }
    int r = 0;
    for (int dz = -2; dz <= 2; ++dz) {
      for (int dy = -2; dy <= 2; ++dy, ++r) {
        cube.row_dy[r] = dy;
        cube.row_dz[r] = dz;
        cube.row_class[r] = kClassOf[dy * dy + dz * dz];
      }
    }
    for (int c = 0; c < CubeShells::kClasses; ++c) {
      for (int row = 0; row < 32; ++row) {
        std::uint64_t counts = 0;
        for (int dx = -2; dx <= 2; ++dx) {
          const int squared = kClassSquared[c] + dx * dx;
          if (!((row >> (dx + 2)) & 1) || squared == 0 || squared > CubeShells::kMaxSquared) {
            continue;
          }
          counts += std::uint64_t{1} << (CubeShells::kCountBits * kShellOf[squared]);
        }
        cube.row_counts[c][row] = counts;
      }
    }
    return cube;
  }();
  return table;
}

}  // namespace

PointCloud PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(const PointCloud& points,
                                                                     int mean_k, double stddev_mul,
                                                                     double leaf_size_m,
                                                                     int threads) {
  PointCloud finite = finitePoints(points);
  const std::size_t n = finite.size();
  if (mean_k < 1 || !std::isfinite(stddev_mul) || n < static_cast<std::size_t>(mean_k) + 1 ||
      !(std::isfinite(leaf_size_m) && leaf_size_m > 0.0)) {
    return finite;
  }
  std::vector<float> mean_distance;
  if (!voxelCentreMeanDistances(finite, mean_k, leaf_size_m, threads, &mean_distance)) {
    return removeStatisticalOutliersOnGrid(finite, mean_k, stddev_mul, leaf_size_m, threads);
  }
  return keepBelowStatisticalThreshold(finite, mean_distance, stddev_mul,
                                       VarianceSum::kDoubleClamped);
}

namespace {

// The voxels of a cloud as bits of a dense occupancy grid over its bounding box, with a margin of
// `radius` cells, and what the centre-distance scan needs of it: the grid offsets by length and
// their bit distances, and each row of the 5 x 5 x 5 cube's first bit.
struct OccupancyBits {
  int radius = 0;
  Eigen::Array3i lo;
  std::int64_t stride_y = 0;
  std::int64_t stride_z = 0;
  std::vector<Eigen::Array3i> cells;  // per point
  std::vector<std::uint64_t> bits;    // one spare word at the end
  const SortedOffsets* table = nullptr;
  std::vector<std::int64_t> deltas;  // the bit distance of each of table's offsets
  bool use_cube = false;             // the cube's shells, where the table holds them all
  std::size_t beyond_cube = 0;       // the table's first offset outside the cube's shells
  std::array<std::int64_t, CubeShells::kRows> row_start;  // bit of each row's first cell
  std::int64_t bitOf(const Eigen::Array3i& c) const {
    const Eigen::Array3i r = c - lo + radius;
    return r[2] * stride_z + r[1] * stride_y + r[0];
  }
};

// The offsets depend on the radius only: computed once per thread and radius.
const SortedOffsets& sortedOffsetsCached(int radius) {
  static thread_local std::map<int, SortedOffsets> tables;
  auto cached = tables.find(radius);
  if (cached == tables.end()) cached = tables.emplace(radius, sortedOffsets(radius)).first;
  return cached->second;
}

// False (nothing built) where the grid would exceed 256 M cells (32 MB).
bool buildOccupancyBits(const PointCloud& finite, double leaf_size_m, int radius,
                        OccupancyBits* grid) {
  const std::size_t n = finite.size();
  grid->radius = radius;
  const double inv_leaf = 1.0 / leaf_size_m;
  std::vector<Eigen::Array3i>& cells = grid->cells;
  cells.resize(n);
  Eigen::Array3i lo = Eigen::Array3i::Constant(std::numeric_limits<int>::max());
  Eigen::Array3i hi = Eigen::Array3i::Constant(std::numeric_limits<int>::min());
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      const double index = std::floor(static_cast<double>(finite[i][d]) * inv_leaf);
      cells[i][d] = static_cast<int>(std::max(-1e9, std::min(1e9, index)));
    }
    lo = lo.min(cells[i]);
    hi = hi.max(cells[i]);
  }
  double num_cells = 1.0;
  for (int d = 0; d < 3; ++d) {
    num_cells *= static_cast<double>(hi[d]) - static_cast<double>(lo[d]) + 1.0 + 2.0 * radius;
  }
  if (!(num_cells <= 256.0 * 1024 * 1024)) return false;
  const Eigen::Array3i dims = hi - lo + 1 + 2 * radius;
  grid->lo = lo;
  grid->stride_y = dims[0];
  grid->stride_z = static_cast<std::int64_t>(dims[0]) * dims[1];
  grid->bits.assign(static_cast<std::size_t>(num_cells) / 64 + 1, 0);
  for (const Eigen::Array3i& c : cells) {
    const std::int64_t b = grid->bitOf(c);
    grid->bits[static_cast<std::size_t>(b) / 64] |= std::uint64_t{1} << (b % 64);
  }
  // One spare word: a row of the cube is read from the word it starts in and the next.
  grid->bits.push_back(0);
  return true;
}

// The scan's offsets on this grid: their bit distances, where the cube's shells end, each cube
// row's first bit.
void prepareScan(const SortedOffsets& table, OccupancyBits* grid) {
  grid->table = &table;
  grid->deltas.resize(table.offsets.size());
  for (std::size_t k = 0; k < grid->deltas.size(); ++k) {
    const Eigen::Array3i& o = table.offsets[k];
    grid->deltas[k] = o[2] * grid->stride_z + o[1] * grid->stride_y + o[0];
  }
  const CubeShells& cube = cubeShells();
  // The cube's shells only where the table holds them all (not for mean_k 1, radius 2).
  grid->use_cube = grid->radius * grid->radius >= CubeShells::kMaxSquared;
  grid->beyond_cube = 0;
  while (grid->use_cube && grid->beyond_cube < table.offsets.size() &&
         table.offsets[grid->beyond_cube].square().sum() <= CubeShells::kMaxSquared) {
    ++grid->beyond_cube;
  }
  for (int r = 0; r < CubeShells::kRows; ++r) {
    grid->row_start[r] = cube.row_dz[r] * grid->stride_z + cube.row_dy[r] * grid->stride_y - 2;
  }
}

// The mean distance (m) from voxel i to its mean_k nearest occupied voxel centres; those missing
// within the radius count at radius + 1 cells.
float meanCentreDistance(const OccupancyBits& grid, std::size_t i, int mean_k, double leaf_size_m) {
  const CubeShells& cube = cubeShells();
  const std::vector<std::uint64_t>& bits = grid.bits;
  const std::int64_t b = grid.bitOf(grid.cells[i]);
  // The occupied cells of the 5 x 5 x 5 cube around the voxel, counted per shell: five bits
  // per row of the cube, and a table turns them into counts at the row's squared lengths.
  std::uint64_t counts = 0;
  for (int r = 0; grid.use_cube && r < CubeShells::kRows; ++r) {
    const std::uint64_t q = static_cast<std::uint64_t>(b + grid.row_start[r]);
    counts += cube.row_counts[cube.row_class[r]][fiveBits(bits, q)];
  }
  // The nearest occupied cells shell by shell: all of a shell's offsets have its length, so
  // adding it once per occupied cell is the scan's sum, bit for bit, in the scan's order.
  int found = 0;
  float sum = 0.f;
  for (int s = 0; s < CubeShells::kShells && found < mean_k; ++s) {
    const int in_shell =
        static_cast<int>((counts >> (CubeShells::kCountBits * s)) & CubeShells::kCountMask);
    const int take = std::min(in_shell, mean_k - found);
    for (int t = 0; t < take; ++t) sum += cube.shell_length[s];
    found += take;
  }
  // Beyond the cube (a surface's edge, a sparse view): the table's offsets in order.
  // Branch-free: whether a neighbour cell is occupied is close to a coin flip on a surface's
  // edge, which a branch mispredicts half the time. Adding 0 for an empty cell leaves the sum's
  // bits as they were (it is never -0), so the sum is that of the occupied cells in order.
  const std::vector<float>& lengths = grid.table->lengths;
  for (std::size_t k = grid.beyond_cube; k < grid.deltas.size() && found < mean_k; ++k) {
    const std::size_t q = static_cast<std::size_t>(b + grid.deltas[k]);
    const std::uint64_t occupied = (bits[q / 64] >> (q % 64)) & 1u;
    sum += lengths[k] * static_cast<float>(occupied);
    found += static_cast<int>(occupied);
  }
  sum += static_cast<float>(mean_k - found) * static_cast<float>(grid.radius + 1);
  return static_cast<float>(leaf_size_m) * sum / static_cast<float>(mean_k);
}

}  // namespace

bool PointCloudFilter::voxelCentreMeanDistances(const PointCloud& finite, int mean_k,
                                                double leaf_size_m, int threads,
                                                std::vector<float>* mean_distance_m) {
  const std::size_t n = finite.size();
  if (mean_k < 1 || !(std::isfinite(leaf_size_m) && leaf_size_m > 0.0)) return false;
  mean_distance_m->clear();
  if (n == 0) return true;
  // The mean_k nearest voxels of a surface lie within about sqrt(mean_k) cells; a point with fewer
  // occupied voxels within twice that counts the missing ones at that distance (an outlier
  // anyway).
  const int radius = std::max(2, static_cast<int>(std::ceil(2.0 * std::sqrt(mean_k))));
  const SortedOffsets& table = sortedOffsetsCached(radius);
  // An occupancy bitset over the bounding box; beyond 32 MB the exact search handles the cloud.
  OccupancyBits grid;
  if (!buildOccupancyBits(finite, leaf_size_m, radius, &grid)) return false;
  prepareScan(table, &grid);
  std::vector<float>& mean_distance = *mean_distance_m;
  mean_distance.assign(n, 0.f);
  parallelRanges(n, threads, 4096, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      mean_distance[i] = meanCentreDistance(grid, i, mean_k, leaf_size_m);
    }
  });
  return true;
}

namespace {

// The exact search's grid: cells of cell_m over the cloud's bounding box, the points
// counting-sorted by cell.
struct CellTable {
  double cell_m = 0.0;
  Eigen::Array3i dims;
  std::vector<Eigen::Array3i> cell_of;  // per point
  std::vector<std::int32_t> start;      // cell c holds order[start[c] .. start[c + 1])
  std::vector<std::int32_t> order;      // the points in cell order
  std::vector<Eigen::Vector3f> sorted;  // the points in cell order, for locality
  std::int64_t indexOf(const Eigen::Array3i& c) const {
    return (static_cast<std::int64_t>(c[2]) * dims[1] + c[1]) * dims[0] + c[0];
  }
};

// False (nothing built) for a grid of more than 1e6 cells a side or 16e6 cells: the k-d tree is
// the better search there.
bool buildCellTable(const PointCloud& finite, double cell_m, CellTable* table) {
  Eigen::Vector3f lo = finite[0];
  Eigen::Vector3f hi = finite[0];
  for (const Eigen::Vector3f& p : finite) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double inv_cell = 1.0 / cell_m;
  Eigen::Array3i& dims = table->dims;
  for (int d = 0; d < 3; ++d) {
    const double cells = std::floor((static_cast<double>(hi[d]) - lo[d]) * inv_cell) + 1.0;
    if (!(cells < 1e6)) return false;
    dims[d] = static_cast<int>(cells);
  }
  const std::int64_t num_cells =
      static_cast<std::int64_t>(dims[0]) * dims[1] * static_cast<std::int64_t>(dims[2]);
  // A dense table of cells when it is small (a view of an object).
  if (num_cells > 16 * 1000 * 1000) return false;
  table->cell_m = cell_m;
  const std::size_t n = finite.size();
  table->cell_of.resize(n);
  std::vector<std::int32_t>& start = table->start;
  start.assign(static_cast<std::size_t>(num_cells) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      const int c =
          static_cast<int>(std::floor((static_cast<double>(finite[i][d]) - lo[d]) * inv_cell));
      table->cell_of[i][d] = std::min(std::max(c, 0), dims[d] - 1);
    }
    ++start[static_cast<std::size_t>(table->indexOf(table->cell_of[i])) + 1];
  }
  // Counting sort: the counts' prefix sums are the cells' starts.
  std::partial_sum(start.begin(), start.end(), start.begin());
  table->order.resize(n);
  std::vector<std::int32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t cell = static_cast<std::size_t>(table->indexOf(table->cell_of[i]));
    table->order[static_cast<std::size_t>(fill[cell]++)] = static_cast<std::int32_t>(i);
  }
  table->sorted.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    table->sorted[k] = finite[static_cast<std::size_t>(table->order[k])];
  }
  return true;
}

// Appends the squared distances from q to the points of cell (x, y, z) (none outside the grid):
// in float, summed dimension by dimension as FLANN's L2 does.
void addCellDistances(const CellTable& table, const Eigen::Vector3f& q, int x, int y, int z,
                      std::vector<float>* candidates) {
  const Eigen::Array3i& dims = table.dims;
  if (x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2]) return;
  const std::size_t c = static_cast<std::size_t>(table.indexOf(Eigen::Array3i(x, y, z)));
  const std::int32_t end = table.start[c + 1];
  for (std::int32_t k = table.start[c]; k < end; ++k) {
    const Eigen::Vector3f& p = table.sorted[static_cast<std::size_t>(k)];
    float d2 = 0.f;
    const float dx = q.x() - p.x();
    d2 += dx * dx;
    const float dy = q.y() - p.y();
    d2 += dy * dy;
    const float dz = q.z() - p.z();
    d2 += dz * dz;
    candidates->push_back(d2);
  }
}

// Keeps the `want` smallest candidates (those under guess_kth, when there are enough of them);
// returns the largest kept.
float keepSmallest(std::size_t want, float guess_kth, std::vector<float>* candidates_in) {
  std::vector<float>& candidates = *candidates_in;
  std::size_t under = 0;
  if (guess_kth > 0.f) {
    // A branch-free partition (each step swaps positions `under` and k).
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      const float d2 = candidates[k];
      candidates[k] = candidates[under];
      candidates[under] = d2;
      under += d2 <= guess_kth ? 1 : 0;
    }
  }
  if (under < want) under = candidates.size();
  std::nth_element(candidates.begin(), candidates.begin() + (want - 1),
                   candidates.begin() + static_cast<std::ptrdiff_t>(under));
  candidates.resize(want);
  return *std::max_element(candidates.begin(), candidates.end());
}

// The squared distances from point i of the table to its `want` nearest (itself included, as
// PCL's search returns it), shell by shell of cells: a point in a cell s + 1 cells away
// (Chebyshev) is at least s cells away in space, so once the want-th distance is within s cells
// nothing further can be nearer. *visited counts the cells visited.
void nearestSquaredDistances(const CellTable& table, const Eigen::Vector3f& q, std::size_t i,
                             std::size_t want, float guess_kth, std::vector<float>* candidates,
                             std::int64_t* visited) {
  const Eigen::Array3i& qc = table.cell_of[i];
  const int max_shell = std::max({table.dims[0], table.dims[1], table.dims[2]});
  candidates->clear();
  for (int s = 0; s <= max_shell; ++s) {
    for (int dz = -s; dz <= s; ++dz) {
      for (int dy = -s; dy <= s; ++dy) {
        const bool inner = std::abs(dz) < s && std::abs(dy) < s;
        for (int dx = -s; dx <= s; dx += (inner ? 2 * s : 1)) {
          ++*visited;
          addCellDistances(table, q, qc[0] + dx, qc[1] + dy, qc[2] + dz, candidates);
          if (s == 0) break;
        }
      }
    }
    if (s > 0 && candidates->size() >= want) {
      const float kth = keepSmallest(want, guess_kth, candidates);
      const double reach = s * table.cell_m;
      if (static_cast<double>(kth) < reach * reach * (1.0 - 1e-6)) break;
    }
  }
}

// PCL's statistic for the queries of the table's order [first, last): each point's mean distance
// to its mean_k nearest, their roots added in ascending order as PCL does, so the result is PCL's.
// Sparse clouds (many isolated points far apart) would visit many empty cells: past a budget
// (shared pro rata by the ranges) it stops, sets *over_budget and returns false (the k-d tree is
// cheaper then).
bool meanDistancesOnGrid(const PointCloud& finite, const CellTable& table, int mean_k,
                         std::size_t first, std::size_t last, std::atomic<bool>* over_budget,
                         std::vector<float>* mean_distance) {
  const std::size_t n = finite.size();
  const std::size_t want = static_cast<std::size_t>(mean_k) + 1;
  const std::int64_t budget =
      400 * static_cast<std::int64_t>(last - first) +
      static_cast<std::int64_t>(1000000.0 * static_cast<double>(last - first) / n) + 1;
  std::int64_t visited = 0;
  std::vector<float> candidates;
  // Neighbouring points have similar k-th distances: the previous query's pre-selects the
  // candidates, and the exact selection then runs on those few when they suffice.
  float guess_kth = 0.f;
  for (std::size_t ordered = first; ordered < last; ++ordered) {
    const std::size_t i = static_cast<std::size_t>(table.order[ordered]);
    nearestSquaredDistances(table, finite[i], i, want, guess_kth, &candidates, &visited);
    if (visited > budget || over_budget->load(std::memory_order_relaxed)) {
      *over_budget = true;
      return false;
    }
    std::sort(candidates.begin(), candidates.end());
    guess_kth = candidates.empty() ? 0.f : 1.5f * candidates.back();
    double sum = 0.0;
    for (std::size_t k = 1; k < want && k < candidates.size(); ++k) {
      sum += std::sqrt(candidates[k]);
    }
    (*mean_distance)[i] = static_cast<float>(sum / mean_k);
  }
  return true;
}

}  // namespace

PointCloud PointCloudFilter::removeStatisticalOutliersOnGrid(const PointCloud& points, int mean_k,
                                                             double stddev_mul, double cell_m,
                                                             int threads) {
  PointCloud finite = finitePoints(points);
  if (mean_k < 1 || !std::isfinite(stddev_mul) ||
      finite.size() < static_cast<std::size_t>(mean_k) + 1) {
    return finite;
  }
  if (!(std::isfinite(cell_m) && cell_m > 0.0)) {
    return removeStatisticalOutliers(finite, mean_k, stddev_mul);
  }
  // On a voxelised surface the k nearest lie within about sqrt(k) / 2 voxels: cells that wide keep
  // the search to the 27 cells around the point (the result does not depend on it).
  cell_m *= std::max(1.0, std::round(std::sqrt(mean_k + 1.0) / 1.5));
  CellTable table;
  if (!buildCellTable(finite, cell_m, &table)) {
    return removeStatisticalOutliers(finite, mean_k, stddev_mul);
  }
  std::vector<float> mean_distance(finite.size());
  std::atomic<bool> over_budget{false};
  // Each query is independent: the queries (in cell order) are split into contiguous ranges.
  // Below a few thousand points a thread costs more than it saves.
  parallelRanges(finite.size(), threads, 4096, [&](std::size_t first, std::size_t last) {
    meanDistancesOnGrid(finite, table, mean_k, first, last, &over_budget, &mean_distance);
  });
  if (over_budget) return removeStatisticalOutliers(finite, mean_k, stddev_mul);
  return keepBelowStatisticalThreshold(finite, mean_distance, stddev_mul, VarianceSum::kPcl);
}

}  // namespace mvod
