// offline_detection: the whole pipeline over a dataset folder in the 7-Scenes layout or a SceneNN
// sequence, no ROS master needed. Every N-th frame is a keyframe: load -> detect ->
// ObjectMapper::processKeyframe; at the end the database is refined (Sec. 3.5), printed, and
// written to objects.json.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_options.h"
#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/ply_writer.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace fs = std::filesystem;
namespace cli = mvod::cli;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;  // the dataset (or another input) cannot be opened or written
constexpr int kExitUsage = 2;    // bad arguments

const char* const kUsage =
    "usage: offline_detection --dataset DIR [options]\n"
    "\n"
    "Runs the multi-view 3D object detection pipeline over a folder in the 7-Scenes layout\n"
    "(frame-NNNNNN.{color.jpg|color.png,depth.png,pose.txt}, camera-intrinsics.txt, optional\n"
    "color-intrinsics.txt and gravity-direction.txt) or a SceneNN sequence (image/, depth/,\n"
    "trajectory.log, optional timestamp.txt and asus.ini; y-up world). No ROS master is needed.\n"
    "\n"
    "options:\n"
    "  --dataset DIR          dataset folder (required)\n"
    "  --format NAME          auto | 7scenes | scenenn (default: auto, from the folder's files)\n"
    "  --detector NAME        files | simulated | fastestdet | maskrcnn (default: files)\n"
    "  --detections DIR       files: folder of <frame>.json detections (required);\n"
    "                         simulated: the sequence with label/ and <id>.xml (default: "
    "--dataset)\n"
    "  --model-dir DIR        folder of the DNN model files (default: $MVOD_MODEL_DIR)\n"
    "  --simulated-seed S     simulated: seed of its failures (default: 1)\n"
    "  --simulated-perfect    simulated: no failures (exact masks and classes, score 0.85)\n"
    "  --score-threshold S    detector score below which detections are not reported (default: "
    "0.5)\n"
    "  --backend NAME         cpu | cuda: where OpenCV DNN runs the detector (default: cpu)\n"
    "  --max-detections N     files: at most N detections per frame, the highest scores\n"
    "                         (default: 100)\n"
    "  --threads N            threads for a keyframe's detections (0 = one per core) (default: 0)\n"
    "  --every N              every N-th frame is a keyframe (default: 10)\n"
    "  --first N, --last N    only frames with index in [first, last]\n"
    "  --output FILE          objects.json to write (default: objects.json)\n"
    "  --output-frame F       gravity_aligned: the table, objects.json and the clouds in a frame\n"
    "                         with z up and the floor at z = 0 (its pose in the dataset's world\n"
    "                         frame is in objects.json; evaluate and ~load_map read it back);\n"
    "                         world: the dataset's world frame (default: gravity_aligned)\n"
    "  --save-clouds DIR      one ASCII PLY per object: fused cloud and LCCP segment\n"
    "  --overlays DIR         detections drawn on each keyframe's colour image (PNG)\n"
    "  --timings FILE         per-keyframe stage times as CSV (keyframes with detections)\n"
    "  --min-probability P    lambda of Eq. 5 (default: 0.5)\n"
    "  --priors FILE          class priors YAML (default: config/class_priors.yaml of the "
    "package)\n"
    "  --no-filter            ablation: no voxel/pass-through/outlier filters\n"
    "  --no-lccp              ablation: no LCCP segmentation\n"
    "  --single-frame         baseline: no fusion across keyframes (each detection a new object)\n"
    "  --paper                the paper's method as published: largest LCCP segment (Eq. 2),\n"
    "                         literal fusion (Eq. 7), min/max box extents, no floor cut\n"
    "  --selection S          largest (Eq. 2) | consistent (default)\n"
    "  --fusion F             paper (Eq. 7) | evidence (default)\n"
    "  --outlier-removal M    statistical_centres (default) | statistical (PCL's exactly, the\n"
    "                         paper's) | voxel_neighbours | none\n"
    "  --lccp-implementation I  voxel_grid (default: supervoxels on a hash grid) | pcl (PCL's,\n"
    "                         the paper's)\n"
    "  --normal-estimation N  cells (default: single-view normals from cell moments) | radius\n"
    "                         (per point over the radius, the paper's)\n"
    "  --no-floor             no floor cut before LCCP and no grounding of boxes on the floor\n"
    "  --no-amodal            no amodal completion (boxes are only what the views saw: a chair\n"
    "                         under a table is its backrest)\n"
    "  --no-existence         keep every object once mapped (no existence evidence: objects\n"
    "                         whose place later views see through, or that are detected in\n"
    "                         few of the views that show them, are not removed)\n"
    "  --every-pixel          no near sampling: every depth pixel of a mask, however close (the\n"
    "                         default samples surfaces nearer than fx x 5 mm on a coarser grid)\n"
    "  --existence-remove-below L  remove an object once its existence log-odds fall below L\n"
    "                         (default -1; the log-odds lie in [-2, 2])\n"
    "  --estimate-gravity     estimate gravity from the dominant plane even where the dataset\n"
    "                         states it (7-Scenes gravity-direction.txt, SceneNN's y-up world)\n"
    "  --corrected-poses DIR  the SLAM's corrections, as at a loop closure: frame-NNNNNN.pose.txt\n"
    "                         files (the 7-Scenes layout); every keyframe processed before\n"
    "                         --correct-at that has a file there takes that pose, and the map\n"
    "                         follows (not with --paper, which keeps no keyframe history)\n"
    "  --correct-at N         apply --corrected-poses just before frame N (default: after the\n"
    "                         last frame)\n"
    "  --quiet                no progress bar and no per-frame warnings (errors are still shown)\n"
    "  --help                 this text\n"
    "\n"
    "exit status: 0 ok, 1 dataset or another input cannot be opened, 2 bad arguments\n";

