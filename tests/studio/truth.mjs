// What the screen shows is what the arm will do (run by tests/teaching/studio_truth.rs as
// `node truth.mjs WAVE_URL TOOL_URL FAST_URL SHOTS_DIR`): on so101_wave.json, every key's ghost
// as drawn, `space` to a key that sets one joint only, the playhead during `y`, a time parked
// on the timeline and a key captured there, Simulate's replay paused and scrubbed; on
// so101-tool-line.json, the tool keys' ghosts; on a list too fast for the limits, the findings
// list. Prints one JSON line of what the pages showed; the Rust side holds the oracles.
import { launchChromium } from './browser.mjs';

const [waveUrl, toolUrl, fastUrl, shots] = process.argv.slice(2);
let step = 'start';
setTimeout(() => fail(`no result after 600 s, at: ${step}`), 600000).unref();

function fail(message) {
  console.error(`truth: ${message}`);
  process.exit(1);
}

const JOINTS = ['shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll', 'gripper'];
const browser = await launchChromium();
const results = { errors: [] };

async function open(url) {
  const page = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
  page.on('pageerror', e => results.errors.push(`page error: ${e.message}`));
  page.on('console', m => { if (m.type() === 'error') results.errors.push(`console: ${m.text()}`); });
  await page.goto(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.view &&
    window.studio.controller && window.studio.playback && window.studio.timeline, null, { timeout: 60000 });
  page.waitFor = (fn, arg) => page.waitForFunction(fn, arg, { timeout: 120000 }).catch(e => fail(`${step}: ${e.message}`));
  return page;
}

// Every joint's angle as drawn on the ghost (or the arm), once the frame after the snapshot
// that changed it is drawn.
async function drawn(page, copy) {
  await page.evaluate(() => new Promise(resolve => { window.studio.view.dirty = true; window.studio.view.onFrame = resolve; }));
  return page.evaluate(([names, copy]) => names.map(n => window.studio.view.jointAngle(n, copy)), [JOINTS, copy]);
}

async function selectKey(page, i) {
  await page.evaluate(i => window.studio.press(`select-key:${i}`), i);
  await page.waitFor(i => window.studio.snapshot.current === i, i);
}

