// PointCloudFilter: voxel grid, depth pass-through and statistical outlier removal on synthetic
// clouds.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <string>

#include "multiview_object_detection/pipeline/stages/point_cloud_filter.h"

namespace mvod {
namespace {

// A dense square patch of the plane z = z0, from the origin along +x and +y, spacing_m apart, with
// a little deterministic jitter.
PointCloud planePatch(float z0, float size_m, float spacing_m, float jitter_m) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> noise(-jitter_m, jitter_m);
  PointCloud points;
  const int n = static_cast<int>(size_m / spacing_m);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const float x = (i + 0.5f) * spacing_m;  // half a spacing off grid lines
      const float y = (j + 0.5f) * spacing_m;
      points.emplace_back(x + noise(rng), y + noise(rng), z0 + noise(rng));
    }
  }
  return points;
}

bool containsPoint(const PointCloud& points, const Eigen::Vector3f& p, float tol) {
  return std::any_of(points.begin(), points.end(),
                     [&](const Eigen::Vector3f& q) { return (q - p).norm() <= tol; });
}

}  // namespace

TEST(PointCloudFilterVoxelize, OneCentroidPerOccupiedVoxel) {
  // 3 x 2 x 1 voxels of 0.1 m, each holding 4 points placed symmetrically about a known centroid.
  PointCloud points;
  std::vector<Eigen::Vector3f> centroids;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 2; ++j) {
      const Eigen::Vector3f c(0.1f * i + 0.04f, 0.1f * j + 0.06f, 0.05f);
      centroids.push_back(c);
      for (const float d : {-0.02f, 0.02f}) {
        points.emplace_back(c + Eigen::Vector3f(d, 0.01f, 0.0f));
        points.emplace_back(c + Eigen::Vector3f(d, -0.01f, 0.0f));
      }
    }
  }
  const PointCloud out = PointCloudFilter::voxelize(points, 0.1);
  ASSERT_EQ(out.size(), 6u);
  for (const Eigen::Vector3f& c : centroids) EXPECT_TRUE(containsPoint(out, c, 1e-5f));
  // Deterministic: the same input in another order gives the same output.
  PointCloud reversed(points.rbegin(), points.rend());
  const PointCloud out_reversed = PointCloudFilter::voxelize(reversed, 0.1);
  ASSERT_EQ(out_reversed.size(), out.size());
  for (std::size_t i = 0; i < out.size(); ++i) EXPECT_LT((out[i] - out_reversed[i]).norm(), 1e-6f);
}

// The reference voxel grid: voxels in ascending (x, y, z) index order, each voxel's points summed
// in input order (what voxelize promised before its radix sort, bit for bit).
PointCloud referenceVoxelize(const PointCloud& points, double leaf_m) {
  std::map<std::array<std::int64_t, 3>, std::vector<std::size_t>> voxels;
  const double inv_leaf = 1.0 / leaf_m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::array<std::int64_t, 3> key;
    for (int d = 0; d < 3; ++d) {
      key[d] = static_cast<std::int64_t>(std::floor(static_cast<double>(points[i][d]) * inv_leaf));
    }
    voxels[key].push_back(i);
  }
  PointCloud out;
  for (const auto& voxel : voxels) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const std::size_t i : voxel.second) sum += points[i].cast<double>();
    out.emplace_back((sum / static_cast<double>(voxel.second.size())).cast<float>());
  }
  return out;
}

TEST(PointCloudFilterVoxelize, SameOrderAndCentroidsAsASortedGrid) {
  // Many points per voxel, negative and positive coordinates, an extent that needs several radix
  // digits (2 m at 1 mm: 8e9 grid positions), and a cloud so far apart that the grid positions
  // overflow 64 bits (the comparison-sort fallback).
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> coordinate(-1.f, 1.f);
  PointCloud points;
  for (int i = 0; i < 20000; ++i) {
    points.emplace_back(coordinate(rng), coordinate(rng), 0.5f * coordinate(rng) + 2.f);
  }
  for (const double leaf_m : {0.1, 0.01, 0.001}) {
    const PointCloud expected = referenceVoxelize(points, leaf_m);
    const PointCloud out = PointCloudFilter::voxelize(points, leaf_m);
    ASSERT_EQ(out.size(), expected.size()) << "leaf " << leaf_m;
    for (std::size_t i = 0; i < out.size(); ++i) {
      ASSERT_EQ(out[i], expected[i]) << "voxel " << i << ", leaf " << leaf_m;
    }
  }
  PointCloud spread = points;
  spread.emplace_back(1e15f, -1e15f, 1e15f);
  spread.emplace_back(-1e15f, 1e15f, -1e15f);
  const PointCloud expected = referenceVoxelize(spread, 1e-3);
  const PointCloud out = PointCloudFilter::voxelize(spread, 1e-3);
  ASSERT_EQ(out.size(), expected.size());
  for (std::size_t i = 0; i < out.size(); ++i) ASSERT_EQ(out[i], expected[i]) << "voxel " << i;
}

