// How well a frame's colour image lines up with its depth projected into the colour camera
// (K_color, T_C_D): the check of a two-camera calibration (a Kinect without hardware registration,
// 7-Scenes' colour camera). The depth image's occluding edges (the near side of each jump) are
// projected into the colour image and shifted until they lie closest to its Canny edges; the
// shift is how far the calibration is off at that frame, in colour pixels (0 = right; du > 0: the
// colour image lies right of the projected depth). One frame's shift is noisy (texture edges,
// unsynchronised cameras): take the median over many frames.
#pragma once

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

struct RegistrationCheckConfig {
  double depth_jump_m = 0.08;  // a depth edge: neighbours this much apart
  int max_shift_px = 25;       // shifts searched, each way
  double truncate_px = 8.0;    // an edge point's distance counts at most this much
  int min_edge_points = 200;   // fewer in the colour image: no measurement
  double canny_low = 40.0;     // on the colour image blurred with sigma 1.2 px
  double canny_high = 100.0;
};

struct RegistrationShift {
  bool valid = false;  // enough depth edges landed in the colour image
  int du_px = 0;       // the shift of the projected depth edges onto the colour edges
  int dv_px = 0;
  double mean_distance_px = 0.0;  // at that shift (truncated)
  int edge_points = 0;
};

// `frame`: colour (CV_8UC3) and depth (16UC1 mm or 32FC1 m), K_depth, K_color, T_C_D.
RegistrationShift measureRegistrationShift(const RgbdFrame& frame,
                                           const RegistrationCheckConfig& config = {});

}  // namespace mvod
