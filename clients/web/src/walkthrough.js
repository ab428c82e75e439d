// Walking through a scene with stable frame costs in the browser: the
// policy of clients/src/walkthrough/policy.rs (Qu, Wan, Qin and Kaufman,
// "Image based rendering with stable frame rates", Sec. 3.1-3.4), with the
// view selection of the server (DMesh Sec. 6.2, engine/src/scene/selection.rs).
// Held meshes are drawn every animation frame; a frame fetches its holes
// (views selected and not held, held meshes whose stated reach no longer
// serves the camera: PROTOCOL.md, "Reach") and then refreshes the oldest held
// meshes while their planned cost fits what the budget leaves. Pure
// functions over camera JSON, so they run in Node's tests as they are.

import { dot, forwardOf, length, quatToMat, sub } from './camera.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {import('./protocol.js').Reach} Reach */
/** @typedef {{age: number, tau: number, reach: Reach | null, triangles: number}} Held */
/** @typedef {'missing' | 'stale' | 'uncovered'} Hole */

/**
 * The server's selection (engine/src/scene/selection.rs): every reference
 * scores its angular term (1 up to a third of the angle limit, then a cosine
 * falling to 0 at the limit: 135 degrees for DMesh, 40 for the limited set)
 * times its positional term (1 / (1 + d / mean d over all references)); as
 * in Unstructured Lumigraph Rendering, a view's weight is its score less
 * the score of the first view left out (the (k + 1)-th best), normalised.
 * So weights are continuous in the camera: a view leaves with weight 0.
 * @param {CameraJson} novel @param {CameraJson[]} refs @returns {{index: number, weight: number}[]}
 */
export function selectViews(novel, refs, maxViews = 5, maxAngleDeg = 135) {
  const n = forwardOf(novel);
  const eye = /** @type {[number, number, number]} */ (novel.pose.translation);
  const k = Math.max(1, maxViews);
  const d = refs.map((r) => length(sub(/** @type {[number, number, number]} */ (r.pose.translation), eye)));
  const mean = refs.length ? d.reduce((s, x) => s + x, 0) / refs.length : 0;
  const flat = maxAngleDeg / 3;
  const g = refs.map((r, i) => {
    const beta = (Math.acos(Math.max(-1, Math.min(1, dot(forwardOf(r), n)))) * 180) / Math.PI;
    const angular = beta <= flat ? 1 : beta < maxAngleDeg ? Math.max(0, Math.cos(((beta - flat) / (maxAngleDeg - flat)) * (Math.PI / 2))) : 0;
    const positional = mean > 0 ? 1 / (1 + d[i] / mean) : 1;
    const score = angular * positional;
    return Number.isFinite(score) ? score : 0;
  });
  const t = [...g].sort((a, b) => b - a)[k] ?? 0;
  let weighted = g.map((s, index) => ({ index, weight: s - t })).filter((w) => g[w.index] > t);
  if (!weighted.length) {
    // The best views tie with the cut: share among the tied best.
    const best = Math.max(0, ...g);
    if (best <= 0) return [];
    weighted = g.map((s, index) => ({ index, weight: 1, s })).filter((w) => w.s === best).slice(0, k).map(({ index, weight }) => ({ index, weight }));
  }
  weighted.sort((a, b) => b.weight - a.weight || a.index - b.index);
  // A view with a negligible share is not worth its mesh (the engine's MIN_SHARE).
  const all = weighted.reduce((s, w) => s + w.weight, 0);
  weighted = weighted.filter((w) => w.weight >= MIN_SHARE * all);
  const total = weighted.reduce((s, w) => s + w.weight, 0);
  return weighted.map((w) => ({ index: w.index, weight: w.weight / total }));
}

/** The smallest share of the total weight a selected view carries (as the engine's). */
export const MIN_SHARE = 1e-4;

/** @param {CameraJson} c */
const focal = (c) => (c.projection.perspective ? Math.max(c.projection.perspective.fx, c.projection.perspective.fy) : null);

/** A bound on a held mesh's error in `cam` as a multiple of its tolerance, or null (unbounded).
 * @param {Reach} reach @param {CameraJson} cam @returns {number | null} */
export function errorFactor(reach, cam) {
  const [f0, f1] = [focal(reach.view), focal(cam)];
  if (f0 !== null && f1 !== null) {
    if (reach.clearance === null) return 0;
    const d = length(sub(/** @type {[number, number, number]} */ (cam.pose.translation), /** @type {[number, number, number]} */ (reach.view.pose.translation)));
    const factor = ((f1 / f0) * reach.clearance) / (reach.clearance - d);
    return d < reach.clearance && Number.isFinite(factor) ? factor : null;
  }
  const [a, b] = [reach.view.projection.orthographic, cam.projection.orthographic];
  if (!a || !b) return null;
  // The orthographic test does not depend on the eye: only the pixel sizes count.
  return Math.min(a.sx, a.sy) / Math.min(b.sx, b.sy);
}

/** The camera's frustum planes in the world, `[nx, ny, nz, d]`: inside when n . p + d >= 0
 * (the server's planes, engine/src/mesh/select.rs). @param {CameraJson} cam */
