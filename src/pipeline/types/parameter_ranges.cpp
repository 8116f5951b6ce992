#include "multiview_object_detection/pipeline/types/parameter_ranges.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "multiview_object_detection/pipeline/types/map_limits.h"

namespace mvod {
namespace {

std::string preciseNumber(double value) {
  std::ostringstream out;
  out << std::setprecision(10) << value;
  return out.str();
}

// "[MIN, MAX] UNIT", or "0 (off) or in [MIN, MAX] UNIT".
std::string rangeText(const ParameterRange& range) {
  std::string text = "[" + preciseNumber(range.min) + ", " + preciseNumber(range.max) + "]";
  if (range.unit[0] != '\0') text += std::string(" ") + range.unit;
  return range.zero_is_off ? "0 (off) or in " + text : text;
}

}  // namespace

const std::vector<ParameterRange>& parameterRanges() {
  static const std::vector<ParameterRange> kRanges = {
      {"queue_size", 1, 1000, "", false, "RGB-D sets held for synchronisation (4 images each)"},
      {"input_min_rate_hz", 0, 1000, "Hz", false, "a slower input is a warning on /diagnostics"},
      {"input_timeout_s", 0.5, 86400, "s", false,
       "an input silent this long is an error on /diagnostics"},
      {"diagnostic_period", 0.02, 60, "s", false, "between /diagnostics messages"},
      {"tf_timeout_s", 0, 60, "s", false, "how long a frame may wait for its pose"},
      {"pose_max_time_diff_s", 0, 10, "s", false, "pose to image stamp distance"},
      {"keyframe_every_n", 1, 1000, "", false, "frames between keyframes"},
      {"detections_max_age_s", 0, 60, "s", false,
       "how long a keyframe's images wait for their detections"},
      {"max_detections_per_frame", 1, 10000, "", false, "object clouds cut per keyframe"},
      {"service_timeout_s", 0.1, 600, "s", false,
       "how long ~load_map, ~reset and ~refine wait for the keyframe in progress"},
      {"autosave_period_s", 1, 86400, "s", true, "one save at most per period"},
      {"processing_queue_size", 1, 1000, "", false,
       "keyframes held for the worker (images: about 2 MB each at 640x480)"},
      {"processing_queue_max_mb", 1, 65536, "MB", false,
       "the queued keyframes' images; past it the oldest is dropped (one is always kept)"},
      {"refine_every_n_keyframes", 0, 10000, "", false, "0 = only on ~refine and at shutdown"},
      {"filter/voxel_leaf_size_m", 0.002, 0.5, "m", false,
       "finer than a Kinect's pixel footprint at 1 m (1 m / 525 px = 1.9 mm) keeps every point: no "
       "reduction"},
      {"filter/min_voxel_neighbours", 0, 26, "", false, "of the 26 neighbours"},
      {"filter/sor_mean_k", 1, 200, "", false, "neighbours searched per point"},
      {"lccp/voxel_resolution_m", 0.003, 0.2, "m", false,
       "supervoxel leaves: octree size and adjacency grow as its cube shrinks"},
      {"lccp/seed_resolution_m", 0.02, 1.0, "m", false,
       "supervoxel seeds (>= voxel_resolution_m); at 5 mm a keyframe took seconds"},
      {"lccp/min_points", 1, 1000000, "", false, "clouds smaller than this are not segmented"},
      {"box/normal_radius_m", 0.005, 0.5, "m", false, "neighbours searched per normal"},
      {"box/max_normals", 3, 1000000, "", false, "normals per box search"},
      {"box/outline_cell_m", 0.002, 0.5, "m", true, "footprint outline cells"},
      {"database/fusion_voxel_size_m", kMinMapVoxelSizeM, 0.2, "m", false,
       "the map's voxel keys address +-5,000 m from 5 mm (map_limits.h)"},
      {"gravity/ransac_iterations", 1, 10000, "", false, "plane hypotheses per keyframe"},
      {"gravity/voxel_size_m", 0.005, 1.0, "m", false, "points the plane search sees"},
      {"corrections/max_memory_mb", 1, 65536, "MB", false,
       "the keyframe history's memory bound; past it the oldest keyframes degrade"},
  };
  return kRanges;
}

const ParameterRange* findParameterRange(const std::string& name) {
  for (const ParameterRange& range : parameterRanges()) {
    if (name == range.name) return &range;
  }
  return nullptr;
}

Status checkParameterRange(const std::string& name, double value) {
  const ParameterRange* range = findParameterRange(name);
  if (range == nullptr) return Status::Error("internal: no range for parameter " + name);
  const bool off = range->zero_is_off && value == 0.0;
  if (off || (std::isfinite(value) && value >= range->min && value <= range->max)) {
    return Status::Ok();
  }
  return Status::Error(name + " must be " + (range->zero_is_off ? "" : "in ") + rangeText(*range) +
                       " (got " + preciseNumber(value) + "): " + range->why);
}

std::string parameterRangesMarkdown() {
  std::string text = "| parameter | range | bounds |\n|---|---|---|\n";
  for (const ParameterRange& range : parameterRanges()) {
    text +=
        std::string("| `") + range.name + "` | " + rangeText(range) + " | " + range.why + " |\n";
  }
  return text;
}

}  // namespace mvod
