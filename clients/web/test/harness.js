// What the browser tests share: a real `dmesh serve` on a free loopback
// port, Debian's Chromium driven by playwright-core, the CPU client
// (`dmesh-client render`) as the reference, and image arithmetic.
//
// The binaries come from DMESH_BIN (default: the workspace's target/debug);
// a missing browser or binary fails the test, it never skips it.

import { spawn, execFile } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { promisify } from 'node:util';
import { PNG } from 'pngjs';
import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
export const ROOT = path.resolve(here, '../../..');
const BIN = process.env.DMESH_BIN || path.join(ROOT, 'target/debug');
export const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const run = promisify(execFile);

/** @param {string} name */
function binary(name) {
  const p = path.join(BIN, name);
  if (!fs.existsSync(p)) throw new Error(`${p} is missing: build it first (cargo build --workspace --bins)`);
  return p;
}

/** @type {(() => void)[]} what to undo when the test process exits */
const cleanups = [];
process.on('exit', () => cleanups.forEach((f) => f()));

/** A fresh temporary directory, removed at exit. */
export function tempDir(prefix = 'dmesh-web-') {
  const d = fs.mkdtempSync(path.join(os.tmpdir(), prefix));
  cleanups.push(() => fs.rmSync(d, { recursive: true, force: true }));
  return d;
}

/**
 * Starts `dmesh serve` on 127.0.0.1:0 with its own data directory and waits
 * for the address it prints.
 * @param {string[]} args extra arguments (e.g. --demo)
 * @returns {Promise<{url: string, stop: () => Promise<void>, data: string}>}
 */
export async function startServer(args = []) {
  const data = tempDir('dmesh-data-');
  const child = spawn(binary('dmesh'), ['serve', '--listen', '127.0.0.1:0', '--data', data, ...args], {
    stdio: ['ignore', 'ignore', 'pipe'],
  });
  let log = '';
  const url = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`dmesh serve printed no address in 120 s:\n${log}`)), 120_000);
    child.stderr.on('data', (chunk) => {
      log += chunk;
      const m = /listening on (http:\/\/[\d.:]+)\r?\n/.exec(log);
      if (m) { clearTimeout(timer); resolve(m[1]); }
    });
    child.on('exit', (code) => { clearTimeout(timer); reject(new Error(`dmesh serve exited (${code}):\n${log}`)); });
  });
  const stop = () => new Promise((resolve) => {
    if (child.exitCode !== null) { resolve(undefined); return; }
    child.once('exit', () => resolve(undefined));
    child.kill('SIGINT');
    setTimeout(() => child.kill('SIGKILL'), 5000).unref();
  });
  cleanups.push(() => child.kill('SIGKILL'));
  return { url: /** @type {string} */ (url), stop, data };
}

