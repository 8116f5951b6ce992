// Every file the offline tools read is a regular file read within a size limit (issue 48, item 6):
// a FIFO or a link to /dev/zero where offline_detection expects a pose, gravity, intrinsics or
// trajectory file is refused at once with a message naming it, and the run exits 1. Each run has a
// time limit and a memory limit: before, a FIFO blocked the tool for ever and /dev/zero was read
// until memory ran out, after which the run carried on and exited 0.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"
#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const char* const kBinary = MVOD_OFFLINE_DETECTION_BIN;
const std::string kSourceDir = MVOD_SOURCE_DIR;
// Far above a run's 2-10 s, far below for ever; 3 GiB of address space: the issue's /dev/zero run
// reached 16.5 GB. AddressSanitizer (make test-sanitize) reserves terabytes of address space for its
// shadow memory, so a limit on it aborts the tool at its start: there the time limit alone catches a
// tool that reads for ever.
#if defined(__SANITIZE_ADDRESS__)
const test::RunLimits kLimits{60, 0};
#else
const test::RunLimits kLimits{60, 3L << 20};
#endif
constexpr int kKilled = 137;

enum class Special { kFifo, kDevZero };

// `path` replaced by a FIFO nobody writes to, or by a symbolic link to /dev/zero.
void makeSpecial(const fs::path& path, Special kind) {
  fs::remove(path);
  if (kind == Special::kFifo) {
    ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0) << path;
  } else {
    fs::create_symlink("/dev/zero", path);
  }
}

std::string kindText(Special kind) { return kind == Special::kFifo ? "FIFO" : "character device"; }

class OfflineSpecialFilesTest : public ::testing::TestWithParam<Special> {
 protected:
  static void SetUpTestSuite() {
    source_ = new fs::path(fs::temp_directory_path() /
                           ("mvod_special_files_" + std::to_string(::getpid())));
    fs::remove_all(*source_);
    SyntheticSceneConfig config;
    config.num_frames = 20;
    const SyntheticScene scene = SyntheticScene::makeDefault(config);
    const Status written =
        scene.writeSevenScenes((*source_ / "dataset").string(), (*source_ / "detections").string());
    ASSERT_TRUE(written.ok()) << written.message();
    written_ = scene.writeSceneNN((*source_ / "scenenn" / "001").string(), "001");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*source_);
    delete source_;
  }
  void SetUp() override {
    work_ = test::freshTestDir("mvod_special_files");
    fs::copy(*source_ / "dataset", work_ / "dataset", fs::copy_options::recursive);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(work_);
  }

  test::RunResult run(const fs::path& dataset, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {"--dataset",    dataset.string(),
                                     "--detections", (*source_ / "detections").string(),
                                     "--every",      "5",
                                     "--priors",     kSourceDir + "/config/class_priors.yaml",
                                     "--output",     (work_ / "objects.json").string(),
                                     "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    return test::runTool(kBinary, args, work_, kLimits);
  }

  // Refused at once (not killed at the limit), exit 1, the file and what it is named.
  void expectRefused(const test::RunResult& result, const fs::path& file, Special kind) {
    EXPECT_NE(result.exit_code, kKilled) << "killed at the time or memory limit: it hung";
    EXPECT_EQ(result.exit_code, 1) << result.err;
    EXPECT_NE(result.err.find(file.string()), std::string::npos) << result.err;
    EXPECT_NE(result.err.find(kindText(kind)), std::string::npos) << result.err;
  }

  static fs::path* source_;
  static Status written_;
  fs::path work_;
};

fs::path* OfflineSpecialFilesTest::source_ = nullptr;
Status OfflineSpecialFilesTest::written_;

TEST_P(OfflineSpecialFilesTest, ACorrectedPoseIsRefusedAndTheCorrectionNotApplied) {
  const fs::path corrected = work_ / "corrected";
  fs::create_directories(corrected);
  fs::copy_file(work_ / "dataset" / "frame-000000.pose.txt", corrected / "frame-000000.pose.txt");
  makeSpecial(corrected / "frame-000005.pose.txt", GetParam());
  const test::RunResult result = run(work_ / "dataset", {"--corrected-poses", corrected.string()});
  expectRefused(result, corrected / "frame-000005.pose.txt", GetParam());
  EXPECT_NE(result.err.find("not applied"), std::string::npos) << result.err;
  // The map of the frames is still written.
  EXPECT_TRUE(fs::is_regular_file(work_ / "objects.json"));
}

TEST_P(OfflineSpecialFilesTest, AFramesPoseIsAnErrorAndTheRunExitsOne) {
  const fs::path pose = work_ / "dataset" / "frame-000010.pose.txt";
  makeSpecial(pose, GetParam());
  const test::RunResult result = run(work_ / "dataset");
  expectRefused(result, pose, GetParam());
  EXPECT_TRUE(fs::is_regular_file(work_ / "objects.json")) << "the other frames' map";
}

TEST_P(OfflineSpecialFilesTest, GravityIntrinsicsAndDepthToColourStopTheRun) {
  for (const std::string name : {"gravity-direction.txt", "camera-intrinsics.txt",
                                 "color-intrinsics.txt", "depth-to-color.txt"}) {
    SCOPED_TRACE(name);
    const fs::path dataset = work_ / ("dataset_" + name);
    fs::copy(work_ / "dataset", dataset, fs::copy_options::recursive);
    if (name == "depth-to-color.txt") {
      // Read only beside a colour camera's intrinsics.
      fs::copy_file(dataset / "camera-intrinsics.txt", dataset / "color-intrinsics.txt",
                    fs::copy_options::overwrite_existing);
    }
    makeSpecial(dataset / name, GetParam());
    const test::RunResult result = run(dataset);
    expectRefused(result, dataset / name, GetParam());
    EXPECT_FALSE(fs::exists(work_ / "objects.json"));
  }
}

TEST_P(OfflineSpecialFilesTest, SceneNNTrajectoryAndTimestampsStopTheRun) {
  ASSERT_TRUE(written_.ok()) << written_.message();
  for (const std::string name : {"trajectory.log", "timestamp.txt"}) {
    SCOPED_TRACE(name);
    const fs::path sequence = work_ / ("scenenn_" + name) / "001";
    fs::create_directories(sequence.parent_path());
    fs::copy(*source_ / "scenenn" / "001", sequence, fs::copy_options::recursive);
    makeSpecial(sequence / name, GetParam());
    std::vector<std::string> args = {"--dataset",  sequence.string(),
                                     "--format",   "scenenn",
                                     "--detector", "simulated",
                                     "--priors",   kSourceDir + "/config/class_priors.yaml",
                                     "--output",   (work_ / "objects.json").string(),
                                     "--quiet"};
    const test::RunResult result = test::runTool(kBinary, args, work_, kLimits);
    expectRefused(result, sequence / name, GetParam());
  }
}

INSTANTIATE_TEST_SUITE_P(FifoAndDevZero, OfflineSpecialFilesTest,
                         ::testing::Values(Special::kFifo, Special::kDevZero),
                         [](const ::testing::TestParamInfo<Special>& info) {
                           return info.param == Special::kFifo ? std::string("Fifo")
                                                               : std::string("DevZero");
                         });

}  // namespace
}  // namespace mvod
