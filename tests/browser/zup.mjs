// A Z-up closed mesh, cut open, in the editor: the 3D view stands it on Z
// and opens facing its landmarks (tests/editor.rs checks what the texture
// view is given to draw).
//
// Usage: node zup.mjs URL X Y Z   (X Y Z: the landmarks' mean position)
// With UVPIN_SCREENSHOTS=FOLDER it also saves a screenshot there.
import path from 'node:path';
import { check, launch, openEditor, until } from './common.mjs';

const [url, ...mean] = process.argv.slice(2);
const landmarks = mean.map(Number);
const shots = process.env.UVPIN_SCREENSHOTS;

const browser = await launch();
try {
  const { page, errors } = await openEditor(browser, url);
  const status = page.getByTestId('status');
  await until('solved', async () => ['reached', 'partial'].includes(await status.getAttribute('data-state')));
  const meshView = page.getByTestId('mesh-view');
  await until('the mesh view is painted', async () => (await meshView.getAttribute('data-ready')) === 'true');
  const cam = await until('the camera faces the landmarks', async () => {
    const c = await page.evaluate(() => window.uvpinEditor.camera());
    const toEye = c.eye.map((x, i) => x - c.target[i]);
    const toMarks = landmarks.map((x, i) => x - c.target[i]);
    const across = (v) => [v[0], v[1], 0];
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const cos = dot(across(toEye), across(toMarks)) / Math.hypot(...across(toEye)) / Math.hypot(...across(toMarks));
    return c.up[2] === 1 && cos > 0.9 ? { ...c, cos } : null;
  });
  check(true, `the 3D view stands on Z and looks at the landmarks' side (cos ${cam.cos.toFixed(3)})`);
  if (shots) await page.screenshot({ path: path.join(shots, 'editor-zup.png') });
  check(errors.length === 0, `no page errors (${errors.join('; ')})`);
} finally {
  await browser.close();
}
