// ObjectCloudExtractor (Eq. 1) and RgbdFrame::validate on small depth images made in the test:
// exact back-projection, invalid depth values, registered and unregistered (two-camera) mask
// lookups against a brute-force projection, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

#include "multiview_object_detection/pipeline/stages/object_cloud_extractor.h"
#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"

namespace mvod {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

RgbdFrame makeRegisteredFrame(const cv::Mat& depth, const CameraIntrinsics& K) {
  RgbdFrame frame;
  frame.index = 3;
  frame.name = "frame-000003";
  frame.depth = depth;
  frame.color_bgr = cv::Mat(depth.size(), CV_8UC3, cv::Scalar(40, 80, 120));
  frame.K_depth = K;
  frame.K_color = K;
  frame.registered = true;
  return frame;
}

Detection2D maskDetection(const cv::Mat& mask, const std::string& class_name = "chair") {
  Detection2D detection;
  detection.class_name = class_name;
  detection.score = 0.9f;
  detection.mask = mask;
  if (mask.type() == CV_8UC1) detection.box_px = cv::boundingRect(mask);
  return detection;
}

// A smooth depth field in millimetres (every pixel valid, 0.8 .. 2.2 m).
cv::Mat smoothDepthMm(int width, int height) {
  cv::Mat depth(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      depth.at<uint16_t>(v, u) =
          static_cast<uint16_t>(1500.0 + 500.0 * std::sin(u / 9.0) * std::cos(v / 13.0) +
                                200.0 * std::sin(u * v / 300.0));
    }
  }
  return depth;
}

// Eq. 1 alone: every valid depth pixel in the mask, without the depth-edge outlier test.
ObjectCloudExtractor::Config rawConfig() {
  ObjectCloudExtractor::Config config;
  config.min_consistent_neighbours = 0;
  return config;
}

bool samePoint(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float tol = 0.f) {
  return (a - b).cwiseAbs().maxCoeff() <= tol;
}

TEST(ObjectCloudExtractorTest, BackProjectionMatchesHandComputedPoints) {
  // fx 100, fy 200, cx 1.5, cy 1: x = (u - 1.5) z / 100, y = (v - 1) z / 200.
  const CameraIntrinsics K{100.0, 200.0, 1.5, 1.0, 4, 3};
  cv::Mat depth = cv::Mat::zeros(3, 4, CV_16UC1);
  depth.at<uint16_t>(0, 0) = 1000;   // (u, v) = (0, 0), 1 m
  depth.at<uint16_t>(2, 3) = 2500;   // (3, 2), 2.5 m
  depth.at<uint16_t>(1, 2) = 65535;  // invalid marker
  depth.at<uint16_t>(0, 1) = 50;     // 5 cm: below min_valid_depth_m = 0.1
  depth.at<uint16_t>(1, 0) = 20000;  // 20 m: above max_valid_depth_m = 10

  const PointCloud points = ObjectCloudExtractor::backProjectDepth(depth, K, 1, 0.1, 10.0);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_TRUE(samePoint(points[0], Eigen::Vector3f(-0.015f, -0.005f, 1.0f), 1e-6f))
      << points[0].transpose();
  EXPECT_TRUE(samePoint(points[1], Eigen::Vector3f(0.0375f, 0.0125f, 2.5f), 1e-6f))
      << points[1].transpose();

  EXPECT_FLOAT_EQ(ObjectCloudExtractor::depthAt(depth, 3, 2, 0.1, 10.0), 2.5f);
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 1, 1, 0.1, 10.0)));  // 0
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 2, 1, 0.1, 10.0)));  // 65535
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 1, 0, 0.1, 10.0)));  // too near
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 0, 1, 0.1, 10.0)));  // too far
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 4, 0, 0.1, 10.0)));  // outside
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth, 0, -1, 0.1, 10.0)));
  // A wider range admits them.
  EXPECT_FLOAT_EQ(ObjectCloudExtractor::depthAt(depth, 1, 0, 0.01, 30.0), 0.05f);
  EXPECT_FLOAT_EQ(ObjectCloudExtractor::depthAt(depth, 0, 1, 0.01, 30.0), 20.0f);

  // extract() with a full mask returns exactly the same points.
  const RgbdFrame frame = makeRegisteredFrame(depth, K);
  ObjectCloudExtractor extractor(rawConfig());
  std::vector<PointCloud> clouds;
  const Status status =
      extractor.extract(frame, {maskDetection(cv::Mat(3, 4, CV_8UC1, cv::Scalar(255)))}, &clouds);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(clouds.size(), 1u);
  ASSERT_EQ(clouds[0].size(), 2u);
  EXPECT_TRUE(samePoint(clouds[0][0], points[0]));
  EXPECT_TRUE(samePoint(clouds[0][1], points[1]));
}

