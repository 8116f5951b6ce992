#include <gtest/gtest.h>

#include <vector>

#include "multiview_object_detection/pipeline/utils/label_layout.h"

namespace mvod {
namespace {

// Twelve labels on one spot, as round a table seen from above: none covers another.
TEST(LabelLayout, LabelsOnOneSpotSpreadWithoutOverlapInsideTheImage) {
  const cv::Rect bounds(0, 40, 400, 300);
  std::vector<cv::Point> anchors(12, cv::Point(200, 190));
  std::vector<cv::Size> sizes(12, cv::Size(90, 14));
  anchors.push_back(cv::Point(395, 335));  // at the corner: kept inside
  sizes.emplace_back(60, 14);
  const std::vector<cv::Rect> rects = layoutLabels(anchors, sizes, bounds);
  ASSERT_EQ(rects.size(), anchors.size());
  // The first is centred on its anchor.
  EXPECT_EQ(rects[0], cv::Rect(155, 183, 90, 14));
  for (size_t i = 0; i < rects.size(); ++i) {
    EXPECT_EQ(rects[i] & bounds, rects[i]) << i;
    EXPECT_EQ(rects[i].size(), sizes[i]);
    for (size_t j = i + 1; j < rects.size(); ++j) {
      EXPECT_EQ((rects[i] & rects[j]).area(), 0) << i << " and " << j;
    }
    // Near the anchor: within the search distance.
    const cv::Point centre(rects[i].x + rects[i].width / 2, rects[i].y + rects[i].height / 2);
    EXPECT_LE(cv::norm(centre - anchors[i]), 161.0) << i;
  }
  EXPECT_TRUE(layoutLabels({cv::Point(1, 1)}, {}, bounds).empty());  // mismatched lengths
}

// A moved label's line runs from its anchor to the label's nearest edge and stops there: it does
// not cross the text.
TEST(LabelLayout, ALeaderLineEndsAtTheLabelsNearestEdge) {
  cv::Mat image(100, 100, CV_8UC3, cv::Scalar::all(0));
  drawLeaderLine(cv::Point(10, 50), cv::Rect(60, 40, 20, 20), cv::Scalar::all(255), &image);
  const auto lit = [&](int x, int y) { return image.at<cv::Vec3b>(y, x)[0] > 0; };
  EXPECT_TRUE(lit(10, 50));
  EXPECT_TRUE(lit(35, 50));
  EXPECT_TRUE(lit(60, 50));
  EXPECT_FALSE(lit(62, 50)) << "the line runs into the label";
  EXPECT_FALSE(lit(70, 50));
  // From below the label: to its bottom edge, straight up.
  image.setTo(cv::Scalar::all(0));
  drawLeaderLine(cv::Point(70, 90), cv::Rect(60, 40, 20, 20), cv::Scalar::all(255), &image);
  EXPECT_TRUE(lit(70, 59));
  EXPECT_FALSE(lit(70, 57));
}

}  // namespace
}  // namespace mvod
