// The direction check in the page (run by tests/teaching/direction.rs as `node direction.mjs
// URL`): the "direction check" button starts it; for each joint the page asks, with the
// joint's name, whether the real one moved as the drawn one did, and its two buttons answer:
// "moved as drawn" for every joint but the elbow (the third), "reversed" for it. Then the
// elbow is selected and jogged +1° by the page's button. Prints one JSON line of what the page
// showed; the test judges it (the file and the servo are its oracle).
import { launchChromium } from './browser.mjs';

const [url] = process.argv.slice(2);
let step = 'start';
setTimeout(() => fail(`no result after 300 s, at: ${step}`), 300000).unref();

function fail(message) {
  console.error(`direction: ${message}`);
  process.exit(1);
}

const browser = await launchChromium();
const results = { errors: [], questions: [] };
try {
  const page = await (await browser.newContext({ viewport: { width: 1200, height: 800 } })).newPage();
  page.on('pageerror', e => results.errors.push(`page error: ${e.message}`));
  page.on('console', m => { if (m.type() === 'error') results.errors.push(`console: ${m.text()}`); });
  await page.goto(url);
  // Hang guards, not timings: a loaded machine may take long over a jog.
  const waitFor = (fn, arg) => page.waitForFunction(fn, arg, { timeout: 120000 });
  await waitFor(() => window.studio && window.studio.snapshot && window.studio.controller);

  step = 'the button';
  await page.click('button[data-key="D"]');
  for (let joint = 0; joint < 6; joint++) {
    step = `joint ${joint}`;
    // Asked once the joint's 5° jog is over.
    await waitFor(j => {
      const s = window.studio.snapshot;
      return s.prompt && s.prompt.kind === 'direction' && s.prompt.joint === j && s.activity.kind === 'idle';
    }, joint);
    results.questions.push(await page.evaluate(() => ({
      text: document.getElementById('question').textContent,
      buttonsShown: !document.getElementById('direction').hidden,
      yesNoShown: !document.getElementById('yesno').hidden,
    })));
    await page.click(joint === 2 ? '#direction button[data-key="r"]' : '#direction button[data-key="m"]');
  }
  step = 'done';
  await waitFor(() => !window.studio.snapshot.prompt && window.studio.snapshot.activity.kind === 'idle');
  results.status = await page.evaluate(() => document.getElementById('status').textContent);

  step = 'elbow +1°';
  await page.evaluate(() => window.studio.send({ key: 'select-joint:2' }));
  await waitFor(() => window.studio.snapshot.selected === 2);
  const before = await page.evaluate(() => window.studio.snapshot.joints[2].present);
  await page.click('button[data-key="right"]');
  await waitFor(b => {
    const s = window.studio.snapshot;
    return Math.abs(s.joints[2].present - (b + 1)) < 0.1 && s.activity.kind === 'idle';
  }, before);
  results.elbow = await page.evaluate(() => window.studio.snapshot.joints[2].present);
} catch (e) {
  fail(`${step}: ${e.stack || e}`);
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