export function frustumPlanes(cam) {
  const { width: w, height: h } = cam;
  /** @type {number[][]} */
  let local;
  const unit = (/** @type {number[]} */ n) => { const l = Math.hypot(n[0], n[1], n[2]); return [n[0] / l, n[1] / l, n[2] / l, 0]; };
  const p = cam.projection.perspective;
  if (p) {
    const [l, r] = [(-0.5 - p.cx) / p.fx, (w - 0.5 - p.cx) / p.fx];
    const [t, b] = [(-0.5 - p.cy) / p.fy, (h - 0.5 - p.cy) / p.fy];
    local = [unit([1, 0, -l]), unit([-1, 0, r]), unit([0, 1, -t]), unit([0, -1, b]), [0, 0, 1, 0]];
  } else {
    const o = /** @type {{sx: number, sy: number, cx: number, cy: number}} */ (cam.projection.orthographic);
    const [l, r] = [(-0.5 - o.cx) * o.sx, (w - 0.5 - o.cx) * o.sx];
    const [t, b] = [(-0.5 - o.cy) * o.sy, (h - 0.5 - o.cy) * o.sy];
    local = [[1, 0, 0, -l], [-1, 0, 0, r], [0, 1, 0, -t], [0, -1, 0, b], [0, 0, 1, 0]];
  }
  const m = quatToMat(cam.pose.rotation);
  const e = cam.pose.translation;
  // n_c . R^T (p - e) + d = (R n_c) . p + (d - (R n_c) . e)
  return local.map(([x, y, z, d]) => {
    const n = [m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z, m[6] * x + m[7] * y + m[8] * z];
    return [n[0], n[1], n[2], d - (n[0] * e[0] + n[1] * e[1] + n[2] * e[2])];
  });
}

/** True when `cam` sees nothing the held mesh culled. @param {Reach} reach @param {CameraJson} cam */
export function covers(reach, cam) {
  if (!reach.culled.length) return true;
  const planes = frustumPlanes(cam);
  return reach.culled.every(([x, y, z, r]) => planes.some(([a, b, c, d]) => a * x + b * y + c * z + d < -r));
}

/** `cam` wider by `guard` of its size on each side, same focal length (what the browser requests).
 * @param {CameraJson} cam @param {number} guard @returns {CameraJson} */
export function widened(cam, guard) {
  const [gw, gh] = [Math.round(cam.width * guard), Math.round(cam.height * guard)];
  const p = cam.projection.perspective;
  const o = cam.projection.orthographic;
  const projection = p
    ? { perspective: { ...p, cx: p.cx + gw, cy: p.cy + gh } }
    : { orthographic: { .../** @type {{sx: number, sy: number, cx: number, cy: number}} */ (o), cx: /** @type {any} */ (o).cx + gw, cy: /** @type {any} */ (o).cy + gh } };
  return { ...cam, width: cam.width + 2 * gw, height: cam.height + 2 * gh, projection };
}

/**
 * Why a held mesh cannot serve `cam` (null when it can).
 * @param {Held | null} held @param {CameraJson} cam @param {number} tau @param {number} staleFactor
 * @returns {Hole | null}
 */
export function hole(held, cam, tau, staleFactor) {
  if (!held) return 'missing';
  if (!held.reach) return null;
  const f = errorFactor(held.reach, cam);
  if (f === null || f * held.tau > staleFactor * tau) return 'stale';
  return covers(held.reach, cam) ? null : 'uncovered';
}

/** Rounds a held mesh may age before it is refreshed first (Qu et al.'s threshold). */
export const MAX_AGE = 10;

/**
 * The fetches of one frame of the balanced strategy: holes, then the oldest
 * held meshes while their triangles fit what `budget` leaves (a missing
 * view planned at the mean held cost). `budget` null: one view's worth, the
 * largest selected held mesh. A held mesh older than `maxAge` rounds (Qu et
 * al.'s age threshold; null: no cap) is over age: the oldest of them is
 * refreshed even when it does not fit, so nothing is held forever (the CPU
 * client's policy.rs does the same).
 * @param {{camera: CameraJson, selected: number[], held: (Held | null)[], tau: number, staleFactor: number, budget: number | null, maxAge?: number | null}} o
 */
export function plan(o) {
  /** @type {[number, Hole][]} */
  const holes = [];
  const kept = [];
  for (const v of o.selected) {
    const why = hole(o.held[v], o.camera, o.tau, o.staleFactor);
    if (why) holes.push([v, why]);
    else kept.push(v);
  }
  const known = o.selected.map((v) => o.held[v]).filter((h) => h).map((h) => /** @type {Held} */ (h).triangles);
  const mean = known.length ? known.reduce((s, t) => s + t, 0) / known.length : 0;
  const budget = o.budget ?? known.reduce((a, b) => Math.max(a, b), 0);
  const plannedHoles = holes.reduce((s, [v]) => s + (o.held[v]?.triangles ?? mean), 0);
  let left = budget - plannedHoles;
  let plannedRefresh = 0;
  const refresh = [];
  kept.sort((a, b) => /** @type {Held} */ (o.held[b]).age - /** @type {Held} */ (o.held[a]).age || a - b);
  const maxAge = o.maxAge === undefined ? MAX_AGE : o.maxAge;
  for (const v of kept) {
    const h = /** @type {Held} */ (o.held[v]);
    const overAge = maxAge !== null && h.age > maxAge && refresh.length === 0;
    if (h.age <= 0 || (h.triangles > left && !overAge)) break;
    left -= h.triangles;
    plannedRefresh += h.triangles;
    refresh.push(v);
  }
  return { holes, refresh, budget, plannedHoles, plannedRefresh };
}
