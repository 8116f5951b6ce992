#include "multiview_object_detection/simulation/room_builder.h"

#include <algorithm>
#include <cmath>

#include "multiview_object_detection/simulation/furniture.h"
#include "multiview_object_detection/simulation/scene_geometry.h"

namespace mvod {
namespace simulation {
namespace {

// Horizontal (footprint) tests of gravity-aligned boxes.
struct Footprint {
  Eigen::Vector2d center;
  Eigen::Vector2d half;
  Eigen::Matrix2d R;  // columns: the box's x and y axes
};

Footprint footprintOf(const OrientedBox& box, double margin_m = 0.0) {
  return {box.center_m.head<2>(), 0.5 * box.size_m.head<2>() + Eigen::Vector2d::Constant(margin_m),
          box.rotation.topLeftCorner<2, 2>()};
}

// Separating axis test of two rectangles.
bool overlaps(const Footprint& a, const Footprint& b) {
  const Eigen::Vector2d d = b.center - a.center;
  for (const Footprint* f : {&a, &b}) {
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d axis = f->R.col(k);
      const double ra =
          a.half.x() * std::abs(a.R.col(0).dot(axis)) + a.half.y() * std::abs(a.R.col(1).dot(axis));
      const double rb =
          b.half.x() * std::abs(b.R.col(0).dot(axis)) + b.half.y() * std::abs(b.R.col(1).dot(axis));
      if (std::abs(d.dot(axis)) > ra + rb) return false;
    }
  }
  return true;
}

double distanceToFootprint(const Footprint& f, const Eigen::Vector2d& p) {
  const Eigen::Vector2d local = f.R.transpose() * (p - f.center);
  return std::hypot(std::max(0.0, std::abs(local.x()) - f.half.x()),
                    std::max(0.0, std::abs(local.y()) - f.half.y()));
}

}  // namespace

RoomBuilder::RoomBuilder(const SyntheticSceneConfig& config, uint64_t seed)
    : config_(config), rng_(seed) {
  const Eigen::Vector2d center(0.5 * config.room_size_x_m, 0.5 * config.room_size_y_m);
  const double rx = std::max(0.5, 0.5 * config.room_size_x_m - config.camera_loop_inset_m);
  const double ry = std::max(0.5, 0.5 * config.room_size_y_m - config.camera_loop_inset_m);
  for (int i = 0; i < 720; ++i) {
    const double a = 2.0 * kPi * i / 720.0;
    loop_.emplace_back(center.x() + rx * std::cos(a), center.y() + ry * std::sin(a));
  }
}

bool RoomBuilder::fits(const OrientedBox& box) const {
  const Footprint f = footprintOf(box);
  for (const Eigen::Vector3d& corner : box.corners()) {
    if (corner.x() < kWallGap || corner.y() < kWallGap ||
        corner.x() > config_.room_size_x_m - kWallGap ||
        corner.y() > config_.room_size_y_m - kWallGap) {
      return false;
    }
  }
  for (const Eigen::Vector2d& p : loop_) {
    if (distanceToFootprint(f, p) < kLoopClearance) return false;
  }
  const Footprint grown = footprintOf(box, 0.5 * kGap);
  for (const OrientedBox& other : floor_) {
    if (overlaps(grown, footprintOf(other, 0.5 * kGap))) return false;
  }
  return true;
}

void RoomBuilder::againstWall(int side, double x, double back_y, Eigen::Vector3d* origin,
                              double* yaw) {
  const double gap = 0.04;
  *yaw = (side == 0 ? 0.0 : kPi) + deg2rad(jitter(2.0));
  const double y = side == 0 ? gap - back_y : config_.room_size_y_m - gap + back_y;
  *origin = Eigen::Vector3d(x, y, 0.0);
}

void RoomBuilder::scatterOnTop(const Eigen::Vector3d& origin, double yaw,
                               const Eigen::Vector2d& half, double top_z, int cups, int books) {
  std::vector<OrientedBox> placed;
  const Eigen::Matrix3d R = yawRotation(yaw);
  for (int k = 0; k < cups + books; ++k) {
    const bool cup = k < cups;
    for (int attempt = 0; attempt < 30; ++attempt) {
      std::vector<LocalPart> parts;
      if (cup) {
        parts = cupParts();
      } else {
        const double bw = rng_.uniform(0.17, 0.24);
        const double bd = rng_.uniform(0.12, 0.17);
        const double bh = rng_.uniform(0.02, 0.045);
        parts = {part(-0.5 * bw, -0.5 * bd, 0.0, 0.5 * bw, 0.5 * bd, bh)};
      }
      const Eigen::Vector2d xy(rng_.uniform(-half.x() + 0.13, half.x() - 0.13),
                               rng_.uniform(-half.y() + 0.13, half.y() - 0.13));
      const double own_yaw = rng_.uniform(-kPi, kPi);
      const Eigen::Vector3d at = origin + R * Eigen::Vector3d(xy.x(), xy.y(), top_z);
      SyntheticObject object = assemble(cup ? "cup" : "book", at, yaw + own_yaw, parts);
      const Footprint f = footprintOf(object.box, 0.015);
      bool free = true;
      for (const OrientedBox& other : placed) {
        if (overlaps(f, footprintOf(other, 0.015))) free = false;
      }
      // Inside the top, 0.1 m from its edges.
      for (const Eigen::Vector3d& corner : object.box.corners()) {
        const Eigen::Vector3d local = R.transpose() * (corner - origin);
        if (std::abs(local.x()) > half.x() - 0.1 || std::abs(local.y()) > half.y() - 0.1) {
          free = false;
        }
      }
      if (!free) continue;
      placed.push_back(object.box);
      addSupported(std::move(object));
      break;
    }
  }
}

bool RoomBuilder::addBookshelf(int side, double x) {
  const double w = rng_.uniform(0.8, 1.1);
  const double d = 0.32;
  const double h = rng_.uniform(1.5, 1.9);
  const int levels = 4 + static_cast<int>(rng_.next() % 2);
  double spacing = 0.0;
  const std::vector<LocalPart> parts = shelfParts(w, d, h, levels, &spacing);
  Eigen::Vector3d origin;
  double yaw = 0.0;
  againstWall(side, x, -0.5 * d, &origin, &yaw);
  SyntheticObject shelf = assemble("shelf", origin, yaw, parts);
  if (!fits(shelf.box)) return false;
  addClutter(std::move(shelf));
  // Books: upright runs from the left side of some boards, at the back.
  int books = 0;
  for (int level = 0; level < levels; ++level) {
    if (rng_.uniform() < 0.35 && !(level == levels - 1 && books == 0)) continue;
    double cursor = -0.5 * w + 0.02 + rng_.uniform(0.01, 0.2);
    const int count = 2 + static_cast<int>(rng_.next() % 4);
    const double board_top = level * spacing + 0.02;
    for (int k = 0; k < count; ++k) {
      const double thickness = rng_.uniform(0.025, 0.05);
      const double height = rng_.uniform(0.18, std::min(0.3, spacing - 0.06));
      const double depth = rng_.uniform(0.15, 0.22);
      if (cursor + thickness > 0.5 * w - 0.025) break;
      const double back_y = -0.5 * d + 0.015;
      const std::vector<LocalPart> book = {
          part(cursor, back_y, board_top, cursor + thickness, back_y + depth, board_top + height)};
      // The book's own frame is the shelf's: assemble at the shelf origin.
      addSupported(assemble("book", origin, yaw, book));
      ++books;
      cursor += thickness + 0.004;
    }
  }
  return true;
}

bool RoomBuilder::addTvOnStand(int side, double x) {
  const double stand_w = rng_.uniform(1.2, 1.6);
  const double stand_d = rng_.uniform(0.34, 0.4);
  const double stand_h = rng_.uniform(0.42, 0.55);
  Eigen::Vector3d origin;
  double yaw = 0.0;
  againstWall(side, x, -0.5 * stand_d, &origin, &yaw);
  SyntheticObject stand =
      assemble("tv stand", origin, yaw,
               {part(-0.5 * stand_w, -0.5 * stand_d, 0.0, 0.5 * stand_w, 0.5 * stand_d, stand_h)});
  if (!fits(stand.box)) return false;
  const double tv_w = std::min(stand_w - 0.1, rng_.uniform(0.9, 1.25));
  const double tv_h = rng_.uniform(0.5, 0.7);
  const Eigen::Vector3d tv_origin =
      origin + yawRotation(yaw) * Eigen::Vector3d(jitter(0.05), -0.05, stand_h);
  addClutter(std::move(stand));
  addSupported(assemble("tv", tv_origin, yaw, tvParts(tv_w, tv_h)));
  return true;
}

}  // namespace simulation
}  // namespace mvod
