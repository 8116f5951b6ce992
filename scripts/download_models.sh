#!/usr/bin/env bash
# Downloads the detector models this package runs through OpenCV DNN into a folder (default:
# ~/.ros/multiview_object_detection/models) and checks their sha256. Needs internet, curl or wget, tar.
#   scripts/download_models.sh [DIR]
# Then point the node / offline runner at DIR: model_dir parameter, --model-dir DIR, or MVOD_MODEL_DIR=DIR.
set -euo pipefail
dir=${1:-$HOME/.ros/multiview_object_detection/models}
mkdir -p "$dir"
cd "$dir"

fetch() {  # url file
  if command -v curl >/dev/null; then curl -fL --retry 3 -o "$2.part" "$1"; else wget -O "$2.part" "$1"; fi
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
echo "models in $dir"
