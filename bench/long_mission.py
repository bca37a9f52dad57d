#!/usr/bin/python3
"""A long live mission on `rgbdcast serve`: memory, view time, throughput, ingest and late-join cost against its length.

The workload: 12 frames of the TUM fr1/xyz 200-319 excerpt (0, 10, ..., 110), reduced once by `rgbdcast reduce` with
its default preset, posed by the ground truth relative to frame 0, and posted again and again in laps of 12 as one
mission (keyframe i is frame 10 * (i mod 12) of lap i div 12, seq i). Two variants:
  exploration  lap L is moved by (4 m * (L mod 20), 0, 5 m * (L div 20)) in the first camera's frame: a building floor,
               every lap new surface;
  revisit      lap L is moved by (1 m * (L mod 2), 0, 0): the robot passes the same place again and again.
For each size N, variant and binary, a fresh server on loopback (its own data dir, stopped by pid) gets, in order:
  1. N keyframes posted back to back over one keep-alive connection (POST p50/p95, client side);
  2. the wait until the tile worker's committed hierarchy holds all N (its lag behind the last POST answer), then
     until it has no stale inner tile ("settled", the same moment for a hierarchy committed whole), and the server's
     CPU seconds (user + system) from its start to then, which a shared machine does not inflate;
  3. RSS (VmRSS, and VmHWM, the peak) after ingest;
  4. VIEWS robot views (pose=capture: the newest keyframe's camera) and VIEWS overviews (a camera that frames the
     whole mission from above and behind at 45 degrees, 60 degrees vertical fov), 640x480, sequential: p50; then
     (unless --no-fidelity) the PSNR of a default robot view and overview against max-error=0 at the same camera, and
     against the captured frame, over the pixels that the newest keyframe's own GLB (uploaded as a scene) draws at
     its capture pose, of the robot view and of that own GLB's view;
  5. CLIENTS concurrent clients for THROUGHPUT_S seconds, each cycling robot, overview and orbit views (the operator
     page's orbit: 2.7 m around a point 1.5 m ahead of a random keyframe's camera): views/s and p99; RSS after;
  6. LIVE more keyframes at LIVE_RATE a second, each timed from its POST's start to the SSE `event: tileset` whose
     version holds it (the event names only the version: the benchmark reads which keyframes a version holds from
     the server's tiles/<mission>/hierarchy.json in the data dir it owns): p50/p95;
  7. late join: tileset.json (asked for with Accept-Encoding: gzip, as a browser does) plus the tiles that a 1280x720
     overview (the same camera) selects at 16 px screen-space error (bench/tileset_selection.py), fetched: the bytes
     on the wire, and tileset.json's own share of them against its JSON;
  8. storage: bytes under the data dir's tiles/<mission>/ and the whole data dir, against the posted bytes;
  9. model.glb?max-error=0 (full detail, merged from the leaf tiles and streamed from disk; the in-memory
     whole-mission model.glb is refused past serve --max-model-keyframes): bytes and seconds; RSS at the end.
A binary whose estimated RSS (--mb-per-keyframe NAME=MB, 3.8 for one named "baseline": it holds every keyframe in
memory) would pass --max-rss-gb at N is skipped ("skipped: memory"); a server whose RSS passes it at any time is
killed by a watchdog ("stopped: memory"). A server that dies or fails a request ends its row ("failed at seq K", K the
last keyframe posted; its log's tail in the JSON), not the run. Prints one table per variant; --json writes every
figure.

    bench/long_mission.py [--variants exploration,revisit] [--bin NAME=PATH ...] [--json OUT] N [N ...]
    (default binaries: new=$RGBDCAST_BIN or build/app/rgbdcast, baseline=$RGBDCAST_BASELINE_BIN when set)
"""
import argparse
import http.client
import json
import math
import os
import random
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib

import numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tileset_selection  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FRAMES = list(range(0, 120, 10))
MISSION = "long"
BASE_RSS_MB = 320.0  # an idle server with one mission's renderers, for the memory estimate


# ---- workload --------------------------------------------------------------------------------------------------

def read_rows(path):
    return [line.split() for line in open(path) if line.strip() and not line.startswith("#")]


