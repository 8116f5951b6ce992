// The map's reach (pipeline/types/map_limits.h): a camera at the edge is mapped in the right place
// and its map saves and loads; one just beyond is refused on the way in, naming the limit; the
// voxel keys hold the whole reach without wrapping; and the loader's bound is the same constant.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "box_scene.h"
#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/types/map_limits.h"
#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace {

// The test room of box_scene.h moved by `offset_m` along x: the same images, the camera (and so
// the box) that far from the world origin.
RgbdFrame frameMovedBy(double offset_m, cv::Mat* mask) {
  test::BoxScene scene;
  scene.wall_y_m = 3.0;
  const Eigen::Isometry3d T_W_D = test::cameraLookingAlongY(Eigen::Vector3d(0, 0, 1), 20.0);
  RgbdFrame frame = test::renderFrame(scene, T_W_D, 1, mask);
  frame.T_W_D.translation().x() += offset_m;
  return frame;
}

std::unique_ptr<ObjectMapper> limitMapper() {
  ClassPriors priors;
  ClassPrior chair;
  chair.class_name = "chair";
  chair.has_size = true;
  chair.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  chair.fusion_distance_m = 0.4;
  priors.set(chair);
  ObjectMapper::Config config;
  config.gravity_down_W = Eigen::Vector3d(0, 0, -1);
  return std::make_unique<ObjectMapper>(config, priors);
}

TEST(MapLimitsTest, CameraAtTheLimitIsAcceptedAndJustBeyondIsRefused) {
  const Eigen::Isometry3d at(Eigen::Translation3d(kCameraCoordinateLimitM, -kCameraCoordinateLimitM,
                                                  kCameraCoordinateLimitM));
  EXPECT_TRUE(checkCameraInMap(at, "pose").ok());
  const Eigen::Isometry3d beyond(Eigen::Translation3d(0.0, kCameraCoordinateLimitM + 0.01, 0.0));
  const Status refused = checkCameraInMap(beyond, "pose 7");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("pose 7"), std::string::npos) << refused.message();
  EXPECT_NE(refused.message().find("4900"), std::string::npos) << refused.message();
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan.translation().x() = std::nan("");
  EXPECT_FALSE(checkCameraInMap(nan, "pose").ok());
}

TEST(MapLimitsTest, VoxelKeysDoNotWrapWithinTheMap) {
  // The corners of the map at the smallest voxel the map accepts: each key unpacks to its own cell
  // (the wrap of 21-bit fields would fold +L onto -L + 2^21 cells).
  for (const double x : {-kMapCoordinateLimitM, kMapCoordinateLimitM}) {
    for (const double y : {-kMapCoordinateLimitM, 0.0, kMapCoordinateLimitM}) {
      const Eigen::Vector3f p(static_cast<float>(x), static_cast<float>(y), 1.0f);
      const Eigen::Vector3i cell = unpackVoxel(voxelKeyOf(p, kMinMapVoxelSizeM));
      const Eigen::Vector3d centre = (cell.cast<double>().array() + 0.5) * kMinMapVoxelSizeM;
      EXPECT_LT((centre - p.cast<double>()).cwiseAbs().maxCoeff(), 2.0 * kMinMapVoxelSizeM)
          << "point " << p.transpose() << " came back at " << centre.transpose();
    }
  }
  EXPECT_NE(voxelKeyOf(Eigen::Vector3f(kMapCoordinateLimitM, 0, 0), kMinMapVoxelSizeM),
            voxelKeyOf(Eigen::Vector3f(-kMapCoordinateLimitM, 0, 0), kMinMapVoxelSizeM));
}

TEST(MapLimitsTest, VoxelsTooSmallForTheMapAreRefused) {
  // The range table's floor for the map voxel is the one the keys need.
  EXPECT_EQ(findParameterRange("database/fusion_voxel_size_m")->min, kMinMapVoxelSizeM);
  ObjectDatabase::Config database;
  database.fusion_voxel_size_m = 1e-6;  // a mistyped parameter: keys would wrap at 1 m
  const Status refused = database.isValid();
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("fusion_voxel_size_m"), std::string::npos);
}

TEST(MapLimitsTest, AnObjectAtTheEdgeIsMappedInPlaceAndItsMapReloads) {
  const double offset_m = kCameraCoordinateLimitM - 1.0;
  cv::Mat mask;
  const RgbdFrame frame = frameMovedBy(offset_m, &mask);
  std::unique_ptr<ObjectMapper> mapper = limitMapper();
  KeyframeReport report;
  const Status status =
      mapper->processKeyframe(frame, {test::detectionFromMask(mask, "chair", 0.9f)}, &report);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(mapper->database().size(), 1u);
  const MapObject& object = mapper->database().objects().begin()->second;
  const Eigen::Vector3d truth = test::BoxScene().box_center + Eigen::Vector3d(offset_m, 0, 0);
  EXPECT_LT((object.box.center_m - truth).norm(), 0.05)
      << "centre " << object.box.center_m.transpose() << ", truth " << truth.transpose();

  std::vector<MapObject> objects;
  for (const auto& entry : mapper->database().objects()) objects.push_back(entry.second);
  const std::deque<KeyframeRecord>& history = mapper->history().records();
  const std::string text = objectsToJson(objects, MapSummary(), true, &history);
  std::vector<MapObject> loaded;
  MapSummary summary;
  std::deque<KeyframeRecord> loaded_history;
  const Status reloaded = objectsFromJson(text, &loaded, &summary, &loaded_history);
  ASSERT_TRUE(reloaded.ok()) << reloaded.message();
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_LT((loaded[0].box.center_m - object.box.center_m).norm(), 0.002);
}

TEST(MapLimitsTest, ACameraJustBeyondTheEdgeIsRefusedAndChangesNothing) {
  cv::Mat mask;
  const RgbdFrame frame = frameMovedBy(kCameraCoordinateLimitM + 1.0, &mask);
  std::unique_ptr<ObjectMapper> mapper = limitMapper();
  KeyframeReport report;
  const Status status =
      mapper->processKeyframe(frame, {test::detectionFromMask(mask, "chair", 0.9f)}, &report);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("beyond"), std::string::npos) << status.message();
  EXPECT_EQ(mapper->database().size(), 0u);
}

TEST(MapLimitsTest, TheLoaderRefusesWhatTheInputsRefuseAndNoLess) {
  // One constant: a map with a box centre at the map's limit loads, one a centimetre beyond does
  // not (the loader's bound is kMapCoordinateLimitM, which the inputs' bound is derived from).
  MapObject object;
  object.id = 1;
  object.class_name = "chair";
  object.probability = 0.9f;
  object.box.center_m = Eigen::Vector3d(kMapCoordinateLimitM, 0, 0.5);
  object.box.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
  object.box.rotation.setIdentity();
  std::vector<MapObject> loaded;
  MapSummary summary;
  const std::string at = objectsToJson({object}, MapSummary(), false);
  Status status = objectsFromJson(at, &loaded, &summary);
  EXPECT_TRUE(status.ok()) << status.message();
  object.box.center_m.x() = kMapCoordinateLimitM + 0.01;
  const std::string beyond = objectsToJson({object}, MapSummary(), false);
  status = objectsFromJson(beyond, &loaded, &summary);
  EXPECT_FALSE(status.ok());
}

}  // namespace
}  // namespace mvod
