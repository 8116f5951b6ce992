// What a save of a given map costs (~save_map, the autosave): the map is loaded (a map folder, or a
// single-file map of 0.9.x), then written as a map folder N times by a new writer each time (as
// ~save_map does: every keyframe file), and N times by one writer whose history gained one keyframe
// since its last save (as the autosave does: the new keyframe's file and map.json). Medians and
// sizes are printed.
//   devel/lib/multiview_object_detection/bench_map_save MAP [REPEATS] [OUTPUT_DIR]
// e.g. the redkitchen map that `make demo DATASET=...` autosaves to build/demo/.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <string>
#include <vector>

#include "multiview_object_detection/io/map_folder.h"

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
    std::fprintf(stderr, "usage: %s MAP [REPEATS (5)] [OUTPUT_DIR (/tmp)]\n", argv[0]);
    return 2;
  }
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const std::string out = std::string(argc > 3 ? argv[3] : "/tmp") + "/bench_map_save.mvmap";
  std::vector<mvod::MapObject> objects;
  mvod::MapSummary summary;
  std::deque<mvod::KeyframeRecord> loaded;
  const auto load_start = std::chrono::steady_clock::now();
  mvod::Status status = mvod::loadMap(argv[1], mvod::Links::kFollow, &objects, &summary, &loaded);
  const double load_ms = msSince(load_start);
  if (!status) {
    std::fprintf(stderr, "cannot load %s: %s\n", argv[1], status.message().c_str());
    return 1;
  }
  // Records as a history holds them (ids for the writer), the last one held back for the
  // autosave's case.
  mvod::KeyframeHistory::Config config;
  config.max_memory_mb = 65536.0;
  mvod::KeyframeHistory history(config);
  for (mvod::KeyframeRecord& record : loaded) history.add(std::move(record));
  std::deque<mvod::KeyframeRecord> all = history.records();
  std::deque<mvod::KeyframeRecord> before_last = all;
  if (!before_last.empty()) before_last.pop_back();
  std::vector<double> full_ms, incremental_ms;
  mvod::MapFolderWriter::Report full, incremental;
  for (int i = 0; i < repeats; ++i) {
    std::filesystem::remove_all(out);
    auto start = std::chrono::steady_clock::now();
    status = mvod::MapFolderWriter().write(out, objects, summary, all, &full);
    full_ms.push_back(msSince(start));
    if (!status) break;
    mvod::MapFolderWriter autosave;
    status = autosave.write(out, objects, summary, before_last);
    if (!status) break;
    start = std::chrono::steady_clock::now();
    status = autosave.write(out, objects, summary, all, &incremental);
    incremental_ms.push_back(msSince(start));
    if (!status) break;
  }
  std::filesystem::remove_all(out);
  if (!status) {
    std::fprintf(stderr, "cannot write %s: %s\n", out.c_str(), status.message().c_str());
    return 1;
  }
  std::printf(
      "%s: %zu objects, %zu keyframes; loading %.0f ms; the map folder %.1f MB; a save of it all "
      "(~save_map, %d keyframe files) %.0f ms; a save after one new keyframe (the autosave: %d "
      "keyframe file, %.2f MB written) %.0f ms (medians of %d)\n",
      argv[1], objects.size(), all.size(), load_ms, full.folder_bytes / 1048576.0,
      full.keyframe_files_written, median(full_ms), incremental.keyframe_files_written,
      incremental.bytes_written / 1048576.0, median(incremental_ms), repeats);
  return 0;
}
