// The page of `tandem serve`: draws the scene and state the server sends
// over /ws, and sends the person's command (keyboard or gamepad) at 30 Hz.
// Frames are the server's: world z up, metres; poses [x, y, z, qx, qy, qz, qw].
// Rebuild the bundle the binary embeds with `npm run build` (in web/).

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { CSS2DRenderer } from 'three/examples/jsm/renderers/CSS2DRenderer.js';
import { COLORS, css, goalColors, gripperOutline, label, setPose, shapeMesh } from './meshes.js';

const $ = (id) => document.getElementById(id);
const COMMAND_HZ = 30;

// The axes' colours (index.html's legend and the triad) and keys.
const AXES = [
  { name: 'x', color: '#e53935', keys: 'W' },
  { name: 'y', color: '#43a047', keys: 'A' },
  { name: 'z', color: '#1e88e5', keys: 'R' },
];

// State the browser tests read (window.tandem): the last messages and counts.
const page = {
  scene: null, state: null, episodes: [], errors: [], connected: false, fps: 0,
  trace: [], scenesReceived: 0, statesReceived: 0, closeCode: null, closeReason: '', sendCommands: true,
  goalColors: [], objectColors: {},
};
window.tandem = page;

// ---------------------------------------------------------------- 3-D view
const view = $('view');
// A software renderer (SwiftShader: no GPU, e.g. headless Chromium) draws
// far fewer frames with antialiasing; leave it out there.
function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
  return !!info && /swiftshader|llvmpipe|software/i.test(gl.getParameter(info.UNMASKED_RENDERER_WEBGL));
}
const software = softwareRenderer();
const renderer = new THREE.WebGLRenderer({ antialias: !software, preserveDrawingBuffer: true });
renderer.setPixelRatio(software ? 1 : window.devicePixelRatio);
view.prepend(renderer.domElement);
// Goal names in the view, in their goal's colour (HTML over the canvas).
const labels = new CSS2DRenderer();
labels.domElement.id = 'labels';
view.prepend(labels.domElement);
const world = new THREE.Scene();
world.background = new THREE.Color(0xf0f2f5);
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 30);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, renderer.domElement);
world.add(new THREE.HemisphereLight(0xffffff, 0x8a8f99, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(-1, -1.5, 3);
world.add(sun);
let grid = null;

let sceneRoot = new THREE.Group();
world.add(sceneRoot);
let linkGroups = [];
let gripperLinksChosen = false;
const gripperShellMaterial = new THREE.MeshStandardMaterial({
  color: COLORS.shell, roughness: 0.55, transparent: true, opacity: 0.45, depthWrite: false,
});
const humanArrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, COLORS.command, 0.03, 0.018);
const executedArrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, COLORS.executed, 0.03, 0.018);
const ellipsoid = new THREE.Mesh(
  new THREE.SphereGeometry(1, 24, 16),
  new THREE.MeshBasicMaterial({ color: COLORS.ellipsoid, wireframe: true, transparent: true, opacity: 0.35 }),
);
ellipsoid.matrixAutoUpdate = false;
// The arrows start inside the hand: drawn over everything.
for (const arrow of [humanArrow, executedArrow]) {
  arrow.traverse((o) => { if (o.material) { o.material.depthTest = false; o.material.transparent = true; } o.renderOrder = 11; });
}
let gripper = new THREE.Group();
world.add(humanArrow, executedArrow, ellipsoid, gripper);

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h);
  labels.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

// The axis-aligned box around the scene's bodies, goals and robot base.
function sceneBounds(scene) {
  const box = new THREE.Box3(new THREE.Vector3(0, 0, 0), new THREE.Vector3(0, 0, 0.3));
  sceneRoot.updateMatrixWorld(true);
  for (const child of sceneRoot.children) if (child.isMesh && child.userData.frame) box.expandByObject(child);
  for (const goal of scene.goals) box.expandByPoint(new THREE.Vector3(...goal.position));
  return box;
}

