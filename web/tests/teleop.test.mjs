// End-to-end tests of `tandem serve` in headless Chromium (Debian's
// /usr/bin/chromium, driven by playwright-core): the page loads and draws,
// shows the axis triad and the keys, names the nearest pair, waits for the
// first command (a page never driven is not recorded), moves the gripper
// the way the triad's x arrow points when W is held (both tasks), draws
// each goal in its belief bar's colour, a scripted keyboard drives the
// gripper toward the box under every mode without a collision, each driven
// episode is recorded and reported once, a finished episode shows why it
// ended (the server's reason), and NaN, malformed and oversized messages from the
// page leave the server healthy. Every
// configuration the page was shown is judged independently of tandem's
// sphere model: example-robot-data's Panda meshes against the box, through
// Pinocchio and coal (python_ref/grasp_mesh_check.py).
//
//   node tests/teleop.test.mjs [--bin PATH] [--python PATH] [--screenshot FILE]
//
// Exit status 0 when every check passed; each failure is printed.

import { chromium } from 'playwright-core';
import { spawn, spawnSync } from 'node:child_process';
import { mkdtempSync, readdirSync, existsSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';

const args = process.argv.slice(2);
const option = (name, fallback) => { const i = args.indexOf(name); return i >= 0 ? args[i + 1] : fallback; };
const bin = resolve(option('--bin', '../target/debug/tandem'));
const screenshot = option('--screenshot', join(tmpdir(), 'tandem-teleop.png'));
const browserPath = process.env.CHROMIUM ?? '/usr/bin/chromium';
const python = resolve(option('--python', '../python_ref/.venv/bin/python'));

// Rotation matrix (rows) of a unit quaternion [qx, qy, qz, qw].
function rotation([x, y, z, w]) {
  return [
    [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
  ];
}

// Clearances of the hand, arm, fingers and pads to the box over every
// configuration, with example-robot-data's meshes (coal).
function meshClearances(joints, box, configurations) {
  const pose = box.shape.pose;
  const request = {
    joints,
    margin: 0,
    grasps: configurations.map((q) => ({
      q,
      final: false,
      box: { half_extents: box.shape.size.map((v) => v / 2), translation: pose.slice(0, 3), rotation: rotation(pose.slice(3)) },
    })),
  };
  const run = spawnSync(python, [resolve('../python_ref/grasp_mesh_check.py')], { input: JSON.stringify(request), maxBuffer: 1 << 28 });
  if (run.status !== 0) throw new Error(`grasp_mesh_check.py failed (${python}): ${run.stderr}`);
  return JSON.parse(run.stdout).worst_motion;
}

const failures = [];
function check(condition, what) {
  console.log(`${condition ? 'ok  ' : 'FAIL'} ${what}`);
  if (!condition) failures.push(what);
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function startServer(recordDir, args = []) {
  if (!existsSync(bin)) throw new Error(`no tandem binary at ${bin} (cargo build first, or --bin PATH)`);
  const server = spawn(bin, ['serve', ...args, '--port', '0', '--record-dir', recordDir], { stdio: ['ignore', 'pipe', 'inherit'] });
  const address = await new Promise((resolveAddress, reject) => {
    let out = '';
    server.stdout.on('data', (chunk) => {
      out += chunk;
      const m = out.match(/http:\/\/([0-9.]+:[0-9]+)\//);
      if (m) resolveAddress(m[1]);
    });
    server.on('exit', (code) => reject(new Error(`tandem serve exited with ${code}: ${out}`)));
    setTimeout(() => reject(new Error(`tandem serve printed no address in 30 s: ${out}`)), 30000);
  });
  return { server, address };
}

async function waitFor(page, predicate, arg, timeout = 30000) {
  await page.waitForFunction(predicate, arg, { timeout, polling: 50 });
}

// The server's reasons (tandem::sim::Reason::NAMES).
const REASONS = ['success', 'collision', 'timeout', 'stopped_short', 'orientation_off', 'not_between_pads',
  'outside_footprint', 'touching_object', 'judge_declined'];

const parquetFiles = (dir) => readdirSync(dir).filter((f) => f.endsWith('.parquet'));
const cosine = (a, b) => (a[0] * b[0] + a[1] * b[1]) / (Math.hypot(...a) * Math.hypot(...b) || 1);

// The axis triad as drawn: per axis its arrow on screen (dx, dy in CSS
// pixels, y down), its stroke colour and its label.
async function triad(page) {
  return page.evaluate(() => Object.fromEntries(['x', 'y', 'z'].map((axis) => {
    const line = document.querySelector(`#triad line[data-axis="${axis}"]`);
    const text = document.querySelector(`#triad text[data-axis="${axis}"]`);
    if (!line || !text) return [axis, null];
    const at = (name) => Number(line.getAttribute(name));
    return [axis, { arrow: [at('x2') - at('x1'), at('y2') - at('y1')], color: line.getAttribute('stroke'), label: text.textContent }];
  })));
}

// Holds `key` for `ms`; returns the gripper's world motion, its motion on
// screen (CSS pixels, y down) and the command the page sent.
async function holdKey(page, key, ms) {
  const before = await page.evaluate(() => window.tandem.state.gripper);
  await page.keyboard.down(key);
  await sleep(ms);
  const [after, human] = await page.evaluate(() => [window.tandem.state.gripper, window.tandem.state.human]);
  await page.keyboard.up(key);
  const [p0, p1] = await page.evaluate(([a, b]) => [window.tandemProject(a), window.tandemProject(b)], [before, after]);
  return { world: after.map((v, k) => v - before[k]), screen: [p1[0] - p0[0], p1[1] - p0[1]], human };
}

// W (+x) moves the gripper along world +x, and on screen the way the
// triad's x arrow points (A, +y, likewise with the y arrow).
async function checkKeysFollowTheTriad(page, task) {
  await sleep(300); // a few frames at the current camera
  const axes = await triad(page);
  for (const [key, k, axis] of [['KeyW', 0, 'x'], ['KeyA', 1, 'y']]) {
    const moved = await holdKey(page, key, 1200);
    const length = Math.hypot(...moved.world);
    const along = moved.world[k] / (length || 1);
    const agree = cosine(moved.screen, axes[axis].arrow);
    check(moved.human[k] > 0.05 && length > 0.02 && along > 0.7,
      `${task}: ${key} commands +${axis} (${moved.human.map((v) => v.toFixed(2)).join(', ')} m/s) and the gripper moves ${(length * 100).toFixed(1)} cm, ${(along * 100).toFixed(0)} % along +${axis}`);
    check(Math.hypot(...moved.screen) > 5 && agree > 0.8,
      `${task}: on screen the gripper moves (${moved.screen.map((v) => v.toFixed(0)).join(', ')}) px the way the triad's ${axis} arrow points (${axes[axis].arrow.map((v) => v.toFixed(0)).join(', ')}; cosine ${agree.toFixed(2)})`);
  }
}

// Each goal's object, its belief bar and its legend row share one colour,
// and no two goals share one.
async function checkGoalColours(page, task) {
  const seen = await page.evaluate(() => {
    const rgb = (c) => { const m = c.match(/\d+/g).map(Number); return `#${m.slice(0, 3).map((v) => v.toString(16).padStart(2, '0')).join('')}`; };
    const bars = [...document.querySelectorAll('#beliefs .bar > div')].map((d) => rgb(d.style.background));
    const legend = [...document.querySelectorAll('#legendGoals span')].map((d) => rgb(d.style.background));
    return { goals: window.tandem.scene.goals.map((g) => g.name), objects: window.tandem.objectColors, bars, legend };
  });
  const objects = seen.goals.map((g) => seen.objects[g]);
  check(objects.every((c, k) => c === seen.bars[k] && c === seen.legend[k]) && new Set(objects).size === objects.length,
    `${task}: each goal is drawn in its belief bar's colour (${seen.goals.map((g, k) => `${g} ${objects[k]}/${seen.bars[k]}`).join(', ')})`);
  return Object.fromEntries(seen.goals.map((g, k) => [g, objects[k]]));
}

// Drives toward goal 0 with the keyboard: hold the key of each axis whose
// error exceeds 1.5 cm, until the episode ends or `seconds` pass. Returns
// the states seen.
async function drive(page, seconds, screenshotPath = null) {
  const goal = await page.evaluate(() => window.tandem.scene.goals[0].position);
  const keys = [['KeyW', 'KeyS'], ['KeyA', 'KeyD'], ['KeyR', 'KeyF']];
  const down = new Set();
  const seen = [];
  const began = Date.now();
  const until = began + seconds * 1000;
  let shot = !screenshotPath;
  while (Date.now() < until) {
    // A picture while the arm moves: the commanded and executed arrows show.
    if (!shot && Date.now() > began + 2500) {
      await page.screenshot({ path: screenshotPath });
      shot = true;
    }
    const state = await page.evaluate(() => window.tandem.state);
    seen.push(state);
    if (state.outcome) break;
    // Above the box first, then down: the approach the dissertation's operators take.
    const above = [goal[0], goal[1], goal[2] + 0.08];
    const horizontal = Math.hypot(state.gripper[0] - goal[0], state.gripper[1] - goal[1]);
    const target = horizontal > 0.03 ? above : goal;
    const want = new Set();
    for (let k = 0; k < 3; k++) {
      const error = target[k] - state.gripper[k];
      if (Math.abs(error) > 0.015) want.add(keys[k][error > 0 ? 0 : 1]);
    }
    for (const key of down) if (!want.has(key)) { await page.keyboard.up(key); down.delete(key); }
    for (const key of want) if (!down.has(key)) { await page.keyboard.down(key); down.add(key); }
    await sleep(60);
  }
  for (const key of down) await page.keyboard.up(key);
  return seen;
}

// `tandem serve PROBLEM --point-cloud FILE`: the cloud's points reach the
// page and are drawn, every one, and the arm still drives beside them.
async function checkPointCloud(browser) {
  const recordDir = mkdtempSync(join(tmpdir(), 'tandem-teleop-cloud-'));
  // A wall behind the robot (x = -0.5 m), 2 cm apart, as an ASCII PLY.
  const wall = [];
  for (let i = 0; i <= 30; i++) for (let j = 0; j <= 30; j++) wall.push(`-0.5 ${(-0.3 + 0.02 * i).toFixed(3)} ${(0.1 + 0.02 * j).toFixed(3)}`);
  const cloud = join(recordDir, 'wall.ply');
  writeFileSync(cloud, `ply\nformat ascii 1.0\nelement vertex ${wall.length}\nproperty float x\nproperty float y\nproperty float z\nend_header\n${wall.join('\n')}\n`);
  const { server, address } = await startServer(recordDir, ['builtin:panda_grasp_box', '--point-cloud', cloud, '--point-radius', '0.01']);
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    await page.goto(`http://${address}`);
    await waitFor(page, () => window.tandem.scene && window.tandem.state);
    const seen = await page.evaluate(() => {
      const body = window.tandem.scene.obstacles.find((o) => o.shape.kind === 'points');
      return { name: body?.name, sent: body ? body.shape.points.length / 3 : 0, radius: body?.shape.radius, drawn: window.tandem.cloudPoints };
    });
    check(seen.name === 'wall' && seen.sent === wall.length && seen.drawn === wall.length && seen.radius === 0.01,
      `--point-cloud: the cloud reaches the page and is drawn (${seen.name}: ${seen.drawn} of ${seen.sent} points, radius ${seen.radius} m)`);
    await page.keyboard.down('KeyR');
    await waitFor(page, () => window.tandem.state.steps > 5, undefined, 10000).catch(() => {});
    await page.keyboard.up('KeyR');
    check(await page.evaluate(() => window.tandem.state.steps > 5), 'the arm drives with the cloud in the scene');
    check(errors.length === 0, `no script errors with a cloud (${errors.join('; ')})`);
    await page.close();
  } finally {
    server.kill('SIGTERM');
  }
}

async function main() {
  const recordDir = mkdtempSync(join(tmpdir(), 'tandem-teleop-'));
  const { server, address } = await startServer(recordDir);
  const base = `http://${address}`;
  const browser = await chromium.launch({
    executablePath: browserPath,
    args: ['--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-quic',
      '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
    const consoleErrors = [];
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    // A stand-in gamepad the test can move (headless Chromium has none).
    await page.addInitScript(() => {
      window.testPad = null;
      navigator.getGamepads = () => [window.testPad];
    });
    await page.goto(base);
    await waitFor(page, () => window.tandem.scene && window.tandem.state);
    const scene = await page.evaluate(() => window.tandem.scene);
    check(scene.task === 'reach-grasp' && scene.links.length >= 8, `the page loads the reach-and-grasp scene (${scene.links.length} links)`);
    check(scene.modes.length === 8, `the page offers every mode (${scene.modes.join(', ')})`);

    // The 3-D view draws something: the canvas has many distinct colours.
    await sleep(500);
    const colours = await page.evaluate(() => {
      const gl = document.querySelector('#view canvas');
      const c = document.createElement('canvas');
      c.width = 160; c.height = 100;
      const ctx = c.getContext('2d');
      ctx.drawImage(gl, 0, 0, c.width, c.height);
      const data = ctx.getImageData(0, 0, c.width, c.height).data;
      const set = new Set();
      for (let i = 0; i < data.length; i += 4) set.add((data[i] >> 3) << 10 | (data[i + 1] >> 3) << 5 | (data[i + 2] >> 3));
      return set.size;
    });
    check(colours > 20, `the 3-D view renders the scene (${colours} distinct colours)`);

    // The view explains itself: the axis triad and the keys.
    const axes = await triad(page);
    check(['x', 'y', 'z'].every((a) => axes[a] && Math.hypot(...axes[a].arrow) > 8)
      && axes.x.color === '#e53935' && axes.y.color === '#43a047' && axes.z.color === '#1e88e5'
      && axes.x.label === 'x (W)' && axes.y.label === 'y (A)' && axes.z.label === 'z (R)',
    `the axis triad is drawn (${['x', 'y', 'z'].map((a) => `${axes[a]?.label} ${axes[a]?.color} (${axes[a]?.arrow.map((v) => v.toFixed(0)).join(', ')})`).join('; ')})`);
    // The default camera looks along +x from behind the robot: x points
    // up the screen (into it), y to the left, z up.
    check(axes.x.arrow[1] < -5 && axes.y.arrow[0] < -5 && axes.z.arrow[1] < -5 && Math.abs(axes.z.arrow[0]) < 1,
      'the default camera looks from behind the robot: x into the screen, y to the left, z up');
    const triadBox = await page.evaluate(() => { const r = document.getElementById('triad').getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; });
    check(triadBox[2] > 50 && triadBox[1] + triadBox[3] <= 760, `the triad is in sight (${triadBox.map((v) => v.toFixed(0)).join(', ')})`);
    const hints = await page.evaluate(() => [document.getElementById('hints').textContent.replace(/\s+/g, ' '), document.getElementById('hints').checkVisibility()]);
    check(hints[1] && hints[0].includes('W/S ±x · A/D ±y · R/F ±z') && hints[0].includes('↑/↓ ±x · ←/→ ±y · PgUp/PgDn ±z'),
      `the keys are shown in the view ("${hints[0].trim().slice(0, 90)}…")`);
    check(await page.evaluate(() => !document.body.innerText.includes('keyboard')), 'no stray "keyboard" on the page');
    await checkGoalColours(page, 'reach-grasp');

    // A page not yet driven: the episode waits (clock at zero), the
    // nearest pair is named, and a reset saves nothing.
    await sleep(1500);
    const waiting = await page.evaluate(() => [window.tandem.state, document.getElementById('status').textContent, document.getElementById('clearance').textContent]);
    check(waiting[0].status === 'waiting' && waiting[0].steps === 0 && waiting[0].time === 0 && waiting[1] === 'waiting to start',
      `before the first command the clock does not run (${waiting[0].status}, ${waiting[0].time} s, ${waiting[0].steps} ticks; "${waiting[1]}")`);
    check(Array.isArray(waiting[0].nearest) && waiting[0].nearest.length === 2 && waiting[2].includes(`${waiting[0].nearest[0]} ↔ `) && waiting[2].startsWith('nearest: '),
      `the nearest pair is named ("${waiting[2]}")`);
    const episodesBefore = await page.evaluate(() => window.tandem.episodes.length);
    const firstScenes = await page.evaluate(() => window.tandem.scenesReceived);
    await page.click('#reset');
    await waitFor(page, (n) => window.tandem.scenesReceived > n && window.tandem.state, firstScenes);
    await sleep(300);
    check(parquetFiles(recordDir).length === 0 && (await page.evaluate(() => window.tandem.episodes.length)) === episodesBefore,
      `a page never driven is not recorded (${parquetFiles(recordDir).length} files in the record folder)`);

    // W moves the gripper the way the triad's x arrow points (this drives
    // the episode: the first reset below saves it). The clock starts then.
    await sleep(600);
    const idle = await page.evaluate(() => window.tandem.state);
    const firstKey = Date.now();
    await checkKeysFollowTheTriad(page, 'reach-grasp');
    const started = await page.evaluate(() => window.tandem.state);
    const elapsed = (Date.now() - firstKey) / 1000;
    check(idle.steps === 0 && started.steps > 0 && started.time > 0 && started.time <= elapsed + 0.2,
      `the clock starts at the first command (${idle.steps} ticks before it; ${started.time.toFixed(1)} s of episode in ${elapsed.toFixed(1)} s since the first key)`);

    // Every mode: reset, drive toward the box, no collision.
    const shown = [];
    const endings = []; // the episodes that ended while driving: mode, state, what the page said
    for (const mode of scene.modes) {
      const scenes = await page.evaluate(() => window.tandem.scenesReceived);
      await page.selectOption('#mode', mode);
      await page.click('#reset');
      await waitFor(page, ([m, n]) => window.tandem.scenesReceived > n && window.tandem.state?.mode === m && !window.tandem.state.outcome, [mode, scenes]);
      const start = await page.evaluate(() => window.tandem.state.gripper);
      const goal = scene.goals[0].position;
      const seen = await drive(page, 12, mode === 'sos' ? screenshot : null);
      const last = seen[seen.length - 1];
      const d0 = Math.hypot(...start.map((x, k) => x - goal[k]));
      const d1 = Math.hypot(...last.gripper.map((x, k) => x - goal[k]));
      const collided = seen.some((s) => s.outcome === 'collision');
      const minClearance = Math.min(...seen.map((s) => (s.min_clearance == null ? Infinity : s.min_clearance)));
      check(d1 < 0.5 * d0, `${mode}: the gripper came from ${(d0 * 100).toFixed(1)} cm to ${(d1 * 100).toFixed(1)} cm of the box (${last.outcome ?? 'running'})`);
      check(!collided && minClearance >= 0, `${mode}: no collision (closest ${(minClearance * 1000).toFixed(1)} mm)`);
      shown.push(...(await page.evaluate(() => window.tandem.trace)));
      if (last.outcome) endings.push([mode, last, await page.evaluate(() => document.getElementById('outcome').textContent)]);
    }
    check(endings.every(([, s, text]) => REASONS.includes(s.reason) && s.reason_detail && text.startsWith(`Episode over: ${s.outcome}`) && text.includes(s.reason_detail)),
      `every episode that ended while driving says why on the page (${endings.map(([m, , text]) => `${m}: "${text}"`).join('; ') || 'none ended by itself'})`);
    const box = scene.objects.find((o) => o.name === 'box');
    const worst = meshClearances(scene.joints, box, shown);
    const parts = Object.entries(worst).map(([k, v]) => `${k} ${(v * 1000).toFixed(1)} mm`).join(', ');
    check(Object.values(worst).every((v) => v >= 0), `every configuration shown (${shown.length}) keeps clear of the box with the real meshes (coal: ${parts})`);
    console.log(`screenshot (sum-of-squares, while driving): ${screenshot}`);
    const fps = await page.evaluate(() => window.tandem.fps);
    console.log(`page frame rate in headless Chromium: ${fps.toFixed(1)} Hz`);
    check(fps > 1, `the page keeps drawing (${fps.toFixed(1)} frames per second)`);

    // The reset before each mode saved the previous episode (the first
    // one's was the keys' check): every driven episode, and only those.
    await page.click('#reset');
    await sleep(1000);
    const files = parquetFiles(recordDir);
    check(files.length === scene.modes.length + 1, `each driven episode was saved as Parquet (${files.length} files for ${scene.modes.length + 1} episodes)`);
    const [episodes, shownEnding] = await page.evaluate(() => [window.tandem.episodes, document.getElementById('outcome').textContent]);
    check(episodes.length === scene.modes.length + 1, `each driven episode was reported to the page once (${episodes.length} episode messages)`);
    // The last one (ended by this reset, or by itself): its outcome and
    // reason stay on the page until the next episode starts.
    const lastEpisode = episodes[episodes.length - 1] ?? {};
    check(REASONS.includes(lastEpisode.reason) && lastEpisode.reason_detail?.length > 0
      && shownEnding.startsWith(`Last episode: ${lastEpisode.outcome}`) && shownEnding.includes(lastEpisode.reason_detail),
    `a finished episode shows why it ended ("${shownEnding}"; reason ${lastEpisode.reason})`);

    // The gamepad: the left stick pushed forward commands +x at the slider's speed.
    await page.evaluate(() => { window.testPad = { id: 'test pad', connected: true, axes: [0, -1, 0, 0], buttons: [] }; });
    await waitFor(page, () => window.tandem.state.human[0] > 0.05, undefined, 5000).catch(() => {});
    const pad = await page.evaluate(() => [window.tandem.state.human, document.getElementById('device').textContent]);
    check(Math.abs(pad[0][0] - 0.1) < 1e-9 && Math.abs(pad[0][1]) < 1e-9 && pad[1].includes('test pad'),
      `the gamepad's left stick drives +x (command ${pad[0].map((v) => v.toFixed(3)).join(', ')} m/s; ${pad[1]})`);
    await page.evaluate(() => { window.testPad = null; });

    // NaN from the page: the arbiter holds and says so.
    await page.evaluate(() => {
      window.tandem.sendCommands = false;
      window.tandemNaN = setInterval(() => window.tandemSend({ type: 'command', linear: [NaN, 0, 0] }), 20);
    });
    // A hold brakes within the motion limits, then stands still.
    await waitFor(page, () => window.tandem.state.status === 'invalid_command'
      && Math.hypot(...window.tandem.state.executed) < 1e-9, undefined, 5000).catch(() => {});
    const held = await page.evaluate(() => window.tandem.state);
    check(held.status === 'invalid_command' && Math.hypot(...held.executed) < 1e-9, `a NaN command holds the arm (status ${held.status})`);
    await page.evaluate(() => { clearInterval(window.tandemNaN); window.tandem.sendCommands = true; });

    // Malformed and oversized messages: an error on the page, then a
    // closed connection that the page reports and re-opens.
    const errorsBefore = await page.evaluate(() => window.tandem.errors.length);
    await page.evaluate(() => window.tandemSend('{"type":"command","linear":[1,2]}', true));
    await waitFor(page, (n) => window.tandem.errors.length > n, errorsBefore, 5000).catch(() => {});
    check(await page.evaluate((n) => window.tandem.errors.length > n, errorsBefore), 'a malformed message is reported on the page');
    await page.evaluate(() => window.tandemSend('x'.repeat(100000), true));
    await waitFor(page, () => window.tandem.closeCode !== null, undefined, 5000).catch(() => {});
    const closed = await page.evaluate(() => [window.tandem.closeCode, window.tandem.closeReason]);
    check(closed[0] === 1009, `an oversized message closes the connection with 1009 (${closed[0]} "${closed[1]}")`);
    // A new connection is a new session, waiting for its first command.
    const scenesBeforeReconnect = await page.evaluate(() => window.tandem.scenesReceived);
    await waitFor(page, (n) => window.tandem.connected && window.tandem.scenesReceived > n && window.tandem.state, scenesBeforeReconnect, 20000).catch(() => {});
    await page.keyboard.down('KeyR');
    await waitFor(page, () => window.tandem.state.steps > 5, undefined, 5000).catch(() => {});
    await page.keyboard.up('KeyR');
    check(await page.evaluate(() => window.tandem.connected && window.tandem.state.steps > 5), 'the page reconnects and drives again');

    // The planar task: picked with the task menu (which hands the keys
    // back), its cylinders drawn in their names' colours, W along the triad.
    const scenesBefore = await page.evaluate(() => window.tandem.scenesReceived);
    await page.selectOption('#task', 'planar');
    await waitFor(page, (n) => window.tandem.scenesReceived > n && window.tandem.scene.task === 'planar' && window.tandem.state, scenesBefore);
    const planarAxes = await triad(page);
    check(planarAxes.x.arrow[1] < -5 && planarAxes.y.arrow[0] < -5, 'planar: the default camera looks from behind too: x into the screen, y to the left');
    const planarColours = await checkGoalColours(page, 'planar');
    const rgb = (hex) => [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16));
    const [red, yellow] = [rgb(planarColours.red ?? '#000000'), rgb(planarColours.yellow ?? '#000000')];
    check(red[0] > 150 && red[1] < 80 && red[2] < 80 && yellow[0] > 200 && yellow[1] > 150 && yellow[2] < 80,
      `planar: the red cylinder is red (${planarColours.red}) and the yellow one yellow (${planarColours.yellow})`);
    await checkKeysFollowTheTriad(page, 'planar');

    const stats = await (await fetch(`${base}/stats`)).json();
    check(stats.sessions_open >= 1 && stats.ticks > 100, `the server is healthy (${stats.ticks} ticks, tick median ${stats.tick_us.median.toFixed(0)} µs, latency median ${stats.latency_us.median.toFixed(0)} µs)`);
    check(consoleErrors.length === 0, `no script errors on the page (${consoleErrors.join('; ')})`);
    await checkPointCloud(browser);
  } finally {
    await browser.close();
    server.kill('SIGTERM');
  }
  if (failures.length) {
    console.error(`${failures.length} check(s) failed`);
    process.exit(1);
  }
  console.log('all browser checks passed');
}

main().catch((e) => { console.error(e); process.exit(1); });
