// rostest (node_autosave.test): a crash loses only what changed since the last autosave. The test
// starts object_detection_node itself, feeds it synthetic frames until the autosave holds a change
// it saw, kills it with SIGKILL at a random moment after that, checks the autosave file (whole,
// loadable, not older than the save that held the change, no temporaries after the restart),
// starts the node again with load_map_on_start and checks that it resumed that map; at the end
// SIGINT, and the final save holds the whole map. How old the file is at the kill is printed, not
// asserted (a sanitizer build on a loaded machine takes seconds for a save).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <fcntl.h>
#include <signal.h>
#include <std_srvs/Trigger.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <random>

#include "multiview_object_detection/GetObjects.h"
#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_folder.h"
#include "node_process.h"
#include "test_node_common.h"

namespace mvod_test {
namespace {

namespace fs = std::filesystem;

constexpr char kNode[] = "/autosave_node";
constexpr char kAutosaveName[] = "autosave_node.autosave.mvmap";

// The objects of a map file; false if it does not load.
bool loadMapFile(const std::string& path, std::vector<mvod::MapObject>* objects,
                 std::string* error) {
  mvod::MapSummary summary;
  std::deque<mvod::KeyframeRecord> history;
  const mvod::Status status =
      mvod::loadMap(path, mvod::Links::kRefuse, objects, &summary, &history);
  if (!status) *error = status.message();
  return status.ok();
}

// Save temporaries in the map directory and the map folders in it.
std::vector<std::string> temporariesIn(const std::string& directory) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(directory)) {
    const std::string name = entry.path().filename().string();
    if (name.find(".save-") != std::string::npos) found.push_back(name);
  }
  return found;
}

// The file's modification time in seconds since the epoch; 0 when it does not exist.
double modificationTimeS(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return 0.0;
  return static_cast<double>(info.st_mtim.tv_sec) +
         1e-9 * static_cast<double>(info.st_mtim.tv_nsec);
}

