// The update rounds: what the page asks the server for as the camera moves.
// At most one round of requests is in flight: while it runs, camera moves
// only mark the state stale (`wanted` runs ahead of `sent`), and the latest
// camera goes out when it returns. With `policy=render` a round is one
// /render request for the camera; with `policy=balanced` (walkthrough.js,
// Qu et al.'s workload balancing) it is the strips of the frame's holes plus
// the oldest held meshes that fit one view's worth of triangles.
// A render answer drawn from live frames (`PUT ...?live=true`) says so in
// its `Dmesh-Frame-Age` header; the rounds then keep asking (`follow=0`
// stops it), so the picture follows the live view.

import { MESH } from './compact.js';
import { BINCODE } from './protocol.js';
import { HttpError, acceptMeshes, answerFormat, retryAfter, serverMessage, serverTiming, sleep } from './net.js';
import { plan, selectViews, widened } from './walkthrough.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {{view: string, camera: CameraJson, color_url: string}} Reference */
/** @typedef {{strips: any, lines: Uint32Array | null, age: number, tau: number, color_url: string}} Held */

/** Milliseconds between the answer of a new live frame and the next request. */
const FOLLOW_MS = 30;
/** The same, when the answer showed the frame already drawn: the view has not moved on. */
const FOLLOW_IDLE_MS = 200;
/** The balanced policy's widening of the requesting camera (walkthrough.js). */
const GUARD = 0.15;
/** A held mesh whose error factor passes this is refreshed. */
const STALE_FACTOR = 1.5;
/** Requests a round sends at once: the server reads as many as its cores at a time. */
const ROUND_CONCURRENCY = 2;

/**
 * What the rounds need of the page.
 * @typedef {{
 *   state: import('./url.js').State,
 *   stats: any,
 *   renderer: import('./renderer.js').Renderer,
 *   server: import('./net.js').Server,
 *   textures: import('./net.js').Textures,
 *   decoder: import('./net.js').Decoder,
 *   camera: () => CameraJson,
 *   draw: (sync?: boolean) => boolean,
 *   say: (text: string | null, kind?: 'error' | 'info') => void,
 *   overlay: () => void,
 * }} Page
 */

export class Rounds {
  /** @param {Page} page */
  constructor(page) {
    this.page = page;
    /** Generation of the state the page shows. */
    this.wanted = 0;
    /** Generation of the last request sent. */
    this.sent = 0;
    this.inFlight = false;
    this.firstDrawn = false;
    /** No request before the scene's cameras have placed the navigator. */
    this.sceneLoaded = false;
    this.followTimer = 0;
    /** When the last live frame drawn became visible, on the page's clock. */
    this.lastFrameAt = -Infinity;
    /** The scene's reference views. @type {Reference[]} */
    this.refs = [];
    /** Held meshes by view id, with their age in rounds since fetched. @type {Map<string, Held>} */
    this.held = new Map();
    /** Per view id, the compact mesh the worker keeps: its ETag and
     * requesting camera, which a refresh names to get only the change from
     * it. @type {Map<string, {etag: string, camera: CameraJson}>} */
    this.compactHeld = new Map();
  }

  /** True when the picture is the answer for the current state and nothing is in flight. */
  idle() {
    return !this.inFlight && this.sent === this.wanted && this.firstDrawn;
  }

  /** A new scene's references: nothing held, no request until `ready`. @param {Reference[]} refs */
  setScene(refs) {
    this.sceneLoaded = false;
    this.refs = refs;
    this.held.clear();
    this.page.renderer.setViews([]);
  }

  /** The state moved: the next round asks for it. */
  stale() {
    this.wanted++;
    this.pump();
  }

  /** Before a frame from `cam`: the balanced policy's held meshes as `cam` selects them. @param {CameraJson} cam */
  beforeDraw(cam) {
    if (this.page.state.policy === 'balanced' && this.held.size) this.syncHeld(cam);
  }

