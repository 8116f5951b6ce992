// Evaluation (Sec. 4.1): VOC AP, voxel IoU, box IoU, matching, loaders and an end-to-end check.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/datasets/ground_truth_geometry.h"
#include "multiview_object_detection/datasets/scenenn_annotation.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/evaluation/object_matches.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/ply_reader.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

class EvaluationFiles : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_evaluation"); }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& content) {
    const fs::path path = dir_ / name;
    fs::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary);
    out << content;
    return path.string();
  }
  fs::path dir_;
};

OrientedBox makeBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw_rad,
                    const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ()) {
  OrientedBox box;
  box.center_m = center;
  box.size_m = size;
  box.rotation = GravityFrame(-up).rotationFromYaw(yaw_rad);
  return box;
}

template <typename T>
void appendBinary(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

// ---- VOC AP ----

TEST(EvaluationVocAp, HandComputedRankedLists) {
  // Perfect list.
  EXPECT_DOUBLE_EQ(vocAveragePrecision({true, true}, 2), 1.0);
  // [TP, FP, TP], 2 GT: recall 0.5 at precision 1, recall 1 at precision 2/3.
  EXPECT_NEAR(vocAveragePrecision({true, false, true}, 2), 0.5 * 1.0 + 0.5 * 2.0 / 3.0, 1e-12);
  // Half the ground truth found, both at precision 1.
  EXPECT_NEAR(vocAveragePrecision({true, true}, 4), 0.5, 1e-12);
  // Nothing found or nothing to find.
  EXPECT_DOUBLE_EQ(vocAveragePrecision({false, false}, 3), 0.0);
  EXPECT_DOUBLE_EQ(vocAveragePrecision({}, 3), 0.0);
  EXPECT_DOUBLE_EQ(vocAveragePrecision({true}, 0), 0.0);
}

TEST(EvaluationVocAp, AllPointInterpolationTakesThePrecisionEnvelope) {
  // [FP, TP, TP, FP], 3 GT: raw precision at recall 1/3 is 1/2, but the envelope lifts it to the
  // 2/3 reached at recall 2/3. Interpolated AP = 2 * (1/3 * 2/3) = 4/9; the raw sum would be 7/18.
  const double ap = vocAveragePrecision({false, true, true, false}, 3);
  EXPECT_NEAR(ap, 4.0 / 9.0, 1e-12);
  EXPECT_GT(std::abs(ap - 7.0 / 18.0), 0.01);
  // [TP, FP, FP, TP], 2 GT: 0.5 * 1 + 0.5 * 0.5.
  EXPECT_NEAR(vocAveragePrecision({true, false, false, true}, 2), 0.75, 1e-12);
}

// ---- Voxel IoU ----

TEST(EvaluationVoxelIoU, CountsSharedOccupiedVoxels) {
  const double v = 0.05;
  // a occupies voxels x = 0, 1 (several points each); b occupies x = 1, 2, 3.
  const PointCloud a = {
      {0.01f, 0.01f, 0.01f}, {0.02f, 0.03f, 0.04f}, {0.06f, 0.01f, 0.01f}, {0.09f, 0.04f, 0.02f}};
  const PointCloud b = {
      {0.07f, 0.02f, 0.02f}, {0.11f, 0.01f, 0.01f}, {0.16f, 0.01f, 0.01f}, {0.17f, 0.02f, 0.02f}};
  EXPECT_NEAR(voxelIoU(a, b, v), 1.0 / 4.0, 1e-12);
  EXPECT_NEAR(voxelIoU(a, a, v), 1.0, 1e-12);
  // Density does not matter, only occupancy.
  PointCloud dense = a;
  for (int i = 0; i < 50; ++i) dense.push_back({0.005f + 0.0008f * i, 0.02f, 0.02f});
  EXPECT_NEAR(voxelIoU(dense, a, v), 1.0, 1e-12);
  // The grid is anchored at the origin: -1 cm and +1 cm are different voxels.
  EXPECT_DOUBLE_EQ(voxelIoU({{-0.01f, 0.01f, 0.01f}}, {{0.01f, 0.01f, 0.01f}}, v), 0.0);
  // Bigger voxels merge them.
  EXPECT_NEAR(voxelIoU(a, b, 0.2), 1.0, 1e-12);
  // Non-finite points are dropped; empty and bad voxel sizes give 0.
  PointCloud with_nan = a;
  with_nan.push_back({NAN, 0.0f, 0.0f});
  EXPECT_NEAR(voxelIoU(with_nan, a, v), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(voxelIoU({}, {}, v), 0.0);
  EXPECT_DOUBLE_EQ(voxelIoU(a, {}, v), 0.0);
  EXPECT_DOUBLE_EQ(voxelIoU(a, a, 0.0), 0.0);
}

// ---- Box IoU ----

TEST(EvaluationBoxIoU, IdenticalShiftedAndRotatedBoxes) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const OrientedBox box = makeBox({1.0, 2.0, 0.5}, {1.0, 1.0, 1.0}, 0.3);
  EXPECT_NEAR(orientedBoxIoU(box, box, up), 1.0, 1e-9);
  // Half a side along the box's own x axis: intersection 0.5, union 1.5.
  OrientedBox shifted = box;
  shifted.center_m += 0.5 * box.rotation.col(0);
  EXPECT_NEAR(orientedBoxIoU(box, shifted, up), 1.0 / 3.0, 1e-9);
  // A quarter up: 0.75 / 1.25.
  OrientedBox raised = box;
  raised.center_m.z() += 0.25;
  EXPECT_NEAR(orientedBoxIoU(box, raised, up), 0.6, 1e-9);
  // Unit square turned 45 degrees about its centre: the overlap is a regular octagon of area
  // 2 (sqrt 2 - 1), so IoU = 2 (sqrt 2 - 1) / (2 - 2 (sqrt 2 - 1)) = 1 / sqrt 2.
  const OrientedBox turned = makeBox(box.center_m, box.size_m, 0.3 + M_PI / 4.0);
  EXPECT_NEAR(orientedBoxIoU(box, turned, up), 1.0 / std::sqrt(2.0), 1e-9);
  // Disjoint and degenerate boxes.
  OrientedBox far = box;
  far.center_m.x() += 5.0;
  EXPECT_DOUBLE_EQ(orientedBoxIoU(box, far, up), 0.0);
  OrientedBox flat = box;
  flat.size_m.z() = 0.0;
  EXPECT_DOUBLE_EQ(orientedBoxIoU(box, flat, up), 0.0);
}

TEST(EvaluationBoxIoU, YUpFrame) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  const OrientedBox box = makeBox({0.0, 0.5, 0.0}, {2.0, 1.0, 1.0}, 0.0, up);
  // Third column is up: the vertical extent (size z) is along world y.
  EXPECT_NEAR(box.rotation.col(2).dot(up), 1.0, 1e-12);
  OrientedBox raised = box;
  raised.center_m.y() += 0.5;  // half the height
  EXPECT_NEAR(orientedBoxIoU(box, raised, up), 1.0 / 3.0, 1e-9);
  const OrientedBox turned = makeBox(box.center_m, {1.0, 1.0, 1.0}, M_PI / 4.0, up);
  const OrientedBox square = makeBox(box.center_m, {1.0, 1.0, 1.0}, 0.0, up);
  EXPECT_NEAR(orientedBoxIoU(square, turned, up), 1.0 / std::sqrt(2.0), 1e-9);
}

