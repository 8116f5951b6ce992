// AmodalCompletion: a chair pushed under a table, seen only by its backrest above the table top,
// completed to its depth on the side the views never saw through. Depth views ray-cast from a few
// axis-aligned parts on a floor (part_scene.h).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "multiview_object_detection/io/json_io.h"
#include "multiview_object_detection/pipeline/map/amodal_completion.h"
#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/object_mapper.h"
#include "multiview_object_detection/pipeline/utils/voxel_key.h"
#include "part_scene.h"

namespace mvod {
namespace {

constexpr double kNoFloor = std::numeric_limits<double>::quiet_NaN();

// One view of the scene as the database gets it: metric depth and the camera.
DepthView render(const test::PartScene& scene, const Eigen::Vector3d& eye,
                 const Eigen::Vector3d& target) {
  cv::Rect unused;
  const RgbdFrame frame = scene.render(test::lookAt(eye, target), "", &unused);
  DepthView view;
  frame.depth.convertTo(view.depth_m, CV_32FC1, 0.001);
  view.K = frame.K_depth;
  view.T_D_W = frame.T_W_D.inverse();
  return view;
}

// s = +1: the table at y < 0.45, a chair pushed under it from +y (seat towards -y). s = -1: the
// same mirrored in y.
struct ChairScene {
  test::PartScene parts;
  OrientedBox backrest_seen;  // what the views show of the chair: its backrest above the table
  OrientedBox chair;          // the whole chair
};

void add(const std::string& object, Eigen::Vector3d lo, Eigen::Vector3d hi, double s,
         test::PartScene* scene) {
  if (s < 0.0) {
    std::swap(lo.y(), hi.y());
    lo.y() = -lo.y();
    hi.y() = -hi.y();
  }
  scene->parts.push_back(test::Part{object, lo, hi});
}

ChairScene chairUnderTable(double s, bool with_table = true) {
  ChairScene scene;
  if (with_table) add("table", {-0.8, -0.45, 0.70}, {0.8, 0.45, 0.74}, s, &scene.parts);
  add("chair", {-0.23, 0.15, 0.42}, {0.23, 0.60, 0.47}, s, &scene.parts);  // seat
  add("chair", {-0.23, 0.55, 0.47}, {0.23, 0.60, 0.88}, s, &scene.parts);  // backrest
  for (const double x : {-0.23, 0.20}) {
    for (const double y : {0.15, 0.57}) {
      add("chair", {x, y, 0.0}, {x + 0.03, y + 0.03, 0.42}, s, &scene.parts);  // legs
    }
  }
  scene.backrest_seen.center_m = Eigen::Vector3d(0.0, s * 0.575, 0.80);
  scene.backrest_seen.size_m = Eigen::Vector3d(0.46, 0.05, 0.16);
  scene.chair.center_m = Eigen::Vector3d(0.0, s * 0.375, 0.44);
  scene.chair.size_m = Eigen::Vector3d(0.46, 0.45, 0.88);
  return scene;
}

// Three views from across the table (its top hides the seat), two from beyond the table's ends,
// which see the floor behind the backrest.
std::vector<DepthView> views(const test::PartScene& scene, double s) {
  std::vector<DepthView> out;
  for (const double x : {-0.6, 0.0, 0.6}) {
    out.push_back(render(scene, {x, -s * 1.2, 1.5}, {0.0, s * 0.5, 0.5}));
  }
  for (const double x : {-1.6, 1.6}) {
    out.push_back(render(scene, {x, s * 0.2, 1.4}, {0.0, s * 0.8, 0.3}));
  }
  return out;
}

AmodalCompletion::Config testConfig() { return AmodalCompletion::Config(); }

TEST(DepthViewTest, VisibilitySaysWhetherTheViewSawThroughAPoint) {
  DepthView view;
  view.K = CameraIntrinsics{500.0, 500.0, 49.5, 49.5, 100, 100};
  view.depth_m = cv::Mat(100, 100, CV_32FC1, cv::Scalar(2.0f));
  view.depth_m.at<float>(50, 50) = 0.f;  // no depth at the pixel of (0, 0, z)
  view.truncation_m = 0.02;
  view.truncation_per_m2 = 0.0;
  using V = DepthView::Visibility;
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.05f, 0.f, 1.0f), 0.05), V::kSeenFree);
  // Within the margin plus the truncation in front of the surface: not seen through.
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 1.94f), 0.05), V::kOnSurface);
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 1.92f), 0.05), V::kSeenFree);
  // On the surface within the truncation either side; beyond it behind the surface: hidden.
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 2.01f), 0.05), V::kOnSurface);
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 2.03f), 0.05), V::kHidden);
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 2.5f), 0.05), V::kHidden);
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.f, 0.f, 1.f), 0.05), V::kNotInView);    // no depth
  EXPECT_EQ(view.visibility(Eigen::Vector3f(1.f, 0.f, 1.f), 0.05), V::kNotInView);    // outside
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, -1.f), 0.05), V::kNotInView);  // behind
  view.depth_m.at<float>(50, 60) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(view.visibility(Eigen::Vector3f(0.1f, 0.f, 5.f), 0.05), V::kNotInView);  // NaN
}

