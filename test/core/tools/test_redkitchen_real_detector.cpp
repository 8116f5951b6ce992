// The map a real instance segmenter gives of a real room: offline_detection with YOLOv5n-seg (its
// own thresholds) over every 10th of the 7-Scenes redkitchen's 1000 frames, with the colour camera
// estimated from the data, scored object by object against the hand-checked annotation
// (test/data/7scenes_redkitchen_annotation). Skipped without ../shared's frames or the model.
// benchmark/redkitchen_benchmark gives the same map with the paper's method and the single-frame
// baseline beside it (docs/benchmarks.md).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/evaluation/object_matches.h"
#include "shared_data.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = MVOD_SOURCE_DIR;
const std::string kAnnotationDir = kSourceDir + "/test/data/7scenes_redkitchen_annotation";

std::string quoted(const std::string& arg) { return "'" + arg + "'"; }

TEST(RedkitchenRealDetectorTest, YoloSegDefaultMapsTheTableChairsAndSmallObjects) {
  const std::string frames = test::sharedPath("data/7scenes_redkitchen/data");
  const std::string models = test::sharedPath("models");
  if (frames.empty() || models.empty() || !fs::exists(fs::path(models) / "yolov5n-seg.onnx")) {
    GTEST_SKIP() << "needs ../shared/data/7scenes_redkitchen/data and "
                    "../shared/models/yolov5n-seg.onnx (or $MVOD_SHARED_DIR)";
  }
  const fs::path work = test::freshTestDir("mvod_redkitchen_yolo");
  const fs::path objects = work / "objects.json";
  const std::string command =
      quoted(MVOD_OFFLINE_DETECTION_BIN) + " --dataset " + quoted(frames) + " --color-intrinsics " +
      quoted(kAnnotationDir + "/colour_camera/color-intrinsics.txt") + " --depth-to-color " +
      quoted(kAnnotationDir + "/colour_camera/depth-to-color.txt") +
      " --detector yolo_seg --model-dir " + quoted(models) + " --every 10 --threads 0 --priors " +
      quoted(kSourceDir + "/config/class_priors.yaml") + " --output " + quoted(objects.string()) +
      " --quiet > " + quoted((work / "log.txt").string()) + " 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << test::readText(work / "log.txt");

  Eigen::Vector3d up;
  bool found = false;
  const std::string annotation = kAnnotationDir + "/ground_truth.json";
  ASSERT_TRUE(readGroundTruthUp(annotation, &up, &found).ok());
  ASSERT_TRUE(found);
  std::vector<GroundTruthObject> truth;
  ASSERT_TRUE(loadSyntheticGroundTruth(annotation, 0.05, up, &truth).ok());
  std::vector<EvaluatedPrediction> predictions;
  ASSERT_TRUE(loadPredictions(objects.string(), "", &predictions, nullptr).ok());
  const ObjectMatches matches = matchObjects(truth, predictions, up);
  const std::string table = objectMatchesToMarkdown(matches, predictions);

  // Issue 49's goals, measured on 2026-12-04: the table at IoU 0.87 (goal >= 0.6: met); chairs A,
  // B and C within 0.05 m, D and E not found (goal 4 of 5: not met; YOLOv5n-seg scores chair D
  // 0.14-0.18 in 2 of the keyframes that show it and never calls chair E a chair); 2 chairs where
  // the annotation has none (goal at most 1: not met). With the colour camera re-fitted on
  // 2026-12-06 (issue 54, item 4): table IoU 0.89, chairs A-C within 0.031 m, 1 chair where the
  // annotation has none. Issue 54's furniture goals, met since (2026-12-07: table 0.89, chairs A-C
  // 0.030, 0.021 and 0.020 m, 1 unmatched chair), are what it asserts: table IoU >= 0.85, chairs
  // A-C (annotation 1-3) within 0.05 m, at most 1 table or chair matching no annotation.
  ASSERT_EQ(matches.annotated[0].class_name, "dining table");
  EXPECT_GE(matches.annotated[0].box_iou, 0.85) << table;
  for (const int chair : {1, 2, 3}) {
    const AnnotatedObjectMatch& m = matches.annotated[chair];
    ASSERT_EQ(m.class_name, "chair");
    EXPECT_GE(m.prediction_id, 0) << "chair " << chair << "\n" << table;
    EXPECT_LE(m.centre_distance_m, 0.05) << "chair " << chair << "\n" << table;
  }
  int unmatched_furniture = 0;
  for (const int id : matches.unmatched_prediction_ids) {
    for (const EvaluatedPrediction& p : predictions) {
      if (p.id == id && (p.class_name == "chair" || p.class_name == "dining table")) {
        ++unmatched_furniture;
      }
    }
  }
  EXPECT_LE(unmatched_furniture, 1) << table;

  // The small objects (issue 54, item 5), as measured on 2026-12-07: the Daedalus journal on the
  // Computer magazine (annotation 8) its own book, 0.039 m from its centre (goal 0.05: met), at IoU
  // 0.34; the brochure pile (11) at 0.29. The two mugs (6, 7) at IoU 0.56 and 0.50 and the wall
  // monitors (13, 14) at 0.46 and 0.22 (goals 0.6 and 0.5: not met). The mask borders at depth
  // edges (extractor/max_depth_edge_margin_px) took the mugs from 0.34 and 0.26 and the monitors
  // from 0.28 and 0.17; the views' consensus box (database/view_consensus_m) the mugs from 0.39 and
  // 0.46 and the books from 0.24 and 0.23. The wall monitors' cut from their wall (class prior
  // on_wall) took monitor 13 from 0.35 to 0.46. A map that loses any of them fails here.
  ASSERT_GE(matches.annotated.size(), 15u);
  const AnnotatedObjectMatch& daedalus = matches.annotated[8];
  ASSERT_EQ(daedalus.class_name, "book");
  EXPECT_GE(daedalus.prediction_id, 0) << table;
  EXPECT_LE(daedalus.centre_distance_m, 0.05) << table;
  EXPECT_GE(daedalus.box_iou, 0.3) << table;
  for (const int mug : {6, 7}) {
    ASSERT_EQ(matches.annotated[mug].class_name, "cup");
    EXPECT_GE(matches.annotated[mug].box_iou, 0.45) << "mug " << mug << "\n" << table;
  }
  const std::pair<int, double> monitors[] = {{13, 0.4}, {14, 0.2}};
  for (const auto& [monitor, min_iou] : monitors) {
    ASSERT_EQ(matches.annotated[monitor].class_name, "tv");
    EXPECT_GE(matches.annotated[monitor].box_iou, min_iou) << "monitor " << monitor << "\n"
                                                           << table;
  }
  EXPECT_GE(matches.annotated[11].prediction_id, 0) << table;
  EXPECT_GE(matches.annotated[11].box_iou, 0.25) << table;
  RecordProperty("per_object", table);
  if (!HasFailure()) fs::remove_all(work);
}

}  // namespace
}  // namespace mvod
