// @ts-check
// The 3D view's cameras as plain geometry (no DOM, no WebGL): matrices, and where an eye may sit.
// A third-person eye is pulled in front of any wall or obstacle between it and its chair, and no
// eye (third person or free) is ever inside a wall: it rises above it.

/** @typedef {[number, number, number]} V3 */
/** @typedef {import("./types.js").PageScene} PageScene */

export const MARGIN_M = 0.3;  // an eye keeps this far from a wall's face (more than the near plane)

/** @param {number} fovy @param {number} aspect @param {number} near @param {number} far */
export function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2);
  const nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}

/** @param {V3} a @param {V3} b @returns {V3} */
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
/** @param {V3} a @returns {V3} */
const norm = (a) => { const l = Math.hypot(...a) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };
/** @param {V3} a @param {V3} b @returns {V3} */
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
/** @param {V3} a @param {V3} b */
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

/** @param {V3} e @param {V3} t @param {V3} up */
export function lookAt(e, t, up) {
  const z = norm(sub(e, t));
  const x = norm(cross(up, z));
  const y = cross(z, x);
  return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, e), -dot(y, e), -dot(z, e), 1];
}

/** column-major 4x4 product a * b @param {number[]} a @param {number[]} b */
export function mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return o;
}

/**
 * Every solid of the scene as a polygon and its height: walls, obstacles, the lab's edge.
 * @param {PageScene} s @param {number} edge  the lab's edge's thickness (m) @param {number} edgeH  and height
 * @returns {{pts: number[][], h: number}[]}
 */
export function solids(s, edge, edgeH) {
  /** @param {number} x0 @param {number} y0 @param {number} x1 @param {number} y1 */
  const box = (x0, y0, x1, y1) => [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
  const out = s.walls.map((w) => ({ pts: w.corners.map((c) => [c[0], c[1]]), h: w.height }));
  for (const o of s.obstacles) out.push({ pts: box(o.x0, o.y0, o.x1, o.y1), h: o.height === undefined ? 1 : o.height });
  const t = edge;
  for (const b of [[-t, -t, s.width + t, 0], [-t, s.height, s.width + t, s.height + t], [-t, 0, 0, s.height], [s.width, 0, s.width + t, s.height]]) {
    out.push({ pts: box(b[0], b[1], b[2], b[3]), h: edgeH });
  }
  return out;
}

/** is (x, y) inside the polygon (even-odd) @param {number[][]} pts @param {number} x @param {number} y */
export function inside(pts, x, y) {
  let inn = false;
  for (let i = 0, j = pts.length - 1; i < pts.length; j = i++) {
    const [xi, yi] = pts[i];
    const [xj, yj] = pts[j];
    if ((yi > y) !== (yj > y) && x < ((xj - xi) * (y - yi)) / (yj - yi) + xi) inn = !inn;
  }
  return inn;
}

/**
 * The first crossing (0..1 along a -> b, in the plan) of the segment with a polygon's edges, or 1.
 * @param {number[][]} pts @param {number[]} a @param {number[]} b
 */
function firstCrossing(pts, a, b) {
  let best = 1;
  const dx = b[0] - a[0];
  const dy = b[1] - a[1];
  for (let i = 0; i < pts.length; i++) {
    const p = pts[i];
    const q = pts[(i + 1) % pts.length];
    const ex = q[0] - p[0];
    const ey = q[1] - p[1];
    const den = dx * ey - dy * ex;
    if (Math.abs(den) < 1e-12) continue;
    const t = ((p[0] - a[0]) * ey - (p[1] - a[1]) * ex) / den;
    const u = ((p[0] - a[0]) * dy - (p[1] - a[1]) * dx) / den;
    if (t >= 0 && t < best && u >= 0 && u <= 1) best = t;
  }
  return best;
}

/**
 * A third-person eye that wants to be at `eye`, looking at `from` (the chair): pulled towards the
 * chair in front of the first solid between them that is taller than the eye line there.
 * @param {{pts: number[][], h: number}[]} solid @param {V3} from @param {V3} eye @returns {V3}
 */
export function unblocked(solid, from, eye) {
  const len = Math.hypot(eye[0] - from[0], eye[1] - from[1]);
  if (len < 1e-9) return eye;
  let t = 1;
  for (const s of solid) {
    const c = firstCrossing(s.pts, from, eye);
    const z = from[2] + (eye[2] - from[2]) * c;
    if (c < t && s.h >= z - MARGIN_M) t = c;
  }
  if (t >= 1) return clearOf(solid, eye);
  const k = Math.max(0, t - MARGIN_M / len);
  return clearOf(solid, [from[0] + (eye[0] - from[0]) * k, from[1] + (eye[1] - from[1]) * k, from[2] + (eye[2] - from[2]) * k]);
}

/**
 * An eye never inside a solid: one that would be is lifted above it.
 * @param {{pts: number[][], h: number}[]} solid @param {V3} eye @returns {V3}
 */
export function clearOf(solid, eye) {
  let z = eye[2];
  for (const s of solid) if (z < s.h + MARGIN_M && inside(s.pts, eye[0], eye[1])) z = s.h + MARGIN_M;
  return [eye[0], eye[1], z];
}
