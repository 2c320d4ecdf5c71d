// rworld run viewer: plays the animated glTF of a run beside its timeline, joint plots and program
// lines.  Everything it needs is in the page (docs/viewer.md); three.js is vendored.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { CSS2DRenderer, CSS2DObject } from "three/addons/renderers/CSS2DRenderer.js";

const api = (window.rworld = window.rworld || { errors: [] });
api.ready = false;

const info = JSON.parse(document.getElementById("rworld-info").textContent);
const glbText = document.getElementById("rworld-glb").textContent.trim();

const MARK_COLOURS = {
  collision: "#d62728", clearance: "#ff7f0e", violation: "#b30000", grasp: "#2ca02c",
  release: "#17becf", place: "#17becf", attach_tool: "#9467bd", detach_tool: "#9467bd",
  sync: "#7f7f7f", sense: "#bcbd22", capture: "#e377c2", move: "#1f77b4", done: "#444444",
};
const JOINT_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2"];

// ------------------------------------------------------------------------------ 3D view
const view = document.getElementById("view");
const renderer = new THREE.WebGLRenderer({ antialias: true });
renderer.setPixelRatio(window.devicePixelRatio);
view.appendChild(renderer.domElement);
const labelRenderer = new CSS2DRenderer();
labelRenderer.domElement.className = "labels";
view.appendChild(labelRenderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color("#f4f5f7");
scene.add(new THREE.HemisphereLight("#ffffff", "#8a8f99", 2.2));
const sun = new THREE.DirectionalLight("#ffffff", 1.6);
sun.position.set(2, 3, 4);
scene.add(sun);
const world = new THREE.Group(); // the cell is z-up; three.js is y-up
world.rotation.x = -Math.PI / 2;
scene.add(world);

const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 1000);
const controls = new OrbitControls(camera, labelRenderer.domElement);
controls.enableDamping = false;

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h);
  labelRenderer.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  drawPlots();
  needsRender = true;
}

// ------------------------------------------------------------------------------ state
let mixer = null, action = null;
let current = 0, playing = false, speed = 1, needsRender = true, lastFrame = null;
const tEnd = info.t_end || 0;
const frameWork = [], frameGaps = [];

function setTime(t) {
  current = Math.min(Math.max(t, 0), tEnd);
  if (action) {
    action.time = current;
    mixer.update(0);
  }
  scrubber.value = String(current);
  clock.textContent = `${current.toFixed(3)} s / ${tEnd.toFixed(3)} s`;
  updateSteps();
  needsRender = true;
}

function frame(now) {
  const started = performance.now();
  if (lastFrame !== null) frameGaps.push(now - lastFrame);
  lastFrame = now;
  if (playing) {
    const dt = frameGaps.length ? frameGaps[frameGaps.length - 1] / 1000 : 0;
    let t = current + dt * speed;
    if (t >= tEnd) { t = tEnd; pause(); }
    setTime(t);
  }
  if (needsRender) {
    controls.update();
    updateContacts();
    renderer.render(scene, camera);
    labelRenderer.render(scene, camera);
    declutter();
    drawCursors();
    needsRender = false;
  }
  if (playing) frameWork.push(performance.now() - started);
  requestAnimationFrame(frame);
}

function play() {
  if (current >= tEnd) setTime(0);
  playing = true;
  playButton.textContent = "❚❚";
  playButton.title = "pause (space)";
}
function pause() {
  playing = false;
  playButton.textContent = "▶";
  playButton.title = "play (space)";
}

// ------------------------------------------------------------------------------ controls
const playButton = document.getElementById("play");
const speedSelect = document.getElementById("speed");
const scrubber = document.getElementById("scrubber");
const clock = document.getElementById("clock");
const marksLayer = document.getElementById("marks");
scrubber.max = String(tEnd);
scrubber.step = "0.001";
playButton.addEventListener("click", () => (playing ? pause() : play()));
speedSelect.addEventListener("change", () => (speed = parseFloat(speedSelect.value)));
scrubber.addEventListener("input", () => { pause(); setTime(parseFloat(scrubber.value)); });
window.addEventListener("keydown", (e) => {
  if (e.code === "Space" && e.target.tagName !== "SELECT") { e.preventDefault(); playing ? pause() : play(); }
});
controls.addEventListener("change", () => (needsRender = true));

