// Server-rendered views: the fallback where WebGL or the npm modules are missing, or with ?render=server. Every view
// is an image the server renders (GET .../view) at the view area's size, capped by the service's 4096 px per side;
// dragging orbits, one request is in flight at a time and a drag during it asks for the latest pose once it returns.
// In mission mode the robot's trajectory and newest camera are drawn over the image on a 2D canvas.
import { quatToMat, captureOrder } from "./three_frames.js";

const kMaxViewSize = 4096;
const sub = (a, b) => a.map((v, i) => v - b[i]);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => { const n = Math.hypot(a[0], a[1], a[2]); return a.map((v) => v / n); };
const fmt = (v) => v.map((x) => x.toFixed(4)).join(",");

export class ServerView {
  // stage: the element the view fills; live: the mission's state (app.js) or null for a scene.
  constructor(stage, live, onError) {
    this.stage = stage;
    this.live = live;
    this.onError = onError;
    this.img = document.createElement("img");
    this.img.id = "view";
    this.img.alt = "rendered view";
    this.img.draggable = false;
    this.overlay = document.createElement("canvas");
    this.overlay.id = "overlay";
    stage.append(this.img, this.overlay);
    this.s = { scene: null, mode: "mesh", yaw: 0, pitch: 0, radius: 1.5, target: [0, 0, 1.5], fov: 50,
               capture: true, robotSeq: null, inFlight: false, pending: false, lastUrl: "", views: 0 };
    this.w = 640; this.h = 480;
    this.measure();
    let drag = null;
    stage.addEventListener("pointerdown", (e) => { drag = { x: e.clientX, y: e.clientY }; stage.classList.add("dragging"); });
    window.addEventListener("pointermove", (e) => {
      if (!drag || !this.s.scene) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag = { x: e.clientX, y: e.clientY };
      this.s.capture = false;
      this.s.robotSeq = null;
      if (this.onDrag) this.onDrag();
      this.s.yaw += dx * 0.4 * Math.PI / 180;
      this.s.pitch = Math.max(-1.4, Math.min(1.4, this.s.pitch + dy * 0.4 * Math.PI / 180));
      this.refresh();
    });
    window.addEventListener("pointerup", () => { drag = null; stage.classList.remove("dragging"); });
    let timer = null;
    new ResizeObserver(() => {
      clearTimeout(timer);
      timer = setTimeout(() => { if (this.measure()) this.refresh(); }, 150);
    }).observe(stage);
  }

  // The view's pixel size: the stage's CSS size, each side in 16..4096. True when it changed.
  measure() {
    const w = Math.max(16, Math.min(kMaxViewSize, Math.round(this.stage.clientWidth || 640)));
    const h = Math.max(16, Math.min(kMaxViewSize, Math.round(this.stage.clientHeight || 480)));
    if (w === this.w && h === this.h) return false;
    this.w = w; this.h = h;
    this.overlay.width = w; this.overlay.height = h;
    return true;
  }

  // World frame: the capture camera's (x right, y down, z forward); the orbit keeps world up = -y.
  eye() {
    const s = this.s, cp = Math.cos(s.pitch), sp = Math.sin(s.pitch), cy = Math.cos(s.yaw), sy = Math.sin(s.yaw);
    return [s.target[0] + s.radius * sy * cp, s.target[1] - s.radius * sp, s.target[2] - s.radius * cy * cp];
  }

  viewUrl() {
    const s = this.s;
    const base = s.scene.viewBase + "/view?width=" + this.w + "&height=" + this.h + "&format=jpeg&quality=85&mode=" + s.mode;
    if (s.robotSeq !== null) return base + "&pose=keyframe:" + s.robotSeq;
    if (s.capture) return base + "&pose=capture";
    return base + "&eye=" + fmt(this.eye()) + "&target=" + fmt(s.target) + "&up=0,-1,0&fov=" + s.fov;
  }

  async refresh() {
    const s = this.s;
    if (!s.scene) return;
    if (s.inFlight) { s.pending = true; return; }
    s.inFlight = true;
    const url = this.viewUrl();
    try {
      const res = await fetch(url);
      if (!res.ok) {
        const err = await res.json().catch(() => ({ error: res.status, detail: "" }));
        this.onError("view failed: " + res.status + " " + err.error + ": " + err.detail);
      } else {
        const blob = await res.blob();
        const old = this.img.src;
        await new Promise((resolve) => { this.img.onload = resolve; this.img.onerror = resolve; this.img.src = URL.createObjectURL(blob); });
        if (old.startsWith("blob:")) URL.revokeObjectURL(old);
        document.getElementById("render-ms").textContent = res.headers.get("X-Render-Ms") || "?";
        document.getElementById("backend").textContent = res.headers.get("X-Backend") || "?";
        s.lastUrl = url;
        s.views += 1;
        this.drawOverlay();
        document.body.dataset.views = String(s.views);
        document.body.dataset.lastView = url;
      }
    } catch (e) {
      this.onError("view failed: " + e);
    }
    s.inFlight = false;
    if (s.pending) { s.pending = false; this.refresh(); }
  }

  async idle() { while (this.s.inFlight || this.s.pending) await new Promise((r) => setTimeout(r, 20)); }

  // A scene: orbit around the centre of its bounds, starting from the capture camera (at the world origin).
  showScene(scene) {
    const s = this.s;
    s.scene = { id: scene.id, viewBase: "/v1/scenes/" + scene.id };
    s.robotSeq = null;
    const b = scene.bounds;
    s.target = b ? [0, 1, 2].map((i) => 0.5 * (b.min[i] + b.max[i])) : [0, 0, 1.5];
    const t = s.target;
    s.radius = Math.max(0.2, Math.hypot(t[0], t[1], t[2]));
    s.yaw = Math.atan2(-t[0], t[2]);
    s.pitch = Math.asin(Math.max(-1, Math.min(1, t[1] / s.radius)));
    s.capture = true;
    return this.refresh();
  }

