// Binary morphology on 8-bit masks, faster than OpenCV's for large round kernels.
#pragma once

#include <opencv2/core.hpp>

namespace mvod {

// The same result as cv::erode(mask, *eroded, cv::getStructuringElement(cv::MORPH_ELLIPSE,
// cv::Size(2 * radius_px + 1, 2 * radius_px + 1))) with OpenCV's default border (outside the image
// does not erode), for a CV_8UC1 mask of 0 and non-zero values (the output holds 0 and 255).
// OpenCV visits every pixel of a non-rectangular kernel, O(pixels x radius²); this takes the
// Euclidean distance transform, O(pixels), and checks the kernel's rows (one run length each) only
// for the pixels whose distance to the background is within half a pixel of the radius.
// radius_px <= 0 copies the mask (as 0 / 255).
void erodeWithEllipse(const cv::Mat& mask, int radius_px, cv::Mat* eroded);

}  // namespace mvod
