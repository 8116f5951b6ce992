// Sec. 3.5 database refinement: the atypical-size filter (Eq. 9) and the intersection filter
// (Eq. 10, 11, Algorithm 1), on boxes and on an ObjectDatabase.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "multiview_object_detection/pipeline/map/refinement.h"

namespace mvod {
namespace {

using Case = IntersectionFilter::Case;

const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

OrientedBox makeBox(const Eigen::Vector3d& center_m, const Eigen::Vector3d& size_m,
                    double yaw_rad = 0.0, const GravityFrame& frame = GravityFrame()) {
  OrientedBox box;
  box.center_m = center_m;
  box.size_m = size_m;
  box.rotation = frame.rotationFromYaw(yaw_rad);
  return box;
}

MapObject makeObject(int id, const std::string& class_name, const OrientedBox& box) {
  MapObject object;
  object.id = id;
  object.class_name = class_name;
  object.class_id = cocoClassId(class_name);
  object.probability = 0.8;
  object.observations = 1;
  object.box = box;
  return object;
}

ObjectDatabase makeDatabase(const std::vector<MapObject>& objects,
                            const ClassPriors& priors = ClassPriors()) {
  ObjectDatabase database(ObjectDatabase::Config(), priors);
  database.setObjects(objects);
  return database;
}

// ---------------------------------------------------------------------------------------------
// Intersection filter: the four situations of Fig. 4, A = a 1 m cube at the origin, B = a 0.5 m
// cube.

struct Figure4Case {
  const char* name;
  OrientedBox b;
  Case expected;
  bool b_deleted;
};

std::vector<Figure4Case> figure4Cases() {
  const Eigen::Vector3d half(0.5, 0.5, 0.5);
  return {
      // (a) apart.
      {"no intersection", makeBox(Eigen::Vector3d(2.0, 0.0, 0.0), half), Case::kNoIntersection,
       false},
      // (b) B reaches 0.15 m into A: η_B = 0.3, η_A = 0.0375.
      {"tiny", makeBox(Eigen::Vector3d(0.6, 0.0, 0.0), half), Case::kTiny, false},
      // (c) 0.35 m of B inside A: η_B = 0.7.
      {"large", makeBox(Eigen::Vector3d(0.4, 0.0, 0.0), half), Case::kLarge, true},
      // (d) B, turned by a yaw, entirely inside A.
      {"full", makeBox(Eigen::Vector3d(0.15, 0.1, -0.2), half, 0.3), Case::kFull, true},
  };
}

class IntersectionFilterTest : public ::testing::Test {
 protected:
  OrientedBox a_ = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 1.0, 1.0));
  IntersectionFilter filter_;  // Γ = 0.5
};

TEST_F(IntersectionFilterTest, ClassifiesTheFourCasesOfFigure4) {
  const std::vector<double> expected_eta_b = {0.0, 0.3, 0.7, 1.0};
  const std::vector<Figure4Case> cases = figure4Cases();
  for (size_t i = 0; i < cases.size(); ++i) {
    double eta_a = -1.0;
    double eta_b = -1.0;
    EXPECT_EQ(filter_.classify(a_, cases[i].b, kUp, &eta_a, &eta_b), cases[i].expected)
        << cases[i].name;
    EXPECT_NEAR(eta_b, expected_eta_b[i], 1e-9) << cases[i].name;
    EXPECT_NEAR(eta_a, expected_eta_b[i] * cases[i].b.volume() / a_.volume(), 1e-9)
        << cases[i].name;
    // The reverse pair: same situation, the ratios swap (the contained box is then A).
    double reverse_a = -1.0;
    double reverse_b = -1.0;
    EXPECT_EQ(filter_.classify(cases[i].b, a_, kUp, &reverse_a, &reverse_b), cases[i].expected)
        << cases[i].name;
    EXPECT_NEAR(reverse_a, eta_b, 1e-12) << cases[i].name;
    EXPECT_NEAR(reverse_b, eta_a, 1e-12) << cases[i].name;
  }
  // Null ratio outputs are allowed.
  EXPECT_EQ(filter_.classify(a_, cases[2].b, kUp), Case::kLarge);
}