TEST(ObjectCloudExtractorTest, FloatDepthInvalidValuesAndSameCloudAsMillimetres) {
  const CameraIntrinsics K{50.0, 50.0, 15.5, 11.5, 32, 24};
  const cv::Mat depth_mm = smoothDepthMm(32, 24);
  cv::Mat depth_m;
  depth_mm.convertTo(depth_m, CV_32FC1, 0.001);
  const PointCloud from_mm = ObjectCloudExtractor::backProjectDepth(depth_mm, K, 1, 0.1, 10.0);
  const PointCloud from_m = ObjectCloudExtractor::backProjectDepth(depth_m, K, 1, 0.1, 10.0);
  ASSERT_EQ(from_mm.size(), 32u * 24u);
  ASSERT_EQ(from_m.size(), from_mm.size());
  for (size_t i = 0; i < from_mm.size(); ++i) {
    ASSERT_TRUE(samePoint(from_mm[i], from_m[i], 1e-5f)) << i;
  }

  // NaN, +-inf, 0, negative and out-of-range metres give no point.
  cv::Mat bad = depth_m.clone();
  bad.at<float>(0, 0) = kNaNf;
  bad.at<float>(0, 1) = std::numeric_limits<float>::infinity();
  bad.at<float>(0, 2) = -std::numeric_limits<float>::infinity();
  bad.at<float>(0, 3) = 0.f;
  bad.at<float>(0, 4) = -1.f;
  bad.at<float>(0, 5) = 0.05f;
  bad.at<float>(0, 6) = 12.f;
  EXPECT_EQ(ObjectCloudExtractor::backProjectDepth(bad, K, 1, 0.1, 10.0).size(), from_m.size() - 7);
  for (int u = 0; u < 7; ++u) {
    EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(bad, u, 0, 0.1, 10.0))) << u;
  }

  // extract() on both types selects the same points.
  cv::Mat mask = cv::Mat::zeros(24, 32, CV_8UC1);
  cv::circle(mask, cv::Point(12, 10), 7, cv::Scalar(255), cv::FILLED);
  ObjectCloudExtractor extractor(rawConfig());
  std::vector<PointCloud> clouds_mm, clouds_m;
  ASSERT_TRUE(
      extractor.extract(makeRegisteredFrame(depth_mm, K), {maskDetection(mask)}, &clouds_mm).ok());
  ASSERT_TRUE(
      extractor.extract(makeRegisteredFrame(depth_m, K), {maskDetection(mask)}, &clouds_m).ok());
  ASSERT_EQ(clouds_mm[0].size(), static_cast<size_t>(cv::countNonZero(mask)));
  ASSERT_EQ(clouds_m[0].size(), clouds_mm[0].size());
  for (size_t i = 0; i < clouds_mm[0].size(); ++i) {
    ASSERT_TRUE(samePoint(clouds_mm[0][i], clouds_m[0][i], 1e-5f)) << i;
  }

  // Unsupported types give nothing rather than garbage.
  cv::Mat depth_8u(24, 32, CV_8UC1, cv::Scalar(100));
  EXPECT_TRUE(ObjectCloudExtractor::backProjectDepth(depth_8u, K, 1, 0.1, 10.0).empty());
  EXPECT_TRUE(std::isnan(ObjectCloudExtractor::depthAt(depth_8u, 1, 1, 0.1, 10.0)));
  EXPECT_TRUE(ObjectCloudExtractor::backProjectDepth(cv::Mat(), K, 1, 0.1, 10.0).empty());
}

// Registered frame: masks are read at the depth pixel itself; overlapping masks share points; the
// pixel stride applies to depth pixels (grid anchored at 0 as in backProjectDepth).
TEST(ObjectCloudExtractorTest, RegisteredOverlappingMasksAndStride) {
  const CameraIntrinsics K{60.0, 60.0, 19.5, 14.5, 40, 30};
  cv::Mat depth = smoothDepthMm(40, 30);
  depth.at<uint16_t>(12, 12) = 0;  // a hole inside both masks
  const RgbdFrame frame = makeRegisteredFrame(depth, K);

  cv::Mat mask_a = cv::Mat::zeros(30, 40, CV_8UC1);
  cv::Mat mask_b = cv::Mat::zeros(30, 40, CV_8UC1);
  cv::rectangle(mask_a, cv::Rect(5, 5, 15, 12), cv::Scalar(255), cv::FILLED);
  cv::circle(mask_b, cv::Point(18, 14), 8, cv::Scalar(1), cv::FILLED);  // any non-zero value

  for (const int stride : {1, 2, 3}) {
    ObjectCloudExtractor::Config config = rawConfig();
    config.pixel_stride = stride;
    ObjectCloudExtractor extractor(config);
    std::vector<PointCloud> clouds;
    const Status status =
        extractor.extract(frame, {maskDetection(mask_a), maskDetection(mask_b, "cup")}, &clouds);
    ASSERT_TRUE(status.ok()) << status.message();
    ASSERT_EQ(clouds.size(), 2u);

    // Brute force: every stride-th pixel, in each mask, with valid depth.
    const cv::Mat* masks[2] = {&mask_a, &mask_b};
    size_t shared = 0;
    for (int k = 0; k < 2; ++k) {
      PointCloud expected;
      for (int v = 0; v < 30; v += stride) {
        for (int u = 0; u < 40; u += stride) {
          if (masks[k]->at<uint8_t>(v, u) == 0 || (u == 12 && v == 12)) continue;
          const float z = depth.at<uint16_t>(v, u) * 0.001f;
          expected.emplace_back((u - 19.5f) * z / 60.f, (v - 14.5f) * z / 60.f, z);
          if (k == 0 && mask_b.at<uint8_t>(v, u) != 0) ++shared;
        }
      }
      ASSERT_EQ(clouds[k].size(), expected.size()) << "stride " << stride << " mask " << k;
      for (size_t i = 0; i < expected.size(); ++i) {
        ASSERT_TRUE(samePoint(clouds[k][i], expected[i], 1e-5f)) << "stride " << stride;
      }
    }
    EXPECT_GT(shared, 0u);  // the overlap is in both clouds
    if (stride == 1) {
      EXPECT_GT(clouds[0].size(), 150u);
    }
  }
}

