// SimulatedInstanceSegmenter on a small synthetic SceneNN-layout sequence written by the fixture:
// perfect mode reproduces the label masks, the failure modes occur at their configured rates over
// many seeds, results are deterministic and independent of frame order, and bad inputs are errors
// (or warnings) naming the file. Also the factory's "simulated" entry.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "multiview_object_detection/simulation/simulated_instance_segmenter.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;
using Config = SimulatedInstanceSegmenter::Config;

constexpr int kWidth = 200;
constexpr int kHeight = 150;

// Label ids of the fixture's XML.
constexpr int kChair = 1;
constexpr int kSofa = 2;  // text "sofa": COCO "couch"
constexpr int kBed = 3;
constexpr int kShelf = 4;    // clutter
constexpr int kWall = 5;     // clutter without false positives
constexpr int kCup = 6;      // under min_pixels
constexpr int kChair2 = 7;   // text "chair2"
constexpr int kSmallTv = 8;  // between min_pixels and small_area_px

// Every probability 0 but the scores left spread (the defaults).
Config zeroRates() {
  Config config = Config::perfect();
  config.min_pixels = 300;
  config.true_score_stddev = 0.1;
  config.confused_score_stddev = 0.15;
  return config;
}

bool sameMask(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != CV_8UC1 || b.type() != CV_8UC1) return false;
  return cv::countNonZero((a != 0) != (b != 0)) == 0;
}

// Pixels of a that are not in b.
int outside(const cv::Mat& a, const cv::Mat& b) { return cv::countNonZero((a != 0) & (b == 0)); }

class SimulatedSegmenterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("mvod_simulated_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    dir_ = root_ / "seq01";
    fs::create_directories(dir_ / "label");
    std::ofstream(dir_ / "seq01.xml")
        << "<annotation>\n"
        << label(kChair, "chair", "chair") << label(kSofa, "sofa", "sofa")
        << label(kBed, "bed", "bed") << label(kShelf, "shelf", "shelves")
        << label(kWall, "wall", "wall") << label(kCup, "cup", "")
        << label(kChair2, "chair2", "chair") << label(kSmallTv, "tv", "television")
        << "</annotation>\n";
    image_ = cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(40, 50, 60));

    // Frame 1: every label as a rectangle, the wall behind the chairs.
    cv::Mat frame1 = cv::Mat::zeros(kHeight, kWidth, CV_16UC1);
    frame1(cv::Rect(0, 0, kWidth, 8)).setTo(kWall);
    frame1(cv::Rect(20, 15, 40, 50)).setTo(kChair);     // 2000 px
    frame1(cv::Rect(70, 15, 50, 40)).setTo(kSofa);      // 2000 px
    frame1(cv::Rect(130, 15, 60, 40)).setTo(kBed);      // 2400 px
    frame1(cv::Rect(20, 85, 40, 50)).setTo(kShelf);     // 2000 px
    frame1(cv::Rect(70, 90, 10, 10)).setTo(kCup);       // 100 px
    frame1(cv::Rect(130, 85, 40, 45)).setTo(kChair2);   // 1800 px
    frame1(cv::Rect(90, 110, 20, 20)).setTo(kSmallTv);  // 400 px
    writeLabels(1, frame1);
    // Frame 2: fewer objects, elsewhere; an ellipse for a non-rectangular mask.
    cv::Mat frame2 = cv::Mat::zeros(kHeight, kWidth, CV_16UC1);
    cv::ellipse(frame2, cv::Point(60, 70), cv::Size(35, 45), 20, 0, 360, cv::Scalar(kChair),
                cv::FILLED);
    frame2(cv::Rect(120, 40, 60, 70)).setTo(kBed);
    writeLabels(2, frame2);
  }
  void TearDown() override { fs::remove_all(root_); }

  static std::string label(int id, const std::string& text, const std::string& nyu) {
    std::string line = "  <label id=\"" + std::to_string(id) + "\" text=\"" + text + "\"";
    if (!nyu.empty()) line += " nyu_class=\"" + nyu + "\"";
    return line + " aabbox=\"0 0 0 1 1 1\"/>\n";
  }
  void writeLabels(int frame, const cv::Mat& labels) {
    char name[32];
    std::snprintf(name, sizeof(name), "label%05d.png", frame);
    ASSERT_TRUE(cv::imwrite((dir_ / "label" / name).string(), labels));
  }
  cv::Mat readLabels(int frame) {
    char name[32];
    std::snprintf(name, sizeof(name), "label%05d.png", frame);
    return cv::imread((dir_ / "label" / name).string(), cv::IMREAD_UNCHANGED);
  }
  // Cached: the statistical tests ask for the same masks thousands of times.
  cv::Mat groundTruth(int frame, int id) {
    cv::Mat& mask = ground_truth_[{frame, id}];
    if (mask.empty()) mask = readLabels(frame) == id;
    return mask;
  }

  std::unique_ptr<SimulatedInstanceSegmenter> make(const Config& config) {
    std::unique_ptr<SimulatedInstanceSegmenter> segmenter;
    const Status status = SimulatedInstanceSegmenter::create(dir_.string(), config, &segmenter);
    EXPECT_TRUE(status.ok()) << status.message();
    return segmenter;
  }
  std::vector<Detection2D> detect(SimulatedInstanceSegmenter* segmenter, int frame,
                                  std::vector<std::string>* warnings = nullptr) {
    char name[32];
    std::snprintf(name, sizeof(name), "image%05d", frame);
    std::vector<Detection2D> detections;
    const Status status = segmenter->detect(image_, name, &detections, warnings);
    EXPECT_TRUE(status.ok()) << status.message();
    return detections;
  }

  // Runs `trials` seeds over frame 1 and calls visit(detections) for each.
  template <typename Visit>
  void overSeeds(Config config, int trials, Visit visit) {
    for (int seed = 0; seed < trials; ++seed) {
      config.seed = static_cast<uint64_t>(seed) * 7919 + 11;
      std::unique_ptr<SimulatedInstanceSegmenter> segmenter = make(config);
      ASSERT_TRUE(segmenter);
      visit(detect(segmenter.get(), 1));
    }
  }

  // The detection whose mask covers most of ground-truth label `id` in frame 1, or nullptr.
  const Detection2D* mainDetectionOf(const std::vector<Detection2D>& detections, int id) {
    const cv::Mat gt = groundTruth(1, id);
    const Detection2D* best = nullptr;
    int best_overlap = 0;
    for (const Detection2D& d : detections) {
      const int overlap = cv::countNonZero(d.mask & gt);
      if (overlap > best_overlap) {
        best_overlap = overlap;
        best = &d;
      }
    }
    return best;
  }

  fs::path root_;
  fs::path dir_;
  cv::Mat image_;
  std::map<std::pair<int, int>, cv::Mat> ground_truth_;
};

