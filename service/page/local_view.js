// Local rendering with WebGL: three.js and 3DTilesRendererJS, served by rgbdcast serve under /web/modules/ (the import
// map of index.html). A mission is its 3D Tiles tileset (tileset.json, GLB tiles with EXT_meshopt_compression,
// refinement REPLACE) drawn by a TilesRenderer; a scene is its GLB through GLTFLoader with the meshopt and Draco
// decoders. OrbitControls orbit, pan and zoom with the mouse and touch. The view fills its stage and follows its size.
//
// A new tileset version is loaded by a second TilesRenderer while the first stays on screen; once the second has
// nothing queued, downloading or parsing it replaces the first. Tile names carry their version and are served as
// immutable, so the browser's cache answers for every tile that did not change: only changed tiles cross the network.
// Frames are drawn when something changed (the camera, a tile, the size), not continuously.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { DRACOLoader } from "three/addons/loaders/DRACOLoader.js";
import { MeshoptDecoder } from "three/addons/libs/meshopt_decoder.module.js";
import { TilesRenderer } from "3d-tiles-renderer";
import { GLTFExtensionsPlugin } from "3d-tiles-renderer/plugins";
import { worldToGltf, poseToGltfCamera, frustumCorners, verticalFovDeg } from "./three_frames.js";

const kBackground = 0x3a4458;
const kDecoders = "/web/modules/three/examples/jsm/libs/draco/";

