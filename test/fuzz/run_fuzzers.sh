#!/usr/bin/env bash
# Builds the libFuzzer harnesses of test/fuzz/ with clang (ASan + UBSan, outside catkin: only the
# project's .cpp files each harness needs) into OUT_DIR, then runs each for SECONDS on a copy of its
# seed corpus (test/fuzz/<name>_corpus/ is never written), with its dictionary <name>.dict if any.
# Fails on any crash, leak, timeout or sanitizer report; the reproducer is left in OUT_DIR/<name>/
# (crash-*, leak-*, timeout-*, oom-*).
#   usage: run_fuzzers.sh OUT_DIR SECONDS [HARNESS...]   (default: all three)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
OUT="${1:?usage: run_fuzzers.sh OUT_DIR SECONDS [HARNESS...]}"
SECONDS_EACH="${2:?usage: run_fuzzers.sh OUT_DIR SECONDS [HARNESS...]}"
shift 2
HARNESSES=("$@")
[[ ${#HARNESSES[@]} -gt 0 ]] || HARNESSES=(map_json detection_json image_decode)

CXX="${FUZZ_CXX:-clang++}"
CXXFLAGS=(-std=c++17 -g -O1 -fno-omit-frame-pointer -fsanitize=fuzzer,address,undefined
  -fno-sanitize-recover=undefined -I"$ROOT/include" $(pkg-config --cflags eigen3 opencv4))
# The project sources each harness needs (nothing of PCL or ROS).
declare -A SOURCES=(
  [map_json]="src/io/json_io.cpp src/io/object_json.cpp src/io/file_io.cpp src/io/history_json.cpp src/io/image_io.cpp src/pipeline/types/common.cpp src/pipeline/map/existence.cpp src/pipeline/map/depth_view.cpp src/pipeline/types/oriented_box.cpp src/pipeline/map/output_frame.cpp"
  [detection_json]="src/detectors/file_instance_segmenter.cpp src/pipeline/types/class_priors.cpp src/io/image_io.cpp src/io/file_io.cpp"
  [image_decode]="src/io/image_io.cpp"
)
declare -A LIBS=(
  [map_json]="-lopencv_imgcodecs -lopencv_imgproc -lopencv_core"
  [detection_json]="-lopencv_imgcodecs -lopencv_imgproc -lopencv_core -lyaml-cpp"
  [image_decode]="-lopencv_imgcodecs -lopencv_imgproc -lopencv_core"
)

mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
for name in "${HARNESSES[@]}"; do
  [[ -n "${SOURCES[$name]+x}" ]] || { echo "[fuzz] unknown harness '$name'" >&2; exit 2; }
  sources=()
  for s in ${SOURCES[$name]}; do sources+=("$ROOT/$s"); done
  echo "[fuzz] building fuzz_$name"
  # shellcheck disable=SC2086
  "$CXX" "${CXXFLAGS[@]}" "$ROOT/test/fuzz/fuzz_$name.cpp" "${sources[@]}" ${LIBS[$name]} \
    -o "$OUT/fuzz_$name"
done

failed=()
for name in "${HARNESSES[@]}"; do
  work="$OUT/$name"
  rm -rf "$work" && mkdir -p "$work/corpus"
  cp "$ROOT/test/fuzz/${name}_corpus/"* "$work/corpus/"
  dict=()
  [[ -f "$ROOT/test/fuzz/$name.dict" ]] && dict=(-dict="$ROOT/test/fuzz/$name.dict")
  echo "[fuzz] fuzz_$name for ${SECONDS_EACH} s"
  # -rss_limit_mb/-malloc_limit_mb: an image bomb that got past the size check would show as OOM.
  if (cd "$work" && UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
      "$OUT/fuzz_$name" -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 \
      -malloc_limit_mb=512 -max_len=65536 -print_final_stats=1 -artifact_prefix="$work/" \
      "${dict[@]}" corpus >"$work/fuzz.log" 2>&1); then
    grep -E '^stat::number_of_executed_units|^stat::average_exec_per_sec|^#[0-9]+ *DONE' \
      "$work/fuzz.log" | sed "s/^/[fuzz] $name: /" || true
  else
    echo "[fuzz] fuzz_$name FAILED; the last lines of $work/fuzz.log:" >&2
    tail -n 40 "$work/fuzz.log" >&2
    ls "$work"/{crash,leak,timeout,oom}-* 2>/dev/null | sed 's/^/[fuzz] reproducer: /' >&2 || true
    failed+=("$name")
  fi
done
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "[fuzz] failed: ${failed[*]}" >&2
  exit 1
fi
echo "[fuzz] all ${#HARNESSES[@]} harnesses ran ${SECONDS_EACH} s without a crash"
