// SceneNN's annotation <id>.xml (shared/formats/scenenn.md): <annotation><label id=".." text=".."
// [nyu_class=".."] aabbox="xmin ymin zmin xmax ymax zmax" [obbox="cx cy cz dx dy dz qx qy qz qw"]
// .../>...</annotation>; a label's id is the PLY mesh's per-vertex `label`.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

struct SceneNNLabel {
  int id = 0;
  std::string text;
  std::string nyu_class;  // empty when absent
  Eigen::Vector3d aabb_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d aabb_max = Eigen::Vector3d::Zero();
  bool has_obbox = false;
  Eigen::Matrix<double, 10, 1> obbox;  // cx cy cz dx dy dz qx qy qz qw, as in the file
};

// The <label> elements of the <annotation> element, in file order (parsed with tinyxml2). id,
// text and aabbox are required, nyu_class and obbox optional; the message of an error names the
// file and the label. `labels` is left untouched on error.
Status readSceneNNXml(const std::string& path, std::vector<SceneNNLabel>* labels);

}  // namespace mvod
