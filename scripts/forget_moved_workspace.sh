#!/usr/bin/env bash
# usage: forget_moved_workspace.sh WORKSPACE...
# A catkin workspace under build/ that was made in another folder (a `cp -a` or `mv` of the checkout) keeps
# CMake caches and devel setup files that name the old path: catkin_make then stops at "Configuring
# incomplete", or the setup files send rosrun back to the old checkout. Its build/ and devel/ are removed so
# that `make build` makes them again here (ccache keeps that quick). A workspace made here is left alone.
set -euo pipefail
for ws in "$@"; do
  cache="$ws/build/CMakeCache.txt"
  [[ -f "$cache" ]] || continue
  made_in=$(sed -n 's/^CMAKE_CACHEFILE_DIR:INTERNAL=//p' "$cache")
  here=$(cd "$ws/build" && pwd -P)
  if [[ -n "$made_in" && "$(cd "$made_in" 2>/dev/null && pwd -P || echo "$made_in")" != "$here" ]]; then
    echo "[build] $ws was made in ${made_in%/build} (a copied or moved checkout): building it again here"
    rm -rf "$ws/build" "$ws/devel"
  fi
done
