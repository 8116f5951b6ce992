#!/usr/bin/env bash
# `make demo`: the ROS node end to end on the embedded synthetic scene.
#   1. generates the synthetic room (RGB-D frames, camera poses, ground truth, 2D detections);
#   2. dataset_to_bag: a bag with what a Kinect driver, ORB-SLAM2 and a detector would publish;
#   3. scripts/demo_replay.py: roslaunch replay.launch (object_detection_node with detector:=topic, rviz on a
#      virtual display), rosbag play, ~refine, ~save_map, the objects as a table, an rviz screenshot;
#   4. evaluate: AP against the ground truth, and a bird's-eye plot of the boxes over the ground truth.
# `make demo DATASET=DIR` does the same on a 7-Scenes-layout folder or a SceneNN sequence with YOLOv5n-seg (when
# yolov5n-seg.onnx is in the model folder), else Mask R-CNN (its weights there), else FastestDet in the
# node (models in MODEL_DIR=DIR, else $MVOD_MODEL_DIR, else $ROS_HOME/multiview_object_detection/models:
# scripts/download_models.sh),
# without the accuracy table (no ground truth). FIRST=N LAST=M replay only those frames; TRAJECTORY=FILE
# (KEYFRAMES=FILE) a SLAM's poses in TUM format instead of the dataset's (its keyframes only).
#   usage: scripts/demo.sh WORKSPACE [DATASET]
# Output: build/demo/ (map.mvmap, accuracy.md/.csv, map.png, rviz.png, roslaunch.log).
set -euo pipefail

# The synthetic scene: "scenenn:ROOM" (SceneNN layout, y-up, simulated detector with its failures; ROOM =
# default, living, bedroom or dining) or "7scenes" (the default room in the 7-Scenes layout, perfect masks).
SCENE=${DEMO_SCENE:-scenenn:default}

ws=${1:?usage: demo.sh WORKSPACE [DATASET]}
dataset_arg=${2:-}
root=$(cd "$(dirname "$0")/.." && pwd)
bin="$ws/devel/lib/multiview_object_detection"
out="$root/build/demo"
for tool in make_synthetic_dataset dataset_to_bag object_detection_node evaluate; do
  [[ -x "$bin/$tool" ]] || { echo "demo: $bin/$tool is missing: run 'make build' first" >&2; exit 1; }
done
# ROS tools on Debian's python; the workspace's setup gives roslaunch the package.
export PATH=/usr/bin:$PATH
set +u
# shellcheck disable=SC1091
source "$ws/devel/setup.bash"
set -u
rm -rf "$out"
mkdir -p "$out"
start=$(date +%s)
range=()
[[ -n "${FIRST:-}" ]] && range+=(--first "$FIRST")
[[ -n "${LAST:-}" ]] && range+=(--last "$LAST")
# TRAJECTORY=FILE [KEYFRAMES=FILE]: a SLAM's poses (TUM format) instead of the dataset's (dataset_to_bag --help).
[[ -n "${TRAJECTORY:-}" ]] && range+=(--trajectory "$TRAJECTORY")
[[ -n "${KEYFRAMES:-}" ]] && range+=(--keyframes "$KEYFRAMES")

