// dataset_to_bag: a 7-Scenes-layout folder or a SceneNN sequence -> a rosbag with what a Kinect
// driver and an ORB-SLAM2 wrapper would publish, so replay.launch can play it through the node:
//   /<camera>/rgb/image_rect_color          sensor_msgs/Image bgr8 (undistorted: the node's name)
//   /<camera>/depth_registered/image_rect   sensor_msgs/Image 16UC1 (mm), in the colour camera
//   /<camera>/rgb/camera_info                sensor_msgs/CameraInfo (colour K)
//   /<camera>/depth_registered/camera_info   the same K (registered depth)
//   /detections (with --detector)            InstanceDetections of the colour image, for the
//                                            node's detector:=topic (an external detector)
//   /orb_slam2_rgbd/pose                     geometry_msgs/PoseStamped, colour camera in
//   world_frame /tf                                      world_frame -> <camera>_rgb_optical_frame
// all stamped with the dataset's time (7-Scenes: index / rate; SceneNN: timestamp.txt) plus
// --time-offset (default 1 s: rosbag rejects time 0, and tf reads stamp 0 as "latest").
// Where colour and depth come from two cameras (7-Scenes with color-intrinsics.txt) the depth is
// registered to the colour camera (registerDepthToColor), as a driver's depth_registered topic is.
// The bag is written to a temporary name beside OUT.bag and renamed to it only when complete: a
// failure (bad data, a full disk) leaves no bag that looks complete.
// Exit status: 0 done, 1 bad or missing data or the bag could not be written (nothing is left at
// OUT.bag), 2 bad usage.
#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "dataset_to_bag_options.h"
#include "multiview_object_detection/datasets/dataset_source.h"
#include "multiview_object_detection/datasets/scenenn_dataset.h"
#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"
#include "multiview_object_detection/ros/conversions.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

using dataset_to_bag::kExitData;
using dataset_to_bag::kMaxStampS;
using dataset_to_bag::Options;
using dataset_to_bag::parseOptions;
using dataset_to_bag::segmenterOptions;

// The dataset, with what a user must tell the node to replay it.
Status openDataset(const Options& options, DatasetSource* source, std::vector<std::string>* notes) {
  ColorCameraFiles camera;
  camera.color_intrinsics = options.color_intrinsics;
  camera.depth_to_color = options.depth_to_color;
  camera.registered = options.registered;
  Status status = openDatasetSource(options.dataset_dir, options.format, source, camera);
  if (status) status = applyTrajectory(options.trajectory, source);
  if (!status) return status;
  *notes = source->notes;
  if (source->has_gravity) {
    const Eigen::Vector3d& g = source->gravity_down_W;
    char text[160];
    std::snprintf(text, sizeof(text),
                  "give the node gravity_down: [%.4f, %.4f, %.4f] (or gravity_source:=estimate)",
                  g.x(), g.y(), g.z());
    notes->push_back(text);
  }
  if (source->format == "7scenes" || !source->has_timestamps) {
    notes->push_back("frames are stamped at --rate-hz");
  }
  return Status::Ok();
}

