// Ray casting of a SyntheticScene: each pixel's ray meets the room (walls, floor, ceiling) or the
// nearest solid part of an object or clutter piece; colour by flat class colours with Lambertian
// shading, depth by the configured sensor model (depth_sensor_model.h).
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/rgbd_frame.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace simulation {

struct RenderOutput {
  cv::Mat color;          // CV_8UC3 BGR
  cv::Mat depth_mm;       // CV_16UC1: the sensor's depth (noise model applied)
  cv::Mat z_m;            // CV_32FC1: exact ray depth, 0 = no hit within kMaxDepthM
  cv::Mat cos_incidence;  // CV_32FC1: |cos| of the angle between the ray and the surface normal
  cv::Mat labels;         // CV_32SC1
};

// Flat BGR colour of a class; unknown classes get a colour from their name.
cv::Vec3d classColor(const std::string& class_name);

// Ray casts one frame. clutter_ids: clutter k gets label objects.size() + 1 + k (else 0).
// sensor_model: apply the configured noise model to depth_mm (else the exact depth in mm).
void renderScene(const SyntheticScene& scene, int frame, const CameraIntrinsics& K,
                 bool clutter_ids, bool sensor_model, RenderOutput* out);

// A rendered frame as the pipeline's input: named frame-NNNNNN, stamped at 30 Hz, depth registered
// to colour, posed at scene.cameraPose(index).
RgbdFrame toRgbdFrame(const SyntheticScene& scene, int index, const CameraIntrinsics& K,
                      const RenderOutput& out);

}  // namespace simulation
}  // namespace mvod
