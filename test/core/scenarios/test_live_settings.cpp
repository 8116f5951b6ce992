// Settings and poses that change under a running map (issue 48): the fusion grid changed live
// (dynamic_reconfigure's database/fusion_voxel_size_m) fuses the map again from the keyframe
// history, as if the new grid had been used from the start; a lap whose poses are upside down
// relative to the configured gravity maps nothing (it used to map every object below the floor).
// (With a floor known, the single view's floor cut already drops whatever lies on or under it.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "room_walk.h"

namespace mvod {
namespace {

class LiveSettingsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(
        ClassPriors::loadYaml(std::string(MVOD_SOURCE_DIR) + "/config/class_priors.yaml", &priors_)
            .ok());
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);  // gravity_source: param
    config_.num_threads = 2;
  }

  // One lap of the room, each keyframe edited by `edit` (may be null), refined every 10
  // keyframes as the node does; the keyframes' warnings appended to *warnings.
  void lap(ObjectMapper* mapper, int* keyframe,
           const std::function<void(RgbdFrame*, std::vector<Detection2D>*)>& edit = nullptr,
           std::vector<std::string>* warnings = nullptr) {
    for (int i = 0; i < test::kFramesPerLap; ++i, ++*keyframe) {
      RgbdFrame frame;
      std::vector<Detection2D> detections;
      test::renderKeyframe(room_, i, *keyframe, &frame, &detections);
      if (edit) edit(&frame, &detections);
      KeyframeReport report;
      EXPECT_TRUE(mapper->processKeyframe(frame, detections, &report).ok());
      if (warnings != nullptr) {
        warnings->insert(warnings->end(), report.warnings.begin(), report.warnings.end());
      }
      if (*keyframe % 10 == 9) mapper->refine();
    }
  }
  // Two laps and the final refinement.
  void map(ObjectMapper* mapper) {
    int keyframe = 0;
    lap(mapper, &keyframe);
    lap(mapper, &keyframe);
    mapper->refine();
  }

  static int count(const std::vector<std::string>& warnings, const std::string& text) {
    return static_cast<int>(
        std::count_if(warnings.begin(), warnings.end(),
                      [&](const std::string& w) { return w.find(text) != std::string::npos; }));
  }

  ClassPriors priors_;
  ObjectMapper::Config config_;
  SyntheticScene room_ = SyntheticScene::makeDefault(test::walkConfig(test::kFramesPerLap));
};

// database/fusion_voxel_size_m 0.01 -> 0.2 m while the node runs: the map is fused again from the
// history at 0.2 m, and is the map a run at 0.2 m from the start gives (the same objects, boxes
// within 3 cm: the voxels the views saw around their cuts are carried over by their centres).
// Before, the objects kept their 1 cm boxes, and were mixed with 20 cm ones as detections fused.
TEST_F(LiveSettingsTest, ANewFusionGridFusesTheMapAgain) {
  ObjectMapper live(config_, priors_);
  map(&live);
  ObjectMapper::Config coarse = config_;
  coarse.database.fusion_voxel_size_m = 0.2;
  ObjectMapper::ReconfigureReport report;
  ASSERT_TRUE(live.updateConfig(coarse, &report).ok());
  ObjectMapper fresh(coarse, priors_);
  map(&fresh);
  const std::vector<MapObject> expected = test::objectsOf(fresh);
  const std::vector<MapObject> actual = test::objectsOf(live);
  const test::MapDifference d = test::compareMaps(expected, actual);
  std::printf(
      "0.01 -> 0.2 m live: fused again %d, objects %d -> %d (%zu removed, %.1f ms); against a run "
      "at 0.2 m: %zu objects, centre %.3f m, size %.3f m, %d missing, %d extra\n",
      report.fused_again, report.objects_before, report.objects_after, report.removed.size(),
      report.time_ms, expected.size(), d.centre_m, d.size_m, d.missing, d.extra);
  EXPECT_TRUE(report.fused_again);
  EXPECT_FALSE(report.next_fusions_only);
  EXPECT_EQ(d.missing, 0);
  EXPECT_EQ(d.extra, 0);
  EXPECT_LE(d.centre_m, 0.03);
  EXPECT_LE(d.size_m, 0.03);
  for (const ObjectMapper::RemovedObject& removed : report.removed) {
    EXPECT_NE(removed.reason.find("fusion_voxel_size_m"), std::string::npos) << removed.reason;
  }
  // Back to 1 cm: the map of 1 cm again.
  ASSERT_TRUE(live.updateConfig(config_, &report).ok());
  ObjectMapper fine(config_, priors_);
  map(&fine);
  const test::MapDifference back = test::compareMaps(test::objectsOf(fine), test::objectsOf(live));
  EXPECT_EQ(back.missing + back.extra, 0);
  EXPECT_LE(back.centre_m, 0.01);
  EXPECT_LE(back.size_m, 0.01);
}

// Without a keyframe history (corrections/enable false) nothing can be fused again: the new grid
// applies to the next fusions, and the report says so.
TEST_F(LiveSettingsTest, WithoutAHistoryANewGridAppliesToTheNextFusions) {
  config_.corrections.enable = false;
  ObjectMapper mapper(config_, priors_);
  int keyframe = 0;
  lap(&mapper, &keyframe);
  const std::vector<MapObject> before = test::objectsOf(mapper);
  ObjectMapper::Config coarse = config_;
  coarse.database.fusion_voxel_size_m = 0.02;
  ObjectMapper::ReconfigureReport report;
  ASSERT_TRUE(mapper.updateConfig(coarse, &report).ok());
  EXPECT_FALSE(report.fused_again);
  EXPECT_TRUE(report.next_fusions_only);
  const test::MapDifference d = test::compareMaps(before, test::objectsOf(mapper));
  EXPECT_EQ(d.centre_m, 0.0);
  EXPECT_EQ(d.missing + d.extra, 0);
}

// gravity_source: param, ~reset, then a lap whose poses are upside down (the world turned 180
// degrees about x): every object used to be mapped upside down, 0.44-0.90 m under the floor's
// height, without a word. The camera is upside down relative to gravity: each keyframe says so
// and maps nothing.
TEST_F(LiveSettingsTest, AnUpsideDownLapMapsNothingBelowTheFloor) {
  ObjectMapper mapper(config_, priors_);
  int keyframe = 0;
  lap(&mapper, &keyframe);
  ASSERT_GE(mapper.database().size(), 7u);
  mapper.reset();
  Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
  flip.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<std::string> warnings;
  lap(
      &mapper, &keyframe,
      [&](RgbdFrame* frame, std::vector<Detection2D>*) { frame->T_W_D = flip * frame->T_W_D; },
      &warnings);
  mapper.refine();
  for (const MapObject& object : test::objectsOf(mapper)) {
    ADD_FAILURE() << object.class_name << " #" << object.id << " mapped at height "
                  << object.box.center_m.z();
  }
  EXPECT_EQ(count(warnings, "upside down"), test::kFramesPerLap);
}

}  // namespace
}  // namespace mvod
