// OrientedBox, GravityFrame and the exact gravity-aligned intersection volume that the intersection
// filter (Eq. 10, 11) relies on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {
namespace {

// A 7-Scenes-like gravity: not along any world axis.
Eigen::Vector3d tiltedGravity() { return Eigen::Vector3d(0.0, 0.9, 0.43).normalized(); }

OrientedBox makeBox(const GravityFrame& frame, const Eigen::Vector3d& center_m,
                    const Eigen::Vector3d& size_m, double yaw_rad) {
  OrientedBox box;
  box.center_m = center_m;
  box.size_m = size_m;
  box.rotation = frame.rotationFromYaw(yaw_rad);
  return box;
}

std::vector<Eigen::Vector2d> square(double half, const Eigen::Vector2d& center) {
  return {center + Eigen::Vector2d(-half, -half), center + Eigen::Vector2d(half, -half),
          center + Eigen::Vector2d(half, half), center + Eigen::Vector2d(-half, half)};
}

// Monte Carlo estimate of vol(a ∩ b): uniform samples in b, the fraction inside a.
double monteCarloIntersection(const OrientedBox& a, const OrientedBox& b, int samples,
                              unsigned int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-0.5, 0.5);
  int inside = 0;
  for (int i = 0; i < samples; ++i) {
    const Eigen::Vector3d local(unit(rng) * b.size_m.x(), unit(rng) * b.size_m.y(),
                                unit(rng) * b.size_m.z());
    if (a.contains(b.center_m + b.rotation * local)) ++inside;
  }
  return b.volume() * inside / samples;
}

TEST(OrientedBoxTest, CornersCarryTheirSignBits) {
  const GravityFrame frame(tiltedGravity());
  const OrientedBox box =
      makeBox(frame, Eigen::Vector3d(1.0, -2.0, 0.5), Eigen::Vector3d(0.4, 0.6, 1.0), 0.7);
  const std::vector<Eigen::Vector3d> corners = box.corners();
  ASSERT_EQ(corners.size(), 8u);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d local = box.rotation.transpose() * (corners[i] - box.center_m);
    EXPECT_NEAR(local.x(), (i & 1 ? 0.2 : -0.2), 1e-12) << i;
    EXPECT_NEAR(local.y(), (i & 2 ? 0.3 : -0.3), 1e-12) << i;
    EXPECT_NEAR(local.z(), (i & 4 ? 0.5 : -0.5), 1e-12) << i;
    mean += corners[i] / 8.0;
  }
  EXPECT_LT((mean - box.center_m).norm(), 1e-12);
  // Corners 0 and 4 differ only in height: along `up`.
  EXPECT_LT(((corners[4] - corners[0]) - 1.0 * frame.up).norm(), 1e-12);
}

TEST(OrientedBoxTest, ContainsRespectsAxesAndMargin) {
  const GravityFrame frame(tiltedGravity());
  const OrientedBox box =
      makeBox(frame, Eigen::Vector3d(1.0, -2.0, 0.5), Eigen::Vector3d(0.4, 0.6, 1.0), 0.7);
  EXPECT_TRUE(box.contains(box.center_m));
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d direction = box.rotation.col(axis);
    const double half = 0.5 * box.size_m[axis];
    EXPECT_TRUE(box.contains(box.center_m + 0.99 * half * direction)) << axis;
    EXPECT_TRUE(box.contains(box.center_m - 0.99 * half * direction)) << axis;
    EXPECT_FALSE(box.contains(box.center_m + 1.01 * half * direction)) << axis;
    EXPECT_FALSE(box.contains(box.center_m - (half + 0.05) * direction)) << axis;
    EXPECT_TRUE(box.contains(box.center_m - (half + 0.05) * direction, 0.06)) << axis;
  }
  // A world-axis offset that is inside an axis-aligned box of the same size is outside this one.
  EXPECT_FALSE(box.contains(box.center_m + Eigen::Vector3d(0.19, 0.29, 0.0) * 1.9));
  EXPECT_FALSE(box.contains(Eigen::Vector3d(std::nan(""), 0.0, 0.0)));
}