  /** @param {CameraJson} cam */
  requestBody(cam) {
    const { state } = this.page;
    /** @type {Record<string, unknown>} */
    const body = { camera: cam, lod: { [state.lodKind]: state.lodValue } };
    if (state.bits !== null) body.bits = state.bits;
    return body;
  }

  /** Sends the latest state when nothing is in flight and it is stale. */
  async pump() {
    const { state, stats, say } = this.page;
    if (this.inFlight || this.sent === this.wanted || !this.sceneLoaded || !state.scene || !state.intrinsics) return;
    this.inFlight = true;
    try {
      await (state.policy === 'balanced' ? this.balancedRound() : this.renderRound());
    } catch (e) {
      /** @type {string} */
      let text;
      if (e instanceof HttpError && e.status === 404) {
        text = `Scene "${state.scene}" is not on this server: ${e.message}. Pick one of the scenes above.`;
      } else if (e instanceof HttpError) {
        text = `The server refused the request (${e.status}): ${e.message}`;
      } else if (e instanceof TypeError) {
        text = `Cannot reach the dmesh server at ${location.origin} (${e.message}). Is \`dmesh serve\` still running? Retrying…`;
      } else {
        text = /** @type {Error} */ (e).message || String(e);
      }
      say(text);
      stats.error = text;
      if (e instanceof TypeError) {
        await sleep(2000);
        this.sent = -1; // try again with the latest state
      }
    } finally {
      this.inFlight = false;
      if (this.sent !== this.wanted) this.pump();
    }
  }

  /** `policy=render`: one /render request for the camera, until one answers the latest state. */
  async renderRound() {
    const { state, stats, renderer, textures, decoder, say } = this.page;
    for (;;) {
      const generation = this.wanted;
      this.sent = generation;
      const cam = this.page.camera();
      const t0 = performance.now();
      const path = `/v1/scenes/${encodeURIComponent(/** @type {string} */ (state.scene))}/render`;
      const r = await fetch(path, {
        method: 'POST',
        headers: { 'content-type': 'application/json', accept: acceptMeshes(state.wire) },
        body: JSON.stringify(this.requestBody(cam)),
      });
      if (r.status === 503) {
        const wait = retryAfter(r);
        stats.retries++;
        say(`The server is busy (503); trying again in ${wait} s.`, 'info');
        await sleep(wait * 1000);
        continue; // with the latest camera
      }
      if (!r.ok) throw new HttpError(r.status, await serverMessage(r));
      const timing = serverTiming(r.headers.get('server-timing'));
      const format = answerFormat(r);
      const body = await r.arrayBuffer();
      const bytes = body.byteLength;
      const entries = performance.getEntriesByName(new URL(path, location.href).href);
      const last = /** @type {PerformanceResourceTiming | undefined} */ (entries[entries.length - 1]);
      const age = r.headers.get('dmesh-frame-age');
      const live = age !== null && Number.isFinite(Number(age));
      const { response, lines, decodeMs } = await decoder.render(body, format, state.mode === 'wireframe', cam);
      if (response.views.length === 0) throw new Error('The server selected no reference view for this camera: turn towards the scene.');
      // A live view's colour may have changed with its frame: revalidate it.
      if (live) for (const v of response.views) textures.stale(v.color_url);
      for (const v of response.views) await textures.load(v.color_url);
      if (renderer.lost) return;
      renderer.setViews(response.views.map((v, k) => ({ ...v, lines: lines[k] })));
      const t1 = performance.now();
      const drawn = this.page.draw(true);
      const t2 = performance.now();
      const done = this.shown(generation, drawn, response.views, null, {
        bytes,
        transfer_bytes: last && last.encodedBodySize ? last.encodedBodySize : bytes,
        extract_ms: timing.extract ?? response.timings.extract_ms,
        server_ms: timing.total ?? response.timings.total_ms,
        decode_ms: decodeMs,
        draw_ms: drawn ? t2 - t1 : 0,
        frame_ms: t2 - t0,
        width: cam.width,
        height: cam.height,
        camera: cam,
        frame_age_ms: live ? Number(age) : null,
        live_frames: stats.live_frames + (live ? 1 : 0),
      });
      if (done) {
        if (live && state.follow) this.follow(performance.now() - Number(age));
        return;
      }
    }
  }

