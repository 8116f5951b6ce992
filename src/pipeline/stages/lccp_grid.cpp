// Supervoxels (Papon et al. 2013) and LCCP's edge classification (Stein et al. 2014) on a hash
// voxel grid: the "voxel_grid" implementation of LccpSegmenter. The algorithm is PCL's; what
// differs is the data structure. Voxels are found by their integer grid keys (no octree), a voxel's
// neighbours are the 27 grid offsets, and the voxel normals, which PCL fits to the list of a
// voxel's neighbours and their neighbours (up to ~700 entries each), come from summed moments.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/point_moments.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {
namespace {

constexpr int kKeyBits = 21;  // per axis; LccpSegmenter refuses extents over 1e6 voxels
constexpr std::int64_t kKeyMax = (std::int64_t{1} << kKeyBits) - 1;

std::uint64_t packKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (static_cast<std::uint64_t>(x) << (2 * kKeyBits)) |
         (static_cast<std::uint64_t>(y) << kKeyBits) | static_cast<std::uint64_t>(z);
}
std::int64_t keyX(std::uint64_t key) { return static_cast<std::int64_t>(key >> (2 * kKeyBits)); }
std::int64_t keyY(std::uint64_t key) {
  return static_cast<std::int64_t>((key >> kKeyBits) & static_cast<std::uint64_t>(kKeyMax));
}
std::int64_t keyZ(std::uint64_t key) {
  return static_cast<std::int64_t>(key & static_cast<std::uint64_t>(kKeyMax));
}

// Morton code (x, y, z bits interleaved from the top, x first): an octree's depth-first order.
// Bit b of x goes to bit 3b + 2 of the code, of y to 3b + 1, of z to 3b (the low 21 bits of each),
// spread and gathered with shifts and masks rather than bit by bit.
std::uint64_t spreadBits(std::int64_t value) {
  std::uint64_t v = static_cast<std::uint64_t>(value) & 0x1fffffULL;
  v = (v | (v << 32)) & 0x1f00000000ffffULL;
  v = (v | (v << 16)) & 0x1f0000ff0000ffULL;
  v = (v | (v << 8)) & 0x100f00f00f00f00fULL;
  v = (v | (v << 4)) & 0x10c30c30c30c30c3ULL;
  v = (v | (v << 2)) & 0x1249249249249249ULL;
  return v;
}
std::int64_t gatherBits(std::uint64_t code) {
  std::uint64_t v = code & 0x1249249249249249ULL;
  v = (v ^ (v >> 2)) & 0x10c30c30c30c30c3ULL;
  v = (v ^ (v >> 4)) & 0x100f00f00f00f00fULL;
  v = (v ^ (v >> 8)) & 0x1f0000ff0000ffULL;
  v = (v ^ (v >> 16)) & 0x1f00000000ffffULL;
  v = (v ^ (v >> 32)) & 0x1fffffULL;
  return static_cast<std::int64_t>(v);
}
std::uint64_t morton(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (spreadBits(x) << 2) | (spreadBits(y) << 1) | spreadBits(z);
}
std::uint64_t unMorton(std::uint64_t code) {
  return packKey(gatherBits(code >> 2), gatherBits(code >> 1), gatherBits(code));
}

// The origin of an octree of leaf size `resolution` over [lower, upper] whose bounds are given
// up front: the bounds centred in a cube of a power-of-two number of leaves (PCL's rule).
Eigen::Vector3d centredOctreeOrigin(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                    double resolution) {
  const double epsilon = std::numeric_limits<float>::epsilon();
  double max_keys = 2.0;
  for (int axis = 0; axis < 3; ++axis) {
    max_keys = std::max(max_keys, std::ceil((upper[axis] - lower[axis] - epsilon) / resolution));
  }
  const int depth = static_cast<int>(std::ceil(std::log2(max_keys) - epsilon));
  const double side = static_cast<double>(std::int64_t{1} << depth) * resolution;
  Eigen::Vector3d origin = lower;
  for (int axis = 0; axis < 3; ++axis) {
    const double oversize = (side - (upper[axis] - lower[axis])) / 2.0;
    if (oversize > epsilon) origin[axis] -= oversize;
  }
  return origin;
}

