// Protocol 7, the compact mesh stream, in the browser (proto/PROTOCOL.md,
// "Protocol 7"; dmesh_proto::compact is the reference). A body carries split,
// leaf and cut bits of the forest's one canonical walk, the cut triangles'
// cases and crossings, depths as nested bit planes of parent-edge residuals
// (crossing sides one level past the finest) and a small header; this module
// rebuilds the vertices, an indexed triangle list, the depths, the cut
// triangles and their parts (proto/src/compact/cut.rs, the same operations
// in the same order) and, as engine/src/mesh/derived_normals.rs does, the
// normals and rho. Pure functions, for the worker and Node.

import { Reader, WireError, readCamera } from './protocol.js';

export const COMPACT_VERSION = 7;
export const MESH = 'application/vnd.dmesh.mesh';

/** Largest grid a stream may describe (as the Rust decoder). */
const MAX_GRID_VERTICES = 2 ** 26;
/** Largest number of planes a level may have. */
const MAX_PLANES = 24;
/** Raw lattice values stay below this. */
const MAX_RAW = 2 ** 50;

/** Rust's `f64::round`: halves away from zero. @param {number} x */
const round = (x) => Math.sign(x) * Math.round(Math.abs(x));

/** Trailing zeros of a positive integer below 2^31. @param {number} c */
const ctz = (c) => 31 - Math.clz32(c & -c);

/** @param {Reader} r @param {string} what */
function bytes(r, what) {
  const n = r.len(1, what);
  const at = r.need(n, what);
  return new Uint8Array(r.buffer, at, n);
}

/**
 * @typedef {object} MeshStream
 * @property {number} version
 * @property {string} scene
 * @property {string} view
 * @property {{epsilon?: number, tau?: number}} lod
 * @property {import('./protocol.js').CameraJson} camera
 * @property {number} extract_ms
 * @property {number} rootSide
 * @property {number} rootsX
 * @property {number} rootsY
 * @property {number} triangles
 * @property {number} cutTriangles
 * @property {Uint8Array} split
 * @property {Uint8Array} leaf
 * @property {Uint8Array} cut
 * @property {Uint8Array} cases  one byte per cut triangle: 3 x lone corner + void side
 * @property {Uint8Array} crossings  per crossing edge met first: half steps - 1, log2 n + 1 bits
 * @property {{scale: number, offset: number} | null} lattice
 * @property {{step: number, planes: number}[]} levels
 * @property {Uint8Array} escapes
 * @property {Uint8Array} exact
 * @property {Uint8Array[]} planes
 * @property {number} totalPlanes
 * @property {number} maxError  largest depth error of the planes held, metres
 * @property {{clearance: number | null, lo: number[], unit: number, culled: number[][]} | null} reach
 * @property {string} etag  the answer's ETag header (not in the body)
 */

/** @param {Reader} r @returns {MeshStream} */
export function readMeshStream(r) {
  const version = r.u16('version');
  if (version !== COMPACT_VERSION) throw new WireError(`compact stream version ${version}; this viewer reads ${COMPACT_VERSION}`);
  const scene = r.string('scene');
  const view = r.string('view');
  const lodKind = r.tag('lod', 4);
  if (lodKind > 1) throw new WireError('a served mesh states epsilon or tau');
  const lodValue = r.f64('lod');
  const lod = lodKind === 0 ? { epsilon: lodValue } : { tau: lodValue };
  const camera = readCamera(r);
  const extract_ms = r.f64('extract_ms');
  const rootSide = r.u32('root_side');
  const rootsX = r.u32('roots_x');
  const rootsY = r.u32('roots_y');
  const triangles = r.u32('triangles');
  const cutTriangles = r.u32('cut_triangles');
  const split = bytes(r, 'split bits');
  const leaf = bytes(r, 'leaf bits');
  const cut = bytes(r, 'cut bits');
  const cases = bytes(r, 'cut cases');
  const crossings = bytes(r, 'crossings');
  const tag = r.u8('lattice');
  if (tag > 1) throw new WireError(`lattice option tag ${tag}`);
  const lattice = tag === 1 ? { scale: r.f64('lattice scale'), offset: r.f64('lattice offset') } : null;
  const nLevels = r.len(5, 'levels');
  const levels = [];
  for (let k = 0; k < nLevels; k++) levels.push({ step: r.f32('step'), planes: r.u8('planes') });
  const escapes = bytes(r, 'escape bits');
  const exact = bytes(r, 'exact depths');
  const nPlanes = r.len(8, 'planes');
  const planes = [];
  for (let k = 0; k < nPlanes; k++) planes.push(bytes(r, 'plane'));
  const totalPlanes = r.u8('total_planes');
  const maxError = r.f32('max_error');
  const rt = r.u8('reach');
  if (rt > 1) throw new WireError(`reach option tag ${rt}`);
  let reach = null;
  if (rt === 1) {
    const some = r.u8('clearance');
    if (some > 1) throw new WireError(`clearance option tag ${some}`);
    const clearance = some === 1 ? r.f64('clearance') : null;
    const lo = [r.f64('lo'), r.f64('lo'), r.f64('lo')];
    const unit = r.f64('unit');
    const count = r.len(8, 'culled');
    const culled = [];
    for (let k = 0; k < count; k++) culled.push([r.u16(), r.u16(), r.u16(), r.u16()]);
    reach = { clearance, lo, unit, culled };
  }
  return {
    version, scene, view, lod, camera, extract_ms, rootSide, rootsX, rootsY, triangles, cutTriangles,
    split, leaf, cut, cases, crossings, lattice, levels, escapes, exact, planes, totalPlanes, maxError, reach, etag: '',
  };
}

/** A strip route's compact body: `{mesh}`, `{change}` (another mesh as its
 * difference from the one the request named as held: `{mesh, reusesDepths}`)
 * or `{planes}` (an update of the mesh the request named as held). `etag` is
 * the answer's ETag header.
 * @param {ArrayBuffer} buffer @param {string} [etag] */
export function readMeshBody(buffer, etag = '') {
  const r = new Reader(buffer);
  const kind = r.tag('mesh body', 3);
  if (kind === 0) {
    const mesh = readMeshStream(r);
    r.end();
    mesh.etag = etag;
    return { mesh };
  }
  if (kind === 2) {
    const mesh = readMeshStream(r);
    const flag = r.u8('reuses_depths');
    if (flag > 1) throw new WireError(`reuses_depths is ${flag}`);
    const reusesDepths = flag === 1;
    const fresh = { split: bytes(r, 'fresh split bits'), leaf: bytes(r, 'fresh leaf bits') };
    if (bytes(r, 'fresh cut bits').length !== 0) throw new WireError('fresh cut bits are not part of a change');
    r.end();
    mesh.etag = etag;
    return { change: { mesh, reusesDepths, fresh } };
  }
  const version = r.u16('version');
  if (version !== COMPACT_VERSION) throw new WireError(`compact stream version ${version}`);
  const first = r.u8('first');
  const n = r.len(8, 'planes');
  const planes = [];
  for (let k = 0; k < n; k++) planes.push(bytes(r, 'plane'));
  const maxError = r.f32('max_error');
  r.end();
  return { planes: { first, planes, maxError, etag } };
}

