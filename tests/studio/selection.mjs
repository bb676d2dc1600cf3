// Several keys at once through the real page (run by tests/teaching/studio_edit.rs as
// `node selection.mjs URL`), on sequences/so101_wave.json (8 keys): a click, a Shift-click and
// a Ctrl-click in the key list; Ctrl+C, a click on the last key, Ctrl+V; a drag of one pasted
// key's mark on the timeline (both move); `d` deletes both; Ctrl+Z brings them back; Ctrl+A
// selects every key; the easing curve of key 0's segment (smooth: no handles; made linear:
// both handles dragged), then `w`. Prints one JSON line of what the page saw; the test judges it.
import { keyMark, run } from './browser.mjs';

const [url, shots] = process.argv.slice(2);

await run('selection', 300, async ({ open, results, fail, at }) => {
  const page = await open(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.timeline);
  const waitFor = (fn, arg) => page.waitForFunction(fn, arg, { timeout: 30000 }).catch(e => fail(`${e.message}: ${fn}`));
  const selected = () => page.evaluate(() => window.studio.snapshot.keys.flatMap((k, i) => (k.selected ? [i] : [])));
  const ariaSelected = () => page.evaluate(() =>
    [...document.querySelectorAll('#keys tbody tr[aria-selected="true"]')].map(r => Number(r.dataset.index)));
  // The key list is drawn anew on every snapshot: on a busy machine a row found may be
  // replaced before the click lands ("not visible", "detached"); the new row is clicked then.
  const row = async i => {
    for (let attempt = 1; ; attempt++) {
      try {
        return await page.click(`#keys tbody tr[data-index="${i}"] td:nth-child(2)`, { force: true, timeout: 20000 });
      } catch (e) {
        if (attempt >= 5 || !/not visible|detached|not attached/.test(e.message)) throw e;
      }
    }
  };
  const sameSelection = want => waitFor(w => {
    const got = window.studio.snapshot.keys.flatMap((k, i) => (k.selected ? [i] : []));
    return JSON.stringify(got) === JSON.stringify(w);
  }, want);

  at('click, shift-click, ctrl-click');
  await row(1);
  await waitFor(() => window.studio.snapshot.current === 1);
  await page.keyboard.down('Shift'); await row(3); await page.keyboard.up('Shift');
  await sameSelection([1, 2, 3]);
  results.range = await selected();
  results.ariaRange = await ariaSelected();
  await page.keyboard.down('Control'); await row(2); await page.keyboard.up('Control');
  await sameSelection([1, 3]);
  results.toggled = await selected();
  results.statusToggled = await page.evaluate(() => document.getElementById('status').textContent);

  at('copy and paste');
  await page.keyboard.press('Control+c');
  await waitFor(() => /copied/.test(document.getElementById('status').textContent));
  await row(7);
  await waitFor(() => window.studio.snapshot.current === 7);
  await page.keyboard.press('Control+v');
  await waitFor(() => window.studio.snapshot.keys.length === 10);
  results.pasted = await page.evaluate(() => ({
    times: window.studio.snapshot.keys.map(k => k.time),
    values: window.studio.snapshot.keys.map(k => k.values),
    current: window.studio.snapshot.current,
  }));
  results.pastedSelection = await selected();

  at('drag the pasted pair');
  const markX = index => keyMark(page, index);
  const before = results.pasted.times;
  const from = await markX(8), to = await markX(9);
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  await page.mouse.move(from.x + (to.x - from.x) / 4, from.y, { steps: 5 });
  await page.mouse.up();
  await page.waitForFunction(t => window.studio.snapshot.keys[8].time !== t, before[8], { timeout: 30000 })
    .catch(async () => fail(`the drag moved nothing: ${await page.evaluate(() => document.getElementById('status').textContent)}`));
  results.dragged = await page.evaluate(() => window.studio.snapshot.keys.map(k => k.time));

  at('delete and undo');
  await page.keyboard.press('d');
  await waitFor(() => window.studio.snapshot.keys.length === 8);
  results.statusDeleted = await page.evaluate(() => document.getElementById('status').textContent);
  await page.keyboard.press('Control+z');
  await waitFor(() => window.studio.snapshot.keys.length === 10);

  at('easing');
  // Key 0 → 1 of the wave is smooth: the curve is drawn without handles, and says why.
  await row(0);
  await waitFor(() => window.studio.snapshot.current === 0 && window.studio.snapshot.easing.from === 0);
  results.easingCubic = await page.evaluate(() => window.studio.snapshot.easing);
  results.easingLabel = await page.evaluate(() => document.getElementById('easinginfo').textContent);
  // p: smooth → monotone → step → linear; then the handles.
  for (let i = 0; i < 3; i++) await page.keyboard.press('p');
  await waitFor(() => window.studio.snapshot.easing.allowed);
  const handle = which => page.evaluate(w => {
    const c = document.getElementById('easing'), e = window.studio.snapshot.easing;
    const h = window.studio.easing.handles(e.out, e.in).find(h => h.which === w);
    const box = c.getBoundingClientRect();
    return { x: box.left + window.studio.easing.x(h.t), y: box.top + window.studio.easing.y(h.s) };
  }, which);
  await page.locator('#easing').scrollIntoViewIfNeeded();
  const dragTo = async (from, dx) => {
    await page.mouse.move(from.x, from.y);
    await page.mouse.down();
    await page.mouse.move(from.x + dx, from.y, { steps: 6 });
    await page.mouse.up();
  };
  // Steady: both handles sit on the diagonal's ends; drag the start's right, the end's left.
  await dragTo(await handle('out'), 50);
  await page.waitForFunction(() => window.studio.snapshot.easing.out > 0, null, { timeout: 30000 })
    .catch(async () => fail(`the handle did not move: ${await page.evaluate(() => JSON.stringify([document.getElementById('status').textContent, window.studio.snapshot.easing, document.getElementById('easing').getBoundingClientRect()]))}`));
  await dragTo(await handle('in'), -40);
  await waitFor(() => window.studio.snapshot.easing.in > 0);
  results.eased = await page.evaluate(() => window.studio.snapshot.easing);
  results.easedStatus = await page.evaluate(() => document.getElementById('status').textContent);
  // The pasted pair selected beside the eased segment's curve, for docs/commands.md.
  await page.keyboard.down('Control'); await row(8); await row(9); await page.keyboard.up('Control');
  await sameSelection([0, 8, 9]);
  await page.screenshot({ path: `${shots}/studio-selection-easing.png` });
  await page.keyboard.press('w');
  await waitFor(() => window.studio.snapshot.dirty === false);

  at('select all');
  await page.keyboard.press('Control+a');
  await sameSelection([0, 1, 2, 3, 4, 5, 6, 7, 8, 9]);
  results.all = await selected();
});
