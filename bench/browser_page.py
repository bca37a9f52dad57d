#!/usr/bin/python3
"""The operator page in headless Chromium (Debian's, SwiftShader WebGL, 2 cores): late join, orbit frame time, and the
server's CPU per operator-minute with local against server rendering, in the same run.

The mission: N keyframes of bench/long_mission.py's exploration workload (12 TUM fr1/xyz frames reduced once, posted
in laps moved 4 m apart) posted to a fresh `rgbdcast serve` on loopback; the benchmark waits until the tile worker's
committed tileset holds all N. Then, each in a fresh Chromium profile (a cold cache) in a WIDTHxHEIGHT window (headless
Chromium's view is smaller: 1280x577 in a 1280x720 window):
  1. late join, local: /?mission=NAME; time from navigation to the first frame that drew a tile (the page's
     firstTilesMs), and until the page has the current tileset version on screen with nothing queued, downloading or
     parsing ("drawn"); the bytes downloaded by then (resource timing: all, the npm modules, tileset + tiles) and the
     view requests;
  2. orbit, local: FRAMES frames, each turning the camera 2 degrees around its target, updating the tiles and drawing,
     then reading one pixel back so that the frame's rasterisation (SwiftShader, in Chromium's GPU process) is in
     its time: p50/p95 ms, draw calls and triangles of the last frame;
  3. an operator orbiting for OPERATOR_S s (DevTools mouse drags, 20 moves a second across the view), once with the
     local page and once with /?mission=NAME&render=server: the server's CPU seconds (utime + stime of its process)
     over that time, per minute, and the view requests it served.
Prints one table; --json writes every figure; --screenshot writes the page as drawn at the first N (the README's
picture: `--screenshot docs/operator-page.png 12`).

    bench/browser_page.py [--bin PATH] [--json OUT] [--screenshot PNG] N [N ...]
"""
import argparse
import base64
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import long_mission as lm  # noqa: E402
from cdp import Cdp  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cpu_s(pid):
    """utime + stime of a process, in seconds."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Chromium:
    """Headless Chromium with a fresh profile and DevTools on a free loopback port; stopped by pid."""

    def __init__(self, work, tag, url, width, height, webgl=True):
        self.profile = tempfile.mkdtemp(prefix=f"chromium-{tag}.", dir=work)
        port = lm.free_port()
        flags = ["--enable-unsafe-swiftshader", "--use-angle=swiftshader"] if webgl else ["--disable-webgl"]
        args = ["chromium", "--headless", "--no-sandbox", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--disable-gpu", "--hide-scrollbars",
                f"--user-data-dir={self.profile}", f"--window-size={width},{height}",
                f"--remote-debugging-port={port}"] + flags + [url]
        self.log = open(os.path.join(work, f"chromium-{tag}.log"), "w")
        env = dict(os.environ, TMPDIR=self.profile)
        self.proc = subprocess.Popen(args, stdout=self.log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        self.cdp = Cdp(port)

    def wait(self, expression, timeout_s, poll_s=0.05):
        """Polls `expression` until it is truthy; returns its value and the seconds waited (None on timeout)."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout_s:
            try:
                v = self.cdp.eval(expression)
            except RuntimeError:
                v = None
            if v:
                return v, time.monotonic() - t0
            time.sleep(poll_s)
        return None, None

    def drag(self, seconds, width, height, rate=20):
        """Mouse drags across the view's middle, left to right and back, `rate` moves a second."""
        x0, y = width * 0.25, height * 0.45
        span = width * 0.3
        self.cdp.call("Input.dispatchMouseEvent", type="mousePressed", x=x0, y=y, button="left", clickCount=1)
        t0 = time.monotonic()
        i = 0
        while time.monotonic() - t0 < seconds:
            i += 1
            phase = (i % 40) / 20.0
            x = x0 + span * (phase if phase <= 1 else 2 - phase)
            self.cdp.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y, button="left", buttons=1)
            time.sleep(max(0.0, t0 + i / rate - time.monotonic()))
        self.cdp.call("Input.dispatchMouseEvent", type="mouseReleased", x=x0, y=y, button="left", clickCount=1)
        return i

    def stop(self):
        os.killpg(self.proc.pid, signal.SIGTERM)
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
        self.log.close()


