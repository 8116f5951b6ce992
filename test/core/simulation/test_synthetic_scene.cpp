// The synthetic scene: layout, camera loop, ray-cast depth against analytic hits, labels, perfect
// detections, sensor noise and the 7-Scenes writer.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

// A small camera keeps the tests fast where the full 640x480 frame is not the point.
SyntheticSceneConfig smallConfig() {
  SyntheticSceneConfig config;
  config.K = CameraIntrinsics{131.25, 131.25, 79.5, 59.5, 160, 120};
  return config;
}

// Depth pixel -> camera-frame point (the inverse of the renderer's pinhole projection).
Eigen::Vector3d backProject(const RgbdFrame& frame, int u, int v) {
  const double z = frame.depth.at<uint16_t>(v, u) * 1e-3;
  return Eigen::Vector3d((u - frame.K_depth.cx) * z / frame.K_depth.fx,
                         (v - frame.K_depth.cy) * z / frame.K_depth.fy, z);
}

OrientedBox inflated(const OrientedBox& box, double margin_m) {
  OrientedBox result = box;
  result.size_m += Eigen::Vector3d::Constant(2.0 * margin_m);
  return result;
}

// Horizontal distance from a point to a gravity-aligned box's footprint (0 inside).
double footprintDistance(const OrientedBox& box, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d local = box.rotation.transpose() * (p_W - box.center_m);
  const double dx = std::max(0.0, std::abs(local.x()) - 0.5 * box.size_m.x());
  const double dy = std::max(0.0, std::abs(local.y()) - 0.5 * box.size_m.y());
  return std::hypot(dx, dy);
}

int countClass(const SyntheticScene& scene, const std::string& class_name) {
  int count = 0;
  for (const SyntheticObject& object : scene.objects()) count += object.class_name == class_name;
  return count;
}

class SyntheticSceneTest : public ::testing::Test {
 protected:
  void SetUp() override { work_ = test::freshTestDir("mvod_synthetic"); }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(work_);
  }
  fs::path work_;
};

TEST_F(SyntheticSceneTest, DefaultLayoutIsPlausible) {
  for (unsigned int seed = 1; seed <= 10; ++seed) {
    SyntheticSceneConfig config;
    config.seed = seed;
    const SyntheticScene scene = SyntheticScene::makeDefault(config);
    ASSERT_EQ(scene.objects().size(), 10u);
    EXPECT_EQ(countClass(scene, "dining table"), 1);
    EXPECT_EQ(countClass(scene, "chair"), 4);
    EXPECT_EQ(countClass(scene, "couch"), 1);
    EXPECT_EQ(countClass(scene, "tv"), 1);
    EXPECT_EQ(countClass(scene, "cup"), 2);
    EXPECT_EQ(countClass(scene, "book"), 1);
    const OrientedBox& table = scene.objects()[0].box;
    ASSERT_EQ(scene.objects()[0].class_name, "dining table");
    const double table_top_m = table.center_m.z() + 0.5 * table.size_m.z();

    const std::vector<SyntheticObject>& objects = scene.objects();
    for (size_t i = 0; i < objects.size(); ++i) {
      const OrientedBox& box = objects[i].box;
      EXPECT_GT(cocoClassId(objects[i].class_name), -1) << objects[i].class_name;
      // Gravity aligned, inside the room, standing on the floor, on the tv stand or on the table.
      EXPECT_NEAR(box.rotation.col(2).dot(Eigen::Vector3d::UnitZ()), 1.0, 1e-9);
      EXPECT_TRUE(isValidPose(Eigen::Isometry3d(box.rotation)));
      for (const Eigen::Vector3d& corner : box.corners()) {
        EXPECT_GE(corner.x(), 0.0);
        EXPECT_LE(corner.x(), config.room_size_x_m);
        EXPECT_GE(corner.y(), 0.0);
        EXPECT_LE(corner.y(), config.room_size_y_m);
        EXPECT_GE(corner.z(), -1e-9);
      }
      const double bottom_m = box.center_m.z() - 0.5 * box.size_m.z();
      const std::string& name = objects[i].class_name;
      if (name == "cup" || name == "book") {
        EXPECT_NEAR(bottom_m, table_top_m, 1e-9) << name;
        EXPECT_TRUE(table.contains(
            Eigen::Vector3d(box.center_m.x(), box.center_m.y(), table.center_m.z()), -0.05))
            << name << " is not on the table top";
      } else if (name != "tv") {
        EXPECT_NEAR(bottom_m, 0.0, 1e-9) << name;
      }
      // Boxes never overlap; chairs keep >= 0.15 m from the table and from each other so a box
      // detector's masks and LCCP can separate them.
      for (size_t j = i + 1; j < objects.size(); ++j) {
        EXPECT_DOUBLE_EQ(
            gravityAlignedIntersectionVolume(box, objects[j].box, Eigen::Vector3d::UnitZ()), 0.0)
            << name << " " << i << " overlaps " << objects[j].class_name << " " << j;
        if (name == "chair" || objects[j].class_name == "chair") {
          EXPECT_DOUBLE_EQ(
              gravityAlignedIntersectionVolume(
                  inflated(box, 0.075), inflated(objects[j].box, 0.075), Eigen::Vector3d::UnitZ()),
              0.0)
              << "seed " << seed << ": " << name << " " << i << " is closer than 0.15 m to "
              << objects[j].class_name << " " << j;
        }
      }
    }
  }
}