/** The planes of an update appended to the held stream they extend.
 * @param {MeshStream} s @param {{first: number, planes: Uint8Array[], maxError: number, etag: string}} u
 * @returns {MeshStream} */
export function applyPlanes(s, u) {
  if (u.first !== s.planes.length) throw new WireError('the planes do not start where the held ones end');
  if (s.planes.length + u.planes.length > s.totalPlanes) throw new WireError('more planes than the mesh has');
  return { ...s, planes: [...s.planes, ...u.planes], maxError: u.maxError, etag: u.etag };
}

/** The forest's geometry (engine/src/mesh/grid.rs). */
class Forest {
  /** @param {number} side @param {number} m @param {number} n */
  constructor(side, m, n) {
    if (!(side >= 2 && side <= 32768 && (side & (side - 1)) === 0)) throw new WireError(`root side ${side} is not a power of two in 2..=32768`);
    if (m === 0 || n === 0) throw new WireError('the forest needs at least one root quad');
    this.side = side; this.m = m; this.n = n;
    /** Set by `kind`: the last vertex asked about is a centre, or a horizontal edge's midpoint. */
    this.centre = false;
    this.horizontal = false;
    this.k = ctz(side);
    this.gw = m * side + 1;
    this.gh = n * side + 1;
    if (this.gw > 65536 || this.gh > 65536 || this.gw * this.gh > MAX_GRID_VERTICES) throw new WireError('the forest is larger than any image a server stores');
  }
  /** h, or 0 for a root corner; sets this.centre and this.horizontal. @param {number} x @param {number} y */
  kind(x, y) {
    const s = this.side;
    if (x % s === 0 && y % s === 0) return 0;
    const tx = x === 0 ? this.k : Math.min(ctz(x), this.k);
    const ty = y === 0 ? this.k : Math.min(ctz(y), this.k);
    this.centre = tx === ty;
    this.horizontal = tx < ty;
    return 1 << Math.min(tx, ty);
  }
  /** The diamond of (x, y) into `out` = [ax, ay, bx, by, p0x, p0y, p1x, p1y]; false for a root corner.
   * @param {number} x @param {number} y @param {Float64Array | number[]} out */
  diamond(x, y, out) {
    const h = this.kind(x, y);
    if (h === 0) return false;
    if (this.centre) {
      // Of c - h and c + h, the odd multiple of 2h.
      const px = Math.floor((x - h) / (2 * h)) % 2 === 1 ? x - h : x + h;
      const py = Math.floor((y - h) / (2 * h)) % 2 === 1 ? y - h : y + h;
      const qx = 2 * x - px; const qy = 2 * y - py;
      out[0] = px; out[1] = py; out[2] = qx; out[3] = qy;
      if (px < qx) { out[4] = px; out[5] = qy; out[6] = qx; out[7] = py; } else { out[4] = qx; out[5] = py; out[6] = px; out[7] = qy; }
    } else if (this.horizontal) {
      out[0] = x - h; out[1] = y; out[2] = x + h; out[3] = y;
      out[4] = x; out[5] = y - h; out[6] = x; out[7] = y + h;
    } else {
      out[0] = x; out[1] = y - h; out[2] = x; out[3] = y + h;
      out[4] = x - h; out[5] = y; out[6] = x + h; out[7] = y;
    }
    return true;
  }
}

/**
 * @typedef {object} GridScratch  grid-sized buffers kept between decodes
 *   (allocating and zeroing them costs more than a small mesh's decode)
 * @property {number} len
 * @property {Uint8Array} split
 * @property {Int32Array} parent
 * @property {Uint8Array} levels
 * @property {Int32Array} slot      -1 where unused
 * @property {number[]} touched     grid indices whose split, parent and level were set
 */
/** @type {GridScratch | null} */
let scratch = null;

/** Clean scratch buffers for a grid of `len` vertices. @param {number} len @returns {GridScratch} */
function gridScratch(len) {
  if (!scratch || scratch.len < len) {
    scratch = {
      len,
      split: new Uint8Array(len),
      parent: new Int32Array(len),
      levels: new Uint8Array(len),
      slot: new Int32Array(len).fill(-1),
      touched: [],
    };
  }
  return scratch;
}

/** Returns the buffers clean: every split vertex's entries and the mesh's vertices' slots.
 * @param {GridScratch} g @param {Uint16Array} ij @param {number} gw */
function release(g, ij, gw) {
  for (const i of g.touched) { g.split[i] = 0; g.parent[i] = 0; g.levels[i] = 0; }
  g.touched.length = 0;
  for (let k = 0; k < ij.length; k += 2) g.slot[ij[k + 1] * gw + ij[k]] = -1;
}

/**
 * @typedef {object} Held  a decoded mesh a change is applied to
 * @property {Uint16Array} ij @property {Uint16Array | Uint32Array} indices
 * @property {Float32Array} depth @property {{scale: number, offset: number} | null} lattice
 * @property {boolean} complete  every plane decoded
 */

/**
 * A held mesh as the context a change's bits are coded in (connectivity.rs,
 * `Context`): `vert[g]` is 1 for a held vertex; `drawn[2 g + half]` has bit 0
 * for a drawn larger triangle whose split vertex is g, bit 1 for a drawn cell
 * triangle whose cell's corner is g.
 * @param {Forest} f @param {Held} held
 */
