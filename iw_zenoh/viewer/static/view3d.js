// @ts-check
// The 3D view in raw WebGL (no library): a lit scene a person can drive by. A sun and a sky light
// shade every face, distance fades into the sky; the floor carries a 1 m grid (every 5 m brighter),
// so speed and distance show; walls, obstacles, doors, beacons and targets are solids of their own
// colours; each chair is a low-poly wheelchair in its state's colour (or its type's model file,
// models.js). First person from a chair (the one followed: driven, else selected, else the first),
// third person behind it (pulled in front of any wall between, camera.js), or a free camera (drag
// to turn, shift-drag or right-drag to pan, wheel to zoom, W A S D to move), never inside a wall.
// Between two states the robots move on along their last motion, drawn every animation frame while
// they do; the drawing's resolution drops while frames cost too much (motion.js). No multisampling:
// in software WebGL it tripled a frame's cost (1280x728: 81 ms against 24 ms, loaded machine).
import { STATE_COLOURS, COLOUR, rgb } from "./palette.js";
import { perspective, lookAt, mul, solids, unblocked, clearOf } from "./camera.js";
import { CHAIR_BOXES, CHAIR_WHEELS, fitted, loadModels } from "./models.js";
import { Motion, Resolution } from "./motion.js";

/** @typedef {import("./camera.js").V3} V3 */
/** @typedef {{buf: WebGLBuffer | null, count: number}} Buf */

const EYE_M = 1.2;             // first person: eyes this high, at the chair's centre of movement
const BEHIND_M = 4.0;          // third person: this far behind
const ABOVE_M = 3.0;           // and this high
const DOOR_M = 2.0;            // a door's height
const SIMPLE_PAST = 150;       // past this many robots, each is its outline extruded (not a chair model)
const MOVING_MS = 1000 / 40;  // robots carried on between states are drawn at most 40 times a second
const FRAME_SLACK_MS = 4;      // a frame this early is on time (animation frames come every 16.7 ms)
const SKY = [0.55, 0.66, 0.78];
const FLOOR = [0.42, 0.44, 0.47];
const GRID = [0.3, 0.32, 0.35];
const GRID_MAJOR = [0.62, 0.64, 0.67];
const WALL = [0.78, 0.75, 0.68];
const OBSTACLE = [0.85, 0.45, 0.18];
const BEACON = rgb(COLOUR.beacon);
const TARGET = rgb(COLOUR.target);
const DOOR_RGB = rgb(COLOUR.door);
const EDGE = [0.6, 0.62, 0.68];
const SEAT = [0.16, 0.17, 0.2];
const WHEEL = [0.1, 0.1, 0.11];
const EDGE_M = 1.0;            // the lab's edge (a wall to the collision check) drawn this high
const EDGE_THICK_M = 0.1;
const STATE_RGB = /** @type {Record<string, number[]>} */ (Object.fromEntries(Object.entries(STATE_COLOURS).map(([k, v]) => [k, rgb(v)])));

const VS = `
attribute vec3 p; attribute vec3 n; attribute vec3 c;
uniform mat4 m; uniform vec3 eye;
varying vec3 vc; varying float dist;
void main() {
  gl_Position = m * vec4(p, 1.0);
  vec3 N = normalize(n);
  float sun = max(dot(N, normalize(vec3(0.45, 0.3, 0.84))), 0.0);
  float sky = 0.5 + 0.5 * N.z;
  vc = c * (0.3 + 0.25 * sky + 0.6 * sun);
  dist = distance(p, eye);
}`;
const FS = `precision mediump float;
uniform vec3 skyc; uniform float fog;
varying vec3 vc; varying float dist;
void main() { gl_FragColor = vec4(mix(vc, skyc, 0.55 * clamp(dist / fog, 0.0, 1.0)), 1.0); }`;

/**
 * A polygon extruded from z0 to z1 (sides facing out whatever its winding; top facing up).
 * @param {number[]} out @param {number[][]} pts @param {number} z0 @param {number} z1 @param {number[]} c
 */
