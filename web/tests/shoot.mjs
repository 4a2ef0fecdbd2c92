// Screenshots of the page for people to look at (not a test):
//   node tests/shoot.mjs [--bin PATH] [--out DIR] [--drive SECONDS] [--key CODE] [--disk]
// writes DIR/page-reach-grasp.png and DIR/page-planar.png (DIR: ../target),
// each after holding KEY (default KeyW, +x) for SECONDS (default 1.5) so
// that the arrows show. --disk serves index.html and dist/app.js from this
// folder instead of the binary's embedded copies: a page change can be
// looked at after `npm run build`, without rebuilding tandem.
import { chromium } from 'playwright-core';
import { spawn } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { join, resolve } from 'node:path';

const args = process.argv.slice(2);
const option = (name, fallback) => { const i = args.indexOf(name); return i >= 0 ? args[i + 1] : fallback; };
const bin = resolve(option('--bin', '../target/debug/tandem'));
const out = resolve(option('--out', '../target'));
const drive = Number(option('--drive', '1.5'));
const key = option('--key', 'KeyW');

const server = spawn(bin, ['serve', '--port', '0', '--no-record'], { stdio: ['ignore', 'pipe', 'inherit'] });
const address = await new Promise((ok) => {
  let text = '';
  server.stdout.on('data', (c) => { text += c; const m = text.match(/http:\/\/([0-9.]+:[0-9]+)\//); if (m) ok(m[1]); });
});
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-quic',
    '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync',
    // A routed (test-served) page counts as non-local: let it reach the server's WebSocket.
    ...(args.includes('--disk') ? ['--disable-features=LocalNetworkAccessChecks'] : [])],
});
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 760 } });
  page.on('pageerror', (e) => console.error(`page error: ${e}`));
  page.on('console', (m) => { if (m.type() === 'error') console.error(`console: ${m.text()}`); });
  if (args.includes('--disk')) {
    await page.route('**/', (r) => r.fulfill({ contentType: 'text/html', body: readFileSync('index.html') }));
    await page.route('**/app.js', (r) => r.fulfill({ contentType: 'text/javascript', body: readFileSync('dist/app.js') }));
  }
  await page.goto(`http://${address}`);
  for (const task of ['reach-grasp', 'planar']) {
    const scenes = await page.evaluate(() => window.tandem.scenesReceived);
    if (task !== 'reach-grasp') await page.selectOption('#task', task);
    await page.waitForFunction(([t, n]) => window.tandem.scene?.task === t && window.tandem.scenesReceived > (t === 'reach-grasp' ? 0 : n) && window.tandem.state, [task, scenes], { timeout: 60000 });
    await page.waitForTimeout(800);
    if (drive > 0) {
      await page.keyboard.down(key);
      await page.waitForTimeout(drive * 1000);
    }
    const file = join(out, `page-${task}.png`);
    await page.screenshot({ path: file });
    if (drive > 0) await page.keyboard.up(key);
    console.log(file);
  }
} finally {
  await browser.close();
  server.kill('SIGTERM');
}
