#!/usr/bin/python3
"""What a keyframe POST costs a client on a direct connection, beyond the server's own work.

For each rgbdcast binary given, starts `rgbdcast serve` on loopback, posts the GLBs given (in order, as seq 1, 2, ...
of one mission, over one keep-alive connection, Python's http.client as the client), ROUNDS times each into a fresh
mission, and prints one table: per binary, the median over all posts of the client's time from the request's start
to the answer, the server's own share (the answer's available - received: body, decode, store, append), of that the
store (both files written and synced: X-Store-Ms) and the renderers' append (X-Append-Ms: only binaries that append
to the resident renderers on POST report it; nan for those that draw new keyframes at the next view), and the
difference (what the connection adds: on loopback nothing but the TCP stack's own waits).

    bench/post_roundtrip.py [--rounds 5] --bin NAME=PATH [--bin NAME=PATH ...] GLB [GLB ...]
"""
import argparse
import http.client
import json
import os
import shutil
import socket
import statistics
import subprocess
import tempfile
import time


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def measure(binary, glbs, rounds):
    data = tempfile.mkdtemp(prefix="rgbdcast-post-rt.")
    port = free_port()
    server = subprocess.Popen([binary, "serve", "--data-dir", data, "--port", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                time.sleep(0.1)
        bodies = [open(g, "rb").read() for g in glbs]
        total, server_ms, store_ms, append_ms = [], [], [], []
        for r in range(rounds):
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            for seq, body in enumerate(bodies, start=1):
                t0 = time.monotonic()
                c.request("POST", f"/v1/missions/rt{r}/keyframes?seq={seq}&pose=0,0,0,0,0,0,1", body=body,
                          headers={"Content-Type": "model/gltf-binary"})
                res = c.getresponse()
                answer = json.loads(res.read())
                t1 = time.monotonic()
                if res.status != 201:
                    raise SystemExit(f"{binary}: POST answered {res.status}: {answer}")
                total.append(1000 * (t1 - t0))
                server_ms.append(1000 * (answer["available"] - answer["received"]))
                store_ms.append(float(res.getheader("X-Store-Ms", "nan")))
                append_ms.append(float(res.getheader("X-Append-Ms", "nan")))
            c.close()
        return total, server_ms, store_ms, append_ms
    finally:
        server.terminate()
        server.wait()
        shutil.rmtree(data, ignore_errors=True)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--bin", action="append", required=True, help="NAME=PATH of an rgbdcast binary")
    p.add_argument("glbs", nargs="+")
    a = p.parse_args()
    sizes = [os.path.getsize(g) for g in a.glbs]
    print(f"{len(a.glbs)} GLBs of {min(sizes) / 1000:.1f}-{max(sizes) / 1000:.1f} kB, {a.rounds} rounds, loopback")
    print("| build | posts | client: start -> answer ms (median) | server: received -> available ms (median) | "
          "of it: store / append ms (median) | the connection's share ms (median) |")
    print("|---|---|---|---|---|---|")
    for spec in a.bin:
        name, path = spec.split("=", 1)
        total, server_ms, store_ms, append_ms = measure(path, a.glbs, a.rounds)
        diff = [t - s for t, s in zip(total, server_ms)]
        print(f"| {name} | {len(total)} | {statistics.median(total):.1f} | {statistics.median(server_ms):.1f} | "
              f"{statistics.median(store_ms):.1f} / {statistics.median(append_ms):.1f} | {statistics.median(diff):.1f} |")


if __name__ == "__main__":
    main()
