// ExistenceModel: one keyframe's vote on an object from its depth (the visibility model shared with
// amodal completion), and the clamped log-odds the votes add up to.
#include <gtest/gtest.h>

#include <limits>

#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/map/existence.h"

namespace mvod {
namespace {

// A camera at the origin looking along +z at a wall `wall_m` away.
DepthView wallView(float wall_m) {
  DepthView view;
  view.K = CameraIntrinsics{100.0, 100.0, 49.5, 49.5, 100, 100};
  view.depth_m = cv::Mat(100, 100, CV_32FC1, cv::Scalar(wall_m));
  view.truncation_m = 0.02;
  view.truncation_per_m2 = 0.0;
  return view;
}

// What a first view mapped of an object: a 0.4 m square panel of voxels (5 cm apart) facing the
// camera `z_m` in front of it, and its box.
struct Panel {
  PointCloud voxels_W;
  OrientedBox box;
};
Panel panelAt(double z_m) {
  Panel panel;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      panel.voxels_W.push_back(
          Eigen::Vector3f(-0.175f + 0.05f * i, -0.175f + 0.05f * j, static_cast<float>(z_m)));
    }
  }
  panel.box.center_m = Eigen::Vector3d(0.0, 0.0, z_m);
  panel.box.size_m = Eigen::Vector3d(0.4, 0.4, 0.05);
  return panel;
}

using Vote = ExistenceModel::Vote;

TEST(ExistenceModelTest, VotesFromWhatTheDepthShows) {
  const ExistenceModel model;
  const Panel panel = panelAt(2.0);
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(4.0f), true), Vote::kDetected);
  // The wall lies 2 m behind the object's place: seen through.
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(4.0f), false), Vote::kSeenThrough);
  // The depth lies on it: there, but not detected.
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(2.01f), false), Vote::kMissed);
  // A nearer surface hides all of it: no vote.
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(1.0f), false), Vote::kNone);
}

TEST(ExistenceModelTest, InvalidDepthAndPlacesOutOfViewDoNotVote) {
  const ExistenceModel model;
  const Panel panel = panelAt(2.0);
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(0.0f), false), Vote::kNone);
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, wallView(std::numeric_limits<float>::quiet_NaN()),
                       false),
            Vote::kNone);
  // Holes over most of the object's pixels: too few of its voxels in view.
  DepthView holes = wallView(4.0f);
  holes.depth_m(cv::Rect(25, 25, 50, 50)).setTo(0.f);
  holes.depth_m(cv::Rect(45, 45, 5, 5)).setTo(4.0f);
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, holes, false), Vote::kNone);
  // Behind the camera, or beside the image.
  DepthView turned = wallView(4.0f);
  turned.T_D_W = Eigen::Isometry3d(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()));
  EXPECT_EQ(model.vote(panel.voxels_W, panel.box, turned, false), Vote::kNone);
  const Panel aside = panelAt(2.0);
  DepthView shifted = wallView(4.0f);
  shifted.T_D_W.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  EXPECT_EQ(model.vote(aside.voxels_W, aside.box, shifted, false), Vote::kNone);
  // Beyond max_depth_m.
  const Panel far = panelAt(6.0);
  EXPECT_EQ(model.vote(far.voxels_W, far.box, wallView(9.0f), false), Vote::kNone);
  EXPECT_EQ(model.vote(PointCloud(), panel.box, wallView(4.0f), false), Vote::kNone);
}