// makeDepthView computes the 3 x 3 ranges on its own cleaned depth (no copy of it): the same
// images as prepareNeighbourhoods on that depth, for 16-bit depth (0, 65535, beyond the range) and
// for float depth with NaN, infinities, negatives and values outside [min, max].
TEST(DepthViewTest, MakeDepthViewPreparesTheNeighbourhoodsOfPrepareNeighbourhoods) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> millimetres(0, 12000);
  cv::Mat depth_mm(48, 64, CV_16UC1);
  cv::Mat depth_m(48, 64, CV_32FC1);
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            -1.f,
                            0.f,
                            0.05f,
                            11.f};
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) {
      const int mm = (u * 7 + v * 3) % 29 == 0 ? 65535 : millimetres(rng);
      depth_mm.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(mm);
      depth_m.at<float>(v, u) = (u * 5 + v * 11) % 13 == 0 ? specials[(u + v) % 7] : mm * 0.001f;
    }
  }
  const CameraIntrinsics K{50.0, 50.0, 31.5, 23.5, 64, 48};
  for (const cv::Mat& depth : {depth_mm, depth_m}) {
    const std::shared_ptr<DepthView> view =
        makeDepthView(depth, K, Eigen::Isometry3d::Identity(), 0.1, 10.0, 0.02, 8.55e-3);
    DepthView reference = *view;
    reference.depth_m = view->depth_m.clone();
    reference.prepareNeighbourhoods();
    ASSERT_EQ(view->lowest_3x3_m.size(), depth.size());
    ASSERT_EQ(view->highest_3x3_m.size(), depth.size());
    EXPECT_EQ(cv::countNonZero(view->lowest_3x3_m != reference.lowest_3x3_m), 0);
    EXPECT_EQ(cv::countNonZero(view->highest_3x3_m != reference.highest_3x3_m), 0);
    // Every depth it keeps is valid and within the range; the rest are 0.
    int kept = 0;
    for (int v = 0; v < 48; ++v) {
      for (int u = 0; u < 64; ++u) {
        const float z = view->depth_m.at<float>(v, u);
        EXPECT_TRUE(z == 0.f || (z >= 0.1f && z <= 10.f)) << u << "," << v << ": " << z;
        kept += z > 0.f ? 1 : 0;
      }
    }
    EXPECT_GT(kept, 48 * 64 / 2);
  }
}

