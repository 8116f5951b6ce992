// Keyframe selection for a live camera stream. ORB-SLAM2's ROS wrappers do not publish their
// keyframes, so the node picks its own: every N-th frame, when the camera has moved enough since
// the last keyframe, or at stamps given from outside (an external keyframe topic). No ROS in here.
#pragma once

#include <deque>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

class KeyframeSelector {
 public:
  enum class Mode {
    kEveryN,    // frames 0, n, 2n, ... of the frames with a valid pose
    kMotion,    // the first frame, then whenever translation or rotation since the last keyframe
                // reaches its threshold
    kExternal,  // frames whose stamp matches a stamp given to addExternalKeyframe()
  };

  struct Config {
    Mode mode = Mode::kMotion;
    int every_n = 10;
    double min_translation_m = 0.2;
    double min_rotation_deg = 15.0;
    // External keyframe stamps match a frame within this time (s).
    double external_stamp_tolerance_s = 0.005;
    Status isValid() const;
    std::string print() const;
  };

  // "every_n", "motion", "external" (or its ROS name "topic") -> Mode; an error names the choices.
  static Status modeFromString(const std::string& name, Mode* mode);
  static std::string modeName(Mode mode);

  KeyframeSelector() = default;
  explicit KeyframeSelector(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }
  // Thresholds changed at run time (dynamic reconfigure); the last keyframe and counters are kept.
  void setConfig(const Config& config) { config_ = config; }

  // Decides for one frame; frames must come in stamp order. A frame with an invalid pose (NaN,
  // non-orthonormal rotation) is never a keyframe and does not count.
  bool isKeyframe(const Eigen::Isometry3d& T_W_C, double stamp_s);

  // kExternal: a keyframe stamp from outside (any order; stamps older than the last decided frame
  // are ignored).
  void addExternalKeyframe(double stamp_s);
  // kExternal: true once isKeyframe can decide this stamp for good, i.e. a keyframe stamp at or
  // after it (within tolerance) has been seen. Other modes: always true.
  bool canDecide(double stamp_s) const;

  // Forgets the last keyframe, counters and external stamps.
  void reset();

  int framesSeen() const { return frames_seen_; }
  int keyframesSelected() const { return keyframes_selected_; }
  bool hasKeyframe() const { return has_keyframe_; }
  const Eigen::Isometry3d& lastKeyframePose() const { return T_W_last_; }

  // Motion between two poses: translation (m) and rotation angle (deg).
  static void motionBetween(const Eigen::Isometry3d& T_W_A, const Eigen::Isometry3d& T_W_B,
                            double* translation_m, double* rotation_deg);

 private:
  Config config_;
  int frames_seen_ = 0;
  int frames_since_keyframe_ = 0;
  int keyframes_selected_ = 0;
  bool has_keyframe_ = false;
  Eigen::Isometry3d T_W_last_ = Eigen::Isometry3d::Identity();
  double last_stamp_s_ = -1e300;
  std::deque<double> external_stamps_s_;  // sorted
};

}  // namespace mvod
