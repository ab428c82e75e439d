// Cameras as dmesh defines them (DESIGN.md, "Camera"): pinhole intrinsics in
// pixels, pixel (u, v) the sample at integer coordinates, OpenCV axes (x
// right, y down, z forward), pose camera-to-world as a unit quaternion
// [x, y, z, w] and the centre. World y is up, as in the simulator's rigs.
// Arithmetic in doubles; only the composed matrices go to the GPU.

/** @typedef {import('./protocol.js').CameraJson} CameraJson */
/** @typedef {[number, number, number]} Vec3 */

/** @param {Vec3} a @param {Vec3} b @returns {Vec3} */
export const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
/** @param {Vec3} a @param {Vec3} b @returns {Vec3} */
export const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
/** @param {Vec3} a @param {number} s @returns {Vec3} */
export const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
/** @param {Vec3} a @param {Vec3} b */
export const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
/** @param {Vec3} a @param {Vec3} b @returns {Vec3} */
export const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
/** @param {Vec3} a */
export const length = (a) => Math.hypot(a[0], a[1], a[2]);
/** @param {Vec3} a @returns {Vec3} */
export const normalize = (a) => { const l = length(a); return l > 0 ? scale(a, 1 / l) : [0, 0, 0]; };

/** Rotation matrix (rows of a 3x3, row-major) of a unit quaternion [x, y, z, w].
 * @param {number[]} q @returns {number[]} */
export function quatToMat(q) {
  const n = Math.hypot(q[0], q[1], q[2], q[3]) || 1;
  const [x, y, z, w] = q.map((c) => c / n);
  return [
    1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
    2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
    2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
  ];
}

/** Unit quaternion of a rotation matrix (row-major 3x3). @param {number[]} m @returns {number[]} */
export function matToQuat(m) {
  const [m00, m01, m02, m10, m11, m12, m20, m21, m22] = m;
  const t = m00 + m11 + m22;
  let q;
  if (t > 0) {
    const s = Math.sqrt(t + 1) * 2;
    q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, s / 4];
  } else if (m00 > m11 && m00 > m22) {
    const s = Math.sqrt(1 + m00 - m11 - m22) * 2;
    q = [s / 4, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s];
  } else if (m11 > m22) {
    const s = Math.sqrt(1 + m11 - m00 - m22) * 2;
    q = [(m01 + m10) / s, s / 4, (m12 + m21) / s, (m02 - m20) / s];
  } else {
    const s = Math.sqrt(1 + m22 - m00 - m11) * 2;
    q = [(m02 + m20) / s, (m12 + m21) / s, s / 4, (m10 - m01) / s];
  }
  const n = Math.hypot(...q);
  return q.map((c) => c / n);
}

/** Camera-to-world rotation of a camera at `eye` looking along `forward`
 * (world y up; straight up or down uses world z), as the simulator's look_at.
 * @param {Vec3} forward @returns {number[]} quaternion */
export function lookAlong(forward) {
  const f = normalize(forward);
  const up = length(cross(f, [0, 1, 0])) < 1e-9 ? [0, 0, 1] : [0, 1, 0];
  const x = normalize(cross(f, /** @type {Vec3} */ (up)));
  const y = cross(f, x);
  return matToQuat([x[0], y[0], f[0], x[1], y[1], f[1], x[2], y[2], f[2]]);
}

/** World direction of the camera's optical axis. @param {CameraJson} c @returns {Vec3} */
export function forwardOf(c) {
  const m = quatToMat(c.pose.rotation);
  return [m[2], m[5], m[8]];
}

/** @param {CameraJson} c @returns {Vec3} */
export const eyeOf = (c) => /** @type {Vec3} */ ([...c.pose.translation]);

/**
 * The point the reference views look at: the least-squares meeting point of
 * their optical axes (as the load generator's orbit), else a metre in front
 * of the first.
 * @param {CameraJson[]} cams @returns {Vec3}
 */
