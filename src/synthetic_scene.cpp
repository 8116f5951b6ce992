#include "multiview_object_detection/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>

#include "multiview_object_detection/class_priors.h"
#include "multiview_object_detection/file_instance_segmenter.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxDepthM = 10.0;  // farther hits read as 0 (no measurement), like a Kinect

double deg2rad(double deg) { return deg * kPi / 180.0; }

// splitmix64: a tiny portable generator, so a seed gives the same scene and noise on every
// platform and standard library (std::normal_distribution is implementation defined).
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Standard normal (Box-Muller).
  double gaussian() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  uint64_t state_;
};

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

// Flat BGR colour of a class; unknown classes get a colour from their name.
cv::Vec3d classColor(const std::string& class_name) {
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

const cv::Vec3d kStandColor(45, 60, 80);     // the tv stand (unlabelled clutter)
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
std::vector<OrientedBox> clutterBoxes(const std::vector<SyntheticObject>& objects) {
  std::vector<OrientedBox> clutter;
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
    clutter.push_back(stand);
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

}  // namespace

SyntheticScene::SyntheticScene(const SyntheticSceneConfig& config,
                               std::vector<SyntheticObject> objects)
    : config_(config), objects_(std::move(objects)) {}

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
  objects.push_back({"dining table", makeBox(table_xy, 0.0, table_size, table_yaw)});

  const Eigen::Matrix2d R_table = yawRotation(table_yaw).topLeftCorner<2, 2>();
  const double chair_offsets_deg[4] = {6.0, -5.0, 8.0, -7.0};
  const Eigen::Vector2d chair_slots[4] = {
      {-0.42, -0.92}, {0.42, -0.92}, {-0.42, 0.92}, {0.42, 0.92}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d offset_T = chair_slots[k] + Eigen::Vector2d(jitter(0.015), jitter(0.015));
    // Chairs face the table: their x axis along the table's, plus a small own yaw.
    const double yaw = table_yaw + deg2rad(chair_offsets_deg[k] + jitter(1.5));
    objects.push_back({"chair", makeBox(table_xy + R_table * offset_T, 0.0,
                                        Eigen::Vector3d(0.5, 0.5, 0.9), yaw)});
  }

  // The couch right of the centre, its back to the dining group, facing the tv corner.
  const Eigen::Vector2d couch_xy = room_center + Eigen::Vector2d(1.45 + jitter(0.03), jitter(0.05));
  objects.push_back({"couch", makeBox(couch_xy, 0.0, Eigen::Vector3d(2.0, 0.9, 0.85),
                                      deg2rad(90.0 + jitter(2.0)))});

  // The tv on its stand (clutterBoxes) in the corner the couch faces, clear of the camera loop.
  // Yaw 135 deg: the screen normal (box y axis) points along the room diagonal, into the room.
  const double tv_yaw = deg2rad(135.0);
  const Eigen::Vector2d tv_normal(-std::sin(tv_yaw), std::cos(tv_yaw));
  const Eigen::Vector2d tv_back =
      Eigen::Vector2d(room_x - 0.5, room_y - 0.5) + jitter(0.05) * Eigen::Vector2d(-1.0, 1.0);
  objects.push_back(
      {"tv", makeBox(tv_back + 0.05 * tv_normal, 0.5, Eigen::Vector3d(1.0, 0.1, 0.6), tv_yaw)});

  // Two cups and a book on the table top, away from its edges.
  const double top_z = table_size.z();
  const Eigen::Vector2d cup_slots[2] = {{-0.45, -0.15}, {0.35, 0.2}};
  for (const Eigen::Vector2d& slot : cup_slots) {
    const Eigen::Vector2d xy =
        table_xy + R_table * (slot + Eigen::Vector2d(jitter(0.03), jitter(0.03)));
    objects.push_back({"cup", makeBox(xy, top_z, Eigen::Vector3d(0.08, 0.08, 0.1),
                                      table_yaw + deg2rad(jitter(20.0)))});
  }
  const Eigen::Vector2d book_xy =
      table_xy + R_table * Eigen::Vector2d(0.05 + jitter(0.03), -0.12 + jitter(0.03));
  objects.push_back({"book", makeBox(book_xy, top_z, Eigen::Vector3d(0.22, 0.16, 0.04),
                                     table_yaw + deg2rad(25.0 + jitter(10.0)))});
  return SyntheticScene(config, std::move(objects));
}

