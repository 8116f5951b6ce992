#include "multiview_object_detection/pipeline/utils/morphology.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace mvod {

void erodeWithEllipse(const cv::Mat& mask, int radius_px, cv::Mat* eroded) {
  CV_Assert(mask.type() == CV_8UC1 && eroded != nullptr);
  const int rows = mask.rows;
  const int cols = mask.cols;
  cv::Mat out(mask.size(), CV_8UC1, cv::Scalar(0));
  if (radius_px <= 0) {
    out.setTo(255, mask);
    *eroded = out;
    return;
  }
  // The kernel's rows, read from OpenCV's own structuring element: row i covers columns
  // [first[i], last[i]] (relative to the anchor at its centre), or nothing.
  const int r = radius_px;
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
  std::vector<int> reach_left(2 * r + 1, -1);
  std::vector<int> reach_right(2 * r + 1, -1);
  for (int i = 0; i <= 2 * r; ++i) {
    const std::uint8_t* row = kernel.ptr<std::uint8_t>(i);
    for (int j = 0; j <= 2 * r; ++j) {
      if (row[j] == 0) continue;
      if (reach_left[i] < 0) reach_left[i] = r - j;
      reach_right[i] = j - r;
    }
  }
  // Per pixel, the runs of non-zero pixels through it to the left and to the right (itself
  // included; 0 on a zero pixel). The border does not erode: runs reaching it count as endless.
  constexpr int kEndless = std::numeric_limits<int>::max() / 2;
  cv::Mat left(mask.size(), CV_32SC1);
  cv::Mat right(mask.size(), CV_32SC1);
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    int* l = left.ptr<int>(y);
    int* rr = right.ptr<int>(y);
    int run = kEndless;
    for (int x = 0; x < cols; ++x) {
      run = m[x] != 0 ? (run == kEndless ? kEndless : run + 1) : 0;
      l[x] = run;
    }
    run = kEndless;
    for (int x = cols - 1; x >= 0; --x) {
      run = m[x] != 0 ? (run == kEndless ? kEndless : run + 1) : 0;
      rr[x] = run;
    }
  }
  // The kernel lies between the discs of radius r - 1/2 and r + 1/2 (its row half-widths are
  // round(sqrt(r² - dy²))): a pixel farther than r + 1/2 from every zero pixel stays, one within
  // r - 1/2 of one goes. Only the pixels in between (a band along the mask's border) need the
  // kernel's rows: on every row inside the image, the runs through the pixel below or above it
  // must cover that row's extent.
  cv::Mat distance;
  cv::distanceTransform(mask, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  const float surely_out = static_cast<float>(r - 0.5 - 1e-3);
  const float surely_in = static_cast<float>(r + 0.5 + 1e-3);
  for (int y = 0; y < rows; ++y) {
    std::uint8_t* o = out.ptr<std::uint8_t>(y);
    const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
    const float* d = distance.ptr<float>(y);
    for (int x = 0; x < cols; ++x) {
      if (m[x] == 0 || d[x] <= surely_out) continue;
      bool keep = true;
      if (d[x] <= surely_in) {
        for (int i = 0; i <= 2 * r && keep; ++i) {
          if (reach_left[i] < 0) continue;
          const int yy = y + i - r;
          if (yy < 0 || yy >= rows) continue;
          keep = left.ptr<int>(yy)[x] > reach_left[i] && right.ptr<int>(yy)[x] > reach_right[i];
        }
      }
      if (keep) o[x] = 255;
    }
  }
  *eroded = out;
}

}  // namespace mvod
