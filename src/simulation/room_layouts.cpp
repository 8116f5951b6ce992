// The rooms of SyntheticScene: the default scene (makeDefault) and the furnished living room,
// bedroom, dining room and close-up room of makeRoom, deterministic for the config's seed.
#include <algorithm>
#include <cmath>

#include "multiview_object_detection/simulation/furniture.h"
#include "multiview_object_detection/simulation/room_builder.h"
#include "multiview_object_detection/simulation/scene_geometry.h"
#include "multiview_object_detection/simulation/split_mix.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {

using simulation::assemble;
using simulation::bedParts;
using simulation::couchParts;
using simulation::deg2rad;
using simulation::fridgeParts;
using simulation::makeChair;
using simulation::part;
using simulation::Rng;
using simulation::RoomBuilder;
using simulation::tableParts;
using simulation::yawRotation;

namespace {

OrientedBox makeBox(const Eigen::Vector2d& center_xy, double bottom_z_m,
                    const Eigen::Vector3d& size_m, double yaw_rad) {
  OrientedBox box;
  box.center_m = Eigen::Vector3d(center_xy.x(), center_xy.y(), bottom_z_m + 0.5 * size_m.z());
  box.size_m = size_m;
  box.rotation = yawRotation(yaw_rad);
  return box;
}

// A chair at a random pose in the free floor.
bool addFreeChair(RoomBuilder* room) {
  return room->place(150, [room]() {
    const Eigen::Vector2d c = room->center();
    const Eigen::Vector3d origin(c.x() + room->jitter(2.0), c.y() + room->jitter(1.6), 0.0);
    return makeChair(room->rng(), origin, room->rng().uniform(-kPi, kPi));
  });
}

void buildLivingRoom(RoomBuilder* room) {
  Rng& rng = room->rng();
  const Eigen::Vector2d c = room->center();
  const int tv_side = static_cast<int>(rng.next() % 2);
  for (int attempt = 0; attempt < 40; ++attempt) {
    if (room->addTvOnStand(tv_side, c.x() + room->jitter(0.6))) break;
  }
  // The couch faces the tv, set back from the room centre.
  room->place(200, [&]() {
    const double w = rng.uniform(1.7, 2.1);
    const double d = rng.uniform(0.85, 0.95);
    const double away = tv_side == 0 ? 1.0 : -1.0;
    const Eigen::Vector3d origin(c.x() + room->jitter(0.4), c.y() + away * rng.uniform(0.0, 0.4),
                                 0.0);
    const double yaw = (tv_side == 0 ? kPi : 0.0) + deg2rad(room->jitter(15.0));
    return assemble("couch", origin, yaw, couchParts(w, d, rng.uniform(0.8, 0.9)));
  });
  for (int attempt = 0; attempt < 40; ++attempt) {
    if (room->addBookshelf(1 - tv_side, c.x() + room->jitter(1.0))) break;
  }
  const int chairs = 1 + static_cast<int>(rng.next() % 2);
  for (int k = 0; k < chairs; ++k) addFreeChair(room);
  // A side table with a cup or a book on it.
  for (int attempt = 0; attempt < 150; ++attempt) {
    const double w = rng.uniform(0.45, 0.6);
    const double h = rng.uniform(0.5, 0.6);
    const Eigen::Vector3d origin(c.x() + room->jitter(2.0), c.y() + room->jitter(1.6), 0.0);
    const double yaw = rng.uniform(-kPi, kPi);
    SyntheticObject table =
        assemble("side table", origin, yaw, {part(-0.5 * w, -0.5 * w, 0.0, 0.5 * w, 0.5 * w, h)});
    if (!room->fits(table.box)) continue;
    room->addClutter(std::move(table));
    const bool cup = rng.uniform() < 0.6;
    room->scatterOnTop(origin, yaw, Eigen::Vector2d(0.5 * w, 0.5 * w), h, cup ? 1 : 0, cup ? 0 : 1);
    break;
  }
}

void buildBedroom(RoomBuilder* room) {
  Rng& rng = room->rng();
  const Eigen::Vector2d c = room->center();
  // The bed stands free, its length along the room's long side.
  double bed_w = 0.0, bed_l = 0.0, bed_yaw = 0.0;
  Eigen::Vector3d bed_origin;
  room->place(200, [&]() {
    bed_w = rng.uniform(1.3, 1.6);
    bed_l = rng.uniform(1.95, 2.1);
    bed_yaw = (rng.uniform() < 0.5 ? 0.5 : -0.5) * kPi + deg2rad(room->jitter(15.0));
    bed_origin = Eigen::Vector3d(c.x() + room->jitter(0.3), c.y() + room->jitter(0.2), 0.0);
    return assemble("bed", bed_origin, bed_yaw, bedParts(bed_w, bed_l));
  });
  // A night stand beside the headboard, with a book and maybe a cup.
  for (const double side : {1.0, -1.0}) {
    const double w = 0.45;
    const double h = rng.uniform(0.5, 0.6);
    const Eigen::Vector3d origin =
        bed_origin + yawRotation(bed_yaw) * Eigen::Vector3d(side * (0.5 * bed_w + 0.1 + 0.5 * w),
                                                            -0.5 * bed_l + 0.05 + 0.5 * w, 0.0);
    SyntheticObject stand = assemble("night stand", origin, bed_yaw,
                                     {part(-0.5 * w, -0.5 * w, 0.0, 0.5 * w, 0.5 * w, h)});
    if (!room->fits(stand.box)) continue;
    room->addClutter(std::move(stand));
    room->scatterOnTop(origin, bed_yaw, Eigen::Vector2d(0.5 * w, 0.5 * w), h,
                       rng.uniform() < 0.5 ? 1 : 0, 1);
    break;
  }
  const int shelf_side = static_cast<int>(rng.next() % 2);
  for (int attempt = 0; attempt < 40; ++attempt) {
    if (room->addBookshelf(shelf_side, c.x() + room->jitter(1.2))) break;
  }
  if (rng.uniform() < 0.6) {
    for (int attempt = 0; attempt < 40; ++attempt) {
      if (room->addTvOnStand(1 - shelf_side, c.x() + room->jitter(1.0))) break;
    }
  }
  if (rng.uniform() < 0.7) addFreeChair(room);
}

void buildDiningRoom(RoomBuilder* room) {
  Rng& rng = room->rng();
  const Eigen::Vector2d c = room->center();
  double table_w = 0.0, table_d = 0.0, table_h = 0.0, table_yaw = 0.0;
  Eigen::Vector3d table_origin;
  const bool have_table = room->place(200, [&]() {
    table_w = rng.uniform(1.4, 1.8);
    table_d = rng.uniform(0.8, 1.0);
    table_h = rng.uniform(0.72, 0.76);
    table_yaw = deg2rad(room->jitter(30.0));
    table_origin = Eigen::Vector3d(c.x() + room->jitter(0.25), c.y() + room->jitter(0.15), 0.0);
    return assemble("dining table", table_origin, table_yaw, tableParts(table_w, table_d, table_h));
  });
  if (have_table) {
    const Eigen::Matrix3d R = yawRotation(table_yaw);
    // Two chairs on each long side, facing the table; one at each end now and then.
    struct Slot {
      double x, y, yaw;
    };
    std::vector<Slot> slots;
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        slots.push_back({sx * 0.25 * table_w, sy * (0.5 * table_d + 0.38), sy < 0 ? 0.0 : kPi});
      }
    }
    for (const double sx : {-1.0, 1.0}) {
      if (rng.uniform() < 0.35) {
        slots.push_back({sx * (0.5 * table_w + 0.38), 0.0, sx < 0 ? -0.5 * kPi : 0.5 * kPi});
      }
    }
    for (const Slot& slot : slots) {
      room->place(10, [&]() {
        const double pull = rng.uniform(0.0, 0.12);
        const Eigen::Vector2d out = Eigen::Vector2d(slot.x, slot.y).normalized();
        const Eigen::Vector3d local(slot.x + pull * out.x() + room->jitter(0.04),
                                    slot.y + pull * out.y() + room->jitter(0.04), 0.0);
        return makeChair(rng, table_origin + R * local,
                         table_yaw + slot.yaw + deg2rad(room->jitter(12.0)));
      });
    }
    room->scatterOnTop(table_origin, table_yaw, Eigen::Vector2d(0.5 * table_w, 0.5 * table_d),
                       table_h, 1 + static_cast<int>(rng.next() % 3),
                       static_cast<int>(rng.next() % 3));
  }
  const int wall = static_cast<int>(rng.next() % 2);
  for (int attempt = 0; attempt < 60; ++attempt) {
    const double w = rng.uniform(0.6, 0.75);
    const double d = rng.uniform(0.62, 0.72);
    const double h = rng.uniform(1.7, 1.9);
    Eigen::Vector3d origin;
    double yaw = 0.0;
    const double x = c.x() + (rng.uniform() < 0.5 ? -1.0 : 1.0) * rng.uniform(0.8, 1.8);
    room->againstWall(wall, x, -0.5 * d, &origin, &yaw);
    SyntheticObject fridge = assemble("refrigerator", origin, yaw, fridgeParts(w, d, h));
    if (!room->fits(fridge.box)) continue;
    room->addObject(std::move(fridge));
    break;
  }
  for (int attempt = 0; attempt < 40; ++attempt) {
    const bool added = rng.uniform() < 0.6
                           ? room->addBookshelf(1 - wall, c.x() + room->jitter(1.0))
                           : room->addTvOnStand(1 - wall, c.x() + room->jitter(1.0));
    if (added) break;
  }
}

