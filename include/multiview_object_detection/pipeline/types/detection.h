// 2D instance detections and the interface every detector backend implements.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// One instance in a colour image. mask is CV_8UC1, non-zero = object, either box-sized (its pixel
// (0, 0) is box_px.tl(); what the detectors and the node store, so a detection costs its box, not
// a whole image) or the colour image's size (accepted from callers). A detector that only gives
// boxes fills the box.
struct Detection2D {
  int class_id = -1;  // index into cocoClassNames(), -1 when unknown
  std::string class_name;
  float score = 0.f;
  cv::Rect box_px;
  cv::Mat mask;
  // The side, in colour pixels, of the grid the detector computed the mask on: its border is
  // uncertain by about one cell (YOLOv5-seg's prototypes: 4 px at its 640 input on a 640-px-wide
  // image; Mask R-CNN's m x m mask stretched over the box). 0 = pixel-exact or not known.
  float mask_cell_px = 0.f;
};

// Where the mask's pixel (0, 0) lies in a colour image of `image_size`: box_px.tl() for a
// box-sized mask, (0, 0) for an image-sized one. False for an empty mask, a type other than
// CV_8UC1, or any other size.
bool maskOrigin(const Detection2D& detection, const cv::Size& image_size, cv::Point* origin);
// The mask over `region` of the colour image: CV_8UC1 of region's size, 0 where the mask does
// not reach. All zeros when maskOrigin() is false.
cv::Mat maskInRegion(const Detection2D& detection, const cv::Size& image_size,
                     const cv::Rect& region);
// The bounding rectangle of a CV_8UC1 mask's non-zero pixels (empty: Rect()), as cv::boundingRect
// gives it, skipping zero runs eight bytes at a time (most of an image-sized mask is zero).
cv::Rect nonZeroBounds(const cv::Mat& mask);
// Makes an image-sized mask box-sized (a copy of the box's pixels); other masks are left as they
// are.
void cropMaskToBox(Detection2D* detection, const cv::Size& image_size);

// Colour image -> instance detections. Implementations: FileInstanceSegmenter (precomputed JSON +
// PNG masks); the OpenCV DNN backends live in their own files.
class InstanceSegmenter {
 public:
  virtual ~InstanceSegmenter() = default;
  // frame_name identifies the frame for backends that read precomputed results (e.g.
  // "frame-000010"). Detections of classes the segmenter cannot name are dropped and reported
  // through `warnings`.
  virtual Status detect(const cv::Mat& image_bgr, const std::string& frame_name,
                        std::vector<Detection2D>* detections,
                        std::vector<std::string>* warnings = nullptr) = 0;
  virtual std::string name() const = 0;
};

}  // namespace mvod