function heldContext(f, held) {
  const gw = f.gw;
  const len = f.gw * f.gh;
  const vert = new Uint8Array(len);
  const drawn = new Uint8Array(2 * len);
  const { ij, indices } = held;
  const n = ij.length / 2;
  for (let k = 0; k < n; k++) {
    if (ij[2 * k] >= f.gw || ij[2 * k + 1] >= f.gh) throw new WireError('a held vertex lies outside the grid');
    vert[ij[2 * k + 1] * gw + ij[2 * k]] = 1;
  }
  const p = [0, 0, 0, 0, 0, 0];
  for (let t = 0; t < indices.length; t += 3) {
    for (let c = 0; c < 3; c++) {
      const v = indices[t + c];
      if (v >= n) throw new WireError('a held triangle has no vertex');
      p[2 * c] = ij[2 * v]; p[2 * c + 1] = ij[2 * v + 1];
    }
    // The right angle is opposite the longest side.
    const d2 = (/** @type {number} */ a, /** @type {number} */ b) => (p[2 * a] - p[2 * b]) ** 2 + (p[2 * a + 1] - p[2 * b + 1]) ** 2;
    const sides = [d2(1, 2), d2(0, 2), d2(0, 1)];
    const apex = sides[0] >= sides[1] && sides[0] >= sides[2] ? 0 : sides[1] >= sides[2] ? 1 : 2;
    const l = (apex + 1) % 3; const r = (apex + 2) % 3;
    const lx = p[2 * l]; const ly = p[2 * l + 1]; const rx = p[2 * r]; const ry = p[2 * r + 1];
    const ax = p[2 * apex]; const ay = p[2 * apex + 1];
    const cell = Math.abs(lx - rx) === 1 && Math.abs(ly - ry) === 1;
    if (cell) {
      const mx = Math.min(lx, rx); const my = Math.min(ly, ry);
      drawn[2 * (my * gw + mx) + (ax !== mx ? 1 : 0)] |= 2;
    } else {
      const mx = (lx + rx) >> 1; const my = (ly + ry) >> 1;
      drawn[2 * (my * gw + mx) + (ax < mx || (ax === mx && ay < my) ? 0 : 1)] |= 1;
    }
  }
  return { vert, drawn };
}

/**
 * Runs the canonical walk over `split`, `leaf` and `cut` bits; returns the
 * drawn triangles' corners and the cut leaves' as grid indices (3 per
 * triangle, oriented). Iterative, with the bit readers inlined: this loop
 * is most of a decode.
 * @param {Forest} f @param {Uint8Array} splitBits @param {Uint8Array} leafBits @param {number} count
 * @param {Uint8Array} cutBits @param {number} cutCount
 * @param {GridScratch} grid clean buffers of the forest's size
 * @param {{vert: Uint8Array, drawn: Uint8Array} | null} held a change's context: the bits of a
 *   triangle the held mesh reached are differences from its fate there; the others' are in `fresh`
 * @param {{split: Uint8Array, leaf: Uint8Array} | null} fresh
 */
function walk(f, splitBits, leafBits, count, cutBits, cutCount, grid, held, fresh) {
  const gw = f.gw;
  const gh = f.gh;
  const { split, parent, levels, touched } = grid;
  // `parent`: one end of the edge each split vertex bisects, plus one (the
  // other end is its mirror; 0: not split yet); `levels`: the level of each
  // split vertex (root corners stay 0); `touched`: what to clear afterwards.
  const out = new Uint32Array(3 * count);
  const cutOut = new Uint32Array(3 * cutCount);
  let drawn = 0;
  let cuts = 0;
  let sAt = 0;
  let lAt = 0;
  let cAt = 0;
  const cEnd = 8 * cutBits.length;
  const sEnd = 8 * splitBits.length;
  const lEnd = 8 * leafBits.length;
  const freshSplit = fresh ? fresh.split : new Uint8Array(0);
  const freshLeaf = fresh ? fresh.leaf : new Uint8Array(0);
  let fsAt = 0;
  let flAt = 0;
  const d = [0, 0, 0, 0, 0, 0, 0, 0];
  // Triangles still to visit, six coordinates each; children pushed in
  // reverse so the entry-side child is visited first.
  const stack = new Int32Array(6 * (4 * f.k + 8));
  const s = f.side;
  for (let qy = 0; qy < f.n; qy++) {
    for (let q = 0; q < f.m; q++) {
      const qx = qy % 2 === 0 ? q : f.m - 1 - q;
      f.diamond(qx * s + s / 2, qy * s + s / 2, d);
      let top = 0;
      stack[0] = d[2]; stack[1] = d[3]; stack[2] = d[0]; stack[3] = d[1]; stack[4] = d[6]; stack[5] = d[7];
      stack[6] = d[0]; stack[7] = d[1]; stack[8] = d[2]; stack[9] = d[3]; stack[10] = d[4]; stack[11] = d[5];
      top = 12;
      while (top > 0) {
        top -= 6;
        const lx = stack[top]; const ly = stack[top + 1];
        const rx = stack[top + 2]; const ry = stack[top + 3];
        const ax = stack[top + 4]; const ay = stack[top + 5];
        let draw = false;
        const cell = (lx - rx === 1 || rx - lx === 1) && (ly - ry === 1 || ry - ly === 1);
        // With a held mesh: whether it reached this triangle, and its fate there.
        let reached = false;
        let splitHeld = 0;
        let drawnHeld = 0;
        if (held) {
          reached = (lx > rx ? lx - rx : rx - lx) === s || held.vert[ay * gw + ax] === 1;
          if (cell) {
            const cx = lx < rx ? lx : rx; const cy = ly < ry ? ly : ry;
            drawnHeld = held.drawn[2 * (cy * gw + cx) + (ax !== cx ? 1 : 0)] & 2 ? 1 : 0;
          } else {
            const mx = (lx + rx) >> 1; const my = (ly + ry) >> 1;
            drawnHeld = held.drawn[2 * (my * gw + mx) + (ax < mx || (ax === mx && ay < my) ? 0 : 1)] & 1;
            splitHeld = held.vert[my * gw + mx] === 1 && drawnHeld === 0 ? 1 : 0;
          }
        }
        if (!cell) {
          const mx = (lx + rx) >> 1;
          const my = (ly + ry) >> 1;
          let splits = split[my * gw + mx] === 1;
          if (!splits) {
            if (held && !reached) {
              if (fsAt >= 8 * freshSplit.length) throw new WireError('fresh split bits end early or run on');
              splits = ((freshSplit[fsAt >> 3] >> (fsAt & 7)) & 1) === 1;
              fsAt++;
            } else {
              if (sAt >= sEnd) throw new WireError('split bits end early or run on');
              splits = (((splitBits[sAt >> 3] >> (sAt & 7)) & 1) ^ splitHeld) === 1;
              sAt++;
            }
          }
          if (splits) {
            // Split: the vertex and the apex opposite this triangle's.
            const m = my * gw + mx;
            if (split[m] === 0) touched.push(m);
            split[m] = 1;
            if (parent[m] === 0) {
              parent[m] = ly * gw + lx + 1;
              // A diagonal hypotenuse makes a centre, an axis-aligned one an
              // edge midpoint; its half-length h gives the level.
              const dx = rx > lx ? rx - lx : lx - rx;
              const dy = ry > ly ? ry - ly : ly - ry;
              const h = (dx > dy ? dx : dy) >> 1;
              levels[m] = 2 * (f.k - 1 - (31 - Math.clz32(h))) + (dx !== 0 && dy !== 0 ? 1 : 2);
            }
            const ox = 2 * mx - ax;
            const oy = 2 * my - ay;
            if (ox >= 0 && oy >= 0 && ox < gw && oy < gh && split[oy * gw + ox] === 0) {
              split[oy * gw + ox] = 1;
              touched.push(oy * gw + ox);
            }
            stack[top] = ax; stack[top + 1] = ay; stack[top + 2] = rx; stack[top + 3] = ry; stack[top + 4] = mx; stack[top + 5] = my;
            stack[top + 6] = lx; stack[top + 7] = ly; stack[top + 8] = ax; stack[top + 9] = ay; stack[top + 10] = mx; stack[top + 11] = my;
            top += 12;
            continue;
          }
        }
        if (held && !reached) {
          if (flAt >= 8 * freshLeaf.length) throw new WireError('fresh leaf bits end early or run on');
          draw = ((freshLeaf[flAt >> 3] >> (flAt & 7)) & 1) === 1;
          flAt++;
        } else {
          if (lAt >= lEnd) throw new WireError('leaf bits end early or run on');
          draw = (((leafBits[lAt >> 3] >> (lAt & 7)) & 1) ^ drawnHeld) === 1;
          lAt++;
        }
        let into = out;
        let o = 0;
        if (draw) {
          if (drawn >= count) throw new WireError('connectivity draws more triangles than the header says');
          o = 3 * drawn++;
        } else {
          // A leaf left out: its cut bit.
          if (cAt >= cEnd) throw new WireError('cut bits end early or run on');
          const isCut = (cutBits[cAt >> 3] >> (cAt & 7)) & 1;
          cAt++;
          if (!isCut) continue;
          if (cuts >= cutCount) throw new WireError('connectivity cuts more triangles than the header says');
          into = cutOut;
          o = 3 * cuts++;
        }
        const cross = (rx - lx) * (ay - ly) - (ry - ly) * (ax - lx);
        if (cross > 0) { into[o] = ry * gw + rx; into[o + 1] = ly * gw + lx; } else { into[o] = ly * gw + lx; into[o + 1] = ry * gw + rx; }
        into[o + 2] = ay * gw + ax;
      }
    }
  }
  const clear = (/** @type {Uint8Array} */ b, /** @type {number} */ at) =>
    (at + 7) >> 3 === b.length && ((at & 7) === 0 || b[at >> 3] >> (at & 7) === 0);
  if (!clear(splitBits, sAt)) throw new WireError('split bits end early or run on');
  if (!clear(leafBits, lAt)) throw new WireError('leaf bits end early or run on');
  if (!clear(cutBits, cAt)) throw new WireError('cut bits end early or run on');
  if (!clear(freshSplit, fsAt)) throw new WireError('fresh split bits end early or run on');
  if (!clear(freshLeaf, flAt)) throw new WireError('fresh leaf bits end early or run on');
  if (drawn !== count) throw new WireError('connectivity draws fewer triangles than the header says');
  if (cuts !== cutCount) throw new WireError('connectivity cuts fewer triangles than the header says');
  return { corners: out, cutCorners: cutOut, parent, levels };
}

