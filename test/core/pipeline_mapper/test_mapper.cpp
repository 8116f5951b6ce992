// ObjectMapper: the per-keyframe pipeline on small frames ray-cast in the test (a box on the floor
// in front of a wall, perfect masks).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "box_scene.h"
#include "multiview_object_detection/pipeline/object_mapper.h"

namespace mvod {
namespace {

constexpr int kRows = 480;
constexpr int kCols = 640;

// The mapper's world: an axis-aligned 0.5 x 0.4 x 0.5 m box at y = 2, a wall at y = 3.
test::BoxScene mapperScene() {
  test::BoxScene scene;
  scene.wall_y_m = 3.0;
  return scene;
}

using test::detectionFromMask;
using test::renderFrame;

bool anyWarningContains(const KeyframeReport& report, const std::string& text) {
  return std::any_of(report.warnings.begin(), report.warnings.end(),
                     [&](const std::string& w) { return w.find(text) != std::string::npos; });
}

class ObjectMapperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClassPrior chair;
    chair.class_name = "chair";
    chair.has_size = true;
    chair.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
    chair.fusion_distance_m = 0.4;
    priors_.set(chair);
    ClassPrior cup;
    cup.class_name = "cup";
    cup.has_size = true;
    cup.size_m = Eigen::Vector3d(0.08, 0.08, 0.1);
    cup.fusion_distance_m = 0.1;
    priors_.set(cup);
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    pose_ = test::cameraLookingAlongY(Eigen::Vector3d(0.0, 0.0, 1.0), 20.0);
    frame_ = renderFrame(scene_, pose_, 1, &mask_);
  }

  // Compares with the true box; the horizontal axes may come out in either order.
  void expectNearTruth(const OrientedBox& box) {
    const Eigen::Vector3d true_center = scene_.box_center;
    const Eigen::Vector3d true_size = 2.0 * scene_.box_half_size;
    EXPECT_LT((box.center_m - true_center).norm(), 0.05) << "centre " << box.center_m.transpose();
    EXPECT_NEAR(box.size_m.z(), true_size.z(), 0.05);
    const double a = std::max(box.size_m.x(), box.size_m.y());
    const double b = std::min(box.size_m.x(), box.size_m.y());
    EXPECT_NEAR(a, 0.5, 0.05) << "size " << box.size_m.transpose();
    EXPECT_NEAR(b, 0.4, 0.05) << "size " << box.size_m.transpose();
    // Gravity-aligned: the third column is up.
    EXPECT_GT(box.rotation.col(2).dot(Eigen::Vector3d::UnitZ()), 0.999);
  }

  ClassPriors priors_;
  ObjectMapper::Config config_;
  test::BoxScene scene_ = mapperScene();
  Eigen::Isometry3d pose_;
  RgbdFrame frame_;
  cv::Mat mask_;
};

TEST_F(ObjectMapperTest, OneDetectionGivesOneObjectNearTheTruth) {
  ASSERT_TRUE(config_.isValid().ok()) << config_.isValid().message();
  ASSERT_GT(cv::countNonZero(mask_), 2000);
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  const Status status =
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report);
  ASSERT_TRUE(status.ok()) << status.message();
  for (const auto& w : report.warnings) ADD_FAILURE() << "unexpected warning: " << w;
  EXPECT_EQ(report.detections, 1);
  EXPECT_EQ(report.above_threshold, 1);
  EXPECT_EQ(report.with_box, 1);
  EXPECT_EQ(report.inserted, 1);
  EXPECT_EQ(report.fused, 0);
  EXPECT_GT(report.times.total_ms, 0.0);
  EXPECT_GE(report.times.total_ms, report.times.extraction_ms);
  // The one detection's single view, between extraction and fusion.
  EXPECT_GT(report.times.largest_view_ms, 0.0);
  EXPECT_LE(report.times.largest_view_ms,
            report.times.total_ms - report.times.extraction_ms - report.times.fusion_ms);
  ASSERT_EQ(mapper.database().size(), 1u);
  const MapObject& object = mapper.database().objects().begin()->second;
  EXPECT_EQ(object.class_name, "chair");
  EXPECT_FLOAT_EQ(object.probability, 0.9f);
  EXPECT_GT(object.points_W.size(), 500u);
  EXPECT_FALSE(object.segment_W.empty());
  expectNearTruth(object.box);
  EXPECT_EQ(mapper.keyframesProcessed(), 1);
}