TEST_F(SyntheticSceneTest, SeedVariesTheSceneDeterministically) {
  SyntheticSceneConfig config;
  const SyntheticScene a = SyntheticScene::makeDefault(config);
  const SyntheticScene b = SyntheticScene::makeDefault(config);
  config.seed = 2;
  const SyntheticScene c = SyntheticScene::makeDefault(config);
  double max_difference_m = 0.0;
  for (size_t i = 0; i < a.objects().size(); ++i) {
    EXPECT_EQ(a.objects()[i].box.center_m, b.objects()[i].box.center_m);
    EXPECT_EQ(a.objects()[i].box.rotation, b.objects()[i].box.rotation);
    EXPECT_EQ(a.objects()[i].class_name, c.objects()[i].class_name);
    max_difference_m = std::max(max_difference_m,
                                (a.objects()[i].box.center_m - c.objects()[i].box.center_m).norm());
  }
  EXPECT_GT(max_difference_m, 0.001);  // seeds vary the layout ...
  EXPECT_LT(max_difference_m, 0.2);    // ... only a little
}

TEST_F(SyntheticSceneTest, CameraLoopLooksIntoTheRoom) {
  const SyntheticSceneConfig config;
  const SyntheticScene scene = SyntheticScene::makeDefault(config);
  const double pitch_rad = config.camera_pitch_deg * M_PI / 180.0;
  const Eigen::Vector3d room_center(0.5 * config.room_size_x_m, 0.5 * config.room_size_y_m, 0.4);
  double min_x = 1e9, max_x = -1e9, min_y = 1e9, max_y = -1e9;
  for (int i = 0; i < config.num_frames; ++i) {
    const Eigen::Isometry3d T_W_C = scene.cameraPose(i);
    ASSERT_TRUE(isValidPose(T_W_C, 1e-9)) << i;
    const Eigen::Vector3d position = T_W_C.translation();
    EXPECT_NEAR(position.z(), config.camera_height_m, 1e-9);
    EXPECT_GT(position.x(), 0.3);
    EXPECT_LT(position.x(), config.room_size_x_m - 0.3);
    EXPECT_GT(position.y(), 0.3);
    EXPECT_LT(position.y(), config.room_size_y_m - 0.3);
    // Optical frame: x right is horizontal (no roll), z forward is pitched, y points down.
    EXPECT_NEAR(T_W_C.linear().col(0).z(), 0.0, 1e-9);
    EXPECT_NEAR(T_W_C.linear().col(2).z(), std::sin(pitch_rad), 1e-9);
    EXPECT_LT(T_W_C.linear().col(1).z(), 0.0);
    // The room centre is ahead, near the image centre column.
    const Eigen::Vector3d center_C = T_W_C.inverse() * room_center;
    EXPECT_GT(center_C.z(), 1.0) << i;
    EXPECT_LT(std::abs(center_C.x() / center_C.z()), 0.1) << i;
    // Never inside or right next to an object (horizontal distance to its footprint).
    for (const SyntheticObject& object : scene.objects()) {
      EXPECT_GT(footprintDistance(object.box, position), 0.4)
          << "frame " << i << " " << object.class_name;
    }
    min_x = std::min(min_x, position.x());
    max_x = std::max(max_x, position.x());
    min_y = std::min(min_y, position.y());
    max_y = std::max(max_y, position.y());
  }
  // One lap around the room centre: the loop surrounds it and closes.
  EXPECT_LT(min_x, room_center.x() - 1.5);
  EXPECT_GT(max_x, room_center.x() + 1.5);
  EXPECT_LT(min_y, room_center.y() - 1.5);
  EXPECT_GT(max_y, room_center.y() + 1.5);
  EXPECT_TRUE(scene.cameraPose(config.num_frames).isApprox(scene.cameraPose(0), 1e-9));
}

