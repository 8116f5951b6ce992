// Real depth and poses: the 7-Scenes redkitchen frames with box-only detections projected from the
// hand-annotated table and chairs (test/data/7scenes_redkitchen_annotation), and its mugs in one
// test. The default cut, fusion and amodal completion against the annotation; the paper's method
// and the default without completion on the same input, reported beside it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "multiview_object_detection/datasets/dataset.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/evaluation/box_detections.h"
#include "multiview_object_detection/evaluation/evaluation.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "shared_data.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

struct BoxComparison {
  double centre_m = 0.0;  // horizontal centre distance
  double edge_m = 0.0;    // worst footprint edge offset (along the truth's axes)
  double top_m = 0.0;     // top height difference
};

BoxComparison compare(const OrientedBox& predicted, const OrientedBox& truth,
                      const Eigen::Vector3d& up) {
  BoxComparison c;
  Eigen::Vector3d d = predicted.center_m - truth.center_m;
  c.centre_m = (d - up * up.dot(d)).norm();
  // The predicted footprint corners in the truth's horizontal axes.
  const Eigen::Vector3d ax = truth.rotation.col(0);
  const Eigen::Vector3d ay = truth.rotation.col(1);
  double lo_x = 1e9, hi_x = -1e9, lo_y = 1e9, hi_y = -1e9;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d corner =
        predicted.center_m +
        predicted.rotation.col(0) * ((i & 1) ? 0.5 : -0.5) * predicted.size_m.x() +
        predicted.rotation.col(1) * ((i & 2) ? 0.5 : -0.5) * predicted.size_m.y() - truth.center_m;
    lo_x = std::min(lo_x, ax.dot(corner));
    hi_x = std::max(hi_x, ax.dot(corner));
    lo_y = std::min(lo_y, ay.dot(corner));
    hi_y = std::max(hi_y, ay.dot(corner));
  }
  const Eigen::Vector3d half = 0.5 * truth.size_m;
  if (std::getenv("MVOD_DEBUG_REDKITCHEN") != nullptr) {
    std::printf("  edges: -x %.2f +x %.2f -y %.2f +y %.2f\n", lo_x + half.x(), hi_x - half.x(),
                lo_y + half.y(), hi_y - half.y());
  }
  c.edge_m = std::max({std::abs(lo_x + half.x()), std::abs(hi_x - half.x()),
                       std::abs(lo_y + half.y()), std::abs(hi_y - half.y())});
  const double top_p = up.dot(predicted.center_m) + 0.5 * predicted.size_m.z();
  const double top_t = up.dot(truth.center_m) + 0.5 * truth.size_m.z();
  c.top_m = std::abs(top_p - top_t);
  return c;
}

class RedkitchenAnnotationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string source = test::sharedPath("data/7scenes_redkitchen/data");
    if (source.empty()) {
      GTEST_SKIP() << "7-Scenes data not found (set MVOD_SHARED_DIR or put shared/ next to the "
                      "repository): ../shared/data/7scenes_redkitchen/data";
    }
    // The frames (links into the read-only shared folder) plus the colour intrinsics 7-Scenes
    // does not ship (Kinect v1 colour default; colour and depth are two cameras).
    dir_ = fs::temp_directory_path() / ("mvod_redkitchen_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    for (const auto& entry : fs::directory_iterator(source)) {
      fs::create_symlink(entry.path(), dir_ / entry.path().filename());
    }
    std::ofstream(dir_ / "color-intrinsics.txt") << "525 0 320\n0 525 240\n0 0 1\n";
    ASSERT_TRUE(SevenScenesDataset::open(dir_.string(), &dataset_).ok());
    ASSERT_TRUE(dataset_.hasGravity());
    up_ = -dataset_.gravityDown_W().normalized();
    RgbdFrame first;
    ASSERT_TRUE(dataset_.load(0, &first).ok());
    pivot_ = first.T_W_D.translation();
    const std::string annotation =
        std::string(MVOD_SOURCE_DIR) + "/test/data/7scenes_redkitchen_annotation/ground_truth.json";
    ASSERT_TRUE(loadSyntheticGroundTruth(annotation, 0.05, up_, &truth_).ok());
    // The table and the five chairs come first; the smaller things annotated after them (cups,
    // books, monitors) are the real-detector benchmark's (benchmark/redkitchen_benchmark) and, the
    // mugs, BoxOnlyDetectionsOfTheMugsAreTheMugs's.
    ASSERT_GE(truth_.size(), 6u);
    truth_.resize(6);
    for (size_t i = 0; i < truth_.size(); ++i) {
      ASSERT_EQ(truth_[i].class_name, i == 0 ? "dining table" : "chair") << i;
    }
    ASSERT_TRUE(
        ClassPriors::loadYaml(std::string(MVOD_SOURCE_DIR) + "/config/class_priors.yaml", &priors_)
            .ok());
  }
  void TearDown() override {
    std::error_code error;
    if (!dir_.empty()) fs::remove_all(dir_, error);
  }

  // SLAM-like drift (scripts/add_drift's): nothing at frame 0, 0.3 m (horizontal) and 4 degrees
  // of yaw about gravity (through the first camera) at frame 999.
  Eigen::Isometry3d drift(int index) const {
    const double share = index / 999.0;
    Eigen::Vector3d direction = up_.cross(Eigen::Vector3d::UnitX()).normalized();
    Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
    drift.linear() = Eigen::AngleAxisd(share * 4.0 * M_PI / 180.0, up_).matrix();
    drift.translation() = pivot_ - drift.linear() * pivot_ + direction * 0.3 * share;
    return drift;
  }

  // Every 10th frame a keyframe, the annotated boxes as box-only detections; no refinement.
  // drifted: the poses drift (drift()); before(index, mapper) runs before frame `index` (and with
  // index 1000 after the last).
  std::vector<MapObject> run(const ObjectMapper::Config& base, bool drifted = false,
                             const std::function<void(int, const std::vector<RgbdFrame>&,
                                                      ObjectMapper*)>& before = nullptr) {
    ObjectMapper::Config config = base;
    config.gravity_down_W = dataset_.gravityDown_W();
    ObjectMapper mapper(config, priors_);
    std::vector<RgbdFrame> keyframes;  // what a correction needs: stamps, true poses
    for (const int index : dataset_.frameIndices()) {
      if (index % 10 != 0) continue;
      if (before) before(index, keyframes, &mapper);
      RgbdFrame frame;
      EXPECT_TRUE(dataset_.load(index, &frame).ok());
      keyframes.push_back(frame);
      // What a box detector reports does not depend on the pose the SLAM gives.
      const std::vector<Detection2D> detections =
          boxDetectionsFromGroundTruth(truth_, frame, box_options_);
      if (drifted) frame.T_W_D = drift(index) * frame.T_W_D;
      KeyframeReport report;
      EXPECT_TRUE(mapper.processKeyframe(frame, detections, &report).ok());
      if (std::getenv("MVOD_DEBUG_REDKITCHEN") != nullptr) {
        for (const std::string& w : report.warnings) std::printf("%s\n", w.c_str());
        for (const Detection2D& d : detections) {
          std::printf("  %s [%d %d %d %d]\n", d.class_name.c_str(), d.box_px.x, d.box_px.y,
                      d.box_px.width, d.box_px.height);
        }
        std::printf("frame %d: %zu detections, %d with box, %zu objects, fused %d\n", index,
                    detections.size(), report.with_box, mapper.database().size(), report.fused);
      }
    }
    if (before) before(1000, keyframes, &mapper);
    std::vector<MapObject> objects;
    for (const auto& entry : mapper.database().objects()) objects.push_back(entry.second);
    if (std::getenv("MVOD_DEBUG_REDKITCHEN") != nullptr) {
      for (const MapObject& o : objects) {
        std::printf("object %d %s obs %d centre %.2f %.2f %.2f size %.2f %.2f %.2f\n", o.id,
                    o.class_name.c_str(), o.observations, o.box.center_m.x(), o.box.center_m.y(),
                    o.box.center_m.z(), o.box.size_m.x(), o.box.size_m.y(), o.box.size_m.z());
      }
    }
    return objects;
  }

  // The same-class object nearest to the truth (horizontally); null when there is none.
  const MapObject* match(const std::vector<MapObject>& objects, const GroundTruthObject& truth) {
    const MapObject* best = nullptr;
    double best_d = 1e9;
    for (const MapObject& object : objects) {
      if (object.class_name != truth.class_name) continue;
      const double d = compare(object.box, truth.box, up_).centre_m;
      if (d < best_d) {
        best_d = d;
        best = &object;
      }
    }
    return best;
  }

  fs::path dir_;
  SevenScenesDataset dataset_;
  Eigen::Vector3d up_;
  Eigen::Vector3d pivot_ = Eigen::Vector3d::Zero();
  std::vector<GroundTruthObject> truth_;
  ClassPriors priors_;
  BoxDetectionOptions box_options_;
};

