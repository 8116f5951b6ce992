// The ranges of the numeric parameters that size a keyframe's work and memory (voxel sizes against
// the sensor's resolution, iteration and neighbour counts, queue lengths, ages): one table, used by
// the Configs' isValid() (so by the node at start, the nodelet, dynamic_reconfigure's updates and
// offline_detection), compared with dynamic_reconfigure's limits by a test, and printed into
// docs/parameters.md by print_parameter_ranges.
#pragma once

#include <string>
#include <vector>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

struct ParameterRange {
  const char* name;  // as in config/object_detection.yaml, e.g. "filter/voxel_leaf_size_m"
  double min;        // closed range [min, max]
  double max;
  const char* unit;  // "m", "s", "" for counts
  bool zero_is_off;  // 0 is accepted too and switches the step off
  const char* why;   // what the bounds keep bounded
};

// Every range, in the order of the parameter file.
const std::vector<ParameterRange>& parameterRanges();

// The range of `name`; nullptr when it has none.
const ParameterRange* findParameterRange(const std::string& name);

// Ok, or "NAME must be in [MIN, MAX] UNIT (got VALUE): WHY". A name without a range is a
// programming error and reported as such.
Status checkParameterRange(const std::string& name, double value);

// The table as Markdown (name, range, unit, why), as docs/parameters.md holds it.
std::string parameterRangesMarkdown();

}  // namespace mvod
