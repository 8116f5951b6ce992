// Mask R-CNN through OpenCV DNN without the real weights: test/tools/make_random_maskrcnn_graph
// writes a frozen graph with random weights for the shared text graph (../shared/models); the
// "maskrcnn" segmenter must load it, run a forward pass on a real 640x480 photo and decode the
// outputs. Skipped when the text graph, labels or photo are absent. The layers are made 4x thinner
// (--depth-multiplier 0.25: same graph, op types and output shapes) so a forward pass takes ~0.4 s
// instead of ~2-3 s on two CPU cores.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "shared_data.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

constexpr char kTextGraph[] = "mask_rcnn_inception_v2_coco_2018_01_28.pbtxt";
constexpr char kLabels[] = "object_detection_classes_coco.txt";
constexpr char kWeights[] = "frozen_inference_graph.pb";
constexpr char kPhoto[] = "sample_person.jpg";
const cv::Size kImageSize(640, 480);

std::string sharedModelsDirForMaskRcnn() { return test::sharedPath("models"); }

[[maybe_unused]] std::string readWholeFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Runs the generator; returns its exit status (-1 when it did not exit normally) and its output.
int runGenerator(const std::string& arguments, const fs::path& log, std::string* output) {
#ifdef MVOD_MAKE_RANDOM_MASKRCNN_BIN
  const std::string command = std::string("'") + MVOD_MAKE_RANDOM_MASKRCNN_BIN + "' " + arguments +
                              " > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  *output = readWholeFile(log);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
#else
  *output = "built without MVOD_MAKE_RANDOM_MASKRCNN_BIN";
  return -1;
#endif
}

class MaskRcnnRandomWeightsTest : public ::testing::Test {
 protected:
  // The 64 MB graph is made once for the suite.
  static void SetUpTestSuite() {
#ifndef MVOD_MAKE_RANDOM_MASKRCNN_BIN
    skip_reason_ = "the test binary was built without MVOD_MAKE_RANDOM_MASKRCNN_BIN";
    return;
#endif
    models_dir_ = sharedModelsDirForMaskRcnn();
    for (const char* file : {kTextGraph, kLabels, kPhoto}) {
      if (models_dir_.empty() || !fs::is_regular_file(fs::path(models_dir_) / file)) {
        skip_reason_ = std::string(file) +
                       " not found in ../shared/models (or $MVOD_SHARED_DIR/models): "
                       "Mask R-CNN random-weight test skipped";
        return;
      }
    }
    std::string pattern = (fs::temp_directory_path() / "mvod_maskrcnn_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      skip_reason_ = "cannot make a temporary folder";
      return;
    }
    work_dir_ = pattern;
    const fs::path shared(models_dir_);
    generator_status_ =
        runGenerator("--pbtxt '" + (shared / kTextGraph).string() + "' --output '" +
                         (work_dir_ / kWeights).string() + "' --seed 7 --depth-multiplier 0.25",
                     work_dir_ / "generator.log", &generator_output_);
    // The segmenter finds all three files by name in one folder, as with the real model.
    std::error_code error;
    fs::create_symlink(shared / kTextGraph, work_dir_ / kTextGraph, error);
    fs::create_symlink(shared / kLabels, work_dir_ / kLabels, error);
  }

  static void TearDownTestSuite() {
    std::error_code error;
    if (!work_dir_.empty()) fs::remove_all(work_dir_, error);
    work_dir_.clear();
  }

  void SetUp() override {
    if (!skip_reason_.empty()) GTEST_SKIP() << skip_reason_;
    ASSERT_EQ(generator_status_, 0) << generator_output_;
    ASSERT_TRUE(fs::is_regular_file(work_dir_ / kWeights)) << generator_output_;
    image_ = cv::imread((fs::path(models_dir_) / kPhoto).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image_.empty());
    cv::resize(image_, image_, kImageSize);
  }

  static std::string skip_reason_;
  static std::string models_dir_;
  static fs::path work_dir_;
  static int generator_status_;
  static std::string generator_output_;
  cv::Mat image_;
};

std::string MaskRcnnRandomWeightsTest::skip_reason_;
std::string MaskRcnnRandomWeightsTest::models_dir_;
fs::path MaskRcnnRandomWeightsTest::work_dir_;
int MaskRcnnRandomWeightsTest::generator_status_ = -1;
std::string MaskRcnnRandomWeightsTest::generator_output_;

TEST_F(MaskRcnnRandomWeightsTest, SegmenterDetectsAndDecodesMasks) {
  SegmenterOptions options;
  options.detector = "maskrcnn";
  options.model_dir = work_dir_.string();
  options.score_threshold = 0.5f;
  std::unique_ptr<InstanceSegmenter> segmenter;
  const Status created = createInstanceSegmenter(options, &segmenter);
  ASSERT_TRUE(created.ok()) << created.message();
  ASSERT_NE(segmenter, nullptr);
  EXPECT_EQ(segmenter->name(), "maskrcnn");

  std::vector<Detection2D> detections;
  std::vector<std::string> warnings;
  const Status detected = segmenter->detect(image_, "frame-000000", &detections, &warnings);
  ASSERT_TRUE(detected.ok()) << detected.message();
  // The generator biases the second stage towards label line 0 ("person") with p ~ 0.97.
  ASSERT_FALSE(detections.empty());
  const int person = cocoClassId("person");
  int masks_with_pixels = 0;
  for (const Detection2D& d : detections) {
    EXPECT_EQ(d.class_name, "person");
    EXPECT_EQ(d.class_id, person);
    EXPECT_GE(d.score, options.score_threshold);
    EXPECT_LE(d.score, 1.f);
    EXPECT_GT(d.box_px.area(), 0);
    EXPECT_EQ(d.box_px & cv::Rect(cv::Point(), kImageSize), d.box_px);
    // Box-sized: the stretched low-resolution mask stays inside its box by construction.
    ASSERT_EQ(d.mask.size(), d.box_px.size());
    ASSERT_EQ(d.mask.type(), CV_8UC1);
    masks_with_pixels += cv::countNonZero(d.mask) > 0;
  }
  EXPECT_GT(masks_with_pixels, 0);
}

