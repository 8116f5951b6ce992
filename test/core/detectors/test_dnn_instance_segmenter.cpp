// The OpenCV DNN backends: post-processing on hand-made output blobs, FastestDet on real photos
// (../shared/models, skipped when absent), and clear errors for missing or corrupt model files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "multiview_object_detection/detectors/dnn_instance_segmenter.h"
#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "shared_data.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

std::string modelsDir() { return test::sharedPath("models"); }

float logit(float p) { return std::log(p / (1.f - p)); }

// A FastestDet-shaped output [1, 85, 22, 22] with every score 0 except the given cells.
struct FastestDetBlob {
  static constexpr int kGrid = 22;
  cv::Mat blob;
  FastestDetBlob() {
    const int sizes[] = {1, 85, kGrid, kGrid};
    blob = cv::Mat(4, sizes, CV_32F, cv::Scalar(0));
  }
  float& at(int c, int h, int w) { return blob.ptr<float>()[(c * kGrid + h) * kGrid + w]; }
  // A box centred at (cx, cy) (normalised) of normalised size (bw, bh).
  void put(int h, int w, float objectness, int class_id, float class_score, float cx, float cy,
           float bw, float bh) {
    at(0, h, w) = objectness;
    at(5 + class_id, h, w) = class_score;
    at(1, h, w) = std::atanh(cx * kGrid - w);
    at(2, h, w) = std::atanh(cy * kGrid - h);
    at(3, h, w) = logit(bw);
    at(4, h, w) = logit(bh);
  }
};

TEST(FastestDetDecodeTest, BoxesScoresAndClasses) {
  FastestDetBlob out;
  const int chair = cocoClassId("chair");
  const int cup = cocoClassId("cup");
  ASSERT_GE(chair, 0);
  out.put(10, 8, 0.9f, chair, 0.8f, 8.3f / 22, 10.6f / 22, 0.25f, 0.5f);
  out.put(4, 15, 0.7f, cup, 0.9f, 15.5f / 22, 4.5f / 22, 0.05f, 0.1f);
  out.put(20, 2, 0.3f, chair, 0.5f, 2.5f / 22, 20.5f / 22, 0.1f, 0.1f);  // 0.15: below threshold
  DnnDecodeConfig config;
  config.score_threshold = 0.5f;
  std::vector<Detection2D> detections;
  ASSERT_TRUE(
      decodeFastestDet(out.blob, cv::Size(640, 480), cocoClassNames(), config, &detections).ok());
  ASSERT_EQ(detections.size(), 2u);
  const Detection2D& first = detections[0];  // sorted by score: chair 0.72, cup 0.63
  EXPECT_EQ(first.class_name, "chair");
  EXPECT_EQ(first.class_id, chair);
  EXPECT_NEAR(first.score, 0.72f, 1e-4);
  // centre (8.3/22 * 640, 10.6/22 * 480) = (241.5, 231.3); size (160, 240).
  EXPECT_NEAR(first.box_px.x, 241.5 - 80, 1.5);
  EXPECT_NEAR(first.box_px.y, 231.3 - 120, 1.5);
  EXPECT_NEAR(first.box_px.width, 160, 2);
  EXPECT_NEAR(first.box_px.height, 240, 2);
  // The box is the mask (box-sized).
  ASSERT_EQ(first.mask.size(), first.box_px.size());
  EXPECT_EQ(cv::countNonZero(first.mask), first.box_px.area());
  EXPECT_EQ(detections[1].class_name, "cup");
  EXPECT_NEAR(detections[1].score, 0.63f, 1e-4);
}

TEST(FastestDetDecodeTest, NonMaximumSuppressionIsPerClass) {
  FastestDetBlob out;
  const int chair = cocoClassId("chair");
  const int couch = cocoClassId("couch");
  // Two overlapping chairs (IoU ~0.8) and a couch on top of them.
  out.put(10, 10, 0.9f, chair, 0.9f, 10.5f / 22, 10.5f / 22, 0.3f, 0.3f);
  out.put(10, 11, 0.8f, chair, 0.9f, 10.9f / 22, 10.5f / 22, 0.3f, 0.3f);
  out.put(11, 10, 0.8f, couch, 0.9f, 10.5f / 22, 11.2f / 22, 0.3f, 0.3f);
  DnnDecodeConfig config;
  config.nms_threshold = 0.45f;
  std::vector<Detection2D> detections;
  ASSERT_TRUE(
      decodeFastestDet(out.blob, cv::Size(352, 352), cocoClassNames(), config, &detections).ok());
  ASSERT_EQ(detections.size(), 2u);
  EXPECT_EQ(detections[0].class_name, "chair");
  EXPECT_NEAR(detections[0].score, 0.81f, 1e-4);  // the stronger chair survives
  EXPECT_EQ(detections[1].class_name, "couch");
}

