// Existence evidence: whether an object is still there. A robot maps a home for days; chairs are
// moved, a box is carried out, the detector now and then calls a cabinet a chair. Every keyframe
// whose view could have seen an object votes on it, from its depth at a sample of the object's
// voxels (DepthView::visibility, the model amodal completion uses):
//   - a detection of the keyframe fused into it: for;
//   - the depth lies on it, mostly in view, but no detection fused into it: weakly against (a
//   missed
//     detection, which a weak detector makes often);
//   - the depth lies clearly beyond most of it: strongly against (its place was seen through);
//   - out of the image, beyond the depth range, hidden behind a nearer surface, at depth holes,
//     or too little of it in view: nothing.
// The votes add up as clamped log-odds; an object whose log-odds reach remove_below is gone.
// Several keyframes must agree: from the clamp, one view with a bad pose never removes an object,
// and a keyframe's see-through counts only from another viewpoint than the last one that counted
// (a camera standing still sees the same thing again). The votes come from keyframes whose depth
// agrees with the rest of the map: the more of the confirmed objects one depth image contradicts
// at once, the more likely the image or its pose is wrong rather than the map (faultOdds). A
// keyframe that is more likely wrong than right (depth of 9.9 m everywhere, images from another
// place than the pose) is a sensor or SLAM fault: it does not vote.
// Not part of the paper.
#pragma once

#include <cstdint>
#include <string>

#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// What the keyframes said of one object so far.
struct ExistenceEvidence {
  double log_odds = 0.0;
  std::uint32_t detected = 0;      // keyframes with a detection fused into it
  std::uint32_t missed = 0;        // keyframes that saw it on their depth but did not detect it
  std::uint32_t seen_through = 0;  // keyframes that saw through it
  // Where the last see-through that counted was seen from (camera centre and optical axis, world
  // frame). Not saved with the map: after a load, the next see-through counts.
  bool has_seen_through_view = false;
  Eigen::Vector3d seen_through_camera_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d seen_through_axis_W = Eigen::Vector3d::UnitZ();
  double probability() const;
};

class ExistenceModel {
 public:
  struct Config {
    // Off: objects stay once mapped (the paper's database).
    bool enable = true;
    double detected_log_odds = 0.85;
    // Weak: a box detector such as FastestDet finds a real chair in a quarter of the views that
    // show it (the redkitchen's chairs: 5 of 21).
    double missed_log_odds = -0.1;
    // Misses lower the log-odds to no less than this: alone they never remove an object (from
    // here, two keyframes that see through it do).
    double missed_floor_log_odds = 1.0;
    double seen_through_log_odds = -1.0;
    double min_log_odds = -2.0;
    double max_log_odds = 2.0;
    // Gone at or below this: from max_log_odds, three keyframes that see through the object; from
    // missed_floor_log_odds, two.
    double remove_below = -1.0;
    // Detections that do not repeat: an object detected in at most fade_max_detected keyframes is
    // gone once at least min_votes_for_share keyframes showed it on their depth (detected or
    // missed) and fewer than min_detected_share of them detected it. Objects detected more often
    // go only by the log-odds (a weak detector finds a real chair in few of its views).
    double min_detected_share = 0.15;
    int min_votes_for_share = 8;
    int fade_max_detected = 1;
    // Voxels of the object each keyframe tests (a stride over its voxels), and how many of them a
    // keyframe must see (on its surface or through it) to vote at all.
    int sample_voxels = 400;
    int min_voxels_in_view = 20;
    // ... and which share of the sample.
    double min_in_view_share = 0.5;
    // Seen through: this share of the voxels in view lies in front of the measured depth by more
    // than free_margin_m (plus the view's truncation at their depth).
    double seen_through_share = 0.5;
    double free_margin_m = 0.1;
    // Voxels farther from the camera than this do not vote (depth noise grows with the square of
    // the range).
    double max_depth_m = 4.5;
    Status isValid() const;
    std::string print() const;
  };

  enum class Vote { kNone, kDetected, kMissed, kSeenThrough };
  // What a keyframe's depth says of the map's confirmed objects (detected in at least
  // kConfirmedDetections keyframes) before it votes: how many it shows on their surface, how many
  // it sees through (the depth alone, detections aside).
  struct DepthCheck {
    int on_surface = 0;
    int seen_through = 0;
  };
  static constexpr std::uint32_t kConfirmedDetections = 2;
  // The odds that a keyframe's depth (or its pose) is wrong, given what it says of the confirmed
  // objects: a fault contradicts an object about as often as not (a depth image or a view of
  // another place, q = 0.5); a right keyframe sees through an object only where it left
  // (kChangeRate, per object and view); faults are rare (kFaultOdds a priori). Each object seen
  // through multiplies the odds by q / kChangeRate = 10, each one seen on its surface by
  // (1 - q) / (1 - kChangeRate) = 0.53. Seeing through 1 of 1: 0.2; 2 of 7: 0.08; 3 of 8: 0.8; 4
  // of 8: 15; 9 of 9 (9.9 m everywhere): 2e7.
  static constexpr double kFaultOdds = 0.02 / 0.98;
  static constexpr double kChangeRate = 0.05;
  static double faultOdds(const DepthCheck& check);
  // More likely wrong than right: a sensor or SLAM fault, which neither votes nor is fused. With
  // the constants above: at least 2 objects seen through and at most 1 on their surface, 3 and at
  // most 4, 4 and at most 8, ...
  static bool isFault(const DepthCheck& check) { return faultOdds(check) > 1.0; }
  // A see-through from within this of the last one that counted is the same look again.
  static constexpr double kSameViewpoint_m = 0.1;
  static constexpr double kSameViewpoint_deg = 7.5;

  ExistenceModel() = default;
  explicit ExistenceModel(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // One keyframe's vote on an object with these voxels (world frame; a stride of them is tested)
  // and box; detected: a detection of this keyframe was fused into it.
  Vote vote(const PointCloud& voxels_W, const OrientedBox& box, const DepthView& view,
            bool detected) const;
  // Adds a vote to the evidence (clamped); true when the object is gone. A see-through from the
  // viewpoint (view, when given) of the last one that counted is no vote.
  bool apply(Vote vote, ExistenceEvidence* evidence, const DepthView* view = nullptr) const;
  // Why an object with this evidence is gone, in the user's words.
  std::string goneReason(const ExistenceEvidence& evidence) const;

 private:
  // False when no corner of the box projects into the view's image in front of the camera.
  static bool boxMayBeInView(const OrientedBox& box, const DepthView& view);

  Config config_;
};

}  // namespace mvod
