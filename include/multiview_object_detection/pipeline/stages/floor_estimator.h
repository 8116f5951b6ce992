// The floor's height along gravity, from the keyframes' depth: the lowest well-populated horizontal
// layer. Objects stand on the floor; the points just above it are floor, not object (issue 10's
// diagnosis: most background left in a cut sits in supervoxels that straddle the object-floor
// junction), so the single-view cut removes them before LCCP and boxes of objects that reach the
// floor are grounded on it.
#pragma once

#include <string>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

class FloorEstimator {
 public:
  struct Config {
    bool enable = true;               // false: no floor cut and no grounding (the paper's pipeline)
    double layer_thickness_m = 0.03;  // a floor layer: this thick along gravity
    // A layer is the floor when it holds this share of a frame's points (and min_layer_points) ...
    double min_layer_fraction = 0.05;
    int min_layer_points = 150;
    // ... and at most this share lies below it (noise, reflections).
    double max_below_fraction = 0.01;
    // Single-view cut: points less than this above the floor are dropped before LCCP, plus the
    // depth noise, which grows with range: clearance = clearance_m + clearance_per_m2 * depth^2.
    double clearance_m = 0.02;
    double clearance_per_m2 = 0.002;
    // A box whose bottom lies within this of the floor is grounded (extended down to it).
    double grounding_distance_m = 0.08;
    Status isValid() const;
    std::string print() const;
  };

  FloorEstimator() = default;
  explicit FloorEstimator(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // One frame's points in the world frame (any subsample). Keeps the lowest floor layer seen so
  // far; a frame that shows no floor changes nothing. Returns true when this frame showed a floor.
  // A different `up` than before (a new gravity estimate) starts over. layer_height_m (optional):
  // the height of this frame's own floor layer, when it showed one.
  bool addFrame(const PointCloud& points_W, const GravityFrame& gravity,
                double* layer_height_m = nullptr);
  bool hasFloor() const { return has_floor_; }
  // Height of the floor surface along gravity.up (m), valid when hasFloor().
  double floorHeight_m() const { return floor_height_m_; }
  // Sets the floor directly (tests, a loaded map).
  void setFloor(double height_m, const Eigen::Vector3d& up);
  void reset();

 private:
  Config config_;
  bool has_floor_ = false;
  double floor_height_m_ = 0.0;
  Eigen::Vector3d up_ = Eigen::Vector3d::Zero();
};

}  // namespace mvod