TEST(NodeAutosaveTest, KillNineAtRandomMomentsResumesFromTheAutosave) {
  ros::NodeHandle nh;
  int cycles = 5;
  ros::param::get("~kill_cycles", cycles);
  const fs::path root = fs::temp_directory_path() / ("mvod_autosave_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const std::string directory = (root / "maps").string();
  fs::create_directories(directory);
  const std::string autosave = directory + "/" + kAutosaveName;
  const std::string autosave_map = autosave + "/map.json";  // written last by each save

  SyntheticStream stream{SyntheticStream::Options()};
  InputPublisher inputs(nh);
  NodeOutputs outputs(nh, kNode, true);
  std::mt19937 rng(20261127u);
  int second = static_cast<int>(std::floor(ros::Time::now().toSec()));
  int frame = 0;
  const auto publishFrame = [&] {
    const ros::Time stamp(static_cast<double>(++second));
    inputs.publish(stream.make(frame++ % stream.options().num_frames, stamp), true, true);
  };
  // A frame every 0.25 s until `end`, calling `poll` every 50 ms; true as soon as `poll` is.
  const auto publishUntil = [&](const ros::WallTime& end, const std::function<bool()>& poll) {
    while (ros::WallTime::now() < end) {
      publishFrame();
      for (int i = 0; i < 5; ++i) {
        ros::WallDuration(0.05).sleep();
        if (poll()) return true;
      }
    }
    return false;
  };
  const auto after = [](double duration_s) {
    return ros::WallTime::now() + ros::WallDuration(duration_s);
  };
  size_t objects_before_kill = 0;
  double held_mtime_s = 0.0;  // the autosave can only get newer than this
  for (int cycle = 0; cycle <= cycles; ++cycle) {
    SCOPED_TRACE("cycle " + std::to_string(cycle));
    const std::string last_out = (root / "last_node.out").string();
    const pid_t pid = startNode(directory, kNode, {}, cycle == cycles ? last_out : "");
    ASSERT_GT(pid, 0);
    KillOnExit node{pid};
    ASSERT_TRUE(ros::service::waitForService(std::string(kNode) + "/get_objects", 30000))
        << "the node did not start";
    ASSERT_TRUE(
        outputs.waitFor([&] { return inputs.connected(1, 1) && outputs.connected(); }, 30.0));
    // Resumed: the map the killed node last autosaved.
    const multiview_object_detection::ObjectArray resumed = getObjects(kNode);
    if (cycle > 0) {
      EXPECT_EQ(resumed.objects.size(), objects_before_kill) << "not resumed from the autosave";
      // The restart removed what the kill may have left mid-save.
      EXPECT_TRUE(outputs.waitFor([&] { return temporariesIn(directory).empty(); }, 5.0));
    }
    if (cycle == cycles) {
      // The last one ends with SIGINT: refined, and saved once more.
      for (int i = 0; i < 4; ++i) {
        publishFrame();
        outputs.waitForObjectsAt(ros::Time(static_cast<double>(second)), 20.0);
      }
      const size_t live = getObjects(kNode).objects.size();
      ::kill(pid, SIGINT);
      int status = 0;
      ASSERT_EQ(::waitpid(pid, &status, 0), pid);
      node.pid = -1;
      EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
      std::vector<mvod::MapObject> saved;
      std::string error;
      ASSERT_TRUE(loadMapFile(autosave, &saved, &error)) << error;
      EXPECT_LE(saved.size(), live) << "the final save has more objects than the node had";
      EXPECT_GT(saved.size(), 0u);
      EXPECT_TRUE(temporariesIn(directory).empty());
      // Its first save wrote the keyframes new since the restart, not the resumed ones again.
      std::string logs;
      mvod::readFile(last_out, &logs);
      int written = -1;
      int total = -1;
      const size_t at = logs.find(" keyframe files written");
      ASSERT_NE(at, std::string::npos) << logs;
      const size_t from = logs.rfind(", ", at);
      ASSERT_EQ(std::sscanf(logs.c_str() + from, ", %d of %d", &written, &total), 2) << logs;
      EXPECT_LT(written, total) << "the resumed history was written again\n" << logs;
      std::printf("[ INFO     ] the resumed node's first save: %d of %d keyframe files written\n",
                  written, total);
      break;
    }
    // Frames for a random 1.5 - 4 s; the wall time of the last map change seen (objects published).
    const double frames_from_s = ros::WallTime::now().toSec();
    double change_s = frames_from_s;
    size_t published = outputs.objectsReceived();
    publishUntil(after(std::uniform_real_distribution<double>(1.5, 4.0)(rng)), [&] {
      if (outputs.objectsReceived() != published) {
        published = outputs.objectsReceived();
        change_s = ros::WallTime::now().toSec();
      }
      return false;
    });
    // Every other cycle (the first among them, so that there is a file to resume from): this node
    // saves periodically, frames on until the file holds a change seen now, that is two saves end
    // after it (the second one's snapshot is taken after the first ended). Not timed: a sanitizer
    // build on a loaded machine takes seconds for a save, and a restarted node first encodes the
    // loaded map's history. The other cycles kill the node wherever the random run left it, often
    // before its first save: the file is then the one the previous node left.
    if (cycle % 2 == 0) {
      int saves_after_change = 0;
      double last_mtime_s = modificationTimeS(autosave_map);
      const bool held = publishUntil(after(120.0), [&] {
        const double mtime_s = modificationTimeS(autosave_map);
        if (mtime_s <= last_mtime_s) return false;
        last_mtime_s = mtime_s;
        if (mtime_s > change_s) ++saves_after_change;
        return saves_after_change == 2;
      });
      ASSERT_TRUE(held) << "the node did not autosave the change seen "
                        << ros::WallTime::now().toSec() - change_s << " s ago\n"
                        << outputs.allLogs();
      held_mtime_s = last_mtime_s;
    }
    // Then SIGKILL at a random moment of a save, a keyframe or neither.
    publishUntil(after(std::uniform_real_distribution<double>(0.0, 2.0)(rng)),
                 [] { return false; });
    const ros::WallTime killed_at = ros::WallTime::now();
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    node.pid = -1;
    // Whole, loadable, and no older than the save that held the change.
    std::vector<mvod::MapObject> saved;
    std::string error;
    ASSERT_TRUE(loadMapFile(autosave, &saved, &error)) << error;
    const double mtime_s = modificationTimeS(autosave_map);
    EXPECT_GE(mtime_s, held_mtime_s) << "the autosave went back to an older file";
    objects_before_kill = saved.size();
    std::printf(
        "[ INFO     ] cycle %d: killed %.1f s after the start of frames, autosave of %zu objects, "
        "%.2f s old\n",
        cycle, killed_at.toSec() - frames_from_s, saved.size(), killed_at.toSec() - mtime_s);
  }
  fs::remove_all(root);
}

// A node fed synthetic frames, 16 at its start. On the paper's (slow) method with a long queue
// (`slow`): the first keyframe processed, the others queued behind a long keyframe in progress.
// `subscribers`: how many nodes must listen to the inputs before the frames go (nodes started
// beside it on the same topics).
class FedNode {
 public:
  FedNode(ros::NodeHandle& nh, const std::string& node, bool slow = true, unsigned subscribers = 1)
      : slow_(slow),
        subscribers_(subscribers),
        node_(node),
        root_(fs::temp_directory_path() / ("mvod" + node + "_" + std::to_string(::getpid()))),
        stream_(SyntheticStream::Options()),
        inputs_(nh),
        outputs_(nh, node, true) {
    fs::remove_all(root_);
    fs::create_directories(root_ / "maps");
  }
  ~FedNode() {
    if (pid_ > 0) stop(SIGKILL);
    fs::remove_all(root_);
  }

  // Starts it (more parameters in `extra`) and feeds it; a failure says which step failed.
  ::testing::AssertionResult start(const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"_detector:=topic",
                                     "_pose_source:=topic",
                                     "_keyframe_mode:=every_n",
                                     "_keyframe_every_n:=1",
                                     slow_ ? "_paper_method:=true" : "_paper_method:=false",
                                     "_processing_queue_size:=30",
                                     "_refine_every_n_keyframes:=0"};
    // Autosave off unless `extra` sets it.
    if (std::none_of(extra.begin(), extra.end(), [](const std::string& arg) {
          return arg.rfind("_autosave_period_s:=", 0) == 0;
        })) {
      args.push_back("_autosave_period_s:=0");
    }
    args.insert(args.end(), extra.begin(), extra.end());
    pid_ = startNode((root_ / "maps").string(), node_, args, (root_ / "node.out").string());
    if (pid_ <= 0) return ::testing::AssertionFailure() << "fork failed";
    if (!ros::service::waitForService(node_ + "/get_objects", 30000)) {
      return ::testing::AssertionFailure() << "the node did not start";
    }
    if (!outputs_.waitFor(
            [&] { return inputs_.connected(subscribers_, subscribers_) && outputs_.connected(); },
            30.0)) {
      return ::testing::AssertionFailure() << "the topics did not connect";
    }
    second_ = static_cast<int>(std::floor(ros::Time::now().toSec()));
    feed(16);
    if (!outputs_.waitForObjectsCount(1, 60.0)) {
      return ::testing::AssertionFailure() << "no keyframe processed\n" << outputs_.allLogs();
    }
    return ::testing::AssertionSuccess();
  }

  // Publishes `frames` more frames, one stamp a second on from the last.
  void feed(int frames) {
    for (int i = 0; i < frames; ++i, ++frame_) {
      inputs_.publish(stream_.make(frame_ % stream_.options().num_frames, ros::Time(++second_)),
                      true, true);
    }
  }
  // Frames the node never gets: their stamps and frames pass unpublished (lost before the node).
  void skip(int frames) {
    frame_ += frames;
    second_ += frames;
  }
  pid_t pid() const { return pid_; }
  // Sends `signal` and waits for the node to end; its wait status.
  int stop(int signal) {
    int status = -1;
    if (pid_ > 0 && ::kill(pid_, signal) == 0) ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  const fs::path& root() const { return root_; }
  NodeOutputs& outputs() { return outputs_; }

 private:
  const bool slow_;
  const unsigned subscribers_;
  std::string node_;
  fs::path root_;
  int second_ = 0;
  int frame_ = 0;
  SyntheticStream stream_;
  InputPublisher inputs_;
  NodeOutputs outputs_;
  pid_t pid_ = -1;
};

TEST(NodeShutdownTest, SigintDoesNotWaitForTheQueuedKeyframes) {
  // The paper's method (slow) with a long queue: SIGINT cancels the keyframe in progress and drops
  // the queue instead of working it off first.
  ros::NodeHandle nh;
  FedNode node(nh, "/sigint_node");
  ASSERT_TRUE(node.start({}));
  const ros::WallTime signalled = ros::WallTime::now();
  const int status = node.stop(SIGINT);
  const double exit_s = (ros::WallTime::now() - signalled).toSec();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
  std::printf("[ INFO     ] SIGINT to exit: %.2f s\n", exit_s);
  // The queue was dropped (or the keyframe in progress cancelled), not worked off.
  std::string logs;
  mvod::readFile((node.root() / "node.out").string(), &logs);
  EXPECT_TRUE(logs.find("queued keyframe(s) dropped") != std::string::npos ||
              logs.find("cancelled (shutdown)") != std::string::npos)
      << logs;
}

// map_directory is proved writable at start: with autosave on, a directory the node cannot write
// ends the start naming it (the first autosave would have failed a minute later); with autosave off
// the node runs and warns that ~save_map will fail.
TEST(NodeStartTest, AnUnwritableMapDirectoryIsReportedAtStart) {
  const fs::path root = fs::temp_directory_path() / ("mvod_map_dir_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  const std::string node = "/map_dir_node";
  const auto run = [&](const std::vector<std::string>& extra, const std::string& out) {
    std::vector<std::string> args = {"_detector:=topic", "_pose_source:=topic",
                                     "_map_directory:=/proc/self"};
    args.insert(args.end(), extra.begin(), extra.end());
    return startNode((root / "maps").string(), node, args, (root / out).string());
  };
  // Autosave on (the default): the node ends.
  const pid_t refused = run({}, "refused.out");
  ASSERT_GT(refused, 0);
  int status = 0;
  pid_t ended = 0;
  for (int i = 0; i < 600 && ended == 0; ++i) {
    ended = ::waitpid(refused, &status, WNOHANG);
    if (ended == 0) ros::WallDuration(0.1).sleep();
  }
  if (ended == 0) {
    ::kill(refused, SIGKILL);
    ::waitpid(refused, &status, 0);
  }
  EXPECT_EQ(ended, refused) << "the node kept running with an unwritable map_directory";
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << "status " << status;
  std::string logs;
  mvod::readFile((root / "refused.out").string(), &logs);
  EXPECT_NE(logs.find("map_directory '/proc/self' is not writable"), std::string::npos) << logs;

  // Autosave off: it runs, and says why saving will fail.
  const pid_t running = run({"_autosave_period_s:=0"}, "running.out");
  ASSERT_GT(running, 0);
  EXPECT_TRUE(ros::service::waitForService(node + "/get_objects", 30000));
  ::kill(running, SIGINT);
  ::waitpid(running, &status, 0);
  mvod::readFile((root / "running.out").string(), &logs);
  EXPECT_NE(logs.find("~save_map will fail"), std::string::npos) << logs;
  fs::remove_all(root);
}

TEST(NodeStartTest, TheFirstGetObjectsAnswersTheMapLoadedAtStart) {
  // A map big enough that loading it takes a while: ~get_objects must not be advertised (and answer
  // an empty map) before load_map_on_start has read it.
  const fs::path root =
      fs::temp_directory_path() / ("mvod_load_start_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  constexpr int kObjects = 24;
  constexpr int kPointsPerObject = 25000;
  std::vector<mvod::MapObject> objects;
  for (int id = 1; id <= kObjects; ++id) {
    mvod::MapObject object;
    object.id = id;
    object.class_id = 56;
    object.class_name = "chair";
    object.probability = 0.8;
    object.observations = 3;
    object.box.center_m = Eigen::Vector3d(1.5 * id, 0.0, 0.45);
    object.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
    object.box.rotation.setIdentity();
    object.last_keyframe = 2;
    // Points on the file format's 1 mm grid.
    for (int i = 0; i < kPointsPerObject; ++i) {
      object.points_W.emplace_back(1.5f * id + 0.001f * (i % 500), 0.001f * (i / 500), 0.45f);
    }
    object.segment_W = object.points_W;
    objects.push_back(std::move(object));
  }
  const std::string map_path = (root / "maps" / "big.json").string();
  ASSERT_TRUE(
      mvod::writeFileAtomic(map_path, mvod::objectsToJson(objects, mvod::MapSummary(), true)).ok());
  const std::string node = "/load_start_node";
  const pid_t pid = startNode((root / "maps").string(), node,
                              {"_detector:=topic", "_pose_source:=topic", "_autosave_period_s:=0",
                               "_load_map_on_start:=big.json"},
                              (root / "node.out").string());
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 60000));
  multiview_object_detection::GetObjects get;
  EXPECT_TRUE(ros::service::call(node + "/get_objects", get));
  EXPECT_EQ(get.response.objects.objects.size(), static_cast<size_t>(kObjects))
      << "the first ~get_objects did not answer the map loaded at start";
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::string logs;
  mvod::readFile((root / "node.out").string(), &logs);
  EXPECT_NE(logs.find("load_map_on_start: resumed 24 objects"), std::string::npos) << logs;
  fs::remove_all(root);
}

// A node killed in its first autosave, after the keyframe files and before map.json, leaves a
// folder without a map and the map.json's temporary. The respawned node starts empty and leaves
// the folder where it is (no map in it to keep aside, and the autosave's files stay beside its
// next save), and its autosave removes the dead node's temporary.
TEST(NodeStartTest, AFirstSaveKilledBeforeItsMapFileIsNoMapAndIsTidiedAway) {
  const fs::path root =
      fs::temp_directory_path() / ("mvod_cut_short_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const fs::path folder = root / "maps" / "cut_short_node.autosave.mvmap";
  fs::create_directories(folder / "keyframes");
  std::ofstream(folder / "keyframes" / "kf3-a1b2c3-7.0-0.kf") << "MVODKF01 cut short";
  std::ofstream(folder / ".lock");
  // A dead process's id: a child that has ended and been waited for.
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ASSERT_GT(dead, 0);
  ::waitpid(dead, nullptr, 0);
  std::ofstream(folder / (".map.json.save-" + std::to_string(dead) + ".Xy12Zw"))
      << "{\"objects\": [";

  const std::string node = "/cut_short_node";
  const pid_t pid = startNode((root / "maps").string(), node,
                              {"_detector:=topic", "_pose_source:=topic", "_autosave_period_s:=1",
                               "_load_map_on_start:=cut_short_node.autosave.mvmap"},
                              (root / "node.out").string());
  ASSERT_GT(pid, 0);
  KillOnExit running{pid};
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 30000));
  multiview_object_detection::GetObjects get;
  EXPECT_TRUE(ros::service::call(node + "/get_objects", get));
  EXPECT_TRUE(get.response.objects.objects.empty());
  const auto clean = [&] { return temporariesIn((root / "maps").string()).empty(); };
  for (int i = 0; i < 50 && !clean(); ++i) ros::WallDuration(0.1).sleep();
  EXPECT_TRUE(clean()) << "the dead node's temporary is still there";
  EXPECT_TRUE(fs::is_directory(folder)) << "the folder was moved";
  for (const auto& entry : fs::directory_iterator(root / "maps")) {
    EXPECT_EQ(entry.path().filename().string().find("unreadable"), std::string::npos)
        << "moved aside: " << entry.path();
  }
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  running.pid = -1;
  std::string logs;
  mvod::readFile((root / "node.out").string(), &logs);
  EXPECT_NE(logs.find("holds no map.json"), std::string::npos) << logs;
  EXPECT_EQ(logs.find("cannot load"), std::string::npos) << logs;
  fs::remove_all(root);
}

