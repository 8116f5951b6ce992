// evaluate: scores an objects.json against ground truth (Sec. 4.1). Per class: AP of object
// segmentation by the IoU of voxelised point sets (match at IoU >= 0.5, VOC all-point AP; the
// paper's Tables 1 and 2) and oriented-box AP at 3D IoU 0.25 and 0.5. Prints a Markdown table.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "cli_options.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/evaluation/map_plot.h"
#include "multiview_object_detection/evaluation/object_matches.h"
#include "multiview_object_detection/io/json_io.h"

namespace fs = std::filesystem;
namespace cli = mvod::cli;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;  // an input cannot be read, or an output cannot be written
constexpr int kExitUsage = 2;    // bad arguments

const char* const kUsage =
    "usage: evaluate --objects objects.json --ground-truth PATH [options]\n"
    "       evaluate --objects A.json --ground-truth A --objects B.json --ground-truth B ...\n"
    "       evaluate --objects objects.json --plot map.png        (no ground truth: plot only)\n"
    "\n"
    "Per-class AP of the detected objects against ground truth: segmentation AP\n"
    "(3D IoU of voxelised point sets >= 0.5, VOC all-point AP, the paper's Sec. 4.1)\n"
    "and oriented-box AP at 3D IoU 0.25 and 0.5; means over the ground-truth classes.\n"
    "\n"
    "PATH: a synthetic ground_truth.json or the dataset folder holding it (boxes;\n"
    "their surface is the ground-truth cloud) or a SceneNN sequence: the <id>\n"
    "folder with <id>.ply and <id>.xml, or the .ply itself.\n"
    "Predicted clouds: the fused cloud stored in objects.json (written with clouds),\n"
    "or object_<id>_<class>_fused.ply in --clouds DIR (offline_detection\n"
    "--save-clouds). A prediction without a cloud segments the ground-truth points\n"
    "inside its box: a proxy; save the clouds for the paper's metric.\n"
    "Several --objects/--ground-truth pairs (and --clouds, one per pair or none) are\n"
    "pooled into one table, as PASCAL VOC pools images: per class, predictions of\n"
    "every scene are ranked together and #GT adds up.\n"
    "\n"
    "options:\n"
    "  --objects FILE       objects.json to score (required; repeat for more scenes)\n"
    "  --ground-truth PATH  ground truth (required unless only --plot; one per --objects)\n"
    "  --clouds DIR         folder of object_<id>_<class>_fused.ply clouds\n"
    "  --plot FILE          bird's-eye PNG of the (first) scene: detected boxes over the\n"
    "                       ground truth (or over their own clouds without ground truth)\n"
    "  --plot-region X0,Y0,X1,Y1\n"
    "                       only this part of the plot (m, in its grid's coordinates: a\n"
    "                       table top), 1600 px on its longer side, grid 0.1 m when that\n"
    "                       side is at most 3 m\n"
    "  --voxel-size M       voxel of the segmentation IoU, metres (default: 0.05)\n"
    "  --up AXIS            world up: x, y, z, -x, -y, -z or auto (default: auto =\n"
    "                       y for SceneNN, whose meshes are y-up; for .json the \"up\"\n"
    "                       the file states, else z)\n"
    "  --markdown FILE      also write the table as Markdown\n"
    "  --csv FILE           also write the table as CSV (AP as fractions)\n"
    "  --per-object FILE    Markdown, object by object (first scene): the map object each\n"
    "                       annotated object became (best same-class box IoU), its box IoU\n"
    "                       and centre error, and the map objects of annotated classes\n"
    "                       that match none (IoU < 0.25)\n"
    "  --help               this text\n"
    "\n"
    "exit status: 0 ok, 1 an input cannot be read or an output written, 2 bad arguments\n";

struct Options {
  std::vector<std::string> objects;
  std::vector<std::string> ground_truth;
  std::vector<std::string> clouds;
  std::string plot;
  std::string markdown;
  std::string csv;
  std::string per_object;
  std::string up = "auto";
  double voxel_size_m = 0.05;
  Eigen::AlignedBox2d plot_region;  // empty: the whole plot
};