// The origin of an octree of leaf size `resolution` that grows to take points one at a time: it
// starts as two leaves around the first point and doubles towards each point outside (PCL's rule).
// Only the origin's lattice and the resulting order of cells matter here.
Eigen::Vector3d growingOctreeOrigin(const std::vector<Eigen::Vector3f>& points, double resolution) {
  const double epsilon = std::numeric_limits<float>::epsilon();
  Eigen::Vector3d lower = points.front().cast<double>() - Eigen::Vector3d::Constant(resolution);
  Eigen::Vector3d upper = points.front().cast<double>() + Eigen::Vector3d::Constant(resolution);
  int depth = 1;
  for (const Eigen::Vector3f& p : points) {
    for (;;) {
      bool outside = false;
      Eigen::Vector3i above = Eigen::Vector3i::Zero();
      for (int axis = 0; axis < 3; ++axis) {
        if (p[axis] < lower[axis]) outside = true;
        if (p[axis] >= upper[axis]) {
          outside = true;
          above[axis] = 1;
        }
      }
      if (!outside) break;
      const double side = static_cast<double>(std::int64_t{1} << depth) * resolution;
      for (int axis = 0; axis < 3; ++axis) {
        if (!above[axis]) lower[axis] -= side;
      }
      ++depth;
      upper = lower + Eigen::Vector3d::Constant(
                          static_cast<double>(std::int64_t{1} << depth) * resolution - epsilon);
    }
  }
  return lower;
}

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

// The plane normal of a multiset: the covariance's eigenvector of the smallest eigenvalue; zero
// when the points do not span a plane's worth of directions (one point, repeated).
Eigen::Vector3f planeNormal(const PointMoments& moments) {
  const Eigen::Matrix3d covariance = moments.covariance();
  if (!(covariance.trace() > 1e-12)) return Eigen::Vector3f::Zero();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  return solver.eigenvectors().col(0).normalized().cast<float>();
}

double angleDeg(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const double cosine =
      std::clamp(static_cast<double>(a.normalized().dot(b.normalized())), -1.0, 1.0);
  return std::acos(cosine) * 180.0 / 3.14159265358979323846;
}

// Entries grouped by a small integer (stable: ascending entry within a group).
struct Buckets {
  std::vector<int> begin;  // group g holds entries[begin[g] .. begin[g + 1])
  std::vector<int> entries;
  void build(const std::vector<int>& group_of, int num_groups) {
    begin.assign(num_groups + 1, 0);
    for (const int g : group_of) {
      if (g >= 0) ++begin[g + 1];
    }
    for (int g = 0; g < num_groups; ++g) begin[g + 1] += begin[g];
    entries.assign(begin[num_groups], 0);
    std::vector<int> next(begin.begin(), begin.end() - 1);
    for (int i = 0; i < static_cast<int>(group_of.size()); ++i) {
      if (group_of[i] >= 0) entries[next[group_of[i]]++] = i;
    }
  }
  int size(int g) const { return begin[g + 1] - begin[g]; }
};

// 1. The voxels of the (log-depth) grid, placed as PCL's adjacency octree places them, in its
// leaf order (Morton order), with their centroids and their occupied 27-neighbourhoods.
struct VoxelGrid {
  std::vector<std::uint64_t> key;
  std::vector<Eigen::Vector3f> centroid;
  std::vector<int> voxel_of_point;   // per input point; -1: none
  std::vector<int> neighbour_begin;  // voxel v's neighbours: neighbours[begin[v] .. begin[v + 1])
  std::vector<int> neighbours;       // itself included (as PCL's adjacency octree)
  int size() const { return static_cast<int>(key.size()); }
};

