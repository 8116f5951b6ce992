#include "multiview_object_detection/evaluation/map_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/oriented_box.h"
#include "multiview_object_detection/pipeline/utils/label_layout.h"

namespace mvod {
namespace {

// A distinct, stable BGR colour per class name (golden-ratio hues), dark enough on white.
cv::Scalar classColorBgr(const std::string& name) {
  uint64_t h = 1469598103934665603ULL;
  for (const char c : name) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
  const double hue = std::fmod(static_cast<double>(h % 1000) * 0.618033988749895, 1.0) * 180.0;
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue, 220, 200));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

// The 4 footprint corners of a box in the plane (e1, e2), in order around the rectangle: of the
// box axes, the one most parallel to up is dropped.
std::vector<Eigen::Vector2d> footprint(const OrientedBox& box, const Eigen::Vector3d& up,
                                       const Eigen::Vector3d& e1, const Eigen::Vector3d& e2) {
  int vertical = 0;
  for (int a = 1; a < 3; ++a) {
    if (std::abs(box.rotation.col(a).dot(up)) > std::abs(box.rotation.col(vertical).dot(up))) {
      vertical = a;
    }
  }
  const int a = (vertical + 1) % 3;
  const int b = (vertical + 2) % 3;
  const Eigen::Vector3d da = 0.5 * box.size_m[a] * box.rotation.col(a);
  const Eigen::Vector3d db = 0.5 * box.size_m[b] * box.rotation.col(b);
  std::vector<Eigen::Vector2d> corners;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(box.center_m + da + db), Eigen::Vector3d(box.center_m + da - db),
        Eigen::Vector3d(box.center_m - da - db), Eigen::Vector3d(box.center_m - da + db)}) {
    corners.emplace_back(p.dot(e1), p.dot(e2));
  }
  return corners;
}

// The plan's axes: up, and e1, e2 spanning the floor plane (image right = e1, image up = e2).
struct PlanAxes {
  Eigen::Vector3d up, e1, e2;
};

PlanAxes planAxes(const Eigen::Vector3d& up_W) {
  PlanAxes axes;
  axes.up = up_W.norm() > 1e-9 ? up_W.normalized() : Eigen::Vector3d::UnitZ();
  Eigen::Index axis = 0;
  axes.up.cwiseAbs().minCoeff(&axis);
  axes.e1 = Eigen::Vector3d::Unit(axis);
  axes.e1 = (axes.e1 - axes.e1.dot(axes.up) * axes.up).normalized();
  axes.e2 = axes.up.cross(axes.e1);
  return axes;
}

// Context points in the plan: the ground truth's, else the predicted clouds, at most about
// max_points (every stride-th).
std::vector<Eigen::Vector2d> contextPoints(const std::vector<GroundTruthObject>& ground_truth,
                                           const std::vector<EvaluatedPrediction>& predictions,
                                           const PlanAxes& axes, int max_points) {
  std::vector<Eigen::Vector2d> points;
  size_t total = 0;
  for (const GroundTruthObject& g : ground_truth) total += g.points_W.size();
  const bool gt_points = total > 0;
  if (!gt_points) {
    for (const EvaluatedPrediction& p : predictions) total += p.points_W.size();
  }
  const size_t stride = std::max<size_t>(1, total / std::max(1, max_points));
  size_t counter = 0;
  auto add_points = [&](const PointCloud& cloud) {
    for (const Eigen::Vector3f& p : cloud) {
      if (counter++ % stride != 0 || !p.allFinite()) continue;
      const Eigen::Vector3d q = p.cast<double>();
      points.emplace_back(q.dot(axes.e1), q.dot(axes.e2));
    }
  };
  if (gt_points) {
    for (const GroundTruthObject& g : ground_truth) add_points(g.points_W);
  } else {
    for (const EvaluatedPrediction& p : predictions) add_points(p.points_W);
  }
  return points;
}

using Polygon2d = std::vector<Eigen::Vector2d>;

