// The gravity-aligned output frame: in a tilted SLAM world (the redkitchen's gravity, ORB-SLAM2's
// y-down camera frame) boxes come out upright, heights above the floor readable, yaw unchanged.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/map/output_frame.h"

namespace mvod {
namespace {

// Gravity in the redkitchen's first-camera frame (README): y down, tilted forward.
const Eigen::Vector3d kTiltedDown = Eigen::Vector3d(-0.009, 0.904, 0.427).normalized();

// An upright 0.5 x 0.4 x 0.8 m box standing on a floor at floor_m along up, yaw 0.6 rad.
MapObject uprightObject(const GravityFrame& gravity, double floor_m) {
  MapObject object;
  object.id = 7;
  object.class_name = "chair";
  object.yaw_rad = 0.6;
  object.box.size_m = Eigen::Vector3d(0.5, 0.4, 0.8);
  object.box.rotation = gravity.rotationFromYaw(object.yaw_rad);
  object.box.center_m = (floor_m + 0.4) * gravity.up + 1.5 * gravity.x_h - 0.7 * gravity.y_h;
  object.observed_box = object.box;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d p = object.box.center_m + 0.01 * i * gravity.up;
    object.points_W.push_back(p.cast<float>());
  }
  return object;
}

TEST(OutputFrameTest, ATiltedWorldComesOutZUpWithHeightsAboveTheFloor) {
  const GravityFrame gravity(kTiltedDown);
  const double floor_m = -1.3;  // the floor 1.3 m below the first camera
  const Eigen::Isometry3d T_W_O = gravityAlignedPose(gravity, floor_m);
  EXPECT_TRUE(isValidPose(T_W_O));
  // z of O is up, against gravity; the origin lies on the floor under the world origin.
  EXPECT_TRUE((T_W_O.linear().col(2) + kTiltedDown).isZero(1e-12));
  EXPECT_NEAR(gravity.up.dot(T_W_O.translation()), floor_m, 1e-12);
  EXPECT_NEAR((T_W_O.translation() - floor_m * gravity.up).norm(), 0.0, 1e-12);

  const MapObject object_W = uprightObject(gravity, floor_m);
  const std::vector<MapObject> objects_O = objectsInFrame({object_W}, T_W_O.inverse(), true);
  ASSERT_EQ(objects_O.size(), 1u);
  const MapObject& object_O = objects_O[0];
  // Upright in O, its centre 0.4 m above the floor, yaw the angle of its first axis about z.
  EXPECT_TRUE(object_O.box.rotation.col(2).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_NEAR(object_O.box.center_m.z(), 0.4, 1e-12);
  EXPECT_NEAR(object_O.box.center_m.x(), 1.5, 1e-12);
  EXPECT_NEAR(object_O.box.center_m.y(), -0.7, 1e-12);
  const Eigen::Vector3d x_axis = object_O.box.rotation.col(0);
  EXPECT_NEAR(std::atan2(x_axis.y(), x_axis.x()), object_W.yaw_rad, 1e-12);
  EXPECT_DOUBLE_EQ(object_O.yaw_rad, object_W.yaw_rad);
  EXPECT_TRUE(object_O.box.size_m == object_W.box.size_m);
  EXPECT_TRUE(object_O.observed_box.center_m.isApprox(object_O.box.center_m, 1e-12));
  // Its cloud moved with it; what is not output (identity, class) is kept.
  ASSERT_EQ(object_O.points_W.size(), object_W.points_W.size());
  EXPECT_NEAR(object_O.points_W[9].z(), 0.49, 1e-5);
  EXPECT_EQ(object_O.id, 7);
  EXPECT_EQ(object_O.class_name, "chair");
}

TEST(OutputFrameTest, WithoutCloudsOnlyTheirSizesAreKept) {
  const GravityFrame gravity(kTiltedDown);
  const MapObject object_W = uprightObject(gravity, 0.0);
  const std::vector<MapObject> objects_O =
      objectsInFrame({object_W}, gravityAlignedPose(gravity, 0.0).inverse(), false);
  ASSERT_EQ(objects_O.size(), 1u);
  EXPECT_EQ(objects_O[0].points_W.size(), object_W.points_W.size());  // num_points is counted
  EXPECT_TRUE(objects_O[0].box.rotation.col(2).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(OutputFrameTest, AZUpWorldKeepsItsAxesAndAnUnknownFloorKeepsTheOrigin) {
  const GravityFrame z_up(Eigen::Vector3d(0, 0, -1));
  const Eigen::Isometry3d T_W_O =
      gravityAlignedPose(z_up, std::numeric_limits<double>::quiet_NaN());
  EXPECT_TRUE(T_W_O.isApprox(Eigen::Isometry3d::Identity(), 1e-15));
  EXPECT_TRUE(gravityAlignedPose(z_up, 0.25).translation().isApprox(Eigen::Vector3d(0, 0, 0.25)));
}

TEST(OutputFrameTest, BoxesRoundTripBetweenTheFrames) {
  const GravityFrame gravity(kTiltedDown);
  const Eigen::Isometry3d T_W_O = gravityAlignedPose(gravity, -1.0);
  const OrientedBox box_W = uprightObject(gravity, -1.0).box;
  const OrientedBox back = transformBox(transformBox(box_W, T_W_O.inverse()), T_W_O);
  EXPECT_TRUE(back.center_m.isApprox(box_W.center_m, 1e-12));
  EXPECT_TRUE(back.rotation.isApprox(box_W.rotation, 1e-12));
}

// objectsInFrame copies MapObject field by field (to leave the evidence and free-space grids
// behind): with the identity every field that a map file holds comes out as it went in, so a field
// added to MapObject and to the files but not to the copy fails here.
TEST(OutputFrameTest, TheIdentityKeepsEveryFieldOfTheFilesButTheGrids) {
  MapObject object;
  object.id = 12;
  object.class_id = 57;
  object.class_name = "couch";
  object.probability = 0.81;
  object.observations = 6;
  object.points_W = {Eigen::Vector3f(1.f, 2.f, 0.5f), Eigen::Vector3f(1.1f, 2.f, 0.4f),
                     Eigen::Vector3f(1.2f, 2.1f, 0.3f)};
  object.segment_W = {Eigen::Vector3f(1.f, 2.f, 0.5f), Eigen::Vector3f(1.1f, 2.f, 0.4f)};
  object.class_scores = {{"couch", 0.81}, {"bed", 0.12}};
  object.box.center_m = Eigen::Vector3d(1.1, 2.05, 0.42);
  object.box.size_m = Eigen::Vector3d(1.8, 0.9, 0.84);
  object.box.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  object.yaw_rad = 0.3;
  object.box_completed = true;
  object.observed_box = object.box;
  object.observed_box.size_m.x() = 1.2;
  object.first_keyframe = 3;
  object.last_keyframe = 17;
  object.first_seen_s = 1.5;
  object.last_seen_s = 9.25;
  object.existence.log_odds = 1.3;
  object.existence.detected = 5;
  object.existence.missed = 2;
  object.existence.seen_through = 1;
  const std::vector<MapObject> copies =
      objectsInFrame({object}, Eigen::Isometry3d::Identity(), /*with_clouds=*/true);
  ASSERT_EQ(copies.size(), 1u);
  const MapSummary summary;
  EXPECT_EQ(objectsToJson(copies, summary, true), objectsToJson({object}, summary, true));
  EXPECT_TRUE(copies[0].evidence.empty());
  EXPECT_TRUE(copies[0].free_space.empty());
}

}  // namespace
}  // namespace mvod