function prism(out, pts, z0, z1, c) {
  /** @param {number} x @param {number} y @param {number} z @param {number} nx @param {number} ny @param {number} nz */
  const push = (x, y, z, nx, ny, nz) => { out.push(x, y, z, nx, ny, nz, c[0], c[1], c[2]); };
  let area = 0;
  for (let i = 0; i < pts.length; i++) { const a = pts[i]; const b = pts[(i + 1) % pts.length]; area += a[0] * b[1] - b[0] * a[1]; }
  const s = area >= 0 ? 1 : -1;
  for (let i = 0; i < pts.length; i++) {
    const [ax, ay] = pts[i];
    const [bx, by] = pts[(i + 1) % pts.length];
    const nx = s * (by - ay);
    const ny = s * (ax - bx);
    push(ax, ay, z0, nx, ny, 0); push(bx, by, z0, nx, ny, 0); push(bx, by, z1, nx, ny, 0);
    push(ax, ay, z0, nx, ny, 0); push(bx, by, z1, nx, ny, 0); push(ax, ay, z1, nx, ny, 0);
  }
  for (let i = 1; i + 1 < pts.length; i++) {
    push(pts[0][0], pts[0][1], z1, 0, 0, 1); push(pts[i][0], pts[i][1], z1, 0, 0, 1); push(pts[i + 1][0], pts[i + 1][1], z1, 0, 0, 1);
  }
}

/** @param {number} x0 @param {number} y0 @param {number} x1 @param {number} y1 */
function box(x0, y0, x1, y1) { return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]; }

/** @param {number} x @param {number} y @param {number} r @param {number} sides */
function disc(x, y, r, sides) {
  return Array.from({ length: sides }, (_, k) => [x + r * Math.cos((2 * Math.PI * k) / sides), y + r * Math.sin((2 * Math.PI * k) / sides)]);
}

/** triangles (x, y, z nine a triangle) into the buffer, with their face normals @param {number[]} out @param {ArrayLike<number>} t @param {number[]} c */
function triangles(out, t, c) {
  for (let i = 0; i + 8 < t.length; i += 9) {
    const ux = t[i + 3] - t[i]; const uy = t[i + 4] - t[i + 1]; const uz = t[i + 5] - t[i + 2];
    const vx = t[i + 6] - t[i]; const vy = t[i + 7] - t[i + 1]; const vz = t[i + 8] - t[i + 2];
    const n = [uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx];
    for (let k = 0; k < 9; k += 3) out.push(t[i + k], t[i + k + 1], t[i + k + 2], n[0], n[1], n[2], c[0], c[1], c[2]);
  }
}

/**
 * The built-in wheelchair for a footprint, as triangles (x, y, z) per part, in the robot's frame.
 * @param {number} length @param {number} width @param {number} com @returns {Record<string, number[]>}
 */
export function chairTriangles(length, width, com) {
  /** @type {Record<string, number[]>} */
  const parts = { frame: [], seat: [], wheel: [] };
  const rear = -(1 - com) * length;
  /** @param {number} u */
  const X = (u) => rear + (u + 0.5) * length;
  /** @param {number} v */
  const Y = (v) => v * width;
  /** a prism as bare triangles @param {number[]} dst @param {number[][]} pts @param {number} z0 @param {number} z1 */
  const bare = (dst, pts, z0, z1) => {
    /** @type {number[]} */
    const tmp = [];
    prism(tmp, pts, z0, z1, [0, 0, 0]);
    for (let i = 0; i < tmp.length; i += 9) dst.push(tmp[i], tmp[i + 1], tmp[i + 2]);
    for (let i = 0; i + 2 < pts.length; i++) dst.push(pts[0][0], pts[0][1], z0, pts[i + 2][0], pts[i + 2][1], z0, pts[i + 1][0], pts[i + 1][1], z0);
  };
  for (const [u0, v0, z0, u1, v1, z1, part] of CHAIR_BOXES) bare(parts[part], box(X(u0), Y(v0), X(u1), Y(v1)), z0, z1);
  for (const [u, v, r, t, part] of CHAIR_WHEELS) {
    const x = part === "wheel" && r > 0.2 ? 0 : X(u);  // the drive wheels on the axis (the centre of movement)
    const y = Y(v);
    // a wheel: a disc in the x-z plane, extruded across y (built in x-y, then turned)
    /** @type {number[]} */
    const flat = [];
    bare(flat, disc(0, 0, r, 12), y - t / 2, y + t / 2);
    for (let i = 0; i < flat.length; i += 3) parts.wheel.push(x + flat[i], flat[i + 2], r + flat[i + 1]);
  }
  return parts;
}

