// make_synthetic_dataset: renders a synthetic room (SyntheticScene::makeDefault, or a furnished
// room of SyntheticScene::makeRoom) as a dataset in the 7-Scenes layout, optionally with perfect
// instance detections, plus ground_truth.json with the true boxes; or as a SceneNN sequence.
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <string>

#include "cli_options.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace {

namespace cli = mvod::cli;

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;  // a folder or file cannot be written
constexpr int kExitUsage = 2;    // bad arguments

const char* const kUsage =
    "usage: make_synthetic_dataset --output DIR [options]\n"
    "\n"
    "Renders a synthetic room to RGB-D frames with ground truth. The default room has a dining\n"
    "table with four chairs, a couch, a tv on a stand, cups and a book; --room living|bedroom|\n"
    "dining|close|random builds a furnished room from multi-part furniture (chairs, tables, "
    "couch,\n"
    "bed, tv, refrigerator, bookshelves with books, cups), varied by the seed. close: a couch and\n"
    "a table with chairs seen from about 1 m, filling the view (random: living, bedroom or\n"
    "dining).\n"
    "\n"
    "--layout 7scenes (default): frame-NNNNNN.color.png, .depth.png, .pose.txt,\n"
    "  camera-intrinsics.txt, gravity-direction.txt (z-up world) and ground_truth.json with the\n"
    "  true boxes and each object's observed surface points.\n"
    "--layout scenenn: a SceneNN sequence in DIR: image/imageNNNNN.png, depth/depthNNNNN.png,\n"
    "  label/labelNNNNN.png (16-bit instance ids of ID.xml), trajectory.log, timestamp.txt,\n"
    "  asus.ini, ID.xml (annotation) and ID.ply (observed surface, per-vertex label); y-up world,\n"
    "  SceneNN's 640x480 camera (fx = fy = 544.47329).\n"
    "\n"
    "options:\n"
    "  --output DIR         dataset folder to write (required)\n"
    "  --layout L           7scenes or scenenn (default: 7scenes)\n"
    "  --room R             default, living, bedroom, dining, close or random (by the seed)\n"
    "                       (default: default)\n"
    "  --id NAME            SceneNN sequence id, the ID of ID.xml/ID.ply\n"
    "                       (default: synthetic_<seed>)\n"
    "  --detections DIR     7scenes only: also write perfect instance detections (JSON + mask\n"
    "                       PNGs) there\n"
    "  --frames N           number of frames, one lap around the room (default: 60)\n"
    "  --seed S             scene variation seed, >= 0 (default: 1)\n"
    "  --noise-model M      quadratic (sigma = K * z^2, see --noise) or kinect (Kinect v1: axial\n"
    "                       noise 1.2 mm + 1.9 mm (z - 0.4)^2, disparity steps, no depth beyond\n"
    "                       5 m, at grazing angles or in the IR shadow of edges)\n"
    "                       (default: quadratic)\n"
    "  --noise K            quadratic model: depth noise sigma = K * z^2 (m), >= 0 (default: 0)\n"
    "  --holes F            fraction of random invalid depth pixels in [0, 1) (default: 0)\n"
    "  --help               this text\n"
    "\n"
    "exit status: 0 ok, 1 a folder or file cannot be written, 2 bad arguments\n";

struct Options {
  std::string output;
  std::string detections;
  std::string layout = "7scenes";
  std::string room = "default";
  std::string id;
  bool noise_given = false;
  mvod::SyntheticSceneConfig scene;
};

// The scene's options: room, frames, seed, depth noise.
void addSceneOptions(CLI::App* app, Options* options) {
  mvod::SyntheticSceneConfig* scene = &options->scene;
  cli::addChoice(app, "--room", {"default", "living", "bedroom", "dining", "close", "random"},
                 &options->room, "--room needs default, living, bedroom, dining, close or random");
  cli::addInteger(app, "--frames", 1, 1000000, &scene->num_frames,
                  "--frames needs an integer >= 1");
  cli::addInteger(app, "--seed", 0, std::numeric_limits<unsigned int>::max(), &scene->seed,
                  "--seed needs an integer >= 0");
  cli::addValue(app, "--noise-model", [scene](const std::string& text) {
    if (text == "quadratic") {
      scene->noise_model = mvod::DepthNoiseModel::kQuadratic;
    } else if (text == "kinect") {
      scene->noise_model = mvod::DepthNoiseModel::kKinect;
    } else {
      return std::string("--noise-model needs quadratic or kinect");
    }
    return std::string();
  });
  cli::addValue(app, "--noise", [options](const std::string& text) {
    options->noise_given = true;
    if (!cli::parseDouble(text, &options->scene.depth_noise_m_per_m2) ||
        options->scene.depth_noise_m_per_m2 < 0.0) {
      return std::string("--noise needs a number >= 0");
    }
    return std::string();
  });
  cli::addNumber(
      app, "--holes", &scene->hole_fraction, [](double f) { return f >= 0.0 && f < 1.0; },
      "--holes needs a number in [0, 1)");
}

