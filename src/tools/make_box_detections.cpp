// make_box_detections: box-only detections from ground-truth 3D boxes, one
// <frame>.json per frame in FileInstanceSegmenter's format, for offline_detection --detector files.
// What a perfect box detector would report: it judges the 3D cut and fusion on real depth and poses
// (e.g. the hand-annotated redkitchen boxes in test/data) without a detector's own errors.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "cli_args.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/box_detections.h"
#include "multiview_object_detection/evaluation/evaluation.h"

namespace fs = std::filesystem;

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

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
    "  --help               this text\n"
    "\n"
    "exit status: 0 ok, 1 an input cannot be read or an output written, 2 bad arguments\n";

}  // namespace

int main(int argc, char** argv) {
  std::string dataset_dir, truth_path, output_dir;
  long every = 1;
  double min_inside = 0.1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (arg == "--dataset" && has_value) {
      dataset_dir = argv[++i];
    } else if (arg == "--ground-truth" && has_value) {
      truth_path = argv[++i];
    } else if (arg == "--output" && has_value) {
      output_dir = argv[++i];
    } else if (arg == "--every" && has_value) {
      if (!mvod::cli::parseLong(argv[++i], 1, 100000, &every)) {
        std::cerr << "make_box_detections: --every needs an integer >= 1\n" << kUsage;
        return kExitUsage;
      }
    } else if (arg == "--min-inside" && has_value) {
      if (!mvod::cli::parseDouble(argv[++i], &min_inside) ||
          !(min_inside >= 0 && min_inside <= 1)) {
        std::cerr << "make_box_detections: --min-inside needs a number in [0, 1]\n" << kUsage;
        return kExitUsage;
      }
    } else {
      std::cerr << "make_box_detections: unknown or incomplete option '" << arg << "'\n" << kUsage;
      return kExitUsage;
    }
  }
  if (dataset_dir.empty() || truth_path.empty() || output_dir.empty()) {
    std::cerr << "make_box_detections: --dataset, --ground-truth and --output are required\n"
              << kUsage;
    return kExitUsage;
  }
  mvod::DatasetSource dataset;
  mvod::Status status = mvod::openDatasetSource(dataset_dir, "auto", &dataset);
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
  std::error_code error;
  fs::create_directories(output_dir, error);
  mvod::BoxDetectionOptions options;
  options.min_inside_fraction = min_inside;
  int frames = 0;
  int boxes = 0;
  for (const int index : dataset.indices) {
    if (index % every != 0) continue;
    mvod::RgbdFrame frame;
    status = dataset.load(index, &frame);
    if (!status) {
      std::cerr << "make_box_detections: " << status.message() << " (frame skipped)\n";
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
  return 0;
}