export class View3D {
  /**
   * @param {HTMLCanvasElement} canvas
   * @param {typeof import("./world.js").world} world  read only
   */
  constructor(canvas, world) {
    this.canvas = canvas;
    this.world = world;
    this.gl = /** @type {WebGLRenderingContext | null} */ (canvas.getContext("webgl", { preserveDrawingBuffer: true, antialias: false }));
    this.motion = new Motion();
    this.nextAt = 0;  // the next drawing of robots carried on (performance.now ms)
    /** @type {Resolution | null} */
    this.resolution = this.gl ? new Resolution(this.gl) : null;
    this.drawn = 0;
    this.mode = "first";
    this.free = { tx: 10, ty: 5, yaw: -Math.PI / 2, pitch: 0.9, dist: 25 };
    this.staticVersion = -1;
    this.seen = "";
    this.camVersion = 0;
    /** @type {number | null} the chair the cameras follow (drive.js: the one driven); null: the selected, else the first */
    this.followId = null;
    /** @type {V3} where the eye was last drawn from (tests look) */
    this.eye = [0, 0, 0];
    /** @type {{pts: number[][], h: number}[]} */
    this.solid = [];
    /** @type {Map<string, import("./models.js").Model>} */
    this.models = new Map();
    /** @type {Map<string, Record<string, number[]>>} a chair's triangles by its footprint and type */
    this.shapes = new Map();
    /** @type {Buf} */ this.staticBuf = { buf: null, count: 0 };
    /** @type {Buf} */ this.dynBuf = { buf: null, count: 0 };
    /** @type {Record<string, any>} */
    this.loc = {};
    if (!this.gl) { console.error("iwz view: this browser gives no WebGL; the 3D view is off"); return; }
    this.setup();
    this.listen();
    loadModels().then((m) => { this.models = m; this.shapes.clear(); this.moved(); });
  }