TEST_F(IntersectionFilterTest, ThresholdDecidesBetweenTinyAndLarge) {
  const OrientedBox b = makeBox(Eigen::Vector3d(0.4, 0.0, 0.0), Eigen::Vector3d(0.5, 0.5, 0.5));
  IntersectionFilter::Config config;
  config.volume_ratio_threshold = 0.75;  // η_B = 0.7 is now tiny
  EXPECT_EQ(IntersectionFilter(config).classify(a_, b, kUp), Case::kTiny);
  config.volume_ratio_threshold = 0.65;
  EXPECT_EQ(IntersectionFilter(config).classify(a_, b, kUp), Case::kLarge);
}

TEST_F(IntersectionFilterTest, FullNeedsTheWholeBoxInside) {
  // Pokes out by 1 cm: large, not full.
  const OrientedBox b = makeBox(Eigen::Vector3d(0.26, 0.0, 0.0), Eigen::Vector3d(0.5, 0.5, 0.5));
  double eta_b = 0.0;
  EXPECT_EQ(filter_.classify(a_, b, kUp, nullptr, &eta_b), Case::kLarge);
  EXPECT_NEAR(eta_b, 0.49 / 0.5, 1e-9);
  // Sharing a face with A is still inside.
  const OrientedBox flush =
      makeBox(Eigen::Vector3d(0.25, 0.0, 0.0), Eigen::Vector3d(0.5, 0.5, 0.5));
  EXPECT_EQ(filter_.classify(a_, flush, kUp), Case::kFull);
}

TEST_F(IntersectionFilterTest, WorksAboutATiltedGravity) {
  const GravityFrame frame(Eigen::Vector3d(0.0, 0.9, 0.43).normalized());
  const OrientedBox a =
      makeBox(Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(1.0, 1.0, 1.0), 0.5, frame);
  // 0.35 m of a 0.5 m cube inside A along A's own x axis.
  const OrientedBox b =
      makeBox(a.center_m + 0.4 * a.rotation.col(0), Eigen::Vector3d(0.5, 0.5, 0.5), 0.5, frame);
  double eta_b = 0.0;
  EXPECT_EQ(filter_.classify(a, b, frame.up, nullptr, &eta_b), Case::kLarge);
  EXPECT_NEAR(eta_b, 0.7, 1e-9);
}

TEST_F(IntersectionFilterTest, DegenerateBoxesDoNotIntersect) {
  OrientedBox flat = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, 0.5, 0.0));
  OrientedBox nan_box = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.5, 0.5, 0.5));
  nan_box.center_m.x() = std::nan("");
  OrientedBox negative = makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(-0.5, -0.5, 0.5));
  for (const OrientedBox& bad : {flat, nan_box, negative}) {
    double eta_a = -1.0;
    double eta_b = -1.0;
    EXPECT_EQ(filter_.classify(a_, bad, kUp, &eta_a, &eta_b), Case::kNoIntersection);
    EXPECT_EQ(eta_a, 0.0);
    EXPECT_EQ(eta_b, 0.0);
    EXPECT_EQ(filter_.classify(bad, a_, kUp), Case::kNoIntersection);
  }
  // And Algorithm 1 neither deletes them nor because of them.
  const ObjectDatabase database =
      makeDatabase({makeObject(1, "chair", flat), makeObject(2, "chair", a_),
                    makeObject(3, "chair", nan_box), makeObject(4, "chair", negative)});
  EXPECT_TRUE(filter_.intersectingObjects(database, kUp).empty());
}

