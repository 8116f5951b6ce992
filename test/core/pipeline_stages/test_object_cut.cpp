// The single-view cut on imperfect detections (bled masks, box-only detections) and evidence fusion
// over views, against the paper's method on the same frames: ray-cast box-on-floor scenes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "box_scene.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "part_scene.h"

namespace mvod {
namespace {

// Mask R-CNN-like bleeding: the mask grown by `pixels` into the background.
Detection2D bledDetection(const cv::Mat& mask, int pixels) {
  cv::Mat bled;
  cv::dilate(
      mask, bled,
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * pixels + 1, 2 * pixels + 1)));
  return test::detectionFromMask(bled, "chair", 0.9f);
}

// A box-only detection of the object's mask (its bounding box), or of the given box.
Detection2D boxOnlyDetection(const cv::Mat& mask, cv::Rect box = cv::Rect()) {
  return test::boxOnlyDetection("chair", box.empty() ? cv::boundingRect(mask) : box, mask.size());
}

struct BoxError {
  double centre_m = 0.0;
  double size_m = 0.0;  // largest per-axis size error (horizontal axes in either order)
  double yaw_deg = 0.0;
};

BoxError boxError(const OrientedBox& box, const test::BoxScene& scene) {
  BoxError error;
  error.centre_m = (box.center_m - scene.box_center).norm();
  const Eigen::Vector3d truth = 2.0 * scene.box_half_size;
  const double a = std::max(box.size_m.x(), box.size_m.y());
  const double b = std::min(box.size_m.x(), box.size_m.y());
  error.size_m = std::max({std::abs(a - std::max(truth.x(), truth.y())),
                           std::abs(b - std::min(truth.x(), truth.y())),
                           std::abs(box.size_m.z() - truth.z())});
  // Yaw modulo 90 degrees (a box's horizontal axes are interchangeable).
  const double yaw = std::atan2(box.rotation(1, 0), box.rotation(0, 0));
  double d = std::fmod(std::abs(yaw - scene.box_yaw_rad), kPi / 2.0);
  error.yaw_deg = std::min(d, kPi / 2.0 - d) * 180.0 / kPi;
  return error;
}

class ObjectCutTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClassPrior chair;
    chair.class_name = "chair";
    chair.has_size = true;
    chair.size_m = Eigen::Vector3d(0.55, 0.55, 0.9);
    chair.fusion_distance_m = 0.4;
    priors_.set(chair);
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    // The world origin on the floor under the object, not at a camera: PCL-style normal
    // orientation towards the origin would make the object's faces look concave.
    scene_.box_center = Eigen::Vector3d(0.0, 0.0, 0.25);
    scene_.box_yaw_rad = 20.0 * kPi / 180.0;
    scene_.wall_y_m = 0.8;
  }

  // Cameras on an arc in front of the object (the wall is behind it), 1.3 m high, 2.2 m away.
  Eigen::Isometry3d arcPose(double angle_deg) const {
    const double a = (angle_deg - 90.0) * kPi / 180.0;
    const Eigen::Vector3d position(2.2 * std::cos(a), 2.2 * std::sin(a), 1.3);
    return test::lookAt(position, scene_.box_center);
  }

  // One keyframe through the mapper; the object's box (fails the test when there is none).
  OrientedBox runSingleView(const ObjectMapper::Config& config, const Detection2D& detection,
                            const RgbdFrame& frame) {
    ObjectMapper mapper(config, priors_);
    KeyframeReport report;
    EXPECT_TRUE(mapper.processKeyframe(frame, {detection}, &report).ok());
    EXPECT_EQ(mapper.database().size(), 1u);
    if (mapper.database().size() != 1u) return OrientedBox();
    return mapper.database().objects().begin()->second.box;
  }

  ClassPriors priors_;
  ObjectMapper::Config config_;
  test::BoxScene scene_;
};

