// rostest (node_map_files.test): the node's map files. A symbolic link at the autosave path, at
// load_map_on_start's or at a ~save_map / ~load_map path is refused with the link's name and
// target, whether it leads out of map_directory (allow_any_map_path: true) or to another map in it;
// the file behind it keeps its content, mode and name (issue 48, item 5: load_map_on_start moved a
// link's target aside and the autosave then wrote over it, 0640 becoming 0644).
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "multiview_object_detection/MapFile.h"
#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "node_process.h"
#include "test_node_common.h"

namespace mvod_test {
namespace {

namespace fs = std::filesystem;

constexpr char kDecoyText[] = "a file the node does not own\n";

// A map folder with a decoy file beside it (0640, not a map), a map of one chair in it
// (other.mvmap), and links: link.mvmap and link.json -> the decoy, to_other.mvmap -> the map.
class NodeMapLinksTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("mvod_map_links_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "maps");
    decoy_ = root_ / "decoy.txt";
    std::ofstream(decoy_) << kDecoyText;
    ASSERT_EQ(::chmod(decoy_.c_str(), 0640), 0);
    mvod::MapObject chair;
    chair.id = 1;
    chair.class_id = 56;
    chair.class_name = "chair";
    chair.probability = 0.8;
    chair.observations = 3;
    chair.box.center_m = Eigen::Vector3d(1.0, 0.0, 0.45);
    chair.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
    chair.box.rotation.setIdentity();
    mvod::MapFolderWriter writer;
    ASSERT_TRUE(
        writer.write((root_ / "maps" / "other.mvmap").string(), {chair}, mvod::MapSummary(), {})
            .ok());
    ASSERT_TRUE(mvod::readFile(otherMap(), &other_text_).ok());
    fs::create_symlink(decoy_, root_ / "maps" / "link.mvmap");
    fs::create_symlink(decoy_, root_ / "maps" / "link.json");
    fs::create_symlink(root_ / "maps" / "other.mvmap", root_ / "maps" / "to_other.mvmap");
  }
  void TearDown() override { fs::remove_all(root_); }
  std::string otherMap() const { return (root_ / "maps" / "other.mvmap" / "map.json").string(); }

  pid_t start(const std::string& node, const std::vector<std::string>& parameters,
              const std::string& output) {
    std::vector<std::string> args = {"_detector:=topic", "_pose_source:=topic"};
    args.insert(args.end(), parameters.begin(), parameters.end());
    return startNode((root_ / "maps").string(), node, args, (root_ / output).string());
  }
  std::string logs(const std::string& output) const {
    std::string text;
    mvod::readFile((root_ / output).string(), &text);
    return text;
  }

  // The decoy and the other map as they were made, the links still links, nothing moved aside.
  void expectUntouched() const {
    std::string text;
    ASSERT_TRUE(mvod::readFile(decoy_.string(), &text).ok()) << "the decoy is gone";
    EXPECT_EQ(text, kDecoyText);
    struct stat info {};
    ASSERT_EQ(::lstat(decoy_.c_str(), &info), 0);
    EXPECT_EQ(info.st_mode & 07777, 0640u) << "the decoy's mode changed";
    ASSERT_TRUE(mvod::readFile(otherMap(), &text).ok());
    EXPECT_EQ(text, other_text_) << "the other map was written over";
    for (const std::string link : {"link.mvmap", "link.json", "to_other.mvmap"}) {
      EXPECT_TRUE(fs::is_symlink(root_ / "maps" / link)) << link;
    }
    for (const fs::path& folder : {root_, root_ / "maps"}) {
      for (const auto& entry : fs::directory_iterator(folder)) {
        const std::string name = entry.path().filename().string();
        EXPECT_EQ(name.find("unreadable"), std::string::npos) << "moved aside: " << name;
      }
    }
  }

  fs::path root_;
  fs::path decoy_;
  std::string other_text_;
};

TEST_F(NodeMapLinksTest, AnAutosavePathThatIsALinkStopsTheStartAndTouchesNothing) {
  // Out of map_directory with allow_any_map_path, and to another map inside it without.
  const std::vector<std::vector<std::string>> cases = {
      {"_allow_any_map_path:=true", "_autosave_path:=link.mvmap", "_load_map_on_start:=link.json"},
      {"_autosave_path:=to_other", "_load_map_on_start:=to_other.mvmap"}};
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE("case " + std::to_string(i));
    std::vector<std::string> parameters = cases[i];
    parameters.push_back("_autosave_period_s:=1");
    const std::string output = "autosave_" + std::to_string(i) + ".out";
    const pid_t pid = start("/map_links_autosave_node", parameters, output);
    ASSERT_GT(pid, 0);
    int status = 0;
    EXPECT_TRUE(endsWithin(pid, 60.0, &status)) << "the node ran with a link as its autosave path";
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << "status " << status;
    const std::string text = logs(output);
    EXPECT_NE(text.find("autosave_path"), std::string::npos) << text;
    EXPECT_NE(text.find("is a symbolic link to "), std::string::npos) << text;
    expectUntouched();
  }
}

TEST_F(NodeMapLinksTest, LoadOnStartSaveAndLoadRefuseLinksAndTheRestWorks) {
  const std::string node = "/map_links_services_node";
  const pid_t pid = start(
      node, {"_allow_any_map_path:=true", "_autosave_period_s:=0", "_load_map_on_start:=link.json"},
      "services.out");
  ASSERT_GT(pid, 0);
  KillOnExit guard{pid};
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 30000)) << logs("services.out");
  EXPECT_TRUE(getObjects(node).objects.empty());
  const auto call = [&](const std::string& service, const std::string& path) {
    multiview_object_detection::MapFile srv;
    srv.request.path = path;
    EXPECT_TRUE(ros::service::call(node + "/" + service, srv)) << service;
    return srv.response;
  };
  for (const std::string link : {"link.json", "link.mvmap", "to_other", "to_other.mvmap"}) {
    for (const std::string service : {"save_map", "load_map"}) {
      SCOPED_TRACE(service + " " + link);
      const multiview_object_detection::MapFile::Response refused = call(service, link);
      EXPECT_FALSE(refused.success);
      EXPECT_NE(refused.message.find("symbolic link to "), std::string::npos) << refused.message;
    }
  }
  expectUntouched();
  // The map itself, by its own path: loaded, then saved under a new name.
  EXPECT_TRUE(call("load_map", "other").success);
  EXPECT_EQ(getObjects(node).objects.size(), 1u);
  EXPECT_TRUE(call("save_map", "own.json").success);
  EXPECT_TRUE(fs::is_regular_file(root_ / "maps" / "own.mvmap" / "map.json"));
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  guard.pid = -1;
  const std::string text = logs("services.out");
  EXPECT_NE(text.find("load_map_on_start"), std::string::npos) << text;
  EXPECT_NE(text.find("symbolic link to " + decoy_.string()), std::string::npos) << text;
  expectUntouched();
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) {
  return mvod_test::runRosTests(argc, argv, "test_node_map_files");
}
