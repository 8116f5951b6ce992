// make_box_detections: box-only detections from ground-truth 3D boxes, one
// <frame>.json per frame in FileInstanceSegmenter's format, for offline_detection --detector files.
// What a perfect box detector would report: it judges the 3D cut and fusion on real depth and poses
// (e.g. the hand-annotated redkitchen boxes in test/data) without a detector's own errors.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_options.h"
#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/box_detections.h"
#include "multiview_object_detection/evaluation/evaluation.h"

namespace fs = std::filesystem;

namespace {

namespace cli = mvod::cli;

constexpr int kExitFailure = 1;

const char* const kUsage =
    "usage: make_box_detections --dataset DIR --ground-truth FILE --output DIR [options]\n"
    "\n"
    "Projects each ground-truth box (a ground_truth.json with boxes, world frame of the dataset)\n"
    "into the colour image of every frame and writes the 2D boxes of the visible ones as\n"
    "<frame>.json (box-only detections, score 0.9).\n"
    "\n"
    "options:\n"
    "  --every N            only every N-th frame (default: 1)\n"
    "  --min-inside F       share of a projected box that must lie inside the image (default 0.1)\n"
    "  --color-intrinsics FILE, --depth-to-color FILE, --registered\n"
    "                       the colour camera apart from the dataset folder (as "
    "offline_detection)\n"
    "  --classes LIST       only the ground truth of these classes, comma-separated (default:\n"
    "                       all; e.g. \"dining table,chair\")\n"
    "  --help               this text\n"
    "\n"
    "exit status: 0 ok, 1 an input cannot be read or an output written, 2 bad arguments\n";

struct Options {
  std::string dataset_dir;
  std::string truth_path;
  std::string output_dir;
  long every = 1;
  double min_inside = 0.1;
  std::string classes;
  mvod::ColorCameraFiles camera;
};

// --classes: the ground truth of the listed classes only (canonical names; all when empty).
void keepClasses(const std::string& list, std::vector<mvod::GroundTruthObject>* truth) {
  if (list.empty()) return;
  std::set<std::string> wanted;
  std::stringstream stream(list);
  for (std::string name; std::getline(stream, name, ',');) {
    wanted.insert(mvod::canonicalClassName(name));
  }
  truth->erase(std::remove_if(truth->begin(), truth->end(),
                              [&](const mvod::GroundTruthObject& object) {
                                return !wanted.count(object.class_name);
                              }),
               truth->end());
}

// -1 when the arguments are fine, else the exit status (usage printed; 0 for --help).
int parseArguments(int argc, char** argv, Options* options) {
  CLI::App app;
  cli::setUp(&app);
  cli::addText(&app, "--dataset", &options->dataset_dir);
  cli::addText(&app, "--ground-truth", &options->truth_path);
  cli::addText(&app, "--output", &options->output_dir);
  cli::addText(&app, "--classes", &options->classes);
  cli::addText(&app, "--color-intrinsics", &options->camera.color_intrinsics);
  cli::addText(&app, "--depth-to-color", &options->camera.depth_to_color);
  cli::addFlag(&app, "--registered", &options->camera.registered);
  cli::addInteger(&app, "--every", 1, 100000, &options->every, "--every needs an integer >= 1");
  cli::addNumber(
      &app, "--min-inside", &options->min_inside, [](double f) { return f >= 0 && f <= 1; },
      "--min-inside needs a number in [0, 1]");
  const int parsed = cli::parse(&app, argc, argv, "make_box_detections", kUsage, "\n");
  if (parsed >= 0) return parsed;
  if (options->dataset_dir.empty() || options->truth_path.empty() || options->output_dir.empty()) {
    return cli::usageError("make_box_detections",
                           "--dataset, --ground-truth and --output are required", kUsage, "\n");
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  Options args;
  const int parsed = parseArguments(argc, argv, &args);
  if (parsed >= 0) return parsed;
  const std::string& dataset_dir = args.dataset_dir;
  const std::string& truth_path = args.truth_path;
  const std::string& output_dir = args.output_dir;
  const long every = args.every;
  const double min_inside = args.min_inside;
  mvod::DatasetSource dataset;
  mvod::Status status = mvod::openDatasetSource(dataset_dir, "auto", &dataset, args.camera);
  if (!status) {
    std::cerr << "make_box_detections: " << status.message() << "\n";
    return kExitFailure;
  }
  for (const std::string& warning : dataset.warnings) {
    std::cerr << "make_box_detections: warning: " << warning << "\n";
  }
  const Eigen::Vector3d up =
      dataset.has_gravity ? Eigen::Vector3d(-dataset.gravity_down_W) : Eigen::Vector3d::UnitZ();
  std::vector<mvod::GroundTruthObject> truth;
  status = mvod::loadSyntheticGroundTruth(truth_path, 0.05, up.normalized(), &truth);
  if (!status) {
    std::cerr << "make_box_detections: " << status.message() << "\n";
    return kExitFailure;
  }
  keepClasses(args.classes, &truth);
  std::error_code error;
  fs::create_directories(output_dir, error);
  mvod::BoxDetectionOptions options;
  options.min_inside_fraction = min_inside;
  int frames = 0;
  int boxes = 0;
  int skipped = 0;
  for (const int index : dataset.indices) {
    if (index % every != 0) continue;
    mvod::RgbdFrame frame;
    status = dataset.load(index, &frame);
    if (!status) {
      std::cerr << "make_box_detections: " << status.message() << " (frame skipped)\n";
      ++skipped;
      continue;
    }
    const std::vector<mvod::Detection2D> detections =
        mvod::boxDetectionsFromGroundTruth(truth, frame, options);
    const fs::path path = fs::path(output_dir) / (dataset.frame_name(index) + ".json");
    std::ofstream out(path);
    out << mvod::boxDetectionsToJson(detections);
    if (!out) {
      std::cerr << "make_box_detections: cannot write " << path.string() << "\n";
      return kExitFailure;
    }
    ++frames;
    boxes += static_cast<int>(detections.size());
  }
  std::cout << "make_box_detections: " << boxes << " boxes in " << frames << " frames -> "
            << output_dir << "\n";
  if (skipped > 0) {
    std::cerr << "make_box_detections: " << skipped << " frame(s) could not be read (above)\n";
    return kExitFailure;
  }
  return 0;
}
