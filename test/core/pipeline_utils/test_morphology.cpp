// erodeWithEllipse against OpenCV's erode with the same elliptic kernel.
#include <gtest/gtest.h>

#include <chrono>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <random>

#include "multiview_object_detection/pipeline/utils/morphology.h"

namespace mvod {
namespace {

cv::Mat openCvErode(const cv::Mat& mask, int radius_px) {
  cv::Mat out;
  cv::erode(
      mask, out,
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_px + 1, 2 * radius_px + 1)));
  return out;
}

// Blobs (filled ellipses and rectangles), holes and speckle, some touching the image border.
cv::Mat randomMask(int rows, int cols, std::mt19937* rng) {
  cv::Mat mask(rows, cols, CV_8UC1, cv::Scalar(0));
  std::uniform_int_distribution<int> x(-20, cols + 20);
  std::uniform_int_distribution<int> y(-20, rows + 20);
  std::uniform_int_distribution<int> size(3, std::max(rows, cols) / 2);
  for (int k = 0; k < 6; ++k) {
    cv::ellipse(mask, cv::Point(x(*rng), y(*rng)), cv::Size(size(*rng), size(*rng)), 17.0 * k, 0,
                360, cv::Scalar(255), cv::FILLED);
    cv::rectangle(mask, cv::Rect(x(*rng), y(*rng), size(*rng), size(*rng)), cv::Scalar(255),
                  cv::FILLED);
  }
  for (int k = 0; k < 4; ++k) {
    cv::circle(mask, cv::Point(x(*rng), y(*rng)), size(*rng) / 4, cv::Scalar(0), cv::FILLED);
  }
  std::uniform_int_distribution<int> speckle_x(0, cols - 1);
  std::uniform_int_distribution<int> speckle_y(0, rows - 1);
  for (int k = 0; k < rows * cols / 200; ++k) {
    mask.at<std::uint8_t>(speckle_y(*rng), speckle_x(*rng)) ^= 255;
  }
  return mask;
}

}  // namespace

TEST(Morphology, ErodeWithEllipseIsOpenCvsErode) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 12; ++trial) {
    const cv::Mat mask = randomMask(40 + 23 * trial, 60 + 17 * trial, &rng);
    for (const int radius : {0, 1, 2, 3, 5, 8, 13, 30}) {
      cv::Mat ours;
      erodeWithEllipse(mask, radius, &ours);
      const cv::Mat expected = radius > 0 ? openCvErode(mask, radius) : mask;
      ASSERT_EQ(ours.size(), mask.size());
      ASSERT_EQ(ours.type(), CV_8UC1);
      EXPECT_EQ(cv::countNonZero(ours != expected), 0)
          << "trial " << trial << " radius " << radius << ": " << cv::countNonZero(ours)
          << " pixels kept, OpenCV " << cv::countNonZero(expected);
    }
  }
  // Degenerate sizes.
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 9), cv::Size(9, 1)}) {
    const cv::Mat full(size, CV_8UC1, cv::Scalar(255));
    cv::Mat ours;
    erodeWithEllipse(full, 4, &ours);
    EXPECT_EQ(cv::countNonZero(ours != openCvErode(full, 4)), 0);
  }
}

TEST(Morphology, ErodeWithEllipseTiming) {
  // A detection's mask of 400 x 300 pixels eroded by 15 % of its shorter side (the segment
  // selector's core): reported, not asserted.
  cv::Mat mask(340, 440, CV_8UC1, cv::Scalar(0));
  cv::ellipse(mask, cv::Point(220, 170), cv::Size(200, 150), 0, 0, 360, cv::Scalar(255),
              cv::FILLED);
  const int radius = 45;
  const auto time_ms = [](const auto& run) {
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < 5; ++k) run();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
               .count() /
           5;
  };
  cv::Mat ours;
  cv::Mat theirs;
  const double ours_ms = time_ms([&] { erodeWithEllipse(mask, radius, &ours); });
  const double theirs_ms = time_ms([&] { theirs = openCvErode(mask, radius); });
  EXPECT_EQ(cv::countNonZero(ours != theirs), 0);
  std::cout << "erode 440x340, radius 45: erodeWithEllipse " << ours_ms << " ms, cv::erode "
            << theirs_ms << " ms\n";
}

}  // namespace mvod
