#!/usr/bin/env bash
# Writes the seed corpus of the rosbag fuzz target, fuzz/corpus/rosbag/ (run by hand when the reader changes; the
# output is committed): four tiny bags (8x6 pixels) on the default topics through tests/input/write_test_bag.py
# (Debian's python3-rosbag): rgb8 + 32FC1 + CameraInfo, bgr8 + 16UC1 + CameraInfo in lz4 chunks, mono8 + 16UC1 in
# bz2 chunks without CameraInfo, and two colour/depth pairs.
set -euo pipefail
cd "$(dirname "$0")/.."
out=fuzz/corpus/rosbag
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
W=8 H=6
/usr/bin/python3 - "$tmp" "$W" "$H" <<'PY'
import struct, sys
d, w, h = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
open(f"{d}/rgb8", "wb").write(bytes((x * 30 + y * 7 + c * 50) % 256 for y in range(h) for x in range(w) for c in range(3)))
open(f"{d}/mono8", "wb").write(bytes((x * 30 + y * 7) % 256 for y in range(h) for x in range(w)))
open(f"{d}/32FC1", "wb").write(b"".join(struct.pack("<f", 1.0 + 0.01 * x if (x + y) % 7 else float("nan"))
                                        for y in range(h) for x in range(w)))
open(f"{d}/16UC1", "wb").write(b"".join(struct.pack("<H", 1000 + 10 * x if (x + y) % 7 else 0)
                                        for y in range(h) for x in range(w)))
PY
info='"camera_info": {"topic": "/camera/rgb/camera_info", "stamp": 0.5, "width": 8, "height": 6,
  "K": [6, 0, 3.5, 0, 6, 2.5, 0, 0, 1], "D": [0.1, -0.2, 0, 0, 0]},'
img() {  # topic stamp encoding step file
  printf '{"topic": "%s", "stamp": %s, "width": %d, "height": %d, "encoding": "%s", "step": %d, "file": "%s"}' \
    "$1" "$2" "$W" "$H" "$3" "$4" "$tmp/$5"
}
c=/camera/rgb/image_color
dp=/camera/depth/image
bag() {  # name manifest-body
  echo "{$2}" > "$tmp/$1.json"
  /usr/bin/python3 tests/input/write_test_bag.py "$tmp/$1.json" "$out/$1.bag"
}
bag rgb8_32f "$info \"images\": [$(img $c 1.0 rgb8 24 rgb8), $(img $dp 1.01 32FC1 32 32FC1)]"
bag bgr8_16u_lz4 "$info \"compression\": \"lz4\", \"images\": [$(img $c 1.0 bgr8 24 rgb8), $(img $dp 1.0 16UC1 16 16UC1)]"
bag mono8_16u_bz2 "\"compression\": \"bz2\", \"images\": [$(img $c 1.0 mono8 8 mono8), $(img $dp 1.0 16UC1 16 16UC1)]"
bag two_pairs "$info \"images\": [$(img $c 1.0 rgb8 24 rgb8), $(img $dp 1.0 32FC1 32 32FC1), $(img $c 2.0 rgb8 24 rgb8), $(img $dp 2.01 16UC1 16 16UC1)]"
ls -l "$out"
