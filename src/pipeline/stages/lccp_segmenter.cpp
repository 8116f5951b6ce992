#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/lccp_segmentation.h>
#include <pcl/segmentation/supervoxel_clustering.h>

#include <algorithm>
#include <cstdint>
#include <exception>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

namespace mvod {
namespace {

constexpr double kMaxVoxelsPerAxis = 1.0e6;

bool finiteNonNegative(double value) { return std::isfinite(value) && value >= 0.0; }

// The "pcl" implementation: PCL's supervoxels and LCCP's edge classification.
Status pclSupervoxels(const PointCloud& points, const std::vector<std::size_t>& source_index,
                      bool log_transform, const LccpSegmenter::Config& config,
                      LccpSegmenter::SupervoxelGraph* graph) {
  using SupervoxelEdge = LccpSegmenter::SupervoxelEdge;
  *graph = LccpSegmenter::SupervoxelGraph();
  graph->point_supervoxel.assign(points.size(), -1);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(source_index.size());
  for (const std::size_t i : source_index) {
    cloud->push_back(pcl::PointXYZ(points[i].x(), points[i].y(), points[i].z()));
  }
  try {
    pcl::SupervoxelClustering<pcl::PointXYZ> supervoxels(
        static_cast<float>(config.voxel_resolution_m),
        static_cast<float>(config.seed_resolution_m));
    supervoxels.setUseSingleCameraTransform(log_transform);
    supervoxels.setInputCloud(cloud);
    supervoxels.setSpatialImportance(static_cast<float>(config.spatial_importance));
    supervoxels.setNormalImportance(static_cast<float>(config.normal_importance));
    supervoxels.setColorImportance(static_cast<float>(config.color_importance));
    std::map<std::uint32_t, pcl::Supervoxel<pcl::PointXYZ>::Ptr> clusters;
    supervoxels.extract(clusters);
    if (clusters.empty()) return Status::Ok();
    std::multimap<std::uint32_t, std::uint32_t> adjacency;
    supervoxels.getSupervoxelAdjacency(adjacency);

    pcl::LCCPSegmentation<pcl::PointXYZ> lccp;
    lccp.setConcavityToleranceThreshold(static_cast<float>(config.concavity_tolerance_deg));
    lccp.setSanityCheck(config.use_sanity_criterion);
    lccp.setSmoothnessCheck(true, static_cast<float>(config.voxel_resolution_m),
                            static_cast<float>(config.seed_resolution_m),
                            static_cast<float>(config.smoothness_threshold));
    lccp.setKFactor(config.use_extended_convexity ? 1 : 0);
    // PCL groups and merges small segments in the order of its graph's vertices, which are heap
    // addresses (boost::setS): the same input could give different segments in another thread or
    // process. Only the convex/concave classification of each edge is taken from PCL; grouping and
    // merging follow the supervoxel labels (groupSupervoxels).
    lccp.setMinSegmentSize(0);
    lccp.setInputSupervoxels(clusters, adjacency);
    lccp.segment();
    pcl::LCCPSegmentation<pcl::PointXYZ>::SupervoxelAdjacencyList lccp_graph;
    lccp.getSVAdjacencyList(lccp_graph);
    std::vector<std::uint32_t> labels;
    labels.reserve(clusters.size());
    for (const auto& entry : clusters) {  // ascending labels (std::map)
      labels.push_back(entry.first);
      const pcl::PointXYZRGBA& c = entry.second->centroid_;
      const pcl::Normal& n = entry.second->normal_;
      graph->centroids.emplace_back(c.x, c.y, c.z);
      graph->normals.emplace_back(n.normal_x, n.normal_y, n.normal_z);
    }
    const auto indexOf = [&labels](std::uint32_t label) {
      return static_cast<int>(std::lower_bound(labels.begin(), labels.end(), label) -
                              labels.begin());
    };
    graph->edges.reserve(boost::num_edges(lccp_graph));
    const auto edge_range = boost::edges(lccp_graph);
    for (auto it = edge_range.first; it != edge_range.second; ++it) {
      SupervoxelEdge edge;
      edge.a = indexOf(lccp_graph[boost::source(*it, lccp_graph)]);
      edge.b = indexOf(lccp_graph[boost::target(*it, lccp_graph)]);
      edge.convex = lccp_graph[*it].is_valid;
      graph->edges.push_back(edge);
    }

    // Each input point takes its supervoxel; label 0 = not in any supervoxel.
    const pcl::PointCloud<pcl::PointXYZL>::Ptr labeled = supervoxels.getLabeledCloud();
    if (labeled == nullptr || labeled->size() != cloud->size()) {
      return Status::Error("supervoxel labels do not match the input cloud");
    }
    for (std::size_t i = 0; i < labeled->size(); ++i) {
      const std::uint32_t label = (*labeled)[i].label;
      if (label == 0 || !std::binary_search(labels.begin(), labels.end(), label)) continue;
      graph->point_supervoxel[source_index[i]] = indexOf(label);
    }
  } catch (const std::exception& e) {
    *graph = LccpSegmenter::SupervoxelGraph();
    return Status::Error(std::string("PCL supervoxel/LCCP failed: ") + e.what());
  } catch (...) {
    *graph = LccpSegmenter::SupervoxelGraph();
    return Status::Error("PCL supervoxel/LCCP failed with an unknown exception");
  }
  return Status::Ok();
}

}  // namespace

Status LccpSegmenter::Config::isValid() const {
  if (Status s = checkParameterRange("lccp/voxel_resolution_m", voxel_resolution_m); !s) return s;
  if (Status s = checkParameterRange("lccp/seed_resolution_m", seed_resolution_m); !s) return s;
  if (!(seed_resolution_m >= voxel_resolution_m)) {
    return Status::Error("lccp/seed_resolution_m must be >= lccp/voxel_resolution_m (got " +
                         std::to_string(seed_resolution_m) + ")");
  }
  if (!finiteNonNegative(spatial_importance) || !finiteNonNegative(normal_importance) ||
      !finiteNonNegative(color_importance)) {
    return Status::Error("spatial/normal/color_importance must be finite values >= 0");
  }
  if (!(finiteNonNegative(concavity_tolerance_deg) && concavity_tolerance_deg < 90.0)) {
    return Status::Error("concavity_tolerance_deg must be in [0, 90) (got " +
                         std::to_string(concavity_tolerance_deg) + ")");
  }
  if (!finiteNonNegative(smoothness_threshold)) {
    return Status::Error("smoothness_threshold must be a finite value >= 0 (got " +
                         std::to_string(smoothness_threshold) + ")");
  }
  if (min_segment_size < 0) {
    return Status::Error("min_segment_size must be >= 0 (got " + std::to_string(min_segment_size) +
                         ")");
  }
  if (num_threads < 1 || num_threads > 256) {
    return Status::Error("num_threads must be in [1, 256] (got " + std::to_string(num_threads) +
                         ")");
  }
  if (implementation != "voxel_grid" && implementation != "pcl") {
    return Status::Error("implementation must be voxel_grid or pcl (got '" + implementation + "')");
  }
  if (use_extended_convexity && implementation != "pcl") {
    return Status::Error("use_extended_convexity needs implementation: pcl");
  }
  if (Status s = checkParameterRange("lccp/min_points", min_points); !s) return s;
  return Status::Ok();
}

std::string LccpSegmenter::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "implementation: " << implementation << "\n"
      << "voxel_resolution_m: " << voxel_resolution_m << "\n"
      << "seed_resolution_m: " << seed_resolution_m << "\n"
      << "spatial_importance: " << spatial_importance << "\n"
      << "normal_importance: " << normal_importance << "\n"
      << "color_importance: " << color_importance << "\n"
      << "log_depth_transform: " << (log_depth_transform ? "true" : "false") << "\n"
      << "concavity_tolerance_deg: " << concavity_tolerance_deg << "\n"
      << "smoothness_threshold: " << smoothness_threshold << "\n"
      << "min_segment_size: " << min_segment_size << "\n"
      << "use_extended_convexity: " << (use_extended_convexity ? "true" : "false") << "\n"
      << "use_sanity_criterion: " << (use_sanity_criterion ? "true" : "false") << "\n"
      << "min_points: " << min_points << "\n";
  return out.str();
}

