#include "multiview_object_detection/evaluation/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>
#include <unordered_map>

#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/evaluation/split_mix.h"
#include "multiview_object_detection/io/ply_writer.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxDepthM = 10.0;  // farther hits read as 0 (no measurement), like a Kinect

double deg2rad(double deg) { return deg * kPi / 180.0; }

using Rng = SplitMix64;

uint64_t mixSeed(uint64_t a, uint64_t b) {
  Rng rng(a * 0x2545f4914f6cdd1dULL + b + 0x632be59bd9b4e019ULL);
  return rng.next();
}

Eigen::Matrix3d yawRotation(double yaw_rad) {
  return Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

OrientedBox makeBox(const Eigen::Vector2d& center_xy, double bottom_z_m,
                    const Eigen::Vector3d& size_m, double yaw_rad) {
  OrientedBox box;
  box.center_m = Eigen::Vector3d(center_xy.x(), center_xy.y(), bottom_z_m + 0.5 * size_m.z());
  box.size_m = size_m;
  box.rotation = yawRotation(yaw_rad);
  return box;
}

const cv::Vec3d kStandColor(45, 60, 80);  // the tv stand (unlabelled clutter)

// Flat BGR colour of a class; unknown classes get a colour from their name.
cv::Vec3d classColor(const std::string& class_name) {
  if (class_name == "tv stand") return kStandColor;
  if (class_name == "bed") return {150, 120, 200};
  if (class_name == "refrigerator") return {225, 228, 230};
  if (class_name == "shelf") return {60, 110, 160};
  if (class_name == "night stand" || class_name == "side table") return {50, 90, 125};
  if (class_name == "dining table") return {40, 85, 150};
  if (class_name == "chair") return {30, 150, 230};
  if (class_name == "couch") return {170, 95, 45};
  if (class_name == "tv") return {70, 60, 55};
  if (class_name == "cup") return {50, 40, 215};
  if (class_name == "book") return {70, 175, 60};
  uint64_t h = 1469598103934665603ULL;
  for (const char c : class_name) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  return {60.0 + (h & 0x7f), 60.0 + ((h >> 8) & 0x7f), 60.0 + ((h >> 16) & 0x7f)};
}

const cv::Vec3d kFloorColor(150, 175, 190);  // beige, with a faint 0.5 m checker
const cv::Vec3d kCeilingColor(235, 235, 235);
const cv::Vec3d kWallColors[4] = {
    {200, 215, 220}, {215, 205, 200}, {195, 210, 205}, {210, 210, 225}};

// Lambertian shading with an ambient floor, so faces of a box differ and overlays read as 3D.
cv::Vec3b shade(const cv::Vec3d& base, const Eigen::Vector3d& normal_W) {
  static const Eigen::Vector3d kLight = Eigen::Vector3d(0.35, 0.55, 0.75).normalized();
  const double intensity = 0.5 + 0.5 * std::max(0.0, normal_W.dot(kLight)) +
                           0.1 * std::abs(normal_W.x());  // side faces differ a little more
  return cv::Vec3b(cv::saturate_cast<uchar>(base[0] * intensity),
                   cv::saturate_cast<uchar>(base[1] * intensity),
                   cv::saturate_cast<uchar>(base[2] * intensity));
}

// A box prepared for ray casting in one frame: the ray origin and direction map into box
// coordinates (the box axes, centred) once per frame.
struct CastBox {
  Eigen::Vector3d half_m;
  Eigen::Matrix3d R_W_B;
  Eigen::Vector3d origin_B;  // camera centre in box coordinates
  Eigen::Matrix3d R_B_C;     // camera ray directions into box coordinates
  cv::Vec3d color;
  int label = 0;    // 0 = background clutter
  cv::Rect pixels;  // image region the box can cover (conservative)
};

CastBox prepare(const OrientedBox& box, const Eigen::Isometry3d& T_W_C, const CameraIntrinsics& K,
                const cv::Vec3d& color, int label) {
  CastBox cast;
  cast.half_m = 0.5 * box.size_m;
  cast.R_W_B = box.rotation;
  cast.origin_B = box.rotation.transpose() * (T_W_C.translation() - box.center_m);
  cast.R_B_C = box.rotation.transpose() * T_W_C.linear();
  cast.color = color;
  cast.label = label;
  // Pixel bounds of the projected corners; a box reaching behind the camera may cover any pixel.
  cast.pixels = cv::Rect(0, 0, K.width, K.height);
  double u_min = std::numeric_limits<double>::infinity(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  bool in_front = true;
  for (const Eigen::Vector3d& corner_W : box.corners()) {
    const Eigen::Vector3d corner_C = T_W_C.inverse() * corner_W;
    if (corner_C.z() < 1e-3) {
      in_front = false;
      break;
    }
    const double u = K.fx * corner_C.x() / corner_C.z() + K.cx;
    const double v = K.fy * corner_C.y() / corner_C.z() + K.cy;
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  if (in_front) {
    const int u0 = std::max(0, static_cast<int>(std::floor(u_min)) - 1);
    const int v0 = std::max(0, static_cast<int>(std::floor(v_min)) - 1);
    const int u1 = std::min(K.width - 1, static_cast<int>(std::ceil(u_max)) + 1);
    const int v1 = std::min(K.height - 1, static_cast<int>(std::ceil(v_max)) + 1);
    cast.pixels = u1 >= u0 && v1 >= v0 ? cv::Rect(u0, v0, u1 - u0 + 1, v1 - v0 + 1) : cv::Rect();
  }
  return cast;
}

// Slab test: the entry distance along the ray (in units of the ray direction) if the ray enters the
// box in front of the camera, with the box axis (0-2) and side (+1/-1) of the entry face.
bool enterBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& half,
              double* t_enter, int* axis, int* side) {
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int near_axis = 0;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (std::abs(o[a]) > half[a]) return false;
      continue;
    }
    const double inv = 1.0 / d[a];
    double t0 = (-half[a] - o[a]) * inv;
    double t1 = (half[a] - o[a]) * inv;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      near_axis = a;
    }
    t_far = std::min(t_far, t1);
    if (t_near > t_far) return false;
  }
  if (!(t_near > 1e-9)) return false;  // behind the camera, or the camera is inside the box
  *t_enter = t_near;
  *axis = near_axis;
  *side = d[near_axis] > 0.0 ? -1 : 1;
  return true;
}