export class LocalView {
  constructor(stage) {
    this.stage = stage;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(kBackground, 1);
    this.renderer.domElement.id = "gl";
    stage.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(60, 4 / 3, 0.02, 2000);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => { this.dirty = true; if (this.onUserMove) this.onUserMove(); });
    this.controls.addEventListener("start", () => { this.userMoving = true; });
    this.controls.addEventListener("end", () => { this.userMoving = false; });
    this.dracoLoader = new DRACOLoader().setDecoderPath(kDecoders);
    this.marks = new THREE.Group();  // trajectory and frustum, in the glTF frame
    this.scene.add(this.marks);
    this.tiles = null;        // the TilesRenderer on screen
    this.nextTiles = null;    // one loading a newer version
    this.wantVersion = null;  // the newest version announced while another one was loading
    this.model = null;        // a scene's GLB
    this.dirty = true;
    this.frameMs = 0;         // update + render of the last drawn frame (CPU)
    this.frames = 0;
    this.firstTilesMs = null;  // when a frame first drew tiles (ms since the page's navigation started)
    this.swaps = [];          // {version, at} of each tileset put on screen
    this.onSwap = null;
    this.keepDrawing = null;  // () => true while the page waits for something a frame brings (the first fit)
    this.resize();
    new ResizeObserver(() => this.resize()).observe(stage);
    const loop = () => { this.frame(); requestAnimationFrame(loop); };
    requestAnimationFrame(loop);
  }

  resize() {
    const w = Math.max(16, this.stage.clientWidth), h = Math.max(16, this.stage.clientHeight);
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    for (const t of [this.tiles, this.nextTiles]) if (t) t.setResolutionFromRenderer(this.camera, this.renderer);
    this.dirty = true;
    this.size = [w, h];
  }

  makeTiles(url) {
    const tiles = new TilesRenderer(url);
    tiles.registerPlugin(new GLTFExtensionsPlugin({ meshoptDecoder: MeshoptDecoder, dracoLoader: this.dracoLoader }));
    tiles.group.rotation.x = -Math.PI / 2;  // the tileset's z-up back to glTF's y-up
    tiles.setCamera(this.camera);
    tiles.setResolutionFromRenderer(this.camera, this.renderer);
    for (const type of ["load-model", "dispose-model", "tile-visibility-change", "load-tile-set"])
      tiles.addEventListener(type, () => { this.dirty = true; });
    tiles.addEventListener("load-error", (e) => { this.lastError = "tile load failed: " + (e.url || "") + " " + (e.error && e.error.message); });
    return tiles;
  }

  static version(tiles) {
    const a = tiles && tiles.rootTileset && tiles.rootTileset.asset;
    return a && a.tilesetVersion !== undefined ? String(a.tilesetVersion) : null;
  }

  // Whether the tileset has any tile below its root (before the first keyframe is in, it has none).
  static hasTiles(tiles) {
    const root = tiles.rootTileset && tiles.rootTileset.root;
    return !!(root && root.children && root.children.length > 0);
  }

  static busy(tiles) {
    if (!tiles.rootTileset) return true;
    const s = tiles.stats;
    return s.queued + s.downloading + s.parsing > 0;
  }

  // Shows the mission's tileset; later calls with a newer version load it behind the one on screen.
  loadTileset(url, version) {
    this.tilesetUrl = url;
    if (!this.tiles) {
      this.tiles = this.makeTiles(url);
      this.scene.add(this.tiles.group);
      return;
    }
    if (version !== undefined && String(version) === LocalView.version(this.tiles)) return;
    if (this.nextTiles) { this.wantVersion = version; return; }
    this.nextTiles = this.makeTiles(url);
    this.nextTiles.group.visible = false;
    this.scene.add(this.nextTiles.group);
  }

  // The loaded version replaces the one on screen once its chosen tiles are in (or at once when it is the same).
  settleNext() {
    const next = this.nextTiles;
    if (!next.rootTileset || LocalView.busy(next)) { this.idleFrames = 0; return; }
    this.idleFrames = (this.idleFrames || 0) + 1;
    if (this.idleFrames < 3) return;  // a few frames with nothing to load
    this.idleFrames = 0;
    const old = this.tiles;
    this.tiles = next;
    this.nextTiles = null;
    next.group.visible = true;
    this.scene.remove(old.group);
    old.dispose();
    this.dirty = true;
    this.swaps.push({ version: LocalView.version(next), at: performance.now() });
    if (this.onSwap) this.onSwap(LocalView.version(next));
    if (this.wantVersion !== null && this.wantVersion !== undefined) {
      const v = this.wantVersion;
      this.wantVersion = null;
      this.loadTileset(this.tilesetUrl, v);
    }
  }

  loadScene(url) {
    const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).setDRACOLoader(this.dracoLoader);
    return new Promise((resolve, reject) => loader.load(url, (gltf) => {
      if (this.model) this.scene.remove(this.model);
      this.model = gltf.scene;
      this.scene.add(this.model);
      this.dirty = true;
      resolve(gltf);
    }, undefined, reject));
  }

  frame() {
    const busy = (this.tiles && LocalView.busy(this.tiles)) || (this.nextTiles && LocalView.busy(this.nextTiles));
    if (!this.dirty && !busy && !this.nextTiles && !(this.keepDrawing && this.keepDrawing())) return;
    this.dirty = false;
    const t0 = performance.now();
    this.camera.updateMatrixWorld();
    if (this.tiles) this.tiles.update();
    if (this.nextTiles) { this.nextTiles.update(); this.settleNext(); }
    this.renderer.render(this.scene, this.camera);
    this.frameMs = performance.now() - t0;
    this.frames += 1;
    if (this.firstTilesMs === null && this.tiles && this.tiles.visibleTiles.size > 0) this.firstTilesMs = performance.now();
    if (this.onFrame) this.onFrame();
  }

  // The eight corners of what is shown (glTF frame: the tileset's root box, or the scene's box), or null before
  // anything is loaded.
  corners() {
    const box = new THREE.Box3(), toWorld = new THREE.Matrix4();
    if (this.tiles && LocalView.hasTiles(this.tiles) && this.tiles.getOrientedBoundingBox(box, toWorld)) {
      this.tiles.group.updateMatrixWorld(true);
      toWorld.premultiply(this.tiles.group.matrixWorld);
    } else if (this.model) {
      box.setFromObject(this.model);
    } else {
      return null;
    }
    if (box.isEmpty()) return null;
    const out = [];
    for (let i = 0; i < 8; i += 1)
      out.push(new THREE.Vector3(i & 1 ? box.max.x : box.min.x, i & 2 ? box.max.y : box.min.y,
                                 i & 4 ? box.max.z : box.min.z).applyMatrix4(toWorld));
    return out;
  }

  // Looks at what is shown from behind and above `pose` (the first keyframe's camera) or from the front, at the
  // smallest distance at which every corner of its box is in the view. False when nothing is loaded yet.
  fit(pose) {
    const corners = this.corners();
    if (!corners) return false;
    const center = new THREE.Vector3();
    for (const c of corners) center.addScaledVector(c, 1 / 8);
    let toward = new THREE.Vector3(0, 0.5, 1);
    if (pose) {
      const c = poseToGltfCamera(pose);
      const back = new THREE.Vector3(0, 0, 1).applyQuaternion(new THREE.Quaternion(...c.quaternion));
      toward = back.setY(0).normalize().add(new THREE.Vector3(0, 0.6, 0));
    }
    toward.normalize();
    this.camera.fov = 60;
    this.camera.position.copy(center).add(toward);
    this.camera.lookAt(center);
    this.camera.updateMatrixWorld(true);
    // In the frame of a camera at the centre looking along -toward (x right, y up, -z ahead): moved back by D, a
    // corner at (x, y, z) is at depth D - z and in view when |x| <= (D - z) tanH and |y| <= (D - z) tanV.
    const view = this.camera.matrixWorldInverse.clone().multiply(new THREE.Matrix4().makeTranslation(toward));
    const tanV = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2)), tanH = tanV * this.camera.aspect;
    let distance = 0, radius = 0;
    for (const c of corners) {
      radius = Math.max(radius, c.distanceTo(center));
      const v = c.clone().applyMatrix4(view);
      distance = Math.max(distance, v.z + Math.abs(v.x) / tanH, v.z + Math.abs(v.y) / tanV);
    }
    if (!(radius > 0)) return false;
    distance *= 1.05;
    this.camera.position.copy(center).addScaledVector(toward, distance);
    this.camera.near = Math.max(0.01, distance / 1000);
    this.camera.far = distance + 4 * radius;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.dirty = true;
    return true;
  }

  // Puts the camera at a keyframe's capture camera (its vertical field of view), orbiting a point 1.5 m ahead.
  goToPose(pose, intrinsics) {
    const c = poseToGltfCamera(pose);
    this.camera.position.set(...c.position);
    this.camera.quaternion.set(...c.quaternion);
    this.camera.fov = verticalFovDeg(intrinsics);
    this.camera.near = 0.02;
    this.camera.updateProjectionMatrix();
    const ahead = new THREE.Vector3(0, 0, -1.5).applyQuaternion(this.camera.quaternion);
    this.controls.target.copy(this.camera.position).add(ahead);
    this.camera.updateMatrixWorld();
    this.dirty = true;
  }

  // The robot's path (world points in capture order) as a line, its newest camera as a frustum, and with `cameras`
  // (the mission's keyframe entries) every keyframe's camera as a smaller one.
  setMarks(points, pose, intrinsics, cameras) {
    for (const o of [...this.marks.children]) { this.marks.remove(o); o.geometry.dispose(); o.material.dispose(); }
    if (points.length > 1) {
      const g = new THREE.BufferGeometry().setFromPoints(points.map((p) => new THREE.Vector3(...worldToGltf(p))));
      this.marks.add(new THREE.Line(g, new THREE.LineBasicMaterial({ color: 0xffcc33, depthTest: false })));
    }
    if (pose) {
      const [apex, ...corners] = frustumCorners(pose, intrinsics, 0.25).map((p) => new THREE.Vector3(...worldToGltf(p)));
      const segs = [];
      for (let i = 0; i < 4; i += 1) segs.push(apex, corners[i], corners[i], corners[(i + 1) % 4]);
      const g = new THREE.BufferGeometry().setFromPoints(segs);
      this.marks.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xff5533, depthTest: false })));
    }
    if (cameras) {
      const segs = [];
      for (const e of cameras.values()) {
        const [apex, ...c] = frustumCorners(e.pose, e.intrinsics, 0.08).map((p) => new THREE.Vector3(...worldToGltf(p)));
        for (let i = 0; i < 4; i += 1) segs.push(apex, c[i], c[i], c[(i + 1) % 4]);
      }
      const g = new THREE.BufferGeometry().setFromPoints(segs);
      this.marks.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0x66ddff, depthTest: false })));
    }
    for (const o of this.marks.children) o.renderOrder = 1;
    this.dirty = true;
  }

  stats() {
    const t = this.tiles;
    const info = this.renderer.info.render;
    return { version: LocalView.version(t), resident: t ? t.stats.inCache : 0, visible: t ? t.visibleTiles.size : 0,
             loading: t ? t.stats.queued + t.stats.downloading + t.stats.parsing : 0, frameMs: this.frameMs,
             calls: info.calls, triangles: info.triangles, frames: this.frames, size: this.size,
             firstTilesMs: this.firstTilesMs };
  }

  // Pixels of the drawn frame that are not the background (by more than 2/255 in some channel), for the tests.
  drawnPixels() {
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const b = [(kBackground >> 16) & 255, (kBackground >> 8) & 255, kBackground & 255];  // sRGB, as drawn
    let drawn = 0;
    for (let i = 0; i < px.length; i += 4)
      if (Math.abs(px[i] - b[0]) > 2 || Math.abs(px[i + 1] - b[1]) > 2 || Math.abs(px[i + 2] - b[2]) > 2) drawn += 1;
    return { drawn, width: w, height: h };
  }
}
