// The map follows the SLAM's corrections (ObjectMapper::correctPoses): a rendered room walked
// twice, the first lap's poses drifting as a visual SLAM's do (0.36 m and 4 degrees of yaw by the
// lap's end), the second lap's right, as after a loop closure. Corrected at the loop, the map must
// equal the one the right poses give from the start.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/object_mapper.h"
#include "room_walk.h"

namespace mvod {
namespace {

constexpr int kLaps = 2;

class PoseCorrectionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new SyntheticScene(SyntheticScene::makeDefault(test::walkConfig(test::kFramesPerLap)));
    for (int k = 0; k < test::kFramesPerLap * kLaps; ++k) {
      RgbdFrame frame;
      std::vector<Detection2D> detections;
      test::renderKeyframe(*scene_, k % test::kFramesPerLap, k, &frame, &detections);
      frames_.push_back(frame);
      detections_.push_back(detections);
    }
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
    frames_.clear();
    detections_.clear();
  }

  void SetUp() override {
    ASSERT_TRUE(
        ClassPriors::loadYaml(std::string(MVOD_SOURCE_DIR) + "/config/class_priors.yaml", &priors_)
            .ok());
    config_.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    config_.num_threads = 2;
  }

  // Keyframe k as the SLAM gave it: the first lap drifts, the second is right.
  RgbdFrame drifted(int k) const {
    RgbdFrame frame = frames_[k];
    if (k < test::kFramesPerLap) {
      const double share = static_cast<double>(k) / (test::kFramesPerLap - 1);
      frame.T_W_D = drift_.at(share, frames_[0].T_W_D.translation()) * frame.T_W_D;
    }
    return frame;
  }
  // The right colour-camera pose of keyframe k, as a correction.
  PoseCorrection truth(int k) const {
    PoseCorrection correction;
    correction.stamp_s = frames_[k].stamp_s;
    correction.T_W_C = frames_[k].T_W_D * frames_[k].T_C_D.inverse();
    return correction;
  }
  std::vector<PoseCorrection> truths(int first, int last) const {
    std::vector<PoseCorrection> corrections;
    for (int k = first; k <= last; ++k) corrections.push_back(truth(k));
    return corrections;
  }

  // Runs every keyframe (drifted or right), calling before(k, mapper) before keyframe k and
  // before(n, mapper) after the last.
  std::vector<MapObject> run(bool drift,
                             const std::function<void(int, ObjectMapper*)>& before = nullptr) {
    ObjectMapper mapper(config_, priors_);
    const int n = static_cast<int>(frames_.size());
    for (int k = 0; k <= n; ++k) {
      if (before) before(k, &mapper);
      if (k == n) break;
      KeyframeReport report;
      EXPECT_TRUE(
          mapper.processKeyframe(drift ? drifted(k) : frames_[k], detections_[k], &report).ok());
    }
    return test::objectsOf(mapper);
  }

  static SyntheticScene* scene_;
  static std::vector<RgbdFrame> frames_;
  static std::vector<std::vector<Detection2D>> detections_;
  ClassPriors priors_;
  ObjectMapper::Config config_;
  test::Drift drift_;
};

SyntheticScene* PoseCorrectionTest::scene_ = nullptr;
std::vector<RgbdFrame> PoseCorrectionTest::frames_;
std::vector<std::vector<Detection2D>> PoseCorrectionTest::detections_;

TEST_F(PoseCorrectionTest, DriftWithoutCorrectionMisplacesObjects) {
  const std::vector<MapObject> truth = run(false);
  ASSERT_GE(truth.size(), 6u);
  const test::MapDifference d = test::compareMaps(truth, run(true));
  std::printf("drifted, not corrected: centre %.3f m, size %.3f m, %d missing, %d extra of %zu\n",
              d.centre_m, d.size_m, d.missing, d.extra, truth.size());
  // What the correction has to repair: boxes off or objects mapped twice.
  EXPECT_TRUE(d.centre_m > 0.05 || d.size_m > 0.05 || d.extra > 0 || d.missing > 0)
      << "centre " << d.centre_m << " size " << d.size_m << " extra " << d.extra;
}