TEST_F(SyntheticSceneTest, RenderIsDeterministicAndFillsTheFrame) {
  const SyntheticScene scene = SyntheticScene::makeDefault(smallConfig());
  RgbdFrame a, b;
  cv::Mat labels_a, labels_b;
  scene.render(7, &a, &labels_a);
  scene.render(7, &b, &labels_b);
  ASSERT_TRUE(a.validate().ok()) << a.validate().message();
  EXPECT_EQ(a.index, 7);
  EXPECT_EQ(a.name, "frame-000007");
  EXPECT_DOUBLE_EQ(a.stamp_s, 7 / 30.0);
  ASSERT_EQ(a.color_bgr.type(), CV_8UC3);
  ASSERT_EQ(a.depth.type(), CV_16UC1);
  ASSERT_EQ(labels_a.type(), CV_32SC1);
  EXPECT_EQ(a.depth.size(), cv::Size(160, 120));
  EXPECT_EQ(labels_a.size(), a.depth.size());
  EXPECT_TRUE(a.registered);
  EXPECT_DOUBLE_EQ(a.K_depth.fx, 131.25);
  EXPECT_DOUBLE_EQ(a.K_color.cy, 59.5);
  EXPECT_TRUE(a.T_W_D.isApprox(scene.cameraPose(7)));
  EXPECT_EQ(cv::norm(a.color_bgr, b.color_bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::countNonZero(labels_a != labels_b), 0);
  // A closed room: every pixel hits something.
  EXPECT_EQ(cv::countNonZero(a.depth == 0), 0);
  // Another frame differs.
  RgbdFrame c;
  scene.render(20, &c, nullptr);
  EXPECT_GT(cv::norm(a.depth, c.depth, cv::NORM_L1), 0.0);

  // Bad intrinsics: empty output, no crash.
  SyntheticSceneConfig bad = smallConfig();
  bad.K.width = 0;
  RgbdFrame empty;
  cv::Mat empty_labels;
  SyntheticScene(bad, scene.objects()).render(0, &empty, &empty_labels);
  EXPECT_TRUE(empty.depth.empty());
  EXPECT_TRUE(empty_labels.empty());
}

TEST_F(SyntheticSceneTest, DepthMatchesAnalyticFloorAndBoxHits) {
  SyntheticSceneConfig config = smallConfig();
  // An empty room first: a pixel below the horizon sees the floor at the analytic distance.
  const SyntheticScene empty(config, {});
  RgbdFrame frame;
  cv::Mat labels;
  empty.render(3, &frame, &labels);
  const Eigen::Isometry3d T_W_C = empty.cameraPose(3);
  const int u = 80, v = 110;
  const Eigen::Vector3d ray_W =
      T_W_C.linear() *
      Eigen::Vector3d((u - config.K.cx) / config.K.fx, (v - config.K.cy) / config.K.fy, 1.0);
  ASSERT_LT(ray_W.z(), 0.0);
  const double floor_depth_m = -T_W_C.translation().z() / ray_W.z();  // z of the camera frame
  EXPECT_NEAR(frame.depth.at<uint16_t>(v, u) * 1e-3, floor_depth_m, 0.0006);
  EXPECT_EQ(labels.at<int32_t>(v, u), 0);

  // Every pixel of the empty room back-projects onto a wall, the floor or the ceiling.
  for (int y = 0; y < frame.depth.rows; y += 7) {
    for (int x = 0; x < frame.depth.cols; x += 7) {
      const Eigen::Vector3d p_W = T_W_C * backProject(frame, x, y);
      const double to_surface =
          std::min({std::abs(p_W.x()), std::abs(p_W.x() - config.room_size_x_m), std::abs(p_W.y()),
                    std::abs(p_W.y() - config.room_size_y_m), std::abs(p_W.z()),
                    std::abs(p_W.z() - config.room_height_m)});
      EXPECT_LT(to_surface, 0.005) << x << "," << y << ": " << p_W.transpose();
    }
  }

  // One yawed box 2.5 m straight ahead: the centre pixel hits its near face, the labelled pixels
  // all lie on its surface.
  OrientedBox box;
  box.size_m = Eigen::Vector3d(0.6, 0.4, 2.0);
  box.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d axis_W = T_W_C.linear().col(2);
  box.center_m = T_W_C.translation() + 2.5 * axis_W;
  box.center_m.z() = 1.0;
  const SyntheticScene one(config, {{"chair", box}});
  one.render(3, &frame, &labels);
  const int count = cv::countNonZero(labels == 1);
  ASSERT_GT(count, 100);
  int on_surface = 0;
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      if (labels.at<int32_t>(y, x) != 1) continue;
      const Eigen::Vector3d p_W = T_W_C * backProject(frame, x, y);
      const bool inside = box.contains(p_W, 0.003);
      const bool deep_inside = box.contains(p_W, -0.003);
      on_surface += inside && !deep_inside;
    }
  }
  EXPECT_EQ(on_surface, count);
  // The centre pixel ray, intersected with the box by bisection on contains(): the first hit.
  const Eigen::Vector3d centre_ray_W =
      T_W_C.linear() *
      Eigen::Vector3d((80 - config.K.cx) / config.K.fx, (60 - config.K.cy) / config.K.fy, 1.0);
  double lo = 0.0, hi = 2.5;
  ASSERT_FALSE(box.contains(T_W_C.translation()));
  ASSERT_TRUE(box.contains(T_W_C.translation() + hi * centre_ray_W));
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (box.contains(T_W_C.translation() + mid * centre_ray_W) ? hi : lo) = mid;
  }
  EXPECT_EQ(labels.at<int32_t>(60, 80), 1);
  EXPECT_NEAR(frame.depth.at<uint16_t>(60, 80) * 1e-3, hi, 0.0006);
}

