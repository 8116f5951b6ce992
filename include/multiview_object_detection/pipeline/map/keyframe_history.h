// What each keyframe contributed to the map, kept so that the map can follow the SLAM's
// corrections. A visual SLAM moves its keyframes at every loop closure and global bundle
// adjustment; the objects were fused from those keyframes' views at the poses they had then. With
// each keyframe's cuts (at the pose they were made with) and its depth image, the map is rebuilt
// from the corrected poses: every view moves rigidly with its keyframe and is fused again, in
// keyframe order, as if the corrected poses had been known from the start (ObjectMapper::
// correctPoses). Not part of the paper.
//
// Memory: per keyframe its depth image (the frame's own buffer: 0.6 MB for 640 x 480 16-bit, 1.2 MB
// for 32-bit) and per detection that made it into the map its cut (a point, 12 bytes, and a normal,
// 12 bytes, per cut point; the cut is voxel-filtered, so about one point per cubic centimetre of
// surface) and the voxel keys it voted against (8 bytes each). Config::max_memory_mb bounds the
// whole (memoryBytes()); past it the oldest keyframes degrade (see Config).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

struct ObjectObservation;

// What a detection's single view cut, at the keyframe's recorded pose: never changed once
// recorded, so records (and the snapshots the node's services save) share it.
struct RecordedCut {
  PointCloud cut_W;                        // ObjectObservation::segment_W
  std::vector<Eigen::Vector3f> normals_W;  // ObjectObservation::segment_normals_W
  std::vector<std::int64_t> outside_keys;  // FusionKeys::outside (voxels seen but not cut)
  double voxel_size_m = 0.0;               // the grid of outside_keys
  std::size_t memoryBytes() const;
};

// One detection's contribution, as its single view made it (at the keyframe's recorded pose).
struct RecordedView {
  int class_id = -1;
  std::string class_name;
  double probability = 0.0;
  OrientedBox box;
  double yaw_rad = 0.0;
  std::shared_ptr<const RecordedCut> cut;  // never null in a record
  // The object the view is part of: a rebuilt object keeps the id most of its views had.
  int object_id = -1;
};

// A keyframe: its poses, its depth and its views. Copies are cheap: the depth image and the cuts
// are shared (neither is changed once recorded).
struct KeyframeRecord {
  int keyframe = 0;  // ObjectMapper's keyframe counter
  double stamp_s = 0.0;
  std::string name;
  Eigen::Isometry3d T_W_D_recorded = Eigen::Isometry3d::Identity();  // the views' pose
  Eigen::Isometry3d T_W_D = Eigen::Isometry3d::Identity();           // the pose now
  Eigen::Isometry3d T_C_D = Eigen::Isometry3d::Identity();           // depth -> colour camera
  CameraIntrinsics K_depth;
  cv::Mat depth;  // a copy of the frame's depth (CV_16UC1 mm or CV_32FC1 m); empty: given up
  bool depth_coarse = false;  // depth (and K_depth) at half resolution (KeyframeHistory's bound)
  // Which data this is, for a map writer that writes each keyframe's data once: a record gets an
  // id unique in the process when it joins a history, and a new revision whenever its depth
  // changes (copies share both, and the data they stand for).
  std::uint64_t uid = 0;
  int revision = 0;
  // A point of the floor layer this keyframe saw, in the depth camera's frame (the floor's height
  // follows the keyframe's pose); valid when has_floor.
  bool has_floor = false;
  Eigen::Vector3d floor_point_D = Eigen::Vector3d::Zero();
  std::vector<RecordedView> views;
  // The refinement (Sec. 3.5) ran after this keyframe's fusion (the node's
  // refine_every_n_keyframes, ~refine): a rebuild refines at the same place, so that the same
  // poses give the same map.
  bool refined_after = false;

  // What moves every recorded world point to where the pose now puts it.
  Eigen::Isometry3d correction() const { return T_W_D * T_W_D_recorded.inverse(); }
  bool corrected() const;
  std::size_t memoryBytes() const;
};

// A corrected camera pose: the keyframe whose images carry this stamp, and its colour camera in
// the world frame (the depth camera follows through the keyframe's T_C_D).
struct PoseCorrection {
  double stamp_s = 0.0;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();
};

