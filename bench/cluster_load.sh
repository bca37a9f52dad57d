#!/usr/bin/env bash
# Views/s and latency of replicas behind nginx (deploy/cluster.sh), against one replica with no nginx, on this
# machine: for each configuration a fresh cluster, S scenes uploaded through the front (frame 0 of TUM fr1/xyz,
# realtime preset; their ids spread over the replicas by the hash), then wrk with bench/view_load.lua over all of
# them (640x480 JPEG from a ring of viewpoints). Then keyframe POSTs through the front: p50 and p95 of 40 sequential
# posts (curl's total time). Prints a table.
#   bench/cluster_load.sh [--duration 15s] [--connections 8] [--scenes 6] [--configs "direct 1 2 3"]
# "direct" is one replica on the same PostgreSQL store, asked directly; "dir" one server on the embedded directory
# store (--data-dir), asked directly; N is N replicas behind nginx.
# Needs wrk, curl, jq, nginx and PostgreSQL 15 (scripts/setup.sh test) and ../shared/data.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"

duration=15s connections=8 scenes=6 configs="direct 1 2 3"
while [ $# -gt 0 ]; do
  case "$1" in
    --duration) duration="$2"; shift 2 ;;
    --connections) connections="$2"; shift 2 ;;
    --scenes) scenes="$2"; shift 2 ;;
    --configs) configs="$2"; shift 2 ;;
    *) echo "cluster_load.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
export RGBDCAST_BIN="${RGBDCAST_BIN:-$ROOT/build/app/rgbdcast}"
TUM="${RGBDCAST_DATA:-$ROOT/../shared/data}/tum/rgbd_dataset_freiburg1_xyz"
WORK="$(mktemp -d /tmp/rgbdcast-cluster-load.XXXXXX)"
chmod 0755 "$WORK"  # PostgreSQL runs as its own user and must reach its folder inside
current=""
dir_pid=""
# Stops the directory-store server this script started (by its pid), SIGKILL after 20 s.
stop_dir_server() {
  [ -n "$dir_pid" ] || return 0
  kill -TERM "$dir_pid" 2> /dev/null || true
  for _ in $(seq 200); do kill -0 "$dir_pid" 2> /dev/null || break; sleep 0.1; done
  kill -KILL "$dir_pid" 2> /dev/null || true
  wait "$dir_pid" 2> /dev/null || true
  dir_pid=""
}
cleanup() {
  stop_dir_server
  if [ -n "$current" ] && [ -f "$current/nginx.conf" ]; then deploy/cluster.sh down "$current" > /dev/null || true; fi
  rm -rf "$WORK"
}
trap cleanup EXIT
cat > "$WORK/k.json" <<'K'
{"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
 "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000}
K

rows=()
for config in $configs; do
  port=$((20000 + RANDOM % 20000))
  replicas="$config"
  [ "$config" = direct ] && replicas=1
  current="$WORK/$config"
  if [ "$config" = dir ]; then
    mkdir -p "$current"
    "$RGBDCAST_BIN" serve --data-dir "$current/data" --port "$((port + 1))" > "$current/serve.log" 2>&1 &
    dir_pid=$!
    url="http://127.0.0.1:$((port + 1))"
    for _ in $(seq 600); do
      [ "$(curl -s -o /dev/null -w '%{http_code}' --max-time 2 "$url/readyz" || true)" = 200 ] && break
      kill -0 "$dir_pid" 2> /dev/null ||
        { echo "cluster_load.sh: serve exited: $(tail -n 1 "$current/serve.log")" >&2; exit 1; }
      sleep 0.1
    done
  else
    front="$(deploy/cluster.sh up "$current" --replicas "$replicas" --port "$port" | tail -n 1)"
    url="$front"
    [ "$config" = direct ] && url="http://127.0.0.1:$((port + 1))"
  fi
  ids=()
  for _ in $(seq "$scenes"); do
    ids+=("$(curl -fsS -F "color=@$TUM/rgb/1305031102.175304.png;type=image/png" \
      -F "depth=@$TUM/depth/1305031102.160407.png;type=image/png" -F "intrinsics=@$WORK/k.json;type=application/json" \
      -F "preset=realtime" "$url/v1/scenes" | jq -r .id)")
  done
  joined="$(IFS=,; echo "${ids[*]}")"
  info="$(curl -fsS "$url/v1/scenes/${ids[0]}")"
  read -r cx cy cz radius < <(echo "$info" | jq -r '.bounds as $b | [range(3)] | map(($b.min[.] + $b.max[.]) / 2) as $c
    | "\($c[0]) \($c[1]) \($c[2]) \(([$c[0], $c[1], $c[2]] | map(. * .) | add | sqrt))"')
  for id in "${ids[@]}"; do curl -fsS -o /dev/null "$url/v1/scenes/$id/view?pose=capture&width=640&height=480"; done
  result="$(wrk -t2 -c"$connections" -d"$duration" --timeout 10s -s bench/view_load.lua "$url" -- \
    "$joined" "$cx" "$cy" "$cz" "$radius" 640 480 | grep '^RESULT' | sed 's/^RESULT //')"
  get() { echo "$result" | tr ' ' '\n' | sed -n "s/^$1=//p"; }
  # Keyframe POSTs through the front (or the replica): 40 in sequence, each a new seq of one mission.
  glb="$WORK/k.glb"
  [ -f "$glb" ] || "$RGBDCAST_BIN" reduce --input "$TUM" --frame 0 --preset realtime --budget-kb 12 --out "$glb" \
    > /dev/null 2>&1 || true
  post_ms=""
  if [ -f "$glb" ]; then
    post_ms="$(for seq in $(seq 0 39); do
      curl -s -o /dev/null -w '%{time_total}\n' --data-binary "@$glb" -H 'Content-Type: model/gltf-binary' \
        "$url/v1/missions/bench/keyframes?seq=$seq&pose=0,0,0,0,0,0,1"
    done | sort -n | awk '{v[NR] = $1 * 1000} END {printf "%.1f %.1f", v[int(NR * 0.5 + 0.5)], v[int(NR * 0.95 + 0.5)]}')"
  fi
  rows+=("| $config | $connections | $scenes | $(get views_per_s) | $(get p50_ms) | $(get p99_ms) | $(get errors) | ${post_ms% *} | ${post_ms#* } |")
  if [ "$config" = dir ]; then stop_dir_server; else deploy/cluster.sh down "$current" > /dev/null; fi
  current=""
done
echo "| replicas | connections | scenes | views/s | p50 ms | p99 ms | errors | keyframe POST p50 ms | p95 ms |"
echo "|---|---|---|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
