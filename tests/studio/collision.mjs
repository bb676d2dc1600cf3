// Drives `keypose studio` on the bimanual wave (two SO-101 arms 0.5 m apart) in Debian's
// Chromium (headless, WebGL through SwiftShader) with playwright-core; run by
// tests/teaching/studio.rs as `node collision.mjs URL SCREENSHOT`. Turns the right arm's pan
// -80° (towards the left arm's side), then the left arm's pan towards the right arm by 10° steps,
// then 1° steps, until a jog is refused; reads which links the page draws red and the status
// line, saves a screenshot and prints one JSON line of results for the Rust side.
import { launchChromium } from './browser.mjs';

const [url, screenshot] = process.argv.slice(2);
// A hang guard, not a timing check.
setTimeout(() => fail('no result after 300 s'), 300000).unref();

function fail(message) {
  console.error(`collision: ${message}`);
  process.exit(1);
}

const browser = await launchChromium();
const results = { steps: [] };
try {
  const page = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
  const errors = [];
  page.on('pageerror', e => errors.push(`page error: ${e.message}`));
  page.on('console', m => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  await page.goto(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller
    && window.studio.view && window.studio.view.meshes !== 'loading', null, { timeout: 120000 })
    .catch(e => fail(`${e.message}; errors ${JSON.stringify(errors)}`));
  // One key, answered; then the snapshot after the arm is at rest.
  const press = async key => {
    await page.evaluate(k => window.studio.send({ key: k }), key);
    await page.evaluate(() => window.studio.sent());
    await page.waitForFunction(() => window.studio.snapshot.activity.kind === 'idle', null, { timeout: 120000 });
    await page.waitForTimeout(150);
    return page.evaluate(() => ({
      status: window.studio.snapshot.status,
      present: window.studio.snapshot.joints.map(j => j.present),
      contacts: window.studio.snapshot.contacts,
      hot: window.studio.view.hotLinks || [],
    }));
  };
  await press('select-joint:6');
  for (let i = 0; i < 8; i++) await press('shift-left');
  await press('select-joint:0');
  let last = null;
  for (const key of [...Array(12).fill('shift-right'), ...Array(12).fill('right')]) {
    const step = await press(key);
    results.steps.push({ key, status: step.status.text, error: step.status.error, pan: step.present[0] });
    if (step.status.error) {
      if (key === 'right') { results.refused = step; break; }
      // A 10° step was refused: go on by 1° steps.
      continue;
    }
    last = step;
    if (results.steps.filter(s => s.error && s.key === 'shift-right').length) continue;
  }
  results.lastAccepted = last;
  await page.screenshot({ path: screenshot });
  results.errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
