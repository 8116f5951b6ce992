// The gravity-aligned output frame (REP 103: z up). SLAM worlds such as ORB-SLAM2's `map` are the
// first camera's frame: y down, z forward, tilted. The node publishes its map in a frame O whose z
// axis points against gravity and whose origin lies on the floor under the world origin, so that
// heights can be read and rviz draws boxes upright.
#pragma once

#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// T_W_O: O's axes are the gravity frame's (x_h, y_h, up), so a box's yaw is the same number in W
// and in O, and a world that already has z up gets the identity rotation. The origin is the world
// origin moved along `up` to the floor (floor_height_m along up; NaN: unknown, the origin stays).
Eigen::Isometry3d gravityAlignedPose(const GravityFrame& gravity, double floor_height_m);

// A box expressed in another frame: T_O_W * box_W.
OrientedBox transformBox(const OrientedBox& box_W, const Eigen::Isometry3d& T_O_W);

// Copies of the objects with their boxes (and, when with_clouds, their clouds) expressed in O. The
// copies' `_W` fields then hold O coordinates: for output only, never back into a database. The
// evidence and free-space grids are left out (empty) of the copies.
std::vector<MapObject> objectsInFrame(const std::vector<MapObject>& objects_W,
                                      const Eigen::Isometry3d& T_O_W, bool with_clouds);

}  // namespace mvod
