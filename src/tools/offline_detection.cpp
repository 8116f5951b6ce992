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

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"
#include "multiview_object_detection/evaluation/keyframe_overlay.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "offline_detection_options.h"
#include "offline_detection_report.h"
#include "offline_detection_warnings.h"

namespace fs = std::filesystem;
using offline_detection::kExitFailure;
using offline_detection::kExitOk;
using offline_detection::kExitUsage;
using offline_detection::Options;
using offline_detection::parseArguments;
using offline_detection::printCostGrowth;
using offline_detection::printHistoryUsage;
using offline_detection::printRefinementRemovals;
using offline_detection::printRunReport;
using offline_detection::printTable;
using offline_detection::RunStats;
using offline_detection::saveClouds;
using offline_detection::summarize;
using offline_detection::writeTimings;

namespace {

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
  segmenter->score_threshold = std::isfinite(options.score_threshold)
                                   ? static_cast<float>(options.score_threshold)
                                   : mvod::kDetectorDefault;
  if (std::isfinite(options.nms_threshold)) {
    segmenter->nms_threshold = static_cast<float>(options.nms_threshold);
  }
  if (std::isfinite(options.mask_threshold)) {
    segmenter->mask_threshold = static_cast<float>(options.mask_threshold);
  }
  if (!options.yolo_seg_model.empty()) segmenter->yolo_seg_model = options.yolo_seg_model;
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
  mvod::ColorCameraFiles camera;
  camera.color_intrinsics = options.color_intrinsics;
  camera.depth_to_color = options.depth_to_color;
  camera.registered = options.registered;
  mvod::Status opened = mvod::openDatasetSource(options.dataset, options.format, dataset, camera);
  if (opened) opened = mvod::applyTrajectory(options.trajectory, dataset);
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
// estimated from the first frames' surfaces). Invalid values are usage errors.
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
  if (options.no_history) config->corrections.enable = false;
  if (options.history_mb > 0.0) config->corrections.max_memory_mb = options.history_mb;
  if (options.every_pixel) config->extractor.near_sampling_leaf_m = 0.0;
  if (std::isfinite(options.existence_remove_below)) {
    config->database.existence.remove_below = options.existence_remove_below;
  }
  config->min_probability = std::isfinite(options.min_probability)
                                ? options.min_probability
                                : mvod::detectorThresholds(options.detector).min_probability;
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
  for (const std::string& dir : {options.save_clouds, options.overlays, options.save_detections}) {
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
    if (!options_.save_detections.empty()) saveDetections(frame, name, detections);
    const mvod::KeyframeReport mapped = mapKeyframe(frame, name, detections);
    if (!options_.overlays.empty()) writeOverlay(frame, name, detections, mapped);
    keyframes_.push_back({index, frame.stamp_s, frame.T_C_D});
  }

