// The dmesh wire protocol in the browser, written from proto/PROTOCOL.md:
// bincode 2, little endian, fixed-width integers, u64 lengths, u32 enum tags.
// Pure functions over ArrayBuffers, so they run in the worker and in Node.

/** @typedef {{perspective?: {fx: number, fy: number, cx: number, cy: number},
 *   orthographic?: {sx: number, sy: number, cx: number, cy: number}}} Projection */
/** @typedef {{width: number, height: number, projection: Projection,
 *   pose: {rotation: number[], translation: number[]}}} CameraJson */
/** @typedef {{exact: number[]} | {residual: Residual}} DepthsJson */
/**
 * @typedef {object} Residual
 * @property {number} bits
 * @property {number} root_side
 * @property {{scale: number, offset: number} | null} lattice
 * @property {number} step
 * @property {ArrayLike<number>} exact
 * @property {ArrayLike<number>} residuals
 * @property {number} max_error
 */
/**
 * A view's mesh, decoded into arrays a GPU takes as they are.
 * @typedef {object} Strips
 * @property {number} version
 * @property {string} scene
 * @property {string} view
 * @property {{epsilon?: number, tau?: number}} lod
 * @property {CameraJson} camera
 * @property {number} vertexCount
 * @property {Uint16Array} ij         2 per vertex: pixel column, row
 * @property {Uint8Array} normal      2 per vertex: octahedral normal
 * @property {Uint8Array} rho         1 per vertex: quality in 1/255
 * @property {Float32Array} depth     1 per vertex: z in metres
 * @property {Uint16Array | Uint32Array} indices  strips, restart = largest value (or a triangle list, see mode)
 * @property {'strips' | 'triangles'} [mode]  'triangles' for the compact stream's indexed triangle lists
 * @property {number} triangles
 * @property {number} extract_ms
 * @property {number} maxDepthError   0 for exact depths
 * @property {Reach | null} reach     for a view-dependent mesh, how far its camera may move
 */
/**
 * What a view-dependent mesh still serves once the camera moves (PROTOCOL.md, "Reach").
 * @typedef {object} Reach
 * @property {CameraJson} view        the camera it was selected and culled for
 * @property {number | null} clearance  metres; null: exact wherever the eye goes
 * @property {number[][]} culled      world spheres [x, y, z, r] holding what was culled
 */
/**
 * @typedef {object} RenderedView
 * @property {number} weight
 * @property {Strips} strips
 * @property {string} color_url
 */
/**
 * @typedef {object} RenderResponse
 * @property {number} version
 * @property {RenderedView[]} views
 * @property {{select_ms: number, extract_ms: number, total_ms: number}} timings
 */

export const PROTOCOL_VERSION = 5;
export const BINCODE = 'application/x-bincode';

/** A malformed body: the message says what and where. */
export class WireError extends Error {}

/** A cursor over a bincode body. */
export class Reader {
  /** @param {ArrayBuffer} buffer */
  constructor(buffer) {
    this.buffer = buffer;
    this.view = new DataView(buffer);
    this.at = 0;
  }
  /** @param {number} n @param {string} what */
  need(n, what) {
    if (this.at + n > this.view.byteLength) {
      throw new WireError(`body ends inside ${what} (offset ${this.at}, ${n} bytes wanted, ${this.view.byteLength - this.at} left)`);
    }
    const at = this.at;
    this.at += n;
    return at;
  }
  u8(what = 'u8') { return this.view.getUint8(this.need(1, what)); }
  u16(what = 'u16') { return this.view.getUint16(this.need(2, what), true); }
  u32(what = 'u32') { return this.view.getUint32(this.need(4, what), true); }
  f32(what = 'f32') { return this.view.getFloat32(this.need(4, what), true); }
  f64(what = 'f64') { return this.view.getFloat64(this.need(8, what), true); }
  /** u64 as a number; lengths past 2^53 cannot be in a body this size. */
  u64(what = 'u64') {
    const at = this.need(8, what);
    const lo = this.view.getUint32(at, true);
    const hi = this.view.getUint32(at + 4, true);
    if (hi > 0x1fffff) throw new WireError(`${what} is too large`);
    return hi * 2 ** 32 + lo;
  }
  i64(what = 'i64') {
    const at = this.need(8, what);
    return Number(this.view.getBigInt64(at, true));
  }
  /** A `Vec` length, checked against the bytes left. @param {number} size @param {string} what */
  len(size, what) {
    const n = this.u64(`${what} length`);
    if (n * size > this.view.byteLength - this.at) {
      throw new WireError(`${what} claims ${n} elements, more than the body holds`);
    }
    return n;
  }
  /** @param {string} what */
  string(what) {
    const n = this.len(1, what);
    const at = this.need(n, what);
    try {
      return new TextDecoder('utf-8', { fatal: true }).decode(new Uint8Array(this.buffer, at, n));
    } catch {
      throw new WireError(`${what} is not UTF-8`);
    }
  }
  /** @param {string} what @param {number} count */
  tag(what, count) {
    const t = this.u32(what);
    if (t >= count) throw new WireError(`${what}: unknown variant ${t}`);
    return t;
  }
  /** Copies `n` little-endian elements into a fresh typed array (aligned, transferable).
   * @template {Uint8ArrayConstructor | Uint16ArrayConstructor | Uint32ArrayConstructor | Float32ArrayConstructor} T
   * @param {T} Type @param {number} n @param {string} what @returns {InstanceType<T>} */
  array(Type, n, what) {
    const size = Type.BYTES_PER_ELEMENT;
    const at = this.need(n * size, what);
    const out = /** @type {InstanceType<T>} */ (new Type(n));
    new Uint8Array(out.buffer).set(new Uint8Array(this.buffer, at, n * size));
    return out;
  }
  end() {
    if (this.at !== this.view.byteLength) {
      throw new WireError(`${this.view.byteLength - this.at} trailing bytes after the value`);
    }
  }
}

