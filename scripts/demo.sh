#!/usr/bin/env bash
# The main job on the built-in sample: install what is needed, build, make the sample, reduce it to a GLB and print
# the report.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh --target rgbdcast make_sample
out=out/sample
mkdir -p "$out"
./build/assets/make_sample "$out/room" 3
./build/app/rgbdcast reduce --input "$out/room" --frame 0 --intrinsics kinect --out "$out/room.glb" --report "$out/room.json"
echo "demo: wrote $out/room.glb and $out/room.json"
