// The viewer's compact-stream decoder (src/compact.js, protocol 7) against a
// real `dmesh serve --demo` and the Rust decoder (`dmesh-client decode`):
// the same vertices, depths, normals, rho, triangles and cut triangles to
// the bit; the surface protocol 5 carries, in fewer triangles (outlines cut,
// not refined); planes that extend a held mesh; malformed and
// mutated bodies refused with a WireError, never another exception. The
// decode rate is a benchmark: bench/decode.js.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { after, before, test } from 'node:test';
import { decodeCompactRender, decodeMesh, readMeshBody, applyPlanes, MESH } from '../src/compact.js';
import { decodeRender, stripTriangles, WireError } from '../src/protocol.js';
import { client, demoNovel, render, startServer, tempDir } from './harness.js';

/** @type {Awaited<ReturnType<typeof startServer>>} */
let server;
before(async () => { server = await startServer(['--demo', '--demo-live-fps', '0']); });
after(async () => { await server.stop(); });

/** @param {any[]} t */
const key = (t) => [...t].sort((a, b) => a - b).join(',');

/** POSTs a strip request for `view` asking for the compact stream. @param {string} view @param {object} body */
async function strips(view, body) {
  const r = await fetch(`${server.url}/v1/scenes/demo/views/${view}/strips`, {
    method: 'POST',
    headers: { 'content-type': 'application/json', accept: MESH },
    body: JSON.stringify(body),
  });
  assert.equal(r.status, 200, await r.clone().text());
  return { body: await r.arrayBuffer(), etag: r.headers.get('etag') };
}

/** The decoded cut triangles as the Rust decoder writes them (cut.rs, `CutTriangle`).
 * @param {import('../src/compact.js').Cuts} c */
function cutsAsRust(c) {
  const out = [];
  for (let k = 0; k < c.at.length / 2; k++) {
    const corners = [0, 1, 2].map((e) => [c.corners[6 * k + 2 * e], c.corners[6 * k + 2 * e + 1]]);
    const lone = Number.isNaN(c.lone[3 * k]) ? null : Array.from(c.lone.subarray(3 * k, 3 * k + 3));
    const other = Number.isNaN(c.other[4 * k]) ? null : Array.from(c.other.subarray(4 * k, 4 * k + 4));
    out.push({ corners, at: [c.at[2 * k], c.at[2 * k + 1]], lone, other });
  }
  return out;
}

/** The Rust decoder's cuts with their depths as f32. @param {any[]} cuts */
const rustCuts = (cuts) => cuts.map((c) => ({
  ...c, lone: c.lone && c.lone.map(Math.fround), other: c.other && c.other.map(Math.fround),
}));

for (const extra of [{}, { bits: 10 }, { bits: 0 }, { bits: 3 }, { lod: { epsilon: 0.01 } }, { lod: { epsilon: 0.01 }, bits: 6 }]) {
  test(`the browser decodes to the Rust decoder's arrays and cuts, bit for bit ${JSON.stringify(extra)}`, async () => {
    const camera = demoNovel();
    const body = { camera, lod: { tau: 1 }, ...extra };
    const bytes = /** @type {ArrayBuffer} */ (await render(server.url, 'demo', body, MESH));
    const dir = tempDir();
    fs.writeFileSync(path.join(dir, 'body'), Buffer.from(bytes));
    fs.writeFileSync(path.join(dir, 'camera.json'), JSON.stringify(camera));
    const rust = JSON.parse(await client(['decode', '--render', '--body', path.join(dir, 'body'), '--camera', path.join(dir, 'camera.json')]));
    const js = decodeCompactRender(bytes.slice(0), camera);
    assert.ok(js.views.length >= 2, 'the demo camera selects several views');
    assert.equal(js.views.length, rust.views.length);
    js.views.forEach((v, k) => {
      const s = v.strips;
      const w = rust.views[k].strips;
      assert.equal(v.weight, rust.views[k].weight);
      assert.equal(s.vertexCount, w.vertices.length);
      w.vertices.forEach((/** @type {any} */ x, /** @type {number} */ i) => {
        assert.equal(s.ij[2 * i], x.i); assert.equal(s.ij[2 * i + 1], x.j);
        assert.equal(s.normal[2 * i], x.normal[0], `${s.view} normal of ${i}`);
        assert.equal(s.normal[2 * i + 1], x.normal[1], `${s.view} normal of ${i}`);
        assert.equal(s.rho[i], x.rho, `${s.view} rho of ${i}`);
        assert.equal(s.depth[i], Math.fround(w.depths.exact[i]), `${s.view} depth of ${i}`);
      });
      const rt = stripTriangles(Uint32Array.from(w.indices.u32 ?? w.indices.u16, (i) => (i === 0xffff && w.indices.u16 ? 0xffffffff : i)));
      assert.equal(s.indices.length, 3 * rt.length);
      for (let t = 0; t < rt.length; t++) assert.deepEqual([s.indices[3 * t], s.indices[3 * t + 1], s.indices[3 * t + 2]], rt[t]);
      assert.deepEqual(s.reach ? s.reach.culled.length : -1, w.reach ? w.reach.culled.length : -1);
      assert.deepEqual(cutsAsRust(s.cuts), rustCuts(w.cuts), `${s.view} cuts`);
      assert.equal(s.parts.depth.length % 3, 0);
      for (const z of s.parts.depth) assert.ok(Number.isFinite(z) && z > 0, `${s.view} part depth ${z}`);
    });
    assert.ok(js.views.some((v) => v.strips.cuts.at.length > 0), 'the demo scene has outlines to cut');
  });
}

