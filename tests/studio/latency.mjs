// A servo's move → the page's frame (run by tests/teaching/studio_truth.rs as
// `node latency.mjs URL SECONDS`): the studio is on a `keypose virtual-bus` whose hand moves
// the limp arm; the page releases every joint (`T`, answered yes) and then records, for
// SECONDS, when each drawn frame showed which pose (window.studio.frames: the wall clock the
// hand's start is stamped with). Prints one JSON line; the test finds the moves in it.
import { run } from './browser.mjs';

const [url, seconds] = process.argv.slice(2);

await run('latency', 300, async ({ open, results, fail, at }) => {
  const page = await open(url);
  await page.waitForFunction(() => window.studio && window.studio.snapshot && window.studio.controller && window.studio.view,
    null, { timeout: 60000 });
  at('release');
  await page.evaluate(() => window.studio.press('T'));
  // Weight-bearing joints are asked about first; the answer releases them.
  if (await page.evaluate(() => Boolean(window.studio.snapshot.prompt))) {
    await page.evaluate(() => window.studio.press('y'));
  }
  await page.waitForFunction(() => window.studio.snapshot.joints.every(j => !j.torque), null, { timeout: 30000 })
    .catch(e => fail(`not released: ${e.message}`));
  at('watch');
  await new Promise(resolve => setTimeout(resolve, Number(seconds) * 1000));
  results.frames = await page.evaluate(() => window.studio.frames);
});
