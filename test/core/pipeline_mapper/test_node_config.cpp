// config/object_detection.yaml, the node's parameter file, against ObjectMapper::Config: the node
// applies `paper_method: true` first and then every parameter the file sets, so the file must not
// set any setting that usePaperMethod() changes (it would silently undo the paper's method).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <map>
#include <set>
#include <sstream>
#include <string>

#include "multiview_object_detection/pipeline/object_mapper.h"

namespace mvod {
namespace {

// "section.key: value" lines of Config::print() as key -> value.
std::map<std::string, std::string> printed(const ObjectMapper::Config& config) {
  std::map<std::string, std::string> values;
  std::istringstream lines(config.print());
  for (std::string line; std::getline(lines, line);) {
    const size_t colon = line.find(": ");
    if (colon != std::string::npos) values[line.substr(0, colon)] = line.substr(colon + 2);
  }
  return values;
}

// Every key the YAML file sets, as "section.key" (nested maps joined by dots).
void collectKeys(const YAML::Node& node, const std::string& prefix, std::set<std::string>* keys) {
  for (const auto& entry : node) {
    const std::string key = prefix + entry.first.as<std::string>();
    if (entry.second.IsMap()) {
      collectKeys(entry.second, key + ".", keys);
    } else {
      keys->insert(key);
    }
  }
}

TEST(NodeConfigFileTest, SetsNothingThatThePaperMethodChanges) {
  ObjectMapper::Config paper;
  paper.usePaperMethod();
  const std::map<std::string, std::string> defaults = printed(ObjectMapper::Config());
  const std::map<std::string, std::string> paper_values = printed(paper);
  std::set<std::string> changed;
  for (const auto& entry : defaults) {
    if (paper_values.at(entry.first) != entry.second) changed.insert(entry.first);
  }
  // The switch changes several settings (guards against a print() that lost them).
  ASSERT_GE(changed.size(), 5u);
  EXPECT_EQ(changed.count("database.fusion"), 1u);

  const YAML::Node file =
      YAML::LoadFile(std::string(MVOD_SOURCE_DIR) + "/config/object_detection.yaml");
  std::set<std::string> keys;
  collectKeys(file, "", &keys);
  ASSERT_EQ(keys.count("paper_method"), 1u);
  ASSERT_GT(keys.size(), 30u);
  // The node reads the segment selection as lccp/selection.
  if (keys.erase("lccp.selection") != 0) keys.insert("selection.selection");
  for (const std::string& key : changed) {
    EXPECT_EQ(keys.count(key), 0u)
        << key << " is set in config/object_detection.yaml: it would override paper_method: true";
  }
}

}  // namespace
}  // namespace mvod
