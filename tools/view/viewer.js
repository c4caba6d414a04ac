// lagrangectl view's page. It computes no pose: every frame's pose comes from
// lagrangectl (the plant's own kinematics; a floating base's frames already in
// the world, placed by its base's pose) and is placed as given. What it
// drew is exposed for tests as window.lagrangeDrawn and, as JSON, in
// #lagrange-drawn: per instance, each frame object's matrix (column-major, as
// three.js keeps it) for the measured pose and the setpoint's ghost, a floating
// base's pose as sent (base) and its ground (ground: z and size, m).
// Text from the server goes into the page only as text (textContent).
//
// Query parameters (documented for users in the README's "The 3-D view" and
// in `lagrangectl view --help`): q=a,b,.. (--urdf: the joints' start),
// t=SECONDS (--log: the time shown first), frames=1 (draw every frame's axes),
// frames_max=N (live: stop listening after N frames), probe=1 (count the
// canvas's non-background pixels into #lagrange-probe after each draw).

import * as THREE from './three/build/three.module.js';
import { OrbitControls } from './three/examples/jsm/controls/OrbitControls.js';
import { STLLoader } from './three/examples/jsm/loaders/STLLoader.js';
import { ColladaLoader } from './three/examples/jsm/loaders/ColladaLoader.js';

const params = new URLSearchParams(location.search);
const probe = params.has('probe');
const framesMax = params.has('frames_max') ? Number(params.get('frames_max')) : Infinity;
const kSpacing = 1.9;  // m between instances along x
const kBackground = 0x1b1d22;

const $ = (id) => document.getElementById(id);
function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined) e.textContent = String(text);
  if (cls) e.className = cls;
  return e;
}

// ---- the scene ----
const container = $('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: probe });
renderer.setPixelRatio(window.devicePixelRatio || 1);
container.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(kBackground);
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 100);
camera.up.set(0, 0, 1);  // z up, as URDF's world
const controls = new OrbitControls(camera, renderer.domElement);
controls.addEventListener('change', () => requestDraw());
scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 0.9));
const sun = new THREE.DirectionalLight(0xffffff, 0.7);
sun.position.set(2, -3, 5);
scene.add(sun);
const grid = new THREE.GridHelper(10, 40, 0x555a66, 0x33363e);
grid.rotation.x = Math.PI / 2;  // into the xy plane
scene.add(grid);

function resize() {
  const w = container.clientWidth || 800, h = container.clientHeight || 600;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  requestDraw();
}
window.addEventListener('resize', resize);

let drawPending = false;
function requestDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(draw);
}

const drawn = {};
window.lagrangeDrawn = drawn;
let drawCount = 0;
function draw() {
  drawPending = false;
  renderer.render(scene, camera);
  ++drawCount;
  $('lagrange-drawn').textContent = JSON.stringify(drawn);
  if (probe) probeCanvas();
}

// Pixels that differ from the background: the canvas is not blank.
function probeCanvas() {
  const gl = renderer.getContext();
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const bg = new THREE.Color(kBackground);
  const r = Math.round(bg.r * 255), g = Math.round(bg.g * 255), b = Math.round(bg.b * 255);
  let lit = 0, checksum = 0;
  for (let i = 0; i < px.length; i += 4) {
    if (Math.abs(px[i] - r) + Math.abs(px[i + 1] - g) + Math.abs(px[i + 2] - b) > 24) ++lit;
    checksum = (checksum * 31 + px[i] + 7 * px[i + 1] + 13 * px[i + 2]) % 1000000007;
  }
  $('lagrange-probe').textContent = JSON.stringify({ nonblank: lit, checksum, width: w, height: h, draws: drawCount,
    camera: camera.position.toArray(), target: controls.target.toArray(), fitted: fittedTo });
}

// ---- a robot: one object per frame, placed at the poses it is given ----
function material(rgba, ghost) {
  const m = new THREE.MeshLambertMaterial({ color: new THREE.Color(rgba[0], rgba[1], rgba[2]) });
  if (ghost || rgba[3] < 1) {
    m.transparent = true;
    m.opacity = ghost ? 0.28 : rgba[3];
    m.depthWrite = !ghost;
  }
  return m;
}
function matrixOf(pose) {  // [R row by row, p] => Matrix4
  return new THREE.Matrix4().set(
    pose[0], pose[1], pose[2], pose[9],
    pose[3], pose[4], pose[5], pose[10],
    pose[6], pose[7], pose[8], pose[11],
    0, 0, 0, 1);
}
const missingLines = [];
function noteMissing(line) {
  missingLines.push(line);
  const box = $('missing');
  box.textContent = '';
  for (const l of missingLines) box.appendChild(el('div', l));
}

