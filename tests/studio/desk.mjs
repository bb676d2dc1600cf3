// Drives `keypose studio` on a sequence whose middle key puts the gripper in the desk
// (home → elbow_flex 80° → home) in Debian's Chromium (headless, WebGL through SwiftShader)
// with playwright-core; run by tests/teaching/studio.rs as `node desk.mjs URL SCREENSHOT`.
// Selects the desk key and reads what the page draws (the key's ghost and its colour, the
// timeline's findings), presses space there and y from the first key, reads the status
// line each time, saves a screenshot and prints one JSON line of results for the Rust side.
import { run } from './browser.mjs';

const [url, screenshot] = process.argv.slice(2);

await run('desk', 300, async ({ open, results, fail, at }) => {
  const page = await open(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller
    && window.studio.view && window.studio.view.meshes !== 'loading', null, { timeout: 120000 })
    .catch(e => fail(e.message));
  // One key, answered; then what the page shows once the arm is at rest.
  const press = async key => {
    at(key);
    await page.evaluate(k => window.studio.send({ key: k }), key);
    await page.evaluate(() => window.studio.sent());
    await page.waitForFunction(() => window.studio.snapshot.activity.kind === 'idle', null, { timeout: 120000 });
    await page.waitForTimeout(150);
    return page.evaluate(() => {
      const s = window.studio.snapshot, view = window.studio.view;
      return {
        status: s.status,
        current: s.current,
        contact: (s.keys[s.current] || {}).contact || null,
        ghostContact: !!view.ghostContact,
        ghostColour: view.ghostMaterial.color.getHex(),
        present: s.joints.map(j => j.present),
      };
    });
  };
  results.home = await press('select-key:0');
  results.desk = await press('select-key:1');
  results.space = await press('space');
  await press('select-key:0');
  results.play = await press('y');
  at('findings');
  await page.waitForFunction(() => window.studio.findings && window.studio.findings.check
    && window.studio.findings.check.length > 0, null, { timeout: 60000 }).catch(() => {});
  results.findings = await page.evaluate(() => (window.studio.findings.check || []).map(f => f.text));
  await press('select-key:1');
  await page.screenshot({ path: screenshot });
});
