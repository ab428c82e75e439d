// The viewer's decoder (src/protocol.js, written from proto/PROTOCOL.md)
// against a real `dmesh serve --demo`: bincode and JSON give the same
// arrays, residual depths decode within the bound the server states, the
// strips' triangles are the ones the server counted, and malformed bodies
// are refused with a reason.

import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import { decodeRender, renderFromJson, stripTriangles, parentEdge, WireError, octDecode } from '../src/protocol.js';
import { demoNovel, render, startServer } from './harness.js';

/** @type {Awaited<ReturnType<typeof startServer>>} */
let server;
before(async () => { server = await startServer(['--demo']); });
after(async () => { await server.stop(); });

/** @param {ArrayLike<number>} a @param {ArrayLike<number>} b */
const same = (a, b) => a.length === b.length && Array.prototype.every.call(a, (v, i) => v === b[i]);

for (const extra of [{}, { bits: 10 }, { bits: 0 }]) {
  test(`bincode and JSON decode to the same arrays ${JSON.stringify(extra)}`, async () => {
    const body = { camera: demoNovel(), tau: 1, ...extra };
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
  const r = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera: demoNovel(), tau: 1 })));
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
  const exact = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, tau: 1 })));
  for (const bits of [4, 10, 16]) {
    const coded = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, tau: 1, bits })));
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

test('malformed bodies are refused with a reason', async () => {
  const good = /** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera: demoNovel(), tau: 2 }));
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