// The 3 x 3 depth ranges computed once per view (prepareNeighbourhoods) give the signed distances
// of the nine-pixel test, bit for bit: at depth edges, beside invalid and NaN pixels, at the image
// border, and after depth_m changes size (the stale ranges are then ignored).
TEST(DepthViewTest, PreparedNeighbourhoodsGiveTheSameSignedDistances) {
  DepthView plain;
  plain.K = CameraIntrinsics{60.0, 60.0, 39.5, 29.5, 80, 60};
  plain.depth_m = cv::Mat(60, 80, CV_32FC1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> depth(1.0f, 1.02f);
  for (int v = 0; v < 60; ++v) {
    for (int u = 0; u < 80; ++u) {
      // Steps of 0.5 m at u = 40 and of 0.3 m at v = 30 (silhouettes across and along the rows),
      // noise, bumps of about the truncation, a few holes and NaNs.
      float d = depth(rng) + (u >= 40 ? 0.5f : 0.0f) + (v >= 30 ? 0.3f : 0.0f);
      if ((u * 5 + v * 17) % 43 == 0) d += 0.07f;
      if ((u * 7 + v * 13) % 61 == 0) d = 0.f;
      if ((u * 11 + v * 3) % 97 == 0) d = std::numeric_limits<float>::quiet_NaN();
      plain.depth_m.at<float>(v, u) = d;
    }
  }
  plain.truncation_m = 0.05;
  plain.truncation_per_m2 = 0.01;
  DepthView prepared = plain;
  prepared.depth_m = plain.depth_m.clone();
  prepared.prepareNeighbourhoods();
  ASSERT_EQ(prepared.lowest_3x3_m.size(), prepared.depth_m.size());
  const auto compare = [](const DepthView& a, const DepthView& b) {
    std::uniform_real_distribution<float> uv(-0.05f, 1.05f);
    std::uniform_real_distribution<float> z(0.8f, 1.8f);
    std::mt19937 points_rng(9);
    int answered = 0, abstained = 0;
    for (int i = 0; i < 20000; ++i) {
      const float zi = z(points_rng);
      const Eigen::Vector3f p((uv(points_rng) * 80.f - 39.5f) * zi / 60.f,
                              (uv(points_rng) * 60.f - 29.5f) * zi / 60.f, zi);
      float sdf_a = -7.f, sdf_b = -7.f;
      const bool ok_a = a.signedDistance(p, &sdf_a);
      const bool ok_b = b.signedDistance(p, &sdf_b);
      EXPECT_EQ(ok_a, ok_b) << "point " << i;
      EXPECT_EQ(sdf_a, sdf_b) << "point " << i;
      ++(ok_a ? answered : abstained);
    }
    // Both outcomes occur often: the comparison covers the edges, holes and the border.
    EXPECT_GT(answered, 2000);
    EXPECT_GT(abstained, 2000);
  };
  compare(plain, prepared);
  // depth_m replaced by one of another size: the stale ranges must not be read.
  prepared.depth_m = cv::Mat(30, 40, CV_32FC1, cv::Scalar(1.2f));
  plain.depth_m = prepared.depth_m.clone();
  std::uniform_real_distribution<float> z(0.8f, 1.8f);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3f p(0.01f * (i % 20) - 0.1f, 0.005f * (i % 10), z(rng));
    float sdf_a = -7.f, sdf_b = -7.f;
    EXPECT_EQ(plain.signedDistance(p, &sdf_a), prepared.signedDistance(p, &sdf_b));
    EXPECT_EQ(sdf_a, sdf_b);
  }
}

TEST(AmodalCompletionTest, ThinAxisOnlyForThinBoxesWhenEnabled) {
  AmodalCompletion completion(testConfig());
  OrientedBox box;
  box.size_m = Eigen::Vector3d(0.46, 0.05, 0.3);
  EXPECT_EQ(completion.thinAxis(box, 0.55), 1);
  box.size_m = Eigen::Vector3d(0.05, 0.46, 0.3);
  EXPECT_EQ(completion.thinAxis(box, 0.55), 0);
  box.size_m = Eigen::Vector3d(0.46, 0.40, 0.3);  // a chair seen whole
  EXPECT_EQ(completion.thinAxis(box, 0.55), -1);
  box.size_m = Eigen::Vector3d(0.46, 0.05, 0.3);
  EXPECT_EQ(completion.thinAxis(box, 0.0), -1);  // the class has no depth
  AmodalCompletion::Config off = testConfig();
  off.enable = false;
  EXPECT_EQ(AmodalCompletion(off).thinAxis(box, 0.55), -1);
  box.size_m = Eigen::Vector3d(0.46, std::numeric_limits<double>::quiet_NaN(), 0.3);
  EXPECT_EQ(completion.thinAxis(box, 0.55), -1);
}

TEST(AmodalCompletionTest, ConfigValidation) {
  EXPECT_TRUE(testConfig().isValid().ok());
  AmodalCompletion::Config c = testConfig();
  c.cell_size_m = 0.0;
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.max_thin_ratio = 1.5;
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.min_free_ratio = 0.5;
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.max_free_share = -0.1;
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.min_in_view = 0;
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.free_margin_m = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(c.isValid().ok());
  c = testConfig();
  c.min_observations = 0;
  EXPECT_FALSE(c.isValid().ok());
}