TEST_F(ObjectMapperTest, SecondViewFusesIntoTheSameObject) {
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report).ok());
  cv::Mat mask2;
  const RgbdFrame second = renderFrame(
      scene_, test::cameraLookingAlongY(Eigen::Vector3d(0.4, 0.1, 1.0), 25.0), 2, &mask2);
  ASSERT_EQ(report.object_ids.size(), 1u);
  const int first_id = report.object_ids[0];
  EXPECT_NE(mapper.database().find(first_id), nullptr);
  // A detection under λ is named as not mapped (-1), the one fused names the first's object.
  ASSERT_TRUE(mapper
                  .processKeyframe(second,
                                   {detectionFromMask(mask2, "chair", 0.1f),
                                    detectionFromMask(mask2, "chair", 0.7f)},
                                   &report)
                  .ok());
  EXPECT_EQ(report.fused, 1);
  EXPECT_EQ(report.object_ids, (std::vector<int>{-1, first_id}));
  EXPECT_EQ(report.inserted, 0);
  ASSERT_EQ(mapper.database().size(), 1u);
  const MapObject& object = mapper.database().objects().begin()->second;
  EXPECT_EQ(object.observations, 2);
  EXPECT_NEAR(object.probability, 0.8, 1e-6);
  EXPECT_EQ(object.first_keyframe, 0);
  EXPECT_EQ(object.last_keyframe, 1);
  expectNearTruth(object.box);
  EXPECT_GT(report.times.fusion_ms, 0.0);
}

TEST_F(ObjectMapperTest, OneThreadAndManyThreadsGiveIdenticalMaps) {
  // Several detections per keyframe (a mask, its box, a part of it, one on the wall), three views:
  // the single-view stage runs on the pool, fusion in detection order.
  std::vector<std::pair<RgbdFrame, std::vector<Detection2D>>> keyframes;
  const Eigen::Vector3d positions[] = {{0.0, 0.0, 1.0}, {0.4, 0.1, 1.0}, {-0.3, 0.2, 1.1}};
  const double tilts[] = {20.0, 25.0, 18.0};
  for (int i = 0; i < 3; ++i) {
    cv::Mat mask;
    const RgbdFrame frame =
        renderFrame(scene_, test::cameraLookingAlongY(positions[i], tilts[i]), i + 1, &mask);
    std::vector<Detection2D> detections = {detectionFromMask(mask, "chair", 0.9f)};
    Detection2D box_only = detectionFromMask(mask, "couch", 0.6f);
    box_only.mask.setTo(0);
    box_only.mask(box_only.box_px).setTo(255);
    detections.push_back(box_only);
    cv::Mat top = mask.clone();
    top(cv::Rect(0, top.rows / 2, top.cols, top.rows - top.rows / 2)).setTo(0);
    if (cv::countNonZero(top) > 100) detections.push_back(detectionFromMask(top, "cup", 0.7f));
    cv::Mat wall = cv::Mat::zeros(mask.size(), CV_8UC1);
    wall(cv::Rect(40, 20, 120, 60)).setTo(255);
    wall.setTo(0, mask);
    if (cv::countNonZero(wall) > 100) detections.push_back(detectionFromMask(wall, "tv", 0.8f));
    // The box-only detection is large enough for its selection masks to be computed on a thread
    // of their own beside its filter and LCCP (with more than one thread).
    EXPECT_GT(static_cast<size_t>(cv::countNonZero(box_only.mask)),
              ObjectMapper::kMinPointsForMasksThread);
    keyframes.emplace_back(frame, detections);
  }
  std::vector<std::vector<MapObject>> maps;
  for (const int threads : {1, 4}) {
    ObjectMapper::Config config = config_;
    config.num_threads = threads;
    ObjectMapper mapper(config, priors_);
    for (const auto& keyframe : keyframes) {
      KeyframeReport report;
      ASSERT_TRUE(mapper.processKeyframe(keyframe.first, keyframe.second, &report).ok());
      EXPECT_GE(report.with_box, 1);
    }
    std::vector<MapObject> objects;
    for (const auto& entry : mapper.database().objects()) objects.push_back(entry.second);
    maps.push_back(objects);
  }
  ASSERT_GE(maps[0].size(), 2u);
  ASSERT_EQ(maps[0].size(), maps[1].size());
  for (size_t i = 0; i < maps[0].size(); ++i) {
    const MapObject& a = maps[0][i];
    const MapObject& b = maps[1][i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.class_name, b.class_name);
    EXPECT_EQ(a.observations, b.observations);
    EXPECT_EQ(a.probability, b.probability);
    EXPECT_EQ(a.box.center_m, b.box.center_m) << a.class_name;
    EXPECT_EQ(a.box.size_m, b.box.size_m) << a.class_name;
    EXPECT_EQ(a.box.rotation, b.box.rotation) << a.class_name;
    EXPECT_EQ(a.points_W, b.points_W) << a.class_name;
    EXPECT_EQ(a.segment_W, b.segment_W) << a.class_name;
  }
  config_.num_threads = -1;
  EXPECT_FALSE(config_.isValid().ok());
}

