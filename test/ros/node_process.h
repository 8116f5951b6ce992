// The node as a child process of a rostest (test_node_autosave, test_node_map_files): started with
// the inputs remapped to the tests' topics and its own map directory, killed if a test ends early.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "test_node_common.h"

namespace mvod_test {

inline std::string nodeBinary() {
  // Beside the test's binary in the devel space.
  return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "object_detection_node")
      .string();
}

// The node process `node` ("/name"), its inputs remapped to the tests' topics, its map_directory
// set and its ROS log beside it; more arguments in `extra`. `output` (optional): the file the
// node's stdout and stderr go to.
inline pid_t startNode(const std::string& map_directory, const std::string& node,
                       const std::vector<std::string>& extra = {}, const std::string& output = "") {
  std::vector<std::string> args = {nodeBinary(),
                                   "__name:=" + node.substr(1),
                                   std::string("rgb/image_rect_color:=") + kRgbTopic,
                                   std::string("depth_registered/image_rect:=") + kDepthTopic,
                                   std::string("rgb/camera_info:=") + kInfoTopic,
                                   std::string("pose:=") + kPoseTopic,
                                   std::string("detections:=") + kDetectionsTopic,
                                   "_map_directory:=" + map_directory,
                                   "__log:=" + map_directory + "/../node.log"};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (!output.empty()) {
      const int fd = ::open(output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
    }
    std::vector<char*> argv;
    for (const std::string& arg : args) argv.push_back(const_cast<char*>(arg.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// SIGKILLs the node when a test ends early (a failed ASSERT): a node left running would keep the
// test run's output pipe open and hold make test up. `pid` -1 once the node has been reaped.
struct KillOnExit {
  pid_t pid = -1;
  ~KillOnExit() {
    if (pid <= 0) return;
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
  }
};

// Waits up to `timeout_s` for `pid` to end by itself; true and its wait status if it did, else it
// is killed (SIGKILL) and false.
inline bool endsWithin(pid_t pid, double timeout_s, int* status) {
  for (int i = 0; i < static_cast<int>(timeout_s * 10.0); ++i) {
    if (::waitpid(pid, status, WNOHANG) == pid) return true;
    ::usleep(100000);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, status, 0);
  return false;
}

}  // namespace mvod_test
