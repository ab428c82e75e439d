// The viewer's decoder (src/protocol.js, written from proto/PROTOCOL.md)
// against a real `dmesh serve --demo`: bincode and JSON give the same
// arrays, residual depths decode within the bound the server states, the
// strips' triangles are the ones the server counted, and malformed bodies
// are refused with a reason.

import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import zlib from 'node:zlib';
import { PNG } from 'pngjs';
import { decodeRender, renderFromJson, stripTriangles, parentEdge, WireError, octDecode, Reader, readStrips } from '../src/protocol.js';
import { demoNovel, render, startServer } from './harness.js';

/** @type {Awaited<ReturnType<typeof startServer>>} */
let server;
before(async () => { server = await startServer(['--demo', '--demo-live-fps', '0']); });
after(async () => { await server.stop(); });

/** @param {ArrayLike<number>} a @param {ArrayLike<number>} b */
const same = (a, b) => a.length === b.length && Array.prototype.every.call(a, (v, i) => v === b[i]);

for (const extra of [{}, { bits: 10 }, { bits: 0 }]) {
  test(`bincode and JSON decode to the same arrays ${JSON.stringify(extra)}`, async () => {
    const body = { camera: demoNovel(), lod: { tau: 1 }, ...extra };
    const b = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', body)));
    const j = renderFromJson(await render(server.url, 'demo', body, 'application/json'));
    assert.ok(b.views.length >= 2, 'the demo camera selects several views');
    assert.equal(b.views.length, j.views.length);
    b.views.forEach((v, k) => {
      const w = j.views[k];
      assert.equal(v.weight, w.weight);
      assert.equal(v.color_url, w.color_url);
      assert.deepEqual(v.strips.camera, w.strips.camera);
      assert.deepEqual(v.strips.lod, w.strips.lod);
      for (const key of /** @type {const} */ (['ij', 'normal', 'rho', 'depth', 'indices'])) {
        assert.ok(same(v.strips[key], w.strips[key]), `${v.strips.view}.${key} differs`);
      }
      assert.equal(v.strips.triangles, w.strips.triangles);
    });
    const weights = b.views.reduce((s, v) => s + v.weight, 0);
    assert.ok(Math.abs(weights - 1) < 1e-9, `weights sum to ${weights}`);
  });
}

test('strips with restarts give the triangles the server counted', async () => {
  const r = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera: demoNovel(), lod: { tau: 1 } })));
  let restarts = 0;
  for (const v of r.views) {
    const s = v.strips;
    const marker = s.indices instanceof Uint16Array ? 0xffff : 0xffffffff;
    restarts += s.indices.filter((i) => i === marker).length;
    assert.equal(stripTriangles(s.indices).length, s.triangles, `view ${s.view}`);
  }
  assert.ok(restarts > 0, 'the demo meshes are segmented, so their strips restart');
});

test('residual depths decode within the stated bound of the exact ones', async () => {
  const camera = demoNovel();
  const exact = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, lod: { tau: 1 } })));
  for (const bits of [4, 10, 16]) {
    const coded = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, lod: { tau: 1 }, bits })));
    coded.views.forEach((v, k) => {
      const e = exact.views[k].strips;
      const s = v.strips;
      assert.ok(same(s.ij, e.ij), 'the same vertices with and without bits');
      assert.ok(s.maxDepthError >= 0 && Number.isFinite(s.maxDepthError));
      let worst = 0;
      for (let q = 0; q < s.depth.length; q++) worst = Math.max(worst, Math.abs(s.depth[q] - e.depth[q]));
      assert.ok(worst <= s.maxDepthError * (1 + 1e-6) + 1e-7, `${bits} bits, view ${s.view}: error ${worst} > stated ${s.maxDepthError}`);
      if (bits === 4) assert.ok(worst > 0, '4 bits cannot be lossless on the demo');
    });
  }
});

/** A 16-bit greyscale PNG of `raw(i, j)`, written by hand (pngjs writes 8 bits).
 * @param {number} w @param {number} h @param {(i: number, j: number) => number} raw */
function png16(w, h, raw) {
  const rows = Buffer.alloc(h * (1 + 2 * w));
  for (let j = 0; j < h; j++) {
    for (let i = 0; i < w; i++) rows.writeUInt16BE(raw(i, j), j * (1 + 2 * w) + 1 + 2 * i);
  }
  const chunk = (/** @type {string} */ type, /** @type {Buffer} */ data) => {
    const body = Buffer.concat([Buffer.from(type, 'ascii'), data]);
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0);
    body.copy(out, 4);
    out.writeUInt32BE(zlib.crc32(body), 8 + data.length);
    return out;
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(w, 0);
  ihdr.writeUInt32BE(h, 4);
  ihdr.set([16, 0, 0, 0, 0], 8);
  return Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(rows)), chunk('IEND', Buffer.alloc(0))]);
}

