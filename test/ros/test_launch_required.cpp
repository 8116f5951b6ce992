// object_detection.launch ends when its node exits: a node that cannot start (no model files) must
// not leave a launch running with no detection. rosrun of the package's tools and rviz's rospack
// queries print no noise; roslaunch --ros-args lists no optional argument as required.
// roslaunch runs here with its own master on a port of its own; it must be gone well within
// kLaunchTimeoutS.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

constexpr int kLaunchTimeoutS = 60;

TEST(LaunchRequiredTest, LaunchEndsWhenTheNodeCannotStart) {
  if (std::system("command -v roslaunch > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "roslaunch not found";
  }
  const fs::path dir =
      fs::temp_directory_path() / ("mvod_launch_required_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "models");  // empty: FastestDet.onnx is missing
  const int port = 20000 + ::getpid() % 20000;
  const fs::path log = dir / "roslaunch.log";
  const std::string command =
      "ROS_MASTER_URI=http://localhost:" + std::to_string(port) + " ROS_HOME='" + dir.string() +
      "' timeout -k 5 " + std::to_string(kLaunchTimeoutS) + " roslaunch -p " +
      std::to_string(port) + " multiview_object_detection object_detection.launch model_dir:='" +
      (dir / "models").string() + "' output:=screen > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  ASSERT_TRUE(WIFEXITED(status)) << text.str();
  // timeout exits 124 (137 after -k) when roslaunch was still running.
  EXPECT_NE(WEXITSTATUS(status), 124) << "roslaunch kept running:\n" << text.str();
  EXPECT_NE(WEXITSTATUS(status), 137) << "roslaunch kept running:\n" << text.str();
  EXPECT_NE(text.str().find("FastestDet.onnx"), std::string::npos) << text.str();
  // detector 'auto' says it looked for YOLOv5n-seg first, and where (issue 56).
  EXPECT_NE(text.str().find("detector 'auto' (it looks for YOLOv5n-seg first, " +
                            (dir / "models" / "yolov5n-seg.onnx").string()),
            std::string::npos)
      << text.str();
  EXPECT_NE(text.str().find("REQUIRED process"), std::string::npos) << text.str();
  fs::remove_all(dir);
}

// rosrun searches the package folder with `find -L`: the workspace's package folder must not lead
// back into the workspace (it printed "find: File system loop detected" twice on every call).
TEST(RosrunTest, FindsTheToolsWithoutAFileSystemLoop) {
  if (std::system("command -v rosrun > /dev/null 2>&1") != 0) GTEST_SKIP() << "rosrun not found";
  const fs::path log = fs::temp_directory_path() / ("mvod_rosrun_" + std::to_string(::getpid()));
  const std::string command =
      "rosrun multiview_object_detection print_parameter_ranges > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  fs::remove(log);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << text.str();
  EXPECT_NE(text.str().find("filter/voxel_leaf_size_m"), std::string::npos) << text.str();
  EXPECT_EQ(text.str().find("File system loop"), std::string::npos) << text.str();
}

// The output of a shell command (stdout and stderr) and its exit status.
std::string run(const std::string& command, int* status) {
  const fs::path log = fs::temp_directory_path() / ("mvod_run_" + std::to_string(::getpid()));
  *status = std::system((command + " > '" + log.string() + "' 2>&1").c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  fs::remove(log);
  return text.str();
}

// `roslaunch --ros-args` lists an argument with an empty default as required (roslaunch's
// arg_dump treats "" as no default): every optional argument has a non-empty default and a doc.
TEST(RosLaunchArgsTest, OnlyTheBagIsRequiredAndEveryArgumentIsDocumented) {
  if (std::system("command -v roslaunch > /dev/null 2>&1") != 0) GTEST_SKIP() << "no roslaunch";
  const std::map<std::string, std::set<std::string>> required = {
      {"object_detection.launch", {}}, {"replay.launch", {"bag"}}, {"kinect_orbslam2.launch", {}}};
  for (const auto& [file, expected] : required) {
    int status = 0;
    const std::string text =
        run("roslaunch --ros-args multiview_object_detection " + file, &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << file << ":\n" << text;
    std::set<std::string> listed;
    bool in_required = false;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("Required Arguments:", 0) == 0) in_required = true;
      if (line.rfind("Optional Arguments:", 0) == 0) in_required = false;
      EXPECT_EQ(line.find("undocumented"), std::string::npos) << file << ": " << line;
      if (in_required && line.rfind("  ", 0) == 0)
        listed.insert(line.substr(2, line.find(':') - 2));
    }
    EXPECT_EQ(listed, expected) << file << ":\n" << text;
  }
}

// kinect_orbslam2.launch sets the parameters appliedAI's orb_slam2_ros reads today (Node.cc from
// 09b82abf): the calibration (camera_info or the args; without either the wrapper stops), the
// depth's units (its default 1 reads a Kinect's millimetres as metres) and the frames that make
// the node's TF look-up the colour camera's pose (docs/live_camera.md).
TEST(KinectOrbslam2LaunchTest, DrivesTheWrapperWithTheParametersItReads) {
  if (std::system("command -v roslaunch > /dev/null 2>&1") != 0) GTEST_SKIP() << "no roslaunch";
  const auto dump = [](const std::string& args) {
    int status = 0;
    const std::string text =
        run("roslaunch --dump-params multiview_object_detection kinect_orbslam2.launch "
            "start_kinect:=false start_orbslam2:=true rviz:=false " +
                args,
            &status);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << text;
    std::map<std::string, std::string> params;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      const std::string prefix = "/orb_slam2_rgbd/";
      const size_t colon = line.find(": ");
      if (line.rfind(prefix, 0) != 0 || colon == std::string::npos) continue;
      params[line.substr(prefix.size(), colon - prefix.size())] = line.substr(colon + 2);
    }
    return params;
  };
  std::map<std::string, std::string> params = dump("");
  EXPECT_EQ(params["depth_map_factor"], "1000.0");
  EXPECT_EQ(params["load_calibration_from_cam"], "true");
  EXPECT_EQ(params["camera_frame_id"], "camera_rgb_frame");
  EXPECT_EQ(params["target_frame_id"], "camera_link");
  EXPECT_EQ(params["pointcloud_frame_id"], "map");
  EXPECT_EQ(params["publish_tf"], "true");
  // Calibration parameters always present: the wrapper falls back to them without camera_info.
  for (const char* name : {"camera_fx", "camera_fy", "camera_cx", "camera_cy", "camera_k1",
                           "camera_k2", "camera_k3", "camera_p1", "camera_p2", "camera_baseline"}) {
    EXPECT_EQ(params.count(name), 1u) << name;
  }
  EXPECT_EQ(params["camera_fx"], "525.0");
  EXPECT_EQ(params["camera_baseline"], "40.0");
  EXPECT_EQ(params.count("settings_file"), 0u);  // read only by versions before 6efc879
  params = dump(
      "orbslam2_calibration:=args camera:=kinect2 depth_map_factor:=1 "
      "orbslam2_settings:=/tmp/TUM1.yaml");
  EXPECT_EQ(params["load_calibration_from_cam"], "false");
  EXPECT_EQ(params["camera_frame_id"], "kinect2_rgb_frame");
  EXPECT_EQ(params["target_frame_id"], "kinect2_link");
  EXPECT_EQ(params["depth_map_factor"], "1.0");
  EXPECT_EQ(params["settings_file"], "/tmp/TUM1.yaml");
}

// rviz asks rospack for media_export's plugins at every start; Debian has no media_export, so each
// demo's log had "[rospack] Error: no such package media_export" (deps/standin: a stand-in).
TEST(RospackTest, MediaExportIsFound) {
  if (std::system("command -v rospack > /dev/null 2>&1") != 0) GTEST_SKIP() << "no rospack";
  int status = 0;
  const std::string text = run("rospack plugins --attrib=plugin media_export", &status);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << text;
  EXPECT_EQ(text.find("no such package"), std::string::npos) << text;
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
