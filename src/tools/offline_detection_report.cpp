#include "offline_detection_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <utility>

#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/io/file_io.h"
#include "multiview_object_detection/io/ply_writer.h"

namespace offline_detection {
namespace {

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  }
  return m;
}

}  // namespace

mvod::MapSummary summarize(const RunStats& stats, size_t num_frames,
                           const mvod::ObjectMapper& mapper,
                           const mvod::ObjectMapper::RefinementReport& refinement) {
  mvod::MapSummary summary;
  summary.frames = static_cast<int>(num_frames);
  summary.keyframes = stats.keyframes;
  summary.removed_atypical = static_cast<int>(refinement.atypical_ids.size());
  summary.removed_intersecting = static_cast<int>(refinement.intersecting_ids.size());
  summary.removed_gone = stats.removed_gone;
  summary.gravity_down_W = -mapper.gravity().up;
  summary.floor_height_m = mapper.floorHeight_m();
  summary.counts = stats.counts;
  auto stage_median = [&](double mvod::StageTimes::*field) {
    std::vector<double> values;
    for (const mvod::StageTimes& t : stats.stage_times) values.push_back(t.*field);
    return median(values);
  };
  mvod::StageTimes& med = summary.stage_ms_median;
  med.extraction_ms = stage_median(&mvod::StageTimes::extraction_ms);
  med.filter_ms = stage_median(&mvod::StageTimes::filter_ms);
  med.lccp_ms = stage_median(&mvod::StageTimes::lccp_ms);
  med.manhattan_ms = stage_median(&mvod::StageTimes::manhattan_ms);
  med.fusion_ms = stage_median(&mvod::StageTimes::fusion_ms);
  med.existence_ms = stage_median(&mvod::StageTimes::existence_ms);
  med.total_ms = stage_median(&mvod::StageTimes::total_ms);
  med.refinement_ms = refinement.time_ms;
  return summary;
}

void printCostGrowth(const RunStats& stats) {
  const std::vector<mvod::StageTimes>& stage_times = stats.stage_times;
  if (stage_times.size() < 40) return;
  // Detector and geometry apart: the detector's time does not grow with the map, the geometry's
  // may.
  std::vector<double> first_detector, first_geometry, last_detector, last_geometry;
  for (size_t k = 0; k < 20; ++k) {
    const size_t late = stage_times.size() - 20 + k;
    first_detector.push_back(stats.stage_detection_ms[k]);
    first_geometry.push_back(stage_times[k].total_ms);
    last_detector.push_back(stats.stage_detection_ms[late]);
    last_geometry.push_back(stage_times[late].total_ms);
  }
  std::fprintf(stderr,
               "offline_detection: time per keyframe (detector + geometry), median of the first "
               "20: %.1f + %.1f ms, of the last 20: %.1f + %.1f ms\n",
               median(first_detector), median(first_geometry), median(last_detector),
               median(last_geometry));
}

bool writeTimings(const std::string& path, const RunStats& stats) {
  std::ofstream csv(path);
  // total_ms is the geometry's (the mapper's stages); detection_ms the detector's, apart.
  csv << "frame,extraction_ms,filter_ms,lccp_ms,manhattan_ms,fusion_ms,total_ms,existence_ms,"
         "largest_view_ms,detection_ms\n";
  for (size_t k = 0; k < stats.stage_times.size(); ++k) {
    const mvod::StageTimes& t = stats.stage_times[k];
    csv << stats.stage_frames[k] << "," << t.extraction_ms << "," << t.filter_ms << "," << t.lccp_ms
        << "," << t.manhattan_ms << "," << t.fusion_ms << "," << t.total_ms << "," << t.existence_ms
        << "," << t.largest_view_ms << "," << stats.stage_detection_ms[k] << "\n";
  }
  if (!csv) {
    std::cerr << "offline_detection: cannot write " << path << "\n";
    return false;
  }
  return true;
}

bool saveClouds(const std::string& dir, const std::vector<mvod::MapObject>& objects) {
  bool all_saved = true;
  for (const mvod::MapObject& object : objects) {
    const std::string stem = dir + "/" + mvod::objectCloudFileStem(object.id, object.class_name);
    for (const auto& part : {std::make_pair("_fused.ply", &object.points_W),
                             std::make_pair("_segment.ply", &object.segment_W)}) {
      const mvod::Status saved =
          mvod::writeFileAtomic(stem + part.first, mvod::plyAsciiXyz(*part.second));
      if (!saved) {
        std::cerr << "offline_detection: " << saved.message() << "\n";
        all_saved = false;
      }
    }
  }
  return all_saved;
}