try {
  // ----- the wave: every key's ghost, and space -----
  step = 'wave: ghosts';
  const wave = await open(waveUrl);
  await wave.waitFor(() => window.studio.timeline && !window.studio.timeline.empty);
  const keys = await wave.evaluate(() => window.studio.snapshot.keys.length);
  results.waveGhosts = [];
  results.waveKeyColumn = [];
  for (let i = 0; i < keys; i++) {
    await selectKey(wave, i);
    results.waveGhosts.push(await drawn(wave, 'ghost'));
    results.waveKeyColumn.push(await wave.evaluate(() => window.studio.snapshot.joints.map(j => j.key_text)));
  }
  results.waveKeyTimes = await wave.evaluate(() => window.studio.snapshot.keys.map(k => k.time));

  step = 'wave: space to key 2';
  await selectKey(wave, 2);
  await wave.evaluate(() => window.studio.press('space'));
  await wave.waitFor(() => window.studio.snapshot.activity.kind === 'to_key');
  await wave.waitFor(() => window.studio.snapshot.activity.kind === 'idle');
  results.spaceGhost = await drawn(wave, 'ghost');
  results.spaceArm = await drawn(wave, 'arm');

  // ----- y: the playhead moves and the current key follows -----
  step = 'wave: play';
  await selectKey(wave, 0);
  await wave.evaluate(() => {
    window.playTrace = [];
    window.studio.playback.seen = [];
    // Sampled until the page says the playback is over (below), not at the first idle
    // snapshot: beside a busy CI one came at 0.22 s of a played sequence and ended the trace.
    window.playTimer = setInterval(() => {
      const s = window.studio.snapshot, t = window.studio.timeline;
      const row = document.querySelector('#keys tr.playing');
      if (s.playhead) {
        window.playTrace.push({ time: s.playhead.time, key: s.playhead.key, phase: s.playhead.phase,
          drawn: window.studio.timelineView.playhead, marked: row ? Number(row.dataset.index) : null });
      }
    }, 25);
  });
  await wave.evaluate(() => window.studio.press('y'));
  await wave.waitFor(() => window.studio.snapshot.playhead && window.studio.snapshot.playhead.time > 3.0);
  await (await wave.$('#timeline')).scrollIntoViewIfNeeded();
  if (shots) await wave.screenshot({ path: `${shots}/studio-playhead.png` });
  await wave.waitFor(() => window.studio.snapshot.activity.kind === 'idle' && !window.studio.playback.playing);
  results.playTrace = await wave.evaluate(() => { clearInterval(window.playTimer); return window.playTrace; });
  results.measuredError = await wave.evaluate(() => window.studio.playback.errors.measured &&
    { largest: window.studio.playback.errors.measured.largest, samples: window.studio.playback.errors.measured.times.length });
  results.playheadAfter = await wave.evaluate(() => window.studio.timelineView.playhead);
  results.playStatus = await wave.evaluate(() => window.studio.snapshot.status.text);

  // ----- Simulate: the replay paused and scrubbed -----
  step = 'wave: simulate';
  await wave.click('#simulate');
  await wave.waitFor(() => window.studio.simulation && window.studio.playback.replaying);
  await wave.click('#replaypause');
  results.replayPaused = await wave.evaluate(() => window.studio.playback.replaying.paused);
  const pausedRow = await wave.evaluate(() => window.studio.playback.replaying.row);
  await wave.waitForTimeout(500);
  results.replayStill = (await wave.evaluate(() => window.studio.playback.replaying.row)) === pausedRow;
  // A real drag on the timeline to about 3 s: the replay follows the cursor, paused.
  const box = await (await wave.$('#timeline')).boundingBox();
  const xOf = t => wave.evaluate(t => {
    const tl = window.studio.timelineView, c = document.getElementById('timeline');
    return tl.x(t) * c.clientWidth / c.width;
  }, t);
  await wave.mouse.move(box.x + await xOf(1.0), box.y + 20);
  await wave.mouse.down();
  await wave.mouse.move(box.x + await xOf(3.0), box.y + 20, { steps: 5 });
  await wave.mouse.up();
  results.scrubbed = await wave.evaluate(() => {
    const p = window.studio.playback, r = p.replaying, trace = p.trace;
    return { parked: window.studio.timelineView.parked, row: r.row, paused: r.paused,
      sequenceTime: trace.sequence_time[r.row], before: trace.sequence_time[r.row - 1],
      playhead: window.studio.timelineView.playhead,
      commanded: trace.commanded[r.row], simulated: trace.position[r.row] };
  });
  results.scrubbedGhost = await drawn(wave, 'ghost');
  results.simulatedError = await wave.evaluate(() => window.studio.playback.errors.simulated.largest);
  results.simulationTracking = await wave.evaluate(() => window.studio.simulation.report.tracking.map(t => t.max_error));
  await wave.click('#replayend');

  // ----- a parked time: the ghost there, a key captured there -----
  step = 'wave: park and capture';
  await wave.evaluate(() => window.studio.timelineView.park(1.0));
  results.parkedGhost = await drawn(wave, 'ghost');
  results.captureButton = await wave.evaluate(() => !document.getElementById('captureat').hidden &&
    document.getElementById('captureat').textContent);
  await wave.click('#captureat');
  await wave.waitFor(() => window.studio.snapshot.keys.length === 9);
  results.afterCapture = await wave.evaluate(() => ({ times: window.studio.snapshot.keys.map(k => k.time),
    current: window.studio.snapshot.current, status: window.studio.snapshot.status }));

  // ----- latency: a key edit to the page's redraw -----
  step = 'wave: key edit latency';
  results.editLatency = [];
  for (let i = 0; i < 10; i++) {
    results.editLatency.push(await wave.evaluate(async i => {
      const studio = window.studio, before = studio.snapshot.seq;
      const started = performance.now();
      // The captured key (1) moved in time, 10 ms at a time.
      studio.press(`key-time:${1000 + 10 * (i + 1)}`);
      await new Promise(resolve => {
        const poll = () => (studio.snapshot.seq > before && Math.abs(studio.snapshot.keys[1].time - (1 + 0.01 * (i + 1))) < 1e-9
          ? resolve() : requestAnimationFrame(poll));
        poll();
      });
      const list = performance.now();
      // The frame that draws it, and the timeline's curves fetched again and drawn.
      await new Promise(resolve => { studio.view.dirty = true; studio.view.onFrame = resolve; });
      const frame = performance.now();
      await new Promise(resolve => {
        const poll = () => (studio.timeline && studio.timeline.key_marks && Math.abs(studio.timelineView.keys[1].time - (1 + 0.01 * (i + 1))) < 1e-9
          ? resolve() : requestAnimationFrame(poll));
        poll();
      });
      return { snapshot: list - started, frame: frame - started, timeline: performance.now() - started };
    }, i));
  }
  await wave.close();

  // ----- tool keys: the solved pose, in the ghost and the key column -----
  step = 'tool keys';
  const tool = await open(toolUrl);
  results.toolGhosts = [];
  results.toolKeyColumn = [];
  for (const i of [0, 1, 2, 3]) {
    await selectKey(tool, i);
    results.toolGhosts.push(await drawn(tool, 'ghost'));
    results.toolKeyColumn.push(await tool.evaluate(() => window.studio.snapshot.joints.map(j => j.key_text)));
  }
  await selectKey(tool, 1);
  await drawn(tool, 'ghost');
  if (shots) await tool.screenshot({ path: `${shots}/studio-ghost-tool-key.png` });
  await tool.close();

  // ----- findings: units, a list, in view -----
  step = 'findings';
  const fast = await open(fastUrl);
  await fast.waitFor(() => window.studio.timeline && (window.studio.timeline.findings || []).length > 0);
  const findings = () => fast.evaluate(() => {
    const box = document.getElementById('findings'), r = box.getBoundingClientRect();
    return { hidden: box.hidden, items: [...box.querySelectorAll('li')].map(li => li.textContent),
      inView: r.top >= 0 && r.bottom <= innerHeight && r.height > 0 };
  });
  results.findings = await findings();
  // Another action later (a key selected, the status line changed): still there.
  await fast.evaluate(() => window.studio.press('>'));
  await fast.waitFor(() => window.studio.snapshot.current === 1);
  await fast.waitForTimeout(300);
  results.findingsLater = await findings();
  await fast.close();
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