// The image: the plan's extent [lo, hi] at `scale` pixels per metre below a legend strip.
struct Canvas {
  Eigen::Vector2d lo, hi;
  double scale = 1.0;
  int legend_px = 46;  // two lines of legend above the plan
  int width = 0, height = 0;
  cv::Point pixel(const Eigen::Vector2d& q) const {
    return cv::Point(static_cast<int>(std::lround((q.x() - lo.x()) * scale)),
                     legend_px + static_cast<int>(std::lround((hi.y() - q.y()) * scale)));
  }
  std::vector<cv::Point> polygon(const Polygon2d& box) const {
    std::vector<cv::Point> pts;
    for (const auto& q : box) pts.push_back(pixel(q));
    return pts;
  }
};

// The extent of everything drawn plus the margin, scaled to fit max_size_px, or the region asked
// for at max_size_px. False: nothing finite.
bool fitCanvas(const std::vector<Eigen::Vector2d>& points, const std::vector<Polygon2d>& gt_boxes,
               const std::vector<Polygon2d>& pred_boxes, const BirdsEyeConfig& config,
               Canvas* canvas) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  auto extend = [&](const Eigen::Vector2d& q) {
    if (!q.allFinite()) return;
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  };
  for (const auto& q : points) extend(q);
  for (const auto& box : gt_boxes)
    for (const auto& q : box) extend(q);
  for (const auto& box : pred_boxes)
    for (const auto& q : box) extend(q);
  if (!(lo.x() <= hi.x())) return false;
  lo -= Eigen::Vector2d::Constant(config.margin_m);
  hi += Eigen::Vector2d::Constant(config.margin_m);
  const bool region = !config.region.isEmpty() && config.region.sizes().minCoeff() > 0.0;
  if (region) {
    lo = config.region.min();
    hi = config.region.max();
  }
  const Eigen::Vector2d extent = hi - lo;
  double scale = config.pixels_per_m;
  const double longest = std::max(extent.x(), extent.y());
  if (region || longest * scale > config.max_size_px) scale = config.max_size_px / longest;
  canvas->lo = lo;
  canvas->hi = hi;
  canvas->scale = scale;
  canvas->width = std::max(320, static_cast<int>(std::ceil(extent.x() * scale)));
  canvas->height = static_cast<int>(std::ceil(extent.y() * scale)) + canvas->legend_px;
  return true;
}

void drawGrid(const Canvas& canvas, double spacing_m, cv::Mat* image) {
  if (!(spacing_m > 0.0)) return;
  const cv::Scalar grid(235, 235, 235);
  const Eigen::Vector2d& lo = canvas.lo;
  const Eigen::Vector2d& hi = canvas.hi;
  for (double x = std::ceil(lo.x() / spacing_m) * spacing_m; x <= hi.x(); x += spacing_m) {
    cv::line(*image, canvas.pixel({x, lo.y()}), canvas.pixel({x, hi.y()}), grid, 1);
  }
  for (double y = std::ceil(lo.y() / spacing_m) * spacing_m; y <= hi.y(); y += spacing_m) {
    cv::line(*image, canvas.pixel({lo.x(), y}), canvas.pixel({hi.x(), y}), grid, 1);
  }
}

void drawPoints(const Canvas& canvas, const std::vector<Eigen::Vector2d>& points, cv::Mat* image) {
  for (const auto& q : points) {
    const cv::Point p = canvas.pixel(q);
    if (p.x >= 0 && p.y >= canvas.legend_px && p.x < canvas.width && p.y < canvas.height) {
      image->at<cv::Vec3b>(p) = cv::Vec3b(185, 185, 185);
    }
  }
}

