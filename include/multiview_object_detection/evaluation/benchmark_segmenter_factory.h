// The detectors the offline tools offer: the deployable ones of detectors/segmenter_factory.h plus
// "simulated" (ground-truth label images of a SceneNN-layout sequence with Mask R-CNN-like
// failures, SimulatedInstanceSegmenter). The node links only the deployable factory.
#pragma once

#include <memory>

#include "multiview_object_detection/detectors/segmenter_factory.h"
#include "multiview_object_detection/simulation/simulated_instance_segmenter.h"

namespace mvod {

struct BenchmarkSegmenterOptions : SegmenterOptions {
  // detector "simulated": detections_dir is the sequence folder (<id>.xml, label/); failure rates,
  // scores and seed (the defaults mimic Mask R-CNN on SceneNN).
  SimulatedInstanceSegmenter::Config simulated;
  Status isValid() const;
};

// As createInstanceSegmenter, plus "simulated".
Status createBenchmarkSegmenter(const BenchmarkSegmenterOptions& options,
                                std::unique_ptr<InstanceSegmenter>* segmenter);

}  // namespace mvod
