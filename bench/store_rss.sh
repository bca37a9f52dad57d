#!/usr/bin/env bash
# What one stored scene costs the server in memory: starts `rgbdcast serve` on an empty
# store, reduces TUM fr1/xyz frame 0 on it (as bench/soak.sh does), then uploads that GLB SCENES more times from 2
# clients and reads the server's RSS (and its anonymous part) before, after the uploads and after deleting them
# again, each after 6 s idle (the server trims its heap when idle). Prints kB of RSS and RssAnon per stored scene.
#   bench/store_rss.sh [SCENES=1000] [BUILD_DIR=build]      RGBDCAST_BIN=... measures another binary
set -euo pipefail
SCENES=${1:-1000}
BUILD=${2:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d /tmp/rgbdcast-store-rss.XXXXXX)
source "$ROOT/bench/serve_common.sh"

start_server "$WORK/store"
base_scene
anon_kib() { awk '/RssAnon/ {print $2}' "/proc/$SERVER/status"; }
rss_kib() { awk '/VmRSS/ {print $2}' "/proc/$SERVER/status"; }
uploader() {  # uploader N: N uploads, the ids to $WORK/ids.N
  for _ in $(seq "$1"); do
    curl -s -o "$WORK/up.$2.json" -H 'Content-Type: model/gltf-binary' --data-binary "@$WORK/scene.glb" "$BASE/v1/scenes"
    scene_id "$WORK/up.$2.json" >> "$WORK/ids.$2"
  done
}
# One upload, view and listing first, so that one-time costs (the first decode, renderer start) are in the base.
uploader 1 0
curl -s -o /dev/null "$BASE/v1/scenes/$ID/view?pose=capture&width=320&height=240"
curl -s -o /dev/null "$BASE/v1/scenes"
sleep 6
RSS0=$(rss_kib); ANON0=$(anon_kib)
uploader $((SCENES / 2)) 1 &
U1=$!
uploader $((SCENES - SCENES / 2)) 2 &
U2=$!
wait "$U1" "$U2"
curl -s -o /dev/null "$BASE/v1/scenes"
sleep 6
RSS1=$(rss_kib); ANON1=$(anon_kib)
STORED=$(curl -s "$BASE/metrics" | awk '$1 == "rgbdcast_scenes_stored" {print $2}')
cat "$WORK/ids.1" "$WORK/ids.2" | while read -r id; do curl -s -o /dev/null -X DELETE "$BASE/v1/scenes/$id"; done
sleep 6
RSS2=$(rss_kib); ANON2=$(anon_kib)
echo "store_rss: $(basename "$BIN"), $STORED scenes stored after $SCENES uploads of a $(stat -c %s "$WORK/scene.glb")-byte GLB"
awk -v n="$SCENES" -v r0="$RSS0" -v a0="$ANON0" -v r1="$RSS1" -v a1="$ANON1" -v r2="$RSS2" -v a2="$ANON2" 'BEGIN{
  printf "store_rss: RSS %.1f -> %.1f MiB (%.1f kB per scene), RssAnon %.1f -> %.1f MiB (%.1f kB per scene)\n",
    r0 / 1024, r1 / 1024, (r1 - r0) * 1.024 / n, a0 / 1024, a1 / 1024, (a1 - a0) * 1.024 / n
  printf "store_rss: after deleting them: RSS %.1f MiB, RssAnon %.1f MiB\n", r2 / 1024, a2 / 1024 }'
