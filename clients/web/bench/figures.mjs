// What the viewer costs in this machine's headless Chromium (SwiftShader, a
// CPU renderer: a floor, not what a GPU gives), against a real release
// `dmesh serve --demo`: per size, the median over repeated updates of the
// draw (three passes, GPU finished), the frame (request sent to picture on
// screen), the decode per 10,000 triangles and the bytes per update.
//
//   cargo build --release --workspace --bins
//   (cd clients/web && DMESH_BIN=../../target/release node bench/figures.mjs [updates])

import os from 'node:os';
import { demoNovel, launch, openViewer, startServer, viewerUrl, waitReady } from '../test/harness.js';

const updates = Number(process.argv[2] || 9);
const median = (/** @type {number[]} */ v) => {
  const s = [...v].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
const server = await startServer(['--demo']);
const browser = await launch();
const rows = [];
try {
  for (const [w, h] of [[256, 192], [640, 480], [1280, 720]]) {
    for (const tau of [1, 4]) {
      const { page } = await openViewer(browser, viewerUrl(server.url, { scene: 'demo', camera: demoNovel(), tau, w, h }), { width: w + 300, height: h });
      await waitReady(page);
      /** @type {Record<string, number[]>} */
      const m = { frame: [], decode: [], bytes: [], transfer: [], triangles: [], extract: [] };
      for (let k = 0; k < updates; k++) {
        const n = await page.evaluate(() => /** @type {any} */ (window).dmeshStats.updates);
        await page.evaluate(() => /** @type {any} */ (window).dmeshRefresh());
        await page.waitForFunction((u) => /** @type {any} */ (window).dmeshStats.updates > u && /** @type {any} */ (window).dmeshIdle(), n);
        const s = await page.evaluate(() => /** @type {any} */ (window).dmeshStats);
        m.frame.push(s.frame_ms); m.decode.push(s.decode_ms); m.bytes.push(s.bytes); m.transfer.push(s.transfer_bytes);
        m.triangles.push(s.triangles); m.extract.push(s.extract_ms);
      }
      const draws = await page.evaluate((n) => /** @type {any} */ (window).dmeshDrawTimes(n), updates);
      const tri = median(m.triangles);
      rows.push(`| ${w} x ${h} | ${tau} | ${tri.toLocaleString('en')} | ${median(draws).toFixed(1)} | ${median(m.frame).toFixed(1)} | ${median(m.extract).toFixed(1)} | ${(median(m.decode) / tri * 1e4).toFixed(2)} | ${(median(m.bytes) / 1024).toFixed(0)} kB (${(median(m.transfer) / 1024).toFixed(0)} kB sent) |`);
      await page.close();
    }
  }
} finally {
  await browser.close();
  await server.stop();
}
console.log(`${os.cpus()[0].model}, ${os.cpus().length} cores; headless Chromium, WebGL2 on SwiftShader; medians of ${updates} updates`);
console.log('| canvas | tau (px) | triangles | draw (ms) | frame (ms) | server extract (ms) | decode per 10k triangles (ms) | bytes per update |');
console.log('|---|---|---|---|---|---|---|---|');
rows.forEach((r) => console.log(r));
