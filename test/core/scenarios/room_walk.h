// A rendered room walked in laps, as a robot maps a home: the default synthetic room, its camera
// loop at a reduced resolution, perfect detections from the label images. Each keyframe can be
// given a drifted pose (a visual SLAM's error) and rendered from another scene (the room changed
// between laps).
#pragma once

#include <cmath>
#include <functional>
#include <vector>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace test {

// Keyframes per lap of the scenario tests: 30 degrees apart.
constexpr int kFramesPerLap = 12;

// The default room at 320 x 240 with light Kinect-like noise; frames_per_lap frames per lap.
inline SyntheticSceneConfig walkConfig(int frames_per_lap) {
  SyntheticSceneConfig config;
  config.num_frames = frames_per_lap;
  config.K = CameraIntrinsics{262.5, 262.5, 159.5, 119.5, 320, 240};
  config.depth_noise_m_per_m2 = 0.0015;
  return config;
}

// SLAM-like drift: nothing at the lap's first frame, `translation_m` (along the world's y) and
// `yaw_deg` (about the world's up, z, through the first camera) at its last.
struct Drift {
  double translation_m = 0.36;
  double yaw_deg = 4.0;
  Eigen::Isometry3d at(double share, const Eigen::Vector3d& pivot_W) const {
    Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
    drift.linear() =
        Eigen::AngleAxisd(yaw_deg * share * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
    drift.translation() =
        pivot_W - drift.linear() * pivot_W + Eigen::Vector3d(0.0, translation_m * share, 0.0);
    return drift;
  }
};

// Frame `lap_frame` of a lap of `scene`, with its perfect detections; stamp = keyframe index.
inline void renderKeyframe(const SyntheticScene& scene, int lap_frame, int keyframe,
                           RgbdFrame* frame, std::vector<Detection2D>* detections) {
  cv::Mat labels;
  scene.render(lap_frame, frame, &labels);
  frame->index = keyframe;
  frame->stamp_s = keyframe;
  frame->name = "keyframe " + std::to_string(keyframe);
  *detections = scene.detectionsFromLabels(labels, 80);
}

// The objects of a mapper, by id.
inline std::vector<MapObject> objectsOf(const ObjectMapper& mapper) {
  std::vector<MapObject> objects;
  for (const auto& entry : mapper.database().objects()) objects.push_back(entry.second);
  return objects;
}

// The largest distance, over the objects of `expected`, to the nearest same-class object of
// `actual` (box centre and size); infinity when a class has fewer objects in `actual`.
struct MapDifference {
  double centre_m = 0.0;
  double size_m = 0.0;
  int missing = 0;  // objects of `expected` without a same-class counterpart
  int extra = 0;    // objects of `actual` not matched
};
inline MapDifference compareMaps(const std::vector<MapObject>& expected,
                                 const std::vector<MapObject>& actual) {
  MapDifference difference;
  std::vector<bool> used(actual.size(), false);
  for (const MapObject& e : expected) {
    int best = -1;
    double best_d = 1e9;
    for (std::size_t i = 0; i < actual.size(); ++i) {
      if (used[i] || actual[i].class_name != e.class_name) continue;
      const double d = (actual[i].box.center_m - e.box.center_m).norm();
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    if (best < 0) {
      ++difference.missing;
      continue;
    }
    used[best] = true;
    difference.centre_m = std::max(difference.centre_m, best_d);
    // Box axes may be listed in another order: compare sorted extents.
    Eigen::Vector3d a = actual[best].box.size_m;
    Eigen::Vector3d b = e.box.size_m;
    std::sort(a.data(), a.data() + 3);
    std::sort(b.data(), b.data() + 3);
    difference.size_m = std::max(difference.size_m, (a - b).cwiseAbs().maxCoeff());
  }
  for (const bool u : used) difference.extra += u ? 0 : 1;
  return difference;
}

}  // namespace test
}  // namespace mvod