TEST_F(PoseCorrectionTest, CorrectionAtTheLoopGivesTheMapOfTheRightPoses) {
  const std::vector<MapObject> truth = run(false);
  ObjectMapper::CorrectionReport report;
  const std::vector<MapObject> corrected = run(true, [&](int k, ObjectMapper* mapper) {
    if (k != test::kFramesPerLap) return;
    ASSERT_TRUE(mapper->correctPoses(truths(0, test::kFramesPerLap - 1), &report).ok());
  });
  EXPECT_FALSE(report.ignored);
  EXPECT_EQ(report.keyframes_moved, test::kFramesPerLap - 1);  // keyframe 0 did not drift
  EXPECT_EQ(report.unmatched, 0);
  EXPECT_GT(report.views_replayed, 0);
  const test::MapDifference d = test::compareMaps(truth, corrected);
  std::printf(
      "corrected at the loop: centre %.3f m, size %.3f m, %d missing, %d extra of %zu; "
      "%d views replayed in %.1f ms\n",
      d.centre_m, d.size_m, d.missing, d.extra, truth.size(), report.views_replayed,
      report.time_ms);
  EXPECT_EQ(d.missing, 0);
  EXPECT_EQ(d.extra, 0);  // nothing mapped twice
  EXPECT_LE(d.centre_m, 0.02);
  EXPECT_LE(d.size_m, 0.02);
}

TEST_F(PoseCorrectionTest, CorrectionAfterTheLastKeyframe) {
  const std::vector<MapObject> truth = run(false);
  const std::vector<MapObject> corrected = run(true, [&](int k, ObjectMapper* mapper) {
    if (k == test::kFramesPerLap * kLaps) {
      ASSERT_TRUE(mapper->correctPoses(truths(0, test::kFramesPerLap - 1), nullptr).ok());
    }
  });
  const test::MapDifference d = test::compareMaps(truth, corrected);
  EXPECT_EQ(d.missing, 0);
  EXPECT_EQ(d.extra, 0);
  EXPECT_LE(d.centre_m, 0.02);
  EXPECT_LE(d.size_m, 0.02);
}

// The replay builds the next record's depth view beside the current record's fusion: on two
// threads the corrected map must be the one thread's, bit for bit (ids, boxes, evidence, votes).
TEST_F(PoseCorrectionTest, TheCorrectionOnTwoThreadsGivesTheOneThreadMap) {
  std::vector<std::vector<MapObject>> maps;
  for (const int threads : {1, 2}) {
    config_.num_threads = threads;
    ObjectMapper::CorrectionReport report;
    maps.push_back(run(true, [&](int k, ObjectMapper* mapper) {
      if (k != test::kFramesPerLap * kLaps) return;
      ASSERT_TRUE(mapper->correctPoses(truths(0, test::kFramesPerLap - 1), &report).ok());
    }));
    EXPECT_GT(report.views_replayed, 0);
  }
  ASSERT_EQ(maps[0].size(), maps[1].size());
  ASSERT_GE(maps[0].size(), 6u);
  for (std::size_t i = 0; i < maps[0].size(); ++i) {
    const MapObject& a = maps[0][i];
    const MapObject& b = maps[1][i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.class_name, b.class_name) << "object " << a.id;
    EXPECT_EQ(a.observations, b.observations) << "object " << a.id;
    EXPECT_EQ(a.probability, b.probability) << "object " << a.id;
    EXPECT_EQ(a.box.center_m, b.box.center_m) << "object " << a.id;
    EXPECT_EQ(a.box.size_m, b.box.size_m) << "object " << a.id;
    EXPECT_EQ(a.box.rotation, b.box.rotation) << "object " << a.id;
    EXPECT_EQ(a.evidence.size(), b.evidence.size()) << "object " << a.id;
    EXPECT_EQ(a.free_space.size(), b.free_space.size()) << "object " << a.id;
    EXPECT_EQ(a.existence.log_odds, b.existence.log_odds) << "object " << a.id;
    EXPECT_EQ(a.existence.detected, b.existence.detected) << "object " << a.id;
    EXPECT_EQ(a.existence.seen_through, b.existence.seen_through) << "object " << a.id;
  }
}