// Every tv stands on a stand: a background box from the floor up to the tv, a little wider and
// deeper, flush with the tv's back (it is not one of objects(), so it has no label).
std::vector<SyntheticObject> clutterBoxes(const std::vector<SyntheticObject>& objects) {
  std::vector<SyntheticObject> clutter;
  for (const SyntheticObject& object : objects) {
    if (object.class_name != "tv") continue;
    const OrientedBox& tv = object.box;
    const double bottom_z_m = tv.center_m.z() - 0.5 * tv.size_m.z();
    if (bottom_z_m < 0.05) continue;
    OrientedBox stand;
    stand.rotation = tv.rotation;
    stand.size_m = Eigen::Vector3d(tv.size_m.x() + 0.2, std::max(0.4, tv.size_m.y()), bottom_z_m);
    // The stand's back is flush with the tv's back (-y side of the tv), it reaches out in front.
    const Eigen::Vector3d back = tv.center_m - 0.5 * tv.size_m.y() * tv.rotation.col(1);
    stand.center_m = back + 0.5 * stand.size_m.y() * tv.rotation.col(1);
    stand.center_m.z() = 0.5 * bottom_z_m;
    clutter.push_back({"tv stand", stand, {}});
  }
  return clutter;
}

std::string formatNumber(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", std::abs(value) < 1e-12 ? 0.0 : value);
  return buffer;
}

Status writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return Status::Error("cannot write " + path.string());
  out << text;
  out.close();
  if (!out) return Status::Error("cannot write " + path.string());
  return Status::Ok();
}

Status makeFolder(const std::string& directory) {
  std::error_code error;
  fs::create_directories(directory, error);
  if (error || !fs::is_directory(directory)) {
    return Status::Error("cannot create folder " + directory +
                         (error ? ": " + error.message() : std::string()));
  }
  return Status::Ok();
}

// The label (object index) under the first pixel of a mask, -1 for an empty mask.
int objectIndexOfMask(const cv::Mat& labels, const cv::Mat& mask) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(mask, pixels);
  if (pixels.empty()) return -1;
  return labels.at<int32_t>(pixels.front()) - 1;
}

std::string frameName(int index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "frame-%06d", index);
  return buffer;
}

// ---- Furniture for makeRoom ----

// One part in the furniture's own frame: x = width, y = depth (+y = front), z up from its base.
struct LocalPart {
  Eigen::Vector3d lo;
  Eigen::Vector3d hi;
};

LocalPart part(double x0, double y0, double z0, double x1, double y1, double z1) {
  return {Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)};
}

// Places local parts at `origin_W` (the local frame's origin) turned by `yaw`: the object's box is
// the union of the parts in its own frame, so it is the tightest box in that yaw.
SyntheticObject assemble(const std::string& name, const Eigen::Vector3d& origin_W, double yaw,
                         const std::vector<LocalPart>& parts) {
  SyntheticObject object;
  object.class_name = name;
  const Eigen::Matrix3d R = yawRotation(yaw);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const LocalPart& local : parts) {
    OrientedBox box;
    box.rotation = R;
    box.size_m = local.hi - local.lo;
    box.center_m = origin_W + R * (0.5 * (local.lo + local.hi));
    object.parts.push_back(box);
    lo = lo.cwiseMin(local.lo);
    hi = hi.cwiseMax(local.hi);
  }
  object.box.rotation = R;
  object.box.size_m = hi - lo;
  object.box.center_m = origin_W + R * (0.5 * (lo + hi));
  if (parts.size() == 1) object.parts.clear();  // the box is the one part
  return object;
}

std::vector<LocalPart> chairParts(double w, double d, double seat_h, double h) {
  const double t = 0.04;  // legs and seat
  std::vector<LocalPart> parts;
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const double x = sx * (0.5 * w - 0.5 * t);
      const double y = sy * (0.5 * d - 0.5 * t);
      parts.push_back(part(x - 0.5 * t, y - 0.5 * t, 0.0, x + 0.5 * t, y + 0.5 * t, seat_h - t));
    }
  }
  parts.push_back(part(-0.5 * w, -0.5 * d, seat_h - t, 0.5 * w, 0.5 * d, seat_h));
  parts.push_back(part(-0.5 * w, -0.5 * d, seat_h, 0.5 * w, -0.5 * d + 0.05, h));  // back
  return parts;
}

std::vector<LocalPart> tableParts(double w, double d, double h) {
  const double leg = 0.06;
  const double top = 0.04;
  std::vector<LocalPart> parts;
  parts.push_back(part(-0.5 * w, -0.5 * d, h - top, 0.5 * w, 0.5 * d, h));
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      const double x = sx * (0.5 * w - 0.05 - 0.5 * leg);
      const double y = sy * (0.5 * d - 0.05 - 0.5 * leg);
      parts.push_back(
          part(x - 0.5 * leg, y - 0.5 * leg, 0.0, x + 0.5 * leg, y + 0.5 * leg, h - top));
    }
  }
  return parts;
}

std::vector<LocalPart> couchParts(double w, double d, double h) {
  const double seat_h = 0.42;
  const double back = 0.22;
  const double arm = 0.18;
  return {part(-0.5 * w, -0.5 * d, 0.0, 0.5 * w, 0.5 * d, seat_h),
          part(-0.5 * w, -0.5 * d, seat_h, 0.5 * w, -0.5 * d + back, h),
          part(-0.5 * w, -0.5 * d + back, seat_h, -0.5 * w + arm, 0.5 * d, seat_h + 0.2),
          part(0.5 * w - arm, -0.5 * d + back, seat_h, 0.5 * w, 0.5 * d, seat_h + 0.2)};
}

// Headboard at -y, foot at +y.
std::vector<LocalPart> bedParts(double w, double l) {
  const double head = 0.08;
  return {part(-0.5 * w, -0.5 * l + head, 0.0, 0.5 * w, 0.5 * l, 0.3),
          part(-0.5 * w + 0.03, -0.5 * l + head + 0.02, 0.3, 0.5 * w - 0.03, 0.5 * l - 0.03, 0.52),
          part(-0.5 * w, -0.5 * l, 0.0, 0.5 * w, -0.5 * l + head, 1.05)};
}

// A flat screen on a foot; the screen faces +y.
std::vector<LocalPart> tvParts(double w, double h) {
  return {part(-0.15, -0.1, 0.0, 0.15, 0.1, 0.02), part(-0.03, -0.02, 0.02, 0.03, 0.02, 0.1),
          part(-0.5 * w, -0.03, 0.1, 0.5 * w, 0.03, 0.1 + h)};
}

std::vector<LocalPart> fridgeParts(double w, double d, double h) {
  const double handle_x = 0.5 * w - 0.1;
  return {part(-0.5 * w, -0.5 * d, 0.0, 0.5 * w, 0.5 * d - 0.03, h),
          part(handle_x, 0.5 * d - 0.03, 0.45, handle_x + 0.03, 0.5 * d, 0.85),
          part(handle_x, 0.5 * d - 0.03, 1.05, handle_x + 0.03, 0.5 * d, 1.55)};
}

// A cup with its handle on the +x side.
std::vector<LocalPart> cupParts() {
  return {part(-0.04, -0.04, 0.0, 0.04, 0.04, 0.095), part(0.04, -0.01, 0.025, 0.06, 0.01, 0.07)};
}