TEST(ObjectCloudExtractorTest, RegisteredDepthEdgeTestIsTheBruteForceOne) {
  // Random depth with holes, saturated and out-of-range values and steps, masks over the image's
  // borders and each other, every stride and neighbour count, millimetres and metres: the clouds
  // are the brute-force per-pixel definition's, bit for bit (depth in metres as a double, the
  // four neighbours at the stride inside the image within tolerance + 3 depth steps).
  const int width = 47;
  const int height = 35;
  const CameraIntrinsics K{55.0, 57.0, 23.2, 16.8, width, height};
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> millimetres(900, 1100);
  std::uniform_int_distribution<int> kind(0, 19);
  cv::Mat depth_mm(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int k = kind(rng);
      depth_mm.at<uint16_t>(v, u) = static_cast<uint16_t>(k == 0   ? 0
                                                          : k == 1 ? 65535
                                                          : k == 2 ? 50
                                                          : k < 5  ? 2000
                                                                   : millimetres(rng));
    }
  }
  cv::Mat depth_m;
  depth_mm.convertTo(depth_m, CV_32FC1, 0.001);
  depth_m.setTo(kNaNf, depth_mm == 0);
  depth_m.setTo(0.f, depth_mm == 65535);
  cv::Mat mask_a = cv::Mat::zeros(height, width, CV_8UC1);
  cv::Mat mask_b = cv::Mat::zeros(height, width, CV_8UC1);
  cv::rectangle(mask_a, cv::Rect(0, 3, 30, 32), cv::Scalar(255),
                cv::FILLED);  // left and bottom borders
  cv::circle(mask_b, cv::Point(35, 10), 14, cv::Scalar(255), cv::FILLED);  // top and right borders
  const cv::Mat* masks[2] = {&mask_a, &mask_b};
  size_t dropped_by_edges = 0;
  for (const cv::Mat& depth : {depth_mm, depth_m}) {
    const RgbdFrame frame = makeRegisteredFrame(depth, K);
    const auto metres = [&](int u, int v) {
      if (u < 0 || v < 0 || u >= width || v >= height) return std::nan("");
      double z;
      if (depth.type() == CV_16UC1) {
        const int mm = depth.at<uint16_t>(v, u);
        if (mm == 0 || mm == 65535) return std::nan("");
        z = 0.001 * mm;
      } else {
        z = depth.at<float>(v, u);
        if (!std::isfinite(z) || z <= 0.0) return std::nan("");
      }
      return z < 0.1 || z > 10.0 ? std::nan("") : z;
    };
    for (const int stride : {1, 2, 3}) {
      for (const int min_neighbours : {0, 1, 2, 3, 4}) {
        ObjectCloudExtractor::Config config;
        config.pixel_stride = stride;
        config.min_consistent_neighbours = min_neighbours;
        std::vector<PointCloud> clouds;
        ASSERT_TRUE(ObjectCloudExtractor(config)
                        .extract(frame, {maskDetection(mask_a), maskDetection(mask_b)}, &clouds)
                        .ok());
        for (int k = 0; k < 2; ++k) {
          PointCloud expected;
          for (int v = 0; v < height; v += stride) {
            for (int u = 0; u < width; u += stride) {
              const double z = metres(u, v);
              if (masks[k]->at<uint8_t>(v, u) == 0 || !std::isfinite(z)) continue;
              const double tolerance_m =
                  config.consistency_tolerance_m + 3.0 * config.depth_step_per_m2 * z * z;
              int agreeing = 0;
              for (const cv::Point d : {cv::Point(stride, 0), cv::Point(-stride, 0),
                                        cv::Point(0, stride), cv::Point(0, -stride)}) {
                agreeing += std::abs(metres(u + d.x, v + d.y) - z) <= tolerance_m;
              }
              if (agreeing < min_neighbours) {
                ++dropped_by_edges;
                continue;
              }
              expected.emplace_back(static_cast<float>((u - K.cx) * z / K.fx),
                                    static_cast<float>((v - K.cy) * z / K.fy),
                                    static_cast<float>(z));
            }
          }
          ASSERT_EQ(clouds[k].size(), expected.size())
              << "stride " << stride << " min_neighbours " << min_neighbours << " mask " << k;
          for (size_t i = 0; i < expected.size(); ++i) ASSERT_EQ(clouds[k][i], expected[i]);
        }
      }
    }
  }
  EXPECT_GT(dropped_by_edges, 500u);
}

TEST(ObjectCloudExtractorTest, DepthRowsAreDepthAtPerPixel) {
  // Millimetres with 0 and 65535, metres with NaN, infinity, zero and negatives, values beyond the
  // valid range: a row at a time gives depthAt's value of every pixel, bit for bit; a row that
  // leaves the image is all NaN.
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> mm(0, 12000);
  cv::Mat depth_mm(9, 31, CV_16UC1);
  for (int v = 0; v < depth_mm.rows; ++v) {
    for (int u = 0; u < depth_mm.cols; ++u) {
      const int value = mm(rng);
      depth_mm.at<uint16_t>(v, u) = static_cast<uint16_t>(value > 11000    ? 65535
                                                          : value % 7 == 0 ? 0
                                                                           : value);
    }
  }
  cv::Mat depth_m;
  depth_mm.convertTo(depth_m, CV_32FC1, 0.001);
  depth_m.at<float>(1, 2) = kNaNf;
  depth_m.at<float>(2, 3) = std::numeric_limits<float>::infinity();
  depth_m.at<float>(3, 4) = -1.f;
  for (const cv::Mat& depth : {depth_mm, depth_m}) {
    for (int v = 0; v < depth.rows; ++v) {
      for (const int stride : {1, 2, 3}) {
        for (const int u0 : {0, 1, 4}) {
          const int count = (depth.cols - u0 + stride - 1) / stride;
          std::vector<float> row(count);
          ObjectCloudExtractor::depthRowAt(depth, v, u0, stride, count, 0.5, 9.0, row.data());
          for (int k = 0; k < count; ++k) {
            const float expected =
                ObjectCloudExtractor::depthAt(depth, u0 + k * stride, v, 0.5, 9.0);
            if (std::isnan(expected)) {
              ASSERT_TRUE(std::isnan(row[k])) << v << " " << u0 + k * stride;
            } else {
              ASSERT_EQ(row[k], expected) << v << " " << u0 + k * stride;
            }
          }
        }
      }
    }
    std::vector<float> beyond(4, 1.f);
    ObjectCloudExtractor::depthRowAt(depth, 0, depth.cols - 3, 1, 4, 0.5, 9.0, beyond.data());
    for (const float z : beyond) EXPECT_TRUE(std::isnan(z));
  }
}