TEST_F(SyntheticSceneTest, LabelsAgreeWithDepth) {
  const SyntheticSceneConfig config = smallConfig();
  const SyntheticScene scene = SyntheticScene::makeDefault(config);
  const SyntheticScene room_only(config, {});
  for (const int i : {0, 13, 31, 47}) {
    RgbdFrame frame, room;
    cv::Mat labels;
    scene.render(i, &frame, &labels);
    room_only.render(i, &room, nullptr);
    const Eigen::Isometry3d& T_W_C = frame.T_W_D;
    int object_pixels = 0;
    int nearer = 0;
    for (int v = 0; v < labels.rows; ++v) {
      for (int u = 0; u < labels.cols; ++u) {
        const int k = labels.at<int32_t>(v, u);
        ASSERT_GE(k, 0);
        ASSERT_LE(k, static_cast<int>(scene.objects().size()));
        const Eigen::Vector3d p_W = T_W_C * backProject(frame, u, v);
        const uint16_t depth_mm = frame.depth.at<uint16_t>(v, u);
        const uint16_t room_mm = room.depth.at<uint16_t>(v, u);
        if (k > 0) {
          ++object_pixels;
          // On its object, and nearer than the room surface behind it.
          EXPECT_TRUE(scene.objects()[k - 1].box.contains(p_W, 0.004))
              << "frame " << i << " (" << u << "," << v << ") label " << k;
          EXPECT_LE(depth_mm, room_mm);
          nearer += depth_mm < room_mm;  // equal only where an object meets the floor or a wall
        } else {
          // Background: inside no labelled object, and no nearer than the room (the tv stand).
          for (const SyntheticObject& object : scene.objects()) {
            EXPECT_FALSE(object.box.contains(p_W, -0.004)) << object.class_name;
          }
          EXPECT_LE(depth_mm, room_mm);
        }
      }
    }
    EXPECT_GT(object_pixels, static_cast<int>(labels.total()) / 10) << "frame " << i;
    EXPECT_GT(nearer, 0.95 * object_pixels) << "frame " << i;
  }
}