TEST_F(ObjectCutTest, BoxOnlyDetectionGivesTheObjectNotTheFloorAndWall) {
  cv::Mat mask;
  const RgbdFrame frame = test::renderFrame(scene_, arcPose(0.0), 0, &mask);
  const Detection2D detection = boxOnlyDetection(mask);

  const BoxError ours = boxError(runSingleView(config_, detection, frame), scene_);
  ObjectMapper::Config paper = config_;
  paper.usePaperMethod();
  const BoxError theirs = boxError(runSingleView(paper, detection, frame), scene_);
  RecordProperty("paper_centre_error_mm", static_cast<int>(1000 * theirs.centre_m));
  RecordProperty("paper_size_error_mm", static_cast<int>(1000 * theirs.size_m));
  RecordProperty("centre_error_mm", static_cast<int>(1000 * ours.centre_m));
  RecordProperty("size_error_mm", static_cast<int>(1000 * ours.size_m));
  // Single views see three faces: within 10 cm (the single-view goal).
  EXPECT_LT(ours.centre_m, 0.10) << "paper: " << theirs.centre_m;
  EXPECT_LT(ours.size_m, 0.10) << "paper: " << theirs.size_m;
  // The scene is a real test of the cut: the paper's largest segment does worse here. (How much
  // worse varies: PCL's supervoxels follow heap-address order, so another allocator, e.g. ASan's,
  // gives other segments: 0.28 m here, 0.11 m under ASan; ours 0.01 m.)
  EXPECT_GT(std::max(theirs.centre_m, theirs.size_m), std::max(ours.centre_m, ours.size_m) + 0.03)
      << "ours " << ours.centre_m << " / " << ours.size_m;
}

TEST_F(ObjectCutTest, BledMaskStaysWithinTenCentimetres) {
  for (const int bleed_px : {4, 8, 12}) {
    cv::Mat mask;
    const RgbdFrame frame = test::renderFrame(scene_, arcPose(-30.0), 0, &mask);
    const BoxError ours =
        boxError(runSingleView(config_, bledDetection(mask, bleed_px), frame), scene_);
    EXPECT_LT(ours.centre_m, 0.10) << bleed_px << " px";
    EXPECT_LT(ours.size_m, 0.10) << bleed_px << " px";
  }
}

TEST_F(ObjectCutTest, EvidenceFusionOverALoopOfBledViews) {
  ObjectMapper mapper(config_, priors_);
  ObjectMapper::Config paper_config = config_;
  paper_config.usePaperMethod();
  ObjectMapper paper(paper_config, priors_);
  int index = 0;
  for (double angle = -60.0; angle <= 60.0; angle += 15.0, ++index) {
    cv::Mat mask;
    const RgbdFrame frame = test::renderFrame(scene_, arcPose(angle), index, &mask);
    const Detection2D detection = bledDetection(mask, 4 + 2 * (index % 5));  // 4 .. 12 px
    ASSERT_TRUE(mapper.processKeyframe(frame, {detection}, nullptr).ok());
    ASSERT_TRUE(paper.processKeyframe(frame, {detection}, nullptr).ok());
  }
  ASSERT_EQ(mapper.database().size(), 1u);
  const MapObject& object = mapper.database().objects().begin()->second;
  EXPECT_EQ(object.observations, index);
  const BoxError ours = boxError(object.box, scene_);
  EXPECT_LT(ours.centre_m, 0.05);
  EXPECT_LT(ours.size_m, 0.10);
  EXPECT_LT(ours.yaw_deg, 5.0);
  // The evidence voted some bled background out.
  int voted_out = 0;
  for (const auto& entry : object.evidence) voted_out += entry.second.outside > entry.second.inside;
  EXPECT_GT(voted_out, 0);
  if (!paper.database().objects().empty()) {
    const BoxError theirs = boxError(paper.database().objects().begin()->second.box, scene_);
    std::printf("[ evidence ] centre %.3f size %.3f yaw %.1f | paper centre %.3f size %.3f\n",
                ours.centre_m, ours.size_m, ours.yaw_deg, theirs.centre_m, theirs.size_m);
  }
}

