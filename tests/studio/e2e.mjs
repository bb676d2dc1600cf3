// Drives `keypose studio` in Debian's Chromium (headless, WebGL through SwiftShader) with
// playwright-core; run by tests/teaching/studio.rs as `node e2e.mjs URL ARTIFACT_DIR`. Prints one
// JSON line of results for the Rust side, which checks the file the keys wrote.
import { launchChromium } from './browser.mjs';
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import http from 'node:http';
import { inflateSync } from 'node:zlib';

const [url, artifacts] = process.argv.slice(2);
// A hang guard, not a timing check: a step that never happens fails the run instead of
// holding CI.
setTimeout(() => fail('no result after 300 s'), 300000).unref();
const target = new URL(url);
const token = target.searchParams.get('token');

function fail(message) {
  console.error(`e2e: ${message}`);
  process.exit(1);
}

// A request from outside the browser, with exactly the headers given (Host included).
function raw(path, headers, method = 'GET') {
  return new Promise((resolve, reject) => {
    const req = http.request({ host: target.hostname, port: target.port, path, method, headers }, res => {
      let body = '';
      res.on('data', c => (body += c));
      res.on('end', () => resolve({ status: res.statusCode, body }));
    });
    req.on('error', reject);
    req.end(method === 'POST' ? '{"key":"n"}' : undefined);
  });
}

// The distinct colours of a PNG (8-bit RGB or RGBA, not interlaced: what Chromium writes).
function pngColours(png) {
  let pos = 8, width = 0, height = 0, channels = 0;
  const idat = [];
  while (pos < png.length) {
    const length = png.readUInt32BE(pos), type = png.toString('ascii', pos + 4, pos + 8);
    const data = png.subarray(pos + 8, pos + 8 + length);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4);
      if (data[8] !== 8 || data[12] !== 0) fail('unexpected PNG bit depth or interlace');
      channels = { 2: 3, 6: 4 }[data[9]] || fail(`PNG colour type ${data[9]}`);
    }
    if (type === 'IDAT') idat.push(data);
    pos += 12 + length;
  }
  const raw = inflateSync(Buffer.concat(idat)), stride = width * channels;
  const out = Buffer.alloc(height * stride), colours = new Set();
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    for (let x = 0; x < stride; x++) {
      const v = raw[y * (stride + 1) + 1 + x];
      const a = x >= channels ? out[y * stride + x - channels] : 0;
      const b = y > 0 ? out[(y - 1) * stride + x] : 0;
      const c = x >= channels && y > 0 ? out[(y - 1) * stride + x - channels] : 0;
      const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
      const paeth = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      out[y * stride + x] = (v + [0, a, b, (a + b) >> 1, paeth][filter]) & 255;
    }
    for (let x = 0; x < width; x++) colours.add(out.readUIntBE(y * stride + x * channels, 3));
  }
  return colours.size;
}