def quat_to_mat(q):
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def mat_to_quat(r):
    t = r[0][0] + r[1][1] + r[2][2]
    if t > 0:
        s = 0.5 / math.sqrt(t + 1)
        return [(r[2][1] - r[1][2]) * s, (r[0][2] - r[2][0]) * s, (r[1][0] - r[0][1]) * s, 0.25 / s]
    i = max(range(3), key=lambda k: r[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(1 + r[i][i] - r[j][j] - r[k][k])
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (r[j][i] + r[i][j]) / s
    q[k] = (r[k][i] + r[i][k]) / s
    q[3] = (r[k][j] - r[j][k]) / s
    return q


def relative_poses(excerpt):
    """Per frame of FRAMES: (R, t) camera-to-world relative to the first, from the nearest ground-truth stamp."""
    rgb = [float(r[0]) for r in read_rows(os.path.join(excerpt, "rgb.txt"))]
    gt = [[float(x) for x in r] for r in read_rows(os.path.join(excerpt, "groundtruth.txt"))]

    def pose(t):
        g = min(gt, key=lambda r: abs(r[0] - t))
        return quat_to_mat(g[4:8]), g[1:4]

    r0, t0 = pose(rgb[FRAMES[0]])
    out = []
    for f in FRAMES:
        r, t = pose(rgb[f])
        rr = [[sum(r0[k][i] * r[k][j] for k in range(3)) for j in range(3)] for i in range(3)]  # R0^T R
        tr = [sum(r0[k][i] * (t[k] - t0[k]) for k in range(3)) for i in range(3)]
        out.append((rr, tr))
    return out


def glb_position_box(path):
    """Min and max of the GLB's POSITION accessors (the keyframe's mesh, in its camera's OpenCV frame)."""
    data = open(path, "rb").read()
    length = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20:20 + length])
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            acc = doc["accessors"][prim["attributes"]["POSITION"]]
            lo = [min(a, b) for a, b in zip(lo, acc["min"])]
            hi = [max(a, b) for a, b in zip(hi, acc["max"])]
    return lo, hi


