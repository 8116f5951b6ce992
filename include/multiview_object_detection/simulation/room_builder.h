// Builds a furnished room for SyntheticScene::makeRoom: floor-standing pieces are accepted only
// where they fit (inside the walls, clear of the camera loop and of each other); small objects
// stand on them.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "multiview_object_detection/simulation/split_mix.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace simulation {

using Rng = SplitMix64;

class RoomBuilder {
 public:
  // The camera loop of `config` (room size, loop inset) is what pieces must keep clear of.
  RoomBuilder(const SyntheticSceneConfig& config, uint64_t seed);

  Rng& rng() { return rng_; }
  double jitter(double amplitude) { return rng_.uniform(-amplitude, amplitude); }

  // True when the footprint of `box` is inside the walls, >= kLoopClearance from the camera loop
  // and >= kGap from every accepted floor-standing piece.
  bool fits(const OrientedBox& box) const;
  // Accepts a floor-standing object or clutter (its footprint blocks later pieces).
  void addObject(SyntheticObject object) {
    floor_.push_back(object.box);
    objects_.push_back(std::move(object));
  }
  void addClutter(SyntheticObject clutter) {
    floor_.push_back(clutter.box);
    clutter_.push_back(std::move(clutter));
  }
  // Objects standing on something else (books, cups): no floor check.
  void addSupported(SyntheticObject object) { objects_.push_back(std::move(object)); }

  // Origin of a piece with its back (local y = back_y) against the wall y = 0 (side 0, facing +y)
  // or y = room_y (side 1, facing -y); its yaw jitters a little.
  void againstWall(int side, double x, double back_y, Eigen::Vector3d* origin, double* yaw);

  // Up to `count` small objects on a support's top (a rectangle of half size `half` in its frame,
  // at height top_z), >= 0.1 m from its edges and 0.03 m from each other.
  void scatterOnTop(const Eigen::Vector3d& origin, double yaw, const Eigen::Vector2d& half,
                    double top_z, int cups, int books);

  // A bookshelf against a wall with books standing on its boards. False if it does not fit.
  bool addBookshelf(int side, double x);

  // A tv on a stand (clutter) against a wall. False if it does not fit.
  bool addTvOnStand(int side, double x);

  // Tries a floor-standing object at random poses from `propose` until one fits.
  template <typename Propose>
  bool place(int attempts, Propose propose) {
    for (int attempt = 0; attempt < attempts; ++attempt) {
      SyntheticObject object = propose();
      if (fits(object.box)) {
        addObject(std::move(object));
        return true;
      }
    }
    return false;
  }

  Eigen::Vector2d center() const {
    return Eigen::Vector2d(0.5 * config_.room_size_x_m, 0.5 * config_.room_size_y_m);
  }
  std::vector<SyntheticObject>& objects() { return objects_; }
  std::vector<SyntheticObject>& clutter() { return clutter_; }

 private:
  static constexpr double kWallGap = 0.02;
  static constexpr double kLoopClearance = 0.35;
  static constexpr double kGap = 0.1;  // between floor-standing pieces
  const SyntheticSceneConfig& config_;
  Rng rng_;
  std::vector<Eigen::Vector2d> loop_;
  std::vector<OrientedBox> floor_;
  std::vector<SyntheticObject> objects_;
  std::vector<SyntheticObject> clutter_;
};

}  // namespace simulation
}  // namespace mvod
