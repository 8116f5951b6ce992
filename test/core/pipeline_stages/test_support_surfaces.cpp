// The cut's support-surface rules (class priors on_floor / flat_top, SegmentSelector) on ray-cast
// scenes of several boxes: a table with a cup and papers on it and a chair pushed under it, as on
// the 7-Scenes redkitchen. Each rule is also switched off to show that the scene needs it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "part_scene.h"

namespace mvod {
namespace {

// A 1.4 x 0.8 m table (top 0.72-0.76 m) centred at the origin with a cup, a tissue box and a stack
// of papers on it, and a chair pushed under its far side: legs, seat under the top, backrest rising
// to 0.95 m just behind the table's far edge (y = 0.4).
test::PartScene tableScene() {
  test::PartScene scene;
  const auto add = [&scene](const std::string& object, Eigen::Vector3d lo, Eigen::Vector3d hi) {
    scene.parts.push_back(test::Part{object, lo, hi});
  };
  add("table", {-0.7, -0.4, 0.72}, {0.7, 0.4, 0.76});
  for (const double x : {-0.65, 0.6}) {
    for (const double y : {-0.35, 0.3}) add("table", {x, y, 0.0}, {x + 0.05, y + 0.05, 0.72});
  }
  add("cup", {-0.45, -0.15, 0.76}, {-0.37, -0.07, 0.86});
  add("papers", {0.05, 0.0, 0.76}, {0.35, 0.3, 0.775});
  add("tissues", {0.14, -0.12, 0.76}, {0.34, 0.0, 0.86});
  // The chair: seat under the table top, backrest behind the far edge.
  add("chair", {0.0, 0.05, 0.42}, {0.46, 0.5, 0.46});
  add("chair", {0.0, 0.45, 0.46}, {0.46, 0.5, 0.95});
  for (const double x : {0.0, 0.42}) {
    for (const double y : {0.05, 0.46}) add("chair", {x, y, 0.0}, {x + 0.04, y + 0.04, 0.42});
  }
  return scene;
}

class SupportSurfacesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    table_.class_name = "dining table";
    table_.has_size = true;
    table_.size_m = Eigen::Vector3d(1.5, 0.9, 0.75);
    table_.fusion_distance_m = 0.8;
    table_.on_floor = true;
    table_.flat_top = true;
    chair_.class_name = "chair";
    chair_.has_size = true;
    chair_.size_m = Eigen::Vector3d(0.55, 0.55, 0.9);
    chair_.fusion_distance_m = 0.3;
    chair_.on_floor = true;
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    scene_ = tableScene();
    // In front of the table's near side, 1.5 m up, looking at the table top.
    T_W_D_ = test::lookAt(Eigen::Vector3d(0.3, -1.6, 1.5), Eigen::Vector3d(0.1, 0.2, 0.6));
  }

  // One keyframe with one box-only detection; false when the detection gave no object.
  bool run(const ClassPrior& prior, const ObjectMapper::Config& config, const cv::Rect& box,
           const RgbdFrame& frame, OrientedBox* result, double* highest_point_m = nullptr) {
    ClassPriors priors;
    priors.set(prior);
    ObjectMapper mapper(config, priors);
    const Detection2D detection = test::boxOnlyDetection(prior.class_name, box, frame.depth.size());
    KeyframeReport report;
    EXPECT_TRUE(mapper.processKeyframe(frame, {detection}, &report).ok());
    for (const std::string& warning : report.warnings) std::printf("  %s\n", warning.c_str());
    if (mapper.database().size() != 1u) return false;
    const MapObject& object = mapper.database().objects().begin()->second;
    *result = object.box;
    if (highest_point_m != nullptr) {
      *highest_point_m = -1e9;
      for (const Eigen::Vector3f& p : object.segment_W) {
        *highest_point_m = std::max(*highest_point_m, static_cast<double>(p.z()));
      }
    }
    return true;
  }

