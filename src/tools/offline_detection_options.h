// offline_detection's command line: the options with their defaults, their checks and the usage
// text (CLI11 through cli_options.h).
#pragma once

#include <limits>
#include <string>

#include "multiview_object_detection/datasets/trajectory.h"

namespace offline_detection {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;  // the dataset (or another input) cannot be opened or written
constexpr int kExitUsage = 2;    // bad arguments

// The options as parsed; an empty string or NaN: the method's default.
struct Options {
  std::string dataset;
  std::string format = "auto";
  std::string color_intrinsics;  // the colour camera apart from the dataset folder
  std::string depth_to_color;
  bool registered = false;
  mvod::TrajectoryOptions trajectory;  // --trajectory, --keyframes, --trajectory-world
  std::string detections;
  std::string detector = "files";
  std::string model_dir;
  double score_threshold = std::numeric_limits<double>::quiet_NaN();  // the detector's own
  double nms_threshold = std::numeric_limits<double>::quiet_NaN();    // the detector's own
  double mask_threshold = std::numeric_limits<double>::quiet_NaN();   // the detector's own
  std::string yolo_seg_model;
  std::string backend = "cpu";
  int max_detections = 100;
  int threads = 0;
  int every = 10;
  int first = std::numeric_limits<int>::min();
  int last = std::numeric_limits<int>::max();
  std::string output = "objects.json";
  std::string output_frame = "gravity_aligned";
  std::string save_clouds;
  std::string overlays;
  std::string save_detections;
  std::string timings;
  double min_probability = std::numeric_limits<double>::quiet_NaN();  // the detector's own
  std::string priors;
  bool no_filter = false;
  bool no_lccp = false;
  bool single_frame = false;
  bool paper = false;
  bool no_floor = false;
  bool no_amodal = false;
  bool no_existence = false;
  bool no_history = false;
  double history_mb = -1.0;  // the history's bound (MB); < 0: the default
  bool every_pixel = false;
  double existence_remove_below = std::numeric_limits<double>::quiet_NaN();
  std::string selection;
  std::string fusion;
  std::string outlier_removal;
  std::string lccp_implementation;
  std::string normal_estimation;
  bool estimate_gravity = false;
  bool simulated_perfect = false;
  long simulated_seed = 1;
  std::string corrected_poses;
  int correct_at = std::numeric_limits<int>::max();
  bool quiet = false;
  bool verbose = false;  // every dropped detection's line (default: counted by reason)
};

// -1 when the arguments are fine, else the exit status (usage printed; 0 for --help).
int parseArguments(int argc, char** argv, Options* options);

}  // namespace offline_detection