TEST(FastestDetDecodeTest, DarknetLabelSpellingsBecomeCocoNames) {
  FastestDetBlob out;
  const int table = cocoClassId("dining table");
  out.put(10, 10, 0.9f, table, 0.9f, 10.5f / 22, 10.5f / 22, 0.3f, 0.3f);
  std::vector<std::string> darknet_labels = cocoClassNames();
  darknet_labels[table] = "diningtable";
  std::vector<Detection2D> detections;
  ASSERT_TRUE(decodeFastestDet(out.blob, cv::Size(640, 480), darknet_labels, {}, &detections).ok());
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_EQ(detections[0].class_name, "dining table");
  EXPECT_EQ(detections[0].class_id, table);
}

TEST(FastestDetDecodeTest, BadBlobsAreErrors) {
  std::vector<Detection2D> detections;
  const cv::Mat flat(85, 484, CV_32F, cv::Scalar(0));
  EXPECT_FALSE(decodeFastestDet(flat, cv::Size(640, 480), cocoClassNames(), {}, &detections).ok());
  FastestDetBlob out;
  const std::vector<std::string> short_labels = {"person", "bicycle"};
  EXPECT_FALSE(decodeFastestDet(out.blob, cv::Size(640, 480), short_labels, {}, &detections).ok());
  EXPECT_FALSE(decodeFastestDet(out.blob, cv::Size(0, 0), cocoClassNames(), {}, &detections).ok());
}

// Mask R-CNN blobs: detection_out_final [1, 1, N, 7] and detection_masks [N, 90, 15, 15].
class MaskRcnnDecodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    labels_.assign(90, "");
    labels_[0] = "person";
    labels_[61] = "chair";
    labels_[11] = "street sign";  // in the 90-id list, not one of the 80 COCO classes
  }
  void make(int n) {
    const int out_sizes[] = {1, 1, n, 7};
    out_ = cv::Mat(4, out_sizes, CV_32F, cv::Scalar(0));
    const int mask_sizes[] = {n, 90, 15, 15};
    masks_ = cv::Mat(4, mask_sizes, CV_32F, cv::Scalar(0));
  }
  void setRow(int i, int class_id, float score, float x1, float y1, float x2, float y2) {
    float* r = out_.ptr<float>() + 7 * i;
    r[0] = 0;
    r[1] = static_cast<float>(class_id);
    r[2] = score;
    r[3] = x1;
    r[4] = y1;
    r[5] = x2;
    r[6] = y2;
  }
  cv::Mat mask(int i, int class_id) {
    return cv::Mat(15, 15, CV_32F, masks_.ptr<float>() + (i * 90 + class_id) * 225);
  }
  std::vector<std::string> labels_;
  cv::Mat out_, masks_;
};

TEST_F(MaskRcnnDecodeTest, MaskOfTheDetectedClassIsStretchedOverTheBox) {
  make(3);
  setRow(0, 61, 0.9f, 0.25f, 0.25f, 0.75f, 0.75f);  // chair, box (160,120)-(480,360)
  setRow(1, 0, 0.3f, 0.0f, 0.0f, 0.5f, 0.5f);       // below λ
  setRow(2, 0, 0.8f, 0.0f, 0.0f, 0.25f, 0.5f);      // person, mask empty
  // The chair's mask: the left half of its 15x15 grid; the person's channel of that row says
  // "everything" and must not be used.
  mask(0, 61)(cv::Rect(0, 0, 7, 15)).setTo(0.9f);
  mask(0, 0).setTo(1.0f);
  DnnDecodeConfig config;
  config.score_threshold = 0.5f;
  config.mask_threshold = 0.5f;
  std::vector<Detection2D> detections;
  ASSERT_TRUE(decodeMaskRcnn(out_, masks_, cv::Size(640, 480), labels_, config, &detections).ok());
  ASSERT_EQ(detections.size(), 2u);
  const Detection2D& chair = detections[0];
  EXPECT_EQ(chair.class_name, "chair");
  EXPECT_EQ(chair.class_id, cocoClassId("chair"));
  EXPECT_EQ(chair.box_px, cv::Rect(160, 120, 320, 240));
  ASSERT_EQ(chair.mask.size(), chair.box_px.size());            // box-sized
  EXPECT_FLOAT_EQ(chair.mask_cell_px, 320.f / masks_.size[3]);  // its mask stretched over the box
  // Left ~7/15 of the box is set, nothing outside the box.
  const cv::Mat full = maskInRegion(chair, cv::Size(640, 480), cv::Rect(0, 0, 640, 480));
  const int area = cv::countNonZero(full);
  EXPECT_NEAR(area, 320 * 240 * 7.0 / 15.0, 320 * 240 * 0.06);
  EXPECT_EQ(cv::countNonZero(full(cv::Rect(0, 0, 160, 480))), 0);
  EXPECT_GT(full.at<uint8_t>(240, 170), 0);
  EXPECT_EQ(full.at<uint8_t>(240, 470), 0);
  EXPECT_EQ(detections[1].class_name, "person");
  EXPECT_EQ(cv::countNonZero(detections[1].mask), 0);
}

