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

#include "lccp_voxel_grid.h"
#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"
#include "multiview_object_detection/pipeline/utils/point_moments.h"
#include "multiview_object_detection/pipeline/utils/radix_sort.h"

namespace mvod {
namespace {

using lccp_grid::buildVoxelGrid;
using lccp_grid::forEachNeighbourKey;
using lccp_grid::growingOctreeOrigin;
using lccp_grid::KeyIndex;
using lccp_grid::keyX;
using lccp_grid::keyY;
using lccp_grid::keyZ;
using lccp_grid::kKeyMax;
using lccp_grid::morton;
using lccp_grid::packKey;
using lccp_grid::VoxelGrid;
using lccp_grid::voxelNormals;

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