for (const mark of info.marks) {
  const tick = document.createElement("button");
  tick.className = `mark mark-${mark.kind}`;
  tick.style.left = `${tEnd > 0 ? (100 * mark.t) / tEnd : 0}%`;
  tick.style.background = MARK_COLOURS[mark.kind] || "#555";
  tick.title = `${mark.t.toFixed(3)} s  ${mark.text}`;
  tick.addEventListener("click", () => { pause(); setTime(mark.t); });
  marksLayer.appendChild(tick);
}

const labelToggle = document.getElementById("labels");
labelToggle.addEventListener("change", () => {
  labelRenderer.domElement.style.display = labelToggle.checked ? "" : "none";
});

// ------------------------------------------------------------------------------ side panel
const stepsBox = document.getElementById("steps");
const stepLines = {};
for (const [device, data] of Object.entries(info.devices)) {
  const row = document.createElement("div");
  row.className = "step";
  row.innerHTML = `<b></b> <span class="text"></span> <code class="where"></code>`;
  row.querySelector("b").textContent = device;
  stepsBox.appendChild(row);
  stepLines[device] = { row, data };
}

function stepAt(spans, t) {
  let lo = 0, hi = spans.length - 1, found = -1;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (spans[mid][0] <= t + 1e-9) { found = mid; lo = mid + 1; } else hi = mid - 1;
  }
  return found < 0 ? -1 : spans[found][1];
}

function updateSteps() {
  for (const { row, data } of Object.values(stepLines)) {
    const index = stepAt(data.spans, current);
    const step = index >= 0 ? data.steps[index] : null;
    row.querySelector(".text").textContent = step ? `step ${index + 1}: ${step.text}` : "(idle)";
    row.querySelector(".where").textContent = step ? step.where : "";
  }
}

const missing = document.getElementById("missing");
if (info.without_geometry.length) {
  missing.textContent = `drawn as axes (no geometry): ${info.without_geometry.join(", ")}`;
} else missing.remove();

// joint plots: each drawn once off screen; a frame copies it and draws the cursor
const plotsBox = document.getElementById("plots");
const plots = [];
for (const [device, data] of Object.entries(info.devices)) {
  const box = document.createElement("div");
  box.className = "plot";
  const title = document.createElement("div");
  title.className = "plot-title";
  title.textContent = `${device}: joint values`;
  const canvas = document.createElement("canvas");
  canvas.addEventListener("click", (e) => {
    const r = canvas.getBoundingClientRect();
    pause();
    setTime(((e.clientX - r.left) / r.width) * tEnd);
  });
  box.append(title, canvas);
  plotsBox.appendChild(box);
  plots.push({ device, data, canvas, background: document.createElement("canvas") });
}

function drawPlots() {
  for (const plot of plots) {
    const width = plot.canvas.clientWidth || 300, height = plot.canvas.clientHeight || 70;
    for (const c of [plot.canvas, plot.background]) { c.width = width; c.height = height; }
    const g = plot.background.getContext("2d");
    g.fillStyle = "#ffffff";
    g.fillRect(0, 0, width, height);
    const t = info.t, series = plot.data.q;
    let lo = Infinity, hi = -Infinity;
    for (const s of series) for (const v of s) { if (v < lo) lo = v; if (v > hi) hi = v; }
    if (!(hi > lo)) { lo -= 1; hi += 1; }
    const x = (k) => (tEnd > 0 ? (t[k] / tEnd) * (width - 1) : 0);
    const y = (v) => height - 3 - ((v - lo) / (hi - lo)) * (height - 6);
    series.forEach((s, j) => {
      g.strokeStyle = JOINT_COLOURS[j % JOINT_COLOURS.length];
      g.lineWidth = 1.2;
      g.beginPath();
      const stride = Math.max(1, Math.floor(s.length / (2 * width)));
      for (let k = 0; k < s.length; k += stride) (k ? g.lineTo : g.moveTo).call(g, x(k), y(s[k]));
      g.stroke();
    });
  }
  drawCursors();
}

