#include "multiview_object_detection/pipeline/types/common.h"

#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <thread>

namespace mvod {

PointCloud transformCloud(const PointCloud& points_A, const Eigen::Isometry3d& T_B_A) {
  const Eigen::Matrix3f R = T_B_A.linear().cast<float>();
  const Eigen::Vector3f t = T_B_A.translation().cast<float>();
  PointCloud points_B;
  points_B.reserve(points_A.size());
  for (const Eigen::Vector3f& p : points_A) points_B.emplace_back(R * p + t);
  return points_B;
}

Eigen::Matrix3d nearestRotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  if ((U * svd.matrixV().transpose()).determinant() < 0.0) U.col(2) *= -1.0;
  return U * svd.matrixV().transpose();
}

void parallelRanges(std::size_t count, int threads, std::size_t min_per_thread,
                    const std::function<void(std::size_t, std::size_t)>& job) {
  const std::size_t by_size = count / std::max<std::size_t>(1, min_per_thread);
  const std::size_t workers =
      std::max<std::size_t>(1, std::min(by_size, static_cast<std::size_t>(std::max(1, threads))));
  if (workers <= 1) {
    if (count > 0) job(0, count);
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  const auto begin_of = [count, workers](std::size_t w) { return count * w / workers; };
  for (std::size_t w = 1; w < workers; ++w) {
    pool.emplace_back([&job, &begin_of, w] { job(begin_of(w), begin_of(w + 1)); });
  }
  job(0, begin_of(1));
  for (std::thread& thread : pool) thread.join();
}

void parallelForEach(std::size_t count, int threads, const std::function<void(std::size_t)>& job) {
  const std::size_t workers = std::min(count, static_cast<std::size_t>(std::max(1, threads)));
  if (workers <= 1) {
    for (std::size_t i = 0; i < count; ++i) job(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t i = next++; i < count; i = next++) job(i);
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& thread : pool) thread.join();
}

bool isValidPose(const Eigen::Isometry3d& T, double tol) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), tol)) return false;
  return R.determinant() > 0.0;
}

}  // namespace mvod