// The chair under the table, from both sides of the scene: completed towards the table, to the
// chair's box.
TEST(AmodalCompletionTest, ChairUnderATableIsCompletedTowardsTheTable) {
  for (const double s : {1.0, -1.0}) {
    SCOPED_TRACE(s > 0 ? "table at -y" : "table at +y");
    const ChairScene scene = chairUnderTable(s);
    const AmodalCompletion completion(testConfig());
    FreeSpaceMap free_space;
    for (const DepthView& view : views(scene.parts, s)) {
      completion.countFreeSpace(view, scene.backrest_seen, 0.45, 0.0, &free_space);
    }
    const AmodalCompletion::Decision decision =
        completion.decide(scene.backrest_seen, 0.45, 0.0, free_space);
    std::printf("[ amodal ] in view %d / %d, seen free %d / %d\n", decision.in_view[0],
                decision.in_view[1], decision.seen_free[0], decision.seen_free[1]);
    ASSERT_EQ(decision.axis, 1);
    // Towards the table: -y for s = +1.
    EXPECT_EQ(decision.side, s > 0 ? -1 : 1);
    const OrientedBox box = AmodalCompletion::complete(scene.backrest_seen, decision, 0.45, 0.0);
    EXPECT_NEAR(box.center_m.y(), scene.chair.center_m.y(), 0.01);
    EXPECT_NEAR(box.center_m.z(), scene.chair.center_m.z(), 0.01);
    EXPECT_NEAR(box.size_m.y(), scene.chair.size_m.y(), 0.01);
    EXPECT_NEAR(box.size_m.z(), scene.chair.size_m.z(), 0.01);
    EXPECT_NEAR(box.size_m.x(), scene.backrest_seen.size_m.x(), 1e-9);
    // Without the floor: the same footprint, the height as seen.
    const OrientedBox floating =
        AmodalCompletion::complete(scene.backrest_seen, decision, 0.45, kNoFloor);
    EXPECT_NEAR(floating.center_m.y(), scene.chair.center_m.y(), 0.01);
    EXPECT_NEAR(floating.size_m.z(), scene.backrest_seen.size_m.z(), 1e-9);
  }
}

// Nothing hides the chair's lower part (no table): the views see through both sides below the
// backrest, so no side is hidden and the box stays what was seen.
TEST(AmodalCompletionTest, NothingHiddenNothingCompleted) {
  const ChairScene scene = chairUnderTable(1.0);
  const OrientedBox panel = scene.backrest_seen;
  test::PartScene alone;  // a backrest-sized panel on two posts, nothing else
  add("panel", {-0.23, 0.55, 0.47}, {0.23, 0.60, 0.88}, 1.0, &alone);
  add("panel", {-0.23, 0.55, 0.0}, {-0.20, 0.58, 0.47}, 1.0, &alone);
  add("panel", {0.20, 0.55, 0.0}, {0.23, 0.58, 0.47}, 1.0, &alone);
  const AmodalCompletion completion(testConfig());
  FreeSpaceMap free_space;
  for (const DepthView& view : views(alone, 1.0)) {
    completion.countFreeSpace(view, panel, 0.45, 0.0, &free_space);
  }
  const AmodalCompletion::Decision decision = completion.decide(panel, 0.45, 0.0, free_space);
  EXPECT_EQ(decision.axis, 1);
  EXPECT_GT(decision.freeShare(0), testConfig().max_free_share);
  EXPECT_GT(decision.freeShare(1), testConfig().max_free_share);
  EXPECT_EQ(decision.side, 0);
  const OrientedBox box = AmodalCompletion::complete(panel, decision, 0.45, 0.0);
  EXPECT_TRUE(box.center_m.isApprox(panel.center_m));
  EXPECT_TRUE(box.size_m.isApprox(panel.size_m));
}

// Too little seen (no views; or only views from one side, which see nothing beyond the backrest
// either): no completion.
TEST(AmodalCompletionTest, UndecidedWithoutEvidenceOnBothSides) {
  const ChairScene scene = chairUnderTable(1.0);
  const AmodalCompletion completion(testConfig());
  FreeSpaceMap free_space;
  EXPECT_EQ(completion.decide(scene.backrest_seen, 0.45, 0.0, free_space).side, 0);
  // Views of an empty room from far away: the cells are never in view.
  const DepthView away = render(test::PartScene(), {0.0, 5.0, 1.2}, {0.0, 9.0, 1.2});
  completion.countFreeSpace(away, scene.backrest_seen, 0.45, 0.0, &free_space);
  const AmodalCompletion::Decision decision =
      completion.decide(scene.backrest_seen, 0.45, 0.0, free_space);
  EXPECT_EQ(decision.in_view[0] + decision.in_view[1], 0);
  EXPECT_EQ(decision.side, 0);
  // A box that is not thin is neither counted nor completed.
  OrientedBox whole = scene.chair;
  FreeSpaceMap untouched;
  for (const DepthView& view : views(scene.parts, 1.0)) {
    completion.countFreeSpace(view, whole, 0.45, 0.0, &untouched);
  }
  EXPECT_TRUE(untouched.empty());
  EXPECT_EQ(completion.decide(whole, 0.45, 0.0, untouched).axis, -1);
}

