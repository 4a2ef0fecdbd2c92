// End-to-end tests of `tandem serve` in headless Chromium (Debian's
// /usr/bin/chromium, driven by playwright-core): the page loads and draws,
// a scripted keyboard drives the gripper toward the box under every mode
// without a collision, each episode is recorded, and NaN, malformed and
// oversized messages from the page leave the server healthy. Every
// configuration the page was shown is judged independently of tandem's
// sphere model: example-robot-data's Panda meshes against the box, through
// Pinocchio and coal (python_ref/grasp_mesh_check.py).
//
//   node tests/teleop.test.mjs [--bin PATH] [--python PATH] [--screenshot FILE]
//
// Exit status 0 when every check passed; each failure is printed.

import { chromium } from 'playwright-core';
import { spawn, spawnSync } from 'node:child_process';
import { mkdtempSync, readdirSync, existsSync } from 'node:fs';
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

async function startServer(recordDir) {
  if (!existsSync(bin)) throw new Error(`no tandem binary at ${bin} (cargo build first, or --bin PATH)`);
  const server = spawn(bin, ['serve', '--port', '0', '--record-dir', recordDir], { stdio: ['ignore', 'pipe', 'inherit'] });
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

    // Every mode: reset, drive toward the box, no collision.
    const shown = [];
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
    }
    const box = scene.objects.find((o) => o.name === 'box');
    const worst = meshClearances(scene.joints, box, shown);
    const parts = Object.entries(worst).map(([k, v]) => `${k} ${(v * 1000).toFixed(1)} mm`).join(', ');
    check(Object.values(worst).every((v) => v >= 0), `every configuration shown (${shown.length}) keeps clear of the box with the real meshes (coal: ${parts})`);
    console.log(`screenshot (sum-of-squares, while driving): ${screenshot}`);
    const fps = await page.evaluate(() => window.tandem.fps);
    console.log(`page frame rate in headless Chromium: ${fps.toFixed(1)} Hz`);
    check(fps > 1, `the page keeps drawing (${fps.toFixed(1)} frames per second)`);

    // The reset before each mode saved the previous episode.
    await page.click('#reset');
    await sleep(1000);
    const files = readdirSync(recordDir).filter((f) => f.endsWith('.parquet'));
    check(files.length >= scene.modes.length, `each driven episode was saved as Parquet (${files.length} files)`);

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
    await waitFor(page, () => window.tandem.state.status === 'invalid_command', undefined, 5000).catch(() => {});
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
    await waitFor(page, () => window.tandem.connected && window.tandem.state && window.tandem.state.steps > 5, undefined, 20000).catch(() => {});
    check(await page.evaluate(() => window.tandem.connected), 'the page reconnects and drives again');

    const stats = await (await fetch(`${base}/stats`)).json();
    check(stats.sessions_open >= 1 && stats.ticks > 100, `the server is healthy (${stats.ticks} ticks, tick median ${stats.tick_us.median.toFixed(0)} µs, latency median ${stats.latency_us.median.toFixed(0)} µs)`);
    check(consoleErrors.length === 0, `no script errors on the page (${consoleErrors.join('; ')})`);
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
