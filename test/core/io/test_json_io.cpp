// objects.json: round trip, validation of malformed documents, atomic writes.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <thread>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/io/map_path.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

MapObject makeObject(int id, const std::string& class_name, double yaw_rad, int num_points) {
  MapObject object;
  object.id = id;
  object.class_name = class_name;
  object.class_id = id * 3;
  object.probability = 0.7312345678901234;
  object.observations = id + 4;
  object.box.center_m = Eigen::Vector3d(1.0 / 3.0, -2.25 * id, 0.123456789);
  object.box.size_m = Eigen::Vector3d(0.61, 0.47, 0.93);
  object.box.rotation = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  object.yaw_rad = yaw_rad;
  object.first_keyframe = 2;
  object.last_keyframe = 17 + id;
  object.first_seen_s = 1234.5;
  object.last_seen_s = 1301.0625;
  // Points on the 1 mm grid the file format keeps.
  for (int i = 0; i < num_points; ++i) {
    object.points_W.emplace_back(0.001f * i, -0.002f * i, 1.5f + 0.001f * (i % 7));
    if (i % 2 == 0) object.segment_W.push_back(object.points_W.back());
  }
  return object;
}

MapSummary makeSummary() {
  MapSummary summary;
  summary.frames = 1000;
  summary.keyframes = 100;
  summary.removed_atypical = 3;
  summary.removed_intersecting = 2;
  summary.gravity_down_W = Eigen::Vector3d(-0.0089, 0.9044, 0.4265);
  summary.floor_height_m = -1.375;
  summary.stage_ms_median.extraction_ms = 12.5;
  summary.stage_ms_median.filter_ms = 3.25;
  summary.stage_ms_median.lccp_ms = 40.125;
  summary.stage_ms_median.manhattan_ms = 7.0;
  summary.stage_ms_median.fusion_ms = 55.5;
  summary.stage_ms_median.refinement_ms = 0.75;
  summary.stage_ms_median.total_ms = 130.0;
  summary.counts.detections = 420;
  summary.counts.above_threshold = 300;
  summary.counts.with_box = 250;
  summary.counts.inserted = 40;
  summary.counts.fused = 210;
  summary.counts.before_refinement = 38;
  return summary;
}

void expectSameObject(const MapObject& a, const MapObject& b, bool with_clouds) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.class_name, b.class_name);
  EXPECT_EQ(a.class_id, b.class_id);
  EXPECT_EQ(a.probability, b.probability);
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_EQ(a.box.center_m, b.box.center_m);
  EXPECT_EQ(a.box.size_m, b.box.size_m);
  EXPECT_EQ(a.box.rotation, b.box.rotation);
  EXPECT_EQ(a.yaw_rad, b.yaw_rad);
  EXPECT_EQ(a.first_keyframe, b.first_keyframe);
  EXPECT_EQ(a.last_keyframe, b.last_keyframe);
  EXPECT_EQ(a.first_seen_s, b.first_seen_s);
  EXPECT_EQ(a.last_seen_s, b.last_seen_s);
  if (with_clouds) {
    ASSERT_EQ(a.points_W.size(), b.points_W.size());
    for (size_t i = 0; i < a.points_W.size(); ++i) {
      EXPECT_LT((a.points_W[i] - b.points_W[i]).norm(), 1e-6f);
    }
    ASSERT_EQ(a.segment_W.size(), b.segment_W.size());
    for (size_t i = 0; i < a.segment_W.size(); ++i) {
      EXPECT_LT((a.segment_W[i] - b.segment_W[i]).norm(), 1e-6f);
    }
  } else {
    EXPECT_TRUE(b.points_W.empty());
    EXPECT_TRUE(b.segment_W.empty());
  }
}

void expectSameSummary(const MapSummary& a, const MapSummary& b) {
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.keyframes, b.keyframes);
  EXPECT_EQ(a.removed_atypical, b.removed_atypical);
  EXPECT_EQ(a.removed_intersecting, b.removed_intersecting);
  EXPECT_EQ(a.gravity_down_W, b.gravity_down_W);
  EXPECT_EQ(std::isnan(a.floor_height_m), std::isnan(b.floor_height_m));
  if (!std::isnan(a.floor_height_m)) {
    EXPECT_EQ(a.floor_height_m, b.floor_height_m);
  }
  EXPECT_EQ(a.stage_ms_median.extraction_ms, b.stage_ms_median.extraction_ms);
  EXPECT_EQ(a.stage_ms_median.filter_ms, b.stage_ms_median.filter_ms);
  EXPECT_EQ(a.stage_ms_median.lccp_ms, b.stage_ms_median.lccp_ms);
  EXPECT_EQ(a.stage_ms_median.manhattan_ms, b.stage_ms_median.manhattan_ms);
  EXPECT_EQ(a.stage_ms_median.fusion_ms, b.stage_ms_median.fusion_ms);
  EXPECT_EQ(a.stage_ms_median.refinement_ms, b.stage_ms_median.refinement_ms);
  EXPECT_EQ(a.stage_ms_median.total_ms, b.stage_ms_median.total_ms);
  EXPECT_EQ(a.counts.detections, b.counts.detections);
  EXPECT_EQ(a.counts.above_threshold, b.counts.above_threshold);
  EXPECT_EQ(a.counts.with_box, b.counts.with_box);
  EXPECT_EQ(a.counts.inserted, b.counts.inserted);
  EXPECT_EQ(a.counts.fused, b.counts.fused);
  EXPECT_EQ(a.counts.before_refinement, b.counts.before_refinement);
}

