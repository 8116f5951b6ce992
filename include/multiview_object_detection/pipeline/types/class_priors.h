// Per-class prior knowledge (config/class_priors.yaml): typical size for the atypical-object filter
// (Eq. 9) and the centre distance under which two detections of the class are the same object
// (Eq. 6).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// The 80 COCO class names in the usual contiguous order (FastestDet/YOLO order). Class ids used in
// this package's outputs are indices into this list.
const std::vector<std::string>& cocoClassNames();
// Index of a COCO class name, or -1 if it is not one.
int cocoClassId(const std::string& class_name);

struct ClassPrior {
  std::string class_name;
  // Typical length x width x height (m); has_size false when the YAML gives no size.
  bool has_size = false;
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  // Eq. 6 threshold Γ_C for this class (m).
  double fusion_distance_m = 0.0;
  // The cut's knowledge of how the class stands (SegmentSelector, "consistent" only):
  // on_floor: it stands on the floor, so what rests on another horizontal surface in its detection
  // (cups on a table in a chair's box) is not part of it.
  bool on_floor = false;
  // flat_top: its top is a support surface (a table), so nothing above or beside that surface is
  // part of it, and its box reaches the floor however little of its legs is seen.
  bool flat_top = false;
  // amodal_depth_m: the horizontal depth of the whole object (a chair's, seat and backrest); a box
  // much thinner than it (only a backrest seen above a table) is completed to it on the side the
  // views never saw through (AmodalCompletion). 0: never completed.
  double amodal_depth_m = 0.0;
  // on_wall: it hangs flat on a wall (a wall monitor, a clock), a few centimetres proud of it: at
  // the depths it is seen from, its front and the wall are one plane in depth. A detection whose
  // core holds only a wall is then the wall's points inside its mask, as a book's is its support's.
  bool on_wall = false;

  // Shapes derived from the fields above (no YAML of their own), for the cut:
  // A class with horizontal surfaces larger than any mask of it covers cleanly (a table's top, a
  // bed's mattress, a couch's seat): flat_top classes, and floor-standing ones at least
  // kLargeSurfaceM across both ways. In its detection, a horizontal plane running past the mask is
  // its own surface, not a bounding one.
  static constexpr double kLargeSurfaceM = 0.8;
  bool hasLargeHorizontalSurface() const;
  // A class that lies flat on a support (a book, a keyboard, a phone): not floor-standing, its
  // shortest prior edge at most kFlatEdgeM. In depth it is part of the support's plane.
  static constexpr double kFlatEdgeM = 0.04;
  bool liesFlat() const;
};

class ClassPriors {
 public:
  // Fusion distance used for classes the file does not list (m).
  double default_fusion_distance_m = 0.5;

  // Parses a YAML file of the form
  //   default_fusion_distance_m: 0.5
  //   classes:
  //     chair: {size_m: [0.55, 0.55, 0.9], fusion_distance_m: 0.4}
  // Returns an error naming the file and the entry on any malformed value.
  static Status loadYaml(const std::string& path, ClassPriors* priors);
  static Status parseYaml(const std::string& yaml_text, ClassPriors* priors);

  void set(const ClassPrior& prior) { priors_[prior.class_name] = prior; }
  // nullptr when the class has no prior.
  const ClassPrior* find(const std::string& class_name) const;
  double fusionDistance(const std::string& class_name) const;
  const std::map<std::string, ClassPrior>& all() const { return priors_; }

 private:
  std::map<std::string, ClassPrior> priors_;
};

}  // namespace mvod