SETTLED = """(() => { const p = window.rgbdcastPage; if (!p || !p.local || !p.fitted) return null;
  const L = p.local, s = L.stats();
  if (L.nextTiles || s.loading > 0 || s.version !== p.live.tilesetVersion || s.visible === 0) return null;
  return { at: performance.now(), stats: s, bytes: p.net.bytes, tileBytes: p.net.tileBytes,
           tileRequests: p.net.tileRequests, viewRequests: p.net.viewRequests,
           moduleBytes: performance.getEntriesByType("resource").filter((e) => e.name.includes("/web/modules/"))
                          .reduce((a, e) => a + e.transferSize, 0),
           tilesetBytes: performance.getEntriesByType("resource").filter((e) => e.name.includes("/tileset.json"))
                          .reduce((a, e) => a + e.transferSize, 0) }; })()"""

ORBIT = """(async () => { const L = window.rgbdcastPage.local, gl = L.renderer.getContext(), c = L.controls;
  const px = new Uint8Array(4), ms = [];
  for (let i = 0; i < %d; i += 1) {
    await new Promise((r) => requestAnimationFrame(r));
    const t0 = performance.now();
    const off = L.camera.position.clone().sub(c.target).applyAxisAngle(L.camera.up, Math.PI / 90);
    L.camera.position.copy(c.target).add(off);
    L.camera.lookAt(c.target);
    L.dirty = true;
    L.frame();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    ms.push(performance.now() - t0);
  }
  const info = L.renderer.info.render;
  return { ms, calls: info.calls, triangles: info.triangles, resident: L.stats().resident }; })()"""


def late_join(server, a, work, n):
    url = f"http://127.0.0.1:{server.port}/?mission={lm.MISSION}"
    ch = Chromium(work, f"local-{n}", url, a.width, a.height)
    r = {}
    try:
        settled, waited = ch.wait(SETTLED, a.timeout_s)
        if not settled:
            r["error"] = "not drawn within %.0f s" % a.timeout_s
            return r
        r.update(drawn_ms=settled["at"], first_tiles_ms=settled["stats"]["firstTilesMs"], bytes=settled["bytes"],
                 module_bytes=settled["moduleBytes"], tile_bytes=settled["tileBytes"],
                 tileset_bytes=settled["tilesetBytes"], tile_requests=settled["tileRequests"],
                 view_requests=settled["viewRequests"], resident=settled["stats"]["resident"],
                 visible=settled["stats"]["visible"], version=settled["stats"]["version"])
        if a.screenshot:  # the page as drawn, once (the first N)
            time.sleep(1.0)  # the status line refreshes every 500 ms
            shot = ch.cdp.call("Page.captureScreenshot", format="png")
            with open(a.screenshot, "wb") as f:
                f.write(base64.b64decode(shot["data"]))
            a.screenshot = None
        o = ch.cdp.eval(ORBIT % a.frames)
        r.update(orbit_p50_ms=lm.pct(o["ms"], 50), orbit_p95_ms=lm.pct(o["ms"], 95), calls=o["calls"],
                 triangles=o["triangles"], resident_after_orbit=o["resident"])
        c0 = cpu_s(server.proc.pid)
        moves = ch.drag(a.operator_s, a.width, a.height)
        c1 = cpu_s(server.proc.pid)
        r["local_cpu_s_per_min"] = (c1 - c0) * 60.0 / a.operator_s
        r["local_moves"] = moves
        r["local_views_while_orbiting"] = ch.cdp.eval("window.rgbdcastPage.net.viewRequests") - r["view_requests"]
    finally:
        ch.stop()
    return r


def server_rendering(server, a, work, n):
    url = f"http://127.0.0.1:{server.port}/?mission={lm.MISSION}&render=server"
    ch = Chromium(work, f"server-{n}", url, a.width, a.height, webgl=False)
    r = {}
    try:
        first, _ = ch.wait("(() => { const p = window.rgbdcastPage; return p && p.server && p.server.s.views > 0 && "
                           "document.getElementById('stream').textContent === 'live'; })()", a.timeout_s)
        if not first:
            r["error"] = "no server view within %.0f s" % a.timeout_s
            return r
        time.sleep(1.0)
        v0 = ch.cdp.eval("window.rgbdcastPage.server.s.views")
        c0 = cpu_s(server.proc.pid)
        r["server_moves"] = ch.drag(a.operator_s, a.width, a.height)
        ch.wait("(() => !window.rgbdcastPage.server.s.inFlight)()", 30)
        c1 = cpu_s(server.proc.pid)
        r["server_cpu_s_per_min"] = (c1 - c0) * 60.0 / a.operator_s
        r["server_views"] = ch.cdp.eval("window.rgbdcastPage.server.s.views") - v0
        r["server_view_size"] = ch.cdp.eval("[window.rgbdcastPage.server.w, window.rgbdcastPage.server.h]")
    finally:
        ch.stop()
    return r


