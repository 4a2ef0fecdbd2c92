// The page of `tandem serve`: draws the scene and state the server sends
// over /ws, and sends the person's command (keyboard or gamepad) at 30 Hz.
// Frames are the server's: world z up, metres; poses [x, y, z, qx, qy, qz, qw].
// Rebuild the bundle the binary embeds with `npm run build` (in web/).

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { ConvexGeometry } from 'three/examples/jsm/geometries/ConvexGeometry.js';

const $ = (id) => document.getElementById(id);
const COMMAND_HZ = 30;
const GOAL_COLORS = [0xe67e22, 0x16a085, 0xc0392b, 0x8e44ad];

// State the browser tests read (window.tandem): the last messages and counts.
const page = {
  scene: null, state: null, episodes: [], errors: [], connected: false, fps: 0,
  trace: [], scenesReceived: 0, statesReceived: 0, closeCode: null, closeReason: '', sendCommands: true,
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
view.appendChild(renderer.domElement);
const world = new THREE.Scene();
world.background = new THREE.Color(0xf0f2f5);
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 20);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, renderer.domElement);
world.add(new THREE.HemisphereLight(0xffffff, 0x8a8f99, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1.5, -1, 3);
world.add(sun);
const grid = new THREE.GridHelper(2, 20, 0xb9bfc9, 0xd5d9e0);
grid.rotation.x = Math.PI / 2;
world.add(grid);

let sceneRoot = new THREE.Group();
world.add(sceneRoot);
let linkGroups = [];
const humanArrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, 0x2a6fdb, 0.03, 0.018);
const executedArrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, 0x1e8e3e, 0.03, 0.018);
const ellipsoid = new THREE.Mesh(
  new THREE.SphereGeometry(1, 24, 16),
  new THREE.MeshBasicMaterial({ color: 0x8e44ad, wireframe: true, transparent: true, opacity: 0.35 }),
);
ellipsoid.matrixAutoUpdate = false;
world.add(humanArrow, executedArrow, ellipsoid);

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

function setPose(object, p) {
  object.position.set(p[0], p[1], p[2]);
  object.quaternion.set(p[3], p[4], p[5], p[6]);
}

// A three.js mesh of one shape of the server's SceneView.
function shapeMesh(shape, material) {
  let geometry;
  switch (shape.kind) {
    case 'box': geometry = new THREE.BoxGeometry(...shape.size); break;
    case 'sphere': geometry = new THREE.SphereGeometry(shape.radius, 14, 10); break;
    case 'cylinder':
      geometry = new THREE.CylinderGeometry(shape.radius, shape.radius, shape.length, 24);
      geometry.rotateX(Math.PI / 2); // three's cylinders run along y, ours along z
      break;
    case 'capsule':
      geometry = new THREE.CapsuleGeometry(shape.radius, shape.length, 6, 16);
      geometry.rotateX(Math.PI / 2);
      break;
    case 'mesh':
      geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.Float32BufferAttribute(shape.vertices, 3));
      geometry.setIndex(shape.indices);
      geometry.computeVertexNormals();
      break;
    case 'hull': {
      const points = [];
      for (let i = 0; i + 2 < shape.points.length; i += 3) points.push(new THREE.Vector3(shape.points[i], shape.points[i + 1], shape.points[i + 2]));
      geometry = new ConvexGeometry(points);
      break;
    }
    default: return null;
  }
  const mesh = new THREE.Mesh(geometry, material);
  setPose(mesh, shape.pose);
  return mesh;
}

