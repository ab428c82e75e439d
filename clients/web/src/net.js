// The viewer's network: requests that wait out a busy server as it asks
// (503 with Retry-After), errors in the server's own words, colour images
// fetched once and revalidated by ETag, and answers decoded off the main
// thread (worker.js): the compact stream (protocol 7, compact.js), bincode
// or JSON (protocol 5, protocol.js).

import { MESH } from './compact.js';
import { BINCODE } from './protocol.js';

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {import('./protocol.js').RenderResponse} RenderResponse */

/** An answer the viewer cannot use, in the server's words. */
export class HttpError extends Error {
  /** @param {number} status @param {string} text */
  constructor(status, text) { super(text); this.status = status; }
}

/** The server's JSON error message, or the status line. @param {Response} r */
export async function serverMessage(r) {
  try {
    const body = await r.json();
    return body?.error?.message || `${r.status} ${r.statusText}`;
  } catch {
    return `${r.status} ${r.statusText}`;
  }
}

export const sleep = (/** @type {number} */ ms) => new Promise((r) => setTimeout(r, ms));

/** Seconds a 503 asks to wait (`Retry-After`), 1 when it does not say. @param {Response} r */
export function retryAfter(r) {
  const after = Number(r.headers.get('retry-after'));
  return Number.isFinite(after) && after >= 0 ? after : 1;
}

/** The Accept header of a mesh request on `wire`. @param {'compact' | 'bincode'} wire */
export function acceptMeshes(wire) {
  return wire === 'compact' ? MESH : `${BINCODE}, application/json;q=0.5`;
}

/** The format of an answer, by its content type. @param {Response} r @returns {'compact' | 'bincode' | 'json'} */
export function answerFormat(r) {
  const type = r.headers.get('content-type') || '';
  return type.startsWith(MESH) ? 'compact' : type.startsWith(BINCODE) ? 'bincode' : 'json';
}

/** `Server-Timing: extract;dur=MS, total;dur=MS` @param {string | null} h */
export function serverTiming(h) {
  /** @type {Record<string, number>} */
  const out = {};
  for (const part of (h || '').split(',')) {
    const m = /^\s*([\w-]+)\s*;\s*dur=([\d.eE+-]+)/.exec(part);
    if (m) out[m[1]] = Number(m[2]);
  }
  return out;
}

/** Requests to one server. */
export class Server {
  /** @param {() => void} onRetry called for each 503 waited out */
  constructor(onRetry) {
    this.onRetry = onRetry;
  }

  /** A fetch that waits out 503s (at most `tries` times), as the server asks.
   * @param {string} path @param {RequestInit} [init] @param {number} [tries] */
  async fetch(path, init, tries = 10) {
    for (let k = 0; ; k++) {
      const r = await fetch(path, init);
      if (r.status !== 503 || k + 1 >= tries) return r;
      this.onRetry();
      await sleep(retryAfter(r) * 1000);
    }
  }

  /** A GET of JSON, with errors in words. @param {string} path */
  async json(path) {
    const r = await this.fetch(path, { headers: { accept: 'application/json' } });
    if (!r.ok) throw new HttpError(r.status, await serverMessage(r));
    return r.json();
  }
}

/** Colour images: fetched once per URL, revalidated by ETag when a scene is
 * (re)loaded or a live view's frame changed. */
export class Textures {
  /** @param {Server} server @param {import('./renderer.js').Renderer} renderer */
  constructor(server, renderer) {
    this.server = server;
    this.renderer = renderer;
    /** @type {Map<string, string>} */
    this.etags = new Map();
    /** URLs known current: not asked again until they are marked stale. @type {Set<string>} */
    this.fresh = new Set();
  }

  /** Revalidate `url` on its next use. @param {string} url */
  stale(url) { this.fresh.delete(url); }

  /** Revalidate every image on its next use. */
  allStale() { this.fresh.clear(); }

  /** Makes sure the renderer holds the current image at `url`. @param {string} url */
  async load(url) {
    const renderer = this.renderer;
    if (this.fresh.has(url)) return;
    /** @type {Record<string, string>} */
    const headers = {};
    const tag = this.etags.get(url);
    if (tag && renderer.images.has(url)) headers['if-none-match'] = tag;
    const r = await this.server.fetch(url, { headers, cache: 'no-cache' });
    if (r.status === 304) { this.fresh.add(url); return; }
    if (!r.ok) throw new HttpError(r.status, `colour image ${url}: ${await serverMessage(r)}`);
    const image = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
    if (!renderer.lost) renderer.uploadTexture(url, image);
    else renderer.images.set(url, image);
    const etag = r.headers.get('etag');
    if (etag) this.etags.set(url, etag);
    this.fresh.add(url);
  }
}

/** Answers decoded in a worker (worker.js), so decoding never stalls a frame. */
export class Decoder {
  /** @param {(text: string) => void} fail called when the worker cannot start */
  constructor(fail) {
    this.worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
    this.nextId = 0;
    /** @type {Map<number, {resolve: (v: any) => void, reject: (e: Error) => void}>} */
    this.pending = new Map();
    this.worker.onmessage = (/** @type {MessageEvent} */ e) => {
      const p = this.pending.get(e.data.id);
      if (!p) return;
      this.pending.delete(e.data.id);
      if (e.data.error) p.reject(new Error(`the server's answer could not be decoded: ${e.data.error}`));
      else p.resolve(e.data);
    };
    this.worker.onerror = (/** @type {ErrorEvent} */ e) => fail(`The decoder could not start: ${e.message}`);
  }

  /** @param {Record<string, unknown>} message @param {ArrayBuffer} body @returns {Promise<any>} */
  post(message, body) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.worker.postMessage({ id, body, ...message }, [body]);
    });
  }

  /** A render answer: the compact stream (for the novel camera `camera`),
   * bincode or JSON.
   * @param {ArrayBuffer} body @param {'compact' | 'bincode' | 'json'} format @param {boolean} lines @param {CameraJson} camera
   * @returns {Promise<{response: RenderResponse, lines: (Uint32Array | null)[], decodeMs: number}>} */
  render(body, format, lines, camera) {
    return this.post({ json: format === 'json', compact: format === 'compact', camera, lines }, body);
  }

  /** One strip answer: the compact stream (requested for `camera`) or
   * bincode. A compact mesh is kept in the worker under `key` with its ETag
   * `etag`; an answer to a request that named `held` may be the change
   * from it. @param {ArrayBuffer} body @param {boolean} compact
   * @param {boolean} lines @param {CameraJson} camera
   * @param {{key: string, etag: string | null, held: string | null}} [names]
   * @returns {Promise<{strips: any, lines: Uint32Array | null, change?: boolean}>} */
  strips(body, compact, lines, camera, names) {
    return this.post({ json: false, lines, kind: compact ? 'mesh' : 'strips', camera, ...names }, body);
  }
}