// ---- Matching ----

TEST(EvaluationMatching, DuplicatesAreFalsePositivesAndBestUnmatchedWins) {
  // Two predictions of the same object: the second is a false positive.
  EXPECT_EQ(matchRankedPredictions({{0.9}, {0.8}}, 0.5), (std::vector<bool>{true, false}));
  // The first takes its best (g1); the second then gets g0.
  EXPECT_EQ(matchRankedPredictions({{0.6, 0.7}, {0.9, 0.0}}, 0.5), (std::vector<bool>{true, true}));
  // The best unmatched object is below the threshold: false positive even if a matched one was
  // above it.
  EXPECT_EQ(matchRankedPredictions({{0.9, 0.0}, {0.95, 0.3}}, 0.5),
            (std::vector<bool>{true, false}));
  // Threshold is inclusive; NaN never matches; no ground truth means all false.
  EXPECT_EQ(matchRankedPredictions({{0.5}}, 0.5), (std::vector<bool>{true}));
  EXPECT_EQ(matchRankedPredictions({{NAN}}, 0.5), (std::vector<bool>{false}));
  EXPECT_EQ(matchRankedPredictions({{}, {}}, 0.5), (std::vector<bool>{false, false}));
}

TEST(EvaluationMatching, ClassMismatchNeverMatches) {
  GroundTruthObject gt;
  gt.class_name = "chair";
  gt.box = makeBox({0, 0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  EvaluatedPrediction pred;
  pred.class_name = "couch";
  pred.probability = 0.9;
  pred.box = gt.box;
  const EvaluationResult result = evaluate({gt}, {pred}, EvaluationOptions());
  ASSERT_EQ(result.classes.size(), 2u);
  EXPECT_EQ(result.classes[0].class_name, "chair");
  EXPECT_DOUBLE_EQ(result.classes[0].ap_segmentation, 0.0);
  EXPECT_DOUBLE_EQ(result.classes[0].ap_box_25, 0.0);
  EXPECT_EQ(result.classes[1].class_name, "couch");
  EXPECT_EQ(result.classes[1].num_predictions, 1);
  EXPECT_TRUE(std::isnan(result.classes[1].ap_segmentation));  // no couch in the GT
  EXPECT_DOUBLE_EQ(result.map_segmentation, 0.0);              // mean over GT classes only
}

// Object by object: each annotation takes its best same-class box, one each; what matches nothing
// (a false chair, a second box on one chair) is listed; an annotation without a box names the
// nearest one of its class.
TEST(EvaluationObjectMatches, EachAnnotationTakesItsBestBoxOnce) {
  std::vector<GroundTruthObject> gt(3);
  gt[0].class_name = "chair";
  gt[0].box = makeBox({0.0, 0.0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  gt[1].class_name = "chair";
  gt[1].box = makeBox({2.0, 0.0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  gt[2].class_name = "dining table";
  gt[2].box = makeBox({1.0, 2.0, 0.375}, {1.5, 0.9, 0.75}, 0.0);
  std::vector<EvaluatedPrediction> predictions(4);
  predictions[0].id = 7;  // chair 0, 5 cm off
  predictions[0].class_name = "chair";
  predictions[0].box = makeBox({0.05, 0.0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  predictions[1].id = 8;  // a second, worse box on chair 0
  predictions[1].class_name = "chair";
  predictions[1].box = makeBox({0.2, 0.0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  predictions[2].id = 9;  // a chair where there is none, 1 m from chair 1
  predictions[2].class_name = "chair";
  predictions[2].box = makeBox({2.0, 1.0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  predictions[3].id = 10;  // a cup: no annotated class, not listed
  predictions[3].class_name = "cup";
  predictions[3].box = makeBox({5.0, 5.0, 0.8}, {0.1, 0.1, 0.1}, 0.0);
  const ObjectMatches matches = matchObjects(gt, predictions, Eigen::Vector3d::UnitZ());
  ASSERT_EQ(matches.annotated.size(), 3u);
  EXPECT_EQ(matches.annotated[0].prediction_id, 7);
  EXPECT_NEAR(matches.annotated[0].box_iou, 0.45 / 0.55, 1e-6);
  EXPECT_NEAR(matches.annotated[0].centre_distance_m, 0.05, 1e-9);
  EXPECT_EQ(matches.annotated[1].prediction_id, -1);               // no box overlaps chair 1
  EXPECT_NEAR(matches.annotated[1].centre_distance_m, 1.0, 1e-9);  // the nearest chair, #9
  EXPECT_EQ(matches.annotated[2].prediction_id, -1);
  EXPECT_TRUE(std::isnan(matches.annotated[2].centre_distance_m));  // no table at all
  EXPECT_EQ(matches.unmatched_prediction_ids, (std::vector<int>{8, 9}));
  const std::string markdown = objectMatchesToMarkdown(matches, predictions);
  EXPECT_NE(markdown.find("| 0 | chair | #7 | 0.82 | 0.050 |"), std::string::npos) << markdown;
  EXPECT_NE(markdown.find("#8 chair, #9 chair"), std::string::npos) << markdown;
}

// One class name per object in every output (issue 56, item 1): a map object the detector called
// "suitcase" is listed as "suitcase" (as rviz and the object messages show it) and still matches
// an annotated "bag", the evaluation class both belong to.
TEST(EvaluationObjectMatches, AnObjectKeepsItsOwnClassNameAndMatchesItsEvaluationClass) {
  std::vector<GroundTruthObject> gt(1);
  gt[0].class_name = "bag";
  gt[0].box = makeBox({0.0, 0.0, 0.3}, {0.5, 0.3, 0.6}, 0.0);
  MapObject suitcase;
  suitcase.id = 39;
  suitcase.class_name = "suitcase";
  suitcase.box = makeBox({0.02, 0.0, 0.3}, {0.5, 0.3, 0.6}, 0.0);
  MapObject handbag = suitcase;  // a second, false one 2 m away
  handbag.id = 40;
  handbag.class_name = "handbag";
  handbag.box.center_m.x() = 2.0;
  const std::vector<EvaluatedPrediction> predictions = predictionsFromObjects({suitcase, handbag});
  ASSERT_EQ(predictions.size(), 2u);
  EXPECT_EQ(predictions[0].class_name, "suitcase");
  const ObjectMatches matches = matchObjects(gt, predictions, Eigen::Vector3d::UnitZ());
  ASSERT_EQ(matches.annotated.size(), 1u);
  EXPECT_EQ(matches.annotated[0].prediction_id, 39);
  EXPECT_EQ(matches.unmatched_prediction_ids, (std::vector<int>{40}));
  const std::string markdown = objectMatchesToMarkdown(matches, predictions);
  EXPECT_NE(markdown.find("#40 handbag"), std::string::npos) << markdown;
}

TEST(EvaluationClasses, SynonymsMapToCocoNames) {
  EXPECT_EQ(canonicalClassName(" Sofa "), "couch");
  EXPECT_EQ(canonicalClassName("television"), "tv");
  EXPECT_EQ(canonicalClassName("handbag"), "bag");
  EXPECT_EQ(canonicalClassName("chair"), "chair");
  EXPECT_EQ(sceneNNClassName("table"), "dining table");
  EXPECT_EQ(sceneNNClassName("monitor"), "tv");
  EXPECT_EQ(sceneNNClassName("chair2"), "chair");
  EXPECT_EQ(sceneNNClassName("refridgerator"), "refrigerator");
  EXPECT_EQ(sceneNNClassName("books"), "book");
  EXPECT_EQ(sceneNNClassName("wall"), "");
  EXPECT_EQ(sceneNNClassName("desk"), "");
}

// ---- Geometry helpers ----

TEST(EvaluationGeometry, BoxSurfaceSamplesAndFittedBox) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const OrientedBox box = makeBox({1.0, -1.0, 0.45}, {0.8, 0.4, 0.9}, 0.5);
  const PointCloud surface = sampleBoxSurface(box, 0.02, up);
  ASSERT_FALSE(surface.empty());
  int bottom_interior = 0;
  for (const Eigen::Vector3f& p : surface) {
    const Eigen::Vector3d local = box.rotation.transpose() * (p.cast<double>() - box.center_m);
    const Eigen::Vector3d distance = (0.5 * box.size_m - local.cwiseAbs());
    EXPECT_GT(distance.minCoeff(), -1e-5);           // inside or on the box
    EXPECT_LT(std::abs(distance.minCoeff()), 1e-5);  // and on its surface
    if (local.z() < -0.45 + 1e-5 && std::abs(local.x()) < 0.39 && std::abs(local.y()) < 0.19) {
      ++bottom_interior;
    }
  }
  EXPECT_EQ(bottom_interior, 0);  // the bottom face is left out
  const OrientedBox fitted = fitGravityAlignedBox(surface, up);
  EXPECT_NEAR(orientedBoxIoU(fitted, box, up), 1.0, 1e-3);
  EXPECT_NEAR(fitted.rotation.col(2).dot(up), 1.0, 1e-9);
  EXPECT_TRUE(sampleBoxSurface(box, 0.0, up).empty());
  EXPECT_DOUBLE_EQ(fitGravityAlignedBox({}, up).volume(), 0.0);
}

TEST(EvaluationGeometry, PartlySeenBoxKeepsItsAxes) {
  // A fridge in a corner: only its front and one side face were seen. The minimum-area rectangle
  // of that L-shaped footprint is diagonal (0.92 x 0.46 at 45 degrees for a 0.62 x 0.70 box); the
  // faces' normals give the box's own axes.
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const OrientedBox box = makeBox({1.0, -1.0, 0.95}, {0.62, 0.70, 1.9}, 0.3);
  PointCloud seen;
  for (const Eigen::Vector3f& p : sampleBoxSurface(box, 0.02, up)) {
    const Eigen::Vector3d local = box.rotation.transpose() * (p.cast<double>() - box.center_m);
    if (local.x() < -0.31 + 1e-5 || local.y() < -0.35 + 1e-5) seen.push_back(p);  // two faces
  }
  ASSERT_GT(seen.size(), 1000u);
  const OrientedBox fitted = fitGravityAlignedBox(seen, up);
  EXPECT_GT(orientedBoxIoU(fitted, box, up), 0.9);
  const double yaw = std::atan2(fitted.rotation(1, 0), fitted.rotation(0, 0));
  const double off = std::remainder(yaw - 0.3, 3.14159265358979323846 / 2.0);
  EXPECT_LT(std::abs(off), 0.02) << "yaw " << yaw;
}

// ---- End to end ----

TEST(EvaluationEndToEnd, PerfectPredictionsScoreOneAndShiftedOnesLower) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<GroundTruthObject> gt(3);
  gt[0].class_name = "chair";
  gt[0].box = makeBox({0.0, 0.0, 0.45}, {0.5, 0.5, 0.9}, 0.2);
  gt[1].class_name = "chair";
  gt[1].box = makeBox({1.5, 0.0, 0.45}, {0.5, 0.5, 0.9}, -0.4);
  gt[2].class_name = "dining table";
  gt[2].box = makeBox({0.7, 1.5, 0.375}, {1.6, 0.9, 0.75}, 0.1);
  std::vector<EvaluatedPrediction> perfect;
  for (size_t i = 0; i < gt.size(); ++i) {
    EvaluatedPrediction p;
    p.id = static_cast<int>(i);
    p.class_name = gt[i].class_name;
    p.probability = 0.9 - 0.1 * i;
    p.box = gt[i].box;
    p.points_W = sampleBoxSurface(gt[i].box, 0.01, up);  // the observed cloud
    perfect.push_back(p);
  }
  const EvaluationOptions options;
  const EvaluationResult best = evaluate(gt, perfect, options);
  ASSERT_EQ(best.classes.size(), 2u);
  EXPECT_DOUBLE_EQ(best.map_segmentation, 1.0);
  EXPECT_DOUBLE_EQ(best.map_box_25, 1.0);
  EXPECT_DOUBLE_EQ(best.map_box_50, 1.0);
  EXPECT_EQ(best.classes[0].num_ground_truth, 2);

  // Predictions without clouds segment the ground-truth points inside their boxes: perfect boxes
  // still score 1, a box 4 cm off still matches (its cloud would not be a shifted copy), and a box
  // 40 cm off does not.
  std::vector<EvaluatedPrediction> boxes_only = perfect;
  for (EvaluatedPrediction& p : boxes_only) p.points_W.clear();
  EXPECT_DOUBLE_EQ(evaluate(gt, boxes_only, options).map_segmentation, 1.0);
  boxes_only[2].box.center_m.x() += 0.04;
  EXPECT_DOUBLE_EQ(evaluate(gt, boxes_only, options).classes[1].ap_segmentation, 1.0);
  boxes_only[2].box.center_m.x() += 0.36;
  boxes_only[2].box.center_m.y() += 0.4;
  EXPECT_DOUBLE_EQ(evaluate(gt, boxes_only, options).classes[1].ap_segmentation, 0.0);

  // Shift the first chair by 30 cm: it no longer matches at 0.5 (box IoU about 0.25).
  std::vector<EvaluatedPrediction> shifted = perfect;
  shifted[0].box.center_m.x() += 0.3;
  for (Eigen::Vector3f& p : shifted[0].points_W) p.x() += 0.3f;
  const EvaluationResult worse = evaluate(gt, shifted, options);
  EXPECT_LT(worse.classes[0].ap_segmentation, 1.0);
  EXPECT_LT(worse.classes[0].ap_box_50, 1.0);
  EXPECT_DOUBLE_EQ(worse.classes[1].ap_segmentation, 1.0);  // the table is untouched
  EXPECT_LT(worse.map_segmentation, best.map_segmentation);

  // A duplicate of the table ranked first with a wrong place costs precision.
  std::vector<EvaluatedPrediction> duplicated = perfect;
  EvaluatedPrediction ghost = perfect[2];
  ghost.probability = 0.99;
  ghost.box.center_m.y() += 2.0;
  for (Eigen::Vector3f& p : ghost.points_W) p.y() += 2.0f;
  duplicated.push_back(ghost);
  const EvaluationResult ghosted = evaluate(gt, duplicated, options);
  EXPECT_NEAR(ghosted.classes[1].ap_segmentation, 0.5, 1e-12);  // [FP, TP], 1 GT
  EXPECT_EQ(ghosted.classes[1].num_predictions, 2);

  // Tables.
  const std::string markdown = evaluationToMarkdown(worse);
  EXPECT_NE(markdown.find("| chair | 2 | 2 |"), std::string::npos) << markdown;
  EXPECT_NE(markdown.find("| **mean** | 3 | 3 |"), std::string::npos) << markdown;
  const std::string csv = evaluationToCsv(best);
  EXPECT_NE(csv.find("class,num_gt,num_pred,ap_seg,ap_box_25,ap_box_50\n"), std::string::npos);
  EXPECT_NE(csv.find("dining table,1,1,1.0000,1.0000,1.0000\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("mean,3,3,1.0000,1.0000,1.0000\n"), std::string::npos) << csv;
  EXPECT_NE(evaluationToMarkdown(evaluate({}, perfect, options)).find("| - |"), std::string::npos);
}

// ---- Loaders ----

const char kAsciiPly[] =
    "ply\n"
    "format ascii 1.0\n"
    "comment made by hand\n"
    "element vertex 4\n"
    "property float x\nproperty float y\nproperty float z\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    "property int label\n"
    "element face 1\n"
    "property list uchar int vertex_indices\n"
    "end_header\n"
    "0 0 0 255 0 0 1\n"
    "1 0 0 255 0 0 1\n"
    "0 1.5 0 0 255 0 2\n"
    "-0.25 0 2 0 0 255 0\n"
    "3 0 1 2\n";

std::string binaryPly(int vertices_declared, int vertices_written) {
  std::string out =
      "ply\nformat binary_little_endian 1.0\nelement face 1\n"
      "property list uchar int vertex_indices\n"
      "element vertex " +
      std::to_string(vertices_declared) +
      "\nproperty double x\nproperty float y\nproperty float z\nproperty ushort label\n"
      "property uchar alpha\nend_header\n";
  appendBinary<uint8_t>(&out, 3);
  for (int i = 0; i < 3; ++i) appendBinary<int32_t>(&out, i);
  for (int i = 0; i < vertices_written; ++i) {
    appendBinary<double>(&out, 0.5 * i);
    appendBinary<float>(&out, -1.0f * i);
    appendBinary<float>(&out, 2.0f);
    appendBinary<uint16_t>(&out, static_cast<uint16_t>(10 + i));
    appendBinary<uint8_t>(&out, 255);
  }
  return out;
}

TEST_F(EvaluationFiles, ReadsAsciiAndBinaryPly) {
  PointCloud points;
  std::vector<int> labels;
  ASSERT_TRUE(readPlyVertices(write("a.ply", kAsciiPly), &points, &labels));
  ASSERT_EQ(points.size(), 4u);
  EXPECT_EQ(labels, (std::vector<int>{1, 1, 2, 0}));
  EXPECT_FLOAT_EQ(points[2].y(), 1.5f);
  EXPECT_FLOAT_EQ(points[3].x(), -0.25f);

  // Binary, with a face element before the vertices and mixed scalar types.
  ASSERT_TRUE(readPlyVertices(write("b.ply", binaryPly(3, 3)), &points, &labels));
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(labels, (std::vector<int>{10, 11, 12}));
  EXPECT_FLOAT_EQ(points[2].x(), 1.0f);
  EXPECT_FLOAT_EQ(points[2].y(), -2.0f);
  EXPECT_FLOAT_EQ(points[1].z(), 2.0f);

  // Without labels requested, a plain xyz PLY (offline_detection --save-clouds) reads too.
  const std::string plain =
      write("c.ply",
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n0.1 0.2 0.3\n0.4 0.5 0.6\n");
  ASSERT_TRUE(readPlyVertices(plain, &points, nullptr));
  EXPECT_EQ(points.size(), 2u);
}

TEST_F(EvaluationFiles, MalformedPlyIsAnErrorNamingTheFile) {
  PointCloud points = {{7.0f, 7.0f, 7.0f}};
  std::vector<int> labels;
  const std::string truncated = write("truncated.ply", binaryPly(5, 3));
  Status status = readPlyVertices(truncated, &points, &labels);
  ASSERT_FALSE(status);
  EXPECT_NE(status.message().find(truncated), std::string::npos) << status.message();
  EXPECT_EQ(points.size(), 1u);  // untouched

  const std::string no_label =
      write("nolabel.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n0 0 0\n");
  status = readPlyVertices(no_label, &points, &labels);
  ASSERT_FALSE(status);
  EXPECT_NE(status.message().find("label"), std::string::npos);
  EXPECT_NE(status.message().find(no_label), std::string::npos);

  const std::string not_ply = write("bad.ply", "hello\n");
  status = readPlyVertices(not_ply, &points, nullptr);
  ASSERT_FALSE(status);
  EXPECT_NE(status.message().find(not_ply), std::string::npos);

  const std::string big_endian =
      write("be.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n");
  EXPECT_FALSE(readPlyVertices(big_endian, &points, nullptr));
  const std::string short_ascii =
      write("short.ply",
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n0 0 0\n1 1\n");
  EXPECT_FALSE(readPlyVertices(short_ascii, &points, nullptr));
  EXPECT_FALSE(readPlyVertices((dir_ / "missing.ply").string(), &points, nullptr));
}

const char kXml[] =
    "<?xml version=\"1.0\"?>\n<annotation>\n"
    "  <label id=\"1\" text=\"chair\" nyu_class=\"chair\" aabbox=\"0 0 0 1 1.5 0\" "
    "obbox=\"0.5 0.75 0 1 1.5 0.1 0 0 0 1\" local_pose=\"0 0 0 1\" color=\"255 0 0\"/>\n"
    "  <label id=\"2\" text=\"sofa\" aabbox=\"-0.25 0 2 -0.25 0 2\" color=\"0 255 0\"/>\n"
    "  <label id=\"3\" text=\"wall\" aabbox=\"0 0 0 1 1 1\" />\n"
    "  <label id=\"4\" text=\"Fish &amp; chips\" aabbox=\"0 0 0 1 1 1\" />\n"
    "</annotation>\n";

TEST_F(EvaluationFiles, ReadsSceneNNXmlWithAndWithoutObbox) {
  std::vector<SceneNNLabel> labels;
  ASSERT_TRUE(readSceneNNXml(write("a.xml", kXml), &labels));
  ASSERT_EQ(labels.size(), 4u);
  EXPECT_EQ(labels[0].id, 1);
  EXPECT_EQ(labels[0].nyu_class, "chair");
  EXPECT_TRUE(labels[0].has_obbox);
  EXPECT_DOUBLE_EQ(labels[0].obbox[4], 1.5);
  EXPECT_DOUBLE_EQ(labels[0].aabb_max.y(), 1.5);
  EXPECT_EQ(labels[1].text, "sofa");
  EXPECT_FALSE(labels[1].has_obbox);
  EXPECT_TRUE(labels[1].nyu_class.empty());
  EXPECT_DOUBLE_EQ(labels[1].aabb_min.z(), 2.0);
  EXPECT_EQ(labels[3].text, "Fish & chips");

  for (const char* bad :
       {"<annotation><label text=\"chair\" aabbox=\"0 0 0 1 1 1\"/></annotation>",
        "<annotation><label id=\"1\" text=\"chair\" aabbox=\"0 0 0 1 1\"/></annotation>",
        "<annotation><label id=\"1\" text=\"chair\" aabbox=\"0 0 0 1 1 1\" "
        "obbox=\"1 2 3\"/></annotation>",
        "<annotation><label id=\"x\" text=\"chair\" aabbox=\"0 0 0 1 1 1\"/></annotation>",
        "<annotation><label id=\"1 text=\"chair\"/></annotation>", "not xml at all"}) {
    const std::string path = write("bad.xml", bad);
    labels.assign(1, SceneNNLabel());
    const Status status = readSceneNNXml(path, &labels);
    ASSERT_FALSE(status) << bad;
    EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
    EXPECT_EQ(labels.size(), 1u);
  }
}

TEST_F(EvaluationFiles, LoadsSceneNNSequenceYUp) {
  write("011/011.ply", kAsciiPly);
  write("011/011.xml", kXml);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  std::vector<GroundTruthObject> objects;
  ASSERT_TRUE(loadSceneNNGroundTruth((dir_ / "011").string(), up, &objects));
  // Label 1 (chair, 2 vertices) and 2 (sofa -> couch, 1 vertex); wall and the unknown label are
  // ignored, and vertex label 0 is unlabelled.
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[0].class_name, "chair");
  EXPECT_EQ(objects[0].points_W.size(), 2u);
  EXPECT_EQ(objects[1].class_name, "couch");
  EXPECT_EQ(objects[1].points_W.size(), 1u);
  // The chair's vertices lie along x at height y = 0: its box is 1 m along x, flat vertically.
  EXPECT_NEAR(objects[0].box.rotation.col(2).dot(up), 1.0, 1e-9);
  EXPECT_NEAR(objects[0].box.size_m.maxCoeff(), 1.0, 1e-6);
  EXPECT_NEAR(objects[0].box.size_m.z(), 0.0, 1e-6);
  EXPECT_NEAR(objects[0].box.center_m.x(), 0.5, 1e-6);

  // The .ply path works too, and says what it left out and why (evaluate lists them); a folder
  // without the files is an error naming what is missing.
  std::vector<std::string> skipped;
  ASSERT_TRUE(loadSceneNNGroundTruth((dir_ / "011" / "011.ply").string(), up, &objects, &skipped));
  EXPECT_EQ(objects.size(), 2u);
  ASSERT_EQ(skipped.size(), 2u);
  EXPECT_EQ(skipped[0].rfind("'wall' (): not one of the 9 classes", 0), 0u) << skipped[0];
  EXPECT_EQ(skipped[1].rfind("'Fish & chips' (): not one of the 9 classes", 0), 0u) << skipped[1];
  fs::create_directories(dir_ / "012");
  const Status missing = loadSceneNNGroundTruth((dir_ / "012").string(), up, &objects);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.message().find("012.ply"), std::string::npos) << missing.message();
  EXPECT_EQ(objects.size(), 2u);
}

// The redkitchen annotation states its world's up (not z); evaluate scores with it.
TEST_F(EvaluationFiles, GroundTruthStatesItsUp) {
  Eigen::Vector3d up(0, 0, 1);
  bool found = true;
  ASSERT_TRUE(readGroundTruthUp(write("none.json", R"({"objects": []})"), &up, &found).ok());
  EXPECT_FALSE(found);
  ASSERT_TRUE(
      readGroundTruthUp(write("up.json", R"({"up": [0, -2, 0], "objects": []})"), &up, &found)
          .ok());
  EXPECT_TRUE(found);
  EXPECT_TRUE(up.isApprox(Eigen::Vector3d(0, -1, 0)));
  EXPECT_FALSE(readGroundTruthUp(write("zero.json", R"({"up": [0, 0, 0]})"), &up, &found).ok());
  const std::string annotation =
      std::string(MVOD_SOURCE_DIR) + "/test/data/7scenes_redkitchen_annotation/ground_truth.json";
  ASSERT_TRUE(readGroundTruthUp(annotation, &up, &found).ok());
  EXPECT_TRUE(found);
  EXPECT_NEAR(up.y(), -0.904, 1e-3);
}

TEST_F(EvaluationFiles, LoadsSyntheticGroundTruth) {
  const std::string path = write("ground_truth.json",
                                 R"({"frames": 10, "objects": [
        {"class_name": "chair", "center": [1, 2, 0.45], "size": [0.5, 0.5, 0.9],
         "rotation": [[0, -1, 0], [1, 0, 0], [0, 0, 1]], "yaw": 1.5707963},
        {"class_name": "", "center": [0, 0, 0.5], "size": [1, 1, 1],
         "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "yaw": 0},
        {"class_name": "Sofa", "center": [3, 0, 0.4], "size": [2, 0.9, 0.8],
         "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "yaw": 0,
         "points": [[3, 0, 0.8], [3.5, 0.2, 0.8]]}]})");
  std::vector<GroundTruthObject> objects;
  ASSERT_TRUE(loadSyntheticGroundTruth(path, 0.01, Eigen::Vector3d::UnitZ(), &objects));
  ASSERT_EQ(objects.size(), 2u);  // the unlabelled clutter box is not ground truth
  EXPECT_EQ(objects[0].class_name, "chair");
  EXPECT_EQ(objects[1].class_name, "couch");
  EXPECT_NEAR(objects[0].box.rotation(1, 0), 1.0, 1e-12);
  ASSERT_EQ(objects[1].points_W.size(), 2u);  // given points win over the box surface
  EXPECT_FLOAT_EQ(objects[1].points_W[1].x(), 3.5f);
  ASSERT_FALSE(objects[0].points_W.empty());
  for (const Eigen::Vector3f& p : objects[0].points_W) {
    EXPECT_TRUE(objects[0].box.contains(p.cast<double>(), 1e-5));
  }

  for (const char* bad :
       {"{", R"({"objects": 3})", R"({"objects": [{"center": [0, 0, 0]}]})",
        R"({"objects": [{"class_name": "chair", "center": [0, 0], "size": [1, 1, 1],
            "yaw": 0}]})",
        R"({"objects": [{"class_name": "chair", "center": [0, 0, 0], "size": [1, 1, 1],
            "rotation": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}]})",
        R"({"objects": [{"class_name": "chair", "center": [0, 0, 0], "size": [1, 1, 1],
            "yaw": 0, "points": [[0, 0]]}]})"}) {
    const std::string bad_path = write("bad.json", bad);
    const Status status =
        loadSyntheticGroundTruth(bad_path, 0.01, Eigen::Vector3d::UnitZ(), &objects);
    ASSERT_FALSE(status) << bad;
    EXPECT_NE(status.message().find(bad_path), std::string::npos) << status.message();
    EXPECT_EQ(objects.size(), 2u);
  }
}

