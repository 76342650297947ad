// The editor in real headless Chromium (driven by playwright-core): run by
// tests/editor.rs against `uvpin edit` on a copy of the sample.
//
// Usage: node editor.mjs URL DIR
//   URL  the editor's address; DIR  the folder holding assets/ and out/.
// With UVPIN_SCREENSHOTS=FOLDER it also saves the README's screenshots.
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { check, launch, openEditor, meshColours, outputUvs as read, textureToPage, until } from './common.mjs';

const [url, dir] = process.argv.slice(2);
const ron = path.join(dir, 'assets/face.uvpin.ron');
const output = path.join(dir, 'out/face.glb');
const shots = process.env.UVPIN_SCREENSHOTS;
const outputUvs = () => read(output);

function rawGet(target, host) {
  const u = new URL(url);
  return new Promise((resolve, reject) => {
    const req = http.request({ host: u.hostname, port: u.port, path: target, headers: { Host: host } }, (res) => {
      res.resume();
      resolve(res.statusCode);
    });
    req.on('error', reject);
    req.end();
  });
}

const browser = await launch();
try {
  const { page, errors } = await openEditor(browser, url);
  const status = page.getByTestId('status');
  const stateIs = (s) => until(`status ${s}`, async () => (await status.getAttribute('data-state')) === s);
  await stateIs('reached');
  const items = page.getByTestId('constraint');
  await until('12 constraints listed', async () => (await items.count()) === 12);
  check(true, 'the page lists the 12 constraints and says reached');

  // The mesh view is not blank: many colours in the WebGL canvas, sampled
  // once the page says this frame painted the solved mesh and its texture.
  const meshView = page.getByTestId('mesh-view');
  await until('the mesh view is painted', async () => (await meshView.getAttribute('data-ready')) === 'true');
  const colours = await meshColours(page);
  check(colours > 30, `the mesh view is drawn (${colours} colours)`);
  if (shots) await page.screenshot({ path: path.join(shots, 'editor.png') });

  // Click the mesh on an unconstrained vertex, then the texture: a new constraint.
  const meshBox = await page.getByTestId('mesh-view').boundingBox();
  const constrained = new Set((await page.evaluate(() => window.uvpinEditor.state().constraints)).map((c) => c.vertex));
  let picked = null;
  for (const [fx, fy] of [[0.36, 0.55], [0.62, 0.6], [0.4, 0.35], [0.6, 0.3], [0.45, 0.75]]) {
    await page.mouse.click(meshBox.x + meshBox.width * fx, meshBox.y + meshBox.height * fy);
    const sel = await page.evaluate(() => window.uvpinEditor.state().selected);
    if (sel && !constrained.has(sel.vertex)) {
      picked = sel;
      break;
    }
  }
  check(picked !== null, `clicking the mesh selects vertex ${picked && picked.vertex}`);
  await until('the selection is shown', async () => (await page.getByTestId('selection').textContent()).includes(`vertex ${picked.vertex}`));
  const now = await page.evaluate((v) => window.uvpinEditor.uvOf(v), picked.vertex);
  const target = [now[0] + 0.01, now[1] + 0.01];
  const toScreen = (uv) => textureToPage(page, uv);
  const at = await toScreen(target);
  await page.mouse.click(at[0], at[1]);
  await until('13 constraints listed', async () => (await items.count()) === 13);
  await until('the file gains the constraint', () => fs.readFileSync(ron, 'utf8').includes(`(vertex: ${picked.vertex}, uv: (`));
  check(true, `the constraint file gains vertex ${picked.vertex}`);
  await until('the output is re-solved with it', () => {
    const uvs = outputUvs();
    const uv = uvs.uv[picked.vertex];
    return Math.hypot(uv[0] - target[0], uv[1] - target[1]) < 2e-3 && uvs.positive === 0 && uvs.zero === 0;
  });
  check(true, 'the output has the vertex on its target (read back independently), no flipped triangles');
  await stateIs('reached');

  // Drag its marker: the layout follows while dragging; the release is saved.
  const previewsBefore = await page.evaluate(() => window.uvpinEditor.previews);
  const savesBefore = await page.evaluate(() => window.uvpinEditor.saves);
  const marker = page.locator(`[data-testid=target-marker][data-vertex="${picked.vertex}"]`);
  const mbox = await marker.boundingBox();
  check(mbox !== null, 'the new target is a numbered marker');
  const from = [mbox.x + mbox.width / 2, mbox.y + mbox.height / 2];
  const dragTo = [target[0] + 0.03, target[1] - 0.02];
  const to = await toScreen(dragTo);
  await page.mouse.move(from[0], from[1]);
  await page.mouse.down();
  for (let k = 1; k <= 12; k++) {
    await page.mouse.move(from[0] + ((to[0] - from[0]) * k) / 12, from[1] + ((to[1] - from[1]) * k) / 12);
    await page.waitForTimeout(40);
  }
  await until('a preview of the dragged target', async () => (await page.evaluate(() => window.uvpinEditor.previews)) > previewsBefore);
  const followed = await until('the layout follows the drag', async () => {
    const uv = await page.evaluate((v) => window.uvpinEditor.uvOf(v), picked.vertex);
    return Math.hypot(uv[0] - dragTo[0], uv[1] - dragTo[1]) < 5e-3 ? uv : null;
  });
  check(followed, `while dragging, the vertex follows to (${followed.map((x) => x.toFixed(3))})`);
  await page.mouse.up();
  await until('the release is saved', async () => (await page.evaluate(() => window.uvpinEditor.saves)) > savesBefore);
  await until('the output follows the release', () => {
    const uv = outputUvs().uv[picked.vertex];
    return Math.hypot(uv[0] - dragTo[0], uv[1] - dragTo[1]) < 5e-3;
  });
  check(true, 'the dragged target is saved and the output re-solved');
  await stateIs('reached');
  await until('the mesh view is painted', async () => (await meshView.getAttribute('data-ready')) === 'true');
  if (shots) await page.screenshot({ path: path.join(shots, 'editor-added.png') });

  // A broken save outside the page: the error with line:column; the output kept.
  const good = fs.readFileSync(ron, 'utf8');
  const kept = fs.readFileSync(output);
  fs.writeFileSync(ron, good.replace('constraints: [', 'constraints: [ (vertex: 1 uv: (0.5, 0.5)),'));
  await stateIs('error');
  const text = await status.textContent();
  check(/:\d+:\d+/.test(text), `the status shows the error with line:column: ${text.slice(0, 120)}`);
  check(Buffer.compare(kept, fs.readFileSync(output)) === 0, 'the output is kept while the file is broken');
  if (shots) await page.screenshot({ path: path.join(shots, 'editor-error.png') });
  fs.writeFileSync(ron, good);
  await stateIs('reached');
  check(true, 'fixing the file recovers');

  // Undo: the new constraint goes away again, in the page and the file.
  await page.getByTestId('undo').click();
  await page.getByTestId('undo').click();
  await until('12 constraints after undo', async () => (await items.count()) === 12);
  await until('the file loses it', () => !fs.readFileSync(ron, 'utf8').includes(`(vertex: ${picked.vertex},`));
  check(true, 'undo removes it from the page and the file');

  // The server refuses foreign hosts and paths outside.
  const host = new URL(url).host;
  check((await rawGet('/api/files', 'evil.example')) === 403, 'a foreign Host header is refused');
  check((await rawGet('/../Cargo.toml', host)) === 404, 'a ../ path is refused');
  check(errors.length === 0, `no console errors${errors.length ? `: ${errors.join(' | ')}` : ''}`);
} finally {
  await browser.close();
}