export function lookedAt(cams) {
  const a = [0, 0, 0, 0, 0, 0, 0, 0, 0];
  const b = [0, 0, 0];
  for (const c of cams) {
    const d = forwardOf(c);
    const t = eyeOf(c);
    for (let r = 0; r < 3; r++) {
      for (let k = 0; k < 3; k++) {
        const m = (r === k ? 1 : 0) - d[r] * d[k];
        a[3 * r + k] += m;
        b[r] += m * t[k];
      }
    }
  }
  const det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
  if (!(Math.abs(det) > 1e-9)) return add(eyeOf(cams[0]), forwardOf(cams[0]));
  const inv = [
    a[4] * a[8] - a[5] * a[7], a[2] * a[7] - a[1] * a[8], a[1] * a[5] - a[2] * a[4],
    a[5] * a[6] - a[3] * a[8], a[0] * a[8] - a[2] * a[6], a[2] * a[3] - a[0] * a[5],
    a[3] * a[7] - a[4] * a[6], a[1] * a[6] - a[0] * a[7], a[0] * a[4] - a[1] * a[3],
  ].map((v) => v / det);
  return [
    inv[0] * b[0] + inv[1] * b[1] + inv[2] * b[2],
    inv[3] * b[0] + inv[4] * b[1] + inv[5] * b[2],
    inv[6] * b[0] + inv[7] * b[1] + inv[8] * b[2],
  ];
}

/**
 * The first camera of a scene, framing the point all references look at
 * (`lookedAt`) from a reference that sees it: the one whose depth at its
 * principal point (`centerDepths[i]`, from the view summaries) is nearest
 * the point's own depth along its axis, so nothing stands between it and
 * the scene's centre (on a ring of views the first in the listing may stand
 * behind a wall). The camera steps back from that reference by 15 % to
 * frame the point, with the reference's vertical field of view. Without
 * depths it stands on the references' mean side, at their mean height and
 * distance.
 * @param {CameraJson[]} refs @param {number} width @param {number} height
 * @param {(number | null | undefined)[]} [centerDepths]
 * @returns {{camera: CameraJson, target: Vec3, reference: number | null}}
 */
export function firstCamera(refs, width, height, centerDepths = []) {
  const target = lookedAt(refs);
  /** @type {number | null} */
  let reference = null;
  let best = Infinity;
  refs.forEach((c, i) => {
    const z = centerDepths[i];
    const along = dot(sub(target, eyeOf(c)), forwardOf(c));
    if (typeof z !== 'number' || !(z > 0) || !(along > 0)) return;
    const miss = Math.abs(z - along) / along;
    if (miss < best) { best = miss; reference = i; }
  });
  let eye;
  if (reference !== null) {
    eye = add(target, scale(sub(eyeOf(refs[reference]), target), 1.15));
  } else {
    const radius = refs.reduce((s, c) => s + length(sub(eyeOf(c), target)), 0) / refs.length;
    const h = refs.reduce((s, c) => s + c.pose.translation[1], 0) / refs.length;
    const flat = Math.sqrt(Math.max(radius * radius - (h - target[1]) ** 2, radius * radius * 0.25));
    // On the side the references are: towards their mean centre, else the first's.
    const mean = scale(refs.reduce((s, c) => add(s, eyeOf(c)), /** @type {Vec3} */ ([0, 0, 0])), 1 / refs.length);
    let side = sub(mean, target);
    if (Math.hypot(side[0], side[2]) < 1e-6 * Math.max(radius, 1e-9)) side = sub(eyeOf(refs[0]), target);
    if (Math.hypot(side[0], side[2]) < 1e-12) side = [0, 0, 1];
    const d = Math.hypot(side[0], side[2]);
    eye = /** @type {Vec3} */ ([target[0] + (flat * side[0]) / d, h, target[2] + (flat * side[2]) / d]);
  }
  const ref = refs[reference ?? 0];
  const p = ref.projection.perspective;
  const fy = p ? p.fy * (height / ref.height) : height;
  const fx = p ? p.fx * (height / ref.height) : height;
  const camera = {
    width,
    height,
    projection: { perspective: { fx, fy, cx: (width - 1) / 2, cy: (height - 1) / 2 } },
    pose: { rotation: lookAlong(sub(target, eye)), translation: eye },
  };
  return { camera, target, reference };
}

