// ObjectDatabase: Eq. 5-8 (insert, same-class nearest-centre fusion, fused clouds, probability
// mean).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <unordered_map>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"

namespace mvod {
namespace {

class ObjectDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClassPrior chair;
    chair.class_name = "chair";
    chair.has_size = true;
    chair.size_m = Eigen::Vector3d(0.5, 0.5, 0.9);
    chair.fusion_distance_m = 0.4;
    priors_.set(chair);
    ClassPrior cup;
    cup.class_name = "cup";
    cup.fusion_distance_m = 0.1;
    priors_.set(cup);
    priors_.default_fusion_distance_m = 0.5;
  }

  // A 0.2 m square patch of points (1 cm spacing) centred on `center`, with a box around it.
  static ObjectObservation observation(const std::string& class_name, const Eigen::Vector3d& center,
                                       double probability, int keyframe) {
    ObjectObservation obs;
    obs.class_name = class_name;
    obs.class_id = class_name == "chair" ? 56 : 41;
    obs.probability = probability;
    obs.keyframe = keyframe;
    obs.stamp_s = keyframe * 0.5;
    for (int i = 0; i < 20; ++i) {
      for (int j = 0; j < 20; ++j) {
        obs.points_W.push_back(
            (center + Eigen::Vector3d(-0.095 + 0.01 * i, -0.095 + 0.01 * j, 0.0)).cast<float>());
      }
    }
    obs.segment_W = obs.points_W;
    obs.box.center_m = center;
    obs.box.size_m = Eigen::Vector3d(0.2, 0.2, 0.01);
    obs.yaw_rad = 0.1;
    return obs;
  }

  // A processor that accepts the fused cloud: box centre = centroid, segment = the cloud.
  static FusedCloudProcessor centroidProcessor(int* calls) {
    return
        [calls](const std::string&, const PointCloud& points_W, const std::vector<Eigen::Vector3f>&,
                PointCloud* segment_W, OrientedBox* box, double* yaw_rad) {
          ++*calls;
          Eigen::Vector3d sum = Eigen::Vector3d::Zero();
          for (const auto& p : points_W) sum += p.cast<double>();
          box->center_m = sum / static_cast<double>(points_W.size());
          box->size_m = Eigen::Vector3d(0.3, 0.3, 0.3);
          *segment_W = points_W;
          *yaw_rad = 0.2;
          return true;
        };
  }

  ClassPriors priors_;
};

TEST_F(ObjectDatabaseTest, InsertsWhenNoObjectOfTheClassExists) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const auto result = database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0),
                                            centroidProcessor(&calls));
  EXPECT_EQ(result.decision, ObjectDatabase::Decision::kInserted);
  EXPECT_TRUE(std::isinf(result.distance_m));
  EXPECT_EQ(calls, 0);
  ASSERT_EQ(database.size(), 1u);
  const MapObject* object = database.find(result.object_id);
  ASSERT_NE(object, nullptr);
  EXPECT_EQ(object->class_name, "chair");
  EXPECT_EQ(object->class_id, 56);
  EXPECT_DOUBLE_EQ(object->probability, 0.8);
  EXPECT_EQ(object->observations, 1);
  EXPECT_EQ(object->first_keyframe, 0);
  EXPECT_EQ(object->last_keyframe, 0);
  EXPECT_NEAR(object->box.center_m.x(), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(object->yaw_rad, 0.1);
  // Inserted clouds are voxelised too: a 1 cm grid at 1 cm stays at about 400 points.
  EXPECT_GE(object->points_W.size(), 300u);
  EXPECT_LE(object->points_W.size(), 441u);
}

TEST_F(ObjectDatabaseTest, FusesWithinTheClassThreshold) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const auto first = database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0),
                                           centroidProcessor(&calls));
  const auto second = database.fuseOrInsert(observation("chair", {1.3, 2.0, 0.5}, 0.6, 1),
                                            centroidProcessor(&calls));
  EXPECT_EQ(second.decision, ObjectDatabase::Decision::kFused);
  EXPECT_EQ(second.object_id, first.object_id);
  EXPECT_NEAR(second.distance_m, 0.3, 1e-9);
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(database.size(), 1u);
  const MapObject* object = database.find(first.object_id);
  EXPECT_EQ(object->observations, 2);
  EXPECT_EQ(object->first_keyframe, 0);
  EXPECT_EQ(object->last_keyframe, 1);
  EXPECT_DOUBLE_EQ(object->last_seen_s, 0.5);
  // The processor's box is taken: the centroid of both patches.
  EXPECT_NEAR(object->box.center_m.x(), 1.15, 0.01);
  EXPECT_DOUBLE_EQ(object->yaw_rad, 0.2);
  // Eq. 7: both patches are in the fused cloud.
  EXPECT_GE(object->points_W.size(), 700u);
}

TEST_F(ObjectDatabaseTest, InsertsBeyondTheClassThreshold) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(&calls));
  const auto result = database.fuseOrInsert(observation("chair", {1.45, 2.0, 0.5}, 0.8, 1),
                                            centroidProcessor(&calls));
  EXPECT_EQ(result.decision, ObjectDatabase::Decision::kInserted);
  EXPECT_NEAR(result.distance_m, 0.45, 1e-9);
  EXPECT_EQ(database.size(), 2u);
  EXPECT_EQ(calls, 0);
  // The class threshold is per class: cups fuse only within 0.1 m.
  database.fuseOrInsert(observation("cup", {0.0, 0.0, 0.8}, 0.8, 1), centroidProcessor(&calls));
  const auto cup = database.fuseOrInsert(observation("cup", {0.15, 0.0, 0.8}, 0.8, 2),
                                         centroidProcessor(&calls));
  EXPECT_EQ(cup.decision, ObjectDatabase::Decision::kInserted);
  EXPECT_EQ(database.findByClass("cup").size(), 2u);
  EXPECT_EQ(database.findByClass("chair").size(), 2u);
}

TEST_F(ObjectDatabaseTest, FusesWithTheNearestOfSeveralCandidates) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const auto a = database.fuseOrInsert(observation("chair", {0.0, 0.0, 0.5}, 0.8, 0),
                                       centroidProcessor(&calls));
  const auto b = database.fuseOrInsert(observation("chair", {0.6, 0.0, 0.5}, 0.8, 0),
                                       centroidProcessor(&calls));
  ASSERT_NE(a.object_id, b.object_id);
  const auto result = database.fuseOrInsert(observation("chair", {0.4, 0.0, 0.5}, 0.8, 1),
                                            centroidProcessor(&calls));
  EXPECT_EQ(result.decision, ObjectDatabase::Decision::kFused);
  EXPECT_EQ(result.object_id, b.object_id);
  EXPECT_NEAR(result.distance_m, 0.2, 1e-9);
}

