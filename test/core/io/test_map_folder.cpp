// The node's map folder (map_folder.h): whatever is saved loads back equal, a history at its memory
// bound included (keyframes with full, coarse and no depth); a save writes only the keyframes that
// are new or changed; a save killed midway leaves the previous map whole; concurrent savers to one
// folder all succeed; the single-file map of 0.9.x still loads; which map a name stands for.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "history_records.h"
#include "multiview_object_detection/io/map_folder.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

MapObject folderTestObject(int id) {
  MapObject object;
  object.id = id;
  object.class_id = 56;
  object.class_name = "chair";
  object.probability = 0.75;
  object.observations = 4;
  object.box.center_m = Eigen::Vector3d(1.0 * id, 0.5, 0.45);
  object.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  object.box.rotation.setIdentity();
  object.last_keyframe = 3;
  for (int i = 0; i < 50; ++i) object.points_W.emplace_back(0.001f * i + id, 0.5f, 0.45f);
  object.segment_W = object.points_W;
  return object;
}

// A history as KeyframeHistory keeps it (uids set), with depth of every kind: 16-bit, 32-bit,
// coarse and given up.
std::deque<KeyframeRecord> folderTestHistory() {
  KeyframeHistory history;
  for (int k = 0; k < 6; ++k) {
    KeyframeRecord record = test::makeRecord(k, k % 2 == 0 ? CV_16UC1 : CV_32FC1);
    if (k == 2) coarsenDepth(&record);
    if (k == 4) record.depth.release();
    history.add(std::move(record));
  }
  return history.records();
}

// Everything a map holds, as the single-file format writes it: equal strings, equal maps.
std::string asText(const std::vector<MapObject>& objects, const MapSummary& summary,
                   const std::deque<KeyframeRecord>& history) {
  return objectsToJson(objects, summary, true, &history);
}

class MapFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::freshTestDir("mvod_map_folder");
    folder_ = (dir_ / "kitchen.mvmap").string();
    summary_.frames = 120;
    summary_.keyframes = 6;
    summary_.floor_height_m = -1.25;
    objects_ = {folderTestObject(1), folderTestObject(4)};
  }
  void TearDown() override { fs::remove_all(dir_); }

  void expectLoadsAs(const std::deque<KeyframeRecord>& history) {
    std::vector<MapObject> objects;
    MapSummary summary;
    std::deque<KeyframeRecord> loaded;
    const Status status = loadMap(folder_, Links::kRefuse, &objects, &summary, &loaded);
    ASSERT_TRUE(status.ok()) << status.message();
    test::expectSameHistory(history, loaded);
    EXPECT_EQ(asText(objects, summary, loaded), asText(objects_, summary_, history));
  }
  std::vector<std::string> keyframeFiles() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(fs::path(folder_) / "keyframes")) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }

  fs::path dir_;
  std::string folder_;
  MapSummary summary_;
  std::vector<MapObject> objects_;
};

TEST_F(MapFolderTest, WhatIsSavedLoadsBackEqual) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  MapFolderWriter writer;
  MapFolderWriter::Report report;
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 6);
  EXPECT_EQ(keyframeFiles().size(), 6u);
  EXPECT_GT(report.folder_bytes, 0u);
  expectLoadsAs(history);
  // Saving the loaded map again is a fixed point.
  std::deque<KeyframeRecord> loaded;
  std::vector<MapObject> objects;
  MapSummary summary;
  ASSERT_TRUE(loadMap(folder_, Links::kRefuse, &objects, &summary, &loaded).ok());
  const std::string again = (dir_ / "again.mvmap").string();
  ASSERT_TRUE(MapFolderWriter().write(again, objects, summary, loaded).ok());
  std::deque<KeyframeRecord> reloaded;
  ASSERT_TRUE(loadMap(again, Links::kRefuse, nullptr, nullptr, &reloaded).ok());
  test::expectSameHistory(history, reloaded);
}

