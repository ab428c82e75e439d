// The viewer's compact-stream decoder timed, not tested: in Node and in
// the page of a real headless Chromium, on the demo's render answers of a
// real `dmesh serve --demo` (tau 1 px with 10 planes, tau 0.25 px with 10
// planes and with all). Median of 15 decodes after 30 warm-up ones; rates
// per 100,000 triangles and in millions of triangles a second, written to
// clients/web/test-output/{compact,browser}-decode.json and printed.
// Usage (after `cargo build --bins`): `npm run bench` in clients/web.
import fs from 'node:fs';
import path from 'node:path';
import { decodeCompactRender, MESH } from '../src/compact.js';
import { ROOT, demoNovel, launch, openViewer, render, startServer, viewerUrl, waitReady } from '../test/harness.js';

const OUT = path.join(ROOT, 'clients/web/test-output');
/** @type {[object, number | null][]} */
const SETTINGS = [[{ tau: 1 }, 10], [{ tau: 0.25 }, 10], [{ tau: 0.25 }, null]];

/** Median decode time of `body` by `decode`, and the triangles it holds.
 * @param {(b: ArrayBuffer) => any} decode @param {ArrayBuffer} body */
function timed(decode, body) {
  let d = decode(body.slice(0));
  for (let i = 0; i < 30; i++) d = decode(body.slice(0));
  const times = [];
  for (let i = 0; i < 15; i++) {
    const t0 = performance.now();
    decode(body.slice(0));
    times.push(performance.now() - t0);
  }
  times.sort((a, b) => a - b);
  const triangles = d.views.reduce((/** @type {number} */ s, /** @type {any} */ v) => s + v.strips.triangles, 0);
  return { triangles, ms: times[times.length >> 1] };
}

/** @param {string} where @param {{lod: object, bits: number | string, triangles: number, bytes: number, ms: number}[]} rows */
function report(where, rows) {
  for (const r of rows) {
    console.log(`${where} decode ${JSON.stringify(r.lod)} bits ${r.bits}: ${r.triangles} triangles, ${r.bytes} bytes, ${r.ms.toFixed(2)} ms (${(r.ms * 1e5 / r.triangles).toFixed(2)} ms per 100k, ${(r.triangles / r.ms / 1e3).toFixed(2)} M/s)`);
  }
}

const server = await startServer(['--demo', '--demo-live-fps', '0']);
const browser = await launch();
try {
  const camera = demoNovel();
  const node = [];
  for (const [lod, bits] of SETTINGS) {
    const body = /** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, lod, ...(bits === null ? {} : { bits }) }, MESH));
    const { triangles, ms } = timed((b) => decodeCompactRender(b, camera), body);
    node.push({ lod, bits: bits ?? 'all', triangles, bytes: body.byteLength, ms });
  }
  const { page } = await openViewer(browser, viewerUrl(server.url, { scene: 'demo', camera, tau: 1, w: 256, h: 192 }));
  await waitReady(page);
  // The page's own module, fetched by URL, timed in the page.
  // The page's own module, fetched by URL, timed in the page as `timed`
  // times it in Node (the page's CSP allows no code passed as a string).
  const chromium = await page.evaluate(async ([cam, settings]) => {
    const url = '/compact.js';
    const { decodeCompactRender: decode, MESH: media } = await import(url);
    const out = [];
    for (const [lod, bits] of settings) {
      const r = await fetch('/v1/scenes/demo/render', {
        method: 'POST',
        headers: { 'content-type': 'application/json', accept: media },
        body: JSON.stringify({ camera: cam, lod, ...(bits === null ? {} : { bits }) }),
      });
      const body = await r.arrayBuffer();
      let d = decode(body.slice(0), cam);
      for (let i = 0; i < 30; i++) d = decode(body.slice(0), cam);
      const times = [];
      for (let i = 0; i < 15; i++) {
        const t0 = performance.now();
        decode(body.slice(0), cam);
        times.push(performance.now() - t0);
      }
      times.sort((a, b) => a - b);
      const triangles = d.views.reduce((/** @type {number} */ s, /** @type {any} */ v) => s + v.strips.triangles, 0);
      out.push({ lod, bits: bits ?? 'all', triangles, bytes: body.byteLength, ms: times[times.length >> 1] });
    }
    return out;
  }, /** @type {const} */ ([camera, SETTINGS]));
  fs.mkdirSync(OUT, { recursive: true });
  fs.writeFileSync(path.join(OUT, 'compact-decode.json'), JSON.stringify(node, null, 1));
  fs.writeFileSync(path.join(OUT, 'browser-decode.json'), JSON.stringify(chromium, null, 1));
  report('Node', node);
  report('Chromium', chromium);
} finally {
  await browser.close();
  await server.stop();
}
