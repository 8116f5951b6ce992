#!/usr/bin/env bash
# Installs the Debian bookworm packages listed in deps/debian-packages.txt (or in the lists given as
# arguments, e.g. deps/fuzz-packages.txt) that are not installed yet.
# Needs root (or sudo) and apt; does nothing when everything is present.
set -euo pipefail
cd "$(dirname "$0")/.."
lists=("$@")
[[ ${#lists[@]} -gt 0 ]] || lists=(deps/debian-packages.txt)
mapfile -t wanted < <(cat "${lists[@]}" | grep -v -E '^\s*(#|$)' | sort -u)
missing=()
for pkg in "${wanted[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$pkg")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "[deps] all ${#wanted[@]} Debian packages present"
  exit 0
fi
echo "[deps] installing ${#missing[@]} Debian packages: ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "[deps] not root and no sudo: install them by hand" >&2; exit 1; }
  SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[deps] done"
