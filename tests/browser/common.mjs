// What the browser tests share: Chromium with software WebGL, checks that
// say what they saw, waiting for a condition, the independent reader.
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
// playwright-core from the repository's .tools (the README's test command installs it).
const { chromium } = createRequire(path.join(here, '../../.tools/node_modules/'))('playwright-core');
const WAIT = 60000;

export function launch() {
  return chromium.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: [
      '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
      '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
      '--disable-quic',
    ],
  });
}

// The editor at `url` in a new page of `browser`; `errors` collects what
// its console reports as errors and what it throws.
export async function openEditor(browser, url) {
  const page = await browser.newPage({ viewport: { width: 1600, height: 820 }, deviceScaleFactor: 1 });
  const errors = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(String(e)));
  await page.goto(url);
  return { page, errors };
}

export function check(ok, what) {
  if (!ok) throw new Error(`check failed: ${what}`);
  console.log(`ok: ${what}`);
}

// Waits until `f` gives a true value (and returns it); fails after a minute.
export async function until(what, f) {
  const t0 = Date.now();
  for (;;) {
    const v = await f();
    if (v) return v;
    if (Date.now() - t0 > WAIT) throw new Error(`timed out: ${what}`);
    await new Promise((r) => setTimeout(r, 50));
  }
}

// The UVs of primitive 0 of the glTF file `output`, read by the independent reader.
export function outputUvs(output) {
  const reader = path.join(here, '../helpers/read_gltf.py');
  const out = JSON.parse(execFileSync('python3', [reader, output, '0', 'uvs']).toString());
  return out[0];
}

// How many colours the mesh view's WebGL canvas shows (sampled).
export function meshColours(page) {
  return page.evaluate(() => {
    const c = document.querySelector('[data-testid=mesh-view]');
    const t = document.createElement('canvas');
    t.width = c.width;
    t.height = c.height;
    const x = t.getContext('2d');
    x.drawImage(c, 0, 0);
    const d = x.getImageData(0, 0, t.width, t.height).data;
    const seen = new Set();
    for (let i = 0; i < d.length; i += 4 * 13) seen.add(((d[i] >> 3) << 10) | ((d[i + 1] >> 3) << 5) | (d[i + 2] >> 3));
    return seen.size;
  });
}

// A texture coordinate's position on the page.
export async function textureToPage(page, uv) {
  const f = await page.evaluate((p) => window.uvpinEditor.textureToScreen(p), uv);
  const box = await page.getByTestId('texture-view').boundingBox();
  return [box.x + f[0], box.y + f[1]];
}
