// libFuzzer harness: the checked decoding of depth, colour and mask files (io/image_io
// decodeImageChecked). The first byte picks how the file is read: bit 0 colour (IMREAD_COLOR) or
// depth/mask (IMREAD_UNCHANGED), bit 1 an expected size of 32x24 (the camera's) or none; the rest
// is the file. Nothing may crash or throw, and nothing larger than allowed may come out: the size
// is checked from the header before decoding, so a bomb never reaches the decoder (libFuzzer's
// -rss_limit_mb / -malloc_limit_mb catch it if it did).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/io/image_io.h"

namespace {

const cv::Size kCameraSize(32, 24);
constexpr int64_t kMaxPixels = int64_t{1} << 20;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz_image_decode: %s\n", what.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const int flags = (data[0] & 1) ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED;
  const cv::Size expected = (data[0] & 2) ? kCameraSize : cv::Size();
  const std::vector<uint8_t> bytes(data + 1, data + size);

  mvod::ImageHeader header;
  const mvod::Status header_status =
      mvod::readImageHeader(bytes.data(), bytes.size(), "fuzz.png", &header);

  cv::Mat image;
  const mvod::Status status =
      mvod::decodeImageChecked(bytes, "fuzz.png", flags, expected, kMaxPixels, &image);
  if (!status) {
    if (status.message().rfind("fuzz.png: ", 0) != 0) fail("an error that does not name the file");
    if (!image.empty()) fail("an error with an image");
    return 0;
  }
  if (!header_status) fail("decoded although the header does not read: " + header_status.message());
  if (image.empty()) fail("success without an image");
  if (int64_t{image.cols} * image.rows > kMaxPixels) fail("an image above max_pixels");
  if (!expected.empty() && image.size() != expected) fail("an image of an unexpected size");
  if (flags == cv::IMREAD_COLOR && image.type() != CV_8UC3) fail("colour that is not 8UC3");
  return 0;
}
