// libFuzzer harness: the map loader (io/json_io objectsFromJson, what ~load_map and the tools
// read). Whatever loads must save (objectsToJson with clouds, as ~save_map writes) and reload to
// the same map: every field of every object and of the summary, clouds within the 1 mm they are
// stored at. The second save must then be byte-identical to the first (saving is a fixed point).
// Any mismatch aborts, which libFuzzer reports as a crash with the input that caused it.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
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
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<MapObject> loaded;
  MapSummary summary;
  const mvod::Status status = mvod::objectsFromJson(text, &loaded, &summary);
  if (!status) {
    expect(!status.message().empty(), "an error without a message");
    return 0;
  }

  const std::string saved = mvod::objectsToJson(loaded, summary, /*include_clouds=*/true);
  std::vector<MapObject> reloaded;
  MapSummary reloaded_summary;
  const mvod::Status reload = mvod::objectsFromJson(saved, &reloaded, &reloaded_summary);
  if (!reload) fail("a loaded map saves to a file that does not load: " + reload.message());

  compareSummaries(summary, reloaded_summary);
  expect(loaded.size() == reloaded.size(), "object count differs");
  for (size_t i = 0; i < loaded.size(); ++i) compareObjects(loaded[i], reloaded[i], i);

  const std::string saved_again =
      mvod::objectsToJson(reloaded, reloaded_summary, /*include_clouds=*/true);
  expect(saved_again == saved, "saving the reloaded map writes a different file");
  return 0;
}