function drawCursors() {
  for (const plot of plots) {
    const g = plot.canvas.getContext("2d");
    if (!plot.canvas.width) continue;
    g.drawImage(plot.background, 0, 0);
    const xc = tEnd > 0 ? (current / tEnd) * (plot.canvas.width - 1) : 0;
    g.strokeStyle = "#d62728";
    g.lineWidth = 1.5;
    g.beginPath();
    g.moveTo(xc, 0);
    g.lineTo(xc, plot.canvas.height);
    g.stroke();
  }
}

// ------------------------------------------------------------------------------ load
function bytesOf(base64) {
  const binary = atob(base64);
  const out = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; i++) out[i] = binary.charCodeAt(i);
  return out.buffer;
}

const labelDivs = [];
function addLabels(root) {
  const byFrame = {};
  root.traverse((o) => { if (o.userData && o.userData.frame) byFrame[o.userData.frame] = o; });
  for (const label of info.labels) {
    const node = byFrame[label.node];
    if (!node) continue;
    const div = document.createElement("div");
    div.className = `label label-${label.kind}`;
    div.textContent = label.text;
    node.add(new CSS2DObject(div));
    labelDivs.push(div);
  }
  return byFrame;
}

// labels of frames close together (a hand's TCPs) would stack on each other: each is moved down
// below those it overlaps, in screen order, after every render
function declutter() {
  if (labelRenderer.domElement.style.display === "none") return;
  const shown = labelDivs.filter((d) => d.parentElement && d.style.display !== "none");
  for (const d of shown) d.style.marginTop = "0px";
  const boxes = shown.map((d) => ({ d, r: d.getBoundingClientRect() }));
  boxes.sort((a, b) => a.r.top - b.r.top || a.r.left - b.r.left);
  const placed = [];
  for (const { d, r } of boxes) {
    let shift = 0;
    for (let moved = true; moved; ) {
      moved = false;
      for (const p of placed) {
        if (r.left < p.right && r.right > p.left && r.top + shift < p.bottom
            && r.bottom + shift > p.top) {
          shift = p.bottom - r.top + 1;
          moved = true;
        }
      }
    }
    d.style.marginTop = `${shift}px`;
    placed.push({ left: r.left, right: r.right, top: r.top + shift, bottom: r.bottom + shift });
  }
}

// recorded probe contacts: a small dot at each, from the instant it was recorded
const contactDots = [];
function addContacts() {
  const radius = Math.max(0.002, 0.004);
  const geometry = new THREE.SphereGeometry(radius, 12, 8);
  const material = new THREE.MeshBasicMaterial({ color: 0xd62728 });
  for (const c of info.contacts || []) {
    const dot = new THREE.Mesh(geometry, material);
    dot.position.set(c.point[0], c.point[1], c.point[2]);
    dot.userData.contact = c;
    dot.visible = false;
    world.add(dot);
    contactDots.push(dot);
  }
}
function updateContacts() {
  for (const dot of contactDots) dot.visible = current >= dot.userData.contact.t - 1e-9;
}

function frameCamera(root) {
  const box = new THREE.Box3().setFromObject(root);
  const size = box.getSize(new THREE.Vector3()).length() || 1;
  const centre = box.getCenter(new THREE.Vector3());
  camera.near = size / 1000;
  camera.far = size * 100;
  camera.position.copy(centre).add(new THREE.Vector3(0.9, 0.6, 1.0).multiplyScalar(size * 0.8));
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();
}

new GLTFLoader().parse(
  bytesOf(glbText),
  "",
  (gltf) => {
    world.add(gltf.scene);
    api.scene = gltf.scene;
    api.frames = addLabels(gltf.scene);
    addContacts();
    if (gltf.animations.length) {
      mixer = new THREE.AnimationMixer(gltf.scene);
      action = mixer.clipAction(gltf.animations[0]);
      action.setLoop(THREE.LoopOnce, 1);
      action.clampWhenFinished = true;
      action.play();
    }
    setTime(0);
    world.updateMatrixWorld(true);
    frameCamera(world);
    resize();
    const hash = new URLSearchParams(location.hash.slice(1));
    if (hash.has("t")) setTime(parseFloat(hash.get("t")));
    if (hash.has("play")) play();
    requestAnimationFrame(frame);
    api.ready = true;
  },
  (error) => {
    api.errors.push(`loading the scene: ${error}`);
    document.getElementById("title").textContent += " (the scene did not load)";
  },
);