// An open bookshelf: two sides, a back, `levels` + 1 boards (bottom and top included); board i
// spans z in [i * spacing, i * spacing + 0.02].
std::vector<LocalPart> shelfParts(double w, double d, double h, int levels, double* spacing) {
  const double t = 0.02;
  *spacing = (h - t) / levels;
  std::vector<LocalPart> parts = {
      part(-0.5 * w, -0.5 * d, 0.0, -0.5 * w + t, 0.5 * d, h),
      part(0.5 * w - t, -0.5 * d, 0.0, 0.5 * w, 0.5 * d, h),
      part(-0.5 * w + t, -0.5 * d, 0.0, 0.5 * w - t, -0.5 * d + 0.01, h)};
  for (int i = 0; i <= levels; ++i) {
    parts.push_back(
        part(-0.5 * w + t, -0.5 * d + 0.01, i * *spacing, 0.5 * w - t, 0.5 * d, i * *spacing + t));
  }
  return parts;
}

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

// Builds a room: floor-standing pieces are accepted only where they fit.
class RoomBuilder {
 public:
  RoomBuilder(const SyntheticSceneConfig& config, uint64_t seed) : config_(config), rng_(seed) {
    const Eigen::Vector2d center(0.5 * config.room_size_x_m, 0.5 * config.room_size_y_m);
    const double rx = std::max(0.5, 0.5 * config.room_size_x_m - config.camera_loop_inset_m);
    const double ry = std::max(0.5, 0.5 * config.room_size_y_m - config.camera_loop_inset_m);
    for (int i = 0; i < 720; ++i) {
      const double a = 2.0 * kPi * i / 720.0;
      loop_.emplace_back(center.x() + rx * std::cos(a), center.y() + ry * std::sin(a));
    }
  }

  Rng& rng() { return rng_; }
  double jitter(double amplitude) { return rng_.uniform(-amplitude, amplitude); }

  // True when the footprint of `box` is inside the walls, >= kLoopClearance from the camera loop
  // and >= kGap from every accepted floor-standing piece.
  bool fits(const OrientedBox& box) const {
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
  // Accepts a floor-standing object or clutter (its footprint blocks later pieces).
  void addObject(SyntheticObject object) {
    floor_.push_back(object.box);
    objects_.push_back(std::move(object));
  }
  void addClutter(SyntheticObject clutter) {
    floor_.push_back(clutter.box);
    clutter_.push_back(std::move(clutter));
  }
  // Objects standing on something else (books, cups): no floor check.
  void addSupported(SyntheticObject object) { objects_.push_back(std::move(object)); }

  // Origin of a piece with its back (local y = back_y) against the wall y = 0 (side 0, facing +y)
  // or y = room_y (side 1, facing -y); its yaw jitters a little.
  void againstWall(int side, double x, double back_y, Eigen::Vector3d* origin, double* yaw) {
    const double gap = 0.04;
    *yaw = (side == 0 ? 0.0 : kPi) + deg2rad(jitter(2.0));
    const double y = side == 0 ? gap - back_y : config_.room_size_y_m - gap + back_y;
    *origin = Eigen::Vector3d(x, y, 0.0);
  }

  // Up to `count` small objects on a support's top (a rectangle of half size `half` in its frame,
  // at height top_z), >= 0.1 m from its edges and 0.03 m from each other.
  void scatterOnTop(const Eigen::Vector3d& origin, double yaw, const Eigen::Vector2d& half,
                    double top_z, int cups, int books) {
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

  // A bookshelf against a wall with books standing on its boards. False if it does not fit.
  bool addBookshelf(int side, double x) {
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
        const std::vector<LocalPart> book = {part(cursor, back_y, board_top, cursor + thickness,
                                                  back_y + depth, board_top + height)};
        // The book's own frame is the shelf's: assemble at the shelf origin.
        addSupported(assemble("book", origin, yaw, book));
        ++books;
        cursor += thickness + 0.004;
      }
    }
    return true;
  }

  // A tv on a stand (clutter) against a wall. False if it does not fit.
  bool addTvOnStand(int side, double x) {
    const double stand_w = rng_.uniform(1.2, 1.6);
    const double stand_d = rng_.uniform(0.34, 0.4);
    const double stand_h = rng_.uniform(0.42, 0.55);
    Eigen::Vector3d origin;
    double yaw = 0.0;
    againstWall(side, x, -0.5 * stand_d, &origin, &yaw);
    SyntheticObject stand = assemble(
        "tv stand", origin, yaw,
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

  // Tries a floor-standing object at random poses from `propose` until one fits.
  template <typename Propose>
  bool place(int attempts, Propose propose) {
    for (int attempt = 0; attempt < attempts; ++attempt) {
      SyntheticObject object = propose();
      if (fits(object.box)) {
        addObject(std::move(object));
        return true;
      }
    }
    return false;
  }

  Eigen::Vector2d center() const {
    return Eigen::Vector2d(0.5 * config_.room_size_x_m, 0.5 * config_.room_size_y_m);
  }
  std::vector<SyntheticObject>& objects() { return objects_; }
  std::vector<SyntheticObject>& clutter() { return clutter_; }

 private:
  static constexpr double kWallGap = 0.02;
  static constexpr double kLoopClearance = 0.35;
  static constexpr double kGap = 0.1;  // between floor-standing pieces
  const SyntheticSceneConfig& config_;
  Rng rng_;
  std::vector<Eigen::Vector2d> loop_;
  std::vector<OrientedBox> floor_;
  std::vector<SyntheticObject> objects_;
  std::vector<SyntheticObject> clutter_;
};

SyntheticObject makeChair(Rng& rng, const Eigen::Vector3d& origin, double yaw) {
  const double w = rng.uniform(0.42, 0.5);
  const double d = rng.uniform(0.44, 0.52);
  return assemble("chair", origin, yaw,
                  chairParts(w, d, rng.uniform(0.43, 0.48), rng.uniform(0.82, 0.95)));
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

// ---- Rendering ----

struct RenderOutput {
  cv::Mat color;          // CV_8UC3 BGR
  cv::Mat depth_mm;       // CV_16UC1: the sensor's depth (noise model applied)
  cv::Mat z_m;            // CV_32FC1: exact ray depth, 0 = no hit within kMaxDepthM
  cv::Mat cos_incidence;  // CV_32FC1: |cos| of the angle between the ray and the surface normal
  cv::Mat labels;         // CV_32SC1
};

// Kinect model steps 1-3 (range, grazing angle, IR shadow) on the exact depth: the pixels that read
// 0 whatever the random draws. `rng` draws the shadow widths.
cv::Mat kinectDropouts(const KinectDepthModel& model, const cv::Mat& z_m,
                       const cv::Mat& cos_incidence, Rng* rng) {
  const int height = z_m.rows;
  const int width = z_m.cols;
  cv::Mat invalid(height, width, CV_8UC1, cv::Scalar(0));
  const double min_cos = std::cos(deg2rad(model.max_incidence_deg));
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const float z = z_m.at<float>(v, u);
      if (!(z > 0.0f) || z < model.min_depth_m || z > model.max_depth_m ||
          cos_incidence.at<float>(v, u) < min_cos) {
        invalid.at<uint8_t>(v, u) = 1;
      }
    }
  }
  const int max_px = std::max(1, model.shadow_max_px);
  const int du[4] = {-1, 1, 0, 0};
  const int dv[4] = {0, 0, -1, 1};
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const float z = z_m.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      for (int n = 0; n < 4; ++n) {
        const int un = u + du[n];
        const int vn = v + dv[n];
        if (un < 0 || vn < 0 || un >= width || vn >= height) continue;
        const float z_near = z_m.at<float>(vn, un);
        if (!(z_near > 0.0f) || z - z_near <= model.shadow_jump_m) continue;
        // (u, v) is on the far side of an edge: a band away from the nearer neighbour.
        const int band = 1 + static_cast<int>(rng->next() % static_cast<uint64_t>(max_px));
        for (int s = 0; s < band; ++s) {
          const int us = u - s * du[n];
          const int vs = v - s * dv[n];
          if (us < 0 || vs < 0 || us >= width || vs >= height) break;
          if (!(z_m.at<float>(vs, us) - z_near > model.shadow_jump_m)) break;
          invalid.at<uint8_t>(vs, us) = 1;
        }
      }
    }
  }
  return invalid;
}

