// LccpSegmenter (Sec. 3.2, Eq. 2): a box cut out of the floor and wall that a bleeding 2D mask
// brought along, on a depth view ray-cast in the test.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>

#include "box_scene.h"
#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"

namespace mvod {
namespace {

// The mask's rectangle grows by this fraction of the box's image size on every side: floor and wall
// together then hold more points than the box, each of them alone fewer (Eq. 2 keeps the largest).
constexpr double kMaskMargin = 0.15;

using test::Surface;

// The LCCP scenes: a box yawed 30 degrees in front of a wall 0.5 m behind it.
test::BoxScene lccpScene() {
  test::BoxScene scene;
  scene.box_yaw_rad = 30.0 * M_PI / 180.0;
  return scene;
}

struct LabeledCloud {
  PointCloud points_C;
  std::vector<Surface> surfaces;
};

// The view a 2D detector's mask gives: every pixel in the box's image rectangle grown by
// `mask_margin` on each side (so floor and wall bleed in), Kinect-like depth noise, then the 0.01 m
// grid of the pipeline (per surface, so that every point keeps its true label).
LabeledCloud renderMaskedView(const test::BoxScene& scene, const Eigen::Isometry3d& T_W_C,
                              double mask_margin, double noise_scale) {
  const double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  const int width = 640, height = 480;
  const Eigen::Isometry3d T_C_W = T_W_C.inverse();
  double u_min = width, u_max = 0, v_min = height, v_max = 0;
  for (const Eigen::Vector3d& corner_W : scene.boxCorners()) {
    const Eigen::Vector3d c = T_C_W * corner_W;
    u_min = std::min(u_min, fx * c.x() / c.z() + cx);
    u_max = std::max(u_max, fx * c.x() / c.z() + cx);
    v_min = std::min(v_min, fy * c.y() / c.z() + cy);
    v_max = std::max(v_max, fy * c.y() / c.z() + cy);
  }
  const double du = mask_margin * (u_max - u_min), dv = mask_margin * (v_max - v_min);
  const int u0 = std::max(0, static_cast<int>(u_min - du));
  const int u1 = std::min(width - 1, static_cast<int>(u_max + du));
  const int v0 = std::max(0, static_cast<int>(v_min - dv));
  const int v1 = std::min(height - 1, static_cast<int>(v_max + dv));

  std::mt19937 rng(3);
  std::normal_distribution<double> unit_noise(0.0, 1.0);
  std::map<Surface, PointCloud> by_surface;
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      const Eigen::Vector3d ray_C((u - cx) / fx, (v - cy) / fy, 1.0);  // z = 1: t is the depth
      Surface surface;
      const double depth = scene.cast(T_W_C.translation(), T_W_C.linear() * ray_C, &surface);
      if (surface == Surface::kNone || !(depth > 0.3 && depth < 4.5)) continue;
      // Kinect v1 axial noise grows with depth squared (Khoshelham & Elberink 2012).
      const double sigma_m = noise_scale * (0.0012 + 0.0019 * (depth - 0.4) * (depth - 0.4));
      const double noisy_depth = depth + sigma_m * unit_noise(rng);
      by_surface[surface].push_back((noisy_depth * ray_C).cast<float>());
    }
  }
  LabeledCloud cloud;
  for (const auto& entry : by_surface) {
    const PointCloud voxels = PointCloudFilter::voxelize(entry.second, 0.01);
    cloud.points_C.insert(cloud.points_C.end(), voxels.begin(), voxels.end());
    cloud.surfaces.insert(cloud.surfaces.end(), voxels.size(), entry.first);
  }
  return cloud;
}

struct SegmentStats {
  int box_in_cloud = 0;
  int box_in_segment = 0;
  int background_in_segment = 0;
  double boxRecall() const { return box_in_cloud > 0 ? double(box_in_segment) / box_in_cloud : 0; }
  double contamination() const {
    const int n = box_in_segment + background_in_segment;
    return n > 0 ? double(background_in_segment) / n : 1.0;
  }
};