TEST_F(PoseCorrectionTest, PartialThenSecondCorrection) {
  const std::vector<MapObject> truth = run(false);
  std::vector<MapObject> after_first;
  const std::vector<MapObject> corrected = run(true, [&](int k, ObjectMapper* mapper) {
    if (k == test::kFramesPerLap) {
      // Only the lap's second half first; the rest keeps its drifted pose.
      ASSERT_TRUE(
          mapper->correctPoses(truths(test::kFramesPerLap / 2, test::kFramesPerLap - 1), nullptr)
              .ok());
      after_first = test::objectsOf(*mapper);
    }
    if (k == test::kFramesPerLap * kLaps) {
      ASSERT_TRUE(mapper->correctPoses(truths(0, test::kFramesPerLap / 2 - 1), nullptr).ok());
    }
  });
  EXPECT_FALSE(after_first.empty());
  const test::MapDifference d = test::compareMaps(truth, corrected);
  EXPECT_EQ(d.missing, 0);
  EXPECT_EQ(d.extra, 0);
  EXPECT_LE(d.centre_m, 0.02);
  EXPECT_LE(d.size_m, 0.02);
}

TEST_F(PoseCorrectionTest, IdsAreKeptAndNeverReused) {
  int next_id_before = 0;
  std::vector<int> ids_before;
  const std::vector<MapObject> corrected = run(true, [&](int k, ObjectMapper* mapper) {
    if (k != test::kFramesPerLap * kLaps) return;
    next_id_before = mapper->database().nextId();
    for (const auto& entry : mapper->database().objects()) ids_before.push_back(entry.first);
    ASSERT_TRUE(mapper->correctPoses(truths(0, test::kFramesPerLap - 1), nullptr).ok());
    EXPECT_GE(mapper->database().nextId(), next_id_before);
  });
  // Every object keeps an id it had (the duplicates the drift made merge into one of theirs).
  for (const MapObject& object : corrected) {
    EXPECT_NE(std::find(ids_before.begin(), ids_before.end(), object.id), ids_before.end())
        << object.class_name << " #" << object.id << " has a new id";
  }
  EXPECT_LE(corrected.size(), ids_before.size());
}

// The pose as a nav_msgs/Path carries it (a quaternion): the node's own ~keyframes path sent back
// on keyframe_poses differs from the keyframes' poses in the last bits.
Eigen::Isometry3d throughQuaternion(const Eigen::Isometry3d& T) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  out.translation() = T.translation();
  return out;
}

// Two maps object for object: ids, classes, boxes, votes (what ~get_objects would show).
void expectSameMap(const std::vector<MapObject>& expected, const std::vector<MapObject>& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const MapObject& a = expected[i];
    const MapObject& b = actual[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.class_name, b.class_name) << "object " << a.id;
    EXPECT_EQ(a.observations, b.observations) << "object " << a.id;
    EXPECT_LE((a.box.center_m - b.box.center_m).norm(), 1e-6) << "object " << a.id;
    EXPECT_LE((a.box.size_m - b.box.size_m).norm(), 1e-6) << "object " << a.id;
    EXPECT_EQ(a.existence.detected, b.existence.detected) << "object " << a.id;
    EXPECT_EQ(a.existence.missed, b.existence.missed) << "object " << a.id;
    EXPECT_EQ(a.existence.seen_through, b.existence.seen_through) << "object " << a.id;
  }
}

