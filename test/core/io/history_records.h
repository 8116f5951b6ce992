// Keyframe records made for the io tests (the single-file history, the map folder): every field
// set to a value that a round trip could get wrong, and comparisons field by field.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/keyframe_history.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace test {

inline KeyframeRecord makeRecord(int keyframe, int depth_type) {
  KeyframeRecord record;
  record.keyframe = keyframe;
  record.stamp_s = 100.25 + keyframe;
  record.name = "frame-" + std::to_string(keyframe);
  record.T_W_D_recorded.linear() =
      Eigen::AngleAxisd(0.3 * keyframe + 0.1, Eigen::Vector3d(0.2, 1.0, -0.4).normalized())
          .matrix();
  record.T_W_D_recorded.translation() = Eigen::Vector3d(1.5, -0.25, 0.125 * keyframe);
  record.T_W_D = Eigen::Translation3d(0.01, 0.02, -0.03) * record.T_W_D_recorded;
  record.T_C_D.translation() = Eigen::Vector3d(0.025, 0.0, 0.0);
  record.K_depth = CameraIntrinsics{525.0, 526.5, 319.5, 239.25, 8, 6};
  if (depth_type == CV_16UC1) {
    record.depth = cv::Mat(6, 8, CV_16UC1);
    for (int i = 0; i < 48; ++i)
      record.depth.at<std::uint16_t>(i) = static_cast<std::uint16_t>(i * 997);
  } else {
    record.depth = cv::Mat(6, 8, CV_32FC1);
    for (int i = 0; i < 48; ++i) record.depth.at<float>(i) = 0.5f + 0.0123f * i;
    record.depth.at<float>(3) = std::numeric_limits<float>::quiet_NaN();
  }
  record.has_floor = keyframe % 2 == 0;
  if (record.has_floor) record.floor_point_D = Eigen::Vector3d(0.1, 1.2, 2.3);
  record.refined_after = keyframe % 2 == 1;
  RecordedView view;
  view.class_id = 56;
  view.class_name = "chair";
  view.probability = 0.8125;
  view.box.center_m = Eigen::Vector3d(1.0, 2.0, 0.45);
  view.box.size_m = Eigen::Vector3d(0.5, 0.55, 0.9);
  view.box.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).matrix();
  view.yaw_rad = 0.7;
  view.object_id = 3 + keyframe;
  auto cut = std::make_shared<RecordedCut>();
  cut->cut_W = {Eigen::Vector3f(1.0001f, 2.123456f, 0.3f), Eigen::Vector3f(-3.5f, 1e-7f, 9.75f)};
  cut->normals_W = {Eigen::Vector3f(0.f, 0.6f, 0.8f),
                    Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN())};
  cut->outside_keys = {packVoxel(Eigen::Vector3i(-5, 3, 100)),
                       packVoxel(Eigen::Vector3i(7, -1, 0))};
  std::sort(cut->outside_keys.begin(), cut->outside_keys.end());
  cut->voxel_size_m = 0.01;
  view.cut = cut;
  record.views.push_back(view);
  return record;
}

inline bool sameFloats(const std::vector<Eigen::Vector3f>& a,
                       const std::vector<Eigen::Vector3f>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      if (std::isnan(a[i][k]) != std::isnan(b[i][k])) return false;
      if (!std::isnan(a[i][k]) && a[i][k] != b[i][k]) return false;
    }
  }
  return true;
}

// a and b hold the same keyframes, field by field, bit for bit.
inline void expectSameHistory(const std::deque<KeyframeRecord>& a,
                              const std::deque<KeyframeRecord>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE("keyframe record " + std::to_string(i));
    const KeyframeRecord& x = a[i];
    const KeyframeRecord& y = b[i];
    EXPECT_EQ(x.keyframe, y.keyframe);
    EXPECT_EQ(x.stamp_s, y.stamp_s);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.T_W_D_recorded.matrix(), y.T_W_D_recorded.matrix());
    EXPECT_EQ(x.T_W_D.matrix(), y.T_W_D.matrix());
    EXPECT_EQ(x.T_C_D.matrix(), y.T_C_D.matrix());
    EXPECT_EQ(x.K_depth.fx, y.K_depth.fx);
    EXPECT_EQ(x.K_depth.fy, y.K_depth.fy);
    EXPECT_EQ(x.K_depth.cx, y.K_depth.cx);
    EXPECT_EQ(x.K_depth.cy, y.K_depth.cy);
    EXPECT_EQ(x.K_depth.width, y.K_depth.width);
    EXPECT_EQ(x.K_depth.height, y.K_depth.height);
    EXPECT_EQ(x.has_floor, y.has_floor);
    EXPECT_EQ(x.refined_after, y.refined_after);
    if (x.has_floor) {
      EXPECT_EQ(x.floor_point_D, y.floor_point_D);
    }
    EXPECT_EQ(x.depth_coarse, y.depth_coarse);
    ASSERT_EQ(x.depth.empty(), y.depth.empty());
    if (!x.depth.empty()) {
      ASSERT_EQ(x.depth.type(), y.depth.type());
      ASSERT_EQ(x.depth.size(), y.depth.size());
      const cv::Mat xc = x.depth.isContinuous() ? x.depth : x.depth.clone();
      const cv::Mat yc = y.depth.isContinuous() ? y.depth : y.depth.clone();
      EXPECT_EQ(std::memcmp(xc.data, yc.data, xc.total() * xc.elemSize()), 0);
    }
    ASSERT_EQ(x.views.size(), y.views.size());
    for (std::size_t k = 0; k < x.views.size(); ++k) {
      const RecordedView& u = x.views[k];
      const RecordedView& v = y.views[k];
      EXPECT_EQ(u.class_name, v.class_name);
      EXPECT_EQ(u.class_id, v.class_id);
      EXPECT_EQ(u.probability, v.probability);
      EXPECT_EQ(u.object_id, v.object_id);
      EXPECT_EQ(u.yaw_rad, v.yaw_rad);
      EXPECT_EQ(u.box.center_m, v.box.center_m);
      EXPECT_EQ(u.box.size_m, v.box.size_m);
      EXPECT_EQ(u.box.rotation, v.box.rotation);
      ASSERT_NE(v.cut, nullptr);
      EXPECT_TRUE(sameFloats(u.cut->cut_W, v.cut->cut_W));
      EXPECT_TRUE(sameFloats(u.cut->normals_W, v.cut->normals_W));
      EXPECT_EQ(u.cut->outside_keys, v.cut->outside_keys);
      EXPECT_EQ(u.cut->voxel_size_m, v.cut->voxel_size_m);
    }
  }
}

}  // namespace test
}  // namespace mvod