struct Options {
  std::string dataset;
  std::string format = "auto";
  std::string detections;
  std::string detector = "files";
  std::string model_dir;
  double score_threshold = 0.5;
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
  std::string timings;
  double min_probability = 0.5;
  std::string priors;
  bool no_filter = false;
  bool no_lccp = false;
  bool single_frame = false;
  bool paper = false;
  bool no_floor = false;
  bool no_amodal = false;
  bool no_existence = false;
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
};

// Input, detector and output options.
void addInputOptions(CLI::App* app, Options* options) {
  for (const auto& [name, value] :
       {std::make_pair("--dataset", &options->dataset),
        std::make_pair("--detections", &options->detections),
        std::make_pair("--detector", &options->detector),
        std::make_pair("--model-dir", &options->model_dir),
        std::make_pair("--output", &options->output),
        std::make_pair("--save-clouds", &options->save_clouds),
        std::make_pair("--overlays", &options->overlays),
        std::make_pair("--timings", &options->timings),
        std::make_pair("--priors", &options->priors),
        std::make_pair("--backend", &options->backend),
        std::make_pair("--corrected-poses", &options->corrected_poses)}) {
    cli::addText(app, name, value, std::string(name) + " needs a value");
  }
  cli::addValue(app, "--format", [options](const std::string& text) {
    if (text.empty()) return std::string("--format needs a value");
    if (text != "auto" && text != "7scenes" && text != "scenenn") {
      return "--format must be auto, 7scenes or scenenn, not '" + text + "'";
    }
    options->format = text;
    return std::string();
  });
  cli::addValue(app, "--output-frame", [options](const std::string& text) {
    if (text != "gravity_aligned" && text != "world") {
      return "--output-frame must be gravity_aligned or world, not '" + text + "'";
    }
    options->output_frame = text;
    return std::string();
  });
  cli::addInteger(app, "--simulated-seed", 0, std::numeric_limits<unsigned int>::max(),
                  &options->simulated_seed, "--simulated-seed needs an integer >= 0");
  cli::addFlag(app, "--simulated-perfect", &options->simulated_perfect);
  cli::addNumber(
      app, "--score-threshold", &options->score_threshold, [](double) { return true; },
      "--score-threshold needs a number");
  cli::addInteger(app, "--max-detections", 1, std::numeric_limits<int>::max(),
                  &options->max_detections, "--max-detections needs an integer >= 1");
  cli::addInteger(app, "--threads", 0, 256, &options->threads,
                  "--threads needs an integer in [0, 256]");
  cli::addValue(app, "--every", [options](const std::string& text) {
    long every = 0;
    if (!cli::parseLong(text, std::numeric_limits<int>::min(), std::numeric_limits<int>::max(),
                        &every)) {
      return std::string("--every needs an integer");
    }
    if (every < 1) return std::string("--every must be >= 1");
    options->every = static_cast<int>(every);
    return std::string();
  });
  cli::addInteger(app, "--first", std::numeric_limits<int>::min(), std::numeric_limits<int>::max(),
                  &options->first, "--first needs an integer");
  cli::addInteger(app, "--last", std::numeric_limits<int>::min(), std::numeric_limits<int>::max(),
                  &options->last, "--last needs an integer");
  cli::addInteger(app, "--correct-at", std::numeric_limits<int>::min(),
                  std::numeric_limits<int>::max(), &options->correct_at,
                  "--correct-at needs an integer");
  cli::addFlag(app, "--quiet", &options->quiet);
}