TEST(ExistenceModelTest, SeveralViewsMustAgreeBeforeAnObjectGoes) {
  const ExistenceModel model;
  ExistenceEvidence evidence;
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(model.apply(Vote::kDetected, &evidence));
  EXPECT_DOUBLE_EQ(evidence.log_odds, model.config().max_log_odds);  // clamped
  EXPECT_EQ(evidence.detected, 5u);
  // From the top, one and two views that see through it leave it; the third removes it.
  EXPECT_FALSE(model.apply(Vote::kSeenThrough, &evidence));
  EXPECT_FALSE(model.apply(Vote::kSeenThrough, &evidence));
  EXPECT_TRUE(model.apply(Vote::kSeenThrough, &evidence));
  EXPECT_EQ(evidence.seen_through, 3u);
  // A detection in 1 of 8 views: gone at the eighth, not before (too few views to judge).
  ExistenceEvidence once;
  EXPECT_FALSE(model.apply(Vote::kDetected, &once));
  for (int i = 0; i < 6; ++i) EXPECT_FALSE(model.apply(Vote::kMissed, &once)) << i;
  EXPECT_TRUE(model.apply(Vote::kMissed, &once));
  EXPECT_EQ(once.missed, 7u);
  EXPECT_GT(once.log_odds, model.config().remove_below);  // the share removed it, not the log-odds
  // Detected in every other view, or in a quarter of them (a weak detector on a real chair): it
  // stays. So does one detected twice and then missed for 25 keyframes.
  ExistenceEvidence half, quarter;
  for (int i = 0; i < 40; ++i) {
    EXPECT_FALSE(model.apply(i % 2 ? Vote::kMissed : Vote::kDetected, &half)) << i;
    EXPECT_FALSE(model.apply(i % 4 ? Vote::kMissed : Vote::kDetected, &quarter)) << i;
  }
  ExistenceEvidence twice;
  model.apply(Vote::kDetected, &twice);
  model.apply(Vote::kDetected, &twice);
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(model.apply(Vote::kMissed, &twice)) << i;
  // Misses alone stop at missed_floor_log_odds; from there two views that see through it remove it.
  EXPECT_DOUBLE_EQ(twice.log_odds, model.config().missed_floor_log_odds);
  EXPECT_FALSE(model.apply(Vote::kSeenThrough, &twice));
  EXPECT_TRUE(model.apply(Vote::kSeenThrough, &twice));
  // Switched off, the evidence is still gathered but nothing goes.
  ExistenceModel::Config off;
  off.enable = false;
  ExistenceEvidence kept;
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(ExistenceModel(off).apply(Vote::kSeenThrough, &kept));
  EXPECT_DOUBLE_EQ(kept.log_odds, off.min_log_odds);
}

// A keyframe that sees through one object, or a few among many it shows on their surface, votes:
// the room changed. One that contradicts most of what it shows is a sensor or SLAM fault.
TEST(ExistenceModelTest, AKeyframeThatContradictsMostOfTheMapIsAFault) {
  using Check = ExistenceModel::DepthCheck;
  const auto fault = [](int on_surface, int seen_through) {
    Check check;
    check.on_surface = on_surface;
    check.seen_through = seen_through;
    return ExistenceModel::isFault(check);
  };
  EXPECT_FALSE(fault(0, 0));
  EXPECT_FALSE(fault(0, 1));  // a chair carried out, alone in view
  EXPECT_FALSE(fault(5, 2));  // a moved chair and a removed couch among five that stay
  EXPECT_FALSE(fault(5, 3));
  EXPECT_TRUE(fault(0, 2));  // depth of 9.9 m everywhere
  EXPECT_TRUE(fault(0, 9));
  EXPECT_TRUE(fault(4, 4));  // images from another place than the pose
  EXPECT_TRUE(fault(2, 6));
  // The odds grow tenfold with each object seen through.
  Check one, two;
  one.seen_through = 1;
  two.seen_through = 2;
  EXPECT_NEAR(ExistenceModel::faultOdds(two) / ExistenceModel::faultOdds(one), 10.0, 1e-9);
}

// A camera standing still that sees through an object again and again counts once; from another
// viewpoint (10 cm or 7.5 degrees away) the see-through counts again.
TEST(ExistenceModelTest, SeeThroughsFromOneViewpointCountOnce) {
  const ExistenceModel model;
  ExistenceEvidence evidence;
  for (int i = 0; i < 5; ++i) model.apply(Vote::kDetected, &evidence);
  const DepthView here = wallView(4.0f);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(model.apply(Vote::kSeenThrough, &evidence, &here));
  EXPECT_EQ(evidence.seen_through, 1u);
  DepthView moved = here;
  moved.T_D_W.translation() = Eigen::Vector3d(0.15, 0.0, 0.0);
  DepthView turned = here;
  turned.T_D_W.linear() =
      Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_FALSE(model.apply(Vote::kSeenThrough, &evidence, &moved));
  EXPECT_TRUE(model.apply(Vote::kSeenThrough, &evidence, &turned));
  EXPECT_EQ(evidence.seen_through, 3u);
}

TEST(ExistenceModelTest, ConfigRefusesValuesOutOfRange) {
  EXPECT_TRUE(ExistenceModel::Config().isValid().ok());
  ExistenceModel::Config c;
  c.remove_below = 3.0;
  EXPECT_FALSE(c.isValid().ok());
  c = ExistenceModel::Config();
  c.seen_through_log_odds = 1.0;
  EXPECT_FALSE(c.isValid().ok());
  c = ExistenceModel::Config();
  c.seen_through_share = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c.isValid().ok());
  c = ExistenceModel::Config();
  c.min_voxels_in_view = c.sample_voxels + 1;
  EXPECT_FALSE(c.isValid().ok());
  c = ExistenceModel::Config();
  c.min_detected_share = 1.5;
  EXPECT_FALSE(c.isValid().ok());
  c = ExistenceModel::Config();
  c.min_votes_for_share = 0;
  EXPECT_FALSE(c.isValid().ok());
}

}  // namespace
}  // namespace mvod