// The cloud's points on the grid of `resolution` (in the log-depth space when log_transform):
// the cloud's bounds centred in a power-of-two box of voxels.
Status voxelKeys(const PointCloud& points, bool log_transform, double resolution,
                 std::vector<std::pair<std::uint64_t, int>>* keyed) {
  const auto transformed = [log_transform](const Eigen::Vector3f& p) {
    return log_transform ? Eigen::Vector3f(p.x() / p.z(), p.y() / p.z(), std::log(p.z())) : p;
  };
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = -lower;
  std::vector<char> usable(points.size(), 0);
  std::vector<Eigen::Vector3f> transformed_points(points.size());  // each transformed once
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite() || (log_transform && !(points[i].z() > 0.0f))) continue;
    transformed_points[i] = transformed(points[i]);
    const Eigen::Vector3d q = transformed_points[i].cast<double>();
    if (!q.allFinite()) continue;
    usable[i] = 1;
    lower = lower.cwiseMin(q);
    upper = upper.cwiseMax(q);
  }
  if (!lower.allFinite()) return Status::Error("no finite points to cluster");
  if (((upper - lower) / resolution).maxCoeff() >= static_cast<double>(kKeyMax)) {
    return Status::Error("cloud extent too large for voxel_resolution_m " +
                         std::to_string(resolution));
  }
  lower = centredOctreeOrigin(lower, upper, resolution);
  keyed->reserve(points.size());  // (Morton code, point)
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!usable[i]) continue;
    const Eigen::Vector3d cell =
        ((transformed_points[i].cast<double>() - lower) / resolution).array().floor();
    keyed->emplace_back(
        morton(static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
               static_cast<std::int64_t>(cell.z())),
        static_cast<int>(i));
  }
  radixSortByKey(keyed);
  return Status::Ok();
}

Status buildVoxelGrid(const PointCloud& points, bool log_transform, double resolution,
                      VoxelGrid* grid) {
  std::vector<std::pair<std::uint64_t, int>> keyed;
  const Status keyed_ok = voxelKeys(points, log_transform, resolution, &keyed);
  if (!keyed_ok) return keyed_ok;
  grid->voxel_of_point.assign(points.size(), -1);
  for (std::size_t begin = 0; begin < keyed.size();) {
    std::size_t end = begin;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();  // float, in input order, as PCL's leaves
    while (end < keyed.size() && keyed[end].first == keyed[begin].first) {
      sum += points[keyed[end].second];
      grid->voxel_of_point[keyed[end].second] = static_cast<int>(grid->key.size());
      ++end;
    }
    grid->key.push_back(unMorton(keyed[begin].first));
    grid->centroid.push_back(sum / static_cast<float>(end - begin));
    begin = end;
  }
  const int num_voxels = grid->size();
  KeyIndex voxel_index(grid->key.size());
  for (int v = 0; v < num_voxels; ++v) voxel_index.insert(grid->key[v], v);
  grid->neighbour_begin.assign(num_voxels + 1, 0);
  grid->neighbours.reserve(static_cast<std::size_t>(num_voxels) * 12);
  for (int v = 0; v < num_voxels; ++v) {
    forEachNeighbourKey(grid->key[v], voxel_index,
                        [grid](int n) { grid->neighbours.push_back(n); });
    grid->neighbour_begin[v + 1] = static_cast<int>(grid->neighbours.size());
  }
  return Status::Ok();
}