  static ClassPrior sizedPrior(const std::string& class_name, const Eigen::Vector3d& size_m,
                               double fusion_distance_m) {
    ClassPrior prior;
    prior.class_name = class_name;
    prior.has_size = true;
    prior.size_m = size_m;
    prior.fusion_distance_m = fusion_distance_m;
    return prior;
  }

  // One keyframe with one mask detection of prior's class; false when it gave no object.
  bool runMask(const ClassPrior& prior, const RgbdFrame& frame, const cv::Mat& mask,
               OrientedBox* result) const {
    ClassPriors priors;
    priors.set(prior);
    ObjectMapper mapper(config_, priors);
    KeyframeReport report;
    EXPECT_TRUE(mapper
                    .processKeyframe(frame, {test::detectionFromMask(mask, prior.class_name, 0.6f)},
                                     &report)
                    .ok());
    for (const std::string& warning : report.warnings) std::printf("  %s\n", warning.c_str());
    if (mapper.database().size() != 1u) return false;
    *result = mapper.database().objects().begin()->second.box;
    return true;
  }

  static double top(const OrientedBox& box) { return box.center_m.z() + 0.5 * box.size_m.z(); }
  static double maxY(const OrientedBox& box) {
    double y = -1e9;
    for (int i = 0; i < 4; ++i) {
      y = std::max(y, box.center_m.y() +
                          box.rotation(1, 0) * ((i & 1) ? 0.5 : -0.5) * box.size_m.x() +
                          box.rotation(1, 1) * ((i & 2) ? 0.5 : -0.5) * box.size_m.y());
    }
    return y;
  }

  ClassPrior table_;
  ClassPrior chair_;
  ObjectMapper::Config config_;
  test::PartScene scene_;
  Eigen::Isometry3d T_W_D_;
};

TEST_F(SupportSurfacesTest, NothingAboveATableTopIsPartOfTheTable) {
  cv::Rect box;
  const RgbdFrame frame = scene_.render(T_W_D_, "table", &box);
  ASSERT_GT(box.area(), 10000);
  // A detector's box of a table takes in the chairs around it: here the backrest above its far
  // edge. The box then holds the cup, the papers and the backrest.
  box.y -= 60;
  box.height += 60;
  OrientedBox ours;
  double highest_m = 0.0;
  ASSERT_TRUE(run(table_, config_, box, frame, &ours, &highest_m));
  EXPECT_NEAR(top(ours), 0.76, 0.03) << "the cup (0.86 m) or the backrest (0.95 m) joined";
  EXPECT_LT(highest_m, 0.76 + 0.045) << "something above the top joined";
  // (The chair's legs under the table still join it: its footprint is not checked here.)

  ClassPrior without = table_;
  without.flat_top = false;
  OrientedBox theirs;
  ASSERT_TRUE(run(without, config_, box, frame, &theirs));
  EXPECT_GT(top(theirs), 0.82) << "the scene does not test flat_top";
  (void)maxY;
}

TEST_F(SupportSurfacesTest, ThingsOnATableInAChairsBoxAreNotTheChair) {
  cv::Rect box;
  const RgbdFrame frame = scene_.render(T_W_D_, "chair", &box);
  ASSERT_GT(box.area(), 2000);
  // A detector's box is not exact: this one clips 6 px off the backrest's right end, so the
  // backrest continues past it in the ring, as a wall would.
  box.width -= 6;
  // The chair's box also covers the table top in front of the backrest, and the papers and the
  // tissue box on it.
  OrientedBox ours;
  ASSERT_TRUE(run(chair_, config_, box, frame, &ours));
  EXPECT_GT(top(ours), 0.9) << "not the backrest";
  EXPECT_GT(ours.center_m.y(), 0.4) << "not the backrest (tissues: y -0.06)";

  // Without on_floor the tissue box, with most points in the box's core, is the chair.
  ClassPrior without = chair_;
  without.on_floor = false;
  OrientedBox theirs;
  ASSERT_TRUE(run(without, config_, box, frame, &theirs));
  EXPECT_LT(theirs.center_m.y(), 0.2) << "the scene does not test on_floor";
  // LCCP left a few of the backrest's lowest points in the table top's segment, which widens the
  // top's footprint up to the backrest: without the edge margin the backrest "rests" on the top.
  ObjectMapper::Config no_margin = config_;
  no_margin.selection.resting_edge_margin_m = 0.0;
  OrientedBox on_rim;
  if (run(chair_, no_margin, box, frame, &on_rim)) {
    EXPECT_LT(top(on_rim), 0.9) << "the scene does not test resting_edge_margin_m";
  }
  // Without the side share, the clipped backrest is a bounding surface and is dropped.
  ObjectMapper::Config any_count = config_;
  any_count.selection.min_ring_share = 0.0;
  OrientedBox clipped;
  if (run(chair_, any_count, box, frame, &clipped)) {
    EXPECT_LT(clipped.center_m.y(), 0.3) << "the scene does not test min_ring_share";
  }
}