// The floor (the output frame's origin) goes with the map; a map without one (no floor found, or a
// map of 0.9.x) reads as unknown; a floor that is not a number or beyond the map is refused.
TEST(JsonIoTest, TheFloorHeightIsKeptAndOptional) {
  MapSummary summary = makeSummary();
  std::vector<MapObject> loaded;
  MapSummary read;
  ASSERT_TRUE(objectsFromJson(objectsToJson({}, summary, false), &loaded, &read).ok());
  EXPECT_EQ(read.floor_height_m, -1.375);

  summary.floor_height_m = std::numeric_limits<double>::quiet_NaN();
  const std::string without = objectsToJson({}, summary, false);
  EXPECT_EQ(without.find("floor_height_m"), std::string::npos);
  read.floor_height_m = 0.0;
  ASSERT_TRUE(objectsFromJson(without, &loaded, &read).ok());
  EXPECT_TRUE(std::isnan(read.floor_height_m));

  for (const char* bad : {"\"low\"", "1e9"}) {
    nlohmann::json doc = nlohmann::json::parse(without);
    doc["floor_height_m"] = nlohmann::json::parse(bad);
    const Status status = objectsFromJson(doc.dump(), &loaded, &read);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("floor_height_m"), std::string::npos) << status.message();
  }
}

// The offline tools' files: written in the gravity-aligned frame with its pose alongside, read back
// in the world frame; a file in that frame with evidence grids, or with a frame that is not a rigid
// transform, is refused.
TEST(JsonIoTest, AFileInTheGravityAlignedFrameReadsBackInTheWorld) {
  MapSummary summary = makeSummary();
  const GravityFrame gravity(summary.gravity_down_W);
  summary.objects_in_gravity_frame = true;
  summary.T_W_O = gravityAlignedPose(gravity, summary.floor_height_m);
  MapObject object = makeObject(3, "chair", 0.2, 20);
  object.box.rotation = gravity.rotationFromYaw(0.2);
  object.observed_box = object.box;
  const std::string text = objectsToJson({object}, summary, true);
  const nlohmann::json raw = nlohmann::json::parse(text);
  ASSERT_TRUE(raw.contains("frame"));
  const Eigen::Vector3d in_file(raw["objects"][0]["center"][0].get<double>(),
                                raw["objects"][0]["center"][1].get<double>(),
                                raw["objects"][0]["center"][2].get<double>());
  EXPECT_LT((summary.T_W_O.inverse() * object.box.center_m - in_file).norm(), 1e-9);
  EXPECT_NEAR(raw["objects"][0]["rotation"][2][2].get<double>(), 1.0, 1e-9);  // upright in O

  std::vector<MapObject> loaded;
  MapSummary read;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &read).ok());
  EXPECT_TRUE(read.objects_in_gravity_frame);
  EXPECT_TRUE(read.T_W_O.isApprox(summary.T_W_O, 1e-12));
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_LT((loaded[0].box.center_m - object.box.center_m).norm(), 1e-9);
  EXPECT_TRUE(loaded[0].box.rotation.isApprox(object.box.rotation, 1e-9));
  ASSERT_EQ(loaded[0].points_W.size(), object.points_W.size());
  // The file stores points on a 1 mm grid (in O here): back in W within half a cell diagonal.
  EXPECT_LT((loaded[0].points_W[5] - object.points_W[5]).norm(), 0.9e-3f);

  nlohmann::json sheared = raw;
  sheared["frame"]["T_world_frame"][0][1] = 0.5;
  EXPECT_FALSE(objectsFromJson(sheared.dump(), &loaded, &read).ok());
  nlohmann::json with_evidence =
      nlohmann::json::parse(objectsToJson({object}, makeSummary(), true));
  with_evidence["frame"] = raw["frame"];
  with_evidence["objects"][0]["evidence"] = {
      {"voxel_size_m", 0.02}, {"voxels", nlohmann::json::parse("[[0, 0, 0, 1, 0]]")}};
  const Status refused = objectsFromJson(with_evidence.dump(), &loaded, &read);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("cannot be rotated"), std::string::npos) << refused.message();
}