/** @param {Reader} r @returns {CameraJson} */
export function readCamera(r) {
  const width = r.u32('camera width');
  const height = r.u32('camera height');
  const kind = r.tag('projection', 2);
  const [a, b, cx, cy] = [r.f64(), r.f64(), r.f64(), r.f64()];
  const projection = kind === 0 ? { perspective: { fx: a, fy: b, cx, cy } } : { orthographic: { sx: a, sy: b, cx, cy } };
  const rotation = [r.f64(), r.f64(), r.f64(), r.f64()];
  const translation = [r.f64(), r.f64(), r.f64()];
  return { width, height, projection, pose: { rotation, translation } };
}

/** @param {Reader} r @returns {Residual} */
function readResidual(r) {
  const bits = r.u8('bits');
  const root_side = r.u32('root_side');
  const tag = r.u8('lattice');
  if (tag > 1) throw new WireError(`lattice option tag ${tag}`);
  const lattice = tag === 1 ? { scale: r.f64('lattice scale'), offset: r.f64('lattice offset') } : null;
  const step = r.f64('step');
  const exact = r.array(Float32Array, r.len(4, 'exact'), 'exact');
  const residuals = r.array(Uint8Array, r.len(1, 'residuals'), 'residuals');
  const max_error = r.f32('max_error');
  return { bits, root_side, lattice, step, exact, residuals, max_error };
}

/** An `Option<Reach>` (PROTOCOL.md, "Reach"). @param {Reader} r @returns {Reach | null} */
function readReach(r) {
  const tag = r.u8('reach');
  if (tag > 1) throw new WireError(`reach option tag ${tag}`);
  if (tag === 0) return null;
  const view = readCamera(r);
  const some = r.u8('clearance');
  if (some > 1) throw new WireError(`clearance option tag ${some}`);
  const clearance = some === 1 ? r.f64('clearance') : null;
  const count = r.len(16, 'culled');
  /** @type {number[][]} */
  const culled = [];
  for (let k = 0; k < count; k++) culled.push([r.f32(), r.f32(), r.f32(), r.f32()]);
  return { view, clearance, culled };
}

/** A strip response (PROTOCOL.md, "Strip response"). @param {Reader} r @returns {Strips} */
export function readStrips(r) {
  const version = r.u16('version');
  if (version !== PROTOCOL_VERSION) throw new WireError(`protocol version ${version}; this viewer reads ${PROTOCOL_VERSION}`);
  const scene = r.string('scene');
  const view = r.string('view');
  const lodKind = r.tag('lod', 2);
  const lodValue = r.f64('lod');
  const lod = lodKind === 0 ? { epsilon: lodValue } : { tau: lodValue };
  const camera = readCamera(r);
  const n = r.len(7, 'vertices');
  const ij = new Uint16Array(2 * n);
  const normal = new Uint8Array(2 * n);
  const rho = new Uint8Array(n);
  const at = r.need(7 * n, 'vertices');
  const dv = r.view;
  for (let k = 0; k < n; k++) {
    const o = at + 7 * k;
    ij[2 * k] = dv.getUint16(o, true);
    ij[2 * k + 1] = dv.getUint16(o + 2, true);
    normal[2 * k] = dv.getUint8(o + 4);
    normal[2 * k + 1] = dv.getUint8(o + 5);
    rho[k] = dv.getUint8(o + 6);
  }
  let depth;
  let maxDepthError = 0;
  if (r.tag('depths', 2) === 0) {
    const m = r.len(4, 'depths');
    if (m !== n) throw new WireError(`${m} depths for ${n} vertices`);
    depth = r.array(Float32Array, m, 'depths');
  } else {
    const res = readResidual(r);
    depth = decodeResidual(res, ij);
    maxDepthError = res.max_error;
  }
  const indices = r.tag('indices', 2) === 0
    ? r.array(Uint16Array, r.len(2, 'indices'), 'indices')
    : r.array(Uint32Array, r.len(4, 'indices'), 'indices');
  const restart = indices instanceof Uint16Array ? 0xffff : 0xffffffff;
  for (let k = 0; k < indices.length; k++) {
    if (indices[k] !== restart && indices[k] >= n) throw new WireError(`index ${indices[k]} past the ${n} vertices`);
  }
  const triangles = r.u32('triangles');
  const extract_ms = r.f64('extract_ms');
  const reach = readReach(r);
  return { version, scene, view, lod, camera, vertexCount: n, ij, normal, rho, depth, indices, triangles, extract_ms, maxDepthError, reach };
}