TEST_F(ObjectDatabaseTest, DifferentClassesNeverFuseByCentreDistance) {
  ObjectDatabase::Config config;
  config.min_overlap_to_fuse = 0.0;  // Eq. 6 alone (the paper's fusion never fuses classes either)
  ObjectDatabase database(config, priors_);
  int calls = 0;
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(&calls));
  const auto result =
      database.fuseOrInsert(observation("cup", {1.0, 2.0, 0.5}, 0.8, 1), centroidProcessor(&calls));
  EXPECT_EQ(result.decision, ObjectDatabase::Decision::kInserted);
  EXPECT_TRUE(std::isinf(result.distance_m));
  EXPECT_EQ(database.size(), 2u);
  EXPECT_EQ(calls, 0);
}

TEST_F(ObjectDatabaseTest, OverlappingCutsFuseAcrossClassesAndTheClassIsVoted) {
  // Evidence fusion: one chair, detected twice as a chair and once, in between, as a couch.
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  auto seen = [](ObjectObservation obs) {
    obs.segment_W = obs.points_W;
    return obs;
  };
  const auto first = database.fuseOrInsert(seen(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0)),
                                           centroidProcessor(&calls));
  const auto second = database.fuseOrInsert(seen(observation("couch", {1.0, 2.0, 0.5}, 0.9, 1)),
                                            centroidProcessor(&calls));
  EXPECT_EQ(second.decision, ObjectDatabase::Decision::kFused);
  EXPECT_EQ(second.object_id, first.object_id);
  ASSERT_EQ(database.size(), 1u);
  EXPECT_EQ(database.objects().begin()->second.class_name, "couch");  // 0.9 > 0.8 so far
  database.fuseOrInsert(seen(observation("chair", {1.0, 2.0, 0.5}, 0.7, 2)),
                        centroidProcessor(&calls));
  ASSERT_EQ(database.size(), 1u);
  const MapObject& object = database.objects().begin()->second;
  EXPECT_EQ(object.class_name, "chair");  // 1.5 against 0.9
  EXPECT_EQ(object.class_id, cocoClassId("chair"));
  EXPECT_EQ(object.observations, 3);
  // A cut beside it (no shared voxels) stays its own object, whatever its class.
  database.fuseOrInsert(seen(observation("couch", {1.5, 2.0, 0.5}, 0.9, 3)),
                        centroidProcessor(&calls));
  EXPECT_EQ(database.size(), 2u);
}

TEST_F(ObjectDatabaseTest, SameClassCutsOneVoxelApartFuseOthersNeedTheVoxelsThemselves) {
  // Evidence fusion: a thin part seen from either side fills neighbouring voxels (here the patch
  // one voxel higher), and the second view's box centre is beyond the chair's 0.4 m: only the
  // overlap within same_class_overlap_voxels can fuse it.
  const auto run = [this](const std::string& second_class, int reach) {
    ObjectDatabase::Config config;
    config.same_class_overlap_voxels = reach;
    ObjectDatabase database(config, priors_);
    int calls = 0;
    database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.505}, 0.8, 0),
                          centroidProcessor(&calls));
    ObjectObservation other = observation(second_class, {1.0, 2.0, 0.515}, 0.8, 1);
    other.box.center_m = Eigen::Vector3d(1.0, 2.6, 0.515);
    other.box.size_m = Eigen::Vector3d(1.0, 1.0, 1.0);
    return database.fuseOrInsert(other, centroidProcessor(&calls)).decision;
  };
  EXPECT_EQ(run("chair", 1), ObjectDatabase::Decision::kFused);
  EXPECT_EQ(run("chair", 0), ObjectDatabase::Decision::kInserted);
  // Another class matches on shared voxels only: a book on a table top does not join the table.
  EXPECT_EQ(run("couch", 1), ObjectDatabase::Decision::kInserted);
  // A chair touching another along one edge: only that edge's voxels (20 of 400) lie within a
  // voxel of it, under min_overlap_to_fuse: two chairs side by side stay two.
  {
    ObjectDatabase database(ObjectDatabase::Config(), priors_);
    int calls = 0;
    database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.505}, 0.8, 0),
                          centroidProcessor(&calls));
    ObjectObservation beside = observation("chair", {1.2, 2.0, 0.505}, 0.8, 1);
    beside.box.center_m = Eigen::Vector3d(1.5, 2.0, 0.505);
    beside.box.size_m = Eigen::Vector3d(1.0, 1.0, 1.0);
    EXPECT_EQ(database.fuseOrInsert(beside, centroidProcessor(&calls)).decision,
              ObjectDatabase::Decision::kInserted);
  }
  // The same patch again (shared voxels) fuses whatever the class.
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.505}, 0.8, 0), centroidProcessor(&calls));
  ObjectObservation same = observation("couch", {1.0, 2.0, 0.505}, 0.8, 1);
  same.box.center_m = Eigen::Vector3d(1.0, 2.6, 0.505);
  same.box.size_m = Eigen::Vector3d(1.0, 1.0, 1.0);
  EXPECT_EQ(database.fuseOrInsert(same, centroidProcessor(&calls)).decision,
            ObjectDatabase::Decision::kFused);
}

TEST_F(ObjectDatabaseTest, DetectionsOfOneKeyframeDoNotFuseWithEachOther) {
  int calls = 0;
  {
    ObjectDatabase database(ObjectDatabase::Config(), priors_);
    database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 3), centroidProcessor(&calls));
    const auto same_keyframe = database.fuseOrInsert(observation("chair", {1.1, 2.0, 0.5}, 0.8, 3),
                                                     centroidProcessor(&calls));
    EXPECT_EQ(same_keyframe.decision, ObjectDatabase::Decision::kInserted);
    EXPECT_EQ(database.size(), 2u);
    // In the next keyframe both are candidates again.
    const auto next = database.fuseOrInsert(observation("chair", {1.1, 2.0, 0.5}, 0.8, 4),
                                            centroidProcessor(&calls));
    EXPECT_EQ(next.decision, ObjectDatabase::Decision::kFused);
    EXPECT_EQ(next.object_id, same_keyframe.object_id);
  }
  {
    ObjectDatabase::Config config;
    config.no_fusion_within_keyframe = false;
    ObjectDatabase database(config, priors_);
    database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 3), centroidProcessor(&calls));
    const auto same_keyframe = database.fuseOrInsert(observation("chair", {1.1, 2.0, 0.5}, 0.8, 3),
                                                     centroidProcessor(&calls));
    EXPECT_EQ(same_keyframe.decision, ObjectDatabase::Decision::kFused);
  }
}

// Evidence fusion's association (issue 54): two books side by side, 2 cm apart, each 0.2 m, and
// every view sees both of them (seen_W) whichever it detects.
class BookAssociationTest : public ObjectDatabaseTest {
 protected:
  void SetUp() override {
    ObjectDatabaseTest::SetUp();
    ClassPrior book;
    book.class_name = "book";
    book.fusion_distance_m = 0.3;  // wider than the books' spacing: Γ_C alone cannot tell them
    priors_.set(book);
  }
  const Eigen::Vector3d a_ = {1.0, 2.0, 0.8};
  const Eigen::Vector3d b_ = {1.22, 2.0, 0.8};