// service_timeout_s bounds the map changes: while the worker is in a long keyframe (the paper's
// method, a queue of 15), ~refine with a 0.1 s timeout answers "busy" and changes nothing, and
// ~get_objects keeps answering from the last snapshot meanwhile.
// A SLAM world tilted like ORB-SLAM2's (the redkitchen's gravity, y down): the node publishes TF
// map -> map_gravity_aligned with z against gravity and its origin on the floor the loaded map was
// saved with, and answers with the map's upright chair standing on that floor, 0.45 m up.
TEST(NodeOutputFrameTest, ATiltedWorldComesOutZUpOnTheLoadedMapsFloor) {
  const fs::path root =
      fs::temp_directory_path() / ("mvod_output_frame_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  const Eigen::Vector3d down = Eigen::Vector3d(-0.009, 0.904, 0.427).normalized();
  const mvod::GravityFrame gravity(down);
  constexpr double kFloorM = -1.3;  // 1.3 m below the first camera
  mvod::MapObject chair;
  chair.id = 4;
  chair.class_id = 56;
  chair.class_name = "chair";
  chair.probability = 0.8;
  chair.observations = 3;
  chair.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  chair.box.rotation = gravity.rotationFromYaw(0.3);
  chair.yaw_rad = 0.3;
  chair.box.center_m = (kFloorM + 0.45) * gravity.up + 2.0 * gravity.x_h;
  chair.last_keyframe = 2;
  mvod::MapSummary summary;
  summary.gravity_down_W = down;
  summary.floor_height_m = kFloorM;
  ASSERT_TRUE(mvod::writeFileAtomic((root / "maps" / "tilted.json").string(),
                                    mvod::objectsToJson({chair}, summary, false))
                  .ok());
  const std::string node = "/output_frame_node";
  // A list: not expressible as a _name:=value argument.
  ros::param::set(node + "/gravity_down", std::vector<double>{down.x(), down.y(), down.z()});
  const pid_t pid = startNode((root / "maps").string(), node,
                              {"_detector:=topic", "_pose_source:=topic", "_autosave_period_s:=0",
                               "_load_map_on_start:=tilted.json"},
                              (root / "node.out").string());
  ASSERT_GT(pid, 0);
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  std::string error;
  const bool has_tf =
      tf_buffer.canTransform(kWorldFrame, kOutputFrame, ros::Time(0), ros::Duration(30.0), &error);
  multiview_object_detection::GetObjects get;
  const bool answered = ros::service::waitForService(node + "/get_objects", 30000) &&
                        ros::service::call(node + "/get_objects", get);
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::string logs;
  mvod::readFile((root / "node.out").string(), &logs);
  fs::remove_all(root);
  ros::param::del(node);

  ASSERT_TRUE(answered) << logs;
  ASSERT_TRUE(has_tf) << error << "\n" << logs;
  const geometry_msgs::Transform t =
      tf_buffer.lookupTransform(kWorldFrame, kOutputFrame, ros::Time(0)).transform;
  const Eigen::Quaterniond q(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z);
  const Eigen::Vector3d origin_W(t.translation.x, t.translation.y, t.translation.z);
  EXPECT_LT((q.toRotationMatrix().col(2) + down).norm(), 1e-6) << "z of the output frame is not up";
  EXPECT_LT((origin_W - kFloorM * gravity.up).norm(), 1e-6) << origin_W.transpose();

  const multiview_object_detection::ObjectArray& answer = get.response.objects;
  EXPECT_EQ(answer.header.frame_id, kOutputFrame);
  ASSERT_EQ(answer.objects.size(), 1u) << logs;
  const Eigen::Isometry3d T_O_B = fromPoseMsg(answer.objects[0].pose);
  EXPECT_GT(T_O_B.linear().col(2).z(), 1.0 - 1e-6) << "the chair is not upright";
  EXPECT_NEAR(T_O_B.translation().z(), 0.45, 1e-4) << "not 0.45 m above the floor";
  EXPECT_NEAR(std::atan2(T_O_B.linear()(1, 0), T_O_B.linear()(0, 0)), 0.3, 1e-4);
}

TEST(NodeServicesTest, MapChangesAnswerBusyPastTheTimeoutAndReadersKeepAnswering) {
  ros::NodeHandle nh;
  FedNode slow(nh, "/busy_node");
  ASSERT_TRUE(slow.start({"_service_timeout_s:=0.1"}));
  const std::string node = "/busy_node";
  int busy = 0, refined = 0, read = 0;
  for (int i = 0; i < 20; ++i) {
    std_srvs::Trigger refine;
    if (ros::service::call(node + "/refine", refine)) {
      if (!refine.response.success) {
        EXPECT_NE(refine.response.message.find("busy"), std::string::npos)
            << refine.response.message;
        ++busy;
      } else {
        ++refined;
      }
    }
    multiview_object_detection::GetObjects get;
    if (ros::service::call(node + "/get_objects", get)) ++read;
  }
  std::printf("[ INFO     ] ~refine: %d busy, %d done; ~get_objects answered %d of 20\n", busy,
              refined, read);
  EXPECT_GT(busy, 0) << "~refine never gave up waiting for the keyframe in progress";
  slow.stop(SIGINT);
  // A read that failed: the node's log says whether it refused or threw (the call itself only
  // returns false).
  std::string logs;
  mvod::readFile((slow.root() / "node.out").string(), &logs);
  EXPECT_EQ(read, 20) << "the node's log:\n" << logs;
}

// /diagnostics notices a dead input: with input_timeout_s 2, the colour topic's status is an ERROR
// naming it within seconds of the start (nothing published), OK while frames come, and an ERROR
// again once they stop.
TEST(NodeDiagnosticsTest, ADeadInputIsAnErrorAndOkWhenItResumes) {
  ros::NodeHandle nh;
  const std::string node = "/diagnostics_node";
  const fs::path root = fs::temp_directory_path() / ("mvod_diag_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  std::mutex mutex;
  std::map<std::string, diagnostic_msgs::DiagnosticStatus> statuses;  // by name, the latest
  const ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 50, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        for (const diagnostic_msgs::DiagnosticStatus& status : msg->status) {
          if (status.name.rfind(node.substr(1) + ":", 0) == 0) statuses[status.name] = status;
        }
      });
  const std::string colour = node.substr(1) + ": input " + kRgbTopic;
  const auto levelIs = [&](int level) {
    std::lock_guard<std::mutex> lock(mutex);
    const auto found = statuses.find(colour);
    return found != statuses.end() && found->second.level == level;
  };
  const auto describe = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    std::string text;
    for (const auto& [name, status] : statuses) {
      text += name + ": " + std::to_string(status.level) + " " + status.message + "\n";
    }
    return text;
  };
  SyntheticStream stream{SyntheticStream::Options()};
  InputPublisher inputs(nh);
  NodeOutputs outputs(nh, node, true);
  const pid_t pid = startNode(
      (root / "maps").string(), node,
      {"_detector:=topic", "_pose_source:=topic", "_input_timeout_s:=2", "_autosave_period_s:=0"},
      (root / "node.out").string());
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 30000));
  EXPECT_TRUE(outputs.waitFor([&] { return levelIs(2); }, 15.0))
      << "no ERROR for the silent colour topic\n"
      << describe();
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_NE(statuses[colour].message.find(kRgbTopic), std::string::npos);
    // The node's name tells which of several mappers a status is from (issue 47: it was "none").
    EXPECT_EQ(statuses[colour].hardware_id, node);
    EXPECT_EQ(statuses.count(node.substr(1) + ": map"), 1u) << describe();
  }
  // Frames at about 5 Hz until the status is OK (at most 15 s).
  int second = static_cast<int>(std::floor(ros::Time::now().toSec()));
  bool ok = false;
  for (int i = 0; i < 75 && !ok; ++i) {
    inputs.publish(stream.make(i % stream.options().num_frames, ros::Time(++second)), true, true);
    ros::WallDuration(0.2).sleep();
    ok = levelIs(0);
  }
  EXPECT_TRUE(ok) << "the colour topic's status did not return to OK\n" << describe();
  // Stopped: an ERROR again.
  EXPECT_TRUE(outputs.waitFor([&] { return levelIs(2); }, 15.0)) << describe();
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::string logs;
  mvod::readFile((root / "node.out").string(), &logs);
  EXPECT_NE(logs.find(std::string("nothing on '") + kRgbTopic), std::string::npos) << logs;
  fs::remove_all(root);
}

