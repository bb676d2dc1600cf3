// A studio without an arm (run by tests/teaching/studio_edit.rs as `node drawn.mjs URL PID`):
// `keypose studio SEQ` without --port. The page jogs the drawn arm, captures a key, drags the
// tool handle, goes to a key and simulates; the studio's process is stopped for 3 s (PID) and
// the page takes control back once it runs; it saves; then the studio's process is killed
// (PID) and the page must say so and stop claiming control, and a key pressed then must be
// answered, not lost. Prints one JSON line; the test judges it.
import { launchChromium } from './browser.mjs';

const [url, pid] = process.argv.slice(2);
let step = 'start';
setTimeout(() => fail(`no result after 600 s, at: ${step}`), 600000).unref();

function fail(message) {
  console.error(`drawn: ${message}`);
  process.exit(1);
}

const browser = await launchChromium();
const results = { errors: [] };
try {
  const page = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
  page.on('pageerror', e => results.errors.push(`page error: ${e.message}`));
  page.on('console', m => {
    // Once the studio is killed, the browser logs the requests it refuses.
    if (m.type() === 'error' && !['killed', 'stalled'].some(s => step.startsWith(s))) results.errors.push(`console: ${m.text()}`);
  });
  await page.goto(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.view);
  const waitFor = (fn, arg, timeout = 30000) => page.waitForFunction(fn, arg, { timeout }).catch(e => fail(`${e.message}: ${fn}`));
  const snapshot = () => page.evaluate(() => window.studio.snapshot);
  results.bus = (await snapshot()).bus;
  results.start = (await snapshot()).joints.map(j => j.present);

  step = 'jog';
  await page.evaluate(() => window.studio.send({ key: 'select-joint:0' }));
  await page.keyboard.press('Shift+ArrowRight');
  await waitFor(() => window.studio.snapshot.activity.kind === 'idle' && window.studio.snapshot.joints[0].present > 5);
  results.jogged = (await snapshot()).joints.map(j => j.present);

  step = 'capture';
  const keys = (await snapshot()).keys.length;
  await page.keyboard.press('n');
  await waitFor(n => window.studio.snapshot.keys.length === n + 1, keys);
  results.keys = (await snapshot()).keys.length;

  step = 'tool handle';
  const tcp = (await snapshot()).tcp;
  await page.evaluate(t => window.studio.moveTool([t[0] - 0.01, t[1], t[2]]), tcp);
  await page.evaluate(() => window.studio.targetsDone());
  await waitFor(() => window.studio.snapshot.activity.kind === 'idle');
  results.target = await page.evaluate(() => window.studio.targets.at(-1));
  results.tcpBefore = tcp;
  results.tcpAfter = (await snapshot()).tcp;

  step = 'go to key 0';
  await page.evaluate(() => window.studio.send({ key: 'select-key:0' }));
  await page.keyboard.press(' ');
  await waitFor(() => window.studio.snapshot.activity.kind !== 'idle');
  await waitFor(() => window.studio.snapshot.activity.kind === 'idle');
  results.atKey0 = (await snapshot()).joints.map(j => j.present);

  step = 'timeline';
  await waitFor(() => window.studio.timeline && !window.studio.timeline.empty);
  results.timelineJoints = await page.evaluate(() => window.studio.timeline.joints.length);

  step = 'simulate';
  await page.click('#simulate');
  await waitFor(() => window.studio.simulation, undefined, 300000);
  results.simulated = await page.evaluate(() => window.studio.simulation.report.passed !== undefined);

  // The studio stopped for 3 s (a machine too busy to run it): the page's heartbeat goes
  // unanswered, so it says it watches, and its lease lapses; once the studio runs again the
  // page takes control back by itself, and a key pressed at once is taken.
  step = 'stalled';
  process.kill(Number(pid), 'SIGSTOP');
  try {
    await waitFor(() => !window.studio.controller);
    results.badgeWhenStalled = await page.evaluate(() => document.getElementById('control').textContent);
    await new Promise(r => setTimeout(r, 1000));
  } finally {
    process.kill(Number(pid), 'SIGCONT');
  }
  step = 'resumed';
  results.keyAfterStall = await page.evaluate(() => window.studio.send({ key: 'select-key:0' }));
  await waitFor(() => window.studio.controller);
  results.badgeAfterStall = await page.evaluate(() => document.getElementById('control').textContent);

  step = 'save';
  await page.keyboard.press('w');
  await waitFor(() => window.studio.snapshot.dirty === false);
  // The save's answer shown too (it comes after the file is checked, which may be after the
  // snapshot that says it is written): what the page says later is about the loss alone.
  await page.evaluate(() => window.studio.sent());
  await waitFor(() => document.getElementById('status').textContent.startsWith('wrote '));

  step = 'killed';
  const killedAt = await page.evaluate(() => performance.now());
  process.kill(Number(pid), 'SIGKILL');
  await waitFor(() => !window.studio.controller);
  results.lostMs = await page.evaluate(t => performance.now() - t, killedAt);
  results.badge = await page.evaluate(() => document.getElementById('control').textContent);
  results.statusWhenLost = await page.evaluate(() => document.getElementById('status').textContent);
  step = 'killed: a key';
  results.keyAfterLoss = await page.evaluate(() => window.studio.send({ key: 'n' }));
  results.statusAfterKey = await page.evaluate(() => document.getElementById('status').textContent);
} catch (e) {
  fail(`${step}: ${e.stack || e}`);
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