TEST(JsonIoTest, RoundTripWithClouds) {
  const std::vector<MapObject> objects = {makeObject(1, "dining table", 0.3, 50),
                                          makeObject(7, "chair", -0.7, 0)};
  const MapSummary summary = makeSummary();
  const std::string text = objectsToJson(objects, summary, true);
  std::vector<MapObject> loaded;
  MapSummary loaded_summary;
  const Status status = objectsFromJson(text, &loaded, &loaded_summary);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(loaded.size(), objects.size());
  for (size_t i = 0; i < objects.size(); ++i) expectSameObject(objects[i], loaded[i], true);
  expectSameSummary(summary, loaded_summary);
  // Writing what was read gives the same document.
  EXPECT_EQ(objectsToJson(loaded, loaded_summary, true), text);
}

TEST(JsonIoTest, EvidenceRoundTripsAndIsValidated) {
  MapObject object = makeObject(4, "chair", 0.1, 10);
  object.evidence_voxel_size_m = 0.01;
  object.class_scores = {{"chair", 2.5}, {"couch", 0.75}};
  object.evidence[packVoxel(Eigen::Vector3i(-3, 5, 70))] = VoxelEvidence{4, 1};
  object.evidence[packVoxel(Eigen::Vector3i(1048575, -1048576, 0))] = VoxelEvidence{1, 65535};
  // A voxel with the views' summed normals (kept for the fused box's yaw).
  object.evidence[packVoxel(Eigen::Vector3i(7, 8, 9))] =
      VoxelEvidence{3, 0, Eigen::Vector3f(0.1f, -2.75f, 1e-3f)};
  // Voxels with the views' summed signed distances (the surface band), with and without normals.
  object.evidence[packVoxel(Eigen::Vector3i(7, 8, 10))] =
      VoxelEvidence{2, 1, Eigen::Vector3f(0.5f, 0.f, -0.25f), 3, -0.0625f};
  object.evidence[packVoxel(Eigen::Vector3i(7, 8, 11))] =
      VoxelEvidence{1, 0, Eigen::Vector3f::Zero(), 65535, 1.5f};
  const std::string text = objectsToJson({object}, makeSummary(), true);
  std::vector<MapObject> loaded;
  MapSummary summary;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &summary).ok());
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_DOUBLE_EQ(loaded[0].evidence_voxel_size_m, 0.01);
  EXPECT_EQ(loaded[0].class_scores, object.class_scores);
  ASSERT_EQ(loaded[0].evidence.size(), 5u);
  for (const auto& entry : object.evidence) {
    const auto it = loaded[0].evidence.find(entry.first);
    ASSERT_NE(it, loaded[0].evidence.end());
    EXPECT_EQ(it->second.inside, entry.second.inside);
    EXPECT_EQ(it->second.outside, entry.second.outside);
    EXPECT_EQ(it->second.normal_sum, entry.second.normal_sum);
    EXPECT_EQ(it->second.sdf_count, entry.second.sdf_count);
    EXPECT_EQ(it->second.sdf_sum, entry.second.sdf_sum);
  }
  // Voxels without normals are written as before ([i, j, k, in, out]): older maps stay readable.
  EXPECT_NE(text.find("[-3,5,70,4,1]"), std::string::npos);
  EXPECT_EQ(objectsToJson(loaded, summary, true), text);
  // Out-of-range votes or coordinates are refused with the field named.
  for (const char* bad :
       {"[0, 0, 0, 70000, 0]", "[0, 0, 2000000, 1, 0]", "[0, 0, 1]", "[0, 0, 0, -1, 0]",
        "[0, 0, 0, 1, 0, 1, 2]", "[0, 0, 0, 1, 0, 1, 2, 1e30]", "[0, 0, 0, 1, 0, 1, \"x\", 0]",
        "[0, 0, 0, 1, 0, 0, 0, 0, 0.1]", "[0, 0, 0, 1, 0, 0, 0, 0, 0.1, -1]",
        "[0, 0, 0, 1, 0, 0, 0, 0, 0.1, 70000]", "[0, 0, 0, 1, 0, 0, 0, 0, 0.1, 1.5]",
        "[0, 0, 0, 1, 0, 0, 0, 0, 1e30, 2]", "[0, 0, 0, 1, 0, 0, 0, 0, \"x\", 2]"}) {
    std::string broken = text;
    const size_t at = broken.find("\"voxels\":[");
    ASSERT_NE(at, std::string::npos);
    broken.insert(at + 10, std::string(bad) + ",");
    const Status status = objectsFromJson(broken, &loaded, &summary);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("evidence"), std::string::npos) << status.message();
  }
}