test('the compact stream carries protocol 5\'s surface with its outlines cut, depths within the stated bound', async () => {
  const camera = demoNovel();
  for (const lod of [{ tau: 1 }, { epsilon: 0.01 }]) {
    const body = { camera, lod };
    const p5 = decodeRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', body)));
    for (const bits of [undefined, 10, 4]) {
      const c = decodeCompactRender(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { ...body, bits }, MESH)), camera);
      assert.equal(c.views.length, p5.views.length);
      let [drawn, refined] = [0, 0];
      c.views.forEach((v, k) => {
        const s = v.strips;
        const w = p5.views[k].strips;
        assert.equal(s.view, w.view);
        // Where protocol 5 refines outlines the compact stream cuts them:
        // the vertices both have carry one depth, within the stated bound.
        const at = new Map();
        for (let i = 0; i < w.depth.length; i++) at.set(w.ij[2 * i] * 65536 + w.ij[2 * i + 1], w.depth[i]);
        let shared = 0;
        for (let i = 0; i < s.depth.length; i++) {
          const z = at.get(s.ij[2 * i] * 65536 + s.ij[2 * i + 1]);
          if (z === undefined) continue;
          shared++;
          assert.ok(Math.abs(s.depth[i] - z) <= s.maxDepthError, `${s.view} depth ${i} at ${bits} planes`);
        }
        assert.ok(shared > s.depth.length / 2, `${s.view}: ${shared} of ${s.depth.length} vertices shared`);
        assert.equal(s.drawnTriangles, s.triangles + s.parts.depth.length / 3);
        drawn += s.drawnTriangles;
        refined += w.triangles;
        // The planes asked for, and no more.
        assert.equal(s.planes, bits === undefined ? s.totalPlanes : Math.min(bits, s.totalPlanes), `${s.view} planes`);
        if (bits === 4) assert.ok(s.maxDepthError > 0);
      });
      // At 1 cm the cuts draw fewer triangles than refinement; at 1 px
      // their parts fill the band refinement leaves out, and may draw more.
      if (lod.epsilon) assert.ok(drawn < refined, `${drawn} triangles drawn with cuts, ${refined} refined`);
    }
  }
});

test('planes extend a held mesh to the one asked for, and a wrong held ETag gets the whole mesh', async () => {
  const camera = demoNovel();
  const ask = { camera, lod: { tau: 1 } };
  const four = await strips('v04', { ...ask, bits: 4 });
  const ten = await strips('v04', { ...ask, bits: 10 });
  const held = readMeshBody(four.body, /** @type {string} */ (four.etag)).mesh;
  assert.ok(held && four.etag && four.etag.endsWith('.p4.v7"'), `the ETag ${four.etag} names the mesh, its planes and the stream`);
  const more = await strips('v04', { ...ask, bits: 10, held: four.etag });
  const update = readMeshBody(more.body, /** @type {string} */ (more.etag)).planes;
  assert.ok(update, 'a held mesh gets planes');
  assert.ok(more.body.byteLength < ten.body.byteLength / 2, `${more.body.byteLength} bytes of planes against ${ten.body.byteLength} for the whole mesh`);
  const raised = decodeMesh(applyPlanes(held, update), camera);
  const direct = decodeMesh(/** @type {any} */ (readMeshBody(ten.body, /** @type {string} */ (ten.etag)).mesh), camera);
  assert.deepEqual(Array.from(raised.depth), Array.from(direct.depth));
  assert.equal(raised.etag, direct.etag);
  // Held for another camera, or a made-up tag: the whole mesh.
  const moved = structuredClone(camera);
  moved.pose.translation[0] += 0.05;
  for (const tag of [(await strips('v04', { camera: moved, lod: { tau: 1 }, bits: 4 })).etag, '"made-up.e0.p4"', 'garbage']) {
    const whole = readMeshBody((await strips('v04', { ...ask, bits: 10, held: tag })).body);
    assert.ok(whole.mesh, `held ${tag} gets the whole mesh`);
  }
  // A static request's ETag answers If-None-Match with 304.
  const s1 = await strips('v04', { lod: { epsilon: 0.01 }, bits: 8 });
  const r = await fetch(`${server.url}/v1/scenes/demo/views/v04/strips`, {
    method: 'POST',
    headers: { 'content-type': 'application/json', accept: MESH, 'if-none-match': /** @type {string} */ (s1.etag) },
    body: JSON.stringify({ lod: { epsilon: 0.01 }, bits: 8 }),
  });
  assert.equal(r.status, 304);
});