// "X0,Y0,X1,Y1" with X0 < X1 and Y0 < Y1, all finite.
bool parseRegion(const std::string& text, Eigen::AlignedBox2d* region) {
  double v[4];
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3], &tail) != 4) {
    return false;
  }
  for (const double x : v) {
    if (!std::isfinite(x)) return false;
  }
  if (!(v[0] < v[2] && v[1] < v[3])) return false;
  *region = Eigen::AlignedBox2d(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
  return true;
}

bool parseAxis(const std::string& text, Eigen::Vector3d* axis) {
  const bool negative = !text.empty() && text[0] == '-';
  const std::string name = negative ? text.substr(1) : text;
  Eigen::Vector3d v;
  if (name == "x") {
    v = Eigen::Vector3d::UnitX();
  } else if (name == "y") {
    v = Eigen::Vector3d::UnitY();
  } else if (name == "z") {
    v = Eigen::Vector3d::UnitZ();
  } else {
    return false;
  }
  *axis = negative ? Eigen::Vector3d(-v) : v;
  return true;
}

// What is missing or inconsistent after parsing, "" when nothing.
std::string checkArguments(const Options& options) {
  if (options.objects.empty()) return "--objects is required";
  if (options.ground_truth.empty()) {
    if (options.plot.empty()) return "--ground-truth is required";
    if (options.objects.size() > 1) return "several --objects need one --ground-truth each";
  } else if (options.ground_truth.size() != options.objects.size()) {
    return "give one --ground-truth per --objects (" + std::to_string(options.objects.size()) +
           " --objects, " + std::to_string(options.ground_truth.size()) + " --ground-truth)";
  }
  if (!options.clouds.empty() && options.clouds.size() != options.objects.size()) {
    return "give --clouds once per --objects, or not at all";
  }
  return "";
}

// -1 when the arguments are fine, else the exit status (usage printed; 0 for --help).
int parseArguments(int argc, char** argv, Options* options) {
  CLI::App app;
  cli::setUp(&app);
  for (const auto& [name, list] : {std::make_pair("--objects", &options->objects),
                                   std::make_pair("--ground-truth", &options->ground_truth),
                                   std::make_pair("--clouds", &options->clouds)}) {
    cli::addValue(&app, name, [name = std::string(name), list](const std::string& text) {
      if (text.empty()) return name + " needs a value";
      list->push_back(text);
      return std::string();
    });
  }
  for (const auto& [name, value] :
       {std::make_pair("--plot", &options->plot), std::make_pair("--markdown", &options->markdown),
        std::make_pair("--csv", &options->csv),
        std::make_pair("--per-object", &options->per_object)}) {
    cli::addText(&app, name, value, std::string(name) + " needs a value");
  }
  cli::addValue(&app, "--up", [options](const std::string& text) {
    Eigen::Vector3d axis;
    if (text.empty()) return std::string("--up needs a value");
    if (text != "auto" && !parseAxis(text, &axis)) {
      return std::string("--up must be x, y, z, -x, -y, -z or auto");
    }
    options->up = text;
    return std::string();
  });
  cli::addValue(&app, "--plot-region", [options](const std::string& text) {
    if (!parseRegion(text, &options->plot_region)) {
      return std::string("--plot-region needs X0,Y0,X1,Y1 (m) with X0 < X1 and Y0 < Y1");
    }
    return std::string();
  });
  cli::addNumber(
      &app, "--voxel-size", &options->voxel_size_m, [](double v) { return v > 0.0; },
      "--voxel-size needs a number > 0 (metres)");
  const int parsed = cli::parse(&app, argc, argv, "evaluate", kUsage);
  if (parsed >= 0) return parsed;
  const std::string error = checkArguments(*options);
  return error.empty() ? -1 : cli::usageError("evaluate", error, kUsage);
}

bool endsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

constexpr int kContinue = -1;  // a phase of main() went through

