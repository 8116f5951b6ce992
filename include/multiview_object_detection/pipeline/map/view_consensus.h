// Evidence fusion: the box of an object that each of its views saw whole, from the views' own
// boxes instead of the union of their cuts.
#pragma once

#include <vector>

#include "multiview_object_detection/pipeline/types/oriented_box.h"

namespace mvod {

// Fewer views than this keep the union's box.
constexpr int kViewConsensusMinViews = 3;

// Views of one object fuse into the union of where each view put it, so the error of the poses
// between the views (a few centimetres, SLAM's or a dataset's) widens the fused box by their
// spread: an 11 cm mug is boxed 18 cm long. Along each axis of `box` (the union's box), each view's
// box spans an interval. The consensus ends are the lower quartile of the views' lower ends and the
// upper quartile of their upper ends: where at least a quarter of the views reach. Where the union
// is wider than that by at most max_disagreement_m on every axis, the views saw the object whole
// and differ by pose error: `box` becomes the consensus (same rotation, within the union). An
// object seen in parts (a table seen half at a time, a chair from the front and the side) differs
// more on some axis and keeps the union. Returns whether `box` changed; never with fewer than
// kViewConsensusMinViews views with finite boxes, or max_disagreement_m <= 0.
bool viewConsensusBox(const std::vector<OrientedBox>& view_boxes, double max_disagreement_m,
                      OrientedBox* box);

}  // namespace mvod
