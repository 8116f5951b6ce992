// A short sensor or SLAM fault must not erase a room that dozens of keyframes confirmed (issue 48):
// the rendered room mapped in two laps, then keyframes whose depth is wrong (9.9 m or 5 m
// everywhere, valid values) at the map's own poses, or whose images come from another place than
// their poses (a SLAM glitch). Such a keyframe sees through most of the objects it could see: it
// is taken for a fault, does not vote and is not fused, and is counted. The changing-room tests
// (test_changing_room.cpp) check that what really left still goes.
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

class SensorFaultTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(
        ClassPriors::loadYaml(std::string(MVOD_SOURCE_DIR) + "/config/class_priors.yaml", &priors_)
            .ok());
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    config_.num_threads = 2;
  }

  // Two clean laps, then `faults` keyframes made by fault(i, frame, detections) from frame i of
  // the lap (i cycling through the lap), then `clean_after` clean keyframes.
  struct Outcome {
    std::vector<MapObject> mapped;  // after the clean laps
    std::vector<MapObject> after;   // after the faults (and the clean keyframes after them)
    std::vector<MapObject> removed;
    int faults_found = 0;  // keyframes reported as faults
  };
  Outcome run(int faults,
              const std::function<void(int, RgbdFrame*, std::vector<Detection2D>*)>& fault,
              int clean_after = 0) {
    ObjectMapper mapper(config_, priors_);
    Outcome outcome;
    int keyframe = 0;
    const auto process = [&](int lap_frame, bool faulty) {
      RgbdFrame frame;
      std::vector<Detection2D> detections;
      test::renderKeyframe(room_, lap_frame, keyframe, &frame, &detections);
      if (faulty) fault(lap_frame, &frame, &detections);
      KeyframeReport report;
      EXPECT_TRUE(mapper.processKeyframe(frame, detections, &report).ok());
      if (faulty) {
        outcome.removed.insert(outcome.removed.end(), report.removed.begin(), report.removed.end());
      }
      if (report.depth_fault) ++outcome.faults_found;
      ++keyframe;
    };
    for (int i = 0; i < 2 * test::kFramesPerLap; ++i) process(i % test::kFramesPerLap, false);
    mapper.refine();
    outcome.mapped = test::objectsOf(mapper);
    for (int i = 0; i < faults; ++i) process(i % test::kFramesPerLap, true);
    for (int i = 0; i < clean_after; ++i) process((faults + i) % test::kFramesPerLap, false);
    mapper.refine();
    outcome.after = test::objectsOf(mapper);
    return outcome;
  }

  // Every object mapped before the faults is still there (same id, same place).
  static void expectNothingLost(const Outcome& outcome, const std::string& what) {
    for (const MapObject& object : outcome.mapped) {
      const auto same = std::find_if(outcome.after.begin(), outcome.after.end(),
                                     [&](const MapObject& o) { return o.id == object.id; });
      ASSERT_NE(same, outcome.after.end())
          << what << ": " << object.class_name << " #" << object.id << " removed";
      EXPECT_LT((same->box.center_m - object.box.center_m).norm(), 0.02)
          << what << ": " << object.class_name << " #" << object.id;
    }
    EXPECT_TRUE(outcome.removed.empty()) << what;
  }

  // Objects after the faults that were not mapped before (phantoms).
  static int phantoms(const Outcome& outcome) {
    int count = 0;
    for (const MapObject& object : outcome.after) {
      count += std::none_of(outcome.mapped.begin(), outcome.mapped.end(),
                            [&](const MapObject& o) { return o.id == object.id; });
    }
    return count;
  }

  static void print(const char* what, const Outcome& outcome, int faults) {
    std::printf(
        "%-26s %zu objects mapped, %zu after, %zu removed, %d phantoms, %d of %d keyframes "
        "taken for faults\n",
        what, outcome.mapped.size(), outcome.after.size(), outcome.removed.size(),
        phantoms(outcome), outcome.faults_found, faults);
  }

  ClassPriors priors_;
  ObjectMapper::Config config_;
  SyntheticScene room_ = SyntheticScene::makeDefault(test::walkConfig(test::kFramesPerLap));
};

// Depth of `depth_m` everywhere (a valid value), the images and pose right.
std::function<void(int, RgbdFrame*, std::vector<Detection2D>*)> farDepth(double depth_m) {
  return [depth_m](int, RgbdFrame* frame, std::vector<Detection2D>*) {
    if (frame->depth.type() == CV_16UC1) {
      frame->depth.setTo(static_cast<int>(depth_m * 1000.0));
    } else {
      frame->depth.setTo(depth_m);
    }
  };
}

TEST_F(SensorFaultTest, ThreeKeyframesOfFarDepthRemoveNothing) {
  const Outcome outcome = run(3, farDepth(9.9));
  print("9.9 m x 3", outcome, 3);
  ASSERT_GE(outcome.mapped.size(), 7u);
  expectNothingLost(outcome, "9.9 m x 3");
  EXPECT_GE(outcome.faults_found, 1);
}

TEST_F(SensorFaultTest, TenKeyframesOfFarDepthRemoveNothing) {
  const Outcome outcome = run(10, farDepth(9.9));
  print("9.9 m x 10", outcome, 10);
  expectNothingLost(outcome, "9.9 m x 10");
  EXPECT_GE(outcome.faults_found, 5);
}

TEST_F(SensorFaultTest, ThirtyKeyframesAtFiveMetresRemoveNothing) {
  const Outcome outcome = run(30, farDepth(5.0));
  print("5 m x 30", outcome, 30);
  expectNothingLost(outcome, "5 m x 30");
  EXPECT_GE(outcome.faults_found, 15);
}

// Three keyframes whose images (colour, depth, detections) are those half a lap further on, at
// the poses of these frames: a SLAM that lost track for a moment.
TEST_F(SensorFaultTest, ASlamGlitchRemovesNoRealObject) {
  const Outcome outcome = run(
      3,
      [this](int lap_frame, RgbdFrame* frame, std::vector<Detection2D>* detections) {
        RgbdFrame elsewhere;
        const int other = (lap_frame + test::kFramesPerLap / 2) % test::kFramesPerLap;
        test::renderKeyframe(room_, other, frame->index, &elsewhere, detections);
        elsewhere.T_W_D = frame->T_W_D;
        elsewhere.stamp_s = frame->stamp_s;
        elsewhere.name = frame->name;
        *frame = elsewhere;
      },
      test::kFramesPerLap);
  print("SLAM glitch x 3", outcome, 3);
  expectNothingLost(outcome, "SLAM glitch");
}

}  // namespace
}  // namespace mvod