// The default camera: behind the robot's base looking along +x, so that
// W (+x) moves the gripper into the screen and A (+y) to the left, with
// the whole scene (both Pandas and the table; the planar table) in view.
// It looks down steeply enough to see the gripper past the arm, and stands
// 30° to the right of straight behind so that x (into the screen) and z
// (up) do not point the same way on screen.
function frameScene(scene) {
  const bounds = sceneBounds(scene);
  const center = bounds.getCenter(new THREE.Vector3());
  if (!scene.planar) center.z = Math.min(center.z, 0.25); // aim at the work, not mid-arm
  const elevation = ((scene.planar ? 55 : 45) * Math.PI) / 180, azimuth = (30 * Math.PI) / 180;
  const direction = new THREE.Vector3(
    -Math.cos(elevation) * Math.cos(azimuth), -Math.cos(elevation) * Math.sin(azimuth), Math.sin(elevation),
  );
  const corners = [];
  for (const x of [bounds.min.x, bounds.max.x]) for (const y of [bounds.min.y, bounds.max.y]) for (const z of [bounds.min.z, bounds.max.z]) corners.push(new THREE.Vector3(x, y, z));
  controls.target.copy(center);
  // The nearest distance at which every corner is on screen (bisection).
  let near = 0.2, far = 10;
  for (let k = 0; k < 30; k++) {
    const d = (near + far) / 2;
    camera.position.copy(center).addScaledVector(direction, d);
    camera.lookAt(center);
    camera.updateMatrixWorld(true);
    const inside = corners.every((c) => {
      const p = c.clone().project(camera);
      return p.z < 1 && Math.abs(p.x) < 0.92 && Math.abs(p.y) < 0.9;
    });
    if (inside) far = d; else near = d;
  }
  camera.position.copy(center).addScaledVector(direction, far);
  controls.update();
}

function buildScene(scene) {
  world.remove(sceneRoot);
  sceneRoot.traverse((o) => { if (o.isCSS2DObject) o.element.remove(); });
  sceneRoot = new THREE.Group();
  const robotMaterial = new THREE.MeshStandardMaterial({ color: COLORS.robot, roughness: 0.55, metalness: 0.05 });
  const obstacleMaterial = new THREE.MeshStandardMaterial({ color: COLORS.obstacle, roughness: 0.9, transparent: true, opacity: 0.55 });
  const objectMaterial = new THREE.MeshStandardMaterial({ color: COLORS.object, roughness: 0.5 });
  page.goalColors = goalColors(scene.goals);
  page.objectColors = {};
  const goalColor = new Map(scene.goals.map((g, k) => [g.name, page.goalColors[k]]));
  linkGroups = scene.links.map((link) => {
    const group = new THREE.Group();
    group.name = link.name;
    for (const shape of link.shapes) {
      const mesh = shapeMesh(shape, robotMaterial);
      if (mesh) group.add(mesh);
    }
    sceneRoot.add(group);
    return group;
  });
  gripperLinksChosen = false;
  page.cloudPoints = 0;
  for (const body of scene.obstacles) {
    const mesh = shapeMesh(body.shape, obstacleMaterial);
    if (mesh) { mesh.name = body.name; mesh.userData.frame = true; sceneRoot.add(mesh); }
    if (mesh?.isPoints) page.cloudPoints += mesh.geometry.getAttribute('position').count;
  }
  for (const body of scene.objects) {
    // A goal's object in the goal's colour; any other object in the objects' one.
    const color = goalColor.get(body.name);
    const material = color === undefined ? objectMaterial : new THREE.MeshStandardMaterial({ color, roughness: 0.5 });
    const mesh = shapeMesh(body.shape, material);
    if (mesh) { mesh.name = body.name; mesh.userData.frame = true; sceneRoot.add(mesh); }
    page.objectColors[body.name] = css(color ?? COLORS.object);
  }
  scene.goals.forEach((goal, k) => {
    const color = page.goalColors[k];
    const points = goal.reference.map((p) => new THREE.Vector3(...p));
    if (points.length > 1) {
      // A tube: WebGL draws lines one pixel wide.
      const path = new THREE.CatmullRomCurve3(points);
      const tube = new THREE.TubeGeometry(path, Math.min(points.length * 2, 200), 0.003, 6, false);
      sceneRoot.add(new THREE.Mesh(tube, new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.8 })));
    }
    const marker = new THREE.Mesh(new THREE.SphereGeometry(0.008, 12, 8), new THREE.MeshBasicMaterial({ color }));
    marker.position.set(...goal.position);
    sceneRoot.add(marker);
    // The name under the goal's object (at its foot), the gripper comes from above.
    const object = scene.objects.find((o) => o.name === goal.name);
    const foot = object ? object.shape.pose[2] - (object.shape.size?.[2] ?? object.shape.length ?? 0) / 2 : goal.position[2];
    sceneRoot.add(label(goal.name, css(color), [goal.position[0], goal.position[1], foot]));
  });
  // The planar gripper moves 10 cm over a 50 × 50 cm table whose near-left
  // corner is the origin (planar_gripper.urdf); the scene has no table
  // body, so the floor grid stands for it.
  if (grid) world.remove(grid);
  grid = scene.planar
    ? new THREE.GridHelper(0.5, 10, 0xb9bfc9, 0xd5d9e0)
    : new THREE.GridHelper(2, 20, 0xb9bfc9, 0xd5d9e0);
  grid.rotation.x = Math.PI / 2;
  if (scene.planar) {
    grid.position.set(0.25, 0.25, 0);
    const table = new THREE.Mesh(new THREE.PlaneGeometry(0.5, 0.5), new THREE.MeshStandardMaterial({ color: COLORS.table, roughness: 1 }));
    table.position.set(0.25, 0.25, -0.001);
    table.userData.frame = true;
    sceneRoot.add(table);
  }
  world.add(grid);
  world.add(sceneRoot);
  world.remove(gripper);
  gripper = gripperOutline(scene.planar ? 'planar' : 'hand');
  gripper.visible = false;
  world.add(gripper);
  showLegend(scene);
  frameScene(scene);
}

