// libFuzzer harness: the map loader (io/json_io objectsFromJson: the tools' objects.json, the
// single-file map of 0.9.x with its keyframe history, and the document of a map folder's map.json).
// Whatever loads must save (objectsToJson with clouds) and reload to the same map: every field of
// every object and of the summary, clouds within the 1 mm they are stored at. The second save must
// then be byte-identical to the first (saving is a fixed point). Any mismatch aborts, which
// libFuzzer reports as a crash with the input that caused it.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <string>
#include <vector>

#include "multiview_object_detection/io/json_io.h"

namespace {

using mvod::MapObject;
using mvod::MapSummary;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz_map_json: %s\n", what.c_str());
  std::abort();
}

void expect(bool condition, const std::string& what) {
  if (!condition) fail(what);
}

// Bitwise-equal doubles (NaN never loads; -0.0 == 0.0 is fine, it prints back as -0.0).
bool same(double a, double b) { return a == b; }

bool sameVector(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return same(a.x(), b.x()) && same(a.y(), b.y()) && same(a.z(), b.z());
}

// Clouds are saved rounded to 1 mm from floats: within half a millimetre plus float rounding.
bool sameCloud(const mvod::PointCloud& a, const mvod::PointCloud& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const double tolerance = 5e-4 + 4.0 * std::abs(a[i][k]) * 1.2e-7;
      if (!(std::abs(static_cast<double>(a[i][k]) - b[i][k]) <= tolerance)) return false;
    }
  }
  return true;
}

void compareSummaries(const MapSummary& a, const MapSummary& b) {
  expect(a.frames == b.frames && a.keyframes == b.keyframes, "summary frames/keyframes differ");
  expect(
      a.removed_atypical == b.removed_atypical && a.removed_intersecting == b.removed_intersecting,
      "summary removed counts differ");
  expect(sameVector(a.gravity_down_W, b.gravity_down_W), "summary gravity_down differs");
  const mvod::StageTimes& s = a.stage_ms_median;
  const mvod::StageTimes& t = b.stage_ms_median;
  expect(same(s.extraction_ms, t.extraction_ms) && same(s.filter_ms, t.filter_ms) &&
             same(s.lccp_ms, t.lccp_ms) && same(s.manhattan_ms, t.manhattan_ms) &&
             same(s.fusion_ms, t.fusion_ms) && same(s.refinement_ms, t.refinement_ms) &&
             same(s.total_ms, t.total_ms),
         "summary stage_ms differs");
  const MapSummary::Counts& c = a.counts;
  const MapSummary::Counts& d = b.counts;
  expect(c.detections == d.detections && c.above_threshold == d.above_threshold &&
             c.with_box == d.with_box && c.inserted == d.inserted && c.fused == d.fused &&
             c.before_refinement == d.before_refinement,
         "summary counts differ");
}

void compareObjects(const MapObject& a, const MapObject& b, size_t index) {
  const std::string where = "object " + std::to_string(index) + ": ";
  expect(a.id == b.id, where + "id differs");
  expect(a.class_id == b.class_id, where + "class_id differs");
  expect(a.class_name == b.class_name, where + "class_name differs");
  expect(same(a.probability, b.probability), where + "probability differs");
  expect(a.observations == b.observations, where + "observations differ");
  expect(sameCloud(a.points_W, b.points_W), where + "points differ");
  expect(sameCloud(a.segment_W, b.segment_W), where + "segment differs");
  expect(a.evidence.size() == b.evidence.size(), where + "evidence voxel count differs");
  for (const auto& voxel : a.evidence) {
    const auto it = b.evidence.find(voxel.first);
    expect(it != b.evidence.end(), where + "an evidence voxel is lost");
    expect(it->second.inside == voxel.second.inside && it->second.outside == voxel.second.outside,
           where + "evidence counts differ");
    expect(it->second.normal_sum == voxel.second.normal_sum, where + "evidence normals differ");
  }
  expect(same(a.evidence_voxel_size_m, b.evidence_voxel_size_m),
         where + "evidence voxel_size_m differs");
  expect(a.class_scores.size() == b.class_scores.size(), where + "class_scores count differs");
  for (const auto& score : a.class_scores) {
    const auto it = b.class_scores.find(score.first);
    expect(it != b.class_scores.end() && same(it->second, score.second),
           where + "class_scores differ");
  }
  expect(sameVector(a.box.center_m, b.box.center_m), where + "box center differs");
  expect(sameVector(a.box.size_m, b.box.size_m), where + "box size differs");
  for (int r = 0; r < 3; ++r) {
    expect(sameVector(a.box.rotation.row(r).transpose(), b.box.rotation.row(r).transpose()),
           where + "box rotation differs");
  }
  expect(same(a.yaw_rad, b.yaw_rad), where + "yaw differs");
  expect(a.first_keyframe == b.first_keyframe && a.last_keyframe == b.last_keyframe,
         where + "keyframes differ");
  expect(same(a.first_seen_s, b.first_seen_s) && same(a.last_seen_s, b.last_seen_s),
         where + "seen times differ");
  expect(same(a.existence.log_odds, b.existence.log_odds) &&
             a.existence.detected == b.existence.detected &&
             a.existence.missed == b.existence.missed &&
             a.existence.seen_through == b.existence.seen_through,
         where + "existence differs");
}

