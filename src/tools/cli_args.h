// Strict number parsing for the command-line tools: the whole text must be a number in range.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string>

namespace mvod {
namespace cli {

inline bool parseLong(const std::string& text, long min_value, long max_value, long* value) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0 || v < min_value || v > max_value) return false;
  *value = v;
  return true;
}

inline bool parseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

}  // namespace cli
}  // namespace mvod