// 2. Voxel normals. PCL fits each to its voxel, its neighbours and their neighbours, counted with
// multiplicity: moments(v) + sum over neighbours n of (moments(n) + neighbourhood moments(n)).
// Each voxel's moments depend on its own neighbourhood only: split over the threads (the same
// result). Turned towards the frame's origin.
std::vector<Eigen::Vector3f> voxelNormals(const VoxelGrid& grid, int threads) {
  constexpr std::size_t kMinVoxelsPerThread = 2048;
  const int num_voxels = grid.size();
  const std::size_t voxel_count = static_cast<std::size_t>(num_voxels);
  const std::vector<int>& begin = grid.neighbour_begin;
  const std::vector<int>& neighbours = grid.neighbours;
  const Eigen::Vector3d origin = grid.centroid.front().cast<double>();  // for the precision
  std::vector<PointMoments> own(num_voxels), around(num_voxels);
  for (int v = 0; v < num_voxels; ++v) own[v].add(grid.centroid[v].cast<double>() - origin);
  parallelRanges(voxel_count, threads, kMinVoxelsPerThread,
                 [&](std::size_t first, std::size_t last) {
                   for (std::size_t v = first; v < last; ++v) {
                     for (int k = begin[v]; k < begin[v + 1]; ++k)
                       around[v].add(own[neighbours[k]]);
                   }
                 });
  std::vector<Eigen::Vector3f> normal(num_voxels);
  parallelRanges(voxel_count, threads, kMinVoxelsPerThread,
                 [&](std::size_t first, std::size_t last) {
                   for (std::size_t v = first; v < last; ++v) {
                     PointMoments total = own[v];
                     for (int k = begin[v]; k < begin[v + 1]; ++k) {
                       total.add(own[neighbours[k]]);
                       total.add(around[neighbours[k]]);
                     }
                     normal[v] = planeNormal(total);
                     if (grid.centroid[v].dot(normal[v]) > 0.0f) normal[v] = -normal[v];
                   }
                 });
  return normal;
}

// 3. Seeds: per occupied cell of a seed_m grid over the voxel centroids (real space), the voxel
// nearest to the cell's centre; kept where enough voxels lie within half a seed. The cells and
// their order are those of PCL's seed octree, which grows around the first centroid.
class SeedCells {
 public:
  SeedCells(const std::vector<Eigen::Vector3f>& centroid, double seed_m)
      : centroid_(centroid), seed_m_(seed_m), origin_(growingOctreeOrigin(centroid, seed_m)) {
    keyed_.reserve(centroid.size());
    for (int v = 0; v < static_cast<int>(centroid.size()); ++v) {
      keyed_.emplace_back(cellOf(centroid[v]), v);
    }
    radixSortByKey(&keyed_);
    for (std::size_t k = 0; k < keyed_.size(); ++k) {
      if (k == 0 || keyed_[k].first != keyed_[k - 1].first) {
        key_.push_back(keyed_[k].first);
        begin_.push_back(static_cast<int>(k));
      }
    }
    begin_.push_back(static_cast<int>(keyed_.size()));
    index_ = KeyIndex(key_.size());
    for (std::size_t c = 0; c < key_.size(); ++c) index_.insert(key_[c], static_cast<int>(c));
  }