TEST_F(IntersectionFilterTest, Algorithm1OnTheFourCasesInBothIdOrders) {
  const OrientedBox far = makeBox(Eigen::Vector3d(5.0, 5.0, 0.0), Eigen::Vector3d(1, 1, 1));
  for (const Figure4Case& c : figure4Cases()) {
    // V_A >= V_B: A is σ (id 1), B is τ (id 2); then V_A < V_B in id order: B first.
    for (const bool big_first : {true, false}) {
      const int id_a = big_first ? 1 : 2;
      const int id_b = big_first ? 2 : 1;
      const ObjectDatabase database =
          makeDatabase({makeObject(id_a, "couch", a_), makeObject(id_b, "chair", c.b),
                        makeObject(3, "tv", far)});
      const std::vector<int> deleted = filter_.intersectingObjects(database, kUp);
      const std::vector<int> expected = c.b_deleted ? std::vector<int>{id_b} : std::vector<int>{};
      EXPECT_EQ(deleted, expected) << c.name << (big_first ? ", big first" : ", small first");
    }
  }
}

TEST_F(IntersectionFilterTest, ChainOfNestedBoxesLosesEveryInnerBoxInAnyIdOrder) {
  const std::vector<OrientedBox> boxes = {
      makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 2.0, 2.0)),              // A
      makeBox(Eigen::Vector3d(0.3, 0.2, 0.0), Eigen::Vector3d(1.0, 1.0, 1.0), 0.4),  // B ⊂ A
      makeBox(Eigen::Vector3d(0.3, 0.2, 0.1), Eigen::Vector3d(0.3, 0.3, 0.3), 1.0),  // C ⊂ B
  };
  std::vector<int> ids = {1, 2, 3};  // ids[k] = id of boxes[k]
  do {
    std::vector<MapObject> objects;
    for (int k = 0; k < 3; ++k) objects.push_back(makeObject(ids[k], "chair", boxes[k]));
    const std::vector<int> deleted = filter_.intersectingObjects(makeDatabase(objects), kUp);
    std::vector<int> expected = {ids[1], ids[2]};
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(deleted, expected) << "ids of A, B, C: " << ids[0] << ", " << ids[1] << ", "
                                 << ids[2];
  } while (std::next_permutation(ids.begin(), ids.end()));
}

TEST_F(IntersectionFilterTest, EveryBoxInsideALargeOneIsDeleted) {
  const ObjectDatabase database = makeDatabase(
      {makeObject(1, "dining table", a_),
       makeObject(2, "cup",
                  makeBox(Eigen::Vector3d(-0.3, 0.0, 0.0), Eigen::Vector3d(0.2, 0.2, 0.2))),
       makeObject(3, "cup",
                  makeBox(Eigen::Vector3d(0.3, 0.0, 0.0), Eigen::Vector3d(0.2, 0.2, 0.2))),
       makeObject(4, "cup",
                  makeBox(Eigen::Vector3d(0.0, 0.3, 0.0), Eigen::Vector3d(0.2, 0.2, 0.2)))});
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), (std::vector<int>{2, 3, 4}));
}

TEST_F(IntersectionFilterTest, MoreContainedOfTwoOverlappingObjectsIsDeleted) {
  // σ (id 1) is the smaller one: 60 % of it lies inside τ (id 2), 30 % of τ inside σ.
  const OrientedBox small = makeBox(Eigen::Vector3d(0.4, 0.0, 0.0), Eigen::Vector3d(1.0, 0.5, 1.0));
  const ObjectDatabase database =
      makeDatabase({makeObject(1, "chair", small), makeObject(2, "chair", a_)});
  double eta_small = 0.0;
  double eta_big = 0.0;
  EXPECT_EQ(filter_.classify(small, a_, kUp, &eta_small, &eta_big), Case::kLarge);
  EXPECT_NEAR(eta_small, 0.6, 1e-9);
  EXPECT_NEAR(eta_big, 0.3, 1e-9);
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), std::vector<int>{1});
}

TEST_F(IntersectionFilterTest, OfTwoIdenticalBoxesTheLaterIsDeleted) {
  const ObjectDatabase database =
      makeDatabase({makeObject(7, "chair", a_), makeObject(4, "couch", a_)});
  EXPECT_EQ(filter_.classify(a_, a_, kUp), Case::kFull);
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), std::vector<int>{7});
}