// Ground truth: translucent green footprints with a dark outline.
void drawGroundTruth(const Canvas& canvas, const std::vector<Polygon2d>& gt_boxes, cv::Mat* image) {
  if (gt_boxes.empty()) return;
  cv::Mat overlay = image->clone();
  for (const auto& box : gt_boxes) {
    cv::fillConvexPoly(overlay, canvas.polygon(box), cv::Scalar(150, 220, 150), cv::LINE_AA);
  }
  cv::addWeighted(overlay, 0.45, *image, 0.55, 0.0, *image);
  for (size_t i = 0; i < gt_boxes.size(); ++i) {
    cv::polylines(*image, std::vector<std::vector<cv::Point>>{canvas.polygon(gt_boxes[i])}, true,
                  cv::Scalar(60, 140, 60), 1, cv::LINE_AA);
  }
}

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kLabelScale = 0.4;

// Text with a white halo, readable over lines and points.
void putHaloText(const std::string& text, const cv::Point& origin, const cv::Scalar& color,
                 double scale, cv::Mat* image) {
  cv::putText(*image, text, origin, kFont, scale, cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
  cv::putText(*image, text, origin, kFont, scale, color, 1, cv::LINE_AA);
}

// Predictions: class-coloured outlines, then "id class p" labels over all of them, each at the free
// spot nearest its box centre; a label pushed off its centre gets a thin line to it.
void drawPredictions(const Canvas& canvas, const std::vector<EvaluatedPrediction>& predictions,
                     const std::vector<Polygon2d>& pred_boxes, cv::Mat* image) {
  std::vector<cv::Point> anchors;
  std::vector<cv::Size> sizes;
  std::vector<std::string> texts;
  std::vector<int> baselines;
  for (size_t i = 0; i < pred_boxes.size(); ++i) {
    const cv::Scalar color = classColorBgr(predictions[i].class_name);
    cv::polylines(*image, std::vector<std::vector<cv::Point>>{canvas.polygon(pred_boxes[i])}, true,
                  color, 2, cv::LINE_AA);
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& q : pred_boxes[i]) centre += 0.25 * q;
    char text[96];
    std::snprintf(text, sizeof(text), "%d %s %.2f", predictions[i].id,
                  predictions[i].class_name.c_str(), predictions[i].probability);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, kFont, kLabelScale, 1, &baseline);
    anchors.push_back(canvas.pixel(centre));
    sizes.emplace_back(size.width + 2, size.height + baseline + 2);
    texts.emplace_back(text);
    baselines.push_back(baseline);
  }
  const cv::Rect plan(0, canvas.legend_px, canvas.width, canvas.height - canvas.legend_px);
  const std::vector<cv::Rect> spots = layoutLabels(anchors, sizes, plan);
  for (size_t i = 0; i < spots.size(); ++i) {
    const cv::Scalar color = classColorBgr(predictions[i].class_name);
    if (!spots[i].contains(anchors[i])) {
      drawLeaderLine(anchors[i], spots[i], color, image);
      cv::circle(*image, anchors[i], 2, color, cv::FILLED, cv::LINE_AA);
    }
  }
  for (size_t i = 0; i < spots.size(); ++i) {
    const cv::Point origin(spots[i].x + 1, spots[i].y + spots[i].height - 1 - baselines[i]);
    putHaloText(texts[i], origin, classColorBgr(predictions[i].class_name), kLabelScale, image);
  }
}

// Metres at the grid lines: x along the bottom edge, y along the left edge.
void drawGridValues(const Canvas& canvas, double spacing_m, cv::Mat* image) {
  if (!(spacing_m > 0.0)) return;
  const cv::Scalar grey(120, 120, 120);
  char text[32];
  for (double x = std::ceil(canvas.lo.x() / spacing_m) * spacing_m; x <= canvas.hi.x();
       x += spacing_m) {
    std::snprintf(text, sizeof(text), "%g", std::abs(x) < 1e-9 ? 0.0 : x);
    const cv::Point p = canvas.pixel({x, canvas.lo.y()});
    putHaloText(text, cv::Point(p.x + 3, canvas.height - 5), grey, 0.35, image);
  }
  for (double y = std::ceil(canvas.lo.y() / spacing_m) * spacing_m; y <= canvas.hi.y();
       y += spacing_m) {
    std::snprintf(text, sizeof(text), "%g", std::abs(y) < 1e-9 ? 0.0 : y);
    const cv::Point p = canvas.pixel({canvas.lo.x(), y});
    if (p.y - 4 < canvas.legend_px + 10) continue;
    putHaloText(text, cv::Point(3, p.y - 4), grey, 0.35, image);
  }
}

