// Sec. 3.5: database refinement - atypical sizes (Eq. 9) and objects mostly inside others (Eq. 10,
// 11, Algorithm 1).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "multiview_object_detection/pipeline/map/object_database.h"
#include "multiview_object_detection/pipeline/types/class_priors.h"

namespace mvod {

class PriorSizeFilter {
 public:
  struct Config {
    bool enable = true;
    double volume_min_ratio = 0.05;  // Γ_Vmin
    double volume_max_ratio = 8.0;   // Γ_Vmax
    double edge_min_ratio = 0.2;     // Γ_E
    bool keep_classes_without_prior = true;
    Status isValid() const;
    std::string print() const;
  };
  PriorSizeFilter() = default;
  explicit PriorSizeFilter(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // Eq. 9's verdict on a box: typical, or which limit it breaks.
  enum class Verdict { kTypical, kTooSmall, kTooLarge, kTooThin, kNoPrior, kNoSize };
  // Eq. 9 on the box of `object`; *reason (when given) says why it is atypical in a user's words
  // ("too small for a chair: volume 0.035 x its prior's (Eq. 9)"), empty when it is typical.
  Verdict judge(const MapObject& object, const ClassPriors& priors,
                std::string* reason = nullptr) const;
  // Eq. 9: true when the box of `object` is a plausible size for its class.
  bool isTypical(const MapObject& object, const ClassPriors& priors) const;
  // Ids of the objects Eq. 9 rejects, in id order; per id its verdict and reason (when given).
  std::vector<int> atypicalObjects(const ObjectDatabase& database,
                                   std::vector<Verdict>* verdicts = nullptr,
                                   std::vector<std::string>* reasons = nullptr) const;

 private:
  Config config_;
};

class IntersectionFilter {
 public:
  struct Config {
    bool enable = true;
    double volume_ratio_threshold = 0.5;  // Γ_V∩ of Eq. 11
    // Duplicates: when each of two objects lies mostly inside the other (both ratios above this),
    // they are one object detected under two labels (a chair sometimes called a couch); the one
    // with less support (observations x probability) goes, whatever their sizes and ids.
    // 0 = Algorithm 1 as published (the more contained one goes, the later one on ties).
    double duplicate_ratio = 0.5;
    // Evidence fusion: the deleted duplicate's views are merged into the one kept (its voxels'
    // votes, observations, class scores) and the merged object re-boxed, instead of being lost: an
    // object whose first views saw disjoint parts is mapped twice, and each copy has parts the
    // other lacks (a chair's legs, its backrest). false, and in the single-frame baseline
    // (database disable_fusion): the duplicate is deleted.
    bool merge_duplicates = true;
    // Containers: of an object mostly inside another (Eq. 11), Algorithm 1 deletes the inner
    // one. When the inner one has at least this many times the container's support, the container
    // goes instead: a real container is in view whenever what lies inside it is, so it collects
    // comparable support; one that a few detections made around several objects (a box spanning
    // two chairs called a couch in 3 keyframes, the chairs seen in 8 and 19) does not.
    // 0 = Algorithm 1 as published (the inner one goes, whatever the support).
    double container_support_ratio = 2.0;
    // Flat tops (flat_top classes: a table): what stands or lies on the top rises above it and is
    // not inside the table (Eq. 11 removed a book lying on the table, its thin box reaching a
    // centimetre into the table's). The table's box is taken this far below its top when judging
    // what lies in it. 0 = Algorithm 1 as published.
    double flat_top_clearance_m = 0.05;
    Status isValid() const;
    std::string print() const;
  };
  // The case of Eq. 11 a pair falls in.
  enum class Case { kNoIntersection = 1, kTiny = 2, kLarge = 3, kFull = 4 };

  IntersectionFilter() = default;
  explicit IntersectionFilter(const Config& config) : config_(config) {}
  const Config& config() const { return config_; }

  // Eq. 10, 11 for one ordered pair (η_A = V∩/V_A, η_B = V∩/V_B); Full when B lies entirely inside
  // A.
  // What the refinement weighs objects by: observations x probability (Eq. 8's running value).
  static double support(const MapObject& object);
  // The box an object's containment is judged on: what its views saw, for a flat_top class
  // without its top flat_top_clearance_m.
  OrientedBox containmentBox(const MapObject& object, const ClassPriors& priors,
                             const Eigen::Vector3d& up) const;

  Case classify(const OrientedBox& a, const OrientedBox& b, const Eigen::Vector3d& up,
                double* eta_a = nullptr, double* eta_b = nullptr) const;
  // Algorithm 1 over the objects in id order: for each σ, ξ is the later object whose containment
  // ratio with σ is largest; whichever of the two is more contained (ratio above the threshold) is
  // deleted (or the container, see container_support_ratio).
  // duplicates (optional): for each object deleted by the duplicate rule, (its id, the id of the
  // object it duplicates), so that a caller can merge the two instead of losing the deleted one's
  // views (ObjectDatabase::mergeInto).
  std::vector<int> intersectingObjects(
      const ObjectDatabase& database, const Eigen::Vector3d& up,
      std::vector<std::pair<int, int>>* duplicates = nullptr) const;

 private:
  Config config_;
};

}  // namespace mvod
