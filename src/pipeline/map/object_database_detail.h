// Evidence helpers shared by ObjectDatabase's source files (object_database.cpp,
// object_database_rebox.cpp). Private to the pipeline library.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/map/depth_view.h"
#include "multiview_object_detection/pipeline/map/object_database.h"

namespace mvod {
namespace object_database_detail {

// This view's signed distance of every voxel of the object it sees (the view's cost: the
// object's voxels, one projection each), over the entries [first, last): each voxel is one entry,
// so disjoint ranges can run in parallel with the same result.
void addSignedDistances(const DepthView& view, double voxel_size_m, EvidenceMap* evidence,
                        std::size_t first, std::size_t last);
// ... over all entries.
void addSignedDistances(const DepthView& view, double voxel_size_m, EvidenceMap* evidence);

// The distinct voxel keys of points_W, ascending (packed keys are non-negative: their order as
// unsigned is their order), radix-sorted instead of hashed.
std::vector<std::int64_t> voxelKeys(const PointCloud& points_W, double voxel_size_m);

// Evidence fusion's class vote: `score` more for `class_name`; the object takes the class with the
// largest sum. An object without scores yet (a map saved before them) starts from its own class.
void addClassScore(const std::string& class_name, double score, MapObject* object);

}  // namespace object_database_detail
}  // namespace mvod
