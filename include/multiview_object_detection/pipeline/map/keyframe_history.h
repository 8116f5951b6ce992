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
// surface) and the voxel keys it voted against (8 bytes each).
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
  cv::Mat depth;  // a copy of the frame's depth (CV_16UC1 mm or CV_32FC1 m)
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
    // At most this many keyframes keep their depth (the oldest give it up first): the memory bound
    // of a long run. A keyframe without depth still moves its views; what its depth told the map
    // (surface band, free space) is not measured again.
    int max_keyframes_with_depth = 1000;
    Status isValid() const;
    std::string print() const;
  };

  KeyframeHistory() = default;
  explicit KeyframeHistory(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }
  void setConfig(const Config& config);

  void add(KeyframeRecord record);
  const std::deque<KeyframeRecord>& records() const { return records_; }
  std::deque<KeyframeRecord>& mutableRecords() { return records_; }
  bool empty() const { return records_.empty(); }
  void clear() { records_.clear(); }

  // Sets the corrected poses of the keyframes the corrections name (by stamp; several corrections
  // of one keyframe: the last). Returns the indices (into records()) of the keyframes whose pose
  // changed; *unmatched: the corrections that matched no keyframe.
  std::vector<std::size_t> correct(const std::vector<PoseCorrection>& corrections,
                                   std::vector<PoseCorrection>* unmatched);
  std::size_t memoryBytes() const;

 private:
  Config config_;
  std::deque<KeyframeRecord> records_;  // keyframe (processing) order
};

// A recorded view moved by `correction` (the keyframe's), as the fusion takes it: its cut, normals
// and box moved rigidly, its keys on the fusion grid (the cut's from its moved points; the voxels
// it voted against moved by their centres). The identity moves nothing: the same observation as
// when it was recorded.
ObjectObservation replayedObservation(const RecordedView& view, const Eigen::Isometry3d& correction,
                                      double voxel_size_m);

}  // namespace mvod