TEST_F(IntersectionFilterTest, OfTwoDuplicatesUnderTwoLabelsTheLessSupportedIsDeleted) {
  // One chair seen 7 times as a chair and twice as a couch: nearly the same box.
  MapObject couch = makeObject(3, "couch", a_);
  couch.observations = 2;
  MapObject chair =
      makeObject(5, "chair", makeBox(Eigen::Vector3d(0.05, 0.0, 0.0), Eigen::Vector3d(1, 1, 1)));
  chair.observations = 7;
  const ObjectDatabase database = makeDatabase({couch, chair});
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), std::vector<int>{3});
  // The deleted duplicate is reported with the object it duplicates (to merge it there); a
  // deletion by Algorithm 1's containment rule is not a duplicate.
  std::vector<std::pair<int, int>> duplicates;
  EXPECT_EQ(filter_.intersectingObjects(database, kUp, &duplicates), std::vector<int>{3});
  EXPECT_EQ(duplicates, (std::vector<std::pair<int, int>>{{3, 5}}));
  const OrientedBox small = makeBox(Eigen::Vector3d(0.4, 0.0, 0.0), Eigen::Vector3d(1.0, 0.5, 1.0));
  EXPECT_EQ(filter_.intersectingObjects(
                makeDatabase({makeObject(1, "chair", small), makeObject(2, "chair", a_)}), kUp,
                &duplicates),
            std::vector<int>{1});
  EXPECT_TRUE(duplicates.empty());
  // Algorithm 1 as published: ids and containment decide, not support.
  IntersectionFilter::Config paper;
  paper.duplicate_ratio = 0.0;
  paper.container_support_ratio = 0.0;
  EXPECT_EQ(IntersectionFilter(paper).intersectingObjects(database, kUp), std::vector<int>{5});
}

TEST_F(IntersectionFilterTest, WeakContainerAroundBetterSupportedObjectsGoes) {
  // Two chairs side by side, seen in 8 and 19 keyframes; a box detection spanning both, called a
  // couch in 3 keyframes, holds each of them entirely.
  MapObject couch = makeObject(
      1, "couch", makeBox(Eigen::Vector3d(0.0, 0.0, 0.45), Eigen::Vector3d(1.2, 0.55, 0.9)));
  couch.observations = 3;
  couch.probability = 0.6;
  MapObject left = makeObject(
      2, "chair", makeBox(Eigen::Vector3d(-0.3, 0.0, 0.44), Eigen::Vector3d(0.48, 0.49, 0.88)));
  left.observations = 8;
  MapObject right = makeObject(
      3, "chair", makeBox(Eigen::Vector3d(0.32, 0.0, 0.43), Eigen::Vector3d(0.5, 0.5, 0.86)));
  right.observations = 19;
  const ObjectDatabase database = makeDatabase({couch, left, right});
  EXPECT_EQ(filter_.classify(couch.box, left.box, kUp), Case::kFull);
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), std::vector<int>{1});
  // Algorithm 1 as published keeps the container and deletes both chairs.
  IntersectionFilter::Config paper;
  paper.duplicate_ratio = 0.0;
  paper.container_support_ratio = 0.0;
  EXPECT_EQ(IntersectionFilter(paper).intersectingObjects(database, kUp), (std::vector<int>{2, 3}));
  // Whatever the ids: the container last.
  couch.id = 9;
  EXPECT_EQ(filter_.intersectingObjects(makeDatabase({couch, left, right}), kUp),
            std::vector<int>{9});
}

TEST_F(IntersectionFilterTest, WellSupportedContainerStillDeletesWhatLiesInside) {
  // A table seen in 20 keyframes; a part of it called a chair in 9 (less than twice the table's
  // support): the part goes, as in Algorithm 1.
  MapObject table = makeObject(
      1, "dining table", makeBox(Eigen::Vector3d(0.0, 0.0, 0.37), Eigen::Vector3d(1.5, 0.9, 0.74)));
  table.observations = 20;
  MapObject part = makeObject(
      2, "chair", makeBox(Eigen::Vector3d(0.5, 0.2, 0.3), Eigen::Vector3d(0.4, 0.4, 0.6)));
  part.observations = 9;
  EXPECT_EQ(filter_.intersectingObjects(makeDatabase({table, part}), kUp), std::vector<int>{2});
  // Seen twice as often as the table, the part stays and the table goes.
  part.observations = 40;
  EXPECT_EQ(filter_.intersectingObjects(makeDatabase({table, part}), kUp), std::vector<int>{1});
  // A ratio of 5 keeps the table.
  IntersectionFilter::Config config;
  config.container_support_ratio = 5.0;
  EXPECT_EQ(IntersectionFilter(config).intersectingObjects(makeDatabase({table, part}), kUp),
            std::vector<int>{2});
}

