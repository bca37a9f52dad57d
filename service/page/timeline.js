// The mission's timeline, drawn by hand on a canvas: one bar per keyframe at its capture time (x), its height the
// keyframe's kB (left scale); a line of the capture-to-available latency in seconds (right scale) where the service
// reports when the keyframe became viewable. `entries` are the mission's keyframe entries (GET /v1/missions/{name}).
export function drawTimeline(canvas, entries) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const list = [...entries.values()].filter((e) => e.captured > 0).sort((a, b) => a.captured - b.captured);
  ctx.font = "10px monospace";
  ctx.fillStyle = "#aab6cc";
  if (list.length === 0) { ctx.fillText("timeline: no keyframes yet", 4, 12); return; }
  const t0 = list[0].captured, t1 = Math.max(list[list.length - 1].captured, t0 + 1);
  const kb = list.map((e) => (e.bytes || 0) / 1024);
  const lat = list.map((e) => (e.available > 0 ? Math.max(0, e.available - e.captured) : null));
  const kbMax = Math.max(1, ...kb), latMax = Math.max(0.1, ...lat.filter((v) => v !== null));
  const left = 4, right = w - 4, top = 14, bottom = h - 4;
  const x = (t) => left + (right - left) * (t - t0) / (t1 - t0);
  const barW = Math.max(1, Math.min(6, (right - left) / list.length - 1));
  ctx.fillStyle = "#5d8ad6";
  list.forEach((e, i) => {
    const bh = (bottom - top) * kb[i] / kbMax;
    ctx.fillRect(x(e.captured) - barW / 2, bottom - bh, barW, bh);
  });
  ctx.strokeStyle = "#ffcc33";
  ctx.beginPath();
  let started = false;
  list.forEach((e, i) => {
    if (lat[i] === null) { started = false; return; }
    const y = bottom - (bottom - top) * lat[i] / latMax;
    if (started) ctx.lineTo(x(e.captured), y); else ctx.moveTo(x(e.captured), y);
    started = true;
  });
  ctx.stroke();
  const total = kb.reduce((a, b) => a + b, 0);
  const lats = lat.filter((v) => v !== null).sort((a, b) => a - b);
  const median = lats.length ? lats[Math.floor(lats.length / 2)] : null;
  ctx.fillStyle = "#aab6cc";
  ctx.fillText(list.length + " keyframes over " + (t1 - t0).toFixed(0) + " s, " + total.toFixed(0) + " kB (bars, max " +
               kbMax.toFixed(0) + " kB)" + (median !== null ? "; capture to available: median " + median.toFixed(2) +
               " s (line, max " + latMax.toFixed(2) + " s)" : ""), 4, 10);
}