// Kinect axial sigma (Nguyen et al. 2012).
double kinectSigma(const KinectDepthModel& model, double z) {
  const double dz = z - model.sigma_offset_m;
  return model.sigma_base_m + model.sigma_quadratic_per_m * dz * dz;
}

// Exact depth -> what the sensor reports (Kinect model steps 4-6).
double kinectMeasure(const KinectDepthModel& model, double z, double noise_draw) {
  double measured = z + kinectSigma(model, z) * noise_draw;
  if (model.quantization_per_m > 0.0 && measured > 0.0) {
    const double disparity = std::round(1.0 / (model.quantization_per_m * measured));
    measured = disparity >= 1.0 ? 1.0 / (model.quantization_per_m * disparity) : 0.0;
  }
  return measured;
}

// Whether the sensor could measure the exact depth z at this incidence: the pixels that make up the
// observed surface (ground-truth points, the SceneNN mesh).
bool inSensorRange(const SyntheticSceneConfig& config, float z, float cos_incidence) {
  if (!(z > 0.0f)) return false;
  if (config.noise_model != DepthNoiseModel::kKinect) return z <= kMaxDepthM;
  const KinectDepthModel& model = config.kinect;
  return z >= model.min_depth_m && z <= model.max_depth_m &&
         cos_incidence >= std::cos(deg2rad(model.max_incidence_deg));
}

