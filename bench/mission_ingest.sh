#!/usr/bin/env bash
# Service side of a live mission: KEYFRAMES frames of the TUM fr1/xyz excerpt (every 120/KEYFRAMES-th),
# each reduced by `rgbdcast reduce --preset realtime` (its default 40 kB budget), posted in order with its ground-truth
# pose (relative to the first). Per keyframe: the post's received -> available time (the server's share of the
# capture-to-view latency), its store and append parts (X-Store-Ms; X-Append-Ms only from binaries that append to the
# renderers on POST, empty otherwise), and a 640x480 orbit view right after it (which draws the new keyframe). Then the same mission loaded whole by a fresh server
# (X-Upload-Ms: what each keyframe would cost if the mission were uploaded again instead of appended).
#   bench/mission_ingest.sh [KEYFRAMES=12] [BUILD_DIR=build]   (RGBDCAST_BIN overrides the binary)
set -euo pipefail
N=${1:-12}
BUILD=${2:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=$(mktemp -d /tmp/rgbdcast-mission-bench.XXXXXX)
source "$ROOT/bench/serve_common.sh"
EXCERPT=${RGBDCAST_DATA:-$ROOT/../shared/data}/tum/rgbd_dataset_freiburg1_xyz_200_319
FRAMES=$(/usr/bin/python3 -c "n=$N; print(' '.join(str(round(i * 119 / max(1, n - 1))) for i in range(n)))")
for f in $FRAMES; do
  "$BIN" reduce --input "$EXCERPT" --frame "$f" --preset realtime --out "$WORK/kf$f.glb" > /dev/null
done
# Ground-truth poses relative to the first keyframe, TUM order (nearest ground-truth stamp to each colour frame).
/usr/bin/python3 - "$EXCERPT" $FRAMES > "$WORK/poses.txt" <<'PY'
import sys, math
root, frames = sys.argv[1], [int(x) for x in sys.argv[2:]]
rows = lambda p: [l.split() for l in open(p) if l.strip() and not l.startswith('#')]
rgb = [float(r[0]) for r in rows(root + '/rgb.txt')]
gt = [[float(x) for x in r] for r in rows(root + '/groundtruth.txt')]
def mat(q):
    x, y, z, w = q; n = math.sqrt(x*x + y*y + z*z + w*w); x, y, z, w = x/n, y/n, z/n, w/n
    return [[1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w)], [2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w)],
            [2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y)]]
def quat(R):
    t = R[0][0] + R[1][1] + R[2][2]
    if t > 0:
        s = 0.5 / math.sqrt(t + 1); return [(R[2][1]-R[1][2])*s, (R[0][2]-R[2][0])*s, (R[1][0]-R[0][1])*s, 0.25/s]
    i = max(range(3), key=lambda k: R[k][k]); j, k = (i+1) % 3, (i+2) % 3
    s = 2 * math.sqrt(1 + R[i][i] - R[j][j] - R[k][k]); q = [0, 0, 0, 0]
    q[i] = 0.25 * s; q[j] = (R[j][i] + R[i][j]) / s; q[k] = (R[k][i] + R[i][k]) / s; q[3] = (R[k][j] - R[j][k]) / s
    return q
def pose(t):
    g = min(gt, key=lambda r: abs(r[0] - t)); return mat(g[4:8]), g[1:4]
R0, t0 = pose(rgb[frames[0]])
for f in frames:
    R, t = pose(rgb[f])
    Rr = [[sum(R0[k][i] * R[k][j] for k in range(3)) for j in range(3)] for i in range(3)]  # R0^T R
    tr = [sum(R0[k][i] * (t[k] - t0[k]) for k in range(3)) for i in range(3)]
    q = quat(Rr)
    print(f, rgb[f], ','.join('%.9g' % v for v in tr + q))
PY
start_server "$WORK/store"
VIEW="$BASE/v1/missions/bench/view?eye=0,-0.3,-1.2&target=0,0,1.5&fov=90&width=640&height=480"
printf "%-4s %-6s %8s %9s %12s %9s %10s %9s %s\n" seq frame kB triangles "post ms" "store ms" "append ms" "view ms" "view uploaded?"
seq=0
: > "$WORK/rows.txt"
while read -r f captured pose; do
  curl -s -D "$WORK/h.txt" -o "$WORK/a.json" -H 'Content-Type: model/gltf-binary' --data-binary "@$WORK/kf$f.glb" \
    "$BASE/v1/missions/bench/keyframes?seq=$seq&pose=$pose&captured=$captured"
  hdr() { tr -d '\r' < "$WORK/h.txt" | awk -v k="$1" 'tolower($1) == tolower(k) ":" {print $2}'; }
  post_ms=$(/usr/bin/python3 -c "import json; a=json.load(open('$WORK/a.json')); print('%.1f' % (1000*(a['available']-a['received'])))")
  bytes=$(/usr/bin/python3 -c "import json; a=json.load(open('$WORK/a.json')); print(a['bytes'], a['triangles'])")
  view_s=$(curl -s -D "$WORK/vh.txt" -o /dev/null -w '%{time_total}' "$VIEW")
  uploaded=$(tr -d '\r' < "$WORK/vh.txt" | awk 'tolower($1) == "x-upload-ms:" {print "yes " $2 " ms"}')
  set -- $bytes
  printf "%-4s %-6s %8.1f %9s %12s %9s %10s %9.1f %s\n" "$seq" "$f" "$(echo "$1 / 1024" | bc -l)" "$2" "$post_ms" \
    "$(hdr X-Store-Ms | cut -c1-6)" "$(hdr X-Append-Ms | cut -c1-6)" "$(echo "$view_s * 1000" | bc -l)" "${uploaded:-no}"
  echo "$post_ms $(hdr X-Store-Ms) $(hdr X-Append-Ms) $(echo "$view_s * 1000" | bc -l)" >> "$WORK/rows.txt"
  seq=$((seq + 1))
done < "$WORK/poses.txt"
/usr/bin/python3 - "$WORK/rows.txt" <<'PY'
import sys, statistics as st
rows = [[float(x) for x in l.split()] for l in open(sys.argv[1])]
later = rows[1:]  # keyframe 0 has no resident mission to append to
print("median over keyframes 1..%d: post %.1f ms, store %.1f ms, append %.1f ms, view %.1f ms" % (
    len(later), *(st.median(r[i] for r in later) for i in range(4))))
PY
kill "$SERVER"; wait "$SERVER" 2>/dev/null || true
start_server "$WORK/store"
curl -s -D "$WORK/vh.txt" -o /dev/null "$VIEW"
echo "a fresh server loading the whole $N-keyframe mission for its first view: X-Upload-Ms $(tr -d '\r' < "$WORK/vh.txt" | awk 'tolower($1) == "x-upload-ms:" {print $2}') ms (decode + upload)"