TEST(ObjectCloudExtractorTest, NonZeroBoundsIsOpenCvsBoundingRect) {
  // Blobs and single pixels anywhere (at the borders, in the last bytes of a row), widths that are
  // not multiples of eight, empty and full masks, views into a larger image: cv::boundingRect's
  // rectangle.
  std::mt19937 rng(4);
  for (int trial = 0; trial < 300; ++trial) {
    const int cols = 1 + static_cast<int>(rng() % 90);
    const int rows = 1 + static_cast<int>(rng() % 40);
    cv::Mat image(rows + 4, cols + 5, CV_8UC1, cv::Scalar(0));
    cv::Mat mask = image(cv::Rect(2, 1, cols, rows));
    const int kind = trial % 5;
    if (kind == 1) mask.setTo(7);
    if (kind == 2)
      mask.at<uint8_t>(static_cast<int>(rng() % rows), static_cast<int>(rng() % cols)) = 1;
    if (kind == 3) {
      cv::circle(mask, cv::Point(static_cast<int>(rng() % cols), static_cast<int>(rng() % rows)),
                 1 + static_cast<int>(rng() % 12), cv::Scalar(255), cv::FILLED);
    }
    if (kind == 4) {
      for (int k = 0; k < 3; ++k) {
        mask.at<uint8_t>(static_cast<int>(rng() % rows), static_cast<int>(rng() % cols)) = 200;
      }
      mask.at<uint8_t>(rows - 1, cols - 1) = 3;
    }
    image.col(0).setTo(255);  // outside the view: not counted
    ASSERT_EQ(nonZeroBounds(mask), cv::boundingRect(mask)) << "trial " << trial;
  }
}

// A box 1.2 m before a wall, and a mask that runs 10 px past the box onto the wall (a mask
// computed on a coarse grid runs up to a cell past its object). The counts of box and wall points
// in the detection's cloud, in a registered frame and in one with two cameras.
struct BoxAndWall {
  int box_points = 0;
  int wall_points = 0;
};
std::vector<BoxAndWall> boxBeforeAWall(const ObjectCloudExtractor::Config& config,
                                       float mask_cell_px, int* mask_wall_pixels, int* box_pixels) {
  const CameraIntrinsics K{60.0, 60.0, 31.5, 23.5, 64, 48};
  cv::Mat depth(48, 64, CV_16UC1, cv::Scalar(2000));
  const cv::Rect box_px(24, 16, 16, 16);
  depth(box_px).setTo(800);
  cv::Mat mask = cv::Mat::zeros(48, 64, CV_8UC1);
  mask(cv::Rect(box_px.x - 10, box_px.y - 10, box_px.width + 20, box_px.height + 20)).setTo(255);
  *mask_wall_pixels = cv::countNonZero(mask) - box_px.area();
  *box_pixels = box_px.area();
  Detection2D detection = maskDetection(mask);
  detection.mask_cell_px = mask_cell_px;
  RgbdFrame registered = makeRegisteredFrame(depth, K);
  RgbdFrame two_cameras = registered;
  two_cameras.registered = false;  // the identity T_C_D: the same pixels
  std::vector<BoxAndWall> counts;
  for (const RgbdFrame* frame : {&registered, &two_cameras}) {
    std::vector<PointCloud> clouds;
    EXPECT_TRUE(ObjectCloudExtractor(config).extract(*frame, {detection}, &clouds).ok());
    BoxAndWall c;
    for (const Eigen::Vector3f& p : clouds.at(0))
      (p.z() < 1.0f ? c.box_points : c.wall_points) += 1;
    counts.push_back(c);
  }
  return counts;
}

// The wall's pixels within one mask cell of the box are left out and every pixel of the box is
// kept; with the cell above max_depth_edge_margin_px, only those within the maximum; a mask of no
// known cell (0) or a maximum of 0 (the paper's method) keeps them all.
TEST(ObjectCloudExtractorTest, MaskBorderPastADepthEdgeIsLeftOutWithinTheMaskCell) {
  // The wall pixels within m px (Chebyshev) of the 16 x 16 box, of the mask's 10 px ring.
  const auto ring = [](int m) { return (16 + 2 * m) * (16 + 2 * m) - 16 * 16; };
  struct Case {
    float cell_px;
    int max_margin_px;
    int wall_left_out;
  };
  const Case cases[] = {
      {4.f, 8, ring(4)}, {20.f, 8, ring(8)}, {0.f, 8, 0}, {4.f, 0, 0}, {1.f, 8, 0}};
  for (const Case& c : cases) {
    ObjectCloudExtractor::Config config = rawConfig();
    config.max_depth_edge_margin_px = c.max_margin_px;
    int mask_wall = 0;
    int box = 0;
    const std::vector<BoxAndWall> counts = boxBeforeAWall(config, c.cell_px, &mask_wall, &box);
    ASSERT_EQ(counts.size(), 2u);
    for (size_t k = 0; k < counts.size(); ++k) {
      const std::string what = std::string(k == 0 ? "registered" : "two cameras") + ", cell " +
                               std::to_string(c.cell_px) + ", max " +
                               std::to_string(c.max_margin_px);
      EXPECT_EQ(counts[k].box_points, box) << what;
      EXPECT_EQ(counts[k].wall_points, mask_wall - c.wall_left_out) << what;
    }
  }
}