TEST(JsonIoTest, ViewBoxesRoundTripAndAreValidated) {
  MapObject object = makeObject(5, "cup", 0.2, 4);
  object.view_boxes.push_back(object.box);
  OrientedBox turned;
  turned.center_m = Eigen::Vector3d(1.25, -0.5, 0.75);
  turned.size_m = Eigen::Vector3d(0.125, 0.0625, 0.1);
  turned.rotation = Eigen::AngleAxisd(-1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  object.view_boxes.push_back(turned);
  const std::string text = objectsToJson({object}, makeSummary(), true);
  std::vector<MapObject> loaded;
  MapSummary summary;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &summary).ok());
  ASSERT_EQ(loaded.size(), 1u);
  ASSERT_EQ(loaded[0].view_boxes.size(), 2u);
  for (std::size_t v = 0; v < 2; ++v) {
    EXPECT_TRUE(loaded[0].view_boxes[v].center_m.isApprox(object.view_boxes[v].center_m, 1e-12));
    EXPECT_TRUE(loaded[0].view_boxes[v].size_m.isApprox(object.view_boxes[v].size_m, 1e-12));
    EXPECT_TRUE(loaded[0].view_boxes[v].rotation.isApprox(object.view_boxes[v].rotation, 1e-12));
  }
  EXPECT_EQ(objectsToJson(loaded, summary, true), text);
  // Without clouds, the views' boxes are left out with the evidence.
  EXPECT_EQ(objectsToJson({object}, makeSummary(), false).find("view_boxes"), std::string::npos);
  // A file from before them loads, without views' boxes.
  std::string old_file = text;
  const std::size_t from = old_file.find(",\"view_boxes\":");
  ASSERT_NE(from, std::string::npos);
  const std::size_t to = old_file.find("]}]", from);
  ASSERT_NE(to, std::string::npos);
  old_file.erase(from, to + 3 - from);
  ASSERT_TRUE(objectsFromJson(old_file, &loaded, &summary).ok()) << old_file;
  EXPECT_TRUE(loaded[0].view_boxes.empty());
  // Broken ones are refused with the field named.
  for (const char* bad : {"3", "[3]",
                          "[{\"center\":[0,0,0],\"size\":[1,1,-1],"
                          "\"rotation\":[[1,0,0],[0,1,0],[0,0,1]]}]",
                          "[{\"center\":[0,0,0],\"size\":[1,1,1],"
                          "\"rotation\":[[2,0,0],[0,1,0],[0,0,1]]}]",
                          "[{\"size\":[1,1,1],\"rotation\":[[1,0,0],[0,1,0],[0,0,1]]}]"}) {
    std::string broken = old_file;
    const std::size_t at = broken.find("\"yaw\"");
    ASSERT_NE(at, std::string::npos);
    broken.insert(at, "\"view_boxes\":" + std::string(bad) + ",");
    const Status status = objectsFromJson(broken, &loaded, &summary);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("view_boxes"), std::string::npos) << status.message();
  }
}

TEST(JsonIoTest, RoundTripWithoutClouds) {
  const std::vector<MapObject> objects = {makeObject(3, "tv", 1.2, 20)};
  const MapSummary summary = makeSummary();
  const std::string text = objectsToJson(objects, summary, false);
  const nlohmann::json doc = nlohmann::json::parse(text);
  EXPECT_FALSE(doc["objects"][0].contains("points"));
  EXPECT_EQ(doc["objects"][0]["num_points"], 20);
  EXPECT_EQ(doc["objects"][0]["class_name"], "tv");
  // Rotation rows: columns are the box axes.
  EXPECT_DOUBLE_EQ(doc["objects"][0]["rotation"][1][0].get<double>(), std::sin(1.2));
  EXPECT_TRUE(doc["stage_ms"].contains("manhattan"));
  std::vector<MapObject> loaded;
  MapSummary loaded_summary;
  const Status status = objectsFromJson(text, &loaded, &loaded_summary);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(loaded.size(), 1u);
  expectSameObject(objects[0], loaded[0], false);
  expectSameSummary(summary, loaded_summary);
}

// Table 4's counts are optional (maps saved before they existed still load) but checked when there.
TEST(JsonIoTest, CountsAreOptionalAndValidated) {
  const std::vector<MapObject> objects = {makeObject(3, "tv", 1.2, 20)};
  nlohmann::json doc = nlohmann::json::parse(objectsToJson(objects, makeSummary(), false));
  EXPECT_EQ(doc["counts"]["fused"], 210);
  doc.erase("counts");
  MapSummary loaded;
  ASSERT_TRUE(objectsFromJson(doc.dump(), nullptr, &loaded).ok());
  EXPECT_EQ(loaded.counts.detections, 0);
  EXPECT_EQ(loaded.counts.before_refinement, 0);
  doc["counts"] = {{"detections", 1}};
  const Status missing = objectsFromJson(doc.dump(), nullptr, &loaded);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("counts.above_threshold"), std::string::npos)
      << missing.message();
  doc = nlohmann::json::parse(objectsToJson(objects, makeSummary(), false));
  doc["counts"]["fused"] = -1;
  EXPECT_FALSE(objectsFromJson(doc.dump(), nullptr, &loaded).ok());
}