// The method's options: Eq. 5's lambda, the ablations and the paper's variants.
void addMethodOptions(CLI::App* app, Options* options) {
  cli::addValue(app, "--min-probability", [options](const std::string& text) {
    if (!cli::parseDouble(text, &options->min_probability)) {
      return std::string("--min-probability needs a number");
    }
    if (options->min_probability < 0.0 || options->min_probability > 1.0) {
      return std::string("--min-probability must be in [0, 1]");
    }
    return std::string();
  });
  cli::addFlag(app, "--no-filter", &options->no_filter);
  cli::addFlag(app, "--no-lccp", &options->no_lccp);
  cli::addFlag(app, "--single-frame", &options->single_frame);
  cli::addFlag(app, "--paper", &options->paper);
  cli::addFlag(app, "--no-floor", &options->no_floor);
  cli::addFlag(app, "--no-amodal", &options->no_amodal);
  cli::addFlag(app, "--no-existence", &options->no_existence);
  cli::addFlag(app, "--every-pixel", &options->every_pixel);
  cli::addNumber(
      app, "--existence-remove-below", &options->existence_remove_below,
      [](double value) { return std::isfinite(value); },
      "--existence-remove-below needs a finite number");
  cli::addFlag(app, "--estimate-gravity", &options->estimate_gravity);
  cli::addChoice(app, "--selection", {"largest", "consistent"}, &options->selection,
                 "--selection needs largest or consistent");
  cli::addChoice(app, "--fusion", {"paper", "evidence"}, &options->fusion,
                 "--fusion needs paper or evidence");
  cli::addChoice(app, "--normal-estimation", {"cells", "radius"}, &options->normal_estimation,
                 "--normal-estimation needs cells or radius");
  cli::addChoice(app, "--lccp-implementation", {"voxel_grid", "pcl"}, &options->lccp_implementation,
                 "--lccp-implementation needs voxel_grid or pcl");
  cli::addChoice(
      app, "--outlier-removal", {"statistical", "statistical_centres", "voxel_neighbours", "none"},
      &options->outlier_removal,
      "--outlier-removal needs statistical, statistical_centres, voxel_neighbours or none");
}

// -1 when the arguments are fine, else the exit status (usage printed; 0 for --help).
int parseArguments(int argc, char** argv, Options* options) {
  CLI::App app;
  cli::setUp(&app);
  addInputOptions(&app, options);
  addMethodOptions(&app, options);
  const int parsed = cli::parse(&app, argc, argv, "offline_detection", kUsage);
  if (parsed >= 0) return parsed;
  std::string error;
  if (options->dataset.empty()) {
    error = "--dataset is required";
  } else if (options->first > options->last) {
    error = "--first is after --last";
  } else if (options->detector == "files" && options->detections.empty()) {
    error = "--detector files needs --detections DIR";
  } else if (options->correct_at != std::numeric_limits<int>::max() &&
             options->corrected_poses.empty()) {
    error = "--correct-at needs --corrected-poses DIR";
  } else if (!options->corrected_poses.empty() && !fs::is_directory(options->corrected_poses)) {
    error = "--corrected-poses: no folder " + options->corrected_poses;
  }
  return error.empty() ? -1 : cli::usageError("offline_detection", error, kUsage);
}

// config/class_priors.yaml of the package: next to the sources (catkin devel space: the workspace's
// src/<package>), or installed under share/<package>.
std::string findDefaultPriors(const char* argv0) {
  std::error_code error;
  fs::path exe = fs::read_symlink("/proc/self/exe", error);
  if (error) exe = fs::absolute(argv0, error);
  const char* kPackage = "multiview_object_detection";
  for (fs::path dir = exe.parent_path(); !dir.empty(); dir = dir.parent_path()) {
    const fs::path candidates[] = {
        dir / "config" / "class_priors.yaml",
        dir / "src" / kPackage / "config" / "class_priors.yaml",
        dir / "share" / kPackage / "config" / "class_priors.yaml",
    };
    for (const fs::path& candidate : candidates) {
      if (fs::is_regular_file(candidate, error)) return candidate.string();
    }
    if (dir == dir.root_path()) break;
  }
  return "";
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  }
  return m;
}

std::string formatDuration(double seconds) {
  const int s = static_cast<int>(std::max(0.0, seconds) + 0.5);
  char text[32];
  std::snprintf(text, sizeof(text), "%d:%02d", s / 60, s % 60);
  return text;
}

// A progress line on stderr: redrawn in place on a terminal, one line per 10% otherwise.
class Progress {
 public:
  Progress(size_t total, bool enabled)
      : total_(total),
        enabled_(enabled),
        tty_(::isatty(STDERR_FILENO) != 0),
        start_(std::chrono::steady_clock::now()) {}

