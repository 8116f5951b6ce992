#include "multiview_object_detection/pipeline/utils/label_layout.h"

#include <algorithm>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace mvod {
namespace {

// Offsets within max_distance_px on a grid of step_px, nearest first (ties: vertical moves first,
// so a label sooner goes over or under its anchor than sideways).
std::vector<cv::Point> spotsNearestFirst(const LabelLayoutConfig& config) {
  const int step = std::max(1, config.step_px);
  const int reach = std::max(0, config.max_distance_px) / step;
  std::vector<cv::Point> offsets;
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      if (dx * dx + dy * dy <= reach * reach) offsets.emplace_back(dx * step, dy * step);
    }
  }
  std::stable_sort(offsets.begin(), offsets.end(), [](const cv::Point& a, const cv::Point& b) {
    const int da = a.x * a.x + a.y * a.y, db = b.x * b.x + b.y * b.y;
    return da != db ? da < db : std::abs(a.x) < std::abs(b.x);
  });
  return offsets;
}

// The rectangle moved (not resized) to lie inside bounds where it fits.
cv::Rect keepInside(cv::Rect rect, const cv::Rect& bounds) {
  rect.x = std::max(bounds.x, std::min(rect.x, bounds.x + bounds.width - rect.width));
  rect.y = std::max(bounds.y, std::min(rect.y, bounds.y + bounds.height - rect.height));
  return rect;
}

int coveredArea(const cv::Rect& rect, const std::vector<cv::Rect>& placed, int gap_px) {
  int area = 0;
  for (const cv::Rect& other : placed) {
    const cv::Rect grown(other.x - gap_px, other.y - gap_px, other.width + 2 * gap_px,
                         other.height + 2 * gap_px);
    area += (rect & grown).area();
  }
  return area;
}

}  // namespace

std::vector<cv::Rect> layoutLabels(const std::vector<cv::Point>& anchors,
                                   const std::vector<cv::Size>& sizes, const cv::Rect& bounds,
                                   const LabelLayoutConfig& config) {
  std::vector<cv::Rect> placed;
  if (anchors.size() != sizes.size()) return placed;
  const std::vector<cv::Point> offsets = spotsNearestFirst(config);
  for (size_t i = 0; i < anchors.size(); ++i) {
    const cv::Point corner(anchors[i].x - sizes[i].width / 2, anchors[i].y - sizes[i].height / 2);
    cv::Rect best = keepInside(cv::Rect(corner, sizes[i]), bounds);
    int best_covered = std::numeric_limits<int>::max();
    for (const cv::Point& offset : offsets) {
      const cv::Rect spot(corner + offset, sizes[i]);
      if ((spot & bounds) != spot) continue;
      const int covered = coveredArea(spot, placed, config.gap_px);
      if (covered < best_covered) {
        best = spot;
        best_covered = covered;
        if (covered == 0) break;
      }
    }
    placed.push_back(best);
  }
  return placed;
}

void drawLeaderLine(const cv::Point& anchor, const cv::Rect& label, const cv::Scalar& colour,
                    cv::Mat* image) {
  const cv::Point end(std::clamp(anchor.x, label.x, label.x + label.width - 1),
                      std::clamp(anchor.y, label.y, label.y + label.height - 1));
  cv::line(*image, anchor, end, colour, 1, cv::LINE_AA);
}

}  // namespace mvod