TEST_F(SimulatedSegmenterTest, PerfectModeReproducesLabelMasks) {
  for (const Config& config : {Config::perfect(), zeroRates()}) {
    std::unique_ptr<SimulatedInstanceSegmenter> segmenter = make(config);
    ASSERT_TRUE(segmenter);
    EXPECT_EQ(segmenter->name(), "simulated");
    EXPECT_EQ(segmenter->labelClasses().at(kSofa), "couch");
    EXPECT_EQ(segmenter->labelClasses().at(kChair2), "chair");
    EXPECT_EQ(segmenter->labelClasses().at(kShelf), "");

    const std::vector<Detection2D> frame1 = detect(segmenter.get(), 1);
    // Chair, couch, bed, chair2, tv (the cup is under min_pixels only in zeroRates()).
    const bool with_cup = config.min_pixels <= 100;
    const std::vector<std::pair<int, std::string>> expected = [&] {
      std::vector<std::pair<int, std::string>> e = {
          {kChair, "chair"}, {kSofa, "couch"}, {kBed, "bed"}};
      if (with_cup) e.push_back({kCup, "cup"});
      e.push_back({kChair2, "chair"});
      e.push_back({kSmallTv, "tv"});
      return e;
    }();
    ASSERT_EQ(frame1.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      const Detection2D& d = frame1[i];
      EXPECT_EQ(d.class_name, expected[i].second);
      EXPECT_EQ(d.class_id, cocoClassId(expected[i].second));
      const cv::Mat gt = groundTruth(1, expected[i].first);
      EXPECT_TRUE(sameMask(d.mask, gt)) << d.class_name;
      EXPECT_EQ(d.box_px, cv::boundingRect(gt));
      EXPECT_EQ(d.mask.size(), image_.size());
      EXPECT_GE(d.score, 0.05f);
      EXPECT_LE(d.score, 0.99f);
      if (config.true_score_stddev == 0.0) {
        EXPECT_FLOAT_EQ(d.score, 0.85f);
      }
    }

    const std::vector<Detection2D> frame2 = detect(segmenter.get(), 2);
    ASSERT_EQ(frame2.size(), 2u);
    EXPECT_TRUE(sameMask(frame2[0].mask, groundTruth(2, kChair)));
    EXPECT_TRUE(sameMask(frame2[1].mask, groundTruth(2, kBed)));
  }
}