// --up auto on .json ground truth: the "up" the files state (each the same), else z.
int stateUp(const std::vector<std::string>& paths, Eigen::Vector3d* up_W) {
  int stated = 0;
  for (const std::string& path : paths) {
    Eigen::Vector3d up;
    bool found = false;
    const mvod::Status read = mvod::readGroundTruthUp(path, &up, &found);
    if (!read) {
      std::cerr << "evaluate: " << read.message() << "\n";
      return kExitFailure;
    }
    if (!found) continue;
    if (stated > 0 && (up - *up_W).norm() > 1e-6) {
      std::cerr << "evaluate: the ground-truth files state different \"up\" vectors: give --up\n";
      return kExitFailure;
    }
    *up_W = up;
    ++stated;
  }
  if (stated > 0 && stated < static_cast<int>(paths.size())) {
    std::cerr << "evaluate: some ground-truth files state an \"up\" and some do not: give --up\n";
    return kExitFailure;
  }
  return kContinue;
}

// A synthetic dataset folder holds its ground_truth.json (the path becomes it); a SceneNN folder
// holds <id>.ply/.xml. The world's up: --up, else z for .json and y for SceneNN (not mixed).
int resolveGroundTruth(Options* options, mvod::EvaluationOptions* evaluation) {
  std::error_code fs_error;
  for (std::string& path : options->ground_truth) {
    if (!fs::exists(path, fs_error)) {
      std::cerr << "evaluate: " << path << ": no such file or folder\n";
      return kExitFailure;
    }
    if (fs::is_directory(path, fs_error) &&
        fs::is_regular_file(fs::path(path) / "ground_truth.json", fs_error)) {
      path = (fs::path(path) / "ground_truth.json").string();
    }
  }
  const bool synthetic =
      options->ground_truth.empty() || endsWith(options->ground_truth.front(), ".json");
  for (const std::string& path : options->ground_truth) {
    if (endsWith(path, ".json") != synthetic && options->up == "auto") {
      std::cerr << "evaluate: the scenes mix synthetic (.json, z-up) and SceneNN (y-up) ground "
                   "truth: give --up\n";
      return kExitUsage;
    }
  }
  evaluation->voxel_size_m = options->voxel_size_m;
  if (options->up == "auto") {
    evaluation->up_W = synthetic ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
    if (synthetic && stateUp(options->ground_truth, &evaluation->up_W) != kContinue) {
      return kExitUsage;
    }
  } else {
    parseAxis(options->up, &evaluation->up_W);
  }
  return kContinue;
}

struct SceneCounts {
  size_t ground_truth = 0;
  std::vector<std::string> skipped_ground_truth;  // "<file>: <label>: <why>"
  size_t predictions = 0;
  int with_clouds = 0;
};

// Scene k's ground truth (when given) and predictions.
int loadScene(const Options& options, size_t k, const mvod::EvaluationOptions& evaluation,
              mvod::EvaluationScene* scene, SceneCounts* counts) {
  if (!options.ground_truth.empty()) {
    const std::string& path = options.ground_truth[k];
    std::vector<std::string> skipped;
    const mvod::Status loaded =
        endsWith(path, ".json")
            ? mvod::loadSyntheticGroundTruth(path, evaluation.surface_spacing_m, evaluation.up_W,
                                             &scene->ground_truth)
            : mvod::loadSceneNNGroundTruth(path, evaluation.up_W, &scene->ground_truth, &skipped);
    if (!loaded) {
      std::cerr << "evaluate: " << loaded.message() << "\n";
      return kExitFailure;
    }
    for (const std::string& label : skipped) {
      counts->skipped_ground_truth.push_back(path + ": " + label);
    }
  }
  int clouds = 0;
  const mvod::Status read = mvod::loadPredictions(
      options.objects[k], options.clouds.empty() ? std::string() : options.clouds[k],
      &scene->predictions, &clouds);
  if (!read) {
    std::cerr << "evaluate: " << read.message() << "\n";
    return kExitFailure;
  }
  counts->with_clouds += clouds;
  counts->ground_truth += scene->ground_truth.size();
  counts->predictions += scene->predictions.size();
  return kContinue;
}

// --plot: the first scene from above. False when it cannot be written.
bool writePlot(const std::string& path, const mvod::EvaluationScene& scene,
               const Eigen::Vector3d& up_W, const Eigen::AlignedBox2d& region) {
  mvod::BirdsEyeConfig config;
  config.region = region;
  if (!region.isEmpty() && region.sizes().maxCoeff() <= 3.0) config.grid_spacing_m = 0.1;
  const cv::Mat image = mvod::drawBirdsEyeMap(scene.ground_truth, scene.predictions, up_W, config);
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    std::cerr << "evaluate: " << path << ": " << e.what() << "\n";
  }
  if (!written) {
    std::cerr << "evaluate: cannot write " << path << "\n";
    return false;
  }
  std::fprintf(stderr, "wrote %s\n", path.c_str());
  return true;
}

