// Single-view stages on one large synthetic view (Google Benchmark; reported in the README, never
// asserted): a couch-sized surface seen at 1.5-2.5 m, 360 x 360 pixels in raster order with
// Kinect-like depth noise, as the extraction hands it to the filter. The stages that split their
// work over threads run with threads:1 and threads:2; BM_ParallelRanges is the cost of one call of
// the thread pool itself (utils/parallel.h).
//   devel/lib/multiview_object_detection/bench_stages --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "multiview_object_detection/pipeline/stages/box_estimator.h"
#include "multiview_object_detection/pipeline/stages/lccp_segmenter.h"
#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"
#include "multiview_object_detection/pipeline/utils/parallel.h"

namespace {

using mvod::PointCloud;

const PointCloud& largeView() {
  static const PointCloud view = [] {
    std::mt19937 rng(1);
    std::normal_distribution<float> noise(0.f, 0.004f);
    PointCloud points;
    for (int v = 60; v < 420; ++v) {
      for (int u = 140; u < 500; ++u) {
        const float z = 1.5f + 0.002f * v + 0.3f * std::sin(u * 0.01f) + noise(rng);
        points.emplace_back((u - 320) * z / 525.f, (v - 240) * z / 525.f, z);
      }
    }
    return points;
  }();
  return view;
}

const PointCloud& voxelizedView() {
  static const PointCloud voxels = mvod::PointCloudFilter::voxelize(largeView(), 0.01);
  return voxels;
}

void BM_Voxelize(benchmark::State& state) {
  for (auto _ : state) {
    benchmark::DoNotOptimize(mvod::PointCloudFilter::voxelize(largeView(), 0.01));
  }
  state.counters["points"] = static_cast<double>(largeView().size());
}
BENCHMARK(BM_Voxelize)->Unit(benchmark::kMillisecond);

void BM_OutlierStatisticOnVoxelCentres(benchmark::State& state) {
  std::vector<float> distances;
  for (auto _ : state) {
    mvod::PointCloudFilter::voxelCentreMeanDistances(voxelizedView(), 20, 0.01,
                                                     static_cast<int>(state.range(0)), &distances);
    benchmark::DoNotOptimize(distances.data());
  }
  state.counters["voxels"] = static_cast<double>(voxelizedView().size());
}
BENCHMARK(BM_OutlierStatisticOnVoxelCentres)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond);

void BM_LccpVoxelGrid(benchmark::State& state) {
  mvod::LccpSegmenter::Config config;
  config.num_threads = static_cast<int>(state.range(0));
  const mvod::LccpSegmenter lccp(config);
  for (auto _ : state) {
    mvod::LccpSegmenter::Result result;
    benchmark::DoNotOptimize(lccp.segment(voxelizedView(), true, &result));
  }
}
BENCHMARK(BM_LccpVoxelGrid)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_BoxFromCellNormals(benchmark::State& state) {
  mvod::BoxEstimator::Config config;
  config.num_threads = static_cast<int>(state.range(0));
  const mvod::BoxEstimator estimator(config);
  const mvod::GravityFrame gravity(Eigen::Vector3d(0, 1, 0));  // image y down: gravity along +y
  for (auto _ : state) {
    mvod::OrientedBox box;
    benchmark::DoNotOptimize(
        estimator.estimate(voxelizedView(), gravity, &box, nullptr, nullptr, 2.0));
  }
}
BENCHMARK(BM_BoxFromCellNormals)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// One parallelRanges call on two threads over a trivial loop: what a stage pays per call.
void BM_ParallelRanges(benchmark::State& state) {
  std::vector<float> out(8192);
  for (auto _ : state) {
    mvod::parallelRanges(out.size(), 2, 1024, [&out](std::size_t first, std::size_t last) {
      for (std::size_t i = first; i < last; ++i) out[i] = static_cast<float>(i);
    });
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_ParallelRanges)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