TEST_F(SimulatedSegmenterTest, DeterministicAndIndependentOfFrameOrder) {
  const Config config;  // every failure mode on
  std::unique_ptr<SimulatedInstanceSegmenter> a = make(config);
  std::unique_ptr<SimulatedInstanceSegmenter> b = make(config);
  ASSERT_TRUE(a && b);
  const std::vector<Detection2D> a1 = detect(a.get(), 1);
  const std::vector<Detection2D> a2 = detect(a.get(), 2);
  const std::vector<Detection2D> b2 = detect(b.get(), 2);  // other order
  const std::vector<Detection2D> b1 = detect(b.get(), 1);
  const std::vector<Detection2D> a1_again = detect(a.get(), 1);
  const auto same = [](const std::vector<Detection2D>& x, const std::vector<Detection2D>& y) {
    if (x.size() != y.size()) return false;
    for (size_t i = 0; i < x.size(); ++i) {
      if (x[i].class_name != y[i].class_name || x[i].score != y[i].score ||
          x[i].box_px != y[i].box_px || !sameMask(x[i].mask, y[i].mask)) {
        return false;
      }
    }
    return true;
  };
  EXPECT_TRUE(same(a1, b1));
  EXPECT_TRUE(same(a2, b2));
  EXPECT_TRUE(same(a1, a1_again));

  // Another seed gives other detections (scores at least).
  Config other = config;
  other.seed = 2;
  std::unique_ptr<SimulatedInstanceSegmenter> c = make(other);
  ASSERT_TRUE(c);
  EXPECT_FALSE(same(a1, detect(c.get(), 1)));
}

TEST_F(SimulatedSegmenterTest, MissRateMatchesConfigAndSmallInstancesAreMissedMore) {
  Config config = zeroRates();
  config.miss_probability = 0.1;
  config.small_miss_probability = 0.8;  // tv: 400 px, between min_pixels 300 and 1500
  int large_seen = 0;
  int large_total = 0;
  int tv_seen = 0;
  int trials = 0;
  overSeeds(config, 400, [&](const std::vector<Detection2D>& detections) {
    ++trials;
    for (const int id : {kChair, kSofa, kBed, kChair2}) {
      ++large_total;
      if (mainDetectionOf(detections, id) != nullptr) ++large_seen;
    }
    if (mainDetectionOf(detections, kSmallTv) != nullptr) ++tv_seen;
    for (const Detection2D& d : detections) {
      EXPECT_NE(d.class_name, "cup");  // 100 px < min_pixels: always missed
    }
  });
  const double large_miss = 1.0 - static_cast<double>(large_seen) / large_total;
  EXPECT_NEAR(large_miss, 0.1, 0.03);
  // 400 px: 0.1 + (0.8 - 0.1) * (1500 - 400) / (1500 - 300) = 0.74.
  const double tv_miss = 1.0 - static_cast<double>(tv_seen) / trials;
  EXPECT_NEAR(tv_miss, 0.74, 0.07);
}