/**
 * @typedef {object} CutShapes  the cut triangles placed, depths to come (cut.rs, `CutShape`)
 * @property {Uint32Array} corners  grid indices, 3 per cut, the lone corner first
 * @property {Uint16Array} at  half steps from the lone corner along its two edges, 2 per cut
 * @property {Uint8Array} drawn  bit 0: the lone part is drawn, bit 1: the other part
 * @property {Int32Array} sides  per cut and crossing, the side depths' places (lone side, other side; -1: void)
 * @property {number[]} ends  per side depth, the grid index of its edge's end on that side
 */

/**
 * Reads the cut triangles' cases and crossings (cut.rs, `decode`): a crossing
 * shared by two cuts is read once, its side depths placed once.
 * @param {Forest} f @param {Uint32Array} leaves the cut leaves' oriented corners
 * @param {Uint8Array} cases @param {Uint8Array} crossings @returns {CutShapes}
 */
function decodeCuts(f, leaves, cases, crossings) {
  const c = leaves.length / 3;
  if (cases.length !== c) throw new WireError('cut cases do not match the cut triangles');
  const gw = f.gw;
  const corners = new Uint32Array(3 * c);
  const at = new Uint16Array(2 * c);
  const drawn = new Uint8Array(c);
  const sides = new Int32Array(4 * c);
  /** @type {number[]} */
  const ends = [];
  /** @type {Map<number, number[]>} edge key -> [h from the first end, first end's side, second end's side] */
  const met = new Map();
  let bit = 0;
  const end = 8 * crossings.length;
  for (let k = 0; k < c; k++) {
    const cs = cases[k];
    if (cs >= 9) throw new WireError('a cut\'s case is not one of the nine');
    const lone = (cs / 3) | 0;
    const v = cs % 3;
    const d0 = v !== 1; const d1 = v !== 2;
    drawn[k] = (d0 ? 1 : 0) | (d1 ? 2 : 0);
    for (let e = 0; e < 3; e++) corners[3 * k + e] = leaves[3 * k + ((lone + e) % 3)];
    const p = corners[3 * k];
    for (let e = 0; e < 2; e++) {
      const q = corners[3 * k + 1 + e];
      const px = p % gw; const py = (p - px) / gw; const qx = q % gw; const qy = (q - qx) / gw;
      const n = Math.max(Math.abs(px - qx), Math.abs(py - qy));
      const forward = p < q;
      const key = forward ? p * 67108864 + q : q * 67108864 + p;
      const first = forward ? d0 : d1; const second = forward ? d1 : d0;
      let m = met.get(key);
      if (m) {
        if ((m[1] >= 0) !== first || (m[2] >= 0) !== second) throw new WireError('two cuts draw different sides of one crossing');
      } else {
        const width = ctz(n) + 1;
        if (bit + width > end) throw new WireError('crossing bits end early or run on');
        let h = 0;
        for (let b = 0; b < width; b++, bit++) h |= ((crossings[bit >> 3] >> (bit & 7)) & 1) << b;
        h += 1;
        if (h >= 2 * n) throw new WireError('a crossing lies on an edge\'s end');
        const s0 = first ? ends.push(forward ? p : q) - 1 : -1;
        const s1 = second ? ends.push(forward ? q : p) - 1 : -1;
        m = [h, s0, s1];
        met.set(key, m);
      }
      at[2 * k + e] = forward ? m[0] : 2 * n - m[0];
      sides[4 * k + 2 * e] = forward ? m[1] : m[2];
      sides[4 * k + 2 * e + 1] = forward ? m[2] : m[1];
    }
  }
  if ((bit + 7) >> 3 !== crossings.length || ((bit & 7) !== 0 && crossings[bit >> 3] >> (bit & 7) !== 0)) {
    throw new WireError('crossing bits end early or run on');
  }
  return { corners, at, drawn, sides, ends };
}

/**
 * Numbers the vertices by first use, then the cuts' drawn corners by first
 * use, then stably by level (as the engine).
 * @param {Forest} f @param {Uint32Array} corners grid indices
 * @param {CutShapes} cuts
 * @param {Uint8Array} levels each split vertex's level, by grid index
 * @param {Int32Array} slot the grid's scratch map, all -1 (left set for the vertices)
 */