std::vector<int> LccpSegmenter::groupSupervoxels(int num_supervoxels,
                                                 const std::vector<SupervoxelEdge>& edges,
                                                 int min_segment_size) {
  const int n = std::max(0, num_supervoxels);
  // Segments are the components of the convex edges (union-find, order-free).
  std::vector<int> parent(n);
  for (int i = 0; i < n; ++i) parent[i] = i;
  const auto find = [&parent](int i) {
    while (parent[i] != i) {
      parent[i] = parent[parent[i]];
      i = parent[i];
    }
    return i;
  };
  for (const SupervoxelEdge& edge : edges) {
    if (!edge.convex || edge.a < 0 || edge.b < 0 || edge.a >= n || edge.b >= n) continue;
    const int ra = find(edge.a);
    const int rb = find(edge.b);
    if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);  // root = lowest supervoxel
  }
  std::vector<int> segment(n);
  for (int i = 0; i < n; ++i) segment[i] = find(i);

  // LCCP's small-segment merge: a segment of at most min_segment_size supervoxels joins its
  // largest neighbouring segment (ties: the lower id); segments in ascending id, repeated until
  // nothing merges. A segment merged away in a pass takes no others in that pass.
  if (min_segment_size > 0) {
    for (bool merged = true; merged;) {
      merged = false;
      std::vector<int> size(n, 0);
      for (int i = 0; i < n; ++i) ++size[segment[i]];
      std::vector<std::set<int>> neighbours(n);
      for (const SupervoxelEdge& edge : edges) {
        if (edge.a < 0 || edge.b < 0 || edge.a >= n || edge.b >= n) continue;
        const int sa = segment[edge.a];
        const int sb = segment[edge.b];
        if (sa == sb) continue;
        neighbours[sa].insert(sb);
        neighbours[sb].insert(sa);
      }
      std::vector<int> merged_into(n, -1);
      for (int s = 0; s < n; ++s) {
        if (size[s] == 0 || size[s] > min_segment_size || neighbours[s].empty()) continue;
        int best = -1;
        for (const int t : neighbours[s]) {
          int target = t;
          while (merged_into[target] >= 0) target = merged_into[target];
          if (target == s || size[target] < size[s]) continue;  // never into a smaller one
          if (best < 0 || size[target] > size[best] ||
              (size[target] == size[best] && target < best)) {
            best = target;
          }
        }
        if (best < 0) continue;
        merged_into[s] = best;
        size[best] += size[s];
        size[s] = 0;
        merged = true;
      }
      if (!merged) break;
      for (int i = 0; i < n; ++i) {
        int target = segment[i];
        while (merged_into[target] >= 0) target = merged_into[target];
        segment[i] = target;
      }
    }
  }

  // Ids 1, 2, ... in the order of each segment's lowest supervoxel; 0 is LCCP's "no segment".
  std::vector<int> id(n, 0);
  int next = 1;
  std::vector<int> out(n);
  for (int i = 0; i < n; ++i) {
    if (id[segment[i]] == 0) id[segment[i]] = next++;
    out[i] = id[segment[i]];
  }
  return out;
}