test('16-bit depth: lattice residuals decode exactly as the server states, each bit halves the error, 16 bits are lossless', async () => {
  const camera = {
    width: 65, height: 49,
    projection: { perspective: { fx: 60, fy: 60, cx: 32, cy: 24 } },
    pose: { rotation: [0, 0, 0, 1], translation: [0, 0, 0] },
  };
  const form = new FormData();
  form.set('camera', JSON.stringify(camera));
  form.set('depth_kind', 'z');
  form.set('scale', '0.001');
  form.set('depth', new Blob([new Uint8Array(png16(65, 49, (i, j) => 2000 + 7 * i * i + 13 * j + ((i * 31 + j * 17) % 5) + (i > 40 ? 1500 : 0)))], { type: 'image/png' }), 'depth.png');
  const colour = new PNG({ width: 65, height: 49 });
  colour.data.fill(128);
  form.set('color', new Blob([new Uint8Array(PNG.sync.write(colour))], { type: 'image/png' }), 'color.png');
  const r = await fetch(`${server.url}/v1/scenes/lattice/views/v`, { method: 'PUT', body: form });
  assert.equal(r.status, 201, await r.text());
  const strips = async (/** @type {string} */ q) => {
    const res = await fetch(`${server.url}/v1/scenes/lattice/views/v/strips?${q}`, { headers: { accept: 'application/x-bincode' } });
    assert.equal(res.status, 200);
    return readStrips(new Reader(await res.arrayBuffer()));
  };
  const exact = await strips('epsilon=0');
  let previous = Infinity;
  for (let bits = 0; bits <= 16; bits++) {
    const s = await strips(`epsilon=0&bits=${bits}`);
    assert.ok(same(s.ij, exact.ij));
    let worst = 0;
    for (let q = 0; q < s.depth.length; q++) worst = Math.max(worst, Math.fround(Math.abs(s.depth[q] - exact.depth[q])));
    assert.equal(worst, s.maxDepthError, `${bits} bits: the browser decodes what the server's decoder does`);
    assert.ok(worst <= previous / 2, `${bits} bits: ${worst} after ${previous}`);
    previous = worst;
  }
  assert.equal(previous, 0, '16 bits of 16-bit depth are lossless');
});

test('malformed bodies are refused with a reason', async () => {
  const good = /** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera: demoNovel(), lod: { tau: 2 } }));
  assert.throws(() => decodeRender(good.slice(0, good.byteLength - 3)), WireError);
  const longer = new Uint8Array(good.byteLength + 1);
  longer.set(new Uint8Array(good));
  assert.throws(() => decodeRender(longer.buffer), /trailing bytes/);
  const wrongVersion = good.slice(0);
  new DataView(wrongVersion).setUint16(0, 99, true);
  assert.throws(() => decodeRender(wrongVersion), /version 99/);
  // A vector length past the end of the body.
  const huge = good.slice(0);
  new DataView(huge).setUint32(2, 0xffffff, true);
  assert.throws(() => decodeRender(huge), WireError);
});

test('parent edges follow PROTOCOL.md', () => {
  // Root corners have none; a root centre bisects its diagonal; edge midpoints their edge.
  assert.equal(parentEdge(0, 0, 4), null);
  assert.equal(parentEdge(4, 8, 4), null);
  // (2, 2) in a root of side 4: h = 2, and of 0 and 4, 4 is the odd multiple of 2h = 4.
  assert.deepEqual(parentEdge(2, 2, 4), [4, 4, 0, 0]);
  assert.deepEqual(parentEdge(2, 0, 4), [0, 0, 4, 0]);
  assert.deepEqual(parentEdge(0, 2, 4), [0, 0, 0, 4]);
  assert.deepEqual(parentEdge(1, 0, 4), [0, 0, 2, 0]);
  // (1, 1) in a root of side 4: of 0 and 2, 2 is the odd multiple of 2h = 2.
  assert.deepEqual(parentEdge(1, 1, 4), [2, 2, 0, 0]);
  const n = octDecode(128, 128);
  assert.ok(Math.abs(Math.hypot(...n) - 1) < 1e-12 && n[2] > 0.99);
});

test('deleting demo-live\'s view stops its feed rather than bringing the view back', async () => {
  const live = await startServer(['--demo', '--demo-live-fps', '20']);
  try {
    const view = `${live.url}/v1/scenes/demo-live/views/v00`;
    assert.equal((await fetch(view)).status, 200, 'the feed has stored a frame');
    assert.equal((await fetch(view, { method: 'DELETE' })).status, 204);
    // Ten frame periods: a feed still running would have stored one.
    await new Promise((resolve) => setTimeout(resolve, 500));
    assert.equal((await fetch(view)).status, 404, 'the deleted view stays deleted');
  } finally {
    await live.stop();
  }
});