  std::uint64_t cellOf(const Eigen::Vector3f& p) const {
    const Eigen::Vector3d cell = ((p.cast<double>() - origin_) / seed_m_).array().floor();
    return packKey(static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
                   static_cast<std::int64_t>(cell.z()));
  }
  // The occupied cells in octree (Morton) order.
  std::vector<int> octreeOrder() const {
    std::vector<std::pair<std::uint64_t, int>> order;
    order.reserve(key_.size());
    for (std::size_t c = 0; c < key_.size(); ++c) {
      order.emplace_back(morton(keyX(key_[c]), keyY(key_[c]), keyZ(key_[c])), static_cast<int>(c));
    }
    radixSortByKey(&order);
    std::vector<int> cells;
    cells.reserve(order.size());
    for (const auto& entry : order) cells.push_back(entry.second);
    return cells;
  }
  // The voxel nearest to cell c's centre among the 27 cells around it (-1: none). The centre and
  // the distances in float, as PCL's octree and k-d tree compute them.
  int nearestToCentre(int c) const {
    const std::uint64_t key = key_[c];
    const Eigen::Vector3f centre(
        static_cast<float>((static_cast<double>(keyX(key)) + 0.5) * seed_m_ + origin_.x()),
        static_cast<float>((static_cast<double>(keyY(key)) + 0.5) * seed_m_ + origin_.y()),
        static_cast<float>((static_cast<double>(keyZ(key)) + 0.5) * seed_m_ + origin_.z()));
    int nearest = -1;
    float nearest_sq = std::numeric_limits<float>::infinity();
    forEachNeighbourKey(key, index_, [&](int cell) {
      for (int k = begin_[cell]; k < begin_[cell + 1]; ++k) {
        const int v = keyed_[k].second;
        const float d_sq = (centroid_[v] - centre).squaredNorm();
        if (d_sq < nearest_sq || (d_sq == nearest_sq && v < nearest)) {
          nearest = v;
          nearest_sq = d_sq;
        }
      }
    });
    return nearest;
  }
  // How many voxels lie within radius_m of voxel v (in the 27 cells around its cell).
  int voxelsNear(int v, double radius_m) const {
    int near = 0;
    const Eigen::Vector3d seed_point = centroid_[v].cast<double>();
    forEachNeighbourKey(cellOf(centroid_[v]), index_, [&](int cell) {
      for (int k = begin_[cell]; k < begin_[cell + 1]; ++k) {
        const double d = (centroid_[keyed_[k].second].cast<double>() - seed_point).norm();
        if (d <= radius_m) ++near;
      }
    });
    return near;
  }

 private:
  const std::vector<Eigen::Vector3f>& centroid_;
  double seed_m_;
  Eigen::Vector3d origin_;
  std::vector<std::pair<std::uint64_t, int>> keyed_;  // (cell key, voxel), by cell
  std::vector<std::uint64_t> key_;                    // the occupied cells
  std::vector<int> begin_;  // cell c's voxels: keyed_[begin_[c] .. begin_[c + 1])
  KeyIndex index_{0};
};

Status placeSeeds(const std::vector<Eigen::Vector3f>& centroid, double seed_m, double resolution,
                  std::vector<int>* seeds) {
  Eigen::Vector3d centroid_lower = centroid.front().cast<double>();
  Eigen::Vector3d centroid_upper = centroid_lower;
  for (const Eigen::Vector3f& c : centroid) {
    centroid_lower = centroid_lower.cwiseMin(c.cast<double>());
    centroid_upper = centroid_upper.cwiseMax(c.cast<double>());
  }
  if (((centroid_upper - centroid_lower) / seed_m).maxCoeff() >= static_cast<double>(kKeyMax / 4)) {
    return Status::Error("cloud extent too large for seed_resolution_m " + std::to_string(seed_m));
  }
  const SeedCells cells(centroid, seed_m);
  const double search_radius_m = 0.5 * seed_m;
  // PCL's bar: a twentieth of the voxels that fit in a disc of the search radius.
  const double min_voxels_near =
      0.05 * search_radius_m * search_radius_m * 3.14159265358979323846 / (resolution * resolution);
  for (const int c : cells.octreeOrder()) {
    const int nearest = cells.nearestToCentre(c);
    if (nearest < 0) continue;
    // Below 1 the seed itself suffices.
    if (min_voxels_near >= 1.0 && !(cells.voxelsNear(nearest, search_radius_m) > min_voxels_near)) {
      continue;
    }
    seeds->push_back(nearest);  // two cells may give the same voxel: PCL keeps both seeds
  }
  if (seeds->empty()) return Status::Error("no supervoxel seeds");
  return Status::Ok();
}

