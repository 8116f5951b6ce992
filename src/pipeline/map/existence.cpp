#include "multiview_object_detection/pipeline/map/existence.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace mvod {

double ExistenceEvidence::probability() const { return 1.0 / (1.0 + std::exp(-log_odds)); }

Status ExistenceModel::Config::isValid() const {
  const auto finite = [](double v) { return std::isfinite(v); };
  if (!(finite(detected_log_odds) && detected_log_odds >= 0.0 && detected_log_odds <= 10.0)) {
    return Status::Error("detected_log_odds must be in [0, 10]");
  }
  if (!(finite(missed_log_odds) && missed_log_odds <= 0.0 && missed_log_odds >= -10.0)) {
    return Status::Error("missed_log_odds must be in [-10, 0]");
  }
  if (!(finite(seen_through_log_odds) && seen_through_log_odds <= 0.0 &&
        seen_through_log_odds >= -10.0)) {
    return Status::Error("seen_through_log_odds must be in [-10, 0]");
  }
  if (!(finite(min_log_odds) && finite(max_log_odds) && min_log_odds < 0.0 && max_log_odds > 0.0 &&
        min_log_odds >= -100.0 && max_log_odds <= 100.0)) {
    return Status::Error("min_log_odds must be in [-100, 0) and max_log_odds in (0, 100]");
  }
  if (!(finite(remove_below) && remove_below > min_log_odds && remove_below < max_log_odds)) {
    return Status::Error("remove_below must lie between min_log_odds and max_log_odds");
  }
  if (!(finite(missed_floor_log_odds) && missed_floor_log_odds >= min_log_odds &&
        missed_floor_log_odds <= max_log_odds)) {
    return Status::Error("missed_floor_log_odds must lie between min_log_odds and max_log_odds");
  }
  if (!(finite(min_detected_share) && min_detected_share >= 0.0 && min_detected_share <= 1.0)) {
    return Status::Error("min_detected_share must be in [0, 1]");
  }
  if (min_votes_for_share < 1 || min_votes_for_share > 100000) {
    return Status::Error("min_votes_for_share must be in [1, 100000]");
  }
  if (fade_max_detected < 0 || fade_max_detected > 100000) {
    return Status::Error("fade_max_detected must be in [0, 100000]");
  }
  if (sample_voxels < 1 || sample_voxels > 100000) {
    return Status::Error("sample_voxels must be in [1, 100000] (got " +
                         std::to_string(sample_voxels) + ")");
  }
  if (min_voxels_in_view < 1 || min_voxels_in_view > sample_voxels) {
    return Status::Error("min_voxels_in_view must be in [1, sample_voxels]");
  }
  for (const double share : {min_in_view_share, seen_through_share}) {
    if (!(finite(share) && share > 0.0 && share <= 1.0)) {
      return Status::Error("min_in_view_share and seen_through_share must be in (0, 1]");
    }
  }
  if (!(finite(free_margin_m) && free_margin_m >= 0.0 && free_margin_m <= 2.0)) {
    return Status::Error("free_margin_m must be in [0, 2] m");
  }
  if (!(finite(max_depth_m) && max_depth_m > 0.1 && max_depth_m <= 100.0)) {
    return Status::Error("max_depth_m must be in (0.1, 100] m");
  }
  return Status::Ok();
}

std::string ExistenceModel::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "detected_log_odds: " << detected_log_odds << "\n"
      << "missed_log_odds: " << missed_log_odds << "\n"
      << "missed_floor_log_odds: " << missed_floor_log_odds << "\n"
      << "seen_through_log_odds: " << seen_through_log_odds << "\n"
      << "min_log_odds: " << min_log_odds << "\n"
      << "max_log_odds: " << max_log_odds << "\n"
      << "remove_below: " << remove_below << "\n"
      << "min_detected_share: " << min_detected_share << "\n"
      << "min_votes_for_share: " << min_votes_for_share << "\n"
      << "fade_max_detected: " << fade_max_detected << "\n"
      << "sample_voxels: " << sample_voxels << "\n"
      << "min_voxels_in_view: " << min_voxels_in_view << "\n"
      << "min_in_view_share: " << min_in_view_share << "\n"
      << "seen_through_share: " << seen_through_share << "\n"
      << "free_margin_m: " << free_margin_m << "\n"
      << "max_depth_m: " << max_depth_m << "\n";
  return out.str();
}

