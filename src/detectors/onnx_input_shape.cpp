#include "multiview_object_detection/detectors/onnx_input_shape.h"

#include <sys/stat.h>

#include <fstream>

namespace mvod {
namespace {

// ONNX field numbers (onnx.proto): ModelProto.graph = 7; GraphProto.input = 11;
// ValueInfoProto.name = 1, .type = 2; TypeProto.tensor_type = 1; TypeProto.Tensor.shape = 2;
// TensorShapeProto.dim = 1; Dimension.dim_value = 1 (varint), .dim_param = 2 (string).
constexpr uint32_t kModelGraph = 7;
constexpr uint32_t kGraphInput = 11;
constexpr uint32_t kValueInfoName = 1;
constexpr uint32_t kValueInfoType = 2;
constexpr uint32_t kTypeTensor = 1;
constexpr uint32_t kTensorShape = 2;
constexpr uint32_t kShapeDim = 1;
constexpr uint32_t kDimValue = 1;

enum WireType : uint32_t { kVarint = 0, kFixed64 = 1, kLengthDelimited = 2, kFixed32 = 5 };

// A read-only view of protobuf bytes: [begin, end) of `data`.
struct Span {
  const std::string* data;
  size_t begin;
  size_t end;
};

bool readVarint(const Span& span, size_t* at, uint64_t* value) {
  *value = 0;
  for (int shift = 0; shift < 64 && *at < span.end; shift += 7) {
    const auto byte = static_cast<uint8_t>((*span.data)[(*at)++]);
    *value |= static_cast<uint64_t>(byte & 0x7f) << shift;
    if ((byte & 0x80) == 0) return true;
  }
  return false;
}

// One field of a message: its number and wire type; for a length-delimited field its payload,
// for a varint its value. False at the end of the span or on a malformed field.
struct Field {
  uint32_t number = 0;
  uint32_t wire = 0;
  uint64_t varint = 0;
  Span payload{nullptr, 0, 0};
};

bool nextField(const Span& span, size_t* at, Field* field, bool* malformed) {
  *malformed = false;
  if (*at >= span.end) return false;
  uint64_t key = 0;
  if (!readVarint(span, at, &key)) return !(*malformed = true);
  field->number = static_cast<uint32_t>(key >> 3);
  field->wire = static_cast<uint32_t>(key & 7);
  switch (field->wire) {
    case kVarint:
      if (!readVarint(span, at, &field->varint)) return !(*malformed = true);
      return true;
    case kFixed64:
    case kFixed32: {
      const size_t width = field->wire == kFixed64 ? 8 : 4;
      if (span.end - *at < width) return !(*malformed = true);
      *at += width;
      return true;
    }
    case kLengthDelimited: {
      uint64_t length = 0;
      if (!readVarint(span, at, &length) || length > span.end - *at) {
        return !(*malformed = true);
      }
      field->payload = Span{span.data, *at, *at + static_cast<size_t>(length)};
      *at += static_cast<size_t>(length);
      return true;
    }
    default:
      return !(*malformed = true);
  }
}

// The first length-delimited field `number` of the message in `span`.
bool findMessage(const Span& span, uint32_t number, Span* found, bool* malformed) {
  size_t at = span.begin;
  Field field;
  while (nextField(span, &at, &field, malformed)) {
    if (field.number == number && field.wire == kLengthDelimited) {
      *found = field.payload;
      return true;
    }
  }
  return false;
}

bool parseDims(const Span& shape, std::vector<int64_t>* dims, bool* malformed) {
  size_t at = shape.begin;
  Field field;
  while (nextField(shape, &at, &field, malformed)) {
    if (field.number != kShapeDim || field.wire != kLengthDelimited) continue;
    int64_t value = -1;
    size_t dim_at = field.payload.begin;
    Field dim_field;
    while (nextField(field.payload, &dim_at, &dim_field, malformed)) {
      if (dim_field.number == kDimValue && dim_field.wire == kVarint) {
        value = static_cast<int64_t>(dim_field.varint);
      }
    }
    if (*malformed) return false;
    dims->push_back(value);
  }
  return !*malformed;
}

bool parseInput(const Span& value_info, OnnxInput* input, bool* malformed) {
  size_t at = value_info.begin;
  Field field;
  while (nextField(value_info, &at, &field, malformed)) {
    if (field.wire != kLengthDelimited) continue;
    if (field.number == kValueInfoName) {
      input->name.assign(*field.payload.data, field.payload.begin,
                         field.payload.end - field.payload.begin);
    } else if (field.number == kValueInfoType) {
      Span tensor, shape;
      if (findMessage(field.payload, kTypeTensor, &tensor, malformed) &&
          findMessage(tensor, kTensorShape, &shape, malformed) &&
          !parseDims(shape, &input->dims, malformed)) {
        return false;
      }
      if (*malformed) return false;
    }
  }
  return !*malformed;
}

}  // namespace

Status readOnnxInputs(const std::string& path, std::vector<OnnxInput>* inputs) {
  inputs->clear();
  struct stat info;
  if (::stat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode)) {
    return Status::Error("'" + path + "' is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  std::string bytes(static_cast<size_t>(info.st_size), '\0');
  if (!in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()))) {
    return Status::Error("cannot read '" + path + "'");
  }
  const Span file{&bytes, 0, bytes.size()};
  Span graph;
  bool malformed = false;
  if (!findMessage(file, kModelGraph, &graph, &malformed)) {
    return Status::Error("'" + path + "' is not an ONNX model (" +
                         (malformed ? "a malformed field" : "no graph") + ")");
  }
  size_t at = graph.begin;
  Field field;
  while (nextField(graph, &at, &field, &malformed)) {
    if (field.number != kGraphInput || field.wire != kLengthDelimited) continue;
    OnnxInput input;
    if (!parseInput(field.payload, &input, &malformed)) break;
    inputs->push_back(std::move(input));
  }
  if (malformed) {
    inputs->clear();
    return Status::Error("'" + path + "' is not an ONNX model (a malformed field in its graph)");
  }
  return Status::Ok();
}

}  // namespace mvod