// A floor seen at a grazing angle steps by centimetres from one pixel row to the next, more than
// the depth tolerance over the margin's 4 rows, but no step between neighbours is a depth edge:
// the margin leaves all of it.
TEST(ObjectCloudExtractorTest, DepthEdgeMarginKeepsASurfaceSeenAtAGrazingAngle) {
  const CameraIntrinsics K{60.0, 60.0, 31.5, 23.5, 64, 48};
  cv::Mat depth(48, 64, CV_16UC1);
  for (int v = 0; v < 48; ++v) depth.row(v).setTo(3000 + 30 * (47 - v));  // 3 cm a row
  const cv::Mat mask(48, 64, CV_8UC1, cv::Scalar(255));
  Detection2D detection = maskDetection(mask);
  detection.mask_cell_px = 4.f;
  std::vector<PointCloud> clouds;
  ASSERT_TRUE(ObjectCloudExtractor(rawConfig())
                  .extract(makeRegisteredFrame(depth, K), {detection}, &clouds)
                  .ok());
  EXPECT_EQ(clouds[0].size(), mask.total());
}

// Two cameras (7-Scenes, Kinect without registration): colour at another resolution and focal
// length, offset by T_C_D. The extractor must select exactly the depth points whose projection into
// the colour image lands in the mask.
TEST(ObjectCloudExtractorTest, UnregisteredFrameUsesColourProjection) {
  const CameraIntrinsics K_d{80.0, 82.0, 39.5, 29.5, 80, 60};
  const CameraIntrinsics K_c{150.0, 148.0, 61.3, 47.7, 120, 96};
  const cv::Mat depth = smoothDepthMm(80, 60);

  RgbdFrame frame;
  frame.name = "two-cameras";
  frame.depth = depth;
  frame.color_bgr = cv::Mat(96, 120, CV_8UC3, cv::Scalar(1, 2, 3));
  frame.K_depth = K_d;
  frame.K_color = K_c;
  frame.registered = false;
  frame.T_C_D = Eigen::Translation3d(0.052, -0.013, 0.008) *
                Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.2, 1.0, -0.1).normalized());
  ASSERT_TRUE(frame.validate().ok()) << frame.validate().message();

  cv::Mat mask_a = cv::Mat::zeros(96, 120, CV_8UC1);
  cv::Mat mask_b = cv::Mat::zeros(96, 120, CV_8UC1);
  cv::ellipse(mask_a, cv::Point(50, 40), cv::Size(25, 18), 20.0, 0.0, 360.0, cv::Scalar(255),
              cv::FILLED);
  cv::rectangle(mask_b, cv::Rect(60, 30, 45, 50), cv::Scalar(255), cv::FILLED);
  // The colour image's right border: depth points that project outside it must not be selected.
  cv::Mat mask_edge = cv::Mat::zeros(96, 120, CV_8UC1);
  mask_edge.colRange(110, 120).setTo(255);

  ObjectCloudExtractor extractor(rawConfig());
  std::vector<PointCloud> clouds;
  const Status status = extractor.extract(
      frame, {maskDetection(mask_a), maskDetection(mask_b, "tv"), maskDetection(mask_edge, "cup")},
      &clouds);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(clouds.size(), 3u);

  const cv::Mat* masks[3] = {&mask_a, &mask_b, &mask_edge};
  for (int k = 0; k < 3; ++k) {
    PointCloud expected;      // brute force: project each depth point into the colour camera
    PointCloud same_uv;       // the wrong method: the mask at the depth pixel's own (u, v)
    int near_pixel_edge = 0;  // projections within 1e-6 px of a rounding boundary (none expected)
    for (int v = 0; v < 60; ++v) {
      for (int u = 0; u < 80; ++u) {
        const double z = depth.at<uint16_t>(v, u) * 0.001;
        const Eigen::Vector3d p_D((u - K_d.cx) * z / K_d.fx, (v - K_d.cy) * z / K_d.fy, z);
        const Eigen::Vector3d p_C = frame.T_C_D * p_D;
        const double uc = K_c.fx * p_C.x() / p_C.z() + K_c.cx;
        const double vc = K_c.fy * p_C.y() / p_C.z() + K_c.cy;
        for (const double c : {uc, vc}) {
          if (std::abs(c - std::floor(c) - 0.5) < 1e-6) ++near_pixel_edge;
        }
        const int ui = static_cast<int>(std::lround(uc));
        const int vi = static_cast<int>(std::lround(vc));
        if (ui >= 0 && vi >= 0 && ui < 120 && vi < 96 && masks[k]->at<uint8_t>(vi, ui) != 0) {
          expected.push_back(p_D.cast<float>());
        }
        if (masks[k]->at<uint8_t>(v, u) != 0) same_uv.push_back(p_D.cast<float>());
      }
    }
    ASSERT_EQ(near_pixel_edge, 0);
    ASSERT_GT(expected.size(), 50u) << "mask " << k;
    ASSERT_EQ(clouds[k].size(), expected.size()) << "mask " << k;
    for (size_t i = 0; i < expected.size(); ++i) {
      ASSERT_TRUE(samePoint(clouds[k][i], expected[i], 1e-6f)) << "mask " << k << " point " << i;
    }
    // And it is not what a pixel-by-pixel lookup would give.
    size_t common = 0;
    for (const Eigen::Vector3f& p : same_uv) {
      for (const Eigen::Vector3f& q : expected) {
        if (samePoint(p, q)) {
          ++common;
          break;
        }
      }
    }
    EXPECT_LT(static_cast<double>(common), 0.8 * std::max(expected.size(), same_uv.size()))
        << "mask " << k << ": the colour projection should differ from a same-(u, v) lookup";
  }
}

