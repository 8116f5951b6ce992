// PLY vertex clouds: the SceneNN meshes (<id>.ply, per-vertex `label`), the synthetic
// SceneNN-layout sequences' surfaces and offline_detection --save-clouds clouds. PCL stays in the
// .cpp.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// The x, y, z of the first `vertex` element (ascii or binary_little_endian; any scalar types; other
// elements, such as faces, before or after it are skipped). With labels non-null, the vertex
// property `label` is required and returned per vertex. On error (the message names the file) the
// outputs are left untouched.
Status readPlyVertices(const std::string& path, PointCloud* points, std::vector<int>* labels);

}  // namespace mvod
