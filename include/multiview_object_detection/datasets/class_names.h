// Class names of the datasets and detectors mapped onto the evaluation's classes (COCO names).
#pragma once

#include <string>

namespace mvod {

// Maps dataset / detector class names to one evaluation class: COCO names stay (sofa -> couch,
// table -> dining table, television / monitor -> tv, books -> book, fridge -> refrigerator, ...),
// and NYU's "bag" plus COCO's backpack / handbag / suitcase all become "bag" (no single COCO
// class). Lower-cased and trimmed; an unknown name is returned as it is (lower-cased, trimmed).
std::string canonicalClassName(const std::string& name);
// SceneNN / NYU label text -> evaluation class, or "" for labels that are not evaluated (walls,
// floor, desk, unknown ...): the nine classes the paper's Table 1 shares between COCO and NYU.
std::string sceneNNClassName(const std::string& label_text);

}  // namespace mvod