def run_one(binary, n, workload, a, work):
    r = {"n": n}
    data = tempfile.mkdtemp(prefix=f"data-{n}.", dir=work)
    log = open(os.path.join(work, f"serve-{n}.log"), "w")
    server = lm.Server(binary, data, log, 1024 * a.max_rss_gb)
    try:
        poster = lm.Poster(server, workload, "exploration")
        for seq in range(n):
            poster.post(seq)
        r["posted_bytes"] = poster.posted_bytes
        lag = lm.wait_tiles(server, n, a.lag_timeout_s)
        if lag is None:
            r["error"] = "the tileset did not hold all keyframes within %.0f s" % a.lag_timeout_s
            return r
        r["tile_lag_s"] = lag
        time.sleep(1.0)  # the committed version's event and tileset.json
        r.update(late_join(server, a, work, n))
        r.update(server_rendering(server, a, work, n))
    finally:
        server.stop()
        log.close()
        if not a.keep_data:
            shutil.rmtree(data, ignore_errors=True)
    return r


def fmt(v, f="%.0f"):
    return "-" if v is None else f % v


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sizes", nargs="+", type=int, help="mission lengths N in keyframes")
    p.add_argument("--bin", default=os.environ.get("RGBDCAST_BIN", os.path.join(ROOT, "build", "app", "rgbdcast")))
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=720)
    p.add_argument("--frames", type=int, default=90, help="orbit frames")
    p.add_argument("--operator-s", type=float, default=20.0, help="seconds of orbiting per rendering mode")
    p.add_argument("--timeout-s", type=float, default=120.0)
    p.add_argument("--lag-timeout-s", type=float, default=900.0)
    p.add_argument("--max-rss-gb", type=float, default=16.0)
    p.add_argument("--data", default=os.environ.get("RGBDCAST_DATA", os.path.join(ROOT, "..", "shared", "data")))
    p.add_argument("--json", help="write every figure here")
    p.add_argument("--keep-data", action="store_true")
    p.add_argument("--screenshot", help="write a PNG of the local page once the first mission is drawn")
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="browser-page-bench.")
    excerpt = os.path.join(a.data, "tum", "rgbd_dataset_freiburg1_xyz_200_319")
    workload = lm.Workload(a.bin, lm.binary_env(a.bin), excerpt, work)
    results = []
    for n in a.sizes:
        results.append(run_one(a.bin, n, workload, a, work))
        print(json.dumps(results[-1]), file=sys.stderr)
    print("| N | first tile frame ms | drawn ms | bytes to drawn kB (modules / tileset + tiles) | tiles fetched | "
          "views asked | orbit frame p50/p95 ms | draw calls | triangles | server CPU s per operator-minute, "
          "local / server views (views served) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        if "error" in r and "drawn_ms" not in r:
            print(f"| {r['n']} | {r['error']} |")
            continue
        print("| %d | %s | %s | %s (%s / %s) | %s | %s | %s/%s | %s | %s | %s / %s (%s) |" % (
            r["n"], fmt(r.get("first_tiles_ms")), fmt(r.get("drawn_ms")), fmt(r.get("bytes", 0) / 1024),
            fmt(r.get("module_bytes", 0) / 1024), fmt((r.get("tileset_bytes", 0) + r.get("tile_bytes", 0)) / 1024),
            r.get("tile_requests"), r.get("view_requests"), fmt(r.get("orbit_p50_ms"), "%.1f"),
            fmt(r.get("orbit_p95_ms"), "%.1f"), r.get("calls"), r.get("triangles"),
            fmt(r.get("local_cpu_s_per_min"), "%.2f"), fmt(r.get("server_cpu_s_per_min"), "%.2f"),
            r.get("server_views")))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
