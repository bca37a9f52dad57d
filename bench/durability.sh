#!/usr/bin/env bash
# Durability of the scene store: ROUNDS times, start `rgbdcast serve`, let 4 clients upload (3 stream
# GLBs, 1 sends RGB-D frames that the server reduces), kill -9 the server at a random moment, then check the store
# as the crash left it and again after a restart: every scene the restarted server lists has its GLB and metadata
# with matching sizes, no GLB or metadata is alone, and no temporary file is left.
#   bench/durability.sh [ROUNDS=50] [BUILD_DIR=build]
set -euo pipefail
ROUNDS=${1:-50}
BUILD=${2:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d /tmp/rgbdcast-durability.XXXXXX)
STORE=$WORK/store
source "$ROOT/bench/serve_common.sh"
trap '[ -n "$SERVER" ] && kill -9 "$SERVER" 2>/dev/null; wait 2>/dev/null || true; rm -rf "$WORK"' EXIT

# Checks the store folder; prints "scenes partial temps".
check_store() {
  local scenes=0 partial=0 temps=0 f id
  for f in "$STORE"/scenes/.tmp-*; do [ -e "$f" ] && temps=$((temps + 1)); done
  for f in "$STORE"/scenes/*.json; do
    [ -e "$f" ] || continue
    id=$(basename "$f" .json)
    if [ -f "$STORE/scenes/$id.glb" ] &&
       [ "$(stat -c %s "$STORE/scenes/$id.glb")" = "$(sed -n 's/.*"bytes": *\([0-9]*\).*/\1/p' "$f" | head -1)" ]; then
      scenes=$((scenes + 1))
    else
      partial=$((partial + 1))
    fi
  done
  for f in "$STORE"/scenes/*.glb; do
    [ -e "$f" ] || continue
    [ -f "${f%.glb}.json" ] || partial=$((partial + 1))
  done
  echo "$scenes $partial $temps"
}

start_server "$STORE"
[ "$(frame_upload "$WORK/first.json")" = 201 ] || { echo "durability: first upload failed"; exit 1; }
ID=$(scene_id "$WORK/first.json")
curl -sf -o "$WORK/scene.glb" "$BASE/v1/scenes/$ID/model.glb"
# The GLB clients send the real scene at 0.4-1.2 MB/s, so a kill often falls in the middle of a body.
kill -9 "$SERVER"; wait "$SERVER" 2>/dev/null || true

BAD_AFTER=0; PARTIAL_AFTER=0; TEMPS_AFTER=0; LEFT_BY_CRASH=0
for round in $(seq "$ROUNDS"); do
  start_server "$STORE"
  for c in 1 2 3; do
    ( while true; do curl -s -o /dev/null --limit-rate $(( (c * 400) ))k -H 'Content-Type: model/gltf-binary' \
        --data-binary "@$WORK/scene.glb" "$BASE/v1/scenes" || true; done ) &
  done
  ( while true; do frame_upload /dev/null > /dev/null || true; done ) &
  sleep "$(awk -v r=$RANDOM 'BEGIN{printf "%.2f", 0.3 + (r % 1500) / 1000.0}')"
  kill -9 "$SERVER"; wait "$SERVER" 2>/dev/null || true
  kill $(jobs -p) 2>/dev/null || true; wait 2>/dev/null || true
  read -r _ _ temps_crash <<< "$(check_store)"
  LEFT_BY_CRASH=$((LEFT_BY_CRASH + temps_crash))
  start_server "$STORE"
  read -r scenes partial temps <<< "$(check_store)"
  listed=$(curl -sf "$BASE/v1/scenes" | sed -n 's/.*"count":\([0-9]*\).*/\1/p')
  [ "$listed" = "$scenes" ] || BAD_AFTER=$((BAD_AFTER + 1))
  PARTIAL_AFTER=$((PARTIAL_AFTER + partial)); TEMPS_AFTER=$((TEMPS_AFTER + temps))
  printf 'round %2d: killed after upload traffic; crash left %d temporary files; after restart %d whole scenes, %d partial, %d temporary, listed %s\n' \
    "$round" "$temps_crash" "$scenes" "$partial" "$temps" "$listed"
  kill -9 "$SERVER"; wait "$SERVER" 2>/dev/null || true
done
echo "durability: $ROUNDS rounds of kill -9 during uploads: $PARTIAL_AFTER partial scenes, $TEMPS_AFTER temporary files after restart, $BAD_AFTER listings that disagree with the folder ($LEFT_BY_CRASH temporary files left by the crashes, all removed at restart)"
[ "$PARTIAL_AFTER" = 0 ] && [ "$TEMPS_AFTER" = 0 ] && [ "$BAD_AFTER" = 0 ]
