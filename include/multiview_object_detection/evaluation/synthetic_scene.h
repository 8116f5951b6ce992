// SyntheticScene moved to simulation/synthetic_scene.h. This forwarding header keeps the ROS node
// tests (test/ros/test_node_common.h, outside the simulation refactoring) compiling; include the
// new path.
#pragma once

#include "multiview_object_detection/simulation/synthetic_scene.h"
