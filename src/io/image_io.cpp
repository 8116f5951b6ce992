// The header parsers follow the PNG specification (signature, then the IHDR chunk: width and
// height as big-endian 32-bit) and JPEG's marker syntax (ITU T.81 B.1: segments FF xx with a
// 16-bit length, the frame header SOFn holding height and width), as libjpeg walks it.
#include "multiview_object_detection/io/image_io.h"

#include <sys/stat.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

namespace mvod {
namespace {

std::string sizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

Status unreadable(const std::string& name, const std::string& reason) {
  return Status::Error(name + ": cannot read the image: " + reason);
}

uint32_t bigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

uint16_t bigEndian16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

Status readPngHeader(const uint8_t* data, size_t size, const std::string& name,
                     ImageHeader* header) {
  // 8-byte signature, then the IHDR chunk: length 13, "IHDR", width, height, ...
  if (size < 8 + 4 + 4 + 8) return unreadable(name, "PNG file cut short before its size");
  if (bigEndian32(data + 8) != 13 || std::memcmp(data + 12, "IHDR", 4) != 0) {
    return unreadable(name, "PNG without an IHDR chunk first");
  }
  const uint32_t width = bigEndian32(data + 16);
  const uint32_t height = bigEndian32(data + 20);
  // The PNG limit is 2^31 - 1; zero is invalid.
  if (width == 0 || height == 0 || width > 0x7fffffffu || height > 0x7fffffffu) {
    return unreadable(name, "PNG header has an invalid size " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  header->format = "PNG";
  header->size = cv::Size(static_cast<int>(width), static_cast<int>(height));
  return Status::Ok();
}

Status readJpegHeader(const uint8_t* data, size_t size, const std::string& name,
                      ImageHeader* header) {
  size_t pos = 2;  // after SOI (FF D8)
  while (true) {
    // The next marker: skip anything up to an FF, then fill bytes (FF FF ...), as libjpeg does.
    while (pos < size && data[pos] != 0xFF) ++pos;
    while (pos < size && data[pos] == 0xFF) ++pos;
    if (pos >= size) return unreadable(name, "JPEG file ends before its frame header");
    const uint8_t marker = data[pos++];
    if (marker == 0x00 || marker == 0x01 || marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7)) {
      continue;  // stuffed zero, TEM, SOI, RSTn: no length field
    }
    if (marker == 0xD9 || marker == 0xDA) {
      return unreadable(name, "JPEG without a frame header before its image data");
    }
    if (pos + 2 > size) return unreadable(name, "JPEG file ends inside a marker");
    const uint16_t length = bigEndian16(data + pos);
    if (length < 2) return unreadable(name, "JPEG marker with an invalid length");
    // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC): precision, height, width, components.
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (length < 8 || pos + 7 > size) {
        return unreadable(name, "JPEG frame header cut short");
      }
      const uint16_t height = bigEndian16(data + pos + 3);
      const uint16_t width = bigEndian16(data + pos + 5);
      if (width == 0 || height == 0) {
        // Height 0 = given later by a DNL marker: too rare to support, and unknown here.
        return unreadable(name, "JPEG frame header has size " + std::to_string(width) + "x" +
                                    std::to_string(height));
      }
      header->format = "JPEG";
      header->size = cv::Size(width, height);
      return Status::Ok();
    }
    pos += length;
  }
}

// A JPEG's frame header can follow EXIF and other segments of up to 64 KB each.
constexpr int64_t kHeaderSearchBytes = int64_t{1} << 20;

// The first max_bytes bytes of a regular file (max_bytes < 0: the whole file, which must be at
// most kMaxImageFileBytes).
Status readPrefix(const std::string& path, int64_t max_bytes, std::vector<uint8_t>* bytes) {
  // stat first: a folder or a FIFO is refused before it is opened (a FIFO would block).
  struct stat info;
  if (::stat(path.c_str(), &info) != 0) return Status::Error(path + ": no such file");
  if (!S_ISREG(info.st_mode)) return Status::Error(path + ": not a regular file");
  if (max_bytes < 0 && info.st_size > kMaxImageFileBytes) {
    return Status::Error(path + ": " + std::to_string(info.st_size) +
                         " bytes, more than the limit of " + std::to_string(kMaxImageFileBytes) +
                         " bytes for an image file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot be read");
  const int64_t wanted = max_bytes < 0 ? info.st_size : std::min<int64_t>(max_bytes, info.st_size);
  bytes->assign(static_cast<size_t>(wanted), 0);
  if (!bytes->empty()) {
    in.read(reinterpret_cast<char*>(bytes->data()), static_cast<std::streamsize>(bytes->size()));
    bytes->resize(static_cast<size_t>(in.gcount()));
  }
  return Status::Ok();
}

}  // namespace

Status readImageHeader(const uint8_t* data, size_t size, const std::string& name,
                       ImageHeader* header) {
  if (header == nullptr) return Status::Error("readImageHeader: header is null");
  static const uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  // OpenCV takes FF D8 FF as a JPEG; the header walk starts at that third byte's marker.
  static const uint8_t kJpegSignature[3] = {0xFF, 0xD8, 0xFF};
  if (data == nullptr || size == 0) return unreadable(name, "empty file");
  if (size >= 8 && std::memcmp(data, kPngSignature, 8) == 0) {
    return readPngHeader(data, size, name, header);
  }
  if (size >= 3 && std::memcmp(data, kJpegSignature, 3) == 0) {
    return readJpegHeader(data, size, name, header);
  }
  return unreadable(name, "not a PNG or JPEG file (other formats are not read)");
}

Status decodeImageChecked(const std::vector<uint8_t>& bytes, const std::string& name,
                          int imread_flags, const cv::Size& expected_size, int64_t max_pixels,
                          cv::Mat* image, const std::string& expected_what) {
  if (image == nullptr) return Status::Error("decodeImageChecked: image is null");
  ImageHeader header;
  Status status = readImageHeader(bytes.data(), bytes.size(), name, &header);
  if (!status) return status;

  const int64_t pixels = int64_t{header.size.width} * header.size.height;
  const bool known = expected_size.width > 0 && expected_size.height > 0;
  // A JPEG decoded with its EXIF orientation may come out transposed; the decoded size is checked
  // exactly below.
  const bool matches =
      header.size == expected_size ||
      (header.format == "JPEG" && (imread_flags & cv::IMREAD_IGNORE_ORIENTATION) == 0 &&
       cv::Size(header.size.height, header.size.width) == expected_size);
  const std::string expected_text =
      known ? sizeText(expected_size) + (expected_what.empty() ? "" : " (" + expected_what + ")")
            : "";
  if (known && !matches) {
    return Status::Error(name + ": image is " + sizeText(header.size) + " pixels (" +
                         header.format + " header), expected " + expected_text + "; not decoded");
  }
  if (pixels > max_pixels) {
    return Status::Error(name + ": image is " + sizeText(header.size) + " pixels (" +
                         header.format + " header), more than the limit of " +
                         std::to_string(max_pixels) + " pixels; not decoded");
  }

  cv::Mat decoded;
  try {
    // imdecode does not copy the buffer; it only reads it.
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                         const_cast<uint8_t*>(bytes.data()));
    decoded = cv::imdecode(buffer, imread_flags);
  } catch (const std::exception& e) {
    return unreadable(name, e.what());
  }
  if (decoded.empty()) {
    return Status::Error(name + ": cannot read the image: the " + header.format +
                         " data is corrupt");
  }
  // The decoder's own idea of the size must agree with the header that was checked.
  if ((known && decoded.size() != expected_size) ||
      int64_t{decoded.cols} * decoded.rows > max_pixels) {
    return Status::Error(name + ": decoded image is " + sizeText(decoded.size()) +
                         (known ? ", expected " + expected_text : std::string()) +
                         " (header said " + sizeText(header.size) + ")");
  }
  *image = decoded;
  return Status::Ok();
}

Status readImageFileHeader(const std::string& path, ImageHeader* header) {
  if (header == nullptr) return Status::Error("readImageFileHeader: header is null");
  std::vector<uint8_t> bytes;
  const Status status = readPrefix(path, kHeaderSearchBytes, &bytes);
  if (!status) return status;
  return readImageHeader(bytes.data(), bytes.size(), path, header);
}

Status readImageChecked(const std::string& path, int imread_flags, const cv::Size& expected_size,
                        int64_t max_pixels, cv::Mat* image, const std::string& expected_what) {
  if (image == nullptr) return Status::Error("readImageChecked: image is null");
  std::vector<uint8_t> bytes;
  const Status status = readPrefix(path, -1, &bytes);
  if (!status) return status;
  return decodeImageChecked(bytes, path, imread_flags, expected_size, max_pixels, image,
                            expected_what);
}

}  // namespace mvod