// What is inconsistent after parsing ("" when nothing); the default id.
std::string checkArguments(Options* options) {
  if (options->output.empty()) return "--output is required";
  if (options->layout == "scenenn" && !options->detections.empty()) {
    return "--detections is for --layout 7scenes only (SceneNN sequences carry label images)";
  }
  if (options->layout == "7scenes" && !options->id.empty()) {
    return "--id is for --layout scenenn only";
  }
  if (options->noise_given && options->scene.noise_model == mvod::DepthNoiseModel::kKinect) {
    return "--noise is for --noise-model quadratic (the kinect model sets its own noise)";
  }
  if (options->id.empty()) options->id = "synthetic_" + std::to_string(options->scene.seed);
  return std::string();
}

// -1 when the arguments are fine, else the exit status (usage printed; 0 for --help).
int parseArguments(int argc, char** argv, Options* options) {
  CLI::App app;
  bool help = false;  // shown only when the whole command line parses, as before
  cli::setUp(&app, &help);
  cli::addText(&app, "--output", &options->output, "--output needs a value");
  cli::addText(&app, "--detections", &options->detections, "--detections needs a value");
  cli::addChoice(&app, "--layout", {"7scenes", "scenenn"}, &options->layout,
                 "--layout needs 7scenes or scenenn");
  cli::addValue(&app, "--id", [options](const std::string& text) {
    if (text.empty() || text.find_first_of("/\\<>\"&") != std::string::npos) {
      return std::string("--id needs a name without / \\ < > \" &");
    }
    options->id = text;
    return std::string();
  });
  addSceneOptions(&app, options);
  const int parsed = cli::parse(&app, argc, argv, "make_synthetic_dataset", kUsage, "\n\n", &help);
  if (parsed >= 0) return parsed;
  const std::string error = checkArguments(options);
  return error.empty() ? -1 : cli::usageError("make_synthetic_dataset", error, kUsage);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const int parsed = parseArguments(argc, argv, &options);
  if (parsed >= 0) return parsed;

  mvod::SyntheticScene scene = mvod::SyntheticScene::makeDefault(options.scene);
  std::string room_name = "default";
  if (options.room != "default") {
    mvod::RoomType type = mvod::roomTypeFromSeed(options.scene.seed);
    if (options.room == "living") type = mvod::RoomType::kLivingRoom;
    if (options.room == "bedroom") type = mvod::RoomType::kBedroom;
    if (options.room == "dining") type = mvod::RoomType::kDiningRoom;
    if (options.room == "close") type = mvod::RoomType::kCloseUp;
    scene = mvod::SyntheticScene::makeRoom(options.scene, type);
    room_name = mvod::roomTypeName(type);
  }
  const bool scenenn = options.layout == "scenenn";
  const auto start = std::chrono::steady_clock::now();
  const mvod::Status written = scenenn ? scene.writeSceneNN(options.output, options.id)
                                       : scene.writeSevenScenes(options.output, options.detections);
  if (!written) {
    std::cerr << "make_synthetic_dataset: " << written.message() << "\n";
    return kExitFailure;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const mvod::SyntheticSceneConfig& config = scene.config();
  const mvod::CameraIntrinsics K = scenenn ? mvod::SyntheticScene::sceneNNIntrinsics() : config.K;
  const bool kinect = config.noise_model == mvod::DepthNoiseModel::kKinect;
  std::printf(
      "wrote %d frames (%s layout, %s room %.2f x %.2f m, %dx%d, %s, holes %.3g) to %s "
      "in %.1f s\n",
      config.num_frames, options.layout.c_str(), room_name.c_str(), config.room_size_x_m,
      config.room_size_y_m, K.width, K.height,
      kinect ? "kinect depth model"
             : ("depth noise " + std::to_string(config.depth_noise_m_per_m2) + " m/m^2").c_str(),
      config.hole_fraction, options.output.c_str(), seconds);
  if (!options.detections.empty()) {
    std::printf("perfect detections in %s\n", options.detections.c_str());
  }
  if (scenenn) {
    std::printf("annotation %s.xml, observed surface %s.ply (y-up world)\n", options.id.c_str(),
                options.id.c_str());
  }
  std::printf("%zu objects (%s), z-up world:\n", scene.objects().size(),
              scenenn ? "label id = index" : "ground_truth.json");
  std::printf("  %-3s %-14s %-24s %-20s %s\n", "id", "class", "centre (m)", "size (m)",
              "yaw (deg)");
  auto printRow = [](int id, const mvod::SyntheticObject& object) {
    const Eigen::Vector3d& c = object.box.center_m;
    const Eigen::Vector3d& s = object.box.size_m;
    const double yaw_deg =
        std::atan2(object.box.rotation(1, 0), object.box.rotation(0, 0)) * 180.0 / M_PI;
    std::printf("  %-3d %-14s (%5.2f, %5.2f, %5.2f)   (%4.2f, %4.2f, %4.2f)   %6.1f\n", id,
                object.class_name.c_str(), c.x(), c.y(), c.z(), s.x(), s.y(), s.z(), yaw_deg);
  };
  for (size_t k = 0; k < scene.objects().size(); ++k) {
    printRow(scene.sceneNNObjectId(static_cast<int>(k)), scene.objects()[k]);
  }
  if (!scene.clutter().empty()) {
    std::printf("%zu clutter pieces (not ground truth):\n", scene.clutter().size());
    for (size_t j = 0; j < scene.clutter().size(); ++j) {
      printRow(scene.sceneNNClutterId(static_cast<int>(j)), scene.clutter()[j]);
    }
  }
  return kExitOk;
}