test('a change applied to the held mesh is the whole new mesh, as the Rust decoder applies it', async () => {
  const camera = demoNovel();
  const moved = structuredClone(camera);
  moved.pose.translation[0] += 0.05;
  const other = structuredClone(camera);
  other.pose.translation[1] += 0.07;
  const dir = tempDir();
  /** @type {[{camera: any, lod: any, bits?: number}, {camera: any, lod: any, bits?: number}][]} */
  const cases = [
    // A finer tolerance, a moved camera, and both with planes (depths sent again).
    [{ camera, lod: { tau: 4 } }, { camera, lod: { tau: 1 } }],
    [{ camera, lod: { tau: 1 } }, { camera: moved, lod: { tau: 1 } }],
    [{ camera, lod: { tau: 4 }, bits: 10 }, { camera: moved, lod: { tau: 1 }, bits: 10 }],
    // Static meshes, whose outlines are cut: a finer tolerance.
    [{ camera: null, lod: { epsilon: 0.02 } }, { camera: null, lod: { epsilon: 0.005 } }],
  ];
  for (const [from, to] of cases) {
    const a = await strips('v04', from);
    const held = decodeMesh(/** @type {any} */ (readMeshBody(a.body, /** @type {string} */ (a.etag)).mesh), from.camera);
    const whole = await strips('v04', to);
    const ch = await strips('v04', { ...to, held: a.etag, held_camera: from.camera });
    const { change } = readMeshBody(ch.body.slice(0), /** @type {string} */ (ch.etag));
    assert.ok(change, `${JSON.stringify(to)} from a held mesh is a change`);
    assert.equal(ch.etag, whole.etag, 'a change names the mesh it makes');
    assert.equal(change.reusesDepths, to.bits === undefined, 'depths are reused between complete meshes');
    // As they travel: content-coded (here gzip; the bit fields are differences, mostly zeros).
    const gz = (/** @type {ArrayBuffer} */ b) => zlib.gzipSync(Buffer.from(b), { level: 6 }).length;
    const [c, w] = [gz(ch.body), gz(whole.body)];
    // Reused depths halve it at least, but a cut's crossing sides always travel.
    const reuses = change.reusesDepths && change.mesh.cutTriangles === 0;
    assert.ok(c < (reuses ? w / 2 : w), `${c} bytes of change against ${w} whole, gzipped`);
    const got = decodeMesh(change.mesh, to.camera, held, change.reusesDepths, change.fresh);
    const want = decodeMesh(/** @type {any} */ (readMeshBody(whole.body, /** @type {string} */ (whole.etag)).mesh), to.camera);
    for (const k of /** @type {const} */ (['ij', 'depth', 'indices', 'normal', 'rho'])) {
      assert.deepEqual(Array.from(got[k]), Array.from(want[k]), `${k} of the change and of the whole mesh`);
    }
    assert.deepEqual(cutsAsRust(got.cuts), cutsAsRust(want.cuts), 'cuts of the change and of the whole mesh');
    fs.writeFileSync(path.join(dir, 'held'), Buffer.from(a.body));
    fs.writeFileSync(path.join(dir, 'change'), Buffer.from(ch.body));
    const args = ['decode', '--body', path.join(dir, 'change'), '--held', path.join(dir, 'held')];
    if (to.camera) {
      fs.writeFileSync(path.join(dir, 'camera.json'), JSON.stringify(to.camera));
      args.push('--camera', path.join(dir, 'camera.json'));
    }
    const rust = JSON.parse(await client(args));
    if (to.lod.epsilon) assert.ok(got.cuts.at.length > 0, 'a static change carries cuts');
    assert.deepEqual(rust.vertices.map((/** @type {any} */ v) => [v.i, v.j]).flat(), Array.from(got.ij));
    assert.deepEqual(rust.depths.exact.map(Math.fround), Array.from(got.depth));
    assert.deepEqual(rustCuts(rust.cuts), cutsAsRust(got.cuts));
    // The same held tag with a camera it was not made for: the whole mesh.
    const wrong = readMeshBody((await strips('v04', { ...to, held: a.etag, held_camera: other })).body);
    assert.ok(wrong.mesh, 'a held camera that does not hash to the tag gets the whole mesh');
  }
});

