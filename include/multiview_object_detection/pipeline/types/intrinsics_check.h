// What the pinhole intrinsics of an RGB-D camera can be, checked against the image they describe:
// the one check of the node's camera_info (ros/conversions) and of the datasets' intrinsics files
// (offline_detection, dataset_to_bag).
#pragma once

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// A K from another camera or a typo misplaces every object, and a K far too wide blows up the
// cloud (fx = fy = 30 px on 640x480, 169 x 166 degrees, made one keyframe take 40 s and 6.7 GB;
// fx = 100, 145 x 135 degrees, 1.5-2.5 s in issue 48's test). RGB-D cameras see from about 60
// degrees across (Kinect v1: 62 x 48 colour, 58 x 45 depth; Asus Xtion, Structure Sensor, Orbbec
// Astra about the same) to 120 (Azure Kinect's depth camera in its wide mode, WFOV: 120 x 120;
// RealSense D435/D455 depth 87 x 58, Kinect v2 70 x 60). The widest bound is the widest camera's
// 120 degrees with 10 to spare for calibration and crops (fx 149 px on 640 px); the narrowest
// leaves room for a crop of a narrow camera (a third of Kinect v1's 62 degrees, half of its 45 up
// and down).
constexpr double kMinHorizontalFovDeg = 20.0;
constexpr double kMaxHorizontalFovDeg = 130.0;
constexpr double kMinVerticalFovDeg = 10.0;
constexpr double kMaxVerticalFovDeg = 130.0;

// K against its width x height image: K's own size, when it has one, the image's; fx, fy > 0 and
// finite; the principal point inside the image; the fields of view within the bounds above. The
// message says what is wrong; the caller names the camera (topic, file).
Status checkIntrinsicsForImage(const CameraIntrinsics& K, int width, int height);

}  // namespace mvod