// Big furniture in the middle of a small room, the camera loop close around it: a couch, a table
// with cups and books on it and a chair at each of its ends. Seen from about 1 m on the near side,
// the furniture fills most of the view (issue 32's workload).
void buildCloseRoom(RoomBuilder* room) {
  Rng& rng = room->rng();
  const Eigen::Vector2d c = room->center();
  const double side = rng.uniform() < 0.5 ? 1.0 : -1.0;  // which half the couch takes
  room->place(200, [&]() {
    const Eigen::Vector3d origin(c.x() + room->jitter(0.25), c.y() - side * rng.uniform(0.5, 0.6),
                                 0.0);
    const double yaw = (side > 0 ? kPi : 0.0) + deg2rad(room->jitter(10.0));
    return assemble(
        "couch", origin, yaw,
        couchParts(rng.uniform(1.6, 1.9), rng.uniform(0.85, 0.95), rng.uniform(0.8, 0.9)));
  });
  double table_w = 0.0, table_d = 0.0, table_h = 0.0, table_yaw = 0.0;
  Eigen::Vector3d table_origin;
  const bool have_table = room->place(200, [&]() {
    table_w = rng.uniform(1.2, 1.4);
    table_d = rng.uniform(0.7, 0.8);
    table_h = rng.uniform(0.72, 0.76);
    table_yaw = deg2rad(room->jitter(12.0));
    table_origin =
        Eigen::Vector3d(c.x() + room->jitter(0.2), c.y() + side * rng.uniform(0.5, 0.6), 0.0);
    return assemble("dining table", table_origin, table_yaw, tableParts(table_w, table_d, table_h));
  });
  if (have_table) {
    const Eigen::Matrix3d R = yawRotation(table_yaw);
    for (const double sx : {-1.0, 1.0}) {
      room->place(10, [&]() {
        const Eigen::Vector3d local(sx * (0.5 * table_w + 0.36 + rng.uniform(0.0, 0.08)),
                                    room->jitter(0.05), 0.0);
        return makeChair(rng, table_origin + R * local,
                         table_yaw + (sx < 0 ? -0.5 : 0.5) * kPi + deg2rad(room->jitter(12.0)));
      });
    }
    room->scatterOnTop(table_origin, table_yaw, Eigen::Vector2d(0.5 * table_w, 0.5 * table_d),
                       table_h, 1 + static_cast<int>(rng.next() % 2), 2);
  }
}

}  // namespace