TEST_F(MapFolderTest, ASaveWritesOnlyTheKeyframesThatAreNewOrChanged) {
  KeyframeHistory history;
  for (int k = 0; k < 4; ++k) history.add(test::makeRecord(k, CV_16UC1));
  MapFolderWriter writer;
  MapFolderWriter::Report report;
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history.records(), &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 4);
  // Unchanged: nothing but map.json.
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history.records(), &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 0);
  EXPECT_EQ(report.keyframe_files_reused, 4);
  // A new keyframe, a corrected pose and a relabelled view (both in map.json), a coarsened depth.
  history.add(test::makeRecord(4, CV_32FC1));
  history.mutableRecords()[0].T_W_D.translation().x() += 0.25;
  history.mutableRecords()[1].views[0].object_id = 99;
  coarsenDepth(&history.mutableRecords()[2]);  // a new revision of its data
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history.records(), &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 2);  // the new one, the coarsened one
  EXPECT_EQ(report.keyframe_files_reused, 3);
  EXPECT_EQ(report.keyframe_files_removed, 1);  // the coarsened one's old file
  EXPECT_LT(report.bytes_written, report.folder_bytes);
  expectLoadsAs(history.records());
  // Keyframes forgotten: their files go.
  std::deque<KeyframeRecord> fewer = history.records();
  fewer.pop_front();
  fewer.pop_front();
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, fewer, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 0);
  EXPECT_EQ(report.keyframe_files_removed, 2);
  EXPECT_EQ(keyframeFiles().size(), 3u);
  expectLoadsAs(fewer);
  // A writer that did not write the folder's files writes its own (another save's files are
  // never taken for its own), and the old ones go once its map.json is in place.
  MapFolderWriter other;
  ASSERT_TRUE(other.write(folder_, objects_, summary_, fewer, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 3);
  EXPECT_EQ(report.keyframe_files_removed, 3);
  expectLoadsAs(fewer);
  // A file deleted behind the writer's back is written again.
  fs::remove(fs::path(folder_) / "keyframes" / keyframeFiles().front());
  ASSERT_TRUE(other.write(folder_, objects_, summary_, fewer, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 1);
  expectLoadsAs(fewer);
}

// A node resuming its autosave (load_map_on_start): its writer adopts the loaded files, so its
// first save writes only the keyframes new or changed since the load, not the whole history again.
TEST_F(MapFolderTest, AWriterAdoptingTheLoadedFilesWritesOnlyWhatChangedSinceTheLoad) {
  ASSERT_TRUE(MapFolderWriter().write(folder_, objects_, summary_, folderTestHistory()).ok());
  std::deque<KeyframeRecord> loaded;
  std::map<int, std::string> files;
  ASSERT_TRUE(loadMap(folder_, Links::kRefuse, nullptr, nullptr, &loaded, &files).ok());
  ASSERT_EQ(files.size(), 6u);
  for (const auto& [keyframe, file] : files) {
    EXPECT_TRUE(fs::exists(fs::path(folder_) / "keyframes" / file)) << keyframe << ": " << file;
  }
  // The history as the resumed node holds it: new uids, then one record coarsened and one added.
  KeyframeHistory history;
  for (KeyframeRecord& record : loaded) history.add(std::move(record));
  history.add(test::makeRecord(6, CV_16UC1));
  std::deque<KeyframeRecord> now = history.records();
  coarsenDepth(&now[0]);

  MapFolderWriter resumed;
  resumed.adopt(folder_, history.records(), files);
  MapFolderWriter::Report report;
  ASSERT_TRUE(resumed.write(folder_, objects_, summary_, now, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 2) << "the coarsened record and the new one";
  EXPECT_EQ(report.keyframe_files_reused, 5);
  EXPECT_EQ(report.keyframe_files_removed, 1) << "the coarsened record's old file";
  EXPECT_EQ(keyframeFiles().size(), 7u);
  expectLoadsAs(now);
  // Files adopted for another folder are not this folder's.
  MapFolderWriter elsewhere;
  elsewhere.adopt((dir_ / "other.mvmap").string(), now, files);
  ASSERT_TRUE(elsewhere.write(folder_, objects_, summary_, now, &report).ok());
  EXPECT_EQ(report.keyframe_files_written, 7);
  // A single-file map names no keyframe files.
  const std::string single = (dir_ / "old.json").string();
  ASSERT_TRUE(writeFileAtomic(single, asText(objects_, summary_, now)).ok());
  ASSERT_TRUE(loadMap(single, Links::kRefuse, nullptr, nullptr, nullptr, &files).ok());
  EXPECT_TRUE(files.empty());
}

TEST_F(MapFolderTest, AHistoryAtItsMemoryBoundSavesAndLoadsBackEqual) {
  // 640 x 480 depth (0.6 MB) and a cut of 20,000 points per keyframe, 40 keyframes, a 6 MB
  // bound: the newest keep their depth, older ones a coarse one, older still their views only,
  // the oldest are forgotten.
  KeyframeHistory::Config config;
  config.max_memory_mb = 6.0;
  KeyframeHistory history(config);
  for (int k = 0; k < 40; ++k) {
    KeyframeRecord record = test::makeRecord(k, k % 3 == 0 ? CV_32FC1 : CV_16UC1);
    record.depth = cv::Mat(480, 640, record.depth.type(), cv::Scalar(1500 + k));
    if (record.depth.type() == CV_32FC1) record.depth.setTo(1.5f + 0.001f * k);
    record.K_depth.width = 640;
    record.K_depth.height = 480;
    auto cut = std::make_shared<RecordedCut>(*record.views[0].cut);
    cut->cut_W.assign(20000, Eigen::Vector3f(0.5f, 0.25f, 0.125f * k));
    cut->normals_W.assign(20000, Eigen::Vector3f(0.f, 0.f, 1.f));
    record.views[0].cut = cut;
    history.add(std::move(record));
    ASSERT_LE(history.memoryBytes(), 6u << 20);
  }
  const KeyframeHistory::Usage usage = history.usage();
  EXPECT_GT(usage.full_depth, 0);
  EXPECT_GT(usage.coarse_depth, 0);
  EXPECT_GT(usage.views_only, 0);
  EXPECT_GT(usage.forgotten, 0);
  MapFolderWriter writer;
  MapFolderWriter::Report report;
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history.records(), &report).ok());
  std::printf(
      "[ INFO     ] %d keyframes (%d full, %d coarse, %d views only), %.1f MB in memory, "
      "%.1f MB on disk\n",
      usage.keyframes, usage.full_depth, usage.coarse_depth, usage.views_only,
      usage.bytes / 1048576.0, report.folder_bytes / 1048576.0);
  expectLoadsAs(history.records());
  // Loaded into a history of the same bound (give or take the strings' capacities), nothing
  // degrades further.
  std::deque<KeyframeRecord> loaded;
  ASSERT_TRUE(loadMap(folder_, Links::kRefuse, nullptr, nullptr, &loaded).ok());
  config.max_memory_mb += 0.01;
  KeyframeHistory reloaded(config);
  for (KeyframeRecord& record : loaded) reloaded.add(std::move(record));
  EXPECT_EQ(reloaded.usage().full_depth, usage.full_depth);
  EXPECT_EQ(reloaded.usage().coarse_depth, usage.coarse_depth);
  EXPECT_EQ(reloaded.usage().views_only, usage.views_only);
}