/** Headless Chromium as the README says: Debian's, no network, empty profile. */
export async function launch() {
  if (!fs.existsSync(CHROMIUM)) throw new Error(`${CHROMIUM} is missing: apt-get install -y chromium`);
  return chromium.launch({
    executablePath: CHROMIUM,
    args: ['--no-sandbox', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run'],
  });
}

/**
 * Opens the viewer and waits for its first frame (or its error).
 * @param {import('playwright-core').Browser} browser @param {string} url
 * @param {{width?: number, height?: number}} [viewport]
 */
export async function openViewer(browser, url, viewport = { width: 640, height: 480 }) {
  const page = await browser.newPage({ viewport: { width: viewport.width ?? 640, height: viewport.height ?? 480 }, deviceScaleFactor: 1 });
  /** @type {string[]} */
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  await page.goto(url);
  return { page, errors };
}

/** @param {import('playwright-core').Page} page */
export async function waitReady(page, timeout = 90_000) {
  await page.waitForFunction(() => /** @type {any} */ (window).dmeshReady || /** @type {any} */ (window).dmeshFailed, null, { timeout });
  const failed = await page.evaluate(() => /** @type {any} */ (window).dmeshFailed);
  if (failed) throw new Error(`the viewer failed: ${await page.evaluate(() => /** @type {any} */ (window).dmeshStats.error)}`);
}

/** The page's picture: RGB rows top down, covered mask, the camera drawn.
 * @param {import('playwright-core').Page} page */
export async function capture(page) {
  const c = await page.evaluate(() => /** @type {any} */ (window).dmeshCapture());
  if (!c) throw new Error('the viewer has nothing drawn to capture');
  return {
    width: c.width,
    height: c.height,
    rgb: new Uint8Array(Buffer.from(c.rgb, 'base64')),
    covered: new Uint8Array(Buffer.from(c.covered, 'base64')),
    camera: c.camera,
  };
}

/** Decodes a PNG to RGB. @param {string} file */
export function readPng(file) {
  const png = PNG.sync.read(fs.readFileSync(file));
  const rgb = new Uint8Array(png.width * png.height * 3);
  for (let k = 0; k < png.width * png.height; k++) {
    rgb[3 * k] = png.data[4 * k];
    rgb[3 * k + 1] = png.data[4 * k + 1];
    rgb[3 * k + 2] = png.data[4 * k + 2];
  }
  return { width: png.width, height: png.height, rgb };
}

/** Writes RGB as a PNG (for looking at what a test saw). @param {string} file
 * @param {{width: number, height: number, rgb: Uint8Array}} img */
export function writePng(file, img) {
  const png = new PNG({ width: img.width, height: img.height });
  for (let k = 0; k < img.width * img.height; k++) {
    png.data[4 * k] = img.rgb[3 * k];
    png.data[4 * k + 1] = img.rgb[3 * k + 1];
    png.data[4 * k + 2] = img.rgb[3 * k + 2];
    png.data[4 * k + 3] = 255;
  }
  fs.writeFileSync(file, PNG.sync.write(png));
}

/**
 * `dmesh-client render` of the same camera and detail: the CPU blend.
 * @param {string} server @param {string} scene @param {object} camera
 * @param {string[]} detail e.g. ['--tau', '1']
 */
export async function cpuRender(server, scene, camera, detail = ['--tau', '1']) {
  const dir = tempDir('dmesh-cpu-');
  const cam = path.join(dir, 'camera.json');
  fs.writeFileSync(cam, JSON.stringify(camera));
  const out = path.join(dir, 'out.png');
  const cov = path.join(dir, 'coverage.png');
  await run(binary('dmesh-client'), ['render', '--server', server, '--scene', scene, '--camera', cam, ...detail,
    '--out', out, '--coverage-out', cov, '--cache', path.join(dir, 'cache')]);
  const image = readPng(out);
  const coverage = readPng(cov);
  const covered = new Uint8Array(image.width * image.height);
  for (let k = 0; k < covered.length; k++) {
    covered[k] = coverage.rgb[3 * k] || coverage.rgb[3 * k + 1] || coverage.rgb[3 * k + 2] ? 1 : 0;
  }
  return { ...image, covered, coverage };
}

/**
 * PSNR (8-bit, mean of the R, G, B squared errors) over the pixels both cover.
 * @param {{rgb: Uint8Array, covered: Uint8Array}} a @param {{rgb: Uint8Array, covered: Uint8Array}} b
 */
export function psnr(a, b) {
  let se = 0;
  let n = 0;
  for (let k = 0; k < a.covered.length; k++) {
    if (!(a.covered[k] && b.covered[k])) continue;
    n++;
    for (let c = 0; c < 3; c++) {
      const d = a.rgb[3 * k + c] - b.rgb[3 * k + c];
      se += (d * d) / 3;
    }
  }
  if (n === 0) throw new Error('the images share no covered pixel');
  const mse = se / n;
  return { psnr: mse > 0 ? 10 * Math.log10((255 * 255) / mse) : Infinity, both: n };
}

/** @param {Uint8Array} mask */
export const count = (mask) => mask.reduce((s, v) => s + (v ? 1 : 0), 0);

/** The viewer's address for a state. @param {string} server @param {Record<string, string | number | object>} q */
export function viewerUrl(server, q) {
  const p = new URLSearchParams();
  for (const [k, v] of Object.entries(q)) p.set(k, typeof v === 'object' ? JSON.stringify(v) : String(v));
  return `${server}/?${p}`;
}

export const demoNovel = () => JSON.parse(fs.readFileSync(path.join(ROOT, 'examples/cameras/demo-novel.json'), 'utf8'));

/**
 * Uploads a view made in the test: depth `z(i, j)` (0 for invalid) as PFM,
 * colour `rgb(i, j)` as PNG, through `PUT /v1/scenes/{scene}/views/{view}`.
 * @param {string} server @param {string} scene @param {string} view @param {object} camera
 * @param {(i: number, j: number) => number} z @param {(i: number, j: number) => [number, number, number]} rgb
 */
export async function uploadView(server, scene, view, camera, z, rgb) {
  const { width: w, height: h } = /** @type {{width: number, height: number}} */ (camera);
  const header = Buffer.from(`Pf\n${w} ${h}\n-1.0\n`);
  const values = Buffer.alloc(4 * w * h);
  // PFM rows run bottom to top.
  for (let j = 0; j < h; j++) for (let i = 0; i < w; i++) values.writeFloatLE(z(i, j), 4 * ((h - 1 - j) * w + i));
  const png = new PNG({ width: w, height: h });
  for (let j = 0; j < h; j++) {
    for (let i = 0; i < w; i++) {
      const [r, g, b] = rgb(i, j);
      png.data.set([r, g, b, 255], 4 * (j * w + i));
    }
  }
  const form = new FormData();
  form.set('camera', JSON.stringify(camera));
  form.set('depth', new Blob([new Uint8Array(Buffer.concat([header, values]))]), 'depth.pfm');
  form.set('color', new Blob([new Uint8Array(PNG.sync.write(png))], { type: 'image/png' }), 'color.png');
  const r = await fetch(`${server}/v1/scenes/${scene}/views/${view}`, { method: 'PUT', body: form });
  if (r.status !== 201) throw new Error(`upload answered ${r.status}: ${await r.text()}`);
  return r.json();
}

/**
 * Runs `dmesh-client ARGS` and returns its standard output.
 * @param {string[]} args */
export async function client(args) {
  const { stdout } = await run(binary('dmesh-client'), args, { maxBuffer: 1 << 28 });
  return stdout;
}

/** POSTs a render request; `accept` picks the encoding. @param {string} server @param {string} scene
 * @param {object} body @param {string} [accept] */
export async function render(server, scene, body, accept = 'application/x-bincode') {
  const r = await fetch(`${server}/v1/scenes/${scene}/render`, {
    method: 'POST',
    headers: { 'content-type': 'application/json', accept },
    body: JSON.stringify(body),
  });
  if (!r.ok) throw new Error(`render answered ${r.status}: ${await r.text()}`);
  return accept === 'application/json' ? r.json() : r.arrayBuffer();
}