// The database: a chair class with amodal_depth_m, evidence fusion, each view's cut the backrest.
class AmodalDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ClassPrior chair;
    chair.class_name = "chair";
    chair.has_size = true;
    chair.size_m = Eigen::Vector3d(0.46, 0.45, 0.88);
    chair.fusion_distance_m = 0.3;
    chair.amodal_depth_m = 0.45;
    priors_.set(chair);
  }

  // The backrest's visible face (towards the table, -y) as the cut, with the scene's view.
  static ObjectObservation backrestObservation(const ChairScene& scene, const DepthView& view,
                                               int keyframe) {
    ObjectObservation obs;
    obs.class_name = "chair";
    obs.class_id = 56;
    obs.probability = 0.8;
    obs.keyframe = keyframe;
    for (double x = -0.225; x <= 0.225; x += 0.01) {
      for (double z = 0.725; z <= 0.875; z += 0.01) {
        obs.segment_W.push_back(Eigen::Vector3f(x, 0.555, z));
        obs.segment_W.push_back(Eigen::Vector3f(x, 0.595, z));
      }
    }
    obs.points_W = obs.segment_W;
    obs.box = scene.backrest_seen;
    obs.depth_view = std::make_shared<DepthView>(view);
    return obs;
  }

  // Boxes the supported voxels axis-aligned (their min/max), as a stand-in for the box stage.
  static FusedCloudProcessor boundsProcessor() {
    return [](const std::string&, const PointCloud& points_W, const std::vector<Eigen::Vector3f>&,
              PointCloud* segment_W, OrientedBox* box, double* yaw_rad) {
      if (points_W.empty()) return false;
      Eigen::Vector3f lo = points_W[0];
      Eigen::Vector3f hi = points_W[0];
      for (const auto& p : points_W) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      *segment_W = points_W;
      box->center_m = (0.5 * (lo + hi)).cast<double>();
      box->size_m = (hi - lo).cast<double>() + Eigen::Vector3d::Constant(0.01);
      box->rotation = Eigen::Matrix3d::Identity();
      *yaw_rad = 0.0;
      return true;
    };
  }

  ClassPriors priors_;
};

