// Shared by the tests that run a script of scripts/ on a bag (test_demo_replay, test_soak): shell
// commands, and a bag of the synthetic room made by the package's own tools. Needs the targets'
// MVOD_MAKE_SYNTHETIC_DATASET_BIN and MVOD_DATASET_TO_BAG_BIN (CMakeLists.txt,
// mvod_add_replay_gtest).
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace mvod {
namespace test {

inline std::string readText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The command's exit status through /bin/sh; -1 when it did not exit (killed by a signal).
inline int run(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// dir/<bag_name>: `frames` frames of the default synthetic room (SceneNN layout, seed 1, Kinect
// noise) with the simulated detector's detections; the tools' output in dir/make.log and
// dir/bag.log. False when either tool failed.
inline bool makeSyntheticBag(const std::filesystem::path& dir, int frames,
                             const std::string& bag_name) {
  const std::string room = (dir / "synthetic_default").string();
  return run(std::string(MVOD_MAKE_SYNTHETIC_DATASET_BIN) +
             " --layout scenenn --room default --seed 1 --noise-model kinect --frames " +
             std::to_string(frames) + " --id synthetic_default --output '" + room + "' > '" +
             (dir / "make.log").string() + "' 2>&1") == 0 &&
         run(std::string(MVOD_DATASET_TO_BAG_BIN) + " --dataset '" + room + "' --output '" +
             (dir / bag_name).string() + "' --detector simulated --quiet > '" +
             (dir / "bag.log").string() + "' 2>&1") == 0;
}

}  // namespace test
}  // namespace mvod