// 4. Expansion, PCL's rule: each supervoxel in turn claims the neighbours of the voxels it held
// when its turn began, wherever its distance (spatial over seed_resolution_m, plus normal) beats
// the distance the voxel was last claimed at; then the centroids move. Seeds start with a zero
// centroid and normal, as PCL's helpers do before their first update.
//
// A supervoxel's voxels are those it owns plus, as in PCL, a seed voxel that a later seed of the
// same voxel took over ("phantom"): PCL removes a voxel only from its owner's set, so the earlier
// seed keeps it, grows from it and counts it in its centroid until it owns it again.
class SupervoxelExpansion {
 public:
  SupervoxelExpansion(const VoxelGrid& grid, const std::vector<Eigen::Vector3f>& normal,
                      const std::vector<int>& seeds, const LccpSegmenter::Config& config)
      : grid_(grid),
        normal_(normal),
        num_seeds_(static_cast<int>(seeds.size())),
        seed_f_(static_cast<float>(config.seed_resolution_m)),
        spatial_importance_(static_cast<float>(config.spatial_importance)),
        normal_importance_(static_cast<float>(config.normal_importance)),
        owner_(grid.size(), -1),
        claimed_at_(grid.size(), std::numeric_limits<float>::max()),
        centroid_(num_seeds_, Eigen::Vector3f::Zero()),
        normal_sv_(num_seeds_, Eigen::Vector3f::Zero()),
        alive_(num_seeds_, 1) {
    for (int s = 0; s < num_seeds_; ++s) {
      if (owner_[seeds[s]] >= 0) phantoms_.emplace_back(owner_[seeds[s]], seeds[s]);
      owner_[seeds[s]] = s;
    }
    members_.build(owner_, num_seeds_);
    groupPhantoms();
  }

  void run(int iterations) {
    for (int iteration = 1; iteration < iterations; ++iteration) {
      for (int s = 0; s < num_seeds_; ++s) {
        if (alive_[s]) claimNeighbours(s);
      }
      members_.build(owner_, num_seeds_);
      groupPhantoms();
      for (int s = 0; s < num_seeds_; ++s) {
        if (alive_[s]) updateCentroid(s);
      }
    }
  }

  // The voxels of supervoxel s, ascending (PCL's leaf set is ordered by voxel index).
  const std::vector<int>& held(int s) {
    held_.clear();
    for (int k = members_.begin[s]; k < members_.begin[s + 1]; ++k) {
      if (owner_[members_.entries[k]] == s) held_.push_back(members_.entries[k]);
    }
    if (phantom_begin_[s] < phantom_begin_[s + 1]) {
      held_.insert(held_.end(), phantom_voxel_.begin() + phantom_begin_[s],
                   phantom_voxel_.begin() + phantom_begin_[s + 1]);
      std::sort(held_.begin(), held_.end());
      held_.erase(std::unique(held_.begin(), held_.end()), held_.end());
    }
    return held_;
  }
  int numSeeds() const { return num_seeds_; }
  bool alive(int s) const { return alive_[s] != 0; }
  int owner(int voxel) const { return owner_[voxel]; }
  const Eigen::Vector3f& centroid(int s) const { return centroid_[s]; }
  const Eigen::Vector3f& normal(int s) const { return normal_sv_[s]; }