TEST_F(SupportSurfacesTest, TheCupOnTheTableIsStillACup) {
  // on_floor and flat_top are the table's and the chair's: a cup keeps what stands on a table.
  ClassPrior cup;
  cup.class_name = "cup";
  cup.has_size = true;
  cup.size_m = Eigen::Vector3d(0.09, 0.09, 0.10);
  cup.fusion_distance_m = 0.1;
  cv::Rect box;
  const RgbdFrame frame = scene_.render(T_W_D_, "cup", &box);
  ASSERT_GT(box.area(), 100);
  OrientedBox ours;
  ASSERT_TRUE(run(cup, config_, box, frame, &ours));
  EXPECT_NEAR(top(ours), 0.86, 0.03);
  EXPECT_NEAR(ours.center_m.x(), -0.41, 0.04);
  EXPECT_NEAR(ours.center_m.y(), -0.11, 0.04);
}

// A real instance mask of a table (YOLOv5-seg's on the redkitchen): its top, with holes where the
// cup, the tissues and the papers stand, and stopping short of the edges. The ring around it is
// full of table top, which the cut took for "a surface running past the detection" and refused the
// table. A class with large horizontal surfaces of its own keeps them.
TEST_F(SupportSurfacesTest, ARealMaskOfTheTableIsTheTable) {
  cv::Rect box;
  cv::Mat mask;
  const RgbdFrame frame = scene_.render(T_W_D_, "table", &box, &mask);
  cv::erode(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(17, 17)));
  ASSERT_GT(cv::countNonZero(mask), 20000);
  OrientedBox ours;
  ASSERT_TRUE(runMask(table_, frame, mask, &ours)) << "the table refused";
  EXPECT_NEAR(top(ours), 0.76, 0.03);
  EXPECT_GT(std::max(ours.size_m.x(), ours.size_m.y()), 1.2);  // most of its 1.4 m

  // A class the same size that is not flat-topped (and under 0.8 m across): its own top is a
  // bounding surface, as before.
  ClassPrior small = table_;
  small.flat_top = false;
  small.size_m = Eigen::Vector3d(0.7, 0.7, 0.75);
  OrientedBox theirs;
  EXPECT_FALSE(runMask(small, frame, mask, &theirs)) << "the scene does not test the surface rule";
}

// A magazine lying on the table is part of its plane in depth (5 mm thick): LCCP cannot cut it out,
// and the core of its (good) mask holds only the table top. A class that lies flat is that plane
// inside its mask: a thin box on the table.
TEST_F(SupportSurfacesTest, AMagazineLyingOnTheTableIsAThinBoxOnIt) {
  test::PartScene scene = scene_;
  scene.parts.push_back(test::Part{"magazine", {-0.35, 0.1, 0.76}, {-0.1, 0.3, 0.765}});
  cv::Rect box;
  cv::Mat mask;
  const RgbdFrame frame = scene.render(T_W_D_, "magazine", &box, &mask);
  ASSERT_GT(cv::countNonZero(mask), 1000);
  const ClassPrior book = sizedPrior("book", Eigen::Vector3d(0.23, 0.16, 0.03), 0.1);
  ASSERT_TRUE(book.liesFlat());
  OrientedBox ours;
  ASSERT_TRUE(runMask(book, frame, mask, &ours));
  EXPECT_NEAR(ours.center_m.x(), -0.225, 0.03);
  EXPECT_NEAR(ours.center_m.y(), 0.2, 0.03);
  EXPECT_NEAR(top(ours), 0.765, 0.02);
  EXPECT_LT(ours.size_m.z(), 0.04);
  EXPECT_NEAR(std::max(ours.size_m.x(), ours.size_m.y()), 0.25, 0.05);

  // A thicker prior (not lying flat): the core holds only the table top, refused as before.
  ClassPrior thick = book;
  thick.size_m = Eigen::Vector3d(0.23, 0.16, 0.10);
  OrientedBox theirs;
  EXPECT_FALSE(runMask(thick, frame, mask, &theirs))
      << "the scene does not test the lies-flat rule";
}

