// The panel: the controls that change the page's state, the figures of the
// last round, and the panel's place. It collapses to a button (and the key
// h), starts collapsed in a narrow window, and sits beside the canvas when
// the window has room for both; `ui=0` hides it, for screenshots and
// embedding.

import { DEFAULT_LIGHT, LOD, lodProblem } from './url.js';

/** @typedef {import('./url.js').LodKind} LodKind */

/** Room the open panel takes on the left, CSS pixels (its width and margins; style.css). */
const PANEL_SPACE = 306;
/** The smallest canvas the panel makes room for beside it. */
const MIN_CANVAS = 320;
/** Below this window width the panel starts collapsed. */
const NARROW = 900;

const $ = (/** @type {string} */ id) => /** @type {HTMLElement} */ (document.getElementById(id));

/** Slider position 0..1000 of a value. @param {LodKind} k @param {number} v */
function toRange(k, v) {
  const d = LOD[k];
  const t = d.log ? Math.log(Math.max(v, d.min) / d.min) / Math.log(d.max / d.min) : (v - d.min) / (d.max - d.min);
  return Math.round(Math.max(0, Math.min(1, t)) * 1000);
}
/** The value at slider position `p`. @param {LodKind} k @param {number} p */
function fromRange(k, p) {
  const d = LOD[k];
  const t = p / 1000;
  const v = d.log ? d.min * (d.max / d.min) ** t : d.min + t * (d.max - d.min);
  return d.int ? Math.round(v) : +v.toPrecision(3);
}

const fmt = (/** @type {number} */ v, d = 1) => (Number.isFinite(v) ? v.toFixed(d) : '–');
const kb = (/** @type {number} */ b) => `${(b / 1024).toFixed(1)} kB`;
/** @param {string} s */
function escape(s) {
  return s.replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c] || c);
}

/**
 * What the panel needs of the page.
 * @typedef {{
 *   state: import('./url.js').State,
 *   ui: boolean,
 *   changed: () => void,
 *   policyChanged: () => void,
 *   navChanged: (mode: 'orbit' | 'fly') => void,
 *   load: () => void,
 *   say: (text: string | null, kind?: 'error' | 'info') => void,
 * }} Page
 */

export class Panel {
  /** @param {Page} page */
  constructor(page) {
    this.page = page;
    this.element = $('panel');
    this.toggle = /** @type {HTMLButtonElement} */ ($('panel-toggle'));
    this.scene = /** @type {HTMLSelectElement} */ ($('scene'));
    this.lodKind = /** @type {HTMLSelectElement} */ ($('lod-kind'));
    this.lodRange = /** @type {HTMLInputElement} */ ($('lod-range'));
    this.lodNumber = /** @type {HTMLInputElement} */ ($('lod-value'));
    this.bits = /** @type {HTMLInputElement} */ ($('bits'));
    this.bitsLabel = $('bits-label');
    this.mode = /** @type {HTMLSelectElement} */ ($('mode'));
    this.nav = /** @type {HTMLSelectElement} */ ($('nav'));
    this.policy = /** @type {HTMLSelectElement} */ ($('policy'));
    this.cosK = /** @type {HTMLInputElement} */ ($('cos-k'));
    this.relight = /** @type {HTMLInputElement} */ ($('relight'));
    this.lightAz = /** @type {HTMLInputElement} */ ($('light-az'));
    this.lightEl = /** @type {HTMLInputElement} */ ($('light-el'));
    this.placed();
    this.wired();
  }

  /** The panel's place: hidden with `ui=0`, collapsed in a narrow window. */
  placed() {
    this.element.hidden = !this.page.ui;
    this.open(this.page.ui && window.innerWidth >= NARROW);
    this.toggle.addEventListener('click', () => this.open(this.collapsed()));
    window.addEventListener('keydown', (e) => {
      const t = /** @type {HTMLElement} */ (e.target);
      if (e.key !== 'h' || e.ctrlKey || e.metaKey || e.altKey || ['INPUT', 'SELECT', 'TEXTAREA'].includes(t.tagName)) return;
      if (!this.element.hidden) this.open(this.collapsed());
    });
    window.addEventListener('resize', () => this.layout());
  }

