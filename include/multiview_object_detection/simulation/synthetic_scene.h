// A small deterministic synthetic indoor scene with known oriented boxes, rendered to RGB-D frames
// with instance labels by ray casting. Used by the tests, `make demo` and the benchmarks: it has
// ground truth. The rest of simulation/ builds it: rooms and furniture, the renderer, the depth
// sensor model, the dataset writers.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/detection.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"
#include "multiview_object_detection/pipeline/types/rgbd_frame.h"
#include "multiview_object_detection/simulation/depth_sensor_model.h"

namespace mvod {

struct SyntheticObject {
  // COCO class of an object ("chair", "dining table" ...); for clutter (SyntheticScene::clutter())
  // its SceneNN label text ("shelf", "tv stand", "night stand").
  std::string class_name;
  // World frame, z up: the ground-truth box. It contains every part: the tightest box in the
  // object's yaw.
  OrientedBox box;
  // The solid boxes the object is built of (seat, back and legs of a chair ...), world frame, each
  // rendered with the object's label. Empty: `box` is the object's one part.
  std::vector<OrientedBox> parts;
};

// The parts of an object (`box` alone when it has no parts).
std::vector<OrientedBox> solidParts(const SyntheticObject& object);

// The room kinds of SyntheticScene::makeRoom.
enum class RoomType { kLivingRoom, kBedroom, kDiningRoom, kCloseUp };
// One of the living room, bedroom and dining room (never kCloseUp: seeds keep their rooms).
RoomType roomTypeFromSeed(unsigned int seed);
const char* roomTypeName(RoomType type);  // "living", "bedroom", "dining", "close"

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
  // Robot-like trajectory: the loop runs camera_loop_inset_m inside the walls; with camera_wobble
  // the height, yaw and pitch also wobble smoothly (sums of sines, whole cycles per lap, phases
  // from the seed) by up to about these amplitudes.
  double camera_loop_inset_m = 0.6;
  bool camera_wobble = false;
  double wobble_height_m = 0.04;
  double wobble_yaw_deg = 6.0;
  double wobble_pitch_deg = 2.5;
  DepthNoiseModel noise_model = DepthNoiseModel::kQuadratic;
  double depth_noise_m_per_m2 = 0.0;  // kQuadratic: noise sigma = k * z^2 (0 = clean)
  double hole_fraction = 0.0;         // random invalid depth pixels (both models)
  KinectDepthModel kinect;            // kKinect
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
  // A furnished room built from multi-part furniture, deterministic for config.seed (layout,
  // counts, sizes, yaws):
  //   living room: a couch facing a tv on a stand, a bookshelf with books, chairs, a side table
  //                with a cup or a book;
  //   bedroom:     a bed with a night stand (a book, a cup), a bookshelf with books, maybe a chair
  //                and a tv on a stand;
  //   dining room: a dining table with 4 to 6 chairs, cups and books on it, a refrigerator, a
  //                bookshelf with books or a tv on a stand;
  //   close-up:    a couch and a table with chairs, cups and books in the middle of a 4.6-5.0 x
  //                4.0-4.4 m room, the camera loop 0.4 m inside the walls and pitched 20-25 deg
  //                down: the furniture, about 1 m away on the near side, fills the view.
  // Shelves, stands and night stands are clutter(). Nothing interpenetrates; every footprint keeps
  // >= 0.35 m from the camera loop. The config's room size, camera height, pitch, loop inset and
  // wobble are replaced by the room's (rooms of 5.0-6.4 x 4.4-5.4 m, camera at 1.0-1.3 m pitched
  // 12-18 deg down, wobbling); the rest (frames, intrinsics, noise) is kept.
  static SyntheticScene makeRoom(const SyntheticSceneConfig& config, RoomType type);
  // Clutter: every tv gets a stand (the default scene's).
  SyntheticScene(const SyntheticSceneConfig& config, std::vector<SyntheticObject> objects);
  SyntheticScene(const SyntheticSceneConfig& config, std::vector<SyntheticObject> objects,
                 std::vector<SyntheticObject> clutter);