 private:
  void claimNeighbours(int s) {
    const Eigen::Vector3f c = centroid_[s];
    const Eigen::Vector3f n = normal_sv_[s];
    for (const int leaf : held(s)) {
      for (int k = grid_.neighbour_begin[leaf]; k < grid_.neighbour_begin[leaf + 1]; ++k) {
        const int v = grid_.neighbours[k];
        if (owner_[v] == s) continue;
        const float distance = (1.0f - std::fabs(n.dot(normal_[v]))) * normal_importance_ +
                               ((c - grid_.centroid[v]).norm() / seed_f_) * spatial_importance_;
        if (distance < claimed_at_[v]) {
          claimed_at_[v] = distance;
          owner_[v] = s;
        }
      }
    }
  }
  void updateCentroid(int s) {
    const std::vector<int>& voxels = held(s);
    if (voxels.empty()) {
      alive_[s] = 0;
      return;
    }
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();  // float, ascending voxels, as PCL
    Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
    for (const int v : voxels) {
      sum += grid_.centroid[v];
      normal_sum += normal_[v];
    }
    centroid_[s] = sum / static_cast<float>(voxels.size());
    normal_sv_[s] = normal_sum.norm() > 0.0f ? normal_sum.normalized() : Eigen::Vector3f::Zero();
  }
  // The phantoms still apart from their voxel's owner, grouped by supervoxel.
  void groupPhantoms() {
    phantoms_.erase(std::remove_if(phantoms_.begin(), phantoms_.end(),
                                   [this](const std::pair<int, int>& p) {
                                     return owner_[p.second] == p.first;  // owned again: a member
                                   }),
                    phantoms_.end());
    std::sort(phantoms_.begin(), phantoms_.end());
    phantoms_.erase(std::unique(phantoms_.begin(), phantoms_.end()), phantoms_.end());
    phantom_begin_.assign(num_seeds_ + 1, 0);
    for (const auto& p : phantoms_) ++phantom_begin_[p.first + 1];
    for (int s = 0; s < num_seeds_; ++s) phantom_begin_[s + 1] += phantom_begin_[s];
    phantom_voxel_.clear();
    for (const auto& p : phantoms_) phantom_voxel_.push_back(p.second);
  }

  const VoxelGrid& grid_;
  const std::vector<Eigen::Vector3f>& normal_;  // per voxel
  const int num_seeds_;
  const float seed_f_;
  const float spatial_importance_;
  const float normal_importance_;
  std::vector<int> owner_;                  // per voxel; -1: none
  std::vector<float> claimed_at_;           // per voxel
  std::vector<Eigen::Vector3f> centroid_;   // per supervoxel
  std::vector<Eigen::Vector3f> normal_sv_;  // per supervoxel
  std::vector<char> alive_;
  std::vector<std::pair<int, int>> phantoms_;  // (supervoxel, voxel), few
  Buckets members_;                            // owned voxels per supervoxel, ascending
  std::vector<int> phantom_begin_;             // phantoms grouped by supervoxel
  std::vector<int> phantom_voxel_;
  std::vector<int> held_;
};

