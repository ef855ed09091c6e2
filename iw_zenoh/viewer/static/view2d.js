// @ts-check
// The 2D top view: walls, targets, beacons, obstacles, robots as their true outlines coloured by
// state, cones with their readings, laser scans, trails, flashing incidents, a scale bar. Drag to
// pan, wheel to zoom, click to select; in obstacle mode drag draws an obstacle; a selected
// obstacle is dragged to move it. It draws only when something changed (a message, the view, a
// flash). It reads the world and never writes it (world.js owns it).
import { STATE_COLOURS, COLOUR } from "./palette.js";

/** @typedef {import("./palette.js").RobotState} RobotState */
/** @typedef {import("./types.js").Obstacle} Obstacle */
/**
 * @typedef {object} Hooks2D  what the view asks of the page
 * @property {(sel: import("./world.js").Selection | null) => void} select
 * @property {(cmd: import("./types.js").PageCommand) => void} send
 * @property {(x: number, y: number) => boolean} mapClick  a click on no robot: true when taken
 * @property {(x: number | null, y: number | null) => void} cursor  where the mouse is (m), null: off the map
 * @property {() => {trails: boolean, cones: boolean, labels: boolean, scans: boolean}} options
 * @property {() => void} drawingDone
 * @property {() => void} drawingStarted
 */

const DOOR = COLOUR.door;
export const SCAN_POINT = COLOUR.scan;  // where a laser beam hit
const SCALE_PX = 120;         // the scale bar is a round length about this long
const SCAN_POINT_PX = 4;
const LABEL_MIN_PX = 14;      // a robot smaller than this on screen gets no label
const CONES_MAX = 400;        // beyond this many robots the cones are drawn only for the selected one
const TRAILS_MAX = 200;       // likewise for trails
const LATENCIES_KEPT = 2000;

/** a round length (1, 2 or 5 times a power of ten) of about `m` metres @param {number} m */
export function roundLength(m) {
  const p = Math.pow(10, Math.floor(Math.log10(m)));
  const f = m / p;
  return (f >= 5 ? 5 : f >= 2 ? 2 : 1) * p;
}

/**
 * Beam k's direction from the robot's heading, degrees (LaserSpec's rule: the first beam looks
 * angle - fov/2, the last angle + fov/2; a single beam looks along angle).
 * @param {import("./types.js").PageLaser} l @param {number} k
 */
export function laserAngle(l, k) {
  return l.beams > 1 ? l.angle_deg - l.fov_deg / 2 + k * l.fov_deg / (l.beams - 1) : l.angle_deg;
}

