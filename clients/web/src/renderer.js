// The epsilon-z-buffer blend of DMesh Sec. 6.3-6.4 in WebGL2, with Verlani
// et al.'s per-pixel cos^k weights (Sec. 3) and DMesh's relighting.
//
// Meshes of the compact stream (protocol 7) are drawn as the indexed
// triangle lists the decoder rebuilds (SwiftShader draws those about three
// times faster than strips); protocol 5's strips as served: TRIANGLE_STRIP
// over the served index buffer, whose restart marker (the largest value of
// its width) is WebGL2's fixed primitive restart index. Positions, projective texture coordinates and the
// rays are rebuilt in the vertex shader from (i, j, depth) and the reference
// camera; a cut triangle's parts (protocol 7) come as vertices of their own
// at float (u, v), so nothing spans a cut. Pixel (x, y) of the novel camera is the sample at integer image
// coordinates, as everywhere in dmesh: it lands on the centre of GL pixel
// (x, H - 1 - y).
//
// Pass 1: every selected view into one depth buffer, its linear z kept in an
// R32F target (nearest surface). Pass 2: each view again, fragments farther
// than (1 + eps_z) times that depth discarded, additive blending of
// (w_i rho rgb, w_i rho) into a float target (RGBA32F where float blending
// is there, else RGBA16F). Pass 3: normalise onto the canvas, filling
// seams of at most two pixels between covered pixels of one surface. The coverage
// view replaces pass 2 by a MAX blend of one channel per view and pass 3 by
// the palette of `dmesh-client render --coverage-out` (DMesh Fig. 19).

/** @typedef {import('./protocol.js').Strips} Strips */
/** @typedef {import('./protocol.js').CameraJson} CameraJson */
import { novelFromRef, toCameraDir, normalize } from './camera.js';

/** The coverage palette, the same as the CPU client's. */
export const PALETTE = [
  [230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200],
  [245, 130, 48], [145, 30, 180], [70, 240, 240], [240, 50, 230],
];

/** Relative depth difference per pixel below which a seam's two sides are one surface (`BlendOptions`). */
export const FILL_DEPTH_TOLERANCE = 0.05;

const NEAR = 1e-3;
const FAR = 1e4;

const VERTEX = `#version 300 es
layout(location = 0) in vec2 a_ij;
layout(location = 1) in float a_depth;
layout(location = 2) in vec2 a_normal;
layout(location = 3) in float a_rho;
uniform vec4 u_ref;          // fx, fy, cx, cy (orthographic: sx, sy, cx, cy)
uniform bool u_ortho;
uniform mat4 u_novelFromRef;
uniform vec4 u_novel;        // fx, fy, cx, cy of the novel camera
uniform vec2 u_size;         // its width, height in pixels
out vec3 v_uvz;              // (i z, j z, z) of the reference: affine in space
out float v_z;               // depth in the novel camera
out float v_rho;
out vec3 v_pos;              // point in the novel camera frame
out vec3 v_normal;           // normal in the novel camera frame
vec3 octDecode(vec2 n) {
  vec2 f = n / 255.0 * 2.0 - 1.0;
  float z = 1.0 - abs(f.x) - abs(f.y);
  if (z < 0.0) f = (1.0 - abs(f.yx)) * vec2(f.x < 0.0 ? -1.0 : 1.0, f.y < 0.0 ? -1.0 : 1.0);
  return normalize(vec3(f, z));
}
void main() {
  float d = a_depth;
  vec3 local = u_ortho
    ? vec3((a_ij.x - u_ref.z) * u_ref.x, (a_ij.y - u_ref.w) * u_ref.y, d)
    : vec3((a_ij.x - u_ref.z) * d / u_ref.x, (a_ij.y - u_ref.w) * d / u_ref.y, d);
  vec3 p = (u_novelFromRef * vec4(local, 1.0)).xyz;
  v_uvz = vec3(a_ij, 1.0) * d;
  v_z = p.z;
  v_rho = a_rho;
  v_pos = p;
  v_normal = mat3(u_novelFromRef) * octDecode(a_normal);
  float n = ${NEAR.toExponential()}, f = ${FAR.toExponential()};
  gl_Position = vec4(
    (u_novel.x * p.x + (u_novel.z + 0.5) * p.z) * 2.0 / u_size.x - p.z,
    p.z - (u_novel.y * p.y + (u_novel.w + 0.5) * p.z) * 2.0 / u_size.y,
    (f + n) / (f - n) * p.z - 2.0 * f * n / (f - n),
    p.z);
}`;