// Poses closer than this are the same keyframe pose: a correction that moves a keyframe less
// moves nothing. A pose sent back as it was received differs in its last bits (a quaternion in a
// nav_msgs/Path, six digits in a pose file: 1e-6 m); 0.1 mm and 1e-4 rad (0.45 mm at the 4.5 m
// the existence votes reach) lie far below the depth noise (1.5 mm at 1 m for a Kinect) and the
// 1 cm fusion grid, and far above any rounding.
constexpr double kSamePoseTranslation_m = 1e-4;
constexpr double kSamePoseRotation_rad = 1e-4;
bool isSamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

class KeyframeHistory {
 public:
  struct Config {
    // Off: nothing is kept and corrections are refused (the paper's method keeps nothing).
    bool enable = true;
    // A correction's stamp matches a keyframe whose stamp is within this (s).
    double stamp_tolerance_s = 0.005;
    // The history's memory bound (MB, memoryBytes()). Past it the oldest keyframes degrade until
    // it holds again. While the depth images take more than a quarter of it, the older half of the
    // keyframes that keep one have it at half resolution (16-bit mm, a quarter of the bytes), and
    // the oldest give theirs up (they still move their views; what their depth told the map,
    // surface band, free space, existence votes, is not measured again). Then the oldest
    // keyframes are forgotten (the objects only they saw stay, but no longer move).
    double max_memory_mb = 1024.0;
    Status isValid() const;
    std::string print() const;
  };

  KeyframeHistory() = default;
  explicit KeyframeHistory(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }
  void setConfig(const Config& config);

  // Records `record` as the newest keyframe, then degrades the oldest until the bound holds.
  void add(KeyframeRecord record);
  const std::deque<KeyframeRecord>& records() const { return records_; }
  std::deque<KeyframeRecord>& mutableRecords() { return records_; }
  bool empty() const { return records_.empty(); }
  void clear() {
    records_.clear();
    forgotten_ = 0;
  }

  // Sets the corrected poses of the keyframes the corrections name (by stamp; several corrections
  // of one keyframe: the last). Returns the indices (into records()) of the keyframes whose pose
  // changed; *unmatched: the corrections that matched no keyframe.
  std::vector<std::size_t> correct(const std::vector<PoseCorrection>& corrections,
                                   std::vector<PoseCorrection>* unmatched);
  std::size_t memoryBytes() const;

  // What the history holds and how far it degraded (for /diagnostics and the tools' reports).
  struct Usage {
    std::size_t bytes = 0;        // memoryBytes()
    std::size_t depth_bytes = 0;  // of that, depth images
    std::size_t cut_bytes = 0;    // cut points, normals and voxel keys
    int keyframes = 0;
    int full_depth = 0;    // keyframes with their depth as recorded
    int coarse_depth = 0;  // with it at half resolution
    int views_only = 0;    // without depth
    int forgotten = 0;     // keyframes dropped since the start (or the last clear())
  };
  Usage usage() const;

 private:
  // Degrades the oldest keyframes until memoryBytes() <= the bound (Config::max_memory_mb).
  void enforceBound();
  // The oldest depth image: coarsened (`coarsen`, the oldest full one), else given up.
  void degradeOldestDepth(bool coarsen);

  Config config_;
  std::deque<KeyframeRecord> records_;  // keyframe (processing) order
  int forgotten_ = 0;
};

// `record`'s depth at half resolution (every second pixel of every second row, as 16-bit mm) and
// its intrinsics to match; a depth already coarse (record.depth_coarse) or none is left as it is.
void coarsenDepth(KeyframeRecord* record);

// A recorded view moved by `correction` (the keyframe's), as the fusion takes it: its cut, normals
// and box moved rigidly, its keys on the fusion grid (the cut's from its moved points; the voxels
// it voted against moved by their centres). The identity moves nothing: the same observation as
// when it was recorded.
ObjectObservation replayedObservation(const RecordedView& view, const Eigen::Isometry3d& correction,
                                      double voxel_size_m);

}  // namespace mvod
