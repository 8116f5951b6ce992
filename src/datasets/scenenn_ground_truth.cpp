// SceneNN ground truth: the labelled mesh <id>.ply and the annotation <id>.xml of a sequence.
#include <filesystem>
#include <map>
#include <system_error>

#include "multiview_object_detection/datasets/class_names.h"
#include "multiview_object_detection/datasets/ground_truth.h"
#include "multiview_object_detection/datasets/ground_truth_geometry.h"
#include "multiview_object_detection/datasets/scenenn_annotation.h"
#include "multiview_object_detection/io/ply_reader.h"

namespace mvod {
namespace {

namespace fs = std::filesystem;

// <id>/<id>.ply and <id>/<id>.xml for the <id> folder, else the .ply given and the .xml beside it.
Status findSceneNNFiles(const std::string& path, fs::path* ply_path, fs::path* xml_path) {
  std::error_code error;
  if (fs::is_directory(path, error)) {
    fs::path dir = fs::path(path).lexically_normal();
    if (dir.filename().empty()) dir = dir.parent_path();
    const std::string id = dir.filename().string();
    *ply_path = dir / (id + ".ply");
    *xml_path = dir / (id + ".xml");
  } else {
    *ply_path = path;
    *xml_path = fs::path(path).replace_extension(".xml");
  }
  if (!fs::is_regular_file(*ply_path, error)) {
    return Status::Error(path + ": no SceneNN mesh " + ply_path->string());
  }
  if (!fs::is_regular_file(*xml_path, error)) {
    return Status::Error(path + ": no SceneNN annotation " + xml_path->string());
  }
  return Status::Ok();
}

// The mesh vertices of each label id but 0 (unlabelled).
Status readLabelledVertices(const fs::path& ply_path, std::map<int, PointCloud>* by_label) {
  PointCloud vertices;
  std::vector<int> vertex_labels;
  const Status status = readPlyVertices(ply_path.string(), &vertices, &vertex_labels);
  if (!status) return status;
  for (size_t i = 0; i < vertices.size(); ++i) {
    if (vertex_labels[i] != 0) (*by_label)[vertex_labels[i]].push_back(vertices[i]);
  }
  return Status::Ok();
}

}  // namespace

Status loadSceneNNGroundTruth(const std::string& path, const Eigen::Vector3d& up_W,
                              std::vector<GroundTruthObject>* objects,
                              std::vector<std::string>* skipped) {
  if (objects == nullptr) return Status::Error(path + ": no output");
  fs::path ply_path;
  fs::path xml_path;
  Status status = findSceneNNFiles(path, &ply_path, &xml_path);
  if (!status) return status;
  std::vector<SceneNNLabel> labels;
  if (!(status = readSceneNNXml(xml_path.string(), &labels))) return status;
  std::map<int, PointCloud> by_label;
  if (!(status = readLabelledVertices(ply_path, &by_label))) return status;
  std::vector<GroundTruthObject> parsed;
  std::vector<std::string> left_out;
  for (const SceneNNLabel& label : labels) {
    const std::string what = "'" + label.text + "' (" + label.nyu_class + ")";
    std::string name = sceneNNClassName(label.nyu_class);
    if (name.empty()) name = sceneNNClassName(label.text);
    if (name.empty()) {
      left_out.push_back(what +
                         ": not one of the 9 classes COCO and NYU share (the paper's Table 1)");
      continue;
    }
    const auto it = by_label.find(label.id);
    if (it == by_label.end() || it->second.empty()) {
      left_out.push_back(what + ": no vertex of the mesh carries its label");
      continue;
    }
    GroundTruthObject object;
    object.class_name = name;
    object.points_W = it->second;
    object.box = fitGravityAlignedBox(object.points_W, up_W);
    parsed.push_back(std::move(object));
  }
  *objects = std::move(parsed);
  if (skipped != nullptr) *skipped = std::move(left_out);
  return Status::Ok();
}

}  // namespace mvod