// The node's own keyframe path sent back: every pose the same but for the quaternion's last bits.
// The map must stay what it is, object for object (a rebuild used to lose objects).
TEST_F(PoseCorrectionTest, TheKeyframesOwnPosesChangeNothing) {
  for (const int refine_every : {0, 10}) {
    std::vector<MapObject> before;
    ObjectMapper::CorrectionReport report;
    const std::vector<MapObject> after = run(false, [&](int k, ObjectMapper* mapper) {
      if (refine_every > 0 && k > 0 && k % refine_every == 0) mapper->refine();
      if (k != test::kFramesPerLap * kLaps) return;
      mapper->refine();
      before = test::objectsOf(*mapper);
      std::vector<PoseCorrection> own;
      for (int i = 0; i < k; ++i) {
        PoseCorrection correction = truth(i);
        correction.T_W_C = throughQuaternion(correction.T_W_C);
        own.push_back(correction);
      }
      ASSERT_TRUE(mapper->correctPoses(own, &report).ok());
    });
    std::printf("refine every %d: own poses back: %d keyframes moved, objects %d -> %d\n",
                refine_every, report.keyframes_moved, report.objects_before, report.objects_after);
    expectSameMap(before, after);
  }
}

// A wrong correction (the first lap 0.5 m off), then the true poses: the map it started from.
TEST_F(PoseCorrectionTest, AWrongCorrectionThenTheTruePosesEndWhereItStarted) {
  for (const int refine_every : {0, 10}) {
    std::vector<MapObject> before;
    std::vector<MapObject> wrong;
    const std::vector<MapObject> after = run(false, [&](int k, ObjectMapper* mapper) {
      if (refine_every > 0 && k > 0 && k % refine_every == 0) mapper->refine();
      if (k != test::kFramesPerLap * kLaps) return;
      mapper->refine();
      before = test::objectsOf(*mapper);
      std::vector<PoseCorrection> off = truths(0, test::kFramesPerLap - 1);
      for (PoseCorrection& correction : off) correction.T_W_C.translation().x() += 0.5;
      ASSERT_TRUE(mapper->correctPoses(off, nullptr).ok());
      wrong = test::objectsOf(*mapper);
      std::vector<PoseCorrection> back = truths(0, test::kFramesPerLap - 1);
      for (PoseCorrection& correction : back) {
        correction.T_W_C = throughQuaternion(correction.T_W_C);
      }
      ASSERT_TRUE(mapper->correctPoses(back, nullptr).ok());
    });
    std::printf(
        "refine every %d: %zu objects, %zu after the wrong correction, %zu after the true\n",
        refine_every, before.size(), wrong.size(), after.size());
    expectSameMap(before, after);
  }
}

