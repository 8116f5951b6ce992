#include "multiview_object_detection/ros/tf_stamp_check.h"

#include <cmath>
#include <cstdio>
#include <iterator>
#include <utility>

namespace mvod {

TfStampCheck::TfStampCheck(std::string world_frame) : world_frame_(std::move(world_frame)) {}

void TfStampCheck::addImage(double stamp_s) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!images_s_.insert(stamp_s).second) return;
  image_order_s_.push_back(stamp_s);
  if (image_order_s_.size() > kMaxImages) {
    images_s_.erase(image_order_s_.front());
    image_order_s_.pop_front();
  }
}

void TfStampCheck::addTransform(const std::string& parent, const std::string& child, double stamp_s,
                                double received_s) {
  // tf2 frame names may carry a leading '/' (tf1 style).
  const std::string bare = !parent.empty() && parent[0] == '/' ? parent.substr(1) : parent;
  if (bare != world_frame_) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  std::deque<Stamps>& window = transforms_[child];
  window.push_back({stamp_s, received_s});
  if (window.size() > kWindow) window.pop_front();
}

std::string TfStampCheck::problem() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [child, window] : transforms_) {
    std::string text = judge(child, window);
    if (!text.empty()) return text;
  }
  return "";
}

std::string TfStampCheck::judge(const std::string& child, const std::deque<Stamps>& window) const {
  if (window.size() < kWindow) return "";
  // Judged only where images came while these transforms did, kMinImages of them or more (a
  // camera that stopped, or a bag of keyframes with a pose for every frame, says nothing).
  const auto first = images_s_.lower_bound(window.front().stamp_s - kSameStampS);
  const auto last = images_s_.upper_bound(window.back().stamp_s + kSameStampS);
  if (std::distance(first, last) < static_cast<std::ptrdiff_t>(kMinImages)) return "";
  std::size_t published = 0;
  for (const Stamps& transform : window) {
    const auto next = images_s_.lower_bound(transform.stamp_s - kSameStampS);
    if (next != images_s_.end() && *next <= transform.stamp_s + kSameStampS) return "";
    if (std::abs(transform.received_s - transform.stamp_s) <= kPublishedWithinS) ++published;
  }
  if (published < kPublishedShare * window.size()) return "";
  char text[600];
  std::snprintf(text, sizeof(text),
                "TF '%s' -> '%s' looks stamped when it was published, not with its images' "
                "stamps: none of its last %zu transforms carries the stamp of a colour image, "
                "and %zu arrived within %.0f ms of their stamp. A look-up at an image's stamp then "
                "returns the pose of a later "
                "image. ethz-asl/orb_slam_2_ros does this: use appliedAI's orb_slam2_ros "
                "(kinect_orbslam2.launch), or its pose per image on the pose topic with "
                "pose_source topic (docs/live_camera.md)",
                world_frame_.c_str(), child.c_str(), window.size(), published,
                1000.0 * kPublishedWithinS);
  return text;
}

}  // namespace mvod
