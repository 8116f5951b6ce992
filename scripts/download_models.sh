#!/usr/bin/env bash
# Downloads the detector models this package runs through OpenCV DNN into a folder (default:
# $ROS_HOME/multiview_object_detection/models, ~/.ros/... without ROS_HOME: where the node and the tools
# look when no model folder is given) and checks their sha256. Needs internet, curl or wget, tar.
#   scripts/download_models.sh [DIR]          (installed: rosrun multiview_object_detection download_models.sh)
# With another DIR, point the node / offline tools at it: model_dir parameter, --model-dir DIR, or
# MVOD_MODEL_DIR=DIR. YOLOv5-seg has no ONNX download upstream: the script says how to export it.
set -euo pipefail
usage() {
  sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'
  echo "Usage: download_models.sh [DIR]   (-h, --help: this text)"
}
case "${1:-}" in
  -h | --help) usage; exit 0 ;;
  -*) echo "download_models.sh: unknown option '$1'" >&2; usage >&2; exit 2 ;;
esac
if [[ $# -gt 1 ]]; then echo "download_models.sh: one folder at most (got $#)" >&2; usage >&2; exit 2; fi
dir=${1:-${ROS_HOME:-$HOME/.ros}/multiview_object_detection/models}
mkdir -p "$dir"
cd "$dir"

fetch() {  # url file
  local status=0
  if command -v curl >/dev/null; then
    curl -fsSL --retry 3 -o "$2.part" "$1" || status=$?
  else
    wget -q -O "$2.part" "$1" || status=$?
  fi
  if [[ $status -ne 0 ]]; then
    rm -f "$2.part"
    echo "download_models.sh: could not download $2 (exit $status of $(command -v curl >/dev/null && echo curl || echo wget)): no network, a proxy, or the file moved." >&2
    echo "  Copy it by hand from $1" >&2
    echo "  into $dir (the files already here are kept), or run this script where there is a network." >&2
    exit 1
  fi
  mv "$2.part" "$2"
}
check() {  # sha256 file; an empty sha256 means upstream publishes none: print it for the record
  local got
  got=$(sha256sum "$2" | cut -d' ' -f1)
  if [[ -z "$1" ]]; then
    echo "  $2: sha256 $got (no pinned checksum: compare with a copy you trust)"
  elif [[ "$got" != "$1" ]]; then
    echo "  $2: sha256 MISMATCH (got $got, expected $1); removed" >&2
    rm -f "$2"
    return 1
  else
    echo "  $2: sha256 ok"
  fi
}

# FastestDet (BSD-3-Clause): dog-qiuqiu/FastestDet, commit 50473cd.
fastestdet=https://raw.githubusercontent.com/dog-qiuqiu/FastestDet/50473cd155cb088aa4a99e64ff6a4b3c24fa07e1
fetch "$fastestdet/example/onnx-runtime/FastestDet.onnx" FastestDet.onnx
check 31cb14c017fce347cb4c846ec62fdf00d76bb3beecdf4be21e7116ac67feb880 FastestDet.onnx
fetch "$fastestdet/configs/coco.names" coco.names
check 634a1132eb33f8091d60f2c346ababe8b905ae08387037aed883953b7329af84 coco.names

# Mask R-CNN Inception v2 COCO (Apache-2.0): OpenCV's text graph and 90-id label list, and the
# TensorFlow model zoo archive holding frozen_inference_graph.pb.
opencv_extra=https://raw.githubusercontent.com/opencv/opencv_extra/4.x/testdata/dnn
fetch "$opencv_extra/mask_rcnn_inception_v2_coco_2018_01_28.pbtxt" \
  mask_rcnn_inception_v2_coco_2018_01_28.pbtxt
check 090923144d81b2e442093f965be27eccda11ce5f781eaf1c7ec76932ce99641e \
  mask_rcnn_inception_v2_coco_2018_01_28.pbtxt
fetch https://raw.githubusercontent.com/opencv/opencv/4.x/samples/data/dnn/object_detection_classes_coco.txt \
  object_detection_classes_coco.txt
check cf743111a02d083f91ada4d99ccd3b937cdfc853cf0f5582ee20ca6621b4393f object_detection_classes_coco.txt
fetch http://download.tensorflow.org/models/object_detection/mask_rcnn_inception_v2_coco_2018_01_28.tar.gz \
  mask_rcnn_inception_v2_coco_2018_01_28.tar.gz
check "" mask_rcnn_inception_v2_coco_2018_01_28.tar.gz
tar -xzf mask_rcnn_inception_v2_coco_2018_01_28.tar.gz --strip-components=1 \
  mask_rcnn_inception_v2_coco_2018_01_28/frozen_inference_graph.pb
check "" frozen_inference_graph.pb
# YOLOv5n-seg (GPL-3.0 at v7.0, AGPL-3.0 now): Ultralytics publishes PyTorch weights only; the ONNX
# file is exported once, on any machine with Python (no Python is needed where the node runs).
if [[ ! -f yolov5n-seg.onnx ]]; then
  cat <<TEXT
  yolov5n-seg.onnx (the default detector, an instance segmenter) is not downloadable as ONNX. Export it
  once with Python 3.8+ (any machine), then copy it here ($dir):
    git clone --branch v7.0 https://github.com/ultralytics/yolov5 && cd yolov5
    pip install -r requirements.txt onnx
    python export.py --weights yolov5n-seg.pt --include onnx --opset 12            # 640 x 640
    python export.py --weights yolov5n-seg.pt --include onnx --opset 12 --imgsz 320  # faster, coarser
  (yolov5s-seg.pt and larger export the same way; give the file with yolo_seg_model / --yolo-seg-model.)
  Until then the node's detector "auto" falls back to FastestDet.
TEXT
fi
echo "models in $dir"
