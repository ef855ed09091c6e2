// The 3D view in raw WebGL (walls, obstacles, chairs and doors are boxes, so no library is needed):
// walls extruded to their heights, chairs and doors as bodies coloured by state; first person from
// a chair (the selected one, else the first), third person behind it, or a free camera (drag to
// turn, shift-drag or right-drag to pan, wheel to zoom, W A S D to move).
import { COLOURS } from "./view2d.js";

const CHAIR_M = 1.0;           // a chair's body height
const DOOR_M = 2.0;            // a door's
const EYE_M = 1.2;             // first person: eyes this high, at the chair's centre of movement
const BEHIND_M = 4.0;          // third person: this far behind
const ABOVE_M = 3.0;           // and this high
const CLEAR = [0.08, 0.09, 0.11];
const FLOOR = [0.16, 0.17, 0.2];
const WALL = [0.62, 0.63, 0.68];
const OBSTACLE = [0.63, 0.53, 0.5];
const BEACON = [1.0, 0.84, 0.31];
const BORDER = [0.45, 0.47, 0.55];
const BORDER_M = 1.0;          // the lab's edge (a wall to the collision check) drawn this high
const BORDER_THICK_M = 0.1;
const DOOR_RGB = [0.55, 0.43, 0.39];

const VS = `
attribute vec3 p; attribute vec3 n; attribute vec3 c;
uniform mat4 m; varying vec3 vc;
void main() {
  gl_Position = m * vec4(p, 1.0);
  vc = c * (0.35 + 0.65 * abs(dot(normalize(n), normalize(vec3(0.4, 0.3, 0.85)))));
}`;
const FS = `precision mediump float; varying vec3 vc; void main() { gl_FragColor = vec4(vc, 1.0); }`;

function hex(h) { return [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16) / 255); }
const STATE_RGB = Object.fromEntries(Object.entries(COLOURS).map(([k, v]) => [k, hex(v)]));

function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2);
  const nf = 1 / (near - far);
  return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}

function lookAt(e, t, up) {
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const norm = (a) => { const l = Math.hypot(...a) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const z = norm(sub(e, t));
  const x = norm(cross(up, z));
  const y = cross(z, x);
  return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, e), -dot(y, e), -dot(z, e), 1];
}

function mul(a, b) {
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return o;
}

// a polygon (counter-clockwise or not) extruded from z0 to z1, into position/normal/colour arrays
function prism(out, pts, z0, z1, rgb) {
  const push = (x, y, z, nx, ny, nz) => { out.push(x, y, z, nx, ny, nz, rgb[0], rgb[1], rgb[2]); };
  for (let i = 0; i < pts.length; i++) {
    const [ax, ay] = pts[i];
    const [bx, by] = pts[(i + 1) % pts.length];
    const nx = by - ay;
    const ny = ax - bx;
    push(ax, ay, z0, nx, ny, 0); push(bx, by, z0, nx, ny, 0); push(bx, by, z1, nx, ny, 0);
    push(ax, ay, z0, nx, ny, 0); push(bx, by, z1, nx, ny, 0); push(ax, ay, z1, nx, ny, 0);
  }
  for (let i = 1; i + 1 < pts.length; i++) {
    push(pts[0][0], pts[0][1], z1, 0, 0, 1); push(pts[i][0], pts[i][1], z1, 0, 0, 1); push(pts[i + 1][0], pts[i + 1][1], z1, 0, 0, 1);
  }
}

function box(x0, y0, x1, y1) { return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]; }

export class View3D {
  constructor(canvas, world) {
    this.canvas = canvas;
    this.world = world;
    this.gl = canvas.getContext("webgl", { preserveDrawingBuffer: true, antialias: false });
    this.drawn = 0;
    this.mode = "first";
    this.free = { tx: 10, ty: 5, yaw: -Math.PI / 2, pitch: 0.9, dist: 25 };
    this.staticVersion = -1;
    this.seen = "";
    if (!this.gl) { console.error("iwz view: this browser gives no WebGL; the 3D view is off"); return; }
    this.setup();
    this.listen();
  }