// A wrong correction of the lap's second half (turned 90 degrees): its keyframes now look through
// the place of the tv, which only the first half saw. The tv stays (none of its views moved; the
// rebuild alone removed it before); what goes is reported with the reason, and had a view in a
// moved keyframe.
TEST_F(PoseCorrectionTest, ACorrectionRemovesOnlyWhatTheMovedPosesExplain) {
  ObjectMapper mapper(config_, priors_);
  for (int k = 0; k < test::kFramesPerLap; ++k) {
    ASSERT_TRUE(mapper.processKeyframe(frames_[k], detections_[k], nullptr).ok());
  }
  mapper.refine();
  const int first_moved = test::kFramesPerLap / 2;
  std::set<int> moved_views;  // objects with a view in a keyframe the correction moves
  for (const KeyframeRecord& record : mapper.history().records()) {
    for (const RecordedView& view : record.views) {
      if (record.keyframe >= first_moved) moved_views.insert(view.object_id);
    }
  }
  const std::vector<MapObject> before = test::objectsOf(mapper);
  std::vector<PoseCorrection> wrong = truths(first_moved, test::kFramesPerLap - 1);
  // Turned by -90 degrees about the half's first camera.
  const Eigen::Vector3d pivot = frames_[first_moved].T_W_D.translation();
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(-M_PI / 2.0, Eigen::Vector3d::UnitZ()).matrix();
  turn.translation() = pivot - turn.linear() * pivot;
  for (PoseCorrection& correction : wrong) correction.T_W_C = turn * correction.T_W_C;
  ObjectMapper::CorrectionReport report;
  ASSERT_TRUE(mapper.correctPoses(wrong, &report).ok());
  const std::vector<MapObject> after = test::objectsOf(mapper);
  std::printf(
      "wrong correction of keyframes %d-%d: objects %zu -> %zu, %zu removed, %d kept "
      "although the rebuild removed them\n",
      first_moved, test::kFramesPerLap - 1, before.size(), after.size(), report.removed.size(),
      report.objects_restored);
  EXPECT_GE(report.objects_restored, 1) << "the wrong poses no longer see through the tv";
  for (const MapObject& object : before) {
    if (moved_views.count(object.id) != 0) continue;
    const bool kept = std::any_of(after.begin(), after.end(),
                                  [&](const MapObject& o) { return o.id == object.id; });
    EXPECT_TRUE(kept) << object.class_name << " #" << object.id
                      << ": none of its views moved, but the correction removed it";
  }
  for (const ObjectMapper::RemovedObject& removed : report.removed) {
    EXPECT_FALSE(removed.reason.empty());
    std::printf("  removed %s #%d: %s\n", removed.object.class_name.c_str(), removed.object.id,
                removed.reason.c_str());
  }
  // Every object that left is reported, none that stayed.
  for (const MapObject& object : before) {
    const bool kept = std::any_of(after.begin(), after.end(),
                                  [&](const MapObject& o) { return o.id == object.id; });
    const bool reported =
        std::any_of(report.removed.begin(), report.removed.end(),
                    [&](const ObjectMapper::RemovedObject& r) { return r.object.id == object.id; });
    EXPECT_NE(kept, reported) << object.class_name << " #" << object.id;
  }
}

TEST_F(PoseCorrectionTest, UnmatchedAndInvalidCorrections) {
  ObjectMapper mapper(config_, priors_);
  for (int k = 0; k < 4; ++k) {
    ASSERT_TRUE(mapper.processKeyframe(drifted(k), detections_[k], nullptr).ok());
  }
  const std::vector<MapObject> before = test::objectsOf(mapper);
  ObjectMapper::CorrectionReport report;
  PoseCorrection stray = truth(1);
  stray.stamp_s = 1000.0;  // no keyframe has it
  ASSERT_TRUE(mapper.correctPoses({stray}, &report).ok());
  EXPECT_EQ(report.unmatched, 1);
  EXPECT_EQ(report.keyframes_moved, 0);
  PoseCorrection bad = truth(1);
  bad.T_W_C.linear() *= 2.0;  // not a rotation
  EXPECT_FALSE(mapper.correctPoses({truth(2), bad}, &report).ok());
  PoseCorrection nan = truth(1);
  nan.T_W_C.translation().x() = std::nan("");
  EXPECT_FALSE(mapper.correctPoses({nan}, &report).ok());
  // Refused batches change nothing.
  const test::MapDifference d = test::compareMaps(before, test::objectsOf(mapper));
  EXPECT_EQ(d.centre_m, 0.0);
  EXPECT_EQ(d.extra + d.missing, 0);
}

TEST_F(PoseCorrectionTest, ThePapersMethodIgnoresCorrections) {
  config_.usePaperMethod();
  ObjectMapper mapper(config_, priors_);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(mapper.processKeyframe(drifted(k), detections_[k], nullptr).ok());
  }
  EXPECT_TRUE(mapper.history().empty());  // nothing kept: no memory spent
  ObjectMapper::CorrectionReport report;
  ASSERT_TRUE(mapper.correctPoses(truths(0, 2), &report).ok());
  EXPECT_TRUE(report.ignored);
  EXPECT_EQ(report.keyframes_moved, 0);
}

}  // namespace
}  // namespace mvod