TEST(JsonIoTest, CloudsAreRoundedToMillimetres) {
  MapObject object = makeObject(1, "cup", 0.0, 0);
  object.points_W = {Eigen::Vector3f(0.12345f, -1.00049f, 2.0f)};
  const nlohmann::json doc = nlohmann::json::parse(objectsToJson({object}, MapSummary(), true));
  EXPECT_DOUBLE_EQ(doc["objects"][0]["points"][0][0].get<double>(), 0.123);
  EXPECT_DOUBLE_EQ(doc["objects"][0]["points"][0][1].get<double>(), -1.0);
  EXPECT_EQ(doc["objects"][0]["segment"].size(), 0u);
}

// Malformed documents: an error that names where, and the outputs stay as they were.
class JsonIoErrorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    objects_ = {makeObject(1, "chair", 0.2, 5), makeObject(2, "cup", 0.0, 3)};
    good_ = nlohmann::json::parse(objectsToJson(objects_, makeSummary(), true));
  }

  void expectError(const std::string& text, const std::string& expected_in_message) {
    std::vector<MapObject> out = {makeObject(99, "sentinel", 0.0, 1)};
    MapSummary summary;
    summary.frames = 12345;
    const Status status = objectsFromJson(text, &out, &summary);
    EXPECT_FALSE(status.ok());
    EXPECT_NE(status.message().find(expected_in_message), std::string::npos)
        << "message: " << status.message();
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].id, 99);
    EXPECT_EQ(out[0].class_name, "sentinel");
    EXPECT_EQ(summary.frames, 12345);
  }

  std::vector<MapObject> objects_;
  nlohmann::json good_;
};

TEST_F(JsonIoErrorTest, GoodDocumentParses) {
  std::vector<MapObject> out;
  MapSummary summary;
  EXPECT_TRUE(objectsFromJson(good_.dump(), &out, &summary).ok());
  EXPECT_EQ(out.size(), 2u);
}

TEST_F(JsonIoErrorTest, TruncatedOrNotJson) {
  const std::string text = good_.dump();
  expectError(text.substr(0, text.size() / 2), "not valid JSON");
  expectError("", "not valid JSON");
  expectError("[1, 2, 3]", "expected a JSON object");
}

TEST_F(JsonIoErrorTest, WrongTypes) {
  nlohmann::json doc = good_;
  doc["objects"][1]["class_name"] = 5;
  expectError(doc.dump(), "objects[1].class_name");
  doc = good_;
  doc["objects"][0]["id"] = "one";
  expectError(doc.dump(), "objects[0].id");
  doc = good_;
  doc["objects"][0]["probability"] = 1.5;
  expectError(doc.dump(), "objects[0].probability");
  doc = good_;
  doc["objects"][1]["center"] = {1.0, 2.0};
  expectError(doc.dump(), "objects[1].center");
  doc = good_;
  doc["objects"][1]["points"][2] = {0.0, "x", 1.0};
  expectError(doc.dump(), "objects[1].points[2]");
  doc = good_;
  doc["objects"] = nlohmann::json::array({nlohmann::json{{"id", 1}}});
  expectError(doc.dump(), "objects[0]");
  doc = good_;
  doc["frames"] = -1;
  expectError(doc.dump(), "frames");
  doc = good_;
  doc["stage_ms"]["lccp"] = "fast";
  expectError(doc.dump(), "stage_ms.lccp");
  doc = good_;
  doc["gravity_down"] = nullptr;
  expectError(doc.dump(), "gravity_down");
}

TEST_F(JsonIoErrorTest, MissingFields) {
  nlohmann::json doc = good_;
  doc["objects"][1].erase("last_seen");
  expectError(doc.dump(), "objects[1].last_seen: missing");
  doc = good_;
  doc.erase("removed");
  expectError(doc.dump(), "removed: missing");
  doc = good_;
  doc.erase("objects");
  expectError(doc.dump(), "objects: missing");
}

TEST_F(JsonIoErrorTest, InvalidValues) {
  nlohmann::json doc = good_;
  doc["objects"][0]["rotation"][0][0] = 2.0;
  expectError(doc.dump(), "objects[0].rotation");
  doc = good_;
  // A reflection is orthonormal but not a rotation.
  doc["objects"][0]["rotation"] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, -1.0}};
  expectError(doc.dump(), "objects[0].rotation");
  doc = good_;
  doc["objects"][1]["size"] = {0.1, -0.2, 0.3};
  expectError(doc.dump(), "objects[1].size");
  doc = good_;
  doc["objects"][1]["id"] = 1;
  expectError(doc.dump(), "duplicate id");
  doc = good_;
  doc["objects"][0]["num_points"] = 4;
  expectError(doc.dump(), "objects[0].num_points");
  // A number too large for a double is rejected by the parser.
  doc = good_;
  doc["objects"][0]["yaw"] = 123.456;
  std::string text = doc.dump();
  const size_t at = text.find("123.456");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 7, "1e999");
  expectError(text, "not valid JSON");
}

class AtomicWriteTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_json_io"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(AtomicWriteTest, WritesReplacesAndLeavesNoTemporary) {
  const std::string path = (dir_ / "objects.json").string();
  ASSERT_TRUE(writeFileAtomic(path, "first").ok());
  ASSERT_TRUE(writeFileAtomic(path, "second, longer content\n").ok());
  std::string content;
  ASSERT_TRUE(readFile(path, &content).ok());
  EXPECT_EQ(content, "second, longer content\n");
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "objects.json");
  }
  EXPECT_EQ(files, 1);
  // Readable by others like any file (mkstemp's 0600 is not kept).
  const auto permissions = fs::status(path).permissions();
  EXPECT_NE(permissions & fs::perms::owner_read, fs::perms::none);
  EXPECT_NE(permissions & fs::perms::group_read, fs::perms::none);
}

TEST_F(AtomicWriteTest, ErrorsNameThePath) {
  const std::string missing_dir = (dir_ / "no" / "such" / "dir" / "objects.json").string();
  const Status written = writeFileAtomic(missing_dir, "x");
  EXPECT_FALSE(written.ok());
  EXPECT_NE(written.message().find("objects.json"), std::string::npos);
  std::string content = "untouched";
  const Status read = readFile((dir_ / "absent.json").string(), &content);
  EXPECT_FALSE(read.ok());
  EXPECT_NE(read.message().find("absent.json"), std::string::npos);
  EXPECT_EQ(content, "untouched");
}

TEST_F(AtomicWriteTest, MapFileRoundTrip) {
  const std::vector<MapObject> objects = {makeObject(4, "couch", 0.5, 30)};
  const std::string path = (dir_ / "map.json").string();
  ASSERT_TRUE(writeFileAtomic(path, objectsToJson(objects, makeSummary(), true)).ok());
  std::string text;
  ASSERT_TRUE(readFile(path, &text).ok());
  std::vector<MapObject> loaded;
  MapSummary summary;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &summary).ok());
  ASSERT_EQ(loaded.size(), 1u);
  expectSameObject(objects[0], loaded[0], true);
}

// The id of a process that has ended (forked, exited and reaped).
pid_t endedProcessId() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

TEST_F(AtomicWriteTest, ReplacedFilesKeepTheirModeAndSavesRemoveOnlyTheirOwnDeadTemporaries) {
  const std::string path = (dir_ / "map.json").string();
  ASSERT_TRUE(writeFileAtomic(path, "first").ok());
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);  // 0600
  // Temporaries of a save that was killed (its process has ended), one of a save in progress (this
  // process), one of another map, and a user's files that merely look like temporaries.
  const std::string dead = ".map.json.save-" + std::to_string(endedProcessId()) + ".AbC123";
  const std::string live = ".map.json.save-" + std::to_string(::getpid()) + ".XyZ789";
  std::ofstream((dir_ / dead).string()) << "orphan";
  std::ofstream((dir_ / live).string()) << "in progress";
  std::ofstream((dir_ / ".other.json.save-1.AbC123").string()) << "not ours";
  std::ofstream((dir_ / "map.json.tmp.ABCDEF").string()) << "the user's";
  std::ofstream((dir_ / ".map.json.save-notapid.ABCDEF").string()) << "the user's";
  ASSERT_TRUE(writeFileAtomic(path, "second").ok());
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_FALSE(fs::exists(dir_ / dead));
  EXPECT_TRUE(fs::exists(dir_ / live));
  EXPECT_TRUE(fs::exists(dir_ / ".other.json.save-1.AbC123"));
  EXPECT_TRUE(fs::exists(dir_ / "map.json.tmp.ABCDEF"));
  EXPECT_TRUE(fs::exists(dir_ / ".map.json.save-notapid.ABCDEF"));
  // A directory is not replaced.
  fs::create_directories(dir_ / "folder.json");
  EXPECT_FALSE(writeFileAtomic((dir_ / "folder.json").string(), "x").ok());
}

TEST_F(AtomicWriteTest, ConcurrentSaversToOnePathAllSucceedAndTheFileIsAlwaysWhole) {
  const std::string path = (dir_ / "map.json").string();
  const std::string a(200000, 'a');
  const std::string b(100000, 'b');
  ASSERT_TRUE(writeFileAtomic(path, a).ok());
  constexpr int kSaves = 40;
  // Another process (as a second node would) and another thread of this one, against this thread.
  const pid_t child = ::fork();
  if (child == 0) {
    int failed = 0;
    for (int i = 0; i < kSaves; ++i) failed += writeFileAtomic(path, b).ok() ? 0 : 1;
    ::_exit(failed == 0 ? 0 : 1);
  }
  std::atomic<int> failed{0};
  std::atomic<int> torn{0};
  std::thread other([&] {
    for (int i = 0; i < kSaves; ++i) failed += writeFileAtomic(path, b).ok() ? 0 : 1;
  });
  for (int i = 0; i < kSaves; ++i) {
    failed += writeFileAtomic(path, a).ok() ? 0 : 1;
    std::string content;
    if (!readFile(path, &content).ok() || (content != a && content != b)) ++torn;
  }
  other.join();
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the other process's saves failed";
  EXPECT_EQ(failed.load(), 0);
  EXPECT_EQ(torn.load(), 0);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) files += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(files, 1) << "temporaries were left behind";
}

