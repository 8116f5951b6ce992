#include "multiview_object_detection/evaluation/map_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

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

}  // namespace

cv::Mat drawBirdsEyeMap(const std::vector<GroundTruthObject>& ground_truth,
                        const std::vector<EvaluatedPrediction>& predictions,
                        const Eigen::Vector3d& up_W, const BirdsEyeConfig& config) {
  const Eigen::Vector3d up = up_W.norm() > 1e-9 ? up_W.normalized() : Eigen::Vector3d::UnitZ();
  Eigen::Index axis = 0;
  up.cwiseAbs().minCoeff(&axis);
  Eigen::Vector3d e1 = Eigen::Vector3d::Unit(axis);
  e1 = (e1 - e1.dot(up) * up).normalized();
  const Eigen::Vector3d e2 = up.cross(e1);

  // Context points: the ground truth's, else the predicted clouds.
  std::vector<Eigen::Vector2d> points;
  size_t total = 0;
  for (const GroundTruthObject& g : ground_truth) total += g.points_W.size();
  const bool gt_points = total > 0;
  if (!gt_points) {
    for (const EvaluatedPrediction& p : predictions) total += p.points_W.size();
  }
  const size_t stride = std::max<size_t>(1, total / std::max(1, config.max_points));
  size_t counter = 0;
  auto add_points = [&](const PointCloud& cloud) {
    for (const Eigen::Vector3f& p : cloud) {
      if (counter++ % stride != 0 || !p.allFinite()) continue;
      const Eigen::Vector3d q = p.cast<double>();
      points.emplace_back(q.dot(e1), q.dot(e2));
    }
  };
  if (gt_points) {
    for (const GroundTruthObject& g : ground_truth) add_points(g.points_W);
  } else {
    for (const EvaluatedPrediction& p : predictions) add_points(p.points_W);
  }

  std::vector<std::vector<Eigen::Vector2d>> gt_boxes, pred_boxes;
  for (const GroundTruthObject& g : ground_truth) gt_boxes.push_back(footprint(g.box, up, e1, e2));
  for (const EvaluatedPrediction& p : predictions) {
    pred_boxes.push_back(footprint(p.box, up, e1, e2));
  }

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
  if (!(lo.x() <= hi.x())) {
    cv::Mat blank(240, 480, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(blank, "no objects", cv::Point(20, 120), cv::FONT_HERSHEY_SIMPLEX, 0.8,
                cv::Scalar(80, 80, 80), 2, cv::LINE_AA);
    return blank;
  }
  lo -= Eigen::Vector2d::Constant(config.margin_m);
  hi += Eigen::Vector2d::Constant(config.margin_m);
  const Eigen::Vector2d extent = hi - lo;
  double scale = config.pixels_per_m;
  const double longest = std::max(extent.x(), extent.y());
  if (longest * scale > config.max_size_px) scale = config.max_size_px / longest;
  const int legend_px = 28;
  const int width = std::max(320, static_cast<int>(std::ceil(extent.x() * scale)));
  const int height = static_cast<int>(std::ceil(extent.y() * scale)) + legend_px;
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  auto pixel = [&](const Eigen::Vector2d& q) {
    return cv::Point(static_cast<int>(std::lround((q.x() - lo.x()) * scale)),
                     legend_px + static_cast<int>(std::lround((hi.y() - q.y()) * scale)));
  };

  if (config.grid_spacing_m > 0.0) {
    const cv::Scalar grid(235, 235, 235);
    for (double x = std::ceil(lo.x() / config.grid_spacing_m) * config.grid_spacing_m; x <= hi.x();
         x += config.grid_spacing_m) {
      cv::line(image, pixel({x, lo.y()}), pixel({x, hi.y()}), grid, 1);
    }
    for (double y = std::ceil(lo.y() / config.grid_spacing_m) * config.grid_spacing_m; y <= hi.y();
         y += config.grid_spacing_m) {
      cv::line(image, pixel({lo.x(), y}), pixel({hi.x(), y}), grid, 1);
    }
  }
  for (const auto& q : points) {
    const cv::Point p = pixel(q);
    if (p.x >= 0 && p.y >= legend_px && p.x < width && p.y < height) {
      image.at<cv::Vec3b>(p) = cv::Vec3b(185, 185, 185);
    }
  }
  auto polygon = [&](const std::vector<Eigen::Vector2d>& box) {
    std::vector<cv::Point> pts;
    for (const auto& q : box) pts.push_back(pixel(q));
    return pts;
  };
  // Ground truth: translucent green footprints with a dark outline.
  if (!gt_boxes.empty()) {
    cv::Mat overlay = image.clone();
    for (const auto& box : gt_boxes) {
      cv::fillConvexPoly(overlay, polygon(box), cv::Scalar(150, 220, 150), cv::LINE_AA);
    }
    cv::addWeighted(overlay, 0.45, image, 0.55, 0.0, image);
    for (size_t i = 0; i < gt_boxes.size(); ++i) {
      cv::polylines(image, std::vector<std::vector<cv::Point>>{polygon(gt_boxes[i])}, true,
                    cv::Scalar(60, 140, 60), 1, cv::LINE_AA);
    }
  }
  // Predictions: class-coloured outlines, an arrow-free heading mark, and "id class p" labels.
  for (size_t i = 0; i < pred_boxes.size(); ++i) {
    const cv::Scalar color = classColorBgr(predictions[i].class_name);
    cv::polylines(image, std::vector<std::vector<cv::Point>>{polygon(pred_boxes[i])}, true, color,
                  2, cv::LINE_AA);
  }
  for (size_t i = 0; i < pred_boxes.size(); ++i) {
    const cv::Scalar color = classColorBgr(predictions[i].class_name);
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& q : pred_boxes[i]) centre += 0.25 * q;
    char text[96];
    std::snprintf(text, sizeof(text), "%d %s %.2f", predictions[i].id,
                  predictions[i].class_name.c_str(), predictions[i].probability);
    const cv::Point p = pixel(centre);
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline);
    const cv::Point origin(std::clamp(p.x - size.width / 2, 0, std::max(0, width - size.width)),
                           std::clamp(p.y + size.height / 2, legend_px + size.height, height - 2));
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 3,
                cv::LINE_AA);
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.4, color, 1, cv::LINE_AA);
  }

  char legend[160];
  std::snprintf(legend, sizeof(legend),
                "%zu detected (coloured, id class probability)%s  grid %.0f m", predictions.size(),
                ground_truth.empty() ? "" : ", ground truth green", config.grid_spacing_m);
  cv::putText(image, legend, cv::Point(8, 19), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  return image;
}

}  // namespace mvod
