#!/usr/bin/env bash
# The main job on the built-in sample: install what building and running needs (scripts/setup.sh demo: not the test
# tools), build without the tests, make the sample (a ray-cast room with Kinect-like depth), reduce it to a GLB with
# its report (the default realtime preset: a few hundred milliseconds, under 40 kB; `--preset paper` is the paper's
# pipeline, seconds), then serve it: open the printed operator page URL.
# Stop the server with Ctrl-C. RGBDCAST_PORT picks the port (default 8080).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh demo
RGBDCAST_BUILD_TESTS=OFF bash scripts/build.sh --target rgbdcast make_sample
out=out/sample
mkdir -p "$out"
./build/assets/make_sample "$out/room" 3
./build/app/rgbdcast reduce --input "$out/room" --frame 0 --intrinsics kinect --out "$out/room.glb" --report "$out/room.json"
echo "demo: wrote $out/room.glb and $out/room.json; starting the view service"
exec ./build/app/rgbdcast serve --data-dir out/store --port "${RGBDCAST_PORT:-8080}" --import "$out/room.glb"
