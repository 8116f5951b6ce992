#include "multiview_object_detection/pipeline/types/oriented_box.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mvod {

std::vector<Eigen::Vector3d> OrientedBox::corners() const {
  std::vector<Eigen::Vector3d> result;
  result.reserve(8);
  const Eigen::Vector3d half = 0.5 * size_m;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d sign((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
    result.push_back(center_m + rotation * sign.cwiseProduct(half));
  }
  return result;
}

bool OrientedBox::contains(const Eigen::Vector3d& p_W, double margin_m) const {
  const Eigen::Vector3d local = rotation.transpose() * (p_W - center_m);
  for (int i = 0; i < 3; ++i) {
    // Written so that a NaN anywhere means "not inside".
    if (!(std::abs(local[i]) <= 0.5 * size_m[i] + margin_m)) return false;
  }
  return true;
}

GravityFrame::GravityFrame(const Eigen::Vector3d& gravity_down_W) {
  const double norm = gravity_down_W.norm();
  up = (norm > 1e-12 && gravity_down_W.allFinite()) ? Eigen::Vector3d(-gravity_down_W / norm)
                                                    : Eigen::Vector3d::UnitZ();
  // World X projected on the horizontal plane, or world Y when X is (nearly) vertical.
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - up.x() * up;
  if (x.norm() < 0.1) x = Eigen::Vector3d::UnitY() - up.y() * up;
  x_h = x.normalized();
  y_h = up.cross(x_h);
}

Eigen::Matrix3d GravityFrame::rotationFromYaw(double yaw_rad) const {
  const double c = std::cos(yaw_rad);
  const double s = std::sin(yaw_rad);
  Eigen::Matrix3d R;
  R.col(0) = c * x_h + s * y_h;
  R.col(1) = -s * x_h + c * y_h;
  R.col(2) = up;
  return R;
}

double GravityFrame::yawOf(const Eigen::Vector3d& direction_W) const {
  return std::atan2(direction_W.dot(y_h), direction_W.dot(x_h));
}

namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

double polygonArea(const std::vector<Eigen::Vector2d>& polygon) {
  double twice = 0.0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    twice += cross2(polygon[i], polygon[(i + 1) % polygon.size()]);
  }
  return 0.5 * twice;
}

}  // namespace

std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross2(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross2(hull[k - 1] - hull[k - 2], points[i - 1] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = points[i - 1];
  }
  hull.resize(k - 1);
  return hull;
}

Rectangle2d minimumAreaRectangle(const std::vector<Eigen::Vector2d>& points) {
  const std::vector<Eigen::Vector2d> hull = convexHull(points);
  std::vector<double> yaws = {0.0};
  for (size_t i = 0; hull.size() >= 2 && i < hull.size(); ++i) {
    const Eigen::Vector2d edge = hull[(i + 1) % hull.size()] - hull[i];
    if (edge.norm() > 1e-12) yaws.push_back(std::atan2(edge.y(), edge.x()));
  }
  Rectangle2d best;
  double best_area = std::numeric_limits<double>::infinity();
  for (const double yaw : yaws) {
    const Rectangle2d rectangle = rectangleAtYaw(hull, yaw);
    if (rectangle.area() < best_area - 1e-12) {
      best_area = rectangle.area();
      best = rectangle;
    }
  }
  return best;
}

Rectangle2d rectangleAtYaw(const std::vector<Eigen::Vector2d>& points, double yaw_rad) {
  const Eigen::Vector2d u(std::cos(yaw_rad), std::sin(yaw_rad));
  const Eigen::Vector2d v(-u.y(), u.x());
  double min_u = std::numeric_limits<double>::infinity(), max_u = -min_u;
  double min_v = min_u, max_v = -min_u;
  for (const Eigen::Vector2d& q : points) {
    min_u = std::min(min_u, q.dot(u));
    max_u = std::max(max_u, q.dot(u));
    min_v = std::min(min_v, q.dot(v));
    max_v = std::max(max_v, q.dot(v));
  }
  Rectangle2d rectangle;
  rectangle.yaw_rad = yaw_rad;
  rectangle.center = 0.5 * (min_u + max_u) * u + 0.5 * (min_v + max_v) * v;
  rectangle.size = Eigen::Vector2d(max_u - min_u, max_v - min_v);
  return rectangle;
}

double convexPolygonIntersectionArea(const std::vector<Eigen::Vector2d>& a,
                                     const std::vector<Eigen::Vector2d>& b) {
  if (a.size() < 3 || b.size() < 3) return 0.0;
  // Sutherland-Hodgman: clip `a` by each (counter-clockwise) edge of `b`.
  std::vector<Eigen::Vector2d> output = a;
  for (size_t e = 0; e < b.size() && !output.empty(); ++e) {
    const Eigen::Vector2d& p = b[e];
    const Eigen::Vector2d edge = b[(e + 1) % b.size()] - p;
    const std::vector<Eigen::Vector2d> input = std::move(output);
    output.clear();
    for (size_t i = 0; i < input.size(); ++i) {
      const Eigen::Vector2d& current = input[i];
      const Eigen::Vector2d& previous = input[(i + input.size() - 1) % input.size()];
      const double side_current = cross2(edge, current - p);
      const double side_previous = cross2(edge, previous - p);
      if (side_current >= 0.0) {
        if (side_previous < 0.0) {
          const double t = side_previous / (side_previous - side_current);
          output.push_back(previous + t * (current - previous));
        }
        output.push_back(current);
      } else if (side_previous >= 0.0) {
        const double t = side_previous / (side_previous - side_current);
        output.push_back(previous + t * (current - previous));
      }
    }
  }
  return output.size() < 3 ? 0.0 : std::abs(polygonArea(output));
}

double gravityAlignedIntersectionVolume(const OrientedBox& a, const OrientedBox& b,
                                        const Eigen::Vector3d& up) {
  // Non-finite input has no meaningful answer, and NaN corners would break the hull's sort.
  auto finite = [](const OrientedBox& box) {
    return box.center_m.allFinite() && box.size_m.allFinite() && box.rotation.allFinite();
  };
  if (!finite(a) || !finite(b) || !up.allFinite()) return 0.0;
  const GravityFrame frame(-up);
  // Footprint: the convex hull of the corners projected on the floor plane (exactly the box's
  // rectangle when its third column is `up`); vertical extent: the corners' range along `up`.
  auto footprint = [&frame](const OrientedBox& box, double* low, double* high) {
    std::vector<Eigen::Vector2d> points;
    *low = std::numeric_limits<double>::infinity();
    *high = -std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& corner : box.corners()) {
      points.emplace_back(corner.dot(frame.x_h), corner.dot(frame.y_h));
      const double h = corner.dot(frame.up);
      *low = std::min(*low, h);
      *high = std::max(*high, h);
    }
    return convexHull(points);
  };
  double a_low, a_high, b_low, b_high;
  const std::vector<Eigen::Vector2d> fa = footprint(a, &a_low, &a_high);
  const std::vector<Eigen::Vector2d> fb = footprint(b, &b_low, &b_high);
  const double overlap = std::min(a_high, b_high) - std::max(a_low, b_low);
  if (!(overlap > 0.0)) return 0.0;
  return convexPolygonIntersectionArea(fa, fb) * overlap;
}

}  // namespace mvod