TEST_F(SyntheticSceneTest, DetectionsFromLabelsMatchTheLabelImage) {
  const SyntheticScene scene = SyntheticScene::makeDefault(smallConfig());
  RgbdFrame frame;
  cv::Mat labels;
  scene.render(0, &frame, &labels);
  const std::vector<Detection2D> detections = scene.detectionsFromLabels(labels, 1);
  std::map<int, int> pixels;  // label -> count
  for (int v = 0; v < labels.rows; ++v) {
    for (int u = 0; u < labels.cols; ++u) {
      if (labels.at<int32_t>(v, u) > 0) ++pixels[labels.at<int32_t>(v, u)];
    }
  }
  ASSERT_EQ(detections.size(), pixels.size());
  ASSERT_GE(detections.size(), 5u);
  std::set<int> seen;
  for (const Detection2D& detection : detections) {
    ASSERT_EQ(detection.mask.type(), CV_8UC1);
    ASSERT_EQ(detection.mask.size(), labels.size());
    // The label under the mask, and the mask is exactly that label's pixels.
    std::vector<cv::Point> points;
    cv::findNonZero(detection.mask, points);
    ASSERT_FALSE(points.empty());
    const int k = labels.at<int32_t>(points.front());
    ASSERT_GT(k, 0);
    EXPECT_TRUE(seen.insert(k).second) << "two detections of object " << k;
    EXPECT_EQ(cv::countNonZero(detection.mask != (labels == k)), 0);
    EXPECT_EQ(cv::countNonZero(detection.mask == 255), pixels[k]);
    EXPECT_EQ(detection.box_px, cv::boundingRect(points));
    EXPECT_EQ(detection.class_name, scene.objects()[k - 1].class_name);
    EXPECT_EQ(detection.class_id, cocoClassId(detection.class_name));
    EXPECT_GE(detection.score, 0.8f);
    EXPECT_LE(detection.score, 0.99f);
  }

  // min_pixels drops the small ones; wrong input gives nothing.
  int min_pixels = 0;
  for (const auto& entry : pixels) min_pixels = std::max(min_pixels, entry.second);
  EXPECT_EQ(scene.detectionsFromLabels(labels, min_pixels).size(), 1u);
  EXPECT_TRUE(scene.detectionsFromLabels(labels, min_pixels + 1).empty());
  cv::Mat as_float;
  labels.convertTo(as_float, CV_32F);
  EXPECT_TRUE(scene.detectionsFromLabels(as_float).empty());
  EXPECT_TRUE(scene.detectionsFromLabels(cv::Mat()).empty());
}

