#!/usr/bin/python3
"""Prints bench/stream_bench.sh's table from its output folder: table.py OUT RUN..."""
import glob
import json
import os
import statistics
import sys


def load(path, default=None):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return default


def evals(path):
    rows = []
    if os.path.exists(path):
        for line in open(path):
            line = line.strip()
            if line:
                try:
                    rows.append(json.loads(line))
                except ValueError:
                    pass
    return rows


def median_of(rows, key):
    vals = [r[key] for r in rows if isinstance(r.get(key), (int, float))]
    return statistics.median(vals) if vals else float("nan")


def percentile(vals, p):
    if not vals:
        return float("nan")
    s = sorted(vals)
    k = (len(s) - 1) * p
    lo, hi = int(k), min(int(k) + 1, len(s) - 1)
    return s[lo] + (s[hi] - s[lo]) * (k - lo)


out, runs = sys.argv[1], sys.argv[2:]
print("| input | link | keyframes sent | kB/keyframe | utilisation busy / run | goodput kbit/s | latency p50 / p95 s "
      "| lost / dup | coverage mission / batch | novel-view PSNR mission / batch dB | stream s |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for ds in ("tum", "icl"):
    batch = evals(f"{out}/{ds}.batch.eval.jsonl")
    for run in runs:
        name = f"{out}/{ds}.{run}"
        if not os.path.exists(f"{name}.times.json"):
            continue  # not run (STREAM_BENCH_INPUTS / STREAM_BENCH_RUNS)
        kbps = float(run.split("-")[0])
        mission = load(f"{name}.mission.json", {}) or {}
        kfs = mission.get("keyframes", [])
        outbox = [load(p) for p in sorted(glob.glob(f"{name}.outbox/kf-*.json"))]
        outbox = [e for e in outbox if e]
        server_seqs = [k["seq"] for k in kfs]
        server = {k["seq"]: k for k in kfs}
        lost = sum(1 for e in outbox if e["seq"] not in server or server[e["seq"]]["bytes"] != e["bytes"])
        frames = [e["frame"] for e in outbox]
        dup = (len(server_seqs) - len(set(server_seqs))) + (len(frames) - len(set(frames)))
        dup += sum(1 for s in server_seqs if s not in {e["seq"] for e in outbox})
        total_bytes = sum(k["bytes"] for k in kfs)
        lat = [k["available"] - k["captured"] for k in kfs if "available" in k and "captured" in k]
        times = load(f"{name}.times.json", {}) or {}
        run_s = times.get("end", 0) - times.get("start", 0)
        busy = None
        log = open(f"{name}.stream.log").read() if os.path.exists(f"{name}.stream.log") else ""
        if "busy " in log:
            try:
                busy = float(log.split("busy ")[1].split(" s")[0])
            except ValueError:
                busy = None
        util_busy = total_bytes * 8 / 1000 / (kbps * busy) if busy else float("nan")
        util_run = total_bytes * 8 / 1000 / (kbps * run_s) if run_s > 0 else float("nan")
        goodput = total_bytes * 8 / 1000 / busy if busy else float("nan")
        ev = evals(f"{name}.eval.jsonl")
        print(f"| {ds} | {run.replace('-outage', ' + 10 s outage')} kbit/s | {len(kfs)} | "
              f"{total_bytes / 1000 / max(len(kfs), 1):.1f} | {100 * util_busy:.0f} % / {100 * util_run:.0f} % | "
              f"{goodput:.0f} | {percentile(lat, 0.5):.2f} / {percentile(lat, 0.95):.2f} | {lost} / {dup} | "
              f"{median_of(ev, 'coverage'):.3f} / {median_of(batch, 'coverage'):.3f} | "
              f"{median_of(ev, 'psnr_valid_db'):.2f} / {median_of(batch, 'psnr_valid_db'):.2f} | {run_s:.0f} |")

# Where a keyframe's latency goes: medians over the keyframes of each stage (ms), from the outbox entries' times
# (tracked, reduced, post_started: kept by rgbdcast stream) and the server's answer (received: the request's
# headers were read; available: stored and appended to the resident mission, so it includes the body's time on the
# line). "-" where the outbox predates those fields.
print()
print("| input | link | keyframes | capture -> tracked ms | tracked -> reduced ms | reduced -> POST start ms | "
      "POST start -> received ms | received -> available ms | budget kB (median) | latency p95 s |")
print("|---|---|---|---|---|---|---|---|---|---|")
stages = [("captured", "tracked"), ("tracked", "reduced"), ("reduced", "post_started"), ("post_started", "received"),
          ("received", "available")]
for ds in ("tum", "icl"):
    for run in runs:
        name = f"{out}/{ds}.{run}"
        if not os.path.exists(f"{name}.times.json"):
            continue  # not run (STREAM_BENCH_INPUTS / STREAM_BENCH_RUNS)
        outbox = [load(p) for p in sorted(glob.glob(f"{name}.outbox/kf-*.json"))]
        rows = []
        for e in outbox:
            if not e or not isinstance(e.get("ack"), dict):
                continue
            t = dict(e)
            t["received"] = e["ack"].get("received")
            t["available"] = e["ack"].get("available")
            rows.append(t)
        cells = []
        for a, b in stages:
            d = [1000 * (r[b] - r[a]) for r in rows if isinstance(r.get(a), (int, float)) and
                 isinstance(r.get(b), (int, float))]
            cells.append(f"{statistics.median(d):.0f}" if d else "-")
        lat = [r["available"] - r["captured"] for r in rows if isinstance(r.get("available"), (int, float))]
        budgets = [r["budget_kb"] for r in rows]
        print(f"| {ds} | {run.replace('-outage', ' + 10 s outage')} kbit/s | {len(rows)} | " + " | ".join(cells) +
              f" | {statistics.median(budgets) if budgets else float('nan'):.1f} | {percentile(lat, 0.95):.2f} |")
