// multiview_object_detection/ObjectDetectionNodelet: the node's code in a nodelet, so a camera
// driver in the same manager hands over its images without copies (as depth_image_proc does).
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>
#include <stdexcept>

#include "multiview_object_detection/ros/object_detection_ros.h"

namespace mvod {

class ObjectDetectionNodelet : public nodelet::Nodelet {
 public:
  ~ObjectDetectionNodelet() override {
    if (node_) node_->shutdown();
  }

 private:
  void onInit() override {
    node_ = std::make_unique<ObjectDetectionRos>(getNodeHandle(), getPrivateNodeHandle());
    if (!node_->ok()) {
      const std::string error = node_->startupError();
      node_.reset();
      // The manager refuses to load the nodelet and reports this.
      throw std::runtime_error("ObjectDetectionNodelet: " + error);
    }
  }

  std::unique_ptr<ObjectDetectionRos> node_;
};

}  // namespace mvod

PLUGINLIB_EXPORT_CLASS(mvod::ObjectDetectionNodelet, nodelet::Nodelet)