// The legend's goal rows: each goal's name in its colour.
function showLegend(scene) {
  $('legendGoals').innerHTML = '';
  scene.goals.forEach((goal, k) => {
    const row = document.createElement('div');
    row.innerHTML = `<span style="background:${css(page.goalColors[k])}"></span>`;
    row.append(`goal "${goal.name}": object, path, belief`);
    $('legendGoals').appendChild(row);
  });
}

function placeArrow(arrow, origin, v, scale) {
  const length = Math.hypot(v[0], v[1], v[2]);
  arrow.visible = length > 1e-4;
  if (!arrow.visible) return;
  arrow.position.set(...origin);
  arrow.setDirection(new THREE.Vector3(v[0] / length, v[1] / length, v[2] / length));
  arrow.setLength(Math.max(length * scale, 0.04), 0.03, 0.018);
}

// The ellipsoid's semi-axes (columns) scaled so its largest is 8 cm.
function placeEllipsoid(axes, origin) {
  const lengths = axes.map((a) => Math.hypot(a[0], a[1], a[2]));
  const largest = Math.max(...lengths);
  ellipsoid.visible = largest > 1e-9;
  if (!ellipsoid.visible) return;
  const s = 0.08 / largest;
  const a = axes.map((v, k) => (lengths[k] * s < 0.004 ? v.map((x) => (x / (lengths[k] || 1)) * 0.004 / s) : v));
  ellipsoid.matrix.set(
    a[0][0] * s, a[1][0] * s, a[2][0] * s, origin[0],
    a[0][1] * s, a[1][1] * s, a[2][1] * s, origin[1],
    a[0][2] * s, a[1][2] * s, a[2][2] * s, origin[2],
    0, 0, 0, 1,
  );
}

// The links that make up the gripper (within 15 cm of its frame at the
// start) are drawn see-through, so the outline inside them shows.
function chooseGripperLinks(state) {
  gripperLinksChosen = true;
  state.links.forEach((pose, k) => {
    const d = Math.hypot(pose[0] - state.gripper[0], pose[1] - state.gripper[1], pose[2] - state.gripper[2]);
    if (d < 0.15 && linkGroups[k]) linkGroups[k].traverse((o) => { if (o.isMesh) o.material = gripperShellMaterial; });
  });
}

function drawState(state) {
  state.links.forEach((pose, k) => { if (linkGroups[k]) setPose(linkGroups[k], pose); });
  if (!gripperLinksChosen) chooseGripperLinks(state);
  if (state.gripper_pose) {
    setPose(gripper, state.gripper_pose);
    gripper.visible = true;
  }
  placeArrow(humanArrow, state.gripper, state.human, 1.2);
  placeArrow(executedArrow, state.gripper, state.executed, 1.2);
  placeEllipsoid(state.ellipsoid, state.gripper);
}