export class View2D {
  /**
   * @param {HTMLCanvasElement} canvas
   * @param {typeof import("./world.js").world} world  read only
   * @param {Hooks2D} hooks
   */
  constructor(canvas, world, hooks) {
    this.canvas = canvas;
    this.ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext("2d"));
    this.world = world;
    this.hooks = hooks;
    this.scale = 40; this.ox = 20; this.oy = 400;   // px per m; screen position of the map's origin
    this.fitted = false;
    this.drawn = 0;
    this.seenVersion = -1;
    this.lastFrames = -1;
    this.drawing = false;     // drawing an obstacle
    /** @type {any} */
    this.drag = null;
    this.animate = false;     // redraw every animation frame, drifting (benchmarks/viewer.py measures so)
    this.dpr = window.devicePixelRatio || 1;
    /** @type {{latencies: number[], scanPoints: number[][]} | null} what hooks.js measures (null: nothing) */
    this.measure = null;
    this.scaleShown = 0;      // the length (m) the scale bar shows
    this.listen();
  }

  /** @param {number} x @param {number} y @returns {[number, number]} */
  toScreen(x, y) { return [this.ox + x * this.scale, this.oy - y * this.scale]; }
  /** @param {number} sx @param {number} sy @returns {[number, number]} */
  toWorld(sx, sy) { return [(sx - this.ox) / this.scale, (this.oy - sy) / this.scale]; }

  /** The whole lab in view (again: the page calls it when the panel opens or closes). */
  fit() {
    const s = this.world.scene;
    const r = this.canvas.getBoundingClientRect();
    if (!s || r.width === 0) return;
    this.scale = Math.min((r.width - 20) / s.width, (r.height - 20) / s.height);
    this.ox = (r.width - s.width * this.scale) / 2;
    this.oy = r.height - (r.height - s.height * this.scale) / 2;
    this.fitted = true;
    this.dirty();
  }

  dirty() { this.seenVersion = -1; }

  toggleDrawing() {
    this.drawing = !this.drawing;
    this.canvas.classList.toggle("drawing", this.drawing);
    (this.drawing ? this.hooks.drawingStarted : this.hooks.drawingDone)();
  }

  listen() {
    const c = this.canvas;
    /** @param {MouseEvent} e @returns {[number, number]} */
    const pos = (e) => { const r = c.getBoundingClientRect(); return [e.clientX - r.left, e.clientY - r.top]; };
    c.addEventListener("wheel", (e) => {
      e.preventDefault();
      const [sx, sy] = pos(e);
      const k = Math.exp(-e.deltaY * 0.0015);
      this.ox = sx - (sx - this.ox) * k; this.oy = sy - (sy - this.oy) * k; this.scale *= k;
      this.dirty();
    }, { passive: false });
    c.addEventListener("mousedown", (e) => {
      const [sx, sy] = pos(e);
      const [wx, wy] = this.toWorld(sx, sy);
      const ob = this.obstacleAt(wx, wy);
      if (this.drawing) this.drag = { kind: "draw", x0: wx, y0: wy, x1: wx, y1: wy };
      else if (ob && this.world.live) this.drag = { kind: "move", ob, wx, wy, dx: 0, dy: 0, moved: false };
      else this.drag = { kind: "pan", sx, sy, moved: false };
    });
    c.addEventListener("mouseleave", () => this.hooks.cursor(null, null));
    window.addEventListener("mousemove", (e) => {
      const d = this.drag;
      const [sx, sy] = pos(e);
      const [wx, wy] = this.toWorld(sx, sy);
      if (e.target === c) this.hooks.cursor(wx, wy);
      if (!d) return;
      if (d.kind === "draw") { d.x1 = wx; d.y1 = wy; }
      else if (d.kind === "move") { d.dx = wx - d.wx; d.dy = wy - d.wy; d.moved = d.moved || Math.hypot(d.dx, d.dy) > 0.02; }
      else {
        this.ox += sx - d.sx; this.oy += sy - d.sy;
        d.moved = d.moved || Math.hypot(sx - d.sx, sy - d.sy) > 3;
        d.sx = sx; d.sy = sy;
      }
      this.dirty();
    });
    window.addEventListener("mouseup", (e) => {
      const d = this.drag;
      this.drag = null;
      if (!d) return;
      const [sx, sy] = pos(e);
      if (d.kind === "draw") this.finishDrawing(d);
      else if (d.kind === "move" && d.moved) {
        const o = d.ob;
        this.hooks.send({ cmd: "move_obstacle", obstacle: { ...o, x0: o.x0 + d.dx, x1: o.x1 + d.dx, y0: o.y0 + d.dy, y1: o.y1 + d.dy } });
      } else if (!d.moved) this.click(sx, sy);
      this.dirty();
    });
    window.addEventListener("resize", () => this.dirty());
  }

  /** @param {{x0: number, y0: number, x1: number, y1: number}} d */
  finishDrawing(d) {
    this.toggleDrawing();
    if (Math.abs(d.x1 - d.x0) < 0.05 || Math.abs(d.y1 - d.y0) < 0.05) return;  // a click, not a box
    const names = new Set((this.world.scene ? this.world.scene.obstacles : []).map((o) => o.name));
    let n = names.size + 1;
    while (names.has(`page-${n}`)) n += 1;
    const ob = { name: `page-${n}`, x0: Math.min(d.x0, d.x1), y0: Math.min(d.y0, d.y1), x1: Math.max(d.x0, d.x1), y1: Math.max(d.y0, d.y1), height: 1.0 };
    this.hooks.send({ cmd: "add_obstacle", obstacle: ob });
  }

  /** @param {number} x @param {number} y @returns {Obstacle | null} */
  obstacleAt(x, y) {
    const s = this.world.scene;
    if (!s) return null;
    return s.obstacles.find((o) => x >= o.x0 && x <= o.x1 && y >= o.y0 && y <= o.y1) || null;
  }

  /** @param {number} x @param {number} y @returns {number | null} */
  robotAt(x, y) {
    const w = this.world;
    let best = null;
    let bestD = Infinity;
    for (let i = 0; i < w.ids.length; i++) {
      const r = w.robots.get(w.ids[i]);
      const reach = r ? Math.max(r.spec.width_m, r.spec.height_m) * 0.75 : 0.5;
      const d = Math.hypot(w.x[i] - x, w.y[i] - y);
      if (d < reach && d < bestD) { best = w.ids[i]; bestD = d; }
    }
    return best;
  }

  /** @param {number} sx @param {number} sy */
  click(sx, sy) {
    const [x, y] = this.toWorld(sx, sy);
    const id = this.robotAt(x, y);
    if (id !== null) { this.hooks.select({ kind: "robot", id }); return; }
    if (this.hooks.mapClick(x, y)) return;
    const ob = this.obstacleAt(x, y);
    this.hooks.select(ob ? { kind: "obstacle", name: ob.name } : null);
  }

  resize() {
    const c = this.canvas;
    const r = c.getBoundingClientRect();
    const w = Math.round(r.width * this.dpr);
    const h = Math.round(r.height * this.dpr);
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; if (!this.fitted) this.fit(); return true; }
    return false;
  }

  /** @param {number} now */
  draw(now) {
    const w = this.world;
    const resized = this.resize();
    if (!resized && w.version === this.seenVersion && !w.flashes.length && !this.drag && !this.animate) return;
    if (this.animate) this.ox += Math.sin(now / 500) * 0.5;
    const newFrame = this.lastFrames !== w.frames;
    this.seenVersion = w.version;
    this.lastFrames = w.frames;
    const g = this.ctx;
    g.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    g.fillStyle = "#15181d";
    g.fillRect(0, 0, this.canvas.width, this.canvas.height);
    if (w.scene) this.drawMap(g, w.scene);
    const opts = this.hooks.options();
    if (opts.trails) this.drawTrails(g);
    if (opts.cones) this.drawCones(g);
    this.drawScans(g, opts.scans);
    this.drawRobots(g, opts.labels);
    this.drawFlashes(g, now);
    if (this.drag && this.drag.kind === "draw") this.drawBox(g, this.drag, "rgba(255,255,255,.35)");
    this.drawScale(g);
    this.drawn += 1;
    const m = this.measure;
    if (m && newFrame && w.tickWallMs > 0 && w.live) {
      m.latencies.push(Date.now() - w.tickWallMs);
      if (m.latencies.length > LATENCIES_KEPT) m.latencies.shift();
    }
  }

  // a scale bar at the bottom right: a round length in metres, with its ticks
  /** @param {CanvasRenderingContext2D} g */
  drawScale(g) {
    const r = this.canvas.getBoundingClientRect();
    const m = roundLength(SCALE_PX / this.scale);
    const px = m * this.scale;
    const x1 = r.width - 16;
    const x0 = x1 - px;
    const y = r.height - 16;
    g.fillStyle = "rgba(21,24,29,.75)";
    g.fillRect(x0 - 8, y - 20, px + 16, 28);
    g.strokeStyle = "#fff"; g.lineWidth = 2;
    g.beginPath(); g.moveTo(x0, y - 5); g.lineTo(x0, y); g.lineTo(x1, y); g.lineTo(x1, y - 5); g.stroke();
    g.fillStyle = "#fff"; g.font = "12px system-ui"; g.textAlign = "center";
    g.fillText(m >= 1 ? `${m} m` : `${Math.round(m * 100)} cm`, (x0 + x1) / 2, y - 7);
    this.scaleShown = m;
  }

  /** @param {CanvasRenderingContext2D | Path2D} g @param {number[][]} pts */
  poly(g, pts) {
    g.moveTo(...this.toScreen(pts[0][0], pts[0][1]));
    for (let i = 1; i < pts.length; i++) g.lineTo(...this.toScreen(pts[i][0], pts[i][1]));
    g.closePath();
  }

  /** @param {CanvasRenderingContext2D} g @param {{x0: number, y0: number, x1: number, y1: number}} b @param {string} fill */
  drawBox(g, b, fill) {
    const [ax, ay] = this.toScreen(Math.min(b.x0, b.x1), Math.max(b.y0, b.y1));
    const [bx, by] = this.toScreen(Math.max(b.x0, b.x1), Math.min(b.y0, b.y1));
    g.fillStyle = fill;
    g.fillRect(ax, ay, bx - ax, by - ay);
  }

  /** @param {CanvasRenderingContext2D} g @param {import("./types.js").PageScene} s */
  drawMap(g, s) {
    const [x0, y0] = this.toScreen(0, s.height);
    g.fillStyle = "#23272e";
    g.fillRect(x0, y0, s.width * this.scale, s.height * this.scale);
    g.strokeStyle = "#555"; g.lineWidth = 1;
    g.strokeRect(x0, y0, s.width * this.scale, s.height * this.scale);
    for (const wall of s.walls) {
      const shade = Math.max(60, Math.min(200, 60 + wall.height * 30));
      g.fillStyle = `rgb(${shade},${shade},${shade + 10})`;
      g.beginPath(); this.poly(g, wall.corners); g.fill();
    }
    g.strokeStyle = COLOUR.target; g.lineWidth = 1.5;
    for (const [x, y, r] of s.targets) {
      const [sx, sy] = this.toScreen(x, y);
      g.beginPath(); g.arc(sx, sy, Math.max(2, r * this.scale), 0, 2 * Math.PI); g.stroke();
    }
    g.fillStyle = COLOUR.beacon;
    for (const [x, y] of s.beacons) {
      const [sx, sy] = this.toScreen(x, y);
      g.beginPath(); g.arc(sx, sy, 5, 0, 2 * Math.PI); g.fill();
    }
    const d = this.drag;
    for (const o of s.obstacles) {
      const moving = d && d.kind === "move" && d.ob.name === o.name;
      const b = moving ? { x0: o.x0 + d.dx, x1: o.x1 + d.dx, y0: o.y0 + d.dy, y1: o.y1 + d.dy } : o;
      const sel = this.world.selected && this.world.selected.kind === "obstacle" && this.world.selected.name === o.name;
      this.drawBox(g, b, sel ? COLOUR.obstacleSelected : COLOUR.obstacle);
    }
  }

  /** @param {CanvasRenderingContext2D} g */
  drawTrails(g) {
    const w = this.world;
    const sel = w.selected && w.selected.kind === "robot" ? w.selected.id : null;
    g.strokeStyle = "rgba(120,170,255,.45)"; g.lineWidth = 1;
    g.beginPath();
    for (const [id, t] of w.trails) {
      if (w.ids.length > TRAILS_MAX && id !== sel) continue;
      if (t.length < 4) continue;
      g.moveTo(...this.toScreen(t[0], t[1]));
      for (let i = 2; i < t.length; i += 2) g.lineTo(...this.toScreen(t[i], t[i + 1]));
    }
    g.stroke();
  }

  /** @param {CanvasRenderingContext2D} g */
  drawCones(g) {
    const w = this.world;
    const sel = w.selected && w.selected.kind === "robot" ? w.selected.id : null;
    const hit = new Path2D();
    const free = new Path2D();
    for (let i = 0; i < w.ids.length; i++) {
      const id = w.ids[i];
      if (w.ids.length > CONES_MAX && id !== sel) continue;
      const r = w.robots.get(id);
      if (!r) continue;
      const prox = w.prox.get(id) || [];
      const c = Math.cos(w.heading[i]);
      const s = Math.sin(w.heading[i]);
      for (let k = 0; k < r.sensors.length; k++) {
        const sn = r.sensors[k];
        const d = prox[k];
        const reach = d === null || d === undefined ? sn.range_m : d;
        const px = w.x[i] + c * sn.x - s * sn.y;
        const py = w.y[i] + s * sn.x + c * sn.y;
        const a = w.heading[i] + sn.angle_deg * Math.PI / 180;
        const half = sn.cone_deg * Math.PI / 360;
        const [sx, sy] = this.toScreen(px, py);
        const path = d === null || d === undefined ? free : hit;
        path.moveTo(sx, sy);
        path.arc(sx, sy, Math.max(1, reach * this.scale), -(a + half), -(a - half));  // screen y is flipped
        path.closePath();
      }
    }
    g.fillStyle = "rgba(255,255,255,.05)"; g.fill(free);
    g.fillStyle = "rgba(255,152,0,.22)"; g.fill(hit);
  }

  // each scanner's beams: faint to its range where it saw nothing, brighter to the hit, and the hit
  // as a dot; every robot's, or only the selected one's when `all` is off
  /** @param {CanvasRenderingContext2D} g @param {boolean} all */
  drawScans(g, all) {
    const w = this.world;
    const sel = w.selected && w.selected.kind === "robot" ? w.selected.id : null;
    const free = new Path2D();
    const rays = new Path2D();
    const dots = new Path2D();
    /** @type {number[][]} */
    const points = [];
    const half = SCAN_POINT_PX / 2;
    for (let i = 0; i < w.ids.length; i++) {
      const id = w.ids[i];
      const scans = w.scans.get(id);
      const r = w.robots.get(id);
      if (!scans || !r || !r.lasers.length || (!all && id !== sel)) continue;
      const c = Math.cos(w.heading[i]);
      const s = Math.sin(w.heading[i]);
      r.lasers.forEach((l, k) => {
        const ranges = scans[k] || [];
        const ox = w.x[i] + c * l.x - s * l.y;
        const oy = w.y[i] + s * l.x + c * l.y;
        const [sx, sy] = this.toScreen(ox, oy);
        for (let b = 0; b < ranges.length; b++) {
          const a = w.heading[i] + laserAngle(l, b) * Math.PI / 180;
          const d = ranges[b];
          const reach = d === null ? l.range_m : d;
          const [ex, ey] = this.toScreen(ox + Math.cos(a) * reach, oy + Math.sin(a) * reach);
          const path = d === null ? free : rays;
          path.moveTo(sx, sy); path.lineTo(ex, ey);
          if (d !== null) { dots.rect(ex - half, ey - half, SCAN_POINT_PX, SCAN_POINT_PX); points.push([ox + Math.cos(a) * d, oy + Math.sin(a) * d]); }
        }
      });
    }
    if (this.measure) this.measure.scanPoints = points;
    g.lineWidth = 1;
    g.strokeStyle = "rgba(255,64,129,.07)"; g.stroke(free);
    g.strokeStyle = "rgba(255,64,129,.3)"; g.stroke(rays);
    g.fillStyle = SCAN_POINT; g.fill(dots);
  }

  /** @param {CanvasRenderingContext2D} g @param {boolean} labels */
  drawRobots(g, labels) {
    const w = this.world;
    /** @type {Record<RobotState | "door", Path2D>} */
    const paths = { driving: new Path2D(), held: new Path2D(), watchdog: new Path2D(), collided: new Path2D(), door: new Path2D() };
    const noses = new Path2D();
    for (let i = 0; i < w.ids.length; i++) {
      const r = w.robots.get(w.ids[i]);
      const out = r && r.outline.length ? r.outline : [[0.3, -0.3], [0.3, 0.3], [-0.3, 0.3], [-0.3, -0.3]];
      const c = Math.cos(w.heading[i]);
      const s = Math.sin(w.heading[i]);
      const st = w.states[i] || "driving";
      const p = r && r.type === "Door" && st === "driving" ? paths.door : paths[st] || paths.driving;
      for (let k = 0; k < out.length; k++) {
        const [sx, sy] = this.toScreen(w.x[i] + c * out[k][0] - s * out[k][1], w.y[i] + s * out[k][0] + c * out[k][1]);
        if (k === 0) p.moveTo(sx, sy); else p.lineTo(sx, sy);
      }
      p.closePath();
      const front = r ? r.spec.width_m * r.spec.com : 0.3;
      const [ax, ay] = this.toScreen(w.x[i], w.y[i]);
      noses.moveTo(ax, ay);
      noses.lineTo(...this.toScreen(w.x[i] + c * front * 1.2, w.y[i] + s * front * 1.2));
    }
    for (const [k, p] of Object.entries(paths)) { g.fillStyle = k === "door" ? DOOR : STATE_COLOURS[/** @type {RobotState} */ (k)]; g.fill(p); }
    g.strokeStyle = "#fff"; g.lineWidth = 1.5; g.stroke(noses);
    const sel = w.selected && w.selected.kind === "robot" ? w.ids.indexOf(w.selected.id) : -1;
    if (sel >= 0) {
      const [sx, sy] = this.toScreen(w.x[sel], w.y[sel]);
      g.strokeStyle = "#fff"; g.lineWidth = 2;
      g.beginPath(); g.arc(sx, sy, Math.max(10, this.scale * 0.8), 0, 2 * Math.PI); g.stroke();
    }
    if (labels) this.drawLabels(g);
  }

  /** @param {CanvasRenderingContext2D} g */
  drawLabels(g) {
    const w = this.world;
    g.fillStyle = "#fff"; g.font = "11px system-ui"; g.textAlign = "center";
    for (let i = 0; i < w.ids.length; i++) {
      const r = w.robots.get(w.ids[i]);
      const size = (r ? Math.max(r.spec.width_m, r.spec.height_m) : 0.6) * this.scale;
      if (size < LABEL_MIN_PX) continue;
      const [sx, sy] = this.toScreen(w.x[i], w.y[i]);
      g.fillText(`${w.ids[i]} ${r ? r.name : ""}`, sx, sy - size * 0.6 - 3);
    }
  }

  /** @param {CanvasRenderingContext2D} g @param {number} now */
  drawFlashes(g, now) {
    for (const f of this.world.flashes) {
      const on = Math.floor(now / 200) % 2 === 0;
      if (!on) continue;
      const [sx, sy] = this.toScreen(f.x, f.y);
      g.strokeStyle = f.kind === "collision" ? COLOUR.collision : COLOUR.incident; g.lineWidth = 3;
      g.beginPath(); g.arc(sx, sy, 16, 0, 2 * Math.PI); g.stroke();
    }
  }
}