if (!(tEnd > 0)) { // one state (rworld render --html): no timeline to play
  document.querySelector("footer").style.display = "none";
  if (!Object.keys(info.devices).length && !info.without_geometry.length) {
    document.querySelector("aside").style.display = "none";
  }
}
window.addEventListener("resize", resize);
document.getElementById("title").textContent = info.title;

// ------------------------------------------------------------------------------ for tests
api.seek = (t) => { pause(); setTime(t); };
api.contactsShown = () => contactDots.filter((d) => d.visible).length;
api.labelOverlaps = () => {
  const r = labelDivs.filter((d) => d.parentElement && d.offsetParent !== null)
    .map((d) => d.getBoundingClientRect());
  let n = 0;
  for (let i = 0; i < r.length; i++) for (let j = i + 1; j < r.length; j++) {
    if (r[i].left < r[j].right && r[j].left < r[i].right && r[i].top < r[j].bottom
        && r[j].top < r[i].bottom) n++;
  }
  return n;
};
api.play = play;
api.pause = pause;
api.time = () => current;
api.worldPosition = (frameName) => {
  const node = api.frames && api.frames[frameName];
  if (!node) return null;
  node.updateWorldMatrix(true, false);
  const p = new THREE.Vector3().setFromMatrixPosition(node.matrixWorld);
  world.worldToLocal(p); // cell coordinates (z up)
  return [p.x, p.y, p.z];
};
api.frustumPoints = (camera) => { // a camera's field of view: its lines' vertices, cell coords
  let node = null;
  if (api.scene) {
    api.scene.traverse((o) => {
      if (o.userData.kind === "frustum" && o.userData.camera === camera) node = o;
    });
  }
  const lines = node && (node.isLineSegments ? node : node.children.find((c) => c.isLineSegments));
  if (!lines) return null;
  lines.updateWorldMatrix(true, false);
  const position = lines.geometry.getAttribute("position");
  const out = [];
  for (let i = 0; i < position.count; i++) {
    const p = new THREE.Vector3().fromBufferAttribute(position, i).applyMatrix4(lines.matrixWorld);
    world.worldToLocal(p);
    out.push([p.x, p.y, p.z]);
  }
  return out;
};
api.screenPoint = (point) => { // a cell point (z up) to page pixels
  const p = world.localToWorld(new THREE.Vector3(...point)).project(camera);
  const r = renderer.domElement.getBoundingClientRect();
  return [r.left + ((p.x + 1) / 2) * r.width, r.top + ((1 - p.y) / 2) * r.height];
};
api.bodyPixel = (frameName) => { // page pixel of the centre of a body's drawn box
  const node = api.frames && api.frames[frameName];
  if (!node) return null;
  const box = new THREE.Box3().setFromObject(node);
  const p = box.getCenter(new THREE.Vector3()).project(camera);
  const r = renderer.domElement.getBoundingClientRect();
  return [r.left + ((p.x + 1) / 2) * r.width, r.top + ((1 - p.y) / 2) * r.height];
};
api.showLabels = (on) => {
  labelToggle.checked = on;
  labelRenderer.domElement.style.display = on ? "" : "none";
};
api.frameDrawn = () => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve)));
api.measure = (ms) => new Promise((resolve) => { // frame times during playback
  frameWork.length = 0;
  frameGaps.length = 0;
  setTime(0);
  play();
  setTimeout(() => {
    pause();
    const sorted = (a) => [...a].sort((x, y) => x - y);
    const pct = (a, p) => (a.length ? sorted(a)[Math.min(a.length - 1, Math.floor(p * a.length))] : null);
    const mean = (a) => (a.length ? a.reduce((x, y) => x + y, 0) / a.length : null);
    resolve({
      frames: frameWork.length,
      work_mean: mean(frameWork), work_p95: pct(frameWork, 0.95),
      gap_mean: mean(frameGaps), gap_median: pct(frameGaps, 0.5), gap_p95: pct(frameGaps, 0.95),
    });
  }, ms);
});
