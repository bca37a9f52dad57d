#!/usr/bin/python3
"""Prints bench/stream_bench.sh's table from its output folder: table.py OUT RUN..."""
import glob
import json
import os
import re
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
# Utilisation, two ways (acknowledged GLB bytes against the link rate):
#   busy = bytes / (rate x the seconds the sender had at least one POST in flight: the union over its lanes);
#   run  = bytes / (rate x the sending window: from the first keyframe being ready in the outbox to the last answer).
# "busy" says how well a POST uses the line while one is out; "run" also counts the line idle because no keyframe was
# waiting. overlap = seconds with two POSTs in flight. line = the relay's own count of upstream bytes (HTTP headers
# and answers' TCP included) over the window: the relay never carries more than its rate.
# Refinements (revisions rev > 0 that replaced a keyframe on the server): the acknowledged bytes are the sender's
# own count ("kB this run": every acknowledged POST body, first revisions and refinements); "run, first revisions"
# counts only the keyframes as first sent, over the window up to the last of them becoming viewable, so it compares
# with a stream that does not refine. kB/keyframe is of the first revisions; latency is first_available - captured
# (when the keyframe first became viewable; a refinement comes later and replaces it).
print("| input | link | keyframes sent | kB/keyframe (first rev) | refinements (kB) | utilisation busy / run | "
      "run, first revisions | line (relay) | overlap s | latency p50 / p95 s | lost / dup | coverage mission / batch | "
      "novel-view PSNR mission / batch dB | stream s |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
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
        lost = sum(1 for e in outbox if e["seq"] not in server or server[e["seq"]]["bytes"] != e["bytes"] or
                   server[e["seq"]].get("rev", 0) != e.get("rev", 0))
        frames = [e["frame"] for e in outbox]
        dup = (len(server_seqs) - len(set(server_seqs))) + (len(frames) - len(set(frames)))
        dup += sum(1 for s in server_seqs if s not in {e["seq"] for e in outbox})
        first_bytes = [e["first_bytes"] if e.get("rev", 0) > 0 else e["bytes"] for e in outbox]
        refined = [e for e in outbox if e.get("rev", 0) > 0]
        refine_kb = sum(e["bytes"] for e in refined) / 1000
        first_avail = {k["seq"]: k.get("first_available", k.get("available")) for k in kfs}
        lat = [first_avail[k["seq"]] - k["captured"] for k in kfs
               if isinstance(first_avail.get(k["seq"]), (int, float)) and "captured" in k]
        times = load(f"{name}.times.json", {}) or {}
        run_s = times.get("end", 0) - times.get("start", 0)
        busy = None
        log = open(f"{name}.stream.log").read() if os.path.exists(f"{name}.stream.log") else ""
        m_acked = re.search(r"\(([0-9.]+) kB this run", log)
        total_bytes = 1000 * float(m_acked.group(1)) if m_acked else sum(k["bytes"] for k in kfs)
        if "busy " in log:
            try:
                busy = float(log.split("busy ")[1].split(" s")[0])
            except ValueError:
                busy = None
        overlap = float("nan")
        if "with 2+ in flight" in log:
            try:
                overlap = float(log.split("busy ")[1].split(" s, ")[1].split(" s of it")[0])
            except (ValueError, IndexError):
                pass
        ready = [e["reduced"] for e in outbox if isinstance(e.get("reduced"), (int, float)) and e["reduced"] > 0]
        answered = [k["available"] for k in kfs if isinstance(k.get("available"), (int, float))]
        window = max(answered) - min(ready) if ready and answered else run_s
        first_answered = [v for v in first_avail.values() if isinstance(v, (int, float))]
        first_window = max(first_answered) - min(ready) if ready and first_answered else float("nan")
        util_first = sum(first_bytes) * 8 / 1000 / (kbps * first_window) if first_window > 0 else float("nan")
        util_busy = total_bytes * 8 / 1000 / (kbps * busy) if busy else float("nan")
        util_run = total_bytes * 8 / 1000 / (kbps * window) if window > 0 else float("nan")
        relay = load(f"{name}.relay.json", {}) or {}
        line = relay.get("up_bytes", 0) * 8 / 1000 / (kbps * window) if window > 0 else float("nan")
        ev = evals(f"{name}.eval.jsonl")
        print(f"| {ds} | {run.replace('-outage', ' + 10 s outage')} kbit/s | {len(kfs)} | "
              f"{sum(first_bytes) / 1000 / max(len(outbox), 1):.1f} | {len(refined)} ({refine_kb:.0f}) | "
              f"{100 * util_busy:.0f} % / {100 * util_run:.0f} % | {100 * util_first:.0f} % | "
              f"{100 * line:.0f} % | {overlap:.2f} | "
              f"{percentile(lat, 0.5):.2f} / {percentile(lat, 0.95):.2f} | {lost} / {dup} | "
              f"{median_of(ev, 'coverage'):.3f} / {median_of(batch, 'coverage'):.3f} | "
              f"{median_of(ev, 'psnr_valid_db'):.2f} / {median_of(batch, 'psnr_valid_db'):.2f} | {run_s:.0f} |")

# Where a keyframe's latency goes: medians over the keyframes of each stage (ms), from the outbox entries' times
# (tracked, reduced, post_started: kept by rgbdcast stream) and the server's answer (received: the request's
# headers were read; available: stored and appended to the resident mission, so it includes the body's time on the
# line). "-" where the outbox predates those fields.
print()
# "POST beyond the line": per first-revision POST (the --post-log timeline), its time from start to answer less its
# body's time at the link rate: the round trip (100 ms here) plus what the sender, the relay and the server add.
print("| input | link | keyframes | capture -> tracked ms | tracked -> reduced ms | reduced -> POST start ms | "
      "POST start -> received ms | received -> available ms | budget kB (median) | latency p95 s | "
      "POST beyond the line ms (median) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
stages = [("captured", "tracked"), ("tracked", "reduced"), ("reduced", "post_started"), ("post_started", "received"),
          ("received", "available")]
for ds in ("tum", "icl"):
    for run in runs:
        name = f"{out}/{ds}.{run}"
        if not os.path.exists(f"{name}.times.json"):
            continue  # not run (STREAM_BENCH_INPUTS / STREAM_BENCH_RUNS)
        outbox = [load(p) for p in sorted(glob.glob(f"{name}.outbox/kf-*.json"))]
        rows = []
        for e in outbox:  # the first revision's times (a refinement's answer comes later)
            ack = e.get("first_ack") if e and e.get("rev", 0) > 0 else (e or {}).get("ack")
            if not isinstance(ack, dict):
                continue
            t = dict(e)
            t["received"] = ack.get("received")
            t["available"] = ack.get("available")
            if e.get("rev", 0) > 0:
                t["budget_kb"] = e.get("first_budget_kb", e["budget_kb"])
            rows.append(t)
        cells = []
        for a, b in stages:
            d = [1000 * (r[b] - r[a]) for r in rows if isinstance(r.get(a), (int, float)) and
                 isinstance(r.get(b), (int, float))]
            cells.append(f"{statistics.median(d):.0f}" if d else "-")
        lat = [r["available"] - r["captured"] for r in rows if isinstance(r.get("available"), (int, float))]
        budgets = [r["budget_kb"] for r in rows]
        kbps = float(run.split("-")[0])
        posts = [json.loads(l) for l in open(f"{name}.posts.jsonl")] if os.path.exists(f"{name}.posts.jsonl") else []
        beyond = [1000 * (p["ended"] - p["started"] - p["bytes"] * 8 / 1000 / kbps) for p in posts
                  if p.get("rev", 0) == 0 and p.get("stored")]
        print(f"| {ds} | {run.replace('-outage', ' + 10 s outage')} kbit/s | {len(rows)} | " + " | ".join(cells) +
              f" | {statistics.median(budgets) if budgets else float('nan'):.1f} | {percentile(lat, 0.95):.2f} | "
              f"{statistics.median(beyond) if beyond else float('nan'):.0f} |")

# Is the tracker keeping up (the stream's "tracking:" line): frames read / tracked / dropped behind the camera, per
# frame the wall time from its due time (or read) to its tracking's end, the reader's and the tracker's CPU time, and
# the keyframes' reduction time on their own thread.
print()
print("| input | link | frames read / tracked / dropped | due -> tracked p50 / p95 ms | reader CPU p50 / p95 ms | "
      "tracker CPU p50 / p95 ms | reduction p50 / p95 ms | load before / after |")
print("|---|---|---|---|---|---|---|---|")
for ds in ("tum", "icl"):
    for run in runs:
        name = f"{out}/{ds}.{run}"
        log = open(f"{name}.stream.log").read() if os.path.exists(f"{name}.stream.log") else ""
        if "tracking:" not in log:
            continue
        t = log.split("tracking:")[1].split("\n")[0]
        m = re.search(r"(\d+) frames read, (\d+) tracked, (\d+) dropped", t)
        pairs = re.findall(r"p50 ([0-9.]+) / p95 ([0-9.]+)", t)  # due -> tracked, reader, tracker, reduction
        if not m or len(pairs) < 4:
            continue
        nums = [float(x) for x in m.groups()] + [float(x) for pair in pairs[:4] for x in pair]
        print(f"| {ds} | {run.replace('-outage', ' + 10 s outage')} kbit/s | {nums[0]:.0f} / {nums[1]:.0f} / "
              f"{nums[2]:.0f} | {nums[3]:.1f} / {nums[4]:.1f} | {nums[5]:.1f} / {nums[6]:.1f} | {nums[7]:.1f} / "
              f"{nums[8]:.1f} | {nums[9]:.0f} / {nums[10]:.0f} | "
              f"{' / '.join(open(name + '.load').read().split()) if os.path.exists(name + '.load') else '-'} |")
