#!/usr/bin/env bash
# Makes docs/overview.png, the README's picture, with rgbdcast's own tools: TUM fr1/xyz frame 0 reduced with the
# defaults, then rendered headless from a viewpoint 15 cm beside the capture camera. Needs a build (scripts/build.sh)
# and ../shared/data.
set -euo pipefail
cd "$(dirname "$0")/.."
input="${1:-../shared/data/tum/rgbd_dataset_freiburg1_xyz}"
work="$(mktemp -d /tmp/rgbdcast-overview.XXXXXX)"
trap 'rm -rf "$work"' EXIT
./build/app/rgbdcast reduce --input "$input" --frame 0 --out "$work/frame.glb" > /dev/null
./build/app/rgbdcast render --scene "$work/frame.glb" --eye 0.15,-0.05,0 --target 0,0,1.5 --width 640 --height 480 \
  --out docs/overview.png
echo "overview_picture.sh: wrote docs/overview.png ($(stat -c %s docs/overview.png) bytes) from $(stat -c %s "$work/frame.glb")-byte GLB"
