// Is the SLAM's TF stamped with its images' stamps? A visual SLAM's pose belongs to the image it
// tracked and carries that image's stamp (appliedAI's orb_slam2_ros does this). A wrapper that
// stamps its TF when it publishes it (ethz-asl/orb_slam_2_ros, from a 100 Hz timer at
// ros::Time::now()) gives a look-up at an image's stamp the pose of an image tracked one tracking
// time later, and nothing in one look-up shows it. This check watches the moving transforms out
// of the world frame: when none of the last kWindow of one of them carries the stamp of an image
// the node received while kMinImages or more images came, and nearly all were stamped at the moment
// they arrived, it says so.
#pragma once

#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <string>

namespace mvod {

class TfStampCheck {
 public:
  explicit TfStampCheck(std::string world_frame);

  // A colour image's stamp (the RGB-D callback's thread).
  void addImage(double stamp_s);
  // A transform of /tf (not /tf_static) and the clock when it arrived (the TF thread). Only those
  // whose parent is the world frame are kept.
  void addTransform(const std::string& parent, const std::string& child, double stamp_s,
                    double received_s);
  // Empty while the stamps look right or too little was seen; otherwise what is wrong, the
  // evidence, and what to do.
  std::string problem() const;

  // Transforms of one child judged at a time (the most recent ones).
  static constexpr std::size_t kWindow = 50;
  // A transform carries an image's stamp when they are this close.
  static constexpr double kSameStampS = 0.001;
  // "Stamped when published": the stamp within this of the arrival (on one machine, loaded too).
  static constexpr double kPublishedWithinS = 0.05;
  // The share of the window that must look published.
  static constexpr double kPublishedShare = 0.9;
  // Images within the window's stamps needed to judge it.
  static constexpr std::size_t kMinImages = 10;
  static constexpr std::size_t kMaxImages = 300;

 private:
  struct Stamps {
    double stamp_s;
    double received_s;
  };
  std::string judge(const std::string& child, const std::deque<Stamps>& window) const;

  const std::string world_frame_;
  mutable std::mutex mutex_;
  std::set<double> images_s_;  // the last kMaxImages colour stamps
  std::deque<double> image_order_s_;
  std::map<std::string, std::deque<Stamps>> transforms_;  // by child frame
};

}  // namespace mvod
