// make_synthetic_dataset: writes the default synthetic scene (SyntheticScene::makeDefault) as a
// dataset in the 7-Scenes layout, optionally with perfect instance detections, plus
// ground_truth.json with the true boxes.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <string>

#include "cli_args.h"
#include "multiview_object_detection/synthetic_scene.h"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;  // a folder or file cannot be written
constexpr int kExitUsage = 2;    // bad arguments

const char* const kUsage =
    "usage: make_synthetic_dataset --output DIR [options]\n"
    "\n"
    "Renders the synthetic room (a dining table with four chairs, a couch, a tv on a stand, cups "
    "and\n"
    "a book) to RGB-D frames in the 7-Scenes layout (frame-NNNNNN.color.png, .depth.png, "
    ".pose.txt,\n"
    "camera-intrinsics.txt, gravity-direction.txt) and writes ground_truth.json with the true "
    "boxes.\n"
    "\n"
    "options:\n"
    "  --output DIR       dataset folder to write (required)\n"
    "  --detections DIR   also write perfect instance detections (JSON + mask PNGs) there\n"
    "  --frames N         number of frames, one lap around the room (default: 60)\n"
    "  --seed S           scene variation seed, >= 0 (default: 1)\n"
    "  --noise K          depth noise sigma = K * z^2 (m), >= 0 (default: 0)\n"
    "  --holes F          fraction of random invalid depth pixels in [0, 1) (default: 0)\n"
    "  --help             this text\n"
    "\n"
    "exit status: 0 ok, 1 a folder or file cannot be written, 2 bad arguments\n";

struct Options {
  std::string output;
  std::string detections;
  mvod::SyntheticSceneConfig scene;
  bool help = false;
};

// Returns an empty string on success, else what is wrong.
std::string parseArguments(int argc, char** argv, Options* options) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    std::string text;
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      options->help = true;
      continue;
    }
    if (arg != "--output" && arg != "--detections" && arg != "--frames" && arg != "--seed" &&
        arg != "--noise" && arg != "--holes") {
      return "unknown argument '" + arg + "'";
    }
    if (!has_value) return arg + " needs a value";
    text = argv[++i];
    if (arg == "--output" || arg == "--detections") {
      if (text.empty()) return arg + " needs a value";
      (arg == "--output" ? options->output : options->detections) = text;
    } else if (arg == "--frames") {
      long frames = 0;
      if (!mvod::cli::parseLong(text, 1, 1000000, &frames)) return "--frames needs an integer >= 1";
      options->scene.num_frames = static_cast<int>(frames);
    } else if (arg == "--seed") {
      long seed = 0;
      if (!mvod::cli::parseLong(text, 0, std::numeric_limits<unsigned int>::max(), &seed)) {
        return "--seed needs an integer >= 0";
      }
      options->scene.seed = static_cast<unsigned int>(seed);
    } else if (arg == "--noise") {
      if (!mvod::cli::parseDouble(text, &options->scene.depth_noise_m_per_m2) ||
          options->scene.depth_noise_m_per_m2 < 0.0) {
        return "--noise needs a number >= 0";
      }
    } else {  // --holes
      if (!mvod::cli::parseDouble(text, &options->scene.hole_fraction) ||
          options->scene.hole_fraction < 0.0 || options->scene.hole_fraction >= 1.0) {
        return "--holes needs a number in [0, 1)";
      }
    }
  }
  if (!options->help && options->output.empty()) return "--output is required";
  return std::string();
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const std::string error = parseArguments(argc, argv, &options);
  if (options.help && error.empty()) {
    std::cout << kUsage;
    return kExitOk;
  }
  if (!error.empty()) {
    std::cerr << "make_synthetic_dataset: " << error << "\n\n" << kUsage;
    return kExitUsage;
  }

  const mvod::SyntheticScene scene = mvod::SyntheticScene::makeDefault(options.scene);
  const mvod::Status written = scene.writeSevenScenes(options.output, options.detections);
  if (!written) {
    std::cerr << "make_synthetic_dataset: " << written.message() << "\n";
    return kExitFailure;
  }

  const mvod::SyntheticSceneConfig& config = scene.config();
  std::printf("wrote %d frames (%dx%d, depth noise %.4g m/m^2, holes %.3g) to %s\n",
              config.num_frames, config.K.width, config.K.height, config.depth_noise_m_per_m2,
              config.hole_fraction, options.output.c_str());
  if (!options.detections.empty()) {
    std::printf("perfect detections in %s\n", options.detections.c_str());
  }
  std::printf("%zu objects (ground_truth.json):\n", scene.objects().size());
  std::printf("  %-14s %-24s %-20s %s\n", "class", "centre (m)", "size (m)", "yaw (deg)");
  for (const mvod::SyntheticObject& object : scene.objects()) {
    const Eigen::Vector3d& c = object.box.center_m;
    const Eigen::Vector3d& s = object.box.size_m;
    const double yaw_deg =
        std::atan2(object.box.rotation(1, 0), object.box.rotation(0, 0)) * 180.0 / M_PI;
    std::printf("  %-14s (%5.2f, %5.2f, %5.2f)   (%4.2f, %4.2f, %4.2f)   %6.1f\n",
                object.class_name.c_str(), c.x(), c.y(), c.z(), s.x(), s.y(), s.z(), yaw_deg);
  }
  return kExitOk;
}