  // --corrected-poses: the keyframes so far that have a pose file there take that pose
  // (before_frame: the frame it happens before; -1 after the last). A pose file that cannot be read
  // (malformed, a FIFO, a device, too large) is an error, and the correction is not applied at all:
  // half a loop closure would bend the map.
  void correctPoses(int before_frame) {
    const std::string when =
        before_frame >= 0 ? "before frame " + std::to_string(before_frame) : "after the last frame";
    std::vector<mvod::PoseCorrection> corrections;
    int unreadable = 0;
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
        ++unreadable;
        report("error: corrected pose " + path.string() + ": " + read.message(), true);
        continue;
      }
      mvod::PoseCorrection correction;
      correction.stamp_s = keyframe.stamp_s;
      correction.T_W_C = T_W_D * keyframe.T_C_D.inverse();
      corrections.push_back(correction);
    }
    if (unreadable > 0) {
      report("error: corrections " + when + " not applied: " + std::to_string(unreadable) +
                 " pose file(s) could not be read",
             true);
      return;
    }
    mvod::ObjectMapper::CorrectionReport correction;
    const mvod::Status applied = mapper_.correctPoses(corrections, &correction);
    if (!applied) {
      ++stats_.errors;
      report("error: corrections " + when + ": " + applied.message(), true);
      return;
    }
    std::ostringstream line;
    if (correction.ignored) {
      line << "corrections " << when
           << " ignored: " << (options_.no_history ? "--no-history" : "the paper's method")
           << " keeps no keyframe history";
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
    for (const std::string& warning : warnings) warn(name + ": warning: " + warning);
    if (!detected) {
      ++stats_.errors;
      report(name + ": error: detection failed: " + detected.message(), true);
      return false;
    }
    return true;
  }

  // The detections with the object each became, and the map's boxes after this keyframe.
  void writeOverlay(const mvod::RgbdFrame& frame, const std::string& name,
                    const std::vector<mvod::Detection2D>& detections,
                    const mvod::KeyframeReport& mapped) {
    const std::string path = options_.overlays + "/" + name + ".overlay.png";
    // Why each detection that was not mapped went, in the summary's plain words.
    std::vector<std::string> reasons(detections.size());
    for (size_t i = 0; i < reasons.size() && i < mapped.drop_reasons.size(); ++i) {
      if (!mapped.drop_reasons[i].empty()) {
        reasons[i] = offline_detection::plainReason(mapped.drop_reasons[i]);
      }
    }
    try {
      const cv::Mat overlay = mvod::drawKeyframeOverlay(
          frame, detections, mapped.object_ids, reasons, mvod::databaseObjects(mapper_.database()));
      if (!cv::imwrite(path, overlay)) {
        report(name + ": warning: cannot write " + path, false);
      }
    } catch (const cv::Exception& e) {
      report(name + ": warning: cannot write " + path + ": " + e.what(), false);
    }
  }

  // --save-detections: the detector's output in the files detector's format, to run the map
  // again (other thresholds, --paper, --single-frame) without the detector.
  void saveDetections(const mvod::RgbdFrame& frame, const std::string& name,
                      std::vector<mvod::Detection2D> detections) {
    for (mvod::Detection2D& detection : detections) {
      cv::Point origin;
      if (!mvod::maskOrigin(detection, frame.color_bgr.size(), &origin)) continue;
      // The files format holds image-sized masks.
      cv::Mat full = cv::Mat::zeros(frame.color_bgr.size(), CV_8UC1);
      detection.mask.copyTo(full(cv::Rect(origin, detection.mask.size())));
      detection.mask = full;
    }
    const mvod::Status written =
        mvod::FileInstanceSegmenter::write(options_.save_detections, name, detections);
    if (!written) {
      ++stats_.errors;
      report(name + ": error: " + written.message(), true);
    }
  }

  // Returns, per detection, the map object it became (-1: not mapped).
  mvod::KeyframeReport mapKeyframe(const mvod::RgbdFrame& frame, const std::string& name,
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
      if (keyframe.depth_fault) ++stats_.keyframes_faulty;
      if (keyframe.above_threshold > 0 && !keyframe.waiting_for_gravity) {
        stats_.stage_times.push_back(keyframe.times);
        stats_.stage_detection_ms.push_back(stats_.detection_ms.back());
        stats_.stage_frames.push_back(name);
      }
    }
    for (const std::string& warning : keyframe.warnings) warn("warning: " + warning);
    for (const mvod::MapObject& object : keyframe.removed) {
      const mvod::ExistenceEvidence& e = object.existence;
      report(name + ": #" + std::to_string(object.id) + " " + object.class_name +
                 " gone (existence: detected in " + std::to_string(e.detected) + ", missed in " +
                 std::to_string(e.missed) + ", seen through in " + std::to_string(e.seen_through) +
                 " keyframes)",
             false);
    }
    return keyframe;
  }

  // A dropped detection or skipped keyframe: counted by its plain reason for the summary, the line
  // itself shown with --verbose.
  void warn(const std::string& line) {
    ++stats_.warnings[offline_detection::plainReason(line)];
    if (options_.verbose) report(line, false);
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

// Refinement (Sec. 3.5), the printed table, objects.json, the clouds, the report.
int finishMap(const Options& options, RunStats stats, size_t num_frames,
              mvod::ObjectMapper* mapper) {
  stats.counts.before_refinement = static_cast<int>(mapper->database().size());
  const mvod::ObjectMapper::RefinementReport refinement = mapper->refine();
  if (!options.quiet) printRefinementRemovals(refinement);
  mvod::MapSummary summary = summarize(stats, num_frames, *mapper, refinement);
  if (options.output_frame == "gravity_aligned") {
    summary.objects_in_gravity_frame = true;
    summary.T_W_O = mvod::gravityAlignedPose(mapper->gravity(), mapper->floorHeight_m());
  }
  if (!options.quiet) printCostGrowth(stats);
  if (!options.timings.empty() && !writeTimings(options.timings, stats)) return kExitFailure;
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
    printHistoryUsage(mapper->history().usage(), mapper->config().corrections.max_memory_mb);
    if (written) std::fprintf(stderr, "wrote %s\n", options.output.c_str());
  }
  // A frame or file that could not be read was reported and skipped; the run says so in its status
  // too (a script must not take a partial map for a whole one).
  if (stats.errors > 0) {
    std::fprintf(stderr, "offline_detection: %d error(s) above; exit status 1\n", stats.errors);
    exit_code = kExitFailure;
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