TEST(PointCloudFilterVoxelize, NegativeCoordinatesSplitAtZero) {
  // floor(), not truncation: -0.01 and +0.01 lie in different voxels.
  const PointCloud points = {Eigen::Vector3f(-0.01f, 0.5f, 0.5f),
                             Eigen::Vector3f(0.01f, 0.5f, 0.5f)};
  EXPECT_EQ(PointCloudFilter::voxelize(points, 0.1).size(), 2u);
}

TEST(PointCloudFilterVoxelize, LargeCoordinatesDoNotOverflow) {
  // 1e5 m from the origin at 0.01 m leaves is 1e7 voxels per axis: beyond PCL's 32-bit grid index.
  PointCloud points;
  const Eigen::Vector3f far(1e5f, -1e5f, 1e5f);
  points.push_back(far);
  points.push_back(far + Eigen::Vector3f(0.03f, 0.0f, 0.0f));  // the next-but-two voxel
  points.push_back(-far);
  points.push_back(Eigen::Vector3f(0.0f, 0.0f, 0.0f));
  const PointCloud out = PointCloudFilter::voxelize(points, 0.01);
  EXPECT_EQ(out.size(), 4u);
  EXPECT_TRUE(containsPoint(out, far, 0.01f));
  EXPECT_TRUE(containsPoint(out, far + Eigen::Vector3f(0.03f, 0.0f, 0.0f), 0.01f));
  EXPECT_TRUE(containsPoint(out, -far, 0.01f));
  EXPECT_TRUE(containsPoint(out, Eigen::Vector3f::Zero(), 1e-6f));
  // Even absurd coordinates and leaf sizes must not crash.
  const PointCloud huge = {Eigen::Vector3f(3e38f, 0.0f, 0.0f), Eigen::Vector3f(1.0f, 1.0f, 1.0f)};
  EXPECT_LE(PointCloudFilter::voxelize(huge, 1e-9).size(), 2u);
}

TEST(PointCloudFilterVoxelize, NonFinitePointsDropped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const PointCloud points = {Eigen::Vector3f(nan, 0.0f, 1.0f), Eigen::Vector3f(0.0f, inf, 1.0f),
                             Eigen::Vector3f(0.02f, 0.02f, 1.02f),
                             Eigen::Vector3f(0.04f, 0.04f, 1.04f)};
  const PointCloud out = PointCloudFilter::voxelize(points, 0.1);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_LT((out[0] - Eigen::Vector3f(0.03f, 0.03f, 1.03f)).norm(), 1e-5f);
  EXPECT_TRUE(PointCloudFilter::voxelize(PointCloud(), 0.1).empty());
  // An invalid leaf size keeps the finite points rather than crashing.
  EXPECT_EQ(PointCloudFilter::voxelize(points, 0.0).size(), 2u);
}

TEST(PointCloudFilterPassThrough, KeepsDepthRangeInclusive) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const PointCloud points = {Eigen::Vector3f(0, 0, 0.2f),  Eigen::Vector3f(0, 0, 0.5f),
                             Eigen::Vector3f(1, 1, 1.0f),  Eigen::Vector3f(0, 0, 4.0f),
                             Eigen::Vector3f(0, 0, 4.5f),  Eigen::Vector3f(0, 0, -1.0f),
                             Eigen::Vector3f(nan, 0, 1.0f)};
  const PointCloud out = PointCloudFilter::passThroughDepth(points, 0.5, 4.0);
  ASSERT_EQ(out.size(), 3u);
  for (const Eigen::Vector3f& p : out) {
    EXPECT_GE(p.z(), 0.5f);
    EXPECT_LE(p.z(), 4.0f);
  }
}