TEST(ObjectCloudExtractorTest, BoxSizedMasksGiveTheSameCloudsAsImageSizedOnes) {
  const CameraIntrinsics K{30.0, 30.0, 15.5, 11.5, 32, 24};
  const RgbdFrame frame = makeRegisteredFrame(smoothDepthMm(32, 24), K);
  // An ellipse in a box inside the image, and one in a box at the image's corner.
  std::vector<Detection2D> full;
  for (const cv::Rect& box : {cv::Rect(6, 4, 14, 12), cv::Rect(0, 0, 10, 9)}) {
    cv::Mat mask = cv::Mat::zeros(24, 32, CV_8UC1);
    cv::ellipse(mask, (box.tl() + box.br()) / 2, cv::Size(box.width / 2 - 1, box.height / 2 - 1), 0,
                0, 360, cv::Scalar(255), -1);
    Detection2D detection = maskDetection(mask);
    detection.box_px = box;
    full.push_back(detection);
  }
  std::vector<Detection2D> cropped = full;
  for (Detection2D& detection : cropped) {
    cropMaskToBox(&detection, cv::Size(32, 24));
    ASSERT_EQ(detection.mask.size(), detection.box_px.size());
  }
  for (const int erosion_px : {0, 1, 2}) {
    ObjectCloudExtractor::Config config = rawConfig();
    config.mask_erosion_px = erosion_px;
    const ObjectCloudExtractor extractor(config);
    std::vector<PointCloud> from_full;
    std::vector<PointCloud> from_cropped;
    ASSERT_TRUE(extractor.extract(frame, full, &from_full).ok());
    ASSERT_TRUE(extractor.extract(frame, cropped, &from_cropped).ok());
    ASSERT_EQ(from_full.size(), 2u);
    ASSERT_EQ(from_cropped.size(), 2u);
    for (size_t i = 0; i < 2; ++i) {
      EXPECT_GT(from_full[i].size(), 0u);
      ASSERT_EQ(from_full[i].size(), from_cropped[i].size()) << "erosion " << erosion_px;
      for (size_t j = 0; j < from_full[i].size(); ++j) {
        EXPECT_EQ(from_full[i][j], from_cropped[i][j]);
      }
    }
  }
}

TEST(ObjectCloudExtractorTest, MasksOfTheWrongSizeOrTypeAreErrors) {
  const CameraIntrinsics K{30.0, 30.0, 7.5, 5.5, 16, 12};
  const RgbdFrame frame = makeRegisteredFrame(smoothDepthMm(16, 12), K);
  ObjectCloudExtractor extractor(rawConfig());
  const cv::Mat good(12, 16, CV_8UC1, cv::Scalar(255));

  std::vector<PointCloud> clouds;
  // Neither the image's size nor its box's (10x8).
  Detection2D wrong_size = maskDetection(cv::Mat(12, 15, CV_8UC1, cv::Scalar(255)));
  wrong_size.box_px = cv::Rect(2, 2, 10, 8);
  Status status = extractor.extract(frame, {maskDetection(good), wrong_size}, &clouds);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("detection 1"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("15x12"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("frame-000003"), std::string::npos) << status.message();

  status =
      extractor.extract(frame, {maskDetection(cv::Mat(12, 16, CV_32FC1, cv::Scalar(1)))}, &clouds);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("detection 0"), std::string::npos) << status.message();

  // An empty mask is no error: an empty cloud.
  Detection2D empty_mask;
  empty_mask.class_name = "cup";
  status = extractor.extract(frame, {empty_mask, maskDetection(good)}, &clouds);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(clouds.size(), 2u);
  EXPECT_TRUE(clouds[0].empty());
  EXPECT_EQ(clouds[1].size(), 16u * 12u);

  // No detections: no clouds.
  ASSERT_TRUE(extractor.extract(frame, {}, &clouds).ok());
  EXPECT_TRUE(clouds.empty());
  EXPECT_FALSE(extractor.extract(frame, {}, nullptr).ok());
}

TEST(ObjectCloudExtractorTest, MaskErosionShrinksTheMask) {
  const CameraIntrinsics K{30.0, 30.0, 9.5, 9.5, 20, 20};
  const RgbdFrame frame = makeRegisteredFrame(smoothDepthMm(20, 20), K);
  cv::Mat mask = cv::Mat::zeros(20, 20, CV_8UC1);
  cv::rectangle(mask, cv::Rect(5, 5, 9, 9), cv::Scalar(255), cv::FILLED);
  for (const int erosion : {0, 1, 2}) {
    ObjectCloudExtractor::Config config = rawConfig();
    config.mask_erosion_px = erosion;
    std::vector<PointCloud> clouds;
    ASSERT_TRUE(ObjectCloudExtractor(config).extract(frame, {maskDetection(mask)}, &clouds).ok());
    const size_t side = 9 - 2 * erosion;
    EXPECT_EQ(clouds[0].size(), side * side) << "erosion " << erosion;
  }
}

