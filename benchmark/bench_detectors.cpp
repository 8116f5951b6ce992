// Detector time per keyframe at 640x480 on this CPU (Google Benchmark; reported in the README,
// never asserted). Models come from $MVOD_MODEL_DIR, else <repo>/../shared/models; a model that is
// absent is skipped with a message.
//   devel/lib/multiview_object_detection/bench_detectors --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "multiview_object_detection/detectors/segmenter_factory.h"

namespace {

namespace fs = std::filesystem;

std::string modelDir() {
  const char* env = std::getenv("MVOD_MODEL_DIR");
  if (env != nullptr && *env != '\0') return env;
  return (fs::path(MVOD_SOURCE_DIR) / ".." / "shared" / "models").string();
}

// A real 640x480 photo when one is there (the detector's work depends little on content).
cv::Mat testImage() {
  cv::Mat image = cv::imread((fs::path(modelDir()) / "sample_person.jpg").string());
  if (image.empty()) {
    image = cv::Mat(480, 640, CV_8UC3);
    cv::randu(image, 0, 255);
  }
  cv::resize(image, image, cv::Size(640, 480));
  return image;
}

void runDetector(benchmark::State& state, const std::string& detector,
                 const std::string& yolo_seg_model = "") {
  mvod::SegmenterOptions options;
  options.detector = detector;
  if (!yolo_seg_model.empty()) options.yolo_seg_model = yolo_seg_model;
  options.model_dir = modelDir();
  std::unique_ptr<mvod::InstanceSegmenter> segmenter;
  const mvod::Status created = mvod::createInstanceSegmenter(options, &segmenter);
  if (!created) {
    state.SkipWithError(created.message().c_str());
    return;
  }
  const cv::Mat image = testImage();
  std::vector<mvod::Detection2D> detections;
  segmenter->detect(image, "warm-up", &detections);  // first call allocates
  for (auto _ : state) {
    const mvod::Status status = segmenter->detect(image, "bench", &detections);
    if (!status) {
      state.SkipWithError(status.message().c_str());
      break;
    }
    benchmark::DoNotOptimize(detections.data());
  }
  state.counters["detections"] = static_cast<double>(detections.size());
}

void BM_FastestDet640x480(benchmark::State& state) { runDetector(state, "fastestdet"); }
void BM_YoloSeg640Input640x480(benchmark::State& state) {
  runDetector(state, "yolo_seg", "yolov5n-seg.onnx");
}
void BM_YoloSeg320Input640x480(benchmark::State& state) {
  runDetector(state, "yolo_seg", "yolov5n-seg-320.onnx");
}
void BM_MaskRcnn640x480(benchmark::State& state) { runDetector(state, "maskrcnn"); }

BENCHMARK(BM_FastestDet640x480)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_YoloSeg640Input640x480)->Unit(benchmark::kMillisecond)->MinTime(3.0);
BENCHMARK(BM_YoloSeg320Input640x480)->Unit(benchmark::kMillisecond)->MinTime(3.0);
BENCHMARK(BM_MaskRcnn640x480)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