// Ray casts one frame. clutter_ids: clutter k gets label objects.size() + 1 + k (else 0).
// sensor_model: apply the configured noise model to depth_mm (else the exact depth in mm).
void renderScene(const SyntheticScene& scene, int frame, const CameraIntrinsics& K,
                 bool clutter_ids, bool sensor_model, RenderOutput* out) {
  const SyntheticSceneConfig& config = scene.config();
  const int width = K.width;
  const int height = K.height;
  const Eigen::Isometry3d T_W_C = scene.cameraPose(frame);
  const std::vector<SyntheticObject>& objects = scene.objects();

  std::vector<CastBox> boxes;
  for (size_t k = 0; k < objects.size(); ++k) {
    const cv::Vec3d color = classColor(objects[k].class_name);
    for (const OrientedBox& part : solidParts(objects[k])) {
      boxes.push_back(prepare(part, T_W_C, K, color, static_cast<int>(k) + 1));
    }
  }
  for (size_t j = 0; j < scene.clutter().size(); ++j) {
    const SyntheticObject& clutter = scene.clutter()[j];
    const int label = clutter_ids ? static_cast<int>(objects.size() + 1 + j) : 0;
    for (const OrientedBox& part : solidParts(clutter)) {
      boxes.push_back(prepare(part, T_W_C, K, classColor(clutter.class_name), label));
    }
  }
  // The room is a box seen from inside: the ray leaves it through a wall, the floor or the ceiling.
  const Eigen::Vector3d room_min(0.0, 0.0, 0.0);
  const Eigen::Vector3d room_max(config.room_size_x_m, config.room_size_y_m, config.room_height_m);
  const Eigen::Vector3d origin_W = T_W_C.translation();
  const Eigen::Matrix3d R_W_C = T_W_C.linear();

  cv::Mat color(height, width, CV_8UC3);
  cv::Mat depth(height, width, CV_16UC1);
  cv::Mat z_image(height, width, CV_32FC1);
  cv::Mat cos_image(height, width, CV_32FC1);
  cv::Mat label_image(height, width, CV_32SC1);
  for (int v = 0; v < height; ++v) {
    cv::Vec3b* color_row = color.ptr<cv::Vec3b>(v);
    uint16_t* depth_row = depth.ptr<uint16_t>(v);
    float* z_row = z_image.ptr<float>(v);
    float* cos_row = cos_image.ptr<float>(v);
    int32_t* label_row = label_image.ptr<int32_t>(v);
    for (int u = 0; u < width; ++u) {
      // Ray with unit optical-axis component: the hit distance t is the depth z directly.
      const Eigen::Vector3d dir_C((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const Eigen::Vector3d dir_W = R_W_C * dir_C;

      double t_best = std::numeric_limits<double>::infinity();
      Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();
      cv::Vec3d base(0, 0, 0);
      int label = 0;
      // Room exit.
      for (int a = 0; a < 3; ++a) {
        if (std::abs(dir_W[a]) < 1e-12) continue;
        const double bound = dir_W[a] > 0.0 ? room_max[a] : room_min[a];
        const double t = (bound - origin_W[a]) / dir_W[a];
        if (t > 0.0 && t < t_best) {
          const Eigen::Vector3d hit = origin_W + t * dir_W;
          bool inside = true;
          for (int b = 0; b < 3; ++b) {
            if (b != a && (hit[b] < room_min[b] - 1e-9 || hit[b] > room_max[b] + 1e-9)) {
              inside = false;
            }
          }
          if (!inside) continue;
          t_best = t;
          normal_W = Eigen::Vector3d::Zero();
          normal_W[a] = dir_W[a] > 0.0 ? -1.0 : 1.0;
          if (a == 2) {
            if (dir_W[a] < 0.0) {
              // Floor: a faint 0.5 m checker gives the colour image some texture.
              const int cell = static_cast<int>(std::floor(hit.x() / 0.5)) +
                               static_cast<int>(std::floor(hit.y() / 0.5));
              base = (cell & 1) ? kFloorColor * 0.92 : kFloorColor;
            } else {
              base = kCeilingColor;
            }
          } else {
            base = kWallColors[2 * a + (dir_W[a] > 0.0 ? 1 : 0)];
          }
        }
      }
      for (const CastBox& box : boxes) {
        if (!box.pixels.contains(cv::Point(u, v))) continue;
        const Eigen::Vector3d dir_B = box.R_B_C * dir_C;
        double t = 0.0;
        int axis = 0;
        int side = 1;
        if (enterBox(box.origin_B, dir_B, box.half_m, &t, &axis, &side) && t < t_best) {
          t_best = t;
          normal_W = side * box.R_W_B.col(axis);
          base = box.color;
          label = box.label;
        }
      }

      if (std::isfinite(t_best) && t_best <= kMaxDepthM) {
        depth_row[u] = static_cast<uint16_t>(std::lround(t_best * 1000.0));
        z_row[u] = static_cast<float>(t_best);
        cos_row[u] = static_cast<float>(std::abs(normal_W.dot(dir_W)) / dir_W.norm());
        color_row[u] = shade(base, normal_W);
        label_row[u] = label;
      } else {
        depth_row[u] = 0;
        z_row[u] = 0.0f;
        cos_row[u] = 0.0f;
        color_row[u] = cv::Vec3b(0, 0, 0);
        label_row[u] = 0;
      }
    }
  }

  // Sensor imperfections, seeded per frame so a frame always looks the same.
  if (sensor_model && config.noise_model == DepthNoiseModel::kQuadratic) {
    const bool noisy = config.depth_noise_m_per_m2 > 0.0;
    const bool holes = config.hole_fraction > 0.0;
    if (noisy || holes) {
      Rng rng(mixSeed(mixSeed(config.seed, 0xde97), static_cast<uint64_t>(frame)));
      for (int v = 0; v < height; ++v) {
        uint16_t* depth_row = depth.ptr<uint16_t>(v);
        for (int u = 0; u < width; ++u) {
          const double hole_draw = holes ? rng.uniform() : 1.0;
          const double noise_draw = noisy ? rng.gaussian() : 0.0;
          if (depth_row[u] == 0) continue;
          if (holes && hole_draw < config.hole_fraction) {
            depth_row[u] = 0;
            continue;
          }
          if (noisy) {
            const double z = depth_row[u] * 1e-3;
            const double noisy_z = z + config.depth_noise_m_per_m2 * z * z * noise_draw;
            const long mm = std::lround(noisy_z * 1000.0);
            depth_row[u] = static_cast<uint16_t>(std::clamp<long>(mm, 1, 65535));
          }
        }
      }
    }
  } else if (sensor_model && config.noise_model == DepthNoiseModel::kKinect) {
    Rng rng(mixSeed(mixSeed(config.seed, 0x41c7), static_cast<uint64_t>(frame)));
    const cv::Mat invalid = kinectDropouts(config.kinect, z_image, cos_image, &rng);
    for (int v = 0; v < height; ++v) {
      uint16_t* depth_row = depth.ptr<uint16_t>(v);
      const float* z_row = z_image.ptr<float>(v);
      const uint8_t* invalid_row = invalid.ptr<uint8_t>(v);
      for (int u = 0; u < width; ++u) {
        const double hole_draw = rng.uniform();
        const double noise_draw = rng.gaussian();
        if (invalid_row[u] || hole_draw < config.hole_fraction) {
          depth_row[u] = 0;
          continue;
        }
        const double measured = kinectMeasure(config.kinect, z_row[u], noise_draw);
        const long mm = std::lround(measured * 1000.0);
        depth_row[u] = measured > 0.0 ? static_cast<uint16_t>(std::clamp<long>(mm, 1, 65535)) : 0;
      }
    }
  }
  out->color = color;
  out->depth_mm = depth;
  out->z_m = z_image;
  out->cos_incidence = cos_image;
  out->labels = label_image;
}

RgbdFrame toRgbdFrame(const SyntheticScene& scene, int index, const CameraIntrinsics& K,
                      const RenderOutput& out) {
  RgbdFrame rgbd;
  rgbd.index = index;
  rgbd.name = frameName(index);
  rgbd.stamp_s = index / 30.0;
  rgbd.color_bgr = out.color;
  rgbd.depth = out.depth_mm;
  rgbd.K_depth = K;
  rgbd.K_color = K;
  rgbd.registered = true;
  rgbd.T_C_D = Eigen::Isometry3d::Identity();
  rgbd.T_W_D = scene.cameraPose(index);
  return rgbd;
}

// Voxel grid accumulating back-projected points: mean position and colour, majority label
// (Boyer-Moore vote).
class VoxelAccumulator {
 public:
  explicit VoxelAccumulator(double voxel_m) : inverse_(1.0 / voxel_m) {}
  void add(const Eigen::Vector3d& p, const cv::Vec3b& bgr, int label) {
    const int64_t ix = static_cast<int64_t>(std::floor(p.x() * inverse_)) + (1 << 20);
    const int64_t iy = static_cast<int64_t>(std::floor(p.y() * inverse_)) + (1 << 20);
    const int64_t iz = static_cast<int64_t>(std::floor(p.z() * inverse_)) + (1 << 20);
    const uint64_t key = (static_cast<uint64_t>(ix) << 42) | (static_cast<uint64_t>(iy) << 21) |
                         static_cast<uint64_t>(iz);
    const auto inserted = index_.emplace(key, static_cast<uint32_t>(voxels_.size()));
    if (inserted.second) voxels_.emplace_back();
    Voxel& voxel = voxels_[inserted.first->second];
    voxel.sum += p;
    for (int c = 0; c < 3; ++c) voxel.bgr[c] += bgr[c];
    ++voxel.count;
    if (voxel.votes == 0) {
      voxel.label = label;
      voxel.votes = 1;
    } else {
      voxel.votes += voxel.label == label ? 1 : -1;
    }
  }
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    uint64_t bgr[3] = {0, 0, 0};
    uint32_t count = 0;
    int label = 0;
    int votes = 0;
  };
  const std::vector<Voxel>& voxels() const { return voxels_; }

 private:
  double inverse_;
  std::unordered_map<uint64_t, uint32_t> index_;
  std::vector<Voxel> voxels_;
};

// The world points of the in-range pixels of a frame, in the accumulator (label_image: the label
// per pixel; only labels >= min_label are added).
void accumulateFrame(const SyntheticSceneConfig& config, const CameraIntrinsics& K,
                     const Eigen::Isometry3d& T_W_C, const RenderOutput& render,
                     const cv::Mat& label_image, int min_label, VoxelAccumulator* grid) {
  const Eigen::Matrix3d R = T_W_C.linear();
  const Eigen::Vector3d t = T_W_C.translation();
  for (int v = 0; v < render.z_m.rows; ++v) {
    const float* z_row = render.z_m.ptr<float>(v);
    const float* cos_row = render.cos_incidence.ptr<float>(v);
    const int32_t* label_row = label_image.ptr<int32_t>(v);
    const cv::Vec3b* color_row = render.color.ptr<cv::Vec3b>(v);
    for (int u = 0; u < render.z_m.cols; ++u) {
      if (label_row[u] < min_label || !inSensorRange(config, z_row[u], cos_row[u])) continue;
      const double z = z_row[u];
      const Eigen::Vector3d p_C((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      grid->add(R * p_C + t, color_row[u], label_row[u]);
    }
  }
}

// z-up world -> SceneNN's y-up world: (x, y, z) -> (x, z, -y).
Eigen::Matrix3d zUpToYUp() {
  Eigen::Matrix3d M;
  M << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return M;
}

Status writeImage(const fs::path& path, const cv::Mat& image) {
  bool written = false;
  try {
    written = cv::imwrite(path.string(), image);
  } catch (const cv::Exception&) {
    written = false;
  }
  return written ? Status::Ok() : Status::Error("cannot write " + path.string());
}

std::string nyuClassName(const std::string& name) {
  static const std::map<std::string, std::string> kNyu = {
      {"chair", "chair"},
      {"dining table", "table"},
      {"couch", "sofa"},
      {"bed", "bed"},
      {"tv", "television"},
      {"book", "books"},
      {"refrigerator", "refridgerator"},  // NYU40's spelling
      {"cup", "cup"},
      {"shelf", "shelves"},
      {"tv stand", "cabinet"},
      {"night stand", "night stand"},
      {"side table", "otherfurniture"}};
  const auto it = kNyu.find(name);
  return it == kNyu.end() ? std::string() : it->second;
}

}  // namespace

std::vector<OrientedBox> solidParts(const SyntheticObject& object) {
  return object.parts.empty() ? std::vector<OrientedBox>{object.box} : object.parts;
}

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
  }
  return "?";
}

