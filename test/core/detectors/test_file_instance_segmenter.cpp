// FileInstanceSegmenter: write() then detect() round trip, missing and malformed files, per-entry
// problems (unknown class, bad mask) reported as warnings, box clipping.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"
#include "test_files.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

class FileInstanceSegmenterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::freshTestDir("mvod_file_segmenter");
    image_ = cv::Mat(24, 32, CV_8UC3, cv::Scalar(10, 20, 30));
  }
  void TearDown() override { fs::remove_all(dir_); }

  void writeText(const std::string& file, const std::string& text) {
    std::ofstream(dir_ / file) << text;
  }

  Status detect(std::vector<Detection2D>* detections, std::vector<std::string>* warnings,
                const std::string& frame = "frame-000010") {
    FileInstanceSegmenter segmenter(dir_.string());
    return segmenter.detect(image_, frame, detections, warnings);
  }

  fs::path dir_;
  cv::Mat image_;
};

bool sameMask(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != CV_8UC1 || b.type() != CV_8UC1) return false;
  return cv::countNonZero((a != 0) != (b != 0)) == 0;
}

TEST_F(FileInstanceSegmenterTest, WriteThenDetectRoundTrip) {
  std::vector<Detection2D> written(3);
  written[0].class_name = "chair";
  written[0].class_id = cocoClassId("chair");
  written[0].score = 0.9f;
  written[0].mask = cv::Mat::zeros(24, 32, CV_8UC1);
  cv::ellipse(written[0].mask, cv::Point(10, 12), cv::Size(6, 8), 0, 0, 360, cv::Scalar(255),
              cv::FILLED);
  written[0].box_px = cv::boundingRect(written[0].mask);
  written[0].mask_cell_px = 4.f;  // a coarse mask's grid, kept with it

  written[1].class_name = "cup";  // box only: no mask file, the box is the mask
  written[1].score = 0.55f;
  written[1].box_px = cv::Rect(20, 3, 5, 4);

  written[2].class_name = "dining table";
  written[2].class_id = cocoClassId("dining table");
  written[2].score = 1.0f;
  written[2].mask = cv::Mat::zeros(24, 32, CV_8UC1);
  written[2].mask(cv::Rect(0, 15, 32, 9)).setTo(7);  // any non-zero value is the object
  written[2].box_px = cv::Rect(0, 15, 32, 9);

  const Status status = FileInstanceSegmenter::write(dir_.string(), "frame-000010", written);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(fs::exists(dir_ / "frame-000010.json"));
  EXPECT_TRUE(fs::exists(dir_ / "frame-000010.0.png"));
  EXPECT_FALSE(fs::exists(dir_ / "frame-000010.1.png"));
  EXPECT_TRUE(fs::exists(dir_ / "frame-000010.2.png"));

  std::vector<Detection2D> read;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detect(&read, &warnings).ok());
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  ASSERT_EQ(read.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(read[k].class_name, written[k].class_name);
    EXPECT_EQ(read[k].class_id, cocoClassId(written[k].class_name));
    EXPECT_GE(read[k].class_id, 0);
    EXPECT_FLOAT_EQ(read[k].score, written[k].score);
    EXPECT_EQ(read[k].box_px, written[k].box_px);
    EXPECT_FLOAT_EQ(read[k].mask_cell_px, written[k].mask_cell_px);  // 0: none written
    ASSERT_EQ(read[k].mask.type(), CV_8UC1);
    ASSERT_EQ(read[k].mask.size(), image_.size());
  }
  EXPECT_TRUE(sameMask(read[0].mask, written[0].mask));
  EXPECT_TRUE(sameMask(read[2].mask, written[2].mask));
  cv::Mat box_mask = cv::Mat::zeros(24, 32, CV_8UC1);
  box_mask(written[1].box_px).setTo(255);
  EXPECT_TRUE(sameMask(read[1].mask, box_mask));
  EXPECT_EQ(cv::countNonZero(read[1].mask), 20);

  // A frame without a file has no detections and is no error; other frames are untouched.
  read.assign(2, Detection2D());
  ASSERT_TRUE(detect(&read, &warnings, "frame-000011").ok());
  EXPECT_TRUE(read.empty());

  // An empty image or frame name is an error.
  FileInstanceSegmenter segmenter(dir_.string());
  EXPECT_FALSE(segmenter.detect(cv::Mat(), "frame-000010", &read).ok());
  EXPECT_FALSE(segmenter.detect(image_, "", &read).ok());
  EXPECT_EQ(segmenter.name(), "files");
}

TEST_F(FileInstanceSegmenterTest, MalformedDocumentIsAnError) {
  const std::string path = (dir_ / "frame-000010.json").string();
  for (const char* text :
       {"[{\"class_name\": \"chair\", ", "{\"class_name\": \"chair\"}", "42", ""}) {
    writeText("frame-000010.json", text);
    std::vector<Detection2D> read(1);
    const Status status = detect(&read, nullptr);
    ASSERT_FALSE(status.ok()) << "'" << text << "'";
    EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
    EXPECT_TRUE(read.empty());
  }
  writeText("frame-000010.json", "[]");
  std::vector<Detection2D> read;
  EXPECT_TRUE(detect(&read, nullptr).ok());
  EXPECT_TRUE(read.empty());
}

