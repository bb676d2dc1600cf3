// Undo and redo through the real page (run by tests/teaching/studio_edit.rs as
// `node undo.mjs URL`), on sequences/so101_wave.json: a plain click on a key's mark in the
// timeline selects it without moving it; `d`, Ctrl+Z, Ctrl+Shift+Z, Ctrl+Y and the undo
// button; a key dragged in time and the drag undone; a refusal on the status line replaced by
// the next answer. Prints one JSON line of what the page saw; the test judges it.
import { keyMark, run } from './browser.mjs';

const [url] = process.argv.slice(2);

await run('undo', 300, async ({ open, results, fail, at }) => {
  // The refused key's 400 is this test's own doing.
  const page = await open(url, { quiet: text => /status of 400/.test(text) });
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.timeline);
  const waitFor = (fn, arg) => page.waitForFunction(fn, arg, { timeout: 30000 }).catch(e => fail(`${e.message}: ${fn}`));
  const times = () => page.evaluate(() => window.studio.snapshot.keys.map(k => k.time));
  const goals = () => page.evaluate(() => window.studio.snapshot.joints.map(j => j.goal));
  results.start = await times();
  results.goalsBefore = await goals();

  // ----- a plain click on key 2's mark: selected, not moved -----
  at('click');
  const markX = index => keyMark(page, index);
  const mark = await markX(2);
  await page.mouse.move(mark.x, mark.y);
  await page.mouse.down();
  await page.mouse.move(mark.x + 1, mark.y);
  await page.mouse.up();
  await waitFor(() => window.studio.snapshot.current === 2);
  await page.evaluate(() => window.studio.sent());
  results.afterClick = await times();

  // ----- delete, undo, redo by the keyboard and the button -----
  at('delete');
  await page.keyboard.press('d');
  await waitFor(() => window.studio.snapshot.keys.length === 7);
  results.undoTitle = await page.evaluate(() => document.getElementById('undo').title);
  await page.keyboard.press('Control+z');
  await waitFor(() => window.studio.snapshot.keys.length === 8);
  results.afterUndo = await times();
  results.currentAfterUndo = await page.evaluate(() => window.studio.snapshot.current);
  results.statusAfterUndo = await page.evaluate(() => document.getElementById('status').textContent);
  await page.keyboard.press('Control+Shift+Z');
  await waitFor(() => window.studio.snapshot.keys.length === 7);
  await page.click('#undo');
  await waitFor(() => window.studio.snapshot.keys.length === 8);
  await page.keyboard.press('Control+y');
  await waitFor(() => window.studio.snapshot.keys.length === 7);
  results.redoOffAtEnd = await page.evaluate(() => document.getElementById('redo').disabled);
  await page.keyboard.press('Control+z');
  await waitFor(() => window.studio.snapshot.keys.length === 8);

  // ----- a drag of key 2's mark moves it in time; Ctrl+Z puts it back -----
  at('drag');
  const from = await markX(2), to = await markX(3);
  await page.mouse.move(from.x, from.y);
  await page.mouse.down();
  await page.mouse.move((from.x + to.x) / 2, from.y, { steps: 5 });
  await page.mouse.up();
  await page.waitForFunction(t => window.studio.snapshot.keys[2].time !== t, results.start[2], { timeout: 30000 })
    .catch(async () => fail(`the drag did not move key 2: ${JSON.stringify(await page.evaluate(() => [document.getElementById('status').textContent, window.studio.refusals]))} ${JSON.stringify([from, to])}`));
  await page.evaluate(() => window.studio.sent());
  results.afterDrag = await times();
  await page.keyboard.press('Control+z');
  await waitFor(t => window.studio.snapshot.keys[2].time === t, results.start[2]);
  results.afterDragUndo = await times();
  results.goalsAfter = await goals();

  // ----- a refusal on the status line is replaced by the next answer -----
  at('stale error');
  await page.evaluate(() => window.studio.send({ key: 'select-key:3' }));
  const said = await page.evaluate(() => document.getElementById('status').textContent);
  await page.evaluate(() => window.studio.send({ key: 'jump' }));
  results.refusal = await page.evaluate(() => document.getElementById('status').className);
  // The same key, the same status: the snapshot does not change, the answer does it.
  await page.evaluate(() => window.studio.send({ key: 'select-key:3' }));
  results.afterRefusal = await page.evaluate(() => ({
    text: document.getElementById('status').textContent,
    error: document.getElementById('status').className === 'error',
  }));
  results.saidBefore = said;

  at('write');
  await page.keyboard.press('w');
  await waitFor(() => window.studio.snapshot.dirty === false);
});
