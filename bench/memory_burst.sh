#!/usr/bin/env bash
# RSS of `rgbdcast serve` around a burst of large views: base after one small view, peak during VIEWS views
# of random sizes up to 4096x4096 from 4 clients, right after, and after IDLE_S seconds without requests.
#   bench/memory_burst.sh [VIEWS=200] [IDLE_S=8] [BUILD_DIR=build]   (RGBDCAST_BIN overrides the binary)
set -euo pipefail
VIEWS=${1:-200}
IDLE=${2:-8}
BUILD=${3:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d /tmp/rgbdcast-memory.XXXXXX)
source "$ROOT/bench/serve_common.sh"
start_server "$WORK/store"
[ "$(frame_upload "$WORK/up.json")" = 201 ] || { echo "memory_burst: upload failed"; exit 1; }
ID=$(scene_id "$WORK/up.json")
curl -sf -o /dev/null "$BASE/v1/scenes/$ID/view?pose=capture&width=320&height=240"
sleep 1
BASE_RSS=$(rss_mib)
for c in 1 2 3 4; do
  ( RANDOM=$c; for _ in $(seq $((VIEWS / 4))); do
      curl -s -o /dev/null "$BASE/v1/scenes/$ID/view?pose=capture&width=$((64 + RANDOM % 4033))&height=$((64 + RANDOM % 4033))"
    done ) &
  CLIENTS="${CLIENTS:-} $!"
done
any_alive() { for p in $CLIENTS; do kill -0 "$p" 2>/dev/null && return 0; done; return 1; }
PEAK=0
while any_alive; do
  PEAK=$(awk -v a="$PEAK" -v b="$(rss_mib)" 'BEGIN{print (b > a ? b : a)}'); sleep 0.5
done
wait $CLIENTS 2>/dev/null || true
AFTER=$(rss_mib)
sleep "$IDLE"
echo "memory: base $BASE_RSS MiB, peak $PEAK MiB, right after $VIEWS views $AFTER MiB, after ${IDLE} s idle $(rss_mib) MiB"
