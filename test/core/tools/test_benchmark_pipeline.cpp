// The synthetic benchmark end to end: a SceneNN-layout sequence (multi-part furniture, Kinect-like
// depth, label images) -> offline_detection with the simulated detector -> objects in SceneNN's
// y-up world; and scripts/ablation's configurations on it (the paper's method and the default).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const std::string kOfflineDetection = MVOD_OFFLINE_DETECTION_BIN;
const std::string kSourceDir = MVOD_SOURCE_DIR;

struct RunResult {
  int exit_code = -1;
  std::string err;
};

RunResult run(const std::string& command_line, const fs::path& work_dir) {
  const fs::path err = work_dir / "stderr.txt";
  const std::string command = command_line + " > /dev/null 2> '" + err.string() + "' < /dev/null";
  const int status = std::system(command.c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.err = test::readText(err);
  return result;
}

class BenchmarkPipelineTest : public ::testing::Test {
 protected:
  // One small dining-room sequence shared by the tests (rendering is the slow part).
  static void SetUpTestSuite() {
    work_ =
        new fs::path(fs::temp_directory_path() / ("mvod_benchmark_" + std::to_string(::getpid())));
    fs::remove_all(*work_);
    fs::create_directories(*work_);
    SyntheticSceneConfig config;
    config.seed = 3;
    config.num_frames = 36;
    config.noise_model = DepthNoiseModel::kKinect;
    scene_ = new SyntheticScene(SyntheticScene::makeRoom(config, RoomType::kDiningRoom));
    sequence_ = new fs::path(*work_ / "dining_3");
    written_ = scene_->writeSceneNN(sequence_->string(), "dining_3");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*work_);
    delete scene_;
    delete sequence_;
    delete work_;
  }
  void SetUp() override { ASSERT_TRUE(written_.ok()) << written_.message(); }

  static fs::path* work_;
  static fs::path* sequence_;
  static SyntheticScene* scene_;
  static Status written_;
};

fs::path* BenchmarkPipelineTest::work_ = nullptr;
fs::path* BenchmarkPipelineTest::sequence_ = nullptr;
SyntheticScene* BenchmarkPipelineTest::scene_ = nullptr;
Status BenchmarkPipelineTest::written_;

TEST_F(BenchmarkPipelineTest, OfflineDetectionOnSceneNNWithSimulatedDetector) {
  const fs::path out = *work_ / "run";
  fs::create_directories(out);
  const RunResult result =
      run("'" + kOfflineDetection + "' --dataset '" + sequence_->string() +
              "' --detector simulated --every 3 --output '" + (out / "objects.json").string() +
              "' --priors '" + kSourceDir + "/config/class_priors.yaml'",
          out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("(scenenn, 36 frames)"), std::string::npos) << result.err;

  std::vector<MapObject> objects;
  MapSummary summary;
  ASSERT_TRUE(objectsFromJson(test::readText(out / "objects.json"), &objects, &summary).ok());
  // SceneNN's world is y-up: the run used gravity (0, -1, 0) and the boxes stand on y.
  EXPECT_LT((summary.gravity_down_W - Eigen::Vector3d(0, -1, 0)).norm(), 1e-9);
  ASSERT_FALSE(objects.empty());
  for (const MapObject& object : objects) {
    EXPECT_GT(std::abs(object.box.rotation.col(2).y()), 0.999) << object.class_name;
  }
  // Table 4's counts are consistent: every boxed detection was inserted or fused, and failures
  // of the simulated detector (misses, scores under lambda) show up as fewer boxes than detections.
  const MapSummary::Counts& c = summary.counts;
  EXPECT_GT(c.detections, 10);
  EXPECT_LE(c.above_threshold, c.detections);
  EXPECT_LE(c.with_box, c.above_threshold);
  EXPECT_EQ(c.inserted + c.fused, c.with_box);
  EXPECT_GT(c.fused, c.inserted);  // multi-view: most detections fuse into known objects
  EXPECT_GE(c.before_refinement, static_cast<int>(objects.size()));

  // Chairs are found where they are, on the floor plane (x, z of the y-up world; ground truth from
  // the sequence's own PLY + XML). Their heights are not checked: LCCP keeps the largest convex
  // part of a multi-part chair (README, Benchmark).
  std::vector<GroundTruthObject> truth;
  ASSERT_TRUE(loadSceneNNGroundTruth(sequence_->string(), Eigen::Vector3d::UnitY(), &truth).ok());
  int chairs = 0;
  int found = 0;
  for (const GroundTruthObject& g : truth) {
    if (g.class_name != "chair") continue;
    ++chairs;
    for (const MapObject& object : objects) {
      const Eigen::Vector3d d = object.box.center_m - g.box.center_m;
      if (object.class_name == "chair" && std::hypot(d.x(), d.z()) < 0.25) {
        ++found;
        break;
      }
    }
  }
  ASSERT_GE(chairs, 4);
  EXPECT_GE(2 * found, chairs) << found << " of " << chairs << " chairs found";
}

