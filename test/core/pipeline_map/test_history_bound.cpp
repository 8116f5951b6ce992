// The keyframe history's memory bound (corrections/max_memory_mb, issue 48): the history never
// holds more than the bound, the oldest keyframes degrade first (coarse depth, then views only,
// then forgotten) and the newest keep their depth; a coarsened depth image sees what the full one
// saw.
#include <gtest/gtest.h>

#include <memory>

#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/map/keyframe_history.h"

namespace mvod {
namespace {

// A keyframe of 640 x 480 16-bit depth (0.6 MB) and one view of `points` cut points.
KeyframeRecord boundTestRecord(int keyframe, int points) {
  KeyframeRecord record;
  record.keyframe = keyframe;
  record.stamp_s = keyframe;
  record.K_depth = CameraIntrinsics{525.0, 525.0, 319.5, 239.5, 640, 480};
  record.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar(1500));
  RecordedView view;
  view.class_name = "chair";
  auto cut = std::make_shared<RecordedCut>();
  cut->cut_W.assign(points, Eigen::Vector3f(0.f, 0.f, 1.5f));
  cut->normals_W.assign(points, Eigen::Vector3f(0.f, 0.f, -1.f));
  cut->voxel_size_m = 0.01;
  view.cut = cut;
  record.views.push_back(view);
  return record;
}

// 0 no depth, 1 coarse, 2 full.
int depthTier(const KeyframeRecord& record) {
  return record.depth.empty() ? 0 : record.depth_coarse ? 1 : 2;
}

TEST(HistoryBoundTest, TheBoundHoldsAndTheOldestDegradeFirst) {
  KeyframeHistory::Config config;
  config.max_memory_mb = 5.0;
  KeyframeHistory history(config);
  for (int k = 0; k < 40; ++k) {
    history.add(boundTestRecord(k, 10000));  // 0.6 MB of depth, 0.24 MB of cut
    ASSERT_LE(history.memoryBytes(), std::size_t{5} << 20) << "after keyframe " << k;
  }
  const KeyframeHistory::Usage usage = history.usage();
  EXPECT_GT(usage.full_depth, 0);
  EXPECT_GT(usage.coarse_depth, 0);
  EXPECT_GT(usage.views_only, 0);
  EXPECT_GT(usage.forgotten, 0);
  EXPECT_EQ(usage.keyframes + usage.forgotten, 40);
  // The newest are kept, in order, and along them the depth only gets better.
  const auto& records = history.records();
  EXPECT_EQ(records.back().keyframe, 39);
  EXPECT_EQ(depthTier(records.back()), 2) << "the newest keyframe lost its depth";
  for (std::size_t i = 1; i < records.size(); ++i) {
    EXPECT_EQ(records[i].keyframe, records[i - 1].keyframe + 1);
    EXPECT_LE(depthTier(records[i - 1]), depthTier(records[i]))
        << "keyframe " << records[i].keyframe;
  }
  // Depth images take at most a quarter of the bound once views had to go.
  EXPECT_LE(usage.depth_bytes, (std::size_t{5} << 20) / 4);
}

TEST(HistoryBoundTest, UnderTheBoundNothingChanges) {
  KeyframeHistory history;  // 1024 MB
  for (int k = 0; k < 20; ++k) history.add(boundTestRecord(k, 1000));
  const KeyframeHistory::Usage usage = history.usage();
  EXPECT_EQ(usage.full_depth, 20);
  EXPECT_EQ(usage.coarse_depth + usage.views_only + usage.forgotten, 0);
  for (const KeyframeRecord& record : history.records()) EXPECT_EQ(record.revision, 0);
}

TEST(HistoryBoundTest, ACoarseDepthSeesWhatTheFullOneSaw) {
  // A wall 2 m away with a box 1.4 m away in front of its left half, in metres (32-bit).
  KeyframeRecord record;
  record.K_depth = CameraIntrinsics{525.0, 525.0, 319.5, 239.5, 640, 480};
  record.depth = cv::Mat(480, 640, CV_32FC1, cv::Scalar(2.0f));
  record.depth(cv::Rect(100, 100, 200, 200)).setTo(1.4f);
  record.T_W_D.translation() = Eigen::Vector3d(0.5, -0.25, 1.0);
  const KeyframeRecord full = record;
  coarsenDepth(&record);
  EXPECT_TRUE(record.depth_coarse);
  EXPECT_EQ(record.revision, 1);
  EXPECT_EQ(record.depth.type(), CV_16UC1);
  EXPECT_EQ(record.depth.size(), cv::Size(320, 240));
  EXPECT_EQ(record.K_depth.width, 320);
  EXPECT_EQ(record.depth.at<std::uint16_t>(60, 60), 1400);  // the box, in mm
  const auto view = [](const KeyframeRecord& r) {
    return makeDepthView(r.depth, r.K_depth, r.T_W_D, 0.1, 10.0, 0.02, 8.55e-3);
  };
  const std::shared_ptr<DepthView> a = view(full);
  const std::shared_ptr<DepthView> b = view(record);
  int compared = 0;
  for (int v = 20; v < 460; v += 37) {
    for (int u = 20; u < 620; u += 41) {
      // A point 1 cm before the surface at pixel (u, v), and one 30 cm before it (seen free).
      const double z = u >= 100 && u < 300 && v >= 100 && v < 300 ? 1.4 : 2.0;
      for (const double before_m : {0.01, 0.3}) {
        const double d = z - before_m;
        const Eigen::Vector3d p_D((u - 319.5) * d / 525.0, (v - 239.5) * d / 525.0, d);
        const Eigen::Vector3f p_W = (record.T_W_D * p_D).cast<float>();
        float sdf_a = 0.f, sdf_b = 0.f;
        const bool seen_a = a->signedDistance(p_W, &sdf_a);
        const bool seen_b = b->signedDistance(p_W, &sdf_b);
        EXPECT_EQ(a->visibility(p_W, 0.05), b->visibility(p_W, 0.05)) << u << "," << v;
        if (!seen_a || !seen_b) continue;  // at the box's edge the views abstain, each at its scale
        EXPECT_NEAR(sdf_a, sdf_b, 0.0011) << u << "," << v;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 100);
}

}  // namespace
}  // namespace mvod