TEST_F(RedkitchenAnnotationTest, BoxOnlyDetectionsGiveTheTableAndChairs) {
  const std::vector<MapObject> ours = run(ObjectMapper::Config());
  ObjectMapper::Config paper_config;
  paper_config.usePaperMethod();
  const std::vector<MapObject> paper = run(paper_config);
  // The default without amodal completion: chairs under the table are their backrests.
  ObjectMapper::Config seen_config;
  seen_config.database.amodal.enable = false;
  const std::vector<MapObject> seen = run(seen_config);

  for (size_t i = 0; i < truth_.size(); ++i) {
    const GroundTruthObject& truth = truth_[i];
    const MapObject* a = match(ours, truth);
    const MapObject* b = match(paper, truth);
    const MapObject* c = match(seen, truth);
    const BoxComparison ca = a ? compare(a->box, truth.box, up_) : BoxComparison{9, 9, 9};
    const BoxComparison cb = b ? compare(b->box, truth.box, up_) : BoxComparison{9, 9, 9};
    const BoxComparison cc = c ? compare(c->box, truth.box, up_) : BoxComparison{9, 9, 9};
    std::printf(
        "[ redkitchen ] %-12s %zu: default centre %.3f edge %.3f top %.3f (obs %d%s) | paper "
        "centre "
        "%.2f edge %.2f top %.2f | no completion centre %.3f edge %.3f top %.3f\n",
        truth.class_name.c_str(), i, ca.centre_m, ca.edge_m, ca.top_m, a ? a->observations : 0,
        a && a->box_completed ? ", completed" : "", cb.centre_m, cb.edge_m, cb.top_m, cc.centre_m,
        cc.edge_m, cc.top_m);
    ASSERT_NE(a, nullptr) << truth.class_name << " " << i << " not in the map";
    // Issue 10's goals: the table within 10 cm in centre, 15 cm on each footprint edge, 5 cm in
    // top height; each chair within 15 cm in centre.
    if (truth.class_name == "dining table") {
      EXPECT_LT(ca.centre_m, 0.10);
      EXPECT_LT(ca.edge_m, 0.15);
      EXPECT_LT(ca.top_m, 0.05);
    } else {
      EXPECT_LT(ca.centre_m, 0.15) << "chair " << i;
    }
    // Chairs C and D (3, 4) are pushed under the table with only their backrests in view: without
    // amodal completion their boxes are the backrests', ~0.2 m behind the chairs' centres; with
    // it, the seat's side (hidden by the table top) is completed.
    if (i == 3 || i == 4) {
      EXPECT_TRUE(a->box_completed) << "chair " << i;
      EXPECT_GT(cc.centre_m, 0.15) << "chair " << i;
    }
  }
}

