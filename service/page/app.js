// The operator page's main module: picks the renderer, lists scenes and missions, follows a mission's event stream,
// and draws the status line and the timeline.
//   /?mission=NAME      a live mission; /?scene=ID a scene; neither: the first scene
//   &render=server      server-rendered views (also chosen when WebGL or the three.js modules are missing)
// Mission mode: the page reads the mission's keyframes (GET /v1/missions/NAME, in pages) once when it opens and again
// from the changed seq on after keyframe events, coalesced: a late-joining page whose stream replays many events reads
// them in one go. Locally it loads the current tileset once and a newer one on each `tileset` event (only changed
// tiles cross the network); it asks the server for a view only for "robot view". EventSource reconnects by itself
// with Last-Event-ID when the stream drops.
// Tests: ?selftest=1 (scene: with server views orbits once by a scripted drag and marks <body data-selftest="done">;
// locally, with &report=URL, POSTs the drawn pixels there);
// ?mission=NAME&selftest=N&report=URL waits for N keyframes, then POSTs what it saw to URL (see selftest.js).
import { drawTimeline } from "./timeline.js";
import { ServerView } from "./server_view.js";
import { captureOrder } from "./three_frames.js";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const mission = params.get("mission");
const sceneId = params.get("scene");
const live = { entries: new Map(), received: 0, opened: 0, reconnects: 0, newest: null,
               follow: false, tilesetKeyframes: new Map(), tilesetVersion: null, shown: [], syncs: 0 };
const net = { bytes: 0, tileBytes: 0, tileRequests: 0, viewRequests: 0, origins: new Set(), urls: [] };
const page = { mode: "server", note: "", local: null, server: null, fitted: false, live, net };
window.rgbdcastPage = page;  // for the tests and the benchmark

function setStatus(text) { $("status").textContent = text; }
function setNote(text) { page.note = text; $("note").textContent = text; $("note").hidden = !text; }

// Every resource the page loads, from the browser's resource timing: bytes over the network (a cached tile counts 0),
// tile and view requests, and the origins asked.
new PerformanceObserver((list) => {
  for (const e of list.getEntries()) {
    net.bytes += e.transferSize || 0;
    net.origins.add(new URL(e.name).origin);
    if (e.name.includes("/tiles/")) { net.tileBytes += e.transferSize || 0; net.tileRequests += e.transferSize > 0 ? 1 : 0; }
    if (/\/view\?/.test(e.name)) net.viewRequests += 1;
    net.urls.push(e.name);
  }
}).observe({ type: "resource", buffered: true });
performance.setResourceTimingBufferSize(100000);

function webglAvailable() {
  try {
    const c = document.createElement("canvas");
    return !!(c.getContext("webgl2") || c.getContext("webgl"));
  } catch (e) {
    return false;
  }
}

async function chooseRenderer() {
  const stage = $("stage");
  if (params.get("render") === "server") {
    setNote("");
  } else if (!webglAvailable()) {
    setNote("WebGL is not available in this browser: showing server-rendered views.");
  } else {
    try {
      const { LocalView } = await import("./local_view.js");
      page.local = new LocalView(stage);
      page.mode = "local";
    } catch (e) {
      setNote("three.js modules not served (npm ci in tools/, or serve --web-modules): showing server-rendered views.");
    }
  }
  if (!page.local) page.server = new ServerView(stage, mission ? live : null, setStatus);
  document.body.dataset.render = page.mode;
  $("render-toggle").textContent = page.mode === "local" ? "render on server" : "render in browser";
  $("render-toggle").onclick = () => {
    const p = new URLSearchParams(location.search);
    if (page.mode === "local") p.set("render", "server"); else p.delete("render");
    location.search = p.toString();
  };
  $("render-info").hidden = page.mode === "local";
}

function statusLine() {
  const kb = (b) => (b / 1024).toFixed(0) + " kB";
  let text = "downloaded " + kb(net.bytes);
  if (page.local) {
    const s = page.local.stats();
    text += " (tiles " + kb(net.tileBytes) + ", " + net.tileRequests + " fetched) | tiles resident " + s.resident +
            ", visible " + s.visible + (s.loading ? ", loading " + s.loading : "") + " | frame " + s.frameMs.toFixed(1) +
            " ms, " + s.calls + " draw calls, " + s.triangles + " triangles | " + s.size[0] + "x" + s.size[1] +
            (s.version !== null ? " | tileset v" + s.version : "");
  } else {
    text += " | " + net.viewRequests + " server views";
  }
  $("statusline").textContent = text;
}

function setDownloads(base, withDraco) {
  $("glb-compact").href = base + "/model.glb?flavor=compact";
  $("glb-compat").href = base + "/model.glb?flavor=compat";
  $("glb-draco").href = base + "/model.glb?flavor=draco";
  $("glb-draco").hidden = !withDraco;
}