// Segment points are the caller's points, bit for bit, so their labels can be looked up exactly.
SegmentStats segmentStats(const LabeledCloud& cloud, const PointCloud& segment) {
  std::map<std::array<float, 3>, Surface> label_of;
  for (std::size_t i = 0; i < cloud.points_C.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points_C[i];
    label_of[{p.x(), p.y(), p.z()}] = cloud.surfaces[i];
  }
  SegmentStats stats;
  stats.box_in_cloud =
      static_cast<int>(std::count(cloud.surfaces.begin(), cloud.surfaces.end(), Surface::kBox));
  for (const Eigen::Vector3f& p : segment) {
    const auto it = label_of.find({p.x(), p.y(), p.z()});
    EXPECT_TRUE(it != label_of.end()) << "segment point not from the input";
    if (it == label_of.end()) continue;
    if (it->second == Surface::kBox) {
      ++stats.box_in_segment;
    } else {
      ++stats.background_in_segment;
    }
  }
  return stats;
}

// Both implementations ("voxel_grid", the default, and "pcl") must cut the same way.
LccpSegmenter::Config withImplementation(const std::string& implementation) {
  LccpSegmenter::Config config;
  config.implementation = implementation;
  return config;
}

class LccpSegmenterBoxScene : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    T_W_C_ = test::cameraLookingAlongY(Eigen::Vector3d(0.3, 0.0, 1.2), 25.0);
    cloud_ = renderMaskedView(scene_, T_W_C_, kMaskMargin, 1.0);
  }
  test::BoxScene scene_ = lccpScene();
  Eigen::Isometry3d T_W_C_;
  LabeledCloud cloud_;
};

}  // namespace

TEST_P(LccpSegmenterBoxScene, MaskedViewHoldsBoxFloorAndWall) {
  // The premise of the test: the mask brought plenty of background along.
  const auto count = [&](Surface s) {
    return std::count(cloud_.surfaces.begin(), cloud_.surfaces.end(), s);
  };
  EXPECT_GT(count(Surface::kBox), 1000);
  EXPECT_GT(count(Surface::kFloor), 0.3 * count(Surface::kBox));
  EXPECT_GT(count(Surface::kWall), 0.3 * count(Surface::kBox));
  // Passing the cloud through would fail the segment checks below.
  EXPECT_GT(count(Surface::kFloor) + count(Surface::kWall), count(Surface::kBox));
}

