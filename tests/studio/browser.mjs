// What the studio's browser scripts share: Debian's Chromium, headless, driven by
// playwright-core, with WebGL through SwiftShader.
import { chromium } from 'playwright-core';

export function launchChromium() {
  return chromium.launch({
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
    // playwright-core gives every launch a fresh, empty profile of its own (a user-data-dir in
    // the temporary directory, removed on close); it never downloads a browser.
  });
}

// One browser script's frame: `name` for its messages, a deadline of `seconds`, the results
// it prints as its last line (a JSON object with `errors`), and `open(url)`, a page of the
// studio at 1280×800 whose errors go into the results (`quiet(text)` leaves out a console error
// the script causes on purpose). `body` gets { open, results, fail, at }; `at(step)` names
// what a failure or the deadline interrupted.
export async function run(name, seconds, body) {
  let step = 'start';
  const fail = message => {
    console.error(`${name}: ${message}`);
    process.exit(1);
  };
  setTimeout(() => fail(`no result after ${seconds} s, at: ${step}`), seconds * 1000).unref();
  const browser = await launchChromium();
  const results = { errors: [] };
  const open = async (url, { quiet = () => false } = {}) => {
    const page = await (await browser.newContext({ viewport: { width: 1280, height: 800 } })).newPage();
    page.on('pageerror', e => results.errors.push(`page error: ${e.message}`));
    page.on('console', m => {
      if (m.type() === 'error' && !quiet(m.text())) results.errors.push(`console: ${m.text()}`);
    });
    await page.goto(url);
    return page;
  };
  try {
    await body({ open, results, fail, at: s => { step = s; } });
  } catch (e) {
    fail(`${step}: ${e.stack || e}`);
  } finally {
    await browser.close();
  }
  console.log(JSON.stringify(results));
}

// Where key `index`'s mark is on the page's timeline (viewport pixels, 30 px below its top),
// once the timeline drawn is the one of the list as it is now (it is fetched after each
// change; the wave's wrist_flex is set by every key, so its row has a mark per key). The same
// span the timeline uses: the curves' and the keys' times.
export async function keyMark(page, index) {
  // The timeline drawn for the snapshot shown now: a fetch for an older list (as many keys,
  // or fewer) may still be on its way under load.
  await page.waitForFunction(() => window.studio.timelineKeys ===
    JSON.stringify([window.studio.snapshot.keys, window.studio.snapshot.current]), null, { timeout: 30000 });
  return page.evaluate(i => {
    const c = document.getElementById('timeline');
    const t = window.studio.snapshot.keys[i].time;
    const d = window.studio.timeline, keys = window.studio.snapshot.keys.map(k => k.time);
    const a = Math.min(d.start, ...keys), b = Math.max(d.end, ...keys, d.start + 0.1);
    const x = 110 + (t - a) / (b - a) * (c.clientWidth - 120);
    const box = c.getBoundingClientRect();
    return { x: box.left + x, y: box.top + 30 };
  }, index);
}