TEST_F(AtomicWriteTest, ReadRefusesFifosDevicesDirectoriesAndHugeFilesAtOnce) {
  const std::string fifo = (dir_ / "map.fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string content = "untouched";
  // Without a writer, opening the FIFO for reading would block forever.
  Status read = readFile(fifo, &content);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.message().find("FIFO"), std::string::npos) << read.message();
  read = readFile("/dev/zero", &content);  // would read until memory runs out
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.message().find("character device"), std::string::npos) << read.message();
  read = readFile(dir_.string(), &content);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.message().find("directory"), std::string::npos) << read.message();
  EXPECT_EQ(content, "untouched");
  const std::string big = (dir_ / "big.json").string();
  ASSERT_TRUE(writeFileAtomic(big, std::string(1000, 'x')).ok());
  read = readFile(big, &content, 999);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.message().find("limit"), std::string::npos) << read.message();
  ASSERT_TRUE(readFile(big, &content, 1000).ok());
  EXPECT_EQ(content.size(), 1000u);
}

TEST_F(JsonIoErrorTest, ParseErrorsDoNotQuoteTheFile) {
  // A file that is not a map (say /etc/shadow) must not have its bytes echoed in the error.
  const Status status = objectsFromJson("root:$6$secret:19000:0:99999:7:::\n", nullptr, nullptr);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.message().find("root"), std::string::npos) << status.message();
  EXPECT_EQ(status.message().find("r'"), std::string::npos) << status.message();
}

TEST_F(JsonIoErrorTest, ValuesThatWouldNotSurviveTheNextSaveAreRefused) {
  nlohmann::json doc = good_;
  doc["objects"][0]["points"][0] = {1e39, 0.0, 0.0};  // beyond float
  expectError(doc.dump(), "objects[0].points[0]");
  doc = good_;
  doc["objects"][0]["center"] = {0.0, 2e5, 0.0};
  expectError(doc.dump(), "objects[0].center");
  doc = good_;
  doc["objects"][0]["probability"] = 5.0;  // a percentage-style score
  expectError(doc.dump(), "objects[0].probability");
  doc = good_;
  doc["objects"][0]["id"] = 2147483647;
  expectError(doc.dump(), "objects[0].id");
}

// Existence evidence (0.10.0) round-trips; maps saved before it load with none (log-odds 0, no
// votes); out-of-range values are refused.
TEST(JsonIoTest, ExistenceRoundTripsIsOptionalAndValidated) {
  std::vector<MapObject> objects = {makeObject(3, "tv", 1.2, 20)};
  objects[0].existence.log_odds = -0.7;
  objects[0].existence.detected = 5;
  objects[0].existence.missed = 2;
  objects[0].existence.seen_through = 1;
  MapSummary summary = makeSummary();
  summary.removed_gone = 4;
  summary.stage_ms_median.existence_ms = 0.5;
  const std::string text = objectsToJson(objects, summary, false);
  std::vector<MapObject> loaded;
  MapSummary loaded_summary;
  ASSERT_TRUE(objectsFromJson(text, &loaded, &loaded_summary).ok());
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_DOUBLE_EQ(loaded[0].existence.log_odds, -0.7);
  EXPECT_EQ(loaded[0].existence.detected, 5u);
  EXPECT_EQ(loaded[0].existence.missed, 2u);
  EXPECT_EQ(loaded[0].existence.seen_through, 1u);
  EXPECT_EQ(loaded_summary.removed_gone, 4);
  EXPECT_DOUBLE_EQ(loaded_summary.stage_ms_median.existence_ms, 0.5);

  nlohmann::json doc = nlohmann::json::parse(text);
  doc["objects"][0].erase("existence");
  doc["removed"].erase("gone");
  doc["stage_ms"].erase("existence");
  ASSERT_TRUE(objectsFromJson(doc.dump(), &loaded, &loaded_summary).ok());
  EXPECT_EQ(loaded[0].existence.log_odds, 0.0);
  EXPECT_EQ(loaded[0].existence.detected + loaded[0].existence.missed, 0u);
  EXPECT_EQ(loaded_summary.removed_gone, 0);

  for (const auto& bad : {std::make_pair("log_odds", nlohmann::json(1e9)),
                          std::make_pair("missed", nlohmann::json(-1)),
                          std::make_pair("seen_through", nlohmann::json("two"))}) {
    doc = nlohmann::json::parse(text);
    doc["objects"][0]["existence"][bad.first] = bad.second;
    const Status refused = objectsFromJson(doc.dump(), &loaded, nullptr);
    ASSERT_FALSE(refused.ok()) << bad.first;
    EXPECT_NE(refused.message().find(std::string("existence.") + bad.first), std::string::npos)
        << refused.message();
  }
}

