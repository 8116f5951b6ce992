#include "multiview_object_detection/datasets/scenenn_annotation.h"

#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "multiview_object_detection/io/json_io.h"

namespace mvod {
namespace {

// Whitespace-separated finite numbers, exactly `count` of them.
bool parseNumbers(const std::string& text, size_t count, std::vector<double>* out) {
  std::istringstream in(text);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) return false;
    values.push_back(v);
  }
  if (values.size() != count) return false;
  *out = std::move(values);
  return true;
}

// The first element called `name` at or below `node`, depth first.
const tinyxml2::XMLElement* findElement(const tinyxml2::XMLNode* node, const char* name) {
  for (const tinyxml2::XMLElement* child = node->FirstChildElement(); child != nullptr;
       child = child->NextSiblingElement()) {
    if (std::strcmp(child->Name(), name) == 0) return child;
    if (const tinyxml2::XMLElement* found = findElement(child, name)) return found;
  }
  return nullptr;
}

// Every element called `name` below `node`, in document order.
void collectElements(const tinyxml2::XMLNode* node, const char* name,
                     std::vector<const tinyxml2::XMLElement*>* out) {
  for (const tinyxml2::XMLElement* child = node->FirstChildElement(); child != nullptr;
       child = child->NextSiblingElement()) {
    if (std::strcmp(child->Name(), name) == 0) out->push_back(child);
    collectElements(child, name, out);
  }
}

Status parseLabel(const tinyxml2::XMLElement& element, const std::string& where,
                  SceneNNLabel* label) {
  const char* id = element.Attribute("id");
  if (id == nullptr) return Status::Error(where + ": missing id");
  char* id_end = nullptr;
  const long id_value = std::strtol(id, &id_end, 10);
  if (*id == '\0' || *id_end != '\0' || id_value < 0 || id_value > 2000000000L) {
    return Status::Error(where + ": bad id '" + id + "'");
  }
  label->id = static_cast<int>(id_value);
  const char* text = element.Attribute("text");
  if (text == nullptr) return Status::Error(where + ": missing text");
  label->text = text;
  if (const char* nyu = element.Attribute("nyu_class")) label->nyu_class = nyu;
  const char* aabb = element.Attribute("aabbox");
  std::vector<double> numbers;
  if (aabb == nullptr) return Status::Error(where + ": missing aabbox");
  if (!parseNumbers(aabb, 6, &numbers)) return Status::Error(where + ": aabbox needs 6 numbers");
  label->aabb_min = Eigen::Vector3d(numbers[0], numbers[1], numbers[2]);
  label->aabb_max = Eigen::Vector3d(numbers[3], numbers[4], numbers[5]);
  if (const char* obb = element.Attribute("obbox")) {
    if (!parseNumbers(obb, 10, &numbers)) {
      return Status::Error(where + ": obbox needs 10 numbers (cx cy cz dx dy dz qx qy qz qw)");
    }
    label->has_obbox = true;
    for (int i = 0; i < 10; ++i) label->obbox[i] = numbers[i];
  }
  return Status::Ok();
}

}  // namespace

Status readSceneNNXml(const std::string& path, std::vector<SceneNNLabel>* labels) {
  if (labels == nullptr) return Status::Error(path + ": no output");
  std::string text;
  const Status status = readFile(path, &text);
  if (!status) return status;
  tinyxml2::XMLDocument document;
  if (document.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS) {
    return Status::Error(path + ": not valid XML: " + document.ErrorStr());
  }
  const tinyxml2::XMLElement* annotation = findElement(&document, "annotation");
  if (annotation == nullptr) return Status::Error(path + ": no <annotation> element");
  std::vector<const tinyxml2::XMLElement*> elements;
  collectElements(annotation, "label", &elements);
  std::vector<SceneNNLabel> parsed(elements.size());
  for (size_t i = 0; i < elements.size(); ++i) {
    const std::string where = path + ": <label> #" + std::to_string(i + 1);
    const Status label = parseLabel(*elements[i], where, &parsed[i]);
    if (!label) return label;
  }
  *labels = std::move(parsed);
  return Status::Ok();
}

}  // namespace mvod
