// @ts-check
// The driver's HUD over the 3D view: which chair, its speed, the speed level, the assistance and
// whether it stepped in, the nearest obstacle (a warning when close), and who drives. The chair is
// the one the 3D camera follows; the drive state comes from drive.js (`show(driveState)` on each
// change; null robot: not driving), and speed from the chair's own motion between frames when no
// one drives.
import { STATE_MEANS } from "./palette.js";

/**
 * @typedef {object} DriveState  what drive.js says of the chair being driven (x35b's driveState)
 * @property {number | null} robot  the chair driven (null: not driving)
 * @property {string} driver  who drives it ("" nobody)
 * @property {boolean} you  this page drives it
 * @property {number} level  speed level 1..5
 * @property {string} assist  off, safe or assist
 * @property {number} v_mps  the command after assistance
 * @property {number} w_radps
 * @property {boolean} intervened  the assistance changed the driver's command
 * @property {number | null} nearest_m  nearest obstacle the chair's sensors see (null: nothing in range)
 * @property {boolean} stale  no input for 300 ms: the dead-man stopped the chair
 */

export const WARN_M = 1.0;     // nearest obstacle closer than this: an amber warning
export const DANGER_M = 0.4;   // closer than this: red
const LEVELS = 5;

export class DriveHud {
  /**
   * @param {HTMLElement} el
   * @param {typeof import("./world.js").world} world  read only
   */
  constructor(el, world) {
    this.el = el;
    this.world = world;
    /** @type {DriveState | null} */
    this.state = null;
    /** @type {number} the robot the 3D camera follows (-1: none) */
    this.index = -1;
    this.shownKey = "";
    this.shown = false;
    /** @type {{x: number, y: number, t: number, id: number} | null} */
    this.prev = null;
    this.speed = 0;
  }

  /** @param {boolean} on */
  setShown(on) { this.shown = on; this.el.hidden = !on; this.shownKey = ""; }

  /** Takes drive.js's state (a copy is kept). @param {DriveState | null} s */
  show(s) { this.state = s && s.robot !== null ? { ...s } : null; this.shownKey = ""; }

  /** @param {number} i the index in world.ids of the chair the camera follows */
  follow(i) { this.index = i; }

  // the followed chair's speed from its last two frames (m/s of simulation time)
  measure() {
    const w = this.world;
    const i = this.index;
    if (i < 0 || i >= w.ids.length) { this.prev = null; return; }
    const now = { x: w.x[i], y: w.y[i], t: w.t_ns, id: w.ids[i] };
    const p = this.prev;
    if (p && p.id === now.id && now.t > p.t) this.speed = Math.hypot(now.x - p.x, now.y - p.y) / ((now.t - p.t) / 1e9);
    else if (!p || p.id !== now.id) this.speed = 0;
    if (!p || now.t !== p.t) this.prev = now;
  }

  draw() {
    if (!this.shown) return;
    this.measure();
    const w = this.world;
    const i = this.index;
    const s = this.state;
    const key = `${w.version}:${i}:${JSON.stringify(s)}`;
    if (key === this.shownKey) return;
    this.shownKey = key;
    if (i < 0 || i >= w.ids.length) { this.el.innerHTML = "<div class=\"hud-chair\">no chair to follow</div>"; return; }
    const id = w.ids[i];
    const r = w.robots.get(id);
    const st = w.states[i] || "driving";
    const driving = s && s.robot === id ? s : null;
    const v = driving ? driving.v_mps : this.speed;
    const top = r && typeof r.spec.max_speed_mps === "number" ? r.spec.max_speed_mps : 1;
    let h = `<div class="hud-chair">chair ${id}${r ? ` \u00b7 ${esc(r.name)}` : ""}<span class="hud-state ${st}">${STATE_MEANS[st].split(" (")[0]}</span></div>`;
    h += `<div class="hud-speed"><b>${Math.abs(v).toFixed(2)}</b> m/s<span class="hud-bar"><i style="width:${Math.min(100, (100 * Math.abs(v)) / top).toFixed(0)}%"></i></span></div>`;
    // nothing in range (null) is no warning: compared as a number, null was 0 m and shown red
    const near = driving ? (driving.nearest_m === null ? Infinity : driving.nearest_m) : nearestSeen(w, id);
    const cls = near < DANGER_M ? "danger" : near < WARN_M ? "warn" : "";
    h += `<div class="hud-near ${cls}">${Number.isFinite(near) ? `nearest obstacle ${near.toFixed(2)} m` : "nothing in sensor range"}</div>`;
    if (driving) {
      const lv = Array.from({ length: LEVELS }, (_, k) => `<i class="${k < driving.level ? "on" : ""}"></i>`).join("");
      h += `<div class="hud-level">speed level <span class="hud-dots">${lv}</span> ${driving.level}/${LEVELS}</div>`;
      h += `<div class="hud-assist ${driving.intervened ? "intervened" : ""}">assistance ${esc(driving.assist)}${driving.intervened ? " \u00b7 stepped in" : ""}</div>`;
      h += `<div class="hud-driver">${driving.you ? "you drive" : driving.driver ? `driven by ${esc(driving.driver)}` : "nobody drives"}${driving.stale ? " \u00b7 no input: stopped" : ""}</div>`;
    } else {
      h += "<div class=\"hud-driver\">watching (not driving)</div>";
    }
    this.el.innerHTML = h;
  }
}

/**
 * The nearest thing a robot's proximity sensors and laser scanners read (Infinity: none).
 * @param {typeof import("./world.js").world} w @param {number} id
 */
export function nearestSeen(w, id) {
  let best = Infinity;
  for (const d of w.prox.get(id) || []) if (d !== null && d < best) best = d;
  for (const scan of w.scans.get(id) || []) for (const d of scan) if (d !== null && d < best) best = d;
  return best;
}

/** @param {unknown} s */
function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => /** @type {Record<string, string>} */ ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
}
