#!/usr/bin/env python3
"""Failover of a mission's views behind nginx: what a kill -9 of the replica serving a mission costs its operators.

For each client count: a fresh cluster (deploy/cluster.sh up, 3 replicas, PostgreSQL, nginx), a mission of K
keyframes (frame 0 of TUM fr1/xyz reduced once, posted through the front at poses 0.5 m apart), and C clients asking
its view (pose=capture, 320x240 JPEG) through the front in a loop. Once the mission's tileset has settled on the
replica that serves it (X-Rgbdcast-Replica), that replica is killed (-9) at KILL_AT_S into the run. A client told
503 (load shed, "render queue full") waits its Retry-After (at most 1 s), as an operator's page does. Prints, per
client count: views/s before the kill, the views shed (503) before and after it, the failed views (any other answer
but 200, or none within 10 s), the time from the kill to the last failure, the time to the first view answered by
another replica, and the latency p50/p99 before and after the kill.
  /usr/bin/python3 bench/cluster_failover.py [--clients 8 32] [--duration-s 15] [--kill-at-s 5] [--keyframes 4]
Needs nginx and PostgreSQL 15 (scripts/setup.sh test), the built binary (RGBDCAST_BIN, else build/app/rgbdcast)
and ../shared/data. Starts and stops only its own cluster (deploy/cluster.sh down, by pid files).
"""
import argparse
import http.client
import json
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TUM = os.path.join(os.environ.get("RGBDCAST_DATA", os.path.join(ROOT, "..", "shared", "data")),
                   "tum", "rgbd_dataset_freiburg1_xyz")


def request(port, method, path, body=None, headers=None, timeout=10.0):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request(method, path, body=body, headers=headers or {})
        r = conn.getresponse()
        data = r.read()
        return r.status, dict(r.getheaders()), data
    finally:
        conn.close()


def percentile(values, q):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


