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
#include "multiview_object_detection/pipeline/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/point_cloud_filter.h"

namespace mvod {
namespace {

constexpr double kPi = 3.14159265358979323846;
// The mask's rectangle grows by this fraction of the box's image size on every side: floor and wall
// together then hold more points than the box, each of them alone fewer (Eq. 2 keeps the largest).
constexpr double kMaskMargin = 0.15;

using test::Surface;

// The LCCP scenes: a box yawed 30 degrees in front of a wall 0.5 m behind it.
test::BoxScene lccpScene() {
  test::BoxScene scene;
  scene.box_yaw_rad = 30.0 * kPi / 180.0;
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

class LccpSegmenterBoxScene : public ::testing::Test {
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

TEST_F(LccpSegmenterBoxScene, MaskedViewHoldsBoxFloorAndWall) {
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

TEST_F(LccpSegmenterBoxScene, CutsBoxFromFloorAndWallWithLogDepth) {
  const LccpSegmenter segmenter;  // defaults, as for a single Kinect view
  LccpSegmenter::Result result;
  ASSERT_TRUE(segmenter.segment(cloud_.points_C, true, &result).ok());
  const SegmentStats stats = segmentStats(cloud_, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
  EXPECT_GT(result.num_supervoxels, 1);
  EXPECT_GE(result.num_segments, 2);
}

TEST_F(LccpSegmenterBoxScene, CutsBoxFromFloorAndWallInWorldFrame) {
  // The fused path: gravity-aligned world frame, no log-depth transform. Its origin is a camera
  // centre, as in ORB-SLAM2's map (normals are flipped towards the origin).
  Eigen::Isometry3d R_W_C = T_W_C_;
  R_W_C.translation().setZero();
  const PointCloud points_W = transformCloud(cloud_.points_C, R_W_C);
  LabeledCloud cloud_W{points_W, cloud_.surfaces};
  const LccpSegmenter segmenter;
  LccpSegmenter::Result result;
  ASSERT_TRUE(segmenter.segment(points_W, false, &result).ok());
  const SegmentStats stats = segmentStats(cloud_W, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
}

TEST_F(LccpSegmenterBoxScene, CutsBoxStandingAgainstWall) {
  // Box square to the camera with its back touching the wall: only concave edges separate them.
  scene_.box_yaw_rad = 0.0;
  scene_.wall_y_m = scene_.box_center.y() + scene_.box_half_size.y();
  const LabeledCloud cloud = renderMaskedView(scene_, T_W_C_, kMaskMargin, 1.0);
  LccpSegmenter::Result result;
  ASSERT_TRUE(LccpSegmenter().segment(cloud.points_C, true, &result).ok());
  const SegmentStats stats = segmentStats(cloud, result.largest_segment);
  EXPECT_GE(stats.boxRecall(), 0.8) << "contamination " << stats.contamination();
  EXPECT_LE(stats.contamination(), 0.1) << "box recall " << stats.boxRecall();
}

TEST_F(LccpSegmenterBoxScene, LogTransformFlagChangesSupervoxels) {
  // With the flag on and off the camera-frame cloud is clustered differently (the transform runs).
  LccpSegmenter::Config config;
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
  EXPECT_TRUE(LccpSegmenter().segment(behind, true, &result).ok());
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

TEST(LccpSegmenterBadInput, EmptyAndNonFinite) {
  const LccpSegmenter segmenter;
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
  bad.normal_importance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bad.isValid().ok());
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