class Robot {
  constructor(model, root, ghost) {
    this.model = model;
    this.ghost = ghost;
    this.frames = model.frames.map(() => {
      const g = new THREE.Group();
      g.matrixAutoUpdate = false;
      root.add(g);
      return g;
    });
    this.root = root;
    this.rods = [];
    this.axes = [];
    const framed = new Set();  // frames whose look is missing: always show their axes
    for (const shape of model.shapes) this.addShape(shape, framed);
    if (model.skeleton) this.frames.forEach((_, k) => framed.add(k));
    this.frames.forEach((f, k) => {
      const a = new THREE.AxesHelper(ghost ? 0.06 : 0.1);
      a.userData.always = framed.has(k) && !ghost;
      a.visible = a.userData.always;
      f.add(a);
      this.axes.push(a);
    });
    if (model.missing) {
      for (const line of model.missing) {
        const m = /^link '([^']*)'/.exec(line);
        const k = m ? model.frames.indexOf(m[1]) : -1;
        if (k >= 0 && !ghost) { this.axes[k].userData.always = true; this.axes[k].visible = true; }
      }
    }
  }
  parentOf(frame) { return frame >= 0 ? this.frames[frame] : this.root; }
  addShape(s, framed) {
    const mat = material(s.rgba, this.ghost);
    let obj = null;
    if (s.type === 'rod') {
      const mesh = new THREE.Mesh(new THREE.CylinderBufferGeometry(s.radius, s.radius, 1, 16), mat);
      this.root.add(mesh);
      this.rods.push({ mesh, from: s.from, to: s.to });
      return;
    }
    if (s.type === 'box') obj = new THREE.Mesh(new THREE.BoxBufferGeometry(s.size[0], s.size[1], s.size[2]), mat);
    if (s.type === 'sphere') obj = new THREE.Mesh(new THREE.SphereBufferGeometry(s.size[0], 20, 14), mat);
    if (s.type === 'cylinder') {  // URDF's cylinder is along z, three.js's along y
      const c = new THREE.Mesh(new THREE.CylinderBufferGeometry(s.size[0], s.size[0], s.size[1], 24), mat);
      c.rotation.x = Math.PI / 2;
      obj = new THREE.Group();
      obj.add(c);
    }
    if (s.type === 'mesh') {
      obj = new THREE.Group();
      obj.scale.set(s.scale[0], s.scale[1], s.scale[2]);
      const url = 'mesh/' + this.model.index + '/' + s.mesh;
      const failed = () => {
        if (!this.ghost) noteMissing(this.model.name + ': mesh ' + url + ' did not load; its frame is drawn');
        if (s.frame >= 0) { framed.add(s.frame); if (this.axes[s.frame]) { this.axes[s.frame].userData.always = true; this.axes[s.frame].visible = true; } }
        requestDraw();
      };
      if (s.format === 'stl') {
        new STLLoader().load(url, (geometry) => { obj.add(new THREE.Mesh(geometry, mat)); requestDraw(); }, undefined, failed);
      } else {
        new ColladaLoader().load(url, (collada) => {
          collada.scene.quaternion.set(0, 0, 0, 1);  // the mesh is in its link's frame, whatever its up axis
          collada.scene.traverse((o) => { if (o.isMesh && this.ghost) o.material = mat; });
          obj.add(collada.scene);
          requestDraw();
        }, undefined, failed);
      }
    }
    if (!obj) return;
    const holder = new THREE.Group();
    holder.matrixAutoUpdate = false;
    holder.matrix.copy(matrixOf(s.origin));
    holder.add(obj);
    this.parentOf(s.frame).add(holder);
  }
  setPoses(poses) {
    poses.forEach((p, k) => {
      const f = this.frames[k];
      f.matrix.copy(matrixOf(p));
      f.matrixWorldNeedsUpdate = true;
    });
    const at = (k) => (k >= 0 ? new THREE.Vector3().setFromMatrixPosition(this.frames[k].matrix) : new THREE.Vector3());
    for (const rod of this.rods) {  // a unit cylinder along y, stretched from one frame's origin to another's
      const a = at(rod.from), b = at(rod.to);
      const d = new THREE.Vector3().subVectors(b, a);
      const len = d.length();
      rod.mesh.visible = len > 1e-9;
      if (!rod.mesh.visible) continue;
      rod.mesh.position.copy(a).addScaledVector(d, 0.5);
      rod.mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), d.clone().divideScalar(len));
      rod.mesh.scale.set(1, len, 1);
    }
    this.root.visible = true;
  }
  matrices() { return this.frames.map((f) => Array.from(f.matrix.elements)); }
  showFrames(on) { for (const a of this.axes) a.visible = on || a.userData.always; }
}