TEST_F(EvaluationFiles, LoadsPredictionsWithCloudsFromJsonOrFolder) {
  std::vector<MapObject> objects(2);
  objects[0].id = 1;
  objects[0].class_name = "chair";
  objects[0].probability = 0.8;
  objects[0].box = makeBox({0, 0, 0.45}, {0.5, 0.5, 0.9}, 0.0);
  objects[0].points_W = {{0.1f, 0.1f, 0.1f}, {0.2f, 0.2f, 0.2f}};
  objects[1].id = 7;
  objects[1].class_name = "dining table";
  objects[1].probability = 0.6;
  objects[1].box = makeBox({2, 0, 0.4}, {1.2, 0.8, 0.8}, 0.0);
  objects[1].points_W = {{2.0f, 0.0f, 0.8f}};

  std::vector<EvaluatedPrediction> predictions;
  int with_clouds = -1;
  // With clouds stored in the JSON.
  const std::string with = write("with.json", objectsToJson(objects, MapSummary(), true));
  ASSERT_TRUE(loadPredictions(with, "", &predictions, &with_clouds));
  ASSERT_EQ(predictions.size(), 2u);
  EXPECT_EQ(with_clouds, 2);
  EXPECT_EQ(predictions[0].points_W.size(), 2u);
  EXPECT_EQ(predictions[1].class_name, "dining table");
  EXPECT_DOUBLE_EQ(predictions[1].probability, 0.6);

  // Without: the --save-clouds folder supplies object 7's cloud, object 1 falls back to its box.
  // The file name that offline_detection --save-clouds gives it (class made file-safe):
  EXPECT_EQ(objectCloudFileStem(7, "dining table"), "object_7_dining_table");
  EXPECT_EQ(objectCloudFileStem(12, "a/b.c-d_e"), "object_12_a_b_c-d_e");
  const std::string without = write("without.json", objectsToJson(objects, MapSummary(), false));
  write("clouds/object_7_dining_table_fused.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n2 0 0.8\n2.1 0 0.8\n2.2 0 0.8\n");
  ASSERT_TRUE(loadPredictions(without, (dir_ / "clouds").string(), &predictions, &with_clouds));
  EXPECT_EQ(with_clouds, 1);
  EXPECT_TRUE(predictions[0].points_W.empty());
  EXPECT_EQ(predictions[1].points_W.size(), 3u);

  const std::string broken = write("broken.json", "{\"objects\": [1]}");
  const Status status = loadPredictions(broken, "", &predictions, nullptr);
  ASSERT_FALSE(status);
  EXPECT_NE(status.message().find(broken), std::string::npos) << status.message();
  EXPECT_EQ(predictions.size(), 2u);
}

}  // namespace
}  // namespace mvod