TEST_F(SyntheticSceneTest, VisibleFractionMeasuresOcclusion) {
  SyntheticSceneConfig config = smallConfig();
  const Eigen::Isometry3d T_W_C = SyntheticScene(config, {}).cameraPose(0);
  const Eigen::Vector3d forward_W =
      Eigen::Vector3d(T_W_C.linear()(0, 2), T_W_C.linear()(1, 2), 0.0).normalized();
  auto boxAt = [&](double distance_m, double width_m, double height_m) {
    OrientedBox box;
    box.size_m = Eigen::Vector3d(width_m, width_m, height_m);
    box.center_m = T_W_C.translation() + distance_m * forward_W;
    box.center_m.z() = 0.5 * height_m;
    return box;
  };
  // A box alone in view: fully visible.
  const OrientedBox target = boxAt(3.0, 0.5, 0.9);
  const SyntheticScene alone(config, {{"chair", target}});
  cv::Mat labels;
  alone.render(0, nullptr, &labels);
  EXPECT_GT(alone.visibleFraction(0, labels, 0), 0.9);
  // A wide, low box in front hides its lower part.
  const SyntheticScene hidden(config, {{"chair", target}, {"couch", boxAt(2.0, 1.6, 0.8)}});
  hidden.render(0, nullptr, &labels);
  const double fraction = hidden.visibleFraction(0, labels, 0);
  EXPECT_GT(fraction, 0.05);
  EXPECT_LT(fraction, 0.6);
  EXPECT_EQ(hidden.visibleFraction(0, labels, 2), 0.0);
  EXPECT_EQ(hidden.visibleFraction(0, labels, -1), 0.0);
  EXPECT_EQ(hidden.visibleFraction(0, cv::Mat(), 0), 0.0);
}

TEST_F(SyntheticSceneTest, NoiseAndHolesChangeDepthOnlyAsConfigured) {
  SyntheticSceneConfig config = smallConfig();
  const SyntheticScene clean = SyntheticScene::makeDefault(config);
  RgbdFrame reference;
  cv::Mat reference_labels;
  clean.render(5, &reference, &reference_labels);

  // Noise only: no holes, sigma = k z^2, colour and labels unchanged, reproducible.
  config.depth_noise_m_per_m2 = 0.003;
  const SyntheticScene noisy = SyntheticScene::makeDefault(config);
  RgbdFrame a, b;
  cv::Mat labels;
  noisy.render(5, &a, &labels);
  noisy.render(5, &b, nullptr);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.color_bgr, reference.color_bgr, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::countNonZero(labels != reference_labels), 0);
  EXPECT_EQ(cv::countNonZero(a.depth == 0), 0);
  double sum_sq = 0.0;
  int changed = 0;
  const int total = static_cast<int>(a.depth.total());
  for (int v = 0; v < a.depth.rows; ++v) {
    for (int u = 0; u < a.depth.cols; ++u) {
      const double z = reference.depth.at<uint16_t>(v, u) * 1e-3;
      const double error = a.depth.at<uint16_t>(v, u) * 1e-3 - z;
      const double sigma = config.depth_noise_m_per_m2 * z * z;
      EXPECT_LE(std::abs(error), 6.0 * sigma + 0.001) << u << "," << v;
      sum_sq += (error * error) / (sigma * sigma + 1e-12);
      changed += error != 0.0;
    }
  }
  EXPECT_GT(changed, total / 2);
  EXPECT_NEAR(std::sqrt(sum_sq / total), 1.0, 0.25);  // rounding to mm adds a little
  RgbdFrame other;
  noisy.render(6, &other, nullptr);
  RgbdFrame other_clean;
  clean.render(6, &other_clean, nullptr);
  EXPECT_GT(cv::norm(other.depth, other_clean.depth, cv::NORM_L1), 0.0);

  // Holes only: the other pixels are exact, about hole_fraction of them are 0.
  config.depth_noise_m_per_m2 = 0.0;
  config.hole_fraction = 0.1;
  const SyntheticScene holey = SyntheticScene::makeDefault(config);
  holey.render(5, &a, nullptr);
  const cv::Mat valid = a.depth != 0;
  EXPECT_NEAR(static_cast<double>(total - cv::countNonZero(valid)) / total, 0.1, 0.02);
  cv::Mat difference;
  cv::absdiff(a.depth, reference.depth, difference);
  difference.setTo(0, ~valid);
  EXPECT_EQ(cv::countNonZero(difference), 0);
  // Each frame has its own holes.
  holey.render(6, &b, nullptr);
  EXPECT_GT(cv::countNonZero((a.depth == 0) != (b.depth == 0)), total / 20);
}