  collapsed() {
    return this.element.classList.contains('collapsed');
  }

  /** Opens or collapses the panel. @param {boolean} open */
  open(open) {
    this.element.classList.toggle('collapsed', !open);
    this.toggle.setAttribute('aria-expanded', String(open));
    this.toggle.textContent = open ? 'hide' : 'panel';
    this.layout();
  }

  /** Puts the canvas beside the open panel when the window has room for both. */
  layout() {
    const open = !this.element.hidden && !this.collapsed();
    const room = window.innerWidth - PANEL_SPACE >= (this.page.state.w ?? MIN_CANVAS);
    document.body.classList.toggle('beside', open && room);
  }

  /** The controls show the state. */
  sync() {
    const { state } = this.page;
    this.lodKind.value = state.lodKind;
    this.lodRange.value = String(toRange(state.lodKind, state.lodValue));
    this.lodNumber.value = String(state.lodValue);
    this.bits.value = String(state.bits ?? -1);
    this.bitsLabel.textContent = state.bits === null ? 'exact' : `${state.bits} bits`;
    this.mode.value = state.mode;
    this.policy.value = state.policy;
    this.cosK.value = state.cosK === null ? '' : String(state.cosK);
    this.relight.checked = !!state.light;
    const l = state.light || DEFAULT_LIGHT;
    const n = Math.hypot(...l);
    this.lightAz.value = String(Math.round((Math.atan2(l[0], l[2]) * 180) / Math.PI));
    this.lightEl.value = String(Math.round((Math.asin(l[1] / n) * 180) / Math.PI));
    this.lightAz.disabled = this.lightEl.disabled = !state.light;
  }

