// The page's state in its address, read and written (main.js keeps it
// there as the camera moves):
//   ?scene=ID&camera=<camera JSON>&tau=1 (or epsilon, max_triangles, budget_ms)
//   &bits=B&cos_k=K&relight=1|x,y,z&mode=blend|coverage|wireframe&fill=0..2&w=W&h=H
//   &policy=render|balanced&wire=compact|bincode&follow=0|1&ui=0
// Reading checks every value; what is wrong is reported in words and
// replaced by its default, never guessed. Pure functions of strings, so the
// Node tests read addresses without a browser.

import { checkCamera } from './camera.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {'tau' | 'epsilon' | 'max_triangles' | 'budget_ms'} LodKind */
/** @typedef {'blend' | 'coverage' | 'wireframe'} Mode */
/** @typedef {[number, number, number]} Light */

/** The levels of detail, as the panel shows them: label, slider range and default. */
export const LOD = /** @type {Record<LodKind, {label: string, min: number, max: number, log: boolean, def: number, int?: boolean}>} */ ({
  tau: { label: 'tau (px)', min: 0, max: 8, log: false, def: 1 },
  epsilon: { label: 'epsilon (m)', min: 1e-4, max: 1, log: true, def: 0.01 },
  max_triangles: { label: 'max triangles', min: 100, max: 2e6, log: true, def: 50000, int: true },
  budget_ms: { label: 'budget (ms)', min: 0.05, max: 100, log: true, def: 2 },
});
/** What a value of each level of detail may be, in words. */
const LOD_RULES = /** @type {Record<LodKind, [(v: number) => boolean, string]>} */ ({
  tau: [(v) => v >= 0, 'pixels, a number >= 0'],
  epsilon: [(v) => v >= 0, 'metres, a number >= 0'],
  max_triangles: [(v) => Number.isInteger(v) && v >= 0 && v < 2 ** 32, 'a whole number of triangles'],
  budget_ms: [(v) => v > 0, 'milliseconds, a number > 0'],
});
export const MODES = /** @type {Mode[]} */ (['blend', 'coverage', 'wireframe']);
export const DEFAULT_LIGHT = /** @type {Light} */ ([0.3, 1.0, 0.4]);

/**
 * The one level of detail `q` names (the wire's `Lod::exactly_one`, in
 * the browser): `null` when it names none, an error in words when it names
 * more than one (`kind` null) or one with a bad value (`kind` that one).
 * @param {URLSearchParams} q
 * @returns {{kind: LodKind, value: number} | {error: string, kind: LodKind | null} | null}
 */
export function exactlyOneLod(q) {
  const given = /** @type {LodKind[]} */ (Object.keys(LOD)).filter((k) => q.has(k));
  if (given.length === 0) return null;
  if (given.length > 1) return { error: `give exactly one of tau, epsilon, max_triangles, budget_ms (got ${given.join(', ')})`, kind: null };
  const kind = given[0];
  const text = q.get(kind) ?? '';
  const value = Number(text);
  const [ok, rule] = LOD_RULES[kind];
  if (text === '' || !Number.isFinite(value) || !ok(value)) return { error: `${kind}=${text}: ${rule}`, kind };
  return { kind, value };
}

/** What the panel accepts as a level of detail typed in: an error in words, or null.
 * @param {LodKind} kind @param {number} value */
export function lodProblem(kind, value) {
  const [ok, rule] = LOD_RULES[kind];
  return Number.isFinite(value) && ok(value) ? null : `${LOD[kind].label}: ${rule}`;
}

/**
 * The state an address (`location.search`) states, and what in it was
 * wrong (each replaced by its default).
 * @param {string} search
 */
