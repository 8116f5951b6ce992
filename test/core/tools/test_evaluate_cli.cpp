// evaluate's command line, run end to end: --plot-region draws only that part of the bird's-eye
// plot, at 1600 px on its longer side, and a region that is not four finite numbers with X0 < X1
// and Y0 < Y1 is refused (exit 2) before anything is read or written.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/json_io.h"
#include "run_tool.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const char* const kEvaluate = MVOD_EVALUATE_BIN;

// A map of one 0.1 m cup on a table top at (0.5, 0.2), z up: objects.json as offline_detection
// writes it.
fs::path writeOneCupMap(const fs::path& dir) {
  MapObject cup;
  cup.id = 1;
  cup.class_name = "cup";
  cup.class_id = 41;
  cup.probability = 0.8;
  cup.observations = 5;
  cup.box.center_m = Eigen::Vector3d(0.5, 0.2, 0.8);
  cup.box.size_m = Eigen::Vector3d(0.1, 0.1, 0.1);
  MapSummary summary;
  summary.frames = 10;
  summary.keyframes = 5;
  const fs::path path = dir / "objects.json";
  EXPECT_TRUE(writeFileAtomic(path.string(), objectsToJson({cup}, summary, false)).ok());
  return path;
}

TEST(EvaluateCliTest, APlotRegionIsDrawnAtTheFullSize) {
  const fs::path work = test::freshTestDir("mvod_evaluate_region");
  const fs::path objects = writeOneCupMap(work);
  const fs::path png = work / "region.png";
  const test::RunResult run = test::runTool(
      kEvaluate,
      {"--objects", objects.string(), "--plot", png.string(), "--plot-region", "0.2,0.0,0.8,0.3"},
      work);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const cv::Mat image = cv::imread(png.string());
  ASSERT_FALSE(image.empty()) << run.err;
  // 0.6 x 0.3 m: 1600 px along the longer side, the shorter one in proportion (less).
  EXPECT_EQ(std::max(image.cols, image.rows), 1600);
  EXPECT_LT(std::min(image.cols, image.rows), 1600);
  fs::remove_all(work);
}

TEST(EvaluateCliTest, AMalformedPlotRegionIsRefused) {
  const fs::path work = test::freshTestDir("mvod_evaluate_bad_region");
  const fs::path objects = writeOneCupMap(work);
  const fs::path png = work / "region.png";
  for (const std::string region :
       {"0,0,1", "0,0,1,1,2", "1,0,0,1", "0,1,1,1", "nan,0,1,1", "0,0,inf,1", "a,b,c,d", ""}) {
    const test::RunResult run = test::runTool(
        kEvaluate, {"--objects", objects.string(), "--plot", png.string(), "--plot-region", region},
        work);
    EXPECT_EQ(run.exit_code, 2) << "'" << region << "'\n" << run.err;
    EXPECT_NE(run.err.find("--plot-region"), std::string::npos) << "'" << region << "'\n"
                                                                << run.err;
    EXPECT_FALSE(fs::exists(png)) << "'" << region << "'";
  }
  fs::remove_all(work);
}

}  // namespace
}  // namespace mvod
