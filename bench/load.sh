#!/usr/bin/env bash
# Load test of `rgbdcast serve`: wrk, 8 connections for 30 s, 640x480 JPEG views of TUM fr1/xyz frame 0
# from a ring of viewpoints; prints p50, p99, views/s and errors.
#
#   bench/load.sh                      # starts build/app/rgbdcast serve on a free port with a temporary store
#   bench/load.sh --url http://127.0.0.1:8080 [--scene ID]   # against a running server (uploads frame 0 if no ID)
# Options: --duration 30s --connections 8 --threads 2 --width 640 --height 480 --bin build/app/rgbdcast
# Needs wrk, curl and jq (scripts/setup.sh installs them) and ../shared/data.
# The uploaded frame is reduced with RGBDCAST_UPLOAD_PRESET (default paper: the BENCHMARKS.md figures were measured
# with the paper preset's 733 kB scene, before realtime became the service's default; realtime gives a 38 kB one).
set -euo pipefail
cd "$(dirname "$0")/.."

url="" scene="" duration="30s" connections=8 threads=2 width=640 height=480 bin="build/app/rgbdcast" extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --url) url="$2"; shift 2 ;;
    --scene) scene="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --connections) connections="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --width) width="$2"; shift 2 ;;
    --height) height="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --) shift; extra=("$@"); break ;;  # passed to rgbdcast serve
    *) echo "load.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
for tool in wrk curl jq; do
  command -v "$tool" >/dev/null || { echo "load.sh: $tool is missing (scripts/setup.sh installs it)" >&2; exit 2; }
done

server_pid="" data_dir=""
cleanup() {
  if [ -n "$server_pid" ]; then kill -TERM "$server_pid" 2>/dev/null || true; wait "$server_pid" 2>/dev/null || true; fi
  if [ -n "$data_dir" ]; then rm -rf "$data_dir"; fi
}
trap cleanup EXIT

if [ -z "$url" ]; then
  [ -x "$bin" ] || { echo "load.sh: $bin not built (cmake --build build --target rgbdcast)" >&2; exit 2; }
  data_dir="$(mktemp -d /tmp/rgbdcast-load.XXXXXX)"
  "$bin" serve --data-dir "$data_dir/store" --port 0 "${extra[@]}" > "$data_dir/server.log" 2>&1 &
  server_pid=$!
  for _ in $(seq 1 300); do
    port="$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$data_dir/server.log")"
    [ -n "$port" ] && break
    kill -0 "$server_pid" 2>/dev/null || { cat "$data_dir/server.log" >&2; exit 1; }
    sleep 0.1
  done
  [ -n "$port" ] || { echo "load.sh: server did not start" >&2; cat "$data_dir/server.log" >&2; exit 1; }
  url="http://127.0.0.1:$port"
  grep "renderer" "$data_dir/server.log" || true
fi

if [ -z "$scene" ]; then
  tum=../shared/data/tum/rgbd_dataset_freiburg1_xyz
  intr="$(mktemp /tmp/rgbdcast-fr1.XXXXXX.json)"
  echo '{"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
         "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000}' > "$intr"
  scene="$(curl -fsS -F "color=@$tum/rgb/1305031102.175304.png;type=image/png" \
                     -F "depth=@$tum/depth/1305031102.160407.png;type=image/png" \
                     -F "intrinsics=@$intr;type=application/json" \
                     -F "preset=${RGBDCAST_UPLOAD_PRESET:-paper}" "$url/v1/scenes" | jq -r .id)"
  rm -f "$intr"
  echo "uploaded frame 0 of fr1/xyz as scene $scene"
fi

info="$(curl -fsS "$url/v1/scenes/$scene")"
read -r cx cy cz radius < <(echo "$info" | jq -r '.bounds as $b | [range(3)] | map(($b.min[.] + $b.max[.]) / 2) as $c
  | "\($c[0]) \($c[1]) \($c[2]) \(([$c[0], $c[1], $c[2]] | map(. * .) | add | sqrt))"')
echo "scene $scene: $(echo "$info" | jq -r '"\(.triangles) triangles, \(.bytes) bytes"'); orbit centre $cx $cy $cz radius $radius"
backend="$(curl -fsS "$url/healthz" | jq -r '"\(.backend) (\(.device))"')"
# One view first, so that the scene is resident (upload time is not a view's).
curl -fsS -o /dev/null "$url/v1/scenes/$scene/view?pose=capture&width=$width&height=$height"

echo "wrk: $connections connections, $threads threads, $duration, ${width}x${height} JPEG, backend $backend"
out="$(wrk -t"$threads" -c"$connections" -d"$duration" --timeout 10s -s bench/view_load.lua "$url" -- \
        "$scene" "$cx" "$cy" "$cz" "$radius" "$width" "$height")"
echo "$out"
result="$(echo "$out" | grep '^RESULT')"
echo
echo "| connections | duration | size | backend | views/s | p50 ms | p99 ms | errors |"
echo "|---|---|---|---|---|---|---|---|"
echo "$result" | sed 's/^RESULT //' | tr ' ' '\n' | awk -F= -v c="$connections" -v d="$duration" -v s="${width}x${height}" \
  -v b="${backend%% *}" '{v[$1]=$2} END {printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n", c, d, s, b, v["views_per_s"], v["p50_ms"], v["p99_ms"], v["errors"]}'