TEST_F(AmodalDatabaseTest, EvidenceFusionCompletesAndTheMapKeepsTheFreeSpace) {
  const ChairScene scene = chairUnderTable(1.0);
  const std::vector<DepthView> depth_views = views(scene.parts, 1.0);
  ObjectDatabase::Config config;
  config.surface_band_m = 0.0;  // both faces of the backrest are the object (not tested here)
  ObjectDatabase database(config, priors_);
  database.setFloorHeight(0.0);
  const FusedCloudProcessor process = boundsProcessor();
  // Views from both sides first: one keyframe alone (min_observations) is not completed.
  const std::vector<size_t> order = {3, 0, 1, 2, 4};
  for (size_t k = 0; k < order.size(); ++k) {
    database.fuseOrInsert(backrestObservation(scene, depth_views[order[k]], static_cast<int>(k)),
                          process);
    if (k == 0) {
      ASSERT_EQ(database.size(), 1u);
      EXPECT_FALSE(database.objects().begin()->second.box_completed);
    }
  }
  ASSERT_EQ(database.size(), 1u);
  const MapObject& object = database.objects().begin()->second;
  EXPECT_TRUE(object.box_completed);
  EXPECT_FALSE(object.free_space.empty());
  EXPECT_NEAR(object.box.center_m.y(), scene.chair.center_m.y(), 0.03);
  EXPECT_NEAR(object.box.size_m.y(), 0.45, 1e-6);
  EXPECT_NEAR(object.box.center_m.z() - 0.5 * object.box.size_m.z(), 0.0, 1e-6);  // on the floor
  // Eq. 6 matches on what was seen: the backrest's box.
  EXPECT_LT(object.observed_box.size_m.y(), 0.1);
  EXPECT_NEAR(object.seenBox().center_m.y(), scene.backrest_seen.center_m.y(), 0.02);

  // Saved and reloaded: the free space and the completion come back.
  std::vector<MapObject> loaded;
  MapSummary summary;
  ASSERT_TRUE(objectsFromJson(objectsToJson(databaseObjects(database), MapSummary(), true), &loaded,
                              &summary)
                  .ok());
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_TRUE(loaded[0].box_completed);
  EXPECT_TRUE(loaded[0].observed_box.center_m.isApprox(object.observed_box.center_m, 1e-6));
  EXPECT_TRUE(loaded[0].observed_box.size_m.isApprox(object.observed_box.size_m, 1e-6));
  EXPECT_EQ(loaded[0].free_space.size(), object.free_space.size());
  EXPECT_EQ(loaded[0].free_space_cell_m, object.free_space_cell_m);
  for (const auto& cell : object.free_space) {
    const auto it = loaded[0].free_space.find(cell.first);
    ASSERT_NE(it, loaded[0].free_space.end());
    EXPECT_EQ(it->second.in_view, cell.second.in_view);
    EXPECT_EQ(it->second.seen_free, cell.second.seen_free);
  }
  // Without clouds (the readable map) there is no free space, only the flag.
  ASSERT_TRUE(objectsFromJson(objectsToJson(databaseObjects(database), MapSummary(), false),
                              &loaded, &summary)
                  .ok());
  EXPECT_TRUE(loaded[0].box_completed);
  EXPECT_TRUE(loaded[0].free_space.empty());

  // A box not along gravity (estimated without the gravity constraint) is left as it is.
  {
    ObjectDatabase tilted(config, priors_);
    tilted.setFloorHeight(0.0);
    tilted.setGravityUp(Eigen::Vector3d(0.0, 0.6, 0.8));
    for (size_t k = 0; k < order.size(); ++k) {
      tilted.fuseOrInsert(backrestObservation(scene, depth_views[order[k]], static_cast<int>(k)),
                          process);
    }
    ASSERT_EQ(tilted.size(), 1u);
    EXPECT_FALSE(tilted.objects().begin()->second.box_completed);
  }

  // Switched off, or the paper's fusion: the box is the backrest's.
  for (const std::string what : {"off", "paper"}) {
    ObjectDatabase::Config other = config;
    if (what == "off") other.amodal.enable = false;
    if (what == "paper") other.fusion = "paper";
    ObjectDatabase plain(other, priors_);
    plain.setFloorHeight(0.0);
    for (size_t k = 0; k < depth_views.size(); ++k) {
      plain.fuseOrInsert(backrestObservation(scene, depth_views[k], static_cast<int>(k)), process);
    }
    ASSERT_EQ(plain.size(), 1u) << what;
    const MapObject& backrest = plain.objects().begin()->second;
    EXPECT_FALSE(backrest.box_completed) << what;
    EXPECT_LT(backrest.box.size_m.y(), 0.1) << what;
  }
}

