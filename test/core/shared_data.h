// Where the tests find ../shared (models, real data): $MVOD_SHARED_DIR, else <repo>/../shared.
// Tests that need it skip with a message naming the path when it is absent.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace mvod {
namespace test {

// The folder `sub` of the shared folder (e.g. "models", "data/7scenes_redkitchen/data"), canonical;
// empty when it does not exist.
inline std::string sharedPath(const std::string& sub = "") {
  namespace fs = std::filesystem;
  const char* env = std::getenv("MVOD_SHARED_DIR");
  fs::path dir =
      env != nullptr && *env != '\0' ? fs::path(env) : fs::path(MVOD_SOURCE_DIR) / ".." / "shared";
  if (!sub.empty()) dir /= sub;
  std::error_code error;
  return fs::is_directory(dir, error) ? fs::canonical(dir, error).string() : std::string();
}

}  // namespace test
}  // namespace mvod