  setup() {
    const gl = /** @type {WebGLRenderingContext} */ (this.gl);
    /** @param {number} type @param {string} src */
    const shader = (type, src) => {
      const s = /** @type {WebGLShader} */ (gl.createShader(type));
      gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(String(gl.getShaderInfoLog(s)));
      return s;
    };
    const prog = /** @type {WebGLProgram} */ (gl.createProgram());
    gl.attachShader(prog, shader(gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, shader(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    gl.useProgram(prog);
    this.loc = {
      p: gl.getAttribLocation(prog, "p"), n: gl.getAttribLocation(prog, "n"), c: gl.getAttribLocation(prog, "c"),
      m: gl.getUniformLocation(prog, "m"), eye: gl.getUniformLocation(prog, "eye"),
      skyc: gl.getUniformLocation(prog, "skyc"), fog: gl.getUniformLocation(prog, "fog"),
    };
    this.staticBuf.buf = gl.createBuffer();
    this.dynBuf.buf = gl.createBuffer();
    gl.enable(gl.DEPTH_TEST);
  }

  listen() {
    const c = this.canvas;
    /** @type {{x: number, y: number, pan: boolean} | null} */
    let drag = null;
    c.addEventListener("contextmenu", (e) => e.preventDefault());
    c.addEventListener("mousedown", (e) => { drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 }; });
    window.addEventListener("mouseup", () => { drag = null; });
    window.addEventListener("mousemove", (e) => {
      if (!drag || this.mode !== "free") return;
      const dx = e.clientX - drag.x;
      const dy = e.clientY - drag.y;
      drag.x = e.clientX; drag.y = e.clientY;
      const f = this.free;
      if (drag.pan) {
        const k = f.dist * 0.002;
        f.tx -= (Math.cos(f.yaw + Math.PI / 2) * dx - Math.cos(f.yaw) * dy) * k;
        f.ty -= (Math.sin(f.yaw + Math.PI / 2) * dx - Math.sin(f.yaw) * dy) * k;
      } else {
        f.yaw -= dx * 0.005;
        f.pitch = Math.min(1.5, Math.max(0.05, f.pitch + dy * 0.005));
      }
      this.moved();
    });
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      this.free.dist = Math.min(500, Math.max(1, this.free.dist * Math.exp(e.deltaY * 0.001)));
      this.moved();
    }, { passive: false });
    window.addEventListener("keydown", (e) => {
      if (this.mode !== "free" || this.canvas.hidden) return;
      const f = this.free;
      const step = Math.max(0.2, f.dist * 0.03);
      const fwd = /** @type {Record<string, number>} */ ({ w: 1, s: -1 })[e.key] || 0;
      const side = /** @type {Record<string, number>} */ ({ a: 1, d: -1 })[e.key] || 0;
      if (!fwd && !side) return;
      f.tx += (-Math.cos(f.yaw) * fwd + Math.cos(f.yaw + Math.PI / 2) * side) * step;
      f.ty += (-Math.sin(f.yaw) * fwd + Math.sin(f.yaw + Math.PI / 2) * side) * step;
      this.moved();
    });
  }

  /** the camera moved: draw again */
  moved() { this.camVersion += 1; }

  /** the sky's colour (what hooks.js counts as not drawn) */
  clearRgb() { return SKY; }

  /** @param {string} mode  "first", "third" or "free" */
  setCamera(mode) {
    this.mode = mode;
    const s = this.world.scene;
    if (mode === "free" && s) { this.free.tx = s.width / 2; this.free.ty = s.height / 2; this.free.dist = Math.max(s.width, s.height); }
    this.moved();
  }

  /** follow this chair (null: the selected one, else the first) @param {number | null} id */
  follow(id) { this.followId = id; this.moved(); }

  sceneChanged() { this.staticVersion = -1; }

  /** @param {Buf} target @param {number[]} data */
  upload(target, data) {
    const gl = /** @type {WebGLRenderingContext} */ (this.gl);
    gl.bindBuffer(gl.ARRAY_BUFFER, target.buf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(data), gl.DYNAMIC_DRAW);
    target.count = data.length / 9;
  }

  buildStatic() {
    const s = this.world.scene;
    /** @type {number[]} */
    const out = [];
    if (s) {
      prism(out, box(0, 0, s.width, s.height), -0.05, 0, FLOOR);
      const step = Math.max(s.width, s.height) > 300 ? 5 : 1;  // a 1 m grid, 5 m in a huge lab
      for (let x = 0; x <= s.width + 1e-9; x += step) {
        const major = Math.round(x) % 5 === 0;
        const hw = major ? 0.025 : 0.012;
        prism(out, box(x - hw, 0, x + hw, s.height), 0, 0.004, major ? GRID_MAJOR : GRID);
      }
      for (let y = 0; y <= s.height + 1e-9; y += step) {
        const major = Math.round(y) % 5 === 0;
        const hw = major ? 0.025 : 0.012;
        prism(out, box(0, y - hw, s.width, y + hw), 0, 0.004, major ? GRID_MAJOR : GRID);
      }
      this.solid = solids(s, EDGE_THICK_M, EDGE_M);
      const t = EDGE_THICK_M;
      for (const b of [[-t, -t, s.width + t, 0], [-t, s.height, s.width + t, s.height + t], [-t, 0, 0, s.height], [s.width, 0, s.width + t, s.height]]) {
        prism(out, box(b[0], b[1], b[2], b[3]), 0, EDGE_M, EDGE);
      }
      for (const w of s.walls) prism(out, w.corners, 0, w.height, WALL);
      for (const o of s.obstacles) prism(out, box(o.x0, o.y0, o.x1, o.y1), 0, o.height === undefined ? 1 : o.height, OBSTACLE);
      for (const [x, y, h] of s.beacons) {
        prism(out, disc(x, y, 0.04, 8), 0, h, BEACON);
        prism(out, disc(x, y, 0.12, 8), h, h + 0.12, BEACON);
      }
      for (const [x, y, r] of s.targets) prism(out, disc(x, y, Math.max(0.1, r), 24), 0, 0.012, TARGET);
      this.staticVersion = s.revision;
    }
    this.upload(this.staticBuf, out);
  }