TEST_F(ObjectMapperTest, DetectionBelowTheThresholdIsDropped) {
  config_.min_probability = 0.5;
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.3f)}, &report).ok());
  EXPECT_EQ(report.detections, 1);
  EXPECT_EQ(report.above_threshold, 0);
  EXPECT_EQ(report.with_box, 0);
  EXPECT_EQ(mapper.database().size(), 0u);
}

// Live reconfiguration (the ROS node's dynamic_reconfigure): new thresholds apply to the next
// keyframe, the map and its ids stay, an invalid config changes nothing.
TEST_F(ObjectMapperTest, UpdateConfigKeepsTheMapAndAppliesNewThresholds) {
  ObjectMapper mapper(config_, priors_);
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.6f)}, nullptr).ok());
  ASSERT_EQ(mapper.database().size(), 1u);
  const int id = mapper.database().objects().begin()->first;

  ObjectMapper::Config stricter = config_;
  stricter.min_probability = 0.7;
  ASSERT_TRUE(mapper.updateConfig(stricter).ok());
  EXPECT_EQ(mapper.config().min_probability, 0.7);
  ASSERT_EQ(mapper.database().size(), 1u);
  EXPECT_NE(mapper.database().find(id), nullptr);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.6f)}, &report).ok());
  EXPECT_EQ(report.above_threshold, 0) << "0.6 is under the new lambda 0.7";
  EXPECT_EQ(mapper.database().find(id)->observations, 1);

  ObjectMapper::Config invalid = stricter;
  invalid.min_probability = 1.5;
  EXPECT_FALSE(mapper.updateConfig(invalid).ok());
  EXPECT_EQ(mapper.config().min_probability, 0.7);

  // A lower threshold lets the same detection fuse into the kept object.
  ObjectMapper::Config looser = stricter;
  looser.min_probability = 0.5;
  ASSERT_TRUE(mapper.updateConfig(looser).ok());
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.6f)}, &report).ok());
  EXPECT_EQ(report.fused, 1);
  EXPECT_EQ(mapper.database().find(id)->observations, 2);
}

TEST_F(ObjectMapperTest, UnknownClassIsAWarning) {
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  Detection2D detection = detectionFromMask(mask_, "spaceship", 0.9f);
  ASSERT_EQ(detection.class_id, -1);
  ASSERT_TRUE(mapper.processKeyframe(frame_, {detection}, &report).ok());
  EXPECT_TRUE(anyWarningContains(report, "unknown class")) << report.warnings.size();
  EXPECT_TRUE(anyWarningContains(report, frame_.name));
  EXPECT_EQ(mapper.database().size(), 0u);
  // A COCO name without an id is fine: the id is looked up.
  detection.class_name = "chair";
  ASSERT_TRUE(mapper.processKeyframe(frame_, {detection}, &report).ok());
  ASSERT_EQ(mapper.database().size(), 1u);
  EXPECT_EQ(mapper.database().objects().begin()->second.class_id, cocoClassId("chair"));
}

// Why each detection was not mapped, per detection (issue 56, item 3: the overlays said "(not
// mapped)" without why): under λ, an unknown class and an empty mask each name their problem; the
// mapped chair has none.
TEST_F(ObjectMapperTest, EachDetectionNotMappedSaysWhy) {
  config_.min_probability = 0.5;
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  Detection2D empty = detectionFromMask(cv::Mat::zeros(kRows, kCols, CV_8UC1), "cup", 0.9f);
  empty.box_px = cv::Rect(0, 0, 1, 1);
  ASSERT_TRUE(mapper
                  .processKeyframe(frame_,
                                   {detectionFromMask(mask_, "chair", 0.3f),
                                    detectionFromMask(mask_, "spaceship", 0.9f), empty,
                                    detectionFromMask(mask_, "chair", 0.9f)},
                                   &report)
                  .ok());
  ASSERT_EQ(report.drop_reasons.size(), 4u);
  EXPECT_EQ(report.drop_reasons[0], "score under min_probability (lambda)");
  EXPECT_NE(report.drop_reasons[1].find("unknown class"), std::string::npos)
      << report.drop_reasons[1];
  EXPECT_FALSE(report.drop_reasons[2].empty());
  EXPECT_EQ(report.drop_reasons[2].find("detection "), std::string::npos)
      << "the problem alone: " << report.drop_reasons[2];
  ASSERT_GE(report.object_ids[3], 0);
  EXPECT_TRUE(report.drop_reasons[3].empty()) << report.drop_reasons[3];
}

