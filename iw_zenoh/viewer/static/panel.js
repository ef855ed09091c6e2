// @ts-check
// The side panel: a selected robot's agent, readings, spec (a readable table: sizes and speeds
// with their units, one row per sensor) and recent events; or a selected obstacle.
import { world } from "./world.js";
import { laserAngle } from "./view2d.js";

/** @typedef {import("./types.js").PageRobot} PageRobot */

/** @param {unknown} s */
export function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => /** @type {Record<string, string>} */ ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
}
/** @param {string} k @param {string} v */
function row(k, v) { return `<tr><td>${k}</td><td>${v}</td></tr>`; }
/** @param {number | null | undefined} v */
function num(v, d = 3) { return v === null || v === undefined ? "-" : Number(v).toFixed(d); }

// the spec's plain fields: [field, label, unit, decimals]; the lists (sensors, lasers, bumpers) get a table each
/** @type {[string, string, string, number][]} */
const SPEC_ROWS = [
  ["type", "type", "", -1],
  ["shape", "shape", "", -1],
  ["width_m", "length (along the heading)", "m", 2],
  ["height_m", "width (wheel base)", "m", 2],
  ["com", "front ahead of the wheel axis", "of the length", 2],
  ["max_speed_mps", "top speed", "m/s", 2],
  ["acceleration_curve", "motor inertia (0 none, 1 never moves)", "", 2],
  ["ticks_per_m", "encoder", "ticks/m", 0],
  ["x_m", "start x", "m", 2],
  ["y_m", "start y", "m", 2],
  ["dir_deg", "start heading", "\u00b0", 1],
  ["beacon_height_m", "carries a beacon", "m high", 2],
];

/** @param {any} v @param {string} unit @param {number} d */
function valued(v, unit, d) {
  if (d < 0 || typeof v !== "number") return esc(v);
  return unit ? `${num(v, d)} ${unit}` : num(v, d);
}

/**
 * An agent's process name told so that a person can place it: a scenario's `agent-N-PROGRAM`
 * becomes "the scenario's agent N, program PROGRAM", with the robots it drives.
 * @param {string} agent @param {number} id
 */
export function agentText(agent, id) {
  if (!agent) return "(none known)";
  const m = /^agent-(\d+)-(.+)$/.exec(agent);
  const said = m ? `${esc(agent)} (the scenario's agent ${m[1]}, program ${esc(m[2])})` : esc(agent);
  const others = [...world.robots.values()].filter((r) => r.agent === agent && r.id !== id);
  return others.length ? `${said}; also drives ${others.map((r) => `${r.id} ${esc(r.name)}`).join(", ")}` : said;
}

/** The spec as tables. @param {PageRobot} r */
export function specTables(r) {
  const s = r.spec;
  let h = "<h4>spec</h4><table class=\"spec\">";
  for (const [k, label, unit, d] of SPEC_ROWS) {
    if (s[k] === null || s[k] === undefined) continue;
    h += row(label, valued(s[k], unit, d));
  }
  if (s.legacy) h += row("legacy powers", "yes (Ciber-Rato rules)");
  if (s.noise) h += row("sensor noise", Object.entries(s.noise).filter(([, n]) => n).map(([k, n]) => `${esc(k)}: \u03c3 ${num(/** @type {any} */ (n).std, 3)}`).join("<br>") || "none");
  h += "</table>";
  if (r.sensors.length) {
    h += "<h4>proximity sensors</h4><table class=\"sensors\"><tr><th>id</th><th>at (m)</th><th>looks</th><th>cone</th><th>range</th></tr>";
    for (const x of r.sensors) {
      h += `<tr><td>${x.id}</td><td>${num(x.x, 2)}, ${num(x.y, 2)}</td><td>${num(x.angle_deg, 0)}\u00b0</td><td>${num(x.cone_deg, 0)}\u00b0</td><td>${num(x.range_m, 1)} m</td></tr>`;
    }
    h += "</table>";
  }
  if (r.lasers.length) {
    h += "<h4>laser scanners</h4><table class=\"sensors\"><tr><th>id</th><th>at (m)</th><th>looks</th><th>field</th><th>beams</th><th>range</th></tr>";
    for (const l of r.lasers) {
      h += `<tr><td>${l.id}</td><td>${num(l.x, 2)}, ${num(l.y, 2)}</td><td>${num(l.angle_deg, 0)}\u00b0</td><td>${num(l.fov_deg, 0)}\u00b0</td><td>${l.beams}</td><td>${num(l.range_m, 1)} m</td></tr>`;
    }
    h += "</table>";
  }
  if (s.bumpers && s.bumpers.length) {
    h += "<h4>bumpers</h4><table class=\"sensors\"><tr><th>id</th><th>corners (m)</th></tr>";
    for (const b of s.bumpers) h += `<tr><td>${b.id}</td><td>${b.corners.map((/** @type {number[]} */ c) => `(${num(c[0], 2)}, ${num(c[1], 2)})`).join(" ")}</td></tr>`;
    h += "</table>";
  }
  return h;
}