TEST(PointCloudFilterOutliers, RemovesIsolatedPointsKeepsPlane) {
  PointCloud points = planePatch(1.0f, 0.5f, 0.01f, 0.001f);
  const std::size_t plane_size = points.size();
  const std::vector<Eigen::Vector3f> outliers = {Eigen::Vector3f(0.25f, 0.25f, 1.5f),
                                                 Eigen::Vector3f(-0.4f, 0.1f, 0.7f),
                                                 Eigen::Vector3f(1.0f, 1.0f, 1.0f)};
  points.insert(points.end(), outliers.begin(), outliers.end());
  const PointCloud out = PointCloudFilter::removeStatisticalOutliers(points, 20, 1.5);
  for (const Eigen::Vector3f& o : outliers) EXPECT_FALSE(containsPoint(out, o, 1e-6f));
  // The plane stays: only a thin fringe (patch corners) may go.
  EXPECT_GE(out.size(), static_cast<std::size_t>(0.95 * plane_size));
  for (const Eigen::Vector3f& p : out) EXPECT_NEAR(p.z(), 1.0f, 0.002f);
}

// A floor, a box top and a sphere (60 000 points, 4 mm Gaussian noise) drawn from rng.
PointCloud noisySurfaces(std::mt19937* rng) {
  std::normal_distribution<float> noise(0.f, 0.004f);
  std::uniform_real_distribution<float> uniform(-1.f, 1.f);
  PointCloud raw;
  for (int i = 0; i < 20000; ++i) {
    raw.emplace_back(uniform(*rng), uniform(*rng), noise(*rng));  // floor
    raw.emplace_back(0.3f + 0.2f * uniform(*rng), 0.2f * uniform(*rng),
                     0.5f + noise(*rng));  // top
    Eigen::Vector3f d(noise(*rng), noise(*rng), noise(*rng));
    raw.push_back(Eigen::Vector3f(-0.5f, 0.5f, 0.3f) + 0.2f * d.normalized() + d);  // sphere
  }
  return raw;
}

TEST(PointCloudFilterOutliers, GridSearchGivesPclsResultExactly) {
  // Voxelised surfaces (a floor, a box, a noisy sphere) plus scattered outliers, at several cell
  // sizes and neighbour counts: the grid's k nearest neighbours give PCL's kept points.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(-1.f, 1.f);
  PointCloud raw = noisySurfaces(&rng);
  for (int i = 0; i < 300; ++i) raw.emplace_back(uniform(rng), uniform(rng), 1.f + uniform(rng));
  for (const double leaf : {0.01, 0.02, 0.035}) {
    const PointCloud voxelized = PointCloudFilter::voxelize(raw, leaf);
    for (const int k : {5, 20}) {
      for (const double mul : {1.0, 2.5}) {
        const PointCloud pcl = PointCloudFilter::removeStatisticalOutliers(voxelized, k, mul);
        const PointCloud grid =
            PointCloudFilter::removeStatisticalOutliersOnGrid(voxelized, k, mul, leaf);
        ASSERT_EQ(pcl.size(), grid.size()) << "leaf " << leaf << " k " << k << " mul " << mul;
        EXPECT_LT(pcl.size(), voxelized.size());
        for (size_t i = 0; i < pcl.size(); ++i) ASSERT_EQ(pcl[i], grid[i]);
        // The neighbour searches split over threads: the same result.
        for (const int threads : {2, 3}) {
          const PointCloud split =
              PointCloudFilter::removeStatisticalOutliersOnGrid(voxelized, k, mul, leaf, threads);
          ASSERT_EQ(split.size(), grid.size()) << "leaf " << leaf << " threads " << threads;
          for (size_t i = 0; i < split.size(); ++i) ASSERT_EQ(split[i], grid[i]);
        }
      }
    }
    // Not voxelised (several points per cell) and a cell size unlike the leaf: still exact.
    const PointCloud pcl = PointCloudFilter::removeStatisticalOutliers(raw, 20, 2.5);
    const PointCloud grid = PointCloudFilter::removeStatisticalOutliersOnGrid(raw, 20, 2.5, leaf);
    ASSERT_EQ(pcl.size(), grid.size()) << "raw, cell " << leaf;
    for (size_t i = 0; i < pcl.size(); ++i) ASSERT_EQ(pcl[i], grid[i]);
  }
}