  showMission(name) {
    this.s.scene = { id: name, viewBase: "/v1/missions/" + encodeURIComponent(name) };
    this.s.capture = false;
  }

  setMode(mode) { this.s.mode = mode; this.refresh(); }

  // Orbit around a point 1.5 m ahead of the first keyframe's camera, from behind and above it.
  orbitFromFirst() {
    const live = this.live, s = this.s;
    const first = captureOrder(live.entries)[0];
    if (first === undefined) return;
    const p = live.entries.get(first).pose;
    const r = quatToMat(p.slice(3, 7));
    s.target = [0, 1, 2].map((i) => p[i] + 1.5 * r[i][2]);
    s.radius = 2.7; s.pitch = 0.2; s.fov = 70;
    s.yaw = Math.atan2(r[0][2], r[2][2]);
    s.robotSeq = null; s.capture = false;
  }

  follow(on) { if (on) { this.s.robotSeq = null; this.s.capture = true; this.refresh(); } }
  robotView(seq) { this.s.robotSeq = seq; this.refresh(); }

  // The camera of the current view as the server builds it: rows of world-to-camera rotation, eye, focal length.
  viewCamera() {
    const s = this.s, live = this.live;
    if (s.robotSeq !== null || s.capture) {
      const e = live.entries.get(s.robotSeq !== null ? s.robotSeq : live.newest);
      if (!e) return null;
      const p = e.pose, r = quatToMat(p.slice(3, 7));
      const cols = [0, 1, 2].map((c) => [r[0][c], r[1][c], r[2][c]]);
      // The keyframe's own intrinsics, scaled to the view as the server scales them (ViewCamera::from_capture).
      const k = e.intrinsics;
      if (!k || !(k.width > 0 && k.height > 0)) return null;
      const sx = this.w / k.width, sy = this.h / k.height;
      return { axes: cols, eye: p.slice(0, 3), fx: k.fx * sx, fy: k.fy * sy,
               cx: (k.cx + 0.5) * sx - 0.5, cy: (k.cy + 0.5) * sy - 0.5 };
    }
    const eye = this.eye();
    const z = norm(sub(s.target, eye));
    const x = norm(cross(z, [0, -1, 0]));
    const y = cross(z, x);
    const f = (this.h / 2) / Math.tan(s.fov * Math.PI / 360);
    return { axes: [x, y, z], eye, fx: f, fy: f, cx: (this.w - 1) / 2, cy: (this.h - 1) / 2 };
  }

  // The robot's path (keyframe positions in capture order) and its newest camera as a small frustum.
  drawOverlay() {
    const ctx = this.overlay.getContext("2d"), live = this.live;
    ctx.clearRect(0, 0, this.w, this.h);
    if (!live || live.entries.size === 0) return;
    const cam = this.viewCamera();
    if (!cam) return;
    const project = (p) => {
      const d = sub(p, cam.eye);
      const c = cam.axes.map((a) => dot(a, d));
      return c[2] < 0.05 ? null : [cam.fx * c[0] / c[2] + cam.cx, cam.fy * c[1] / c[2] + cam.cy];
    };
    const points = captureOrder(live.entries).map((seq) => project(live.entries.get(seq).pose.slice(0, 3)));
    ctx.strokeStyle = "#ffcc33"; ctx.lineWidth = 2; ctx.beginPath();
    let started = false;
    for (const q of points) {
      if (!q) { started = false; continue; }
      if (started) ctx.lineTo(q[0], q[1]); else ctx.moveTo(q[0], q[1]);
      started = true;
    }
    ctx.stroke();
    ctx.fillStyle = "#ffcc33";
    for (const q of points) if (q) ctx.fillRect(q[0] - 2, q[1] - 2, 4, 4);
    const e = live.entries.get(live.newest);
    if (e && this.s.robotSeq === null && !this.s.capture) {
      const p = e.pose, r = quatToMat(p.slice(3, 7));
      const at = (x, y, z) => [0, 1, 2].map((i) => p[i] + r[i][0] * x + r[i][1] * y + r[i][2] * z);
      const apex = project(p.slice(0, 3));
      const corners = [[-0.12, -0.09, 0.2], [0.12, -0.09, 0.2], [0.12, 0.09, 0.2], [-0.12, 0.09, 0.2]]
        .map((c) => project(at(...c)));
      if (apex && corners.every((c) => c)) {
        ctx.strokeStyle = "#ff5533"; ctx.beginPath();
        for (const c of corners) { ctx.moveTo(apex[0], apex[1]); ctx.lineTo(c[0], c[1]); }
        ctx.moveTo(corners[3][0], corners[3][1]);
        for (const c of corners) ctx.lineTo(c[0], c[1]);
        ctx.stroke();
      }
    }
  }

  // Pixels of the image brighter than 8/255 in some channel, and pixels of the overlay drawn at all (the tests).
  drawnPixels() { return countPixels(this.img, this.w, this.h, (r, g, b) => Math.max(r, g, b) > 8); }
  overlayPixels() { return countPixels(this.overlay, this.w, this.h, (r, g, b, a) => a > 0); }
}

function countPixels(source, w, h, test) {
  const c = document.createElement("canvas");
  c.width = w; c.height = h;
  const ctx = c.getContext("2d");
  ctx.drawImage(source, 0, 0, w, h);
  const d = ctx.getImageData(0, 0, w, h).data;
  let n = 0;
  for (let i = 0; i < d.length; i += 4) if (test(d[i], d[i + 1], d[i + 2], d[i + 3])) n += 1;
  return n;
}