// --per-object: the first scene object by object, and a line on stderr.
bool writePerObject(const std::string& path, const mvod::EvaluationScene& scene,
                    const Eigen::Vector3d& up_W) {
  const mvod::ObjectMatches matches =
      mvod::matchObjects(scene.ground_truth, scene.predictions, up_W);
  int matched = 0;
  for (const mvod::AnnotatedObjectMatch& m : matches.annotated) matched += m.box_iou >= 0.25;
  std::fprintf(stderr,
               "per object: %d of %zu annotated objects matched at box IoU >= 0.25; %zu map "
               "objects of annotated classes match none\n",
               matched, matches.annotated.size(), matches.unmatched_prediction_ids.size());
  const mvod::Status written =
      mvod::writeFileAtomic(path, mvod::objectMatchesToMarkdown(matches, scene.predictions));
  if (!written) {
    std::cerr << "evaluate: " << written.message() << "\n";
    return false;
  }
  std::fprintf(stderr, "wrote %s\n", path.c_str());
  return true;
}

// The table on stdout (and --markdown, --csv). False when a file cannot be written.
bool report(const Options& options, const mvod::EvaluationResult& result, const SceneCounts& counts,
            double voxel_size_m) {
  std::string markdown = mvod::evaluationToMarkdown(result);
  // Ground truth left out of the table is listed with the reason: two correctly placed cups must
  // not look like false objects of a room said to hold none.
  if (!counts.skipped_ground_truth.empty()) {
    markdown += "\nGround truth not evaluated (" +
                std::to_string(counts.skipped_ground_truth.size()) + "):\n\n";
    for (const std::string& label : counts.skipped_ground_truth) markdown += "- " + label + "\n";
  }
  std::fputs(markdown.c_str(), stdout);
  std::fprintf(stderr,
               "%zu scene(s): %zu ground-truth objects (%zu annotated ones not evaluated, listed "
               "below the table), %zu predictions (%d with clouds; the others segment the ground "
               "truth inside their box); voxel %.3f m\n",
               options.objects.size(), counts.ground_truth, counts.skipped_ground_truth.size(),
               counts.predictions, counts.with_clouds, voxel_size_m);
  bool all_written = true;
  for (const auto& [path, text] : {std::make_pair(options.markdown, markdown),
                                   std::make_pair(options.csv, mvod::evaluationToCsv(result))}) {
    if (path.empty()) continue;
    const mvod::Status written = mvod::writeFileAtomic(path, text);
    if (!written) {
      std::cerr << "evaluate: " << written.message() << "\n";
      all_written = false;
    }
  }
  return all_written;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  int status = parseArguments(argc, argv, &options);
  if (status != kContinue) return status;
  mvod::EvaluationOptions evaluation;
  if ((status = resolveGroundTruth(&options, &evaluation)) != kContinue) return status;
  std::vector<mvod::EvaluationScene> scenes(options.objects.size());
  SceneCounts counts;
  for (size_t k = 0; k < scenes.size(); ++k) {
    if ((status = loadScene(options, k, evaluation, &scenes[k], &counts)) != kContinue) {
      return status;
    }
  }
  int exit_code = kExitOk;
  if (!options.plot.empty() &&
      !writePlot(options.plot, scenes.front(), evaluation.up_W, options.plot_region)) {
    exit_code = kExitFailure;
  }
  if (options.ground_truth.empty()) return exit_code;
  if (!options.per_object.empty() &&
      !writePerObject(options.per_object, scenes.front(), evaluation.up_W)) {
    exit_code = kExitFailure;
  }
  const mvod::EvaluationResult result = mvod::evaluateScenes(std::move(scenes), evaluation);
  if (!report(options, result, counts, evaluation.voxel_size_m)) exit_code = kExitFailure;
  return exit_code;
}