def keyframe_glb(work):
    glb = os.path.join(work, "k.glb")
    binary = os.environ.get("RGBDCAST_BIN", os.path.join(ROOT, "build", "app", "rgbdcast"))
    subprocess.run([binary, "reduce", "--input", TUM, "--frame", "0", "--preset", "realtime", "--budget-kb", "12",
                    "--out", glb], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(glb, "rb") as f:
        return f.read()


def wait_settled(port, mission, timeout_s=120.0):
    """The replica that serves the mission's views, once they come from its settled tileset alone."""
    end = time.monotonic() + timeout_s
    path = f"/v1/missions/{mission}/view?pose=capture&width=64&height=48&format=png"
    while time.monotonic() < end:
        try:
            status, h, _ = request(port, "GET", path)
            if (status == 200 and h.get("X-Pending-Keyframes") == "0" and h.get("X-Stale-Tiles") == "0"
                    and h.get("X-Tileset-Version", "0") != "0"):
                return h["X-Rgbdcast-Replica"]
        except OSError:
            pass
        time.sleep(0.2)
    raise SystemExit(f"cluster_failover.py: mission {mission} never settled within {timeout_s:.0f} s")


def run_clients(port, path, clients, duration_s, kill_at_s, kill):
    """Each client asks `path` in a loop; `kill` runs at kill_at_s. Returns (t_kill, [(t0, t1, status, replica)])."""
    start = time.monotonic()
    stop = start + duration_s
    results, lock = [], threading.Lock()

    def client():
        while time.monotonic() < stop:
            t0 = time.monotonic()
            retry_after = 0.0
            try:
                status, h, _ = request(port, "GET", path)
                replica = h.get("X-Rgbdcast-Replica", "")
                if status == 503:
                    retry_after = min(1.0, float(h.get("Retry-After", "1")))
            except (OSError, ValueError):
                status, replica = 0, ""
            with lock:
                results.append((t0 - start, time.monotonic() - start, status, replica))
            time.sleep(retry_after)  # as an operator's page does: a shed view is asked again when told

    threads = [threading.Thread(target=client) for _ in range(clients)]
    for t in threads:
        t.start()
    time.sleep(max(0.0, start + kill_at_s - time.monotonic()))
    t_kill = time.monotonic() - start
    kill()
    for t in threads:
        t.join()
    return t_kill, results


def one_run(work, glb, clients, args):
    cluster = os.path.join(work, f"c{clients}")
    for _ in range(3):  # a port taken by another program: another one
        port = random.randint(20000, 39000)
        up = subprocess.run([os.path.join(ROOT, "deploy", "cluster.sh"), "up", cluster, "--replicas", "3", "--port",
                             str(port)], capture_output=True, text=True)
        if up.returncode == 0 or "cannot bind" not in up.stderr:
            break
        subprocess.run([os.path.join(ROOT, "deploy", "cluster.sh"), "down", cluster], capture_output=True)
    try:
        if up.returncode != 0:
            raise SystemExit(f"cluster_failover.py: cluster.sh up failed: {up.stderr.strip()}")
        mission = f"failover{clients}"
        for seq in range(args.keyframes):
            status, _, body = request(port, "POST", f"/v1/missions/{mission}/keyframes?seq={seq}"
                                      f"&pose={0.5 * seq},0,0,0,0,0,1", glb,
                                      {"Content-Type": "model/gltf-binary"})
            if status != 201:
                raise SystemExit(f"cluster_failover.py: keyframe {seq} answered {status}: {body[:200]!r}")
        serving = wait_settled(port, mission)
        with open(os.path.join(cluster, f"replica-{serving}.pid")) as f:
            pid = int(f.read().strip())
        path = f"/v1/missions/{mission}/view?pose=capture&width=320&height=240&format=jpeg"
        t_kill, results = run_clients(port, path, clients, args.duration_s, args.kill_at_s,
                                      lambda: os.kill(pid, signal.SIGKILL))
    finally:
        subprocess.run([os.path.join(ROOT, "deploy", "cluster.sh"), "down", cluster], capture_output=True)
    before = [r for r in results if r[1] <= t_kill]
    after = [r for r in results if r[0] >= t_kill]
    shed = [r for r in results if r[2] == 503]
    failed = [r for r in results if r[2] not in (200, 503)]
    other = [r[1] for r in results if r[2] == 200 and r[0] >= t_kill and r[3] and r[3] != serving]
    row = {
        "clients": clients,
        "served_by": serving,
        "views": len(results),
        "views_per_s_before": len([r for r in before if r[2] == 200]) / t_kill if t_kill > 0 else float("nan"),
        "shed_before": len([r for r in shed if r[1] <= t_kill]),
        "shed_after": len([r for r in shed if r[1] > t_kill]),
        "failed": len(failed),
        "failed_statuses": sorted({r[2] for r in failed}),
        "last_failure_after_kill_s": max((r[1] - t_kill for r in failed), default=0.0),
        "first_other_replica_after_kill_s": (min(other) - t_kill) if other else float("nan"),
        "p50_before_ms": 1000 * percentile([r[1] - r[0] for r in before if r[2] == 200], 0.5),
        "p99_before_ms": 1000 * percentile([r[1] - r[0] for r in before if r[2] == 200], 0.99),
        "p50_after_ms": 1000 * percentile([r[1] - r[0] for r in after if r[2] == 200], 0.5),
        "p99_after_ms": 1000 * percentile([r[1] - r[0] for r in after if r[2] == 200], 0.99),
    }
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--clients", type=int, nargs="+", default=[8, 32])
    p.add_argument("--duration-s", type=float, default=15.0)
    p.add_argument("--kill-at-s", type=float, default=5.0)
    p.add_argument("--keyframes", type=int, default=4)
    p.add_argument("--json", help="also write the rows here")
    args = p.parse_args()
    if not os.path.isdir(TUM):
        raise SystemExit(f"cluster_failover.py: no TUM data at {TUM}")
    work = tempfile.mkdtemp(prefix="rgbdcast-failover-", dir="/tmp")
    os.chmod(work, 0o755)  # PostgreSQL runs as its own user and must reach its folder inside
    try:
        glb = keyframe_glb(work)
        rows = [one_run(work, glb, c, args) for c in args.clients]
    finally:
        subprocess.run(["rm", "-rf", work])
    print("| clients | views | views/s before | shed (503) before / after | failed (statuses) | last failure after "
          "kill s | first view from another replica s | p50/p99 ms before | p50/p99 ms after |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        statuses = ",".join(str(s) for s in r["failed_statuses"]) or "-"
        print(f"| {r['clients']} | {r['views']} | {r['views_per_s_before']:.1f} | {r['shed_before']} / "
              f"{r['shed_after']} | {r['failed']} ({statuses}) | "
              f"{r['last_failure_after_kill_s']:.2f} | {r['first_other_replica_after_kill_s']:.2f} | "
              f"{r['p50_before_ms']:.0f}/{r['p99_before_ms']:.0f} | {r['p50_after_ms']:.0f}/{r['p99_after_ms']:.0f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