// "+x", "-z": the world axis a unit vector lies along; its components otherwise.
std::string axisName(const Eigen::Vector3d& e) {
  for (int k = 0; k < 3; ++k) {
    if (std::abs(e[k]) > 0.999) return std::string(e[k] > 0 ? "+" : "-") + "xyz"[k];
  }
  const Eigen::Vector3d rounded = (e * 100.0).array().round() / 100.0 + 0.0;  // no "-0.00"
  char text[64];
  std::snprintf(text, sizeof(text), "(%.2f, %.2f, %.2f)", rounded.x() + 0.0, rounded.y() + 0.0,
                rounded.z() + 0.0);
  return text;
}

// Two lines: what is drawn, then how to read the plan (view, axes, units, grid).
void drawLegend(const Canvas& canvas, const PlanAxes& axes, size_t num_predictions,
                bool ground_truth, const BirdsEyeConfig& config, cv::Mat* image) {
  char what[160], how[200];
  std::snprintf(what, sizeof(what), "%zu detected (coloured: id class probability)%s",
                num_predictions, ground_truth ? ", ground truth green" : "");
  std::snprintf(how, sizeof(how), "seen from above: up %s, right %s, top %s; m, grid %g m",
                axisName(axes.up).c_str(), axisName(axes.e1).c_str(), axisName(axes.e2).c_str(),
                config.grid_spacing_m);
  for (const auto& [text, y] :
       {std::make_pair(std::string(what), 18), std::make_pair(std::string(how), 38)}) {
    // Shrunk to the width of a narrow map rather than cut.
    int baseline = 0;
    const double width = cv::getTextSize(text, kFont, 0.5, 1, &baseline).width;
    const double scale = std::min(0.5, 0.5 * (canvas.width - 12) / std::max(1.0, width));
    cv::putText(*image, text, cv::Point(6, y), kFont, scale, cv::Scalar(40, 40, 40), 1,
                cv::LINE_AA);
  }
}

}  // namespace

cv::Mat drawBirdsEyeMap(const std::vector<GroundTruthObject>& ground_truth,
                        const std::vector<EvaluatedPrediction>& predictions,
                        const Eigen::Vector3d& up_W, const BirdsEyeConfig& config) {
  const PlanAxes axes = planAxes(up_W);
  const std::vector<Eigen::Vector2d> points =
      contextPoints(ground_truth, predictions, axes, config.max_points);
  std::vector<Polygon2d> gt_boxes, pred_boxes;
  for (const GroundTruthObject& g : ground_truth) {
    gt_boxes.push_back(footprint(g.box, axes.up, axes.e1, axes.e2));
  }
  for (const EvaluatedPrediction& p : predictions) {
    pred_boxes.push_back(footprint(p.box, axes.up, axes.e1, axes.e2));
  }
  Canvas canvas;
  if (!fitCanvas(points, gt_boxes, pred_boxes, config, &canvas)) {
    cv::Mat blank(240, 480, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(blank, "no objects", cv::Point(20, 120), cv::FONT_HERSHEY_SIMPLEX, 0.8,
                cv::Scalar(80, 80, 80), 2, cv::LINE_AA);
    return blank;
  }
  cv::Mat image(canvas.height, canvas.width, CV_8UC3, cv::Scalar(255, 255, 255));
  drawGrid(canvas, config.grid_spacing_m, &image);
  drawPoints(canvas, points, &image);
  drawGroundTruth(canvas, gt_boxes, &image);
  drawGridValues(canvas, config.grid_spacing_m, &image);
  drawPredictions(canvas, predictions, pred_boxes, &image);
  drawLegend(canvas, axes, predictions.size(), !ground_truth.empty(), config, &image);
  return image;
}

}  // namespace mvod
