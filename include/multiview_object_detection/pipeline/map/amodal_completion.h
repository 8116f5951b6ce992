// Amodal completion: the box of an object whose hidden part is known to exist. A chair pushed under
// a table shows only its backrest above the table top; its box is then a thin slab ~0.25 m behind
// the chair's centre. For classes with a known horizontal depth (ClassPrior::amodal_depth_m), a box
// much thinner than that depth is extended to it, towards the side that the views never saw
// through, when the other side was seen through clearly more often. Not part of the paper.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// What the views saw of one cell around an object: how often it was in view with a valid depth at
// its pixel, and how often of those the view saw through it (measured surface beyond it).
struct FreeSpaceCount {
  std::uint16_t in_view = 0;
  std::uint16_t seen_free = 0;
};
// Key: voxelKeyOf(cell centre, AmodalCompletion::Config::cell_size_m).
using FreeSpaceMap = std::unordered_map<std::int64_t, FreeSpaceCount>;

class AmodalCompletion {
 public:
  struct Config {
    // Off: every box is what the views saw of the object (the paper's boxes).
    bool enable = true;
    // The free-space cells around a candidate object (m).
    double cell_size_m = 0.05;
    // A candidate: its thinner horizontal extent is below this share of the class's depth.
    double max_thin_ratio = 0.5;
    // Seen through: the measured depth lies this much (plus the DepthView's truncation at the
    // cell's depth) beyond the cell's centre (m).
    double free_margin_m = 0.05;
    // The side completed is seen through in at most this share of its in-view samples ...
    double max_free_share = 0.05;
    // ... and the other side at least this many times as often (share against share).
    double min_free_ratio = 4.0;
    // ... and each side was in view at least this often (cells x views).
    int min_in_view = 200;
    // ... and the object was seen in at least this many keyframes (one view's thin fragment of
    // something else is not completed into a chair; its free space is still counted).
    int min_observations = 2;
    Status isValid() const;
    std::string print() const;
  };

  // Both sides of a candidate's thin axis.
  struct Decision {
    int axis = -1;  // box column (0 or 1) of the thin horizontal extent; -1: not a candidate
    int side = 0;   // +1 / -1 along that column: the side to complete; 0: none
    int in_view[2] = {0, 0};  // [0]: the + side, [1]: the - side
    int seen_free[2] = {0, 0};
    double freeShare(int i) const {
      return in_view[i] > 0 ? static_cast<double>(seen_free[i]) / in_view[i] : 0.0;
    }
  };

  AmodalCompletion() = default;
  explicit AmodalCompletion(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // The box column (0 or 1) of the thinner horizontal extent of a gravity-aligned box (column 2
  // up) when it is below max_thin_ratio x depth_m; -1 otherwise (or when disabled).
  int thinAxis(const OrientedBox& box, double depth_m) const;
  // Adds one view's samples of the cells beside and below a candidate box: within depth_m of it
  // along its thin axis, from its bottom down to depth_m below it (not below floor_height_m, the
  // height along box column 2 of the floor; NaN: unknown). Nothing for a box that is not a
  // candidate.
  void countFreeSpace(const DepthView& view, const OrientedBox& box, double depth_m,
                      double floor_height_m, FreeSpaceMap* free_space) const;
  // The decision for a candidate box from its counts.
  Decision decide(const OrientedBox& box, double depth_m, double floor_height_m,
                  const FreeSpaceMap& free_space) const;
  // The box extended along decision.axis to depth_m, on decision.side (its visible face stays),
  // and down to floor_height_m when that is known and below the box. Unchanged without a side.
  static OrientedBox complete(const OrientedBox& box, const Decision& decision, double depth_m,
                              double floor_height_m);

 private:
  // Calls visit(key, centre, side) for the cells whose centres lie in the region beside the box
  // (side +1 / -1) within depth_m along `axis`.
  template <typename Visit>
  void forEachCell(const OrientedBox& box, int axis, double depth_m, double floor_height_m,
                   Visit visit) const;

  Config config_;
};

}  // namespace mvod