TEST_F(ObjectMapperTest, BadFrameIsAnErrorAndChangesNothing) {
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report).ok());
  const OrientedBox box_before = mapper.database().objects().begin()->second.box;

  RgbdFrame bad = frame_;
  bad.depth = cv::Mat(kRows, kCols, CV_8UC1, cv::Scalar(1));
  Status status = mapper.processKeyframe(bad, {detectionFromMask(mask_, "chair", 0.9f)}, &report);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(status.message().empty());

  RgbdFrame bad_pose = frame_;
  bad_pose.T_W_D.matrix()(0, 0) = std::nan("");
  status = mapper.processKeyframe(bad_pose, {detectionFromMask(mask_, "chair", 0.9f)}, &report);
  EXPECT_FALSE(status.ok());

  ASSERT_EQ(mapper.database().size(), 1u);
  const MapObject& object = mapper.database().objects().begin()->second;
  EXPECT_EQ(object.observations, 1);
  EXPECT_TRUE(object.box.center_m.isApprox(box_before.center_m));
  EXPECT_EQ(mapper.keyframesProcessed(), 1);
}

TEST_F(ObjectMapperTest, EmptyAndBrokenMasksAreWarningsNotErrors) {
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  Detection2D empty = detectionFromMask(cv::Mat::zeros(kRows, kCols, CV_8UC1), "cup", 0.9f);
  empty.box_px = cv::Rect(0, 0, 1, 1);
  Detection2D wrong_size = detectionFromMask(mask_, "couch", 0.9f);
  cv::resize(mask_, wrong_size.mask, cv::Size(100, 50), 0, 0, cv::INTER_NEAREST);
  const Status status = mapper.processKeyframe(
      frame_, {empty, wrong_size, detectionFromMask(mask_, "chair", 0.9f)}, &report);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_GE(report.warnings.size(), 1u);
  EXPECT_EQ(report.above_threshold, 3);
  ASSERT_EQ(mapper.database().findByClass("chair").size(), 1u);
  EXPECT_EQ(mapper.database().findByClass("cup").size(), 0u);
}

TEST_F(ObjectMapperTest, RefineRemovesAnAtypicalObject) {
  // Two objects in one place: fusion by overlap (evidence fusion's default) would make them one.
  config_.database.min_overlap_to_fuse = 0.0;
  ObjectMapper mapper(config_, priors_);
  KeyframeReport report;
  // The same 0.5 m box once as a chair (plausible) and, from another keyframe, as a cup (far too
  // big).
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report).ok());
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "cup", 0.9f)}, &report).ok());
  ASSERT_EQ(mapper.database().size(), 2u);
  const int cup_id = mapper.database().findByClass("cup").front()->id;
  const int chair_id = mapper.database().findByClass("chair").front()->id;
  const OrientedBox cup_box = mapper.database().find(cup_id)->box;
  const ObjectMapper::RefinementReport refined = mapper.refine();
  EXPECT_EQ(refined.atypical_ids, std::vector<int>{cup_id});
  // Not silently: the cup is reported as it was, with why.
  ASSERT_EQ(refined.removed.size(), 1u);
  EXPECT_EQ(refined.removed[0].object.id, cup_id);
  EXPECT_EQ(refined.removed[0].object.class_name, "cup");
  EXPECT_TRUE(refined.removed[0].object.box.center_m.isApprox(cup_box.center_m));
  EXPECT_EQ(refined.removed[0].reason.rfind("too large for a cup", 0), 0u)
      << refined.removed[0].reason;
  EXPECT_TRUE(refined.intersecting_ids.empty());
  EXPECT_GE(refined.time_ms, 0.0);
  ASSERT_EQ(mapper.database().size(), 1u);
  EXPECT_NE(mapper.database().find(chair_id), nullptr);
  EXPECT_EQ(mapper.database().find(cup_id), nullptr);
}