// 5. The supervoxels (live ones, in seed order), their points and their adjacency: s and t are
// adjacent where a voxel of s (phantoms included, as in PCL) neighbours one that t owns. Each
// adjacency classified by LCCP's edge test.
void buildGraph(std::size_t num_points, const VoxelGrid& grid, SupervoxelExpansion* expansion,
                const LccpSegmenter::Config& config, LccpSegmenter::SupervoxelGraph* graph) {
  const int num_seeds = expansion->numSeeds();
  std::vector<int> index_of(num_seeds, -1);
  for (int s = 0; s < num_seeds; ++s) {
    if (!expansion->alive(s)) continue;
    index_of[s] = static_cast<int>(graph->centroids.size());
    graph->centroids.push_back(expansion->centroid(s));
    graph->normals.push_back(expansion->normal(s));
  }
  for (std::size_t i = 0; i < num_points; ++i) {
    const int voxel = grid.voxel_of_point[i];
    if (voxel >= 0 && expansion->owner(voxel) >= 0) {
      graph->point_supervoxel[i] = index_of[expansion->owner(voxel)];
    }
  }
  std::vector<int> seen_from(num_seeds, -1);
  std::vector<std::uint64_t> pairs;
  for (int s = 0; s < num_seeds; ++s) {
    if (!expansion->alive(s)) continue;
    for (const int leaf : expansion->held(s)) {
      for (int j = grid.neighbour_begin[leaf]; j < grid.neighbour_begin[leaf + 1]; ++j) {
        const int t = expansion->owner(grid.neighbours[j]);
        if (t < 0 || t == s || seen_from[t] == s) continue;
        seen_from[t] = s;
        const std::uint64_t a = static_cast<std::uint64_t>(std::min(index_of[s], index_of[t]));
        const std::uint64_t b = static_cast<std::uint64_t>(std::max(index_of[s], index_of[t]));
        pairs.push_back((a << 32) | b);
      }
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  graph->edges.reserve(pairs.size());
  for (const std::uint64_t pair : pairs) {
    LccpSegmenter::SupervoxelEdge edge;
    edge.a = static_cast<int>(pair >> 32);
    edge.b = static_cast<int>(pair & 0xffffffffu);
    edge.convex =
        LccpSegmenter::convexConnection(graph->centroids[edge.a], graph->normals[edge.a],
                                        graph->centroids[edge.b], graph->normals[edge.b], config);
    graph->edges.push_back(edge);
  }
}

}  // namespace

bool LccpSegmenter::convexConnection(const Eigen::Vector3f& c_s, const Eigen::Vector3f& n_s_in,
                                     const Eigen::Vector3f& c_t, const Eigen::Vector3f& n_t_in,
                                     const Config& config) {
  const Eigen::Vector3f n_s = n_s_in.normalized();
  const Eigen::Vector3f n_t = n_t_in.normalized();
  const double normal_angle_deg = angleDeg(n_s, n_t);
  const Eigen::Vector3f t_to_s = c_s - c_t;
  const Eigen::Vector3f bend_axis = n_s.cross(n_t);

  // Smoothness: the patches' offset along either normal may not exceed what their bend explains
  // over a seed's width, plus smoothness_threshold voxels of slack: a step is not a joint.
  const float expected_offset_m = bend_axis.norm() * static_cast<float>(config.seed_resolution_m);
  const float offset_m = std::min(std::fabs(t_to_s.dot(n_s)), std::fabs(t_to_s.dot(n_t)));
  if (offset_m > expected_offset_m +
                     static_cast<float>(config.smoothness_threshold * config.voxel_resolution_m)) {
    return false;
  }
  // Sanity: where the line between the centroids runs nearly along the bend axis, convexity is
  // not defined; the more the normals differ, the wider that cone (a sigmoid up to 60 deg).
  if (config.use_sanity_criterion) {
    const double axis_angle_deg = angleDeg(bend_axis, t_to_s);
    const double to_axis_deg = std::min(axis_angle_deg, 180.0 - axis_angle_deg);
    const double cone_deg = 60.0 / (1.0 + std::exp(-0.25 * (normal_angle_deg - 25.0)));
    if (to_axis_deg < cone_deg) return false;
  }
  // Convex: seen from t towards s, s's normal leans away no less than t's.
  const bool convex = angleDeg(t_to_s, n_s) - angleDeg(t_to_s, n_t) <= 0.0;
  return convex || normal_angle_deg < config.concavity_tolerance_deg;
}

Status LccpSegmenter::gridSupervoxels(const PointCloud& points, bool log_transform,
                                      SupervoxelGraph* graph) const {
  if (graph == nullptr) return Status::Error("graph must not be null");
  *graph = SupervoxelGraph();
  const Status valid = config_.isValid();
  if (!valid) return valid;
  graph->point_supervoxel.assign(points.size(), -1);
  const double resolution = static_cast<float>(config_.voxel_resolution_m);
  VoxelGrid grid;
  const Status voxelized = buildVoxelGrid(points, log_transform, resolution, &grid);
  if (!voxelized) return voxelized;
  const std::vector<Eigen::Vector3f> normal = voxelNormals(grid, config_.num_threads);
  std::vector<int> seeds;
  const double seed_m = static_cast<float>(config_.seed_resolution_m);
  const Status seeded = placeSeeds(grid.centroid, seed_m, resolution, &seeds);
  if (!seeded) return seeded;
  SupervoxelExpansion expansion(grid, normal, seeds, config_);
  expansion.run(static_cast<int>(1.8f * static_cast<float>(config_.seed_resolution_m) /
                                 static_cast<float>(config_.voxel_resolution_m)));
  buildGraph(points.size(), grid, &expansion, config_, graph);
  return Status::Ok();
}

}  // namespace mvod