bool ExistenceModel::boxMayBeInView(const OrientedBox& box, const DepthView& view) {
  const int width = view.depth_m.cols;
  const int height = view.depth_m.rows;
  double u_min = 1e18, u_max = -1e18, v_min = 1e18, v_max = -1e18;
  for (const Eigen::Vector3d& corner_W : box.corners()) {
    const Eigen::Vector3d p_D = view.T_D_W * corner_W;
    if (!(p_D.z() > 1e-3)) return true;  // reaches behind the camera: let the voxels decide
    const double u = view.K.fx * p_D.x() / p_D.z() + view.K.cx;
    const double v = view.K.fy * p_D.y() / p_D.z() + view.K.cy;
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  return u_max >= 0.0 && v_max >= 0.0 && u_min < width && v_min < height;
}

ExistenceModel::Vote ExistenceModel::vote(const PointCloud& voxels_W, const OrientedBox& box,
                                          const DepthView& view, bool detected) const {
  if (detected) return Vote::kDetected;
  if (voxels_W.empty() || view.depth_m.empty() || !boxMayBeInView(box, view)) return Vote::kNone;
  const std::size_t stride =
      std::max<std::size_t>(1, (voxels_W.size() + config_.sample_voxels - 1) /
                                   static_cast<std::size_t>(config_.sample_voxels));
  int sampled = 0;
  int on_surface = 0;
  int seen_free = 0;
  for (std::size_t i = 0; i < voxels_W.size(); i += stride) {
    ++sampled;
    const Eigen::Vector3f& p_W = voxels_W[i];
    if ((view.T_D_W * p_W.cast<double>()).z() > config_.max_depth_m) continue;
    switch (view.visibility(p_W, config_.free_margin_m)) {
      case DepthView::Visibility::kOnSurface:
        ++on_surface;
        break;
      case DepthView::Visibility::kSeenFree:
        ++seen_free;
        break;
      default:
        break;  // not in view, or hidden: nothing
    }
  }
  const int in_view = on_surface + seen_free;
  if (in_view < config_.min_voxels_in_view || in_view < config_.min_in_view_share * sampled) {
    return Vote::kNone;
  }
  if (seen_free >= config_.seen_through_share * in_view) return Vote::kSeenThrough;
  return Vote::kMissed;
}

double ExistenceModel::faultOdds(const DepthCheck& check) {
  constexpr double kFaultContradicts = 0.5;  // q
  return kFaultOdds * std::pow(kFaultContradicts / kChangeRate, check.seen_through) *
         std::pow((1.0 - kFaultContradicts) / (1.0 - kChangeRate), check.on_surface);
}

bool ExistenceModel::apply(Vote vote, ExistenceEvidence* evidence, const DepthView* view) const {
  if (vote == Vote::kSeenThrough && view != nullptr) {
    const Eigen::Isometry3d T_W_D = view->T_D_W.inverse();
    const Eigen::Vector3d camera_W = T_W_D.translation();
    const Eigen::Vector3d axis_W = T_W_D.linear().col(2);
    if (evidence->has_seen_through_view &&
        (camera_W - evidence->seen_through_camera_W).norm() < kSameViewpoint_m &&
        axis_W.dot(evidence->seen_through_axis_W) > std::cos(kSameViewpoint_deg * M_PI / 180.0)) {
      vote = Vote::kNone;  // the same look again
    } else {
      evidence->has_seen_through_view = true;
      evidence->seen_through_camera_W = camera_W;
      evidence->seen_through_axis_W = axis_W;
    }
  }
  double change = 0.0;
  switch (vote) {
    case Vote::kDetected:
      change = config_.detected_log_odds;
      ++evidence->detected;
      break;
    case Vote::kMissed:
      change = config_.missed_log_odds;
      ++evidence->missed;
      break;
    case Vote::kSeenThrough:
      change = config_.seen_through_log_odds;
      ++evidence->seen_through;
      break;
    case Vote::kNone:
      break;
  }
  double log_odds = evidence->log_odds + change;
  if (vote == Vote::kMissed) {
    log_odds = std::max(log_odds, std::min(evidence->log_odds, config_.missed_floor_log_odds));
  }
  evidence->log_odds = std::clamp(log_odds, config_.min_log_odds, config_.max_log_odds);
  if (!config_.enable) return false;
  if (evidence->log_odds <= config_.remove_below) return true;
  const std::uint32_t votes = evidence->detected + evidence->missed;
  return evidence->detected <= static_cast<std::uint32_t>(config_.fade_max_detected) &&
         votes >= static_cast<std::uint32_t>(config_.min_votes_for_share) &&
         evidence->detected < config_.min_detected_share * votes;
}

std::string ExistenceModel::goneReason(const ExistenceEvidence& evidence) const {
  const std::uint32_t showed = evidence.detected + evidence.missed;
  if (evidence.log_odds > config_.remove_below) {
    return "a detection that did not repeat: detected in " + std::to_string(evidence.detected) +
           " of the " + std::to_string(showed) + " keyframes whose depth showed it";
  }
  return "its place was seen through: by " + std::to_string(evidence.seen_through) +
         " keyframes (detected in " + std::to_string(evidence.detected) + ")";
}

}  // namespace mvod