/** a scan's nearest range, and the direction of its beam from the heading
 * @param {{id: number, ranges: (number | null)[]}} scan @param {PageRobot | undefined} robot */
function nearest(scan, robot) {
  let best = -1;
  scan.ranges.forEach((v, k) => { if (v !== null && (best < 0 || v < /** @type {number} */ (scan.ranges[best]))) best = k; });
  if (best < 0) return "nothing in range";
  const l = robot && robot.lasers.find((a) => a.id === scan.id);
  const at = l ? ` at ${num(laserAngle(l, best), 1)}\u00b0` : "";
  return `nearest ${num(scan.ranges[best], 2)} m${at}`;
}

/** @param {HTMLElement} title @param {HTMLElement} body */
export function drawPanel(title, body) {
  const sel = world.selected;
  if (!sel) { body.innerHTML = ""; return; }
  if (sel.kind === "obstacle") {
    const o = world.scene && world.scene.obstacles.find((ob) => ob.name === sel.name);
    title.textContent = `obstacle ${sel.name}`;
    body.innerHTML = o ? `<table>${row("from", `${num(o.x0, 2)}, ${num(o.y0, 2)} m`)}${row("to", `${num(o.x1, 2)}, ${num(o.y1, 2)} m`)}${row("height", `${num(o.height, 2)} m`)}</table><p>Drag it on the map to move it.</p>` : "";
    return;
  }
  const r = world.robots.get(sel.id);
  title.textContent = `robot ${sel.id}${r ? ` \u00b7 ${r.name}` : ""}`;
  const m = world.reading && world.reading.robot_id === sel.id ? world.reading : null;
  let h = "<table>";
  const agent = (m && m.reading && m.reading.agent) || (r && r.agent) || "";
  if (m || r) h += row("agent", agentText(agent, sel.id));
  if (m) {
    const rd = m.reading || {};
    h += row("pose", m.pose ? `${num(m.pose[0], 2)} m, ${num(m.pose[1], 2)} m, ${num(m.pose[2] * 180 / Math.PI, 1)}\u00b0` : "-");
    h += row("speed", `${num(m.speed, 2)} m/s`);
    h += row("motors", m.motors ? `L ${num(m.motors[0], 4)} R ${num(m.motors[1], 4)} (power)` : "-");
    if (m.reading) {
      h += row("proximity", rd.proximity_ids.map((/** @type {number} */ id, /** @type {number} */ i) => `${id}: ${rd.proximity_m[i] === null ? "nothing in range" : `${num(rd.proximity_m[i], 2)} m`}`).join("<br>"));
      h += row("compass", `${num(rd.compass_deg, 1)}\u00b0`);
      h += row("beacons", (rd.beacons_deg || []).map((/** @type {number | null} */ b) => (b === null ? "not seen" : `${num(b, 1)}\u00b0`)).join(", ") || "-");
      h += row("gps", rd.gps.length === 3 ? `${num(rd.gps[0], 2)} m, ${num(rd.gps[1], 2)} m, ${num(rd.gps[2], 1)}\u00b0` : rd.gps.map((/** @type {number} */ v) => num(v, 2)).join(", "));
      h += row("ground", esc(rd.ground));
      h += row("collision", rd.collision ? "yes" : "no");
      h += row("bumpers", (rd.bumpers || []).map((/** @type {boolean} */ b) => (b ? "hit" : "-")).join(" ") || "-");
      h += row("encoders", `${rd.encoders.join(", ")} ticks`);
      for (const scan of rd.lasers || []) h += row(`laser ${scan.id}`, nearest(scan, r));
      h += row("reading of tick", esc(rd.tick));
    }
  }
  h += "</table>";
  if (r) h += specTables(r);
  if (m && m.events.length) {
    h += "<h4>recent events</h4><table>";
    for (const e of m.events.slice().reverse()) h += row(`${(e.t_ns / 1e9).toFixed(1)} s`, `${esc(e.kind)}: ${esc(e.reason)}`);
    h += "</table>";
  }
  body.innerHTML = h;
}
