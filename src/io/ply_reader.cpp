// PLY vertex clouds read with PCL's PLY parser, pcl::io::ply::ply_parser (libpcl_io_ply of
// Debian's libpcl-io): it reads the header, skips what has no callback (faces, colours, normals)
// and hands each vertex property to a callback here. Why the parser and not pcl::PLYReader /
// pcl::io::loadPLYFile (measured on this machine, PCL 1.13):
//  - PLYReader lives in libpcl_io, whose dependencies (VTK, OpenNI, libusb: 65 shared libraries)
//    add about 100 ms to the start of every program that links this io layer, the ROS node
//    included; libpcl_io_ply needs only the C++ runtime.
//  - PLYReader allocates the declared vertex count before it reads the body (a 200-byte header
//    claiming 4e9 vertices throws std::bad_alloc); here at most one vertex per byte of the file is
//    reserved.
//  - PLYReader prints a warning for every property it does not map (SceneNN's faces, alpha);
//    the parser's messages come back here and an error names the file and the line.
// Speed (a 1.5 M-vertex binary mesh with normals, colours, labels and 3 M faces, 84 MB, SceneNN's
// size): 0.25-0.31 s here (reading stops after the vertices), 0.7-1.1 s with PLYReader (the whole
// file), 1.5-1.7 s with this project's earlier hand-written reader.
// Same points and labels as that reader on the SceneNN-layout meshes, the synthetic sequences and
// the --save-clouds files (evaluate's tables compared byte for byte). Stricter on odd files: an
// ASCII item must be one line, list counts must be uchar, ushort or uint.
#include "multiview_object_detection/io/ply_reader.h"

#include <pcl/io/ply/ply_parser.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <system_error>
#include <tuple>

#include "multiview_object_detection/io/json_io.h"

namespace mvod {
namespace {

namespace ply = pcl::io::ply;

// Thrown from a parser callback to stop reading: after the last vertex (what follows, such as
// the faces, is not needed) or at a bad value (`error` set).
struct StopParsing {
  std::string error;
};

// What readFile (json_io.h) refuses is refused here too: a missing file, anything but a regular
// file (a FIFO would block the parser's stream) and files over kDefaultMaxFileBytes.
Status checkReadable(const std::string& path, uintmax_t* size) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (error) return Status::Error("cannot open " + path + ": " + error.message());
  if (!fs::is_regular_file(status)) {
    return Status::Error("cannot read " + path + ": it is not a regular file");
  }
  *size = fs::file_size(path, error);
  if (error) return Status::Error("cannot stat " + path + ": " + error.message());
  if (*size > kDefaultMaxFileBytes) {
    return Status::Error("cannot read " + path + ": " + std::to_string(*size) +
                         " bytes, more than the limit of " + std::to_string(kDefaultMaxFileBytes));
  }
  return Status::Ok();
}

// Collects x, y, z (and label) of the first `vertex` element from the parser's callbacks.
class VertexCollector {
 public:
  VertexCollector(bool want_labels, uintmax_t file_bytes)
      : want_labels_(want_labels), file_bytes_(file_bytes) {}

  void setUp(ply::ply_parser* parser) {
    parser->format_callback(
        [this](ply::format_type format, const std::string&) { format_ = format; });
    parser->element_definition_callback(
        [this](const std::string& name, std::size_t count) { return defineElement(name, count); });
    ply::ply_parser::scalar_property_definition_callbacks_type scalars;
    setScalarCallback<ply::int8>(&scalars);
    setScalarCallback<ply::int16>(&scalars);
    setScalarCallback<ply::int32>(&scalars);
    setScalarCallback<ply::uint8>(&scalars);
    setScalarCallback<ply::uint16>(&scalars);
    setScalarCallback<ply::uint32>(&scalars);
    setScalarCallback<ply::float32>(&scalars);
    setScalarCallback<ply::float64>(&scalars);
    parser->scalar_property_definition_callbacks(scalars);
    parser->end_header_callback([this]() { return checkHeader(); });
  }

  // The first problem found in the header ("" = none).
  const std::string& headerError() const { return header_error_; }
  PointCloud& points() { return points_; }
  std::vector<int>& labels() { return labels_; }

 private:
  enum Slot { kX = 0, kY, kZ, kLabel, kSlots };

  template <typename Scalar>
  void setScalarCallback(ply::ply_parser::scalar_property_definition_callbacks_type* scalars) {
    ply::ply_parser::at<Scalar>(*scalars) = [this](const std::string& element,
                                                   const std::string& property) {
      return defineScalar<Scalar>(element, property);
    };
  }