// The depth-edge test: a box at 1 m before a wall at 2 m, a column of flying pixels between them
// (1.5 m) along the box's left edge, and one speckle (3 m) in the wall. With the test on, the
// flying pixels and the speckle go, and so do the box's and the image's four corners (two
// agreeing neighbours each); every other pixel of the wall and the box stays, on their edges too.
TEST(ObjectCloudExtractorTest, DepthEdgeOutliersAreRemovedSurfacesKept) {
  const CameraIntrinsics K{100.0, 100.0, 19.5, 14.5, 40, 30};
  cv::Mat depth(30, 40, CV_16UC1, cv::Scalar(2000));
  depth(cv::Rect(15, 10, 10, 10)).setTo(1000);  // the box: 100 pixels
  depth(cv::Rect(14, 10, 1, 10)).setTo(1500);   // flying pixels: 10
  depth.at<uint16_t>(25, 5) = 3000;             // speckle
  const RgbdFrame frame = makeRegisteredFrame(depth, K);
  const Detection2D all = maskDetection(cv::Mat(30, 40, CV_8UC1, cv::Scalar(255)));

  std::vector<PointCloud> raw;
  ASSERT_TRUE(ObjectCloudExtractor(rawConfig()).extract(frame, {all}, &raw).ok());
  ASSERT_EQ(raw[0].size(), 1200u);

  ObjectCloudExtractor::Config config;
  ASSERT_EQ(config.min_consistent_neighbours, 3);  // the default
  std::vector<PointCloud> clouds;
  ASSERT_TRUE(ObjectCloudExtractor(config).extract(frame, {all}, &clouds).ok());
  int box = 0, wall = 0, other = 0;
  for (const Eigen::Vector3f& p : clouds[0]) {
    if (std::abs(p.z() - 1.0f) < 1e-3f) {
      ++box;
    } else if (std::abs(p.z() - 2.0f) < 1e-3f) {
      ++wall;
    } else {
      ++other;
    }
  }
  EXPECT_EQ(box, 100 - 4);
  EXPECT_EQ(wall, 1200 - 100 - 10 - 1 - 4);
  EXPECT_EQ(other, 0);

  // 0 switches the test off.
  config.min_consistent_neighbours = 0;
  ASSERT_TRUE(ObjectCloudExtractor(config).extract(frame, {all}, &clouds).ok());
  EXPECT_EQ(clouds[0].size(), 1200u);
  config.min_consistent_neighbours = 5;
  EXPECT_FALSE(config.isValid().ok());
}

TEST(ObjectCloudExtractorTest, InvalidFramesAreRejectedWithTheFrameName) {
  const CameraIntrinsics K{30.0, 30.0, 7.5, 5.5, 16, 12};
  const RgbdFrame good = makeRegisteredFrame(smoothDepthMm(16, 12), K);
  ASSERT_TRUE(good.validate().ok()) << good.validate().message();
  const std::vector<Detection2D> detections = {
      maskDetection(cv::Mat(12, 16, CV_8UC1, cv::Scalar(255)))};
  ObjectCloudExtractor extractor(rawConfig());

  auto expectError = [&](const RgbdFrame& frame, const std::string& fragment) {
    const Status valid = frame.validate();
    EXPECT_FALSE(valid.ok()) << fragment;
    EXPECT_NE(valid.message().find(fragment), std::string::npos) << valid.message();
    const std::string label =
        frame.name.empty() ? "frame " + std::to_string(frame.index) : frame.name;
    EXPECT_EQ(valid.message().rfind(label, 0), 0u) << valid.message();
    std::vector<PointCloud> clouds;
    const Status extracted = extractor.extract(frame, detections, &clouds);
    EXPECT_FALSE(extracted.ok()) << fragment;
    EXPECT_EQ(extracted.message(), valid.message());
  };

  RgbdFrame frame = good;
  frame.depth = cv::Mat(12, 16, CV_8UC1, cv::Scalar(10));
  expectError(frame, "depth is 8UC1, expected 16UC1 (mm) or 32FC1 (m)");

  frame = good;
  frame.depth = smoothDepthMm(8, 6);
  frame.K_depth.width = 8;
  frame.K_depth.height = 6;
  expectError(frame, "colour 16x12 but depth 8x6");

  frame = good;
  frame.K_depth.width = 20;
  expectError(frame, "depth intrinsics are for 20x12");

  frame = good;
  frame.T_W_D.translation().x() = std::nan("");
  expectError(frame, "T_W_D");

  frame = good;
  frame.T_W_D.linear() *= 2.0;  // not a rotation
  expectError(frame, "T_W_D");

  frame = good;
  frame.K_depth.fx = 0.0;
  expectError(frame, "invalid depth intrinsics");

  frame = good;
  frame.color_bgr = cv::Mat(12, 16, CV_8UC1, cv::Scalar(1));
  expectError(frame, "colour is 8UC1");

  frame = good;
  frame.color_bgr = cv::Mat();
  expectError(frame, "colour image is empty");

  frame = good;
  frame.depth = cv::Mat();
  expectError(frame, "depth image is empty");

  // Unregistered: colour intrinsics and T_C_D must be valid; sizes may differ.
  frame = good;
  frame.name.clear();
  frame.index = 7;
  frame.registered = false;
  frame.color_bgr = cv::Mat(24, 32, CV_8UC3, cv::Scalar(0, 0, 0));
  frame.K_color = CameraIntrinsics{60.0, 60.0, 15.5, 11.5, 32, 24};
  EXPECT_TRUE(frame.validate().ok()) << frame.validate().message();
  RgbdFrame bad = frame;
  bad.T_C_D.translation().y() = std::numeric_limits<double>::infinity();
  expectError(bad, "T_C_D");
  bad = frame;
  bad.K_color = CameraIntrinsics();
  expectError(bad, "invalid colour intrinsics");
  bad = frame;
  bad.K_color.height = 12;
  expectError(bad, "colour intrinsics are for 32x12");
}

