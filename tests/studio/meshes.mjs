// Drives `keypose studio` on an SO-101 in Debian's Chromium (headless, WebGL through
// SwiftShader) with playwright-core; run by tests/teaching/studio.rs as
// `node meshes.mjs URL SCREENSHOT`. Waits for the official meshes, moves the arm to the
// wave's "raise" key, checks that every drawn mesh of the arm projects inside the view at
// 1280×800, saves a screenshot and prints one JSON line of results for the Rust side.
import { launchChromium } from './browser.mjs';

const [url, screenshot] = process.argv.slice(2);
// A hang guard, not a timing check.
setTimeout(() => fail('no result after 300 s'), 300000).unref();

function fail(message) {
  console.error(`meshes: ${message}`);
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
  // Key 1 is "raise": the arm moves there (space), up and to the side.
  for (const key of ['select-key:1', 'space']) {
    await page.evaluate(k => window.studio.send({ key: k }), key);
  }
  await page.evaluate(() => window.studio.sent());
  await page.waitForFunction(() => {
    const s = window.studio.snapshot;
    return Math.abs(s.joints[0].present - 20) < 0.1 && Math.abs(s.joints[2].present + 45) < 0.1
      && s.activity.kind === 'idle';
  }, null, { timeout: 120000 }).catch(e => fail(`${e.message}; errors ${JSON.stringify(errors)}`));
  await page.waitForTimeout(500);
  Object.assign(results, await page.evaluate(async () => {
    const THREE = await import('three');
    const view = window.studio.view;
    const arm = view.parts[0].arm;
    view.scene.updateMatrixWorld(true);
    // Every vertex of every visible mesh of the arm, projected: where it lands in the view.
    const lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    const p = new THREE.Vector3();
    let meshes = 0;
    arm.root.traverse(o => {
      if (!o.isMesh || !o.visible || !arm.shapes.includes(o)) return;
      meshes += 1;
      const position = o.geometry.attributes.position;
      for (let i = 0; i < position.count; i++) {
        p.fromBufferAttribute(position, i).applyMatrix4(o.matrixWorld).project(view.camera);
        lo[0] = Math.min(lo[0], p.x); lo[1] = Math.min(lo[1], p.y);
        hi[0] = Math.max(hi[0], p.x); hi[1] = Math.max(hi[1], p.y);
      }
    });
    // The jaw's mesh: where the page draws it, to compare with forward kinematics.
    const jaw = arm.shapes.find(o => o.userData.link === 'gripper');
    const box = new THREE.Box3().setFromObject(jaw);
    return {
      state: view.meshes,
      meshes,
      links: [...new Set(arm.shapes.map(o => o.userData.link))],
      stl: arm.shapes.every(o => o.geometry.attributes.position.count > 0),
      ndcLow: lo, ndcHigh: hi,
      jawBox: [box.min.toArray(), box.max.toArray()],
      present: window.studio.snapshot.joints.map(j => j.present),
    };
  }));
  await page.screenshot({ path: screenshot });
  results.errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(results));