RoomType roomTypeFromSeed(unsigned int seed) {
  Rng rng(mixSeed(seed, 0x7001));
  return static_cast<RoomType>(rng.next() % 3);
}

const char* roomTypeName(RoomType type) {
  switch (type) {
    case RoomType::kLivingRoom:
      return "living";
    case RoomType::kBedroom:
      return "bedroom";
    case RoomType::kDiningRoom:
      return "dining";
    case RoomType::kCloseUp:
      return "close";
  }
  return "?";
}

SyntheticScene SyntheticScene::makeRoom(const SyntheticSceneConfig& base, RoomType type) {
  SyntheticSceneConfig config = base;
  const uint64_t type_salt = static_cast<uint64_t>(type);
  Rng rng(mixSeed(base.seed, 0x400d0 + type_salt));
  // Rooms small enough that the far wall is within the sensor's range from the loop.
  Eigen::Vector4d size_range(5.0, 6.0, 4.4, 5.2);  // x_lo, x_hi, y_lo, y_hi (living room)
  switch (type) {
    case RoomType::kLivingRoom:
      break;
    case RoomType::kBedroom:
      size_range << 5.4, 6.4, 4.6, 5.4;
      break;
    case RoomType::kDiningRoom:
      size_range << 5.2, 6.2, 4.6, 5.4;
      break;
    case RoomType::kCloseUp:
      size_range << 4.6, 5.0, 4.0, 4.4;
      break;
  }
  config.room_size_x_m = rng.uniform(size_range[0], size_range[1]);
  config.room_size_y_m = rng.uniform(size_range[2], size_range[3]);
  config.room_height_m = rng.uniform(2.5, 2.8);
  config.camera_height_m = rng.uniform(1.0, 1.3);
  config.camera_pitch_deg = -rng.uniform(12.0, 18.0);
  config.camera_loop_inset_m = 0.8;
  if (type == RoomType::kCloseUp) {
    // The loop close to the walls, so the camera passes about 1 m from the furniture.
    config.camera_loop_inset_m = 0.4;
    config.camera_pitch_deg = -rng.uniform(20.0, 25.0);
  }
  config.camera_wobble = true;

  RoomBuilder room(config, mixSeed(base.seed, 0xf00d0 + type_salt));
  switch (type) {
    case RoomType::kLivingRoom:
      buildLivingRoom(&room);
      break;
    case RoomType::kBedroom:
      buildBedroom(&room);
      break;
    case RoomType::kDiningRoom:
      buildDiningRoom(&room);
      break;
    case RoomType::kCloseUp:
      buildCloseRoom(&room);
      break;
  }
  return SyntheticScene(config, std::move(room.objects()), std::move(room.clutter()));
}