/** A render response: version, views (weight, strips, colour URL), timings.
 * @param {ArrayBuffer} buffer @returns {RenderResponse} */
export function decodeRender(buffer) {
  const r = new Reader(buffer);
  const version = r.u16('version');
  if (version !== PROTOCOL_VERSION) throw new WireError(`protocol version ${version}; this viewer reads ${PROTOCOL_VERSION}`);
  const count = r.len(8, 'views');
  const views = [];
  for (let k = 0; k < count; k++) {
    const weight = r.f64('weight');
    const strips = readStrips(r);
    const color_url = r.string('color_url');
    views.push({ weight, strips, color_url });
  }
  const timings = { select_ms: r.f64('select_ms'), extract_ms: r.f64('extract_ms'), total_ms: r.f64('total_ms') };
  r.end();
  return { version, views, timings };
}

/** The same value from the JSON fallback, into the same arrays.
 * @param {any} json @returns {RenderResponse} */
export function renderFromJson(json) {
  if (json.version !== PROTOCOL_VERSION) throw new WireError(`protocol version ${json.version}; this viewer reads ${PROTOCOL_VERSION}`);
  const views = json.views.map((/** @type {any} */ v) => {
    const s = v.strips;
    const n = s.vertices.length;
    const ij = new Uint16Array(2 * n);
    const normal = new Uint8Array(2 * n);
    const rho = new Uint8Array(n);
    s.vertices.forEach((/** @type {any} */ x, /** @type {number} */ k) => {
      ij[2 * k] = x.i; ij[2 * k + 1] = x.j;
      normal[2 * k] = x.normal[0]; normal[2 * k + 1] = x.normal[1];
      rho[k] = x.rho;
    });
    const depth = s.depths.exact ? Float32Array.from(s.depths.exact) : decodeResidual(s.depths.residual, ij);
    const indices = s.indices.u16 ? Uint16Array.from(s.indices.u16) : Uint32Array.from(s.indices.u32);
    return {
      weight: v.weight,
      color_url: v.color_url,
      strips: {
        version: s.version, scene: s.scene, view: s.view, lod: s.lod, camera: s.camera, vertexCount: n,
        ij, normal, rho, depth, indices, triangles: s.triangles, extract_ms: s.extract_ms, reach: s.reach ?? null,
        maxDepthError: s.depths.residual ? s.depths.residual.max_error : 0,
      },
    };
  });
  return { version: json.version, views, timings: json.timings };
}

/** Rust's `f64::round`: halves away from zero. @param {number} x */
const round = (x) => Math.sign(x) * Math.round(Math.abs(x));

/** Raw lattice values stay below this (sums of two exact in a double). */
const MAX_RAW = 2 ** 50;

/**
 * The edge a grid vertex bisects (PROTOCOL.md, "Residual depths"), or null.
 * @param {number} i @param {number} j @param {number} rootSide
 * @returns {[number, number, number, number] | null} ax, ay, bx, by
 */
export function parentEdge(i, j, rootSide) {
  const s = Math.max(rootSide, 2);
  if (i % s === 0 && j % s === 0) return null;
  const cap = Math.log2(s);
  const tz = (/** @type {number} */ c) => (c === 0 ? cap : Math.min(cap, 31 - Math.clz32(c & -c)));
  const tx = tz(i);
  const ty = tz(j);
  const h = 2 ** Math.min(tx, ty);
  if (tx === ty) {
    const odd = (/** @type {number} */ c) => (Math.floor((c - h) / (2 * h)) % 2 === 1 ? c - h : c + h);
    const px = odd(i);
    const py = odd(j);
    return [px, py, 2 * i - px, 2 * j - py];
  }
  return tx < ty ? [i - h, j, i + h, j] : [i, j - h, i, j + h];
}

/**
 * Residual-coded depths back to metres, in vertex order (PROTOCOL.md,
 * "Residual depths": closed-loop prediction from the parent edge, code 0 an
 * escape to the next exact depth, arithmetic in raw units on a lattice).
 * @param {Residual} res @param {Uint16Array} ij @returns {Float32Array}
 */
