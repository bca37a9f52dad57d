# Shared by bench/soak.sh, bench/durability.sh and bench/memory_burst.sh (sourced, not run): the binary, the data,
# a free loopback port, starting `rgbdcast serve` and uploading TUM fr1/xyz frame 0 as a multipart frame.
# Expects ROOT and WORK to be set by the caller; sets BIN, TUM, PORT, BASE, SERVER (and ID, by base_scene).
# On exit: the server stopped and WORK removed (a caller that needs another cleanup sets its own trap after this).
trap 'kill "$SERVER" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$WORK"' EXIT
BIN=${RGBDCAST_BIN:-$ROOT/${BUILD:-build}/app/rgbdcast}
TUM=${RGBDCAST_DATA:-$ROOT/../shared/data}/tum/rgbd_dataset_freiburg1_xyz
PORT=${PORT:-$((20000 + RANDOM % 20000))}
BASE=http://127.0.0.1:$PORT
SERVER=
cat > "$WORK/k.json" <<'K'
{"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
 "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000}
K

# start_server STORE_DIR: starts the server in the background and waits for /healthz.
start_server() {
  "$BIN" serve --data-dir "$1" --bind 127.0.0.1 --port "$PORT" > "$WORK/server.log" 2>&1 &
  SERVER=$!
  for _ in $(seq 200); do curl -sf "$BASE/healthz" > /dev/null && return 0; sleep 0.05; done
  echo "$(basename "$0"): the server did not start"; cat "$WORK/server.log"; exit 1
}
# frame_upload OUT_FILE: POSTs frame 0 as color, depth and intrinsics parts; prints the HTTP status. The preset is
# RGBDCAST_UPLOAD_PRESET, paper by default: the figures in BENCHMARKS.md were measured with the paper preset's scene,
# from before realtime became the service's default.
frame_upload() {
  curl -s -o "$1" -w '%{http_code}' -F "color=@$TUM/rgb/1305031102.175304.png;type=image/png" \
    -F "depth=@$TUM/depth/1305031102.160407.png;type=image/png" -F "intrinsics=@$WORK/k.json" \
    -F "preset=${RGBDCAST_UPLOAD_PRESET:-paper}" "$BASE/v1/scenes"
}
# scene_id JSON_FILE: the "id" of a stored scene's JSON.
scene_id() { sed -n 's/.*"id":"\([0-9a-f]*\)".*/\1/p' "$1"; }
# rss_mib: the server's resident set in MiB.
rss_mib() { awk '/VmRSS/ {printf "%.1f", $2 / 1024}' "/proc/$SERVER/status"; }
# base_scene: reduces frame 0 on the server (frame_upload); sets ID to its scene and downloads its GLB to
# $WORK/scene.glb, the body bench/soak.sh and bench/store_rss.sh upload again.
base_scene() {
  [ "$(frame_upload "$WORK/first.json")" = 201 ] || { echo "$(basename "$0"): the first frame upload failed"; cat "$WORK/server.log"; exit 1; }
  ID=$(scene_id "$WORK/first.json")
  curl -sf -o "$WORK/scene.glb" "$BASE/v1/scenes/$ID/model.glb"
}
