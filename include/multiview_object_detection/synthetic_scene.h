// A small deterministic synthetic indoor scene with known oriented boxes, rendered to RGB-D frames
// with instance labels by ray casting. Used by the tests, `make demo` and the benchmarks: it has
// ground truth.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detection.h"
#include "multiview_object_detection/oriented_box.h"
#include "multiview_object_detection/rgbd_frame.h"

namespace mvod {

struct SyntheticObject {
  std::string class_name;
  OrientedBox box;  // world frame, z up
};

struct SyntheticSceneConfig {
  unsigned int seed = 1;
  // Floor [0, x] x [0, y] at z = 0, walls around, ceiling at room_height. 7 x 5.5 m keeps the
  // camera loop (0.6 m inside the walls) about 0.5 m or more from the furniture in the middle.
  double room_size_x_m = 7.0;
  double room_size_y_m = 5.5;
  double room_height_m = 2.6;
  int num_frames = 60;
  double camera_height_m = 1.2;   // robot-mounted camera looking roughly level
  double camera_pitch_deg = -20;  // negative = looking down
  CameraIntrinsics K{525.0, 525.0, 319.5, 239.5, 640, 480};
  double depth_noise_m_per_m2 = 0.0;  // Kinect-like noise sigma = k * z^2 (0 = clean)
  double hole_fraction = 0.0;         // random invalid depth pixels
  // writeSevenScenes' detections skip objects of which less than this fraction is visible (hidden
  // behind others or cut by the image border), as a real detector would miss them; their slivers
  // (a chair's top behind the table) would also give boxes far from the object. 0 = every object
  // with a visible pixel.
  double min_visible_fraction = 0.35;
};

class SyntheticScene {
 public:
  // The default scene: a table, chairs around it, a couch, a tv on a stand, cups and a book on the
  // table.
  static SyntheticScene makeDefault(const SyntheticSceneConfig& config);
  SyntheticScene(const SyntheticSceneConfig& config, std::vector<SyntheticObject> objects);

  const std::vector<SyntheticObject>& objects() const { return objects_; }
  const SyntheticSceneConfig& config() const { return config_; }
  // Camera (optical frame: z forward, y down) to world for frame i: a loop around the room centre.
  Eigen::Isometry3d cameraPose(int frame) const;
  // Renders frame i: 16-bit mm depth, BGR colour, and a label image (CV_32SC1: 0 = background/room
  // and the tv stand, k = objects()[k-1]). Either output may be null.
  void render(int frame, RgbdFrame* rgbd, cv::Mat* labels) const;
  // Perfect detections from a label image (masks of visible pixels, min_pixels or more).
  std::vector<Detection2D> detectionsFromLabels(const cv::Mat& labels, int min_pixels = 200) const;
  // Visible pixels of objects()[object_index] in frame i's label image over the area of its whole
  // projected box (in [0, 1]; 0 when the box reaches behind the camera or the index is invalid).
  double visibleFraction(int frame, const cv::Mat& labels, int object_index) const;

  // Writes frames in the 7-Scenes layout to `dataset_dir` and (if not empty) perfect detections
  // with mask PNGs to `detections_dir` (objects at least config.min_visible_fraction visible), plus
  // ground_truth.json with the boxes.
  Status writeSevenScenes(const std::string& dataset_dir, const std::string& detections_dir) const;

 private:
  SyntheticSceneConfig config_;
  std::vector<SyntheticObject> objects_;
};

}  // namespace mvod
