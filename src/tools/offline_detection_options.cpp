#include "offline_detection_options.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>

#include "cli_options.h"

namespace offline_detection {
namespace {

namespace fs = std::filesystem;
namespace cli = mvod::cli;

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
    "  --color-intrinsics FILE  7-Scenes layout: the colour camera's 3x3 K, instead of the\n"
    "                         folder's color-intrinsics.txt (a read-only dataset needs no file\n"
    "                         written into it)\n"
    "  --depth-to-color FILE  7-Scenes layout: T_C_D, 4x4 row-major, p_C = R p_D + t (a depth\n"
    "                         camera point in the colour camera), instead of the folder's\n"
    "                         depth-to-color.txt\n"
    "  --registered           7-Scenes layout: colour and depth are one camera (the folder's\n"
    "                         colour files are not read)\n"
    "  --trajectory FILE      a SLAM's poses instead of the dataset's: TUM format ('t tx ty tz\n"
    "                         qx qy qz qw' per line, the colour camera to the SLAM's world, t\n"
    "                         the frame's stamp: 7-Scenes frame / 30 s); frames without a pose\n"
    "                         within half a frame are left out\n"
    "  --keyframes FILE       map only the frames at this TUM file's stamps, with its poses (a\n"
    "                         SLAM's final keyframe poses, e.g. KeyFrameTrajectory.txt); use\n"
    "                         --every 1\n"
    "  --trajectory-world W   aligned: the SLAM's world placed so that its first frame has the\n"
    "                         dataset's pose (the dataset's gravity and annotation apply);\n"
    "                         slam: as it is, gravity estimated (default: aligned)\n"
    "  --detector NAME        files | simulated | yolo_seg | fastestdet | maskrcnn (default:\n"
    "                         files)\n"
    "  --detections DIR       files: folder of <frame>.json detections (required);\n"
    "                         simulated: the sequence with label/ and <id>.xml (default: "
    "--dataset)\n"
    "  --model-dir DIR        folder of the DNN model files (default: $MVOD_MODEL_DIR, else\n"
    "                         $ROS_HOME/multiview_object_detection/models, ~/.ros/...)\n"
    "  --simulated-seed S     simulated: seed of its failures (default: 1)\n"
    "  --simulated-perfect    simulated: no failures (exact masks and classes, score 0.85)\n"
    "  --score-threshold S    detector score below which detections are not reported (default:\n"
    "                         the detector's own: yolo_seg 0.15, fastestdet and maskrcnn 0.5)\n"
    "  --nms-threshold T, --mask-threshold T  fastestdet, yolo_seg: NMS IoU; yolo_seg,\n"
    "                         maskrcnn: mask probability -> binary (default: the detector's)\n"
    "  --yolo-seg-model FILE  yolo_seg: another export of the official layout, e.g.\n"
    "                         yolov5n-seg-320.onnx or yolov5s-seg.onnx (default:\n"
    "                         yolov5n-seg.onnx; a name is looked up in the model folder)\n"
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
    "  --save-detections DIR  each keyframe's detections as <frame>.json and mask PNGs, the\n"
    "                         format --detector files reads (a detector run once, the map made\n"
    "                         again with other options)\n"
    "  --timings FILE         per-keyframe stage times as CSV (keyframes with detections)\n"
    "  --min-probability P    lambda of Eq. 5 (default: the detector's own: yolo_seg 0.15,\n"
    "                         the others 0.5)\n"
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
    "  --no-history           keep no keyframe history (the map cannot follow SLAM corrections;\n"
    "                         --corrected-poses is then ignored, as with --paper)\n"
    "  --history-mb MB        the keyframe history's memory bound (corrections/max_memory_mb,\n"
    "                         default 1024); past it the oldest keyframes degrade\n"
    "  --every-pixel          no near sampling: every depth pixel of a mask, however close (the\n"
    "                         default samples surfaces nearer than fx x 5 mm on a coarser grid)\n"
    "  --existence-remove-below L  remove an object once its existence log-odds fall below L\n"
    "                         (default -1; the log-odds lie in [-2, 2])\n"
    "  --estimate-gravity     estimate gravity from the frame's surfaces even where the dataset\n"
    "                         states it (7-Scenes gravity-direction.txt, SceneNN's y-up world)\n"
    "  --corrected-poses DIR  the SLAM's corrections, as at a loop closure: frame-NNNNNN.pose.txt\n"
    "                         files (the 7-Scenes layout); every keyframe processed before\n"
    "                         --correct-at that has a file there takes that pose, and the map\n"
    "                         follows (not with --paper, which keeps no keyframe history)\n"
    "  --correct-at N         apply --corrected-poses just before frame N (default: after the\n"
    "                         last frame)\n"
    "  --quiet                no progress bar and no per-frame warnings (errors are still shown)\n"
    "  --verbose              a line for each dropped detection and skipped keyframe, with the\n"
    "                         mapper's words (default: counted by plain reason in the summary)\n"
    "  --help                 this text\n"
    "\n"
    "exit status: 0 ok, 1 dataset or another input cannot be opened, the output cannot be\n"
    "written, or an error was reported during the run (the map of the rest is written), 2 bad\n"
    "arguments\n";

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
        std::make_pair("--save-detections", &options->save_detections),
        std::make_pair("--timings", &options->timings),
        std::make_pair("--priors", &options->priors),
        std::make_pair("--backend", &options->backend),
        std::make_pair("--yolo-seg-model", &options->yolo_seg_model),
        std::make_pair("--corrected-poses", &options->corrected_poses),
        std::make_pair("--color-intrinsics", &options->color_intrinsics),
        std::make_pair("--depth-to-color", &options->depth_to_color),
        std::make_pair("--trajectory", &options->trajectory.trajectory),
        std::make_pair("--keyframes", &options->trajectory.keyframes)}) {
    cli::addText(app, name, value, std::string(name) + " needs a value");
  }
  cli::addValue(app, "--trajectory-world", [options](const std::string& text) {
    if (text != "aligned" && text != "slam") {
      return "--trajectory-world must be aligned or slam, not '" + text + "'";
    }
    options->trajectory.align_first_frame = text == "aligned";
    return std::string();
  });
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
  cli::addNumber(
      app, "--nms-threshold", &options->nms_threshold, [](double) { return true; },
      "--nms-threshold needs a number");
  cli::addNumber(
      app, "--mask-threshold", &options->mask_threshold, [](double) { return true; },
      "--mask-threshold needs a number");
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
  cli::addFlag(app, "--verbose", &options->verbose);
  cli::addFlag(app, "--registered", &options->registered);
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
  cli::addFlag(app, "--no-history", &options->no_history);
  cli::addFlag(app, "--every-pixel", &options->every_pixel);
  cli::addNumber(
      app, "--history-mb", &options->history_mb, [](double value) { return value > 0.0; },
      "--history-mb needs a number of MB > 0");
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

}  // namespace

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

}  // namespace offline_detection