namespace {

// Table 3's "-LCCP" ablation and clouds too small to split: one segment of all finite points.
std::vector<int> finiteIndices(const PointCloud& points) {
  std::vector<int> all;
  all.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].allFinite()) all.push_back(static_cast<int>(i));
  }
  return all;
}

// PCL's octree keys are 32-bit (and it asserts on overflow), the voxel grid's 21-bit: refuses
// absurd extents, of the voxels (in the log-depth space for a single view) and of the seeds (in
// metres: a view spanning 1 m to 1e20 m is small in log depth).
Status checkExtent(const PointCloud& points, const std::vector<std::size_t>& source_index,
                   bool log_transform, const LccpSegmenter::Config& config) {
  Eigen::Array3d lower = Eigen::Array3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Array3d upper = -lower;
  Eigen::Array3d lower_m = lower;
  Eigen::Array3d upper_m = upper;
  for (const std::size_t i : source_index) {
    const Eigen::Vector3f& p = points[i];
    const Eigen::Array3d q = log_transform
                                 ? Eigen::Array3d(p.x() / p.z(), p.y() / p.z(), std::log(p.z()))
                                 : p.cast<double>().array();
    lower = lower.min(q);
    upper = upper.max(q);
    lower_m = lower_m.min(p.cast<double>().array());
    upper_m = upper_m.max(p.cast<double>().array());
  }
  if ((upper - lower).maxCoeff() / config.voxel_resolution_m > kMaxVoxelsPerAxis) {
    return Status::Error("cloud extent " + std::to_string((upper - lower).maxCoeff()) +
                         " is too large for voxel_resolution_m " +
                         std::to_string(config.voxel_resolution_m));
  }
  if ((upper_m - lower_m).maxCoeff() / config.seed_resolution_m > kMaxVoxelsPerAxis) {
    return Status::Error("cloud extent " + std::to_string((upper_m - lower_m).maxCoeff()) +
                         " m is too large for seed_resolution_m " +
                         std::to_string(config.seed_resolution_m));
  }
  return Status::Ok();
}

