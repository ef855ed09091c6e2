// @ts-check
// The page's one copy of the world as the server tells it. Only this module writes `world`: the
// server's messages through `apply`, the page's choices through `select` and `changed`; every
// other module reads it, and hears of changes through `on`.
import { STATE_NAMES } from "./palette.js";

/** @typedef {import("./types.js").PageMessage} PageMessage */
/** @typedef {import("./types.js").PageRobot} PageRobot */
/** @typedef {import("./types.js").PageScene} PageScene */
/** @typedef {import("./types.js").PageStatus} PageStatus */
/** @typedef {import("./types.js").PageReading} PageReading */
/** @typedef {import("./types.js").PageTimeline} PageTimeline */
/** @typedef {import("./palette.js").RobotState} RobotState */
/** @typedef {{kind: "robot", id: number} | {kind: "obstacle", name: string}} Selection */
/** @typedef {{x: number, y: number, kind: string, until: number}} Flash */

const TRAIL_POINTS = 80;      // positions kept per robot
const TRAIL_EVERY = 3;        // frames between two trail points
const FLASH_MS = 2500;        // how long an incident flashes
const FLASHED = ["collision", "watchdog", "removed", "agent-lost", "refused", "holding"];

export const world = {
  live: true, sim: "", connected: false, steer: true,
  /** @type {PageScene | null} */ scene: null,
  /** @type {Map<number, PageRobot>} */ robots: new Map(),
  /** @type {number[]} */ ids: [],
  /** @type {number[]} */ x: [],
  /** @type {number[]} */ y: [],
  /** @type {number[]} */ heading: [],
  /** @type {RobotState[]} */ states: [],     // one name per robot, in the order of ids
  tick: 0, t_ns: 0, heldReason: "",
  sentMs: 0, tickWallMs: 0, frameAt: 0,       // when the last frame was sent, and when it arrived
  /** @type {Map<number, (number | null)[]>} */ prox: new Map(),      // id -> one distance per sensor
  /** @type {Map<number, (number | null)[][]>} */ scans: new Map(),  // id -> one list of ranges per scanner
  /** @type {Map<number, number[]>} */ trails: new Map(),             // id -> x0, y0, x1, y1, ...
  frames: 0,
  /** @type {Flash[]} */ flashes: [],
  /** @type {PageStatus | null} */ status: null,
  /** @type {(PageTimeline & {marks: import("./types.js").TimelineMark[]}) | null} */ timeline: null,
  /** @type {Selection | null} */ selected: null,
  /** @type {PageReading | null} */ reading: null,
  version: 0,                                 // +1 at every change: the views redraw when it moves
};

/** @type {Map<string, ((m: any) => void)[]>} */
const listeners = new Map();

/**
 * Calls `fn` after the world took in a message of `type` ("scene", "frame", ... or "select",
 * "connected").
 * @param {string} type
 * @param {(m: any) => void} fn
 */
export function on(type, fn) {
  const l = listeners.get(type) || [];
  l.push(fn);
  listeners.set(type, l);
}

/** @param {string} type @param {any} m */
function tell(type, m) { for (const fn of listeners.get(type) || []) fn(m); }

/** Something the views draw changed (an option, the camera): they redraw. */
export function changed() { world.version += 1; }

/** @param {boolean} up */
export function setConnected(up) { world.connected = up; changed(); tell("connected", up); }

/** @param {Selection | null} sel */
export function select(sel) {
  world.selected = sel;
  world.reading = null;
  changed();
  tell("select", sel);
}

/** the index of the selected robot in `ids`, or -1 */
export function selectedIndex() {
  const s = world.selected;
  return s && s.kind === "robot" ? world.ids.indexOf(s.id) : -1;
}

/** @param {import("./types.js").PageScene} m */
function scene(m) {
  world.scene = m;
  world.robots = new Map(m.robots.map((r) => [r.id, r]));
  for (const id of [...world.trails.keys()]) if (!world.robots.has(id)) world.trails.delete(id);
  for (const id of [...world.scans.keys()]) if (!world.robots.has(id)) world.scans.delete(id);
  const s = world.selected;
  if (s && s.kind === "obstacle" && !m.obstacles.some((o) => o.name === s.name)) select(null);
}

/** @param {import("./types.js").PageFrame} m */
function frame(m) {
  if (m.ids !== null) {
    world.ids = m.ids;
    const have = new Set(m.ids);
    for (const id of [...world.trails.keys()]) if (!have.has(id)) world.trails.delete(id);
    const s = world.selected;
    if (s && s.kind === "robot" && !have.has(s.id)) select(null);
  }
  world.x = m.x; world.y = m.y; world.heading = m.heading;
  world.states = Array.from(m.state, (c) => STATE_NAMES[/** @type {keyof STATE_NAMES} */ (c)] || "driving");
  world.tick = m.tick; world.t_ns = m.t_ns; world.heldReason = m.held_reason;
  world.sentMs = m.sent_ms; world.tickWallMs = m.tick_wall_ms; world.frameAt = performance.now();
  world.frames += 1;
  if (world.frames % TRAIL_EVERY === 0) {
    for (let i = 0; i < world.ids.length; i++) {
      let t = world.trails.get(world.ids[i]);
      if (!t) { t = []; world.trails.set(world.ids[i], t); }
      t.push(world.x[i], world.y[i]);
      if (t.length > 2 * TRAIL_POINTS) t.splice(0, 2);
    }
  }
}

/** @param {import("./types.js").PageEvent} m */
function event(m) {
  if (m.where && FLASHED.includes(m.kind)) {
    world.flashes.push({ x: m.where[0], y: m.where[1], kind: m.kind, until: performance.now() + FLASH_MS });
  }
}

/** Forgets the flashes that are over. @param {number} now */
export function expireFlashes(now) {
  if (world.flashes.length) world.flashes = world.flashes.filter((f) => f.until > now);
}

/** Forgets the scans of every robot but `keep` (the page stopped drawing them). @param {number | null} keep */
export function forgetScans(keep) {
  for (const id of [...world.scans.keys()]) if (id !== keep) world.scans.delete(id);
}

/** @type {Record<string, (m: any) => void>} */
const take = {
  /** @param {import("./types.js").PageHello} m */
  hello(m) { world.live = m.live; world.sim = m.sim; world.steer = m.steer !== false; },
  scene,
  frame,
  /** @param {PageStatus} m */
  status(m) { world.status = m; },
  /** @param {import("./types.js").PageReadings} m */
  readings(m) { for (const [id, v] of Object.entries(m.prox)) world.prox.set(Number(id), v); },
  /** @param {import("./types.js").PageScans} m */
  scans(m) { for (const [id, v] of Object.entries(m.scans)) world.scans.set(Number(id), v); },
  /** @param {PageReading} m */
  reading(m) { world.reading = m; },
  event,
  /** @param {PageTimeline} m */
  timeline(m) {
    const marks = m.marks === null && world.timeline ? world.timeline.marks : m.marks;
    world.timeline = { ...m, marks: marks || [] };
  },
};

/**
 * Takes in one message from the server, then tells those listening for its type.
 * @param {PageMessage} m
 */
export function apply(m) {
  const t = take[m.type];
  if (t) t(m);
  world.version += 1;
  tell(m.type, m);
}
