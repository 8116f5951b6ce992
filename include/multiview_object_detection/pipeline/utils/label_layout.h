// Text labels on an image without overlaps: each goes to the free spot nearest its anchor. For the
// pictures people read (the bird's-eye map, the keyframe overlays, the detections image), where the
// labels of objects close together would cover each other.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace mvod {

struct LabelLayoutConfig {
  int step_px = 3;            // between the spots tried around an anchor
  int max_distance_px = 160;  // farthest spot tried from an anchor
  int gap_px = 1;             // kept clear around each placed label
};

// Rectangles of `sizes`, in input order, each centred as near its anchor as possible while inside
// `bounds` and clear of every rectangle placed before it. A label with no free spot within
// max_distance_px goes where it covers the fewest pixels of earlier labels. Sizes and anchors must
// have the same length (else: empty result).
std::vector<cv::Rect> layoutLabels(const std::vector<cv::Point>& anchors,
                                   const std::vector<cv::Size>& sizes, const cv::Rect& bounds,
                                   const LabelLayoutConfig& config = {});

// A label placed away from its anchor is tied to it: a thin line from `anchor` to the point of
// `label` nearest it, drawn on `image`.
void drawLeaderLine(const cv::Point& anchor, const cv::Rect& label, const cv::Scalar& colour,
                    cv::Mat* image);

}  // namespace mvod
