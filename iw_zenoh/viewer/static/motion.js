// @ts-check
// What the 3D view draws between two of the world's states, and at what resolution.
// * Motion: the world tells poses 20 times a second (a tick); a driver in first person would see
//   the view jump at that rate. Between two states each robot's pose is carried on along its last
//   motion (from the two last states, by the wall time between them), for at most one interval:
//   the view moves at the screen's rate with no added delay (interpolating would show the past).
//   When no state follows (a paused run), the true pose is drawn again after two intervals.
// * Resolution: software WebGL (Chromium's SwiftShader, headless tests) pays for every pixel; a
//   frame that costs more than the frame budget lowers the drawing's resolution (the canvas is
//   stretched to its place), a quick one raises it back, slowly, so a real GPU stays at full.

const LEAD_INTERVALS = 1;      // carried on for at most this many intervals between states
const STOP_INTERVALS = 2;      // no state for this many intervals: the true pose again
const SMOOTH = 0.2;            // the interval between states is a moving average, this much the newest
const PAUSE_CAP = 2;           // a gap longer than this many intervals counts as this many
const JUMP_M = 2.0;            // a move longer than this between two states is a jump, not motion
const BUDGET_MS = 28;          // a frame costing more than this (under 35 frames/s) lowers the resolution
const QUICK_MS = 20;           // frames this quick (about the screen's 60 a second) may raise it
const SCALE_MIN = 0.35;        // at most this much lower (per side)
const SCALE_STEP = 0.85;
const SOFTWARE_START = 0.6;    // a software renderer starts this low (its first frames are not slow)
const JUDGE_FRAMES = 8;        // drawn frames averaged before a change
const RAISE_AFTER_MS = 4000;   // a raise waits this long after a lowering
const CEILING_MS = 30000;      // and the resolution that was too slow is not tried again for this long

/** The poses to draw now: the last state's, carried on along each robot's last motion. */
export class Motion {
  constructor() {
    /** @type {Map<number, number[]>} id -> [x, y, heading] of the state before the last */
    this.before = new Map();
    /** @type {Map<number, number[]>} id -> [x, y, heading] of the last state */
    this.last = new Map();
    this.frames = -1;      // the world's frame count taken last
    this.at = 0;           // when the last state came (performance.now ms)
    this.interval = 0;     // wall ms between two states, averaged (0: not known)
    this.moving = false;   // some robot is carried on now: draw every frame
    /** @type {number[]} */ this.x = [];
    /** @type {number[]} */ this.y = [];
    /** @type {number[]} */ this.heading = [];
  }

  /**
   * The poses to draw at ``now`` (in the order of ``world.ids``, in ``this.x``, ``y``, ``heading``).
   * @param {typeof import("./world.js").world} w @param {number} now  performance.now() ms
   */
  update(w, now) {
    if (w.frames !== this.frames) {
      const dt = this.frames >= 0 && w.frameAt > this.at ? w.frameAt - this.at : 0;
      // smoothed: states that arrive bunched (a loaded machine) do not make a tick's motion look quicker
      // (a pause's long gap counts as at most PAUSE_CAP intervals)
      const d = this.interval > 0 ? Math.min(dt, PAUSE_CAP * this.interval) : dt;
      this.interval = d <= 0 ? this.interval : this.interval > 0 ? (1 - SMOOTH) * this.interval + SMOOTH * d : d;
      this.frames = w.frames;
      this.at = w.frameAt;
      this.before = this.last;
      this.last = new Map();
      for (let i = 0; i < w.ids.length; i++) this.last.set(w.ids[i], [w.x[i], w.y[i], w.heading[i]]);
    }
    const since = now - this.at;
    const on = this.interval > 0 && since < STOP_INTERVALS * this.interval;
    const f = on ? Math.min(since, LEAD_INTERVALS * this.interval) / this.interval : 0;
    this.moving = false;
    const n = w.ids.length;
    this.x.length = n; this.y.length = n; this.heading.length = n;
    for (let i = 0; i < n; i++) {
      let x = w.x[i]; let y = w.y[i]; let h = w.heading[i];
      const b = f > 0 ? this.before.get(w.ids[i]) : undefined;
      if (b) {
        const dx = x - b[0]; const dy = y - b[1];
        let dh = h - b[2];
        dh = Math.atan2(Math.sin(dh), Math.cos(dh));
        if (Math.hypot(dx, dy) < JUMP_M && (dx || dy || dh)) {
          x += f * dx; y += f * dy; h += f * dh;
          this.moving = true;
        }
      }
      this.x[i] = x; this.y[i] = y; this.heading[i] = h;
    }
  }
}

/** The drawing's resolution, lowered while frames cost more than the budget. */
export class Resolution {
  /** @param {WebGLRenderingContext} gl */
  constructor(gl) {
    const info = gl.getExtension("WEBGL_debug_renderer_info");
    const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
    this.software = /swiftshader|llvmpipe|software/i.test(name);
    this.scale = this.software ? SOFTWARE_START : 1;
    this.lastAt = 0;       // when the view was last called (performance.now ms)
    this.drewLast = false; // and whether it drew then
    /** @type {number[]} */ this.costs = [];
    this.loweredAt = -Infinity;
    this.ceiling = Infinity;  // the scale last found too slow (not tried again until ceilingUntil)
    this.ceilingUntil = -Infinity;
  }

  /** Called each animation frame, before drawing: the cost of the last drawn frame is what passed since. @param {number} now */
  frame(now) {
    // a view not shown for a while (the 2D map) is not a slow frame
    if (this.drewLast && this.lastAt > 0 && now - this.lastAt < 10 * BUDGET_MS) this.costs.push(now - this.lastAt);
    this.lastAt = now;
    this.drewLast = false;
    if (this.costs.length < JUDGE_FRAMES) return;
    const mean = this.costs.reduce((a, b) => a + b, 0) / this.costs.length;
    this.costs.length = 0;
    if (mean > BUDGET_MS && this.scale > SCALE_MIN) {
      this.ceiling = this.scale;
      this.ceilingUntil = now + CEILING_MS;
      this.scale = Math.max(SCALE_MIN, this.scale * SCALE_STEP);
      this.loweredAt = now;
    } else if (mean < QUICK_MS && this.scale < 1 && now - this.loweredAt > RAISE_AFTER_MS) {
      const up = Math.min(1, this.scale / SCALE_STEP);
      if (up < this.ceiling - 1e-9 || now > this.ceilingUntil) this.scale = up;
    }
  }

  /** The view drew this frame. */
  drew() { this.drewLast = true; }
}