TEST_F(BenchmarkPipelineTest, AblationScriptRunsThePaperAndTheDefaultConfigurations) {
  const fs::path out = *work_ / "ablation";
  const std::string bin_dir = fs::path(kOfflineDetection).parent_path().string();
  const RunResult result =
      run("/usr/bin/python3 '" + kSourceDir + "/scripts/ablation' --scene '" + sequence_->string() +
              "' --every 6 --jobs 1 --configs "
              "paper,paper:single-frame,paper:-Filter,paper:-LCCP,default,cut-only,fusion-only "
              "--bin-dir '" +
              bin_dir + "' --output '" + out.string() + "'",
          *work_);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string markdown = test::readText(out / "ablation.md");
  EXPECT_NE(markdown.find("| Class | #GT | paper | paper:single-frame | paper:-Filter | "
                          "paper:-LCCP | default | cut-only | fusion-only |"),
            std::string::npos)
      << markdown;
  EXPECT_NE(markdown.find("## Counts (Table 4)"), std::string::npos);
  EXPECT_NE(markdown.find("dining table"), std::string::npos);

  auto summary_of = [&](const std::string& config) {
    MapSummary summary;
    std::vector<MapObject> objects;
    const Status read = objectsFromJson(test::readText(out / config / "dining_3" / "objects.json"),
                                        &objects, &summary);
    EXPECT_TRUE(read.ok()) << config << ": " << read.message();
    return summary;
  };
  const MapSummary full = summary_of("paper");
  const MapSummary single = summary_of("paper:single-frame");
  const MapSummary no_filter = summary_of("paper:-Filter");
  const MapSummary no_lccp = summary_of("paper:-LCCP");
  EXPECT_GT(summary_of("default").counts.fused, 0);
  // The flags reached the runs: no fusion in the baseline, no filter / LCCP time when off.
  EXPECT_GT(full.counts.fused, 0);
  EXPECT_EQ(single.counts.fused, 0);
  EXPECT_EQ(single.counts.inserted, single.counts.with_box);
  EXPECT_LT(no_filter.stage_ms_median.filter_ms, 0.2 * full.stage_ms_median.filter_ms);
  EXPECT_LT(no_lccp.stage_ms_median.lccp_ms, 0.2 * full.stage_ms_median.lccp_ms);

  // One CSV row per configuration and class, AP as fractions.
  const std::string csv = test::readText(out / "ablation.csv");
  for (const char* config : {"paper,", "paper:single-frame,", "paper:-Filter,", "paper:-LCCP,",
                             "default,", "cut-only,", "fusion-only,"}) {
    EXPECT_NE(csv.find(std::string("\n") + config + "mean,"), std::string::npos) << csv;
  }
}

TEST_F(BenchmarkPipelineTest, OneAndTwoThreadsGiveIdenticalMapsInBothMethods) {
  // A furnished room gives LCCP many small segments to merge; PCL's own merge followed heap
  // addresses, and this sequence then gave different maps on 1 and 2 threads.
  for (const std::string method : {"default", "paper"}) {
    std::vector<nlohmann::json> maps;
    for (const int threads : {1, 2}) {
      const fs::path out = *work_ / ("threads_" + method + "_" + std::to_string(threads));
      fs::create_directories(out);
      const RunResult result =
          run("'" + kOfflineDetection + "' --dataset '" + sequence_->string() +
                  "' --detector simulated --every 3 --threads " + std::to_string(threads) +
                  (method == "paper" ? " --paper" : "") + " --output '" +
                  (out / "objects.json").string() + "' --priors '" + kSourceDir +
                  "/config/class_priors.yaml'",
              out);
      ASSERT_EQ(result.exit_code, 0) << result.err;
      maps.push_back(nlohmann::json::parse(test::readText(out / "objects.json")));
    }
    ASSERT_TRUE(maps[0].contains("objects"));
    EXPECT_GE(maps[0]["objects"].size(), 5u) << method;
    // (Compared as a whole; the maps themselves are too long for a failure message.)
    EXPECT_TRUE(maps[0]["objects"] == maps[1]["objects"])
        << method << ": the objects differ (" << maps[0]["objects"].size() << " and "
        << maps[1]["objects"].size() << " objects)";
    EXPECT_EQ(maps[0]["removed"], maps[1]["removed"]) << method;
    EXPECT_EQ(maps[0]["counts"], maps[1]["counts"]) << method;
  }
}

}  // namespace
}  // namespace mvod