  /** Asks again soon: the live view has moved on, or will. @param {number} frameAt when the frame drawn became visible */
  follow(frameAt) {
    const same = Math.abs(frameAt - this.lastFrameAt) < 5;
    this.lastFrameAt = frameAt;
    if (!same) this.page.stats.live_new_frames++;
    clearTimeout(this.followTimer);
    this.followTimer = window.setTimeout(() => {
      if (this.page.state.follow) this.stale();
    }, same ? FOLLOW_IDLE_MS : FOLLOW_MS);
  }

  /**
   * Puts a round's figures on the page: the drawn `views` (with their ages
   * when `age` is given) and `figures`. True once the frame for the state
   * `generation` asked for is on screen.
   * @param {number} generation @param {boolean} drawn
   * @param {{weight: number, strips: any}[]} views @param {((view: string) => number) | null} age
   * @param {Record<string, unknown>} figures
   */
  shown(generation, drawn, views, age, figures) {
    const { state, stats } = this.page;
    this.page.say(null);
    stats.error = null;
    Object.assign(stats, {
      scene: state.scene,
      updates: stats.updates + 1,
      views: views.map((v) => ({
        view: v.strips.view,
        weight: v.weight,
        triangles: v.strips.drawnTriangles ?? v.strips.triangles,
        vertices: v.strips.vertexCount,
        lod: v.strips.lod,
        max_depth_error: v.strips.maxDepthError,
        ...(age ? { age: age(v.strips.view) } : {}),
      })),
      triangles: views.reduce((s, v) => s + (v.strips.drawnTriangles ?? v.strips.triangles), 0),
      vertices: views.reduce((s, v) => s + v.strips.vertexCount, 0),
      ...figures,
    });
    this.page.overlay();
    if (this.wanted !== generation) return false;
    if (!this.firstDrawn && drawn) {
      this.firstDrawn = true;
      Object.assign(window, { dmeshReady: true });
    }
    return true;
  }

  /** One view's mesh for `cam` (the page's wire), decoded in the worker; on
   * the compact wire, as the change from the mesh held for the view.
   * @param {number} v @param {CameraJson} cam */
  async fetchStrips(v, cam) {
    const { state, stats, server, decoder } = this.page;
    const ref = this.refs[v];
    const path = `/v1/scenes/${encodeURIComponent(/** @type {string} */ (state.scene))}/views/${encodeURIComponent(ref.view)}/strips`;
    const key = `${state.scene}/${ref.view}`;
    const body = this.requestBody(cam);
    const from = state.wire === 'compact' ? this.compactHeld.get(key) : undefined;
    if (from) { body.held = from.etag; body.held_camera = from.camera; }
    const r = await server.fetch(path, {
      method: 'POST',
      headers: { 'content-type': 'application/json', accept: state.wire === 'compact' ? MESH : BINCODE },
      body: JSON.stringify(body),
    }, Infinity);
    if (!r.ok) throw new HttpError(r.status, await serverMessage(r));
    const compact = answerFormat(r) === 'compact';
    const buffer = await r.arrayBuffer();
    const bytes = buffer.byteLength;
    const etag = r.headers.get('etag');
    this.compactHeld.delete(key);
    const { strips, lines, change } = await decoder.strips(buffer, compact, state.mode === 'wireframe', cam, { key, etag, held: from?.etag ?? null });
    if (compact && etag) this.compactHeld.set(key, { etag, camera: cam });
    // Meshes fetched again, and of those, how many came as the change from the held one.
    if (from) { stats.walk.refetched++; if (change) stats.walk.changes++; }
    return { v, strips, lines, bytes, extract: serverTiming(r.headers.get('server-timing')).extract ?? strips.extract_ms };
  }

