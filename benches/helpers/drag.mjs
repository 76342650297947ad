// Drags a target marker in the editor for a few seconds in headless Chromium
// and prints what the page measured, as JSON: the latency from each pointer
// move to the redraw of its solve, how many solves were drawn, and for how
// long the drag ran, and the coarse level's vertices it was shown on (0:
// the chart itself). Used by `cargo bench --bench editor`.
//
// Usage: node drag.mjs URL SECONDS
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const { chromium } = createRequire(path.join(here, '../../.tools/node_modules/'))('playwright-core');
const [url, seconds] = [process.argv[2], Number(process.argv[3] || 4)];

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
    '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1600, height: 820 } });
  await page.goto(url);
  const t0 = Date.now();
  while ((await page.getByTestId('status').getAttribute('data-state')) !== 'reached') {
    if (Date.now() - t0 > 120000) throw new Error('the sample never solved');
    await page.waitForTimeout(50);
  }
  // As a user would: the layout is shown and the page ready to drag.
  while (!(await page.evaluate(() => window.uvpinEditor.dragReady()))) await page.waitForTimeout(50);
  const start = await page.evaluate(() => window.uvpinEditor.state().constraints[0].uv);
  const screen = async (uv) => {
    const f = await page.evaluate((p) => window.uvpinEditor.textureToScreen(p), uv);
    const box = await page.getByTestId('texture-view').boundingBox();
    return [box.x + f[0], box.y + f[1]];
  };
  const box = await page.getByTestId('target-marker').first().boundingBox();
  const from = [box.x + box.width / 2, box.y + box.height / 2];
  const edge = await screen([start[0] + 0.015, start[1]]);
  const radius = edge[0] - from[0];
  await page.mouse.move(from[0], from[1]);
  await page.mouse.down();
  const began = Date.now();
  let k = 0;
  // A pointer move every 16 ms (60 Hz), round a small circle.
  while (Date.now() - began < seconds * 1000) {
    const a = (k++ / 60) * Math.PI * 2;
    await page.mouse.move(from[0] + radius * Math.sin(a), from[1] + radius * (1 - Math.cos(a)) * 0.5);
    await page.waitForTimeout(16);
  }
  const elapsed = (Date.now() - began) / 1000;
  const level = await page.evaluate(() => window.uvpinEditor.shownLevel());
  await page.mouse.up();
  const m = await page.evaluate(() => ({ latencies: window.uvpinEditor.latencies, previews: window.uvpinEditor.previews }));
  console.log(JSON.stringify({ ...m, level, seconds: elapsed, moves: k }));
} finally {
  await browser.close();
}