TEST_F(IntersectionFilterTest, CompletedChairUnderATableIsJudgedOnWhatWasSeen) {
  // A table (20 keyframes) and a chair pushed under it (9): its completed box (seat under the
  // table top) lies 0.6 inside the table's; its observed part, the backrest beyond the table's
  // edge, not at all.
  MapObject table = makeObject(
      1, "dining table", makeBox(Eigen::Vector3d(0.0, 0.0, 0.37), Eigen::Vector3d(1.5, 0.9, 0.74)));
  table.observations = 20;
  MapObject chair = makeObject(
      2, "chair", makeBox(Eigen::Vector3d(0.3, 0.35, 0.42), Eigen::Vector3d(0.5, 0.55, 0.84)));
  chair.observations = 9;
  // Without completion, a box like that lies mostly inside the table's: deleted (Algorithm 1).
  EXPECT_EQ(filter_.intersectingObjects(makeDatabase({table, chair}), kUp), std::vector<int>{2});
  chair.box_completed = true;
  chair.observed_box = makeBox(Eigen::Vector3d(0.3, 0.6, 0.6), Eigen::Vector3d(0.5, 0.05, 0.48));
  EXPECT_TRUE(filter_.intersectingObjects(makeDatabase({table, chair}), kUp).empty());
}

TEST_F(IntersectionFilterTest, DeletedObjectCausesNoFurtherDeletion) {
  // X (id 1) = A. Y (id 2) pokes out of X: η_Y = 0.6 > η_X = 0.3, so X's step deletes Y. Z (id 3)
  // lies entirely inside the part of Y outside X: it only intersects the deleted Y and stays.
  const OrientedBox y = makeBox(Eigen::Vector3d(0.4, 0.0, 0.0), Eigen::Vector3d(1.0, 0.5, 1.0));
  const OrientedBox z = makeBox(Eigen::Vector3d(0.7, 0.0, 0.0), Eigen::Vector3d(0.3, 0.3, 0.3));
  const ObjectDatabase database = makeDatabase(
      {makeObject(1, "couch", a_), makeObject(2, "chair", y), makeObject(3, "cup", z)});
  EXPECT_EQ(filter_.classify(y, z, kUp), Case::kFull);
  EXPECT_EQ(filter_.classify(a_, z, kUp), Case::kNoIntersection);
  EXPECT_EQ(filter_.intersectingObjects(database, kUp), std::vector<int>{2});
}

TEST_F(IntersectionFilterTest, TinyOverlapsAndDisabledFilterDeleteNothing) {
  std::vector<MapObject> objects;
  for (int i = 0; i < 5; ++i) {  // a row of cubes overlapping their neighbours by 10 %
    objects.push_back(makeObject(
        i + 1, "chair", makeBox(Eigen::Vector3d(0.9 * i, 0, 0), Eigen::Vector3d(1, 1, 1))));
  }
  EXPECT_TRUE(filter_.intersectingObjects(makeDatabase(objects), kUp).empty());

  const ObjectDatabase nested = makeDatabase(
      {makeObject(1, "couch", a_),
       makeObject(2, "cup", makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0.2, 0.2)))});
  ASSERT_EQ(filter_.intersectingObjects(nested, kUp), std::vector<int>{2});
  IntersectionFilter::Config config;
  config.enable = false;
  EXPECT_TRUE(IntersectionFilter(config).intersectingObjects(nested, kUp).empty());
  EXPECT_TRUE(filter_.intersectingObjects(ObjectDatabase(), kUp).empty());
}