  void update(size_t done, int keyframes, size_t objects) {
    if (!enabled_ || total_ == 0) return;
    const int decile = static_cast<int>(10 * done / total_);
    if (!tty_ && decile == last_decile_) return;
    last_decile_ = decile;
    const double elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double eta_s = done > 0 ? elapsed_s * static_cast<double>(total_ - done) / done : 0.0;
    const int width = 30;
    const int filled = static_cast<int>(width * done / total_);
    std::string bar(filled, '#');
    bar.resize(width, '.');
    char line[256];
    std::snprintf(line, sizeof(line), "[%s] frame %zu/%zu  keyframes %d  objects %zu  ETA %s",
                  bar.c_str(), done, total_, keyframes, objects, formatDuration(eta_s).c_str());
    if (tty_) {
      std::fprintf(stderr, "\r%s\033[K", line);
      drawn_ = true;
    } else {
      std::fprintf(stderr, "%s\n", line);
    }
    std::fflush(stderr);
  }
  // Ends the in-place line before other output goes to stderr.
  void breakLine() {
    if (drawn_) std::fprintf(stderr, "\n");
    drawn_ = false;
  }

 private:
  size_t total_;
  bool enabled_;
  bool tty_;
  std::chrono::steady_clock::time_point start_;
  int last_decile_ = -1;
  bool drawn_ = false;
};

std::string fileSafe(std::string name) {
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return name;
}

void printTable(const std::vector<mvod::MapObject>& objects, const std::string& frame) {
  std::printf("objects in the %s frame%s\n", frame.c_str(),
              frame == "gravity_aligned" ? " (z up, the floor at z = 0)" : "");
  std::printf("%4s  %-16s %5s %4s  %-26s %-22s %8s\n", "id", "class", "prob", "obs", "centre (m)",
              "size (m)", "yaw (deg)");
  for (const mvod::MapObject& o : objects) {
    const Eigen::Vector3d& c = o.box.center_m;
    const Eigen::Vector3d& s = o.box.size_m;
    std::printf("%4d  %-16s %5.2f %4d  (%6.2f, %6.2f, %6.2f)   (%5.2f, %5.2f, %5.2f)  %8.1f\n",
                o.id, o.class_name.c_str(), o.probability, o.observations, c.x(), c.y(), c.z(),
                s.x(), s.y(), s.z(), o.yaw_rad * 180.0 / M_PI);
  }
  std::fflush(stdout);
}

}  // namespace

