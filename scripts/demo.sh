#!/usr/bin/env bash
# `make demo`: generates the embedded synthetic scene (a room with a table, chairs, a couch, a tv, cups and
# a book, rendered to RGB-D with known boxes), runs the offline pipeline over it with perfect instance masks,
# and prints the objects it found next to the ground truth.
#   usage: scripts/demo.sh WORKSPACE
set -euo pipefail
ws=${1:?usage: demo.sh WORKSPACE}
root=$(cd "$(dirname "$0")/.." && pwd)
bin="$ws/devel/lib/multiview_object_detection"
out="$root/build/demo"
for tool in make_synthetic_dataset offline_detection evaluate; do
  [[ -x "$bin/$tool" ]] || { echo "demo: $bin/$tool is missing: run 'make build' first" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out"

echo "== 1/2 synthetic scene (60 RGB-D frames, 640x480, Kinect-like noise) -> $out/dataset"
"$bin/make_synthetic_dataset" --output "$out/dataset" --detections "$out/detections" --frames 60 \
  --noise 0.0015 --holes 0.02

echo
echo "== 2/2 offline_detection: every 5th frame a keyframe, perfect masks"
"$bin/offline_detection" --dataset "$out/dataset" --detections "$out/detections" --every 5 \
  --priors "$root/config/class_priors.yaml" --output "$out/objects.json" \
  --save-clouds "$out/clouds" --overlays "$out/overlays"

echo
echo "ground truth (dataset/ground_truth.json):"
/usr/bin/python3 - "$out/dataset/ground_truth.json" <<'PY'
import json, sys
gt = json.load(open(sys.argv[1]))
import math
print("%-16s %-26s %-22s %s" % ("class", "centre (m)", "size (m)", "yaw (deg)"))
for o in gt["objects"]:
    c, s = o["center"], o["size"]
    print("%-16s (%6.2f, %6.2f, %6.2f)   (%5.2f, %5.2f, %5.2f)  %8.1f"
          % (o["class_name"], *c, *s, math.degrees(o["yaw"])))
PY
echo
echo "== accuracy against the ground truth (evaluate; see README, Evaluation)"
"$bin/evaluate" --objects "$out/objects.json" --ground-truth "$out/dataset/ground_truth.json" \
  --clouds "$out/clouds" --markdown "$out/accuracy.md" --csv "$out/accuracy.csv"
echo
echo "wrote $out/objects.json, object clouds in $out/clouds, keyframe overlays in $out/overlays"
