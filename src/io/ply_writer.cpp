// Why these are not PCL's PLY writer: see ply_writer.h.
#include "multiview_object_detection/io/ply_writer.h"

#include <cstdio>
#include <cstring>
#include <sstream>

namespace mvod {

std::string plyAsciiXyz(const PointCloud& points) {
  std::ostringstream out;
  out << "ply\nformat ascii 1.0\nelement vertex " << points.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  char line[96];
  for (const Eigen::Vector3f& p : points) {
    std::snprintf(line, sizeof(line), "%.4f %.4f %.4f\n", p.x(), p.y(), p.z());
    out << line;
  }
  return out.str();
}

std::string plyBinaryColoredLabelled(const std::string& comment,
                                     const std::vector<PlyColoredVertex>& vertices) {
  std::string ply = "ply\nformat binary_little_endian 1.0\ncomment " + comment +
                    "\nelement vertex " + std::to_string(vertices.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                    "property ushort label\nend_header\n";
  const size_t header_size = ply.size();
  constexpr size_t kVertexBytes = 3 * 4 + 3 + 2;
  ply.resize(header_size + vertices.size() * kVertexBytes);
  char* cursor = &ply[header_size];
  for (const PlyColoredVertex& vertex : vertices) {
    std::memcpy(cursor, vertex.xyz, sizeof(vertex.xyz));  // little-endian host (x86, ARM)
    cursor += sizeof(vertex.xyz);
    std::memcpy(cursor, vertex.rgb, sizeof(vertex.rgb));
    cursor += sizeof(vertex.rgb);
    std::memcpy(cursor, &vertex.label, sizeof(vertex.label));
    cursor += sizeof(vertex.label);
  }
  return ply;
}

}  // namespace mvod
