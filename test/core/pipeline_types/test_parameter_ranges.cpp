// The table of parameter ranges: its entries are parameters of config/object_detection.yaml (or
// read by the node beside it) whose defaults lie inside, the check refuses just beyond each bound,
// and docs/parameters.md holds the table as print_parameter_ranges prints it.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>
#include <sstream>

#include "multiview_object_detection/pipeline/types/parameter_ranges.h"
#include "test_files.h"

namespace mvod {
namespace {

// The YAML node of "a/b/c" in `root` (undefined when absent).
YAML::Node lookup(const YAML::Node& root, const std::string& name) {
  YAML::Node node = YAML::Clone(root);
  std::stringstream parts(name);
  std::string part;
  while (std::getline(parts, part, '/')) {
    if (!node.IsMap() || !node[part]) return YAML::Node(YAML::NodeType::Undefined);
    node = node[part];
  }
  return node;
}

// Parameters the node reads but that the shipped file leaves at their built-in default.
bool notInTheShippedFile(const std::string& name) { return name == "box/outline_cell_m"; }

TEST(ParameterRangesTest, EveryRangeIsAParameterWhoseDefaultLiesInside) {
  const YAML::Node file =
      YAML::LoadFile(std::string(MVOD_SOURCE_DIR) + "/config/object_detection.yaml");
  ASSERT_FALSE(parameterRanges().empty());
  for (const ParameterRange& range : parameterRanges()) {
    SCOPED_TRACE(range.name);
    EXPECT_LT(range.min, range.max);
    EXPECT_GE(range.min, 0.0);
    const std::string name = range.name;
    if (name.size() > 2 && name.compare(name.size() - 2, 2, "_m") == 0) {
      EXPECT_STREQ(range.unit, "m");
    } else if ((name.size() > 2 && name.compare(name.size() - 2, 2, "_s") == 0) ||
               name == "diagnostic_period") {  // diagnostic_updater's name
      EXPECT_STREQ(range.unit, "s");
    } else if (name.size() > 3 && name.compare(name.size() - 3, 3, "_hz") == 0) {
      EXPECT_STREQ(range.unit, "Hz");
    } else if (name.size() > 3 && name.compare(name.size() - 3, 3, "_mb") == 0) {
      EXPECT_STREQ(range.unit, "MB");
    } else {
      EXPECT_STREQ(range.unit, "");
    }
    if (notInTheShippedFile(name)) continue;
    const YAML::Node value = lookup(file, name);
    ASSERT_TRUE(value.IsScalar()) << "not in config/object_detection.yaml";
    EXPECT_TRUE(checkParameterRange(name, value.as<double>()).ok())
        << checkParameterRange(name, value.as<double>()).message();
  }
}

TEST(ParameterRangesTest, BoundsAreAcceptedAndJustBeyondRefusedNamingTheRange) {
  for (const ParameterRange& range : parameterRanges()) {
    SCOPED_TRACE(range.name);
    EXPECT_TRUE(checkParameterRange(range.name, range.min).ok());
    EXPECT_TRUE(checkParameterRange(range.name, range.max).ok());
    // Counts step by one; sizes and times by a thousandth of their lower bound (or of 1).
    const bool count = range.unit[0] == '\0';
    const double below = count ? range.min - 1.0 : range.min - 1e-3 * std::max(range.min, 1e-3);
    const double above = count ? range.max + 1.0 : range.max * 1.001;
    for (const double value :
         {below, above, std::nan(""), std::numeric_limits<double>::infinity(), 1e300, -1e300}) {
      if (range.zero_is_off && value == 0.0) continue;
      const Status status = checkParameterRange(range.name, value);
      EXPECT_FALSE(status.ok()) << value;
      EXPECT_NE(status.message().find(std::string(range.name) + " must be"), std::string::npos)
          << status.message();
      EXPECT_NE(status.message().find(range.why), std::string::npos) << status.message();
    }
    EXPECT_EQ(checkParameterRange(range.name, 0.0).ok(), range.zero_is_off || range.min == 0.0);
  }
  EXPECT_FALSE(checkParameterRange("no/such_parameter", 1.0).ok());
}

TEST(ParameterRangesTest, TheParameterDocsHoldTheTable) {
  const std::string docs = test::readText(std::string(MVOD_SOURCE_DIR) + "/docs/parameters.md");
  EXPECT_NE(docs.find(parameterRangesMarkdown()), std::string::npos)
      << "docs/parameters.md does not hold the current table; regenerate it with\n"
         "  print_parameter_ranges --update docs/parameters.md\n"
      << parameterRangesMarkdown();
}

}  // namespace
}  // namespace mvod
