// PLY files this project writes, returned as their bytes (the caller writes them).
//
// Written by hand, not with PCL's pcl::PLYWriter / pcl::io::savePLYFile, because the files must
// stay byte-identical to those of earlier releases (the synthetic datasets are compared with diff
// -r, offline_detection's clouds are read back by evaluate): PLYWriter always writes
// "comment PCL generated", fifteen obj_info lines and an empty face element (and by default a
// camera element), and formats ASCII numbers with the stream's precision (0.123457, 1e-05)
// instead of "%.4f" (checked against PCL 1.13's output).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// ASCII vertices "x y z" with 4 decimals (0.1 mm): offline_detection --save-clouds.
std::string plyAsciiXyz(const PointCloud& points);

struct PlyColoredVertex {
  float xyz[3] = {0.0f, 0.0f, 0.0f};
  uint8_t rgb[3] = {0, 0, 0};
  uint16_t label = 0;
};
// Binary little-endian vertices: float x, y, z, uchar red, green, blue, ushort label, with one
// comment line in the header. A SceneNN-layout mesh without faces (the synthetic sequences).
std::string plyBinaryColoredLabelled(const std::string& comment,
                                     const std::vector<PlyColoredVertex>& vertices);

}  // namespace mvod
