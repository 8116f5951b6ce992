// A SceneNN sequence after ONI extraction (the layout of hkust-vgd/scenenn's playback tool; see
// shared/formats/scenenn.md):
//   image/imageNNNNN.png   colour (RGB24 PNG, 640x480), NNNNN 1-based, 5 digits
//   depth/depthNNNNN.png   16-bit depth in millimetres, registered to colour by OpenNI
//   trajectory.log         blocks of 5 lines: a header whose first token is the 0-based frame
//   index,
//                          then 4 rows of a 4x4 camera -> world matrix. imageNNNNN.png <-> index
//                          N-1.
//   timestamp.txt          optional; lines "k color_ts depth_ts" (k 1-based, OpenNI microseconds).
//                          Without it, stamps are (k - 1) / 30 s.
//   asus.ini               optional; "key value" lines (also "key = value"; '#'/';' comments and
//                          [sections] ignored). fx, fy, cx, cy are read; each absent key keeps the
//                          value used by every SceneNN tool: fx = fy = 544.47329, cx = 320, cy =
//                          240. Looked for in DIR, DIR/intrinsic and DIR/../intrinsic (the main
//                          repo keeps one intrinsic/asus.ini for all sequences); none found = those
//                          defaults.
// Image sizes: open() reads the first frames' PNG headers (no decoding) to learn the camera's
// image size; load() refuses, before decoding, images of another size or above
// kDefaultMaxImagePixels (io/image_io.h). Colour images without a depth image are skipped with a
// warning (warnings()).
// A frame is listed when depth/depthNNNNN.png exists; checkFrame() (cheap, no image read) and
// load() fail for a frame without a pose (or without a time stamp when timestamp.txt exists), so a
// sequence with more images than poses can still be used up to its last pose.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"

namespace mvod {

class SceneNNDataset {
 public:
  // Asus Xtion intrinsics used by SceneNN (640x480).
  static constexpr double kDefaultFocalPx = 544.47329;
  static constexpr double kDefaultCx = 320.0;
  static constexpr double kDefaultCy = 240.0;
  static constexpr double kDefaultFrameRateHz = 30.0;

  // Lists the frames, reads the intrinsics, trajectory and time stamps; fails on a missing folder,
  // no depth images, a missing or malformed trajectory.log, or a malformed timestamp.txt/asus.ini.
  // Frames without a pose or stamp are found by checkFrame()/load().
  static Status open(const std::string& directory, SceneNNDataset* dataset);

  size_t size() const { return frame_indices_.size(); }
  // 1-based file numbers (depth00001.png -> 1), ascending.
  const std::vector<int>& frameIndices() const { return frame_indices_; }
  static std::string frameName(int index);  // "image00001"
  // The frame has a pose (and a stamp when there are stamps); the message names the file.
  Status checkFrame(int index) const;
  // Loads one frame (images, pose, stamp); the message names the file on any problem. The frame
  // is registered (one camera): K_color = K_depth, T_C_D = identity.
  Status load(int index, RgbdFrame* frame) const;

  const std::string& directory() const { return directory_; }
  const CameraIntrinsics& intrinsics() const { return K_; }
  const std::string& intrinsicsPath() const { return intrinsics_path_; }  // "" = defaults
  bool hasTimestamps() const { return !stamps_s_.empty(); }
  // The frame's stamp as load() gives it; NaN for a frame without one (timestamp.txt lacks it).
  double stampOf(int index) const;
  // What may make the results wrong, found by open() (e.g. frames skipped for a missing depth
  // image).
  const std::vector<std::string>& warnings() const { return warnings_; }

  // File parsers, public for tests. The message names the file.
  // asus.ini -> fx, fy, cx, cy (width/height 0); absent keys keep the defaults above.
  static Status readIntrinsics(const std::string& path, CameraIntrinsics* K);
  // trajectory.log -> pose per 0-based header index (rigid within 1e-2, re-orthonormalised).
  static Status readTrajectory(const std::string& path,
                               std::map<int, Eigen::Isometry3d>* T_W_C_by_index);
  // timestamp.txt -> colour stamp in seconds per 1-based frame number.
  static Status readTimestamps(const std::string& path, std::map<int, double>* stamp_s_by_frame);

 private:
  std::string directory_;
  std::string intrinsics_path_;
  std::vector<int> frame_indices_;
  CameraIntrinsics K_;
  std::map<int, Eigen::Isometry3d> T_W_C_by_index_;
  std::map<int, double> stamps_s_;
  std::vector<std::string> warnings_;
  // The camera's image size (depth and colour are registered) and the file it was read from;
  // empty = unknown (any size within kDefaultMaxImagePixels).
  cv::Size image_size_;
  std::string image_size_source_;
};

// Registers a depth image to the colour camera (what a Kinect driver's depth_registered topic
// holds): each valid depth pixel is back-projected with K_depth, moved by T_C_D (depth camera ->
// colour camera), projected with K_color to its nearest pixel, and the nearest depth wins
// (z-buffer). Output: CV_16UC1 millimetres of K_color.width x K_color.height (both must be > 0); 0
// = no depth. Input: CV_16UC1 millimetres (0 and 65535 = invalid) or CV_32FC1 metres (0/NaN =
// invalid); output depths are clamped to 65534 mm so that none reads as invalid.
Status registerDepthToColor(const cv::Mat& depth_D, const CameraIntrinsics& K_depth,
                            const CameraIntrinsics& K_color, const Eigen::Isometry3d& T_C_D,
                            cv::Mat* depth_C_mm);

}  // namespace mvod