namespace {

// run()'s phases return an exit status, or kContinue to go on.
constexpr int kContinue = -1;

// The detector's options; bad ones are usage errors (exit 2), found before any file is touched.
int segmenterOptions(const Options& options, mvod::BenchmarkSegmenterOptions* segmenter) {
  segmenter->detector = options.detector;
  segmenter->detections_dir = options.detections.empty() && options.detector == "simulated"
                                  ? options.dataset
                                  : options.detections;
  segmenter->model_dir = options.model_dir;
  segmenter->score_threshold = static_cast<float>(options.score_threshold);
  segmenter->backend = options.backend;
  segmenter->max_detections = options.max_detections;
  if (options.simulated_perfect) {
    segmenter->simulated = mvod::SimulatedInstanceSegmenter::Config::perfect();
  }
  segmenter->simulated.seed = static_cast<uint64_t>(options.simulated_seed);
  const mvod::Status valid = segmenter->isValid();
  if (!valid) {
    std::cerr << "offline_detection: " << valid.message() << "\n";
    return kExitUsage;
  }
  return kContinue;
}

// The dataset; its warnings, and its notes unless --quiet.
int openDataset(const Options& options, mvod::DatasetSource* dataset) {
  const mvod::Status opened = mvod::openDatasetSource(options.dataset, options.format, dataset);
  if (!opened) {
    std::cerr << "offline_detection: cannot open dataset " << options.dataset << ": "
              << opened.message() << "\n";
    return kExitFailure;
  }
  for (const std::string& warning : dataset->warnings) {
    std::cerr << "offline_detection: warning: " << warning << "\n";
  }
  if (!options.quiet) {
    std::cerr << "offline_detection: " << options.dataset << " (" << dataset->format << ", "
              << dataset->indices.size() << " frames)\n";
    for (const std::string& note : dataset->notes) {
      std::cerr << "offline_detection: " << note << "\n";
    }
  }
  return kContinue;
}

// --priors, else the package's config/class_priors.yaml.
int loadPriors(Options* options, const char* argv0, mvod::ClassPriors* priors) {
  if (options->priors.empty()) {
    options->priors = findDefaultPriors(argv0);
    if (options->priors.empty()) {
      std::cerr << "offline_detection: config/class_priors.yaml not found next to the package's "
                   "sources or install space; give it with --priors FILE\n";
      return kExitFailure;
    }
  }
  const mvod::Status loaded = mvod::ClassPriors::loadYaml(options->priors, priors);
  if (!loaded) {
    std::cerr << "offline_detection: " << loaded.message() << "\n";
    return kExitFailure;
  }
  return kContinue;
}

// The mapper's configuration: the method's options, the dataset's gravity when it has one (else
// estimated from the first frames' dominant plane). Invalid values are usage errors.
int mapperConfig(const Options& options, const mvod::DatasetSource& dataset,
                 mvod::ObjectMapper::Config* config) {
  if (options.paper) config->usePaperMethod();
  if (!options.selection.empty()) config->selection.selection = options.selection;
  if (!options.fusion.empty()) config->database.fusion = options.fusion;
  if (!options.outlier_removal.empty()) config->filter.outlier_removal = options.outlier_removal;
  if (!options.normal_estimation.empty()) config->box.normal_estimation = options.normal_estimation;
  if (!options.lccp_implementation.empty()) {
    config->lccp.implementation = options.lccp_implementation;
  }
  if (options.no_floor) config->floor.enable = false;
  if (options.no_amodal) config->database.amodal.enable = false;
  if (options.no_existence) config->database.existence.enable = false;
  if (options.every_pixel) config->extractor.near_sampling_leaf_m = 0.0;
  if (std::isfinite(options.existence_remove_below)) {
    config->database.existence.remove_below = options.existence_remove_below;
  }
  config->min_probability = options.min_probability;
  config->num_threads = options.threads;
  config->filter.enable = !options.no_filter;
  config->lccp.enable = !options.no_lccp;
  config->database.disable_fusion = options.single_frame;
  config->gravity_down_W = dataset.has_gravity && !options.estimate_gravity
                               ? dataset.gravity_down_W
                               : Eigen::Vector3d::Zero();
  const mvod::Status valid = config->isValid();
  if (!valid) {
    std::cerr << "offline_detection: invalid configuration: " << valid.message() << "\n";
    return kExitUsage;
  }
  return kContinue;
}

// The folders of --save-clouds and --overlays.
int makeOutputFolders(const Options& options) {
  for (const std::string& dir : {options.save_clouds, options.overlays}) {
    std::error_code error;
    if (!dir.empty() && !fs::create_directories(dir, error) && error) {
      std::cerr << "offline_detection: cannot create " << dir << ": " << error.message() << "\n";
      return kExitFailure;
    }
  }
  return kContinue;
}

// The dataset's frames with an index in [--first, --last].
std::vector<int> selectFrames(const Options& options, const mvod::DatasetSource& dataset) {
  std::vector<int> frames;
  for (const int index : dataset.indices) {
    if (index >= options.first && index <= options.last) frames.push_back(index);
  }
  if (frames.empty()) {
    std::cerr << "offline_detection: no frames in " << options.dataset << " within the range\n";
  }
  return frames;
}

// What the keyframes of a run gave.
struct RunStats {
  std::vector<mvod::StageTimes> stage_times;  // keyframes that had detections to process
  std::vector<std::string> stage_frames;      // their names
  std::vector<double> detection_ms;
  int keyframes = 0;
  int errors = 0;
  mvod::MapSummary::Counts counts;
  std::vector<double> correction_ms;  // --corrected-poses: each correction's time
  int keyframes_corrected = 0;
  int removed_gone = 0;  // by the existence evidence
};

// Every N-th frame through load -> detect -> ObjectMapper::processKeyframe, with a progress line.
class KeyframeLoop {
 public:
  KeyframeLoop(const Options& options, mvod::DatasetSource* dataset,
               mvod::InstanceSegmenter* segmenter, mvod::ObjectMapper* mapper, size_t num_frames)
      : options_(options),
        dataset_(*dataset),
        segmenter_(*segmenter),
        mapper_(*mapper),
        progress_(num_frames, !options.quiet) {}

  void run(const std::vector<int>& frames) {
    bool corrected = options_.corrected_poses.empty();
    for (size_t i = 0; i < frames.size(); ++i) {
      if (!corrected && frames[i] >= options_.correct_at) {
        correctPoses(frames[i]);
        corrected = true;
      }
      if (i % static_cast<size_t>(options_.every) == 0) processFrame(frames[i]);
      progress_.update(i + 1, stats_.keyframes, mapper_.database().size());
    }
    progress_.breakLine();
    if (!corrected) correctPoses(-1);
  }
  const RunStats& stats() const { return stats_; }

 private:
  void processFrame(int index) {
    const std::string name = dataset_.frame_name(index);
    mvod::RgbdFrame frame;
    const mvod::Status loaded = dataset_.load(index, &frame);
    if (!loaded) {
      ++stats_.errors;
      report(name + ": error: " + loaded.message(), true);
      return;
    }
    if (frame.name.empty()) frame.name = name;
    std::vector<mvod::Detection2D> detections;
    if (!detect(frame, name, &detections)) return;
    if (!options_.overlays.empty()) writeOverlay(frame, name, detections);
    mapKeyframe(frame, name, detections);
    keyframes_.push_back({index, frame.stamp_s, frame.T_C_D});
  }