function assemble(f, corners, cuts, levels, slot) {
  const gw = f.gw;
  const used = new Int32Array(corners.length + cuts.corners.length);
  let n = 0;
  const perLevel = new Uint32Array(2 * f.k + 2);
  const use = (/** @type {number} */ g) => {
    if (slot[g] === -1) {
      slot[g] = 0;
      perLevel[levels[g] + 1]++;
      used[n++] = g;
    }
  };
  for (let c = 0; c < corners.length; c++) use(corners[c]);
  for (let k = 0; k < cuts.drawn.length; k++) {
    if (cuts.drawn[k] & 1) use(cuts.corners[3 * k]);
    if (cuts.drawn[k] & 2) { use(cuts.corners[3 * k + 1]); use(cuts.corners[3 * k + 2]); }
  }
  for (let l = 1; l < perLevel.length; l++) perLevel[l] += perLevel[l - 1];
  const ij = new Uint16Array(2 * n);
  const level = new Uint8Array(n);
  for (let u = 0; u < n; u++) {
    const g = used[u];
    const lv = levels[g];
    const at = perLevel[lv]++;
    const x = g % gw;
    ij[2 * at] = x;
    ij[2 * at + 1] = (g - x) / gw;
    level[at] = lv;
    slot[g] = at;
  }
  let indices;
  if (n < 65535) {
    indices = new Uint16Array(corners.length);
    for (let c = 0; c < corners.length; c++) indices[c] = slot[corners[c]];
  } else {
    indices = new Uint32Array(corners.length);
    for (let c = 0; c < corners.length; c++) indices[c] = slot[corners[c]];
  }
  return { ij, level, indices, slot };
}

/**
 * Depths from the first `held` planes (bitplanes.rs). `slot` numbers the
 * grid's vertices as the mesh does (-1: not in it); a vertex's predictors
 * are coarser, so in the mesh they come before it.
 * @param {Forest} f @param {MeshStream} s @param {Uint16Array} ij @param {Uint8Array} level
 * @param {Int32Array} parent @param {Int32Array} slot @param {number} held
 * @param {Float32Array | null} known depths the client has (NaN where it has none), skipped by the code
 * @param {Int32Array} sideEnds per crossing side, the vertex number it is predicted from; its depth
 *   follows the vertices', on the level past the finest
 */
function depths(f, s, ij, level, parent, slot, held, known, sideEnds) {
  const { lattice, levels } = s;
  if (levels.length !== 2 * f.k + 2) throw new WireError('depth levels do not match the forest');
  if (held > s.planes.length) throw new WireError('fewer depth planes than stated');
  for (const l of levels) {
    if (l.planes > MAX_PLANES) throw new WireError('a level has more than 24 planes');
    if (lattice ? l.step !== 1 : !(Number.isFinite(l.step) && l.step > 0)) throw new WireError('bad depth step');
  }
  if (lattice && !(Number.isFinite(lattice.scale) && lattice.scale !== 0 && Number.isFinite(lattice.offset))) {
    throw new WireError('lattice scale must be finite and non-zero, offset finite');
  }
  const nv = ij.length / 2;
  const n = nv + sideEnds.length;
  const gw = f.gw;
  const gh = f.gh;
  // Predictors: two vertices (mean), one (its value: pb = -1) or none (pa = -1).
  const pa = new Int32Array(n).fill(-1);
  const pb = new Int32Array(n).fill(-1);
  const side = f.side;
  const at = (/** @type {number} */ x, /** @type {number} */ y) => (x >= 0 && y >= 0 && x < gw && y < gh ? slot[y * gw + x] : -1);
  for (let k = 0; k < sideEnds.length; k++) pa[nv + k] = sideEnds[k];
  for (let k = 0; k < nv; k++) {
    const x = ij[2 * k]; const y = ij[2 * k + 1];
    if (x % side === 0 && y % side === 0) continue;
    // The edge it bisects: the walk's split recorded one end, the other
    // mirrors it; the apexes lie across the other diagonal, smaller x (then y) first.
    const e = parent[y * gw + x] - 1;
    const ex = e % gw;
    const ey = (e - ex) / gw;
    const dx = ex - x; const dy = ey - y;
    let p0x = x + dy; let p0y = y - dx; let p1x = x - dy; let p1y = y + dx;
    if (p1x < p0x || (p1x === p0x && p1y < p0y)) { const tx = p0x; const ty = p0y; p0x = p1x; p0y = p1y; p1x = tx; p1y = ty; }
    const a = slot[e];
    const b = slot[(y - dy) * gw + (x - dx)];
    const c = at(p0x, p0y);
    const d = at(p1x, p1y);
    if (a >= 0 && b >= 0) { pa[k] = a; pb[k] = b; } else if (c >= 0 && d >= 0) { pa[k] = c; pb[k] = d; } else {
      pa[k] = a >= 0 ? a : b >= 0 ? b : c >= 0 ? c : d;
    }
  }
  // Escape bits, one per predicted vertex: coded[k] when it is neither an anchor nor escaped.
  const coded = new Uint8Array(n);
  let exactCount = 0;
  {
    const b = s.escapes;
    let bit = 0;
    for (let k = 0; k < n; k++) {
      if (known && !Number.isNaN(known[k])) continue;
      if (pa[k] < 0) { exactCount++; continue; }
      if (bit >= 8 * b.length) throw new WireError('escape bits end early or run on');
      const escaped = (b[bit >> 3] >> (bit & 7)) & 1;
      bit++;
      coded[k] = 1 - escaped;
      exactCount += escaped;
    }
    if ((bit + 7) >> 3 !== b.length || ((bit & 7) !== 0 && b[bit >> 3] >> (bit & 7) !== 0)) throw new WireError('escape bits end early or run on');
  }
  if (s.exact.length !== 4 * exactCount) throw new WireError('exact depth bytes do not match the anchors and escapes');
  const mb = new Uint32Array(n);
  const negative = new Uint8Array(n);
  // Planes of each coded vertex's level (0 for the others).
  const lp = new Uint8Array(n);
  const levelOf = (/** @type {number} */ k) => (k < nv ? level[k] : levels.length - 1);
  for (let k = 0; k < n; k++) if (coded[k]) lp[k] = levels[levelOf(k)].planes;
  // Vertices a plane made non-zero, whose signs follow its bits.
  const fresh = new Int32Array(n);
  for (let t = 1; t <= held; t++) {
    const plane = s.planes[t - 1];
    const end = 8 * plane.length;
    let bit = 0;
    let count = 0;
    for (let k = 0; k < n; k++) {
      if (lp[k] < t) continue;
      if (bit >= end) throw new WireError('a depth plane ends early or runs on');
      const m = (mb[k] << 1) | ((plane[bit >> 3] >> (bit & 7)) & 1);
      mb[k] = m;
      if (m === 1) fresh[count++] = k;
      bit++;
    }
    for (let c = 0; c < count; c++) {
      if (bit >= end) throw new WireError('a depth plane ends early or runs on');
      negative[fresh[c]] = (plane[bit >> 3] >> (bit & 7)) & 1;
      bit++;
    }
    if ((bit + 7) >> 3 !== plane.length || ((bit & 7) !== 0 && plane[bit >> 3] >> (bit & 7) !== 0)) {
      throw new WireError('a depth plane ends early or runs on');
    }
  }
  const units = new Float64Array(n);
  const out = new Float32Array(n);
  const scratch = new DataView(new ArrayBuffer(4));
  const steps = Float64Array.from(levels, (l) => l.step);
  const planesOf = Uint8Array.from(levels, (l) => l.planes);
  let next = 0;
  const valid = (/** @type {number} */ z) => Number.isFinite(z) && z > 0;
  for (let k = 0; k < n; k++) {
    if (known && !Number.isNaN(known[k])) {
      const z = known[k];
      if (!valid(z)) throw new WireError('a known depth is not finite and positive');
      out[k] = z;
      units[k] = lattice ? round((z - lattice.offset) / lattice.scale) : z;
      continue;
    }
    if (!coded[k]) {
      for (let b = 0; b < 4; b++) scratch.setUint8(b, s.exact[b * exactCount + next]);
      next++;
      const z = scratch.getFloat32(0, true);
      if (!valid(z)) throw new WireError('an exact depth is not finite and positive');
      out[k] = z;
      units[k] = lattice ? round((z - lattice.offset) / lattice.scale) : z;
      if (lattice && !(Math.abs(units[k]) < MAX_RAW)) throw new WireError('an exact depth lies off the lattice\'s range');
      continue;
    }
    const lv = levelOf(k);
    const step = steps[lv];
    const sh = planesOf[lv] - Math.min(planesOf[lv], held);
    let pred;
    if (pb[k] >= 0) {
      const mid = (units[pa[k]] + units[pb[k]]) * 0.5;
      pred = lattice ? Math.floor(mid) : mid;
    } else {
      pred = units[pa[k]];
    }
    const m = mb[k];
    const mag = sh === 0 ? m : m === 0 ? 0 : m * (1 << sh) + (1 << (sh - 1));
    const value = negative[k] ? pred - mag * step : pred + mag * step;
    let z = lattice ? Math.fround(value * lattice.scale + lattice.offset) : Math.fround(value);
    let u = lattice ? value : z;
    if (!valid(z)) {
      z = lattice ? Math.fround(pred * lattice.scale + lattice.offset) : Math.fround(pred);
      u = lattice ? pred : z;
      if (!valid(z)) throw new WireError('depths decode to no valid depth');
    }
    if (lattice && !(Math.abs(u) < MAX_RAW)) throw new WireError('depths leave the lattice\'s range');
    out[k] = z;
    units[k] = u;
  }
  return out;
}

