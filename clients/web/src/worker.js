// Decodes render responses off the main thread (bincode, or the JSON
// fallback) and hands back the typed arrays, transferred, not copied.

import { decodeRender, readStrips, Reader, renderFromJson, stripTriangles } from './protocol.js';

/** Edges of the strips' triangles, each once, for the wireframe view.
 * @param {Uint16Array | Uint32Array} indices */
function edges(indices) {
  const seen = new Set();
  const out = [];
  for (const [a, b, c] of stripTriangles(indices)) {
    for (const [p, q] of [[a, b], [b, c], [c, a]]) {
      const key = p < q ? p * 4294967296 + q : q * 4294967296 + p;
      if (!seen.has(key)) { seen.add(key); out.push(p, q); }
    }
  }
  return Uint32Array.from(out);
}

self.onmessage = (/** @type {MessageEvent} */ e) => {
  const { id, body, json, lines, kind } = e.data;
  const start = performance.now();
  try {
    if (kind === 'strips') {
      const r = new Reader(body);
      const s = readStrips(r);
      r.end();
      const wire = lines ? edges(s.indices) : null;
      /** @type {Transferable[]} */
      const transfer = [s.ij.buffer, s.normal.buffer, s.rho.buffer, s.depth.buffer, s.indices.buffer];
      if (wire) transfer.push(wire.buffer);
      self.postMessage({ id, strips: s, lines: wire, decodeMs: performance.now() - start }, { transfer });
      return;
    }
    const r = json ? renderFromJson(JSON.parse(new TextDecoder().decode(body))) : decodeRender(body);
    const decodeMs = performance.now() - start;
    const wire = r.views.map((v) => (lines ? edges(v.strips.indices) : null));
    /** @type {Transferable[]} */
    const transfer = [];
    for (const v of r.views) {
      const s = v.strips;
      for (const a of [s.ij, s.normal, s.rho, s.depth, s.indices]) transfer.push(a.buffer);
    }
    for (const l of wire) if (l) transfer.push(l.buffer);
    self.postMessage({ id, response: r, lines: wire, decodeMs }, { transfer });
  } catch (err) {
    self.postMessage({ id, error: err instanceof Error ? err.message : String(err) });
  }
};