  // A detection of the book at `book`, its box centre `box_shift_m` along x (a view's cut that
  // ran a little onto the table), seeing `seen` around it.
  ObjectObservation detect(const Eigen::Vector3d& book, double box_shift_m, int keyframe,
                           const std::vector<Eigen::Vector3d>& seen) const {
    ObjectObservation obs = observation("book", book, 0.7, keyframe);
    obs.box.center_m.x() += box_shift_m;
    for (const Eigen::Vector3d& centre : seen) {
      const ObjectObservation other = observation("book", centre, 0.7, keyframe);
      obs.seen_W.insert(obs.seen_W.end(), other.points_W.begin(), other.points_W.end());
    }
    return obs;
  }
};

TEST_F(BookAssociationTest, NeighboursOfOneClassStayApartAcrossViews) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const int first_a =
      database.fuseOrInsert(detect(a_, 0.0, 0, {a_, b_}), centroidProcessor(&calls)).object_id;
  const int first_b =
      database.fuseOrInsert(detect(b_, 0.0, 0, {a_, b_}), centroidProcessor(&calls)).object_id;
  ASSERT_NE(first_a, first_b);
  for (int keyframe = 1; keyframe < 5; ++keyframe) {
    // B listed first, each box centre pulled towards the other book: by centre distance B's
    // detection would be nearer A's box (and A's nearer B's).
    const ObjectObservation b = detect(b_, -0.12, keyframe, {a_, b_});
    const ObjectObservation a = detect(a_, 0.12, keyframe, {a_, b_});
    const std::vector<int> ids = database.associate({&b, &a});
    ASSERT_EQ(ids.size(), 2u);
    EXPECT_EQ(ids[0], first_b) << "keyframe " << keyframe;
    EXPECT_EQ(ids[1], first_a) << "keyframe " << keyframe;
    database.fuseOrInsert(b, centroidProcessor(&calls), false, ids[0]);
    database.fuseOrInsert(a, centroidProcessor(&calls), false, ids[1]);
  }
  EXPECT_EQ(database.size(), 2u);
  EXPECT_EQ(database.find(first_a)->observations, 5);
  EXPECT_EQ(database.find(first_b)->observations, 5);
}

TEST_F(BookAssociationTest, ADetectionDoesNotJoinAnObjectItsViewSawApart) {
  // Book A mapped alone; then B alone, 0.22 m away (within Γ_C 0.3 m), its cut sharing no voxel
  // with A. Seeing A's surface beside its cut, B's view says A is something else.
  int calls = 0;
  {
    ObjectDatabase database(ObjectDatabase::Config(), priors_);
    database.fuseOrInsert(detect(a_, 0.0, 0, {a_, b_}), centroidProcessor(&calls));
    const auto b = database.fuseOrInsert(detect(b_, 0.0, 1, {a_, b_}), centroidProcessor(&calls));
    EXPECT_EQ(b.decision, ObjectDatabase::Decision::kInserted);
    EXPECT_EQ(database.size(), 2u);
  }
  // A view that did not see A's place (only B's surface around its cut) has no say on A: Eq. 6's
  // Γ_C fuses it (one object seen from another side, or with a pose a little off).
  {
    ObjectDatabase database(ObjectDatabase::Config(), priors_);
    database.fuseOrInsert(detect(a_, 0.0, 0, {a_}), centroidProcessor(&calls));
    const auto b = database.fuseOrInsert(detect(b_, 0.0, 1, {b_}), centroidProcessor(&calls));
    EXPECT_EQ(b.decision, ObjectDatabase::Decision::kFused);
  }
  // The paper's fusion is Eq. 6 as written: centres only.
  {
    ObjectDatabase::Config config;
    config.fusion = "paper";
    ObjectDatabase database(config, priors_);
    database.fuseOrInsert(detect(a_, 0.0, 0, {a_, b_}), centroidProcessor(&calls));
    const auto b = database.fuseOrInsert(detect(b_, 0.0, 1, {a_, b_}), centroidProcessor(&calls));
    EXPECT_EQ(b.decision, ObjectDatabase::Decision::kFused);
  }
}

TEST_F(ObjectDatabaseTest, TwoDetectionsOfOneKeyframeNeverJoinOneObject) {
  // One chair patch mapped; then one keyframe detects it twice: the whole patch and a copy shifted
  // by one voxel. The better overlap joins the chair, the other becomes an object of its own,
  // whichever comes first, and with the sequential fuseOrInsert too.
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const int chair =
      database
          .fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(&calls))
          .object_id;
  const ObjectObservation shifted = observation("chair", {1.05, 2.0, 0.5}, 0.8, 1);
  const ObjectObservation whole = observation("chair", {1.0, 2.0, 0.5}, 0.8, 1);
  const std::vector<int> ids = database.associate({&shifted, &whole});
  EXPECT_EQ(ids[0], -1);
  EXPECT_EQ(ids[1], chair);
  const auto first = database.fuseOrInsert(whole, centroidProcessor(&calls));
  const auto second = database.fuseOrInsert(shifted, centroidProcessor(&calls));
  EXPECT_EQ(first.object_id, chair);
  EXPECT_EQ(second.decision, ObjectDatabase::Decision::kInserted);
  EXPECT_EQ(database.size(), 2u);
}

TEST_F(ObjectDatabaseTest, SingleFrameBaselineNeverFuses) {
  ObjectDatabase::Config config;
  config.disable_fusion = true;
  ObjectDatabase database(config, priors_);
  int calls = 0;
  for (int k = 0; k < 5; ++k) {
    const auto result = database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, k),
                                              centroidProcessor(&calls));
    EXPECT_EQ(result.decision, ObjectDatabase::Decision::kInserted);
  }
  EXPECT_EQ(database.size(), 5u);
  EXPECT_EQ(calls, 0);
}

TEST_F(ObjectDatabaseTest, ProbabilityIsTheMeanOfNewAndStored) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const auto first = database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.9, 0),
                                           centroidProcessor(&calls));
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.5, 1), centroidProcessor(&calls));
  EXPECT_NEAR(database.find(first.object_id)->probability, 0.7, 1e-12);
  // Eq. 8 is pairwise: (0.3 + 0.7) / 2, not the mean of all three views.
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.3, 2), centroidProcessor(&calls));
  EXPECT_NEAR(database.find(first.object_id)->probability, 0.5, 1e-12);
  EXPECT_EQ(database.find(first.object_id)->observations, 3);
}

TEST_F(ObjectDatabaseTest, FusedCloudStaysBoundedWhenTheSameSurfaceIsSeenAgain) {
  ObjectDatabase::Config config;
  config.fusion_voxel_size_m = 0.01;
  config.fusion = "paper";  // Eq. 7's union of the views' clouds
  ObjectDatabase database(config, priors_);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(0.0f, 0.5f);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  int calls = 0;
  int id = 0;
  for (int k = 0; k < 200; ++k) {
    // A new random sampling of the same 0.5 m x 0.5 m table top each view.
    ObjectObservation obs = observation("chair", {0.25, 0.25, 0.7}, 0.8, k);
    obs.points_W.clear();
    for (int i = 0; i < 3000; ++i) {
      obs.points_W.emplace_back(coordinate(rng), coordinate(rng), 0.7f + noise(rng));
    }
    const auto result = database.fuseOrInsert(obs, centroidProcessor(&calls));
    if (k == 0) id = result.object_id;
    ASSERT_EQ(result.object_id, id);
  }
  const MapObject* object = database.find(id);
  ASSERT_NE(object, nullptr);
  EXPECT_EQ(object->observations, 200);
  // 51 x 51 cells in the plane, a noise band of at most 3 cells: far below 200 x 3000 points.
  EXPECT_LE(object->points_W.size(), 51u * 51u * 3u);
  EXPECT_GE(object->points_W.size(), 2000u);
  for (const auto& p : object->points_W) {
    EXPECT_GE(p.x(), -0.01f);
    EXPECT_LE(p.x(), 0.51f);
  }
}