  const std::vector<SyntheticObject>& objects() const { return objects_; }
  // Scenery that is no detector class (shelves, stands): rendered with label 0 by render(), with
  // its own SceneNN label by writeSceneNN.
  const std::vector<SyntheticObject>& clutter() const { return clutter_; }
  const SyntheticSceneConfig& config() const { return config_; }
  // Camera (optical frame: z forward, y down) to world for frame i: a loop around the room centre.
  Eigen::Isometry3d cameraPose(int frame) const;
  // Renders frame i: 16-bit mm depth (the configured noise model), BGR colour, and a label image
  // (CV_32SC1: 0 = background/room and clutter, k = objects()[k-1]). Either output may be null.
  void render(int frame, RgbdFrame* rgbd, cv::Mat* labels) const;
  // Perfect detections from a label image (masks of visible pixels, min_pixels or more).
  std::vector<Detection2D> detectionsFromLabels(const cv::Mat& labels, int min_pixels = 200) const;
  // Visible pixels of objects()[object_index] in frame i's label image over the area of its whole
  // projected box (in [0, 1]; 0 when the box reaches behind the camera or the index is invalid).
  double visibleFraction(int frame, const cv::Mat& labels, int object_index) const;

  // Writes frames in the 7-Scenes layout to `dataset_dir` and (if not empty) perfect detections
  // with mask PNGs to `detections_dir` (objects at least config.min_visible_fraction visible), plus
  // ground_truth.json with the boxes.
  // Each object of ground_truth.json also has "points": its observed surface, the noise-free
  // back-projected pixels of all frames within the sensor's range, one point (the mean) per 1.5 cm
  // voxel, in millimetres precision.
  Status writeSevenScenes(const std::string& dataset_dir, const std::string& detections_dir) const;

  // SceneNN's intrinsics (fx = fy = 544.47329, cx = 320, cy = 240, 640x480).
  static CameraIntrinsics sceneNNIntrinsics();
  // Label ids of writeSceneNN: objects()[k] -> k + 1, clutter()[j] -> objects().size() + 1 + j.
  int sceneNNObjectId(int object_index) const { return object_index + 1; }
  int sceneNNClutterId(int clutter_index) const {
    return static_cast<int>(objects_.size()) + 1 + clutter_index;
  }
  // Writes the frames as a SceneNN sequence (shared/formats/scenenn.md; SceneNNDataset reads it,
  // loadSceneNNGroundTruth its <id>.ply/<id>.xml when the folder is named <id>) into sequence_dir,
  // rendered with sceneNNIntrinsics() whatever config().K is. The world frame is y-up, like
  // SceneNN's meshes: a z-up point (x, y, z) is written as (x, z, -y).
  //   image/imageNNNNN.png   colour; NNNNN = frame + 1
  //   depth/depthNNNNN.png   16-bit millimetres (the configured noise model)
  //   label/labelNNNNN.png   16-bit instance labels: the XML label id of the object or clutter
  //                          seen at the pixel (whether or not it has depth), 0 = floor, walls,
  //                          ceiling
  //   trajectory.log         5-line blocks "i i i+1" + 4x4 camera (optical) -> world, i = frame
  //   timestamp.txt          "NNNNN color_us depth_us", 30 Hz from 0
  //   asus.ini               fx, fy, cx, cy, depth_width, depth_height
  //   <id>.xml               <annotation><label id text nyu_class aabbox obbox color/>...: text =
  //                          the COCO class (clutter: "shelf", "tv stand" ...), nyu_class = the
  //                          NYU name (sofa, table, television, books, refridgerator ...), aabbox
  //                          and obbox ("cx cy cz dx dy dz qx qy qz qw") of the true box
  //   <id>.ply               binary little-endian vertices x y z (float), red green blue (uchar),
  //                          label (ushort, 0 = room): the observed surface, the noise-free
  //                          back-projected pixels of all frames within the sensor's range, one
  //                          vertex per 1 cm voxel (mean position and colour, majority label)
  Status writeSceneNN(const std::string& sequence_dir, const std::string& id) const;

 private:
  SyntheticSceneConfig config_;
  std::vector<SyntheticObject> objects_;
  std::vector<SyntheticObject> clutter_;
};

}  // namespace mvod
