#include "multiview_object_detection/evaluation/benchmark_segmenter_factory.h"

#include <utility>

namespace mvod {

Status BenchmarkSegmenterOptions::isValid() const {
  if (detector != "simulated") {
    const Status valid = SegmenterOptions::isValid();
    if (!valid && detector != "files" && detector != "yolo_seg" && detector != "fastestdet" &&
        detector != "maskrcnn") {
      return Status::Error("detector '" + detector +
                           "' is unknown (use files, yolo_seg, fastestdet, maskrcnn or simulated)");
    }
    return valid;
  }
  if (detections_dir.empty()) {
    return Status::Error(
        "detector 'simulated' needs the sequence folder (with <id>.xml and label/)");
  }
  const Status valid = simulated.isValid();
  if (!valid) return Status::Error("detector 'simulated': " + valid.message());
  return isValidExceptDetector();
}

Status createBenchmarkSegmenter(const BenchmarkSegmenterOptions& options,
                                std::unique_ptr<InstanceSegmenter>* segmenter) {
  segmenter->reset();
  const Status valid = options.isValid();
  if (!valid) return valid;
  if (options.detector != "simulated") return createInstanceSegmenter(options, segmenter);
  std::unique_ptr<SimulatedInstanceSegmenter> simulated;
  const Status created =
      SimulatedInstanceSegmenter::create(options.detections_dir, options.simulated, &simulated);
  if (!created) return created;
  *segmenter = std::move(simulated);
  return Status::Ok();
}

}  // namespace mvod
