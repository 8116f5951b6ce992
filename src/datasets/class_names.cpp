#include "multiview_object_detection/datasets/class_names.h"

#include <cctype>
#include <map>
#include <set>

namespace mvod {
namespace {

std::string lowerTrim(const std::string& name) {
  size_t begin = 0;
  size_t end = name.size();
  while (begin < end && std::isspace(static_cast<unsigned char>(name[begin]))) ++begin;
  while (end > begin && std::isspace(static_cast<unsigned char>(name[end - 1]))) --end;
  std::string out = name.substr(begin, end - begin);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

std::string canonicalClassName(const std::string& name) {
  static const std::map<std::string, std::string> kSynonyms = {
      {"sofa", "couch"},
      {"table", "dining table"},
      {"diningtable", "dining table"},
      {"dining_table", "dining table"},
      {"television", "tv"},
      {"tvmonitor", "tv"},
      {"monitor", "tv"},
      {"books", "book"},
      {"fridge", "refrigerator"},
      {"refridgerator", "refrigerator"},  // NYU40's spelling
      {"backpack", "bag"},
      {"handbag", "bag"},
      {"suitcase", "bag"}};
  const std::string key = lowerTrim(name);
  const auto it = kSynonyms.find(key);
  return it == kSynonyms.end() ? key : it->second;
}

std::string sceneNNClassName(const std::string& label_text) {
  // The nine classes COCO and NYU share (the paper's Table 1). Desk is its own NYU class: left out.
  static const std::set<std::string> kEvaluated = {
      "bed", "chair", "couch", "dining table", "book", "refrigerator", "tv", "toilet", "bag"};
  std::string key = lowerTrim(label_text);
  // SceneNN instance texts sometimes carry a number ("chair2").
  while (!key.empty() && std::isdigit(static_cast<unsigned char>(key.back()))) key.pop_back();
  if (key == "coffee table") key = "table";
  const std::string name = canonicalClassName(key);
  return kEvaluated.count(name) ? name : std::string();
}

}  // namespace mvod
