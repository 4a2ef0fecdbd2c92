// End-to-end latency of `tandem serve`, without a browser: a WebSocket
// client sends a distinct command every 10 ms and times how long until a
// state carrying it comes back (send → server tick → state → receive),
// at each control rate given. Also prints the server's own /stats (tick
// time, command received → state sent).
//
//   node --experimental-websocket bench/latency.mjs [--bin PATH] [--seconds 10] [30 1000]
//
// (Node 22 and later have WebSocket without the flag.)

import { spawn } from 'node:child_process';
import { resolve } from 'node:path';

const args = process.argv.slice(2);
const take = (name, fallback) => {
  const i = args.indexOf(name);
  if (i < 0) return fallback;
  const [, value] = args.splice(i, 2);
  return value;
};
const bin = resolve(take('--bin', '../target/release/tandem'));
const seconds = Number(take('--seconds', '10'));
const rates = args.length ? args.map(Number) : [30, 1000];

function percentiles(values) {
  const v = [...values].sort((a, b) => a - b);
  const at = (q) => v[Math.min(v.length - 1, Math.floor(q * v.length))];
  return { count: v.length, median: at(0.5), p99: at(0.99), max: v[v.length - 1] };
}
const ms = (p) => `median ${p.median.toFixed(2)} ms, p99 ${p.p99.toFixed(2)} ms, max ${p.max.toFixed(2)} ms (${p.count})`;

async function measure(rate) {
  const server = spawn(bin, ['serve', '--port', '0', '--no-record', '--task', 'reach-grasp', '--rate', String(rate)], { stdio: ['ignore', 'pipe', 'inherit'] });
  const address = await new Promise((ok, fail) => {
    server.stdout.on('data', (d) => { const m = String(d).match(/http:\/\/([0-9.]+:[0-9]+)\//); if (m) ok(m[1]); });
    server.on('exit', (code) => fail(new Error(`tandem serve exited with ${code}`)));
  });
  const ws = new WebSocket(`ws://${address}/ws`);
  const sentAt = new Map();
  const roundTrips = [];
  let ready = false;
  let k = 0;
  ws.onmessage = (event) => {
    const m = JSON.parse(event.data);
    if (m.type === 'scene') ready = true;
    if (m.type !== 'state' || m.human == null) return;
    // Commands alternate tiny distinct y values; the first state that
    // carries one closes its round trip.
    const key = m.human[1].toFixed(9);
    if (sentAt.has(key)) {
      roundTrips.push(performance.now() - sentAt.get(key));
      sentAt.delete(key);
    }
  };
  await new Promise((ok) => { ws.onopen = ok; });
  while (!ready) await new Promise((r) => setTimeout(r, 20));
  const end = performance.now() + seconds * 1000;
  while (performance.now() < end) {
    k += 1;
    const y = (k % 1000) * 1e-6; // m/s: distinct, too small to matter
    sentAt.set(y.toFixed(9), performance.now());
    ws.send(JSON.stringify({ type: 'command', linear: [0, y, 0] }));
    await new Promise((r) => setTimeout(r, 10));
  }
  const stats = await (await fetch(`http://${address}/stats`)).json();
  ws.close();
  server.kill('SIGTERM');
  console.log(`control rate ${rate} Hz (states at most ${Math.min(rate, 60)} Hz):`);
  console.log(`  client round trip (send → state received): ${ms(percentiles(roundTrips))}`);
  const us = (p) => `median ${p.median.toFixed(0)} µs, p99 ${p.p99.toFixed(0)} µs, max ${p.max.toFixed(0)} µs (${p.count})`;
  console.log(`  server tick (arbiter):                      ${us(stats.tick_us)}`);
  console.log(`  server command received → state sent:      ${us(stats.latency_us)}`);
  console.log(`  ticks ${stats.ticks}, late ticks ${stats.late_ticks} (started over 1.5 periods after the previous)`);
}

for (const rate of rates) await measure(rate);