  setup() {
    const gl = this.gl;
    const shader = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const prog = gl.createProgram();
    gl.attachShader(prog, shader(gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, shader(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(prog);
    gl.useProgram(prog);
    this.loc = { p: gl.getAttribLocation(prog, "p"), n: gl.getAttribLocation(prog, "n"), c: gl.getAttribLocation(prog, "c"), m: gl.getUniformLocation(prog, "m") };
    this.staticBuf = { buf: gl.createBuffer(), count: 0 };
    this.dynBuf = { buf: gl.createBuffer(), count: 0 };
    gl.enable(gl.DEPTH_TEST);
  }

  listen() {
    const c = this.canvas;
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
      this.world.version += 1;
    });
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      this.free.dist = Math.min(500, Math.max(1, this.free.dist * Math.exp(e.deltaY * 0.001)));
      this.world.version += 1;
    }, { passive: false });
    window.addEventListener("keydown", (e) => {
      if (this.mode !== "free" || this.canvas.hidden) return;
      const f = this.free;
      const step = Math.max(0.2, f.dist * 0.03);
      const fwd = { w: 1, s: -1 }[e.key] || 0;
      const side = { a: 1, d: -1 }[e.key] || 0;
      f.tx += (-Math.cos(f.yaw) * fwd + Math.cos(f.yaw + Math.PI / 2) * side) * step;
      f.ty += (-Math.sin(f.yaw) * fwd + Math.sin(f.yaw + Math.PI / 2) * side) * step;
      this.world.version += 1;
    });
  }

  setCamera(mode) {
    this.mode = mode;
    const s = this.world.scene;
    if (mode === "free" && s) { this.free.tx = s.width / 2; this.free.ty = s.height / 2; this.free.dist = Math.max(s.width, s.height); }
    this.seen = "";
  }

  sceneChanged() { this.staticVersion = -1; }

  upload(target, data) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, target.buf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(data), gl.DYNAMIC_DRAW);
    target.count = data.length / 9;
  }

  buildStatic() {
    const s = this.world.scene;
    const out = [];
    if (s) {
      prism(out, box(0, 0, s.width, s.height), -0.02, 0, FLOOR);
      const t = BORDER_THICK_M;
      for (const b of [[-t, -t, s.width + t, 0], [-t, s.height, s.width + t, s.height + t], [-t, 0, 0, s.height], [s.width, 0, s.width + t, s.height]]) {
        prism(out, box(...b), 0, BORDER_M, BORDER);
      }
      for (const w of s.walls) prism(out, w.corners, 0, w.height, WALL);
      for (const o of s.obstacles) prism(out, box(o.x0, o.y0, o.x1, o.y1), 0, o.height, OBSTACLE);
      for (const [x, y, h] of s.beacons) prism(out, box(x - 0.05, y - 0.05, x + 0.05, y + 0.05), 0, h, BEACON);
      this.staticVersion = s.revision;
    }
    this.upload(this.staticBuf, out);
  }

  chair() {
    const w = this.world;
    const sel = w.selected && w.selected.kind === "robot" ? w.ids.indexOf(w.selected.id) : -1;
    return sel >= 0 ? sel : w.ids.length ? 0 : -1;
  }

  buildRobots(skip) {
    const w = this.world;
    const out = [];
    for (let i = 0; i < w.ids.length; i++) {
      if (i === skip) continue;
      const r = w.robots.get(w.ids[i]);
      const outline = r && r.outline.length ? r.outline : box(-0.3, -0.3, 0.3, 0.3);
      const c = Math.cos(w.heading[i]);
      const s = Math.sin(w.heading[i]);
      const pts = outline.map(([px, py]) => [w.x[i] + c * px - s * py, w.y[i] + s * px + c * py]);
      const door = r && r.type === "Door";
      const st = w.state[i] || "d";
      prism(out, pts, 0, door ? DOOR_M : CHAIR_M, door && st === "d" ? DOOR_RGB : STATE_RGB[st] || STATE_RGB.d);
      if (!door) {  // a nose, so the heading shows
        const f = r ? r.spec.width * r.spec.com : 0.3;
        prism(out, box(-0.05, -0.05, 0.05, 0.05).map(([px, py]) => [w.x[i] + c * (f + px) - s * py, w.y[i] + s * (f + px) + c * py]), CHAIR_M, CHAIR_M + 0.1, [1, 1, 1]);
      }
    }
    this.upload(this.dynBuf, out);
  }

  camera(aspect) {
    const w = this.world;
    const proj = perspective(this.mode === "first" ? 1.2 : 0.9, aspect, 0.05, 1000);
    const i = this.chair();
    let eye;
    let target;
    if (this.mode !== "free" && i >= 0) {
      const c = Math.cos(w.heading[i]);
      const s = Math.sin(w.heading[i]);
      if (this.mode === "first") {
        eye = [w.x[i], w.y[i], EYE_M];
        target = [w.x[i] + c, w.y[i] + s, EYE_M - 0.15];
      } else {
        eye = [w.x[i] - BEHIND_M * c, w.y[i] - BEHIND_M * s, ABOVE_M];
        target = [w.x[i], w.y[i], CHAIR_M * 0.8];
      }
    } else {
      const f = this.free;
      eye = [f.tx + f.dist * Math.cos(f.pitch) * Math.cos(f.yaw), f.ty + f.dist * Math.cos(f.pitch) * Math.sin(f.yaw), f.dist * Math.sin(f.pitch)];
      target = [f.tx, f.ty, 0];
    }
    return { m: mul(proj, lookAt(eye, target, [0, 0, 1])), skip: this.mode === "first" ? i : -1 };
  }

  bind(target) {
    const gl = this.gl;
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
    const r = c.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    const wpx = Math.max(1, Math.round(r.width * dpr));
    const hpx = Math.max(1, Math.round(r.height * dpr));
    const key = `${this.world.version}:${wpx}x${hpx}:${this.mode}`;
    if (key === this.seen) return;
    this.seen = key;
    if (c.width !== wpx || c.height !== hpx) { c.width = wpx; c.height = hpx; }
    if (this.world.scene && this.staticVersion !== this.world.scene.revision) this.buildStatic();
    const cam = this.camera(wpx / hpx);
    this.buildRobots(cam.skip);
    gl.viewport(0, 0, wpx, hpx);
    gl.clearColor(CLEAR[0], CLEAR[1], CLEAR[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.uniformMatrix4fv(this.loc.m, false, new Float32Array(cam.m));
    this.bind(this.staticBuf);
    this.bind(this.dynBuf);
    this.drawn += 1;
  }

  // how much of the canvas is not the clear colour, and how many colours it shows (for tests)
  coverage() {
    const gl = this.gl;
    if (!gl) return { drawn: 0, covered: 0, colours: 0 };
    const w = this.canvas.width;
    const h = this.canvas.height;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const bg = CLEAR.map((v) => Math.round(v * 255));
    let covered = 0;
    const colours = new Set();
    for (let i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - bg[0]) + Math.abs(px[i + 1] - bg[1]) + Math.abs(px[i + 2] - bg[2]) > 6) covered += 1;
      if (i % 64 === 0) colours.add((px[i] << 16) | (px[i + 1] << 8) | px[i + 2]);
    }
    return { drawn: this.drawn, covered: covered / (w * h), colours: colours.size };
  }
}
