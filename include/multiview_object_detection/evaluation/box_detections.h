// Box-only detections made from ground-truth 3D boxes: what a perfect box detector (FastestDet,
// YOLO) would report for one frame. Used to judge the 3D cut and fusion on real depth and poses
// with hand-annotated objects (test/data/7scenes_redkitchen_annotation), without the detector's
// own misses and false positives.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

struct BoxDetectionOptions {
  // A box is reported when its centre projects into the image in front of the camera, and at
  // least this share of its projected 2D box lies inside the image (the reported box is clipped).
  double min_inside_fraction = 0.1;  // low: a close table is mostly outside the image
  double min_depth_m = 0.3;          // every corner at least this far in front of the colour camera
  int min_side_px = 8;
  float score = 0.9f;
};

// The 2D box of each visible ground-truth object in the frame's colour image (T_C_D, K_color,
// T_W_D), its mask the filled box. Class names as in the ground truth.
std::vector<Detection2D> boxDetectionsFromGroundTruth(const std::vector<GroundTruthObject>& truth,
                                                      const RgbdFrame& frame,
                                                      const BoxDetectionOptions& options);

// The detections as FileInstanceSegmenter JSON ([{"class_name", "score", "box": [x1, y1, x2,
// y2]}]).
std::string boxDetectionsToJson(const std::vector<Detection2D>& detections);

}  // namespace mvod
