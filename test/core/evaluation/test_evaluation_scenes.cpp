// Pooled evaluation over several scenes (VOC-style) and the bird's-eye map plot.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/datasets/ground_truth_geometry.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/evaluation/map_plot.h"

namespace mvod {
namespace {

OrientedBox yawedBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw_rad) {
  OrientedBox box;
  box.center_m = center;
  box.size_m = size;
  box.rotation = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return box;
}

GroundTruthObject groundTruth(const std::string& name, const OrientedBox& box) {
  GroundTruthObject object;
  object.class_name = name;
  object.box = box;
  object.points_W = sampleBoxSurface(box, 0.01, Eigen::Vector3d::UnitZ());
  return object;
}

EvaluatedPrediction prediction(int id, const GroundTruthObject& gt, double probability,
                               double shift_x_m = 0.0) {
  EvaluatedPrediction p;
  p.id = id;
  p.class_name = gt.class_name;
  p.probability = probability;
  p.box = gt.box;
  p.box.center_m.x() += shift_x_m;
  p.points_W = gt.points_W;
  for (Eigen::Vector3f& q : p.points_W) q.x() += static_cast<float>(shift_x_m);
  return p;
}

TEST(EvaluationScenes, PoolsRankingAcrossScenesWithoutCrossMatches) {
  // Two scenes with one chair each at the SAME place: a prediction of scene 0 must not match
  // scene 1's chair.
  const GroundTruthObject chair =
      groundTruth("chair", yawedBox({1, 1, 0.45}, {0.5, 0.5, 0.9}, 0.3));
  EvaluationScene first;
  first.ground_truth = {chair};
  first.predictions = {prediction(1, chair, 0.9)};
  EvaluationScene second;
  second.ground_truth = {chair};
  // Scene 1: a wrong detection ranked highest, then the right one.
  second.predictions = {prediction(2, chair, 0.95, 1.5), prediction(3, chair, 0.6)};
  const EvaluationOptions options;
  const EvaluationResult pooled = evaluateScenes({first, second}, options);
  ASSERT_EQ(pooled.classes.size(), 1u);
  EXPECT_EQ(pooled.classes[0].num_ground_truth, 2);
  EXPECT_EQ(pooled.classes[0].num_predictions, 3);
  // Ranked over both scenes: FP (0.95), TP (0.9), TP (0.6): precision envelope 2/3 over recall
  // 0 -> 1, so AP = 2/3. Scene by scene it would be 1 and 0.5.
  EXPECT_NEAR(pooled.classes[0].ap_segmentation, 2.0 / 3.0, 1e-9);
  EXPECT_NEAR(pooled.classes[0].ap_box_50, 2.0 / 3.0, 1e-9);
  EXPECT_NEAR(evaluate(first.ground_truth, first.predictions, options).map_segmentation, 1.0,
              1e-12);

  // A scene without a chair whose (wrong) chair lies where scene 0's chair is: pooled, it is a
  // false positive; merged into one scene it would take scene 0's chair.
  EvaluationScene empty;
  empty.ground_truth = {groundTruth("bed", yawedBox({5, 5, 0.3}, {2.0, 1.6, 0.6}, 0.0))};
  empty.predictions = {prediction(4, chair, 0.95)};
  EvaluationScene one = first;
  one.predictions[0].probability = 0.6;
  const EvaluationResult with_empty = evaluateScenes({one, empty}, options);
  EXPECT_NEAR(with_empty.classes[1].ap_segmentation, 0.5, 1e-9);  // [FP, TP], 1 GT
  std::vector<EvaluatedPrediction> merged = {one.predictions[0], empty.predictions[0]};
  EXPECT_NEAR(evaluate(first.ground_truth, merged, options).classes[0].ap_segmentation, 1.0, 1e-9);

  // One scene pooled is the scene itself.
  const EvaluationResult single = evaluateScenes({second}, options);
  const EvaluationResult direct = evaluate(second.ground_truth, second.predictions, options);
  EXPECT_DOUBLE_EQ(single.map_segmentation, direct.map_segmentation);
  EXPECT_DOUBLE_EQ(single.map_box_25, direct.map_box_25);
}

TEST(EvaluationScenes, YUpScenesShiftHorizontally) {
  // y-up: scenes move along x or z, never up, so box IoU (footprint x height) stays exact.
  EvaluationOptions options;
  options.up_W = Eigen::Vector3d::UnitY();
  GroundTruthObject bed;
  bed.class_name = "bed";
  bed.box.center_m = Eigen::Vector3d(0, 0.3, 0);
  bed.box.size_m = Eigen::Vector3d(2.0, 0.6, 1.6);
  bed.points_W = sampleBoxSurface(bed.box, 0.02, options.up_W);
  EvaluatedPrediction p;
  p.class_name = "bed";
  p.probability = 0.8;
  p.box = bed.box;
  p.points_W = bed.points_W;
  EvaluationScene scene{{bed}, {p}};
  const EvaluationResult result = evaluateScenes({scene, scene, scene}, options);
  EXPECT_DOUBLE_EQ(result.map_segmentation, 1.0);
  EXPECT_DOUBLE_EQ(result.map_box_50, 1.0);
  EXPECT_EQ(result.classes[0].num_ground_truth, 3);
}

TEST(BirdsEyeMap, DrawsGroundTruthAndColouredPredictionsWhereTheyAre) {
  const GroundTruthObject table =
      groundTruth("dining table", yawedBox({2, 1, 0.375}, {1.6, 0.9, 0.75}, 0.0));
  const GroundTruthObject chair =
      groundTruth("chair", yawedBox({4, 3, 0.45}, {0.5, 0.5, 0.9}, 0.5));
  BirdsEyeConfig config;
  config.pixels_per_m = 100.0;
  config.margin_m = 0.5;
  const cv::Mat image = drawBirdsEyeMap({table, chair}, {prediction(1, table, 0.9)},
                                        Eigen::Vector3d::UnitZ(), config);
  ASSERT_FALSE(image.empty());
  ASSERT_EQ(image.type(), CV_8UC3);
  // Footprints: table x in [1.2, 2.8], y in [0.55, 1.45]; chair (yaw 0.5) reaches
  // 0.25 (cos 0.5 + sin 0.5) = 0.339 m from its centre. Plus 0.5 m margins, 100 px/m, and a 46 px
  // legend band on top.
  const double reach = 0.25 * (std::cos(0.5) + std::sin(0.5));
  const double x_lo = 1.2 - 0.5;
  const double y_hi = 3.0 + reach + 0.5;
  EXPECT_NEAR(image.cols, 100.0 * (4.0 + reach + 0.5 - x_lo), 2.0);
  EXPECT_NEAR(image.rows, 46 + 100.0 * (y_hi - (0.55 - 0.5)), 2.0);
  auto pixel = [&](double x, double y) {
    return image.at<cv::Vec3b>(static_cast<int>(std::lround(46 + (y_hi - y) * 100.0)),
                               static_cast<int>(std::lround((x - x_lo) * 100.0)));
  };
  auto is_coloured = [](const cv::Vec3b& c) {
    return std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]}) > 80;
  };
  // The predicted table's outline (left edge, x = 1.2) is drawn in a saturated class colour.
  EXPECT_TRUE(is_coloured(pixel(1.2, 0.8))) << pixel(1.2, 0.8);
  // Inside the unpredicted chair: only the ground truth's green fill and grey points, no
  // saturated outline; outside everything: white.
  const cv::Vec3b chair_inside = pixel(4.0, 3.0);
  EXPECT_NE(chair_inside, cv::Vec3b(255, 255, 255));
  EXPECT_GT(chair_inside[1], chair_inside[2]);  // green-ish fill (BGR)
  EXPECT_EQ(pixel(3.5, 0.7), cv::Vec3b(255, 255, 255));
  // Seen from above: y grows upwards in the image (the chair row is above the table row).
  EXPECT_NE(pixel(4.0, 3.0), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(pixel(3.6, 1.3), cv::Vec3b(255, 255, 255));

  // Nothing to draw: a small note image, no crash.
  const cv::Mat blank = drawBirdsEyeMap({}, {}, Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(blank.empty());
}

// A region of the plan (a table top): only it, at max_size_px on its longer side.
TEST(BirdsEyeMap, ARegionIsDrawnAloneAtTheFullSize) {
  const GroundTruthObject table =
      groundTruth("dining table", yawedBox({2, 1, 0.375}, {1.6, 0.9, 0.75}, 0.0));
  const GroundTruthObject mug = groundTruth("cup", yawedBox({2.2, 1.1, 0.8}, {0.1, 0.08, 0.1}, 0));
  BirdsEyeConfig config;
  config.max_size_px = 1000;
  config.grid_spacing_m = 0.1;
  config.region = Eigen::AlignedBox2d(Eigen::Vector2d(1.9, 0.9), Eigen::Vector2d(2.4, 1.2));
  const cv::Mat image =
      drawBirdsEyeMap({table, mug}, {prediction(3, mug, 0.7)}, Eigen::Vector3d::UnitZ(), config);
  ASSERT_EQ(image.cols, 1000);  // 0.5 m at 2000 px/m
  ASSERT_EQ(image.rows, 46 + 600);
  auto pixel = [&](double x, double y) {
    return image.at<cv::Vec3b>(static_cast<int>(std::lround(46 + (1.2 - y) * 2000.0)),
                               static_cast<int>(std::lround((x - 1.9) * 2000.0)));
  };
  auto is_coloured = [](const cv::Vec3b& c) {
    return std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]}) > 80;
  };
  // The mug's predicted outline (its left edge, x = 2.15) 500 px from the image's left edge.
  bool outline = false;
  for (int dx = -2; dx <= 2; ++dx) outline = outline || is_coloured(pixel(2.15 + dx / 2000.0, 1.1));
  EXPECT_TRUE(outline);
  // Without the region: the whole table at pixels_per_m, the mug a few pixels.
  BirdsEyeConfig whole = config;
  whole.region = Eigen::AlignedBox2d();
  EXPECT_LT(
      drawBirdsEyeMap({table, mug}, {prediction(3, mug, 0.7)}, Eigen::Vector3d::UnitZ(), whole)
          .cols,
      400);
}

// A narrow map (one chair): the legend shrinks to the image's width instead of running off it.
TEST(BirdsEyeMap, LegendFitsANarrowMap) {
  const GroundTruthObject chair = groundTruth("chair", yawedBox({1, 1, 0.45}, {0.5, 0.5, 0.9}, 0));
  const cv::Mat image = drawBirdsEyeMap({chair}, {prediction(7, chair, 0.5)},
                                        Eigen::Vector3d::UnitZ(), BirdsEyeConfig{});
  ASSERT_EQ(image.cols, 320);  // the narrowest image
  cv::Mat grey;
  cv::cvtColor(image.rowRange(0, 46), grey, cv::COLOR_BGR2GRAY);
  // Text in both legend lines, none in the last 5 columns.
  EXPECT_GT(cv::countNonZero(grey.rowRange(0, 23) < 128), 50);
  EXPECT_GT(cv::countNonZero(grey.rowRange(23, 46) < 128), 50);
  EXPECT_EQ(cv::countNonZero(grey.colRange(grey.cols - 5, grey.cols) < 200), 0);
}

}  // namespace
}  // namespace mvod