// Issue 57, items 1-3: what a strange or shared map folder does to the node.

// Waits up to `timeout_s` for the process to end; its wait status, or -1 (then it was killed).
int waitForExit(pid_t pid, double timeout_s) {
  int status = 0;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::WallTime::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    ros::WallDuration(0.05).sleep();
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

std::string readLog(const fs::path& path) {
  std::string text;
  mvod::readFile(path.string(), &text);
  return text;
}

// A FIFO in place of the folder's lock file: the start neither hangs on it (load_map_on_start) nor
// keeps the node from ending at SIGTERM; the load is refused naming the FIFO.
TEST(NodeMapFolderTest, AFifoAtTheLockNeitherHangsTheStartNorOutlivesSigterm) {
  const fs::path root =
      fs::temp_directory_path() / ("mvod_fifo_lock_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const fs::path folder = root / "maps" / "fifo_node.autosave.mvmap";
  fs::create_directories(root / "maps");
  mvod::MapObject chair;
  chair.id = 1;
  chair.class_id = 56;
  chair.class_name = "chair";
  chair.probability = 0.8;
  chair.observations = 3;
  chair.box.center_m = Eigen::Vector3d(1.0, 0.0, 0.45);
  chair.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  chair.box.rotation.setIdentity();
  ASSERT_TRUE(mvod::MapFolderWriter().write(folder.string(), {chair}, mvod::MapSummary(), {}).ok());
  fs::remove(folder / ".lock");
  ASSERT_EQ(::mkfifo((folder / ".lock").c_str(), 0600), 0);
  const std::string node = "/fifo_node";
  const pid_t pid = startNode((root / "maps").string(), node,
                              {"_detector:=topic", "_pose_source:=topic", "_autosave_period_s:=1",
                               "_load_map_on_start:=fifo_node.autosave.mvmap"},
                              (root / "node.out").string());
  ASSERT_GT(pid, 0);
  KillOnExit running{pid};
  EXPECT_TRUE(ros::service::waitForService(node + "/get_objects", 30000))
      << "the node did not start\n"
      << readLog(root / "node.out");
  ::kill(pid, SIGTERM);
  const int status = waitForExit(pid, 20.0);
  running.pid = -1;
  EXPECT_NE(status, -1) << "SIGTERM did not end the node";
  const std::string logs = readLog(root / "node.out");
  EXPECT_NE(logs.find("FIFO"), std::string::npos) << logs;
  fs::remove_all(root);
}

// Two nodes with one autosave_path: the second takes a folder of its own and says so; both maps
// are saved, neither overwrites the other.
TEST(NodeMapFolderTest, TwoNodesOnOneAutosavePathEachSaveTheirOwnMap) {
  ros::NodeHandle nh;
  FedNode first(nh, "/twin_a", false, 2);
  const fs::path maps = first.root() / "maps";
  const std::vector<std::string> shared = {"_autosave_path:=twins.mvmap", "_autosave_period_s:=1"};
  std::vector<std::string> args = {"_detector:=topic",           "_pose_source:=topic",
                                   "_keyframe_mode:=every_n",    "_keyframe_every_n:=1",
                                   "_processing_queue_size:=30", "_refine_every_n_keyframes:=0"};
  args.insert(args.end(), shared.begin(), shared.end());
  const pid_t second = startNode(maps.string(), "/twin_b", args, (first.root() / "b.out").string());
  ASSERT_GT(second, 0);
  KillOnExit running{second};
  ASSERT_TRUE(ros::service::waitForService("/twin_b/get_objects", 30000));
  ASSERT_TRUE(first.start(shared));
  const auto saved = [&] {
    return fs::exists(maps / "twins.mvmap" / "map.json") &&
           fs::exists(maps / "twins-2.mvmap" / "map.json");
  };
  for (int i = 0; i < 180 && !saved(); ++i) {  // 90 s at most: a sanitizer build is slow
    first.feed(2);
    ros::WallDuration(0.5).sleep();
  }
  EXPECT_TRUE(saved()) << readLog(first.root() / "node.out") << readLog(first.root() / "b.out");
  ::kill(second, SIGINT);
  EXPECT_NE(waitForExit(second, 30.0), -1);
  running.pid = -1;
  first.stop(SIGINT);
  const std::string logs = readLog(first.root() / "node.out") + readLog(first.root() / "b.out");
  EXPECT_NE(logs.find("in use by another process (pid "), std::string::npos) << logs;
  EXPECT_NE(logs.find("twins-2.mvmap instead"), std::string::npos) << logs;
  for (const char* folder : {"twins.mvmap", "twins-2.mvmap"}) {
    std::vector<mvod::MapObject> objects;
    const mvod::Status loaded =
        mvod::loadMap((maps / folder).string(), mvod::Links::kRefuse, &objects, nullptr, nullptr);
    EXPECT_TRUE(loaded.ok()) << folder << ": " << loaded.message();
    EXPECT_FALSE(objects.empty()) << folder;
  }
}

// A save that cannot go where it should (a directory put where the lock file was, after the
// start) goes to the fallback beside it, and /diagnostics turns ERROR naming both.
TEST(NodeMapFolderTest, ASaveThatCannotGoWhereItShouldGoesToTheFallback) {
  ros::NodeHandle nh;
  const std::string node = "/fallback_node";
  std::mutex mutex;
  diagnostic_msgs::DiagnosticStatus map_status;
  const ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 50, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& msg) {
        const std::lock_guard<std::mutex> lock(mutex);
        for (const diagnostic_msgs::DiagnosticStatus& status : msg->status) {
          if (status.name == node.substr(1) + ": map") map_status = status;
        }
      });
  FedNode fed(nh, node, false);
  const fs::path folder = fed.root() / "maps" / "fallback_node.autosave.mvmap";
  const fs::path fallback = fed.root() / "maps" / "fallback_node.autosave-2.mvmap";
  ASSERT_TRUE(fed.start({"_autosave_period_s:=1"}));
  NodeOutputs& outputs = fed.outputs();
  ASSERT_TRUE(outputs.waitFor([&] { return fs::exists(folder / "map.json"); }, 90.0));
  fs::remove(folder / ".lock");
  fs::create_directory(folder / ".lock");
  bool moved = false;
  for (int i = 0; i < 300 && !moved; ++i) {
    fed.feed(1);
    ros::WallDuration(0.3).sleep();
    moved = fs::exists(fallback / "map.json");
  }
  EXPECT_TRUE(moved) << readLog(fed.root() / "node.out");
  const bool error = outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return map_status.level == diagnostic_msgs::DiagnosticStatus::ERROR;
      },
      15.0);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(error) << map_status.message;
    EXPECT_NE(map_status.message.find(fallback.string() + " instead"), std::string::npos)
        << map_status.message;
    EXPECT_NE(map_status.message.find("directory"), std::string::npos) << map_status.message;
  }
  fed.stop(SIGINT);
  std::vector<mvod::MapObject> objects;
  const mvod::Status loaded =
      mvod::loadMap(fallback.string(), mvod::Links::kRefuse, &objects, nullptr, nullptr);
  EXPECT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_FALSE(objects.empty());
}

