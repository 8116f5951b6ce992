#include "multiview_object_detection/pipeline/detection.h"

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

void cropMaskToBox(Detection2D* detection, const cv::Size& image_size) {
  const cv::Rect image_rect(cv::Point(0, 0), image_size);
  if (detection->mask.size() != image_size || detection->mask.type() != CV_8UC1) return;
  const cv::Rect box = detection->box_px & image_rect;
  if (box != detection->box_px || box.empty() || box == image_rect) return;
  detection->mask = detection->mask(box).clone();
}

}  // namespace mvod
