#include "multiview_object_detection/pipeline/map/refinement.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace mvod {

namespace {

// Full (Eq. 11 case 4) is η_B = 1; the polygon clipping is exact up to rounding.
constexpr double kFullTolerance = 1e-6;

// A ratio to its prior in two significant figures, without an exponent: 0.0028, 0.18, 8.1, 120.
std::string ratioText(double ratio) {
  char text[32];
  std::snprintf(text, sizeof(text), ratio < 10.0 ? "%.2g" : "%.0f", ratio);
  return text;
}

std::string streamNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Volume of a box that can take part in an intersection, 0 for a degenerate or non-finite one (it
// has no volume to share, and η = V∩ / V must not divide by zero; Eq. 9 is what removes such
// boxes).
double usableVolume(const OrientedBox& box) {
  if (!box.center_m.allFinite() || !box.size_m.allFinite() || !box.rotation.allFinite()) return 0.0;
  if (!(box.size_m.minCoeff() > 0.0)) return 0.0;
  return box.volume();
}

// Eq. 10 for the pair (a, b): η_a = V∩ / V_a, η_b = V∩ / V_b, both in [0, 1].
void volumeRatios(const OrientedBox& a, double volume_a, const OrientedBox& b, double volume_b,
                  const Eigen::Vector3d& up, double* eta_a, double* eta_b) {
  *eta_a = 0.0;
  *eta_b = 0.0;
  if (!(volume_a > 0.0) || !(volume_b > 0.0)) return;
  // Boxes whose bounding spheres are apart cannot intersect: skips the polygon clipping.
  const double reach_m = 0.5 * (a.size_m.norm() + b.size_m.norm());
  if ((a.center_m - b.center_m).squaredNorm() > reach_m * reach_m) return;
  const double intersection = gravityAlignedIntersectionVolume(a, b, up);
  if (!(intersection > 0.0)) return;
  // Rounding can push V∩ a hair above the smaller volume.
  *eta_a = std::min(1.0, intersection / volume_a);
  *eta_b = std::min(1.0, intersection / volume_b);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// PriorSizeFilter (Sec. 3.5.1)

Status PriorSizeFilter::Config::isValid() const {
  if (!(std::isfinite(volume_min_ratio) && volume_min_ratio >= 0.0)) {
    return Status::Error("volume_min_ratio must be a finite value >= 0 (got " +
                         streamNumber(volume_min_ratio) + ")");
  }
  // An infinite volume_max_ratio is allowed: it means no upper volume limit.
  if (!(volume_max_ratio > 0.0 && volume_max_ratio >= volume_min_ratio)) {
    return Status::Error("volume_max_ratio must be > 0 and >= volume_min_ratio (got " +
                         streamNumber(volume_max_ratio) + ", volume_min_ratio " +
                         streamNumber(volume_min_ratio) + ")");
  }
  if (!(std::isfinite(edge_min_ratio) && edge_min_ratio >= 0.0)) {
    return Status::Error("edge_min_ratio must be a finite value >= 0 (got " +
                         streamNumber(edge_min_ratio) + ")");
  }
  return Status::Ok();
}

std::string PriorSizeFilter::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "volume_min_ratio: " << volume_min_ratio << "\n"
      << "volume_max_ratio: " << volume_max_ratio << "\n"
      << "edge_min_ratio: " << edge_min_ratio << "\n"
      << "keep_classes_without_prior: " << (keep_classes_without_prior ? "true" : "false") << "\n";
  return out.str();
}

bool PriorSizeFilter::isTypical(const MapObject& object, const ClassPriors& priors) const {
  return judge(object, priors) == Verdict::kTypical;
}

PriorSizeFilter::Verdict PriorSizeFilter::judge(const MapObject& object, const ClassPriors& priors,
                                                std::string* reason) const {
  const auto say = [reason](Verdict verdict, const std::string& text) {
    if (reason != nullptr) *reason = text;
    return verdict;
  };
  std::string class_name = object.class_name;
  if (class_name.empty() && object.class_id >= 0 &&
      object.class_id < static_cast<int>(cocoClassNames().size())) {
    class_name = cocoClassNames()[object.class_id];
  }
  const ClassPrior* prior = priors.find(class_name);
  if (prior == nullptr || !prior->has_size) {
    return config_.keep_classes_without_prior
               ? say(Verdict::kTypical, "")
               : say(Verdict::kNoPrior, "no size prior for its class (Eq. 9)");
  }
  const Eigen::Vector3d& size = object.box.size_m;
  if (!size.allFinite() || !(size.minCoeff() >= 0.0)) {
    return say(Verdict::kNoSize, "no valid box size (Eq. 9)");
  }
  // Eq. 9. The prior's L, W, H and the box's need not be in the same order: only the volume and the
  // shortest edge are compared.
  const double volume_ratio = size.prod() / prior->size_m.prod();
  const double edge_ratio = size.minCoeff() / prior->size_m.minCoeff();
  const std::string of = " for a " + class_name + ": ";
  if (!(volume_ratio >= config_.volume_min_ratio)) {
    return say(Verdict::kTooSmall,
               "too small" + of + "volume " + ratioText(volume_ratio) + " x its prior's (Eq. 9)");
  }
  if (!(volume_ratio <= config_.volume_max_ratio)) {
    return say(Verdict::kTooLarge,
               "too large" + of + "volume " + ratioText(volume_ratio) + " x its prior's (Eq. 9)");
  }
  if (!(edge_ratio >= config_.edge_min_ratio)) {
    return say(Verdict::kTooThin, "too thin" + of + "shortest edge " + ratioText(edge_ratio) +
                                      " x its prior's (Eq. 9)");
  }
  return say(Verdict::kTypical, "");
}

std::vector<int> PriorSizeFilter::atypicalObjects(const ObjectDatabase& database,
                                                  std::vector<Verdict>* verdicts,
                                                  std::vector<std::string>* reasons) const {
  std::vector<int> ids;
  if (!config_.enable) return ids;
  std::string reason;
  for (const auto& entry : database.objects()) {
    const Verdict verdict = judge(entry.second, database.priors(), &reason);
    if (verdict == Verdict::kTypical) continue;
    ids.push_back(entry.first);
    if (verdicts != nullptr) verdicts->push_back(verdict);
    if (reasons != nullptr) reasons->push_back(reason);
  }
  return ids;
}

// ---------------------------------------------------------------------------------------------
// IntersectionFilter (Sec. 3.5.2)

Status IntersectionFilter::Config::isValid() const {
  if (!(volume_ratio_threshold >= 0.0 && volume_ratio_threshold <= 1.0)) {
    return Status::Error("volume_ratio_threshold must be in [0, 1] (got " +
                         streamNumber(volume_ratio_threshold) + ")");
  }
  if (!(duplicate_ratio >= 0.0 && duplicate_ratio <= 1.0)) {
    return Status::Error("duplicate_ratio must be in [0, 1] (got " +
                         std::to_string(duplicate_ratio) + ")");
  }
  if (!(std::isfinite(flat_top_clearance_m) && flat_top_clearance_m >= 0.0)) {
    return Status::Error("flat_top_clearance_m must be a finite value >= 0 (got " +
                         streamNumber(flat_top_clearance_m) + ")");
  }
  if (!(container_support_ratio == 0.0 ||
        (std::isfinite(container_support_ratio) && container_support_ratio >= 1.0))) {
    return Status::Error("container_support_ratio must be 0 (off) or a finite value >= 1 (got " +
                         streamNumber(container_support_ratio) + ")");
  }
  return Status::Ok();
}

std::string IntersectionFilter::Config::print() const {
  std::ostringstream out;
  out << "enable: " << (enable ? "true" : "false") << "\n"
      << "volume_ratio_threshold: " << volume_ratio_threshold << "\n"
      << "duplicate_ratio: " << duplicate_ratio << "\n"
      << "merge_duplicates: " << (merge_duplicates ? "true" : "false") << "\n"
      << "container_support_ratio: " << container_support_ratio << "\n"
      << "flat_top_clearance_m: " << flat_top_clearance_m << "\n";
  return out.str();
}

OrientedBox IntersectionFilter::containmentBox(const MapObject& object, const ClassPriors& priors,
                                               const Eigen::Vector3d& up) const {
  OrientedBox box = object.seenBox();
  const ClassPrior* prior = priors.find(object.class_name);
  if (prior == nullptr || !prior->flat_top || !(config_.flat_top_clearance_m > 0.0)) return box;
  // Its vertical axis is up (gravity-aligned boxes); lower the top, keep the bottom.
  const double lowered = std::min(config_.flat_top_clearance_m, 0.5 * box.size_m.z());
  box.size_m.z() -= lowered;
  box.center_m -= 0.5 * lowered * up.normalized();
  return box;
}

double IntersectionFilter::support(const MapObject& object) {
  return object.observations * object.probability;
}

// Eq. 11 is written with B as the box that lies inside A. For an ordered pair in which A is the
// more contained one (η_A > η_B), the case reported is that of the pair with the roles swapped:
// the case describes the intersection (Fig. 4 a-d), and *eta_a / *eta_b (always for the pair as
// given) tell which box is inside. So Large / Full mean "the more contained box has η > Γ / = 1".
IntersectionFilter::Case IntersectionFilter::classify(const OrientedBox& a, const OrientedBox& b,
                                                      const Eigen::Vector3d& up, double* eta_a,
                                                      double* eta_b) const {
  double ratio_a = 0.0;
  double ratio_b = 0.0;
  volumeRatios(a, usableVolume(a), b, usableVolume(b), up, &ratio_a, &ratio_b);
  if (eta_a != nullptr) *eta_a = ratio_a;
  if (eta_b != nullptr) *eta_b = ratio_b;

  const double inner = std::max(ratio_a, ratio_b);
  if (ratio_a == 0.0 && ratio_b == 0.0) return Case::kNoIntersection;  // (1)
  if (inner <= config_.volume_ratio_threshold) return Case::kTiny;     // (2)
  if (inner >= 1.0 - kFullTolerance) return Case::kFull;               // (4)
  return Case::kLarge;                                                 // (3)
}

// Algorithm 1, read as follows (the pseudo-code leaves these open):
//  - ξ is the later object τ whose pair with σ has the largest containment max(η_σ, η_τ), i.e. the
//    partner most worth deleting or deleting σ for; line 9-14 then compare η_σ and η_ξ of that
//    pair: σ is deleted when it is the more contained one (η_σ > η_ξ, η_σ > Γ), else ξ when
//    η_ξ >= η_σ and η_ξ > Γ (equal ratios, e.g. two identical boxes: the later object goes).
//  - Objects already marked for deletion take no further part: no object is deleted twice and a
//    deleted object causes no other deletion.
//  - When ξ is deleted, σ's step is repeated over the remaining later objects until it deletes
//    nothing or deletes σ. Algorithm 1 as printed deletes at most one partner per σ, which would
//    keep the second of two objects lying inside one large object; Eq. 11 says every object mostly
//    inside another goes, and with the repetition nested chains (A ⊃ B ⊃ C) lose every inner box
//    whatever the id order.
std::vector<int> IntersectionFilter::intersectingObjects(
    const ObjectDatabase& database, const Eigen::Vector3d& up,
    std::vector<std::pair<int, int>>* duplicates) const {
  if (duplicates != nullptr) duplicates->clear();
  std::vector<int> deleted_ids;
  if (!config_.enable) return deleted_ids;

  std::vector<const MapObject*> objects;  // id order (std::map)
  // A completed box (amodal completion) reaches into what no view saw: a chair pushed under a
  // table would lie mostly inside the table's box. Containment is judged on what was seen, and a
  // flat top's box below its top (flat_top_clearance_m).
  std::vector<OrientedBox> boxes;
  std::vector<double> volumes;
  for (const auto& entry : database.objects()) {
    objects.push_back(&entry.second);
    boxes.push_back(containmentBox(entry.second, database.priors(), up));
    volumes.push_back(usableVolume(boxes.back()));
  }
  const size_t count = objects.size();
  const double threshold = config_.volume_ratio_threshold;
  std::vector<bool> deleted(count, false);

  struct Pair {
    size_t tau;
    double eta_sigma;
    double eta_tau;
  };
  std::vector<Pair> pairs;
  for (size_t sigma = 0; sigma < count; ++sigma) {
    if (deleted[sigma]) continue;
    // Eq. 10 against every later object (lines 3-7), computed once.
    pairs.clear();
    for (size_t tau = sigma + 1; tau < count; ++tau) {
      if (deleted[tau]) continue;
      Pair pair{tau, 0.0, 0.0};
      volumeRatios(boxes[sigma], volumes[sigma], boxes[tau], volumes[tau], up, &pair.eta_sigma,
                   &pair.eta_tau);
      if (pair.eta_sigma > 0.0 || pair.eta_tau > 0.0) pairs.push_back(pair);
    }
    while (true) {
      // Line 8: ξ = the remaining partner of largest containment (first one on ties).
      const Pair* xi = nullptr;
      for (const Pair& pair : pairs) {
        if (deleted[pair.tau]) continue;
        if (xi == nullptr ||
            std::max(pair.eta_sigma, pair.eta_tau) > std::max(xi->eta_sigma, xi->eta_tau)) {
          xi = &pair;
        }
      }
      if (xi == nullptr) break;
      if (config_.duplicate_ratio > 0.0 &&
          std::min(xi->eta_sigma, xi->eta_tau) > config_.duplicate_ratio) {
        if (support(*objects[sigma]) < support(*objects[xi->tau])) {
          deleted[sigma] = true;
          if (duplicates != nullptr) {
            duplicates->emplace_back(objects[sigma]->id, objects[xi->tau]->id);
          }
          break;
        }
        deleted[xi->tau] = true;
        if (duplicates != nullptr) {
          duplicates->emplace_back(objects[xi->tau]->id, objects[sigma]->id);
        }
        continue;
      }
      const bool sigma_inner = xi->eta_sigma > xi->eta_tau;
      if (config_.container_support_ratio > 0.0 &&
          (sigma_inner ? xi->eta_sigma : xi->eta_tau) > threshold) {
        const double inner = support(sigma_inner ? *objects[sigma] : *objects[xi->tau]);
        const double outer = support(sigma_inner ? *objects[xi->tau] : *objects[sigma]);
        if (inner >= config_.container_support_ratio * outer) {  // the container goes
          if (sigma_inner) {
            deleted[xi->tau] = true;
            continue;
          }
          deleted[sigma] = true;
          break;
        }
      }
      if (xi->eta_sigma > xi->eta_tau && xi->eta_sigma > threshold) {  // line 9
        deleted[sigma] = true;
        break;
      }
      if (xi->eta_tau >= xi->eta_sigma && xi->eta_tau > threshold) {  // line 12
        deleted[xi->tau] = true;
        continue;
      }
      break;  // the largest containment is at most Γ: no other partner can exceed it
    }
  }

  for (size_t i = 0; i < count; ++i) {
    if (deleted[i]) deleted_ids.push_back(objects[i]->id);
  }
  return deleted_ids;
}

}  // namespace mvod
