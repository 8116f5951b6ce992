// What an autosave (or ~save_map) of a given map costs: the map file is loaded, then serialised
// (objectsToJson with clouds and the keyframe history, as the node writes it) and written
// (writeFileAtomic, fsync included) N times; medians and the size are printed.
//   devel/lib/multiview_object_detection/bench_map_save MAP.json [REPEATS] [OUTPUT_DIR]
// e.g. the redkitchen map that `make demo DATASET=...` autosaves to build/demo/.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <string>
#include <vector>

#include "multiview_object_detection/io/json_io.h"

namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MAP.json [REPEATS (5)] [OUTPUT_DIR (/tmp)]\n", argv[0]);
    return 2;
  }
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const std::string out = std::string(argc > 3 ? argv[3] : "/tmp") + "/bench_map_save.json";
  std::string text;
  std::vector<mvod::MapObject> objects;
  mvod::MapSummary summary;
  std::deque<mvod::KeyframeRecord> history;
  mvod::Status status = mvod::readFile(argv[1], &text, 2LL << 30);
  const auto load_start = std::chrono::steady_clock::now();
  if (status) status = mvod::objectsFromJson(text, &objects, &summary, &history);
  const double load_ms = msSince(load_start);
  if (!status) {
    std::fprintf(stderr, "cannot load %s: %s\n", argv[1], status.message().c_str());
    return 1;
  }
  // As ~save_map (no cache), then as the autosave (the cache of the previous save: the same map,
  // every keyframe already encoded once).
  std::vector<double> serialise_ms, write_ms, cached_ms;
  mvod::MapEncodingCache cache;
  mvod::objectsToJson(objects, summary, true, &history, &cache);
  size_t bytes = 0;
  for (int i = 0; i < repeats; ++i) {
    auto start = std::chrono::steady_clock::now();
    const std::string json = mvod::objectsToJson(objects, summary, true, &history);
    serialise_ms.push_back(msSince(start));
    bytes = json.size();
    start = std::chrono::steady_clock::now();
    status = mvod::writeFileAtomic(out, json);
    write_ms.push_back(msSince(start));
    start = std::chrono::steady_clock::now();
    const std::string again = mvod::objectsToJson(objects, summary, true, &history, &cache);
    cached_ms.push_back(msSince(start));
    if (again != json) {
      std::fprintf(stderr, "the cached encoding differs from the plain one\n");
      return 1;
    }
    if (!status) {
      std::fprintf(stderr, "cannot write %s: %s\n", out.c_str(), status.message().c_str());
      return 1;
    }
  }
  std::remove(out.c_str());
  std::printf(
      "%s: %zu objects, %zu keyframes; loading %.0f ms; a save: %.1f MB, serialising %.0f ms + "
      "writing %.0f ms = %.0f ms; serialising with the previous save's encodings (the autosave) "
      "%.0f ms (medians of %d)\n",
      argv[1], objects.size(), history.size(), load_ms, bytes / 1048576.0, median(serialise_ms),
      median(write_ms), median(serialise_ms) + median(write_ms), median(cached_ms), repeats);
  return 0;
}