TEST(GravityFrameTest, TiltedGravityGivesAnOrthonormalRightHandedFrame) {
  const Eigen::Vector3d gravity = tiltedGravity();
  const GravityFrame frame(gravity * 9.81);  // the magnitude does not matter
  EXPECT_LT((frame.up + gravity).norm(), 1e-12);
  EXPECT_NEAR(frame.x_h.norm(), 1.0, 1e-12);
  EXPECT_NEAR(frame.y_h.norm(), 1.0, 1e-12);
  EXPECT_NEAR(frame.up.norm(), 1.0, 1e-12);
  EXPECT_NEAR(frame.x_h.dot(frame.up), 0.0, 1e-12);
  EXPECT_NEAR(frame.y_h.dot(frame.up), 0.0, 1e-12);
  EXPECT_NEAR(frame.x_h.dot(frame.y_h), 0.0, 1e-12);
  EXPECT_LT((frame.up.cross(frame.x_h) - frame.y_h).norm(), 1e-12);
  // x_h is world X made horizontal: here world X is already horizontal.
  EXPECT_LT((frame.x_h - Eigen::Vector3d::UnitX()).norm(), 1e-12);
}

TEST(GravityFrameTest, FallsBackToWorldYWhenWorldXIsVertical) {
  const GravityFrame frame(Eigen::Vector3d(-1.0, 0.0, 0.0));
  EXPECT_LT((frame.up - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_NEAR(frame.x_h.norm(), 1.0, 1e-12);
  EXPECT_NEAR(frame.x_h.dot(frame.up), 0.0, 1e-12);
  EXPECT_NEAR(frame.y_h.dot(frame.up), 0.0, 1e-12);
  EXPECT_NEAR(frame.x_h.dot(frame.y_h), 0.0, 1e-12);
}

TEST(GravityFrameTest, InvalidGravityMeansZUp) {
  for (const Eigen::Vector3d& gravity :
       {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(std::nan(""), 0.0, -1.0),
        Eigen::Vector3d(0.0, std::numeric_limits<double>::infinity(), 0.0)}) {
    const GravityFrame frame(gravity);
    EXPECT_LT((frame.up - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
    EXPECT_TRUE(frame.x_h.allFinite());
    EXPECT_TRUE(frame.y_h.allFinite());
  }
}

TEST(GravityFrameTest, RotationFromYawRoundTripsThroughYawOf) {
  const GravityFrame frame(tiltedGravity());
  for (double yaw = -3.1; yaw < 3.14; yaw += 0.37) {
    const Eigen::Matrix3d R = frame.rotationFromYaw(yaw);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-12) << yaw;
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12) << yaw;
    EXPECT_LT((R.col(2) - frame.up).norm(), 1e-12) << yaw;
    EXPECT_NEAR(frame.yawOf(R.col(0)), yaw, 1e-12) << yaw;
    EXPECT_NEAR(frame.yawOf(R.col(1)), std::remainder(yaw + M_PI / 2.0, 2.0 * M_PI), 1e-12) << yaw;
    // The vertical part of the direction is ignored, and so is its length.
    EXPECT_NEAR(frame.yawOf(2.5 * R.col(0) - 3.0 * frame.up), yaw, 1e-12) << yaw;
  }
  EXPECT_NEAR(frame.yawOf(frame.x_h), 0.0, 1e-12);
  EXPECT_NEAR(frame.yawOf(frame.y_h), M_PI / 2.0, 1e-12);
}

TEST(PolygonIntersectionTest, AxisAlignedSquares) {
  const std::vector<Eigen::Vector2d> unit = square(0.5, Eigen::Vector2d(0.0, 0.0));
  EXPECT_NEAR(convexPolygonIntersectionArea(unit, unit), 1.0, 1e-12);
  // Half overlap.
  const std::vector<Eigen::Vector2d> shifted = square(0.5, Eigen::Vector2d(0.5, 0.0));
  EXPECT_NEAR(convexPolygonIntersectionArea(unit, shifted), 0.5, 1e-12);
  EXPECT_NEAR(convexPolygonIntersectionArea(shifted, unit), 0.5, 1e-12);
  // Quarter overlap.
  const std::vector<Eigen::Vector2d> diagonal = square(0.5, Eigen::Vector2d(0.5, 0.5));
  EXPECT_NEAR(convexPolygonIntersectionArea(unit, diagonal), 0.25, 1e-12);
  // None.
  const std::vector<Eigen::Vector2d> far = square(0.5, Eigen::Vector2d(3.0, 0.2));
  EXPECT_NEAR(convexPolygonIntersectionArea(unit, far), 0.0, 1e-12);
  // Contained, either way round.
  const std::vector<Eigen::Vector2d> small = square(0.2, Eigen::Vector2d(0.1, -0.2));
  EXPECT_NEAR(convexPolygonIntersectionArea(unit, small), 0.16, 1e-12);
  EXPECT_NEAR(convexPolygonIntersectionArea(small, unit), 0.16, 1e-12);
}

TEST(PolygonIntersectionTest, RotatedSquareInSquareMatchesTheAnalyticArea) {
  const std::vector<Eigen::Vector2d> big = square(1.0, Eigen::Vector2d(0.0, 0.0));  // area 4
  for (const double r : {0.8, 1.2, 1.5, 1.9}) {
    // A square rotated by 45 degrees: vertices at distance r on the axes (area 2 r^2). Beyond
    // x = 1 each vertex pokes out as a triangle of area (r - 1)^2.
    const std::vector<Eigen::Vector2d> diamond = {Eigen::Vector2d(r, 0.0), Eigen::Vector2d(0.0, r),
                                                  Eigen::Vector2d(-r, 0.0),
                                                  Eigen::Vector2d(0.0, -r)};
    const double outside = r > 1.0 ? 4.0 * (r - 1.0) * (r - 1.0) : 0.0;
    const double expected = 2.0 * r * r - outside;
    EXPECT_NEAR(convexPolygonIntersectionArea(big, diamond), expected, 1e-12) << r;
    EXPECT_NEAR(convexPolygonIntersectionArea(diamond, big), expected, 1e-12) << r;
  }
}

TEST(PolygonIntersectionTest, DegeneratePolygonsHaveNoArea) {
  const std::vector<Eigen::Vector2d> unit = square(0.5, Eigen::Vector2d(0.0, 0.0));
  EXPECT_EQ(convexPolygonIntersectionArea(unit, {}), 0.0);
  EXPECT_EQ(convexPolygonIntersectionArea({Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0)}, unit),
            0.0);
}

TEST(IntersectionVolumeTest, YawRotatedBoxesMatchMonteCarlo) {
  const GravityFrame frame(tiltedGravity());
  const Eigen::Vector3d origin(0.3, -1.0, 2.0);
  const OrientedBox a = makeBox(frame, origin, Eigen::Vector3d(1.0, 0.6, 0.8), 0.3);
  const OrientedBox b = makeBox(frame, origin + 0.35 * frame.x_h + 0.1 * frame.y_h + 0.2 * frame.up,
                                Eigen::Vector3d(0.7, 0.5, 0.6), 1.1);
  const double exact = gravityAlignedIntersectionVolume(a, b, frame.up);
  const double estimate = monteCarloIntersection(a, b, 400000, 7);
  ASSERT_GT(estimate, 0.1 * b.volume()) << "the boxes are meant to overlap partly";
  ASSERT_LT(estimate, 0.9 * b.volume()) << "the boxes are meant to overlap partly";
  EXPECT_NEAR(exact, estimate, 0.02 * estimate);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(b, a, frame.up), exact, 1e-12);

  // The same with another yaw and offset, estimated from samples in a.
  const OrientedBox c = makeBox(frame, origin - 0.4 * frame.y_h - 0.3 * frame.up,
                                Eigen::Vector3d(1.2, 0.4, 0.5), -0.8);
  const double exact_ac = gravityAlignedIntersectionVolume(a, c, frame.up);
  const double estimate_ac = monteCarloIntersection(c, a, 400000, 11);
  ASSERT_GT(estimate_ac, 0.02 * a.volume());
  EXPECT_NEAR(exact_ac, estimate_ac, 0.03 * estimate_ac);
}