TEST_F(SimulatedSegmenterTest, ConfusionRatesAndLowerScores) {
  Config config = zeroRates();
  config.confusions = {{"chair", "couch", 0.1}, {"couch", "chair", 0.2}, {"bed", "couch", 0.05}};
  int chairs = 0, chairs_as_couch = 0, couches_as_chair = 0, beds_as_couch = 0, trials = 0;
  double true_sum = 0.0, confused_sum = 0.0;
  int true_n = 0, confused_n = 0;
  overSeeds(config, 300, [&](const std::vector<Detection2D>& detections) {
    ++trials;
    for (const int id : {kChair, kChair2}) {
      const Detection2D* d = mainDetectionOf(detections, id);
      ASSERT_NE(d, nullptr);
      ++chairs;
      const bool confused = d->class_name == "couch";
      if (confused) ++chairs_as_couch;
      EXPECT_TRUE(confused || d->class_name == "chair");
      EXPECT_EQ(d->class_id, cocoClassId(d->class_name));
      (confused ? confused_sum : true_sum) += d->score;
      ++(confused ? confused_n : true_n);
    }
    if (mainDetectionOf(detections, kSofa)->class_name == "chair") ++couches_as_chair;
    if (mainDetectionOf(detections, kBed)->class_name == "couch") ++beds_as_couch;
    // The masks stay exact: confusion changes the class only.
    EXPECT_TRUE(sameMask(mainDetectionOf(detections, kChair)->mask, groundTruth(1, kChair)));
  });
  EXPECT_NEAR(static_cast<double>(chairs_as_couch) / chairs, 0.1, 0.03);
  EXPECT_NEAR(static_cast<double>(couches_as_chair) / trials, 0.2, 0.06);
  EXPECT_NEAR(static_cast<double>(beds_as_couch) / trials, 0.05, 0.03);
  ASSERT_GT(confused_n, 10);
  EXPECT_NEAR(true_sum / true_n, 0.85, 0.02);
  EXPECT_NEAR(confused_sum / confused_n, 0.6, 0.06);
}

TEST_F(SimulatedSegmenterTest, BleedGrowsMasksIntoTheBackground) {
  Config config = zeroRates();
  config.bleed_probability = 0.5;
  config.max_bleed_px = 15;
  int bled = 0;
  int total = 0;
  overSeeds(config, 300, [&](const std::vector<Detection2D>& detections) {
    const cv::Mat gt = groundTruth(1, kChair);
    const Detection2D* d = mainDetectionOf(detections, kChair);
    ASSERT_NE(d, nullptr);
    ++total;
    EXPECT_EQ(outside(gt, d->mask), 0);  // dilation keeps every object pixel
    const int extra = outside(d->mask, gt);
    if (extra > 0) {
      ++bled;
      // At least 2 px on every side of the 40 x 50 rectangle, at most 15.
      EXPECT_GE(d->box_px.width, 40 + 2 * 2);
      EXPECT_LE(d->box_px.width, 40 + 2 * 15);
      EXPECT_GE(d->box_px.height, 50 + 2 * 2);
      EXPECT_LE(d->box_px.height, 50 + 2 * 15);
      EXPECT_EQ(d->box_px, cv::boundingRect(d->mask));
    }
  });
  EXPECT_NEAR(static_cast<double>(bled) / total, 0.5, 0.08);
}

TEST_F(SimulatedSegmenterTest, JitterMovesOnlyTheBoundary) {
  Config config = zeroRates();
  config.jitter_probability = 1.0;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  int changed = 0;
  overSeeds(config, 40, [&](const std::vector<Detection2D>& detections) {
    const cv::Mat gt = groundTruth(1, kChair);
    cv::Mat grown, shrunk;
    cv::dilate(gt, grown, kernel);
    cv::erode(gt, shrunk, kernel);
    const Detection2D* d = mainDetectionOf(detections, kChair);
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(outside(d->mask, grown), 0);   // at most jitter_px (1) out
    EXPECT_EQ(outside(shrunk, d->mask), 0);  // and in
    if (!sameMask(d->mask, gt)) ++changed;
  });
  EXPECT_GT(changed, 35);
}