// The statistic on voxel centres, straight from its definition: for each cell, the lengths (in
// cells) to every other occupied cell within the search radius, sorted, the first mean_k summed
// in float; missing neighbours count radius + 1. A brute-force search: for small clouds.
std::vector<float> voxelCentreDistancesReference(const PointCloud& points, int mean_k,
                                                 double leaf_size_m) {
  const int radius = std::max(2, static_cast<int>(std::ceil(2.0 * std::sqrt(mean_k))));
  std::vector<std::array<std::int64_t, 3>> cells;
  for (const Eigen::Vector3f& p : points) {
    std::array<std::int64_t, 3> c;
    for (int d = 0; d < 3; ++d) {
      c[d] = static_cast<std::int64_t>(std::floor(static_cast<double>(p[d]) / leaf_size_m));
    }
    cells.push_back(c);
  }
  // Candidates by x cell, so that each point looks only at the slab within the radius.
  std::vector<size_t> by_x(points.size());
  for (size_t i = 0; i < by_x.size(); ++i) by_x[i] = i;
  std::sort(by_x.begin(), by_x.end(),
            [&](size_t a, size_t b) { return cells[a][0] < cells[b][0]; });
  const auto x_below = [&](std::int64_t x) {
    return std::partition_point(by_x.begin(), by_x.end(),
                                [&](size_t j) { return cells[j][0] < x; });
  };
  std::vector<float> mean_distance(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    std::vector<std::int64_t> squared;
    const auto last = x_below(cells[i][0] + radius + 1);
    for (auto it = x_below(cells[i][0] - radius); it != last; ++it) {
      const size_t j = *it;
      std::int64_t s = 0;
      for (int d = 0; d < 3; ++d) s += (cells[j][d] - cells[i][d]) * (cells[j][d] - cells[i][d]);
      if (s > 0 && s <= radius * radius) squared.push_back(s);
    }
    std::sort(squared.begin(), squared.end());
    float sum = 0.f;
    int found = 0;
    for (; found < mean_k && found < static_cast<int>(squared.size()); ++found) {
      sum += std::sqrt(static_cast<float>(squared[found]));
    }
    sum += static_cast<float>(mean_k - found) * static_cast<float>(radius + 1);
    mean_distance[i] = static_cast<float>(leaf_size_m) * sum / static_cast<float>(mean_k);
  }
  return mean_distance;
}

TEST(PointCloudFilterOutliers, VoxelCentresStatisticIsItsDefinition) {
  // A tilted plane with a ragged edge, a thin rod, a sparse row and scattered specks, voxelised:
  // inside a surface the nearest cells lie in the 5 x 5 x 5 cube around a cell, at an edge or on
  // the rod beyond it. Each point's mean distance is the definition's, bit for bit, for small and
  // large mean_k (1 uses no cube), and on 1 to 3 threads.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uniform(-1.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.003f);
  PointCloud raw;
  for (int i = 0; i < 80000; ++i) {
    const float x = 0.6f * uniform(rng);
    const float y = 0.4f * uniform(rng);
    if (x > 0.4f && y > 0.1f * std::sin(20.f * x)) continue;  // ragged edge
    raw.emplace_back(x, y, 0.4f * x + 0.25f * y + noise(rng));
  }
  for (int i = 0; i < 60; ++i) raw.emplace_back(0.65f, -0.3f + 0.01f * i, 0.1f);  // rod
  for (int i = 0; i < 15; ++i) raw.emplace_back(-0.3f + 0.04f * i, 0.45f, 0.f);   // sparse row
  for (int i = 0; i < 40; ++i) {
    raw.emplace_back(0.7f * uniform(rng), 0.5f * uniform(rng), 0.3f * uniform(rng));  // specks
  }
  const double leaf = 0.01;
  const PointCloud voxelized = PointCloudFilter::voxelize(raw, leaf);
  ASSERT_GT(voxelized.size(), 3u * 4096u);  // three threads' shares of the queries (4096 each)
  for (const int k : {1, 2, 5, 20, 40}) {
    const std::vector<float> expected = voxelCentreDistancesReference(voxelized, k, leaf);
    for (const int threads : {1, 2, 3}) {
      std::vector<float> distances;
      ASSERT_TRUE(
          PointCloudFilter::voxelCentreMeanDistances(voxelized, k, leaf, threads, &distances));
      ASSERT_EQ(distances.size(), expected.size());
      for (size_t i = 0; i < expected.size(); ++i) {
        ASSERT_EQ(distances[i], expected[i]) << "k " << k << " point " << i;
      }
    }
  }
  // Too wide for the occupancy grid: nothing computed (the filter then searches exactly).
  PointCloud spread = voxelized;
  spread.emplace_back(300.f, -300.f, 300.f);
  std::vector<float> distances;
  EXPECT_FALSE(PointCloudFilter::voxelCentreMeanDistances(spread, 20, leaf, 1, &distances));
  EXPECT_FALSE(PointCloudFilter::voxelCentreMeanDistances(voxelized, 0, leaf, 1, &distances));
  EXPECT_TRUE(PointCloudFilter::voxelCentreMeanDistances({}, 20, leaf, 1, &distances));
  EXPECT_TRUE(distances.empty());
}