const DEPTH = `#version 300 es
precision highp float;
in float v_z;
out vec4 o_z;
void main() { o_z = vec4(v_z, 0.0, 0.0, 1.0); }`;

const ACCUMULATE = `#version 300 es
precision highp float;
in vec3 v_uvz;
in float v_z;
in float v_rho;
in vec3 v_pos;
in vec3 v_normal;
uniform highp sampler2D u_zbuf;
uniform sampler2D u_color;
uniform vec2 u_refSize;
uniform vec3 u_refEye;       // reference centre in the novel camera frame
uniform float u_weight;
uniform float u_epsZ;
uniform float u_cosK;        // < 0: off
uniform bool u_relight;
uniform vec3 u_light;        // unit, towards the light, novel camera frame
uniform float u_shininess;
uniform int u_view;          // coverage: the view's channel, or -1
layout(location = 0) out vec4 o_accum;
layout(location = 1) out vec4 o_cover;
void main() {
  float zmin = texelFetch(u_zbuf, ivec2(gl_FragCoord.xy), 0).r;
  if (v_z > zmin * (1.0 + u_epsZ)) discard;
  if (u_view >= 0) {
    vec4 bits = vec4(0.0);
    bits[u_view % 4] = 1.0;
    o_accum = u_view < 4 ? bits : vec4(0.0);
    o_cover = u_view < 4 ? vec4(0.0) : bits;
    return;
  }
  vec2 uv = v_uvz.xy / v_uvz.z;
  vec3 c = texture(u_color, (uv + 0.5) / u_refSize).rgb;
  float w = u_weight * max(v_rho, 1e-3);
  vec3 toNovel = normalize(-v_pos);
  if (u_cosK >= 0.0) {
    vec3 toRef = normalize(u_refEye - v_pos);
    w *= pow(max(dot(toRef, toNovel), 0.0), u_cosK);
  }
  if (u_relight) {
    vec3 n = normalize(v_normal);
    float nl = dot(n, u_light);
    vec3 r = 2.0 * nl * n - u_light;
    // No highlight from a light behind the surface.
    float spec = nl > 0.0 ? pow(max(dot(r, toNovel), 0.0), u_shininess) : 0.0;
    c = c * (0.3 + 0.7 * max(nl, 0.0)) + vec3(0.3 * spec);
  }
  o_accum = vec4(c * w, w);
  o_cover = vec4(0.0);
}`;

const QUAD = `#version 300 es
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}`;