// Issue 57, item 4: processing_queue_max_mb bounds the queue by its images, whatever its length
// (here 1 MB, two or three of the 320x240 keyframes, in a queue of 30 behind the slow method), and
// /diagnostics shows the queue's memory and the process's.
// The node's map status on /diagnostics, each handed to `on_status` under `mutex`.
ros::Subscriber subscribeMapStatus(
    ros::NodeHandle& nh, const std::string& node, std::mutex* mutex,
    const std::function<void(const diagnostic_msgs::DiagnosticStatus&)>& on_status) {
  return nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 50,
      [node, mutex, on_status](const diagnostic_msgs::DiagnosticArrayConstPtr& msg) {
        const std::lock_guard<std::mutex> lock(*mutex);
        for (const diagnostic_msgs::DiagnosticStatus& status : msg->status) {
          if (status.name == node.substr(1) + ": map") on_status(status);
        }
      });
}

// Frames lost before the node (issue 55, item 5): a stream whose images stop for 3 frames and go
// on. The node counts the gap from the stamps (these frames carry no sequence numbers) and warns on
// /diagnostics with the share, instead of a map status that stays 'ok'.
TEST(NodeFrameGapsTest, FramesLostBeforeTheNodeAreCountedAndWarned) {
  ros::NodeHandle nh;
  const std::string node = "/gaps_node";
  std::mutex mutex;
  double lost = -1.0;
  double received = -1.0;
  std::string warning;
  const ros::Subscriber sub =
      subscribeMapStatus(nh, node, &mutex, [&](const diagnostic_msgs::DiagnosticStatus& status) {
        for (const diagnostic_msgs::KeyValue& value : status.values) {
          const double number = std::atof(value.value.c_str());
          if (value.key == "frames lost before the node") lost = number;
          if (value.key == "frames received") received = number;
        }
        if (status.level == diagnostic_msgs::DiagnosticStatus::WARN &&
            status.message.find("lost before the node") != std::string::npos) {
          warning = status.message;
        }
      });
  FedNode fed(nh, node, false);
  ASSERT_TRUE(fed.start({"_diagnostic_period:=0.2"}));
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(warning.empty()) << warning;  // 16 frames one second apart: nothing lost
  }
  fed.skip(3);
  fed.feed(8);
  NodeOutputs& outputs = fed.outputs();
  EXPECT_TRUE(outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return received >= 24.0 && !warning.empty();
      },
      30.0))
      << "received " << received << ", lost " << lost;
  fed.stop(SIGINT);
  const std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(lost, 3.0);
  EXPECT_EQ(received, 24.0);
  // The share at the report after the gap: 3 of (3 + the frames received by then).
  EXPECT_EQ(warning.rfind("3 of ", 0), 0u) << warning;
  EXPECT_NE(warning.find(" %) lost before the node"), std::string::npos) << warning;
  const std::string logs = readLog(fed.root() / "node.out");
  EXPECT_NE(logs.find("3 frame(s) lost just before"), std::string::npos) << logs;
}