// The axis triad (bottom left of the view): world x, y, z as the camera
// sees them, each labelled with its key, redrawn every frame so that it
// turns with the view. SVG, so that the tests can read where it points.
const SVG = 'http://www.w3.org/2000/svg';
const triad = $('triad');
const TRIAD_CENTER = [75, 68], TRIAD_LENGTH = 32;
const triadParts = AXES.map((axis) => {
  const line = document.createElementNS(SVG, 'line');
  line.setAttribute('stroke', axis.color);
  line.setAttribute('stroke-width', '3');
  line.setAttribute('marker-end', `url(#head-${axis.name})`);
  line.dataset.axis = axis.name;
  const text = document.createElementNS(SVG, 'text');
  text.setAttribute('fill', axis.color);
  text.textContent = `${axis.name} (${axis.keys})`;
  text.dataset.axis = axis.name;
  const group = document.createElementNS(SVG, 'g');
  group.append(line, text);
  triad.appendChild(group);
  return { group, line, text };
});
const axisDirection = new THREE.Vector3();
let triadOrder = '';
function drawTriad() {
  camera.updateMatrixWorld();
  const depth = AXES.map((axis, k) => {
    axisDirection.set(k === 0 ? 1 : 0, k === 1 ? 1 : 0, k === 2 ? 1 : 0).transformDirection(camera.matrixWorldInverse);
    const dx = axisDirection.x * TRIAD_LENGTH, dy = -axisDirection.y * TRIAD_LENGTH;
    const { line, text } = triadParts[k];
    const [cx, cy] = TRIAD_CENTER;
    line.setAttribute('x1', cx);
    line.setAttribute('y1', cy);
    line.setAttribute('x2', (cx + dx).toFixed(1));
    line.setAttribute('y2', (cy + dy).toFixed(1));
    // The label beyond the tip, on the side the axis leans to, so that
    // labels of axes pointing nearly the same way do not overlap.
    const n = Math.hypot(dx, dy) || 1;
    const side = dx / n > 0.25 ? 'start' : dx / n < -0.25 ? 'end' : 'middle';
    text.setAttribute('text-anchor', side);
    text.setAttribute('x', (cx + dx + (dx / n) * 6).toFixed(1));
    text.setAttribute('y', (cy + dy + (dy / n) * 10 + 4).toFixed(1));
    return axisDirection.z;
  });
  // Axes pointing away from the viewer first, so nearer ones draw on top.
  const order = [0, 1, 2].sort((a, b) => depth[a] - depth[b]);
  if (order.join() !== triadOrder) {
    triadOrder = order.join();
    order.forEach((k) => triad.appendChild(triadParts[k].group));
  }
}

// For the tests: a world point's position on the page (CSS pixels).
window.tandemProject = (p) => {
  camera.updateMatrixWorld();
  const v = new THREE.Vector3(...p).project(camera);
  const r = renderer.domElement.getBoundingClientRect();
  return [r.left + ((v.x + 1) / 2) * r.width, r.top + ((1 - v.y) / 2) * r.height];
};

let frames = 0, fpsSince = performance.now();
function animate(now) {
  requestAnimationFrame(animate);
  pollGamepad();
  renderer.render(world, camera);
  labels.render(world, camera);
  drawTriad();
  frames += 1;
  if (now - fpsSince > 1000) {
    page.fps = (frames * 1000) / (now - fpsSince);
    $('fps').textContent = `${page.fps.toFixed(0)} Hz`;
    frames = 0;
    fpsSince = now;
  }
}
requestAnimationFrame(animate);

// ------------------------------------------------------------ readouts
function log(text, isError = false) {
  const line = document.createElement('div');
  line.textContent = `${new Date().toLocaleTimeString()} ${text}`;
  if (isError) line.className = 'error';
  $('log').prepend(line);
  while ($('log').childNodes.length > 40) $('log').lastChild.remove();
}

const fmt = {
  us: (v) => (v == null ? '–' : v < 1000 ? `${v.toFixed(0)} µs` : `${(v / 1000).toFixed(1)} ms`),
  mm: (v) => (v == null ? '∞' : `${(v * 1000).toFixed(1)} mm`),
};

// A body's name as a person reads it: the other Panda's spheres are one arm.
const bodyName = (name) => name.replace(/^other_arm_\d+$/, 'other arm');