SyntheticScene::SyntheticScene(const SyntheticSceneConfig& config,
                               std::vector<SyntheticObject> objects)
    : config_(config), objects_(std::move(objects)), clutter_(clutterBoxes(objects_)) {}

SyntheticScene::SyntheticScene(const SyntheticSceneConfig& config,
                               std::vector<SyntheticObject> objects,
                               std::vector<SyntheticObject> clutter)
    : config_(config), objects_(std::move(objects)), clutter_(std::move(clutter)) {}

CameraIntrinsics SyntheticScene::sceneNNIntrinsics() {
  return CameraIntrinsics{544.47329, 544.47329, 320.0, 240.0, 640, 480};
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
  }
  config.room_size_x_m = rng.uniform(size_range[0], size_range[1]);
  config.room_size_y_m = rng.uniform(size_range[2], size_range[3]);
  config.room_height_m = rng.uniform(2.5, 2.8);
  config.camera_height_m = rng.uniform(1.0, 1.3);
  config.camera_pitch_deg = -rng.uniform(12.0, 18.0);
  config.camera_loop_inset_m = 0.8;
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

Eigen::Isometry3d SyntheticScene::cameraPose(int frame) const {
  // A robot driving an ellipse around the room centre, its camera turned towards the centre: every
  // object inside the loop is seen from all sides over one lap.
  const int frames = std::max(1, config_.num_frames);
  const double angle = kPi + 2.0 * kPi * static_cast<double>(frame) / frames;
  const Eigen::Vector2d center(0.5 * config_.room_size_x_m, 0.5 * config_.room_size_y_m);
  const double inset = config_.camera_loop_inset_m;
  const double radius_x = std::max(0.5, 0.5 * config_.room_size_x_m - inset);
  const double radius_y = std::max(0.5, 0.5 * config_.room_size_y_m - inset);
  Eigen::Vector3d position(center.x() + radius_x * std::cos(angle),
                           center.y() + radius_y * std::sin(angle), config_.camera_height_m);
  double yaw = std::atan2(center.y() - position.y(), center.x() - position.x());
  double pitch = deg2rad(config_.camera_pitch_deg);
  if (config_.camera_wobble) {
    // A robot's bumps and steering: smooth, whole cycles per lap (the lap closes), seeded phases.
    Rng rng(mixSeed(config_.seed, 0x30bb1e));
    double phase[4];
    for (double& p : phase) p = rng.uniform(0.0, 2.0 * kPi);
    const double s = 2.0 * kPi * static_cast<double>(frame) / frames;
    position.z() += config_.wobble_height_m * std::sin(3.0 * s + phase[0]);
    yaw += deg2rad(config_.wobble_yaw_deg) *
           (0.7 * std::sin(2.0 * s + phase[1]) + 0.3 * std::sin(5.0 * s + phase[2]));
    pitch += deg2rad(config_.wobble_pitch_deg) * std::sin(4.0 * s + phase[3]);
  }

  // Optical frame: z forward, x right, y down.
  const Eigen::Vector3d forward(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                                std::sin(pitch));
  const Eigen::Vector3d right(std::sin(yaw), -std::cos(yaw), 0.0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
  T_W_C.linear().col(0) = right;
  T_W_C.linear().col(1) = down;
  T_W_C.linear().col(2) = forward;
  T_W_C.translation() = position;
  return T_W_C;
}

void SyntheticScene::render(int frame, RgbdFrame* rgbd, cv::Mat* labels) const {
  const CameraIntrinsics& K = config_.K;
  if (rgbd == nullptr && labels == nullptr) return;
  if (K.width <= 0 || K.height <= 0 || !K.isValid()) {
    if (rgbd != nullptr) *rgbd = RgbdFrame();
    if (labels != nullptr) *labels = cv::Mat();
    return;
  }
  RenderOutput out;
  renderScene(*this, frame, K, /*clutter_ids=*/false, /*sensor_model=*/true, &out);
  if (rgbd != nullptr) *rgbd = toRgbdFrame(*this, frame, K, out);
  if (labels != nullptr) *labels = out.labels;
}

std::vector<Detection2D> SyntheticScene::detectionsFromLabels(const cv::Mat& labels,
                                                              int min_pixels) const {
  std::vector<Detection2D> detections;
  if (labels.empty() || labels.type() != CV_32SC1) return detections;
  const int count = static_cast<int>(objects_.size());
  std::vector<int> pixels(count + 1, 0);
  std::vector<cv::Rect> boxes(count + 1);
  std::vector<int> min_u(count + 1, labels.cols), max_u(count + 1, -1);
  std::vector<int> min_v(count + 1, labels.rows), max_v(count + 1, -1);
  for (int v = 0; v < labels.rows; ++v) {
    const int32_t* row = labels.ptr<int32_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const int k = row[u];
      if (k <= 0 || k > count) continue;
      ++pixels[k];
      min_u[k] = std::min(min_u[k], u);
      max_u[k] = std::max(max_u[k], u);
      min_v[k] = std::min(min_v[k], v);
      max_v[k] = std::max(max_v[k], v);
    }
  }
  for (int k = 1; k <= count; ++k) {
    if (pixels[k] == 0 || pixels[k] < min_pixels) continue;
    const SyntheticObject& object = objects_[k - 1];
    if (object.class_name.empty()) continue;
    Detection2D detection;
    detection.class_name = object.class_name;
    detection.class_id = cocoClassId(object.class_name);
    // A fixed, slightly different confidence per object, as a detector would give.
    detection.score = 0.99f - 0.015f * static_cast<float>((k - 1) % 12);
    detection.box_px =
        cv::Rect(min_u[k], min_v[k], max_u[k] - min_u[k] + 1, max_v[k] - min_v[k] + 1);
    detection.mask = cv::Mat(labels == k);  // 255 on the object, 0 elsewhere
    detections.push_back(std::move(detection));
  }
  return detections;
}