SyntheticScene SyntheticScene::makeDefault(const SyntheticSceneConfig& config) {
  // Small seed-dependent variations; seed 1 gives the same scene on every run.
  Rng rng(mixSeed(config.seed, 0x5ce7e));
  auto jitter = [&rng](double amplitude) { return rng.uniform(-amplitude, amplitude); };

  const double room_x = config.room_size_x_m;
  const double room_y = config.room_size_y_m;
  const Eigen::Vector2d room_center(0.5 * room_x, 0.5 * room_y);
  std::vector<SyntheticObject> objects;

  // The dining group left of the room centre: table yawed ~15 deg, two chairs on each long side,
  // each >= 0.15 m from the table and from each other so the boxes never touch.
  const Eigen::Vector2d table_xy = room_center + Eigen::Vector2d(-0.9 + jitter(0.03), jitter(0.03));
  const double table_yaw = deg2rad(15.0 + jitter(3.0));
  const Eigen::Vector3d table_size(1.6, 0.9, 0.75);
  objects.push_back({"dining table", makeBox(table_xy, 0.0, table_size, table_yaw), {}});

  const Eigen::Matrix2d R_table = yawRotation(table_yaw).topLeftCorner<2, 2>();
  const double chair_offsets_deg[4] = {6.0, -5.0, 8.0, -7.0};
  const Eigen::Vector2d chair_slots[4] = {
      {-0.42, -0.92}, {0.42, -0.92}, {-0.42, 0.92}, {0.42, 0.92}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d offset_T = chair_slots[k] + Eigen::Vector2d(jitter(0.015), jitter(0.015));
    // Chairs face the table: their x axis along the table's, plus a small own yaw.
    const double yaw = table_yaw + deg2rad(chair_offsets_deg[k] + jitter(1.5));
    objects.push_back(
        {"chair",
         makeBox(table_xy + R_table * offset_T, 0.0, Eigen::Vector3d(0.5, 0.5, 0.9), yaw),
         {}});
  }

  // The couch right of the centre, its back to the dining group, facing the tv corner.
  const Eigen::Vector2d couch_xy = room_center + Eigen::Vector2d(1.45 + jitter(0.03), jitter(0.05));
  objects.push_back(
      {"couch",
       makeBox(couch_xy, 0.0, Eigen::Vector3d(2.0, 0.9, 0.85), deg2rad(90.0 + jitter(2.0))),
       {}});

  // The tv on its stand (clutterBoxes) in the corner the couch faces, clear of the camera loop.
  // Yaw 135 deg: the screen normal (box y axis) points along the room diagonal, into the room.
  const double tv_yaw = deg2rad(135.0);
  const Eigen::Vector2d tv_normal(-std::sin(tv_yaw), std::cos(tv_yaw));
  const Eigen::Vector2d tv_back =
      Eigen::Vector2d(room_x - 0.5, room_y - 0.5) + jitter(0.05) * Eigen::Vector2d(-1.0, 1.0);
  objects.push_back(
      {"tv", makeBox(tv_back + 0.05 * tv_normal, 0.5, Eigen::Vector3d(1.0, 0.1, 0.6), tv_yaw), {}});

  // Two cups and a book on the table top, away from its edges.
  const double top_z = table_size.z();
  const Eigen::Vector2d cup_slots[2] = {{-0.45, -0.15}, {0.35, 0.2}};
  for (const Eigen::Vector2d& slot : cup_slots) {
    const Eigen::Vector2d xy =
        table_xy + R_table * (slot + Eigen::Vector2d(jitter(0.03), jitter(0.03)));
    objects.push_back(
        {"cup",
         makeBox(xy, top_z, Eigen::Vector3d(0.08, 0.08, 0.1), table_yaw + deg2rad(jitter(20.0))),
         {}});
  }
  const Eigen::Vector2d book_xy =
      table_xy + R_table * Eigen::Vector2d(0.05 + jitter(0.03), -0.12 + jitter(0.03));
  objects.push_back({"book",
                     makeBox(book_xy, top_z, Eigen::Vector3d(0.22, 0.16, 0.04),
                             table_yaw + deg2rad(25.0 + jitter(10.0))),
                     {}});
  return SyntheticScene(config, std::move(objects));
}

}  // namespace mvod