export function decodeResidual(res, ij) {
  const { bits, root_side: side, lattice, step } = res;
  if (bits > 16) throw new WireError(`residual bits ${bits}; at most 16`);
  if (!(side > 0 && (side & (side - 1)) === 0)) throw new WireError(`root_side ${side} is not a power of two`);
  if (lattice) {
    if (!(Number.isFinite(lattice.scale) && lattice.scale !== 0 && Number.isFinite(lattice.offset))) {
      throw new WireError('lattice scale must be finite and non-zero');
    }
    if (!(step >= 1 && step <= MAX_RAW && Number.isInteger(step))) throw new WireError(`lattice step ${step} is not a whole number of raw units`);
  } else if (!(Number.isFinite(step) && step >= 0)) {
    throw new WireError(`step ${step} must be finite and not negative`);
  }
  const n = ij.length / 2;
  const half = bits === 0 ? 0 : 2 ** (bits - 1);
  /** @type {Map<number, number>} */
  const seen = new Map();
  const key = (/** @type {number} */ i, /** @type {number} */ j) => i * 65536 + j;
  const units = new Float64Array(n);
  const out = new Float32Array(n);
  let next = 0;
  let bit = 0;
  const take = () => {
    let v = 0;
    for (let b = 0; b < bits; b++, bit++) {
      const byte = res.residuals[bit >> 3];
      if (byte === undefined) throw new WireError('residuals end early');
      v += ((byte >> (bit & 7)) & 1) * 2 ** b;
    }
    return v;
  };
  const exact = (/** @type {number} */ k) => {
    if (next >= res.exact.length) throw new WireError('exact depths end early');
    out[k] = res.exact[next++];
    units[k] = lattice ? round((out[k] - lattice.offset) / lattice.scale) : out[k];
  };
  for (let k = 0; k < n; k++) {
    const i = ij[2 * k];
    const j = ij[2 * k + 1];
    const e = parentEdge(i, j, side);
    const a = e && seen.get(key(e[0], e[1]));
    const b = e && seen.get(key(e[2], e[3]));
    if (a === undefined || b === undefined || a === null || b === null) {
      exact(k);
    } else {
      const mid = (units[a] + units[b]) * 0.5;
      const p = lattice ? Math.floor(mid) : mid;
      const c = bits === 0 ? -1 : take();
      if (c === -1) {
        out[k] = Math.fround(p);
        units[k] = out[k];
      } else if (c === 0) {
        exact(k);
      } else {
        const u = p + (c - half) * step;
        if (lattice) {
          out[k] = Math.fround(u * lattice.scale + lattice.offset);
          units[k] = u;
        } else {
          out[k] = Math.fround(u);
          units[k] = out[k];
        }
      }
    }
    if (!(Number.isFinite(out[k]) && out[k] > 0)) throw new WireError(`decoded depth ${out[k]} at vertex ${k}`);
    if (lattice && !(Math.abs(units[k]) < MAX_RAW)) throw new WireError(`raw depth ${units[k]} at vertex ${k} out of range`);
    seen.set(key(i, j), k);
  }
  if (next !== res.exact.length) throw new WireError('more exact depths than anchors and escapes');
  return out;
}

/** Octahedral normal (PROTOCOL.md) to a unit vector in the reference camera frame.
 * @param {number} a @param {number} b @returns {[number, number, number]} */
export function octDecode(a, b) {
  let x = (a / 255) * 2 - 1;
  let y = (b / 255) * 2 - 1;
  const z = 1 - Math.abs(x) - Math.abs(y);
  if (z < 0) {
    const [ox, oy] = [x, y];
    x = (1 - Math.abs(oy)) * (ox < 0 ? -1 : 1);
    y = (1 - Math.abs(ox)) * (oy < 0 ? -1 : 1);
  }
  const l = Math.hypot(x, y, z) || 1;
  return [x / l, y / l, z / l];
}

/** Triangles of generalised strips with restarts, as dmesh's `decode_strips`
 * defines them (degenerate triangles dropped), for tests and statistics.
 * @param {Uint16Array | Uint32Array} indices @returns {number[][]} */
export function stripTriangles(indices) {
  const restart = indices instanceof Uint16Array ? 0xffff : 0xffffffff;
  const out = [];
  let run = 0;
  for (let k = 0; k < indices.length; k++) {
    if (indices[k] === restart) { run = 0; continue; }
    run++;
    if (run >= 3) {
      const [a, b, c] = [indices[k - 2], indices[k - 1], indices[k]];
      if (a !== b && b !== c && a !== c) out.push(run % 2 === 1 ? [a, b, c] : [b, a, c]);
    }
  }
  return out;
}