test('malformed and mutated bodies are refused with a WireError, never another exception', async () => {
  const camera = demoNovel();
  const good = new Uint8Array(/** @type {ArrayBuffer} */ (await render(server.url, 'demo', { camera, lod: { tau: 4 }, bits: 8, max_views: 2 }, MESH)));
  decodeCompactRender(good.slice().buffer, camera);
  for (const cut of [0, 1, 2, 10, 50, good.length >> 1, good.length - 1]) {
    assert.throws(() => decodeCompactRender(good.slice(0, cut).buffer, camera), WireError, `cut at ${cut}`);
  }
  // A bounded fuzz: single-byte and bit mutations anywhere in the body.
  let seed = 12345;
  const rnd = () => { seed = (seed * 1103515245 + 12345) >>> 0; return seed / 2 ** 32; };
  let refused = 0;
  const deadline = performance.now() + 15_000;
  let runs = 0;
  for (; runs < 3000 && performance.now() < deadline; runs++) {
    const b = good.slice();
    const edits = 1 + Math.floor(rnd() * 4);
    for (let e = 0; e < edits; e++) {
      const at = Math.floor(rnd() * b.length);
      b[at] = rnd() < 0.5 ? b[at] ^ (1 << Math.floor(rnd() * 8)) : Math.floor(rnd() * 256);
    }
    try {
      const r = decodeCompactRender(b.buffer, camera);
      for (const v of r.views) {
        const s = v.strips;
        for (const z of s.depth) assert.ok(Number.isFinite(z) && z > 0, 'decoded depths are finite and positive');
        for (const i of s.indices) assert.ok(i < s.vertexCount, 'indices stay inside the vertices');
      }
    } catch (e) {
      if (!(e instanceof WireError)) throw new Error(`run ${runs}: ${e instanceof Error ? e.stack : e}`);
      refused++;
    }
  }
  assert.ok(refused > runs / 4, `${refused} of ${runs} mutated bodies refused`);
  // Changes, mutated, applied to the mesh they were asked against.
  const moved = structuredClone(camera);
  moved.pose.translation[0] += 0.05;
  const a = await strips('v04', { camera, lod: { tau: 4 } });
  const held = decodeMesh(/** @type {any} */ (readMeshBody(a.body).mesh), camera);
  const change = new Uint8Array((await strips('v04', { camera: moved, lod: { tau: 2 }, held: a.etag, held_camera: camera })).body);
  assert.ok(readMeshBody(change.slice().buffer).change, 'a change to mutate');
  let changesRefused = 0;
  let changeRuns = 0;
  const until = performance.now() + 10_000;
  for (; changeRuns < 1500 && performance.now() < until; changeRuns++) {
    const b = change.slice();
    for (let e = 0; e < 1 + Math.floor(rnd() * 4); e++) {
      const at = Math.floor(rnd() * b.length);
      b[at] = rnd() < 0.5 ? b[at] ^ (1 << Math.floor(rnd() * 8)) : Math.floor(rnd() * 256);
    }
    try {
      const body = readMeshBody(b.buffer);
      const c = body.change;
      const s = c ? decodeMesh(c.mesh, moved, held, c.reusesDepths, c.fresh) : body.mesh ? decodeMesh(body.mesh, moved) : null;
      if (s) {
        for (const z of s.depth) assert.ok(Number.isFinite(z) && z > 0, 'decoded depths are finite and positive');
        for (const i of s.indices) assert.ok(i < s.vertexCount, 'indices stay inside the vertices');
      }
    } catch (e) {
      if (!(e instanceof WireError)) throw new Error(`change run ${changeRuns}: ${e instanceof Error ? e.stack : e}`);
      changesRefused++;
    }
  }
  assert.ok(changesRefused > changeRuns / 4, `${changesRefused} of ${changeRuns} mutated changes refused`);
});