double SyntheticScene::visibleFraction(int frame, const cv::Mat& labels, int object_index) const {
  if (object_index < 0 || object_index >= static_cast<int>(objects_.size()) || labels.empty() ||
      labels.type() != CV_32SC1 || !config_.K.isValid()) {
    return 0.0;
  }
  // Area of the convex hull of the projected corners: what the object would cover on an unbounded
  // image plane with nothing in front of it.
  const CameraIntrinsics& K = config_.K;
  const Eigen::Isometry3d T_C_W = cameraPose(frame).inverse();
  std::vector<cv::Point2f> corners_px;
  for (const Eigen::Vector3d& corner_W : objects_[object_index].box.corners()) {
    const Eigen::Vector3d corner_C = T_C_W * corner_W;
    if (corner_C.z() < 1e-3) return 0.0;
    corners_px.emplace_back(static_cast<float>(K.fx * corner_C.x() / corner_C.z() + K.cx),
                            static_cast<float>(K.fy * corner_C.y() / corner_C.z() + K.cy));
  }
  std::vector<cv::Point2f> hull;
  cv::convexHull(corners_px, hull);
  const double area_px = cv::contourArea(hull);
  if (!(area_px > 0.0)) return 0.0;
  const int visible_px = cv::countNonZero(labels == object_index + 1);
  return std::min(1.0, visible_px / area_px);
}

Status SyntheticScene::writeSevenScenes(const std::string& dataset_dir,
                                        const std::string& detections_dir) const {
  if (dataset_dir.empty()) return Status::Error("writeSevenScenes: dataset folder is empty");
  Status status = makeFolder(dataset_dir);
  if (!status) return status;
  if (!detections_dir.empty() && !(status = makeFolder(detections_dir))) return status;
  const fs::path dir(dataset_dir);
  const CameraIntrinsics& K = config_.K;

  status = writeText(dir / "camera-intrinsics.txt",
                     formatNumber(K.fx) + " 0 " + formatNumber(K.cx) + "\n0 " + formatNumber(K.fy) +
                         " " + formatNumber(K.cy) + "\n0 0 1\n");
  if (!status) return status;
  // World z is up: gravity points down.
  if (!(status = writeText(dir / "gravity-direction.txt", "0 0 -1\n"))) return status;

  // The observed surface of each object: its pixels' exact depth, on a 1.5 cm grid.
  std::vector<VoxelAccumulator> surfaces(objects_.size(), VoxelAccumulator(0.015));
  const bool renderable = K.width > 0 && K.height > 0 && K.isValid();
  for (int i = 0; i < config_.num_frames; ++i) {
    RgbdFrame frame;
    cv::Mat labels;
    if (renderable) {
      RenderOutput out;
      renderScene(*this, i, K, /*clutter_ids=*/false, /*sensor_model=*/true, &out);
      frame = toRgbdFrame(*this, i, K, out);
      labels = out.labels;
      const Eigen::Matrix3d R = frame.T_W_D.linear();
      const Eigen::Vector3d t = frame.T_W_D.translation();
      for (int v = 0; v < K.height; ++v) {
        for (int u = 0; u < K.width; ++u) {
          const int label = labels.at<int32_t>(v, u);
          const float z = out.z_m.at<float>(v, u);
          if (label < 1 || !inSensorRange(config_, z, out.cos_incidence.at<float>(v, u))) continue;
          const Eigen::Vector3d p_C((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
          surfaces[label - 1].add(R * p_C + t, cv::Vec3b(), label);
        }
      }
    }
    if (frame.color_bgr.empty()) {
      return Status::Error("writeSevenScenes: cannot render frame " + std::to_string(i) +
                           " (invalid intrinsics " + std::to_string(K.width) + "x" +
                           std::to_string(K.height) + ")");
    }
    const fs::path color_path = dir / (frame.name + ".color.png");
    const fs::path depth_path = dir / (frame.name + ".depth.png");
    bool written = false;
    try {
      written = cv::imwrite(color_path.string(), frame.color_bgr);
    } catch (const cv::Exception&) {
      written = false;
    }
    if (!written) return Status::Error("cannot write " + color_path.string());
    try {
      written = cv::imwrite(depth_path.string(), frame.depth);
    } catch (const cv::Exception&) {
      written = false;
    }
    if (!written) return Status::Error("cannot write " + depth_path.string());

    // 4x4 camera-to-world, row-major, as 7-Scenes.
    const Eigen::Matrix4d T = frame.T_W_D.matrix();
    std::string pose;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) pose += formatNumber(T(r, c)) + (c < 3 ? " " : "\n");
    }
    if (!(status = writeText(dir / (frame.name + ".pose.txt"), pose))) return status;

    if (!detections_dir.empty()) {
      // A detector misses objects that are mostly hidden or out of view; their slivers would also
      // give boxes far from the object's centre.
      std::vector<Detection2D> detections;
      for (Detection2D& detection : detectionsFromLabels(labels)) {
        const int k = objectIndexOfMask(labels, detection.mask);
        if (k >= 0 && visibleFraction(i, labels, k) >= config_.min_visible_fraction) {
          detections.push_back(std::move(detection));
        }
      }
      status = FileInstanceSegmenter::write(detections_dir, frame.name, detections);
      if (!status) return status;
    }
  }

  nlohmann::json objects = nlohmann::json::array();
  std::vector<std::string> point_texts;
  for (size_t k = 0; k < objects_.size(); ++k) {
    const SyntheticObject& object = objects_[k];
    const OrientedBox& box = object.box;
    nlohmann::json rotation = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) {
      rotation.push_back({box.rotation(r, 0), box.rotation(r, 1), box.rotation(r, 2)});
    }
    objects.push_back({{"class_name", object.class_name},
                       {"center", {box.center_m.x(), box.center_m.y(), box.center_m.z()}},
                       {"size", {box.size_m.x(), box.size_m.y(), box.size_m.z()}},
                       {"rotation", rotation},
                       {"yaw", std::atan2(box.rotation(1, 0), box.rotation(0, 0))},
                       {"points", "@POINTS" + std::to_string(k) + "@"}});
    // One compact line of points (millimetres), spliced in below: dump(2) would give each number
    // its own line.
    std::string text = "[";
    char buffer[96];
    for (const VoxelAccumulator::Voxel& voxel : surfaces[k].voxels()) {
      const Eigen::Vector3d p = voxel.sum / voxel.count;
      std::snprintf(buffer, sizeof(buffer), "%s[%.3f,%.3f,%.3f]", text.size() > 1 ? "," : "", p.x(),
                    p.y(), p.z());
      text += buffer;
    }
    point_texts.push_back(text + "]");
  }
  nlohmann::json ground_truth = {{"objects", objects}, {"frames", config_.num_frames}};
  std::string json_text = ground_truth.dump(2) + "\n";
  for (size_t k = 0; k < point_texts.size(); ++k) {
    const std::string placeholder = "\"@POINTS" + std::to_string(k) + "@\"";
    const size_t at = json_text.find(placeholder);
    if (at != std::string::npos) json_text.replace(at, placeholder.size(), point_texts[k]);
  }
  return writeText(dir / "ground_truth.json", json_text);
}