  ply::ply_parser::element_callbacks_type defineElement(const std::string& name,
                                                        std::size_t count) {
    const int index = num_elements_++;
    if (name == "vertex" && vertex_element_ < 0) {
      vertex_element_ = index;
      vertex_count_ = count;
      // Every vertex takes at least a byte: reserve no more than the file could hold.
      const size_t reserve = static_cast<size_t>(std::min<uintmax_t>(count, file_bytes_));
      points_.reserve(reserve);
      if (want_labels_) labels_.reserve(reserve);
      return {[this]() { beginElement(vertex_element_); }, [this]() { endVertex(); }};
    }
    return {[this, index]() { beginElement(index); }, []() {}};
  }

  template <typename Scalar>
  std::function<void(Scalar)> defineScalar(const std::string& element,
                                           const std::string& property) {
    if (element != "vertex") return {};
    int slot = -1;
    if (property == "x") slot = kX;
    if (property == "y") slot = kY;
    if (property == "z") slot = kZ;
    if (property == "label" && want_labels_) slot = kLabel;
    if (slot < 0) return {};  // not needed: the parser skips it
    have_[slot] = true;
    return [this, slot](Scalar value) { values_[slot] = static_cast<double>(value); };
  }

  bool checkHeader() {
    if (format_ == ply::binary_big_endian_format) {
      header_error_ = "unsupported PLY format 'binary_big_endian'";
    } else if (vertex_element_ < 0) {
      header_error_ = "no vertex element";
    } else if (!have_[kX] || !have_[kY] || !have_[kZ]) {
      header_error_ = "vertex element lacks x, y or z";
    } else if (want_labels_ && !have_[kLabel]) {
      header_error_ = "no vertex property 'label'";
    }
    return header_error_.empty();  // false ends the parse
  }

  // An element after the vertices: they are complete (possibly none).
  void beginElement(int index) {
    if (index > vertex_element_ && vertex_element_ >= 0) throw StopParsing{};
  }

  void endVertex() {
    points_.emplace_back(static_cast<float>(values_[kX]), static_cast<float>(values_[kY]),
                         static_cast<float>(values_[kZ]));
    if (want_labels_) {
      const double label = values_[kLabel];
      if (!std::isfinite(label) || std::abs(label) > 2e9) {
        throw StopParsing{"bad label at vertex " + std::to_string(points_.size() - 1)};
      }
      labels_.push_back(static_cast<int>(label));
    }
    if (points_.size() == vertex_count_) throw StopParsing{};
  }

  const bool want_labels_;
  const uintmax_t file_bytes_;
  ply::format_type format_ = ply::unknown;
  int num_elements_ = 0;
  int vertex_element_ = -1;
  size_t vertex_count_ = 0;
  bool have_[kSlots] = {false, false, false, false};
  double values_[kSlots] = {0.0, 0.0, 0.0, 0.0};
  std::string header_error_;
  PointCloud points_;
  std::vector<int> labels_;
};

}  // namespace

Status readPlyVertices(const std::string& path, PointCloud* points, std::vector<int>* labels) {
  if (points == nullptr) return Status::Error(path + ": no output cloud");
  uintmax_t file_bytes = 0;
  const Status readable = checkReadable(path, &file_bytes);
  if (!readable) return readable;

  VertexCollector collector(labels != nullptr, file_bytes);
  ply::ply_parser parser;
  collector.setUp(&parser);
  std::string parse_error;
  parser.error_callback([&parse_error, &path](std::size_t line, const std::string& message) {
    if (parse_error.empty()) parse_error = path + ":" + std::to_string(line) + ": " + message;
  });
  bool complete = false;
  try {
    // true also when the header check stopped it (headerError); false on a parse error. Stopped by
    // the last vertex (or the element after the vertices) when the vertices are complete.
    complete = parser.parse(path) && collector.headerError().empty();
  } catch (const StopParsing& stop) {
    if (!stop.error.empty()) return Status::Error(path + ": " + stop.error);
    complete = true;
  }
  if (!collector.headerError().empty()) {
    return Status::Error(path + ": " + collector.headerError());
  }
  if (!complete) {
    return Status::Error(parse_error.empty() ? path + ": not a readable PLY file"
                                             : parse_error + " (truncated or malformed PLY)");
  }
  *points = std::move(collector.points());
  if (labels != nullptr) *labels = std::move(collector.labels());
  return Status::Ok();
}

}  // namespace mvod