TEST(JsonIoTest, WhatTheMapHoldsRoundTrips) {
  // Class names are detector strings: bytes that are not UTF-8 must not make the map unsavable.
  std::vector<MapObject> objects = {makeObject(1, "chair", 0.1, 4)};
  objects[0].class_name = std::string("ch\xff\xfeir");
  const std::string text = objectsToJson(objects, makeSummary(), true);
  std::vector<MapObject> loaded;
  ASSERT_TRUE(objectsFromJson(text, &loaded, nullptr).ok());
  ASSERT_EQ(loaded.size(), 1u);
  // Saved again, it reads the same.
  std::vector<MapObject> again;
  ASSERT_TRUE(objectsFromJson(objectsToJson(loaded, makeSummary(), true), &again, nullptr).ok());
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].class_name, loaded[0].class_name);
}

class MapPathTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::freshTestDir("mvod_map_path"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(MapPathTest, RelativePathsResolveIntoTheMapDirectoryAndOthersAreRefused) {
  MapPathPolicy policy;
  policy.directory = (dir_ / "maps").string();
  std::string resolved;
  ASSERT_TRUE(resolveMapPath("kitchen.json", policy, true, &resolved).ok());
  EXPECT_EQ(resolved, (dir_ / "maps" / "kitchen.json").string());
  EXPECT_TRUE(fs::is_directory(dir_ / "maps"));  // created for writing
  ASSERT_TRUE(resolveMapPath("floor1/kitchen.json", policy, true, &resolved).ok());
  EXPECT_TRUE(fs::is_directory(dir_ / "maps" / "floor1"));
  ASSERT_TRUE(resolveMapPath((dir_ / "maps" / "a.json").string(), policy, false, &resolved).ok());

  for (const std::string& outside :
       {std::string("/etc/shadow"), std::string("../escape.json"),
        (dir_ / "maps" / ".." / "x.json").string(), (dir_ / "mapsX" / "y.json").string()}) {
    const Status status = resolveMapPath(outside, policy, true, &resolved);
    ASSERT_FALSE(status.ok()) << outside;
    EXPECT_NE(status.message().find("map_directory"), std::string::npos) << status.message();
    EXPECT_NE(status.message().find("allow_any_map_path"), std::string::npos);
  }
  // A link inside the directory that leads out of it is refused too.
  fs::create_symlink("/etc", dir_ / "maps" / "etc");
  EXPECT_FALSE(resolveMapPath("etc/passwd", policy, false, &resolved).ok());
  EXPECT_FALSE(resolveMapPath("", policy, false, &resolved).ok());
  EXPECT_FALSE(resolveMapPath("maps/", policy, false, &resolved).ok());

  policy.allow_any_path = true;
  ASSERT_TRUE(resolveMapPath((dir_ / "elsewhere.json").string(), policy, true, &resolved).ok());
  EXPECT_EQ(resolved, (dir_ / "elsewhere.json").string());
}

TEST_F(MapPathTest, TheMapDirectoryIsCreatedAndProvedWritableAtStart) {
  MapPathPolicy policy;
  policy.directory = (dir_ / "new" / "maps").string();
  ASSERT_TRUE(prepareMapDirectory(policy).ok());
  EXPECT_TRUE(fs::is_directory(dir_ / "new" / "maps"));
  EXPECT_TRUE(fs::is_empty(dir_ / "new" / "maps")) << "the probe file was left behind";

  for (const std::string& bad : {std::string("/proc/self"), std::string("relative/maps"),
                                 (dir_ / "file" / "below").string()}) {
    std::ofstream(dir_ / "file") << "not a directory";
    policy.directory = bad;
    const Status status = prepareMapDirectory(policy);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("map_directory '" + bad + "'"), std::string::npos)
        << status.message();
  }
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(dir_ / "read_only");
    fs::permissions(dir_ / "read_only", fs::perms::owner_read | fs::perms::owner_exec);
    policy.directory = (dir_ / "read_only").string();
    EXPECT_NE(prepareMapDirectory(policy).message().find("not writable"), std::string::npos);
    fs::permissions(dir_ / "read_only", fs::perms::owner_all);
  }
}

TEST(MapPathDefaultTest, DefaultIsUnderRosHome) {
  const std::string directory = defaultMapDirectory();
  EXPECT_NE(directory.find("multiview_object_detection/maps"), std::string::npos);
  EXPECT_EQ(directory[0], '/');
}

}  // namespace
}  // namespace mvod
