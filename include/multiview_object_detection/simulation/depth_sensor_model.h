// The simulated depth sensor: what it reports of the exact ray-cast depth (noise, holes,
// dropouts), and which pixels it can measure at all.
#pragma once

#include <opencv2/core.hpp>

namespace mvod {

enum class DepthNoiseModel {
  kQuadratic,  // sigma = depth_noise_m_per_m2 * z^2, plus hole_fraction random holes
  kKinect,     // KinectDepthModel: the Kinect v1 / Asus Xtion structured-light sensor
};

// A Kinect v1-like depth sensor, applied to the exact ray-cast depth in this order:
struct KinectDepthModel {
  // 1. Range: no depth (0) nearer than min_depth_m or beyond max_depth_m (the projected pattern is
  //    too faint farther away).
  double min_depth_m = 0.4;
  double max_depth_m = 5.0;
  // 2. Grazing angles: no depth where the ray meets the surface at more than max_incidence_deg
  //    from its normal (the pattern smears out).
  double max_incidence_deg = 80.0;
  // 3. IR shadow / edge dropout: a pixel on the far side of a depth discontinuity (a 4-neighbour is
  //    nearer by more than shadow_jump_m) and 0 to shadow_max_px - 1 more pixels beyond it, away
  //    from the edge (1 to shadow_max_px in all, drawn per edge pixel), read 0.
  double shadow_jump_m = 0.1;
  int shadow_max_px = 3;
  // 4. Random holes: SyntheticSceneConfig::hole_fraction of the remaining pixels read 0.
  // 5. Axial noise (Nguyen, Izadi, Lovell 2012): gaussian with sigma(z) = sigma_base_m +
  //    sigma_quadratic_per_m * (z - sigma_offset_m)^2 metres (6 mm at 2 m, 19 mm at 4 m).
  double sigma_base_m = 0.0012;
  double sigma_quadratic_per_m = 0.0019;
  double sigma_offset_m = 0.4;
  // 6. Disparity quantisation: depth comes from an integer disparity d = round(1 / (k z)), so only
  //    the depths 1 / (k d) occur, steps of about k z^2 (11 mm at 2 m, 46 mm at 4 m for Kinect v1:
  //    k = 2.85e-3 per metre). 0 = no quantisation. Then rounding to millimetres.
  double quantization_per_m = 2.85e-3;
};

struct SyntheticSceneConfig;

namespace simulation {

constexpr double kMaxDepthM = 10.0;  // farther hits read as 0 (no measurement), like a Kinect

// Whether the sensor could measure the exact depth z at this incidence: the pixels that make up the
// observed surface (ground-truth points, the SceneNN mesh).
bool inSensorRange(const SyntheticSceneConfig& config, float z, float cos_incidence);

// The configured noise model (config.noise_model) applied to frame `frame`'s depth_mm (CV_16UC1,
// the exact depth in millimetres), seeded per frame so a frame always looks the same. z_m and
// cos_incidence (CV_32FC1): the exact ray depth and |cos| of the incidence angle per pixel.
void applyDepthNoise(const SyntheticSceneConfig& config, int frame, const cv::Mat& z_m,
                     const cv::Mat& cos_incidence, cv::Mat* depth_mm);

}  // namespace simulation
}  // namespace mvod