// A wall monitor 5 mm proud of its wall, seen from 2.5 m: in depth its front and the wall are one
// plane, which runs past the detection. An on_wall class is the wall's points inside its mask.
TEST_F(SupportSurfacesTest, AMonitorOnTheWallIsTheWallInsideItsMask) {
  test::PartScene scene;
  scene.parts.push_back(test::Part{"", {-2.0, 2.0, 0.0}, {2.0, 2.1, 2.6}});
  scene.parts.push_back(test::Part{"monitor", {-0.3, 1.995, 1.2}, {0.3, 2.0, 1.55}});
  cv::Rect box;
  cv::Mat mask;
  const RgbdFrame frame =
      scene.render(test::lookAt(Eigen::Vector3d(0.4, -0.4, 1.4), Eigen::Vector3d(0.0, 2.0, 1.375)),
                   "monitor", &box, &mask);
  ASSERT_GT(cv::countNonZero(mask), 2000);
  ClassPrior tv = sizedPrior("tv", Eigen::Vector3d(1.0, 0.1, 0.6), 0.5);
  tv.on_wall = true;
  OrientedBox ours;
  ASSERT_TRUE(runMask(tv, frame, mask, &ours));
  EXPECT_NEAR(ours.center_m.x(), 0.0, 0.03);
  EXPECT_NEAR(ours.center_m.y(), 2.0, 0.03);
  EXPECT_NEAR(ours.center_m.z(), 1.375, 0.03);
  EXPECT_NEAR(std::max(ours.size_m.x(), ours.size_m.y()), 0.6, 0.06);
  EXPECT_LT(std::min(ours.size_m.x(), ours.size_m.y()), 0.05);
  EXPECT_NEAR(ours.size_m.z(), 0.35, 0.05);

  // The same prior without on_wall: the core holds only the wall, and the detection is refused.
  ClassPrior loose = tv;
  loose.on_wall = false;
  OrientedBox theirs;
  EXPECT_FALSE(runMask(loose, frame, mask, &theirs)) << "the scene does not test the on_wall rule";
}

// A book 4 cm thick on the table, seen with a detector's box (a box-only detection, or a sloppy
// mask) that takes in the table around it. What stands on a table is seen with the table around it:
// the ring around the box is mostly table top, and the box's points on it, outside what stands
// above it, are the table's.
TEST_F(SupportSurfacesTest, WhatStandsOnTheTableIsCutFromTheTableAroundIt) {
  test::PartScene scene = scene_;
  scene.parts.push_back(test::Part{"book", {-0.62, 0.15, 0.76}, {-0.40, 0.31, 0.80}});
  cv::Rect box;
  const RgbdFrame frame = scene.render(T_W_D_, "book", &box);
  ASSERT_GT(box.area(), 1000);
  box -= cv::Point(25, 25);
  box += cv::Size(50, 50);
  const ClassPrior book = sizedPrior("book", Eigen::Vector3d(0.23, 0.16, 0.05), 0.1);
  OrientedBox ours;
  ASSERT_TRUE(run(book, config_, box, frame, &ours));
  EXPECT_NEAR(ours.center_m.x(), -0.51, 0.02);
  EXPECT_NEAR(ours.center_m.y(), 0.23, 0.02);
  EXPECT_NEAR(std::max(ours.size_m.x(), ours.size_m.y()), 0.22, 0.03);
  EXPECT_NEAR(std::min(ours.size_m.x(), ours.size_m.y()), 0.16, 0.03);
  EXPECT_NEAR(top(ours), 0.80, 0.01);
  EXPECT_NEAR(ours.size_m.z(), 0.04, 0.015) << "down to the table: its lowest points stay";

  // With a band of 5 cm around the support the whole book lies within it: nothing stands on the
  // table, and the box's table top stays.
  ObjectMapper::Config wide_band = config_;
  wide_band.selection.plane_distance_m = 0.05;
  OrientedBox theirs;
  ASSERT_TRUE(run(book, wide_band, box, frame, &theirs));
  EXPECT_GT(std::max(theirs.size_m.x(), theirs.size_m.y()), 0.3)
      << "the scene does not test the support";
}

