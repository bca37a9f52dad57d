#!/usr/bin/env bash
# bench/stream_bench.sh: rgbdcast stream over an emulated link. For each input and link it starts a fresh
# `rgbdcast serve`, a link relay in front of it (bench/stream/link_relay.py: rate, one-way delay, loss, outage; this
# kernel has no sch_netem, see its header), streams the input with --link-kbps equal to the link rate, then reads the
# mission back and prints one table (bench/stream/table.py): keyframes sent, kB per keyframe, link utilisation,
# capture-to-view latency p50/p95 ("available" - "captured"), keyframes lost/duplicated (outbox vs
# GET /v1/missions/{name}), and coverage + novel-view PSNR of the final mission against a batch
# `reduce --sequence --preset realtime` of the same frames (rgbdcast eval with ground-truth poses).
# Extra flags of `rgbdcast stream`: STREAM_BENCH_STREAM_ARGS (e.g. "--latency-ms 0" for the rate rule alone).
# The outage starts once half of the 2 Mbit/s run's keyframes are in the outbox, so that run comes first; without it
# STREAM_BENCH_OUTAGE_AFTER=K says after how many. The servers, relays and watchers it started are stopped (by pid)
# when it ends, also on a failure.
# Usage: bash bench/stream_bench.sh [OUT_DIR]   (needs build/app/rgbdcast; about 15 min on 2 busy cores)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BIN=${RGBDCAST_BIN:-$ROOT/build/app/rgbdcast}   # RGBDCAST_BIN: another build of it (e.g. a baseline)
DATA=$ROOT/../shared/data
OUT=${1:-/tmp/rgbdcast_stream_bench}
PY=/usr/bin/python3
REALTIME=${STREAM_BENCH_REALTIME:-}   # set to --realtime to read frames at their own timestamps
# STREAM_BENCH_REUSE_BATCH=1 keeps the batch results of an earlier run in OUT (they do not depend on the link).
if [[ -z ${STREAM_BENCH_REUSE_BATCH:-} ]]; then rm -rf "$OUT"; fi
mkdir -p "$OUT"

declare -A INPUT=([tum]=$DATA/tum/rgbd_dataset_freiburg1_xyz_200_319 [icl]=$DATA/augmented_icl_livingroom)
declare -A GT=([tum]=$DATA/tum/rgbd_dataset_freiburg1_xyz_200_319/groundtruth.txt [icl]=$DATA/augmented_icl_livingroom/trajectory.log)
declare -A VIEWS=([tum]="10 35 65 95 115" [icl]="1 2 3 4")
RUNS=${STREAM_BENCH_RUNS:-"2000 500 100 500-outage"}   # a subset, e.g. STREAM_BENCH_RUNS=500
DATASETS=${STREAM_BENCH_INPUTS:-"tum icl"}
port=$((20000 + RANDOM % 20000))
serve_pid= relay_pid= watcher_pid=
stop_started() {
  local pid
  for pid in $watcher_pid $relay_pid $serve_pid; do kill -TERM "$pid" 2>/dev/null && wait "$pid" 2>/dev/null || true; done
  serve_pid= relay_pid= watcher_pid=
  return 0
}
trap stop_started EXIT
# A build that can log its POSTs writes them to NAME.posts.jsonl (table.py's timeline; older builds lack the flag).
POST_LOG=; if "$BIN" stream --help 2>/dev/null | grep -- --post-log >/dev/null; then POST_LOG=1; fi


eval_scene() {  # eval_scene NAME GLB DATASET -> NAME.eval.jsonl (one JSON line per novel view)
  local name=$1 glb=$2 ds=$3
  : > "$OUT/$name.eval.jsonl"
  for f in ${VIEWS[$ds]}; do
    "$BIN" eval --input "${INPUT[$ds]}" --frame "$f" --scene "$glb" --groundtruth "${GT[$ds]}" --scene-frame 0 \
      2>/dev/null | tr -d '\n' >> "$OUT/$name.eval.jsonl" || true
    echo >> "$OUT/$name.eval.jsonl"
  done
}