sensor_msgs::CameraInfo cameraInfoMsg(const CameraIntrinsics& K, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo msg;
  msg.header = header;
  msg.width = static_cast<uint32_t>(K.width);
  msg.height = static_cast<uint32_t>(K.height);
  msg.distortion_model = "plumb_bob";
  msg.D.assign(5, 0.0);  // the datasets' images are undistorted
  msg.K = {K.fx, 0.0, K.cx, 0.0, K.fy, K.cy, 0.0, 0.0, 1.0};
  msg.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  msg.P = {K.fx, 0.0, K.cx, 0.0, 0.0, K.fy, K.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return msg;
}

// A bar redrawn in place on a terminal; in a log (stderr not a terminal) a line every 10 %.
void printProgress(size_t done, size_t total, double elapsed_s) {
  constexpr int kWidth = 30;
  static const bool terminal = ::isatty(STDERR_FILENO) != 0;
  const double fraction = total == 0 ? 1.0 : static_cast<double>(done) / total;
  if (!terminal) {
    const size_t step = std::max<size_t>(1, total / 10);
    if (done % step != 0 && done != total) return;
    std::fprintf(stderr, "dataset_to_bag: %zu/%zu frames %3d%% %.1f s\n", done, total,
                 static_cast<int>(fraction * 100.0), elapsed_s);
    return;
  }
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(filled, '#');
  bar.resize(kWidth, '.');
  std::fprintf(stderr, "\r[%s] %zu/%zu frames %3d%% %.1f s", bar.c_str(), done, total,
               static_cast<int>(fraction * 100.0), elapsed_s);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

constexpr int kContinue = -1;  // a phase of convert() went through

// The dataset and the frames to convert: those in [--first, --last], each with its files.
int selectFrames(const Options& options, DatasetSource* source, std::vector<int>* indices) {
  std::vector<std::string> notes;
  Status status = openDataset(options, source, &notes);
  if (!status) {
    std::cerr << "dataset_to_bag: " << status.message() << "\n";
    return kExitData;
  }
  // Warnings even with --quiet: they say the bag may not be what was meant.
  for (const std::string& warning : source->warnings) {
    std::cerr << "dataset_to_bag: warning: " << warning << "\n";
  }
  for (int index : source->indices) {
    if (index >= options.first && (options.last < 0 || index <= options.last)) {
      indices->push_back(index);
    }
  }
  if (indices->empty()) {
    std::cerr << "dataset_to_bag: " << options.dataset_dir << ": no frames in the range --first "
              << options.first << " --last " << options.last << " (the dataset has "
              << source->indices.size() << " frames)\n";
    return kExitData;
  }
  for (int index : *indices) {
    status = source->check(index);
    if (!status) {
      std::cerr << "dataset_to_bag: " << status.message() << " (use --first/--last to convert "
                << "the frames that have one)\n";
      return kExitData;
    }
  }
  if (!options.quiet) {
    std::cerr << "dataset_to_bag: " << options.dataset_dir << " (" << source->format << "), "
              << indices->size() << " frames -> " << options.output_path << "\n";
    for (const std::string& note : notes) std::cerr << "dataset_to_bag: " << note << "\n";
  }
  return kContinue;
}

// With --detector: the detector whose detections are recorded.
int createSegmenter(const Options& options, std::unique_ptr<InstanceSegmenter>* segmenter) {
  if (options.detector.empty()) return kContinue;
  const Status status = createBenchmarkSegmenter(segmenterOptions(options), segmenter);
  if (!status) {
    std::cerr << "dataset_to_bag: detector " << options.detector << ": " << status.message()
              << "\n";
    return kExitData;
  }
  if (!options.quiet) {
    std::cerr << "dataset_to_bag: recording " << (*segmenter)->name() << " detections on "
              << options.detections_topic << " (replay with detector:=topic)\n";
  }
  return kContinue;
}

// A frame's stamp in the bag: the dataset's time (or index / --rate-hz) + --time-offset; it must be
// > 0, below 2^31 s and must not go back in time.
Status frameStamp(const Options& options, const DatasetSource& source, const RgbdFrame& frame,
                  double previous_stamp_s, double* stamp_s) {
  const double dataset_stamp_s =
      source.has_timestamps
          ? frame.stamp_s
          : (source.format == "scenenn" ? frame.index - 1 : frame.index) / options.rate_hz;
  *stamp_s = dataset_stamp_s + options.time_offset_s;
  if (!(*stamp_s > 0.0)) {
    return Status::Error(frame.name + ": time stamp " + std::to_string(*stamp_s) +
                         " s is not > 0 (rosbag needs positive times): use --time-offset");
  }
  if (!(*stamp_s < kMaxStampS)) {
    return Status::Error(frame.name + ": time stamp " + std::to_string(*stamp_s) +
                         " s is not below 2^31 s (what ros::Time and the tools reading the bag " +
                         "hold): check the dataset's time stamps, --rate-hz and --time-offset");
  }
  if (*stamp_s < previous_stamp_s) {
    return Status::Error(frame.name + ": time stamp " + std::to_string(*stamp_s) +
                         " s goes back in time (previous frame " +
                         std::to_string(previous_stamp_s) + " s)");
  }
  return Status::Ok();
}

// Depth in the colour camera (16-bit millimetres) and the colour camera's intrinsics.
Status colorCameraDepth(const RgbdFrame& frame, cv::Mat* depth_mm, CameraIntrinsics* K_color) {
  *K_color = frame.registered ? frame.K_depth : frame.K_color;
  K_color->width = frame.color_bgr.cols;
  K_color->height = frame.color_bgr.rows;
  if (!frame.registered) {
    const Status status =
        registerDepthToColor(frame.depth, frame.K_depth, *K_color, frame.T_C_D, depth_mm);
    return status ? Status::Ok() : Status::Error(frame.name + ": " + status.message());
  }
  if (frame.depth.type() == CV_16UC1) {
    *depth_mm = frame.depth;
  } else {
    frame.depth.convertTo(*depth_mm, CV_16UC1, 1e3);  // saturates; NaN -> 0
  }
  return Status::Ok();
}

// --output: a new file or a regular file to replace, in a folder that exists. Anything else (a
// device such as /dev/full, a folder) is refused: the bag goes to a temporary file renamed over it.
Status checkOutputPath(const std::string& output_path, fs::path* target) {
  std::error_code error;
  fs::path path(output_path);
  const fs::file_status status = fs::status(path, error);
  if (fs::exists(status)) {
    if (!fs::is_regular_file(status)) {
      return Status::Error(output_path + ": not a regular file (write the bag to a file)");
    }
    path = fs::canonical(path, error);  // through a link: beside the file it names
    if (error) return Status::Error(output_path + ": " + error.message());
  }
  const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(folder, error)) {
    return Status::Error(output_path + ": folder " + folder.string() + " does not exist");
  }
  *target = path;
  return Status::Ok();
}

// The bag being written: per frame TF, pose, camera infos, images (and detections). It is written
// to a temporary name beside the target and renamed to the target by close(); a failure, or
// leaving before close(), removes it.
class BagWriter {
 public:
  BagWriter(const Options& options, const DatasetSource& source, InstanceSegmenter* segmenter)
      : options_(options),
        source_(source),
        segmenter_(segmenter),
        ns_("/" + options.camera),
        optical_frame_(options.camera + "_rgb_optical_frame") {}
  ~BagWriter() { discard(); }

  int open() {
    const Status target = checkOutputPath(options_.output_path, &target_path_);
    if (!target) {
      std::cerr << "dataset_to_bag: " << target.message() << "\n";
      return kExitData;
    }
    temp_path_ = target_path_.string() + ".partial-" + std::to_string(::getpid());
    bag_ = std::make_unique<rosbag::Bag>();
    try {
      bag_->open(temp_path_.string(), rosbag::bagmode::Write);
      if (options_.lz4) bag_->setCompression(rosbag::compression::LZ4);
    } catch (const std::exception& e) {
      return fail(temp_path_.string() + ": cannot write the bag: " + e.what());
    }
    return kContinue;
  }

  // Frame `index`, the seq-th of the bag.
  int writeFrame(size_t seq, int index) {
    RgbdFrame frame;
    Status status = source_.load(index, &frame);
    if (!status) return fail(status.message());
    double stamp_s = 0.0;
    if (!(status = frameStamp(options_, source_, frame, previous_stamp_s_, &stamp_s))) {
      return fail(status.message());
    }
    previous_stamp_s_ = stamp_s;
    cv::Mat depth_mm;
    CameraIntrinsics K_color;
    if (!(status = colorCameraDepth(frame, &depth_mm, &K_color))) return fail(status.message());
    std_msgs::Header header;
    header.seq = static_cast<uint32_t>(seq);
    header.stamp = ros::Time(stamp_s);
    header.frame_id = optical_frame_;
    try {
      writeCamera(frame, depth_mm, K_color, header);
    } catch (const std::exception& e) {
      return fail(temp_path_.string() + ": cannot write: " + e.what());
    }
    return segmenter_ == nullptr ? kContinue : writeDetections(frame, index, header);
  }

  // Completes the bag and renames it to the target.
  int close() {
    try {
      bag_->close();
    } catch (const std::exception& e) {
      return fail(temp_path_.string() + ": cannot complete the bag: " + e.what());
    }
    bag_.reset();
    std::error_code error;
    fs::rename(temp_path_, target_path_, error);
    if (error) {
      return fail("cannot rename " + temp_path_.string() + " to " + target_path_.string() + ": " +
                  error.message());
    }
    temp_path_.clear();
    return kContinue;
  }

 private:
  // TF and pose first: a node that receives the images can already look the pose up.
  void writeCamera(const RgbdFrame& frame, const cv::Mat& depth_mm, const CameraIntrinsics& K_color,
                   const std_msgs::Header& header) {
    const Eigen::Isometry3d T_W_C = frame.T_W_D * frame.T_C_D.inverse();
    geometry_msgs::PoseStamped pose;
    pose.header = header;
    pose.header.frame_id = options_.world_frame;
    pose.pose = poseToMsg(T_W_C);
    geometry_msgs::TransformStamped transform;
    transform.header = pose.header;
    transform.child_frame_id = optical_frame_;
    transform.transform = transformToMsg(T_W_C);
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(transform);
    bag_->write("/tf", header.stamp, tf);
    bag_->write(options_.pose_topic, header.stamp, pose);
    bag_->write(ns_ + "/rgb/camera_info", header.stamp, cameraInfoMsg(K_color, header));
    bag_->write(ns_ + "/depth_registered/camera_info", header.stamp,
                cameraInfoMsg(K_color, header));
    bag_->write(ns_ + "/rgb/image_rect_color", header.stamp,
                *colorImageToMsg(frame.color_bgr, header));
    bag_->write(ns_ + "/depth_registered/image_rect", header.stamp,
                *cv_bridge::CvImage(header, sensor_msgs::image_encodings::TYPE_16UC1, depth_mm)
                     .toImageMsg());
  }

  int writeDetections(const RgbdFrame& frame, int index, const std_msgs::Header& header) {
    std::vector<Detection2D> detections;
    std::vector<std::string> warnings;
    const Status status =
        segmenter_->detect(frame.color_bgr, source_.frame_name(index), &detections, &warnings);
    if (!status) {
      return fail(frame.name + ": detector " + segmenter_->name() + ": " + status.message());
    }
    if (!options_.quiet) {
      for (const std::string& warning : warnings) {
        std::cerr << "\ndataset_to_bag: " << frame.name << ": " << warning << "\n";
      }
    }
    try {
      bag_->write(options_.detections_topic, header.stamp,
                  detectionsToMsg(detections, frame.color_bgr.size(), header));
    } catch (const std::exception& e) {
      return fail(temp_path_.string() + ": cannot write: " + e.what());
    }
    return kContinue;
  }

  int fail(const std::string& message) {
    if (!options_.quiet) std::cerr << "\n";
    std::cerr << "dataset_to_bag: " << message << " (no bag written to " << options_.output_path
              << ")\n";
    discard();
    return kExitData;
  }

  // Closes and removes the temporary bag, if there is one: no half-written bag is left.
  void discard() {
    if (bag_) {
      try {
        bag_->close();
        bag_.reset();
      } catch (const std::exception&) {
        // A Bag whose close() threw (a full disk) throws again from its destructor, which would
        // end the process in std::terminate: it is left unfreed, reachable from here (not a leak
        // to LeakSanitizer); the process exits right after.
        [[maybe_unused]] static rosbag::Bag* volatile abandoned = nullptr;  // volatile: kept
        abandoned = bag_.release();
      }
    }
    if (!temp_path_.empty()) {
      std::error_code error;
      fs::remove(temp_path_, error);
      temp_path_.clear();
    }
  }

  const Options& options_;
  const DatasetSource& source_;
  InstanceSegmenter* segmenter_;
  const std::string ns_;
  const std::string optical_frame_;
  fs::path target_path_;  // --output (through a link: the file it names)
  fs::path temp_path_;    // the bag being written beside it; empty once renamed or removed
  std::unique_ptr<rosbag::Bag> bag_;
  double previous_stamp_s_ = -1.0;
};

// Writes every selected frame; returns the exit status.
int convert(const Options& options) {
  DatasetSource source;
  std::vector<int> indices;
  int status = selectFrames(options, &source, &indices);
  if (status != kContinue) return status;
  std::unique_ptr<InstanceSegmenter> segmenter;
  if ((status = createSegmenter(options, &segmenter)) != kContinue) return status;
  BagWriter writer(options, source, segmenter.get());
  if ((status = writer.open()) != kContinue) return status;
  const auto start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < indices.size(); ++i) {
    if ((status = writer.writeFrame(i, indices[i])) != kContinue) return status;
    if (!options.quiet) {
      const double elapsed_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      printProgress(i + 1, indices.size(), elapsed_s);
    }
  }
  if ((status = writer.close()) != kContinue) return status;
  if (!options.quiet) {
    std::cerr << "dataset_to_bag: wrote " << indices.size() << " frames to " << options.output_path
              << "\n";
  }
  return 0;
}

}  // namespace
}  // namespace mvod

int main(int argc, char** argv) {
  mvod::Options options;
  const int parsed = mvod::parseOptions(argc, argv, &options);
  if (parsed >= 0) return parsed;
  try {
    return mvod::convert(options);
  } catch (const std::exception& e) {
    // What a phase did not foresee still ends with a message and an exit status, not an abort;
    // the temporary bag is removed on the way out (BagWriter's destructor).
    std::cerr << "\ndataset_to_bag: " << e.what() << " (no bag written to " << options.output_path
              << ")\n";
    return mvod::dataset_to_bag::kExitData;
  }
}