// One chair mapped twice (its first views saw disjoint parts): a copy without legs, seen in 8
// keyframes, and a whole one seen in 2, each box mostly inside the other. The refinement's
// duplicate rule keeps the better-supported copy; merging gives it the other's voxels, legs
// included. Without merging the kept box stays legless.
TEST_F(ObjectMapperTest, RefineMergesADuplicateIntoTheCopyItKeeps) {
  const auto run = [&](bool merge) {
    ObjectMapper::Config config = config_;
    config.intersection_filter.merge_duplicates = merge;
    ObjectMapper mapper(config, priors_);
    const auto copy = [&](int id, int observations, double bottom_m) {
      MapObject object;
      object.id = id;
      object.class_name = "chair";
      object.class_id = cocoClassId("chair");
      object.probability = 0.8;
      object.observations = observations;
      object.evidence_voxel_size_m = config.database.fusion_voxel_size_m;
      // The four sides of a 0.5 m square chair from bottom_m to 0.9 m, 1 cm voxels.
      for (int k = static_cast<int>(std::lround(bottom_m * 100)); k < 90; ++k) {
        for (int i = 0; i < 50; ++i) {
          const float z = 0.005f + 0.01f * k;
          const float t = -0.245f + 0.01f * i;
          for (const Eigen::Vector3f& p :
               {Eigen::Vector3f(t, -0.245f, z), Eigen::Vector3f(t, 0.245f, z),
                Eigen::Vector3f(-0.245f, t, z), Eigen::Vector3f(0.245f, t, z)}) {
            VoxelEvidence& e =
                object.evidence[mapper.database().voxelKey(p + Eigen::Vector3f(1.f, 2.f, 0.f))];
            e.inside = static_cast<std::uint16_t>(observations);
          }
        }
      }
      for (const auto& entry : object.evidence) {
        object.points_W.push_back(mapper.database().voxelCentre(entry.first));
      }
      object.segment_W = object.points_W;
      object.box.center_m = Eigen::Vector3d(1.0, 2.0, 0.5 * (bottom_m + 0.9));
      object.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9 - bottom_m);
      return object;
    };
    EXPECT_TRUE(mapper.mutableDatabase().setObjects({copy(1, 8, 0.3), copy(2, 2, 0.0)}).ok());
    const ObjectMapper::RefinementReport refined = mapper.refine();
    EXPECT_EQ(refined.intersecting_ids, std::vector<int>{2});
    EXPECT_EQ(refined.removed.size(), 1u);
    EXPECT_EQ(mapper.database().size(), 1u);
    const MapObject* kept = mapper.database().find(1);
    EXPECT_NE(kept, nullptr);
    return std::make_pair(refined, kept != nullptr ? *kept : MapObject());
  };
  const auto merged = run(true);
  EXPECT_EQ(merged.first.merged_ids, (std::vector<std::pair<int, int>>{{2, 1}}));
  // The duplicate as it was before the merge (legs and all), and where it went.
  ASSERT_EQ(merged.first.removed.size(), 1u);
  EXPECT_EQ(merged.first.removed[0].object.id, 2);
  EXPECT_EQ(merged.first.removed[0].object.observations, 2);
  EXPECT_EQ(merged.first.removed[0].reason, "a duplicate, merged into #1");
  EXPECT_EQ(merged.second.observations, 10);
  EXPECT_GT(merged.second.box.size_m.z(), 0.85);  // down to the legs' feet
  EXPECT_NEAR(merged.second.box.center_m.z(), 0.45, 0.03);
  const auto deleted = run(false);
  EXPECT_TRUE(deleted.first.merged_ids.empty());
  ASSERT_EQ(deleted.first.removed.size(), 1u);
  EXPECT_EQ(deleted.first.removed[0].reason, "mostly inside another object (Eq. 10, 11)");
  EXPECT_EQ(deleted.second.observations, 8);
  EXPECT_NEAR(deleted.second.box.size_m.z(), 0.6, 0.01);  // untouched: no legs
}

