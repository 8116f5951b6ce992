// What the pinhole intrinsics of an RGB-D camera can be, checked against the image they describe:
// the one check of the node's camera_info (ros/conversions) and of the datasets' intrinsics files
// (offline_detection, dataset_to_bag).
#pragma once

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// A K from another camera or a typo misplaces every object, and a K far too wide blows up the
// cloud (fx = fy = 30 px on 640x480, 169 x 166 degrees, made one keyframe take 40 s and 6.7 GB).
// RGB-D cameras see about 45-120 degrees across; the bounds leave room on both sides.
constexpr double kMinHorizontalFovDeg = 20.0;
constexpr double kMaxHorizontalFovDeg = 150.0;
constexpr double kMinVerticalFovDeg = 10.0;
constexpr double kMaxVerticalFovDeg = 150.0;

// K against its width x height image: K's own size, when it has one, the image's; fx, fy > 0 and
// finite; the principal point inside the image; the fields of view within the bounds above. The
// message says what is wrong; the caller names the camera (topic, file).
Status checkIntrinsicsForImage(const CameraIntrinsics& K, int width, int height);

}  // namespace mvod