bool sameFloat(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

bool sameTriples(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (!sameFloat(a[i][k], b[i][k])) return false;
    }
  }
  return true;
}

// The keyframe history: every field exactly (points and normals are stored as float32 bits).
void compareHistories(const std::deque<mvod::KeyframeRecord>& a,
                      const std::deque<mvod::KeyframeRecord>& b) {
  expect(a.size() == b.size(), "history length differs");
  for (size_t i = 0; i < a.size(); ++i) {
    const std::string where = "keyframe record " + std::to_string(i) + ": ";
    const mvod::KeyframeRecord& r = a[i];
    const mvod::KeyframeRecord& s = b[i];
    expect(r.keyframe == s.keyframe && same(r.stamp_s, s.stamp_s) && r.name == s.name,
           where + "keyframe, stamp or name differs");
    expect(r.T_W_D_recorded.matrix() == s.T_W_D_recorded.matrix() &&
               r.T_W_D.matrix() == s.T_W_D.matrix() && r.T_C_D.matrix() == s.T_C_D.matrix(),
           where + "poses differ");
    expect(same(r.K_depth.fx, s.K_depth.fx) && same(r.K_depth.fy, s.K_depth.fy) &&
               same(r.K_depth.cx, s.K_depth.cx) && same(r.K_depth.cy, s.K_depth.cy) &&
               r.K_depth.width == s.K_depth.width && r.K_depth.height == s.K_depth.height,
           where + "intrinsics differ");
    expect(r.has_floor == s.has_floor && (!r.has_floor || r.floor_point_D == s.floor_point_D),
           where + "floor point differs");
    expect(r.depth.type() == s.depth.type() && r.depth.size() == s.depth.size() &&
               (r.depth.empty() ||
                std::memcmp(r.depth.data, s.depth.data, r.depth.total() * r.depth.elemSize()) == 0),
           where + "depth differs");
    expect(r.views.size() == s.views.size(), where + "view count differs");
    for (size_t k = 0; k < r.views.size(); ++k) {
      const mvod::RecordedView& u = r.views[k];
      const mvod::RecordedView& v = s.views[k];
      expect(u.class_id == v.class_id && u.class_name == v.class_name &&
                 same(u.probability, v.probability) && u.object_id == v.object_id &&
                 same(u.yaw_rad, v.yaw_rad) && sameVector(u.box.center_m, v.box.center_m) &&
                 sameVector(u.box.size_m, v.box.size_m) && u.box.rotation == v.box.rotation,
             where + "view fields differ");
      expect(sameTriples(u.cut->cut_W, v.cut->cut_W) &&
                 sameTriples(u.cut->normals_W, v.cut->normals_W) &&
                 u.cut->outside_keys == v.cut->outside_keys &&
                 same(u.cut->voxel_size_m, v.cut->voxel_size_m),
             where + "view cut differs");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<MapObject> loaded;
  MapSummary summary;
  std::deque<mvod::KeyframeRecord> history;
  const mvod::Status status = mvod::objectsFromJson(text, &loaded, &summary, &history);
  if (!status) {
    expect(!status.message().empty(), "an error without a message");
    return 0;
  }

  const std::string saved = mvod::objectsToJson(loaded, summary, /*include_clouds=*/true, &history);
  std::vector<MapObject> reloaded;
  MapSummary reloaded_summary;
  std::deque<mvod::KeyframeRecord> reloaded_history;
  const mvod::Status reload =
      mvod::objectsFromJson(saved, &reloaded, &reloaded_summary, &reloaded_history);
  if (!reload) fail("a loaded map saves to a file that does not load: " + reload.message());

  compareSummaries(summary, reloaded_summary);
  expect(loaded.size() == reloaded.size(), "object count differs");
  for (size_t i = 0; i < loaded.size(); ++i) compareObjects(loaded[i], reloaded[i], i);
  compareHistories(history, reloaded_history);

  const std::string saved_again = mvod::objectsToJson(reloaded, reloaded_summary,
                                                      /*include_clouds=*/true, &reloaded_history);
  expect(saved_again == saved, "saving the reloaded map writes a different file");
  return 0;
}