Eigen::Isometry3d SyntheticScene::cameraPose(int frame) const {
  // A robot driving an ellipse around the room centre, its camera turned towards the centre: every
  // object inside the loop is seen from all sides over one lap.
  const int frames = std::max(1, config_.num_frames);
  const double angle = kPi + 2.0 * kPi * static_cast<double>(frame) / frames;
  const Eigen::Vector2d center(0.5 * config_.room_size_x_m, 0.5 * config_.room_size_y_m);
  const double radius_x = std::max(0.5, 0.5 * config_.room_size_x_m - 0.6);
  const double radius_y = std::max(0.5, 0.5 * config_.room_size_y_m - 0.6);
  const Eigen::Vector3d position(center.x() + radius_x * std::cos(angle),
                                 center.y() + radius_y * std::sin(angle), config_.camera_height_m);
  const double yaw = std::atan2(center.y() - position.y(), center.x() - position.x());
  const double pitch = deg2rad(config_.camera_pitch_deg);

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
  const int width = K.width;
  const int height = K.height;
  if (rgbd == nullptr && labels == nullptr) return;
  if (width <= 0 || height <= 0 || !K.isValid()) {
    if (rgbd != nullptr) *rgbd = RgbdFrame();
    if (labels != nullptr) *labels = cv::Mat();
    return;
  }
  const Eigen::Isometry3d T_W_C = cameraPose(frame);

  std::vector<CastBox> boxes;
  for (size_t k = 0; k < objects_.size(); ++k) {
    boxes.push_back(prepare(objects_[k].box, T_W_C, K, classColor(objects_[k].class_name),
                            static_cast<int>(k) + 1));
  }
  for (const OrientedBox& clutter : clutterBoxes(objects_)) {
    boxes.push_back(prepare(clutter, T_W_C, K, kStandColor, 0));
  }
  // The room is a box seen from inside: the ray leaves it through a wall, the floor or the ceiling.
  const Eigen::Vector3d room_min(0.0, 0.0, 0.0);
  const Eigen::Vector3d room_max(config_.room_size_x_m, config_.room_size_y_m,
                                 config_.room_height_m);
  const Eigen::Vector3d origin_W = T_W_C.translation();
  const Eigen::Matrix3d R_W_C = T_W_C.linear();

  cv::Mat color(height, width, CV_8UC3);
  cv::Mat depth(height, width, CV_16UC1);
  cv::Mat label_image(height, width, CV_32SC1);
  for (int v = 0; v < height; ++v) {
    cv::Vec3b* color_row = color.ptr<cv::Vec3b>(v);
    uint16_t* depth_row = depth.ptr<uint16_t>(v);
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
        color_row[u] = shade(base, normal_W);
        label_row[u] = label;
      } else {
        depth_row[u] = 0;
        color_row[u] = cv::Vec3b(0, 0, 0);
        label_row[u] = 0;
      }
    }
  }

  // Sensor imperfections, seeded per frame so a frame always looks the same.
  const bool noisy = config_.depth_noise_m_per_m2 > 0.0;
  const bool holes = config_.hole_fraction > 0.0;
  if (noisy || holes) {
    Rng rng(mixSeed(mixSeed(config_.seed, 0xde97), static_cast<uint64_t>(frame)));
    for (int v = 0; v < height; ++v) {
      uint16_t* depth_row = depth.ptr<uint16_t>(v);
      for (int u = 0; u < width; ++u) {
        const double hole_draw = holes ? rng.uniform() : 1.0;
        const double noise_draw = noisy ? rng.gaussian() : 0.0;
        if (depth_row[u] == 0) continue;
        if (holes && hole_draw < config_.hole_fraction) {
          depth_row[u] = 0;
          continue;
        }
        if (noisy) {
          const double z = depth_row[u] * 1e-3;
          const double noisy_z = z + config_.depth_noise_m_per_m2 * z * z * noise_draw;
          const long mm = std::lround(noisy_z * 1000.0);
          depth_row[u] = static_cast<uint16_t>(std::clamp<long>(mm, 1, 65535));
        }
      }
    }
  }

  if (rgbd != nullptr) {
    *rgbd = RgbdFrame();
    rgbd->index = frame;
    rgbd->name = frameName(frame);
    rgbd->stamp_s = frame / 30.0;
    rgbd->color_bgr = color;
    rgbd->depth = depth;
    rgbd->K_depth = K;
    rgbd->K_color = K;
    rgbd->registered = true;
    rgbd->T_C_D = Eigen::Isometry3d::Identity();
    rgbd->T_W_D = T_W_C;
  }
  if (labels != nullptr) *labels = label_image;
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

  for (int i = 0; i < config_.num_frames; ++i) {
    RgbdFrame frame;
    cv::Mat labels;
    render(i, &frame, &labels);
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
  for (const SyntheticObject& object : objects_) {
    const OrientedBox& box = object.box;
    nlohmann::json rotation = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) {
      rotation.push_back({box.rotation(r, 0), box.rotation(r, 1), box.rotation(r, 2)});
    }
    objects.push_back({{"class_name", object.class_name},
                       {"center", {box.center_m.x(), box.center_m.y(), box.center_m.z()}},
                       {"size", {box.size_m.x(), box.size_m.y(), box.size_m.z()}},
                       {"rotation", rotation},
                       {"yaw", std::atan2(box.rotation(1, 0), box.rotation(0, 0))}});
  }
  nlohmann::json ground_truth = {{"objects", objects}, {"frames", config_.num_frames}};
  return writeText(dir / "ground_truth.json", ground_truth.dump(2) + "\n");
}

}  // namespace mvod