// A SLAM's TF stamped when it is published, not with its image's stamp (ethz-asl/orb_slam_2_ros;
// issue 55, item 1): the node names it on /diagnostics and in its log. The same stream with the
// TF at the images' stamps (appliedAI's wrapper) says nothing.
TEST(NodeTfStampTest, ATfStampedWhenPublishedIsAWarningNamingTheCause) {
  ros::NodeHandle nh;
  const std::string node = "/tf_stamp_node";
  const fs::path root = fs::temp_directory_path() / ("mvod_tf_stamp_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  std::mutex mutex;
  std::string warning;
  double received = -1.0;
  int statuses = 0;
  const ros::Subscriber sub =
      subscribeMapStatus(nh, node, &mutex, [&](const diagnostic_msgs::DiagnosticStatus& status) {
        ++statuses;
        for (const diagnostic_msgs::KeyValue& value : status.values) {
          if (value.key == "frames received") received = std::atof(value.value.c_str());
        }
        if (status.message.find("stamped when it was published") != std::string::npos) {
          warning = status.message;
        }
      });
  SyntheticStream stream{SyntheticStream::Options()};
  InputPublisher inputs(nh);
  NodeOutputs outputs(nh, node, true);
  const pid_t pid =
      startNode((root / "maps").string(), node,
                {"_detector:=topic", "_pose_source:=tf", "_keyframe_mode:=every_n",
                 "_keyframe_every_n:=5", "_autosave_period_s:=0", "_diagnostic_period:=0.2"},
                (root / "node.out").string());
  ASSERT_GT(pid, 0);
  KillOnExit guard{pid};
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 30000));
  ASSERT_TRUE(outputs.waitFor([&] { return inputs.connected(1, 0) && outputs.connected(); }, 30.0));
  // A stream of about 20 frames a second (the pause is the camera's frame period, not a wait for
  // the node); `at_publishing`: the pose's TF goes after the images, stamped then.
  int frame = 0;
  auto feed = [&](int frames, bool at_publishing) {
    for (int i = 0; i < frames; ++i, ++frame) {
      FrameMsgs msgs = stream.make(frame % stream.options().num_frames, ros::Time::now());
      if (at_publishing) {
        inputs.publish(msgs, false, true, false);
        msgs.pose.header.stamp = ros::Time::now();
        inputs.publishTf(msgs.pose);
      } else {
        inputs.publish(msgs, false, true, true);
      }
      ros::WallDuration(0.03).sleep();
    }
  };
  feed(80, false);
  ASSERT_TRUE(outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return received >= 80.0;
      },
      20.0))
      << "received " << received;
  // Three more map statuses: the node's judgement (made as the transforms came) is in them.
  int statuses_then = 0;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    statuses_then = statuses;
  }
  ASSERT_TRUE(outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return statuses >= statuses_then + 3;
      },
      20.0));
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(warning.empty()) << warning;
  }
  feed(80, true);
  EXPECT_TRUE(outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return !warning.empty();
      },
      20.0));
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_NE(warning.find("TF 'map' -> '" + std::string(kCameraFrame) + "'"), std::string::npos)
        << warning;
    EXPECT_NE(warning.find("ethz-asl/orb_slam_2_ros"), std::string::npos) << warning;
  }
  ::kill(pid, SIGINT);
  ::waitpid(pid, nullptr, 0);
  guard.pid = -1;
  const std::string logs = readLog(root / "node.out");
  EXPECT_NE(logs.find("looks stamped when it was published"), std::string::npos) << logs;
  fs::remove_all(root);
}