TEST(IntersectionFilterConfigTest, Validation) {
  IntersectionFilter::Config config;
  EXPECT_TRUE(config.isValid().ok()) << config.isValid().message();
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    config.volume_ratio_threshold = bad;
    const Status status = config.isValid();
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("volume_ratio_threshold"), std::string::npos);
  }
  config.volume_ratio_threshold = 0.3;
  for (const double bad : {-1.0, 0.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
    config.container_support_ratio = bad;
    const Status status = config.isValid();
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("container_support_ratio"), std::string::npos);
  }
  for (const double good : {0.0, 1.0, 2.0}) {
    config.container_support_ratio = good;
    EXPECT_TRUE(config.isValid().ok()) << good;
  }
  EXPECT_NE(config.print().find("volume_ratio_threshold: 0.3\n"), std::string::npos)
      << config.print();
  EXPECT_NE(config.print().find("enable: true\n"), std::string::npos) << config.print();
}

// ---------------------------------------------------------------------------------------------
// Prior size filter (Eq. 9): chair prior 0.55 x 0.55 x 0.9 m (volume 0.27225 m^3, min edge 0.55).

class PriorSizeFilterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClassPrior chair;
    chair.class_name = "chair";
    chair.has_size = true;
    chair.size_m = Eigen::Vector3d(0.55, 0.55, 0.9);
    priors_.set(chair);
    ClassPrior cup;  // listed, but without a size
    cup.class_name = "cup";
    cup.fusion_distance_m = 0.1;
    priors_.set(cup);
  }

  bool typical(const Eigen::Vector3d& size_m, const std::string& class_name = "chair",
               const PriorSizeFilter::Config& config = PriorSizeFilter::Config()) const {
    return PriorSizeFilter(config).isTypical(
        makeObject(1, class_name, makeBox(Eigen::Vector3d(1, 1, 0.5), size_m)), priors_);
  }

  ClassPriors priors_;
};

TEST_F(PriorSizeFilterTest, TypicalSizesAreKeptInAnyOrder) {
  EXPECT_TRUE(typical(Eigen::Vector3d(0.5, 0.5, 0.9)));
  EXPECT_TRUE(typical(Eigen::Vector3d(0.9, 0.5, 0.45)));  // axes in another order
  EXPECT_TRUE(typical(Eigen::Vector3d(0.3, 0.4, 0.5)));   // a partial view: smaller but plausible
}

TEST_F(PriorSizeFilterTest, TooSmallAndTooBigAreRemoved) {
  EXPECT_FALSE(typical(Eigen::Vector3d(0.10, 0.15, 0.05)));  // the paper's example
  EXPECT_FALSE(typical(Eigen::Vector3d(2.0, 2.0, 2.0)));
  EXPECT_FALSE(typical(Eigen::Vector3d(0.0, 0.0, 0.0)));
}

// The refinement says which way an object is atypical (issue 54, item 3): a box far larger than
// its class is often neighbours taken as one, a far smaller or thinner one a fragment.
TEST_F(PriorSizeFilterTest, TheReasonSaysTooLargeTooSmallOrTooThin) {
  const PriorSizeFilter filter;
  const auto reason = [&](const Eigen::Vector3d& size_m) {
    std::string why = "not set";
    filter.judge(makeObject(1, "chair", makeBox(Eigen::Vector3d(1, 1, 0.5), size_m)), priors_,
                 &why);
    return why;
  };
  EXPECT_EQ(reason(Eigen::Vector3d(0.5, 0.5, 0.9)), "");
  // 0.1 x 0.15 x 0.05 m: 0.00075 m^3, 0.0028 of the prior's 0.27225 m^3.
  EXPECT_EQ(reason(Eigen::Vector3d(0.10, 0.15, 0.05)),
            "too small for a chair: volume 0.0028 x its prior's (Eq. 9)");
  EXPECT_EQ(reason(Eigen::Vector3d(2.0, 2.0, 2.0)),
            "too large for a chair: volume 29 x its prior's (Eq. 9)");
  // A slab of a chair's volume: 0.05 m against the prior's shortest edge 0.55 m.
  EXPECT_EQ(reason(Eigen::Vector3d(2.0, 2.0, 0.05)),
            "too thin for a chair: shortest edge 0.091 x its prior's (Eq. 9)");
  // Each reason agrees with isTypical.
  for (const Eigen::Vector3d& size :
       {Eigen::Vector3d(0.3, 0.4, 0.5), Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(3, 1, 1)}) {
    EXPECT_EQ(reason(size).empty(), typical(size)) << size.transpose();
  }
}

