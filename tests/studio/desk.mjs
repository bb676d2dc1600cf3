// Drives `keypose studio` on a sequence whose middle key puts the gripper in the desk
// (home → elbow_flex 80° → home) in Debian's Chromium (headless, WebGL through SwiftShader)
// with playwright-core; run by tests/teaching/studio.rs as `node desk.mjs URL SCREENSHOT`.
// Selects the desk key and reads what the page draws (the key's ghost and its colour, the
// timeline's findings), presses space there and y from the first key, reads the status
// line each time, saves a screenshot and prints one JSON line of results for the Rust side.
import { launchChromium } from './browser.mjs';

const [url, screenshot] = process.argv.slice(2);
// A hang guard, not a timing check.
setTimeout(() => fail('no result after 300 s'), 300000).unref();

function fail(message) {
  console.error(`desk: ${message}`);
  process.exit(1);
}

const browser = await launchChromium();
const results = {};
try {
  const page = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
  const errors = [];
  page.on('pageerror', e => errors.push(`page error: ${e.message}`));
  page.on('console', m => { if (m.type() === 'error') errors.push(`console: ${m.text()}`); });
  await page.goto(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller
    && window.studio.view && window.studio.view.meshes !== 'loading', null, { timeout: 120000 })
    .catch(e => fail(`${e.message}; errors ${JSON.stringify(errors)}`));
  // One key, answered; then what the page shows once the arm is at rest.
  const press = async key => {
    await page.evaluate(k => window.studio.send({ key: k }), key);
    await page.evaluate(() => window.studio.sent());
    await page.waitForFunction(() => window.studio.snapshot.activity.kind === 'idle', null, { timeout: 120000 });
    await page.waitForTimeout(150);
    return page.evaluate(() => ({
      status: window.studio.snapshot.status,
      current: window.studio.snapshot.current,
      contact: (window.studio.snapshot.keys[window.studio.snapshot.current] || {}).contact || null,
      ghostContact: !!window.studio.view.ghostContact,
      ghostColour: window.studio.view.ghostMaterial.color.getHex(),
      present: window.studio.snapshot.joints.map(j => j.present),
    }));
  };
  results.home = await press('select-key:0');
  results.desk = await press('select-key:1');
  results.space = await press('space');
  await press('select-key:0');
  results.play = await press('y');
  await page.waitForFunction(() => window.studio.findings && window.studio.findings.check
    && window.studio.findings.check.length > 0, null, { timeout: 60000 }).catch(() => {});
  results.findings = await page.evaluate(() => (window.studio.findings.check || []).map(f => f.text));
  await press('select-key:1');
  await page.screenshot({ path: screenshot });
  results.errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