TEST_F(MaskRcnnDecodeTest, ClassesOutsideTheEightyAreMarkedUnknownAndBadBlobsAreErrors) {
  make(1);
  setRow(0, 11, 0.9f, 0.1f, 0.1f, 0.2f, 0.2f);
  std::vector<Detection2D> detections;
  ASSERT_TRUE(decodeMaskRcnn(out_, masks_, cv::Size(640, 480), labels_, {}, &detections).ok());
  ASSERT_EQ(detections.size(), 1u);
  EXPECT_EQ(detections[0].class_id, -1);
  const cv::Mat two_d(3, 7, CV_32F, cv::Scalar(0));
  EXPECT_FALSE(decodeMaskRcnn(two_d, masks_, cv::Size(640, 480), labels_, {}, &detections).ok());
  make(2);
  const int mask_sizes[] = {1, 90, 15, 15};
  const cv::Mat too_few(4, mask_sizes, CV_32F, cv::Scalar(0));
  EXPECT_FALSE(decodeMaskRcnn(out_, too_few, cv::Size(640, 480), labels_, {}, &detections).ok());
}

TEST(DnnSegmenterFilesTest, MissingAndCorruptModelsSayWhatIsMissing) {
  const fs::path dir = fs::temp_directory_path() / ("mvod_dnn_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  SegmenterOptions options;
  options.model_dir = dir.string();
  std::unique_ptr<InstanceSegmenter> segmenter;

  options.detector = "fastestdet";
  Status status = createInstanceSegmenter(options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(segmenter);
  EXPECT_NE(status.message().find((dir / "FastestDet.onnx").string()), std::string::npos)
      << status.message();
  EXPECT_NE(status.message().find("download_models.sh"), std::string::npos) << status.message();

  std::ofstream(dir / "FastestDet.onnx") << "this is not an ONNX file";
  status = createInstanceSegmenter(options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("could not be loaded"), std::string::npos) << status.message();

  options.detector = "maskrcnn";
  status = createInstanceSegmenter(options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("frozen_inference_graph.pb"), std::string::npos)
      << status.message();
  fs::remove_all(dir);
}

class FastestDetRealTest : public ::testing::Test {
 protected:
  void SetUp() override {
    models_ = modelsDir();
    if (models_.empty() || !fs::exists(fs::path(models_) / "FastestDet.onnx")) {
      GTEST_SKIP() << "FastestDet.onnx not found (set MVOD_SHARED_DIR or put shared/models next "
                      "to the repository)";
    }
    SegmenterOptions options;
    options.detector = "fastestdet";
    options.model_dir = models_;
    const Status status = createInstanceSegmenter(options, &segmenter_);
    ASSERT_TRUE(status.ok()) << status.message();
  }
  std::vector<std::string> classesIn(const std::string& image) {
    const cv::Mat bgr = cv::imread((fs::path(models_) / image).string());
    EXPECT_FALSE(bgr.empty()) << image;
    std::vector<Detection2D> detections;
    const Status status = segmenter_->detect(bgr, image, &detections);
    EXPECT_TRUE(status.ok()) << status.message();
    std::vector<std::string> names;
    for (const Detection2D& d : detections) {
      names.push_back(d.class_name);
      EXPECT_EQ(d.mask.size(), d.box_px.size());  // box-sized
      EXPECT_GT(cv::countNonZero(d.mask), 0);
    }
    return names;
  }
  bool has(const std::vector<std::string>& names, const std::string& name) {
    return std::find(names.begin(), names.end(), name) != names.end();
  }
  std::string models_;
  std::unique_ptr<InstanceSegmenter> segmenter_;
};

// A label file of another model (3 names, or 81) was accepted at start, then every keyframe
// failed in decoding: now the load refuses it, naming the file and both counts.
TEST_F(FastestDetRealTest, LabelFileOfAnotherClassCountIsRefusedAtLoad) {
  const fs::path dir = fs::temp_directory_path() / ("mvod_labels_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  DnnModelOptions options;
  options.model_path = (fs::path(models_) / "FastestDet.onnx").string();
  std::unique_ptr<DnnInstanceSegmenter> segmenter;
  const fs::path three = dir / "three.names";
  std::ofstream(three) << "person\nchair\ntable\n";
  options.labels_path = three.string();
  Status status =
      DnnInstanceSegmenter::create(DnnInstanceSegmenter::Model::kFastestDet, options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_FALSE(segmenter);
  for (const std::string& fragment :
       {three.string(), std::string("3 names"), std::string("80 classes"), options.model_path}) {
    EXPECT_NE(status.message().find(fragment), std::string::npos)
        << "'" << fragment << "' not in: " << status.message();
  }
  const fs::path more = dir / "more.names";
  {
    std::ofstream out(more);
    for (const std::string& name : cocoClassNames()) out << name << "\n";
    out << "unicorn\n";
  }
  options.labels_path = more.string();
  status =
      DnnInstanceSegmenter::create(DnnInstanceSegmenter::Model::kFastestDet, options, &segmenter);
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("81 names"), std::string::npos) << status.message();
  // The model's own label file loads.
  options.labels_path = (fs::path(models_) / "coco.names").string();
  status =
      DnnInstanceSegmenter::create(DnnInstanceSegmenter::Model::kFastestDet, options, &segmenter);
  EXPECT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(segmenter->labels().size(), 80u);
  fs::remove_all(dir);
}

TEST_F(FastestDetRealTest, FindsThePersonAndTheDog) {
  const std::vector<std::string> names = classesIn("sample_person.jpg");
  EXPECT_TRUE(has(names, "person")) << ::testing::PrintToString(names);
  EXPECT_TRUE(has(names, "dog")) << ::testing::PrintToString(names);
}

TEST_F(FastestDetRealTest, FindsTheDogBicycleOrCar) {
  const std::vector<std::string> names = classesIn("sample_dog.jpg");
  EXPECT_TRUE(has(names, "dog") || has(names, "bicycle") || has(names, "car"))
      << ::testing::PrintToString(names);
}

// The real kitchen (7-Scenes redkitchen, ../shared/data): every 20th of the 1000 frames. Chairs and
// mugs are in view throughout; FastestDet must find each in some frames.
TEST_F(FastestDetRealTest, FindsChairsAndCupsInTheRedkitchen) {
  const fs::path data = fs::path(models_) / ".." / "data" / "7scenes_redkitchen" / "data";
  if (!fs::is_directory(data)) GTEST_SKIP() << "7-Scenes data not found: " << data;
  std::map<std::string, int> frames_with;
  int frames = 0;
  for (int index = 0; index < 1000; index += 20) {
    char name[64];
    std::snprintf(name, sizeof(name), "frame-%06d.color.jpg", index);
    const cv::Mat bgr = cv::imread((data / name).string());
    if (bgr.empty()) continue;
    ++frames;
    std::vector<Detection2D> detections;
    ASSERT_TRUE(segmenter_->detect(bgr, name, &detections).ok());
    std::set<std::string> classes;
    for (const Detection2D& d : detections) classes.insert(d.class_name);
    for (const std::string& c : classes) ++frames_with[c];
  }
  ASSERT_GE(frames, 40) << "redkitchen frames missing under " << data;
  std::string summary;
  for (const auto& entry : frames_with) {
    summary += entry.first + ": " + std::to_string(entry.second) + " frames\n";
  }
  EXPECT_GE(frames_with["cup"], 10) << summary;   // measured: 28 of 50
  EXPECT_GE(frames_with["chair"], 5) << summary;  // measured: 19 of 50
  RecordProperty("classes_per_frame", summary);
}

TEST_F(FastestDetRealTest, RejectsImagesThatAreNotBgr) {
  std::vector<Detection2D> detections;
  EXPECT_FALSE(segmenter_->detect(cv::Mat(), "empty", &detections).ok());
  EXPECT_FALSE(segmenter_->detect(cv::Mat(480, 640, CV_16UC1), "depth", &detections).ok());
}

}  // namespace
}  // namespace mvod
