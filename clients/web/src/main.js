// The dmesh viewer: picks a scene, moves a camera through it, asks the
// server for the selected views' view-dependent strips (DMesh Sec. 6.2) and
// blends them on the GPU (renderer.js). This file wires the parts:
// - url.js: the page's state in its address;
// - net.js: requests, the ETag cache of colour images, the decoding worker;
// - rounds.js: what is asked of the server as the camera moves (at most one
//   round in flight; live views followed);
// - panel.js: the controls, the figures and the panel's place;
// - renderer.js and controls.js: the GPU and the navigator.
// Between answers every frame redraws the held meshes from the current
// camera, so motion stays smooth however long the server takes.

import { firstCamera, lookedAt, resized } from './camera.js';
import { Navigator, distanceTo } from './controls.js';
import { Decoder, HttpError, Server, Textures } from './net.js';
import { Panel } from './panel.js';
import { Renderer, RenderError } from './renderer.js';
import { Rounds } from './rounds.js';
import { readUrl, urlQuery } from './url.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */

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

const url = readUrl(location.search);
/** @type {import('./url.js').State} */
const state = {
  scene: url.scene,
  lodKind: url.lodKind,
  lodValue: url.lodValue,
  bits: url.bits,
  cosK: url.cosK,
  light: url.light,
  mode: url.mode,
  w: url.w,
  h: url.h,
  fill: url.fill,
  intrinsics: url.camera,
  policy: url.policy,
  wire: url.wire,
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

/** A failure the page cannot go past. @param {string} text */
function fail(text) {
  stats.error = text;
  say(text);
  Object.assign(window, { dmeshFailed: true });
}

const nav = new Navigator(canvas, () => changed(true));

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

let urlTimer = 0;
/** Keeps the address current, at most every 150 ms. */
function writeUrl() {
  clearTimeout(urlTimer);
  urlTimer = window.setTimeout(() => {
    history.replaceState(null, '', `${location.pathname}?${urlQuery(state, state.intrinsics ? camera() : null, url.ui)}`);
  }, 150);
}

// ---- the parts ---------------------------------------------------------

const panel = new Panel({
  state,
  ui: url.ui,
  changed: () => changed(),
  policyChanged: () => { rounds?.held.clear(); changed(); },
  navChanged: (mode) => { nav.mode = mode; },
  load: () => { loadScene().catch(sceneFailed); },
  say,
});

/** @type {Rounds | null} */
let rounds = null;
try {
  const renderer = new Renderer(canvas);
  stats.accum_format = renderer.accumFormat;
  const server = new Server(() => { stats.retries++; });
  rounds = new Rounds({
    state,
    stats,
    renderer,
    server,
    textures: new Textures(server, renderer),
    decoder: new Decoder(fail),
    camera,
    draw,
    say,
    overlay: () => panel.overlay(stats),
  });
} catch (e) {
  fail(e instanceof RenderError ? e.message : `The viewer cannot start WebGL2: ${e}`);
}

// ---- drawing -----------------------------------------------------------

/** @type {CameraJson | null} */
let lastDrawn = null;
/** Draws the held meshes from the current camera; `sync` waits for the GPU. */
function draw(sync = false) {
  const renderer = rounds?.page.renderer;
  if (!rounds || !renderer || renderer.lost) return false;
  const cam = camera();
  rounds.beforeDraw(cam);
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
  scheduleDraw();
  writeUrl();
  if (moved) stats.camera = camera();
  rounds?.stale();
}

canvas.addEventListener('webglcontextlost', (/** @type {Event} */ e) => {
  e.preventDefault();
  rounds?.page.renderer.contextLost();
  say('The GPU context was lost; restoring it…', 'info');
});
canvas.addEventListener('webglcontextrestored', () => {
  if (!rounds) return;
  try {
    rounds.page.renderer.init();
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

// ---- scenes ------------------------------------------------------------

/** @param {unknown} e */
function sceneFailed(e) {
  if (e instanceof HttpError && e.status === 404) {
    const known = panel.knownScenes();
    say(`Scene "${state.scene}" is not on this server (${e.message}). ${known.length ? `Scenes here: ${known.join(', ')}.` : 'The server has no scene yet: upload views first.'}`);
  } else if (e instanceof TypeError) {
    say(`Cannot reach the dmesh server at ${location.origin} (${e.message}). Is \`dmesh serve\` running?`);
  } else {
    say(e instanceof Error ? e.message : String(e));
  }
  stats.error = message.textContent;
}

/** Loads the scene's references and places the first camera (camera.js,
 * `firstCamera`) unless the address gave one. */
async function loadScene() {
  if (!rounds) return;
  const { server, textures } = rounds.page;
  const scene = /** @type {string} */ (state.scene);
  rounds.sceneLoaded = false;
  panel.scene.value = scene;
  const list = await server.json(`/v1/scenes/${encodeURIComponent(scene)}/views`);
  if (!list.views.length) throw new Error(`Scene "${scene}" has no views yet: upload some first.`);
  // One request at a time: the page never competes with itself for the
  // server's few read slots (which are as many as its cores).
  const summaries = [];
  for (const v of list.views) {
    summaries.push(await server.json(`/v1/scenes/${encodeURIComponent(scene)}/views/${encodeURIComponent(v)}`));
  }
  const refs = summaries.map((s) => ({ view: s.view, camera: /** @type {CameraJson} */ (s.camera), color_url: s.color_url }));
  rounds.setScene(refs);
  textures.allStale();
  const cams = refs.map((r) => r.camera);
  if (!state.intrinsics) {
    const { w, h } = size();
    const first = firstCamera(cams, w, h, summaries.map((s) => s.center_depth));
    stats.start = { reference: first.reference === null ? null : refs[first.reference].view, target: first.target };
    state.intrinsics = first.camera;
    nav.set(first.camera, distanceTo(first.camera, first.target));
  } else {
    nav.set(state.intrinsics, distanceTo(state.intrinsics, lookedAt(cams)));
  }
  stats.camera = camera();
  rounds.sceneLoaded = true;
  changed();
}

async function start() {
  panel.sync();
  panel.notice(url.problems);
  if (!rounds) return;
  let scenes;
  try {
    scenes = (await rounds.page.server.json('/v1/scenes')).scenes;
  } catch (e) {
    sceneFailed(e);
    return;
  }
  if (!state.scene) state.scene = scenes.includes('demo') ? 'demo' : scenes[0] || null;
  panel.scenes(scenes, state.scene);
  if (!state.scene) {
    say('The server has no scene yet: upload views (see the README), or start it with `dmesh serve --demo`.');
    return;
  }
  try {
    await loadScene();
  } catch (e) {
    sceneFailed(e);
  }
}

// ---- for tests ---------------------------------------------------------

/** The picture and its coverage: `{width, height, rgb, covered}` base64. */
function capture() {
  if (!rounds || !draw(true)) return null;
  const c = rounds.page.renderer.capture();
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
// A turn of the camera by a fixed step, as a held key turns it by a step
// that depends on the frame rate.
const turnBy = (/** @type {number} */ dx, /** @type {number} */ dy) => nav.turn(dx, dy);
Object.assign(window, {
  dmeshCapture: capture,
  dmeshDrawTimes: drawTimes,
  dmeshIdle: () => rounds?.idle() ?? false,
  dmeshRefresh: () => changed(),
  dmeshTurn: turnBy,
});

start();