TEST_F(ObjectMapperTest, WaitsForGravityWhenNoneIsConfigured) {
  config_.gravity_down_W = Eigen::Vector3d::Zero();
  ObjectMapper mapper(config_, priors_);
  EXPECT_FALSE(mapper.hasGravity());
  // Facing the wall from 1 m, level: no horizontal plane in view.
  test::BoxScene wall_only = scene_;
  wall_only.with_box = false;
  cv::Mat unused;
  const RgbdFrame wall = renderFrame(
      wall_only, test::cameraLookingAlongY(Eigen::Vector3d(0, 2.0, 1.0), 0.0), 0, &unused);
  KeyframeReport report;
  ASSERT_TRUE(
      mapper.processKeyframe(wall, {detectionFromMask(mask_, "chair", 0.9f)}, &report).ok());
  EXPECT_TRUE(report.waiting_for_gravity);
  EXPECT_TRUE(anyWarningContains(report, "waiting for gravity"));
  EXPECT_EQ(mapper.database().size(), 0u);

  // The floor is in this view: gravity is estimated and the detection processed.
  ASSERT_TRUE(
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report).ok());
  ASSERT_TRUE(mapper.hasGravity());
  EXPECT_FALSE(report.waiting_for_gravity);
  EXPECT_GT(mapper.gravity().up.dot(Eigen::Vector3d::UnitZ()), std::cos(5.0 * kPi / 180.0));
  EXPECT_EQ(mapper.database().size(), 1u);

  mapper.reset();
  EXPECT_FALSE(mapper.hasGravity());
  EXPECT_EQ(mapper.database().size(), 0u);
  EXPECT_EQ(mapper.keyframesProcessed(), 0);
}

TEST_F(ObjectMapperTest, ConfigValidationNamesTheSection) {
  ObjectMapper::Config config;
  EXPECT_TRUE(config.isValid().ok()) << config.isValid().message();
  config.min_probability = 1.5;
  EXPECT_NE(config.isValid().message().find("min_probability"), std::string::npos);
  config = ObjectMapper::Config();
  config.database.fusion_voxel_size_m = -1.0;
  EXPECT_FALSE(config.isValid().ok());
  // Named as the parameter file names it (database/fusion_voxel_size_m), once.
  EXPECT_EQ(config.isValid().message().rfind("database/fusion_voxel_size_m must be", 0), 0u)
      << config.isValid().message();
  config = ObjectMapper::Config();
  config.database.min_overlap_to_fuse = 2.0;  // a check without a table range: section prefixed
  EXPECT_EQ(config.isValid().message().rfind("database.", 0), 0u) << config.isValid().message();
  const std::string printed = ObjectMapper::Config().print();
  EXPECT_NE(printed.find("min_probability: 0.5"), std::string::npos);
  EXPECT_NE(printed.find("database.fusion_voxel_size_m: 0.01"), std::string::npos);
}

TEST_F(ObjectMapperTest, ACancelledKeyframeLeavesTheMapAsItWas) {
  ObjectMapper mapper(config_, priors_);
  std::atomic<bool> cancel{true};
  mapper.setCancelFlag(&cancel);
  KeyframeReport report;
  Status status =
      mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("cancelled"), std::string::npos) << status.message();
  EXPECT_EQ(mapper.database().size(), 0u);
  EXPECT_EQ(mapper.keyframesProcessed(), 0);
  EXPECT_TRUE(mapper.history().empty());
  // Cleared, the same keyframe maps as ever.
  cancel = false;
  status = mapper.processKeyframe(frame_, {detectionFromMask(mask_, "chair", 0.9f)}, &report);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(mapper.database().size(), 1u);
  expectNearTruth(mapper.database().objects().begin()->second.box);
  EXPECT_EQ(mapper.keyframesProcessed(), 1);
}

TEST_F(ObjectMapperTest, ACancelFromAnotherThreadStopsAKeyframeBetweenItsStages) {
  // Many detections of the same chair on one thread: the cancel arrives while they run, and the
  // keyframe ends at the next check with nothing mapped.
  ObjectMapper::Config config = config_;
  config.num_threads = 1;
  ObjectMapper mapper(config, priors_);
  std::atomic<bool> cancel{false};
  mapper.setCancelFlag(&cancel);
  std::vector<Detection2D> detections(40, detectionFromMask(mask_, "chair", 0.9f));
  std::thread canceller([&cancel] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    cancel = true;
  });
  KeyframeReport report;
  const Status status = mapper.processKeyframe(frame_, detections, &report);
  canceller.join();
  ASSERT_FALSE(status.ok()) << "40 detections took less than 30 ms: the cancel came too late";
  EXPECT_NE(status.message().find("cancelled"), std::string::npos) << status.message();
  EXPECT_EQ(mapper.database().size(), 0u);
}

}  // namespace
}  // namespace mvod
