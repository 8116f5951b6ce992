// Furniture of the synthetic rooms (SyntheticScene::makeRoom): multi-part pieces built from solid
// boxes ("parts") in the piece's own frame, placed in the world by assemble().
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "multiview_object_detection/simulation/split_mix.h"
#include "multiview_object_detection/simulation/synthetic_scene.h"

namespace mvod {
namespace simulation {

// One part in the furniture's own frame: x = width, y = depth (+y = front), z up from its base.
struct LocalPart {
  Eigen::Vector3d lo;
  Eigen::Vector3d hi;
};

LocalPart part(double x0, double y0, double z0, double x1, double y1, double z1);

// Places local parts at `origin_W` (the local frame's origin) turned by `yaw`: the object's box is
// the union of the parts in its own frame, so it is the tightest box in that yaw.
SyntheticObject assemble(const std::string& name, const Eigen::Vector3d& origin_W, double yaw,
                         const std::vector<LocalPart>& parts);

// Four legs, a seat and a back at -y.
std::vector<LocalPart> chairParts(double w, double d, double seat_h, double h);
// A top on four legs.
std::vector<LocalPart> tableParts(double w, double d, double h);
// A seat, a back at -y and two arms.
std::vector<LocalPart> couchParts(double w, double d, double h);
// Headboard at -y, foot at +y.
std::vector<LocalPart> bedParts(double w, double l);
// A flat screen on a foot; the screen faces +y.
std::vector<LocalPart> tvParts(double w, double h);
// A body with two door handles at +y.
std::vector<LocalPart> fridgeParts(double w, double d, double h);
// A cup with its handle on the +x side.
std::vector<LocalPart> cupParts();
// An open bookshelf: two sides, a back, `levels` + 1 boards (bottom and top included); board i
// spans z in [i * spacing, i * spacing + 0.02].
std::vector<LocalPart> shelfParts(double w, double d, double h, int levels, double* spacing);

// A chair of random size (width, depth, seat and back height) at origin, turned by yaw.
SyntheticObject makeChair(SplitMix64& rng, const Eigen::Vector3d& origin, double yaw);

}  // namespace simulation
}  // namespace mvod
