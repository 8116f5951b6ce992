// libFuzzer harness: the detection file reader of `detector: files` (FileInstanceSegmenter's
// parseDetections, one <frame>.json document). It must never throw or crash; what it returns must
// hold to the documented contract: at most max_detections, scores in [0, 1], known COCO classes,
// boxes inside the image, CV_8UC1 masks of the image's size. Mask names resolve in a folder with
// two real masks (m.png of the image's size, small.png of another size) made at start-up.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "multiview_object_detection/detectors/file_instance_segmenter.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace {

namespace fs = std::filesystem;

const cv::Size kImageSize(32, 24);
constexpr int kMaxDetections = 4;
std::string g_mask_directory;

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz_detection_json: %s\n", what.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  const fs::path dir =
      fs::temp_directory_path() / ("mvod_fuzz_detection_masks_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  cv::Mat mask = cv::Mat::zeros(kImageSize, CV_8UC1);
  mask(cv::Rect(3, 4, 6, 5)).setTo(255);
  if (!cv::imwrite((dir / "m.png").string(), mask) ||
      !cv::imwrite((dir / "small.png").string(), cv::Mat(10, 10, CV_8UC1, cv::Scalar(255)))) {
    fail("cannot write the masks in " + dir.string());
  }
  g_mask_directory = dir.string();
  std::atexit([] {
    std::error_code error;
    fs::remove_all(g_mask_directory, error);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mvod::FileInstanceSegmenter::Config config;
  config.max_detections = kMaxDetections;
  std::vector<mvod::Detection2D> detections;
  std::vector<std::string> warnings;
  const mvod::Status status = mvod::FileInstanceSegmenter::parseDetections(
      text, "fuzz.json", g_mask_directory, kImageSize, config, &detections, &warnings);
  if (!status) {
    if (status.message().empty()) fail("an error without a message");
    if (!detections.empty()) fail("an error with detections");
    return 0;
  }
  if (detections.size() > static_cast<size_t>(kMaxDetections)) fail("more than max_detections");
  const cv::Rect image(cv::Point(0, 0), kImageSize);
  for (const mvod::Detection2D& d : detections) {
    if (!(d.score >= 0.f && d.score <= 1.f)) fail("a score outside [0, 1]");
    if (d.class_id < 0 || d.class_id >= static_cast<int>(mvod::cocoClassNames().size()) ||
        mvod::cocoClassNames()[d.class_id] != d.class_name) {
      fail("an unknown class or a name that is not its id's");
    }
    if (d.box_px.empty() || (d.box_px & image) != d.box_px) fail("a box outside the image");
    if (d.mask.type() != CV_8UC1 || d.mask.size() != kImageSize) fail("a mask of the wrong kind");
    if (cv::countNonZero(d.mask) == 0) fail("an empty mask");
  }
  for (const std::string& warning : warnings) {
    if (warning.rfind("fuzz.json: ", 0) != 0) fail("a warning that does not name the file");
  }
  return 0;
}