TEST_P(LccpSegmenterBoxScene, CutsBoxFromFloorAndWallWithLogDepth) {
  const LccpSegmenter segmenter(withImplementation(GetParam()));  // as for a single Kinect view
  LccpSegmenter::Result result;
  ASSERT_TRUE(segmenter.segment(cloud_.points_C, true, &result).ok());
  const SegmentStats stats = segmentStats(cloud_, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
  EXPECT_GT(result.num_supervoxels, 1);
  EXPECT_GE(result.num_segments, 2);
}

TEST_P(LccpSegmenterBoxScene, CutsBoxFromFloorAndWallInWorldFrame) {
  // The fused path: gravity-aligned world frame, no log-depth transform. Its origin is a camera
  // centre, as in ORB-SLAM2's map (normals are flipped towards the origin).
  Eigen::Isometry3d R_W_C = T_W_C_;
  R_W_C.translation().setZero();
  const PointCloud points_W = transformCloud(cloud_.points_C, R_W_C);
  LabeledCloud cloud_W{points_W, cloud_.surfaces};
  const LccpSegmenter segmenter(withImplementation(GetParam()));
  LccpSegmenter::Result result;
  ASSERT_TRUE(segmenter.segment(points_W, false, &result).ok());
  const SegmentStats stats = segmentStats(cloud_W, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
}

TEST_P(LccpSegmenterBoxScene, CutsBoxStandingAgainstWall) {
  // Box square to the camera with its back touching the wall: only concave edges separate them.
  scene_.box_yaw_rad = 0.0;
  scene_.wall_y_m = scene_.box_center.y() + scene_.box_half_size.y();
  const LabeledCloud cloud = renderMaskedView(scene_, T_W_C_, kMaskMargin, 1.0);
  LccpSegmenter::Result result;
  ASSERT_TRUE(
      LccpSegmenter(withImplementation(GetParam())).segment(cloud.points_C, true, &result).ok());
  const SegmentStats stats = segmentStats(cloud, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
}

TEST_P(LccpSegmenterBoxScene, LogTransformFlagChangesSupervoxels) {
  // With the flag on and off the camera-frame cloud is clustered differently (the transform runs).
  LccpSegmenter::Config config = withImplementation(GetParam());
  config.log_depth_transform = true;
  LccpSegmenter::Result with_log;
  ASSERT_TRUE(LccpSegmenter(config).segment(cloud_.points_C, true, &with_log).ok());
  config.log_depth_transform = false;
  LccpSegmenter::Result without_log;
  ASSERT_TRUE(LccpSegmenter(config).segment(cloud_.points_C, true, &without_log).ok());
  EXPECT_FALSE(with_log.largest_segment.empty());
  EXPECT_FALSE(without_log.largest_segment.empty());
  EXPECT_NE(with_log.num_supervoxels, without_log.num_supervoxels);
  // Points behind the camera make the transform undefined: it is skipped, not a crash.
  PointCloud behind = cloud_.points_C;
  behind.emplace_back(0.0f, 0.0f, -1.0f);
  LccpSegmenter::Result result;
  EXPECT_TRUE(LccpSegmenter(withImplementation(GetParam())).segment(behind, true, &result).ok());
  EXPECT_FALSE(result.largest_segment.empty());
}

TEST(LccpSegmenterPassThrough, DisabledKeepsWholeCloud) {
  LccpSegmenter::Config config;
  config.enable = false;
  const test::BoxScene scene = lccpScene();
  const LabeledCloud cloud = renderMaskedView(
      scene, test::cameraLookingAlongY(Eigen::Vector3d(0.3, 0.0, 1.2), 25.0), kMaskMargin, 1.0);
  LccpSegmenter::Result result;
  ASSERT_TRUE(LccpSegmenter(config).segment(cloud.points_C, true, &result).ok());
  ASSERT_EQ(result.largest_segment.size(), cloud.points_C.size());
  for (std::size_t i = 0; i < cloud.points_C.size(); ++i) {
    EXPECT_EQ(result.largest_segment[i], cloud.points_C[i]);
  }
}

TEST(LccpSegmenterPassThrough, TinyCloudKeptWhole) {
  PointCloud points;
  for (int i = 0; i < 10; ++i) points.emplace_back(0.01f * i, 0.0f, 1.0f);
  LccpSegmenter::Result result;
  ASSERT_TRUE(LccpSegmenter().segment(points, true, &result).ok());
  EXPECT_EQ(result.largest_segment, points);
  EXPECT_EQ(result.num_supervoxels, 0);
}

INSTANTIATE_TEST_SUITE_P(Implementations, LccpSegmenterBoxScene,
                         ::testing::Values("voxel_grid", "pcl"));

class LccpSegmenterBadInput : public ::testing::TestWithParam<std::string> {};

TEST_P(LccpSegmenterBadInput, EmptyAndNonFinite) {
  const LccpSegmenter segmenter(withImplementation(GetParam()));
  LccpSegmenter::Result result;
  EXPECT_FALSE(segmenter.segment(PointCloud(), true, &result).ok());
  EXPECT_TRUE(result.largest_segment.empty());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(
      segmenter.segment(PointCloud(50, Eigen::Vector3f(nan, nan, nan)), true, &result).ok());
  EXPECT_FALSE(segmenter.segment(PointCloud(5, Eigen::Vector3f::Ones()), true, nullptr).ok());
  // Extents PCL's 32-bit octree keys cannot hold are an error, not an assertion.
  PointCloud huge;
  for (int i = 0; i < 100; ++i) huge.emplace_back(1e8f * (i % 2), 0.01f * i, 1.0f);
  EXPECT_FALSE(segmenter.segment(huge, false, &result).ok());
  // Small in log depth (1 m to 1e20 m) but not in metres: refused too, not an overflow.
  PointCloud deep;
  for (int i = 0; i < 100; ++i) deep.emplace_back(0.01f * i, 0.0f, i % 2 ? 1.0f : 1e20f);
  EXPECT_FALSE(segmenter.segment(deep, true, &result).ok());
  // Identical points are one supervoxel, kept whole.
  ASSERT_TRUE(
      segmenter.segment(PointCloud(100, Eigen::Vector3f(0.1f, 0.2f, 1.0f)), true, &result).ok());
  EXPECT_EQ(result.largest_segment.size(), 100u);
  // NaNs among good points are dropped, never returned.
  PointCloud mixed;
  for (int i = 0; i < 10; ++i) mixed.emplace_back(0.01f * i, 0.0f, 1.0f);
  mixed.emplace_back(nan, 0.0f, 1.0f);
  ASSERT_TRUE(segmenter.segment(mixed, true, &result).ok());
  EXPECT_EQ(result.largest_segment.size(), 10u);
}

INSTANTIATE_TEST_SUITE_P(Implementations, LccpSegmenterBadInput,
                         ::testing::Values("voxel_grid", "pcl"));

TEST(LccpSegmenterConfig, Validation) {
  LccpSegmenter::Config config;
  EXPECT_TRUE(config.isValid().ok());
  EXPECT_NE(config.print().find("concavity_tolerance_deg: "), std::string::npos);
  LccpSegmenter::Config bad = config;
  bad.voxel_resolution_m = 0.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.seed_resolution_m = 0.5 * config.voxel_resolution_m;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.concavity_tolerance_deg = -1.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.min_segment_size = -1;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.num_threads = 0;
  EXPECT_FALSE(bad.isValid().ok());
  bad.num_threads = 257;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.normal_importance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.implementation = "octree";
  EXPECT_FALSE(bad.isValid().ok());
  // PCL's extended convexity (k-convexity) exists only in PCL's implementation.
  bad = config;
  bad.use_extended_convexity = true;
  EXPECT_FALSE(bad.isValid().ok());
  bad.implementation = "pcl";
  EXPECT_TRUE(bad.isValid().ok());
  // An invalid config is reported by segment(), not acted on.
  LccpSegmenter::Result result;
  bad = config;
  bad.voxel_resolution_m = -1.0;
  PointCloud points(100, Eigen::Vector3f(0.0f, 0.0f, 1.0f));
  EXPECT_FALSE(LccpSegmenter(bad).segment(points, true, &result).ok());
}

}  // namespace mvod

namespace mvod {
namespace {

using Edge = LccpSegmenter::SupervoxelEdge;

Edge edge(int a, int b, bool convex) {
  Edge e;
  e.a = a;
  e.b = b;
  e.convex = convex;
  return e;
}

}  // namespace

TEST(LccpGrouping, SegmentsAreTheComponentsOfConvexEdges) {
  // 0-1-2 convex, 2-3 concave, 3-4 convex, 5 alone.
  const std::vector<Edge> edges = {edge(0, 1, true), edge(1, 2, true), edge(2, 3, false),
                                   edge(3, 4, true)};
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(6, edges, 0), (std::vector<int>{1, 1, 1, 2, 2, 3}));
}

TEST(LccpGrouping, SmallSegmentJoinsItsLargestNeighbour) {
  // Supervoxel 5 touches {3, 4} (2 supervoxels) and {0, 1, 2} (3) by concave edges only: with
  // min_segment_size 1 it joins the larger. Supervoxel 6 touches nothing and stays alone.
  const std::vector<Edge> edges = {edge(0, 1, true), edge(1, 2, true),  edge(2, 3, false),
                                   edge(3, 4, true), edge(5, 3, false), edge(5, 0, false)};
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(7, edges, 1), (std::vector<int>{1, 1, 1, 2, 2, 1, 3}));
  // Without the merge it stays its own segment.
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(7, edges, 0), (std::vector<int>{1, 1, 1, 2, 2, 3, 4}));
}