TEST_F(MapFolderTest, ASaveKilledMidwayLeavesThePreviousMapWhole) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  MapFolderWriter writer;
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history).ok());
  // What a save killed before its map.json leaves: new keyframe files, a temporary of map.json.
  std::ofstream(fs::path(folder_) / "keyframes" / "kf9-dead-1.0-0.kf") << "half a keyframe";
  const std::string temporary = ".map.json.save-999999.AbCdEf";
  std::ofstream(fs::path(folder_) / temporary) << "{\"frames\": 1";
  expectLoadsAs(history);
  // The next save removes the keyframe file no map names (a temporary of a live process stays).
  MapFolderWriter::Report report;
  ASSERT_TRUE(writer.write(folder_, objects_, summary_, history, &report).ok());
  EXPECT_EQ(report.keyframe_files_removed, 1);
  EXPECT_FALSE(fs::exists(fs::path(folder_) / "keyframes" / "kf9-dead-1.0-0.kf"));
  expectLoadsAs(history);
}

TEST_F(MapFolderTest, BrokenFilesAreErrorsNamingTheFile) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  ASSERT_TRUE(MapFolderWriter().write(folder_, objects_, summary_, history).ok());
  const std::string name = keyframeFiles().front();
  const fs::path file = fs::path(folder_) / "keyframes" / name;
  const std::string bytes = test::readText(file);
  const auto expectRefused = [&](const std::string& what, const std::string& needle) {
    std::vector<MapObject> objects = {folderTestObject(7)};
    const Status status = loadMap(folder_, Links::kRefuse, &objects, nullptr, nullptr);
    EXPECT_FALSE(status.ok()) << what;
    EXPECT_NE(status.message().find(needle), std::string::npos) << what << ": " << status.message();
    ASSERT_EQ(objects.size(), 1u) << what << ": the outputs were touched";
  };
  std::ofstream(file, std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  expectRefused("truncated", name);
  std::ofstream(file, std::ios::trunc) << "not a keyframe";
  expectRefused("no header", "MVODKF01");
  fs::remove(file);
  expectRefused("missing", name);
  fs::create_symlink("/dev/zero", file);
  expectRefused("a link to /dev/zero", "symbolic link");
  fs::remove(file);
  ::mkfifo(file.c_str(), 0600);
  expectRefused("a FIFO", "FIFO");
  fs::remove(file);
  std::ofstream(file) << bytes;
  expectLoadsAs(history);
  // A map.json naming a file outside keyframes/.
  std::string map = test::readText(fs::path(folder_) / "map.json");
  const size_t at = map.find(name);
  ASSERT_NE(at, std::string::npos);
  std::ofstream(fs::path(folder_) / "map.json", std::ios::trunc)
      << map.replace(at, name.size(), "../../../etc/passwd");
  expectRefused("a path outside the folder", "file");
}

