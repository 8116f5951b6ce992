// dataset_to_bag's command line: the options with their defaults, their checks and the usage text
// (CLI11 through cli_options.h).
#pragma once

#include <string>

#include "multiview_object_detection/datasets/trajectory.h"
#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"

namespace mvod {
namespace dataset_to_bag {

constexpr int kExitData = 1;
constexpr int kExitUsage = 2;
// --rate-hz: what a camera records at; a rate near 0 puts stamps past what ros::Time holds.
constexpr double kMinRateHz = 0.01;
constexpr double kMaxRateHz = 1000.0;
// Stamps stay below 2^31 s (2038-01-19): ros::Time holds 32 bits of seconds, and tools that read
// them as signed numbers only 31.
constexpr double kMaxStampS = 2147483648.0;

struct Options {
  std::string dataset_dir;
  std::string output_path;
  std::string format = "auto";
  std::string camera = "camera";
  std::string world_frame = "map";
  std::string pose_topic = "/orb_slam2_rgbd/pose";
  // 7-Scenes layout: the colour camera from outside the folder (offline_detection's options).
  std::string color_intrinsics;
  std::string depth_to_color;
  bool registered = false;
  TrajectoryOptions trajectory;  // --trajectory, --keyframes, --trajectory-world
  double rate_hz = 30.0;
  double time_offset_s = 1.0;
  long first = 0;
  long last = -1;        // -1 = no limit
  std::string detector;  // empty = no detections in the bag
  std::string detections_dir;
  std::string model_dir;
  std::string detections_topic = "/detections";
  bool lz4 = false;
  bool quiet = false;
};

// The detector's options (--detector, --detections, --model-dir).
BenchmarkSegmenterOptions segmenterOptions(const Options& options);

// -1 when the options are fine, else the exit status (usage printed; 0 for --help).
int parseOptions(int argc, char** argv, Options* options);

}  // namespace dataset_to_bag
}  // namespace mvod