def lap_offset(variant, lap):
    if variant == "exploration":
        return [4.0 * (lap % 20), 0.0, 5.0 * (lap // 20)]
    return [1.0 * (lap % 2), 0.0, 0.0]


class Workload:
    def __init__(self, binary, env, excerpt, work):
        self.bodies, self.boxes = [], []
        for f in FRAMES:
            out = os.path.join(work, f"kf{f}.glb")
            subprocess.run([binary, "reduce", "--input", excerpt, "--frame", str(f), "--out", out], env=env,
                           check=True, stdout=subprocess.DEVNULL)
            self.bodies.append(open(out, "rb").read())
            self.boxes.append(glb_position_box(out))
        self.poses = relative_poses(excerpt)
        self.images = [os.path.join(excerpt, r[1]) for r in read_rows(os.path.join(excerpt, "rgb.txt"))]

    def frame_image(self, i):
        """The colour image keyframe i was reduced from."""
        return self.images[FRAMES[i % len(FRAMES)]]

    def keyframe(self, variant, i):
        """(body, pose query value, camera-to-world R, t) of keyframe i."""
        r, t = self.poses[i % len(FRAMES)]
        off = lap_offset(variant, i // len(FRAMES))
        tw = [t[k] + off[k] for k in range(3)]
        pose = ",".join("%.9g" % v for v in tw + mat_to_quat(r))
        return self.bodies[i % len(FRAMES)], pose, r, tw

    def world_box(self, variant, n):
        lo, hi = [math.inf] * 3, [-math.inf] * 3
        for i in range(min(n, len(FRAMES))):
            _, _, r, t = self.keyframe(variant, i)
            blo, bhi = self.boxes[i]
            for c in range(8):
                p = [(bhi if c >> k & 1 else blo)[k] for k in range(3)]
                w = [sum(r[a][b] * p[b] for b in range(3)) + t[a] for a in range(3)]
                lo, hi = [min(a, b) for a, b in zip(lo, w)], [max(a, b) for a, b in zip(hi, w)]
        offs = [lap_offset(variant, lap) for lap in range((n + len(FRAMES) - 1) // len(FRAMES))]
        return ([lo[k] + min(o[k] for o in offs) for k in range(3)], [hi[k] + max(o[k] for o in offs) for k in range(3)])


def overview_camera(box, fov_deg=60.0):
    """Eye and target in the world frame (OpenCV axes, up = -y): the box's bounding sphere framed from above and
    behind, looking down at 45 degrees."""
    lo, hi = box
    c = [(lo[k] + hi[k]) / 2 for k in range(3)]
    radius = 0.5 * math.dist(lo, hi)
    d = 1.05 * radius / math.sin(math.radians(fov_deg) / 2)
    direction = [0.0, math.sqrt(0.5), math.sqrt(0.5)]  # eye -> target: down (+y) and forward (+z)
    return [c[k] - d * direction[k] for k in range(3)], c


def fmt3(v):
    return ",".join("%.4f" % x for x in v)


# ---- server ----------------------------------------------------------------------------------------------------

def binary_env(path):
    env = dict(os.environ)
    folder = os.path.dirname(os.path.abspath(path))
    if any(name.startswith("librgbdcast") for name in os.listdir(folder)):
        env["LD_LIBRARY_PATH"] = folder + (":" + env["LD_LIBRARY_PATH"] if env.get("LD_LIBRARY_PATH") else "")
    return env


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """`rgbdcast serve` on a free loopback port, watched: past max_rss_mb of VmRSS it is killed (SIGKILL, by pid) and
    killed_at_mb says so, since one view can grow a server by gigabytes between two requests."""

    def __init__(self, binary, data, log, max_rss_mb):
        self.port = free_port()
        self.data = data
        self.killed_at_mb = None
        self.proc = subprocess.Popen([binary, "serve", "--data-dir", data, "--bind", "127.0.0.1", "--port",
                                      str(self.port)], stdout=log, stderr=subprocess.STDOUT, env=binary_env(binary))
        self._stopping = threading.Event()
        self._watchdog = threading.Thread(target=self._watch, args=(max_rss_mb,), daemon=True)
        self._watchdog.start()
        for _ in range(300):
            if self.proc.poll() is not None:
                raise RuntimeError(f"{binary} serve exited with {self.proc.returncode}")
            try:
                status, _, _ = self.get("/healthz", timeout=1)
                if status == 200:
                    return
            except OSError:
                pass
            time.sleep(0.1)
        raise RuntimeError(f"{binary} serve did not answer /healthz")

    def connect(self, timeout=120):
        return http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)

    def get(self, path, timeout=120):
        c = self.connect(timeout)
        try:
            c.request("GET", path)
            res = c.getresponse()
            return res.status, res.read(), res
        finally:
            c.close()

    def _watch(self, max_rss_mb):
        while not self._stopping.wait(0.25):
            try:
                rss = self.memory_mb()[0]
            except (OSError, KeyError):
                return  # the server is gone
            if rss > max_rss_mb:
                self.killed_at_mb = rss
                self.proc.kill()
                return

    def memory_mb(self):
        """(VmRSS, VmHWM) in MiB."""
        fields = {}
        with open(f"/proc/{self.proc.pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("VmRSS", "VmHWM"):
                    fields[key] = int(value.split()[0]) / 1024
        return fields["VmRSS"], fields["VmHWM"]

    def cpu_s(self):
        """CPU seconds (user + system) the server has used: unlike wall time, it holds on a shared machine."""
        with open(f"/proc/{self.proc.pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def check_alive(self):
        code = self.proc.poll()
        if code is not None:
            raise RuntimeError(f"the server exited with {code}")

    def hierarchy(self):
        """(version, set of seqs) of the committed tile hierarchy, or (0, empty) before the first commit."""
        try:
            j = json.load(open(os.path.join(self.data, "tiles", MISSION, "hierarchy.json")))
        except (OSError, ValueError):
            return 0, set()
        return j["version"], {k[0] for k in j["keyframes"]}

    def stale_tiles(self):
        """Stale tiles in the committed hierarchy (records' 13th field, where the format has one), or None unread."""
        try:
            j = json.load(open(os.path.join(self.data, "tiles", MISSION, "hierarchy.json")))
        except (OSError, ValueError):
            return None
        return sum(1 for t in j["tiles"] if len(t) > 12 and t[12])

    def stop(self):
        self._stopping.set()
        self._watchdog.join()
        self.proc.terminate()
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def pct(values, q):
    if not values:
        return None
    s = sorted(values)
    return s[min(len(s) - 1, max(0, math.ceil(q / 100 * len(s)) - 1))]


# ---- phases ----------------------------------------------------------------------------------------------------

class Poster:
    """Keyframe POSTs over one keep-alive connection, reopened when the server closed it (idle timeout)."""

    def __init__(self, server, workload, variant):
        self.server, self.workload, self.variant = server, workload, variant
        self.conn = server.connect()
        self.posted_bytes = 0

    def post(self, seq):
        body, pose, _, _ = self.workload.keyframe(self.variant, seq)
        path = f"/v1/missions/{MISSION}/keyframes?seq={seq}&pose={pose}"
        for attempt in range(2):
            t0 = time.monotonic()
            try:
                self.conn.request("POST", path, body=body, headers={"Content-Type": "model/gltf-binary"})
                res = self.conn.getresponse()
                answer = res.read()
                break
            except (http.client.HTTPException, ConnectionError):
                self.conn.close()
                self.conn = self.server.connect()
                if attempt:
                    raise
        t1 = time.monotonic()
        if res.status not in (200, 201):
            raise RuntimeError(f"POST seq {seq}: {res.status} {answer[:200]!r}")
        self.posted_bytes += len(body)
        return t0, t1


def wait_tiles(server, n, timeout_s):
    """Seconds until the committed hierarchy holds seqs 0..n-1, or None after timeout_s."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        _, seqs = server.hierarchy()
        if len(seqs) >= n and all(s in seqs for s in range(n)):
            return time.monotonic() - t0
        server.check_alive()
        time.sleep(0.2)
    return None


def wait_settled(server, timeout_s):
    """Seconds until the committed hierarchy has no stale tile (every inner tile built from its children's current
    content), or None after timeout_s."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        if server.stale_tiles() == 0:
            return time.monotonic() - t0
        server.check_alive()
        time.sleep(0.2)
    return None


def view_paths(workload, variant, n, width, height, extra):
    eye, target = overview_camera(workload.world_box(variant, n))
    q = f"width={width}&height={height}" + (f"&{extra}" if extra else "")
    robot = f"/v1/missions/{MISSION}/view?pose=capture&{q}"
    overview = f"/v1/missions/{MISSION}/view?eye={fmt3(eye)}&target={fmt3(target)}&up=0,-1,0&fov=60&{q}"

    def orbit(rng):
        _, _, r, t = workload.keyframe(variant, rng.randrange(n))
        centre = [t[k] + 1.5 * r[k][2] for k in range(3)]
        yaw, pitch, radius = rng.uniform(-math.pi, math.pi), 0.2, 2.7
        e = [centre[0] + radius * math.sin(yaw) * math.cos(pitch), centre[1] - radius * math.sin(pitch),
             centre[2] - radius * math.cos(yaw) * math.cos(pitch)]
        return f"/v1/missions/{MISSION}/view?eye={fmt3(e)}&target={fmt3(centre)}&up=0,-1,0&fov=70&{q}"

    return robot, overview, orbit


def png_rgb(data):
    """An 8-bit RGB or RGBA PNG (not interlaced), as the service writes its views, as an h x w x 3 or 4 array."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, w = 8, [], 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", chunk)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise ValueError("not an 8-bit RGB(A) PNG")
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat.append(chunk)
        pos += 12 + length
    raw, stride = zlib.decompress(b"".join(idat)), w * bpp
    out, prev = bytearray(h * stride), bytearray(stride)
    for y in range(h):
        f, row = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(bpp, stride):
                row[i] = (row[i] + row[i - bpp]) & 255
        elif f == 2:
            row = bytearray((a + b) & 255 for a, b in zip(row, prev))
        elif f == 3:
            for i in range(stride):
                row[i] = (row[i] + ((row[i - bpp] if i >= bpp else 0) + prev[i]) // 2) & 255
        elif f == 4:
            for i in range(stride):
                a, b = (row[i - bpp] if i >= bpp else 0), prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                row[i] = (row[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out[y * stride:(y + 1) * stride], prev = row, row
    return numpy.frombuffer(bytes(out), numpy.uint8).reshape(h, w, bpp)


def psnr_db(a, b, mask=None):
    """PSNR of the RGB channels of a against b, over the pixels mask (h x w, bool) holds, or all."""
    d = (a[:, :, :3].astype(numpy.float64) - b[:, :, :3].astype(numpy.float64)) ** 2
    mse = numpy.mean(d if mask is None else d[mask])
    return float("inf") if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)


def fidelity(server, workload, variant, n, robot, overview):
    """PSNR (dB) of the default robot view and overview against max-error=0 (full detail) at the same camera; and
    against the captured frame, over the pixels the newest keyframe's own GLB draws (uploaded as a scene, rendered at
    its capture pose), of the robot view (that keyframe's capture camera, the tileset) and of that own GLB's view."""
    def png(path):
        status, body, _ = server.get(path + "&format=png")
        if status != 200:
            raise RuntimeError(f"view {path}: {status}")
        return png_rgb(body)

    def full(path):
        return path.replace("view?", "view?max-error=0&", 1)

    robot_img = png(robot)
    out = {"robot_db": psnr_db(robot_img, png(full(robot))), "overview_db": psnr_db(png(overview), png(full(overview)))}
    c = server.connect()
    try:
        c.request("POST", "/v1/scenes", body=workload.keyframe(variant, n - 1)[0],
                  headers={"Content-Type": "model/gltf-binary"})
        res = c.getresponse()
        answer = res.read()
    finally:
        c.close()
    if res.status != 201:
        raise RuntimeError(f"scene upload: {res.status} {answer[:200]!r}")
    scene = json.loads(answer)["id"]
    own = png(f"/v1/scenes/{scene}/view?{robot.split('?', 1)[1]}")
    frame = png_rgb(open(workload.frame_image(n - 1), "rb").read())
    drawn = own[:, :, 3] > 0 if own.shape[2] == 4 else None
    out["robot_vs_frame_db"] = psnr_db(robot_img, frame, drawn)
    out["own_glb_vs_frame_db"] = psnr_db(own, frame, drawn)
    return out


def timed_views(server, path, count):
    c = server.connect()
    times = []
    try:
        for _ in range(count):
            t0 = time.monotonic()
            c.request("GET", path)
            res = c.getresponse()
            res.read()
            if res.status != 200:
                raise RuntimeError(f"view {path}: {res.status}")
            times.append(1000 * (time.monotonic() - t0))
    finally:
        c.close()
    return times


def throughput(server, robot, overview, orbit, clients, seconds):
    lock = threading.Lock()
    times, failures = [], [0]
    end = time.monotonic() + seconds

    def client(k):
        rng = random.Random(k)
        c = server.connect(timeout=60)
        i = k
        while time.monotonic() < end:
            path = (robot, overview, None)[i % 3] or orbit(rng)
            i += 1
            t0 = time.monotonic()
            try:
                c.request("GET", path)
                res = c.getresponse()
                res.read()
                ok = res.status == 200
            except (http.client.HTTPException, OSError):
                c.close()
                c = server.connect(timeout=60)
                ok = False
            with lock:
                if ok:
                    times.append(1000 * (time.monotonic() - t0))
                else:
                    failures[0] += 1
        c.close()

    t0 = time.monotonic()
    threads = [threading.Thread(target=client, args=(k,)) for k in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    elapsed = time.monotonic() - t0
    return {"views": len(times), "failures": failures[0], "views_per_s": len(times) / elapsed,
            "p50_ms": pct(times, 50), "p99_ms": pct(times, 99)}


def live_ingest(server, poster, first_seq, count, rate, timeout_s):
    """Keyframes first_seq.. posted at `rate` a second; seconds from each POST's start to the first tileset event
    whose version holds it (None when none did within timeout_s of the last POST)."""
    events = []  # (arrival, version, seqs held)
    stop = threading.Event()
    conn = server.connect(timeout=timeout_s + count / rate + 60)
    conn.request("GET", f"/v1/missions/{MISSION}/events?last_event_id={first_seq - 1}")
    res = conn.getresponse()
    if res.status != 200:
        raise RuntimeError(f"events: {res.status}")

    def reader():
        kind = None
        try:
            while not stop.is_set():
                line = res.readline()
                if not line:
                    return
                line = line.decode().rstrip("\r\n")
                if line.startswith("event:"):
                    kind = line[6:].strip()
                elif line.startswith("data:") and kind == "tileset":
                    arrival = time.monotonic()
                    version = json.loads(line[5:])["version"]
                    held_version, seqs = server.hierarchy()
                    # A newer commit read meanwhile says nothing of this version: it is credited at its own event.
                    events.append((arrival, version, seqs if held_version == version else set()))
                elif not line:
                    kind = None
        except (OSError, ValueError, AttributeError, http.client.HTTPException):
            return  # the stream ended, or was shut down below (http.client then fails in its own ways)

    thread = threading.Thread(target=reader, daemon=True)
    thread.start()
    starts = {}
    t_begin = time.monotonic()
    for k in range(count):
        time.sleep(max(0.0, t_begin + k / rate - time.monotonic()))
        seq = first_seq + k
        starts[seq] = poster.post(seq)[0]
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        held = set().union(*(e[2] for e in events)) if events else set()
        if all(s in held for s in starts):
            break
        server.check_alive()
        time.sleep(0.1)
    stop.set()
    try:
        conn.sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    thread.join(timeout=5)
    conn.close()
    latencies = {}
    for seq, t0 in starts.items():
        seen = [arrival for arrival, _, seqs in events if seq in seqs and arrival >= t0]
        latencies[seq] = (min(seen) - t0) if seen else None
    return latencies


def late_join(server, camera_eye_world, width, height, fovy_deg, max_sse):
    # As a browser asks for it (gzip: Chromium also offers br, which the standard library cannot decode); "bytes"
    # counts what crossed the wire, "tileset_bytes" the JSON itself.
    c = server.connect()
    try:
        t0 = time.monotonic()
        c.request("GET", f"/v1/missions/{MISSION}/tileset.json", headers={"Accept-Encoding": "gzip"})
        res = c.getresponse()
        wire = res.read()
        tileset_s = time.monotonic() - t0
    finally:
        c.close()
    if res.status != 200:
        return {"error": f"tileset.json: {res.status}"}
    encoding = res.getheader("Content-Encoding", "identity")
    body = zlib.decompress(wire, 16 + zlib.MAX_WBITS) if encoding == "gzip" else wire
    tileset = json.loads(body)
    eye = tileset_selection.world_to_tileset(camera_eye_world)
    uris = tileset_selection.select_contents(tileset, eye, height, math.radians(fovy_deg), max_sse)
    tile_bytes = 0
    c = server.connect()
    try:
        for uri in uris:
            c.request("GET", f"/v1/missions/{MISSION}/{uri}")
            res = c.getresponse()
            data = res.read()
            if res.status != 200:
                return {"error": f"{uri}: {res.status}"}
            tile_bytes += len(data)
    finally:
        c.close()
    return {"tileset_bytes": len(body), "tileset_wire_bytes": len(wire), "tileset_encoding": encoding,
            "tileset_ms": 1000 * tileset_s, "tiles": len(uris), "tile_bytes": tile_bytes,
            "bytes": len(wire) + tile_bytes, "version": tileset["asset"].get("tilesetVersion"), "width": width,
            "height": height}


def folder_bytes(path):
    total = 0
    for folder, _, files in os.walk(path):
        for name in files:
            try:
                total += os.path.getsize(os.path.join(folder, name))
            except OSError:
                pass
    return total


def run_one(name, binary, n, variant, workload, a, work):
    r = {"binary": name, "path": binary, "n": n, "variant": variant}
    estimate_mb = BASE_RSS_MB + a.mb_per_keyframe.get(name, 0.0) * n
    if estimate_mb > 1024 * a.max_rss_gb:
        r["skipped"] = f"memory (estimated {estimate_mb / 1024:.1f} GB)"
        return r
    data = tempfile.mkdtemp(prefix=f"data-{name}-{variant}-{n}.", dir=work)
    log = open(os.path.join(work, f"serve-{name}-{variant}-{n}.log"), "w")
    server = Server(binary, data, log, 1024 * a.max_rss_gb)
    try:
        poster = Poster(server, workload, variant)
        post_ms, last_answer = [], None
        t_bulk = time.monotonic()
        for seq in range(n):
            t0, t1 = poster.post(seq)
            post_ms.append(1000 * (t1 - t0))
            last_answer = t1
        r.update(posted_bytes=poster.posted_bytes, bulk_s=time.monotonic() - t_bulk, post_p50_ms=pct(post_ms, 50),
                 post_p95_ms=pct(post_ms, 95))
        # The tile worker's lag: from the last POST's answer until the committed hierarchy holds every keyframe.
        r["tile_lag_s"] = None if wait_tiles(server, n, a.lag_timeout_s) is None else time.monotonic() - last_answer
        # ... and until no inner tile is stale any more (the same moment for a hierarchy built in one commit).
        r["settled_s"] = None if wait_settled(server, a.lag_timeout_s) is None else time.monotonic() - last_answer
        r["ingest_cpu_s"] = server.cpu_s()
        r["rss_ingest_mb"], r["hwm_ingest_mb"] = server.memory_mb()

        robot, overview, orbit = view_paths(workload, variant, n, 640, 480, a.view_extra)
        first = timed_views(server, robot, 2)  # one per renderer: a renderer that does not hold the mission loads it
        r["first_views_ms"] = first
        r["robot_p50_ms"] = pct(timed_views(server, robot, a.views), 50)
        r["overview_p50_ms"] = pct(timed_views(server, overview, a.views), 50)
        if a.fidelity:
            r["fidelity"] = fidelity(server, workload, variant, n, robot, overview)
        r["throughput"] = throughput(server, robot, overview, orbit, a.clients, a.throughput_s)
        r["rss_views_mb"], r["hwm_views_mb"] = server.memory_mb()

        poster.conn.close()
        poster.conn = server.connect()
        lat = live_ingest(server, poster, n, a.live, a.live_rate, a.live_timeout_s)
        got = [v for v in lat.values() if v is not None]
        r["live"] = {"keyframes": len(lat), "seen": len(got), "p50_ms": pct([1000 * v for v in got], 50),
                     "p95_ms": pct([1000 * v for v in got], 95) if len(got) == len(lat) else None}
        r["posted_bytes"] = poster.posted_bytes
        total = n + a.live
        r["tile_lag_after_live_s"] = wait_tiles(server, total, a.lag_timeout_s)

        eye, _ = overview_camera(workload.world_box(variant, total))
        r["late_join"] = late_join(server, eye, 1280, 720, 60.0, 16.0)
        r["tiles_bytes"] = folder_bytes(os.path.join(data, "tiles", MISSION))
        r["data_bytes"] = folder_bytes(data)

        t0 = time.monotonic()
        status, body, _ = server.get(f"/v1/missions/{MISSION}/model.glb?max-error=0", timeout=a.model_timeout_s)
        r["model"] = {"status": status, "bytes": len(body), "s": time.monotonic() - t0}
        del body
        r["rss_end_mb"], r["hwm_end_mb"] = server.memory_mb()
        return r
    except (OSError, RuntimeError, http.client.HTTPException, ValueError) as e:
        # A server that died or failed a request ends this row, not the run: the row says what happened and where.
        code = server.proc.poll()
        r["failed"] = f"{type(e).__name__}: {e}"[:200] + ("" if code is None else f"; server exited with {code}")
        if server.killed_at_mb is not None:
            r["failed"] = f"stopped: memory ({server.killed_at_mb:.0f} MB RSS)"
        r["failed_at_seq"] = locals().get("seq")
        log.flush()
        r["log_tail"] = open(log.name, errors="replace").read()[-2000:]
        print(f"long_mission: {variant} N={n} {name}: {r['failed']} (seq {r['failed_at_seq']})\n{r['log_tail']}",
              file=sys.stderr, flush=True)
        return r
    finally:
        server.stop()
        log.close()
        if not a.keep_data:
            shutil.rmtree(data, ignore_errors=True)


# ---- report ----------------------------------------------------------------------------------------------------

def cell(v, f="%.0f"):
    return "-" if v is None else f % v


COLUMNS = ["N", "binary", "posted MB", "POST p50/p95 ms", "tile lag s", "settled s", "ingest CPU s", "RSS ingest MB (peak)", "RSS views MB (peak)",
           "robot p50 ms", "overview p50 ms", "robot/overview dB vs full, robot/own GLB dB vs frame",
           "8 clients views/s (p99 ms)", "tileset p50/p95 ms", "late join MB (tileset.json on the wire / JSON MB; tiles)",
           "tiles/posted", "data/posted", "model.glb?max-error=0 MB (s)", "RSS end MB (peak)"]


def fidelity_cell(f):
    if not f:
        return "-"
    return "/".join("%.1f" % f[k] for k in ("robot_db", "overview_db", "robot_vs_frame_db", "own_glb_vs_frame_db"))


def row(r):
    if "failed" in r:
        return [str(r["n"]), r["binary"], f"failed at seq {r['failed_at_seq']}: {r['failed']}"] + [""] * (len(COLUMNS) - 3)
    if "skipped" in r:
        return [str(r["n"]), r["binary"], "skipped: " + r["skipped"]] + [""] * (len(COLUMNS) - 3)
    mb = 1e6
    t, live, lj, m = r["throughput"], r["live"], r["late_join"], r["model"]
    live_cell = f"{cell(live['p50_ms'])}/{cell(live['p95_ms'])}"
    if live["seen"] < live["keyframes"]:
        live_cell += f" ({live['keyframes'] - live['seen']} unseen)"
    return [str(r["n"]), r["binary"], "%.1f" % (r["posted_bytes"] / mb),
            f"{cell(r['post_p50_ms'], '%.1f')}/{cell(r['post_p95_ms'], '%.1f')}", cell(r["tile_lag_s"], "%.1f"),
            cell(r.get("settled_s"), "%.1f"),
            cell(r.get("ingest_cpu_s"), "%.1f"), f"{r['rss_ingest_mb']:.0f} ({r['hwm_ingest_mb']:.0f})", f"{r['rss_views_mb']:.0f} ({r['hwm_views_mb']:.0f})",
            cell(r["robot_p50_ms"], "%.1f"), cell(r["overview_p50_ms"], "%.1f"), fidelity_cell(r.get("fidelity")),
            f"{t['views_per_s']:.1f} ({cell(t['p99_ms'])})" + (f" {t['failures']} failed" if t["failures"] else ""),
            live_cell, ("%.2f (%.2f / %.2f; %d)" % (lj["bytes"] / mb, lj["tileset_wire_bytes"] / mb, lj["tileset_bytes"] / mb,
                                        lj["tiles"])) if "bytes" in lj else lj.get("error", "-"),
            "%.2f" % (r["tiles_bytes"] / r["posted_bytes"]), "%.2f" % (r["data_bytes"] / r["posted_bytes"]),
            "%.1f (%.1f)" % (m["bytes"] / mb, m["s"]) if m["status"] == 200 else f"HTTP {m['status']}",
            f"{r['rss_end_mb']:.0f} ({r['hwm_end_mb']:.0f})"]


def print_table(variant, results):
    print(f"\n{variant}:")
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    for r in results:
        print("| " + " | ".join(row(r)) + " |")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("sizes", nargs="+", type=int, help="mission lengths N in keyframes")
    p.add_argument("--variants", default="exploration,revisit")
    p.add_argument("--bin", action="append", default=[], help="NAME=PATH of an rgbdcast binary, run in this order")
    p.add_argument("--mb-per-keyframe", action="append", default=[],
                   help="NAME=MB: RSS a keyframe costs that binary, for skipping sizes that would pass --max-rss-gb")
    p.add_argument("--max-rss-gb", type=float, default=16.0)
    p.add_argument("--view-extra", default="", help="query parameters added to every view, e.g. 'max-error=1'")
    p.add_argument("--views", type=int, default=20, help="robot views and overviews each, sequential")
    p.add_argument("--no-fidelity", dest="fidelity", action="store_false",
                   help="skip the PSNR of default views against max-error=0 and of the robot view against its GLB")
    p.add_argument("--clients", type=int, default=8)
    p.add_argument("--throughput-s", type=float, default=10.0)
    p.add_argument("--live", type=int, default=20, help="keyframes posted at --live-rate after the bulk")
    p.add_argument("--live-rate", type=float, default=2.0)
    p.add_argument("--live-timeout-s", type=float, default=60.0)
    p.add_argument("--lag-timeout-s", type=float, default=1800.0, help="longest wait for the tile worker")
    p.add_argument("--model-timeout-s", type=float, default=600.0)
    p.add_argument("--data", default=os.environ.get("RGBDCAST_DATA", os.path.join(ROOT, "..", "shared", "data")))
    p.add_argument("--json", help="write every figure here")
    p.add_argument("--keep-data", action="store_true", help="keep each server's data dir")
    a = p.parse_args()
    bins = [tuple(s.split("=", 1)) for s in a.bin]
    if not bins:
        bins.append(("new", os.environ.get("RGBDCAST_BIN", os.path.join(ROOT, "build", "app", "rgbdcast"))))
        if os.environ.get("RGBDCAST_BASELINE_BIN"):
            bins.append(("baseline", os.environ["RGBDCAST_BASELINE_BIN"]))
    a.mb_per_keyframe = dict((k, float(v)) for k, v in (s.split("=", 1) for s in a.mb_per_keyframe))
    if any(name == "baseline" for name, _ in bins):
        a.mb_per_keyframe.setdefault("baseline", 3.8)
    excerpt = os.path.join(a.data, "tum", "rgbd_dataset_freiburg1_xyz_200_319")
    work = tempfile.mkdtemp(prefix="rgbdcast-long-mission.")
    try:
        workload = Workload(bins[0][1], binary_env(bins[0][1]), excerpt, work)
        print(f"long_mission: 12 keyframes of {sum(map(len, workload.bodies)) / 1e3:.0f} kB in all, reduced by "
              f"{bins[0][0]}; {os.cpu_count()} cores; views {a.views} each, {a.clients} clients for "
              f"{a.throughput_s:.0f} s, {a.live} live keyframes at {a.live_rate}/s"
              + (f"; views with {a.view_extra}" if a.view_extra else ""), flush=True)
        results = []
        for variant in a.variants.split(","):
            rows = []
            for n in a.sizes:
                for name, binary in bins:
                    t0 = time.monotonic()
                    r = run_one(name, binary, n, variant, workload, a, work)
                    r["wall_s"] = time.monotonic() - t0
                    r["views_each"] = a.views
                    print(f"long_mission: {variant} N={n} {name}: {r['wall_s']:.0f} s", file=sys.stderr, flush=True)
                    rows.append(r)
                    results.append(r)
                    if a.json:
                        json.dump(results, open(a.json, "w"), indent=1)
            print_table(variant, rows)
    finally:
        if a.keep_data:
            print(f"long_mission: data kept in {work}", file=sys.stderr, flush=True)
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
