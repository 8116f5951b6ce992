#include "multiview_object_detection/datasets/trajectory.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <sstream>
#include <utility>

#include "multiview_object_detection/io/file_io.h"

namespace mvod {
namespace {

// The pose in `poses` (ascending) nearest to stamp_s within max_diff_s; null if none.
const StampedPose* nearestPose(const std::vector<StampedPose>& poses, double stamp_s,
                               double max_diff_s) {
  const auto after =
      std::lower_bound(poses.begin(), poses.end(), stamp_s,
                       [](const StampedPose& pose, double stamp) { return pose.stamp_s < stamp; });
  const StampedPose* best = nullptr;
  for (auto it : {after, after == poses.begin() ? poses.end() : after - 1}) {
    if (it == poses.end()) continue;
    const double diff = std::abs(it->stamp_s - stamp_s);
    if (diff <= max_diff_s && (best == nullptr || diff < std::abs(best->stamp_s - stamp_s))) {
      best = &*it;
    }
  }
  return best;
}

Status readIfGiven(const std::string& path, std::vector<StampedPose>* poses) {
  return path.empty() ? Status::Ok() : readTumTrajectory(path, poses);
}

}  // namespace

Status readTumTrajectory(const std::string& path, std::vector<StampedPose>* poses) {
  std::string text;
  const Status read = readFile(path, &text, kDefaultMaxFileBytes, Links::kFollow);
  if (!read) return read;
  std::istringstream lines(text);
  std::vector<StampedPose> parsed;
  int number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++number;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    double v[8];
    int count = 0;
    while (count < 8 && fields >> v[count]) ++count;
    std::string rest;
    const bool finite = std::all_of(v, v + count, [](double x) { return std::isfinite(x); });
    if (count != 8 || (fields >> rest) || !finite) {
      return Status::Error(path + ":" + std::to_string(number) +
                           ": expected 8 finite numbers 't tx ty tz qx qy qz qw' (TUM format)");
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-2) {
      return Status::Error(path + ":" + std::to_string(number) + ": the quaternion's norm is " +
                           std::to_string(q.norm()) + ", not 1");
    }
    StampedPose pose;
    pose.stamp_s = v[0];
    pose.T_W_C.linear() = q.normalized().toRotationMatrix();
    pose.T_W_C.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
    parsed.push_back(pose);
  }
  if (parsed.empty()) return Status::Error(path + ": no poses (TUM format, one per line)");
  std::stable_sort(parsed.begin(), parsed.end(), [](const StampedPose& a, const StampedPose& b) {
    return a.stamp_s < b.stamp_s;
  });
  *poses = std::move(parsed);
  return Status::Ok();
}

Status applyTrajectory(const TrajectoryOptions& options, DatasetSource* source) {
  if (options.trajectory.empty() && options.keyframes.empty()) return Status::Ok();
  std::vector<StampedPose> trajectory;
  std::vector<StampedPose> keyframes;
  Status status = readIfGiven(options.trajectory, &trajectory);
  if (status) status = readIfGiven(options.keyframes, &keyframes);
  if (!status) return status;
  // The poses the kept frames take: the keyframes' where given (final, optimised), else every
  // frame's.
  const auto poses = std::make_shared<std::vector<StampedPose>>(
      keyframes.empty() ? std::move(trajectory) : std::move(keyframes));
  if (!source->stamp_s) return Status::Error(source->directory + ": its frames have no stamps");
  const double max_diff_s = options.max_stamp_diff_s;
  const std::function<double(int)> stamp_s = source->stamp_s;
  const auto poseOf = [poses, stamp_s, max_diff_s](int index) {
    return nearestPose(*poses, stamp_s(index), max_diff_s);
  };
  std::vector<int> kept;
  for (const int index : source->indices) {
    if (poseOf(index) != nullptr) kept.push_back(index);
  }
  const std::string file = options.keyframes.empty() ? options.trajectory : options.keyframes;
  if (kept.empty()) {
    return Status::Error(file + ": no pose within " + std::to_string(max_diff_s) +
                         " s of any frame's stamp (" + source->directory + ")");
  }
  // The SLAM's world in the dataset's: from the first kept frame's two poses.
  Eigen::Isometry3d T_Wd_Ws = Eigen::Isometry3d::Identity();
  if (options.align_first_frame) {
    RgbdFrame first;
    if (!(status = source->load(kept.front(), &first))) return status;
    T_Wd_Ws = first.T_W_D * (poseOf(kept.front())->T_W_C * first.T_C_D).inverse();
  } else {
    source->has_gravity = false;
    source->notes.push_back("the trajectory's world is not the dataset's: gravity is estimated");
  }
  std::ostringstream note;
  note << "poses from " << file << ": " << kept.size() << " of " << source->indices.size()
       << " frames have one"
       << (options.align_first_frame ? ", the trajectory's world aligned to the dataset's at "
                                       "its first frame"
                                     : "");
  source->notes.push_back(note.str());
  const auto load = source->load;
  source->load = [load, poseOf, T_Wd_Ws](int index, RgbdFrame* frame) {
    RgbdFrame loaded;
    const Status status = load(index, &loaded);
    if (!status) return status;
    const StampedPose* pose = poseOf(index);
    if (pose == nullptr) return Status::Error("no trajectory pose for frame " + loaded.name);
    loaded.T_W_D = T_Wd_Ws * pose->T_W_C * loaded.T_C_D;
    *frame = std::move(loaded);
    return Status::Ok();
  };
  source->indices = std::move(kept);
  return Status::Ok();
}

}  // namespace mvod