model_dir=""
gravity=""       # gravity_down for the node, a YAML list; empty = gravity_source:=estimate
ground_truth=""  # for evaluate; empty = none
if [[ -z "$dataset_arg" ]]; then
  # ---- the synthetic scene --------------------------------------------------------------------------------
  if [[ "$SCENE" == scenenn:* ]]; then
    room=${SCENE#scenenn:}
    id="synthetic_$room"  # a SceneNN sequence folder <id>/ holds <id>.xml and <id>.ply
    echo "== 1/4 synthetic SceneNN sequence, room '$room' (60 RGB-D frames, Kinect v1 noise) -> $out/$id"
    "$bin/make_synthetic_dataset" --layout scenenn --room "$room" --seed 1 --noise-model kinect --frames 60 \
      --id "$id" --output "$out/$id"
    dataset="$out/$id"
    detector_args=(--detector simulated)
    gravity="[0, -1, 0]"   # SceneNN is y-up
    ground_truth="$out/$id"
    every=5
  else
    echo "== 1/4 synthetic room (60 RGB-D frames, 640x480, Kinect-like noise, perfect masks) -> $out/dataset"
    "$bin/make_synthetic_dataset" --output "$out/dataset" --detections "$out/detections" --frames 60 \
      --noise 0.0015 --holes 0.02
    dataset="$out/dataset"
    detector_args=(--detector files --detections "$out/detections")
    gravity="[0, 0, -1]"
    ground_truth="$out/dataset/ground_truth.json"
    every=5
  fi
  node_detector=topic
  rate=1.0
else
  # ---- a real dataset, YOLOv5n-seg, Mask R-CNN or FastestDet in the node -----------------------------------
  [[ -d "$dataset_arg" ]] || { echo "demo: DATASET=$dataset_arg is not a folder" >&2; exit 1; }
  dataset=$(cd "$dataset_arg" && pwd)
  dataset_name=$dataset
  # MODEL_DIR=DIR (make demo's), else $MVOD_MODEL_DIR, else the folder download_models.sh fills.
  model_dir=${MODEL_DIR:-${MVOD_MODEL_DIR:-${ROS_HOME:-$HOME/.ros}/multiview_object_detection/models}}
  [[ -d "$model_dir" ]] || { echo "demo: model folder $model_dir does not exist (MODEL_DIR=DIR," \
    "MVOD_MODEL_DIR, or scripts/download_models.sh to fill the default one)" >&2; exit 1; }
  if [[ -f "$model_dir/yolov5n-seg.onnx" ]]; then
    node_detector=yolo_seg
    detector_name="YOLOv5n-seg"
  elif [[ -f "$model_dir/frozen_inference_graph.pb" &&
    -f "$model_dir/mask_rcnn_inception_v2_coco_2018_01_28.pbtxt" &&
    -f "$model_dir/object_detection_classes_coco.txt" ]]; then
    node_detector=maskrcnn
    detector_name="Mask R-CNN"
  elif [[ -f "$model_dir/FastestDet.onnx" && -f "$model_dir/coco.names" ]]; then
    node_detector=fastestdet
    detector_name=FastestDet
  else
    echo "demo: no YOLOv5n-seg, Mask R-CNN or FastestDet model in $model_dir: run scripts/download_models.sh" \
      "(or MODEL_DIR=DIR for the folder that holds them)" >&2
    exit 1
  fi
  echo "== 1/4 dataset $dataset, $detector_name from $model_dir"
  if [[ -f "$dataset/camera-intrinsics.txt" && ! -f "$dataset/color-intrinsics.txt" ]] &&
    compgen -G "$dataset/frame-*.color.*" >/dev/null; then
    # 7-Scenes does not register colour to depth; take the Kinect v1 colour camera's default intrinsics
    # (README, Real data). The dataset itself is not touched: a folder of links gets the extra file.
    echo "   no color-intrinsics.txt: using the Kinect v1 colour default (fx = fy = 525, cx = 320, cy = 240)"
    mkdir -p "$out/dataset"
    ln -s "$dataset"/* "$out/dataset/"
    printf '525 0 320\n0 525 240\n0 0 1\n' >"$out/dataset/color-intrinsics.txt"
    dataset="$out/dataset"
  fi
  if [[ -f "$dataset/gravity-direction.txt" ]]; then
    gravity=$(awk '{ for (i = 1; i <= NF; i++) v[n++] = $i } END { printf "[%.4f, %.4f, %.4f]", v[0], v[1], v[2] }' \
      "$dataset/gravity-direction.txt")
  elif [[ -f "$dataset/trajectory.log" || -d "$dataset/depth" ]]; then
    gravity="[0, -1, 0]"   # SceneNN is y-up
  fi
  detector_args=()
  every=10
  [[ -n "${KEYFRAMES:-}" ]] && every=1  # the bag holds the SLAM's keyframes only: each is one
  rate=${RATE:-0.5}
fi

echo
echo "== 2/4 dataset_to_bag -> $out/demo.bag"
"$bin/dataset_to_bag" --dataset "$dataset" --output "$out/demo.bag" "${detector_args[@]}" "${range[@]}" \
  2>&1 | tee "$out/dataset_to_bag.log"
# The tool says which gravity the node needs when the dataset knows it.
said=$(grep -o -E 'gravity_down: \[[^]]*\]' "$out/dataset_to_bag.log" | head -n 1 | sed 's/gravity_down: //' || true)
[[ -n "$said" ]] && gravity=$said

echo
echo "== 3/4 replay through object_detection_node (every ${every}th frame a keyframe, gravity ${gravity:-estimated})"
replay=(--bag "$out/demo.bag" --output-dir "$out" --detector "$node_detector" --keyframe-every "$every"
  --rate "$rate" --rviz-config "$root/rviz/demo.rviz")
if [[ -n "$gravity" ]]; then replay+=(--gravity-down "$gravity"); else replay+=(--gravity-estimate); fi
[[ "$node_detector" == topic ]] || replay+=(--model-dir "$model_dir")
/usr/bin/python3 "$root/scripts/demo_replay.py" "${replay[@]}"

echo
if [[ -n "$ground_truth" ]]; then
  echo "== 4/4 accuracy against the ground truth (evaluate; see README, Offline tools)"
  "$bin/evaluate" --objects "$out/map.mvmap" --ground-truth "$ground_truth" \
    --markdown "$out/accuracy.md" --csv "$out/accuracy.csv" --plot "$out/map.png"
else
  echo "== 4/4 no ground truth for $dataset_name: no accuracy table; the bird's-eye map of the objects"
  "$bin/evaluate" --objects "$out/map.mvmap" --plot "$out/map.png"
fi
echo
echo "demo done in $(($(date +%s) - start)) s. In $out:"
for f in map.mvmap accuracy.md map.png rviz.png roslaunch.log demo.bag; do
  if [[ -e "$out/$f" ]]; then echo "  $f"; fi
done
if [[ -n "$gravity" ]]; then gravity_arg="gravity_down:=\"$gravity\""; else gravity_arg="gravity_source:=estimate"; fi
echo "Replay it with rviz on your screen:"
echo "  roslaunch multiview_object_detection replay.launch bag:=$out/demo.bag pose_source:=topic" \
  "detector:=$node_detector keyframe_mode:=every_n keyframe_every_n:=$every $gravity_arg" \
  "${model_dir:+model_dir:=$model_dir}"