function buildScene(scene) {
  world.remove(sceneRoot);
  sceneRoot = new THREE.Group();
  const robotMaterial = new THREE.MeshStandardMaterial({ color: 0xe9edf5, roughness: 0.55, metalness: 0.05 });
  const obstacleMaterial = new THREE.MeshStandardMaterial({ color: 0x7d8794, roughness: 0.9, transparent: true, opacity: 0.55 });
  const objectMaterial = new THREE.MeshStandardMaterial({ color: 0xf39c12, roughness: 0.5 });
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
  for (const body of scene.obstacles) {
    const mesh = shapeMesh(body.shape, obstacleMaterial);
    if (mesh) { mesh.name = body.name; sceneRoot.add(mesh); }
  }
  for (const body of scene.objects) {
    const mesh = shapeMesh(body.shape, objectMaterial);
    if (mesh) { mesh.name = body.name; sceneRoot.add(mesh); }
  }
  scene.goals.forEach((goal, k) => {
    const color = GOAL_COLORS[k % GOAL_COLORS.length];
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
  });
  world.add(sceneRoot);
  // Frame the task: the planar arm from above, the Panda from its front left.
  if (scene.planar) {
    controls.target.set(0.25, 0.25, 0);
    camera.position.set(0.25, 0.0, 0.95);
  } else {
    controls.target.set(0.4, -0.05, 0.2);
    camera.position.set(1.7, 0.75, 0.95);
  }
  controls.update();
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

function drawState(state) {
  state.links.forEach((pose, k) => { if (linkGroups[k]) setPose(linkGroups[k], pose); });
  placeArrow(humanArrow, state.gripper, state.human, 1.2);
  placeArrow(executedArrow, state.gripper, state.executed, 1.2);
  placeEllipsoid(state.ellipsoid, state.gripper);
}

let frames = 0, fpsSince = performance.now();
function animate(now) {
  requestAnimationFrame(animate);
  pollGamepad();
  renderer.render(world, camera);
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

function showState(state) {
  $('status').textContent = state.stale_command ? `${state.status} (no command: holding)` : state.status;
  $('tick').textContent = fmt.us(state.tick_us);
  if (state.latency_us > 0) $('latency').textContent = fmt.us(state.latency_us); // states between commands carry none
  $('clearance').textContent = fmt.mm(state.clearance);
  $('minClearance').textContent = fmt.mm(state.min_clearance);
  $('time').textContent = `${state.time.toFixed(1)} s / ${state.steps}`;
  $('counts').textContent = `${state.commands} / ${state.rejected}`;
  const outcome = $('outcome');
  outcome.textContent = state.outcome ? `Episode over: ${state.outcome}. Reset to drive again.` : '';
  outcome.className = state.outcome || '';
  const bars = $('beliefs');
  if (bars.childNodes.length !== state.beliefs.length) {
    bars.innerHTML = '';
    state.beliefs.forEach((_, k) => {
      const name = page.scene?.goals[k]?.name ?? `goal ${k}`;
      const row = document.createElement('div');
      row.innerHTML = `<div>${name} <span class="p"></span></div><div class="bar"><div style="background:#${GOAL_COLORS[k % GOAL_COLORS.length].toString(16).padStart(6, '0')}"></div></div>`;
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
      log(`episode ${message.outcome} after ${message.time.toFixed(1)} s${message.file ? `, saved to ${message.file}` : ''}`, message.outcome !== 'success');
      break;
    case 'error':
      page.errors.push(message.message);
      log(message.message, true);
      break;
    default: log(`unknown message ${message.type}`, true);
  }
}

$('mode').addEventListener('change', () => send({ type: 'mode', mode: $('mode').value }));
$('task').addEventListener('change', () => send({ type: 'reset', task: $('task').value }));
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
  if (e.target instanceof HTMLSelectElement || !(e.code in KEYS)) return;
  held.add(e.code);
  e.preventDefault();
});
window.addEventListener('keyup', (e) => held.delete(e.code));
window.addEventListener('blur', () => held.clear());

let gamepadCommand = null;
function pollGamepad() {
  const pad = [...(navigator.getGamepads ? navigator.getGamepads() : [])].find((p) => p && p.connected);
  if (!pad) { gamepadCommand = null; return; }
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