TEST_F(ObjectDatabaseTest, FailedReprocessingKeepsThePreviousBox) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const ObjectObservation first_obs = observation("chair", {1.0, 2.0, 0.5}, 0.8, 0);
  const auto first = database.fuseOrInsert(first_obs, centroidProcessor(&calls));
  int failed_calls = 0;
  const FusedCloudProcessor failing = [&failed_calls](const std::string&, const PointCloud&,
                                                      const std::vector<Eigen::Vector3f>&,
                                                      PointCloud*, OrientedBox* box, double*) {
    ++failed_calls;
    box->center_m = Eigen::Vector3d(9, 9, 9);  // must be ignored
    return false;
  };
  const auto second = database.fuseOrInsert(observation("chair", {1.2, 2.0, 0.5}, 0.4, 1), failing);
  EXPECT_EQ(second.decision, ObjectDatabase::Decision::kFused);
  EXPECT_EQ(failed_calls, 1);
  const MapObject* object = database.find(first.object_id);
  EXPECT_TRUE(object->box.center_m.isApprox(first_obs.box.center_m));
  EXPECT_TRUE(object->box.size_m.isApprox(first_obs.box.size_m));
  EXPECT_EQ(object->segment_W.size(), first_obs.segment_W.size());
  EXPECT_DOUBLE_EQ(object->yaw_rad, first_obs.yaw_rad);
  // The rest of the fusion still happens.
  EXPECT_NEAR(object->probability, 0.6, 1e-12);
  EXPECT_EQ(object->observations, 2);
  EXPECT_GT(object->points_W.size(), first_obs.points_W.size());
}

TEST_F(ObjectDatabaseTest, IdsAreNeverReused) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  std::vector<int> ids;
  for (int k = 0; k < 3; ++k) {
    ids.push_back(database
                      .fuseOrInsert(observation("chair", {2.0 * k, 0.0, 0.5}, 0.8, 0),
                                    centroidProcessor(&calls))
                      .object_id);
  }
  EXPECT_EQ(ids, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(database.remove(3));
  EXPECT_FALSE(database.remove(3));
  EXPECT_EQ(database.find(3), nullptr);
  const int after_remove =
      database
          .fuseOrInsert(observation("chair", {10.0, 0.0, 0.5}, 0.8, 1), centroidProcessor(&calls))
          .object_id;
  EXPECT_EQ(after_remove, 4);
  database.clear();
  EXPECT_EQ(database.size(), 0u);
  const int after_clear =
      database
          .fuseOrInsert(observation("chair", {10.0, 0.0, 0.5}, 0.8, 2), centroidProcessor(&calls))
          .object_id;
  EXPECT_EQ(after_clear, 5);

  // Loading a map: ids continue after the largest loaded id.
  MapObject loaded;
  loaded.id = 42;
  loaded.class_name = "cup";
  ASSERT_TRUE(database.setObjects({loaded}).ok());
  EXPECT_EQ(database.size(), 1u);
  EXPECT_NE(database.find(42), nullptr);
  EXPECT_EQ(database.nextId(), 43);

  // Ids near INT_MAX (a hand-edited or hostile map) are refused, and the map is kept: the next
  // id can never overflow.
  MapObject huge = loaded;
  huge.id = std::numeric_limits<int>::max();
  const Status refused = database.setObjects({huge});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("2147483647"), std::string::npos) << refused.message();
  EXPECT_NE(database.find(42), nullptr);
  EXPECT_FALSE(database.setObjects({loaded, loaded}).ok());  // repeated id
  EXPECT_NE(database.find(42), nullptr);

  // The largest id allowed still leaves a next id: no object is dropped.
  huge.id = kMaxObjectId;
  ASSERT_TRUE(database.setObjects({huge}).ok());
  const ObjectDatabase::FusionResult next = database.fuseOrInsert(
      observation("chair", {20.0, 0.0, 0.5}, 0.8, 3), centroidProcessor(&calls));
  EXPECT_GE(next.object_id, 0);
  EXPECT_NE(next.object_id, kMaxObjectId);
  EXPECT_EQ(database.size(), 2u);
  const ObjectDatabase::FusionResult after = database.fuseOrInsert(
      observation("chair", {30.0, 0.0, 0.5}, 0.8, 4), centroidProcessor(&calls));
  EXPECT_EQ(database.size(), 3u);
  EXPECT_NE(after.object_id, next.object_id);
}

TEST_F(ObjectDatabaseTest, ConfigValidation) {
  ObjectDatabase::Config config;
  EXPECT_TRUE(config.isValid().ok());
  config.fusion_voxel_size_m = 0.0;
  EXPECT_FALSE(config.isValid().ok());
  EXPECT_NE(config.isValid().message().find("fusion_voxel_size_m"), std::string::npos);
  config.fusion_voxel_size_m = std::nan("");
  EXPECT_FALSE(config.isValid().ok());
  config = ObjectDatabase::Config();
  config.same_class_overlap_voxels = 4;
  EXPECT_FALSE(config.isValid().ok());
  EXPECT_NE(config.isValid().message().find("same_class_overlap_voxels"), std::string::npos);
  EXPECT_NE(ObjectDatabase::Config().print().find("fusion_voxel_size_m: 0.01"), std::string::npos);
}