// The two mugs from box-only detections, beside the table's and the chairs' as a box detector
// reports them: each box takes in the table top around its mug, which is the mug's support, not the
// mug (issue 54). On this input the mugs' boxes reach IoU 0.56 and 0.49; without the cut from the
// support 0.16 and 0.47 (the white mug's box a strip of table top).
TEST_F(RedkitchenAnnotationTest, BoxOnlyDetectionsOfTheMugsAreTheMugs) {
  std::vector<GroundTruthObject> annotated;
  ASSERT_TRUE(
      loadSyntheticGroundTruth(std::string(MVOD_SOURCE_DIR) +
                                   "/test/data/7scenes_redkitchen_annotation/ground_truth.json",
                               0.05, up_, &annotated)
          .ok());
  ASSERT_GE(annotated.size(), 8u);
  for (size_t i = 6; i < 8; ++i) {
    ASSERT_EQ(annotated[i].class_name, "cup") << i;
    truth_.push_back(annotated[i]);
  }
  const std::vector<MapObject> ours = run(ObjectMapper::Config());
  for (size_t i = 6; i < 8; ++i) {
    double best_iou = 0.0;
    for (const MapObject& object : ours) {
      if (object.class_name != "cup") continue;
      best_iou = std::max(best_iou, orientedBoxIoU(object.box, truth_[i].box, up_));
    }
    std::printf("[ redkitchen ] mug %zu: box IoU %.2f\n", i, best_iou);
    EXPECT_GT(best_iou, 0.4) << "mug " << i;
  }
}

// The same with drifting poses, as a visual SLAM gives them (0.3 m and 4 degrees over the 1000
// frames), corrected as at a loop closure at frame 500 (the keyframes so far take their true
// poses; the later ones drift on) and after the last frame (all of them): the map then meets the
// same goals as without drift. Before the last correction the second half's drift shows.
TEST_F(RedkitchenAnnotationTest, DriftCorrectedAtFrame500AndAtTheEnd) {
  std::vector<MapObject> before_last;
  int moved_at_500 = 0;
  int moved_at_end = 0;
  double correction_ms = 0.0;
  const auto correct = [&](int index, const std::vector<RgbdFrame>& keyframes,
                           ObjectMapper* mapper) {
    if (index != 500 && index != 1000) return;
    if (index == 1000) {
      for (const auto& entry : mapper->database().objects()) before_last.push_back(entry.second);
    }
    std::vector<PoseCorrection> corrections;
    for (const RgbdFrame& keyframe : keyframes) {
      corrections.push_back({keyframe.stamp_s, keyframe.T_W_D * keyframe.T_C_D.inverse()});
    }
    ObjectMapper::CorrectionReport report;
    ASSERT_TRUE(mapper->correctPoses(corrections, &report).ok());
    (index == 500 ? moved_at_500 : moved_at_end) = report.keyframes_moved;
    correction_ms = report.time_ms;
  };
  const std::vector<MapObject> corrected = run(ObjectMapper::Config(), true, correct);
  EXPECT_EQ(moved_at_500, 49);  // keyframes 10 ... 490 (frame 0 does not drift)
  EXPECT_EQ(moved_at_end, 50);  // keyframes 500 ... 990
  double worst_before = 0.0;
  for (size_t i = 0; i < truth_.size(); ++i) {
    const GroundTruthObject& truth = truth_[i];
    const MapObject* a = match(corrected, truth);
    const MapObject* b = match(before_last, truth);
    const BoxComparison ca = a ? compare(a->box, truth.box, up_) : BoxComparison{9, 9, 9};
    const BoxComparison cb = b ? compare(b->box, truth.box, up_) : BoxComparison{9, 9, 9};
    worst_before = std::max({worst_before, cb.centre_m, cb.top_m});
    std::printf(
        "[ redkitchen drift ] %-12s %zu: corrected centre %.3f edge %.3f top %.3f | "
        "before the last correction centre %.3f edge %.3f top %.3f\n",
        truth.class_name.c_str(), i, ca.centre_m, ca.edge_m, ca.top_m, cb.centre_m, cb.edge_m,
        cb.top_m);
    ASSERT_NE(a, nullptr) << truth.class_name << " " << i << " not in the map";
    if (truth.class_name == "dining table") {
      EXPECT_LT(ca.centre_m, 0.10);
      EXPECT_LT(ca.edge_m, 0.15);
      EXPECT_LT(ca.top_m, 0.05);
    } else {
      EXPECT_LT(ca.centre_m, 0.15) << "chair " << i;
    }
  }
  std::printf("[ redkitchen drift ] the last correction: %d keyframes in %.1f ms\n", moved_at_end,
              correction_ms);
  // What the corrections repaired.
  EXPECT_GT(worst_before, 0.10);
}

}  // namespace
}  // namespace mvod
