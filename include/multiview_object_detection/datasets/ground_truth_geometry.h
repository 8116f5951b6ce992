// Geometry of ground-truth objects: the surface of a box, the gravity-aligned box of a cloud.
#pragma once

#include <Eigen/Core>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// Points on the box surface, on a grid of `spacing_m`; the face whose outward normal is -up is left
// out (it rests on the floor or is seen by no camera above it, and the ground-truth mesh has none).
PointCloud sampleBoxSurface(const OrientedBox& box, double spacing_m, const Eigen::Vector3d& up_W);

// Gravity-aligned box of a cloud (an object's observed surface): the yaw of the surfaces' Manhattan
// frame (Eq. 3, as the predictions' boxes), the extents min/max, third column = up_W. A partly seen
// object shows two perpendicular faces: their minimum-area rectangle would be diagonal and wrong,
// their normals give the object's axes. Where the normals show no box structure (cylinders, too few
// points), the minimum-area rectangle of the footprint (rotating calipers).
OrientedBox fitGravityAlignedBox(const PointCloud& points_W, const Eigen::Vector3d& up_W);

}  // namespace mvod
