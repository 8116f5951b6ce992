#include "dataset_to_bag_options.h"

#include <cctype>
#include <functional>
#include <iostream>
#include <utility>

#include "cli_options.h"

namespace mvod {
namespace dataset_to_bag {
namespace {

const char kUsage[] =
    "Usage: dataset_to_bag --dataset DIR --output OUT.bag [options]\n"
    "  Converts a 7-Scenes-layout folder or a SceneNN sequence (image/, depth/, trajectory.log,\n"
    "  timestamp.txt, asus.ini) into a rosbag for replay.launch.\n"
    "Options:\n"
    "  --format auto|7scenes|scenenn  dataset layout (auto: trajectory.log or depth/ -> SceneNN,\n"
    "                                 camera-intrinsics.txt -> 7-Scenes) [auto]\n"
    "  --color-intrinsics FILE        7-Scenes layout: the colour camera's 3x3 K, instead of the\n"
    "                                 folder's color-intrinsics.txt (nothing written into a\n"
    "                                 read-only dataset)\n"
    "  --depth-to-color FILE          7-Scenes layout: T_C_D, 4x4 row-major, p_C = R p_D + t (a\n"
    "                                 depth camera point in the colour camera), instead of the\n"
    "                                 folder's depth-to-color.txt\n"
    "  --registered                   7-Scenes layout: colour and depth are one camera (the\n"
    "                                 folder's colour files are not read)\n"
    "  --trajectory FILE              a SLAM's poses instead of the dataset's (TUM format 't tx\n"
    "                                 ty tz qx qy qz qw', the colour camera to the SLAM's world,\n"
    "                                 t the frame's stamp); frames without one are left out\n"
    "  --keyframes FILE               only the frames at this TUM file's stamps, with its poses\n"
    "                                 (e.g. KeyFrameTrajectory.txt; the node with\n"
    "                                 keyframe_every_n 1 maps each)\n"
    "  --trajectory-world aligned|slam  aligned: the SLAM's world placed so that its first frame\n"
    "                                 has the dataset's pose; slam: as it is [aligned]\n"
    "  --camera NAME                  topic namespace and frame prefix [camera]\n"
    "  --world-frame FRAME            parent frame of the pose and TF [map]\n"
    "  --pose-topic TOPIC             [/orb_slam2_rgbd/pose]\n"
    "  --rate-hz HZ                   frame rate where the dataset has no time stamps (7-Scenes,\n"
    "                                 SceneNN without timestamp.txt), 0.01 to 1000 [30]\n"
    "  --time-offset S                added to every stamp (> 0: rosbag rejects time 0; every\n"
    "                                 stamp must stay below 2^31 s) [1]\n"
    "  --first N, --last N            only frames whose number is in [N, M] (inclusive; 7-Scenes\n"
    "                                 frame-NNNNNN, SceneNN imageNNNNN) [all]\n"
    "  --detector NAME                also record 2D detections of every frame as\n"
    "                                 InstanceDetections (replay with detector:=topic): files\n"
    "                                 (JSON + masks in --detections DIR), simulated (the\n"
    "                                 synthetic benchmark's label images), fastestdet, maskrcnn\n"
    "  --detections DIR               folder for files / simulated [the dataset folder]\n"
    "  --model-dir DIR                DNN model folder [$MVOD_MODEL_DIR]\n"
    "  --detections-topic TOPIC       [/detections]\n"
    "  --lz4                          compress the bag (LZ4)\n"
    "  --quiet                        no progress bar\n";

bool isValidGraphName(const std::string& name) {
  if (name.empty()) return false;
  size_t start = name[0] == '/' ? 1 : 0;
  if (start == name.size()) return false;
  while (start <= name.size()) {
    size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    if (end == start) return false;  // "//" or a trailing '/'
    if (!std::isalpha(static_cast<unsigned char>(name[start]))) return false;
    for (size_t i = start; i < end; ++i) {
      const unsigned char c = static_cast<unsigned char>(name[i]);
      if (!std::isalnum(c) && c != '_') return false;
    }
    start = end + 1;
  }
  return true;
}

int usageError(const std::string& message) {
  std::cerr << "dataset_to_bag: " << message << "\n" << kUsage;
  return kExitUsage;
}

}  // namespace

BenchmarkSegmenterOptions segmenterOptions(const Options& options) {
  BenchmarkSegmenterOptions segmenter;
  segmenter.detector = options.detector;
  segmenter.detections_dir =
      options.detections_dir.empty() ? options.dataset_dir : options.detections_dir;
  segmenter.model_dir = options.model_dir;
  return segmenter;
}

namespace {

// The options together: required ones, ROS names, the frame range, the detector.
int checkOptions(const Options* options) {
  if (options->dataset_dir.empty()) return usageError("--dataset is required");
  if (options->output_path.empty()) return usageError("--output is required");
  if (options->camera.empty() || options->world_frame.empty() || options->pose_topic.empty()) {
    return usageError("--camera, --world-frame and --pose-topic must not be empty");
  }
  // ROS graph names: segments of [A-Za-z][A-Za-z0-9_]* joined by single '/' (a bag with other
  // topic names cannot be subscribed to).
  const std::pair<const char*, const std::string*> names[] = {
      {"--camera", &options->camera},
      {"--pose-topic", &options->pose_topic},
      {"--detections-topic", &options->detections_topic},
      {"--world-frame", &options->world_frame}};
  for (const auto& name : names) {
    if (!isValidGraphName(*name.second)) {
      return usageError(std::string(name.first) + " '" + *name.second +
                        "' is not a valid ROS name: use letters, digits and '_', segments "
                        "separated by single '/', each starting with a letter");
    }
  }
  if (options->last >= 0 && options->last < options->first) {
    return usageError("--last " + std::to_string(options->last) + " is before --first " +
                      std::to_string(options->first));
  }
  if (!options->detector.empty()) {
    const Status valid = segmenterOptions(*options).isValid();
    if (!valid) return usageError(valid.message());
  } else if (!options->detections_dir.empty()) {
    return usageError("--detections needs --detector");
  }
  return -1;
}

// A number for which `valid` holds; the message names the text given.
void addNumber(CLI::App* app, const std::string& name, double* value,
               std::function<bool(double)> valid, const std::string& expected) {
  cli::addValue(app, name, [=](const std::string& text) {
    double parsed = 0.0;
    if (!cli::parseDouble(text, &parsed) || !valid(parsed)) {
      return name + " needs " + expected + ", not '" + text + "'";
    }
    *value = parsed;
    return std::string();
  });
}

// A frame number >= 0; the message names the text given.
void addFrameNumber(CLI::App* app, const std::string& name, long* value) {
  cli::addValue(app, name, [=](const std::string& text) {
    if (!cli::parseLong(text, 0, 999999999, value)) {
      return name + " needs a frame number >= 0, not '" + text + "'";
    }
    return std::string();
  });
}

void addOptions(CLI::App* app, Options* options) {
  for (const auto& [name, value] :
       {std::make_pair("--dataset", &options->dataset_dir),
        std::make_pair("--output", &options->output_path),
        std::make_pair("--detector", &options->detector),
        std::make_pair("--detections", &options->detections_dir),
        std::make_pair("--model-dir", &options->model_dir),
        std::make_pair("--camera", &options->camera),
        std::make_pair("--world-frame", &options->world_frame),
        std::make_pair("--pose-topic", &options->pose_topic),
        std::make_pair("--color-intrinsics", &options->color_intrinsics),
        std::make_pair("--depth-to-color", &options->depth_to_color),
        std::make_pair("--trajectory", &options->trajectory.trajectory),
        std::make_pair("--keyframes", &options->trajectory.keyframes)}) {
    cli::addText(app, name, value);
  }
  cli::addValue(app, "--trajectory-world", [options](const std::string& text) {
    if (text != "aligned" && text != "slam") {
      return "--trajectory-world must be aligned or slam, not '" + text + "'";
    }
    options->trajectory.align_first_frame = text == "aligned";
    return std::string();
  });
  cli::addValue(app, "--format", [options](const std::string& text) {
    if (text != "auto" && text != "7scenes" && text != "scenenn") {
      return "--format must be auto, 7scenes or scenenn, not '" + text + "'";
    }
    options->format = text;
    return std::string();
  });
  cli::addText(app, "--detections-topic", &options->detections_topic,
               "--detections-topic must not be empty");
  addNumber(
      app, "--rate-hz", &options->rate_hz,
      [](double v) { return v >= kMinRateHz && v <= kMaxRateHz; }, "a rate in [0.01, 1000] Hz");
  addNumber(
      app, "--time-offset", &options->time_offset_s,
      [](double v) { return v >= 0.0 && v < kMaxStampS; }, "a number in [0, 2^31) s");
  addFrameNumber(app, "--first", &options->first);
  addFrameNumber(app, "--last", &options->last);
  cli::addFlag(app, "--lz4", &options->lz4);
  cli::addFlag(app, "--registered", &options->registered);
  cli::addFlag(app, "--quiet", &options->quiet);
}

}  // namespace

int parseOptions(int argc, char** argv, Options* options) {
  CLI::App app;
  cli::setUp(&app);
  addOptions(&app, options);
  const int parsed = cli::parse(&app, argc, argv, "dataset_to_bag", kUsage, "\n");
  if (parsed >= 0) return parsed;
  return checkOptions(options);
}

}  // namespace dataset_to_bag
}  // namespace mvod
