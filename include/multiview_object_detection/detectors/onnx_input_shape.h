// The declared shape of an ONNX model's graph inputs, read from the file's protobuf without a
// protobuf library: OpenCV 4.6 does not report an ONNX network's input size, and a network
// exported for a fixed size (YOLOv5-seg at 640 or 320) fails on any other.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

struct OnnxInput {
  std::string name;
  // One entry per dimension: its size, or -1 where the file names it symbolically (a dynamic
  // export) or gives nothing.
  std::vector<int64_t> dims;
};

// The graph's inputs (initializers listed as inputs by older exporters included), in file order.
// An error for a file that is not a readable ONNX model (no graph, a truncated or malformed
// field).
Status readOnnxInputs(const std::string& path, std::vector<OnnxInput>* inputs);

}  // namespace mvod