// A bag played again (or a clock reset) while the synchroniser still holds a message of the old
// stream: message_filters warned "Messages of type 0 arrived out of order" and held the old
// message against the new stream (issue 56, after ~reset and a replay). The node now starts its
// synchroniser afresh, says why, and takes the new stream's frames.
TEST(NodeInputTimeJumpTest, ABagPlayedAgainRestartsTheSynchroniser) {
  ros::NodeHandle nh;
  const std::string node = "/time_jump_node";
  const fs::path root =
      fs::temp_directory_path() / ("mvod_time_jump_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "maps");
  std::mutex mutex;
  double received = -1.0;
  const ros::Subscriber sub =
      subscribeMapStatus(nh, node, &mutex, [&](const diagnostic_msgs::DiagnosticStatus& status) {
        for (const diagnostic_msgs::KeyValue& value : status.values) {
          if (value.key == "frames received") received = std::atof(value.value.c_str());
        }
      });
  SyntheticStream stream{SyntheticStream::Options()};
  InputPublisher inputs(nh);
  NodeOutputs outputs(nh, node, true);
  const pid_t pid =
      startNode((root / "maps").string(), node,
                {"_detector:=topic", "_pose_source:=topic", "_keyframe_mode:=every_n",
                 "_keyframe_every_n:=1", "_autosave_period_s:=0", "_diagnostic_period:=0.2"},
                (root / "node.out").string());
  ASSERT_GT(pid, 0);
  KillOnExit guard{pid};
  ASSERT_TRUE(ros::service::waitForService(node + "/get_objects", 30000));
  ASSERT_TRUE(outputs.waitFor([&] { return inputs.connected(1, 1) && outputs.connected(); }, 30.0));
  const auto received_at_least = [&](double count) {
    return outputs.waitFor(
        [&] {
          const std::lock_guard<std::mutex> lock(mutex);
          return received >= count;
        },
        30.0);
  };
  const ros::Time start = ros::Time::now();
  auto feed = [&](const ros::Time& first, int frames) {
    for (int i = 0; i < frames; ++i) {
      inputs.publish(stream.make(i % stream.options().num_frames, first + ros::Duration(0.1 * i)));
    }
  };
  feed(start, 5);
  ASSERT_TRUE(received_at_least(5.0)) << "received " << received;
  // The old stream's last colour image and camera_info, without their depth image: they stay in
  // the synchroniser. Messages of one topic arrive in order, so they are there before the new
  // stream's colour image and camera_info.
  FrameMsgs last = stream.make(5, start + ros::Duration(0.5));
  inputs.info_.publish(last.info);
  inputs.rgb_.publish(last.rgb);
  // The bag again, from its start: 10 s earlier.
  feed(start - ros::Duration(10.0), 5);
  EXPECT_TRUE(received_at_least(10.0)) << "received " << received;
  ::kill(pid, SIGINT);
  ::waitpid(pid, nullptr, 0);
  guard.pid = -1;
  const std::string logs = readLog(root / "node.out");
  EXPECT_EQ(logs.find("arrived out of order"), std::string::npos) << logs;
  EXPECT_NE(logs.find("the RGB-D synchroniser starts afresh"), std::string::npos) << logs;
  fs::remove_all(root);
}

TEST(NodeMemoryTest, TheQueueIsBoundedByItsImagesMemory) {
  ros::NodeHandle nh;
  const std::string node = "/queue_mb_node";
  std::mutex mutex;
  double max_queue_mb = -1.0;
  double max_queue_length = -1.0;
  double dropped = -1.0;
  double rss_mb = -1.0;
  const ros::Subscriber sub =
      subscribeMapStatus(nh, node, &mutex, [&](const diagnostic_msgs::DiagnosticStatus& status) {
        for (const diagnostic_msgs::KeyValue& value : status.values) {
          const double number = std::atof(value.value.c_str());
          if (value.key == "queue MB") max_queue_mb = std::max(max_queue_mb, number);
          if (value.key == "queue length") max_queue_length = std::max(max_queue_length, number);
          if (value.key == "keyframes dropped") dropped = number;
          if (value.key == "process RSS MB") rss_mb = number;
        }
      });
  FedNode fed(nh, node, true);
  ASSERT_TRUE(fed.start({"_processing_queue_max_mb:=1", "_diagnostic_period:=0.2"}));
  NodeOutputs& outputs = fed.outputs();
  EXPECT_TRUE(outputs.waitFor(
      [&] {
        const std::lock_guard<std::mutex> lock(mutex);
        return dropped >= 10.0 && rss_mb > 0.0;
      },
      30.0));
  fed.stop(SIGINT);
  const std::lock_guard<std::mutex> lock(mutex);
  EXPECT_GE(dropped, 10.0) << "16 keyframes in a queue of 30: the memory bound dropped none";
  EXPECT_LE(max_queue_length, 3.0);
  EXPECT_GT(max_queue_mb, 0.0);
  EXPECT_LE(max_queue_mb, 1.0);
  EXPECT_GT(rss_mb, 10.0);
  const std::string logs = readLog(fed.root() / "node.out");
  EXPECT_NE(logs.find("processing queue full (processing_queue_max_mb"), std::string::npos) << logs;
}

}  // namespace
}  // namespace mvod_test

int main(int argc, char** argv) { return mvod_test::runRosTests(argc, argv, "test_node_autosave"); }
