// The box of an object each view saw whole, from the views' boxes (view_consensus.h): pose error
// between the views no longer widens it, and an object seen in parts keeps the union.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "multiview_object_detection/pipeline/map/view_consensus.h"

namespace mvod {
namespace {

OrientedBox viewBoxAt(const Eigen::Vector3d& center_m, const Eigen::Vector3d& size_m,
                      double yaw_rad = 0.0) {
  OrientedBox box;
  box.center_m = center_m;
  box.size_m = size_m;
  box.rotation = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return box;
}

// The union of the views' boxes along the world axes (the views here are axis-aligned).
OrientedBox unionOfViews(const std::vector<OrientedBox>& views) {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  for (const OrientedBox& view : views) {
    low = low.cwiseMin(view.center_m - 0.5 * view.size_m);
    high = high.cwiseMax(view.center_m + 0.5 * view.size_m);
  }
  return viewBoxAt(0.5 * (low + high), high - low);
}

// A 10 x 8 x 10 cm mug at (1, 2, 0.8), seen whole by 20 views whose poses are off by up to 3 cm
// along x and 1.5 cm along y (an even spread, as drift gives).
std::vector<OrientedBox> driftedViewsOfAMug() {
  std::vector<OrientedBox> views;
  for (int v = 0; v < 20; ++v) {
    const double dx_m = -0.03 + 0.06 * v / 19.0;
    const double dy_m = 0.015 * std::sin(v);
    views.push_back(viewBoxAt({1.0 + dx_m, 2.0 + dy_m, 0.8}, {0.10, 0.08, 0.10}));
  }
  return views;
}

TEST(ViewConsensusTest, ViewsOffByPoseErrorGiveTheObjectsOwnSize) {
  const std::vector<OrientedBox> views = driftedViewsOfAMug();
  OrientedBox box = unionOfViews(views);
  ASSERT_NEAR(box.size_m.x(), 0.16, 1e-9);  // the union: 6 cm too long
  ASSERT_TRUE(viewConsensusBox(views, 0.06, &box));
  // The quartiles of the ends: a quarter of the spread is left on each side.
  EXPECT_NEAR(box.size_m.x(), 0.13, 0.005);
  EXPECT_LT(box.size_m.y(), 0.08 + 0.02);
  EXPECT_NEAR(box.size_m.z(), 0.10, 1e-9);
  EXPECT_NEAR(box.center_m.x(), 1.0, 0.005);
  EXPECT_NEAR(box.center_m.y(), 2.0, 0.005);
  EXPECT_NEAR(box.center_m.z(), 0.8, 1e-9);
}

TEST(ViewConsensusTest, AnObjectSeenInPartsKeepsTheUnion) {
  // A 1.5 m table seen half at a time, its left half by 8 views and its right half by 2: the
  // upper quartile of the views' ends falls in its middle, 0.75 m short of the union.
  std::vector<OrientedBox> views;
  for (int v = 0; v < 10; ++v) {
    const double x_m = v < 8 ? 0.625 : 1.375;
    views.push_back(viewBoxAt({x_m, 2.0, 0.38}, {0.75, 0.9, 0.76}));
  }
  OrientedBox box = unionOfViews(views);
  const OrientedBox before = box;
  EXPECT_FALSE(viewConsensusBox(views, 0.06, &box));
  EXPECT_EQ(box.center_m, before.center_m);
  EXPECT_EQ(box.size_m, before.size_m);
  // The same views with a tolerance above their disagreement: the consensus (never beyond the
  // union).
  EXPECT_TRUE(viewConsensusBox(views, 1.0, &box));
  EXPECT_LE(box.size_m.x(), before.size_m.x());
}

TEST(ViewConsensusTest, FewViewsOrNoToleranceKeepTheUnion) {
  std::vector<OrientedBox> views = driftedViewsOfAMug();
  const OrientedBox before = unionOfViews(views);
  OrientedBox box = before;
  EXPECT_FALSE(viewConsensusBox(views, 0.0, &box));
  EXPECT_FALSE(viewConsensusBox({views[0], views[19]}, 0.06, &box));
  // Views with a non-finite box do not count.
  OrientedBox broken = views[0];
  broken.center_m.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(viewConsensusBox({views[0], views[19], broken}, 0.06, &box));
  EXPECT_EQ(box.center_m, before.center_m);
  EXPECT_EQ(box.size_m, before.size_m);
  EXPECT_TRUE(viewConsensusBox({views[0], views[10], views[19], broken}, 0.06, &box));
}

TEST(ViewConsensusTest, ViewsTurnedAboutGravityAreMeasuredAlongTheFusedAxes) {
  // The fused box turned 30 degrees; the views' boxes the same, each off along the box's x.
  const double yaw_rad = 0.5236;
  const Eigen::Vector3d x_axis(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  std::vector<OrientedBox> views;
  for (int v = 0; v < 12; ++v) {
    const double d_m = -0.025 + 0.05 * v / 11.0;
    views.push_back(
        viewBoxAt(Eigen::Vector3d(0.5, 0.5, 0.75) + d_m * x_axis, {0.25, 0.18, 0.02}, yaw_rad));
  }
  OrientedBox box = viewBoxAt({0.5, 0.5, 0.75}, {0.30, 0.18, 0.02}, yaw_rad);
  ASSERT_TRUE(viewConsensusBox(views, 0.06, &box));
  EXPECT_NEAR(box.size_m.x(), 0.275, 0.006);
  EXPECT_NEAR(box.size_m.y(), 0.18, 1e-9);
  EXPECT_NEAR((box.center_m - Eigen::Vector3d(0.5, 0.5, 0.75)).norm(), 0.0, 0.003);
}

}  // namespace
}  // namespace mvod
