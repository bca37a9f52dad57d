#!/usr/bin/env bash
# Soak test of `rgbdcast serve` (issue 11): 8 clients on loopback mix GLB uploads, views of random sizes and modes,
# GLB downloads, listings and deletes for DURATION seconds, then the server stops by itself. Reports the number of
# requests by status class, every 5xx, and RSS after warm-up vs at the end.
#   bench/soak.sh [DURATION_S=1800] [CLIENTS=8] [BUILD_DIR=build]
# Needs the TUM fr1/xyz frame 0 under ../shared/data (the first scene is reduced from it on the server).
set -euo pipefail
DURATION=${1:-1800}
CLIENTS=${2:-8}
BUILD=${3:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${RGBDCAST_BIN:-$ROOT/$BUILD/app/rgbdcast}
DATA=${RGBDCAST_DATA:-$ROOT/../shared/data}
TUM=$DATA/tum/rgbd_dataset_freiburg1_xyz
WORK=$(mktemp -d /tmp/rgbdcast-soak.XXXXXX)
PORT=${PORT:-$((20000 + RANDOM % 20000))}
BASE=http://127.0.0.1:$PORT
trap 'kill "$SERVER" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$WORK"' EXIT

"$BIN" serve --data-dir "$WORK/store" --bind 127.0.0.1 --port "$PORT" > "$WORK/server.log" 2>&1 &
SERVER=$!
for _ in $(seq 100); do curl -sf "$BASE/healthz" > /dev/null && break; sleep 0.2; done
cat > "$WORK/k.json" <<'K'
{"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
 "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000}
K
ID=$(curl -sf -F "color=@$TUM/rgb/1305031102.175304.png;type=image/png" \
  -F "depth=@$TUM/depth/1305031102.160407.png;type=image/png" -F "intrinsics=@$WORK/k.json" "$BASE/v1/scenes" |
  sed -n 's/.*"id":"\([0-9a-f]*\)".*/\1/p')
[ -n "$ID" ] || { echo "soak: the first frame upload failed"; cat "$WORK/server.log"; exit 1; }
curl -sf -o "$WORK/scene.glb" "$BASE/v1/scenes/$ID/model.glb"
echo "soak: server pid $SERVER, port $PORT, base scene $ID ($(stat -c %s "$WORK/scene.glb") bytes), $CLIENTS clients, ${DURATION} s"

rss_kb() { awk '/VmRSS/ {print $2}' "/proc/$SERVER/status"; }
END=$(( $(date +%s) + DURATION ))
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
      [ "$out" = 201 ] && mine+=("$(sed -n 's/.*"id":"\([0-9a-f]*\)".*/\1/p' "$WORK/up$n.json")")
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
RSS_WARM=$(rss_kb)
: > "$WORK/rss.log"
while [ "$(date +%s)" -lt "$END" ]; do echo "$(date +%s) $(rss_kb)" >> "$WORK/rss.log"; sleep 10; done
wait $(jobs -p | grep -v "^$SERVER$") 2>/dev/null || true
sleep 6  # idle: the server trims its heap and resets renderers that served large views
RSS_END=$(rss_kb)
RSS_MAX=$(awk 'BEGIN{m=0} {if ($2>m) m=$2} END{print m}' "$WORK/rss.log")
cat "$WORK"/client*.log > "$WORK/all.log"
TOTAL=$(wc -l < "$WORK/all.log")
FIVE=$(awk '$2 ~ /^5/' "$WORK/all.log" | wc -l)
ZERO=$(awk '$2 == "000"' "$WORK/all.log" | wc -l)
echo "soak: $TOTAL requests in ${DURATION} s by $CLIENTS clients"
awk '{c[$1" "$2]++} END{for (k in c) print "  " k, c[k]}' "$WORK/all.log" | sort
echo "soak: 5xx $FIVE, no response $ZERO"
awk -v w="$RSS_WARM" -v e="$RSS_END" -v m="$RSS_MAX" 'BEGIN{printf "soak: RSS after warm-up %.1f MiB, max %.1f MiB, end (after 6 s idle) %.1f MiB, growth %+.1f %%\n", w/1024, m/1024, e/1024, (e-w)*100.0/w}'
kill -0 "$SERVER" 2>/dev/null && echo "soak: server alive at the end" || { echo "soak: SERVER DIED"; exit 1; }
[ "$FIVE" = 0 ] && [ "$ZERO" = 0 ]