TEST(IntersectionVolumeTest, ContainedAndIdenticalBoxes) {
  const GravityFrame frame(tiltedGravity());
  const OrientedBox a =
      makeBox(frame, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(1.0, 0.8, 0.9), 0.4);
  const OrientedBox inner = makeBox(frame, a.center_m + 0.1 * frame.x_h - 0.1 * frame.up,
                                    Eigen::Vector3d(0.3, 0.2, 0.4), -1.0);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(a, inner, frame.up), inner.volume(), 1e-12);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(inner, a, frame.up), inner.volume(), 1e-12);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(a, a, frame.up), a.volume(), 1e-12);
  // A quarter turn of yaw swaps the footprint's axes of a square-footprint box: the same box.
  OrientedBox turned = a;
  turned.size_m = Eigen::Vector3d(0.8, 0.8, 0.9);
  OrientedBox square_box = turned;
  turned.rotation = frame.rotationFromYaw(0.4 + M_PI / 2.0);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(square_box, turned, frame.up), square_box.volume(),
              1e-12);
}

TEST(IntersectionVolumeTest, DisjointBoxesHaveNoIntersection) {
  const GravityFrame frame(tiltedGravity());
  const OrientedBox a =
      makeBox(frame, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1.0, 1.0, 0.8), 0.2);
  // Same footprint, disjoint vertical extents (one just above the other, and touching).
  const OrientedBox above = makeBox(frame, 0.81 * frame.up, Eigen::Vector3d(1.0, 1.0, 0.8), 0.2);
  const OrientedBox touching = makeBox(frame, 0.8 * frame.up, Eigen::Vector3d(1.0, 1.0, 0.8), 0.2);
  const OrientedBox below = makeBox(frame, -1.5 * frame.up, Eigen::Vector3d(0.5, 0.5, 0.5), 1.0);
  EXPECT_EQ(gravityAlignedIntersectionVolume(a, above, frame.up), 0.0);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(a, touching, frame.up), 0.0, 1e-12);
  EXPECT_EQ(gravityAlignedIntersectionVolume(below, a, frame.up), 0.0);
  // Same height, footprints apart.
  const OrientedBox beside = makeBox(frame, 1.2 * frame.x_h, Eigen::Vector3d(1.0, 1.0, 0.8), 0.0);
  EXPECT_EQ(gravityAlignedIntersectionVolume(a, beside, frame.up), 0.0);
  // Overlapping in height only a little: the volume is the footprint overlap times that.
  const OrientedBox shifted = makeBox(frame, 0.7 * frame.up, Eigen::Vector3d(1.0, 1.0, 0.8), 0.2);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(a, shifted, frame.up), 1.0 * 0.1, 1e-12);
}

