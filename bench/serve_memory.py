#!/usr/bin/python3
"""Where `rgbdcast serve`'s memory goes on a long mission: RSS by kind of mapping, and the renderers' resident parts.

The workload is bench/long_mission.py's (12 TUM fr1/xyz frames reduced once, posted in laps as one mission; --variant
exploration or revisit). A fresh server on loopback (its own data dir, stopped by pid) gets N keyframes; once its
tileset has settled, and again after VIEWS robot views and VIEWS overviews (640x480, sequential), the table gives
/proc/PID/smaps' Rss summed by kind (heap, anonymous mappings: lavapipe's device memory is host memory; shared
libraries; the rest), /metrics' rgbdcast_resident_part_bytes and rgbdcast_resident_parts, and for the views the
p50 time and the last view's X-Tiles, X-Max-Error and X-Parts-Loaded.

    bench/serve_memory.py [--variant revisit] [--views 10] [--bin PATH] N
"""
import argparse
import collections
import os
import re
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import long_mission as lm  # noqa: E402

KINDS = ("heap", "anon", "libraries", "other")


def rss_by_kind(pid):
    kb = collections.Counter()
    kind = "other"
    with open(f"/proc/{pid}/smaps") as f:
        for line in f:
            if re.match(r"^[0-9a-f]+-[0-9a-f]+ ", line):
                parts = line.split()
                path = parts[5] if len(parts) > 5 else ""
                kind = ("heap" if path == "[heap]" else "anon" if not path else
                        "libraries" if ".so" in os.path.basename(path) else "other")
            elif line.startswith("Rss:"):
                kb[kind] += int(line.split()[1])
    return {k: kb[k] / 1024 for k in KINDS}


def resident(server):
    _, body, _ = server.get("/metrics")
    out = {}
    for line in body.decode().split("\n"):
        m = re.match(r"^rgbdcast_resident_part(_bytes|s) (\S+)$", line)
        if m:
            out[m.group(1)] = float(m.group(2))
    return out.get("_bytes", 0) / 2**20, int(out.get("s", 0))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("n", type=int, help="keyframes")
    p.add_argument("--variant", default="revisit", choices=["exploration", "revisit"])
    p.add_argument("--views", type=int, default=10)
    p.add_argument("--bin", default=os.environ.get("RGBDCAST_BIN", os.path.join(lm.ROOT, "build", "app", "rgbdcast")))
    p.add_argument("--lag-timeout-s", type=float, default=1800.0)
    p.add_argument("--data", default=os.path.join(lm.ROOT, "..", "shared", "data"))
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="rgbdcast-serve-memory.")
    server = None
    try:
        workload = lm.Workload(a.bin, lm.binary_env(a.bin),
                               os.path.join(a.data, "tum", "rgbd_dataset_freiburg1_xyz_200_319"), work)
        server = lm.Server(a.bin, tempfile.mkdtemp(dir=work), open(os.path.join(work, "serve.log"), "w"), 1 << 40)
        poster = lm.Poster(server, workload, a.variant)
        for seq in range(a.n):
            poster.post(seq)
        if lm.wait_tiles(server, a.n, a.lag_timeout_s) is None or lm.wait_settled(server, a.lag_timeout_s) is None:
            sys.exit(f"serve_memory: the tileset did not settle in {a.lag_timeout_s:.0f} s")
        robot, overview, _ = lm.view_paths(workload, a.variant, a.n, 640, 480, "")
        print(f"serve_memory: {a.variant}, N = {a.n}, {a.bin}")
        print("| after | p50 ms | tiles | max-error px | parts loaded | heap MB | anon MB | libraries MB | other MB |"
              " resident parts MB (count) |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for label, path in (("ingest", None), ("robot views", robot), ("overviews", overview)):
            view = ["-"] * 4
            if path:
                ms = lm.timed_views(server, path, a.views)
                _, _, res = server.get(path)
                view = [f"{lm.pct(ms, 50):.1f}"] + [res.getheader(h) or "-" for h in
                                                     ("X-Tiles", "X-Max-Error", "X-Parts-Loaded")]
            kinds = rss_by_kind(server.proc.pid)
            mb, count = resident(server)
            print(f"| {label} | " + " | ".join(view) + " | " + " | ".join(f"{kinds[k]:.0f}" for k in KINDS) +
                  f" | {mb:.0f} ({count}) |", flush=True)
    finally:
        if server:
            server.stop()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