TEST_F(MapFolderTest, LinksAreNeitherWrittenThroughNorRead) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  const fs::path real = dir_ / "real.mvmap";
  ASSERT_TRUE(MapFolderWriter().write(real.string(), objects_, summary_, history).ok());
  const std::string before = test::readText(real / "map.json");
  fs::create_symlink(real, folder_);
  const Status written = MapFolderWriter().write(folder_, {}, MapSummary(), {});
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.message().find("symbolic link"), std::string::npos) << written.message();
  EXPECT_EQ(test::readText(real / "map.json"), before);
  const Status loaded = loadMap(folder_, Links::kRefuse, nullptr, nullptr, nullptr);
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.message().find("symbolic link"), std::string::npos) << loaded.message();
}

// Issue 57, items 1 and 2: what is put in place of the lock file or the keyframes folder refuses
// the load at once, with the reason; nothing blocks (a FIFO's open would wait for a writer).
TEST_F(MapFolderTest, AStrangeLockOrKeyframesFolderIsRefusedAtOnceWithTheReason) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  ASSERT_TRUE(MapFolderWriter().write(folder_, objects_, summary_, history).ok());
  const fs::path lock = fs::path(folder_) / ".lock";
  const auto expectRefused = [&](const std::string& what, const std::string& needle) {
    const auto start = std::chrono::steady_clock::now();
    const Status loaded = loadMap(folder_, Links::kRefuse, nullptr, nullptr, nullptr);
    const Status saved = MapFolderWriter().write(folder_, objects_, summary_, history);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5)) << what;
    EXPECT_FALSE(loaded.ok()) << what;
    EXPECT_NE(loaded.message().find(needle), std::string::npos) << what << ": " << loaded.message();
    EXPECT_FALSE(saved.ok()) << what;
  };
  fs::remove(lock);
  ASSERT_EQ(::mkfifo(lock.c_str(), 0600), 0);
  expectRefused("a FIFO at .lock", "FIFO");
  fs::remove(lock);
  fs::create_directory(lock);
  expectRefused("a directory at .lock", "directory");
  fs::remove(lock);
  fs::create_symlink("/dev/null", lock);
  expectRefused("a link at .lock", "regular file");
  fs::remove(lock);
  expectLoadsAs(history);
  // keyframes/ a link to a copy outside the folder: refused, not read from there.
  const fs::path outside = dir_ / "elsewhere";
  fs::rename(fs::path(folder_) / "keyframes", outside);
  fs::create_directory_symlink(outside, fs::path(folder_) / "keyframes");
  expectRefused("keyframes/ a link", "never read or saved through a link");
  fs::remove(fs::path(folder_) / "keyframes");
  fs::rename(outside, fs::path(folder_) / "keyframes");
  expectLoadsAs(history);
}