/** Rust's `v as u8`: truncated, saturating, NaN to 0. @param {number} v */
const asU8 = (v) => (v > 0 ? Math.min(255, Math.floor(v)) : 0);

/** Octahedral encoding (engine/src/mesh/normals.rs, oct_encode) into out[o], out[o + 1].
 * @param {number} nx @param {number} ny @param {number} nz @param {Uint8Array} out @param {number} o */
function octEncode(nx, ny, nz, out, o) {
  const l1 = Math.abs(nx) + Math.abs(ny) + Math.abs(nz);
  if (!(l1 > 0 && Number.isFinite(l1))) { out[o] = 128; out[o + 1] = 128; return; }
  const inv = 1 / l1;
  let px = nx * inv;
  let py = ny * inv;
  if (nz < 0) {
    // Rust's copysign: the sign bit, so -0 counts as negative.
    const ax = Math.abs(px); const ay = Math.abs(py);
    const fx = px < 0 || Object.is(px, -0) ? -(1 - ay) : 1 - ay;
    py = py < 0 || Object.is(py, -0) ? -(1 - ax) : 1 - ax;
    px = fx;
  }
  out[o] = asU8(px * 127.5 + 128);
  out[o + 1] = asU8(py * 127.5 + 128);
}

/**
 * Normals and rho from the decoded mesh (engine/src/mesh/derived_normals.rs).
 * @param {import('./protocol.js').CameraJson} cam @param {Uint16Array} ij @param {Float32Array} z
 * @param {Uint16Array | Uint32Array} tri
 */
export function deriveNormals(cam, ij, z, tri) {
  const n = z.length;
  const p = new Float64Array(3 * n);
  const persp = cam.projection.perspective;
  const ortho = cam.projection.orthographic;
  for (let k = 0; k < n; k++) {
    const u = ij[2 * k]; const v = ij[2 * k + 1]; const d = z[k];
    let ax; let bx; let ay; let by;
    if (persp) { ax = 0.0; bx = (u - persp.cx) / persp.fx; ay = 0.0; by = (v - persp.cy) / persp.fy; } else {
      const o = /** @type {{sx: number, sy: number, cx: number, cy: number}} */ (ortho);
      ax = (u - o.cx) * o.sx; bx = 0.0; ay = (v - o.cy) * o.sy; by = 0.0;
    }
    p[3 * k] = ax + bx * d; p[3 * k + 1] = ay + by * d; p[3 * k + 2] = d;
  }
  const sum = new Float64Array(3 * n);
  for (let t = 0; t < tri.length; t += 3) {
    const a = 3 * tri[t]; const b = 3 * tri[t + 1]; const c = 3 * tri[t + 2];
    const e1x = p[b] - p[a]; const e1y = p[b + 1] - p[a + 1]; const e1z = p[b + 2] - p[a + 2];
    const e2x = p[c] - p[a]; const e2y = p[c + 1] - p[a + 1]; const e2z = p[c + 2] - p[a + 2];
    const nx = e1y * e2z - e1z * e2y;
    const ny = e1z * e2x - e1x * e2z;
    const nz = e1x * e2y - e1y * e2x;
    sum[a] += nx; sum[a + 1] += ny; sum[a + 2] += nz;
    sum[b] += nx; sum[b + 1] += ny; sum[b + 2] += nz;
    sum[c] += nx; sum[c + 1] += ny; sum[c + 2] += nz;
  }
  const normal = new Uint8Array(2 * n);
  const rho = new Uint8Array(n);
  for (let k = 0; k < n; k++) {
    const nx = sum[3 * k]; const ny = sum[3 * k + 1]; const nz = sum[3 * k + 2];
    const vx = ortho ? 0.0 : p[3 * k]; const vy = ortho ? 0.0 : p[3 * k + 1]; const vz = ortho ? 1.0 : p[3 * k + 2];
    const nv = nx * vx + ny * vy + nz * vz;
    const nn = (nx * nx + ny * ny + nz * nz) * (vx * vx + vy * vy + vz * vz);
    if (!(nn > 0 && nn < Infinity)) { octEncode(-vx, -vy, -vz, normal, 2 * k); rho[k] = 0; continue; }
    const flip = nv > 0 ? -1.0 : 1.0;
    octEncode(nx * flip, ny * flip, nz * flip, normal, 2 * k);
    rho[k] = asU8((Math.abs(nv) / Math.sqrt(nn)) * 255 + 0.5);
  }
  return { normal, rho };
}

