// Stop through the real page (run by tests/teaching/studio.rs as `node stop.mjs URL`): an arrow key
// held for two seconds and let go, then the Stop button; and the Stop of a page that only
// watches. (Sixty jogs queued at once are tested on the engine, tests/teaching/studio_engine.rs: a
// browser sends no more than six requests at a time to one server, so a flood from a page
// arrives over seconds, not at once.) Prints one JSON line:
// for each stop, how far the pan went after it and how long until the arm was at rest, as
// the page's snapshots saw it.
import { launchChromium } from './browser.mjs';

const [url] = process.argv.slice(2);
// A hang guard, not a timing check; it says which step it was at.
let step = 'start';
setTimeout(() => fail(`no result after 300 s, at: ${step}`), 300000).unref();

function fail(message) {
  console.error(`stop: ${message}`);
  process.exit(1);
}

const browser = await launchChromium();
const results = {};
try {
  const a = await (await browser.newContext()).newPage();
  const errors = [];
  a.on('pageerror', e => errors.push(`page error: ${e.message}`));
  a.on('console', m => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  await a.goto(url);
  await a.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller);
  const waitFor = (fn, arg) => a.waitForFunction(fn, arg, { timeout: 30000 }).catch(e => fail(`${e.message}: ${fn}`));
  // Every snapshot's pan and activity, with the page's clock, from here on.
  await a.evaluate(() => {
    window.panTrace = [];
    setInterval(() => {
      const s = window.studio.snapshot;
      window.panTrace.push({ t: performance.now(), pan: s.joints[0].present, kind: s.activity.kind });
    }, 10);
  });
  await a.evaluate(() => window.studio.send({ key: 'select-joint:0' }));
  await a.evaluate(() => window.studio.sent());

  // What the pan did after the last stop: degrees from the stop to rest, and the time from
  // the stop to the last snapshot in which it still moved.
  const afterStop = () => a.evaluate(() => {
    const stop = window.studio.stops.at(-1);
    const trace = window.panTrace.filter(p => p.t >= stop);
    const atStop = window.panTrace.filter(p => p.t < stop).at(-1).pan;
    let lastMove = stop;
    for (let i = 1; i < trace.length; i++) if (Math.abs(trace[i].pan - trace[i - 1].pan) > 1e-9) lastMove = trace[i].t;
    return { degrees: trace.at(-1).pan - atStop, ms: lastMove - stop, at: trace.at(-1).pan };
  });

  // ----- an arrow key held for 2 s (auto-repeat at ~30 Hz), let go, then Stop -----
  step = 'held key';
  const heldUntil = Date.now() + 2000;
  await a.keyboard.down('ArrowRight');
  while (Date.now() < heldUntil) {
    await a.waitForTimeout(33);
    await a.keyboard.down('ArrowRight');
  }
  await a.keyboard.up('ArrowRight');
  results.heldDegrees = await a.evaluate(() => window.studio.snapshot.joints[0].present);
  step = 'held key: Stop';
  await a.click('#stop');
  await waitFor(() => window.studio.snapshot.activity.kind === 'idle');
  await a.waitForTimeout(300);
  results.held = await afterStop();

  // ----- a page that only watches may stop (not move) -----
  step = 'watcher';
  const b = await (await browser.newContext()).newPage();
  b.on('console', m => {
    if (m.type() === 'error' && !/status of 409/.test(m.text())) errors.push(`watcher console: ${m.text()}`);
  });
  await b.goto(url);
  await b.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.view);
  results.watcherControls = await b.evaluate(() => window.studio.controller);
  results.watcherJog = await b.evaluate(() => window.studio.send({ key: 'shift-right' }));
  await a.evaluate(() => window.studio.send({ key: 'shift-right' }));
  await waitFor(() => window.studio.snapshot.activity.kind === 'jog');
  results.watcherStop = await b.evaluate(() => window.studio.stop());
  await waitFor(() => window.studio.snapshot.activity.kind === 'idle');
  results.watcherStatus = await a.evaluate(() => window.studio.snapshot.status.text);
  results.errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
