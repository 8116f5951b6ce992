// offline_detection's report of a run: the keyframes' statistics, the map's summary (objects.json),
// the printed table and report, --timings and --save-clouds.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "offline_detection_warnings.h"

namespace offline_detection {

// What the keyframes of a run gave.
struct RunStats {
  std::vector<mvod::StageTimes> stage_times;  // keyframes that had detections to process
  std::vector<std::string> stage_frames;      // their names
  std::vector<double> detection_ms;
  // Per entry of stage_times: its keyframe's detector time (--timings' detection_ms).
  std::vector<double> stage_detection_ms;
  int keyframes = 0;
  int errors = 0;
  mvod::MapSummary::Counts counts;
  std::vector<double> correction_ms;  // --corrected-poses: each correction's time
  int keyframes_corrected = 0;
  int removed_gone = 0;      // by the existence evidence
  int keyframes_faulty = 0;  // taken for sensor or SLAM faults (KeyframeReport::depth_fault)
  // Dropped detections and skipped keyframes by plain reason (offline_detection_warnings.h).
  WarningTally warnings;
};

// The map's summary; Table 5's split as medians per keyframe (over the keyframes that had
// detections to process).
mvod::MapSummary summarize(const RunStats& stats, size_t num_frames,
                           const mvod::ObjectMapper& mapper,
                           const mvod::ObjectMapper::RefinementReport& refinement);

// Does the cost per keyframe grow with the map? The first and the last 20 keyframes, on stderr.
void printCostGrowth(const RunStats& stats);

// --timings: per-keyframe stage times as CSV; false (with a message) if the file cannot be written.
bool writeTimings(const std::string& path, const RunStats& stats);

// --save-clouds: each object's fused cloud and LCCP segment as ASCII PLY. False if one fails.
bool saveClouds(const std::string& dir, const std::vector<mvod::MapObject>& objects);

// The objects as a table on stdout, in `frame` (gravity_aligned or world).
void printTable(const std::vector<mvod::MapObject>& objects, const std::string& frame);

// What the refinement removed, one line per object with its class, box size and the reason
// (atypical size, mostly inside another, merged duplicate), as it was before it.
void printRefinementRemovals(const mvod::ObjectMapper::RefinementReport& refinement);

// Frames, keyframes, objects, removals, stage medians and counts, on stderr.
// The keyframe history's size and how far it degraded under its bound.
void printHistoryUsage(const mvod::KeyframeHistory::Usage& usage, double max_memory_mb);

void printRunReport(const RunStats& stats, size_t num_frames, size_t num_objects,
                    const mvod::ObjectMapper::RefinementReport& refinement,
                    const mvod::MapSummary& summary);

}  // namespace offline_detection
