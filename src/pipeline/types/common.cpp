#include "multiview_object_detection/pipeline/types/common.h"

#include <Eigen/SVD>

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

bool isValidPose(const Eigen::Isometry3d& T, double tol) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3d R = T.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), tol)) return false;
  return R.determinant() > 0.0;
}

}  // namespace mvod
