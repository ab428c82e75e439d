// Decodes answers off the main thread (the compact stream, bincode, or the
// JSON fallback) and hands back the typed arrays, transferred, not copied.

import { decodeCompactRender, decodeMesh, readMeshBody } from './compact.js';
import { decodeRender, readStrips, Reader, renderFromJson, stripTriangles } from './protocol.js';

/** The triangles of a decoded mesh: strips, or an indexed list.
 * @param {{indices: Uint16Array | Uint32Array, mode?: string}} s */
function triangles(s) {
  if (s.mode !== 'triangles') return stripTriangles(s.indices);
  const out = [];
  for (let k = 0; k + 2 < s.indices.length; k += 3) out.push([s.indices[k], s.indices[k + 1], s.indices[k + 2]]);
  return out;
}

/** Edges of a mesh's triangles, each once, for the wireframe view; a cut
 * triangle's parts follow the vertices, numbered from `vertexCount`.
 * @param {{indices: Uint16Array | Uint32Array, mode?: string, vertexCount: number, parts?: {depth: Float32Array}}} s */
function edges(s) {
  const seen = new Set();
  const out = [];
  const all = triangles(s);
  const parts = s.parts ? s.parts.depth.length : 0;
  for (let k = 0; k < parts; k += 3) all.push([s.vertexCount + k, s.vertexCount + k + 1, s.vertexCount + k + 2]);
  for (const [a, b, c] of all) {
    for (const [p, q] of [[a, b], [b, c], [c, a]]) {
      const key = p < q ? p * 4294967296 + q : q * 4294967296 + p;
      if (!seen.has(key)) { seen.add(key); out.push(p, q); }
    }
  }
  return Uint32Array.from(out);
}

/** The buffers of a decoded mesh, to transfer.
 * @param {any} s @returns {Transferable[]} */
function buffers(s) {
  const out = [s.ij.buffer, s.normal.buffer, s.rho.buffer, s.depth.buffer, s.indices.buffer];
  if (s.parts) out.push(s.parts.uv.buffer, s.parts.depth.buffer, s.parts.normal.buffer, s.parts.rho.buffer);
  return out;
}

/** Per view: the last compact mesh decoded, kept (copied) for a change
 * from it. @type {Map<string, import('./compact.js').Held & {etag: string}>} */
const kept = new Map();

self.onmessage = (/** @type {MessageEvent} */ e) => {
  const { id, body, json, lines, kind, compact, camera, key, etag, held } = e.data;
  const start = performance.now();
  try {
    if (kind === 'mesh') {
      // A strip route's compact body: a whole mesh, or the change from the
      // one kept for `key` that the request named as held.
      const answer = readMeshBody(body, etag ?? '');
      let s;
      if (answer.mesh) {
        s = decodeMesh(answer.mesh, camera);
      } else if (answer.change) {
        const h = key ? kept.get(key) : undefined;
        if (!h || h.etag !== held) throw new Error('a change arrived for a mesh this viewer does not hold');
        s = decodeMesh(answer.change.mesh, camera, h, answer.change.reusesDepths, answer.change.fresh);
      } else {
        throw new Error('planes arrived for a mesh this viewer does not hold');
      }
      if (key && etag) {
        kept.set(key, { etag, ij: s.ij.slice(), indices: s.indices.slice(), depth: s.depth.slice(), lattice: s.lattice, complete: s.complete });
      }
      const wire = lines ? edges(s) : null;
      /** @type {Transferable[]} */
      const transfer = buffers(s);
      if (wire) transfer.push(wire.buffer);
      self.postMessage({ id, strips: s, lines: wire, change: !!answer.change, decodeMs: performance.now() - start }, { transfer });
      return;
    }
    if (kind === 'strips') {
      const r = new Reader(body);
      const s = readStrips(r);
      r.end();
      const wire = lines ? edges(s) : null;
      /** @type {Transferable[]} */
      const transfer = [s.ij.buffer, s.normal.buffer, s.rho.buffer, s.depth.buffer, s.indices.buffer];
      if (wire) transfer.push(wire.buffer);
      self.postMessage({ id, strips: s, lines: wire, decodeMs: performance.now() - start }, { transfer });
      return;
    }
    /** @type {any} */
    const r = compact
      ? decodeCompactRender(body, camera)
      : json ? renderFromJson(JSON.parse(new TextDecoder().decode(body))) : decodeRender(body);
    const decodeMs = performance.now() - start;
    const wire = r.views.map((/** @type {any} */ v) => (lines ? edges(v.strips) : null));
    /** @type {Transferable[]} */
    const transfer = [];
    for (const v of r.views) transfer.push(...buffers(v.strips));
    for (const l of wire) if (l) transfer.push(l.buffer);
    self.postMessage({ id, response: r, lines: wire, decodeMs }, { transfer });
  } catch (err) {
    self.postMessage({ id, error: err instanceof Error ? err.message : String(err) });
  }
};