TEST(IntersectionVolumeTest, BadBoxesGiveZeroNotACrash) {
  const GravityFrame frame(tiltedGravity());
  const OrientedBox a =
      makeBox(frame, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1.0, 1.0, 1.0), 0.2);
  OrientedBox nan_center = a;
  nan_center.center_m.x() = std::nan("");
  OrientedBox nan_size = a;
  nan_size.size_m.y() = std::nan("");
  OrientedBox flat = a;
  flat.size_m.z() = 0.0;
  OrientedBox point = a;
  point.size_m.setZero();
  EXPECT_EQ(gravityAlignedIntersectionVolume(a, nan_center, frame.up), 0.0);
  EXPECT_EQ(gravityAlignedIntersectionVolume(nan_size, a, frame.up), 0.0);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(a, flat, frame.up), 0.0, 1e-12);
  EXPECT_NEAR(gravityAlignedIntersectionVolume(point, a, frame.up), 0.0, 1e-12);
  EXPECT_EQ(gravityAlignedIntersectionVolume(a, a, Eigen::Vector3d(std::nan(""), 0, 1)), 0.0);
}

}  // namespace
}  // namespace mvod

namespace mvod {
namespace {

TEST(MinimumAreaRectangleTest, RecoversARotatedRectangle) {
  const double yaw = 0.6;
  const Eigen::Vector2d u(std::cos(yaw), std::sin(yaw));
  const Eigen::Vector2d v(-u.y(), u.x());
  const Eigen::Vector2d center(1.5, -2.0);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 10; ++j) {
      points.push_back(center + (-0.4 + 0.04 * i) * u + (-0.15 + 0.03 * j) * v);
    }
  }
  const Rectangle2d rectangle = minimumAreaRectangle(points);
  const Eigen::Vector2d size = rectangle.size;
  // The first side may be either edge direction: compare sorted sizes and the axis modulo 90 deg.
  EXPECT_NEAR(std::max(size.x(), size.y()), 0.8, 1e-9);
  EXPECT_NEAR(std::min(size.x(), size.y()), 0.3, 1e-9);
  EXPECT_NEAR(std::abs(std::sin(2.0 * (rectangle.yaw_rad - yaw))), 0.0, 1e-9);
  EXPECT_LT((rectangle.center - center).norm(), 1e-9);
  EXPECT_EQ(minimumAreaRectangle({}).size, Eigen::Vector2d::Zero());
}

TEST(NearestRotationTest, SnapsANearlyOrthonormalMatrix) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  Eigen::Matrix3d noisy = R;
  noisy(0, 1) += 2e-3;
  noisy(2, 0) -= 1e-3;
  const Eigen::Matrix3d snapped = nearestRotation(noisy);
  EXPECT_TRUE((snapped.transpose() * snapped).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_NEAR(snapped.determinant(), 1.0, 1e-12);
  EXPECT_LT((snapped - R).norm(), 3e-3);
  // A reflection becomes a proper rotation.
  EXPECT_NEAR(nearestRotation(-Eigen::Matrix3d::Identity()).determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace mvod