  // --corrected-poses: the keyframes so far that have a pose file there take that pose
  // (before_frame: the frame it happens before; -1 after the last).
  void correctPoses(int before_frame) {
    std::vector<mvod::PoseCorrection> corrections;
    for (const ProcessedKeyframe& keyframe : keyframes_) {
      char name[32];
      std::snprintf(name, sizeof(name), "frame-%06d.pose.txt", keyframe.index);
      const fs::path path = fs::path(options_.corrected_poses) / name;
      std::error_code error;
      if (!fs::exists(path, error)) continue;
      Eigen::Isometry3d T_W_D;
      const mvod::Status read = mvod::SevenScenesDataset::readPose(path.string(), &T_W_D);
      if (!read) {
        ++stats_.errors;
        report("error: corrected pose " + path.string() + ": " + read.message(), true);
        continue;
      }
      mvod::PoseCorrection correction;
      correction.stamp_s = keyframe.stamp_s;
      correction.T_W_C = T_W_D * keyframe.T_C_D.inverse();
      corrections.push_back(correction);
    }
    mvod::ObjectMapper::CorrectionReport correction;
    const mvod::Status applied = mapper_.correctPoses(corrections, &correction);
    const std::string when =
        before_frame >= 0 ? "before frame " + std::to_string(before_frame) : "after the last frame";
    if (!applied) {
      ++stats_.errors;
      report("error: corrections " + when + ": " + applied.message(), true);
      return;
    }
    std::ostringstream line;
    if (correction.ignored) {
      line << "corrections " << when << " ignored: the paper's method keeps no keyframe history";
    } else {
      line << "corrections " << when << ": " << corrections.size() << " pose files, "
           << correction.keyframes_moved << " keyframes moved, " << correction.views_replayed
           << " views fused again, objects " << correction.objects_before << " -> "
           << correction.objects_after << " (" << correction.time_ms << " ms)";
    }
    report(line.str(), false);
    stats_.correction_ms.push_back(correction.time_ms);
    stats_.keyframes_corrected += correction.keyframes_moved;
  }

  // The detector on the frame, timed; false (an error counted) when it fails.
  bool detect(const mvod::RgbdFrame& frame, const std::string& name,
              std::vector<mvod::Detection2D>* detections) {
    std::vector<std::string> warnings;
    const auto t0 = std::chrono::steady_clock::now();
    const mvod::Status detected =
        segmenter_.detect(frame.color_bgr, frame.name, detections, &warnings);
    stats_.detection_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    for (const std::string& warning : warnings) report(name + ": warning: " + warning, false);
    if (!detected) {
      ++stats_.errors;
      report(name + ": error: detection failed: " + detected.message(), true);
      return false;
    }
    return true;
  }

  void writeOverlay(const mvod::RgbdFrame& frame, const std::string& name,
                    const std::vector<mvod::Detection2D>& detections) {
    const std::string path = options_.overlays + "/" + name + ".overlay.png";
    try {
      if (!cv::imwrite(path, mvod::drawDetections(frame.color_bgr, detections))) {
        report(name + ": warning: cannot write " + path, false);
      }
    } catch (const cv::Exception& e) {
      report(name + ": warning: cannot write " + path + ": " + e.what(), false);
    }
  }

  void mapKeyframe(const mvod::RgbdFrame& frame, const std::string& name,
                   const std::vector<mvod::Detection2D>& detections) {
    mvod::KeyframeReport keyframe;
    const mvod::Status processed = mapper_.processKeyframe(frame, detections, &keyframe);
    if (!processed) {
      ++stats_.errors;
      report(name + ": error: " + processed.message(), true);
    } else {
      ++stats_.keyframes;
      mvod::MapSummary::Counts& counts = stats_.counts;
      counts.detections += keyframe.detections;
      counts.above_threshold += keyframe.above_threshold;
      counts.with_box += keyframe.with_box;
      counts.inserted += keyframe.inserted;
      counts.fused += keyframe.fused;
      stats_.removed_gone += static_cast<int>(keyframe.removed.size());
      if (keyframe.above_threshold > 0 && !keyframe.waiting_for_gravity) {
        stats_.stage_times.push_back(keyframe.times);
        stats_.stage_frames.push_back(name);
      }
    }
    for (const std::string& warning : keyframe.warnings) report("warning: " + warning, false);
    for (const mvod::MapObject& object : keyframe.removed) {
      const mvod::ExistenceEvidence& e = object.existence;
      report(name + ": #" + std::to_string(object.id) + " " + object.class_name +
                 " gone (existence: detected in " + std::to_string(e.detected) + ", missed in " +
                 std::to_string(e.missed) + ", seen through in " + std::to_string(e.seen_through) +
                 " keyframes)",
             false);
    }
  }

  // A line on stderr (not with --quiet unless it is an error), below the progress line.
  void report(const std::string& line, bool is_error) {
    if (options_.quiet && !is_error) return;
    progress_.breakLine();
    std::cerr << line << "\n";
  }

