#include "multiview_object_detection/evaluation/keyframe_overlay.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/pipeline/utils/label_layout.h"

namespace mvod {
namespace {

// Nearer than this to the colour camera a corner is not projected (behind it, or at its centre).
constexpr double kMinDepthM = 0.05;

// The box's 12 edges as corner index pairs (corner i has sign bits x: i&1, y: i&2, z: i&4).
constexpr int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                               {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

// The map's boxes: white at this opacity over the image, lighter than the detections.
constexpr double kBoxOpacity = 0.5;
// A map label placed farther than this from its box is left out (it would not read as the box's).
constexpr int kMaxLabelShiftPx = 24;

// The box's edges in white; false when none is in view, else *label_at is its topmost point.
bool drawBox(const RgbdFrame& frame, const Eigen::Isometry3d& T_C_W, const MapObject& object,
             cv::Mat* canvas, cv::Point* label_at) {
  const std::vector<Eigen::Vector3d> corners_W = object.box.corners();
  std::vector<cv::Point2d> pixels(corners_W.size());
  std::vector<bool> in_front(corners_W.size(), false);
  const CameraIntrinsics& K = frame.K_color;
  for (size_t i = 0; i < corners_W.size(); ++i) {
    const Eigen::Vector3d p_C = T_C_W * corners_W[i];
    if (!(p_C.z() > kMinDepthM)) continue;
    in_front[i] = true;
    pixels[i] = cv::Point2d(K.fx * p_C.x() / p_C.z() + K.cx, K.fy * p_C.y() / p_C.z() + K.cy);
  }
  const cv::Scalar colour(255, 255, 255);
  const cv::Rect image(cv::Point(), canvas->size());
  bool drawn = false;
  *label_at = cv::Point(canvas->cols, canvas->rows);
  for (const auto& edge : kEdges) {
    if (!in_front[edge[0]] || !in_front[edge[1]]) continue;
    cv::Point a(cvRound(pixels[edge[0]].x), cvRound(pixels[edge[0]].y));
    cv::Point b(cvRound(pixels[edge[1]].x), cvRound(pixels[edge[1]].y));
    if (!cv::clipLine(image, a, b)) continue;
    cv::line(*canvas, a, b, colour, 1, cv::LINE_AA);
    drawn = true;
    for (const cv::Point& p : {a, b}) {
      if (p.y < label_at->y || (p.y == label_at->y && p.x < label_at->x)) *label_at = p;
    }
  }
  return drawn;
}

// "#id class" over each drawn box's topmost point, at the free spot nearest it (label_layout.h),
// where one is free within kMaxLabelShiftPx and clear of the detections' labels; a label that does
// not fit there is left out.
void drawBoxLabels(const std::vector<cv::Point>& tops, const std::vector<std::string>& texts,
                   const std::vector<cv::Rect>& detection_labels, cv::Mat* canvas) {
  constexpr double kScale = 0.45;
  std::vector<cv::Point> anchors;
  std::vector<cv::Size> sizes;
  int baseline = 0;
  for (size_t i = 0; i < texts.size(); ++i) {
    const cv::Size text = cv::getTextSize(texts[i], cv::FONT_HERSHEY_SIMPLEX, kScale, 1, &baseline);
    sizes.emplace_back(text.width + 4, text.height + baseline + 2);
    anchors.emplace_back(tops[i].x + sizes.back().width / 2, tops[i].y - sizes.back().height / 2);
  }
  LabelLayoutConfig layout;
  layout.max_distance_px = kMaxLabelShiftPx;
  const std::vector<cv::Rect> spots =
      layoutLabels(anchors, sizes, cv::Rect(cv::Point(), canvas->size()), layout);
  const cv::Scalar white(255, 255, 255);
  // The detections' labels, drawn over these, count as taken.
  std::vector<cv::Rect> drawn = detection_labels;
  for (size_t i = 0; i < spots.size(); ++i) {
    const cv::Point centre(spots[i].x + spots[i].width / 2, spots[i].y + spots[i].height / 2);
    const bool overlaps = std::any_of(drawn.begin(), drawn.end(), [&](const cv::Rect& other) {
      return (other & spots[i]).area() > 0;
    });
    if (overlaps || cv::norm(centre - anchors[i]) > kMaxLabelShiftPx) continue;
    drawn.push_back(spots[i]);
    if (cv::norm(centre - anchors[i]) > 3.0) {
      drawLeaderLine(tops[i], spots[i], white, canvas);
    }
    const cv::Point origin(spots[i].x + 2, spots[i].y + spots[i].height - 1 - baseline);
    cv::putText(*canvas, texts[i], origin, cv::FONT_HERSHEY_SIMPLEX, kScale, cv::Scalar(0, 0, 0),
                3);
    cv::putText(*canvas, texts[i], origin, cv::FONT_HERSHEY_SIMPLEX, kScale, white, 1);
  }
}

}  // namespace

cv::Mat drawKeyframeOverlay(const RgbdFrame& frame, const std::vector<Detection2D>& detections,
                            const std::vector<int>& object_ids,
                            const std::vector<std::string>& drop_reasons,
                            const std::vector<MapObject>& objects) {
  // Each detection's label says where it went: the object it became (with that object's class
  // where it is another: evidence fusion lets a detection vote into the object its cut lies on),
  // or why it was not mapped.
  std::vector<Detection2D> labelled = detections;
  for (size_t k = 0; k < labelled.size(); ++k) {
    const int id = k < object_ids.size() ? object_ids[k] : -1;
    if (id >= 0) {
      const auto object = std::find_if(objects.begin(), objects.end(),
                                       [id](const MapObject& o) { return o.id == id; });
      const bool other_class =
          object != objects.end() && object->class_name != labelled[k].class_name;
      labelled[k].class_name +=
          " -> #" + std::to_string(id) + (other_class ? " " + object->class_name : "");
    } else {
      const std::string why = k < drop_reasons.size() ? drop_reasons[k] : "";
      labelled[k].class_name += why.empty() ? " (not mapped)" : " (not mapped: " + why + ")";
    }
  }
  // The map's boxes first, lighter (blended), the detections (and their labels) over them.
  cv::Mat canvas = frame.color_bgr.clone();
  cv::Mat boxes = canvas.clone();
  const Eigen::Isometry3d T_C_W = frame.T_C_D * frame.T_W_D.inverse();
  std::vector<cv::Point> tops;
  std::vector<std::string> texts;
  for (const MapObject& object : objects) {
    cv::Point top;
    if (!drawBox(frame, T_C_W, object, &boxes, &top)) continue;
    tops.push_back(top);
    texts.push_back("#" + std::to_string(object.id) + " " + object.class_name);
  }
  cv::addWeighted(boxes, kBoxOpacity, canvas, 1.0 - kBoxOpacity, 0.0, canvas);
  const DetectionLabels detection_labels = layoutDetectionLabels(labelled, canvas.size());
  drawBoxLabels(tops, texts, detection_labels.spots, &canvas);
  return drawDetections(canvas, labelled, detection_labels);
}

}  // namespace mvod