TEST_F(ObjectDatabaseTest, EvidenceVotesOutBackgroundThatOtherViewsSawOutsideTheirCut) {
  ObjectDatabase::Config config;  // fusion: evidence (the default)
  ASSERT_EQ(config.fusion, "evidence");
  ObjectDatabase database(config, priors_);
  // The object: a 0.2 m square at z = 0.7. The first view's cut also holds a strip of floor it
  // bled into; the next two views see that floor (seen_W) but leave it out of their cut.
  PointCloud floor_strip;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 5; ++j)
      floor_strip.emplace_back(0.005f + 0.01f * i, 0.305f + 0.01f * j, 0.005f);
  }
  int calls = 0;
  PointCloud last_supported;
  for (int k = 0; k < 3; ++k) {
    ObjectObservation obs = observation("chair", {0.1, 0.1, 0.7}, 0.8, k);
    obs.segment_W = obs.points_W;
    obs.seen_W = obs.points_W;
    obs.seen_W.insert(obs.seen_W.end(), floor_strip.begin(), floor_strip.end());
    if (k == 0) obs.segment_W.insert(obs.segment_W.end(), floor_strip.begin(), floor_strip.end());
    const auto processor = [&](const std::string& class_name, const PointCloud& points_W,
                               const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                               OrientedBox* box, double* yaw_rad) {
      last_supported = points_W;
      return centroidProcessor(&calls)(class_name, points_W, normals_W, segment_W, box, yaw_rad);
    };
    database.fuseOrInsert(obs, processor);
  }
  ASSERT_EQ(database.size(), 1u);
  const MapObject& object = database.objects().begin()->second;
  EXPECT_EQ(object.observations, 3);
  EXPECT_EQ(calls, 2);
  // 400 object voxels inside 3 times; 100 floor voxels inside once, outside twice.
  EXPECT_EQ(object.evidence.size(), 500u);
  const PointCloud supported = database.supportedVoxels(object);
  EXPECT_EQ(supported.size(), 400u);
  EXPECT_EQ(last_supported.size(), 400u);
  for (const auto& p : supported) EXPECT_GT(p.z(), 0.6f);
  // The box was made from the supported voxels only: its centre is the object's.
  EXPECT_NEAR(object.box.center_m.z(), 0.7, 0.01);
  // A map saved before evidence fusion (no evidence) goes on fusing from its segment.
  MapObject legacy = object;
  legacy.evidence.clear();
  legacy.evidence_voxel_size_m = 0.0;
  database.setObjects({legacy});
  ObjectObservation obs = observation("chair", {0.1, 0.1, 0.7}, 0.8, 10);
  obs.segment_W = obs.points_W;
  database.fuseOrInsert(obs, centroidProcessor(&calls));
  EXPECT_EQ(database.objects().begin()->second.evidence.size(), 400u);
}

// The projective signed distance of a point: measured depth at its pixel minus its depth, truncated
// in front, unknown behind the truncation and wherever the view has no depth.
TEST(DepthViewTest, SignedDistanceIsTruncatedAndNeedsADepth) {
  DepthView view;
  view.K = CameraIntrinsics{500.0, 500.0, 49.5, 49.5, 100, 100};
  view.depth_m = cv::Mat(100, 100, CV_32FC1, cv::Scalar(2.0f));
  view.depth_m(cv::Rect(49, 49, 3, 3)).setTo(0.f);  // no depth around the centre pixel
  view.truncation_m = 0.02;
  view.truncation_per_m2 = 0.0;
  float sdf = 0.f;
  ASSERT_TRUE(view.signedDistance(Eigen::Vector3f(0.1f, 0.f, 1.99f), &sdf));
  EXPECT_NEAR(sdf, 0.01f, 1e-5f);  // 1 cm in front of the surface
  ASSERT_TRUE(view.signedDistance(Eigen::Vector3f(0.1f, 0.f, 2.015f), &sdf));
  EXPECT_NEAR(sdf, -0.015f, 1e-5f);  // just behind it
  ASSERT_TRUE(view.signedDistance(Eigen::Vector3f(0.1f, 0.f, 1.5f), &sdf));
  EXPECT_NEAR(sdf, 0.02f, 1e-6f);  // seen through: the truncation
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(0.1f, 0.f, 2.1f), &sdf));  // hidden
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(0.f, 0.f, 2.f), &sdf));    // no depth
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(1.f, 0.f, 2.f), &sdf));    // outside
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(0.1f, 0.f, -2.f), &sdf));  // behind
  // The truncation grows with depth (the sensor's depth steps).
  view.truncation_per_m2 = 0.01;
  ASSERT_TRUE(view.signedDistance(Eigen::Vector3f(0.05f, 0.f, 1.0f), &sdf));
  EXPECT_NEAR(sdf, 0.02f + 0.01f * 1.0f, 1e-6f);
  // A thin leg at 1 m (pixel columns 70-74) before the 2 m surface: a point of the leg that
  // rounds to the column just beside it (75) lies at a depth edge, where the view abstains,
  // instead of looking seen through.
  view.depth_m(cv::Rect(70, 0, 5, 100)).setTo(1.0f);
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(0.051f, 0.f, 1.0f), &sdf));  // u = 75
  ASSERT_TRUE(view.signedDistance(Eigen::Vector3f(0.055f, 0.f, 1.0f), &sdf));   // u = 77
  EXPECT_NEAR(sdf, 0.03f, 1e-6f);  // two columns off: seen through
  // One pixel without depth next to it: no vote either.
  view.depth_m.at<float>(10, 86) = 0.f;
  EXPECT_FALSE(view.signedDistance(Eigen::Vector3f(0.070f, -0.080f, 1.0f), &sdf));  // u 85, v 10
}

// Three views of a 0.2 m square at 2 m: the first view's depth (and cut) also holds a patch of
// noise 5 cm in front of the surface, which the other two views see through. Its voxels, inside
// once and never seen as surface outside the cut, have a mean signed distance of 3.3 cm: outside
// surface_band_m (2 cm), so they are not the object; without the band they are.
TEST_F(ObjectDatabaseTest, EvidenceKeepsTheSurfaceTheViewsAgreeOn) {
  const auto run = [&](double band_m, std::size_t* supported_voxels, double* mean_z) {
    ObjectDatabase::Config config;
    config.surface_band_m = band_m;
    ObjectDatabase database(config, priors_);
    PointCloud noise;
    for (int i = 0; i < 5; ++i) {
      for (int j = 0; j < 5; ++j)
        noise.emplace_back(0.005f + 0.01f * i, 0.005f + 0.01f * j, 1.955f);
    }
    for (int k = 0; k < 3; ++k) {
      ObjectObservation obs = observation("chair", {0.0, 0.0, 2.005}, 0.8, k);
      obs.seen_W = obs.points_W;
      auto view = std::make_shared<DepthView>();
      view->K = CameraIntrinsics{500.0, 500.0, 199.5, 199.5, 400, 400};
      view->depth_m = cv::Mat(400, 400, CV_32FC1, cv::Scalar(2.005f));
      view->truncation_m = 0.02;
      view->truncation_per_m2 = 3 * 2.85e-3;
      if (k == 0) {
        // The noisy view measured the patch 5 cm nearer, and its cut holds it instead of the
        // surface behind it.
        for (const Eigen::Vector3f& p : noise) {
          const int u = static_cast<int>(std::floor(500.0 * p.x() / p.z() + 199.5 + 0.5));
          const int v = static_cast<int>(std::floor(500.0 * p.y() / p.z() + 199.5 + 0.5));
          for (int du = -2; du <= 2; ++du) {
            for (int dv = -2; dv <= 2; ++dv) view->depth_m.at<float>(v + dv, u + du) = 1.955f;
          }
        }
        obs.segment_W.insert(obs.segment_W.end(), noise.begin(), noise.end());
      }
      obs.depth_view = view;
      int calls = 0;
      database.fuseOrInsert(obs, centroidProcessor(&calls));
    }
    ASSERT_EQ(database.size(), 1u);
    const PointCloud supported = database.supportedVoxels(database.objects().begin()->second);
    *supported_voxels = supported.size();
    double sum = 0.0;
    for (const Eigen::Vector3f& p : supported) sum += p.z();
    *mean_z = sum / std::max<std::size_t>(1, supported.size());
  };
  std::size_t with_band = 0;
  std::size_t without_band = 0;
  double z_with = 0.0;
  double z_without = 0.0;
  run(0.02, &with_band, &z_with);
  run(0.0, &without_band, &z_without);
  // The square's 400 voxels stay; the 25 noise voxels go only with the band.
  EXPECT_EQ(with_band, 400u);
  EXPECT_EQ(without_band, 425u);
  EXPECT_NEAR(z_with, 2.005, 1e-3);
  EXPECT_LT(z_without, 2.005 - 1e-3);
}

