// The browser's walkthrough policy (src/walkthrough.js) against the same
// cases as the Rust policy's tests, and its selection against the server's.
import test from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { covers, errorFactor, plan, selectViews, widened } from '../src/walkthrough.js';
import { lookAlong } from '../src/camera.js';

/** @param {number[]} eye @param {number[]} [forward] */
function cam(eye, forward = [0, 0, 1]) {
  return {
    width: 64, height: 48,
    projection: { perspective: { fx: 50, fy: 50, cx: 31.5, cy: 23.5 } },
    pose: { rotation: lookAlong(/** @type {any} */ (forward)), translation: eye },
  };
}

test('the error factor grows with the eye move and ends at the clearance', () => {
  const reach = { view: cam([0, 0, 0]), clearance: 2, culled: [] };
  assert.equal(errorFactor(reach, cam([0, 0, 0])), 1);
  assert.equal(errorFactor(reach, cam([1, 0, 0])), 2);
  assert.equal(errorFactor(reach, cam([0, 2, 0])), null);
  assert.equal(errorFactor({ ...reach, clearance: null }, cam([9, 9, 9])), 0);
});

test('a culled sphere in view is not covered, one behind is', () => {
  const reach = { view: cam([0, 0, 0]), clearance: null, culled: [[0, 0, -5, 1]] };
  assert.ok(covers(reach, cam([0, 0, 0])));
  reach.culled.push([0, 0, 5, 1]);
  assert.ok(!covers(reach, cam([0, 0, 0])));
  assert.ok(covers(reach, cam([0, 0, 0], [1, 0, 0])), "looking sideways, neither is in view");
  // A guard band: the widened camera sees a sphere just outside the frame.
  const edge = { view: cam([0, 0, 0]), clearance: null, culled: [[4.2, 0, 5, 0.1]] };
  assert.ok(covers(edge, cam([0, 0, 0])));
  assert.ok(!covers(edge, widened(cam([0, 0, 0]), 0.25)));
});

test('holes come first and apart; the refresh takes the oldest while they fit', () => {
  const held = (/** @type {number} */ age, /** @type {number} */ t) => ({ age, tau: 1, triangles: t, reach: { view: cam([0, 0, 0]), clearance: 10, culled: [] } });
  const p = plan({ camera: cam([0, 0, 0]), selected: [0, 1, 2, 3], held: [held(3, 100), held(7, 100), held(5, 100), null], tau: 1, staleFactor: 1.5, budget: 250 });
  assert.deepEqual(p.holes, [[3, 'missing']]);
  assert.deepEqual(p.refresh, [1]);
  assert.ok(p.plannedHoles + p.plannedRefresh <= p.budget);
  // Moved past the stale factor: every held mesh is a hole.
  const q = plan({ camera: cam([6, 0, 0]), selected: [0, 1], held: [held(1, 10), held(1, 10)], tau: 1, staleFactor: 1.5, budget: null });
  assert.deepEqual(q.holes, [[0, 'stale'], [1, 'stale']]);
  assert.deepEqual(q.refresh, []);
});

test('an over-age mesh is refreshed first, past the budget if need be; without the cap it waits', () => {
  const held = (/** @type {number} */ age, /** @type {number} */ t) => ({ age, tau: 1, triangles: t, reach: { view: cam([0, 0, 0]), clearance: 10, culled: [] } });
  const o = { camera: cam([0, 0, 0]), selected: [0, 1], held: [held(11, 300), held(5, 100)], tau: 1, staleFactor: 1.5, budget: 250 };
  assert.deepEqual(plan(o).refresh, [0]);
  assert.deepEqual(plan({ ...o, maxAge: null }).refresh, []);
  assert.deepEqual(plan({ ...o, held: [held(10, 300), held(5, 100)] }).refresh, []);
});

test('selection keeps views within 135 degrees, heaviest first, weights summing to 1', () => {
  const refs = [cam([0, 0, 0]), cam([1, 0, 0], [0.5, 0, 0.866]), cam([1, 0, 0], [0.985, 0, -0.174]), cam([0, 0, 0], [0, 0, -1])];
  const sel = selectViews(cam([0.2, 0, 0], [0.174, 0, 0.985]), refs, 5);
  assert.equal(sel[0].index, 0);
  assert.ok(sel.every((s) => s.index !== 3));
  assert.equal(sel.length, 3);
  assert.ok(Math.abs(sel.reduce((s, w) => s + w.weight, 0) - 1) < 1e-12);
});

test('selection gives the engine\'s weights on the shared cases (selection-cases.json)', () => {
  const { refs, cases } = JSON.parse(fs.readFileSync(new URL('./selection-cases.json', import.meta.url), 'utf8'));
  assert.ok(cases.length >= 40);
  for (const c of cases) {
    const got = selectViews(c.novel, refs, c.max_views, c.max_angle_deg);
    assert.deepEqual(got.map((w) => w.index), c.weights.map((/** @type {number[]} */ w) => w[0]), JSON.stringify(c.novel.pose));
    got.forEach((w, k) => assert.ok(Math.abs(w.weight - c.weights[k][1]) <= 1e-12, `${w.weight} against ${c.weights[k][1]}`));
  }
});

test('a view leaves the selection with weight 0: no step of an orbit moves more than 0.005 of the weight', () => {
  const { refs } = JSON.parse(fs.readFileSync(new URL('./selection-cases.json', import.meta.url), 'utf8'));
  const weights = (/** @type {any} */ novel) => {
    const w = new Array(refs.length).fill(0);
    for (const s of selectViews(novel, refs)) w[s.index] = s.weight;
    return w;
  };
  /** @type {number[] | null} */
  let previous = null;
  let worst = 0;
  for (let k = 0; k <= 3600; k++) {
    const a = (2 * Math.PI * k) / 3600;
    const eye = [3.3 * Math.sin(a), 1.8, 3.3 * Math.cos(a)];
    const w = weights(cam(eye, [0 - eye[0], 0.4 - eye[1], 0 - eye[2]].map((v, _, all) => v / Math.hypot(...all))));
    if (previous) { const p = previous; worst = Math.max(worst, 0.5 * w.reduce((s, x, i) => s + Math.abs(x - p[i]), 0)); }
    previous = w;
  }
  assert.ok(worst <= 0.005, `a 0.1 degree step moves ${worst} of the weight`);
});