const browser = await launchChromium();
const results = {};
try {
  // ----- the controller's page: loads without a JavaScript error -----
  const a = await (await browser.newContext({ viewport: { width: 1200, height: 800 } })).newPage();
  const errors = [];
  a.on('pageerror', e => errors.push(`page error: ${e.message}`));
  a.on('console', m => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  // Every Referer the page's requests carry (none may hold the token).
  const referers = [];
  a.on('request', r => { const referer = r.headers()['referer']; if (referer) referers.push(referer); });
  await a.goto(url);
  await a.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.loadMs !== null);
  // The address bar once the page has loaded: the token has left it.
  results.addressBar = await a.evaluate(() => location.href);
  const snapshot = () => a.evaluate(() => window.studio.snapshot);
  // On a timeout, say what the page showed and what went wrong in it.
  // Hang guards, not timings: a loaded machine may take long over a jog.
  const waitFor = (fn, arg) => a.waitForFunction(fn, arg, { timeout: 120000 }).catch(async e => {
    const s = await a.evaluate(() => window.studio.snapshot).catch(() => null);
    fail(`${e.message}\nwaiting for ${fn}\nerrors: ${JSON.stringify(errors)}\nstatus: ${JSON.stringify(s && s.status)} joints: ${JSON.stringify(s && s.joints.map(j => [j.present, j.goal]))}` +
      `\nrefusals: ${JSON.stringify(await a.evaluate(() => window.studio.refusals).catch(() => null))}`);
  });

  // ----- teach by the keys of `keypose teach` -----
  // The page sends keys one after another, in the order pressed.
  const press = key => a.keyboard.press(key);
  await press('n');
  await waitFor(() => window.studio.snapshot.keys.length === 1);
  await press('Shift+ArrowRight');
  await press('Shift+ArrowRight');
  await waitFor(() => Math.abs(window.studio.snapshot.joints[0].present - 20) < 0.1);
  await press('n');
  await waitFor(() => window.studio.snapshot.keys.length === 2);
  await press('ArrowDown');
  // One degree a press, each watched until it arrives (three quick presses would give two:
  // while a jog runs only the newest press waits behind it).
  for (let i = 1; i <= 3; i++) {
    await press('ArrowRight');
    await waitFor(i => Math.abs(window.studio.snapshot.joints[1].present - i) < 0.1 && window.studio.snapshot.activity.kind === 'idle', i);
  }
  await press('u');
  await waitFor(() => window.studio.snapshot.keys[1].values[1] === 3);
  // A prompt answered in the page's box: N opens it, the box takes the name, Enter sets it.
  await press('Shift+N');
  await waitFor(() => window.studio.snapshot.prompt && window.studio.snapshot.prompt.kind === 'text');
  await a.fill('#answer', 'wave');
  await a.press('#answer', 'Enter');
  await waitFor(() => window.studio.snapshot.keys[1].name === 'wave');
  await press('n');
  await waitFor(() => window.studio.snapshot.keys.length === 3);
  await press('d');
  await waitFor(() => window.studio.snapshot.keys.length === 2);
  await press('<');
  await press('>');
  await press('w');
  await waitFor(() => !window.studio.snapshot.dirty);
  results.status = (await snapshot()).status.text;

  // ----- mirroring: the button, then the hotkey, on key 1 (pan 20°, lift 3°) -----
  await a.click('button[data-key="m"]');
  await waitFor(() => window.studio.snapshot.keys[1].values[0] === -20);
  results.mirrored = [(await snapshot()).keys[1].values.slice(0, 2)];
  await press('m');
  await waitFor(() => window.studio.snapshot.keys[1].values[0] === 20);
  results.mirrored.push((await snapshot()).keys[1].values.slice(0, 2));

  // ----- the 3D view: drawn, and the arm where the servos are -----
  const png = await a.locator('#view').screenshot();
  results.colours = pngColours(png);
  results.drawnPan = await a.evaluate(() => window.studio.view.jointAngle('shoulder_pan'));
  // The tool where the page draws it (its scene graph, built from the MJCF bodies) and where
  // keypose computes it (forward kinematics of the robot description), at three poses.
  results.tcp = [];
  for (const keys of [[], ['down', 'shift-left', 'shift-left', 'shift-left'], ['down', 'shift-right', 'shift-right', 'down', 'shift-left']]) {
    for (const key of keys) await a.evaluate(k => window.studio.send({ key: k }), key);
    await a.waitForTimeout(300);
    results.tcp.push(await a.evaluate(() => ({ drawn: window.studio.view.tcpPosition(), computed: window.studio.snapshot.tcp })));
  }
  await a.screenshot({ path: join(artifacts, 'studio.png') });

  // ----- the timeline: the keys' curves and a drag of key 1 from 2 s to 3 s -----
  await waitFor(() => window.studio.timeline && !window.studio.timeline.empty);
  results.timelineJoints = await a.evaluate(() => window.studio.timeline.joints.length);
  // Each servo's torque against its line, a curve per row.
  results.torqueRows = await a.evaluate(() => {
    const t = window.studio.timeline.torque;
    return t && t.joints.map(j => Array.isArray(j) && j.length === t.times.length && j.length > 0);
  });
  await a.evaluate(() => window.studio.send({ key: 'select-key:1' }));
  await a.evaluate(() => window.studio.send({ key: 'key-time:3000' }));
  await waitFor(() => window.studio.snapshot.keys[1].time === 3);
  results.keyTimes = (await snapshot()).keys.map(k => k.time);

  // ----- a jog's goal to the first frame that shows the arm moving (the session ramps a jog
  // before it reads again, as in the terminal) -----
  await a.evaluate(() => window.studio.send({ key: 'select-joint:0' }));
  const jogs = [];
  for (let i = 0; i < 5; i++) {
    jogs.push(await a.evaluate(() => new Promise(resolve => {
      const view = window.studio.view, before = view.jointAngle('shoulder_pan'), t0 = performance.now();
      window.studio.send({ key: 'right' });
      const check = () => (Math.abs(view.jointAngle('shoulder_pan') - before) > 1e-6
        ? resolve(performance.now() - t0)
        : performance.now() - t0 > 10000 ? resolve(null) : requestAnimationFrame(check));
      requestAnimationFrame(check);
    })));
    // The jog answered (its ramp done) and the emulated servo at rest before the next one.
    await a.evaluate(() => window.studio.sent());
    await a.waitForTimeout(400);
  }
  results.jogToFrameMs = jogs;
  results.loadMs = await a.evaluate(() => window.studio.loadMs);

  // ----- the tool handle: dragged by the mouse (the gizmo's centre, in small steps, as a
  // hand would), then a target a metre out, which the server refuses -----
  // The state as the server has it once the last answer came (the stream may lag behind).
  const state = async () => JSON.parse((await raw('/api/state', { Host: target.host, 'X-Keypose-Token': token })).body);
  // Until the last jog the handle asked for has arrived (a target's answer comes when its
  // jog starts).
  const atRest = async () => { while ((await state()).activity.kind !== 'idle') await a.waitForTimeout(50); };
  results.handleStart = (await state()).tcp;
  const at = await a.evaluate(() => window.studio.handle.screenPosition());
  await a.mouse.move(at.x, at.y);
  await a.mouse.down();
  for (let i = 1; i <= 12; i++) {
    await a.mouse.move(at.x + 2 * i, at.y + 2 * i);
    await a.waitForTimeout(60);
  }
  await a.mouse.up();
  await a.evaluate(() => window.studio.targetsDone());
  await a.evaluate(() => window.studio.sent());
  await atRest();
  results.dragTargets = await a.evaluate(() => window.studio.targets.slice());
  results.dragGoals = (await state()).joints.map(j => j.goal);
  results.toolTargetMs = results.dragTargets.map(t => t.ms);
  await a.evaluate(() => window.studio.moveTool([1, 0, 0.1]));
  await a.evaluate(() => window.studio.targetsDone());
  results.farTarget = await a.evaluate(() => window.studio.targets.at(-1));
  results.farHandleRed = await a.evaluate(() => window.studio.handle.refused);
  const far = await state();
  results.farGoals = far.joints.map(j => j.goal);
  results.farStatus = far.status;

  // ----- refusals: no token, a foreign Origin, a rebound Host -----
  const host = target.host;
  results.noToken = (await raw('/api/state', { Host: host })).status;
  results.noTokenPage = (await raw('/', { Host: host })).status;
  results.foreignOrigin = (await raw('/api/key', { Host: host, Origin: 'http://evil.example', 'X-Keypose-Token': token }, 'POST')).status;
  results.reboundHost = (await raw('/api/state', { Host: `evil.example:${target.port}`, 'X-Keypose-Token': token })).status;
  results.withToken = (await raw('/api/state', { Host: host, 'X-Keypose-Token': token })).status;

  // ----- a second page watches; its key is refused -----
  const b = await (await browser.newContext()).newPage();
  const errorsB = [];
  b.on('pageerror', e => errorsB.push(`page error: ${e.message}`));
  b.on('console', m => {
    // A watcher's refused requests show as failed loads (409); nothing else may go wrong.
    if (m.type() === 'error' && !/status of 409/.test(m.text())) errorsB.push(`console: ${m.text()}`);
  });
  await b.goto(url);
  await b.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.view);
  results.secondControls = await b.evaluate(() => window.studio.controller);
  results.secondHandleShown = await b.evaluate(() => window.studio.handle.gizmo.enabled);
  results.secondKeyAccepted = await b.evaluate(() => window.studio.press('n'));
  results.secondRefusal = await b.evaluate(() => window.studio.refusals.at(-1));
  results.keysAfterRefusal = (await snapshot()).keys.length;

  // ----- the controller closes its page while playing: playback stops the soft way -----
  await a.keyboard.press('<');
  await a.keyboard.press('y');
  await waitFor(() => window.studio.snapshot.activity.kind === 'play');
  // While it plays: how often snapshots come, and how old each is when its frame is drawn.
  const watched = await a.evaluate(() => new Promise(resolve => {
    const { arrivals, latencies } = window.studio, from = [arrivals.length, latencies.length];
    setTimeout(() => {
      const seen = arrivals.slice(from[0]);
      resolve({
        intervals: seen.slice(1).map((s, i) => s.at - seen[i].at),
        arrival: seen.map(s => s.delay),
        frame: latencies.slice(from[1]),
      });
    }, 1000);
  }));
  results.playSnapshotIntervalsMs = watched.intervals;
  results.playSnapshotToArrivalMs = watched.arrival;
  results.playSnapshotToFrameMs = watched.frame;
  await a.close();
  await b.waitForFunction(() => window.studio.snapshot.activity.kind === 'idle', null, { timeout: 120000 });
  results.afterClose = await b.evaluate(() => window.studio.snapshot.status.text);
  // The watcher may take control once nobody holds it, and its keys then count. The closed
  // page's lease ends when its release arrives or, failing that, lapses (2 s): until then a
  // take is refused, so the test takes as a user would, again until it is granted.
  const deadline = Date.now() + 15000;
  while (!(await b.evaluate(() => window.studio.controller)) && Date.now() < deadline) {
    await b.click('#take');
    await b.waitForTimeout(250);
  }
  await b.waitForFunction(() => window.studio.controller, null, { timeout: 1000 });
  results.takenOver = await b.evaluate(() => window.studio.press('>'));
  results.referers = referers;
  results.errors = errors.concat(errorsB);
} finally {
  await browser.close();
}
// Median, 90th percentile and worst of each measured series, for the README.
const summary = xs => {
  const s = xs.filter(x => x !== null).sort((a, b) => a - b);
  const at = q => Math.round(s[Math.min(s.length - 1, Math.floor(q * s.length))]);
  return s.length ? { n: s.length, median: at(0.5), p90: at(0.9), max: at(1) } : null;
};
results.summary = Object.fromEntries(['jogToFrameMs', 'toolTargetMs', 'playSnapshotIntervalsMs', 'playSnapshotToArrivalMs', 'playSnapshotToFrameMs']
  .map(k => [k, summary(results[k] || [])]));
writeFileSync(join(artifacts, 'results.json'), JSON.stringify(results, null, 1));
console.log(JSON.stringify(results));