TEST_F(ObjectCutTest, SelectionMasksGivenOrComputedGiveTheSameCut) {
  // The selection's masks computed beforehand (as the mapper does beside the filter and LCCP for
  // a large detection) select the same points as select() computing them itself, for a mask and a
  // box-only detection; the core lies in the mask and the ring outside it; a box outside or over
  // the whole image is refused there.
  cv::Mat mask;
  const RgbdFrame frame = test::renderFrame(scene_, arcPose(20.0), 0, &mask);
  const SegmentSelector selector(config_.selection);
  const PointCloudFilter filter(config_.filter);
  const LccpSegmenter lccp(config_.lccp);
  for (const Detection2D& detection : {bledDetection(mask, 6), boxOnlyDetection(mask)}) {
    std::vector<PointCloud> clouds;
    ASSERT_TRUE(ObjectCloudExtractor(config_.extractor).extract(frame, {detection}, &clouds).ok());
    const PointCloud filtered = filter.filterCameraFrame(clouds[0]);
    LccpSegmenter::Result segmentation;
    ASSERT_TRUE(lccp.segment(filtered, true, &segmentation).ok());
    ASSERT_GT(segmentation.segments.size(), 1u);
    SegmentSelector::Input input;
    input.points_D = &filtered;
    input.segments = &segmentation.segments;
    input.detection = &detection;
    input.frame = &frame;
    input.prior = priors_.find("chair");
    input.gravity = GravityFrame(config_.gravity_down_W);
    SegmentSelector::Result computed;
    ASSERT_TRUE(selector.select(input, &computed).ok());
    const SegmentSelector::DetectionMasks masks =
        selector.detectionMasks(detection, frame.color_bgr.size());
    ASSERT_TRUE(masks.status.ok());
    EXPECT_EQ(cv::countNonZero(masks.core & ~masks.mask), 0);
    EXPECT_EQ(cv::countNonZero(masks.ring & masks.mask), 0);
    EXPECT_GT(cv::countNonZero(masks.core), 0);
    EXPECT_GT(cv::countNonZero(masks.ring), 0);
    input.masks = &masks;
    SegmentSelector::Result given;
    ASSERT_TRUE(selector.select(input, &given).ok());
    EXPECT_EQ(given.indices, computed.indices);
    EXPECT_EQ(given.kept_segments, computed.kept_segments);
    EXPECT_EQ(given.bounding_segments, computed.bounding_segments);
    EXPECT_LT(computed.indices.size(), filtered.size());  // something was cut away
  }
  Detection2D outside = boxOnlyDetection(mask);
  outside.box_px = cv::Rect(-50, -50, 20, 20);
  EXPECT_FALSE(selector.detectionMasks(outside, frame.color_bgr.size()).status.ok());
  Detection2D everything = boxOnlyDetection(mask, cv::Rect(0, 0, 640, 480));
  const Status whole = selector.detectionMasks(everything, frame.color_bgr.size()).status;
  EXPECT_NE(whole.message().find("whole image"), std::string::npos) << whole.message();
}

TEST_F(ObjectCutTest, ViewRowsAndTheSurfaceSeenAroundTheBox) {
  // The frame view's row index: the points of a row range are those of its rows. The surface a
  // view saw around the object's box (evidence fusion votes on it) is taken from the rows the grown
  // box can project to: the same points as testing every point of the view, for views from the
  // front, the side and close above (the box's projection then spans most rows).
  int index = 0;
  for (const double angle : {0.0, 50.0, -80.0}) {
    cv::Mat mask;
    const RgbdFrame frame = test::renderFrame(scene_, arcPose(angle), index++, &mask);
    const SegmentSelector::FrameView view = SegmentSelector::makeFrameView(
        frame, 2, config_.extractor.min_valid_depth_m, config_.extractor.max_valid_depth_m);
    ASSERT_EQ(view.row_begin.size(), 240u + 1u);
    for (const auto& rows : {std::make_pair(0, 480), std::make_pair(101, 203),
                             std::make_pair(-50, 10), std::make_pair(470, 900)}) {
      const std::pair<size_t, size_t> range = view.rows(rows.first, rows.second);
      size_t expected_first = view.points_D.size();
      size_t expected_end = 0;
      for (size_t k = 0; k < view.points_D.size(); ++k) {
        const int v = view.pixels_color[k].y;  // registered: the depth pixel
        if (v >= rows.first && v < rows.second) {
          expected_first = std::min(expected_first, k);
          expected_end = std::max(expected_end, k + 1);
        }
      }
      if (expected_end == 0) {
        EXPECT_EQ(range.first, range.second);
      } else {
        EXPECT_EQ(range.first, expected_first);
        EXPECT_EQ(range.second, expected_end);
      }
    }
    const Detection2D detection = bledDetection(mask, 6);
    std::vector<PointCloud> clouds;
    ASSERT_TRUE(ObjectCloudExtractor(config_.extractor).extract(frame, {detection}, &clouds).ok());
    ObjectMapper mapper(config_, priors_);
    ObjectObservation observation;
    ASSERT_TRUE(mapper.processSingleView(frame, detection, clouds[0], &observation, nullptr).ok());
    const Eigen::Matrix3f R_B_W = observation.box.rotation.transpose().cast<float>();
    const Eigen::Vector3f centre = observation.box.center_m.cast<float>();
    const Eigen::Vector3f half =
        (0.5 * observation.box.size_m).cast<float>() + Eigen::Vector3f::Constant(0.3f);
    PointCloud seen;
    for (const Eigen::Vector3f& p_W : view.points_W) {
      if (((R_B_W * (p_W - centre)).cwiseAbs() - half).maxCoeff() <= 0.f) seen.push_back(p_W);
    }
    EXPECT_GT(seen.size(), clouds[0].size() / 8);
    EXPECT_LT(seen.size(), view.points_W.size());
    EXPECT_EQ(observation.seen_W, seen) << "view at " << angle << " degrees";
  }
}