// Pass 3, with the seam fill of `clients/src/holes.rs`: an uncovered pixel
// between covered pixels of one surface, at most u_fill pixels of gap along
// a row, a column or a diagonal (depths within u_fillTol per pixel between
// them, or the step explained by the surface's own gradient on both sides),
// takes their colour interpolated; the narrowest gap wins, in the
// CPU client's order (GL rows run bottom up, so its diagonals swap).
const NORMALISE = `#version 300 es
precision highp float;
uniform highp sampler2D u_accum;
uniform highp sampler2D u_z;
uniform int u_fill;
uniform float u_fillTol;
out vec4 o_color;
bool covered(ivec2 p, ivec2 size, out vec3 c, out float z) {
  if (p.x < 0 || p.y < 0 || p.x >= size.x || p.y >= size.y) return false;
  vec4 a = texelFetch(u_accum, p, 0);
  if (a.a <= 0.0) return false;
  c = a.rgb / a.a;
  z = texelFetch(u_z, p, 0).r;
  return true;
}
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(u_accum, p, 0);
  if (a.a > 0.0 || u_fill <= 0) {
    o_color = vec4(a.a > 0.0 ? a.rgb / a.a : vec3(0.0), 1.0);
    return;
  }
  ivec2 size = textureSize(u_accum, 0);
  ivec2 dirs[4] = ivec2[4](ivec2(1, 0), ivec2(0, 1), ivec2(1, -1), ivec2(1, 1));
  int best = 1000;
  vec3 fill = vec3(0.0);
  for (int k = 0; k < 4; k++) {
    ivec2 d = dirs[k];
    int ta = 0, tb = 0;
    vec3 ca = vec3(0.0), cb = vec3(0.0);
    float za = 0.0, zb = 0.0;
    for (int t = 1; t <= 2; t++) {
      if (t > u_fill) break;
      vec3 c; float z;
      if (ta == 0 && covered(p + t * d, size, c, z)) { ta = t; ca = c; za = z; }
      if (tb == 0 && covered(p - t * d, size, c, z)) { tb = t; cb = c; zb = z; }
    }
    if (ta == 0 || tb == 0) continue;
    int gap = ta + tb - 1;
    if (gap > u_fill) continue;
    float tol = u_fillTol * min(za, zb);
    float steps = float(ta + tb);
    if (abs(za - zb) > tol * steps) {
      // Or the surface's own gradient, read one pixel out on each side, explains the step.
      vec3 c2; float za2, zb2;
      if (!covered(p + (ta + 1) * d, size, c2, za2) || !covered(p - (tb + 1) * d, size, c2, zb2)) continue;
      float sa = za2 - za, sb = zb - zb2;
      if (abs(sa - sb) > tol || abs((za - zb) - 0.5 * (sa + sb) * steps) > tol * steps) continue;
    }
    if (gap < best) {
      best = gap;
      fill = (ca * float(tb) + cb * float(ta)) / float(ta + tb);
    }
  }
  o_color = vec4(fill, 1.0);
}`;

// Written out per channel: SwiftShader runs a loop with dynamic vector
// indexing about a hundred times slower.
const COVERAGE = `#version 300 es
precision highp float;
uniform highp sampler2D u_accum;
uniform highp sampler2D u_cover;
uniform vec3 u_palette[8];
out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = step(0.5, texelFetch(u_accum, p, 0));
  vec4 b = step(0.5, texelFetch(u_cover, p, 0));
  vec3 sum = a.x * u_palette[0] + a.y * u_palette[1] + a.z * u_palette[2] + a.w * u_palette[3]
    + b.x * u_palette[4] + b.y * u_palette[5] + b.z * u_palette[6] + b.w * u_palette[7];
  float n = dot(a, vec4(1.0)) + dot(b, vec4(1.0));
  o_color = vec4(n > 0.0 ? floor(sum / n) / 255.0 : vec3(0.0), 1.0);
}`;

const LINE = `#version 300 es
precision highp float;
uniform vec3 u_lineColor;
out vec4 o_color;
void main() { o_color = vec4(u_lineColor, 1.0); }`;

/** A GL error that the page shows in plain words. */
/**
 * A mesh with its cut triangles' parts (the compact stream, protocol 7)
 * appended as vertices of their own, so nothing spans a cut: positions as
 * floats, since a crossing lies between samples. A mesh without parts is
 * drawn as it came.
 * @param {any} s
 */
function withParts(s) {
  const p = s.parts;
  if (!p || p.depth.length === 0) return s;
  const n = s.vertexCount;
  const m = p.depth.length;
  const ij = new Float32Array(2 * (n + m));
  ij.set(s.ij);
  ij.set(p.uv, 2 * n);
  const join = (/** @type {any} */ a, /** @type {any} */ b) => { const out = new a.constructor(a.length + b.length); out.set(a); out.set(b, a.length); return out; };
  const indices = n + m < 65535 ? new Uint16Array(s.indices.length + m) : new Uint32Array(s.indices.length + m);
  indices.set(s.indices);
  for (let k = 0; k < m; k++) indices[s.indices.length + k] = n + k;
  return { ...s, ij, depth: join(s.depth, p.depth), normal: join(s.normal, p.normal), rho: join(s.rho, p.rho), indices };
}

export class RenderError extends Error {}

/**
 * @typedef {object} GpuView
 * @property {WebGLVertexArrayObject} vao
 * @property {WebGLBuffer[]} buffers
 * @property {number} count
 * @property {number} type
 * @property {number} primitive  TRIANGLES or TRIANGLE_STRIP
 * @property {WebGLBuffer | null} lines
 * @property {WebGLVertexArrayObject | null} lineVao
 * @property {number} lineCount
 */