// An episode's outcome and why, from a state or an episode message
// (`outcome`, `reason`: the reason's name, `reason_detail`: it in words):
// "collision — panda_hand touched table", "failed (stopped short) — the
// operator stopped 3.2 cm from the goal (within 1 cm counts)".
function ending({ outcome, reason, reason_detail: detail }) {
  const named = reason && reason !== outcome ? ` (${reason.replaceAll('_', ' ')})` : '';
  const why = detail ? ` — ${detail.replace(/other_arm_\d+/g, 'other arm')}` : '';
  return `${outcome}${named}${why}`;
}

function showState(state) {
  const waiting = state.status === 'waiting';
  $('status').textContent = waiting
    ? 'waiting to start'
    : state.stale_command ? `${state.status} (no command: holding)` : state.status;
  $('hints').classList.toggle('waiting', waiting && !state.outcome);
  $('tick').textContent = waiting ? '–' : fmt.us(state.tick_us);
  if (state.latency_us > 0) $('latency').textContent = fmt.us(state.latency_us); // states between commands carry none
  $('clearance').textContent = state.nearest
    ? `nearest: ${bodyName(state.nearest[0])} ↔ ${bodyName(state.nearest[1])}, ${fmt.mm(state.clearance)}`
    : `nearest: ${fmt.mm(state.clearance)}`;
  $('minClearance').textContent = fmt.mm(state.min_clearance);
  $('time').textContent = `${state.time.toFixed(1)} s / ${state.steps}`;
  $('counts').textContent = `${state.commands} / ${state.rejected}`;
  // How and why the episode ended; after a reset, the last episode's
  // until the next one starts.
  const outcome = $('outcome');
  const last = page.episodes[page.episodes.length - 1];
  if (state.outcome) {
    outcome.textContent = `Episode over: ${ending(state)}. Reset to drive again.`;
    outcome.className = state.outcome;
  } else if (waiting && last) {
    outcome.textContent = `Last episode: ${ending(last)}.`;
    outcome.className = 'last';
  } else {
    outcome.textContent = '';
    outcome.className = '';
  }
  const bars = $('beliefs');
  if (bars.childNodes.length !== state.beliefs.length) {
    bars.innerHTML = '';
    state.beliefs.forEach((_, k) => {
      const name = page.scene?.goals[k]?.name ?? `goal ${k}`;
      const row = document.createElement('div');
      const color = css(page.goalColors[k] ?? COLORS.object);
      row.innerHTML = `<div><span class="swatch" style="background:${color}"></span><span class="name"></span> <span class="p"></span></div><div class="bar"><div style="background:${color}"></div></div>`;
      row.querySelector('.name').textContent = name;
      bars.appendChild(row);
    });
  }
  state.beliefs.forEach((b, k) => {
    const row = bars.childNodes[k];
    row.querySelector('.p').textContent = `${(b * 100).toFixed(0)} %`;
    row.querySelector('.bar > div').style.width = `${(b * 100).toFixed(1)}%`;
  });
}

// ---------------------------------------------------------- connection
let socket = null;
let retry = null;

function send(message, raw = false) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(raw ? message : JSON.stringify(message));
}
// For the browser tests: send any message (`raw`: a string as it is).
window.tandemSend = send;

function connect() {
  clearTimeout(retry);
  const url = `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`;
  socket = new WebSocket(url);
  socket.onopen = () => {
    page.connected = true;
    $('connection').textContent = `connected to ${location.host}`;
    $('connection').className = 'ok';
  };
  socket.onclose = (event) => {
    page.connected = false;
    page.closeCode = event.code;
    page.closeReason = event.reason;
    const why = event.reason ? `: ${event.reason}` : '';
    $('connection').textContent = `disconnected (code ${event.code}${why}); retrying…`;
    $('connection').className = 'bad';
    log(`connection closed (code ${event.code}${why})`, event.code !== 1000);
    retry = setTimeout(connect, 2000);
  };
  socket.onmessage = (event) => receive(JSON.parse(event.data));
}