  /** the index in world.ids of the chair the cameras follow, or -1 */
  chair() {
    const w = this.world;
    if (this.followId !== null) { const i = w.ids.indexOf(this.followId); if (i >= 0) return i; }
    const sel = w.selected && w.selected.kind === "robot" ? w.ids.indexOf(w.selected.id) : -1;
    return sel >= 0 ? sel : w.ids.length ? 0 : -1;
  }

  /** a chair's parts in its own frame (cached by footprint and type) @param {import("./types.js").PageRobot} r */
  shape(r) {
    const L = Number(r.spec.width_m) || 1;
    const W = Number(r.spec.height_m) || 1;
    const com = Number(r.spec.com) || 0.5;
    const key = `${r.type}:${L}:${W}:${com}`;
    let got = this.shapes.get(key);
    if (!got) {
      const m = this.models.get(r.type.toLowerCase());
      got = m ? { frame: Array.from(fitted(m, L, W, com * L)), seat: [], wheel: [] } : chairTriangles(L, W, com);
      this.shapes.set(key, got);
    }
    return got;
  }

  /** @param {number} skip  the robot not drawn (the first person's own chair), or -1 */
  buildRobots(skip) {
    const w = this.world;
    const at = this.motion;  // the poses drawn now
    /** @type {number[]} */
    const out = [];
    const simple = w.ids.length > SIMPLE_PAST;
    for (let i = 0; i < w.ids.length; i++) {
      if (i === skip) continue;
      const r = w.robots.get(w.ids[i]);
      const c = Math.cos(at.heading[i]);
      const s = Math.sin(at.heading[i]);
      const x = at.x[i];
      const y = at.y[i];
      const st = w.states[i] || "driving";
      const door = r && r.type === "Door";
      if (door || simple || !r) {
        const outline = r && r.outline.length ? r.outline : box(-0.3, -0.3, 0.3, 0.3);
        const pts = outline.map(([px, py]) => [x + c * px - s * py, y + s * px + c * py]);
        prism(out, pts, 0, door ? DOOR_M : 1.0, door && st === "driving" ? DOOR_RGB : STATE_RGB[st] || STATE_RGB.driving);
        continue;
      }
      const parts = this.shape(r);
      for (const [part, tris] of Object.entries(parts)) {
        const colour = part === "seat" ? SEAT : part === "wheel" ? WHEEL : STATE_RGB[st] || STATE_RGB.driving;
        const moved = new Array(tris.length);
        for (let k = 0; k < tris.length; k += 3) {
          moved[k] = x + c * tris[k] - s * tris[k + 1];
          moved[k + 1] = y + s * tris[k] + c * tris[k + 1];
          moved[k + 2] = tris[k + 2];
        }
        triangles(out, moved, colour);
      }
    }
    this.upload(this.dynBuf, out);
  }