// ---- Scenes ----
async function showScene(id) {
  const scene = await (await fetch("/v1/scenes/" + encodeURIComponent(id))).json();
  for (const li of document.querySelectorAll("#scenes li")) li.classList.toggle("sel", li.dataset.id === scene.id);
  setDownloads("/v1/scenes/" + scene.id, true);
  $("tileset-link").hidden = true;
  setStatus("scene " + scene.id + "\n" + (scene.triangles ?? "?") + " triangles, " + scene.bytes + " bytes");
  $("reset").onclick = () => (page.local ? page.local.fit() : page.server.showScene(scene));
  if (page.local) {
    await page.local.loadScene("/v1/scenes/" + scene.id + "/model.glb?flavor=compact");
    page.local.fit();
    return scene;
  }
  await page.server.showScene(scene);
  return scene;
}

async function loadScenes() {
  const body = await (await fetch("/v1/scenes")).json();
  const ul = $("scenes");
  ul.innerHTML = "";
  for (const s of body.scenes) {
    const li = document.createElement("li");
    li.textContent = s.id.slice(0, 12) + "  " + (s.triangles ?? "?") + " tri";
    li.dataset.id = s.id;
    li.title = s.id;
    li.onclick = () => { location.search = "?scene=" + s.id + (page.mode === "server" ? "&render=server" : ""); };
    ul.appendChild(li);
  }
  return body.scenes;
}

async function loadMissions() {
  const body = await (await fetch("/v1/missions")).json();
  const ul = $("missions");
  ul.innerHTML = "";
  for (const m of body.missions) {
    const li = document.createElement("li");
    li.textContent = m.name + "  " + m.keyframes + " kf";
    li.classList.toggle("sel", m.name === mission);
    li.onclick = () => { location.search = "?mission=" + encodeURIComponent(m.name) + (page.mode === "server" ? "&render=server" : ""); };
    ul.appendChild(li);
  }
}

// ---- Missions ----
const missionBase = () => "/v1/missions/" + encodeURIComponent(mission);

// Reads the mission's pages from seq `from` on (all of them when undefined); `changed` gets the seqs that were new
// or refined (a higher rev).
async function readMission(from, changed) {
  let after = from === undefined ? null : from - 1;
  let body = null;
  do {
    const query = after === null || after < 0 ? "" : "?after=" + after;
    const res = await fetch(missionBase() + query);
    if (!res.ok) { setStatus("mission " + mission + ": " + res.status); return null; }
    body = await res.json();
    for (const k of body.keyframes) {
      const had = live.entries.get(k.seq);
      if (!had || (had.rev || 0) < (k.rev || 0)) changed.push(k.seq);
      live.entries.set(k.seq, k);
    }
    after = body.next_after;
  } while (after !== null);
  const order = captureOrder(live.entries);
  live.newest = order.length ? order[order.length - 1] : null;
  return body;
}

let syncFrom = null, syncing = null, waiting = [];
// Coalesces keyframe events into one read of the mission from the lowest changed seq; resolves once that read, the
// marks and (server mode) the view are done. Each keyframe the read found new or refined is then "shown".
function sync(seq) {
  syncFrom = syncFrom === null ? seq : Math.min(syncFrom, seq);
  const done = new Promise((resolve) => waiting.push(resolve));  // before runSync takes the waiting list
  if (!syncing) syncing = runSync();
  return done;
}
async function runSync() {
  while (syncFrom !== null) {
    const from = syncFrom, done = waiting;
    syncFrom = null; waiting = [];
    const changed = [];
    const body = await readMission(from, changed);
    live.syncs += 1;
    if (body) missionShown(body);
    if (page.server) await page.server.refresh();
    for (const seq of changed) {
      live.shown.push(seq);
      if (page.onKeyframeShown) page.onKeyframeShown(live.entries.get(seq));
    }
    for (const resolve of done) resolve();
  }
  syncing = null;
}

function missionShown(body) {
  setStatus("mission " + mission + "\n" + body.keyframe_count + " keyframes, " + body.triangles + " triangles, " +
            body.bytes + " bytes\nnewest: keyframe " + live.newest);
  drawTimeline($("timeline"), live.entries);
  const newest = live.entries.get(live.newest);
  if (page.local) {
    const points = captureOrder(live.entries).map((s) => live.entries.get(s).pose.slice(0, 3));
    page.local.setMarks(points, newest && newest.pose, newest && newest.intrinsics, $("cameras").classList.contains("on") ? live.entries : null);
    if (live.follow && newest) page.local.goToPose(newest.pose, newest.intrinsics);
  } else if (!live.oriented && live.entries.size > 0) {
    page.server.orbitFromFirst();
    live.oriented = true;
  }
}

function firstPose() {
  const first = captureOrder(live.entries)[0];
  return first === undefined ? null : live.entries.get(first).pose;
}

function setFollow(on) {
  live.follow = on;
  $("follow").classList.toggle("on", on);
  const newest = live.entries.get(live.newest);
  if (page.local) { if (on && newest) page.local.goToPose(newest.pose, newest.intrinsics); }
  else page.server.follow(on);
}