TEST_F(SimulatedSegmenterTest, PartsAreConfusableClassesWithLowerScores) {
  Config config = zeroRates();
  config.part_probability = 0.15;
  config.part_removed_probability = 0.5;
  int instances = 0, parts = 0, removed = 0;
  overSeeds(config, 300, [&](const std::vector<Detection2D>& detections) {
    // Chair -> couch, couch -> chair, bed -> couch (defaults).
    for (const auto& [id, part_class] : std::vector<std::pair<int, std::string>>{
             {kChair, "couch"}, {kSofa, "chair"}, {kBed, "couch"}}) {
      ++instances;
      const cv::Mat gt = groundTruth(1, id);
      const int gt_area = cv::countNonZero(gt);
      const Detection2D* main = nullptr;
      const Detection2D* part = nullptr;
      for (const Detection2D& d : detections) {
        if (cv::countNonZero(d.mask & gt) == 0) continue;
        (d.class_name == part_class ? part : main) = &d;
      }
      ASSERT_NE(main, nullptr);
      EXPECT_EQ(outside(main->mask, gt), 0);
      if (part == nullptr) {
        EXPECT_TRUE(sameMask(main->mask, gt));
        continue;
      }
      ++parts;
      EXPECT_EQ(part->class_id, cocoClassId(part_class));
      EXPECT_LT(part->score, main->score);
      EXPECT_EQ(outside(part->mask, gt), 0);
      const int part_area = cv::countNonZero(part->mask);
      EXPECT_GE(part_area, 0.25 * gt_area);
      EXPECT_LE(part_area, 0.55 * gt_area);
      // A strip along one side: its box shares three sides with the instance's.
      const cv::Rect whole = cv::boundingRect(gt);
      const cv::Rect strip = part->box_px;
      const int shared = (strip.x == whole.x) + (strip.y == whole.y) +
                         (strip.br().x == whole.br().x) + (strip.br().y == whole.br().y);
      EXPECT_EQ(shared, 3);
      if (cv::countNonZero(main->mask & part->mask) == 0) {
        ++removed;
        EXPECT_TRUE(sameMask(main->mask | part->mask, gt));
      } else {
        EXPECT_TRUE(sameMask(main->mask, gt));
      }
    }
  });
  EXPECT_NEAR(static_cast<double>(parts) / instances, 0.15, 0.04);
  ASSERT_GT(parts, 0);
  EXPECT_NEAR(static_cast<double>(removed) / parts, 0.5, 0.15);
}

TEST_F(SimulatedSegmenterTest, FalsePositivesOnlyOnConfiguredClutter) {
  Config config = zeroRates();
  config.false_positives = {{"shelf", "book", 0.1}, {"shelf", "refrigerator", 0.05}};
  int books = 0, fridges = 0, trials = 0;
  overSeeds(config, 400, [&](const std::vector<Detection2D>& detections) {
    ++trials;
    EXPECT_EQ(mainDetectionOf(detections, kWall), nullptr);  // clutter without an entry
    const Detection2D* d = mainDetectionOf(detections, kShelf);
    if (d == nullptr) return;
    EXPECT_TRUE(sameMask(d->mask, groundTruth(1, kShelf)));
    if (d->class_name == "book") ++books;
    if (d->class_name == "refrigerator") ++fridges;
  });
  EXPECT_NEAR(static_cast<double>(books) / trials, 0.1, 0.04);
  EXPECT_NEAR(static_cast<double>(fridges) / trials, 0.05, 0.03);
}

TEST_F(SimulatedSegmenterTest, DefaultScoresSpreadSomeUnderLambda) {
  int under = 0, total = 0;
  overSeeds(Config(), 100, [&](const std::vector<Detection2D>& detections) {
    for (const Detection2D& d : detections) {
      ++total;
      EXPECT_GE(d.score, 0.04f);  // parts: at most 0.9 x their instance's
      EXPECT_LE(d.score, 0.99f);
      EXPECT_GE(d.class_id, 0);
      EXPECT_EQ(d.mask.size(), image_.size());
      EXPECT_EQ(d.box_px, cv::boundingRect(d.mask));
      if (d.score < 0.5f) ++under;
    }
  });
  EXPECT_GT(total, 300);
  EXPECT_GT(under, 0);
  EXPECT_LT(under, total / 4);
}

