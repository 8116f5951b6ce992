#include "multiview_object_detection/simulation/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "multiview_object_detection/simulation/depth_sensor_model.h"

namespace mvod {
namespace simulation {
namespace {

const cv::Vec3d kStandColor(45, 60, 80);  // the tv stand (unlabelled clutter)

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

std::string frameName(int index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "frame-%06d", index);
  return buffer;
}

// Where a ray meets the scene first: the distance along the ray (in units of the ray direction),
// the surface normal, its flat colour and label.
struct RayHit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();
  cv::Vec3d base = cv::Vec3d(0, 0, 0);
  int label = 0;
};

// The solid parts of the objects (label k + 1 for objects()[k]) and of the clutter, prepared for
// the camera T_W_C.
std::vector<CastBox> castBoxes(const SyntheticScene& scene, const Eigen::Isometry3d& T_W_C,
                               const CameraIntrinsics& K, bool clutter_ids) {
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
  return boxes;
}

// The room is a box seen from inside: the ray leaves it through a wall, the floor or the ceiling.
void hitRoom(const Eigen::Vector3d& room_max, const Eigen::Vector3d& origin_W,
             const Eigen::Vector3d& dir_W, RayHit* ray) {
  const Eigen::Vector3d room_min(0.0, 0.0, 0.0);
  for (int a = 0; a < 3; ++a) {
    if (std::abs(dir_W[a]) < 1e-12) continue;
    const double bound = dir_W[a] > 0.0 ? room_max[a] : room_min[a];
    const double t = (bound - origin_W[a]) / dir_W[a];
    if (t > 0.0 && t < ray->t) {
      const Eigen::Vector3d hit = origin_W + t * dir_W;
      bool inside = true;
      for (int b = 0; b < 3; ++b) {
        if (b != a && (hit[b] < room_min[b] - 1e-9 || hit[b] > room_max[b] + 1e-9)) {
          inside = false;
        }
      }
      if (!inside) continue;
      ray->t = t;
      ray->normal_W = Eigen::Vector3d::Zero();
      ray->normal_W[a] = dir_W[a] > 0.0 ? -1.0 : 1.0;
      if (a == 2) {
        if (dir_W[a] < 0.0) {
          // Floor: a faint 0.5 m checker gives the colour image some texture.
          const int cell = static_cast<int>(std::floor(hit.x() / 0.5)) +
                           static_cast<int>(std::floor(hit.y() / 0.5));
          ray->base = (cell & 1) ? kFloorColor * 0.92 : kFloorColor;
        } else {
          ray->base = kCeilingColor;
        }
      } else {
        ray->base = kWallColors[2 * a + (dir_W[a] > 0.0 ? 1 : 0)];
      }
    }
  }
}

// The nearest box the ray enters before ray->t. (u, v): the pixel, dir_C: its ray in the camera.
void hitBoxes(const std::vector<CastBox>& boxes, int u, int v, const Eigen::Vector3d& dir_C,
              RayHit* ray) {
  for (const CastBox& box : boxes) {
    if (!box.pixels.contains(cv::Point(u, v))) continue;
    const Eigen::Vector3d dir_B = box.R_B_C * dir_C;
    double t = 0.0;
    int axis = 0;
    int side = 1;
    if (enterBox(box.origin_B, dir_B, box.half_m, &t, &axis, &side) && t < ray->t) {
      ray->t = t;
      ray->normal_W = side * box.R_W_B.col(axis);
      ray->base = box.color;
      ray->label = box.label;
    }
  }
}

// Colour, exact depth, incidence and label of every pixel (no sensor model).
void castRays(const SyntheticSceneConfig& config, const std::vector<CastBox>& boxes,
              const Eigen::Isometry3d& T_W_C, const CameraIntrinsics& K, RenderOutput* out) {
  const int width = K.width;
  const int height = K.height;
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
      RayHit ray;
      hitRoom(room_max, origin_W, dir_W, &ray);
      hitBoxes(boxes, u, v, dir_C, &ray);
      const double t_best = ray.t;
      if (std::isfinite(t_best) && t_best <= kMaxDepthM) {
        depth_row[u] = static_cast<uint16_t>(std::lround(t_best * 1000.0));
        z_row[u] = static_cast<float>(t_best);
        cos_row[u] = static_cast<float>(std::abs(ray.normal_W.dot(dir_W)) / dir_W.norm());
        color_row[u] = shade(ray.base, ray.normal_W);
        label_row[u] = ray.label;
      } else {
        depth_row[u] = 0;
        z_row[u] = 0.0f;
        cos_row[u] = 0.0f;
        color_row[u] = cv::Vec3b(0, 0, 0);
        label_row[u] = 0;
      }
    }
  }
  out->color = color;
  out->depth_mm = depth;
  out->z_m = z_image;
  out->cos_incidence = cos_image;
  out->labels = label_image;
}

}  // namespace

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

void renderScene(const SyntheticScene& scene, int frame, const CameraIntrinsics& K,
                 bool clutter_ids, bool sensor_model, RenderOutput* out) {
  const Eigen::Isometry3d T_W_C = scene.cameraPose(frame);
  castRays(scene.config(), castBoxes(scene, T_W_C, K, clutter_ids), T_W_C, K, out);
  // Sensor imperfections, seeded per frame so a frame always looks the same.
  if (sensor_model) {
    applyDepthNoise(scene.config(), frame, out->z_m, out->cos_incidence, &out->depth_mm);
  }
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

}  // namespace simulation
}  // namespace mvod