  /** @param {number} aspect */
  camera(aspect) {
    const w = this.world;
    const s = w.scene;
    const span = s ? Math.hypot(s.width, s.height) : 100;
    const proj = perspective(this.mode === "first" ? 1.2 : 0.9, aspect, 0.1, Math.max(200, 3 * span));
    const i = this.chair();
    /** @type {V3} */
    let eye;
    /** @type {V3} */
    let target;
    if (this.mode !== "free" && i >= 0) {
      const at = this.motion;  // the followed chair where it is drawn now
      const x = at.x[i];
      const y = at.y[i];
      const c = Math.cos(at.heading[i]);
      const sn = Math.sin(at.heading[i]);
      if (this.mode === "first") {
        eye = [x, y, EYE_M];
        target = [x + c, y + sn, EYE_M - 0.15];
      } else {
        target = [x, y, 0.8];
        const e = unblocked(this.solid, [x, y, 1.0], [x - BEHIND_M * c, y - BEHIND_M * sn, ABOVE_M]);
        eye = clearOf(this.solid, [e[0], e[1], ABOVE_M]);  // pulled in: still above the chair, looking down on it
      }
    } else {
      const f = this.free;
      eye = clearOf(this.solid, [f.tx + f.dist * Math.cos(f.pitch) * Math.cos(f.yaw), f.ty + f.dist * Math.cos(f.pitch) * Math.sin(f.yaw), f.dist * Math.sin(f.pitch)]);
      target = [f.tx, f.ty, 0];
    }
    this.eye = eye;
    return { m: mul(proj, lookAt(eye, target, [0, 0, 1])), skip: this.mode === "first" ? i : -1, fog: Math.max(30, span) };
  }

  /** @param {Buf} target */
  bind(target) {
    const gl = /** @type {WebGLRenderingContext} */ (this.gl);
    const L = this.loc;
    gl.bindBuffer(gl.ARRAY_BUFFER, target.buf);
    for (const [a, off] of [[L.p, 0], [L.n, 12], [L.c, 24]]) {
      gl.enableVertexAttribArray(a);
      gl.vertexAttribPointer(a, 3, gl.FLOAT, false, 36, off);
    }
    gl.drawArrays(gl.TRIANGLES, 0, target.count);
  }

  draw() {
    const gl = this.gl;
    if (!gl) return;
    const c = this.canvas;
    const now = performance.now();
    const res = /** @type {Resolution} */ (this.resolution);
    res.frame(now);
    this.motion.update(this.world, now);
    const r = c.getBoundingClientRect();
    const dpr = (window.devicePixelRatio || 1) * res.scale;
    const wpx = Math.max(1, Math.round(r.width * dpr));
    const hpx = Math.max(1, Math.round(r.height * dpr));
    // on every change; while robots move on between states, at most MOVING_FPS (the browser's
    // CPU is the chain's too: the viewer and the chairs' agents share the machine); once more when they stop
    const base = `${this.world.version}:${this.camVersion}:${wpx}x${hpx}:${this.mode}`;
    const key = `${base}:${this.motion.moving ? "moving" : "still"}`;
    if (key === this.seen && (!this.motion.moving || now < this.nextAt - FRAME_SLACK_MS)) return;
    this.nextAt = (now - this.nextAt < MOVING_MS ? this.nextAt : now) + MOVING_MS;
    this.seen = key;
    res.drew();
    if (c.width !== wpx || c.height !== hpx) { c.width = wpx; c.height = hpx; }
    if (this.world.scene && this.staticVersion !== this.world.scene.revision) this.buildStatic();
    const cam = this.camera(wpx / hpx);
    this.buildRobots(cam.skip);
    gl.viewport(0, 0, wpx, hpx);
    gl.clearColor(SKY[0], SKY[1], SKY[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.uniformMatrix4fv(this.loc.m, false, new Float32Array(cam.m));
    gl.uniform3fv(this.loc.eye, new Float32Array(this.eye));
    gl.uniform3fv(this.loc.skyc, new Float32Array(SKY));
    gl.uniform1f(this.loc.fog, cam.fog);
    this.bind(this.staticBuf);
    this.bind(this.dynBuf);
    this.drawn += 1;
  }
}