TEST(FlatTopOfFusedObjectTest, WhatStandsOnTheTopGoes) {
  // A fused table on a 1 cm grid: a 1.4 x 0.8 m top two voxels thick (0.74-0.76 m), four legs, and
  // what single views let through: a cup standing on it (0.76-0.86 m) and a few stray voxels.
  const auto voxel = [](int x, int y, int z) {
    return Eigen::Vector3f((x + 0.5f) * 0.01f, (y + 0.5f) * 0.01f, (z + 0.5f) * 0.01f);
  };
  PointCloud table;
  for (int x = 0; x < 140; ++x) {
    for (int y = 0; y < 80; ++y) {
      for (int z = 74; z < 76; ++z) table.push_back(voxel(x, y, z));
    }
  }
  for (const int x : {0, 136}) {
    for (const int y : {0, 76}) {
      for (int z = 0; z < 74; ++z) {
        for (int k = 0; k < 4; ++k) table.push_back(voxel(x + k, y + k, z));
      }
    }
  }
  PointCloud above;
  for (int z = 76; z < 86; ++z) {
    for (int k = 0; k < 8; ++k) above.push_back(voxel(40 + k, 30, z));
  }
  above.push_back(voxel(100, 40, 84));
  PointCloud cloud = table;
  cloud.insert(cloud.end(), above.begin(), above.end());
  PointCloud below;
  ASSERT_TRUE(SegmentSelector::belowFlatTop(cloud, Eigen::Vector3d::UnitZ(), 0.03, 0.15, &below));
  // The table stays whole and in order. Of the cup, what lies within the clearance of the top
  // stays (3 cm, at the 1 cm layers' resolution: its lowest 3-4 layers); the rest and the stray
  // voxel go.
  ASSERT_GE(below.size(), table.size());
  for (size_t i = 0; i < table.size(); ++i) ASSERT_EQ(below[i], table[i]);
  for (const Eigen::Vector3f& p : below) EXPECT_LE(p.z(), 0.80f);
  EXPECT_GE(below.size(), table.size() + 3 * 8);
  EXPECT_LE(below.size(), table.size() + 4 * 8);
  PointCloud ignored;
  EXPECT_FALSE(SegmentSelector::belowFlatTop(table, Eigen::Vector3d::UnitZ(), 0.03, 0.15, &ignored))
      << "nothing above the top: nothing to clip";
  // No layer holds 15 % of a tall, even object (a chair's back and legs): nothing happens.
  PointCloud column;
  for (int z = 0; z < 100; ++z) column.push_back(voxel(0, 0, z));
  EXPECT_FALSE(
      SegmentSelector::belowFlatTop(column, Eigen::Vector3d::UnitZ(), 0.03, 0.15, &ignored));
  EXPECT_FALSE(
      SegmentSelector::belowFlatTop(PointCloud(), Eigen::Vector3d::UnitZ(), 0.03, 0.15, &ignored));
  EXPECT_FALSE(SegmentSelector::belowFlatTop(cloud, Eigen::Vector3d::Zero(), 0.03, 0.15, &ignored));
}

}  // namespace
}  // namespace mvod