TEST_F(PriorSizeFilterTest, VolumeLimitsAreTheRatiosTimesThePriorVolume) {
  const Eigen::Vector3d prior(0.55, 0.55, 0.9);
  // Scaling the prior shape by s scales the volume by s^3 (and keeps the edges long enough).
  const double s_min = std::cbrt(0.05);
  EXPECT_TRUE(typical(prior * s_min * (1.0 + 1e-6)));
  EXPECT_FALSE(typical(prior * s_min * (1.0 - 1e-6)));
  const double s_max = std::cbrt(8.0);
  EXPECT_TRUE(typical(prior * s_max * (1.0 - 1e-6)));
  EXPECT_FALSE(typical(prior * s_max * (1.0 + 1e-6)));
  // Other thresholds move the limits.
  PriorSizeFilter::Config strict;
  strict.volume_min_ratio = 0.5;
  strict.volume_max_ratio = 2.0;
  EXPECT_TRUE(typical(prior, "chair", strict));
  EXPECT_FALSE(typical(prior * std::cbrt(0.4), "chair", strict));
  EXPECT_FALSE(typical(prior * std::cbrt(2.5), "chair", strict));
  EXPECT_TRUE(typical(prior * std::cbrt(0.4)));
  EXPECT_TRUE(typical(prior * std::cbrt(2.5)));
}

TEST_F(PriorSizeFilterTest, VolumeFineButOneEdgeTooShortIsRemoved) {
  // 0.9 x 0.9 x 0.05: volume 0.0405 >= 0.05 * 0.272, but 0.05 < 0.2 * 0.55 = 0.11.
  const Eigen::Vector3d slab(0.9, 0.9, 0.05);
  ASSERT_GE(slab.prod(), 0.05 * 0.55 * 0.55 * 0.9);
  EXPECT_FALSE(typical(slab));
  EXPECT_FALSE(typical(Eigen::Vector3d(0.05, 0.9, 0.9)));
  // The edge limit itself: Γ_E times the prior's shortest edge.
  EXPECT_TRUE(typical(Eigen::Vector3d(0.9, 0.9, 0.11 * (1.0 + 1e-6))));
  EXPECT_FALSE(typical(Eigen::Vector3d(0.9, 0.9, 0.11 * (1.0 - 1e-6))));
  PriorSizeFilter::Config lenient;
  lenient.edge_min_ratio = 0.05;
  EXPECT_TRUE(typical(slab, "chair", lenient));
}

TEST_F(PriorSizeFilterTest, BadSizesAreRemoved) {
  EXPECT_FALSE(typical(Eigen::Vector3d(0.5, std::nan(""), 0.9)));
  EXPECT_FALSE(typical(Eigen::Vector3d(0.5, std::numeric_limits<double>::infinity(), 0.9)));
  EXPECT_FALSE(typical(Eigen::Vector3d(-0.5, -0.5, 0.9)));
}

TEST_F(PriorSizeFilterTest, ClassesWithoutPriorFollowTheConfig) {
  const Eigen::Vector3d huge(5.0, 5.0, 5.0);
  EXPECT_TRUE(typical(huge, "teddy bear"));  // not listed
  EXPECT_TRUE(typical(huge, "cup"));         // listed without a size
  PriorSizeFilter::Config config;
  config.keep_classes_without_prior = false;
  EXPECT_FALSE(typical(huge, "teddy bear", config));
  EXPECT_FALSE(typical(huge, "cup", config));
  EXPECT_FALSE(typical(Eigen::Vector3d(0.5, 0.5, 0.9), "teddy bear", config));
  EXPECT_TRUE(typical(Eigen::Vector3d(0.5, 0.5, 0.9), "chair", config));
}

