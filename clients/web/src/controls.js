// Orbit and fly navigation with mouse, touch and keyboard. The pose is kept
// as an eye, a heading (yaw, pitch; world y up) and a distance to the point
// looked at: orbit turns the eye around that point, fly turns the view
// around the eye and moves both.

import { add, cross, forwardOf, length, lookAlong, normalize, scale, sub } from './camera.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {import('./camera.js').Vec3} Vec3 */

const KEYS = new Set(['w', 'a', 's', 'd', 'q', 'e', 'arrowup', 'arrowdown', 'arrowleft', 'arrowright']);

export class Navigator {
  /**
   * @param {HTMLElement} element  receives the pointer and key events
   * @param {() => void} changed   called whenever the pose moves
   */
  constructor(element, changed) {
    this.element = element;
    this.changed = changed;
    /** @type {'orbit' | 'fly'} */
    this.mode = 'orbit';
    this.eye = /** @type {Vec3} */ ([0, 0, 0]);
    this.yaw = 0;
    this.pitch = 0;
    this.distance = 1;
    /** @type {number[] | null} the exact rotation of a camera set from outside, until the user moves */
    this.rotation = null;
    /** @type {Set<string>} */
    this.keys = new Set();
    /** @type {Map<number, {x: number, y: number}>} */
    this.pointers = new Map();
    this.lastTick = 0;
    this.running = false;
    this.listen();
  }

  /** Takes a camera's pose and the distance to the point it looks at.
   * @param {CameraJson} camera @param {number} distance */
  set(camera, distance) {
    const f = forwardOf(camera);
    this.eye = /** @type {Vec3} */ ([...camera.pose.translation]);
    this.yaw = Math.atan2(f[0], f[2]);
    this.pitch = Math.asin(Math.max(-1, Math.min(1, -f[1])));
    this.distance = Math.max(distance, 1e-3);
    this.rotation = [...camera.pose.rotation];
  }

  /** @returns {Vec3} */
  forward() {
    const c = Math.cos(this.pitch);
    return [c * Math.sin(this.yaw), -Math.sin(this.pitch), c * Math.cos(this.yaw)];
  }

  /** @returns {Vec3} */
  target() { return add(this.eye, scale(this.forward(), this.distance)); }

  /** The pose: rotation (quaternion) and translation. */
  pose() {
    return { rotation: this.rotation || lookAlong(this.forward()), translation: [...this.eye] };
  }

  /** Turns by screen pixels. @param {number} dx @param {number} dy */
  turn(dx, dy) {
    const target = this.target();
    this.yaw += dx * 0.005;
    this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch - dy * 0.005));
    if (this.mode === 'orbit') this.eye = sub(target, scale(this.forward(), this.distance));
    this.moved();
  }

  /** Moves eye and target in the camera's frame. @param {number} right @param {number} up @param {number} ahead */
  move(right, up, ahead) {
    const f = this.forward();
    const r = normalize(cross([0, 1, 0], f));
    const step = this.distance;
    this.eye = add(this.eye, add(scale(r, -right * step), add(scale([0, 1, 0], up * step), scale(f, ahead * step))));
    this.moved();
  }

  /** Zooms (orbit: distance to the target; fly: a step forward). @param {number} factor */
  zoom(factor) {
    if (this.mode === 'orbit') {
      const target = this.target();
      this.distance = Math.max(1e-2, this.distance * factor);
      this.eye = sub(target, scale(this.forward(), this.distance));
    } else {
      this.eye = add(this.eye, scale(this.forward(), this.distance * (1 - factor)));
    }
    this.moved();
  }

  moved() {
    this.rotation = null;
    this.changed();
  }

  listen() {
    const el = this.element;
    el.addEventListener('pointerdown', (e) => {
      el.setPointerCapture(e.pointerId);
      this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
      el.focus();
    });
    el.addEventListener('pointermove', (e) => {
      const p = this.pointers.get(e.pointerId);
      if (!p) return;
      const dx = e.clientX - p.x;
      const dy = e.clientY - p.y;
      if (this.pointers.size === 2) {
        const [a, b] = [...this.pointers.values()];
        const before = Math.hypot(a.x - b.x, a.y - b.y);
        p.x = e.clientX; p.y = e.clientY;
        const after = Math.hypot(a.x - b.x, a.y - b.y);
        if (before > 0 && after > 0) this.zoom(before / after);
        return;
      }
      p.x = e.clientX; p.y = e.clientY;
      const pan = e.shiftKey || e.buttons === 2 || e.buttons === 4;
      if (pan) {
        const k = 1 / Math.max(el.clientHeight, 1);
        this.move(-dx * k, dy * k, 0);
      } else {
        this.turn(dx, dy);
      }
    });
    const up = (/** @type {PointerEvent} */ e) => this.pointers.delete(e.pointerId);
    el.addEventListener('pointerup', up);
    el.addEventListener('pointercancel', up);
    el.addEventListener('contextmenu', (e) => e.preventDefault());
    el.addEventListener('wheel', (e) => {
      e.preventDefault();
      this.zoom(Math.exp(e.deltaY * 0.001));
    }, { passive: false });
    el.addEventListener('keydown', (e) => {
      const k = e.key.toLowerCase();
      if (KEYS.has(k)) {
        e.preventDefault();
        this.keys.add(k);
        if (!this.running) { this.running = true; this.tick(); }
      }
    });
    el.addEventListener('keyup', (e) => this.keys.delete(e.key.toLowerCase()));
    el.addEventListener('blur', () => this.keys.clear());
  }

  /** Applies held keys, once per animation frame while any is down. */
  tick() {
    if (this.keys.size === 0) { this.lastTick = 0; this.running = false; return; }
    const now = performance.now();
    const dt = this.lastTick ? Math.min((now - this.lastTick) / 1000, 0.1) : 1 / 60;
    this.lastTick = now;
    const held = (/** @type {string} */ k) => (this.keys.has(k) ? 1 : 0);
    const speed = 0.5 * dt;
    const turn = 300 * dt;
    if (this.mode === 'fly') {
      this.move((held('d') - held('a')) * speed, (held('e') - held('q')) * speed, (held('w') - held('s')) * speed);
      this.turn((held('arrowright') - held('arrowleft')) * turn, (held('arrowdown') - held('arrowup')) * turn);
    } else {
      this.turn((held('d') + held('arrowright') - held('a') - held('arrowleft')) * turn,
        (held('s') + held('arrowdown') - held('w') - held('arrowup')) * turn);
      const z = held('q') - held('e');
      if (z) this.zoom(Math.exp(z * dt));
    }
    requestAnimationFrame(() => this.tick());
  }
}

/** Distance from a camera to the point `target`. @param {CameraJson} c @param {Vec3} target */
export const distanceTo = (c, target) => length(sub(target, /** @type {Vec3} */ (c.pose.translation)));
