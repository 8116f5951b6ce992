#!/usr/bin/env bash
# usage: build_standin.sh WORKSPACE [catkin_make args...]
# Builds the stand-ins of the ROS packages Debian bookworm lacks (deps/standin/README.md: vision_msgs,
# jsk_recognition_msgs, media_export) into WORKSPACE, each only where the real one is not installed. With all of
# them installed, WORKSPACE is removed and the package is built against the real ones.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
ws=$1
shift

# The prefix holding an installed <pkg> (where catkin's find_package and rospack look: the prefixes of
# CMAKE_PREFIX_PATH and /usr), this workspace left out.
installed() {
  local pkg=$1 prefix prefixes
  IFS=: read -r -a prefixes <<< "${CMAKE_PREFIX_PATH:-}:/usr"
  for prefix in "${prefixes[@]}"; do
    [[ -n "$prefix" && "$prefix" != "$ws"* ]] || continue
    if [[ -f "$prefix/share/$pkg/package.xml" ]]; then
      echo "$prefix"
      return 0
    fi
  done
  return 1
}

built=()
mkdir -p "$ws/src"
for pkg in vision_msgs jsk_recognition_msgs media_export; do
  if prefix=$(installed "$pkg"); then
    echo "[standin] $pkg: the installed one in $prefix"
    rm -f "$ws/src/$pkg"
  else
    ln -sfn "$root/deps/standin/$pkg" "$ws/src/$pkg"
    built+=("$pkg")
  fi
done
if [[ ${#built[@]} -eq 0 ]]; then
  rm -rf "$ws"
  exit 0
fi
cd "$ws"
catkin_make "$@" > "$ws/build.log" 2>&1 || { tail -n 40 "$ws/build.log"; exit 1; }
echo "[standin] built ${built[*]} in $ws (deps/standin/README.md)"
