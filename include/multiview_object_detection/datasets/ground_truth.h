// Ground truth of the evaluation (Sec. 4.1): the objects of a scene with their class, box and
// surface points, from this project's synthetic ground_truth.json (boxes, z-up) or from a SceneNN
// sequence (<id>.ply mesh with a per-vertex `label` + <id>.xml annotation, y-up mesh frame).
// Errors name the file.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"
#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

struct GroundTruthObject {
  std::string class_name;  // canonical evaluation class (see canonicalClassName)
  OrientedBox box;         // gravity-aligned: its footprint lies in the floor plane of `up`
  PointCloud points_W;     // may be empty: the evaluation then samples the box surface
};

// The synthetic ground_truth.json (SyntheticScene::writeSevenScenes). Points: an object's optional
// "points" ([[x, y, z], ...], e.g. its observed surface), else the box surface (sampleBoxSurface at
// spacing_m, bottom face left out): what a depth camera can see of the rendered box. Objects with
// an empty class_name (clutter) are skipped.
Status loadSyntheticGroundTruth(const std::string& path, double spacing_m,
                                const Eigen::Vector3d& up_W,
                                std::vector<GroundTruthObject>* objects);
// The world's up a synthetic ground_truth.json states ("up": [x, y, z], as the redkitchen
// annotation does); *found false (and *up_W untouched) when it states none.
Status readGroundTruthUp(const std::string& path, Eigen::Vector3d* up_W, bool* found);
// A SceneNN sequence: `path` is the <id> folder (with <id>.ply and <id>.xml) or the .ply itself
// (the .xml next to it). Points: the mesh vertices of each label with an evaluated class; box: the
// gravity-aligned box of those vertices (the XML obbox is documented as inaccurate). Labels with no
// vertex are skipped. The mesh frame is y-up: pass up_W = (0, 1, 0).
// skipped (optional): each annotated label left out, as "<its text> (<NYU class>): <why>".
Status loadSceneNNGroundTruth(const std::string& path, const Eigen::Vector3d& up_W,
                              std::vector<GroundTruthObject>* objects,
                              std::vector<std::string>* skipped = nullptr);

}  // namespace mvod
