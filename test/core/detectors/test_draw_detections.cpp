#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "multiview_object_detection/detectors/segmenter_factory.h"

namespace mvod {
namespace {

int countColour(const cv::Mat& image, const cv::Vec3b& colour) {
  int count = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) count += image.at<cv::Vec3b>(y, x) == colour;
  }
  return count;
}

// Two boxes with the same top-left corner (a person and the chair they sit on): each label is a
// filled patch of its class colour, and neither covers the other.
TEST(DrawDetections, LabelsOfBoxesSharingACornerBothShow) {
  Detection2D a, b;
  a.class_id = 56;
  a.class_name = "chair";
  a.score = 0.9f;
  a.box_px = cv::Rect(50, 60, 80, 80);
  b = a;
  b.class_id = 0;
  b.class_name = "person";
  b.score = 0.8f;
  b.box_px = cv::Rect(50, 60, 60, 100);
  const cv::Mat image = drawDetections(cv::Mat(220, 240, CV_8UC3, cv::Scalar(0, 0, 0)), {a, b});
  // Each box's bottom edge, where the other box draws nothing, gives its colour.
  const cv::Vec3b colour_a = image.at<cv::Vec3b>(139, 90);
  const cv::Vec3b colour_b = image.at<cv::Vec3b>(159, 80);
  ASSERT_NE(colour_a, cv::Vec3b(0, 0, 0));
  ASSERT_NE(colour_b, cv::Vec3b(0, 0, 0));
  ASSERT_NE(colour_a, colour_b);
  // Outside the boxes only the labels are drawn: each fills most of a text-sized patch there.
  cv::Mat outside = image.clone();
  cv::rectangle(outside, cv::Rect(48, 58, 84, 104), cv::Scalar(0, 0, 0), cv::FILLED);
  EXPECT_GT(countColour(outside, colour_a), 300);
  EXPECT_GT(countColour(outside, colour_b), 300);
}

}  // namespace
}  // namespace mvod
