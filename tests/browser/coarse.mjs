// A drag previewed on the chart's coarse level, in real headless Chromium:
// run by tests/editor.rs against `uvpin edit --coarse-above 0` on a copy of
// the sample (so its chart, small as it is, is previewed on its level).
//
// Usage: node coarse.mjs URL DIR VERTICES
//   URL  the editor's address; DIR  the folder holding assets/ and out/;
//   VERTICES  the sample's vertex count.
// With UVPIN_SCREENSHOTS=FOLDER it also saves a screenshot of the drag.
import path from 'node:path';
import { check, launch, openEditor, meshColours, outputUvs, textureToPage, until } from './common.mjs';

const [url, dir, vertices] = process.argv.slice(2);
const output = path.join(dir, 'out/face.glb');
const shots = process.env.UVPIN_SCREENSHOTS;

const browser = await launch();
try {
  const { page, errors } = await openEditor(browser, url);
  const status = page.getByTestId('status');
  const editor = (f, arg) => page.evaluate(f, arg);
  await until('the sample is solved', async () => (await status.getAttribute('data-state')) === 'reached');
  await until('the chart itself is shown', async () => (await editor(() => window.uvpinEditor.shownLevel())) === 0);
  check(true, 'before dragging, the chart itself is shown');

  const first = (await editor(() => window.uvpinEditor.state().constraints))[0];
  const marker = page.locator(`[data-testid=target-marker][data-vertex="${first.vertex}"]`);
  const box = await marker.boundingBox();
  const from = [box.x + box.width / 2, box.y + box.height / 2];
  const dragTo = [first.uv[0] + 0.02, first.uv[1] - 0.015];
  const to = await textureToPage(page, dragTo);
  const saves = await editor(() => window.uvpinEditor.saves);
  await page.mouse.move(from[0], from[1]);
  await page.mouse.down();
  for (let k = 1; k <= 12; k++) {
    await page.mouse.move(from[0] + ((to[0] - from[0]) * k) / 12, from[1] + ((to[1] - from[1]) * k) / 12);
    await page.waitForTimeout(40);
  }
  const level = await until('a preview on the coarse level', () => editor(() => window.uvpinEditor.shownLevel()));
  check(level > 100 && level < Number(vertices), `the drag is shown on a coarse level of ${level} of ${vertices} vertices`);
  const followed = await until('the dragged vertex follows', async () => {
    const uv = await editor((v) => window.uvpinEditor.uvOf(v), first.vertex);
    return uv && Math.hypot(uv[0] - dragTo[0], uv[1] - dragTo[1]) < 1e-4 ? uv : null;
  });
  check(followed, `on the coarse level the landmark is on its target (${followed.map((x) => x.toFixed(4))})`);
  const words = await status.textContent();
  check(words.includes('coarse level') && !words.includes('partial'), `the status says so: ${words.slice(0, 140)}`);
  const colours = await meshColours(page);
  check(colours > 30, `the mesh view draws the coarse level textured (${colours} colours)`);
  if (shots) await page.screenshot({ path: path.join(shots, 'editor-coarse.png') });

  await page.mouse.up();
  await until('the release is saved', async () => (await editor(() => window.uvpinEditor.saves)) > saves);
  await until('the output follows the release', () => {
    const uv = outputUvs(output).uv[first.vertex];
    return Math.hypot(uv[0] - dragTo[0], uv[1] - dragTo[1]) < 1e-4;
  });
  check(true, 'the release is solved in full and written (read back independently)');
  await until('the chart itself is shown again', async () =>
    (await editor(() => window.uvpinEditor.shownLevel())) === 0 && (await status.getAttribute('data-state')) === 'reached');
  check(true, 'after the release the solved chart replaces the coarse level');
  check(errors.length === 0, `no console errors${errors.length ? `: ${errors.join(' | ')}` : ''}`);
} finally {
  await browser.close();
}