// The whole pipeline on the chair under the table: box-only detections of the chair in five
// keyframes (three across the table, two from beyond its ends). Each view's cut is the backrest
// above the table top; the fused box is completed to the chair.
TEST(AmodalMapperTest, ChairUnderATableFromBoxDetections) {
  const ChairScene scene = chairUnderTable(1.0);
  ClassPriors priors;
  ClassPrior chair;
  chair.class_name = "chair";
  chair.has_size = true;
  chair.size_m = Eigen::Vector3d(0.46, 0.45, 0.88);
  chair.fusion_distance_m = 0.3;
  chair.on_floor = true;
  chair.amodal_depth_m = 0.45;
  priors.set(chair);
  const auto run = [&](bool amodal) {
    ObjectMapper::Config config;
    config.gravity_down_W = Eigen::Vector3d(0, 0, -1);
    config.database.amodal.enable = amodal;
    ObjectMapper mapper(config, priors);
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> cameras;
    for (const double x : {-0.6, 0.0, 0.6}) {
      cameras.push_back({{x, -1.2, 1.5}, {0.0, 0.5, 0.5}});
    }
    for (const double x : {-1.6, 1.6}) cameras.push_back({{x, 0.2, 1.4}, {0.0, 0.8, 0.3}});
    for (size_t k = 0; k < cameras.size(); ++k) {
      cv::Rect box;
      RgbdFrame frame =
          scene.parts.render(test::lookAt(cameras[k].first, cameras[k].second), "chair", &box);
      frame.name = "frame-" + std::to_string(k);
      frame.stamp_s = static_cast<double>(k);
      const Detection2D detection = test::boxOnlyDetection("chair", box, frame.depth.size());
      KeyframeReport report;
      EXPECT_TRUE(mapper.processKeyframe(frame, {detection}, &report).ok());
    }
    EXPECT_EQ(mapper.database().size(), 1u);
    return mapper.database().size() == 1u ? mapper.database().objects().begin()->second
                                          : MapObject();
  };
  const MapObject completed = run(true);
  const MapObject seen = run(false);
  const auto horizontal = [&scene](const OrientedBox& box) {
    return (box.center_m - scene.chair.center_m).head<2>().norm();
  };
  std::printf(
      "[ amodal ] mapper: completed centre %.3f m off, size %.2f %.2f %.2f; without %.3f m\n",
      horizontal(completed.box), completed.box.size_m.x(), completed.box.size_m.y(),
      completed.box.size_m.z(), horizontal(seen.box));
  EXPECT_TRUE(completed.box_completed);
  EXPECT_LT(horizontal(completed.box), 0.05);
  EXPECT_NEAR(completed.box.center_m.z() - 0.5 * completed.box.size_m.z(), 0.0, 0.05);
  EXPECT_FALSE(seen.box_completed);
  EXPECT_GT(horizontal(seen.box), 0.15);
}

TEST(AmodalJsonTest, MalformedFreeSpaceIsAnErrorNamingTheField) {
  MapObject chair;
  chair.id = 1;
  chair.class_name = "chair";
  chair.class_id = 56;
  chair.probability = 0.8;
  chair.box.size_m = Eigen::Vector3d(0.4, 0.4, 0.8);
  chair.points_W = {Eigen::Vector3f(0.f, 0.f, 0.f)};
  const nlohmann::json good = nlohmann::json::parse(objectsToJson({chair}, MapSummary(), true));
  const auto parse = [&good](const nlohmann::json& free_space, const nlohmann::json& completed,
                             std::vector<MapObject>* objects) {
    nlohmann::json doc = good;
    doc["objects"][0]["free_space"] = free_space;
    doc["objects"][0]["box_completed"] = completed;
    MapSummary summary;
    return objectsFromJson(doc.dump(), objects, &summary);
  };
  for (const char* bad :
       {R"([1, 2])", R"({"cell_size_m": 0, "cells": []})",
        R"({"cell_size_m": 0.05, "cells": [[0, 0, 0, 1]]})",
        R"({"cell_size_m": 0.05, "cells": [[0, 0, 0, 1, 2]]})",
        R"({"cell_size_m": 0.05, "cells": [[0, 0, 0, 70000, 2]]})",
        R"({"cell_size_m": 0.05, "cells": [[0, 0, 0.5, 1, 0]]})",
        R"({"cell_size_m": 0.05, "cells": [[18446744073709551615, 0, 0, 1, 0]]})"}) {
    std::vector<MapObject> objects;
    const Status status = parse(nlohmann::json::parse(bad), false, &objects);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_NE(status.message().find("objects[0].free_space"), std::string::npos)
        << status.message();
  }
  std::vector<MapObject> objects;
  ASSERT_TRUE(parse(nlohmann::json::parse(R"({"cell_size_m": 0.05, "cells": [[1, -2, 3, 4, 1]]})"),
                    true, &objects)
                  .ok());
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_TRUE(objects[0].box_completed);
  EXPECT_EQ(objects[0].free_space_cell_m, 0.05);
  ASSERT_EQ(objects[0].free_space.size(), 1u);
  EXPECT_EQ(objects[0].free_space.begin()->first, packVoxel(Eigen::Vector3i(1, -2, 3)));
  EXPECT_EQ(objects[0].free_space.begin()->second.in_view, 4);
  EXPECT_EQ(objects[0].free_space.begin()->second.seen_free, 1);
  const Status flag =
      parse(nlohmann::json::parse(R"({"cell_size_m": 0.05, "cells": []})"), 1, &objects);
  EXPECT_FALSE(flag.ok());
  EXPECT_NE(flag.message().find("box_completed"), std::string::npos) << flag.message();
}

}  // namespace
}  // namespace mvod
