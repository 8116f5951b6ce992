// rostest (parameter_sweep.test): every parameter of the range table (parameter_ranges.h) set
// through the ROS parameter server, as a user's launch file or `rosparam set` would, at its bounds
// and just beyond. The node's own reader and check (getObjectDetectionConfigFromRosParam,
// isValid) refuse each value beyond with a message naming the parameter; each value at a bound is
// accepted, and for the mapper's parameters the mapper then maps two synthetic keyframes (their
// time is recorded, not asserted: timing goals live in the benchmarks).
#include <gtest/gtest.h>
#include <ros/package.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/ros/ros_params.h"
#include "test_node_common.h"

namespace mvod_test {
namespace {

using mvod::ParameterRange;

constexpr char kNamespace[] = "/sweep";

bool isCount(const ParameterRange& range) { return range.unit[0] == '\0'; }

// Sets `name` under kNamespace (an int for counts, as YAML would type it).
void setParam(const ParameterRange& range, double value) {
  ros::NodeHandle nh(kNamespace);
  if (isCount(range)) {
    nh.setParam(range.name, static_cast<int>(value));
  } else {
    nh.setParam(range.name, value);
  }
}

// The node's configuration read from kNamespace, as at start.
mvod::ObjectDetectionRosConfig readConfig(mvod::ParamErrors* errors) {
  ros::NodeHandle nh(kNamespace);
  mvod::ObjectDetectionRosConfig config = mvod::getObjectDetectionConfigFromRosParam(nh, errors);
  config.detector = "topic";  // no model files needed
  return config;
}

class ParameterSweepTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle(kNamespace).deleteParam("");
    ros::NodeHandle(kNamespace).setParam("gravity_down", std::vector<double>{0.0, 0.0, -1.0});
  }
  void TearDown() override { ros::NodeHandle(kNamespace).deleteParam(""); }
};

TEST_F(ParameterSweepTest, JustBeyondEachBoundTheStartIsRefusedNamingTheParameter) {
  for (const ParameterRange& range : mvod::parameterRanges()) {
    const double step = isCount(range) ? 1.0 : 1e-3 * std::max(range.min, 1e-3);
    for (const double value : {range.min - step, range.max + std::max(step, 1e-3 * range.max)}) {
      if (range.zero_is_off && value == 0.0) continue;
      SCOPED_TRACE(std::string(range.name) + " = " + std::to_string(value));
      SetUp();
      setParam(range, value);
      mvod::ParamErrors errors;
      const mvod::ObjectDetectionRosConfig config = readConfig(&errors);
      EXPECT_TRUE(errors.empty()) << errors.front();
      const mvod::Status status = config.isValid();
      EXPECT_FALSE(status.ok());
      EXPECT_NE(status.message().find(std::string(range.name) + " must be"), std::string::npos)
          << status.message();
    }
  }
}

TEST_F(ParameterSweepTest, AtEachBoundTheStartIsAcceptedAndTheMapperMaps) {
  mvod::ClassPriors priors;
  ASSERT_TRUE(mvod::ClassPriors::loadYaml(
                  ros::package::getPath("multiview_object_detection") + "/config/class_priors.yaml",
                  &priors)
                  .ok());
  SyntheticStream::Options options;
  options.num_frames = 2;
  const SyntheticStream stream(options);
  for (const ParameterRange& range : mvod::parameterRanges()) {
    for (const double value : {range.min, range.max}) {
      const std::string what = std::string(range.name) + " = " + std::to_string(value);
      SCOPED_TRACE(what);
      SetUp();
      setParam(range, value);
      // The seeds cannot be finer than the leaves (0.015 m, seeds 0.05 m by default): each
      // follows the other past the default.
      if (std::string(range.name) == "lccp/voxel_resolution_m") {
        ros::NodeHandle(kNamespace).setParam("lccp/seed_resolution_m", std::max(value, 0.05));
      }
      if (std::string(range.name) == "lccp/seed_resolution_m") {
        ros::NodeHandle(kNamespace).setParam("lccp/voxel_resolution_m", std::min(value, 0.015));
      }
      mvod::ParamErrors errors;
      const mvod::ObjectDetectionRosConfig config = readConfig(&errors);
      EXPECT_TRUE(errors.empty()) << errors.front();
      const mvod::Status status = config.isValid();
      ASSERT_TRUE(status.ok()) << status.message();
      if (std::string(range.name).find('/') == std::string::npos) continue;  // not the mapper's
      mvod::ObjectMapper mapper(config.mapperConfig(), priors);
      const ros::WallTime start = ros::WallTime::now();
      for (int i = 0; i < options.num_frames; ++i) {
        mvod::RgbdFrame frame;
        cv::Mat labels;
        stream.scene().render(i, &frame, &labels);
        mvod::KeyframeReport report;
        EXPECT_TRUE(
            mapper.processKeyframe(frame, stream.scene().detectionsFromLabels(labels, 50), &report)
                .ok());
      }
      const double ms = (ros::WallTime::now() - start).toSec() * 1000.0;
      std::printf("[ INFO     ] %-40s %8.1f ms for 2 keyframes, %zu objects\n", what.c_str(), ms,
                  mapper.database().size());
      RecordProperty(std::string(range.name) + (value == range.min ? "_min_ms" : "_max_ms"),
                     std::to_string(ms));
    }
  }
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_parameter_sweep");
}
