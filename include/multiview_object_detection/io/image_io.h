// Image files from disk (depth, colour, masks, label images) read with their size checked BEFORE
// decoding: an 800 KB PNG can claim 20000x20000 pixels and cost gigabytes once decoded. The width
// and height come from the header (PNG IHDR, JPEG SOF); the image is decoded only when they are
// what the caller expects (the camera's size, the colour image's size) and within max_pixels.
// Only PNG and JPEG are accepted: other formats' headers are not parsed here, so their size could
// not be checked first.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// 8K UHD (7680x4320): above any depth camera and most colour cameras. Decoded as 8-bit BGR that is
// about 100 MB.
constexpr int64_t kDefaultMaxImagePixels = int64_t{7680} * 4320;
// Larger files are refused before they are read.
constexpr int64_t kMaxImageFileBytes = int64_t{256} << 20;

struct ImageHeader {
  std::string format;  // "PNG" or "JPEG"
  cv::Size size;       // as stored (a JPEG's EXIF orientation is not applied)
};

// Width and height from the first bytes of a PNG (IHDR) or JPEG (first SOF marker) without
// decoding anything. The message says what is wrong; `name` (a path) starts it.
Status readImageHeader(const uint8_t* data, size_t size, const std::string& name,
                       ImageHeader* header);

// The header of the file at `path` (a regular file; only its first bytes are read).
Status readImageFileHeader(const std::string& path, ImageHeader* header);

// Decodes `bytes` (cv::imdecode with imread_flags) when its header says the image is
// expected_size (an empty cv::Size = unknown: any size) and has at most max_pixels pixels. A
// refused image is never decoded; the message names `name` and both sizes. Decoding errors are
// errors too (never an exception). `image` is left untouched on failure.
// `expected_what` (optional) says where expected_size comes from, e.g. "the colour image's size".
Status decodeImageChecked(const std::vector<uint8_t>& bytes, const std::string& name,
                          int imread_flags, const cv::Size& expected_size, int64_t max_pixels,
                          cv::Mat* image, const std::string& expected_what = "");

// Reads the file at `path` (a regular file of at most kMaxImageFileBytes) and decodes it as
// decodeImageChecked does. The message names the file.
Status readImageChecked(const std::string& path, int imread_flags, const cv::Size& expected_size,
                        int64_t max_pixels, cv::Mat* image, const std::string& expected_what = "");

}  // namespace mvod