TEST_F(SyntheticSceneTest, WritesSevenScenesLayout) {
  SyntheticSceneConfig config = smallConfig();
  config.num_frames = 4;
  const SyntheticScene scene = SyntheticScene::makeDefault(config);
  const fs::path dataset = work_ / "dataset";
  const fs::path detections = work_ / "nested" / "detections";
  const Status written = scene.writeSevenScenes(dataset.string(), detections.string());
  ASSERT_TRUE(written.ok()) << written.message();

  int files = 0;
  for (const auto& entry : fs::directory_iterator(dataset)) files += entry.is_regular_file();
  EXPECT_EQ(files, 4 * 3 + 3);  // colour, depth, pose per frame; intrinsics, gravity, ground truth
  for (int i = 0; i < config.num_frames; ++i) {
    char stem[32];
    std::snprintf(stem, sizeof(stem), "frame-%06d", i);
    EXPECT_TRUE(fs::exists(dataset / (std::string(stem) + ".color.png"))) << stem;
    EXPECT_TRUE(fs::exists(detections / (std::string(stem) + ".json"))) << stem;
  }

  // Pose back: 4x4 row-major camera to world.
  std::istringstream pose_text(test::readText(dataset / "frame-000002.pose.txt"));
  Eigen::Matrix4d pose;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) ASSERT_TRUE(pose_text >> pose(r, c));
  }
  EXPECT_TRUE(pose.isApprox(scene.cameraPose(2).matrix(), 1e-8)) << pose;
  std::istringstream k_text(test::readText(dataset / "camera-intrinsics.txt"));
  Eigen::Matrix3d K;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) ASSERT_TRUE(k_text >> K(r, c));
  }
  EXPECT_TRUE(K.isApprox(config.K.K()));
  std::istringstream gravity_text(test::readText(dataset / "gravity-direction.txt"));
  Eigen::Vector3d gravity;
  ASSERT_TRUE(gravity_text >> gravity.x() >> gravity.y() >> gravity.z());
  EXPECT_EQ(gravity, Eigen::Vector3d(0, 0, -1));

  // Images back: the depth PNG is the 16-bit render, the colour PNG lossless.
  RgbdFrame frame;
  cv::Mat labels;
  scene.render(2, &frame, &labels);
  const cv::Mat depth =
      cv::imread((dataset / "frame-000002.depth.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(depth, frame.depth, cv::NORM_INF), 0.0);
  const cv::Mat color = cv::imread((dataset / "frame-000002.color.png").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(color, frame.color_bgr, cv::NORM_INF), 0.0);

  // Detections back: the objects visible enough, with their exact masks.
  FileInstanceSegmenter reader(detections.string());
  std::vector<Detection2D> read;
  ASSERT_TRUE(reader.detect(frame.color_bgr, frame.name, &read).ok());
  std::vector<Detection2D> expected;
  for (Detection2D& detection : scene.detectionsFromLabels(labels)) {
    std::vector<cv::Point> points;
    cv::findNonZero(detection.mask, points);
    const int k = labels.at<int32_t>(points.front()) - 1;
    if (scene.visibleFraction(2, labels, k) >= config.min_visible_fraction) {
      expected.push_back(detection);
    }
  }
  ASSERT_FALSE(expected.empty());
  ASSERT_EQ(read.size(), expected.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].class_name, expected[i].class_name);
    ASSERT_EQ(read[i].mask.size(), expected[i].mask.size());
    EXPECT_EQ(cv::countNonZero((read[i].mask != 0) != (expected[i].mask != 0)), 0) << i;
  }

  // Ground truth.
  const nlohmann::json truth = nlohmann::json::parse(test::readText(dataset / "ground_truth.json"));
  ASSERT_EQ(truth.at("objects").size(), scene.objects().size());
  for (size_t i = 0; i < scene.objects().size(); ++i) {
    const nlohmann::json& object = truth["objects"][i];
    const OrientedBox& box = scene.objects()[i].box;
    EXPECT_EQ(object.at("class_name").get<std::string>(), scene.objects()[i].class_name);
    for (int a = 0; a < 3; ++a) {
      EXPECT_DOUBLE_EQ(object.at("center")[a].get<double>(), box.center_m[a]);
      EXPECT_DOUBLE_EQ(object.at("size")[a].get<double>(), box.size_m[a]);
      for (int b = 0; b < 3; ++b) {
        EXPECT_DOUBLE_EQ(object.at("rotation")[a][b].get<double>(), box.rotation(a, b));
      }
    }
    EXPECT_NEAR(object.at("yaw").get<double>(), std::atan2(box.rotation(1, 0), box.rotation(0, 0)),
                1e-12);
  }

  // Without a detections folder only the dataset is written.
  const fs::path plain = work_ / "plain";
  ASSERT_TRUE(scene.writeSevenScenes(plain.string(), "").ok());
  EXPECT_TRUE(fs::exists(plain / "ground_truth.json"));
}