for ds in $DATASETS; do
  if [[ -z ${STREAM_BENCH_REUSE_BATCH:-} || ! -s $OUT/$ds.batch.eval.jsonl ]]; then
    echo "== $ds: batch reduce --sequence --preset realtime" >&2
    "$BIN" reduce --sequence --preset realtime --no-progress --input "${INPUT[$ds]}" --out "$OUT/$ds.batch.glb" \
      --report "$OUT/$ds.batch.json" > "$OUT/$ds.batch.log" 2>&1
    eval_scene "$ds.batch" "$OUT/$ds.batch.glb" "$ds"
  fi
  for run in $RUNS; do
    kbps=${run%-outage}
    name=$ds.$run
    echo "== $name" >&2
    rm -rf "$OUT/$name".*
    if [[ $run == *outage ]]; then
      if [[ -n ${STREAM_BENCH_OUTAGE_AFTER:-} ]]; then
        half=$STREAM_BENCH_OUTAGE_AFTER
      elif compgen -G "$OUT/$ds.2000.outbox/kf-*.json" >/dev/null; then
        half=$(( $(ls "$OUT/$ds.2000.outbox"/kf-*.json | wc -l) / 2 )); [[ $half -lt 1 ]] && half=1
      else
        echo "stream_bench: $name needs the 2000 run first (it starts the outage at half its keyframes), or STREAM_BENCH_OUTAGE_AFTER=K" >&2
        exit 2
      fi
    fi
    port=$((port + 2)); sport=$port; rport=$((port + 1))   # not in a subshell: $port must advance
    "$BIN" serve --data-dir "$OUT/$name.data" --port "$sport" --allow-origin "http://127.0.0.1:$rport" > "$OUT/$name.serve.log" 2>&1 &
    serve_pid=$!
    $PY bench/stream/link_relay.py --listen-port "$rport" --target-port "$sport" --kbps "$kbps" --delay-ms 50 \
      --outage-s 10 --stats "$OUT/$name.relay.json" > "$OUT/$name.relay.log" 2>&1 &
    relay_pid=$!
    for _ in $(seq 100); do curl -sf "http://127.0.0.1:$sport/healthz" >/dev/null && break; sleep 0.1; done
    for _ in $(seq 100); do curl -sf "http://127.0.0.1:$rport/healthz" >/dev/null && break; sleep 0.1; done   # the relay too
    watcher_pid=
    if [[ $run == *outage ]]; then
      # The outage in the middle: once `half` keyframes are in the outbox.
      ( while [[ $(ls "$OUT/$name.outbox"/kf-*.json 2>/dev/null | wc -l) -lt $half ]]; do sleep 0.05; done
        date +%s.%N > "$OUT/$name.outage_start"; kill -USR1 $relay_pid ) &
      watcher_pid=$!
    fi
    cut -d' ' -f1 /proc/loadavg > "$OUT/$name.load"   # the 1-minute load average before and after the run
    start=$(date +%s.%N)
    "$BIN" stream --input "${INPUT[$ds]}" --server "http://127.0.0.1:$rport" --mission "$ds$kbps" $REALTIME \
      --outbox "$OUT/$name.outbox" --link-kbps "$kbps" --progress-interval 5 ${POST_LOG:+--post-log "$OUT/$name.posts.jsonl"} ${STREAM_BENCH_STREAM_ARGS:-} \
      > "$OUT/$name.stream.log" 2> "$OUT/$name.stream.err" || echo "stream exited $?" >> "$OUT/$name.stream.err"
    end=$(date +%s.%N)
    cut -d' ' -f1 /proc/loadavg >> "$OUT/$name.load"
    echo "{\"start\": $start, \"end\": $end}" > "$OUT/$name.times.json"
    curl -sf "http://127.0.0.1:$sport/v1/missions/$ds$kbps" > "$OUT/$name.mission.json" || echo '{}' > "$OUT/$name.mission.json"
    curl -sf "http://127.0.0.1:$sport/v1/missions/$ds$kbps/model.glb" -o "$OUT/$name.model.glb" || true
    stop_started
    [[ -s $OUT/$name.model.glb ]] && eval_scene "$name" "$OUT/$name.model.glb" "$ds"
  done
done
$PY bench/stream/table.py "$OUT" $RUNS