/**
 * @typedef {object} DrawView
 * @property {Strips} strips
 * @property {number} weight
 * @property {string} color_url
 * @property {Uint32Array | null} lines
 */

/**
 * @typedef {object} DrawOptions
 * @property {CameraJson} camera       the novel camera (its size: the drawing buffer)
 * @property {'blend' | 'coverage' | 'wireframe'} mode
 * @property {number} epsZ
 * @property {number | null} cosK
 * @property {[number, number, number] | null} light   world direction towards the light
 * @property {number} shininess
 * @property {number} fillGaps    seams of at most this many pixels are filled (0: none)
 */

/** @typedef {{p: WebGLProgram, u: Record<string, WebGLUniformLocation | null>}} Program */
/**
 * @typedef {object} Targets
 * @property {number} w
 * @property {number} h
 * @property {WebGLTexture} z
 * @property {WebGLTexture} accum
 * @property {WebGLTexture} cover
 * @property {WebGLRenderbuffer} depth
 * @property {WebGLFramebuffer} fbDepth
 * @property {WebGLFramebuffer} fbAccum
 */

/** Set by `init` (again after a lost context). */
const UNSET = /** @type {any} */ (null);

export class Renderer {
  /** @param {HTMLCanvasElement} canvas */
  constructor(canvas) {
    this.canvas = canvas;
    /** @type {WebGL2RenderingContext} */
    this.gl = UNSET;
    /** @type {Program} */
    this.depthProgram = UNSET;
    /** @type {Program} */
    this.accumProgram = UNSET;
    /** @type {Program} */
    this.normaliseProgram = UNSET;
    /** @type {Program} */
    this.coverageProgram = UNSET;
    /** @type {Program} */
    this.lineProgram = UNSET;
    /** @type {Targets | null} */
    this.targets = null;
    /** @type {Map<string, WebGLTexture>} */
    this.textures = new Map();
    /** @type {GpuView[]} */
    this.gpu = [];
    this.floatBlend = false;
    this.accumFormat = '';
    /** @type {Map<string, ImageBitmap>} colour images by URL, kept across a lost context */
    this.images = new Map();
    /** @type {DrawView[]} */
    this.views = [];
    this.lost = false;
    this.init();
  }