TEST_F(SyntheticSceneTest, WriteErrorsNameThePath) {
  SyntheticSceneConfig config = smallConfig();
  config.num_frames = 1;
  const SyntheticScene scene = SyntheticScene::makeDefault(config);
  const fs::path file = work_ / "a_file";
  std::ofstream(file) << "x";
  const Status under_file = scene.writeSevenScenes((file / "dataset").string(), "");
  ASSERT_FALSE(under_file.ok());
  EXPECT_NE(under_file.message().find((file / "dataset").string()), std::string::npos)
      << under_file.message();
  const Status detections_under_file =
      scene.writeSevenScenes((work_ / "ok").string(), (file / "detections").string());
  ASSERT_FALSE(detections_under_file.ok());
  EXPECT_NE(detections_under_file.message().find("detections"), std::string::npos)
      << detections_under_file.message();
  EXPECT_FALSE(scene.writeSevenScenes("", "").ok());
}

// What the offline runner test needs: every large object is seen well, from several keyframes.
TEST_F(SyntheticSceneTest, LargeObjectsAreVisibleInManyDefaultFrames) {
  const SyntheticSceneConfig config;
  const SyntheticScene scene = SyntheticScene::makeDefault(config);
  const size_t count = scene.objects().size();
  std::vector<int> frames_seen(count, 0), keyframes_detected(count, 0);
  for (int i = 0; i < config.num_frames; ++i) {
    cv::Mat labels;
    scene.render(i, nullptr, &labels);
    for (size_t k = 0; k < count; ++k) {
      frames_seen[k] += cv::countNonZero(labels == static_cast<int>(k) + 1) >= 2000;
      if (i % 5 == 0) {
        keyframes_detected[k] +=
            scene.visibleFraction(i, labels, static_cast<int>(k)) >= config.min_visible_fraction;
      }
    }
  }
  int large = 0;
  for (size_t k = 0; k < count; ++k) {
    if (scene.objects()[k].box.size_m.minCoeff() < 0.3) continue;
    ++large;
    EXPECT_GE(frames_seen[k], 10) << scene.objects()[k].class_name << " " << k;
    EXPECT_GE(keyframes_detected[k], 2) << scene.objects()[k].class_name << " " << k;
  }
  EXPECT_EQ(large, 6);  // table, 4 chairs, couch
}

}  // namespace
}  // namespace mvod