// Robot view: the robot's newest camera. Locally the view moves there and the server's image of that camera appears
// beside it; with server views the view is that image.
async function robotView() {
  setFollow(false);
  const newest = live.entries.get(live.newest);
  if (!newest) return;
  if (!page.local) return page.server.robotView(live.newest);
  page.local.goToPose(newest.pose, newest.intrinsics);
  const k = newest.intrinsics || { width: 640, height: 480 };
  const w = Math.min(480, k.width), h = Math.round(w * k.height / k.width);
  const res = await fetch(missionBase() + "/view?pose=keyframe:" + live.newest + "&width=" + w + "&height=" + h +
                          "&format=jpeg&quality=85");
  if (!res.ok) return setStatus("robot view failed: " + res.status);
  const img = $("robot-image");
  const old = img.src;
  img.src = URL.createObjectURL(await res.blob());
  if (old.startsWith("blob:")) URL.revokeObjectURL(old);
  $("robot-inset").hidden = false;
  live.robotUrl = res.url;
}

function subscribe() {
  const es = new EventSource(missionBase() + "/events");
  es.onopen = () => { live.opened += 1; if (live.opened > 1) live.reconnects += 1; $("stream").textContent = "live"; };
  es.onerror = () => { $("stream").textContent = "reconnecting..."; };
  es.addEventListener("keyframe", (e) => {
    live.received += 1;
    const k = JSON.parse(e.data);
    // A replay of a keyframe the page has already read is skipped (a higher rev is a refinement): a late-joining page
    // reads the mission once, not once per replayed event.
    const had = live.entries.get(k.seq);
    if (had && (had.rev || 0) >= (k.rev || 0)) return;
    sync(k.seq);
  });
  es.addEventListener("tileset", (e) => {
    const t = JSON.parse(e.data);
    live.tilesetVersion = String(t.version);
    if (t.keyframes !== undefined) live.tilesetKeyframes.set(String(t.version), t.keyframes);
    if (page.local) page.local.loadTileset(missionBase() + "/tileset.json", String(t.version));
  });
}

async function startMission() {
  $("mission-controls").hidden = false;
  setDownloads(missionBase(), true);
  $("tileset-link").href = missionBase() + "/tileset.json";
  $("tileset-link").hidden = false;
  $("follow").onclick = () => setFollow(!live.follow);
  $("robot-view").onclick = () => robotView();
  $("robot-close").onclick = () => { $("robot-inset").hidden = true; };
  $("cameras").onclick = () => {
    $("cameras").classList.toggle("on");
    if (live.entries.size) missionShown({ keyframe_count: live.entries.size, triangles: "?", bytes: "?" });
  };
  $("reset").onclick = () => {
    setFollow(false);
    $("robot-inset").hidden = true;
    if (page.local) page.local.fit(firstPose());
    else { page.server.orbitFromFirst(); page.server.refresh(); }
  };
  if (page.local) {
    // The current tileset, once; newer versions come with `tileset` events.
    page.local.loadTileset(missionBase() + "/tileset.json");
    // The first view fits the mission once its tileset has tiles and its keyframes are read: frames run until then,
    // whatever the order in which the two arrive.
    page.local.keepDrawing = () => !page.fitted;
    page.local.onFrame = () => {
      if (!page.fitted && live.entries.size > 0 && page.local.fit(firstPose())) page.fitted = true;
    };
    page.local.onUserMove = () => { if (live.follow && page.local.userMoving) setFollow(false); };
  } else {
    page.server.showMission(mission);
    page.server.onDrag = () => setFollow(false);
  }
  await sync(0);
  subscribe();
}

async function main() {
  await chooseRenderer();
  setInterval(statusLine, 500);
  window.addEventListener("resize", () => drawTimeline($("timeline"), live.entries));
  $("mode-mesh").onclick = () => { if (page.server) page.server.setMode("mesh"); };
  $("mode-points").onclick = () => { if (page.server) page.server.setMode("points"); };
  $("modes").hidden = !!page.local;
  loadMissions().catch(() => {});
  if (mission) {
    $("timeline").hidden = false;
    const want = parseInt(params.get("selftest") || "0", 10);
    if (want > 0) {
      const { missionSelftest } = await import("./selftest.js");
      missionSelftest(page, net, want, params.get("report"));
    }
    await startMission();
    return;
  }
  const scenes = await loadScenes();
  if (scenes.length === 0 && !sceneId) { setStatus("no scenes yet: POST a GLB or a frame to /v1/scenes"); return; }
  await showScene(sceneId || scenes[0].id);
  if (params.get("selftest") === "1") {
    const { sceneSelftest } = await import("./selftest.js");
    await sceneSelftest(page, net, params.get("report"));
  }
}

main().catch((e) => { setStatus("page failed: " + e); document.body.dataset.selftest = "error"; });