// near_sampling_leaf_m: near pixels on a coarser grid (a subset of every pixel's points) at the
// same 1 cm voxels; far pixels all kept; 0 keeps every pixel.
TEST(ObjectCloudExtractorTest, NearSurfacesAreSampledOnACoarserGridAtTheSameVoxels) {
  const CameraIntrinsics K{525.0, 525.0, 319.5, 239.5, 640, 480};
  cv::Mat depth_mm(480, 640, CV_16UC1);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      // Left: a slanted wall 0.9-1.1 m away (stride 2); right: one 3 m away (stride 1).
      depth_mm.at<uint16_t>(v, u) =
          static_cast<uint16_t>(u < 320 ? 900.0 + 200.0 * u / 320.0 : 3000.0 + 0.2 * v);
    }
  }
  const RgbdFrame frame = makeRegisteredFrame(depth_mm, K);
  cv::Mat near_mask = cv::Mat::zeros(480, 640, CV_8UC1);
  near_mask.colRange(20, 300).rowRange(20, 460).setTo(255);
  cv::Mat far_mask = cv::Mat::zeros(480, 640, CV_8UC1);
  far_mask.colRange(340, 620).rowRange(20, 460).setTo(255);
  const std::vector<Detection2D> detections = {maskDetection(near_mask),
                                               maskDetection(far_mask, "tv")};

  ObjectCloudExtractor::Config every_pixel;
  every_pixel.near_sampling_leaf_m = 0.0;
  ObjectCloudExtractor::Config sampled;  // the default, 1 cm
  ASSERT_DOUBLE_EQ(sampled.near_sampling_leaf_m, 0.01);
  std::vector<PointCloud> all, few;
  ASSERT_TRUE(ObjectCloudExtractor(every_pixel).extract(frame, detections, &all).ok());
  ASSERT_TRUE(ObjectCloudExtractor(sampled).extract(frame, detections, &few).ok());
  ASSERT_EQ(all.size(), 2u);
  ASSERT_EQ(few.size(), 2u);

  // Near: 0.5 * 525 * 0.01 / z = 2.4-2.9 px, stride 2: a quarter of the points, each one of the
  // full cloud's.
  EXPECT_NEAR(static_cast<double>(few[0].size()) / all[0].size(), 0.25, 0.01);
  size_t k = 0;
  for (const Eigen::Vector3f& p : few[0]) {
    while (k < all[0].size() && !samePoint(all[0][k], p)) ++k;
    ASSERT_LT(k, all[0].size()) << "a sampled point that is not in the full cloud";
  }
  // ... and the same 1 cm voxels, but for some that the slanted surface only grazes (measured:
  // 96.7 % of them).
  const size_t all_voxels = PointCloudFilter::voxelize(all[0], 0.01).size();
  const size_t few_voxels = PointCloudFilter::voxelize(few[0], 0.01).size();
  EXPECT_GE(few_voxels, 0.96 * all_voxels) << few_voxels << " of " << all_voxels;
  // Far: stride 1, every pixel.
  ASSERT_EQ(few[1].size(), all[1].size());
  for (size_t i = 0; i < all[1].size(); ++i) ASSERT_TRUE(samePoint(few[1][i], all[1][i]));

  // Unregistered frames sample the same way.
  RgbdFrame two_cameras = frame;
  two_cameras.registered = false;
  std::vector<PointCloud> unregistered;
  ASSERT_TRUE(ObjectCloudExtractor(sampled).extract(two_cameras, detections, &unregistered).ok());
  ASSERT_EQ(unregistered.size(), 2u);
  EXPECT_EQ(unregistered[0].size(), few[0].size());
  EXPECT_EQ(unregistered[1].size(), few[1].size());
}

TEST(ObjectCloudExtractorTest, ConfigValidationAndPrint) {
  ObjectCloudExtractor::Config config;
  EXPECT_TRUE(config.isValid().ok());
  const std::string printed = config.print();
  for (const char* key :
       {"min_valid_depth_m: 0.1\n", "max_valid_depth_m: 10\n", "mask_erosion_px: 0\n",
        "pixel_stride: 1\n", "near_sampling_leaf_m: 0.01\n"}) {
    EXPECT_NE(printed.find(key), std::string::npos) << printed;
  }

  ObjectCloudExtractor::Config bad = config;
  bad.pixel_stride = 0;
  EXPECT_NE(bad.isValid().message().find("pixel_stride"), std::string::npos);
  for (const double leaf_m : {-0.01, 0.2, std::nan("")}) {
    bad = config;
    bad.near_sampling_leaf_m = leaf_m;
    EXPECT_NE(bad.isValid().message().find("near_sampling_leaf_m"), std::string::npos) << leaf_m;
  }
  bad = config;
  bad.mask_erosion_px = -1;
  EXPECT_NE(bad.isValid().message().find("mask_erosion_px"), std::string::npos);
  bad = config;
  bad.max_valid_depth_m = 0.05;
  EXPECT_NE(bad.isValid().message().find("max_valid_depth_m"), std::string::npos);
  bad = config;
  bad.min_valid_depth_m = std::nan("");
  EXPECT_NE(bad.isValid().message().find("min_valid_depth_m"), std::string::npos);

  // extract() refuses to run with an invalid config.
  const RgbdFrame frame =
      makeRegisteredFrame(smoothDepthMm(8, 6), CameraIntrinsics{10, 10, 3.5, 2.5, 8, 6});
  std::vector<PointCloud> clouds;
  bad = config;
  bad.pixel_stride = 0;
  EXPECT_FALSE(ObjectCloudExtractor(bad).extract(frame, {}, &clouds).ok());
}

}  // namespace
}  // namespace mvod