export function readUrl(search) {
  const q = new URLSearchParams(search);
  /** @type {string[]} */
  const problems = [];
  const num = (/** @type {string} */ name, /** @type {(v: number) => boolean} */ ok, /** @type {string} */ rule) => {
    const t = q.get(name);
    if (t === null || t === '') return null;
    const v = Number(t);
    if (!Number.isFinite(v) || !ok(v)) { problems.push(`${name}=${t}: ${rule}`); return null; }
    return v;
  };
  /** @type {LodKind} */
  let lodKind = 'tau';
  let lodValue = LOD.tau.def;
  const lod = exactlyOneLod(q);
  if (lod && 'error' in lod) {
    problems.push(lod.error);
    // A bad value of the one named keeps its kind, at its default.
    if (lod.kind) { lodKind = lod.kind; lodValue = LOD[lod.kind].def; }
  } else if (lod) {
    ({ kind: lodKind, value: lodValue } = lod);
  }
  const bits = num('bits', (v) => Number.isInteger(v) && v >= 0 && v <= 16, 'a whole number 0..16');
  const cosK = num('cos_k', (v) => v >= 0, 'an exponent >= 0');
  const fill = num('fill', (v) => Number.isInteger(v) && v >= 0 && v <= 2, 'seam width to fill, 0..2 pixels');
  const w = num('w', (v) => Number.isInteger(v) && v >= 1 && v <= 8192, 'canvas width in pixels, 1..8192');
  const h = num('h', (v) => Number.isInteger(v) && v >= 1 && v <= 8192, 'canvas height in pixels, 1..8192');
  let mode = /** @type {Mode} */ (q.get('mode') || 'blend');
  if (!MODES.includes(mode)) { problems.push(`mode=${mode}: use blend, coverage or wireframe`); mode = 'blend'; }
  /** @type {Light | null} */
  let light = null;
  const relight = q.get('relight');
  if (relight !== null && relight !== '' && relight !== '0' && relight !== 'false') {
    const parts = relight.split(',').map(Number);
    if (relight === '1' || relight === 'true') light = DEFAULT_LIGHT;
    else if (parts.length === 3 && parts.every(Number.isFinite) && Math.hypot(...parts) > 0) light = /** @type {Light} */ (parts);
    else problems.push(`relight=${relight}: use 1 or a direction x,y,z`);
  }
  /** @type {CameraJson | null} */
  let camera = null;
  const cam = q.get('camera');
  if (cam) {
    try {
      camera = checkCamera(JSON.parse(cam));
    } catch (e) {
      problems.push(`camera: ${e instanceof SyntaxError ? 'not JSON' : /** @type {Error} */ (e).message}`);
    }
  }
  const choice = /** @template {string} T @param {string} name @param {T[]} allowed @param {string} rule @returns {T} */ (name, allowed, rule) => {
    const t = /** @type {T} */ (q.get(name) ?? allowed[0]);
    if (allowed.includes(t)) return t;
    problems.push(`${name}=${t}: ${rule}`);
    return allowed[0];
  };
  const policy = choice('policy', ['render', 'balanced'], 'use render or balanced');
  // Meshes travel in the compact stream (protocol 7) unless the address asks for protocol 5.
  const wire = choice('wire', ['compact', 'bincode'], 'use compact or bincode');
  const follow = choice('follow', ['1', '0'], 'use 1 (follow live views, the default) or 0') !== '0';
  const ui = choice('ui', ['1', '0'], 'use 0 (no panel) or 1') !== '0';
  return { scene: q.get('scene'), camera, lodKind, lodValue, bits, cosK, light, mode, w, h, fill: fill ?? 2, policy, wire, follow, ui, problems };
}

/** The page's state, as the address keeps it. @typedef {{
 *   scene: string | null, lodKind: LodKind, lodValue: number, bits: number | null, cosK: number | null,
 *   light: Light | null, mode: Mode, w: number | null, h: number | null, fill: number,
 *   intrinsics: CameraJson | null, policy: 'render' | 'balanced', wire: 'compact' | 'bincode', follow: boolean,
 * }} State */

/**
 * The address of `state` seen from `camera` (defaults left out), the
 * inverse of [`readUrl`].
 * @param {State} state @param {CameraJson | null} camera @param {boolean} ui
 */
export function urlQuery(state, camera, ui) {
  const q = new URLSearchParams();
  if (state.scene) q.set('scene', state.scene);
  if (camera) q.set('camera', JSON.stringify(camera));
  q.set(state.lodKind, String(state.lodValue));
  if (state.bits !== null) q.set('bits', String(state.bits));
  if (state.cosK !== null) q.set('cos_k', String(state.cosK));
  if (state.light) q.set('relight', state.light.map((v) => +v.toFixed(4)).join(','));
  if (state.mode !== 'blend') q.set('mode', state.mode);
  if (state.fill !== 2) q.set('fill', String(state.fill));
  if (state.w !== null) q.set('w', String(state.w));
  if (state.h !== null) q.set('h', String(state.h));
  if (state.policy !== 'render') q.set('policy', state.policy);
  if (state.wire !== 'compact') q.set('wire', state.wire);
  if (!state.follow) q.set('follow', '0');
  if (!ui) q.set('ui', '0');
  return q.toString();
}