TEST(SegmentAdjacency, NeighbouringCellsAsDefined) {
  // Random segments of random points (a few large, many small; around the origin, so cells of
  // both signs), 9 and 100 segments (the dense grid's path and the sorted keys' path), and a
  // cloud too wide for the grid: a touches b where points of the two lie in the same or in
  // neighbouring voxelKeyOf cells.
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> uniform(-0.5f, 0.5f);
  for (const int num_segments : {9, 64, 65, 100}) {
    for (const float spread : {1.f, 3e5f}) {
      PointCloud points;
      std::vector<std::vector<int>> segments(num_segments);
      for (int s = 0; s < num_segments; ++s) {
        const Eigen::Vector3f centre =
            0.4f * Eigen::Vector3f(uniform(rng), uniform(rng), uniform(rng));
        const int size = s % 7 == 0 ? 300 : 1 + static_cast<int>(rng() % 20);
        for (int k = 0; k < size; ++k) {
          segments[s].push_back(static_cast<int>(points.size()));
          points.push_back(centre +
                           0.08f * Eigen::Vector3f(uniform(rng), uniform(rng), uniform(rng)));
        }
      }
      if (spread > 1.f) points[segments[0][0]] = Eigen::Vector3f(spread, 0.f, 0.f);
      const double cell_m = 0.03;
      const std::vector<std::vector<char>> adjacent =
          SegmentSelector::segmentAdjacency(points, segments, cell_m);
      std::vector<Eigen::Vector3i> cells;
      for (const Eigen::Vector3f& p : points) cells.push_back(unpackVoxel(voxelKeyOf(p, cell_m)));
      int touching = 0;
      for (int a = 0; a < num_segments; ++a) {
        for (int b = 0; b < num_segments; ++b) {
          bool expected = false;
          for (const int i : segments[a]) {
            for (const int j : segments[b]) {
              expected = expected || (cells[i] - cells[j]).cwiseAbs().maxCoeff() <= 1;
            }
          }
          ASSERT_EQ(adjacent[a][b] != 0, expected)
              << a << " " << b << " of " << num_segments << ", spread " << spread;
          touching += expected && a != b;
        }
      }
      EXPECT_GE(touching, num_segments / 2);  // pairs, both ways
    }
  }
}

TEST_F(ObjectCutTest, DetectionOfOnlyFloorAndWallIsSkippedWithAWarning) {
  cv::Mat mask;
  const RgbdFrame frame = test::renderFrame(scene_, arcPose(0.0), 7, &mask);
  test::BoxScene empty = scene_;
  empty.with_box = false;
  cv::Mat no_mask;
  const RgbdFrame empty_frame = test::renderFrame(empty, arcPose(0.0), 7, &no_mask);
  // The box where the object would be, over a scene with nothing but floor and wall.
  const Detection2D detection = boxOnlyDetection(mask);
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(mapper.processKeyframe(empty_frame, {detection}, &report).ok());
  EXPECT_EQ(mapper.database().size(), 0u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("frame-7"), std::string::npos) << report.warnings[0];
  EXPECT_NE(report.warnings[0].find("detection 0"), std::string::npos) << report.warnings[0];
}

TEST_F(ObjectCutTest, MaskEntirelyOnTheFloorIsSkipped) {
  cv::Mat mask;
  const RgbdFrame frame = test::renderFrame(scene_, arcPose(0.0), 3, &mask);
  // A blob on the floor in the lower image, away from the object.
  cv::Mat floor_mask = cv::Mat::zeros(mask.size(), CV_8UC1);
  cv::rectangle(floor_mask, cv::Rect(20, 420, 120, 50), cv::Scalar(255), cv::FILLED);
  floor_mask.setTo(0, mask);
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(frame, {test::detectionFromMask(floor_mask, "chair", 0.9f)}, &report)
          .ok());
  EXPECT_EQ(mapper.database().size(), 0u);
  EXPECT_EQ(report.warnings.size(), 1u);
}

TEST_F(ObjectCutTest, BoxCoveringTheWholeImageIsSkipped) {
  cv::Mat mask;
  const RgbdFrame frame = test::renderFrame(scene_, arcPose(0.0), 4, &mask);
  const Detection2D detection =
      boxOnlyDetection(mask, cv::Rect(0, 0, frame.color_bgr.cols, frame.color_bgr.rows));
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(mapper.processKeyframe(frame, {detection}, &report).ok());
  EXPECT_EQ(mapper.database().size(), 0u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("whole image"), std::string::npos) << report.warnings[0];
}

