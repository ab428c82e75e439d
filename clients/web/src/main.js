// The dmesh viewer: picks a scene, moves a camera through it, asks the
// server for the selected views' view-dependent strips (DMesh Sec. 6.2) and
// blends them on the GPU (renderer.js). The page state lives in the URL:
//   ?scene=ID&camera=<camera JSON>&tau=1 (or epsilon, max_triangles, budget_ms)
//   &bits=B&cos_k=K&relight=1|x,y,z&mode=blend|coverage|wireframe&fill=0..2&w=W&h=H
//   &policy=render|balanced&wire=compact|bincode&follow=0|1&ui=0
// The panel collapses to a button (and the key h), starts collapsed in a
// narrow window, and sits beside the canvas when the window has room for
// both; `ui=0` hides it, for screenshots and embedding.
// At most one round of requests is in flight: while it runs, camera moves
// only mark the state stale, and the latest camera goes out when it returns.
// Between answers every frame redraws the held meshes from the current
// camera, so motion stays smooth however long the server takes. With
// `policy=render` a round is one /render request for the camera; with
// `policy=balanced` (walkthrough.js, Qu et al.'s workload balancing) it is
// the strips of the frame's holes plus the oldest held meshes that fit one
// view's worth of triangles, and the held meshes' ages show in the overlay.
// A render answer drawn from live frames (`PUT ...?live=true`) says so in
// its `Dmesh-Frame-Age` header; the page then keeps asking (`follow=0`
// stops it), so the picture follows the live view, and shows the frame's age.

import { MESH } from './compact.js';
import { BINCODE } from './protocol.js';
import { checkCamera, firstCamera, lookedAt, resized } from './camera.js';
import { Navigator, distanceTo } from './controls.js';
import { Renderer, RenderError } from './renderer.js';
import { plan, selectViews, widened } from './walkthrough.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {import('./protocol.js').RenderResponse} RenderResponse */
/** @typedef {'tau' | 'epsilon' | 'max_triangles' | 'budget_ms'} LodKind */

const LOD = /** @type {Record<LodKind, {label: string, min: number, max: number, log: boolean, def: number, int?: boolean}>} */ ({
  tau: { label: 'tau (px)', min: 0, max: 8, log: false, def: 1 },
  epsilon: { label: 'epsilon (m)', min: 1e-4, max: 1, log: true, def: 0.01 },
  max_triangles: { label: 'max triangles', min: 100, max: 2e6, log: true, def: 50000, int: true },
  budget_ms: { label: 'budget (ms)', min: 0.05, max: 100, log: true, def: 2 },
});
const MODES = ['blend', 'coverage', 'wireframe'];
const DEFAULT_LIGHT = /** @type {[number, number, number]} */ ([0.3, 1.0, 0.4]);

const $ = (/** @type {string} */ id) => /** @type {HTMLElement} */ (document.getElementById(id));
const message = $('message');
const canvas = /** @type {HTMLCanvasElement} */ ($('view'));
const stage = $('stage');

/** Plain words on the page (and null clears them). @param {string | null} text @param {'error' | 'info'} [kind] */
function say(text, kind = 'error') {
  message.textContent = text || '';
  message.className = text ? kind : '';
  message.hidden = !text;
}

