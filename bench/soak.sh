#!/usr/bin/env bash
# Soak test of `rgbdcast serve`: 8 clients on loopback mix GLB uploads, views of random sizes and modes,
# GLB downloads, listings and deletes for DURATION seconds, then the server stops by itself. Reports the number of
# requests by status class, every 5xx, and RSS after warm-up vs at its peak and at the end.
#   bench/soak.sh [DURATION_S=1800] [CLIENTS=8] [BUILD_DIR=build]
# Needs the TUM fr1/xyz frame 0 under ../shared/data (the first scene is reduced from it on the server).
# The store stays at a steady size, so that RSS measures the server and not how many scenes it holds: each client
# keeps at most SOAK_OWN_SCENES (default 4) scenes of its own and deletes its oldest right after an upload that
# takes it past that, besides the random deletes of the mix; the store never holds more than
# CLIENTS x SOAK_OWN_SCENES + 1 scenes. (Until harden4 uploads outnumbered deletes 10:6 and the store grew by about
# one scene per second; what a stored scene costs is measured by bench/store_rss.sh.)
set -euo pipefail
DURATION=${1:-1800}
CLIENTS=${2:-8}
BUILD=${3:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d /tmp/rgbdcast-soak.XXXXXX)
source "$ROOT/bench/serve_common.sh"

start_server "$WORK/store"
base_scene
echo "soak: server pid $SERVER, port $PORT, base scene $ID ($(stat -c %s "$WORK/scene.glb") bytes), $CLIENTS clients, ${DURATION} s"

END=$(( $(date +%s) + DURATION ))
OWN=${SOAK_OWN_SCENES:-4}
client() {
  local n=$1 log=$WORK/client$n.log mine=() code
  RANDOM=$((n * 7919))
  while [ "$(date +%s)" -lt "$END" ]; do
    local r=$((RANDOM % 100)) w=$((16 + RANDOM % 1024)) h=$((16 + RANDOM % 768))
    if [ $r -lt 10 ]; then
      local out
      out=$(curl -s -o "$WORK/up$n.json" -w '%{http_code}' -H 'Content-Type: model/gltf-binary' \
        --data-binary "@$WORK/scene.glb" "$BASE/v1/scenes")
      echo "POST $out" >> "$log"
      [ "$out" = 201 ] && mine+=("$(scene_id "$WORK/up$n.json")")
      if [ ${#mine[@]} -gt "$OWN" ]; then
        code=$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$BASE/v1/scenes/${mine[0]}")
        echo "DELETE $code" >> "$log"
        mine=("${mine[@]:1}")
      fi
    elif [ $r -lt 16 ] && [ ${#mine[@]} -gt 0 ]; then
      code=$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "$BASE/v1/scenes/${mine[0]}")
      echo "DELETE $code" >> "$log"
      mine=("${mine[@]:1}")
    elif [ $r -lt 20 ]; then
      code=$(curl -s -o /dev/null -w '%{http_code}' "$BASE/v1/scenes/$ID/model.glb"); echo "GLB $code" >> "$log"
    elif [ $r -lt 24 ]; then
      code=$(curl -s -o /dev/null -w '%{http_code}' "$BASE/v1/scenes"); echo "LIST $code" >> "$log"
    else
      local mode=mesh; [ $((RANDOM % 4)) = 0 ] && mode=points
      local target=$ID; [ ${#mine[@]} -gt 0 ] && [ $((RANDOM % 2)) = 0 ] && target=${mine[0]}
      code=$(curl -s -o /dev/null -w '%{http_code}' \
        "$BASE/v1/scenes/$target/view?pose=capture&width=$w&height=$h&mode=$mode&format=jpeg")
      echo "VIEW $code" >> "$log"
    fi
  done
}
for n in $(seq "$CLIENTS"); do client "$n" & done
WARM=$(( DURATION / 10 < 60 ? DURATION / 10 : 60 ))
sleep "$WARM"
RSS_WARM=$(rss_mib)
STORED_WARM=$(curl -s "$BASE/metrics" | awk '$1 == "rgbdcast_scenes_stored" {print $2}')
: > "$WORK/rss.log"
stored() { curl -s "$BASE/metrics" | awk '$1 == "rgbdcast_scenes_stored" {print $2}'; }
anon_file() { awk '/RssAnon|RssFile/ {printf "%.1f ", $2 / 1024}' "/proc/$SERVER/status"; }
while [ "$(date +%s)" -lt "$END" ]; do
  echo "$(date +%s) $(rss_mib) $(stored) $(anon_file)" >> "$WORK/rss.log"
  sleep 10
done
wait $(jobs -p | grep -v "^$SERVER$") 2>/dev/null || true
sleep 6  # idle: the server trims its heap and resets renderers that served large views
RSS_END=$(rss_mib)
RSS_MAX=$(awk 'BEGIN{m=0} {if ($2>m) m=$2} END{print m}' "$WORK/rss.log")
cat "$WORK"/client*.log > "$WORK/all.log"
TOTAL=$(wc -l < "$WORK/all.log")
FIVE=$(awk '$2 ~ /^5/' "$WORK/all.log" | wc -l)
ZERO=$(awk '$2 == "000"' "$WORK/all.log" | wc -l)
echo "soak: $TOTAL requests in ${DURATION} s by $CLIENTS clients"
awk '{c[$1" "$2]++} END{for (k in c) print "  " k, c[k]}' "$WORK/all.log" | sort
echo "soak: 5xx $FIVE, no response $ZERO"
awk -v w="$RSS_WARM" -v e="$RSS_END" -v m="$RSS_MAX" 'BEGIN{printf "soak: RSS after warm-up %.1f MiB, max %.1f MiB (%+.1f %%), end (after 6 s idle) %.1f MiB, growth %+.1f %%\n", w, m, (m-w)*100.0/w, e, (e-w)*100.0/w}'
# The trend without one sample's luck: medians of the first and last 30 samples (5 minutes each in a long run).
sort_median() { sort -n | awk '{v[NR] = $1} END{if (NR == 0) print 0; else print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2)}'; }
MED_FIRST=$(head -n 30 "$WORK/rss.log" | awk '{print $2}' | sort_median)
MED_LAST=$(tail -n 30 "$WORK/rss.log" | awk '{print $2}' | sort_median)
awk -v w="$RSS_WARM" -v a="$MED_FIRST" -v b="$MED_LAST" -v n="$(wc -l < "$WORK/rss.log")" 'BEGIN{printf "soak: %d RSS samples; median of the first 30 %.1f MiB (%+.1f %%), of the last 30 %.1f MiB (%+.1f %%)\n", n, a, (a-w)*100.0/w, b, (b-w)*100.0/w}'
awk -v w="$STORED_WARM" '{if ($3 > m) m = $3; if (n == 0 || $3 < lo) lo = $3; n++; last = $3} END{printf "soak: scenes stored after warm-up %d, during the run %d..%d, at the end %d\n", w, lo, m, last}' "$WORK/rss.log"
# RSS_LOG=FILE keeps the trace (every 10 s after warm-up): Unix time, RSS in MiB, scenes stored, its anonymous and
# file-backed parts in MiB.
[ -n "${RSS_LOG:-}" ] && cp "$WORK/rss.log" "$RSS_LOG"
kill -0 "$SERVER" 2>/dev/null && echo "soak: server alive at the end" || { echo "soak: SERVER DIED"; exit 1; }
[ "$FIVE" = 0 ] && [ "$ZERO" = 0 ]