// Each point takes its supervoxel's segment (points in no supervoxel are in none); the segments
// largest first, the largest by point count (ties: the lower segment id) the object (Eq. 2).
Status collectSegments(const PointCloud& points, const std::vector<int>& point_supervoxel,
                       const std::vector<int>& supervoxel_segment, int num_segments,
                       LccpSegmenter::Result* result) {
  std::vector<std::vector<int>> by_segment(num_segments + 1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const int supervoxel = point_supervoxel[i];
    if (supervoxel >= 0) by_segment[supervoxel_segment[supervoxel]].push_back(static_cast<int>(i));
  }
  int largest = 0;
  for (int id = 1; id <= num_segments; ++id) {
    if (by_segment[id].size() > by_segment[largest].size()) largest = id;
  }
  if (largest == 0) return Status::Error("LCCP assigned no point to a segment");
  result->largest_segment.reserve(by_segment[largest].size());
  for (const int i : by_segment[largest]) result->largest_segment.push_back(points[i]);
  result->segments.push_back(std::move(by_segment[largest]));
  for (int id = 1; id <= num_segments; ++id) {
    if (id != largest && !by_segment[id].empty())
      result->segments.push_back(std::move(by_segment[id]));
  }
  std::stable_sort(
      result->segments.begin() + 1, result->segments.end(),
      [](const std::vector<int>& a, const std::vector<int>& b) { return a.size() > b.size(); });
  return Status::Ok();
}

}  // namespace

Status LccpSegmenter::segment(const PointCloud& points, bool points_in_camera_frame,
                              Result* result) const {
  if (result == nullptr) return Status::Error("result must not be null");
  *result = Result();
  // Table 3's "-LCCP" ablation: the whole cloud is the object.
  if (!config_.enable) {
    result->largest_segment = points;
    result->segments.push_back(finiteIndices(points));
    return Status::Ok();
  }
  const Status valid = config_.isValid();
  if (!valid) return valid;

  // Only finite points are clustered; `source_index` lists them.
  std::vector<std::size_t> source_index;
  source_index.reserve(points.size());
  float min_z = std::numeric_limits<float>::infinity();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    source_index.push_back(i);
    min_z = std::min(min_z, points[i].z());
  }
  if (source_index.empty()) {
    return Status::Error("no finite points to segment (" + std::to_string(points.size()) +
                         " points in)");
  }
  if (static_cast<int>(source_index.size()) < config_.min_points) {
    // Too small to split into supervoxels: keep it whole.
    for (const std::size_t i : source_index) result->largest_segment.push_back(points[i]);
    result->segments.push_back(finiteIndices(points));
    return Status::Ok();
  }

  // Sec. 3.2: the paper's logarithmic depth transform (x/z, y/z, log z) keeps supervoxels fair
  // to the depth-dependent density of a single view; only defined in front of the camera.
  const bool log_transform = config_.log_depth_transform && points_in_camera_frame && min_z > 1e-3f;
  const Status extent = checkExtent(points, source_index, log_transform, config_);
  if (!extent) return extent;

  SupervoxelGraph graph;
  const Status clustered =
      config_.implementation == "pcl"
          ? pclSupervoxels(points, source_index, log_transform, config_, &graph)
          : gridSupervoxels(points, log_transform, &graph);
  if (!clustered) return clustered;
  const int num_supervoxels = static_cast<int>(graph.centroids.size());
  result->num_supervoxels = num_supervoxels;
  if (num_supervoxels == 0) {
    return Status::Error("supervoxel clustering found no supervoxels in " +
                         std::to_string(source_index.size()) + " points (too sparse?)");
  }
  // Eq. 2: merge supervoxels across convex (and, with the sanity criterion, not singular) edges;
  // concave edges separate an object from the floor and wall it stands against.
  const std::vector<int> supervoxel_segment =
      groupSupervoxels(num_supervoxels, graph.edges, config_.min_segment_size);
  const int num_segments =
      *std::max_element(supervoxel_segment.begin(), supervoxel_segment.end());  // ids 1..n
  result->num_segments = num_segments;
  return collectSegments(points, graph.point_supervoxel, supervoxel_segment, num_segments, result);
}

}  // namespace mvod
