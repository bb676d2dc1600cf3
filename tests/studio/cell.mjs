// Drives `keypose studio` on a cell of two arms in Debian's Chromium (headless, WebGL through
// SwiftShader) with playwright-core; run by tests/teaching/studio.rs as `node cell.mjs URL`. Bends the
// right arm, reads where the page draws its tool, moves the tool handle 10 mm along the
// scene's x, and prints one JSON line of results for the Rust side to check.
import { launchChromium } from './browser.mjs';
import http from 'node:http';

const [url] = process.argv.slice(2);
// A hang guard, not a timing check.
setTimeout(() => fail('no result after 300 s'), 300000).unref();
const target = new URL(url);
const token = target.searchParams.get('token');

function fail(message) {
  console.error(`cell: ${message}`);
  process.exit(1);
}

// The state as the server has it (the stream may lag behind the last answer).
function state() {
  return new Promise((resolve, reject) => {
    const req = http.request({ host: target.hostname, port: target.port, path: '/api/state',
      headers: { Host: target.host, 'X-Keypose-Token': token } }, res => {
      let body = '';
      res.on('data', c => (body += c));
      res.on('end', () => resolve(JSON.parse(body)));
    });
    req.on('error', reject);
    req.end();
  });
}

const browser = await launchChromium();
const results = {};
try {
  const page = await (await browser.newContext({ viewport: { width: 1200, height: 800 } })).newPage();
  const errors = [];
  page.on('pageerror', e => errors.push(`page error: ${e.message}`));
  page.on('console', m => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  await page.goto(url);
  // Generous waits: SwiftShader draws two arms slowly on a loaded machine.
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.loadMs !== null,
    null, { timeout: 120000 }).catch(e => fail(`${e.message}; errors ${JSON.stringify(errors)}`));
  // The right arm's lift −30°, its elbow +30°: away from the stretched, singular home. Each
  // 10° jog watched until it arrives (while a jog runs only the newest press waits behind it,
  // so quick presses on a loaded machine would give fewer jogs).
  const jogs = [['select-joint:7', 7, 0], ['shift-left', 7, -10], ['shift-left', 7, -20], ['shift-left', 7, -30],
    ['down', 8, 0], ['shift-right', 8, 10], ['shift-right', 8, 20], ['shift-right', 8, 30]];
  for (const [key, joint, value] of jogs) {
    await page.evaluate(k => window.studio.send({ key: k }), key);
    await page.evaluate(() => window.studio.sent());
    await page.waitForFunction(([joint, value]) => {
      const s = window.studio.snapshot;
      return s.selected === joint && Math.abs(s.joints[joint].present - value) < 0.1 && s.activity.kind === 'idle';
    }, [joint, value], { timeout: 120000 }).catch(async e => {
      const s = await page.evaluate(() => window.studio.snapshot).catch(() => null);
      fail(`${key} to ${value}° on joint ${joint}: ${e.message}; errors ${JSON.stringify(errors)}; ` +
        `status ${JSON.stringify(s && s.status)}; activity ${JSON.stringify(s && s.activity)}; ` +
        `present ${JSON.stringify(s && s.joints.map(j => j.present))}`);
    });
  }
  // Let the stream's last snapshot (the servos at rest) reach the page and be drawn.
  await page.waitForTimeout(500);
  Object.assign(results, await page.evaluate(() => ({
    toolArm: window.studio.snapshot.tool_arm,
    present: window.studio.snapshot.joints.map(j => j.present),
    computed: window.studio.snapshot.tcp,
    drawn: window.studio.view.tcpPosition(),
    drawnWorld: window.studio.view.toolWorld().toArray(),
    parts: window.studio.view.parts.length,
  })));
  const goalsBefore = (await state()).joints.map(j => j.goal);
  // The handle's ball 10 mm along the scene's x, as a drag leaves it.
  await page.evaluate(() => {
    const handle = window.studio.handle;
    handle.ball.position.x += 0.01;
    handle.gizmo.dispatchEvent({ type: 'objectChange' });
  });
  await page.evaluate(() => window.studio.targetsDone());
  await page.evaluate(() => window.studio.sent());
  // Until the handle's jog has arrived: its goals published and the jog over. A target's
  // answer comes when its jog starts, which the published state may not show yet; the wait
  // is a hang guard, not a timing (a loaded machine may take long).
  const moved = s => s.activity.kind === 'idle' && s.joints.some((j, i) => j.goal !== goalsBefore[i]);
  for (const start = Date.now(); !moved(await state()); await page.waitForTimeout(50)) {
    if (Date.now() - start > 120000) fail(`the handle's jog did not arrive: ${JSON.stringify(await state())}`);
  }
  results.target = await page.evaluate(() => window.studio.targets.at(-1));
  results.goals = (await state()).joints.map(j => j.goal);
  results.errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