TEST_F(FileInstanceSegmenterTest, BadEntriesAreSkippedWithAWarning) {
  cv::Mat small_mask(10, 10, CV_8UC1, cv::Scalar(255));
  ASSERT_TRUE(cv::imwrite((dir_ / "small.png").string(), small_mask));
  writeText("frame-000010.json",
            "[\n"
            " {\"class_name\": \"unicorn\", \"score\": 0.9, \"box\": [1, 1, 5, 5]},\n"
            " {\"class_name\": \"chair\", \"score\": 0.8, \"box\": [1, 1, 5, 5]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.7, \"box\": [0, 0, 4, 4], \"mask\": "
            "\"small.png\"},\n"
            " {\"class_name\": \"cup\", \"score\": 0.7, \"box\": [0, 0, 4, 4], \"mask\": "
            "\"missing.png\"},\n"
            " {\"class_name\": \"cup\", \"score\": \"high\", \"box\": [0, 0, 4, 4]},\n"
            " {\"class_name\": \"cup\", \"score\": 1.5, \"box\": [0, 0, 4, 4]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [0, 0, 4]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [5, 5, 2, 8]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [40, 30, 50, 35]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5},\n"
            " {\"class_name\": 3, \"score\": 0.5, \"box\": [0, 0, 4, 4]},\n"
            " \"not an object\",\n"
            " {\"class_id\": 62, \"score\": 0.6, \"box\": [2, 2, 6, 6]},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [0, 0, 4, 4], "
            "\"mask_cell_px\": -4},\n"
            " {\"class_name\": \"cup\", \"score\": 0.5, \"box\": [0, 0, 4, 4], "
            "\"mask_cell_px\": \"4\"}\n"
            "]\n");
  std::vector<Detection2D> read;
  std::vector<std::string> warnings;
  const Status status = detect(&read, &warnings);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].class_name, "chair");
  EXPECT_EQ(read[0].class_id, cocoClassId("chair"));
  EXPECT_EQ(read[1].class_name, cocoClassNames()[62]);  // named from its class_id
  ASSERT_EQ(warnings.size(), 13u);
  const std::string path = (dir_ / "frame-000010.json").string();
  for (const std::string& warning : warnings) {
    EXPECT_EQ(warning.rfind(path, 0), 0u) << warning;
  }
  EXPECT_NE(warnings[0].find("entry 0"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("unknown class 'unicorn'"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find("entry 2"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[1].find("10x10"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[2].find("missing.png"), std::string::npos) << warnings[2];
  EXPECT_NE(warnings[11].find("mask_cell_px"), std::string::npos) << warnings[11];
  EXPECT_NE(warnings[12].find("mask_cell_px"), std::string::npos) << warnings[12];

  // Without a warnings vector the good entries still come through.
  ASSERT_TRUE(detect(&read, nullptr).ok());
  EXPECT_EQ(read.size(), 2u);
}

TEST_F(FileInstanceSegmenterTest, BoxesAreClippedAndMasksGiveBoxes) {
  cv::Mat mask = cv::Mat::zeros(24, 32, CV_8UC1);
  mask(cv::Rect(3, 4, 6, 5)).setTo(255);
  ASSERT_TRUE(cv::imwrite((dir_ / "m.png").string(), mask));
  writeText("frame-000010.json",
            "[{\"class_name\": \"tv\", \"score\": 0.9, \"box\": [-5, -3, 10, 8]},\n"
            " {\"class_name\": \"tv\", \"score\": 0.9, \"box\": [1.5, 2.2, 4.1, 5]},\n"
            " {\"class_name\": \"tv\", \"score\": 0.9, \"box\": [20, 10, 40, 30]},\n"
            " {\"class_name\": \"tv\", \"score\": 0.9, \"mask\": \"m.png\"},\n"
            " {\"class_name\": \"tv\", \"score\": 0.9, \"box\": [0, 0, 32, 24], \"mask\": \"" +
                (dir_ / "m.png").string() + "\"}]");
  std::vector<Detection2D> read;
  std::vector<std::string> warnings;
  ASSERT_TRUE(detect(&read, &warnings).ok());
  ASSERT_EQ(read.size(), 5u) << (warnings.empty() ? "" : warnings.front());
  EXPECT_EQ(read[0].box_px, cv::Rect(0, 0, 10, 8));
  EXPECT_EQ(cv::countNonZero(read[0].mask), 80);
  EXPECT_EQ(read[1].box_px, cv::Rect(1, 2, 4, 3));
  EXPECT_EQ(read[2].box_px, cv::Rect(20, 10, 12, 14));
  EXPECT_EQ(cv::countNonZero(read[2].mask), 12 * 14);
  EXPECT_EQ(read[3].box_px, cv::Rect(3, 4, 6, 5));  // from the mask
  EXPECT_TRUE(sameMask(read[3].mask, mask));
  EXPECT_EQ(read[4].box_px, cv::Rect(0, 0, 32, 24));  // the given box; the mask stays the mask
  EXPECT_TRUE(sameMask(read[4].mask, mask));          // absolute mask path
}

}  // namespace
}  // namespace mvod
