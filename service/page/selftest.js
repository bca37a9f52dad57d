// What the browser tests ask the page to do and report (tests/service/test_operator_page.cpp, test_mission_page.cpp,
// test_browser_page.cpp). Loaded only with ?selftest=...
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const $ = (id) => document.getElementById(id);

// Scene, local rendering: once the GLB is drawn, its drawn pixels and the page's requests go to `report`.
async function localScene(page, net, report) {
  const local = page.local;
  const frames = local.frames;
  local.dirty = true;  // one more frame: the fitted view is on screen
  while (local.frames === frames) await sleep(50);
  const d = local.drawnPixels();
  await post(report, { mode: page.mode, note: page.note, drawn: d.drawn, width: d.width, height: d.height,
                       stats: local.stats(), network: networkReport(net) });
}

// Scene, server views: a scripted drag through the same handlers a mouse uses (75 px right: 30 degrees of orbit).
export async function sceneSelftest(page, net, report) {
  if (page.local) return report ? localScene(page, net, report) : undefined;
  await page.server.idle();
  const stage = $("stage"), r = stage.getBoundingClientRect();
  const x0 = r.left + 320, y0 = r.top + 240;
  stage.dispatchEvent(new PointerEvent("pointerdown", { clientX: x0, clientY: y0, bubbles: true }));
  window.dispatchEvent(new PointerEvent("pointermove", { clientX: x0 + 75, clientY: y0, bubbles: true }));
  window.dispatchEvent(new PointerEvent("pointerup", { clientX: x0 + 75, clientY: y0, bubbles: true }));
  await page.server.idle();
  document.body.dataset.selftest = page.server.s.lastUrl.includes("eye=") ? "done" : "failed";
}

function networkReport(net) {
  return { bytes: net.bytes, tileBytes: net.tileBytes, tileRequests: net.tileRequests, viewRequests: net.viewRequests,
           origins: [...net.origins], urls: net.urls.slice(0, 400) };
}

async function post(report, result) {
  document.body.dataset.selftest = "done";
  await fetch(report, { method: "POST", mode: "no-cors", body: JSON.stringify(result) });
}

// Mission, server views: after each of `want` keyframes, the drawn pixels of the view and of the overlay (and a POST
// to /shown-N beside `report`, N the keyframes shown); then the robot-view and follow buttons.
async function serverMission(page, net, want, report) {
  const live = page.live, v = page.server, seen = [], pixels = [], overlay = [];
  await new Promise((resolve) => {
    page.onKeyframeShown = async (k) => {
      await v.idle();
      seen.push(k.seq);
      pixels.push(v.drawnPixels());
      overlay.push(v.overlayPixels());
      // The test may post the next keyframe once the page has shown this many.
      await fetch(new URL("/shown-" + seen.length, report), { method: "POST", mode: "no-cors", body: String(k.seq) });
      if (seen.length >= want) resolve();
    };
  });
  $("robot-view").click();
  await sleep(50);
  await v.idle();
  const robotUrl = v.s.lastUrl;
  const rc = v.viewCamera();
  const robotCamera = rc ? { fx: rc.fx, fy: rc.fy, cx: rc.cx, cy: rc.cy, width: v.w, height: v.h } : null;
  $("follow").click();
  await sleep(50);
  await v.idle();
  await post(report, { mode: page.mode, note: page.note, seen, pixels, received: live.received,
                       distinct: live.entries.size, reconnects: live.reconnects, robotUrl, followUrl: v.s.lastUrl,
                       newest: live.newest, overlayPixels: overlay, robotCamera, syncs: live.syncs,
                       network: networkReport(net) });
}

// Waits until the local view has nothing to load for a few checks running.
async function settled(local, ms = 60000) {
  const t0 = performance.now();
  let idle = 0;
  while (idle < 5 && performance.now() - t0 < ms) {
    const s = local.stats();
    idle = !local.nextTiles && local.tiles && local.tiles.rootTileset && s.loading === 0 ? idle + 1 : 0;
    await sleep(50);
  }
}

// Mission, local rendering: a sample of the drawn pixels each time a tileset version is on screen (also POSTed to
// /drawn-K beside `report`, K its keyframes), until the view shows a version holding `want` keyframes; then the view
// area is resized and drawn again.
async function localMission(page, net, want, report) {
  const live = page.live, local = page.local, samples = [];
  const t0 = performance.now();
  let firstDrawnMs = null;
  const sample = async () => {
    await settled(local);
    const version = local.stats().version;
    const d = local.drawnPixels();
    if (firstDrawnMs === null && d.drawn > 0) firstDrawnMs = performance.now() - t0;
    const keyframes = live.tilesetKeyframes.get(version) ?? null;
    samples.push({ version, keyframes, drawn: d.drawn,
                   width: d.width, height: d.height, tileBytes: net.tileBytes, tileRequests: net.tileRequests });
    // The test posts the next keyframe once the page has drawn this many.
    if (keyframes !== null)
      await fetch(new URL("/drawn-" + keyframes, report), { method: "POST", mode: "no-cors", body: String(d.drawn) });
  };
  let last = null;
  while (performance.now() - t0 < 120000) {
    const v = local.stats().version;
    if (v !== null && v !== last && page.fitted && live.tilesetKeyframes.has(v)) { await sample(); last = v; }
    const k = live.tilesetKeyframes.get(last);
    if (live.entries.size >= want && k !== undefined && k >= want) break;
    await sleep(100);
  }
  const before = local.drawnPixels();
  // Resize the view area (the stage follows its CSS size; a window resize does the same through the layout).
  $("stage").style.right = "auto";
  $("stage").style.width = Math.round(before.width * 0.6) + "px";
  $("stage").style.height = Math.round(before.height * 0.7) + "px";
  await sleep(300);
  local.dirty = true;
  await settled(local);
  const after = local.drawnPixels();
  await post(report, { mode: page.mode, note: page.note, samples, firstDrawnMs, resized: { before, after },
                       stats: local.stats(), received: live.received, distinct: live.entries.size,
                       reconnects: live.reconnects, syncs: live.syncs, network: networkReport(net) });
}

export function missionSelftest(page, net, want, report) {
  const run = page.local ? localMission : serverMission;
  run(page, net, want, report).catch((e) => {
    document.body.dataset.selftest = "error";
    fetch(report, { method: "POST", mode: "no-cors", body: JSON.stringify({ error: String(e && e.stack || e) }) });
  });
}