function receive(message) {
  switch (message.type) {
    case 'hello': log(`server tandem ${message.version}, control at ${message.rate_hz} Hz`); break;
    case 'preparing':
      $('busy').style.display = 'block';
      log(`preparing ${message.task} (seed ${message.seed})…`);
      break;
    case 'scene':
      $('busy').style.display = 'none';
      page.scene = message;
      page.scenesReceived += 1;
      page.trace = [];
      page.state = null;
      $('task').value = message.task;
      $('mode').innerHTML = message.modes.map((m) => `<option>${m}</option>`).join('');
      $('mode').value = message.mode;
      $('beliefs').innerHTML = '';
      buildScene(message);
      log(`${message.task}: ${message.problem}, seed ${message.seed}, ${message.goals.length} goal(s)`);
      break;
    case 'state':
      page.state = message;
      page.statesReceived += 1;
      if (page.trace.length < 100000) page.trace.push(message.q); // every configuration shown, for the tests
      if ($('mode').value !== message.mode) $('mode').value = message.mode;
      drawState(message);
      showState(message);
      break;
    case 'episode':
      page.episodes.push(message);
      log(`episode ${ending(message)}, after ${message.time.toFixed(1)} s${message.file ? `, saved to ${message.file}` : ''}`, message.outcome !== 'success');
      break;
    case 'error':
      page.errors.push(message.message);
      log(message.message, true);
      break;
    default: log(`unknown message ${message.type}`, true);
  }
}

// Controls give the keyboard back after use: a focused select or slider
// would otherwise take the arrow keys (and a select the letters).
$('mode').addEventListener('change', () => { send({ type: 'mode', mode: $('mode').value }); $('mode').blur(); });
$('task').addEventListener('change', () => { send({ type: 'reset', task: $('task').value }); $('task').blur(); });
$('speed').addEventListener('change', () => $('speed').blur());
$('reset').addEventListener('click', () => send({ type: 'reset' }));
$('next').addEventListener('click', () => send({ type: 'reset', seed: (page.scene?.seed ?? 0) + 1 }));
$('speed').addEventListener('input', () => { $('speedValue').textContent = Number($('speed').value).toFixed(2); });

// --------------------------------------------------------------- input
// Keys in world axes: x away from the robot's base, y to its left, z up.
const KEYS = {
  KeyW: [1, 0, 0], ArrowUp: [1, 0, 0], KeyS: [-1, 0, 0], ArrowDown: [-1, 0, 0],
  KeyA: [0, 1, 0], ArrowLeft: [0, 1, 0], KeyD: [0, -1, 0], ArrowRight: [0, -1, 0],
  KeyR: [0, 0, 1], PageUp: [0, 0, 1], KeyF: [0, 0, -1], PageDown: [0, 0, -1],
};
const held = new Set();
window.addEventListener('keydown', (e) => {
  if (!(e.code in KEYS)) return;
  const control = e.target instanceof HTMLSelectElement || e.target instanceof HTMLInputElement;
  if (control && !e.code.startsWith('Key')) return; // arrows and page keys stay the control's
  held.add(e.code);
  e.preventDefault();
});
window.addEventListener('keyup', (e) => held.delete(e.code));
window.addEventListener('blur', () => held.clear());

let gamepadCommand = null;
function pollGamepad() {
  const pad = [...(navigator.getGamepads ? navigator.getGamepads() : [])].find((p) => p && p.connected);
  if (!pad) {
    if (gamepadCommand) $('device').textContent = '';
    gamepadCommand = null;
    return;
  }
  $('device').textContent = `gamepad: ${pad.id}`;
  const dead = (v) => (Math.abs(v) < 0.15 ? 0 : v);
  // Left stick: x (forward/back), y (left/right); right stick vertical: z.
  gamepadCommand = [-dead(pad.axes[1] ?? 0), -dead(pad.axes[0] ?? 0), -dead(pad.axes[3] ?? 0)];
}

function currentCommand() {
  const speed = Number($('speed').value);
  let v = [0, 0, 0];
  for (const code of held) KEYS[code].forEach((x, k) => { v[k] += x; });
  const norm = Math.hypot(...v);
  if (norm > 0) return v.map((x) => (x / norm) * speed);
  if (gamepadCommand) {
    const g = gamepadCommand;
    const m = Math.min(Math.hypot(...g), 1);
    const n = Math.hypot(...g) || 1;
    v = g.map((x) => (x / n) * m * speed);
  }
  return v;
}

setInterval(() => { if (page.sendCommands) send({ type: 'command', linear: currentCommand() }); }, 1000 / COMMAND_HZ);
connect();