/**
 * @typedef {object} Cuts  decoded cut triangles (cut.rs, `CutTriangle`), per cut
 * @property {Uint16Array} corners  (i, j) of the lone corner, then the other two: 6 per cut
 * @property {Uint16Array} at  half steps from the lone corner: 2 per cut
 * @property {Float32Array} lone  the lone part's depths at its corner and the two crossings (NaN: void): 3 per cut
 * @property {Float32Array} other  the other part's at crossing 1, corners 1 and 2, crossing 2 (NaN: void): 4 per cut
 */

/** The cut triangles with their depths: corners' from the vertices, crossings' from the sides.
 * @param {Forest} f @param {CutShapes} shapes @param {Int32Array} slot @param {Float32Array} depth
 * @param {Float32Array} sideDepth @returns {Cuts} */
function cutDepths(f, shapes, slot, depth, sideDepth) {
  const c = shapes.drawn.length;
  const corners = new Uint16Array(6 * c);
  const lone = new Float32Array(3 * c).fill(NaN);
  const other = new Float32Array(4 * c).fill(NaN);
  const gw = f.gw;
  for (let k = 0; k < c; k++) {
    for (let e = 0; e < 3; e++) {
      const g = shapes.corners[3 * k + e];
      const x = g % gw;
      corners[6 * k + 2 * e] = x; corners[6 * k + 2 * e + 1] = (g - x) / gw;
    }
    const z = (/** @type {number} */ e) => depth[slot[shapes.corners[3 * k + e]]];
    const sd = shapes.sides;
    if (shapes.drawn[k] & 1) {
      lone[3 * k] = z(0); lone[3 * k + 1] = sideDepth[sd[4 * k]]; lone[3 * k + 2] = sideDepth[sd[4 * k + 2]];
    }
    if (shapes.drawn[k] & 2) {
      other[4 * k] = sideDepth[sd[4 * k + 1]]; other[4 * k + 1] = z(1); other[4 * k + 2] = z(2); other[4 * k + 3] = sideDepth[sd[4 * k + 3]];
    }
  }
  return { corners, at: shapes.at.slice(), lone, other };
}

/**
 * The triangles the cuts draw (cut.rs, `CutTriangle::parts`, the same
 * operations in the same order): per cut the lone part, then the other's
 * two split along crossing 1 to corner 2, those of no area left out; with a
 * flat normal and rho per part (`derived_normals.rs` of that one triangle).
 * @param {import('./protocol.js').CameraJson} cam @param {Cuts} cuts
 * @returns {{uv: Float32Array, depth: Float32Array, normal: Uint8Array, rho: Uint8Array}}
 */
export function cutParts(cam, cuts) {
  /** @type {number[]} */
  const pts = [];
  const c = cuts.at.length / 2;
  for (let k = 0; k < c; k++) {
    const x0 = cuts.corners[6 * k]; const y0 = cuts.corners[6 * k + 1];
    const cross = [1, 2].map((e) => {
      const dx = cuts.corners[6 * k + 2 * e] - x0; const dy = cuts.corners[6 * k + 2 * e + 1] - y0;
      const t = cuts.at[2 * k + e - 1] / (2.0 * Math.max(Math.abs(dx), Math.abs(dy)));
      return [x0 + t * dx, y0 + t * dy];
    });
    const corner = (/** @type {number} */ e) => [cuts.corners[6 * k + 2 * e], cuts.corners[6 * k + 2 * e + 1]];
    /** @type {number[][][]} */
    const tris = [];
    if (!Number.isNaN(cuts.lone[3 * k])) {
      const z = cuts.lone.subarray(3 * k, 3 * k + 3);
      tris.push([[...corner(0), z[0]], [...cross[0], z[1]], [...cross[1], z[2]]]);
    }
    if (!Number.isNaN(cuts.other[4 * k])) {
      const z = cuts.other.subarray(4 * k, 4 * k + 4);
      const a = [...cross[0], z[0]];
      tris.push([a, [...corner(1), z[1]], [...corner(2), z[2]]]);
      tris.push([a, [...corner(2), z[2]], [...cross[1], z[3]]]);
    }
    for (const t of tris) {
      const area = (t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[1][1] - t[0][1]) * (t[2][0] - t[0][0]);
      if (area !== 0) for (const p of t) pts.push(p[0], p[1], p[2]);
    }
  }
  const n = pts.length / 3;
  const uv = new Float32Array(2 * n);
  const depth = new Float32Array(n);
  for (let k = 0; k < n; k++) { uv[2 * k] = pts[3 * k]; uv[2 * k + 1] = pts[3 * k + 1]; depth[k] = pts[3 * k + 2]; }
  // Flat normals: each part alone through deriveNormals' arithmetic.
  const normal = new Uint8Array(2 * n);
  const rho = new Uint8Array(n);
  const persp = cam.projection.perspective;
  const ortho = cam.projection.orthographic;
  const p = new Float64Array(9);
  for (let t = 0; t < n; t += 3) {
    for (let v = 0; v < 3; v++) {
      const u = pts[3 * (t + v)]; const w = pts[3 * (t + v) + 1]; const d = pts[3 * (t + v) + 2];
      if (persp) { p[3 * v] = ((u - persp.cx) / persp.fx) * d; p[3 * v + 1] = ((w - persp.cy) / persp.fy) * d; } else {
        const o = /** @type {{sx: number, sy: number, cx: number, cy: number}} */ (ortho);
        p[3 * v] = (u - o.cx) * o.sx; p[3 * v + 1] = (w - o.cy) * o.sy;
      }
      p[3 * v + 2] = d;
    }
    const e1x = p[3] - p[0]; const e1y = p[4] - p[1]; const e1z = p[5] - p[2];
    const e2x = p[6] - p[0]; const e2y = p[7] - p[1]; const e2z = p[8] - p[2];
    const nx = e1y * e2z - e1z * e2y; const ny = e1z * e2x - e1x * e2z; const nz = e1x * e2y - e1y * e2x;
    for (let v = 0; v < 3; v++) {
      const vx = ortho ? 0.0 : p[3 * v]; const vy = ortho ? 0.0 : p[3 * v + 1]; const vz = ortho ? 1.0 : p[3 * v + 2];
      const nv = nx * vx + ny * vy + nz * vz;
      const nn = (nx * nx + ny * ny + nz * nz) * (vx * vx + vy * vy + vz * vz);
      const k = t + v;
      if (!(nn > 0 && nn < Infinity)) { octEncode(-vx, -vy, -vz, normal, 2 * k); rho[k] = 0; continue; }
      const flip = nv > 0 ? -1.0 : 1.0;
      octEncode(nx * flip, ny * flip, nz * flip, normal, 2 * k);
      rho[k] = asU8((Math.abs(nv) / Math.sqrt(nn)) * 255 + 0.5);
    }
  }
  return { uv, depth, normal, rho };
}