TEST(PointCloudFilterOutliers, VoxelCentresStatisticsCloseToPcls) {
  // The same voxelised surfaces and outliers as above: on voxel centres, the statistic keeps and
  // drops nearly the same points as PCL's exact k nearest, and every scattered outlier goes.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uniform(-1.f, 1.f);
  PointCloud raw = noisySurfaces(&rng);
  PointCloud outliers;
  for (int i = 0; i < 300; ++i)
    outliers.emplace_back(uniform(rng), uniform(rng), 1.3f + 0.5f * uniform(rng));
  const double leaf = 0.01;
  PointCloud voxelized = PointCloudFilter::voxelize(raw, leaf);
  const PointCloud outliers_voxelized = PointCloudFilter::voxelize(outliers, leaf);
  voxelized.insert(voxelized.end(), outliers_voxelized.begin(), outliers_voxelized.end());
  for (const double mul : {1.0, 2.5}) {
    const PointCloud exact =
        PointCloudFilter::removeStatisticalOutliersOnGrid(voxelized, 20, mul, leaf);
    const PointCloud centres =
        PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(voxelized, 20, mul, leaf);
    for (const Eigen::Vector3f& o : outliers_voxelized) {
      EXPECT_FALSE(containsPoint(centres, o, 1e-6f)) << "mul " << mul;
    }
    // Points kept by one and not the other: a few near the threshold (under 1 % at the default
    // 2.5, under 4 % at 1.0, where the threshold lies inside the bulk of the distances).
    // Both keep the input order: one walk over the input.
    std::size_t differ = 0;
    std::size_t in_exact = 0;
    std::size_t in_centres = 0;
    for (const Eigen::Vector3f& p : voxelized) {
      const bool kept_exact = in_exact < exact.size() && exact[in_exact] == p;
      const bool kept_centres = in_centres < centres.size() && centres[in_centres] == p;
      in_exact += kept_exact;
      in_centres += kept_centres;
      differ += kept_exact != kept_centres;
    }
    ASSERT_EQ(in_exact, exact.size());
    ASSERT_EQ(in_centres, centres.size());
    EXPECT_LT(differ, voxelized.size() / (mul > 2.0 ? 100 : 25))
        << "mul " << mul << ": " << differ << " of " << voxelized.size();
    std::printf("mul %.1f: %zu of %zu differ\n", mul, differ, voxelized.size());
    // Something was removed besides the outliers only where the exact one removes some too.
    EXPECT_LT(centres.size(), voxelized.size() - outliers_voxelized.size() / 2);
    // Threads split the queries: the same result, in input order.
    for (const int threads : {2, 3}) {
      const PointCloud split = PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(
          voxelized, 20, mul, leaf, threads);
      ASSERT_EQ(split.size(), centres.size());
      for (std::size_t i = 0; i < split.size(); ++i) ASSERT_EQ(split[i], centres[i]);
    }
  }
  // A cloud spanning too many cells for its occupancy grid: the exact search's result.
  PointCloud spread = voxelized;
  spread.emplace_back(300.f, -300.f, 300.f);
  const PointCloud exact_spread =
      PointCloudFilter::removeStatisticalOutliersOnGrid(spread, 20, 2.5, leaf);
  const PointCloud centres_spread =
      PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(spread, 20, 2.5, leaf);
  ASSERT_EQ(centres_spread.size(), exact_spread.size());
  for (std::size_t i = 0; i < exact_spread.size(); ++i)
    ASSERT_EQ(centres_spread[i], exact_spread[i]);
  // Too few points, a bad leaf: unchanged.
  const PointCloud few = {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(5, 5, 5)};
  EXPECT_EQ(PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(few, 20, 1.0, leaf).size(),
            2u);
  EXPECT_EQ(
      PointCloudFilter::removeStatisticalOutliersOnVoxelCentres(voxelized, 20, 1.0, 0.0).size(),
      voxelized.size());
}

