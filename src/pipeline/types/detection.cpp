#include "multiview_object_detection/pipeline/types/detection.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace mvod {

bool maskOrigin(const Detection2D& detection, const cv::Size& image_size, cv::Point* origin) {
  const cv::Mat& mask = detection.mask;
  if (mask.empty() || mask.type() != CV_8UC1) return false;
  if (mask.size() == image_size) {
    *origin = cv::Point(0, 0);
    return true;
  }
  const cv::Rect image_rect(cv::Point(0, 0), image_size);
  if (mask.size() == detection.box_px.size() &&
      (detection.box_px & image_rect) == detection.box_px) {
    *origin = detection.box_px.tl();
    return true;
  }
  return false;
}

cv::Mat maskInRegion(const Detection2D& detection, const cv::Size& image_size,
                     const cv::Rect& region) {
  cv::Mat out(region.size(), CV_8UC1, cv::Scalar(0));
  cv::Point origin;
  if (!maskOrigin(detection, image_size, &origin)) return out;
  const cv::Rect mask_rect(origin, detection.mask.size());
  const cv::Rect overlap = mask_rect & region;
  if (overlap.empty()) return out;
  detection.mask(overlap - origin).copyTo(out(overlap - region.tl()));
  return out;
}

cv::Rect nonZeroBounds(const cv::Mat& mask) {
  CV_Assert(mask.type() == CV_8UC1);
  int top = -1;
  int bottom = -1;
  int left = mask.cols;
  int right = -1;
  for (int y = 0; y < mask.rows; ++y) {
    const std::uint8_t* row = mask.ptr<std::uint8_t>(y);
    int x = 0;
    for (std::uint64_t word = 0; x + 8 <= mask.cols; x += 8) {
      std::memcpy(&word, row + x, sizeof(word));
      if (word != 0) break;
    }
    while (x < mask.cols && row[x] == 0) ++x;
    if (x == mask.cols) continue;  // an empty row
    if (top < 0) top = y;
    bottom = y;
    left = std::min(left, x);
    // From the right, down to the rightmost column found so far (row[x] stops it in any case).
    int r = mask.cols - 1;
    for (std::uint64_t word = 0; r - 7 > right; r -= 8) {
      std::memcpy(&word, row + r - 7, sizeof(word));
      if (word != 0) break;
    }
    while (r > right && row[r] == 0) --r;
    right = std::max(right, r);
  }
  if (top < 0) return cv::Rect();
  return cv::Rect(left, top, right - left + 1, bottom - top + 1);
}

void cropMaskToBox(Detection2D* detection, const cv::Size& image_size) {
  const cv::Rect image_rect(cv::Point(0, 0), image_size);
  if (detection->mask.size() != image_size || detection->mask.type() != CV_8UC1) return;
  const cv::Rect box = detection->box_px & image_rect;
  if (box != detection->box_px || box.empty() || box == image_rect) return;
  detection->mask = detection->mask(box).clone();
}

}  // namespace mvod
