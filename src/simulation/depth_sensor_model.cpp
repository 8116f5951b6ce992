#include "multiview_object_detection/simulation/depth_sensor_model.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "multiview_object_detection/simulation/scene_geometry.h"
#include "multiview_object_detection/simulation/split_mix.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace simulation {
namespace {

using Rng = SplitMix64;

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

// Quadratic model: sigma = depth_noise_m_per_m2 * z^2, plus hole_fraction random holes.
void applyQuadraticNoise(const SyntheticSceneConfig& config, int frame, cv::Mat* depth) {
  const int height = depth->rows;
  const int width = depth->cols;
  const bool noisy = config.depth_noise_m_per_m2 > 0.0;
  const bool holes = config.hole_fraction > 0.0;
  if (noisy || holes) {
    Rng rng(mixSeed(mixSeed(config.seed, 0xde97), static_cast<uint64_t>(frame)));
    for (int v = 0; v < height; ++v) {
      uint16_t* depth_row = depth->ptr<uint16_t>(v);
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
}

// The Kinect model (KinectDepthModel's steps 1-6).
void applyKinectNoise(const SyntheticSceneConfig& config, int frame, const cv::Mat& z_image,
                      const cv::Mat& cos_image, cv::Mat* depth) {
  const int height = depth->rows;
  const int width = depth->cols;
  Rng rng(mixSeed(mixSeed(config.seed, 0x41c7), static_cast<uint64_t>(frame)));
  const cv::Mat invalid = kinectDropouts(config.kinect, z_image, cos_image, &rng);
  for (int v = 0; v < height; ++v) {
    uint16_t* depth_row = depth->ptr<uint16_t>(v);
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

}  // namespace

// Whether the sensor could measure the exact depth z at this incidence: the pixels that make up the
// observed surface (ground-truth points, the SceneNN mesh).
bool inSensorRange(const SyntheticSceneConfig& config, float z, float cos_incidence) {
  if (!(z > 0.0f)) return false;
  if (config.noise_model != DepthNoiseModel::kKinect) return z <= kMaxDepthM;
  const KinectDepthModel& model = config.kinect;
  return z >= model.min_depth_m && z <= model.max_depth_m &&
         cos_incidence >= std::cos(deg2rad(model.max_incidence_deg));
}

void applyDepthNoise(const SyntheticSceneConfig& config, int frame, const cv::Mat& z_m,
                     const cv::Mat& cos_incidence, cv::Mat* depth_mm) {
  if (config.noise_model == DepthNoiseModel::kQuadratic) {
    applyQuadraticNoise(config, frame, depth_mm);
  } else if (config.noise_model == DepthNoiseModel::kKinect) {
    applyKinectNoise(config, frame, z_m, cos_incidence, depth_mm);
  }
}

}  // namespace simulation
}  // namespace mvod