// Evidence fusion keeps each voxel's normals (summed, as the views turned them to their cameras):
// the fused box gets them without a neighbour search. A map saved without normals gives the
// processor none, and it estimates them.
TEST_F(ObjectDatabaseTest, EvidenceKeepsTheViewsNormalsPerVoxel) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  std::vector<std::vector<Eigen::Vector3f>> received;
  const auto processor = [&](const std::string& class_name, const PointCloud& points_W,
                             const std::vector<Eigen::Vector3f>& normals_W, PointCloud* segment_W,
                             OrientedBox* box, double* yaw_rad) {
    received.push_back(normals_W);
    int calls = 0;
    return centroidProcessor(&calls)(class_name, points_W, normals_W, segment_W, box, yaw_rad);
  };
  // Two views of the patch at z = 0.7: normals tilted +x and -x about +z; their sum is +z. Half of
  // the second view's points have no normal (NaN).
  for (int k = 0; k < 2; ++k) {
    ObjectObservation obs = observation("chair", {0.1, 0.1, 0.7}, 0.8, k);
    const Eigen::Vector3f tilted = Eigen::Vector3f(k == 0 ? 0.6f : -0.6f, 0.f, 0.8f);
    for (size_t i = 0; i < obs.segment_W.size(); ++i) {
      obs.segment_normals_W.push_back(
          k == 1 && i % 2 == 1 ? Eigen::Vector3f::Constant(std::nanf("")) : tilted);
    }
    database.fuseOrInsert(obs, processor);
  }
  ASSERT_EQ(database.size(), 1u);
  ASSERT_EQ(received.size(), 1u);  // the second view fused
  ASSERT_EQ(received[0].size(), 400u);
  const MapObject& object = database.objects().begin()->second;
  int summed = 0;
  for (const auto& entry : object.evidence) {
    const Eigen::Vector3f& n = entry.second.normal_sum;
    if (std::abs(n.x()) < 1e-6f) {
      EXPECT_TRUE(n.isApprox(Eigen::Vector3f(0.f, 0.f, 1.6f), 1e-6f)) << n.transpose();
      ++summed;
    } else {
      EXPECT_TRUE(n.isApprox(Eigen::Vector3f(0.6f, 0.f, 0.8f), 1e-6f)) << n.transpose();
    }
  }
  EXPECT_EQ(summed, 200);
  std::vector<Eigen::Vector3f> normals;
  database.supportedVoxels(object, &normals);
  ASSERT_EQ(normals.size(), 400u);
  int vertical = 0;
  for (const Eigen::Vector3f& n : normals) {
    EXPECT_NEAR(n.norm(), 1.f, 1e-5f);
    vertical += n.isApprox(Eigen::Vector3f::UnitZ(), 1e-5f);
  }
  EXPECT_EQ(vertical, 200);

  // The same evidence without normals (a map saved before they were kept): none handed on.
  MapObject legacy = object;
  for (auto& entry : legacy.evidence) entry.second.normal_sum.setZero();
  database.setObjects({legacy});
  ObjectObservation obs = observation("chair", {0.1, 0.1, 0.7}, 0.8, 5);
  database.fuseOrInsert(obs, processor);
  ASSERT_EQ(received.size(), 2u);
  EXPECT_TRUE(received[1].empty());
}

// EvidenceMap against std::unordered_map on the same random inserts, look-ups and updates, with
// keys that collide in the low bits (packed neighbours) and far apart; its entries keep their
// insertion order, and reserve() and copies keep the content.
TEST(EvidenceMapTest, BehavesLikeAHashMapAndKeepsTheInsertionOrder) {
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    EvidenceMap map;
    std::unordered_map<std::int64_t, VoxelEvidence> reference;
    std::vector<std::int64_t> inserted;
    const int operations = 1 + static_cast<int>(rng() % 20000);
    for (int i = 0; i < operations; ++i) {
      const std::int64_t key = rng() % 3 == 0
                                   ? packVoxel(Eigen::Vector3i(static_cast<int>(rng() % 8),
                                                               static_cast<int>(rng() % 8) - 4, 0))
                                   : static_cast<std::int64_t>(rng() >> 2);
      switch (rng() % 3) {
        case 0:
          if (map.count(key) == 0) inserted.push_back(key);
          ++map[key].inside;
          ++reference[key].inside;
          break;
        case 1: {
          const auto it = map.find(key);
          const auto expected = reference.find(key);
          ASSERT_EQ(it == map.end(), expected == reference.end());
          if (it != map.end()) {
            EXPECT_EQ(it->first, key);
            ++it->second.outside;
            ++expected->second.outside;
          }
          break;
        }
        default:
          ASSERT_EQ(map.count(key), reference.count(key));
      }
      if (rng() % 4000 == 0) map.reserve(static_cast<std::size_t>(rng() % 30000));
    }
    const EvidenceMap copy = map;
    ASSERT_EQ(copy.size(), reference.size());
    ASSERT_EQ(copy.empty(), reference.empty());
    std::size_t position = 0;
    for (const auto& entry : copy) {
      ASSERT_EQ(entry.first, inserted[position]);  // insertion order
      EXPECT_EQ(&copy.entry(position), &entry);
      const auto expected = reference.find(entry.first);
      ASSERT_NE(expected, reference.end());
      EXPECT_EQ(entry.second.inside, expected->second.inside);
      EXPECT_EQ(entry.second.outside, expected->second.outside);
      ++position;
    }
  }
  EvidenceMap map;
  map[packVoxel(Eigen::Vector3i(1, 2, 3))].inside = 2;
  map.clear();
  EXPECT_TRUE(map.empty());
  EXPECT_EQ(map.find(packVoxel(Eigen::Vector3i(1, 2, 3))), map.end());
  EXPECT_EQ(map[packVoxel(Eigen::Vector3i(1, 2, 3))].inside, 0);  // a fresh entry after clear()
}

