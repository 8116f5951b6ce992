// Gravity-aligned oriented 3D boxes (Sec. 3.3) and the exact intersection volume the intersection
// filter (Eq. 10, 11) needs.
#pragma once

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// A box in the world frame. rotation's columns are the box axes in world coordinates; size_m[i] is
// the full extent along column i. For boxes made by BoxEstimator, column 2 is "up" (minus gravity),
// so the box is gravity-aligned and only its yaw about the vertical is free.
struct OrientedBox {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();

  double volume() const { return size_m.x() * size_m.y() * size_m.z(); }
  // The 8 corners in world coordinates; corner i has sign bits (x: i&1, y: i&2, z: i&4).
  std::vector<Eigen::Vector3d> corners() const;
  bool contains(const Eigen::Vector3d& p_W, double margin_m = 0.0) const;
};

// The gravity frame of the world: up = -gravity (unit), and a horizontal reference axis x_h (world
// X projected on the horizontal plane, or world Y when X is near vertical). Yaw is measured from
// x_h about up.
struct GravityFrame {
  explicit GravityFrame(const Eigen::Vector3d& gravity_down_W = Eigen::Vector3d(0, 0, -1));
  Eigen::Vector3d up;
  Eigen::Vector3d x_h;
  Eigen::Vector3d y_h;  // up x x_h
  // Rotation whose columns are (cos(yaw) x_h + sin(yaw) y_h, -sin(yaw) x_h + cos(yaw) y_h, up).
  Eigen::Matrix3d rotationFromYaw(double yaw_rad) const;
  // Yaw of a horizontal direction (its vertical part is ignored).
  double yawOf(const Eigen::Vector3d& direction_W) const;
};

// Exact volume of the intersection of two boxes that share the vertical axis `up` as their third
// column: the area of the intersection of their two footprint rectangles in the floor plane (convex
// polygon clipping) times the overlap of their vertical extents. Returns 0 for disjoint boxes.
double gravityAlignedIntersectionVolume(const OrientedBox& a, const OrientedBox& b,
                                        const Eigen::Vector3d& up);

// Counter-clockwise convex hull of 2D points (Andrew's monotone chain); duplicates removed, fewer
// than three distinct points are returned as they are.
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points);

// The smallest-area rectangle around 2D points: one of its sides lies on a convex hull edge, so
// each edge direction is tried. yaw_rad is the direction of its first side (0 when the points have
// no extent); size is the extent along that side and the one perpendicular to it.
struct Rectangle2d {
  double yaw_rad = 0.0;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d size = Eigen::Vector2d::Zero();
  double area() const { return size.x() * size.y(); }
};
Rectangle2d minimumAreaRectangle(const std::vector<Eigen::Vector2d>& points);
// The rectangle around 2D points whose first side has direction yaw_rad (infinite area for no
// points).
Rectangle2d rectangleAtYaw(const std::vector<Eigen::Vector2d>& points, double yaw_rad);

// Area of the intersection of two convex polygons given counter-clockwise (Sutherland-Hodgman).
double convexPolygonIntersectionArea(const std::vector<Eigen::Vector2d>& a,
                                     const std::vector<Eigen::Vector2d>& b);

}  // namespace mvod