TEST(PointCloudFilterOutliers, SparseVoxelsGoSurfacesStay) {
  // On a 1 cm grid: a flat 20 x 20 patch (8 neighbours inside, 5 on its border, 3 at its four
  // corners), a line of voxels (2 neighbours), a pair (1) and isolated specks (0).
  const float leaf = 0.01f;
  const auto at = [leaf](int x, int y, int z) {
    return Eigen::Vector3f((x + 0.5f) * leaf, (y + 0.5f) * leaf, (z + 0.5f) * leaf);
  };
  PointCloud patch;
  for (int x = 0; x < 20; ++x) {
    for (int y = 0; y < 20; ++y) patch.push_back(at(x, y, 100));
  }
  PointCloud noise;
  for (int k = 0; k < 15; ++k) noise.push_back(at(40 + k, 0, 90));  // a line
  noise.push_back(at(-30, -30, 120));                               // a pair
  noise.push_back(at(-29, -30, 121));
  for (int k = 0; k < 5; ++k) noise.push_back(at(-50 + 7 * k, 60, 80 - 9 * k));  // specks
  PointCloud cloud = patch;
  cloud.insert(cloud.end(), noise.begin(), noise.end());
  const PointCloud kept = PointCloudFilter::removeSparseVoxels(cloud, leaf, 4);
  // The patch without its 4 corners, in input order; none of the noise.
  ASSERT_EQ(kept.size(), patch.size() - 4);
  EXPECT_EQ(kept.front(), patch[1]);
  for (const Eigen::Vector3f& p : noise) EXPECT_FALSE(containsPoint(kept, p, 1e-6f));
  EXPECT_FALSE(containsPoint(kept, at(0, 0, 100), 1e-6f));
  EXPECT_TRUE(containsPoint(kept, at(0, 7, 100), 1e-6f));  // border: 5 neighbours
  // 3 keeps the corners too; 0 keeps everything; 9 keeps nothing of a flat patch.
  EXPECT_EQ(PointCloudFilter::removeSparseVoxels(cloud, leaf, 3).size(), patch.size());
  EXPECT_EQ(PointCloudFilter::removeSparseVoxels(cloud, leaf, 0).size(), cloud.size());
  EXPECT_TRUE(PointCloudFilter::removeSparseVoxels(cloud, leaf, 9).empty());
  // Far-apart points (the hash set instead of the dense grid) and non-finite ones.
  PointCloud spread = cloud;
  spread.emplace_back(5e4f, -5e4f, 5e4f);
  spread.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.f, 1.f);
  const PointCloud kept_spread = PointCloudFilter::removeSparseVoxels(spread, leaf, 4);
  ASSERT_EQ(kept_spread.size(), kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(kept_spread[i], kept[i]);
}