// The label count is checked against the masks' class count (90) at load, not at every keyframe.
TEST_F(MaskRcnnRandomWeightsTest, LabelFileOfAnotherClassCountIsRefusedAtLoad) {
  const fs::path dir = work_dir_ / "three_labels";
  fs::create_directories(dir);
  std::error_code error;
  fs::create_symlink(work_dir_ / kWeights, dir / kWeights, error);
  fs::create_symlink(fs::path(models_dir_) / kTextGraph, dir / kTextGraph, error);
  std::ofstream(dir / kLabels) << "person\nbicycle\ncar\n";
  SegmenterOptions options;
  options.detector = "maskrcnn";
  options.model_dir = dir.string();
  std::unique_ptr<InstanceSegmenter> segmenter;
  const Status created = createInstanceSegmenter(options, &segmenter);
  ASSERT_FALSE(created.ok());
  EXPECT_FALSE(segmenter);
  for (const std::string& fragment :
       {(dir / kLabels).string(), std::string("3 names"), std::string("90 classes")}) {
    EXPECT_NE(created.message().find(fragment), std::string::npos)
        << "'" << fragment << "' not in: " << created.message();
  }
}

TEST_F(MaskRcnnRandomWeightsTest, RawForwardGivesDetectionAndMaskBlobs) {
  const fs::path shared(models_dir_);
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromTensorflow((work_dir_ / kWeights).string(),
                                         (shared / kTextGraph).string());
  } catch (const cv::Exception& e) {
    FAIL() << "OpenCV could not load the random-weight graph: " << e.what();
  }
  ASSERT_FALSE(net.empty());
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  net.setInput(cv::dnn::blobFromImage(image_, 1.0, image_.size(), cv::Scalar(), true, false));
  std::vector<cv::Mat> outputs;
  net.forward(outputs, std::vector<std::string>{"detection_out_final", "detection_masks"});
  ASSERT_EQ(outputs.size(), 2u);

  const cv::Mat& boxes = outputs[0];
  ASSERT_EQ(boxes.dims, 4);
  EXPECT_EQ(boxes.size[0], 1);
  EXPECT_EQ(boxes.size[1], 1);
  EXPECT_EQ(boxes.size[3], 7);
  const int rows = boxes.size[2];
  ASSERT_GT(rows, 0);

  const cv::Mat& masks = outputs[1];
  ASSERT_EQ(masks.dims, 4);
  EXPECT_EQ(masks.size[0], rows);  // one set of class masks per output row
  EXPECT_EQ(masks.size[1], 90);    // COCO classes of the model
  EXPECT_EQ(masks.size[2], 15);
  EXPECT_EQ(masks.size[3], 15);
  EXPECT_TRUE(cv::checkRange(boxes));
  double min_mask = 0.0, max_mask = 0.0;
  cv::minMaxIdx(masks, &min_mask, &max_mask);
  EXPECT_GE(min_mask, 0.0);  // sigmoid outputs
  EXPECT_LE(max_mask, 1.0);
  EXPECT_LT(min_mask, max_mask);

  int confident = 0;
  const float* row = boxes.ptr<float>();
  for (int i = 0; i < rows; ++i, row += 7) {
    if (row[2] < 0.5f) continue;
    ++confident;
    EXPECT_EQ(row[1], 0.f);  // class index 0 = label line 0
    for (int k = 3; k < 7; ++k) {
      EXPECT_GE(row[k], 0.f);
      EXPECT_LE(row[k], 1.f);
    }
    EXPECT_LT(row[3], row[5]);
    EXPECT_LT(row[4], row[6]);
  }
  EXPECT_GT(confident, 0);
}

TEST(MaskRcnnRandomGraphToolTest, RejectsOtherGraphs) {
#ifndef MVOD_MAKE_RANDOM_MASKRCNN_BIN
  GTEST_SKIP() << "the test binary was built without MVOD_MAKE_RANDOM_MASKRCNN_BIN";
#endif
  std::string pattern = (fs::temp_directory_path() / "mvod_maskrcnn_tool_XXXXXX").string();
  ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
  const fs::path work_dir = pattern;
  // A text graph that is no Mask R-CNN: a clear error and a non-zero exit status, no output file.
  const fs::path other = work_dir / "other.pbtxt";
  std::ofstream(other) << "node { name: \"input\" op: \"Placeholder\" }\n"
                          "node { name: \"conv\" op: \"Conv2D\" input: \"input\" "
                          "input: \"conv/weights\" }\n";
  std::string output;
  const int status = runGenerator(
      "--pbtxt '" + other.string() + "' --output '" + (work_dir / "other.pb").string() + "'",
      work_dir / "other.log", &output);
  EXPECT_NE(status, 0);
  EXPECT_NE(output.find("PriorBox"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(work_dir / "other.pb"));
  EXPECT_FALSE(fs::exists(work_dir / "other.pb.partial"));
  EXPECT_NE(runGenerator("--pbtxt '" + (work_dir / "missing.pbtxt").string() + "' --output '" +
                             (work_dir / "missing.pb").string() + "'",
                         work_dir / "missing.log", &output),
            0);
  EXPECT_NE(output.find("cannot read"), std::string::npos) << output;
  std::error_code error;
  fs::remove_all(work_dir, error);
}

}  // namespace
}  // namespace mvod