  const Options& options_;
  mvod::DatasetSource& dataset_;
  mvod::InstanceSegmenter& segmenter_;
  mvod::ObjectMapper& mapper_;
  Progress progress_;
  RunStats stats_;
  struct ProcessedKeyframe {
    int index;
    double stamp_s;
    Eigen::Isometry3d T_C_D;
  };
  std::vector<ProcessedKeyframe> keyframes_;
};

// The map's summary; Table 5's split as medians per keyframe (over the keyframes that had
// detections to process).
mvod::MapSummary summarize(const RunStats& stats, size_t num_frames,
                           const mvod::ObjectMapper& mapper,
                           const mvod::ObjectMapper::RefinementReport& refinement) {
  mvod::MapSummary summary;
  summary.frames = static_cast<int>(num_frames);
  summary.keyframes = stats.keyframes;
  summary.removed_atypical = static_cast<int>(refinement.atypical_ids.size());
  summary.removed_intersecting = static_cast<int>(refinement.intersecting_ids.size());
  summary.removed_gone = stats.removed_gone;
  summary.gravity_down_W = -mapper.gravity().up;
  summary.floor_height_m = mapper.floorHeight_m();
  summary.counts = stats.counts;
  auto stage_median = [&](double mvod::StageTimes::*field) {
    std::vector<double> values;
    for (const mvod::StageTimes& t : stats.stage_times) values.push_back(t.*field);
    return median(values);
  };
  mvod::StageTimes& med = summary.stage_ms_median;
  med.extraction_ms = stage_median(&mvod::StageTimes::extraction_ms);
  med.filter_ms = stage_median(&mvod::StageTimes::filter_ms);
  med.lccp_ms = stage_median(&mvod::StageTimes::lccp_ms);
  med.manhattan_ms = stage_median(&mvod::StageTimes::manhattan_ms);
  med.fusion_ms = stage_median(&mvod::StageTimes::fusion_ms);
  med.existence_ms = stage_median(&mvod::StageTimes::existence_ms);
  med.total_ms = stage_median(&mvod::StageTimes::total_ms);
  med.refinement_ms = refinement.time_ms;
  return summary;
}

// Does the cost per keyframe grow with the map? The first and the last 20 keyframes.
void printCostGrowth(const std::vector<mvod::StageTimes>& stage_times) {
  if (stage_times.size() < 40) return;
  std::vector<double> first, last;
  for (size_t k = 0; k < 20; ++k) {
    first.push_back(stage_times[k].total_ms);
    last.push_back(stage_times[stage_times.size() - 20 + k].total_ms);
  }
  std::fprintf(stderr,
               "offline_detection: time per keyframe, median of the first 20: %.1f ms, of the "
               "last 20: %.1f ms\n",
               median(first), median(last));
}

// --timings: per-keyframe stage times as CSV.
int writeTimings(const std::string& path, const RunStats& stats) {
  std::ofstream csv(path);
  csv << "frame,extraction_ms,filter_ms,lccp_ms,manhattan_ms,fusion_ms,total_ms,existence_ms\n";
  for (size_t k = 0; k < stats.stage_times.size(); ++k) {
    const mvod::StageTimes& t = stats.stage_times[k];
    csv << stats.stage_frames[k] << "," << t.extraction_ms << "," << t.filter_ms << "," << t.lccp_ms
        << "," << t.manhattan_ms << "," << t.fusion_ms << "," << t.total_ms << "," << t.existence_ms
        << "\n";
  }
  if (!csv) {
    std::cerr << "offline_detection: cannot write " << path << "\n";
    return kExitFailure;
  }
  return kContinue;
}

// --save-clouds: each object's fused cloud and LCCP segment as ASCII PLY. False if one fails.
bool saveClouds(const std::string& dir, const std::vector<mvod::MapObject>& objects) {
  bool all_saved = true;
  for (const mvod::MapObject& object : objects) {
    const std::string stem =
        dir + "/object_" + std::to_string(object.id) + "_" + fileSafe(object.class_name);
    for (const auto& part : {std::make_pair("_fused.ply", &object.points_W),
                             std::make_pair("_segment.ply", &object.segment_W)}) {
      const mvod::Status saved =
          mvod::writeFileAtomic(stem + part.first, mvod::plyAsciiXyz(*part.second));
      if (!saved) {
        std::cerr << "offline_detection: " << saved.message() << "\n";
        all_saved = false;
      }
    }
  }
  return all_saved;
}

void printRunReport(const RunStats& stats, size_t num_frames, size_t num_objects,
                    const mvod::ObjectMapper::RefinementReport& refinement,
                    const mvod::MapSummary& summary) {
  const mvod::StageTimes& med = summary.stage_ms_median;
  const mvod::MapSummary::Counts& counts = summary.counts;
  std::fprintf(stderr,
               "%zu frames, %d keyframes (%zu with detections), %d errors; %zu objects "
               "(removed: %zu atypical, %zu intersecting, of which %zu merged into a duplicate; "
               "%d gone by the existence evidence)\n"
               "stage medians (ms): detection %.1f  extraction %.1f  filter %.1f  lccp %.1f  "
               "manhattan %.1f  fusion %.1f  existence %.1f  total %.1f  refinement %.1f\n"
               "counts: %d detections, %d >= lambda, %d with a box, %d inserted, %d fused; "
               "%d objects before refinement\n",
               num_frames, stats.keyframes, stats.stage_times.size(), stats.errors, num_objects,
               refinement.atypical_ids.size(), refinement.intersecting_ids.size(),
               refinement.merged_ids.size(), stats.removed_gone, median(stats.detection_ms),
               med.extraction_ms, med.filter_ms, med.lccp_ms, med.manhattan_ms, med.fusion_ms,
               med.existence_ms, med.total_ms, med.refinement_ms, counts.detections,
               counts.above_threshold, counts.with_box, counts.inserted, counts.fused,
               counts.before_refinement);
}

// Refinement (Sec. 3.5), the printed table, objects.json, the clouds, the report.
int finishMap(const Options& options, RunStats stats, size_t num_frames,
              mvod::ObjectMapper* mapper) {
  stats.counts.before_refinement = static_cast<int>(mapper->database().size());
  const mvod::ObjectMapper::RefinementReport refinement = mapper->refine();
  mvod::MapSummary summary = summarize(stats, num_frames, *mapper, refinement);
  if (options.output_frame == "gravity_aligned") {
    summary.objects_in_gravity_frame = true;
    summary.T_W_O = mvod::gravityAlignedPose(mapper->gravity(), mapper->floorHeight_m());
  }
  if (!options.quiet) printCostGrowth(stats.stage_times);
  if (!options.timings.empty() && writeTimings(options.timings, stats) != kContinue) {
    return kExitFailure;
  }
  const std::vector<mvod::MapObject> objects = mvod::databaseObjects(mapper->database());
  // What the table and the clouds show: objects.json is written in the same frame (objectsToJson).
  const std::vector<mvod::MapObject> shown =
      summary.objects_in_gravity_frame
          ? mvod::objectsInFrame(objects, summary.T_W_O.inverse(), !options.save_clouds.empty())
          : std::vector<mvod::MapObject>();
  printTable(summary.objects_in_gravity_frame ? shown : objects, options.output_frame);
  int exit_code = kExitOk;
  const mvod::Status written =
      mvod::writeFileAtomic(options.output, mvod::objectsToJson(objects, summary, false));
  if (!written) {
    std::cerr << "offline_detection: " << written.message() << "\n";
    exit_code = kExitFailure;
  }
  if (!options.save_clouds.empty() &&
      !saveClouds(options.save_clouds, summary.objects_in_gravity_frame ? shown : objects)) {
    exit_code = kExitFailure;
  }
  if (!options.quiet) {
    printRunReport(stats, num_frames, objects.size(), refinement, summary);
    if (written) std::fprintf(stderr, "wrote %s\n", options.output.c_str());
  }
  return exit_code;
}

// main() without the last-resort catch: parse, open the dataset, set up the detector and the
// mapper, run the keyframes, finish the map.
int run(int argc, char** argv) {
  Options options;
  int status = parseArguments(argc, argv, &options);
  if (status != kContinue) return status;
  mvod::BenchmarkSegmenterOptions segmenter_options;
  if ((status = segmenterOptions(options, &segmenter_options)) != kContinue) return status;
  mvod::DatasetSource dataset;
  if ((status = openDataset(options, &dataset)) != kContinue) return status;
  mvod::ClassPriors priors;
  if ((status = loadPriors(&options, argv[0], &priors)) != kContinue) return status;
  std::unique_ptr<mvod::InstanceSegmenter> segmenter;
  const mvod::Status created = mvod::createBenchmarkSegmenter(segmenter_options, &segmenter);
  if (!created) {
    std::cerr << "offline_detection: " << created.message() << "\n";
    return kExitFailure;
  }
  mvod::ObjectMapper::Config config;
  if ((status = mapperConfig(options, dataset, &config)) != kContinue) return status;
  mvod::ObjectMapper mapper(config, priors);
  if ((status = makeOutputFolders(options)) != kContinue) return status;

  const std::vector<int> frames = selectFrames(options, dataset);
  KeyframeLoop keyframes(options, &dataset, segmenter.get(), &mapper, frames.size());
  keyframes.run(frames);
  return finishMap(options, keyframes.stats(), frames.size(), &mapper);
}

}  // namespace

// Every input problem should be a Status with a message; anything thrown past that (a library's
// exception, memory) still ends with a message and exit 1 instead of an abort.
int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "\noffline_detection: error: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "\noffline_detection: error: unknown exception\n";
  }
  return kExitFailure;
}