TEST_F(PriorSizeFilterTest, ClassIdNamesTheClassWhenTheNameIsMissing) {
  MapObject object =
      makeObject(1, "chair", makeBox(Eigen::Vector3d::Zero(), Eigen::Vector3d(2, 2, 2)));
  object.class_name.clear();
  ASSERT_EQ(object.class_id, cocoClassId("chair"));
  EXPECT_FALSE(PriorSizeFilter().isTypical(object, priors_));
}

TEST_F(PriorSizeFilterTest, AtypicalObjectsOfADatabase) {
  const ObjectDatabase database = makeDatabase(
      {makeObject(3, "chair", makeBox(Eigen::Vector3d(0, 0, 0.45), Eigen::Vector3d(0.5, 0.5, 0.9))),
       makeObject(5, "chair", makeBox(Eigen::Vector3d(1, 0, 0.1), Eigen::Vector3d(0.9, 0.9, 0.05))),
       makeObject(6, "teddy bear", makeBox(Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(3, 3, 3))),
       makeObject(8, "chair", makeBox(Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(0.1, 0.15, 0.05))),
       makeObject(9, "chair", makeBox(Eigen::Vector3d(4, 0, 1), Eigen::Vector3d(2, 2, 2)))},
      priors_);
  EXPECT_EQ(PriorSizeFilter().atypicalObjects(database), (std::vector<int>{5, 8, 9}));
  // Per id, which way (5: a 5 cm slab of a chair; 8: a fragment; 9: 2 m across).
  using Verdict = PriorSizeFilter::Verdict;
  std::vector<Verdict> verdicts;
  std::vector<std::string> reasons;
  PriorSizeFilter().atypicalObjects(database, &verdicts, &reasons);
  EXPECT_EQ(verdicts,
            (std::vector<Verdict>{Verdict::kTooThin, Verdict::kTooSmall, Verdict::kTooLarge}));
  ASSERT_EQ(reasons.size(), 3u);
  EXPECT_EQ(reasons[2].rfind("too large for a chair", 0), 0u) << reasons[2];
  PriorSizeFilter::Config config;
  config.keep_classes_without_prior = false;
  EXPECT_EQ(PriorSizeFilter(config).atypicalObjects(database), (std::vector<int>{5, 6, 8, 9}));
  config.enable = false;
  EXPECT_TRUE(PriorSizeFilter(config).atypicalObjects(database).empty());
}

TEST(PriorSizeFilterConfigTest, Validation) {
  PriorSizeFilter::Config config;
  EXPECT_TRUE(config.isValid().ok()) << config.isValid().message();
  {
    PriorSizeFilter::Config bad = config;
    bad.volume_min_ratio = -0.1;
    EXPECT_NE(bad.isValid().message().find("volume_min_ratio"), std::string::npos);
    bad.volume_min_ratio = std::nan("");
    EXPECT_FALSE(bad.isValid().ok());
  }
  {
    PriorSizeFilter::Config bad = config;
    bad.volume_max_ratio = 0.01;  // below volume_min_ratio
    EXPECT_NE(bad.isValid().message().find("volume_max_ratio"), std::string::npos);
    bad.volume_max_ratio = std::nan("");
    EXPECT_FALSE(bad.isValid().ok());
    bad.volume_max_ratio = std::numeric_limits<double>::infinity();  // no upper limit
    EXPECT_TRUE(bad.isValid().ok());
  }
  {
    PriorSizeFilter::Config bad = config;
    bad.edge_min_ratio = -1.0;
    EXPECT_NE(bad.isValid().message().find("edge_min_ratio"), std::string::npos);
    bad.edge_min_ratio = std::numeric_limits<double>::infinity();
    EXPECT_FALSE(bad.isValid().ok());
  }
  const std::string printed = config.print();
  for (const char* line : {"enable: true\n", "volume_min_ratio: 0.05\n", "volume_max_ratio: 8\n",
                           "edge_min_ratio: 0.2\n", "keep_classes_without_prior: true\n"}) {
    EXPECT_NE(printed.find(line), std::string::npos) << line << " not in\n" << printed;
  }
}

}  // namespace
}  // namespace mvod
