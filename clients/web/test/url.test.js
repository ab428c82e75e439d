// The page's address (src/url.js), read and written without a browser.
import test from 'node:test';
import assert from 'node:assert/strict';
import { exactlyOneLod, lodProblem, readUrl, urlQuery } from '../src/url.js';

const q = (/** @type {string} */ s) => new URLSearchParams(s);

test('an address names exactly one level of detail, as the wire does', () => {
  assert.deepEqual(exactlyOneLod(q('epsilon=0.01')), { kind: 'epsilon', value: 0.01 });
  assert.deepEqual(exactlyOneLod(q('tau=1')), { kind: 'tau', value: 1 });
  assert.deepEqual(exactlyOneLod(q('max_triangles=7')), { kind: 'max_triangles', value: 7 });
  assert.deepEqual(exactlyOneLod(q('budget_ms=2')), { kind: 'budget_ms', value: 2 });
  assert.equal(exactlyOneLod(q('scene=demo')), null, 'none named: the page chooses its default');
  const two = exactlyOneLod(q('tau=1&epsilon=0.01'));
  assert.ok(two && 'error' in two && /exactly one/.test(two.error) && two.kind === null, JSON.stringify(two));
  for (const bad of ['tau=-1', 'epsilon=x', 'max_triangles=1.5', 'max_triangles=4294967296', 'budget_ms=0', 'tau=']) {
    const got = exactlyOneLod(q(bad));
    assert.ok(got && 'error' in got && got.kind === bad.split('=')[0], `${bad}: ${JSON.stringify(got)}`);
  }
  assert.equal(lodProblem('tau', 0), null);
  assert.match(/** @type {string} */ (lodProblem('budget_ms', 0)), /> 0/);
});

test('a bad address is reported value by value and each replaced by its default', () => {
  const url = readUrl('?scene=demo&tau=-1&mode=sideways&camera=%7Bnot-json&policy=x&wire=y&follow=2&ui=3&bits=17&fill=3');
  const said = url.problems.join('; ');
  for (const name of ['tau=-1', 'mode=sideways', 'camera: not JSON', 'policy=x', 'wire=y', 'follow=2', 'ui=3', 'bits=17', 'fill=3']) {
    assert.ok(said.includes(name), `${name} not reported in: ${said}`);
  }
  assert.equal(url.problems.length, 9);
  assert.deepEqual(
    [url.lodKind, url.lodValue, url.mode, url.camera, url.policy, url.wire, url.follow, url.ui, url.bits, url.fill],
    ['tau', 1, 'blend', null, 'render', 'compact', true, true, null, 2],
  );
  // A bad value of the one level named keeps its kind, at its default.
  const eps = readUrl('?epsilon=-3');
  assert.deepEqual([eps.lodKind, eps.lodValue, eps.problems.length], ['epsilon', 0.01, 1]);
  assert.deepEqual(readUrl('').problems, []);
});

test('what the page writes it reads back', () => {
  const camera = {
    width: 64, height: 48,
    projection: { perspective: { fx: 50, fy: 50, cx: 31.5, cy: 23.5 } },
    pose: { rotation: [0, 0, 0, 1], translation: [1, 2, 3] },
  };
  /** @type {import('../src/url.js').State} */
  const state = {
    scene: 'a b&c', lodKind: 'max_triangles', lodValue: 5000, bits: 6, cosK: 4, light: [0, 1, 0], mode: 'coverage',
    w: 320, h: 240, fill: 1, intrinsics: camera, policy: 'balanced', wire: 'bincode', follow: false,
  };
  const back = readUrl(`?${urlQuery(state, camera, false)}`);
  assert.deepEqual(back.problems, []);
  const { problems, camera: read, ui, ...rest } = back;
  assert.deepEqual(read, camera);
  assert.equal(ui, false);
  const { intrinsics, ...wanted } = state;
  assert.deepEqual(rest, wanted);
  // The defaults are left out of the address.
  const plain = urlQuery({ ...state, bits: null, cosK: null, light: null, mode: 'blend', w: null, h: null, fill: 2, policy: 'render', wire: 'compact', follow: true }, null, true);
  assert.equal(plain, 'scene=a+b%26c&max_triangles=5000');
});