/** Reads and checks the URL's state; bad values are reported, not guessed. */
function readUrl() {
  const q = new URLSearchParams(location.search);
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
  let lodValue = 1;
  const given = /** @type {LodKind[]} */ (['tau', 'epsilon', 'max_triangles', 'budget_ms']).filter((k) => q.has(k));
  if (given.length > 1) problems.push(`give one of tau, epsilon, max_triangles, budget_ms (got ${given.join(', ')}); using ${given[0]}`);
  if (given.length) {
    lodKind = given[0];
    const rules = {
      tau: [(/** @type {number} */ v) => v >= 0, 'pixels, a number >= 0'],
      epsilon: [(/** @type {number} */ v) => v >= 0, 'metres, a number >= 0'],
      max_triangles: [(/** @type {number} */ v) => Number.isInteger(v) && v >= 0 && v < 2 ** 32, 'a whole number of triangles'],
      budget_ms: [(/** @type {number} */ v) => v > 0, 'milliseconds, a number > 0'],
    };
    const [ok, rule] = rules[lodKind];
    lodValue = num(lodKind, /** @type {(v: number) => boolean} */ (ok), /** @type {string} */ (rule)) ?? LOD[lodKind].def;
  }
  const bits = num('bits', (v) => Number.isInteger(v) && v >= 0 && v <= 16, 'a whole number 0..16');
  const cosK = num('cos_k', (v) => v >= 0, 'an exponent >= 0');
  const fill = num('fill', (v) => Number.isInteger(v) && v >= 0 && v <= 2, 'seam width to fill, 0..2 pixels');
  const w = num('w', (v) => Number.isInteger(v) && v >= 1 && v <= 8192, 'canvas width in pixels, 1..8192');
  const h = num('h', (v) => Number.isInteger(v) && v >= 1 && v <= 8192, 'canvas height in pixels, 1..8192');
  let mode = q.get('mode') || 'blend';
  if (!MODES.includes(mode)) { problems.push(`mode=${mode}: use blend, coverage or wireframe`); mode = 'blend'; }
  /** @type {[number, number, number] | null} */
  let light = null;
  const relight = q.get('relight');
  if (relight !== null && relight !== '' && relight !== '0' && relight !== 'false') {
    const parts = relight.split(',').map(Number);
    if (relight === '1' || relight === 'true') light = DEFAULT_LIGHT;
    else if (parts.length === 3 && parts.every(Number.isFinite) && Math.hypot(...parts) > 0) light = /** @type {[number, number, number]} */ (parts);
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
  let policy = q.get('policy') || 'render';
  if (!['render', 'balanced'].includes(policy)) { problems.push(`policy=${policy}: use render or balanced`); policy = 'render'; }
  // Meshes travel in the compact stream (protocol 6) unless the URL asks for protocol 5.
  let wire = q.get('wire') || 'compact';
  if (!['compact', 'bincode'].includes(wire)) { problems.push(`wire=${wire}: use compact or bincode`); wire = 'compact'; }
  const followText = q.get('follow') ?? '1';
  if (!['0', '1'].includes(followText)) problems.push(`follow=${followText}: use 1 (follow live views, the default) or 0`);
  const follow = followText !== '0';
  const uiText = q.get('ui') ?? '1';
  if (!['0', '1'].includes(uiText)) problems.push(`ui=${uiText}: use 0 (no panel) or 1`);
  const ui = uiText !== '0';
  return { scene: q.get('scene'), camera, lodKind, lodValue, bits, cosK, light, mode, w, h, fill: fill ?? 2, policy, wire, follow, ui, problems };
}

const url = readUrl();
const state = {
  scene: /** @type {string | null} */ (url.scene),
  lodKind: url.lodKind,
  lodValue: url.lodValue,
  bits: url.bits,
  cosK: url.cosK,
  light: url.light,
  mode: /** @type {'blend' | 'coverage' | 'wireframe'} */ (url.mode),
  w: url.w,
  h: url.h,
  /** Seams of at most this many pixels filled (the CPU client's `--fill-gaps`). */
  fill: url.fill,
  /** Intrinsics (width, height, projection) the camera is scaled from. */
  intrinsics: /** @type {CameraJson | null} */ (url.camera),
  /** How rounds of requests are made. */
  policy: /** @type {'render' | 'balanced'} */ (url.policy),
  /** How meshes travel. */
  wire: /** @type {'compact' | 'bincode'} */ (url.wire),
  /** Whether answers drawn from live frames are followed by the next request. */
  follow: url.follow,
};

/** The figures the overlay shows; also `window.dmeshStats`. */
const stats = {
  scene: '',
  updates: 0,
  /** @type {{view: string, weight: number, triangles: number, vertices: number, lod: object, max_depth_error: number}[]} */
  views: [],
  triangles: 0,
  vertices: 0,
  bytes: 0,
  transfer_bytes: 0,
  extract_ms: 0,
  server_ms: 0,
  decode_ms: 0,
  draw_ms: 0,
  frame_ms: 0,
  retries: 0,
  /** The balanced policy's last round: frame, holes by kind, refreshed, budget (triangles). */
  walk: { frame: 0, holes: 0, missing: 0, stale: 0, uncovered: 0, refreshed: 0, budget: 0, planned: 0, changes: 0, refetched: 0 },
  /** @type {{view: string, age: number}[]} ages of the held meshes drawn */
  ages: [],
  context_restores: 0,
  /** The reference the first camera was placed from (null: none saw the centre) and the point it frames. */
  start: /** @type {{reference: string | null, target: number[]} | null} */ (null),
  /** The youngest live frame drawn: its age when the answer left the server, ms (null: no live frame). */
  frame_age_ms: /** @type {number | null} */ (null),
  /** Answers drawn from live frames. */
  live_frames: 0,
  /** Of those, the answers that brought a frame not drawn before. */
  live_new_frames: 0,
  accum_format: '',
  width: 0,
  height: 0,
  dpr: 1,
  /** @type {CameraJson | null} */
  camera: null,
  /** @type {string | null} */
  error: null,
};
Object.assign(window, { dmeshStats: stats, dmeshReady: false });

/** @type {Renderer | null} */
let renderer = null;
try {
  renderer = new Renderer(canvas);
  stats.accum_format = renderer.accumFormat;
} catch (e) {
  fail(e instanceof RenderError ? e.message : `The viewer cannot start WebGL2: ${e}`);
}

/** A failure the page cannot go past. @param {string} text */
function fail(text) {
  stats.error = text;
  say(text);
  Object.assign(window, { dmeshFailed: true });
}

const nav = new Navigator(canvas, () => changed(true));
let target = /** @type {import('./camera.js').Vec3} */ ([0, 0, 1]);

// ---- sizes -------------------------------------------------------------

function size() {
  const dpr = window.devicePixelRatio || 1;
  const cssW = state.w ?? Math.max(1, stage.clientWidth);
  const cssH = state.h ?? Math.max(1, stage.clientHeight);
  canvas.style.width = `${cssW}px`;
  canvas.style.height = `${cssH}px`;
  const w = Math.max(1, Math.round(cssW * dpr));
  const h = Math.max(1, Math.round(cssH * dpr));
  if (canvas.width !== w) canvas.width = w;
  if (canvas.height !== h) canvas.height = h;
  stats.dpr = dpr;
  return { w, h };
}

/** The novel camera now: the navigator's pose, the intrinsics scaled to the drawing buffer. */
function camera() {
  const { w, h } = size();
  const base = /** @type {CameraJson} */ (state.intrinsics);
  return resized({ ...base, pose: nav.pose() }, w, h);
}

// ---- the URL -----------------------------------------------------------

let urlTimer = 0;
function writeUrl() {
  clearTimeout(urlTimer);
  urlTimer = window.setTimeout(() => {
    const q = new URLSearchParams();
    if (state.scene) q.set('scene', state.scene);
    if (state.intrinsics) q.set('camera', JSON.stringify(camera()));
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
    if (!url.ui) q.set('ui', '0');
    history.replaceState(null, '', `${location.pathname}?${q}`);
  }, 150);
}

// ---- requests ----------------------------------------------------------

const worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
let nextId = 0;
/** @type {Map<number, {resolve: (v: any) => void, reject: (e: Error) => void}>} */
const pending = new Map();
worker.onmessage = (/** @type {MessageEvent} */ e) => {
  const p = pending.get(e.data.id);
  if (!p) return;
  pending.delete(e.data.id);
  if (e.data.error) p.reject(new Error(`the server's answer could not be decoded: ${e.data.error}`));
  else p.resolve(e.data);
};
worker.onerror = (/** @type {ErrorEvent} */ e) => fail(`The decoder could not start: ${e.message}`);

/** A render answer, decoded in the worker: the compact stream (for the
 * novel camera `camera`), bincode or JSON.
 * @param {ArrayBuffer} body @param {'compact' | 'bincode' | 'json'} format @param {boolean} lines @param {CameraJson} camera
 * @returns {Promise<{response: RenderResponse, lines: (Uint32Array | null)[], decodeMs: number}>} */
function decode(body, format, lines, camera) {
  const id = nextId++;
  return new Promise((resolve, reject) => {
    pending.set(id, { resolve, reject });
    worker.postMessage({ id, body, json: format === 'json', compact: format === 'compact', camera, lines }, [body]);
  });
}

/** One strip answer, decoded in the worker: the compact stream (requested
 * for `camera`) or bincode. A compact mesh is kept in the worker under `key`
 * with its ETag `etag`; an answer to a request that named `held` may be
 * the change from it. @param {ArrayBuffer} body @param {boolean} compact
 * @param {boolean} lines @param {CameraJson} camera
 * @param {{key: string, etag: string | null, held: string | null}} [names]
 * @returns {Promise<{strips: any, lines: Uint32Array | null, change?: boolean}>} */
function decodeStrips(body, compact, lines, camera, names) {
  const id = nextId++;
  return new Promise((resolve, reject) => {
    pending.set(id, { resolve, reject });
    worker.postMessage({ id, body, json: false, lines, kind: compact ? 'mesh' : 'strips', camera, ...names }, [body]);
  });
}

/** The Accept header of a mesh request in the page's wire. */
function acceptMeshes() {
  return state.wire === 'compact' ? MESH : `${BINCODE}, application/json;q=0.5`;
}

/** The format of an answer, by its content type. @param {Response} r @returns {'compact' | 'bincode' | 'json'} */
function answerFormat(r) {
  const type = r.headers.get('content-type') || '';
  return type.startsWith(MESH) ? 'compact' : type.startsWith(BINCODE) ? 'bincode' : 'json';
}

/** An answer the viewer cannot use, in the server's words. */
class HttpError extends Error {
  /** @param {number} status @param {string} text */
  constructor(status, text) { super(text); this.status = status; }
}

/** The server's JSON error message, or the status line. @param {Response} r */
async function serverMessage(r) {
  try {
    const body = await r.json();
    return body?.error?.message || `${r.status} ${r.statusText}`;
  } catch {
    return `${r.status} ${r.statusText}`;
  }
}

const sleep = (/** @type {number} */ ms) => new Promise((r) => setTimeout(r, ms));

/** Seconds a 503 asks to wait (`Retry-After`), 1 when it does not say. @param {Response} r */
function retryAfter(r) {
  const after = Number(r.headers.get('retry-after'));
  return Number.isFinite(after) && after >= 0 ? after : 1;
}

/** A fetch that waits out 503s (at most `tries` times), as the server asks.
 * @param {string} path @param {RequestInit} [init] @param {number} [tries] */
async function fetchPatiently(path, init, tries = 10) {
  for (let k = 0; ; k++) {
    const r = await fetch(path, init);
    if (r.status !== 503 || k + 1 >= tries) return r;
    stats.retries++;
    await sleep(retryAfter(r) * 1000);
  }
}

/** A GET of JSON, with errors in words. @param {string} path */
async function getJson(path) {
  const r = await fetchPatiently(path, { headers: { accept: 'application/json' } });
  if (!r.ok) throw new HttpError(r.status, await serverMessage(r));
  return r.json();
}

/** Colour images: fetched once per URL, revalidated by ETag when a scene is (re)loaded. */
const etags = /** @type {Map<string, string>} */ (new Map());
const fresh = /** @type {Set<string>} */ (new Set());
/** @param {string} colorUrl */
async function texture(colorUrl) {
  if (!renderer || fresh.has(colorUrl)) return;
  /** @type {Record<string, string>} */
  const headers = {};
  const tag = etags.get(colorUrl);
  if (tag && renderer.images.has(colorUrl)) headers['if-none-match'] = tag;
  const r = await fetchPatiently(colorUrl, { headers, cache: 'no-cache' });
  if (r.status === 304) { fresh.add(colorUrl); return; }
  if (!r.ok) throw new HttpError(r.status, `colour image ${colorUrl}: ${await serverMessage(r)}`);
  const image = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
  if (!renderer.lost) renderer.uploadTexture(colorUrl, image);
  else renderer.images.set(colorUrl, image);
  const etag = r.headers.get('etag');
  if (etag) etags.set(colorUrl, etag);
  fresh.add(colorUrl);
}

/** `Server-Timing: extract;dur=MS, total;dur=MS` @param {string | null} h */
function serverTiming(h) {
  /** @type {Record<string, number>} */
  const out = {};
  for (const part of (h || '').split(',')) {
    const m = /^\s*([\w-]+)\s*;\s*dur=([\d.eE+-]+)/.exec(part);
    if (m) out[m[1]] = Number(m[2]);
  }
  return out;
}

let wanted = 0; // generation of the state the page shows
let sent = 0;   // generation of the last request sent
let inFlight = false;
let firstDrawn = false;
let sceneLoaded = false; // no request before the scene's cameras have placed the navigator

/** @param {CameraJson} cam */
function requestBody(cam) {
  /** @type {Record<string, unknown>} */
  const body = { camera: cam, lod: { [state.lodKind]: state.lodValue } };
  if (state.bits !== null) body.bits = state.bits;
  return body;
}

/** Sends the latest state when nothing is in flight and it is stale. */
async function pump() {
  if (inFlight || sent === wanted || !sceneLoaded || !state.scene || !state.intrinsics || !renderer) return;
  inFlight = true;
  try {
    await (state.policy === 'balanced' ? updateBalanced() : update());
  } catch (e) {
    if (e instanceof HttpError && e.status === 404) {
      say(`Scene "${state.scene}" is not on this server: ${e.message}. Pick one of the scenes above.`);
    } else if (e instanceof HttpError) {
      say(`The server refused the request (${e.status}): ${e.message}`);
    } else if (e instanceof TypeError) {
      say(`Cannot reach the dmesh server at ${location.origin} (${e.message}). Is \`dmesh serve\` still running? Retrying…`);
      await sleep(2000);
      sent = -1; // try again with the latest state
    } else {
      say(/** @type {Error} */ (e).message || String(e));
    }
    stats.error = message.textContent;
  } finally {
    inFlight = false;
    if (sent !== wanted) pump();
  }
}

async function update() {
  for (;;) {
    const generation = wanted;
    sent = generation;
    const cam = camera();
    const t0 = performance.now();
    const path = `/v1/scenes/${encodeURIComponent(/** @type {string} */ (state.scene))}/render`;
    const r = await fetch(path, {
      method: 'POST',
      headers: { 'content-type': 'application/json', accept: acceptMeshes() },
      body: JSON.stringify(requestBody(cam)),
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
    const { response, lines, decodeMs } = await decode(body, format, state.mode === 'wireframe', cam);
    if (response.views.length === 0) throw new Error('The server selected no reference view for this camera: turn towards the scene.');
    // A live view's colour may have changed with its frame: revalidate it.
    if (live) for (const v of response.views) fresh.delete(v.color_url);
    for (const v of response.views) await texture(v.color_url);
    if (!renderer || renderer.lost) return;
    renderer.setViews(response.views.map((v, k) => ({ ...v, lines: lines[k] })));
    const t1 = performance.now();
    const drawn = draw(true);
    const t2 = performance.now();
    const done = shown(generation, drawn, response.views, null, {
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
      if (live && state.follow) follow(performance.now() - Number(age));
      return;
    }
  }
}

/** Milliseconds between the answer of a new live frame and the next request. */
const FOLLOW_MS = 30;
/** The same, when the answer showed the frame already drawn: the view has not moved on. */
const FOLLOW_IDLE_MS = 200;
let followTimer = 0;
/** When the last live frame drawn became visible, on the page's clock. */
let lastFrameAt = -Infinity;
/** Asks again soon: the live view has moved on, or will. @param {number} frameAt when the frame drawn became visible */
function follow(frameAt) {
  const same = Math.abs(frameAt - lastFrameAt) < 5;
  lastFrameAt = frameAt;
  if (!same) stats.live_new_frames++;
  clearTimeout(followTimer);
  followTimer = window.setTimeout(() => {
    if (!state.follow) return;
    wanted++;
    pump();
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
function shown(generation, drawn, views, age, figures) {
  say(null);
  stats.error = null;
  Object.assign(stats, {
    scene: state.scene,
    updates: stats.updates + 1,
    views: views.map((v) => ({
      view: v.strips.view,
      weight: v.weight,
      triangles: v.strips.triangles,
      vertices: v.strips.vertexCount,
      lod: v.strips.lod,
      max_depth_error: v.strips.maxDepthError,
      ...(age ? { age: age(v.strips.view) } : {}),
    })),
    triangles: views.reduce((s, v) => s + v.strips.triangles, 0),
    vertices: views.reduce((s, v) => s + v.strips.vertexCount, 0),
    ...figures,
  });
  overlay();
  if (wanted !== generation) return false;
  if (!firstDrawn && drawn) {
    firstDrawn = true;
    Object.assign(window, { dmeshReady: true });
  }
  return true;
}

// ---- the balanced walkthrough (walkthrough.js) --------------------------

/** The scene's reference views: id, camera, colour URL (from loadScene). */
let refs = /** @type {{view: string, camera: CameraJson, color_url: string}[]} */ ([]);
/** Held meshes by view id, with their age in rounds since fetched. */
const held = /** @type {Map<string, {strips: any, lines: Uint32Array | null, age: number, tau: number, color_url: string}>} */ (new Map());
const GUARD = 0.15;
const STALE_FACTOR = 1.5;
/** Requests a round sends at once: the server reads as many as its cores at a time. */
const ROUND_CONCURRENCY = 2;

/** Per view id, the compact mesh the worker keeps: its ETag and requesting
 * camera, which a refresh names to get only the change from it. */
const compactHeld = /** @type {Map<string, {etag: string, camera: CameraJson}>} */ (new Map());

/** One view's mesh for `cam` (the page's wire), decoded in the worker; on
 * the compact wire, as the change from the mesh held for the view.
 * @param {number} v @param {CameraJson} cam */
async function fetchStrips(v, cam) {
  const ref = refs[v];
  const path = `/v1/scenes/${encodeURIComponent(/** @type {string} */ (state.scene))}/views/${encodeURIComponent(ref.view)}/strips`;
  const key = `${state.scene}/${ref.view}`;
  const body = requestBody(cam);
  const from = state.wire === 'compact' ? compactHeld.get(key) : undefined;
  if (from) { body.held = from.etag; body.held_camera = from.camera; }
  const r = await fetchPatiently(path, {
    method: 'POST',
    headers: { 'content-type': 'application/json', accept: state.wire === 'compact' ? MESH : BINCODE },
    body: JSON.stringify(body),
  }, Infinity);
  if (!r.ok) throw new HttpError(r.status, await serverMessage(r));
  const compact = answerFormat(r) === 'compact';
  const buffer = await r.arrayBuffer();
  const bytes = buffer.byteLength;
  const etag = r.headers.get('etag');
  compactHeld.delete(key);
  const { strips, lines, change } = await decodeStrips(buffer, compact, state.mode === 'wireframe', cam, { key, etag, held: from?.etag ?? null });
  if (compact && etag) compactHeld.set(key, { etag, camera: cam });
  // Meshes fetched again, and of those, how many came as the change from the held one.
  if (from) { stats.walk.refetched++; if (change) stats.walk.changes++; }
  return { v, strips, lines, bytes, extract: serverTiming(r.headers.get('server-timing')).extract ?? strips.extract_ms };
}

/** The selected held meshes for `cam`, weights renormalised over those held. @param {CameraJson} cam */
function heldSelection(cam) {
  const sel = selectViews(cam, refs.map((r) => r.camera));
  const have = sel.filter((s) => held.has(refs[s.index].view));
  const total = have.reduce((t, s) => t + s.weight, 0) || 1;
  return { sel, have: have.map((s) => ({ index: s.index, weight: s.weight / total })) };
}

/** Points the renderer at the held meshes `cam` selects: new buffers only when the set changed. @param {CameraJson} cam */
function syncHeld(cam) {
  if (!renderer || renderer.lost) return;
  const { have } = heldSelection(cam);
  const chosen = have.map((s) => /** @type {NonNullable<ReturnType<typeof held.get>>} */ (held.get(refs[s.index].view)));
  const same = renderer.views.length === chosen.length && renderer.views.every((v, k) => v.strips === chosen[k].strips);
  if (!same) {
    renderer.setViews(chosen.map((h, k) => ({ weight: have[k].weight, strips: h.strips, color_url: h.color_url, lines: h.lines })));
  } else {
    renderer.views.forEach((v, k) => { v.weight = have[k].weight; });
  }
  stats.ages = have.map((s) => ({ view: refs[s.index].view, age: /** @type {any} */ (held.get(refs[s.index].view)).age }));
}

async function updateBalanced() {
  for (;;) {
    const generation = wanted;
    sent = generation;
    const cam = camera();
    const t0 = performance.now();
    for (const h of held.values()) h.age++;
    const { sel } = heldSelection(cam);
    if (sel.length === 0) throw new Error('No reference view looks this way: turn towards the scene.');
    const heldList = refs.map((r) => {
      const h = held.get(r.view);
      return h ? { age: h.age, tau: h.tau, reach: h.strips.reach, triangles: h.strips.triangles } : null;
    });
    const tau = state.lodKind === 'tau' ? state.lodValue : 1;
    const p = plan({ camera: cam, selected: sel.map((s) => s.index), held: heldList, tau, staleFactor: STALE_FACTOR, budget: null });
    const asked = widened(cam, GUARD);
    const todo = [...p.holes.map((h) => h[0]), ...p.refresh];
    const got = [];
    for (let k = 0; k < todo.length; k += ROUND_CONCURRENCY) {
      got.push(...(await Promise.all(todo.slice(k, k + ROUND_CONCURRENCY).map((v) => fetchStrips(v, asked)))));
    }
    for (const g of got) {
      await texture(refs[g.v].color_url);
      const lod = g.strips.lod;
      held.set(refs[g.v].view, { strips: g.strips, lines: g.lines, age: 0, tau: lod.tau ?? tau, color_url: refs[g.v].color_url });
    }
    if (!renderer || renderer.lost) return;
    const t1 = performance.now();
    syncHeld(camera());
    const drawn = draw(true);
    const t2 = performance.now();
    const count = (/** @type {string} */ why) => p.holes.filter((h) => h[1] === why).length;
    const bytes = got.reduce((s, g) => s + g.bytes, 0);
    const extract = got.reduce((s, g) => s + g.extract, 0);
    const done = shown(generation, drawn, renderer.views, (view) => /** @type {any} */ (held.get(view)).age, {
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

// ---- drawing -----------------------------------------------------------

/** @type {CameraJson | null} */
let lastDrawn = null;
/** Draws the held meshes from the current camera; `sync` waits for the GPU. */
function draw(sync = false) {
  if (!renderer || renderer.lost) return false;
  const cam = camera();
  if (state.policy === 'balanced' && held.size) syncHeld(cam);
  if (renderer.views.length === 0) return false;
  renderer.draw({
    camera: cam,
    mode: state.mode,
    epsZ: 0.01,
    cosK: state.cosK,
    light: state.light,
    shininess: 32,
    fillGaps: state.fill,
  });
  if (sync) renderer.finish();
  lastDrawn = cam;
  return true;
}

let drawQueued = false;
function scheduleDraw() {
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(() => {
    drawQueued = false;
    draw();
  });
}

/** The state moved: redraw what is held, and fetch for it. @param {boolean} [moved] */
function changed(moved = false) {
  wanted++;
  scheduleDraw();
  writeUrl();
  if (moved) stats.camera = camera();
  pump();
}

canvas.addEventListener('webglcontextlost', (/** @type {Event} */ e) => {
  e.preventDefault();
  renderer?.contextLost();
  say('The GPU context was lost; restoring it…', 'info');
});
canvas.addEventListener('webglcontextrestored', () => {
  if (!renderer) return;
  try {
    renderer.init();
    stats.context_restores++;
    say(null);
    draw(true);
    Object.assign(window, { dmeshRestored: stats.context_restores });
  } catch (e) {
    fail(`The GPU context could not be restored: ${/** @type {Error} */ (e).message}`);
  }
});

new ResizeObserver(() => {
  if (!state.intrinsics) return;
  changed();
}).observe(stage);

// ---- the panel's place -------------------------------------------------

const panel = $('panel');
const panelToggle = /** @type {HTMLButtonElement} */ ($('panel-toggle'));
/** Room the open panel takes on the left, CSS pixels (its width and margins; style.css). */
const PANEL_SPACE = 306;
/** The smallest canvas the panel makes room for beside it. */
const MIN_CANVAS = 320;
/** Below this window width the panel starts collapsed. */
const NARROW = 900;

/** Puts the canvas beside the open panel when the window has room for both. */
function layout() {
  const open = !panel.hidden && !panel.classList.contains('collapsed');
  const room = window.innerWidth - PANEL_SPACE >= (state.w ?? MIN_CANVAS);
  document.body.classList.toggle('beside', open && room);
}
/** @param {boolean} open */
function setPanel(open) {
  panel.classList.toggle('collapsed', !open);
  panelToggle.setAttribute('aria-expanded', String(open));
  panelToggle.textContent = open ? 'hide' : 'panel';
  layout();
}
panel.hidden = !url.ui;
setPanel(url.ui && window.innerWidth >= NARROW);
panelToggle.addEventListener('click', () => setPanel(panel.classList.contains('collapsed')));
window.addEventListener('keydown', (e) => {
  const t = /** @type {HTMLElement} */ (e.target);
  if (e.key !== 'h' || e.ctrlKey || e.metaKey || e.altKey || ['INPUT', 'SELECT', 'TEXTAREA'].includes(t.tagName)) return;
  if (!panel.hidden) setPanel(panel.classList.contains('collapsed'));
});
window.addEventListener('resize', layout);

// ---- the panel ---------------------------------------------------------

const sceneSelect = /** @type {HTMLSelectElement} */ ($('scene'));
const lodSelect = /** @type {HTMLSelectElement} */ ($('lod-kind'));
const lodRange = /** @type {HTMLInputElement} */ ($('lod-range'));
const lodNumber = /** @type {HTMLInputElement} */ ($('lod-value'));
const bitsRange = /** @type {HTMLInputElement} */ ($('bits'));
const bitsLabel = $('bits-label');
const modeSelect = /** @type {HTMLSelectElement} */ ($('mode'));
const navSelect = /** @type {HTMLSelectElement} */ ($('nav'));
const policySelect = /** @type {HTMLSelectElement} */ ($('policy'));
const cosInput = /** @type {HTMLInputElement} */ ($('cos-k'));
const relightBox = /** @type {HTMLInputElement} */ ($('relight'));
const lightAz = /** @type {HTMLInputElement} */ ($('light-az'));
const lightEl = /** @type {HTMLInputElement} */ ($('light-el'));

/** Slider position 0..1000 of a value, and back. */
function toRange(/** @type {LodKind} */ k, /** @type {number} */ v) {
  const d = LOD[k];
  const t = d.log ? Math.log(Math.max(v, d.min) / d.min) / Math.log(d.max / d.min) : (v - d.min) / (d.max - d.min);
  return Math.round(Math.max(0, Math.min(1, t)) * 1000);
}
function fromRange(/** @type {LodKind} */ k, /** @type {number} */ p) {
  const d = LOD[k];
  const t = p / 1000;
  const v = d.log ? d.min * (d.max / d.min) ** t : d.min + t * (d.max - d.min);
  return d.int ? Math.round(v) : +v.toPrecision(3);
}

function syncPanel() {
  lodSelect.value = state.lodKind;
  lodRange.value = String(toRange(state.lodKind, state.lodValue));
  lodNumber.value = String(state.lodValue);
  bitsRange.value = String(state.bits ?? -1);
  bitsLabel.textContent = state.bits === null ? 'exact' : `${state.bits} bits`;
  modeSelect.value = state.mode;
  policySelect.value = state.policy;
  cosInput.value = state.cosK === null ? '' : String(state.cosK);
  relightBox.checked = !!state.light;
  const l = state.light || DEFAULT_LIGHT;
  const n = Math.hypot(...l);
  lightAz.value = String(Math.round((Math.atan2(l[0], l[2]) * 180) / Math.PI));
  lightEl.value = String(Math.round((Math.asin(l[1] / n) * 180) / Math.PI));
  lightAz.disabled = lightEl.disabled = !state.light;
}

lodSelect.addEventListener('change', () => {
  state.lodKind = /** @type {LodKind} */ (lodSelect.value);
  state.lodValue = LOD[state.lodKind].def;
  syncPanel();
  changed();
});
lodRange.addEventListener('input', () => {
  state.lodValue = fromRange(state.lodKind, Number(lodRange.value));
  lodNumber.value = String(state.lodValue);
  changed();
});
lodNumber.addEventListener('change', () => {
  const v = Number(lodNumber.value);
  if (!Number.isFinite(v) || v < 0 || (state.lodKind === 'budget_ms' && v <= 0)) {
    say(`${LOD[state.lodKind].label} must be a number${state.lodKind === 'budget_ms' ? ' > 0' : ' >= 0'}`);
    return;
  }
  state.lodValue = LOD[state.lodKind].int ? Math.round(v) : v;
  syncPanel();
  changed();
});
bitsRange.addEventListener('input', () => {
  const b = Number(bitsRange.value);
  state.bits = b < 0 ? null : b;
  bitsLabel.textContent = state.bits === null ? 'exact' : `${state.bits} bits`;
  changed();
});
modeSelect.addEventListener('change', () => {
  state.mode = /** @type {'blend' | 'coverage' | 'wireframe'} */ (modeSelect.value);
  changed();
});
policySelect.addEventListener('change', () => {
  state.policy = /** @type {'render' | 'balanced'} */ (policySelect.value);
  held.clear();
  changed();
});
navSelect.addEventListener('change', () => { nav.mode = /** @type {'orbit' | 'fly'} */ (navSelect.value); });
cosInput.addEventListener('change', () => {
  const v = cosInput.value.trim() === '' ? null : Number(cosInput.value);
  if (v !== null && !(Number.isFinite(v) && v >= 0)) { say('cos^k needs an exponent >= 0, or nothing'); return; }
  state.cosK = v;
  changed();
});
const lightChanged = () => {
  if (relightBox.checked) {
    const az = (Number(lightAz.value) * Math.PI) / 180;
    const el = (Number(lightEl.value) * Math.PI) / 180;
    state.light = [Math.cos(el) * Math.sin(az), Math.sin(el), Math.cos(el) * Math.cos(az)];
  } else {
    state.light = null;
  }
  lightAz.disabled = lightEl.disabled = !state.light;
  changed();
};
relightBox.addEventListener('change', lightChanged);
lightAz.addEventListener('input', lightChanged);
lightEl.addEventListener('input', lightChanged);
sceneSelect.addEventListener('change', () => {
  state.scene = sceneSelect.value;
  state.intrinsics = null;
  loadScene().catch(sceneFailed);
});
$('reset').addEventListener('click', () => {
  state.intrinsics = null;
  loadScene().catch(sceneFailed);
});

const fmt = (/** @type {number} */ v, d = 1) => (Number.isFinite(v) ? v.toFixed(d) : '–');
const kb = (/** @type {number} */ b) => `${(b / 1024).toFixed(1)} kB`;
function overlay() {
  const lod = (/** @type {any} */ l) => (l.tau !== undefined ? `tau ${fmt(l.tau, 2)} px` : `eps ${fmt(l.epsilon * 1000, 2)} mm`);
  const balanced = state.policy === 'balanced';
  const ages = new Map(stats.ages.map((a) => [a.view, a.age]));
  const age = (/** @type {string} */ v) => (balanced ? `<td>${ages.get(v) ?? '–'}</td>` : '');
  const rows = stats.views.map((v) => `<tr><td>${escape(v.view)}</td><td>${fmt(v.weight, 3)}</td><td>${v.triangles.toLocaleString()}</td><td>${lod(v.lod)}</td>${age(v.view)}</tr>`);
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
/** @param {string} s */
function escape(s) {
  return s.replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c] || c);
}

// ---- scenes ------------------------------------------------------------

/** @param {unknown} e */
function sceneFailed(e) {
  if (e instanceof HttpError && e.status === 404) {
    const known = [...sceneSelect.options].map((o) => o.value).filter(Boolean);
    say(`Scene "${state.scene}" is not on this server (${e.message}). ${known.length ? `Scenes here: ${known.join(', ')}.` : 'The server has no scene yet: upload views first.'}`);
  } else if (e instanceof TypeError) {
    say(`Cannot reach the dmesh server at ${location.origin} (${e.message}). Is \`dmesh serve\` running?`);
  } else {
    say(e instanceof Error ? e.message : String(e));
  }
  stats.error = message.textContent;
}

async function loadScene() {
  const scene = /** @type {string} */ (state.scene);
  sceneLoaded = false;
  sceneSelect.value = scene;
  const list = await getJson(`/v1/scenes/${encodeURIComponent(scene)}/views`);
  if (!list.views.length) throw new Error(`Scene "${scene}" has no views yet: upload some first.`);
  // One request at a time: the page never competes with itself for the
  // server's few read slots (which are as many as its cores).
  const summaries = [];
  for (const v of list.views) {
    summaries.push(await getJson(`/v1/scenes/${encodeURIComponent(scene)}/views/${encodeURIComponent(v)}`));
  }
  refs = summaries.map((s) => ({ view: s.view, camera: /** @type {CameraJson} */ (s.camera), color_url: s.color_url }));
  const centerDepths = summaries.map((s) => s.center_depth);
  held.clear();
  renderer?.setViews([]);
  const cams = refs.map((r) => r.camera);
  target = lookedAt(cams);
  fresh.clear();
  if (!state.intrinsics) {
    const { w, h } = size();
    const first = firstCamera(cams, w, h, centerDepths);
    stats.start = { reference: first.reference === null ? null : refs[first.reference].view, target: first.target };
    state.intrinsics = first.camera;
    nav.set(first.camera, distanceTo(first.camera, first.target));
  } else {
    nav.set(state.intrinsics, distanceTo(state.intrinsics, target));
  }
  stats.camera = camera();
  sceneLoaded = true;
  changed();
}

async function start() {
  syncPanel();
  if (url.problems.length) {
    const notice = $('notice');
    notice.textContent = `Ignored in the address: ${url.problems.join('; ')}.`;
    notice.hidden = false;
  }
  if (!renderer) return;
  let scenes;
  try {
    scenes = (await getJson('/v1/scenes')).scenes;
  } catch (e) {
    sceneFailed(e);
    return;
  }
  sceneSelect.replaceChildren(...scenes.map((/** @type {string} */ s) => new Option(s, s)));
  if (!state.scene) state.scene = scenes.includes('demo') ? 'demo' : scenes[0] || null;
  if (!state.scene) {
    say('The server has no scene yet: upload views (see the README), or start it with `dmesh serve --demo`.');
    return;
  }
  if (!scenes.includes(state.scene)) sceneSelect.add(new Option(`${state.scene} (missing)`, state.scene));
  try {
    await loadScene();
  } catch (e) {
    sceneFailed(e);
  }
}

/** The picture and its coverage, for tests: `{width, height, rgb, covered}` base64. */
function capture() {
  if (!renderer || !draw(true)) return null;
  const c = renderer.capture();
  const b64 = (/** @type {Uint8Array} */ a) => {
    let s = '';
    for (let k = 0; k < a.length; k += 0x8000) s += String.fromCharCode(...a.subarray(k, k + 0x8000));
    return btoa(s);
  };
  return { width: c.width, height: c.height, rgb: b64(c.rgb), covered: b64(c.covered), camera: lastDrawn };
}
/** Draw times of `n` redraws of the held meshes, GPU finished each time (figures). @param {number} n */
function drawTimes(n) {
  const out = [];
  for (let k = 0; k < n; k++) {
    const t = performance.now();
    if (!draw(true)) break;
    out.push(performance.now() - t);
  }
  return out;
}
/** True when the picture is the answer for the current state and nothing is in flight. */
const idle = () => !inFlight && sent === wanted && firstDrawn;
// For tests: a turn of the camera by a fixed step, as a held key turns it
// by a step that depends on the frame rate.
const turnBy = (/** @type {number} */ dx, /** @type {number} */ dy) => nav.turn(dx, dy);
Object.assign(window, { dmeshCapture: capture, dmeshDrawTimes: drawTimes, dmeshIdle: idle, dmeshRefresh: () => changed(), dmeshTurn: turnBy });

start();