// ---- instances: the 3-D models and the side panel ----
let model = null;
const robots = [];   // by model index: {measured, ghost}
const cards = {};    // by instance name
const history = {};  // by instance name: recent eps and tau/limit for the plots

function build(m) {
  model = m;
  const n = m.models.length;
  m.models.forEach((g, i) => {
    const place = new THREE.Group();
    place.position.x = (i - (n - 1) / 2) * kSpacing;
    if (g.planar) place.rotation.x = Math.PI / 2;  // the plant's xy plane upright, its −y down
    scene.add(place);
    const a = new THREE.Group(), b = new THREE.Group();
    a.visible = false;
    b.visible = false;
    place.add(a);
    place.add(b);
    // A task-space controller's target: a frame's axes and a translucent ball at its origin.
    const target = new THREE.Group();
    target.matrixAutoUpdate = false;
    target.visible = false;
    target.add(new THREE.AxesHelper(0.15));
    target.add(new THREE.Mesh(new THREE.SphereBufferGeometry(0.025, 16, 12), material([0.95, 0.85, 0.2, 1], true)));
    place.add(target);
    // An mpc controller's plan: each frame's path through the plan's knots, a polyline (planPaths).
    const plan = new THREE.Group();
    plan.visible = false;
    place.add(plan);
    const ground = g.floating_base ? groundOf(n) : null;
    if (ground) place.add(ground);
    robots[i] = { measured: new Robot(g, a, false), ghost: new Robot(g, b, true), place, target, plan, ground };
    for (const line of g.missing) noteMissing(g.name + ': ' + line);
  });
  const span = Math.max(1, n) * kSpacing;
  camera.position.set(0, -Math.max(3.2, 1.3 * span), 1.4);
  controls.target.set(0, 0, 0.35);
  controls.update();
  $('show-frames').checked = params.get('frames') === '1';
  $('show-frames').addEventListener('change', applyToggles);
  $('show-ghost').addEventListener('change', applyToggles);
  applyToggles();
  resize();
}
// A floating base's ground: a translucent plane at z = 0 of its world, kSpacing wide beside other instances
// (their grounds tile), seen from below too (a base with no contact falls through it). Its depth is pushed
// back so that the grid's lines at z = 0 stay on top of it.
function groundOf(models) {
  const width = models > 1 ? kSpacing : 6, depth = 6;
  const m = new THREE.MeshLambertMaterial({ color: 0x4a5468, transparent: true, opacity: 0.5, side: THREE.DoubleSide,
    depthWrite: false, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
  const plane = new THREE.Mesh(new THREE.PlaneBufferGeometry(width, depth), m);  // in its xy plane, at z = 0
  plane.userData.size = [width, depth];
  return plane;
}
function applyToggles() {
  const frames = $('show-frames').checked, ghost = $('show-ghost').checked;
  for (const r of robots) {
    r.measured.showFrames(frames);
    r.ghost.showFrames(false);
    r.ghost.root.userData.allowed = ghost;
    if (!ghost) { r.ghost.root.visible = false; r.target.visible = false; r.plan.visible = false; }
  }
  requestDraw();
}

function card(name) {
  if (cards[name]) return cards[name];
  const c = el('div', undefined, 'card');
  const parts = {
    head: el('div'), line: el('div', '', 'small'), reason: el('div', '', 'warn small'), note: el('div', '', 'warn small'),
    event: el('div', '', 'mode-fault small'),
    eps: el('canvas', undefined, 'plot'), tau: el('canvas', undefined, 'plot'),
  };
  parts.name = el('span', name, 'name');
  parts.mode = el('span', '');
  parts.head.append(parts.name, ' ', parts.mode);
  c.append(parts.head, parts.line, parts.reason, parts.event, parts.note, el('div', 'ε (J) and its quadrature bound', 'small'), parts.eps,
           el('div', 'τ / limit per joint', 'small'), parts.tau);
  $('instances').appendChild(c);
  cards[name] = parts;
  history[name] = { eps: [], bound: [], tau: [] };
  return parts;
}

const fmt = (x, d = 3) => (typeof x === 'number' ? x.toFixed(d) : '—');
function showInstance(inst) {
  if (inst.mode === undefined) return;  // --urdf: a model, no run
  const c = card(inst.name);
  c.mode.textContent = inst.mode + (inst.stale ? ' (STALE: no state for ' + fmt(inst.age, 1) + ' s)' : '');
  c.mode.className = 'mode-' + inst.mode;
  c.line.textContent = (inst.controller || '') + '   t ' + fmt(inst.t) + ' s   tick ' + inst.tick + '   run ' + inst.run +
    (inst.log_t !== undefined ? '   logged at ' + fmt(inst.log_t) + ' s' : '');
  c.reason.textContent = inst.reason || '';
  c.note.textContent = [inst.note, inst.warning].filter(Boolean).join('; ');
  const h = history[inst.name];
  // The moment it faulted (or was stopped), as lagrangectl saw it in every state: kept after it leaves that mode.
  const e = inst.event;
  c.event.textContent = e ? 'entered ' + e.mode + ' at t = ' + fmt(e.t) + ' s (tick ' + e.tick + ', run ' + e.run + ')' : '';
  if (typeof inst.eps === 'number') { h.eps.push(inst.eps); h.bound.push(inst.eps_bound); }
  const g = inst.model >= 0 ? model.models[inst.model] : null;
  if (g && inst.tau) h.tau.push(inst.tau.map((t, j) => (g.tau_limits[j] ? t / g.tau_limits[j] : null)));
  for (const k of ['eps', 'bound', 'tau']) if (h[k].length > 240) h[k].splice(0, h[k].length - 240);
}

let plotCount = 0;
function plots() {
  if (plotCount++ % 6 !== 0) return;  // every 6th frame: 10 Hz at 60 frames per second is plenty for a glance
  for (const name of Object.keys(cards)) {
    const h = history[name], c = cards[name];
    plot(c.eps, [h.eps, h.bound, h.bound.map((b) => (typeof b === 'number' ? -b : b))], ['#6cf', '#777', '#777'], null);
    const series = h.tau.length ? h.tau[0].map((_, j) => h.tau.map((row) => row[j])) : [];
    plot(c.tau, series, ['#fa5', '#7d7', '#d7d', '#7dd', '#dd7', '#f77', '#77f'], 1);
  }
}
function plot(canvas, series, colors, fixed) {
  const w = canvas.width = canvas.clientWidth || 300, h = canvas.height = canvas.clientHeight || 48;
  const ctx = canvas.getContext('2d');
  ctx.clearRect(0, 0, w, h);
  let lim = fixed || 0;
  if (!fixed) for (const s of series) for (const v of s) if (typeof v === 'number') lim = Math.max(lim, Math.abs(v));
  if (!(lim > 0)) lim = 1;
  ctx.strokeStyle = '#333';
  ctx.beginPath(); ctx.moveTo(0, h / 2); ctx.lineTo(w, h / 2); ctx.stroke();
  series.forEach((s, i) => {
    ctx.strokeStyle = colors[i % colors.length];
    ctx.beginPath();
    let started = false;
    s.forEach((v, k) => {
      if (typeof v !== 'number') { started = false; return; }
      const x = w - ((s.length - 1 - k) / 239) * w, y = h / 2 - (v / lim) * (h / 2 - 2);  // the newest at the right
      if (started) ctx.lineTo(x, y); else ctx.moveTo(x, y);
      started = true;
    });
    ctx.stroke();
  });
  ctx.fillStyle = '#889';
  ctx.fillText('±' + lim.toPrecision(2), 2, 10);
}

// The plan's frame paths as polylines with their knots marked, in the plan group (replaced per frame).
function planPaths(group, plan) {
  while (group.children.length) {
    const c = group.children.pop();
    c.geometry.dispose();
  }
  planPaths.line = planPaths.line || new THREE.LineBasicMaterial({ color: 0x3aa0ff, transparent: true, opacity: 0.7 });
  planPaths.point = planPaths.point || new THREE.PointsMaterial({ color: 0x3aa0ff, size: 0.02 });
  const lineMaterial = planPaths.line, pointMaterial = planPaths.point;
  for (const path of plan.paths) {
    if (path.length < 2) continue;
    const geometry = new THREE.BufferGeometry().setFromPoints(path.map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    group.add(new THREE.Line(geometry, lineMaterial));
    group.add(new THREE.Points(geometry.clone(), pointMaterial));
  }
}

// One frame from the server: each instance's poses placed, its text shown.
function apply(frame) {
  const seen = new Set();
  for (const inst of frame.instances) {
    showInstance(inst);
    if (inst.model < 0 || !robots[inst.model]) continue;
    const r = robots[inst.model];
    const record = { model: inst.model, q: inst.q };
    if (inst.base) record.base = inst.base;  // a floating base's pose, as published: the frames are placed by it
    if (r.ground) record.ground = { z: r.ground.position.z, size: r.ground.userData.size };
    if (inst.poses) {
      r.measured.setPoses(inst.poses);
      record.measured = r.measured.matrices();
      seen.add(inst.model);
    }
    // The setpoint's ghost only where a controller follows q_des (not under a task-space controller: its
    // target is drawn instead; not while the external controller applies streamed torques).
    if (inst.ghost) {
      r.ghost.setPoses(inst.ghost);
      record.q_des = inst.q_des;
      record.ghost = r.ghost.matrices();
    }
    r.ghost.root.visible = Boolean(inst.ghost) && r.ghost.root.userData.allowed !== false;
    r.target.visible = Boolean(inst.target) && $('show-ghost').checked;
    if (inst.target) {  // (w, x, y, z) and p, as published: placed, not computed
      const [w, x, y, z] = inst.target.q;
      const m = new THREE.Matrix4().makeRotationFromQuaternion(new THREE.Quaternion(x, y, z, w));
      m.setPosition(new THREE.Vector3(inst.target.p[0], inst.target.p[1], inst.target.p[2]));
      r.target.matrix.copy(m);
      r.target.matrixWorldNeedsUpdate = true;
      record.target = { frame: inst.target.frame, p: inst.target.p, q: inst.target.q, matrix: Array.from(r.target.matrix.elements) };
    }
    r.plan.visible = Boolean(inst.plan) && $('show-ghost').checked;
    if (inst.plan && inst.plan.sequence !== r.planSequence) {  // a new plan: its paths rebuilt
      planPaths(r.plan, inst.plan);
      r.planSequence = inst.plan.sequence;
    }
    if (inst.plan) record.plan = { sequence: inst.plan.sequence, status: inst.plan.status, paths: inst.plan.paths.length };
    record.mode = inst.mode;
    record.t = inst.t;
    drawn[inst.name] = record;
  }
  if (frame.daemons) {
    $('status').textContent = frame.daemons.length === 0 ? 'no lagranged heard yet on ' + model.bus.url :
      frame.daemons.map((d) => (d.prefix ? d.prefix + ' ' : '') + 'lagranged run ' + d.run + (d.stale ? ' STALE' : '') +
        '   ticks ' + d.ticks + '   overruns ' + d.overruns).join('\n');
  }
  plots();
  for (const m of seen) posed.add(m);
  if (!userMoved && posed.size > fittedTo) fit();
  if (probe) draw();  // at once, not at the next animation frame: a headless test reads the document right after
  else requestDraw();
}

// Whenever a robot is placed for the first time, until the user moves the
// camera: the camera takes in every robot placed so far.
const posed = new Set();
let fittedTo = 0, userMoved = false;
renderer.domElement.addEventListener('pointerdown', () => { userMoved = true; });
renderer.domElement.addEventListener('wheel', () => { userMoved = true; });
function fit() {
  fittedTo = posed.size;
  scene.updateMatrixWorld(true);  // the places' offsets and turns, before the first render
  const box = new THREE.Box3();
  for (const m of posed) box.expandByObject(robots[m].measured.root);
  if (box.isEmpty()) return;
  const center = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3());
  const radius = Math.max(0.3, 0.5 * size.length());
  const tan = Math.tan((camera.fov * Math.PI) / 360);
  const distance = 1.1 * radius / (tan * Math.min(1, camera.aspect));  // the narrower of the two fields of view
  controls.target.copy(center);
  camera.position.set(center.x, center.y - 0.95 * distance, center.z + 0.3 * distance);
  controls.update();
}

// ---- the three sources ----
async function getJson(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(url + ': ' + r.status + ' ' + (await r.text()));
  return r.json();
}

function startLive() {
  $('status').textContent = 'listening on ' + model.bus.url;
  const source = new EventSource('api/stream');
  let frames = 0;
  source.onmessage = (e) => {
    const frame = JSON.parse(e.data);
    apply(frame);
    if (frame.instances.length > 0 && ++frames >= framesMax) source.close();
  };
  source.onerror = () => { $('status').textContent = 'the stream from lagrangectl view stopped (reconnecting)'; };
}

function startUrdf() {
  const g = model.models[0];
  $('status').textContent = g.name + ': ' + g.dofs + ' joints';
  $('ghost-label').classList.add('hidden');  // a model alone has no setpoint
  const q = g.joints.map(() => 0);
  if (params.has('q')) params.get('q').split(',').forEach((v, j) => { if (j < q.length) q[j] = Number(v); });
  let inFlight = false, again = false;
  const update = async () => {
    if (inFlight) { again = true; return; }
    inFlight = true;
    try { apply(await getJson('api/poses?q=' + q.join(','))); } catch (e) { $('status').textContent = String(e.message); }
    inFlight = false;
    if (again) { again = false; update(); }
  };
  g.joints.forEach((j, k) => {
    const row = el('div', undefined, 'small');
    const label = el('span', j.name + ' ' + q[k].toFixed(3));
    const s = el('input');
    Object.assign(s, { type: 'range', min: j.lower, max: j.upper, step: 0.001 });
    s.value = q[k];
    s.addEventListener('input', () => { q[k] = Number(s.value); label.textContent = j.name + ' ' + q[k].toFixed(3); update(); });
    row.append(label, s);
    $('sliders').appendChild(row);
  });
  update();
}

function startLog() {
  const log = model.log;
  $('status').textContent = 'log ' + log.file + ': ' + log.duration.toFixed(3) + ' s';
  for (const n of log.notes) noteMissing(n);
  $('log-controls').classList.remove('hidden');
  const slider = $('log-slider');
  slider.max = log.duration;
  let t = params.has('t') ? Number(params.get('t')) : 0;
  let inFlight = false, again = false;
  const show = async () => {
    if (inFlight) { again = true; return; }
    inFlight = true;
    $('log-time').textContent = t.toFixed(3) + ' s';
    try { apply(await getJson('api/log?t=' + t)); } catch (e) { $('status').textContent = String(e.message); }
    inFlight = false;
    if (again) { again = false; show(); }
  };
  slider.value = t;
  slider.addEventListener('input', () => { t = Number(slider.value); show(); });
  let playing = null;
  $('play').addEventListener('click', () => {
    if (playing) { clearInterval(playing); playing = null; $('play').textContent = 'play'; return; }
    $('play').textContent = 'pause';
    let last = performance.now();
    playing = setInterval(() => {
      const now = performance.now();
      t = Math.min(log.duration, t + (now - last) / 1000);
      last = now;
      slider.value = t;
      show();
      if (t >= log.duration) { clearInterval(playing); playing = null; $('play').textContent = 'play'; }
    }, 1000 / model.rate);
  });
  show();
}

getJson('api/model').then((m) => {
  $('title').textContent = 'lagrange view: ' + m.mode;
  build(m);
  if (m.mode === 'live') startLive();
  if (m.mode === 'urdf') startUrdf();
  if (m.mode === 'log') startLog();
}).catch((e) => { $('status').textContent = 'cannot load the model: ' + e.message; });