TEST(LccpGrouping, TiesGoToTheLowerSegmentAndNeverIntoASmallerOne) {
  // Supervoxel 2 alone between two segments of two: it joins the one of the lower supervoxels.
  const std::vector<Edge> tie = {edge(0, 1, true), edge(3, 4, true), edge(2, 4, false),
                                 edge(2, 0, false)};
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(5, tie, 1), (std::vector<int>{1, 1, 1, 2, 2}));
  // min_segment_size 2: {0, 1} is small but its only neighbour {2} is smaller; {2} joins {0, 1}.
  const std::vector<Edge> smaller = {edge(0, 1, true), edge(1, 2, false)};
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(3, smaller, 2), (std::vector<int>{1, 1, 1}));
  // Bad indices are ignored.
  EXPECT_EQ(LccpSegmenter::groupSupervoxels(2, {edge(0, 7, true), edge(-1, 1, true)}, 1),
            (std::vector<int>{1, 2}));
}

TEST(LccpGrouping, EdgeOrderAndDirectionDoNotMatter) {
  // PCL's own grouping follows its graph's vertex order (heap addresses); this one must give the
  // same segments for any order of the same edges.
  std::mt19937 rng(11);
  const int n = 300;
  std::vector<Edge> edges;
  std::uniform_int_distribution<int> node(0, n - 1);
  std::bernoulli_distribution convex(0.35);
  for (int i = 0; i < 2 * n; ++i) {
    const int a = node(rng), b = node(rng);
    if (a != b) edges.push_back(edge(a, b, convex(rng)));
  }
  for (const int min_size : {0, 1, 3}) {
    const std::vector<int> reference = LccpSegmenter::groupSupervoxels(n, edges, min_size);
    ASSERT_EQ(reference.size(), static_cast<size_t>(n));
    EXPECT_GT(*std::max_element(reference.begin(), reference.end()), 5);
    for (int trial = 0; trial < 10; ++trial) {
      std::vector<Edge> shuffled = edges;
      std::shuffle(shuffled.begin(), shuffled.end(), rng);
      for (Edge& e : shuffled) {
        if (rng() % 2) std::swap(e.a, e.b);
      }
      EXPECT_EQ(LccpSegmenter::groupSupervoxels(n, shuffled, min_size), reference)
          << "min_segment_size " << min_size << ", trial " << trial;
    }
  }
}

}  // namespace mvod