void printHistoryUsage(const mvod::KeyframeHistory::Usage& usage, double max_memory_mb) {
  if (usage.keyframes == 0 && usage.forgotten == 0) return;
  constexpr double kMB = 1024.0 * 1024.0;
  const double per_keyframe_mb =
      usage.keyframes > 0 ? static_cast<double>(usage.bytes) / kMB / usage.keyframes : 0.0;
  std::fprintf(stderr,
               "keyframe history: %d keyframes, %.1f MB of %.0f (%.3f MB per keyframe: depth %.1f "
               "MB, cuts %.1f MB); %d with full depth, %d coarse, %d views only, %d forgotten\n",
               usage.keyframes, static_cast<double>(usage.bytes) / kMB, max_memory_mb,
               per_keyframe_mb, static_cast<double>(usage.depth_bytes) / kMB,
               static_cast<double>(usage.cut_bytes) / kMB, usage.full_depth, usage.coarse_depth,
               usage.views_only, usage.forgotten);
}

void printRunReport(const RunStats& stats, size_t num_frames, size_t num_objects,
                    const mvod::ObjectMapper::RefinementReport& refinement,
                    const mvod::MapSummary& summary) {
  const mvod::StageTimes& med = summary.stage_ms_median;
  const mvod::MapSummary::Counts& counts = summary.counts;
  // The keyframe's whole time, detector and geometry (they run one after the other).
  std::vector<double> keyframe_ms;
  for (size_t k = 0; k < stats.stage_times.size(); ++k) {
    keyframe_ms.push_back(stats.stage_detection_ms[k] + stats.stage_times[k].total_ms);
  }
  std::fprintf(stderr,
               "%zu frames, %d keyframes (%zu with detections, %d taken for sensor or SLAM "
               "faults), %d errors; %zu objects "
               "(removed: %zu atypical (%d too large, %d too small or thin), %zu intersecting, of "
               "which %zu merged into a duplicate; "
               "%d gone by the existence evidence)\n"
               "stage medians (ms): detection %.1f  extraction %.1f  filter %.1f  lccp %.1f  "
               "manhattan %.1f  fusion %.1f  existence %.1f  total %.1f (geometry; with the "
               "detection %.1f)  refinement %.1f\n"
               "counts: %d detections, %d >= lambda, %d with a box, %d inserted, %d fused; "
               "%d objects before refinement\n",
               num_frames, stats.keyframes, stats.stage_times.size(), stats.keyframes_faulty,
               stats.errors, num_objects, refinement.atypical_ids.size(),
               refinement.atypical_too_large,
               static_cast<int>(refinement.atypical_ids.size()) - refinement.atypical_too_large,
               refinement.intersecting_ids.size(), refinement.merged_ids.size(), stats.removed_gone,
               median(stats.detection_ms), med.extraction_ms, med.filter_ms, med.lccp_ms,
               med.manhattan_ms, med.fusion_ms, med.existence_ms, med.total_ms, median(keyframe_ms),
               med.refinement_ms, counts.detections, counts.above_threshold, counts.with_box,
               counts.inserted, counts.fused, counts.before_refinement);
  if (!stats.warnings.empty()) {
    int total = 0;
    for (const auto& entry : stats.warnings) total += entry.second;
    std::fprintf(stderr, "dropped detections and skipped keyframes (%d; each with --verbose): %s\n",
                 total, describeTally(stats.warnings).c_str());
  }
}

void printTable(const std::vector<mvod::MapObject>& objects, const std::string& frame) {
  std::printf("objects in the %s frame%s\n", frame.c_str(),
              frame == "gravity_aligned" ? " (z up, the floor at z = 0)" : "");
  std::printf("%4s  %-16s %5s %4s  %-26s %-22s %8s\n", "id", "class", "prob", "obs", "centre (m)",
              "size (m)", "yaw (deg)");
  for (const mvod::MapObject& o : objects) {
    const Eigen::Vector3d& c = o.box.center_m;
    const Eigen::Vector3d& s = o.box.size_m;
    std::printf("%4d  %-16s %5.2f %4d  (%6.2f, %6.2f, %6.2f)   (%5.2f, %5.2f, %5.2f)  %8.1f\n",
                o.id, o.class_name.c_str(), o.probability, o.observations, c.x(), c.y(), c.z(),
                s.x(), s.y(), s.z(), o.yaw_rad * 180.0 / M_PI);
  }
  std::fflush(stdout);
}

void printRefinementRemovals(const mvod::ObjectMapper::RefinementReport& refinement) {
  for (const mvod::ObjectMapper::RemovedObject& entry : refinement.removed) {
    const mvod::MapObject& object = entry.object;
    const Eigen::Vector3d& size = object.box.size_m;
    std::fprintf(stderr, "refinement removed #%d %s (%.2f x %.2f x %.2f m, %d views): %s\n",
                 object.id, object.class_name.c_str(), size.x(), size.y(), size.z(),
                 object.observations, entry.reason.c_str());
  }
}

}  // namespace offline_detection