  /** Each control changes the state and says so. */
  wired() {
    const { state, changed, say } = this.page;
    this.lodKind.addEventListener('change', () => {
      state.lodKind = /** @type {LodKind} */ (this.lodKind.value);
      state.lodValue = LOD[state.lodKind].def;
      this.sync();
      changed();
    });
    this.lodRange.addEventListener('input', () => {
      state.lodValue = fromRange(state.lodKind, Number(this.lodRange.value));
      this.lodNumber.value = String(state.lodValue);
      changed();
    });
    this.lodNumber.addEventListener('change', () => {
      const v = LOD[state.lodKind].int ? Math.round(Number(this.lodNumber.value)) : Number(this.lodNumber.value);
      const problem = lodProblem(state.lodKind, v);
      if (problem) { say(problem); return; }
      state.lodValue = v;
      this.sync();
      changed();
    });
    this.bits.addEventListener('input', () => {
      const b = Number(this.bits.value);
      state.bits = b < 0 ? null : b;
      this.bitsLabel.textContent = state.bits === null ? 'exact' : `${state.bits} bits`;
      changed();
    });
    this.mode.addEventListener('change', () => {
      state.mode = /** @type {'blend' | 'coverage' | 'wireframe'} */ (this.mode.value);
      changed();
    });
    this.policy.addEventListener('change', () => {
      state.policy = /** @type {'render' | 'balanced'} */ (this.policy.value);
      this.page.policyChanged();
    });
    this.nav.addEventListener('change', () => this.page.navChanged(/** @type {'orbit' | 'fly'} */ (this.nav.value)));
    this.cosK.addEventListener('change', () => {
      const v = this.cosK.value.trim() === '' ? null : Number(this.cosK.value);
      if (v !== null && !(Number.isFinite(v) && v >= 0)) { say('cos^k needs an exponent >= 0, or nothing'); return; }
      state.cosK = v;
      changed();
    });
    const lightChanged = () => {
      if (this.relight.checked) {
        const az = (Number(this.lightAz.value) * Math.PI) / 180;
        const el = (Number(this.lightEl.value) * Math.PI) / 180;
        state.light = [Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az)];
      } else {
        state.light = null;
      }
      this.lightAz.disabled = this.lightEl.disabled = !state.light;
      changed();
    };
    this.relight.addEventListener('change', lightChanged);
    this.lightAz.addEventListener('input', lightChanged);
    this.lightEl.addEventListener('input', lightChanged);
    this.scene.addEventListener('change', () => {
      state.scene = this.scene.value;
      state.intrinsics = null;
      this.page.load();
    });
    $('reset').addEventListener('click', () => {
      state.intrinsics = null;
      this.page.load();
    });
  }

  /** The scenes the server has, `current` selected (added as missing when it is not among them).
   * @param {string[]} scenes @param {string | null} current */
  scenes(scenes, current) {
    this.scene.replaceChildren(...scenes.map((s) => new Option(s, s)));
    if (current === null) return;
    if (!scenes.includes(current)) this.scene.add(new Option(`${current} (missing)`, current));
    this.scene.value = current;
  }

  /** The scenes listed. */
  knownScenes() {
    return [...this.scene.options].map((o) => o.value).filter(Boolean);
  }

  /** What the address held that was ignored. @param {string[]} problems */
  notice(problems) {
    if (!problems.length) return;
    const notice = $('notice');
    notice.textContent = `Ignored in the address: ${problems.join('; ')}.`;
    notice.hidden = false;
  }

  /** The figures of the last round (`window.dmeshStats`). @param {any} stats */
  overlay(stats) {
    const lod = (/** @type {any} */ l) => (l.tau !== undefined ? `tau ${fmt(l.tau, 2)} px` : `eps ${fmt(l.epsilon * 1000, 2)} mm`);
    const balanced = this.page.state.policy === 'balanced';
    const ages = new Map(stats.ages.map((/** @type {{view: string, age: number}} */ a) => [a.view, a.age]));
    const age = (/** @type {string} */ v) => (balanced ? `<td>${ages.get(v) ?? '–'}</td>` : '');
    const rows = stats.views.map((/** @type {any} */ v) => `<tr><td>${escape(v.view)}</td><td>${fmt(v.weight, 3)}</td><td>${v.triangles.toLocaleString()}</td><td>${lod(v.lod)}</td>${age(v.view)}</tr>`);
    const w = stats.walk;
    const walkRow = balanced
      ? `<tr><td>round ${w.frame}</td><td>${w.holes} holes (${w.missing} new, ${w.stale} stale, ${w.uncovered} uncovered), ${w.refreshed} refreshed within ${Math.round(w.budget).toLocaleString()} triangles</td></tr>`
      : '';
    $('stats').innerHTML = `
    <table class="views"><tr><th>view</th><th>weight</th><th>triangles</th><th>tolerance</th>${balanced ? '<th>age</th>' : ''}</tr>${rows.join('')}</table>
    <table class="figures">
      <tr><td>triangles</td><td>${stats.triangles.toLocaleString()}</td></tr>
      <tr><td>bytes</td><td>${kb(stats.bytes)} (${kb(stats.transfer_bytes)} sent)</td></tr>
      <tr><td>server extract</td><td>${fmt(stats.extract_ms, 2)} ms</td></tr>
      <tr><td>decode</td><td>${fmt(stats.decode_ms, 2)} ms</td></tr>
      <tr><td>draw</td><td>${fmt(stats.draw_ms, 2)} ms</td></tr>
      <tr><td>frame</td><td>${fmt(stats.frame_ms, 1)} ms</td></tr>
      ${stats.frame_age_ms !== null ? `<tr><td>live frame age</td><td>${fmt(stats.frame_age_ms, 0)} ms (${stats.live_frames} frames)</td></tr>` : ''}
      <tr><td>canvas</td><td>${stats.width} × ${stats.height} (dpr ${stats.dpr}, ${stats.accum_format})</td></tr>
      ${walkRow}
    </table>`;
  }
}