TEST(PointCloudFilterOutliers, ConfiguredRemovalInBothChains) {
  // A voxelised patch with specks: voxel_neighbours and both statistical ones drop the specks,
  // none keeps them; the fused chain applies the same choice.
  PointCloud points = planePatch(1.0f, 0.4f, 0.005f, 0.0005f);
  const std::vector<Eigen::Vector3f> specks = {Eigen::Vector3f(0.2f, 0.2f, 1.3f),
                                               Eigen::Vector3f(0.6f, 0.1f, 0.8f)};
  points.insert(points.end(), specks.begin(), specks.end());
  for (const std::string mode :
       {"voxel_neighbours", "statistical", "statistical_centres", "none"}) {
    PointCloudFilter::Config config;
    config.outlier_removal = mode;
    ASSERT_TRUE(config.isValid().ok());
    const PointCloudFilter filter(config);
    for (const PointCloud& out : {filter.filterCameraFrame(points), filter.filterFused(points)}) {
      for (const Eigen::Vector3f& speck : specks) {
        EXPECT_EQ(containsPoint(out, speck, 0.006f), mode == "none") << mode;
      }
      EXPECT_GT(out.size(), 1000u) << mode;
    }
  }
  PointCloudFilter::Config bad;
  bad.outlier_removal = "median";
  EXPECT_FALSE(bad.isValid().ok());
  bad = PointCloudFilter::Config();
  bad.min_voxel_neighbours = 27;
  EXPECT_FALSE(bad.isValid().ok());
}

TEST(PointCloudFilterOutliers, TooFewPointsPassThrough) {
  const PointCloud points = {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0, 0.01f, 1),
                             Eigen::Vector3f(5, 5, 5)};
  EXPECT_EQ(PointCloudFilter::removeStatisticalOutliers(points, 20, 1.0).size(), points.size());
  EXPECT_TRUE(PointCloudFilter::removeStatisticalOutliers(PointCloud(), 20, 1.0).empty());
}

TEST(PointCloudFilterPipeline, CameraFrameAndFusedChains) {
  PointCloudFilter::Config config;
  config.voxel_leaf_size_m = 0.02;
  config.min_depth_m = 0.5;
  config.max_depth_m = 3.0;
  PointCloud points = planePatch(1.01f, 0.6f, 0.005f, 0.0005f);  // mid-voxel, 16 points a voxel
  points.emplace_back(0.3f, 0.3f, 3.5f);                         // beyond max depth
  points.emplace_back(0.3f, 0.3f, 2.0f);                         // in range but isolated
  const PointCloudFilter filter(config);
  const PointCloud filtered = filter.filterCameraFrame(points);
  EXPECT_FALSE(containsPoint(filtered, Eigen::Vector3f(0.3f, 0.3f, 3.5f), 0.05f));
  EXPECT_FALSE(containsPoint(filtered, Eigen::Vector3f(0.3f, 0.3f, 2.0f), 0.05f));
  // 0.6 m / 0.02 m = 30 voxels per side, a 900-voxel plane before outlier removal.
  EXPECT_GT(filtered.size(), 800u);
  EXPECT_LE(filtered.size(), 900u);
  // The fused chain has no depth range, so only the isolated points go.
  const PointCloud fused = filter.filterFused(points);
  EXPECT_GT(fused.size(), 800u);
  EXPECT_LE(fused.size(), 900u);
  // A cloud already on the same grid (the database's fusion grid) skips the voxel pass with the
  // same result, point for point; on another grid it is re-gridded.
  const PointCloud on_grid = PointCloudFilter::voxelize(points, config.voxel_leaf_size_m);
  EXPECT_EQ(filter.filterFused(on_grid, config.voxel_leaf_size_m), filter.filterFused(on_grid));
  EXPECT_EQ(filter.filterFused(points, 0.0), fused);
  EXPECT_GT(filter.filterFused(points, config.voxel_leaf_size_m).size(), fused.size());
  // enable = false is the "-Filter" ablation: the cloud passes through.
  config.enable = false;
  EXPECT_EQ(PointCloudFilter(config).filterCameraFrame(points).size(), points.size());
  EXPECT_EQ(PointCloudFilter(config).filterFused(points).size(), points.size());
}

TEST(PointCloudFilterConfig, Validation) {
  PointCloudFilter::Config config;
  EXPECT_TRUE(config.isValid().ok());
  EXPECT_NE(config.print().find("voxel_leaf_size_m: 0.01"), std::string::npos);
  PointCloudFilter::Config bad = config;
  bad.voxel_leaf_size_m = 0.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.voxel_leaf_size_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.max_depth_m = bad.min_depth_m;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.min_depth_m = -1.0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.sor_mean_k = 0;
  EXPECT_FALSE(bad.isValid().ok());
  bad = config;
  bad.sor_stddev_mul = -1.0;
  EXPECT_FALSE(bad.isValid().ok());
}

}  // namespace mvod