// Issue 57, item 5: a keyframe naming an object id no object can have is refused; one naming an
// object refined away since (an id below the map's ids, no object of it) loads.
TEST_F(MapFolderTest, KeyframesNamingImpossibleObjectIdsAreRefused) {
  std::deque<KeyframeRecord> history = folderTestHistory();
  ASSERT_FALSE(history.front().views.empty());
  history.front().views.front().object_id = 3;  // no object 3: refined away
  ASSERT_TRUE(MapFolderWriter().write(folder_, objects_, summary_, history).ok());
  expectLoadsAs(history);
  const fs::path map_json = fs::path(folder_) / "map.json";
  std::string map = test::readText(map_json);
  const std::string ids = "\"object_ids\":[3";
  const size_t at = map.find(ids);
  ASSERT_NE(at, std::string::npos) << map.substr(0, 400);
  std::ofstream(map_json, std::ios::trunc)
      << map.replace(at, ids.size(), "\"object_ids\":[2147483647");
  const Status loaded = loadMap(folder_, Links::kRefuse, nullptr, nullptr, nullptr);
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.message().find("object_ids"), std::string::npos) << loaded.message();
}

// Issue 57, item 3: one claim on a folder at a time, across processes; it ends with its process.
TEST_F(MapFolderTest, AFolderIsClaimedByOneProcessAtATime) {
  MapFolderClaim mine;
  ASSERT_TRUE(mine.claim(folder_).ok());
  const pid_t child = ::fork();
  if (child == 0) {
    MapFolderClaim theirs;
    const Status status = theirs.claim(folder_);
    const bool refused_naming_me =
        !status.ok() &&
        status.message().find("pid " + std::to_string(::getppid())) != std::string::npos;
    ::_exit(refused_naming_me ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "a second process claimed the folder, or its refusal did not name the holder";
  mine.release();
  const pid_t second = ::fork();
  if (second == 0) {
    MapFolderClaim theirs;
    ::_exit(theirs.claim(folder_).ok() ? 0 : 1);
  }
  ASSERT_EQ(::waitpid(second, &status, 0), second);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "released, yet not claimable";
}

TEST_F(MapFolderTest, ConcurrentSaversToOneFolderAllSucceedAndTheMapAlwaysLoads) {
  std::deque<KeyframeRecord> a = folderTestHistory();
  std::deque<KeyframeRecord> b = a;
  b.pop_front();
  ASSERT_TRUE(MapFolderWriter().write(folder_, objects_, summary_, a).ok());
  constexpr int kSaves = 15;
  // Another process (a second node's ~save_map), another thread (the autosave), and this one.
  const pid_t child = ::fork();
  if (child == 0) {
    MapFolderWriter writer;
    int failed = 0;
    for (int i = 0; i < kSaves; ++i) failed += writer.write(folder_, objects_, summary_, b) ? 0 : 1;
    ::_exit(failed == 0 ? 0 : 1);
  }
  std::atomic<int> failed{0};
  std::thread other([&] {
    MapFolderWriter writer;
    for (int i = 0; i < kSaves; ++i) failed += writer.write(folder_, objects_, summary_, a) ? 0 : 1;
  });
  int broken = 0;
  MapFolderWriter writer;
  for (int i = 0; i < kSaves; ++i) {
    failed += writer.write(folder_, objects_, summary_, b) ? 0 : 1;
    std::deque<KeyframeRecord> loaded;
    if (!loadMap(folder_, Links::kRefuse, nullptr, nullptr, &loaded).ok() ||
        (loaded.size() != a.size() && loaded.size() != b.size())) {
      ++broken;
    }
  }
  other.join();
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the other process's saves failed";
  EXPECT_EQ(failed.load(), 0);
  EXPECT_EQ(broken, 0);
  // The last save's files and nothing else.
  std::deque<KeyframeRecord> last;
  ASSERT_TRUE(loadMap(folder_, Links::kRefuse, nullptr, nullptr, &last).ok());
  EXPECT_EQ(keyframeFiles().size(), last.size());
}

TEST_F(MapFolderTest, TheSingleFileMapOfEarlierReleasesStillLoads) {
  const std::deque<KeyframeRecord> history = folderTestHistory();
  const fs::path file = dir_ / "old.json";
  ASSERT_TRUE(writeFileAtomic(file.string(), asText(objects_, summary_, history)).ok());
  std::vector<MapObject> objects;
  MapSummary summary;
  std::deque<KeyframeRecord> loaded;
  const Status status = loadMap(file.string(), Links::kRefuse, &objects, &summary, &loaded);
  ASSERT_TRUE(status.ok()) << status.message();
  test::expectSameHistory(history, loaded);
  EXPECT_EQ(asText(objects, summary, loaded), asText(objects_, summary_, history));
  // Its limit is not the 1 GiB of other files: the node wrote such files past 1 GiB.
  EXPECT_GT(kMaxSingleFileMapBytes, kDefaultMaxFileBytes);
}

TEST(MapFolderNamesTest, ANameStandsForItsFolderOrAnEarlierReleasesFile) {
  EXPECT_EQ(mapFolderPath("/maps/kitchen"), "/maps/kitchen.mvmap");
  EXPECT_EQ(mapFolderPath("/maps/kitchen.json"), "/maps/kitchen.mvmap");
  EXPECT_EQ(mapFolderPath("/maps/kitchen.mvmap"), "/maps/kitchen.mvmap");
  const fs::path dir = test::freshTestDir("mvod_map_names");
  const std::string name = (dir / "kitchen.json").string();
  EXPECT_EQ(mapToLoad(name), "");
  std::ofstream(name) << "{}";  // a map file of 0.9.x
  EXPECT_EQ(mapToLoad(name), name);
  ASSERT_TRUE(MapFolderWriter().write((dir / "kitchen.mvmap").string(), {}, MapSummary(), {}).ok());
  EXPECT_EQ(mapToLoad(name), (dir / "kitchen.mvmap").string()) << "the folder is newer";
  EXPECT_EQ(mapToLoad((dir / "kitchen").string()), (dir / "kitchen.mvmap").string());
  ::sleep(1);  // file systems whose times have a resolution of 1 s
  std::ofstream(name) << "{}";
  EXPECT_EQ(mapToLoad(name), name) << "the file is newer";
  fs::remove_all(dir);
}

TEST(MapFolderNamesTest, AFolderWithoutMapJsonHoldsNoMapAndSaysSo) {
  const fs::path dir = test::freshTestDir("mvod_map_cut_short");
  const std::string name = (dir / "kitchen.mvmap").string();
  EXPECT_EQ(noMapText(name), "no map at " + name);
  EXPECT_EQ(noMapText((dir / "kitchen.json").string()),
            "no map at " + name + " (nor a map file " + (dir / "kitchen.json").string() + ")");
  // What a first save killed before its map.json leaves.
  fs::create_directories(dir / "kitchen.mvmap" / "keyframes");
  std::ofstream(dir / "kitchen.mvmap" / "keyframes" / "kf1-abc-1.0-0.kf") << "MVODKF01";
  std::ofstream(dir / "kitchen.mvmap" / ".map.json.save-123.abcdef") << "{";
  EXPECT_EQ(mapToLoad(name), "");
  EXPECT_NE(noMapText(name).find(name + " holds no map.json"), std::string::npos)
      << noMapText(name);
  // A map file of 0.9.x beside it is the map.
  std::ofstream(dir / "kitchen.json") << "{}";
  EXPECT_EQ(mapToLoad((dir / "kitchen.json").string()), (dir / "kitchen.json").string());
  // A map.json that is there but not a file is still the folder's, for the load to refuse.
  fs::create_directories(dir / "kitchen.mvmap" / "map.json");
  EXPECT_EQ(mapToLoad(name), name);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mvod
