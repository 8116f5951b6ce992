// The colour-to-depth registration check (registration_check.h): on a synthetic frame it finds the
// shift a known calibration error makes, and on the real redkitchen the annotation's colour camera
// (test/data/7scenes_redkitchen_annotation/colour_camera, T_C_D: p_C = R p_D + t) lines colour up
// with depth within 4 px (issue 54, item 4: the file had the translation's sign reversed, 13 px
// off). Skipped without ../shared's frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/evaluation/registration_check.h"
#include "shared_data.h"

namespace mvod {
namespace {

// A square 1 m away in front of a wall 2 m away, seen by the depth camera; the colour image shows
// the square (white on grey) where it lies in the colour camera `T_C_D_true` puts it.
RgbdFrame squareInFrontOfAWall(const Eigen::Isometry3d& T_C_D_true) {
  RgbdFrame frame;
  frame.K_depth = {585.0, 585.0, 320.0, 240.0, 640, 480};
  frame.K_color = {525.0, 525.0, 320.0, 240.0, 640, 480};
  frame.registered = false;
  frame.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(2000));
  frame.depth(cv::Rect(220, 150, 200, 180)).setTo(1000);
  frame.color_bgr = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  for (int v = 150; v < 330; ++v) {
    for (int u = 220; u < 420; ++u) {
      const Eigen::Vector3d p_D((u - 320.0) / 585.0, (v - 240.0) / 585.0, 1.0);
      const Eigen::Vector3d p_C = T_C_D_true * p_D;
      const int uc = static_cast<int>(std::lround(525.0 * p_C.x() / p_C.z() + 320.0));
      const int vc = static_cast<int>(std::lround(525.0 * p_C.y() / p_C.z() + 240.0));
      if (uc >= 0 && vc >= 0 && uc < 640 && vc < 480) {
        cv::circle(frame.color_bgr, cv::Point(uc, vc), 1, cv::Scalar(230, 230, 230), -1);
      }
    }
  }
  return frame;
}

TEST(RegistrationCheckTest, FindsTheShiftOfAWrongCalibration) {
  Eigen::Isometry3d T_C_D_true = Eigen::Isometry3d::Identity();
  T_C_D_true.translation() = Eigen::Vector3d(-0.025, 0.0, 0.0);
  RgbdFrame frame = squareInFrontOfAWall(T_C_D_true);
  frame.T_C_D = T_C_D_true;
  RegistrationShift shift = measureRegistrationShift(frame);
  ASSERT_TRUE(shift.valid);
  EXPECT_LE(std::abs(shift.du_px), 1);
  EXPECT_LE(std::abs(shift.dv_px), 1);
  // A calibration 3.5 cm off along x: the square's edges, 1 m away, land 3.5 cm x 525 px / 1 m =
  // 18 px to the right of where the colour image shows them.
  frame.T_C_D.translation() = Eigen::Vector3d(0.01, 0.0, 0.0);
  shift = measureRegistrationShift(frame);
  ASSERT_TRUE(shift.valid);
  EXPECT_NEAR(shift.du_px, -18, 1);
  EXPECT_LE(std::abs(shift.dv_px), 1);
}

TEST(RegistrationCheckTest, TheRedkitchenColourCameraLinesUpWithDepth) {
  const std::string frames = test::sharedPath("data/7scenes_redkitchen/data");
  if (frames.empty()) {
    GTEST_SKIP() << "needs ../shared/data/7scenes_redkitchen/data (or $MVOD_SHARED_DIR)";
  }
  const std::string camera =
      std::string(MVOD_SOURCE_DIR) + "/test/data/7scenes_redkitchen_annotation/colour_camera/";
  SevenScenesDataset dataset;
  const Status opened = SevenScenesDataset::open(
      frames, &dataset, {camera + "color-intrinsics.txt", camera + "depth-to-color.txt", false});
  ASSERT_TRUE(opened.ok()) << opened.message();
  std::vector<int> du;
  std::vector<int> dv;
  for (size_t i = 0; i < dataset.size(); i += 25) {
    RgbdFrame frame;
    ASSERT_TRUE(dataset.load(dataset.frameIndices()[i], &frame).ok());
    const RegistrationShift shift = measureRegistrationShift(frame);
    if (!shift.valid) continue;
    du.push_back(shift.du_px);
    dv.push_back(shift.dv_px);
  }
  ASSERT_GE(du.size(), 30u);
  std::nth_element(du.begin(), du.begin() + du.size() / 2, du.end());
  std::nth_element(dv.begin(), dv.begin() + dv.size() / 2, dv.end());
  const int median_du = du[du.size() / 2];
  const int median_dv = dv[dv.size() / 2];
  std::printf(
      "[ INFO     ] redkitchen colour camera: median shift du %d px, dv %d px over %zu frames\n",
      median_du, median_dv, du.size());
  EXPECT_LE(std::abs(median_du), 4);
  EXPECT_LE(std::abs(median_dv), 4);
}

}  // namespace
}  // namespace mvod