/**
 * The same camera for an image of `width x height`: the vertical field of
 * view kept, the principal point kept relative to the image centre, so a
 * resize neither moves nor stretches the picture.
 * @param {CameraJson} c @param {number} width @param {number} height @returns {CameraJson}
 */
export function resized(c, width, height) {
  if (c.width === width && c.height === height) return c;
  const s = height / c.height;
  const p = c.projection.perspective;
  if (!p) throw new Error('the viewer needs a perspective camera');
  const cx = (p.cx + 0.5 - c.width / 2) * s + width / 2 - 0.5;
  const cy = (p.cy + 0.5 - c.height / 2) * s + height / 2 - 0.5;
  return { ...c, width, height, projection: { perspective: { fx: p.fx * s, fy: p.fy * s, cx, cy } } };
}

/**
 * A camera JSON as the server accepts it, or an error saying what is wrong.
 * @param {any} c @returns {CameraJson}
 */
export function checkCamera(c) {
  const finite = (/** @type {any} */ v) => typeof v === 'number' && Number.isFinite(v);
  if (!c || typeof c !== 'object') throw new Error('camera must be a JSON object');
  if (!(Number.isInteger(c.width) && c.width > 0 && Number.isInteger(c.height) && c.height > 0)) {
    throw new Error('camera width and height must be positive integers');
  }
  const p = c.projection && c.projection.perspective;
  if (!p || ![p.fx, p.fy, p.cx, p.cy].every(finite) || !(p.fx > 0 && p.fy > 0)) {
    throw new Error('camera projection must be {"perspective": {fx, fy, cx, cy}} with fx, fy > 0');
  }
  const pose = c.pose || { rotation: [0, 0, 0, 1], translation: [0, 0, 0] };
  if (!Array.isArray(pose.rotation) || pose.rotation.length !== 4 || !pose.rotation.every(finite) ||
    !(Math.hypot(...pose.rotation) > 1e-6)) {
    throw new Error('camera pose.rotation must be a quaternion [x, y, z, w]');
  }
  if (!Array.isArray(pose.translation) || pose.translation.length !== 3 || !pose.translation.every(finite)) {
    throw new Error('camera pose.translation must be [x, y, z]');
  }
  const n = Math.hypot(...pose.rotation);
  return {
    width: c.width,
    height: c.height,
    projection: { perspective: { fx: p.fx, fy: p.fy, cx: p.cx, cy: p.cy } },
    pose: { rotation: pose.rotation.map((/** @type {number} */ v) => v / n), translation: [...pose.translation] },
  };
}

/**
 * Column-major 4x4 taking points of the reference camera's frame into the
 * novel camera's frame: novel_from_world * world_from_reference.
 * @param {CameraJson} novel @param {CameraJson} ref @returns {Float32Array}
 */
export function novelFromRef(novel, ref) {
  const rn = quatToMat(novel.pose.rotation);
  const rr = quatToMat(ref.pose.rotation);
  const tn = novel.pose.translation;
  const tr = ref.pose.translation;
  // R = rn^T rr, t = rn^T (tr - tn)
  /** @type {number[]} */
  const r = [];
  for (let i = 0; i < 3; i++) {
    for (let j = 0; j < 3; j++) {
      r[3 * i + j] = rn[i] * rr[j] + rn[3 + i] * rr[3 + j] + rn[6 + i] * rr[6 + j];
    }
  }
  const d = [tr[0] - tn[0], tr[1] - tn[1], tr[2] - tn[2]];
  const t = [0, 1, 2].map((i) => rn[i] * d[0] + rn[3 + i] * d[1] + rn[6 + i] * d[2]);
  return new Float32Array([
    r[0], r[3], r[6], 0,
    r[1], r[4], r[7], 0,
    r[2], r[5], r[8], 0,
    t[0], t[1], t[2], 1,
  ]);
}

/** A world direction in the novel camera's frame. @param {CameraJson} novel @param {Vec3} d @returns {Vec3} */
export function toCameraDir(novel, d) {
  const m = quatToMat(novel.pose.rotation);
  return [
    m[0] * d[0] + m[3] * d[1] + m[6] * d[2],
    m[1] * d[0] + m[4] * d[1] + m[7] * d[2],
    m[2] * d[0] + m[5] * d[1] + m[8] * d[2],
  ];
}