// The single-view stage's precomputed voxels (ObjectObservation::fusion_keys) and the re-boxing's
// signed distances in chunks of voxels on several threads give the same evidence, voxel by voxel,
// as computing them in the fusion on one thread. The object (a 0.8 m square, ~6800 voxels) spans
// two chunks; keys on another grid are ignored.
TEST_F(ObjectDatabaseTest, PrecomputedVoxelsAndParallelSignedDistancesGiveTheSameEvidence) {
  auto view = std::make_shared<DepthView>();
  view->K = CameraIntrinsics{400.0, 400.0, 199.5, 199.5, 400, 400};
  view->depth_m = cv::Mat(400, 400, CV_32FC1, cv::Scalar(1.0f));
  view->depth_m(cv::Rect(0, 0, 400, 200)).setTo(1.004f);  // two depths: distinct sums
  view->truncation_m = 0.02;
  const auto make = [&](int keyframe, double shift_m, bool precompute, double keys_voxel_m) {
    ObjectObservation obs;
    obs.class_name = "chair";
    obs.class_id = 56;
    obs.probability = 0.8;
    obs.keyframe = keyframe;
    for (int i = 0; i < 160; ++i) {
      for (int j = 0; j < 160; ++j) {
        const Eigen::Vector3f p(-0.4f + 0.005f * i + static_cast<float>(shift_m),
                                -0.4f + 0.005f * j, 1.0f + 0.0001f * (i % 7));
        obs.points_W.push_back(p);
        (keyframe > 0 && j >= 150 ? obs.seen_W : obs.segment_W).push_back(p);  // a strip later
        // views see but leave out of their cut
      }
    }
    obs.seen_W.insert(obs.seen_W.end(), obs.segment_W.begin(), obs.segment_W.end());
    obs.segment_normals_W.assign(obs.segment_W.size(), Eigen::Vector3f(0.f, 0.f, -1.f));
    obs.box.center_m = Eigen::Vector3d(shift_m, -0.025, 1.0);
    obs.box.size_m = Eigen::Vector3d(0.8, 0.75, 0.01);
    obs.depth_view = view;
    if (precompute) {
      obs.fusion_keys = std::make_shared<const FusionKeys>(
          makeFusionKeys(obs.segment_W, obs.seen_W, keys_voxel_m));
    }
    return obs;
  };
  const auto run = [&](bool precompute, double keys_voxel_m, int threads) {
    ObjectDatabase database(ObjectDatabase::Config(), priors_);
    int calls = 0;
    database.fuseOrInsert(make(0, 0.0, precompute, keys_voxel_m), centroidProcessor(&calls));
    database.fuseOrInsert(make(1, 0.013, precompute, keys_voxel_m), centroidProcessor(&calls),
                          true);
    database.fuseOrInsert(make(2, -0.021, precompute, keys_voxel_m), centroidProcessor(&calls),
                          true);
    EXPECT_EQ(database.reboxPending(centroidProcessor(&calls), threads), 1);
    EXPECT_EQ(database.size(), 1u);
    return database.objects().begin()->second;
  };
  const MapObject reference = run(false, 0.0, 1);
  ASSERT_GT(reference.evidence.size(), 4096u);  // more than one chunk of voxels
  int measured = 0;
  for (const auto& entry : reference.evidence) measured += entry.second.sdf_count > 0 ? 1 : 0;
  EXPECT_GT(measured, 6000);
  for (const auto& variant :
       {std::make_pair(true, 1), std::make_pair(true, 3), std::make_pair(false, 2)}) {
    const MapObject other = run(variant.first, 0.01, variant.second);
    ASSERT_EQ(other.evidence.size(), reference.evidence.size());
    for (const auto& entry : reference.evidence) {
      const auto it = other.evidence.find(entry.first);
      ASSERT_NE(it, other.evidence.end());
      EXPECT_EQ(it->second.inside, entry.second.inside);
      EXPECT_EQ(it->second.outside, entry.second.outside);
      EXPECT_EQ(it->second.sdf_count, entry.second.sdf_count);
      EXPECT_EQ(it->second.sdf_sum, entry.second.sdf_sum);  // bit for bit
      EXPECT_EQ(it->second.normal_sum, entry.second.normal_sum);
    }
    EXPECT_EQ(other.box.center_m, reference.box.center_m);
  }
  // Keys on another grid than the database's are recomputed, not used.
  const MapObject other_grid = run(true, 0.02, 2);
  EXPECT_EQ(other_grid.evidence.size(), reference.evidence.size());
  EXPECT_EQ(other_grid.box.center_m, reference.box.center_m);
  // Some voxels were seen outside the cut.
  int voted_out = 0;
  for (const auto& entry : reference.evidence) voted_out += entry.second.outside > 0 ? 1 : 0;
  EXPECT_GT(voted_out, 0);
}

// One object mapped twice: merging adds the second's votes, signed distances and normals to the
// first's voxels, with its observations and class scores, re-boxes the merged object and removes
// the second. Refused: an unknown or identical id, an object without evidence.
TEST_F(ObjectDatabaseTest, MergingADuplicateAddsItsEvidenceAndRemovesIt) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  // Two chairs' views 1 m apart (not fused), then one more view of the first.
  const int a =
      database
          .fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(&calls))
          .object_id;
  const int b =
      database
          .fuseOrInsert(observation("chair", {1.1, 2.0, 0.5}, 0.5, 0), centroidProcessor(&calls))
          .object_id;
  ASSERT_NE(a, b);
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.6, 1), centroidProcessor(&calls));
  ASSERT_EQ(database.size(), 2u);
  const MapObject before_a = *database.find(a);
  const MapObject before_b = *database.find(b);
  EXPECT_EQ(before_a.observations, 2);
  EXPECT_FALSE(database.mergeInto(a, a, centroidProcessor(&calls)));
  EXPECT_FALSE(database.mergeInto(a, 99, centroidProcessor(&calls)));
  calls = 0;
  ASSERT_TRUE(database.mergeInto(a, b, centroidProcessor(&calls)));
  EXPECT_EQ(calls, 1);  // re-boxed once
  ASSERT_EQ(database.size(), 1u);
  EXPECT_EQ(database.find(b), nullptr);
  const MapObject& merged = *database.find(a);
  EXPECT_EQ(merged.observations, 3);
  EXPECT_NEAR(merged.probability, (before_a.probability * 2 + 0.5) / 3.0, 1e-12);
  // a's 400 voxels and b's 400, 10 columns over: 200 shared.
  EXPECT_EQ(merged.evidence.size(), 600u);
  for (const auto& entry : before_b.evidence) {
    const auto it = merged.evidence.find(entry.first);
    ASSERT_NE(it, merged.evidence.end());
    const auto in_a = before_a.evidence.find(entry.first);
    const int inside_a = in_a == before_a.evidence.end() ? 0 : in_a->second.inside;
    EXPECT_EQ(it->second.inside, inside_a + entry.second.inside);
  }
  EXPECT_EQ(merged.points_W.size(), 600u);
  EXPECT_EQ(merged.segment_W.size(), 600u);  // the processor's segment: every supported voxel
  // The merged box: the processor's, from the union (its centre between the two patches).
  EXPECT_GT(merged.box.center_m.x(), before_a.box.center_m.x());
  EXPECT_NEAR(merged.class_scores.at("chair"), 0.8 + 0.6 + 0.5, 1e-12);
  // Both objects' views box it.
  EXPECT_EQ(merged.view_boxes.size(), before_a.view_boxes.size() + before_b.view_boxes.size());
  EXPECT_EQ(merged.view_boxes.size(), 3u);
  // An object without evidence (a map from the paper's fusion) is not merged.
  MapObject legacy = merged;
  legacy.id = 42;
  legacy.evidence.clear();
  database.setObjects({merged, legacy});
  EXPECT_FALSE(database.mergeInto(a, 42, centroidProcessor(&calls)));
  EXPECT_EQ(database.size(), 2u);
}