  /** The selected held meshes for `cam`, weights renormalised over those held. @param {CameraJson} cam */
  heldSelection(cam) {
    const sel = selectViews(cam, this.refs.map((r) => r.camera));
    const have = sel.filter((s) => this.held.has(this.refs[s.index].view));
    const total = have.reduce((t, s) => t + s.weight, 0) || 1;
    return { sel, have: have.map((s) => ({ index: s.index, weight: s.weight / total })) };
  }

  /** Points the renderer at the held meshes `cam` selects: new buffers only when the set changed. @param {CameraJson} cam */
  syncHeld(cam) {
    const { renderer, stats } = this.page;
    if (renderer.lost) return;
    const { have } = this.heldSelection(cam);
    const heldOf = (/** @type {number} */ index) => /** @type {Held} */ (this.held.get(this.refs[index].view));
    const chosen = have.map((s) => heldOf(s.index));
    const same = renderer.views.length === chosen.length && renderer.views.every((v, k) => v.strips === chosen[k].strips);
    if (!same) {
      renderer.setViews(chosen.map((h, k) => ({ weight: have[k].weight, strips: h.strips, color_url: h.color_url, lines: h.lines })));
    } else {
      renderer.views.forEach((v, k) => { v.weight = have[k].weight; });
    }
    stats.ages = have.map((s) => ({ view: this.refs[s.index].view, age: heldOf(s.index).age }));
  }

  /** `policy=balanced`: the frame's holes, then the oldest held meshes that fit the budget. */
  async balancedRound() {
    const { state, stats, renderer, textures } = this.page;
    for (;;) {
      const generation = this.wanted;
      this.sent = generation;
      const cam = this.page.camera();
      const t0 = performance.now();
      for (const h of this.held.values()) h.age++;
      const { sel } = this.heldSelection(cam);
      if (sel.length === 0) throw new Error('No reference view looks this way: turn towards the scene.');
      const heldList = this.refs.map((r) => {
        const h = this.held.get(r.view);
        return h ? { age: h.age, tau: h.tau, reach: h.strips.reach, triangles: h.strips.drawnTriangles ?? h.strips.triangles } : null;
      });
      const tau = state.lodKind === 'tau' ? state.lodValue : 1;
      const p = plan({ camera: cam, selected: sel.map((s) => s.index), held: heldList, tau, staleFactor: STALE_FACTOR, budget: null });
      const asked = widened(cam, GUARD);
      const todo = [...p.holes.map((h) => h[0]), ...p.refresh];
      const got = [];
      for (let k = 0; k < todo.length; k += ROUND_CONCURRENCY) {
        got.push(...(await Promise.all(todo.slice(k, k + ROUND_CONCURRENCY).map((v) => this.fetchStrips(v, asked)))));
      }
      for (const g of got) {
        await textures.load(this.refs[g.v].color_url);
        const lod = g.strips.lod;
        this.held.set(this.refs[g.v].view, { strips: g.strips, lines: g.lines, age: 0, tau: lod.tau ?? tau, color_url: this.refs[g.v].color_url });
      }
      if (renderer.lost) return;
      const t1 = performance.now();
      this.syncHeld(this.page.camera());
      const drawn = this.page.draw(true);
      const t2 = performance.now();
      const count = (/** @type {string} */ why) => p.holes.filter((h) => h[1] === why).length;
      const bytes = got.reduce((s, g) => s + g.bytes, 0);
      const extract = got.reduce((s, g) => s + g.extract, 0);
      const done = this.shown(generation, drawn, renderer.views, (view) => /** @type {Held} */ (this.held.get(view)).age, {
        walk: {
          changes: stats.walk.changes, refetched: stats.walk.refetched,
          frame: stats.walk.frame + 1, holes: p.holes.length, missing: count('missing'), stale: count('stale'),
          uncovered: count('uncovered'), refreshed: p.refresh.length, budget: p.budget, planned: p.plannedHoles + p.plannedRefresh,
        },
        bytes,
        transfer_bytes: bytes,
        extract_ms: extract,
        server_ms: extract,
        draw_ms: drawn ? t2 - t1 : 0,
        frame_ms: t2 - t0,
        width: cam.width,
        height: cam.height,
        camera: cam,
      });
      if (done) return;
    }
  }
}
