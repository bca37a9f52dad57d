#!/usr/bin/env bash
# RSS of `rgbdcast serve` around a burst of large views (issue 11): base after one small view, peak after VIEWS views
# of random sizes up to 4096x4096 from 4 clients, and after IDLE_S seconds without requests.
#   bench/memory_burst.sh [VIEWS=200] [IDLE_S=8] [BUILD_DIR=build]   (RGBDCAST_BIN overrides the binary)
set -euo pipefail
VIEWS=${1:-200}
IDLE=${2:-8}
BUILD=${3:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${RGBDCAST_BIN:-$ROOT/$BUILD/app/rgbdcast}
TUM=${RGBDCAST_DATA:-$ROOT/../shared/data}/tum/rgbd_dataset_freiburg1_xyz
WORK=$(mktemp -d /tmp/rgbdcast-memory.XXXXXX)
PORT=${PORT:-$((20000 + RANDOM % 20000))}
BASE=http://127.0.0.1:$PORT
trap 'kill "$SERVER" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$WORK"' EXIT
"$BIN" serve --data-dir "$WORK/store" --bind 127.0.0.1 --port "$PORT" > "$WORK/server.log" 2>&1 &
SERVER=$!
for _ in $(seq 100); do curl -sf "$BASE/healthz" > /dev/null && break; sleep 0.2; done
echo '{"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480, "depth_scale": 5000}' > "$WORK/k.json"
ID=$(curl -sf -F "color=@$TUM/rgb/1305031102.175304.png" -F "depth=@$TUM/depth/1305031102.160407.png" \
  -F "intrinsics=@$WORK/k.json" "$BASE/v1/scenes" | sed -n 's/.*"id":"\([0-9a-f]*\)".*/\1/p')
rss() { awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$SERVER/status"; }
curl -sf -o /dev/null "$BASE/v1/scenes/$ID/view?pose=capture&width=320&height=240"
sleep 1
BASE_RSS=$(rss)
PEAK=0
for c in 1 2 3 4; do
  ( RANDOM=$c; for _ in $(seq $((VIEWS / 4))); do
      curl -s -o /dev/null "$BASE/v1/scenes/$ID/view?pose=capture&width=$((64 + RANDOM % 4033))&height=$((64 + RANDOM % 4033))"
    done ) &
done
while [ "$(jobs -p | wc -l)" -gt 1 ]; do
  r=$(rss); PEAK=$(awk -v a="$PEAK" -v b="$r" 'BEGIN{print (b > a ? b : a)}'); sleep 0.5
  [ "$(jobs -rp | grep -vc "^$SERVER$")" = 0 ] && break
done
wait $(jobs -p | grep -v "^$SERVER$") 2>/dev/null || true
AFTER=$(rss)
sleep "$IDLE"
IDLE_RSS=$(rss)
echo "memory: base $BASE_RSS MiB, peak $PEAK MiB, right after $VIEWS views $AFTER MiB, after ${IDLE} s idle $IDLE_RSS MiB"