namespace mvod {
namespace {

// Share of the points of `a` that are also in `b` and vice versa (indices into the same cloud).
double overlap(const std::vector<int>& a, const std::vector<int>& b) {
  std::vector<int> sa = a, sb = b, both;
  std::sort(sa.begin(), sa.end());
  std::sort(sb.begin(), sb.end());
  std::set_intersection(sa.begin(), sa.end(), sb.begin(), sb.end(), std::back_inserter(both));
  const std::size_t larger = std::max(sa.size(), sb.size());
  return larger > 0 ? static_cast<double>(both.size()) / larger : 1.0;
}

}  // namespace

// The voxel grid reimplements PCL's supervoxels (same voxels, seeds, expansion and convexity
// test), so both give the same segments up to float rounding: on these scenes, bit for bit.
TEST(LccpGridSupervoxels, SameSegmentsAsPcl) {
  const Eigen::Isometry3d T_W_C = test::cameraLookingAlongY(Eigen::Vector3d(0.3, 0.0, 1.2), 25.0);
  for (const double yaw_deg : {0.0, 30.0, 60.0}) {
    test::BoxScene scene = lccpScene();
    scene.box_yaw_rad = yaw_deg * M_PI / 180.0;
    const LabeledCloud cloud = renderMaskedView(scene, T_W_C, kMaskMargin, 1.0);
    Eigen::Isometry3d R_W_C = T_W_C;
    R_W_C.translation().setZero();
    // Seeds of 0.1 m also exercise PCL's seed bar (voxels near a seed), inactive at 0.05 m.
    for (const double seed_m : {0.05, 0.1}) {
      for (const bool camera_frame : {true, false}) {
        SCOPED_TRACE("yaw " + std::to_string(yaw_deg) + " seed " + std::to_string(seed_m) +
                     (camera_frame ? " camera" : " world"));
        const PointCloud points =
            camera_frame ? cloud.points_C : transformCloud(cloud.points_C, R_W_C);
        LccpSegmenter::Config grid_config = withImplementation("voxel_grid");
        grid_config.seed_resolution_m = seed_m;
        LccpSegmenter::Config pcl_config = grid_config;
        pcl_config.implementation = "pcl";
        LccpSegmenter::Result grid, pcl;
        ASSERT_TRUE(LccpSegmenter(grid_config).segment(points, camera_frame, &grid).ok());
        ASSERT_TRUE(LccpSegmenter(pcl_config).segment(points, camera_frame, &pcl).ok());
        EXPECT_GT(grid.num_supervoxels, 10);
        EXPECT_NEAR(grid.num_supervoxels, pcl.num_supervoxels, 0.02 * pcl.num_supervoxels);
        EXPECT_NEAR(grid.num_segments, pcl.num_segments, 1);
        ASSERT_FALSE(grid.segments.empty());
        ASSERT_FALSE(pcl.segments.empty());
        EXPECT_GE(overlap(grid.segments[0], pcl.segments[0]), 0.99);
      }
    }
  }
}

TEST(LccpGridSupervoxels, GraphIsWellFormedAndDeterministic) {
  const test::BoxScene scene = lccpScene();
  LabeledCloud cloud = renderMaskedView(
      scene, test::cameraLookingAlongY(Eigen::Vector3d(0.3, 0.0, 1.2), 25.0), kMaskMargin, 1.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.points_C.insert(cloud.points_C.begin() + 7, Eigen::Vector3f(nan, 0.0f, 1.0f));
  const LccpSegmenter segmenter;
  LccpSegmenter::SupervoxelGraph graph;
  ASSERT_TRUE(segmenter.gridSupervoxels(cloud.points_C, true, &graph).ok());
  const int n = static_cast<int>(graph.centroids.size());
  ASSERT_GT(n, 50);
  ASSERT_EQ(graph.normals.size(), graph.centroids.size());
  ASSERT_EQ(graph.point_supervoxel.size(), cloud.points_C.size());
  EXPECT_EQ(graph.point_supervoxel[7], -1);  // the NaN
  std::vector<int> points_in(n, 0);
  int labelled = 0;
  for (const int s : graph.point_supervoxel) {
    ASSERT_GE(s, -1);
    ASSERT_LT(s, n);
    if (s >= 0) {
      ++points_in[s];
      ++labelled;
    }
  }
  EXPECT_GE(labelled, 0.95 * (cloud.points_C.size() - 1));
  EXPECT_EQ(std::count(points_in.begin(), points_in.end(), 0), 0) << "empty supervoxel";
  for (int s = 0; s < n; ++s) {
    EXPECT_NEAR(graph.normals[s].norm(), 1.0f, 1e-4f);
    EXPECT_LE(graph.centroids[s].dot(graph.normals[s]), 0.0f) << "normal not towards the camera";
  }
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    const LccpSegmenter::SupervoxelEdge& e = graph.edges[k];
    ASSERT_TRUE(e.a >= 0 && e.a < e.b && e.b < n);
    if (k > 0) {
      const LccpSegmenter::SupervoxelEdge& p = graph.edges[k - 1];
      EXPECT_TRUE(std::make_pair(p.a, p.b) < std::make_pair(e.a, e.b)) << "edges not ascending";
    }
  }
  LccpSegmenter::SupervoxelGraph again;
  ASSERT_TRUE(segmenter.gridSupervoxels(cloud.points_C, true, &again).ok());
  EXPECT_EQ(again.point_supervoxel, graph.point_supervoxel);
  ASSERT_EQ(again.edges.size(), graph.edges.size());
  for (std::size_t k = 0; k < graph.edges.size(); ++k) {
    EXPECT_EQ(again.edges[k].convex, graph.edges[k].convex);
  }
  // The voxel normals split over threads: the same graph, bit for bit. The threads take at least
  // 2048 voxels each, so this needs a larger cloud than the scene's view: a wavy 3 m x 3 m surface
  // 2 m in front of the camera, 1 cm apart (~10^4 voxels of the log-depth grid).
  PointCloud wavy;
  for (int i = 0; i < 300; ++i) {
    for (int j = 0; j < 300; ++j) {
      const float x = -1.5f + 0.01f * i;
      const float y = -1.5f + 0.01f * j;
      wavy.emplace_back(x, y, 2.0f + 0.2f * std::sin(3.0f * x) * std::cos(2.0f * y));
    }
  }
  LccpSegmenter::SupervoxelGraph one_thread;
  ASSERT_TRUE(segmenter.gridSupervoxels(wavy, true, &one_thread).ok());
  ASSERT_GT(one_thread.centroids.size(), 50u);
  for (const int threads : {2, 3}) {
    LccpSegmenter::Config config;
    config.num_threads = threads;
    LccpSegmenter::SupervoxelGraph threaded;
    ASSERT_TRUE(LccpSegmenter(config).gridSupervoxels(wavy, true, &threaded).ok());
    EXPECT_EQ(threaded.point_supervoxel, one_thread.point_supervoxel) << threads << " threads";
    EXPECT_EQ(threaded.normals, one_thread.normals) << threads << " threads";
    EXPECT_EQ(threaded.centroids, one_thread.centroids) << threads << " threads";
    ASSERT_EQ(threaded.edges.size(), one_thread.edges.size());
    for (std::size_t k = 0; k < one_thread.edges.size(); ++k) {
      EXPECT_EQ(threaded.edges[k].convex, one_thread.edges[k].convex);
    }
  }
  // Nothing usable: an error, not an empty success.
  EXPECT_FALSE(
      segmenter.gridSupervoxels(PointCloud(3, Eigen::Vector3f(nan, nan, nan)), true, &graph).ok());
  EXPECT_FALSE(segmenter.gridSupervoxels(cloud.points_C, true, nullptr).ok());
}

// LCCP's edge test on two patches 5 cm apart: z up, normals towards the viewer.
TEST(LccpConvexity, ConvexRidgeJoinsAndConcaveCornerSeparates) {
  const LccpSegmenter::Config config;
  // A box's top and its front face meet at a ridge: convex.
  EXPECT_TRUE(LccpSegmenter::convexConnection({0.0f, 0.0f, 0.5f}, {0.0f, 0.0f, 1.0f},
                                              {0.0f, 0.05f, 0.45f}, {0.0f, 1.0f, 0.0f}, config));
  // The floor and a wall behind it meet in a corner: concave.
  EXPECT_FALSE(LccpSegmenter::convexConnection({0.0f, 0.05f, 0.0f}, {0.0f, 0.0f, 1.0f},
                                               {0.0f, 0.0f, 0.05f}, {0.0f, 1.0f, 0.0f}, config));
  // The direction of the test does not matter.
  EXPECT_FALSE(LccpSegmenter::convexConnection({0.0f, 0.0f, 0.05f}, {0.0f, 1.0f, 0.0f},
                                               {0.0f, 0.05f, 0.0f}, {0.0f, 0.0f, 1.0f}, config));
}

TEST(LccpConvexity, ShallowConcavityWithinToleranceJoins) {
  LccpSegmenter::Config config;
  // Two patches of a slightly concave surface (normals 6 degrees apart, bending up).
  const float a = static_cast<float>(3.0 * M_PI / 180.0);
  const Eigen::Vector3f n_s(-std::sin(a), 0.0f, std::cos(a));
  const Eigen::Vector3f n_t(std::sin(a), 0.0f, std::cos(a));
  const Eigen::Vector3f c_s(0.05f, 0.0f, 0.05f * std::tan(a));
  const Eigen::Vector3f c_t(-0.05f, 0.0f, 0.05f * std::tan(a));
  config.concavity_tolerance_deg = 10.0;
  EXPECT_TRUE(LccpSegmenter::convexConnection(c_s, n_s, c_t, n_t, config));
  config.concavity_tolerance_deg = 5.0;
  EXPECT_FALSE(LccpSegmenter::convexConnection(c_s, n_s, c_t, n_t, config));
}

TEST(LccpConvexity, StepBetweenParallelPatchesSeparates) {
  LccpSegmenter::Config config;
  const Eigen::Vector3f up(0.0f, 0.0f, 1.0f);
  // Same plane: joined. A 4 cm step (a book on a table): not, though the normals agree.
  EXPECT_TRUE(
      LccpSegmenter::convexConnection({0.05f, 0.0f, 0.0f}, up, {0.0f, 0.0f, 0.0f}, up, config));
  EXPECT_FALSE(
      LccpSegmenter::convexConnection({0.05f, 0.0f, 0.04f}, up, {0.0f, 0.0f, 0.0f}, up, config));
  // The slack is smoothness_threshold voxels: a 1 mm step passes.
  EXPECT_TRUE(
      LccpSegmenter::convexConnection({0.05f, 0.0f, 0.001f}, up, {0.0f, 0.0f, 0.0f}, up, config));
}

TEST(LccpConvexity, SanityCriterionRejectsConnectionsAlongTheBendAxis) {
  LccpSegmenter::Config config;
  // Normals 60 degrees apart bending about x; the centroids lie along x, on the bend axis:
  // convexity is undefined there.
  const float a = static_cast<float>(30.0 * M_PI / 180.0);
  const Eigen::Vector3f n_s(0.0f, -std::sin(a), std::cos(a));
  const Eigen::Vector3f n_t(0.0f, std::sin(a), std::cos(a));
  const Eigen::Vector3f c_s(0.05f, 0.0f, 0.0f), c_t(0.0f, 0.0f, 0.0f);
  config.use_sanity_criterion = true;
  config.smoothness_threshold = 10.0;  // isolate the sanity criterion
  EXPECT_FALSE(LccpSegmenter::convexConnection(c_s, n_s, c_t, n_t, config));
  config.use_sanity_criterion = false;
  EXPECT_TRUE(LccpSegmenter::convexConnection(c_s, n_s, c_t, n_t, config));
}

}  // namespace mvod
