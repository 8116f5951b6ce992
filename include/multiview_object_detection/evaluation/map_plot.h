// A bird's-eye PNG of an object map: box footprints (predicted, class-coloured, labelled) over the
// ground truth (grey footprints and points), seen from above along -up. For people to look at:
// `evaluate --plot` and `make demo` write it.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "multiview_object_detection/evaluation/evaluation.h"

namespace mvod {

struct BirdsEyeConfig {
  double pixels_per_m = 120.0;  // scale; the image grows with the map (capped at max_size_px)
  int max_size_px = 1600;       // longest image side; the scale shrinks to fit
  double margin_m = 0.5;        // around everything drawn
  double grid_spacing_m = 1.0;  // 0 = no grid
  int max_points = 60000;       // context points drawn (ground truth, else predicted clouds)
  // Only this part of the plan (m, in the grid's coordinates), drawn at max_size_px on its longer
  // side: a table top's mugs and books. Empty (the default): everything drawn, at pixels_per_m.
  Eigen::AlignedBox2d region;
};

// Plan view in the floor plane of up_W: image right = e1 (the world axis most orthogonal to up),
// image up = up x e1, so the view is from above. Empty inputs give a small blank image with a note.
cv::Mat drawBirdsEyeMap(const std::vector<GroundTruthObject>& ground_truth,
                        const std::vector<EvaluatedPrediction>& predictions,
                        const Eigen::Vector3d& up_W, const BirdsEyeConfig& config = {});

}  // namespace mvod