/**
 * A compact mesh decoded into the arrays the renderer draws (the `Strips`
 * shape of protocol.js, with `mode: 'triangles'`: an indexed triangle list).
 * `requesting` is the camera the request named (a view-dependent mesh's
 * reach refers to it). With `held`, `s` is a change's mesh, applied to the
 * held mesh (with its depths when the change `reusesDepths`).
 * @param {MeshStream} s @param {import('./protocol.js').CameraJson | null} requesting
 * @param {Held | null} [held] @param {boolean} [reusesDepths]
 * @param {{split: Uint8Array, leaf: Uint8Array} | null} [fresh] the change's bits of triangles the held mesh never reached
 */
export function decodeMesh(s, requesting, held = null, reusesDepths = false, fresh = null) {
  const f = new Forest(s.rootSide, s.rootsX, s.rootsY);
  // The forest is the reference image's: the fewest roots of this side covering it.
  const covers = (/** @type {number} */ roots, /** @type {number} */ size) =>
    size >= 2 && (roots - 1) * f.side < size - 1 && roots * f.side >= size - 1;
  if (!(covers(f.m, s.camera.width) && covers(f.n, s.camera.height))) {
    throw new WireError(`${f.m} x ${f.n} roots of side ${f.side} do not cover the ${s.camera.width} x ${s.camera.height} reference image`);
  }
  if (s.triangles > 2 * (f.gw - 1) * (f.gh - 1)) throw new WireError(`${s.triangles} triangles is more than the forest holds`);
  if (s.cutTriangles > 2 * (f.gw - 1) * (f.gh - 1)) throw new WireError(`${s.cutTriangles} cut triangles is more than the forest holds`);
  if (s.planes.length > s.totalPlanes) throw new WireError('more planes than the mesh has');
  if (!(Number.isFinite(s.maxError) && s.maxError >= 0)) throw new WireError('the error bound must be finite and not negative');
  const context = held ? heldContext(f, held) : null;
  if (reusesDepths) {
    const same = held && s.lattice && held.lattice && held.lattice.scale === s.lattice.scale && held.lattice.offset === s.lattice.offset;
    if (!(held && held.complete && same)) throw new WireError('the change reuses depths the held mesh does not have');
  }
  const grid = gridScratch(f.gw * f.gh);
  // A decode that fails leaves the buffers dirty: drop them.
  scratch = null;
  const { corners, cutCorners, parent, levels } = walk(f, s.split, s.leaf, s.triangles, s.cut, s.cutTriangles, grid, context,
    held ? fresh ?? { split: new Uint8Array(0), leaf: new Uint8Array(0) } : null);
  const shapes = decodeCuts(f, cutCorners, s.cases, s.crossings);
  const { ij, level, indices, slot } = assemble(f, corners, shapes, levels, grid.slot);
  const { width, height } = s.camera;
  for (let k = 0; k < ij.length; k += 2) {
    if (ij[k] >= width || ij[k + 1] >= height) throw new WireError('a vertex lies outside the reference image');
  }
  const nv = ij.length / 2;
  const sideEnds = Int32Array.from(shapes.ends, (g) => slot[g]);
  let known = null;
  if (reusesDepths && held) {
    // The held depths by grid vertex, then in this mesh's numbering; crossing sides are always sent.
    const byGrid = new Float32Array(f.gw * f.gh).fill(NaN);
    for (let k = 0; k < held.depth.length; k++) byGrid[held.ij[2 * k + 1] * f.gw + held.ij[2 * k]] = held.depth[k];
    known = new Float32Array(nv + sideEnds.length).fill(NaN);
    for (let k = 0; k < nv; k++) known[k] = byGrid[ij[2 * k + 1] * f.gw + ij[2 * k]];
  }
  const all = depths(f, s, ij, level, parent, slot, s.planes.length, known, sideEnds);
  const depth = all.subarray(0, nv).slice();
  const cuts = cutDepths(f, shapes, slot, depth, all.subarray(nv));
  release(grid, ij, f.gw);
  scratch = grid;
  const { normal, rho } = deriveNormals(s.camera, ij, depth, indices);
  const parts = cutParts(s.camera, cuts);
  let reach = null;
  if (s.reach) {
    const { lo, unit } = s.reach;
    reach = {
      view: requesting ?? s.camera,
      clearance: s.reach.clearance,
      culled: s.reach.culled.map(([x, y, z, r]) => [lo[0] + x * unit, lo[1] + y * unit, lo[2] + z * unit, r * unit]),
    };
  }
  return {
    version: s.version, scene: s.scene, view: s.view, lod: s.lod, camera: s.camera,
    vertexCount: ij.length / 2, ij, normal, rho, depth, indices, mode: /** @type {'triangles'} */ ('triangles'),
    cuts, parts, triangles: s.triangles, drawnTriangles: s.triangles + parts.depth.length / 3, extract_ms: s.extract_ms, maxDepthError: s.maxError, reach,
    etag: s.etag, planes: s.planes.length, totalPlanes: s.totalPlanes,
    lattice: s.lattice, complete: s.planes.length === s.totalPlanes,
  };
}

/** A compact render response: version, views (weight, mesh, colour URL), timings.
 * @param {ArrayBuffer} buffer @param {import('./protocol.js').CameraJson} novel */
export function decodeCompactRender(buffer, novel) {
  const r = new Reader(buffer);
  const version = r.u16('version');
  if (version !== COMPACT_VERSION) throw new WireError(`compact stream version ${version}; this viewer reads ${COMPACT_VERSION}`);
  const count = r.len(8, 'views');
  const streams = [];
  for (let k = 0; k < count; k++) {
    const weight = r.f64('weight');
    const mesh = readMeshStream(r);
    const color_url = r.string('color_url');
    streams.push({ weight, mesh, color_url });
  }
  const timings = { select_ms: r.f64('select_ms'), extract_ms: r.f64('extract_ms'), total_ms: r.f64('total_ms') };
  r.end();
  const views = streams.map(({ weight, mesh, color_url }) => ({ weight, color_url, strips: decodeMesh(mesh, mesh.reach ? novel : null) }));
  return { version, views, timings };
}