// Views of one patch whose poses are off by up to 3.5 cm along x: the union of their cuts is that
// much longer than the patch; the views' consensus box is not (view_consensus.h). 0 = the union.
TEST_F(ObjectDatabaseTest, ViewsOffByPoseErrorAreBoxedByTheirConsensus) {
  // The bounds of the supported voxels, half a voxel out on each side.
  const FusedCloudProcessor bounds = [](const std::string&, const PointCloud& points_W,
                                        const std::vector<Eigen::Vector3f>&, PointCloud* segment_W,
                                        OrientedBox* box, double* yaw_rad) {
    Eigen::Vector3f low = points_W.front();
    Eigen::Vector3f high = points_W.front();
    for (const auto& p : points_W) {
      low = low.cwiseMin(p);
      high = high.cwiseMax(p);
    }
    box->center_m = (0.5f * (low + high)).cast<double>();
    box->size_m = (high - low).cast<double>() + Eigen::Vector3d::Constant(0.01);
    box->rotation.setIdentity();
    *segment_W = points_W;
    *yaw_rad = 0.0;
    return true;
  };
  double length_m[2] = {0.0, 0.0};
  for (const double consensus_m : {0.0, 0.06}) {
    ObjectDatabase::Config config;
    config.view_consensus_m = consensus_m;
    ObjectDatabase database(config, priors_);
    for (int v = 0; v < 8; ++v) {
      database.fuseOrInsert(observation("chair", {0.9825 + 0.005 * v, 2.0, 0.5}, 0.8, v), bounds);
    }
    ASSERT_EQ(database.size(), 1u);
    const MapObject& object = database.objects().begin()->second;
    EXPECT_EQ(object.view_boxes.size(), 8u);
    length_m[consensus_m > 0.0 ? 1 : 0] = object.box.size_m.x();
    EXPECT_NEAR(object.box.center_m.x(), 1.0, 0.003);
  }
  EXPECT_NEAR(length_m[0], 0.235, 0.006);  // the union: 20 cm of patch and 3.5 cm of spread
  EXPECT_LT(length_m[1], length_m[0] - 0.01);
  EXPECT_GE(length_m[1], 0.2);
}

TEST_F(ObjectDatabaseTest, AnObjectKeepsTheBoxesOfItsLatestViewsOnly) {
  ObjectDatabase database(ObjectDatabase::Config(), priors_);
  int calls = 0;
  const int views = static_cast<int>(kMaxViewBoxes) + 2;
  for (int v = 0; v < views; ++v) {
    ObjectObservation obs = observation("chair", {1.0, 2.0, 0.5}, 0.8, v);
    obs.box.size_m.z() = 0.001 * v;  // tells the views apart
    database.fuseOrInsert(obs, centroidProcessor(&calls));
  }
  ASSERT_EQ(database.size(), 1u);
  const MapObject& object = database.objects().begin()->second;
  ASSERT_EQ(object.view_boxes.size(), kMaxViewBoxes);
  EXPECT_DOUBLE_EQ(object.view_boxes.front().size_m.z(), 0.002);
  EXPECT_DOUBLE_EQ(object.view_boxes.back().size_m.z(), 0.001 * (views - 1));
}

TEST_F(ObjectDatabaseTest, DeferredReboxingBoxesEachObjectOnceWithTheSameResult) {
  // Two chairs seen in keyframe 0, then each twice in keyframe 1 (the second time shifted) and a
  // cup once: the same objects, votes and boxes as fusing immediately, one box per object.
  ObjectDatabase::Config config;
  config.no_fusion_within_keyframe = false;
  const auto run = [&](bool defer, int threads, int* calls) {
    ObjectDatabase database(config, priors_);
    database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(calls));
    database.fuseOrInsert(observation("chair", {3.0, 2.0, 0.5}, 0.7, 0), centroidProcessor(calls));
    database.fuseOrInsert(observation("cup", {5.0, 2.0, 0.8}, 0.6, 0), centroidProcessor(calls));
    for (const double shift : {0.0, 0.02}) {
      database.fuseOrInsert(observation("chair", {3.0 + shift, 2.0, 0.5}, 0.9, 1),
                            centroidProcessor(calls), defer);
      database.fuseOrInsert(observation("chair", {1.0 + shift, 2.0, 0.5}, 0.6, 1),
                            centroidProcessor(calls), defer);
    }
    database.fuseOrInsert(observation("cup", {5.0, 2.0, 0.8}, 0.9, 1), centroidProcessor(calls),
                          defer);
    if (defer) {
      EXPECT_EQ(database.pendingRebox().size(), 3u);
      EXPECT_EQ(database.reboxPending(centroidProcessor(calls), threads), 3);
      EXPECT_TRUE(database.pendingRebox().empty());
    }
    return database;
  };
  int immediate_calls = 0;
  const ObjectDatabase immediate = run(false, 1, &immediate_calls);
  EXPECT_EQ(immediate_calls, 5);  // one per fusion
  for (const int threads : {1, 3}) {
    int deferred_calls = 0;
    const ObjectDatabase deferred = run(true, threads, &deferred_calls);
    EXPECT_EQ(deferred_calls, 3);  // one per fused object
    ASSERT_EQ(deferred.size(), immediate.size());
    for (const auto& entry : immediate.objects()) {
      const MapObject* other = deferred.find(entry.first);
      ASSERT_NE(other, nullptr);
      EXPECT_EQ(other->observations, entry.second.observations);
      EXPECT_DOUBLE_EQ(other->probability, entry.second.probability);
      EXPECT_EQ(other->box.center_m, entry.second.box.center_m) << "object " << entry.first;
      EXPECT_EQ(other->segment_W, entry.second.segment_W);
      EXPECT_EQ(other->points_W.size(), entry.second.points_W.size());
      EXPECT_DOUBLE_EQ(other->yaw_rad, entry.second.yaw_rad);
    }
  }
  // A removed object is no longer pending; the paper's fusion never defers.
  ObjectDatabase database(config, priors_);
  int calls = 0;
  const auto first = database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0),
                                           centroidProcessor(&calls));
  database.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 1), centroidProcessor(&calls),
                        true);
  ASSERT_EQ(database.pendingRebox().size(), 1u);
  database.remove(first.object_id);
  EXPECT_TRUE(database.pendingRebox().empty());
  EXPECT_EQ(database.reboxPending(centroidProcessor(&calls), 2), 0);
  ObjectDatabase::Config paper = config;
  paper.fusion = "paper";
  ObjectDatabase literal(paper, priors_);
  literal.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 0), centroidProcessor(&calls));
  calls = 0;
  literal.fuseOrInsert(observation("chair", {1.0, 2.0, 0.5}, 0.8, 1), centroidProcessor(&calls),
                       true);
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(literal.pendingRebox().empty());
}

}  // namespace
}  // namespace mvod
