// The keyframe history in the map file: everything the map needs to follow the SLAM's corrections
// once reloaded (poses, intrinsics, depth, each view's cut, normals and voxel keys) round-trips
// exactly, and a malformed history is refused with the field named.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "history_records.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace {

using test::makeRecord;

std::string saveMap(const std::deque<KeyframeRecord>& history) {
  return objectsToJson({}, MapSummary(), true, &history);
}

TEST(HistoryJson, RoundTripsExactly) {
  const std::deque<KeyframeRecord> history = {makeRecord(0, CV_16UC1), makeRecord(3, CV_32FC1)};
  const std::string text = saveMap(history);
  std::deque<KeyframeRecord> loaded;
  ASSERT_TRUE(objectsFromJson(text, nullptr, nullptr, &loaded).ok());
  test::expectSameHistory(history, loaded);
  // Saving is a fixed point.
  EXPECT_EQ(saveMap(loaded), text);
}

TEST(HistoryJson, AMapWithoutHistoryLoadsWithAnEmptyOne) {
  std::deque<KeyframeRecord> loaded = {makeRecord(0, CV_16UC1)};
  ASSERT_TRUE(
      objectsFromJson(objectsToJson({}, MapSummary(), true), nullptr, nullptr, &loaded).ok());
  EXPECT_TRUE(loaded.empty());
}

// Each corruption of a valid history is refused, naming the field.
TEST(HistoryJson, MalformedHistoriesAreRefused) {
  const nlohmann::json valid = nlohmann::json::parse(saveMap({makeRecord(0, CV_16UC1)}));
  struct Case {
    const char* what;
    std::function<void(nlohmann::json*)> corrupt;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"not rigid", [](nlohmann::json* k) { (*k)["T_W_D"][0][0] = 2.0; }, "T_W_D"},
      {"far away", [](nlohmann::json* k) { (*k)["T_W_D"][0][3] = 1e9; }, "T_W_D"},
      {"bad K", [](nlohmann::json* k) { (*k)["K"][0] = -1.0; }, "K"},
      {"bad base64", [](nlohmann::json* k) { (*k)["views"][0]["cut"] = "@@@@"; }, "cut"},
      {"cut not triples", [](nlohmann::json* k) { (*k)["views"][0]["cut"] = "AAAA"; }, "cut"},
      {"normals count", [](nlohmann::json* k) { (*k)["views"][0]["normals"] = "AAAAAAAAAAAAAAAA"; },
       "normals"},
      {"negative key", [](nlohmann::json* k) { (*k)["views"][0]["outside"] = "//////////8="; },
       "outside"},
      {"probability", [](nlohmann::json* k) { (*k)["views"][0]["probability"] = 3.0; },
       "probability"},
      {"depth size", [](nlohmann::json* k) { (*k)["depth"]["width"] = 9; }, "depth"},
      {"depth encoding", [](nlohmann::json* k) { (*k)["depth"]["encoding"] = "exr"; }, "encoding"},
      {"depth data", [](nlohmann::json* k) { (*k)["depth"]["data"] = "AAAA"; }, "depth"},
      {"huge depth", [](nlohmann::json* k) { (*k)["depth"]["width"] = 100000; }, "depth"},
      {"views not array", [](nlohmann::json* k) { (*k)["views"] = 3; }, "views"},
      {"no stamp", [](nlohmann::json* k) { k->erase("stamp"); }, "stamp"},
      {"refined not boolean", [](nlohmann::json* k) { (*k)["refined_after"] = 1; },
       "refined_after"},
  };
  for (const Case& c : cases) {
    nlohmann::json doc = valid;
    c.corrupt(&doc["keyframe_history"][0]);
    std::deque<KeyframeRecord> loaded;
    const Status status = objectsFromJson(doc.dump(), nullptr, nullptr, &loaded);
    EXPECT_FALSE(status.ok()) << c.what;
    EXPECT_NE(status.message().find(c.field), std::string::npos)
        << c.what << ": " << status.message();
  }
  // Keyframes out of order.
  nlohmann::json doc =
      nlohmann::json::parse(saveMap({makeRecord(4, CV_16UC1), makeRecord(2, CV_16UC1)}));
  EXPECT_FALSE(objectsFromJson(doc.dump(), nullptr, nullptr, nullptr).ok());
}

}  // namespace
}  // namespace mvod