  init() {
    const gl = this.canvas.getContext('webgl2', { antialias: false, depth: false, alpha: false, preserveDrawingBuffer: false });
    if (!gl) throw new RenderError('This browser has no WebGL2, which the viewer needs to draw the meshes.');
    this.gl = gl;
    if (!gl.getExtension('EXT_color_buffer_float')) {
      throw new RenderError('This browser cannot render to float buffers (EXT_color_buffer_float), which the blend needs.');
    }
    this.floatBlend = !!gl.getExtension('EXT_float_blend');
    this.accumFormat = this.floatBlend ? 'RGBA32F' : 'RGBA16F';
    const program = (/** @type {string} */ vs, /** @type {string} */ fs) => {
      const p = /** @type {WebGLProgram} */ (gl.createProgram());
      for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
        const s = /** @type {WebGLShader} */ (gl.createShader(/** @type {number} */ (type)));
        gl.shaderSource(s, /** @type {string} */ (src));
        gl.compileShader(s);
        if (!gl.getShaderParameter(s, gl.COMPILE_STATUS) && !gl.isContextLost()) {
          throw new RenderError(`shader: ${gl.getShaderInfoLog(s)}`);
        }
        gl.attachShader(p, s);
      }
      gl.linkProgram(p);
      if (!gl.getProgramParameter(p, gl.LINK_STATUS) && !gl.isContextLost()) {
        throw new RenderError(`program: ${gl.getProgramInfoLog(p)}`);
      }
      /** @type {Record<string, WebGLUniformLocation | null>} */
      const u = {};
      const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS) || 0;
      for (let k = 0; k < n; k++) {
        const info = gl.getActiveUniform(p, k);
        if (info) u[info.name.replace(/\[0\]$/, '')] = gl.getUniformLocation(p, info.name);
      }
      return { p, u };
    };
    this.depthProgram = program(VERTEX, DEPTH);
    this.accumProgram = program(VERTEX, ACCUMULATE);
    this.normaliseProgram = program(QUAD, NORMALISE);
    this.coverageProgram = program(QUAD, COVERAGE);
    this.lineProgram = program(VERTEX, LINE);
    this.textures = new Map();
    for (const [url, image] of this.images) this.uploadTexture(url, image);
    this.gpu = this.views.map((v) => this.uploadView(v));
    this.targets = null;
    this.lost = false;
  }

  /** Drops everything GL; `init` builds it again from what is held. */
  contextLost() {
    this.lost = true;
    this.targets = null;
  }

  /** @param {string} url @param {ImageBitmap} image */
  uploadTexture(url, image) {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    this.images.set(url, image);
    const old = this.textures.get(url);
    if (old) gl.deleteTexture(old);
    const t = /** @type {WebGLTexture} */ (gl.createTexture());
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, image);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    this.textures.set(url, t);
  }

  /** @param {DrawView} v @returns {GpuView} */
  uploadView(v) {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    const s = withParts(v.strips);
    const vao = /** @type {WebGLVertexArrayObject} */ (gl.createVertexArray());
    gl.bindVertexArray(vao);
    const attribute = (/** @type {number} */ loc, /** @type {ArrayBufferView} */ data, /** @type {number} */ size,
      /** @type {number} */ type, /** @type {boolean} */ norm) => {
      const b = /** @type {WebGLBuffer} */ (gl.createBuffer());
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, type, norm, 0, 0);
      return b;
    };
    const ijType = s.ij instanceof Float32Array ? gl.FLOAT : gl.UNSIGNED_SHORT;
    const buffers = [
      attribute(0, s.ij, 2, ijType, false),
      attribute(1, s.depth, 1, gl.FLOAT, false),
      attribute(2, s.normal, 2, gl.UNSIGNED_BYTE, false),
      attribute(3, s.rho, 1, gl.UNSIGNED_BYTE, true),
    ];
    const ib = /** @type {WebGLBuffer} */ (gl.createBuffer());
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, s.indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    buffers.push(ib);
    let lines = null;
    let lineVao = null;
    if (v.lines) {
      // The wireframe's own vertex array over the same attributes, so its
      // element buffer never replaces the strips'.
      lineVao = /** @type {WebGLVertexArrayObject} */ (gl.createVertexArray());
      gl.bindVertexArray(lineVao);
      [[0, 2, ijType, false], [1, 1, gl.FLOAT, false], [2, 2, gl.UNSIGNED_BYTE, false], [3, 1, gl.UNSIGNED_BYTE, true]]
        .forEach(([loc, size, type, norm], k) => {
          gl.bindBuffer(gl.ARRAY_BUFFER, buffers[k]);
          gl.enableVertexAttribArray(/** @type {number} */ (loc));
          gl.vertexAttribPointer(/** @type {number} */ (loc), /** @type {number} */ (size), /** @type {number} */ (type), /** @type {boolean} */ (norm), 0, 0);
        });
      lines = /** @type {WebGLBuffer} */ (gl.createBuffer());
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, lines);
      gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, v.lines, gl.STATIC_DRAW);
      gl.bindVertexArray(null);
    }
    return {
      vao, buffers, count: s.indices.length,
      type: s.indices instanceof Uint16Array ? gl.UNSIGNED_SHORT : gl.UNSIGNED_INT,
      // The compact stream's meshes arrive as indexed triangles, protocol 5's as strips.
      primitive: s.mode === 'triangles' ? gl.TRIANGLES : gl.TRIANGLE_STRIP,
      lines, lineVao, lineCount: v.lines ? v.lines.length : 0,
    };
  }

  /** Replaces the held meshes. @param {DrawView[]} views */
  setViews(views) {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    if (!this.lost) {
      for (const g of this.gpu) {
        g.buffers.forEach((b) => gl.deleteBuffer(b));
        if (g.lines) gl.deleteBuffer(g.lines);
        if (g.lineVao) gl.deleteVertexArray(g.lineVao);
        gl.deleteVertexArray(g.vao);
      }
    }
    this.views = views;
    this.gpu = this.lost ? [] : views.map((v) => this.uploadView(v));
  }

  /** @param {number} w @param {number} h */
  ensureTargets(w, h) {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    if (this.targets && this.targets.w === w && this.targets.h === h) return this.targets;
    if (this.targets) {
      const t = this.targets;
      [t.z, t.accum, t.cover].forEach((x) => gl.deleteTexture(x));
      gl.deleteRenderbuffer(t.depth);
      [t.fbDepth, t.fbAccum].forEach((x) => gl.deleteFramebuffer(x));
    }
    const texture = (/** @type {number} */ format) => {
      const t = /** @type {WebGLTexture} */ (gl.createTexture());
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.texStorage2D(gl.TEXTURE_2D, 1, format, w, h);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      return t;
    };
    const z = texture(gl.R32F);
    const accum = texture(this.floatBlend ? gl.RGBA32F : gl.RGBA16F);
    const cover = texture(gl.RGBA8);
    const depth = /** @type {WebGLRenderbuffer} */ (gl.createRenderbuffer());
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, w, h);
    const fbDepth = /** @type {WebGLFramebuffer} */ (gl.createFramebuffer());
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbDepth);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, z, 0);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    const check = (/** @type {string} */ what) => {
      const s = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
      if (s !== gl.FRAMEBUFFER_COMPLETE && !gl.isContextLost()) throw new RenderError(`${what} framebuffer incomplete (0x${s.toString(16)})`);
    };
    check('depth');
    const fbAccum = /** @type {WebGLFramebuffer} */ (gl.createFramebuffer());
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbAccum);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, accum, 0);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT1, gl.TEXTURE_2D, cover, 0);
    gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
    check('accumulation');
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    this.targets = { w, h, z, accum, cover, depth, fbDepth, fbAccum };
    return this.targets;
  }

  /** @param {Program} prog @param {CameraJson} novel @param {Strips} s */
  setCameraUniforms(prog, novel, s) {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    const u = prog.u;
    const ref = s.camera;
    const rp = ref.projection.perspective || ref.projection.orthographic;
    const rv = /** @type {{cx: number, cy: number}} */ (rp);
    const a = 'fx' in rv ? /** @type {any} */ (rv).fx : /** @type {any} */ (rv).sx;
    const b = 'fy' in rv ? /** @type {any} */ (rv).fy : /** @type {any} */ (rv).sy;
    gl.uniform4f(u.u_ref, a, b, rv.cx, rv.cy);
    gl.uniform1i(u.u_ortho, ref.projection.orthographic ? 1 : 0);
    gl.uniformMatrix4fv(u.u_novelFromRef, false, novelFromRef(novel, ref));
    const np = /** @type {{fx: number, fy: number, cx: number, cy: number}} */ (novel.projection.perspective);
    gl.uniform4f(u.u_novel, np.fx, np.fy, np.cx, np.cy);
    gl.uniform2f(u.u_size, novel.width, novel.height);
  }

  /**
   * Draws the held meshes for `o.camera`. Returns false when the context is lost.
   * @param {DrawOptions} o
   */
  draw(o) {
    if (this.lost) return false;
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    const { width: w, height: h } = o.camera;
    const t = this.ensureTargets(w, h);
    gl.viewport(0, 0, w, h);
    gl.disable(gl.CULL_FACE);
    // Pass 1: nearest depth of all views.
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbDepth);
    gl.clearBufferfv(gl.COLOR, 0, [1e30, 0, 0, 1]);
    gl.clearBufferfv(gl.DEPTH, 0, [1]);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(true);
    gl.disable(gl.BLEND);
    gl.useProgram(this.depthProgram.p);
    this.views.forEach((v, k) => {
      this.setCameraUniforms(this.depthProgram, o.camera, v.strips);
      const g = this.gpu[k];
      gl.bindVertexArray(g.vao);
      gl.drawElements(g.primitive, g.count, g.type, 0);
    });
    // Pass 2: accumulate what lies within eps_z of it.
    gl.disable(gl.DEPTH_TEST);
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbAccum);
    gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]);
    gl.clearBufferfv(gl.COLOR, 1, [0, 0, 0, 0]);
    gl.enable(gl.BLEND);
    const coverage = o.mode === 'coverage';
    gl.blendEquation(coverage ? gl.MAX : gl.FUNC_ADD);
    gl.blendFunc(gl.ONE, gl.ONE);
    const ap = this.accumProgram;
    gl.useProgram(ap.p);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, t.z);
    gl.uniform1i(ap.u.u_zbuf, 0);
    gl.uniform1i(ap.u.u_color, 1);
    gl.uniform1f(ap.u.u_epsZ, o.epsZ);
    gl.uniform1f(ap.u.u_cosK, o.cosK === null ? -1 : o.cosK);
    gl.uniform1i(ap.u.u_relight, o.light ? 1 : 0);
    gl.uniform3fv(ap.u.u_light, toCameraDir(o.camera, normalize(o.light || [0, 1, 0])));
    gl.uniform1f(ap.u.u_shininess, o.shininess);
    this.views.forEach((v, k) => {
      this.setCameraUniforms(ap, o.camera, v.strips);
      const ref = v.strips.camera;
      const m = novelFromRef(o.camera, ref);
      gl.uniform3f(ap.u.u_refEye, m[12], m[13], m[14]);
      gl.uniform2f(ap.u.u_refSize, ref.width, ref.height);
      gl.uniform1f(ap.u.u_weight, v.weight);
      gl.uniform1i(ap.u.u_view, coverage ? Math.min(k, 7) : -1);
      gl.activeTexture(gl.TEXTURE1);
      gl.bindTexture(gl.TEXTURE_2D, this.textures.get(v.color_url) || null);
      const g = this.gpu[k];
      gl.bindVertexArray(g.vao);
      gl.drawElements(g.primitive, g.count, g.type, 0);
    });
    gl.disable(gl.BLEND);
    gl.blendEquation(gl.FUNC_ADD);
    // Pass 3: normalise onto the canvas.
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const np = coverage ? this.coverageProgram : this.normaliseProgram;
    gl.useProgram(np.p);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, t.accum);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, coverage ? t.cover : t.z);
    gl.uniform1i(np.u.u_accum, 0);
    if (coverage) {
      gl.uniform1i(np.u.u_cover, 1);
      gl.uniform3fv(np.u.u_palette, PALETTE.flat());
    } else {
      gl.uniform1i(np.u.u_z, 1);
      gl.uniform1i(np.u.u_fill, o.fillGaps);
      gl.uniform1f(np.u.u_fillTol, FILL_DEPTH_TOLERANCE);
    }
    gl.bindVertexArray(null);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    if (o.mode === 'wireframe') {
      const lp = this.lineProgram;
      gl.useProgram(lp.p);
      this.views.forEach((v, k) => {
        const g = this.gpu[k];
        if (!g.lines) return;
        this.setCameraUniforms(lp, o.camera, v.strips);
        gl.uniform3fv(lp.u.u_lineColor, PALETTE[k % 8].map((c) => c / 255));
        gl.bindVertexArray(g.lineVao);
        gl.drawElements(gl.LINES, g.lineCount, gl.UNSIGNED_INT, 0);
      });
    }
    gl.bindVertexArray(null);
    return true;
  }

  /** Waits until the GPU has finished (one pixel read back): draw times are honest. */
  finish() {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
  }

  /**
   * The picture as the CPU client writes it (rows top to bottom, RGB) and
   * which pixels any view covered; call right after `draw`.
   */
  capture() {
    const gl = /** @type {WebGL2RenderingContext} */ (this.gl);
    const t = /** @type {NonNullable<Renderer['targets']>} */ (this.targets);
    const { w, h } = t;
    const rgba = new Uint8Array(4 * w * h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const acc = new Float32Array(4 * w * h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbAccum);
    gl.readBuffer(gl.COLOR_ATTACHMENT0);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, acc);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const rgb = new Uint8Array(3 * w * h);
    const covered = new Uint8Array(w * h);
    for (let y = 0; y < h; y++) {
      const gy = h - 1 - y;
      for (let x = 0; x < w; x++) {
        const s = gy * w + x;
        const d = y * w + x;
        rgb[3 * d] = rgba[4 * s];
        rgb[3 * d + 1] = rgba[4 * s + 1];
        rgb[3 * d + 2] = rgba[4 * s + 2];
        covered[d] = acc[4 * s] + acc[4 * s + 1] + acc[4 * s + 2] + acc[4 * s + 3] > 0 ? 1 : 0;
      }
    }
    return { width: w, height: h, rgb, covered };
  }
}
