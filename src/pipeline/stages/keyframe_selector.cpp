#include "multiview_object_detection/pipeline/stages/keyframe_selector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

namespace mvod {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

}  // namespace

Status KeyframeSelector::Config::isValid() const {
  if (Status s = checkParameterRange("keyframe_every_n", every_n); !s) return s;
  if (!(std::isfinite(min_translation_m) && min_translation_m >= 0.0)) {
    return Status::Error("keyframe min_translation_m must be >= 0 (got " +
                         std::to_string(min_translation_m) + ")");
  }
  if (!(std::isfinite(min_rotation_deg) && min_rotation_deg >= 0.0 && min_rotation_deg <= 180.0)) {
    return Status::Error("keyframe min_rotation_deg must be in [0, 180] (got " +
                         std::to_string(min_rotation_deg) + ")");
  }
  if (!(std::isfinite(external_stamp_tolerance_s) && external_stamp_tolerance_s >= 0.0)) {
    return Status::Error("keyframe external_stamp_tolerance_s must be >= 0");
  }
  return Status::Ok();
}

std::string KeyframeSelector::Config::print() const {
  std::ostringstream out;
  out << "mode: " << modeName(mode) << "\n"
      << "every_n: " << every_n << "\n"
      << "min_translation_m: " << min_translation_m << "\n"
      << "min_rotation_deg: " << min_rotation_deg << "\n"
      << "external_stamp_tolerance_s: " << external_stamp_tolerance_s << "\n";
  return out.str();
}

Status KeyframeSelector::modeFromString(const std::string& name, Mode* mode) {
  if (name == "every_n") {
    *mode = Mode::kEveryN;
  } else if (name == "motion") {
    *mode = Mode::kMotion;
  } else if (name == "external" || name == "topic") {
    *mode = Mode::kExternal;
  } else {
    return Status::Error("keyframe mode '" + name + "' is unknown (use every_n, motion or topic)");
  }
  return Status::Ok();
}

std::string KeyframeSelector::modeName(Mode mode) {
  switch (mode) {
    case Mode::kEveryN:
      return "every_n";
    case Mode::kMotion:
      return "motion";
    case Mode::kExternal:
      return "external";
  }
  return "unknown";
}

void KeyframeSelector::motionBetween(const Eigen::Isometry3d& T_W_A, const Eigen::Isometry3d& T_W_B,
                                     double* translation_m, double* rotation_deg) {
  *translation_m = (T_W_B.translation() - T_W_A.translation()).norm();
  const Eigen::Matrix3d R_A_B = T_W_A.linear().transpose() * T_W_B.linear();
  // angle = acos((trace - 1) / 2), clamped against rounding.
  const double c = std::clamp((R_A_B.trace() - 1.0) / 2.0, -1.0, 1.0);
  *rotation_deg = std::acos(c) * kRadToDeg;
}

bool KeyframeSelector::isKeyframe(const Eigen::Isometry3d& T_W_C, double stamp_s) {
  if (!isValidPose(T_W_C) || !std::isfinite(stamp_s)) return false;
  ++frames_seen_;
  last_stamp_s_ = stamp_s;
  bool keyframe = false;
  switch (config_.mode) {
    case Mode::kEveryN:
      keyframe = !has_keyframe_ || frames_since_keyframe_ + 1 >= config_.every_n;
      break;
    case Mode::kMotion: {
      if (!has_keyframe_) {
        keyframe = true;
        break;
      }
      double translation_m = 0.0;
      double rotation_deg = 0.0;
      motionBetween(T_W_last_, T_W_C, &translation_m, &rotation_deg);
      keyframe =
          translation_m >= config_.min_translation_m || rotation_deg >= config_.min_rotation_deg;
      break;
    }
    case Mode::kExternal: {
      const double tol = config_.external_stamp_tolerance_s;
      // Stamps too old for this and any later frame are gone for good.
      while (!external_stamps_s_.empty() && external_stamps_s_.front() < stamp_s - tol) {
        external_stamps_s_.pop_front();
      }
      if (!external_stamps_s_.empty() && external_stamps_s_.front() <= stamp_s + tol) {
        keyframe = true;
        external_stamps_s_.pop_front();
      }
      break;
    }
  }
  if (keyframe) {
    has_keyframe_ = true;
    T_W_last_ = T_W_C;
    frames_since_keyframe_ = 0;
    ++keyframes_selected_;
  } else {
    ++frames_since_keyframe_;
  }
  return keyframe;
}

void KeyframeSelector::addExternalKeyframe(double stamp_s) {
  if (!std::isfinite(stamp_s)) return;
  if (stamp_s < last_stamp_s_ - config_.external_stamp_tolerance_s) return;
  external_stamps_s_.insert(
      std::upper_bound(external_stamps_s_.begin(), external_stamps_s_.end(), stamp_s), stamp_s);
  // Bounded: a keyframe topic without images must not grow this forever.
  constexpr size_t kMaxStamps = 1000;
  while (external_stamps_s_.size() > kMaxStamps) external_stamps_s_.pop_front();
}

bool KeyframeSelector::canDecide(double stamp_s) const {
  if (config_.mode != Mode::kExternal) return true;
  return !external_stamps_s_.empty() &&
         external_stamps_s_.back() >= stamp_s - config_.external_stamp_tolerance_s;
}

void KeyframeSelector::reset() {
  frames_seen_ = 0;
  frames_since_keyframe_ = 0;
  keyframes_selected_ = 0;
  has_keyframe_ = false;
  T_W_last_ = Eigen::Isometry3d::Identity();
  last_stamp_s_ = -1e300;
  external_stamps_s_.clear();
}

}  // namespace mvod