Status SyntheticScene::writeSceneNN(const std::string& sequence_dir, const std::string& id) const {
  if (sequence_dir.empty()) return Status::Error("writeSceneNN: sequence folder is empty");
  if (id.empty() || id.find_first_of("/\\<>\"&") != std::string::npos) {
    return Status::Error("writeSceneNN: bad sequence id '" + id + "'");
  }
  const fs::path dir(sequence_dir);
  Status status;
  for (const fs::path& folder : {dir, dir / "image", dir / "depth", dir / "label"}) {
    if (!(status = makeFolder(folder.string()))) return status;
  }
  // SceneNN's camera, whatever config().K is.
  SyntheticSceneConfig config = config_;
  config.K = sceneNNIntrinsics();
  const SyntheticScene view(config, objects_, clutter_);
  const CameraIntrinsics& K = config.K;
  const Eigen::Matrix3d M = zUpToYUp();

  std::string trajectory, timestamps;
  VoxelAccumulator surface(0.01);
  char buffer[256];
  for (int i = 0; i < config.num_frames; ++i) {
    RenderOutput out;
    renderScene(view, i, K, /*clutter_ids=*/true, /*sensor_model=*/true, &out);
    std::snprintf(buffer, sizeof(buffer), "%05d", i + 1);
    const std::string number = buffer;
    if (!(status = writeImage(dir / "image" / ("image" + number + ".png"), out.color))) {
      return status;
    }
    if (!(status = writeImage(dir / "depth" / ("depth" + number + ".png"), out.depth_mm))) {
      return status;
    }
    cv::Mat labels16;
    out.labels.convertTo(labels16, CV_16UC1);  // saturates; ids stay far below 65535
    if (!(status = writeImage(dir / "label" / ("label" + number + ".png"), labels16))) {
      return status;
    }
    const Eigen::Isometry3d T_W_C = view.cameraPose(i);
    accumulateFrame(config, K, T_W_C, out, out.labels, 0, &surface);

    // Camera -> y-up world.
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    T.topLeftCorner<3, 3>() = M * T_W_C.linear();
    T.topRightCorner<3, 1>() = M * T_W_C.translation();
    trajectory += std::to_string(i) + " " + std::to_string(i) + " " + std::to_string(i + 1) + "\n";
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) trajectory += formatNumber(T(r, c)) + (c < 3 ? " " : "\n");
    }
    const long long stamp_us = std::llround(i * 1e6 / 30.0);
    timestamps += std::to_string(i + 1) + " " + std::to_string(stamp_us) + " " +
                  std::to_string(stamp_us) + "\n";
  }
  if (!(status = writeText(dir / "trajectory.log", trajectory))) return status;
  if (!(status = writeText(dir / "timestamp.txt", timestamps))) return status;
  status =
      writeText(dir / "asus.ini", "fx " + formatNumber(K.fx) + "\nfy " + formatNumber(K.fy) +
                                      "\ncx " + formatNumber(K.cx) + "\ncy " + formatNumber(K.cy) +
                                      "\ndepth_width " + std::to_string(K.width) +
                                      "\ndepth_height " + std::to_string(K.height) + "\n");
  if (!status) return status;

  // Annotation: one label per object and per clutter piece, boxes in the y-up frame.
  std::string xml = "<annotation>\n";
  auto addLabel = [&](int label_id, const SyntheticObject& object) {
    const OrientedBox& box = object.box;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (const Eigen::Vector3d& corner : box.corners()) {
      lo = lo.cwiseMin(M * corner);
      hi = hi.cwiseMax(M * corner);
    }
    const Eigen::Vector3d center = M * box.center_m;
    const Eigen::Quaterniond q(M * box.rotation);
    const cv::Vec3d bgr = classColor(object.class_name);
    xml += "  <label id=\"" + std::to_string(label_id) + "\" text=\"" + object.class_name +
           "\" nyu_class=\"" + nyuClassName(object.class_name) + "\" aabbox=\"";
    for (int a = 0; a < 3; ++a) xml += formatNumber(lo[a]) + " ";
    for (int a = 0; a < 3; ++a) xml += formatNumber(hi[a]) + (a < 2 ? " " : "\" obbox=\"");
    for (int a = 0; a < 3; ++a) xml += formatNumber(center[a]) + " ";
    for (int a = 0; a < 3; ++a) xml += formatNumber(box.size_m[a]) + " ";
    xml += formatNumber(q.x()) + " " + formatNumber(q.y()) + " " + formatNumber(q.z()) + " " +
           formatNumber(q.w()) + "\" color=\"" + std::to_string(static_cast<int>(bgr[2])) + " " +
           std::to_string(static_cast<int>(bgr[1])) + " " +
           std::to_string(static_cast<int>(bgr[0])) + "\"/>\n";
  };
  for (size_t k = 0; k < objects_.size(); ++k) {
    addLabel(sceneNNObjectId(static_cast<int>(k)), objects_[k]);
  }
  for (size_t j = 0; j < clutter_.size(); ++j) {
    addLabel(sceneNNClutterId(static_cast<int>(j)), clutter_[j]);
  }
  xml += "</annotation>\n";
  if (!(status = writeText(dir / (id + ".xml"), xml))) return status;

  // The observed surface as a labelled vertex cloud (binary little-endian PLY).
  std::vector<PlyColoredVertex> vertices;
  vertices.reserve(surface.voxels().size());
  for (const VoxelAccumulator::Voxel& voxel : surface.voxels()) {
    const Eigen::Vector3d p = M * (voxel.sum / voxel.count);
    PlyColoredVertex vertex;
    vertex.xyz[0] = static_cast<float>(p.x());
    vertex.xyz[1] = static_cast<float>(p.y());
    vertex.xyz[2] = static_cast<float>(p.z());
    for (int c = 0; c < 3; ++c) {  // BGR sums -> RGB
      vertex.rgb[c] = static_cast<uint8_t>(voxel.bgr[2 - c] / voxel.count);
    }
    vertex.label = static_cast<uint16_t>(std::clamp(voxel.label, 0, 65535));
    vertices.push_back(vertex);
  }
  const std::string ply = plyBinaryColoredLabelled(
      "synthetic SceneNN-layout sequence (multiview_object_detection), y-up", vertices);
  return writeText(dir / (id + ".ply"), ply);
}

}  // namespace mvod