TEST_F(SimulatedSegmenterTest, UnknownLabelIdIsAWarning) {
  cv::Mat labels = readLabels(2);
  labels(cv::Rect(0, 0, 30, 30)).setTo(99);
  writeLabels(3, labels);
  std::unique_ptr<SimulatedInstanceSegmenter> segmenter = make(Config::perfect());
  ASSERT_TRUE(segmenter);
  std::vector<std::string> warnings;
  const std::vector<Detection2D> detections = detect(segmenter.get(), 3, &warnings);
  EXPECT_EQ(detections.size(), 2u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("label id 99"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("label00003.png"), std::string::npos) << warnings[0];
}

TEST_F(SimulatedSegmenterTest, BadInputsAreErrorsNamingTheFile) {
  std::unique_ptr<SimulatedInstanceSegmenter> segmenter = make(Config());
  ASSERT_TRUE(segmenter);
  std::vector<Detection2D> detections;

  Status status = segmenter->detect(image_, "image00009", &detections);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find((dir_ / "label" / "label00009.png").string()), std::string::npos)
      << status.message();

  status = segmenter->detect(image_, "image", &detections);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("frame number"), std::string::npos) << status.message();

  writeLabels(4, cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(1)));  // 8 bit
  status = segmenter->detect(image_, "image00004", &detections);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("label00004.png"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("CV_16UC1"), std::string::npos) << status.message();

  writeLabels(5, cv::Mat::zeros(kHeight / 2, kWidth / 2, CV_16UC1));  // wrong size
  status = segmenter->detect(image_, "image00005", &detections);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("label00005.png"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("100x75"), std::string::npos) << status.message();

  std::ofstream(dir_ / "label" / "label00006.png") << "not a png";
  status = segmenter->detect(image_, "image00006", &detections);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("label00006.png"), std::string::npos) << status.message();
  EXPECT_TRUE(detections.empty());

  // No XML.
  fs::remove(dir_ / "seq01.xml");
  std::unique_ptr<SimulatedInstanceSegmenter> none;
  status = SimulatedInstanceSegmenter::create(dir_.string(), Config(), &none);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(none);
  EXPECT_NE(status.message().find((dir_ / "seq01.xml").string()), std::string::npos)
      << status.message();
}

TEST(SimulatedSegmenterConfigTest, Validation) {
  EXPECT_TRUE(Config().isValid().ok()) << Config().isValid().message();
  EXPECT_TRUE(Config::perfect().isValid().ok());
  Config config;
  config.miss_probability = 1.5;
  EXPECT_NE(config.isValid().message().find("miss_probability"), std::string::npos);
  config = Config();
  config.max_bleed_px = 1;
  EXPECT_FALSE(config.isValid().ok());
  config = Config();
  config.confusions.push_back({"sofa", "chair", 0.1});
  EXPECT_NE(config.isValid().message().find("'couch'"), std::string::npos)
      << config.isValid().message();
  config = Config();
  config.confusions.push_back({"chair", "couch", 0.95});  // chair sums to 1.05
  EXPECT_NE(config.isValid().message().find("sum"), std::string::npos);
  config = Config();
  config.false_positives.push_back({"shelf", "bookshelf", 0.1});
  EXPECT_NE(config.isValid().message().find("not a COCO class"), std::string::npos);
  config = Config();
  config.part_classes["chair"] = "sofa";
  EXPECT_FALSE(config.isValid().ok());
  config = Config();
  config.min_score = 0.9;
  config.max_score = 0.5;
  EXPECT_FALSE(config.isValid().ok());
}

TEST_F(SimulatedSegmenterTest, FactoryCreatesSimulatedByName) {
  BenchmarkSegmenterOptions options;
  options.detector = "simulated";
  options.simulated = Config::perfect();
  std::unique_ptr<InstanceSegmenter> segmenter;

  EXPECT_FALSE(options.isValid().ok());  // no folder
  EXPECT_NE(options.isValid().message().find("simulated"), std::string::npos);

  options.detections_dir = (root_ / "missing").string();
  Status status = createBenchmarkSegmenter(options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(segmenter);
  EXPECT_NE(status.message().find(options.detections_dir), std::string::npos) << status.message();

  options.detections_dir = dir_.string() + "/";  // a trailing slash still finds seq01.xml
  options.simulated.miss_probability = -1.0;
  status = createBenchmarkSegmenter(options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("miss_probability"), std::string::npos) << status.message();

  options.simulated.miss_probability = 0.0;
  status = createBenchmarkSegmenter(options, &segmenter);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_TRUE(segmenter);
  EXPECT_EQ(segmenter->name(), "simulated");
  std::vector<Detection2D> detections;
  ASSERT_TRUE(segmenter->detect(image_, "image00002", &detections).ok());
  EXPECT_EQ(detections.size(), 2u);

  options.detector = "simulate";
  EXPECT_NE(options.isValid().message().find("simulated"), std::string::npos);

  // The deployable factory (the node's) refuses the benchmark detector and says where it is.
  SegmenterOptions deployable;
  deployable.detector = "simulated";
  deployable.detections_dir = dir_.string();
  EXPECT_FALSE(createInstanceSegmenter(deployable, &segmenter).ok());
  EXPECT_FALSE(segmenter);
  EXPECT_NE(deployable.isValid().message().find("offline_detection"), std::string::npos);
}

}  // namespace
}  // namespace mvod
