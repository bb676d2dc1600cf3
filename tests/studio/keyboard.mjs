// The page by keyboard, on a phone's screen (run by tests/teaching/studio_keyboard.rs as
// `node keyboard.mjs URL`), on sequences/so101_wave.json, in a 390×844 viewport at 3 device
// pixels per CSS pixel: the layout (no sideways scroll, Stop in reach, a sharp timeline);
// Space and Enter on a focused button press it; Tab into the key list, arrows within it, its
// ARIA roles; the live region speaking the status; the unsaved mark and the browser's
// question on reload. Prints one JSON line of what the page saw; the test judges it.
import { launchChromium } from './browser.mjs';

const [url] = process.argv.slice(2);
let step = 'start';
setTimeout(() => fail(`no result after 300 s, at: ${step}`), 300000).unref();

function fail(message) {
  console.error(`keyboard: ${message}`);
  process.exit(1);
}

// Thrown to end the run early, with what it saw so far.
class Done extends Error {}

const browser = await launchChromium();
const results = { errors: [] };
try {
  const context = await browser.newContext({ viewport: { width: 390, height: 844 }, deviceScaleFactor: 3 });
  const page = await context.newPage();
  page.on('pageerror', e => results.errors.push(`page error: ${e.message}`));
  page.on('console', m => {
    // The reload at the end loads the page without its token (it left the address bar).
    if (m.type() === 'error' && !/status of 403/.test(m.text())) results.errors.push(`console: ${m.text()}`);
  });
  await page.goto(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.timeline);
  // Waits for fn(arg) in the page; false (recorded, judged by the test) when it never holds.
  const waitFor = (fn, arg) => page.waitForFunction(fn, arg, { timeout: 30000 }).then(() => true, () => false);
  const snapshot = () => page.evaluate(() => {
    const s = window.studio.snapshot;
    return { current: s.current, selected: s.selected, goals: s.joints.map(j => j.goal), activity: s.activity.kind, dirty: s.dirty };
  });

  // ----- the layout at 390 px -----
  step = 'layout';
  results.layout = await page.evaluate(() => {
    const root = document.documentElement;
    const c = document.getElementById('timeline');
    const right = el => el.getBoundingClientRect().right;
    const buttons = [...document.querySelectorAll('button')].filter(b => b.offsetParent);
    return {
      scrollWidth: root.scrollWidth, clientWidth: root.clientWidth, ratio: window.devicePixelRatio,
      canvasWidth: c.width, canvasCssWidth: c.clientWidth, canvasHeight: c.height, canvasCssHeight: c.clientHeight,
      keysRight: right(document.getElementById('keys')),
      buttonsRight: Math.max(...buttons.map(right)),
      // The 3D view above the timeline: its foot no lower than the timeline's top.
      stacked: document.getElementById('view').getBoundingClientRect().bottom <= c.getBoundingClientRect().top,
    };
  });
  // Scrolled to the foot (the timeline): the Stop button is still on the screen.
  await page.evaluate(() => window.scrollTo(0, document.documentElement.scrollHeight));
  results.layout.scrolled = await page.evaluate(() => window.scrollY);
  results.layout.stopVisible = await page.locator('#stop').isVisible();
  results.layout.stopInView = await page.evaluate(() => {
    const r = document.getElementById('stop').getBoundingClientRect();
    return r.top >= 0 && r.bottom <= window.innerHeight && r.left >= 0 && r.right <= window.innerWidth;
  });
  await page.evaluate(() => window.scrollTo(0, 0));

  // ----- Space and Enter on a focused button -----
  step = 'space on a button';
  // On key 1 ("raise", away from the arm's pose at home), where the page's Space (go to the
  // key) would move the arm.
  await page.evaluate(() => window.studio.send({ key: 'select-key:1' }));
  await waitFor(() => window.studio.snapshot.current === 1);
  const before = await snapshot();
  results.before = before;
  await page.focus('button[data-key=">"]');
  await page.keyboard.press(' ');
  results.spacePressed = await waitFor(c => window.studio.snapshot.current === c + 1, before.current);
  await page.evaluate(() => window.studio.sent());
  results.afterSpace = await snapshot();
  results.focusKept = await page.evaluate(() => document.activeElement.dataset.key);
  await page.focus('button[data-key="<"]');
  await page.keyboard.press('Enter');
  results.enterPressed = await waitFor(c => window.studio.snapshot.current === c, before.current);
  await page.evaluate(() => window.studio.sent());
  results.afterEnter = await snapshot();

  // ----- the key list: Tab into it, arrows within it -----
  step = 'key list';
  // The control before the list in the tab order: the last joint button.
  await page.focus('#jointbuttons button:last-of-type');
  await page.keyboard.press('Tab');
  results.tabbedInto = await page.evaluate(() => ({
    role: document.activeElement.getAttribute('role'),
    options: document.activeElement.querySelectorAll('[role=option]').length,
  }));
  const liveBefore = await page.evaluate(() => document.querySelector('[aria-live]')?.textContent ?? null);
  const aria = () => page.evaluate(() => {
    const list = document.querySelector('[role=listbox]');
    return {
      selected: [...document.querySelectorAll('[role=option]')].map(o => o.getAttribute('aria-selected') === 'true'),
      active: list && list.getAttribute('aria-activedescendant'),
    };
  });
  const start = (await snapshot()).current;
  await page.keyboard.press('ArrowDown');
  results.arrowDown = await waitFor(c => window.studio.snapshot.current === c + 1, start);
  await page.evaluate(() => window.studio.sent());
  await waitFor(c => document.querySelector(`[role=option][aria-selected=true]`)?.dataset.index === String(c + 1), start);
  results.ariaAfterDown = await aria();
  results.afterDown = await snapshot();
  // The live region says what the status line says, once it has caught up.
  await waitFor(() => {
    const live = document.querySelector('[aria-live]');
    return live && live.textContent === document.getElementById('status').textContent;
  });
  results.live = await page.evaluate(was => ({
    before: was,
    after: document.querySelector('[aria-live]')?.textContent ?? null,
    status: document.getElementById('status').textContent,
  }), liveBefore);
  await page.keyboard.press('ArrowUp');
  results.arrowUp = await waitFor(c => window.studio.snapshot.current === c, start);
  await page.evaluate(() => window.studio.sent());
  await waitFor(c => document.querySelector(`[role=option][aria-selected=true]`)?.dataset.index === String(c), start);
  results.ariaAfterUp = await aria();
  results.afterUp = await snapshot();
  results.start = start;

  // ----- unsaved edits: the mark, the question on reload -----
  step = 'unsaved';
  await page.evaluate(() => document.activeElement.blur());
  results.markBefore = await page.locator('#unsaved').isVisible();
  await page.keyboard.press(']');
  results.edited = await waitFor(() => window.studio.snapshot.dirty === true);
  await page.evaluate(() => window.studio.sent());
  results.markAfterEdit = await page.locator('#unsaved').isVisible();
  const dialogs = [];
  page.on('dialog', d => { dialogs.push(d.type()); d.dismiss().catch(() => {}); });
  // Dismissed, the question keeps the page: the reload never completes.
  page.reload({ timeout: 30000 }).catch(() => {});
  results.askedOnReload = await page.waitForEvent('dialog', { timeout: 30000 }).then(d => d.type(), () => null);
  // Not asked, the page has reloaded (without its token): nothing more to see.
  if (!results.askedOnReload) throw new Done();
  await page.keyboard.press('w');
  results.saved = await waitFor(() => window.studio.snapshot.dirty === false);
  results.markAfterSave = await page.locator('#unsaved').isVisible();
  const asked = dialogs.length;
  await page.reload({ timeout: 30000 }).catch(e => results.errors.push(`reload after save: ${e.message}`));
  results.dialogsAfterSave = dialogs.length - asked;
} catch (e) {
  if (!(e instanceof Done)) fail(`${step}: ${e.stack || e}`);
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