TEST_F(ObjectCutTest, FloorEstimatorFindsTheLowestPopulatedLayer) {
  FloorEstimator floor;
  const GravityFrame gravity(Eigen::Vector3d(0, 0, -1));
  PointCloud points;
  // A wall alone (heights spread evenly) shows no floor.
  for (int i = 0; i < 2000; ++i) points.emplace_back(0.001f * i, 1.0f, 0.001f * i);
  EXPECT_FALSE(floor.addFrame(points, gravity));
  EXPECT_FALSE(floor.hasFloor());
  // A table top at 0.75 m, then a frame that also sees the floor at 0.10 m with a few outliers
  // below it: the floor is the lowest well-populated layer.
  PointCloud table;
  for (int i = 0; i < 3000; ++i) table.emplace_back(0.001f * i, 0.5f, 0.75f + 0.001f * (i % 5));
  EXPECT_TRUE(floor.addFrame(table, gravity));
  EXPECT_NEAR(floor.floorHeight_m(), 0.75, 0.01);
  PointCloud room = table;
  for (int i = 0; i < 3000; ++i) room.emplace_back(0.001f * i, 2.0f, 0.10f + 0.002f * (i % 5));
  for (int i = 0; i < 10; ++i) room.emplace_back(0.0f, 0.0f, -0.5f);
  EXPECT_TRUE(floor.addFrame(room, gravity));
  EXPECT_NEAR(floor.floorHeight_m(), 0.104, 0.01);
  // A later view of the table alone does not lift it again.
  EXPECT_TRUE(floor.addFrame(table, gravity));
  EXPECT_NEAR(floor.floorHeight_m(), 0.104, 0.01);
}

// The floor layer by its definition: every height sorted, a window of layer_thickness_m slid up
// from each of the lowest max_below_fraction of them; NaN when none holds enough points.
double floorLayerReference(const PointCloud& points_W, const GravityFrame& gravity,
                           const FloorEstimator::Config& config) {
  std::vector<double> heights;
  for (const Eigen::Vector3f& p : points_W) heights.push_back(gravity.up.dot(p.cast<double>()));
  std::sort(heights.begin(), heights.end());
  const size_t n = heights.size();
  const size_t needed = std::max<size_t>(static_cast<size_t>(config.min_layer_points),
                                         static_cast<size_t>(config.min_layer_fraction * n));
  for (size_t lo = 0; lo <= static_cast<size_t>(config.max_below_fraction * n) && lo < n; ++lo) {
    size_t hi = lo;
    while (hi < n && heights[hi] - heights[lo] <= config.layer_thickness_m) ++hi;
    if (hi - lo >= needed) return heights[lo + (hi - lo) / 2];
  }
  return std::nan("");
}

TEST(FloorEstimatorLayer, SameLayerAsSortingEveryHeight) {
  // Rooms of random floors, tables, walls and outliers below the floor, in many proportions (the
  // estimator sorts only the heights that a window can reach): the floor height is the
  // definition's, to the bit, or none where the definition finds none.
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> uniform(0.f, 1.f);
  const GravityFrame gravity(Eigen::Vector3d(0, 0, -1));
  FloorEstimator::Config config;
  int found = 0;
  for (int room = 0; room < 60; ++room) {
    PointCloud points;
    const float floor_z = 0.5f * uniform(rng) - 0.25f;
    const int floor_points = static_cast<int>(6000 * uniform(rng) * uniform(rng));
    for (int i = 0; i < floor_points; ++i) {
      points.emplace_back(uniform(rng), uniform(rng), floor_z + 0.02f * (uniform(rng) - 0.5f));
    }
    for (int i = 0; i < 3000; ++i) {  // a table top and a wall
      points.emplace_back(uniform(rng), uniform(rng), floor_z + 0.74f + 0.01f * uniform(rng));
      points.emplace_back(uniform(rng), 1.f, floor_z + 2.5f * uniform(rng));
    }
    const int below = static_cast<int>(200 * uniform(rng));
    for (int i = 0; i < below; ++i) points.emplace_back(0.f, 0.f, floor_z - uniform(rng));
    FloorEstimator floor(config);
    const double expected = floorLayerReference(points, gravity, config);
    EXPECT_EQ(floor.addFrame(points, gravity), std::isfinite(expected)) << "room " << room;
    if (std::isfinite(expected)) {
      EXPECT_EQ(floor.floorHeight_m(), expected) << "room " << room;
      ++found;
    }
  }
  EXPECT_GT(found, 10);  // both outcomes occur
  EXPECT_LT(found, 60);
}

}  // namespace
}  // namespace mvod
