// checkIntrinsicsForImage: the check of the node's camera_info and of the datasets' intrinsics.
#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/intrinsics_check.h"

namespace mvod {
namespace {

::testing::AssertionResult refusedWith(const CameraIntrinsics& K, int width, int height,
                                       const std::vector<std::string>& fragments) {
  const Status status = checkIntrinsicsForImage(K, width, height);
  if (status) return ::testing::AssertionFailure() << "accepted";
  for (const std::string& fragment : fragments) {
    if (status.message().find(fragment) == std::string::npos) {
      return ::testing::AssertionFailure() << "'" << fragment << "' not in: " << status.message();
    }
  }
  return ::testing::AssertionSuccess() << status.message();
}

TEST(IntrinsicsCheckTest, RealRgbdCamerasAreAccepted) {
  // Kinect v1 (57 x 45 degrees), SceneNN's Asus Xtion, a RealSense D435 colour camera at 1280x720
  // (69 x 42), a wide one at 848x480 (fx 300: 110 x 77), the small synthetic test camera.
  EXPECT_TRUE(checkIntrinsicsForImage({525.0, 525.0, 319.5, 239.5, 640, 480}, 640, 480).ok());
  EXPECT_TRUE(checkIntrinsicsForImage({544.47329, 544.47329, 320, 240, 0, 0}, 640, 480).ok());
  EXPECT_TRUE(checkIntrinsicsForImage({910.0, 910.0, 640.0, 360.0, 1280, 720}, 1280, 720).ok());
  EXPECT_TRUE(checkIntrinsicsForImage({300.0, 300.0, 424.0, 240.0, 848, 480}, 848, 480).ok());
  EXPECT_TRUE(checkIntrinsicsForImage({131.25, 131.25, 79.5, 59.5, 160, 120}, 160, 120).ok());
  // The widest: Azure Kinect's depth camera in WFOV mode, 120 x 120 degrees on 1024x1024.
  EXPECT_TRUE(checkIntrinsicsForImage({295.6, 295.6, 511.5, 511.5, 1024, 1024}, 1024, 1024).ok());
}

// fx = fy = 100 px on 640x480: 145 x 135 degrees, wider than any RGB-D camera (Azure Kinect WFOV:
// 120); it used to be accepted and a keyframe then took 1.5-2.5 s.
TEST(IntrinsicsCheckTest, WiderThanTheWidestRgbdCameraIsRefused) {
  EXPECT_TRUE(refusedWith({100.0, 100.0, 319.5, 239.5, 640, 480}, 640, 480,
                          {"field of view", "145", "640x480"}));
  // 131 degrees across (fx 146 px on 640): just past the bound.
  EXPECT_TRUE(refusedWith({146.0, 146.0, 319.5, 239.5, 640, 480}, 640, 480, {"field of view"}));
}

TEST(IntrinsicsCheckTest, FieldsOfViewNoRgbdCameraHasAreRefused) {
  // fx = fy = 30 px on 640x480: 169 x 166 degrees (one keyframe took 40 s and 6.7 GB).
  EXPECT_TRUE(refusedWith({30.0, 30.0, 319.5, 239.5, 640, 480}, 640, 480,
                          {"field of view", "169", "640x480"}));
  // A telephoto K (fx 3000 px on 640x480: 12 degrees across).
  EXPECT_TRUE(refusedWith({3000.0, 3000.0, 319.5, 239.5, 640, 480}, 640, 480, {"field of view"}));
  // Fine across, absurd up and down (fy 10 px) or too narrow up and down (fy 5000 px).
  EXPECT_TRUE(refusedWith({525.0, 10.0, 319.5, 239.5, 640, 480}, 640, 480, {"field of view"}));
  EXPECT_TRUE(refusedWith({525.0, 5000.0, 319.5, 239.5, 640, 480}, 640, 480, {"field of view"}));
  // A 640x480 K on a 64x48 image (a crop or another camera's file): 7 degrees across.
  EXPECT_TRUE(refusedWith({525.0, 525.0, 31.5, 23.5, 0, 0}, 64, 48, {"field of view"}));
}

TEST(IntrinsicsCheckTest, PrincipalPointOutsideTheImageIsRefused) {
  EXPECT_TRUE(
      refusedWith({525.0, 525.0, 320.0, 240.0, 0, 0}, 64, 48, {"principal point", "64x48"}));
  EXPECT_TRUE(refusedWith({525.0, 525.0, -1.0, 239.5, 0, 0}, 640, 480, {"principal point"}));
  EXPECT_TRUE(refusedWith({525.0, 525.0, 319.5, 481.0, 0, 0}, 640, 480, {"principal point"}));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(refusedWith({525.0, 525.0, nan, 239.5, 0, 0}, 640, 480, {"principal point"}));
}

TEST(IntrinsicsCheckTest, BadFocalLengthsAndSizesAreRefused) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double f : {0.0, -525.0, nan, inf}) {
    EXPECT_TRUE(refusedWith({f, 525.0, 319.5, 239.5, 0, 0}, 640, 480, {"fx"})) << f;
    EXPECT_TRUE(refusedWith({525.0, f, 319.5, 239.5, 0, 0}, 640, 480, {"fy"})) << f;
  }
  // K for another size than the image's.
  EXPECT_TRUE(
      refusedWith({525.0, 525.0, 319.5, 239.5, 640, 480}, 320, 240, {"640x480", "320x240"}));
  EXPECT_TRUE(refusedWith({525.0, 525.0, 319.5, 239.5, 0, 0}, 0, 480, {"empty"}));
}

}  // namespace
}  // namespace mvod
