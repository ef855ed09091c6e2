// @ts-check
// iwz view: driving a chair from the page (docs/driving.md, "From the page"). The inputs (keyboard,
// gamepad, on-screen joystick), the drive panel, and the chair's drive state as its agent tells it.
// The page sends a `drive` command at a steady 20 Hz while it drives, and at once when a key
// changes or the stick (on-screen or gamepad) moves (looked at every animation frame, sent at most
// every CHANGE_MS); zero when the tab is hidden or the gamepad is unplugged; a release when the page closes.
// The chair's agent decides who drives (one driver, explicit takeover) and stops the chair by itself
// when no input came for 300 ms: the page's zero and release only make that sooner.
// It reads the world (world.js) and never writes it; app.js wires it in one place (initDrive).
import { world, on } from "./world.js";

/**
 * What the chair's agent says of its driving (a `drive` message's `state`: iw.DriveState).
 * @typedef {{driver: string, level: number, assist: string, v_mps: number, w_radps: number,
 *   input_v_mps: number, input_w_radps: number, intervened: boolean, nearest_m: number | null,
 *   goal: number[] | null, stale: boolean}} DriveState
 */
/**
 * The drive state of the chair this page drives (``robot`` null: it drives none), for the HUD.
 * @typedef {{robot: number | null, driver: string, you: boolean, level: number, assist: string,
 *   v_mps: number, w_radps: number, intervened: boolean, nearest_m: number | null, stale: boolean,
 *   goal: number[] | null, accepting: boolean}} PageDriveState
 */
/**
 * What the page (app.js) gives this module.
 * @typedef {{send: (cmd: any) => void, toast: (text: string) => void,
 *   setView: (mode: "2d" | "first" | "third" | "free") => void,
 *   onMapClick: (fn: (x: number, y: number) => boolean) => void}} DriveHooks
 */

export const SEND_MS = 50;          // the steady rate of input while driving: 20 Hz
const CHANGE_MS = 30;               // a stick that moved is sent at once, at most this often (with the
                                    // steady 20 Hz, at most 40 a second: the viewer takes 50 a second)
export const LEVELS = 5;            // speed levels 1..5
const DEADMAN_BUTTONS = [0, 4];     // gamepad: A / cross, or the left shoulder, must be held to drive
const LEVEL_UP_BUTTON = 12;         // gamepad: d-pad up / down change the speed level
const LEVEL_DOWN_BUTTON = 13;
const ASSISTS = ["off", "safe", "assist"];
const KEYS = {
  ArrowUp: "up", KeyW: "up", ArrowDown: "down", KeyS: "down",
  ArrowLeft: "left", KeyA: "left", ArrowRight: "right", KeyD: "right",
};

/** @type {PageDriveState} */
export const driveState = {
  robot: null, driver: "", you: false, level: 3, assist: "off", v_mps: 0, w_radps: 0,
  intervened: false, nearest_m: null, stale: false, goal: null, accepting: false,
};

/** @type {((s: PageDriveState) => void)[]} */
const listeners = [];
/** Calls ``fn`` with the drive state whenever it changes (the HUD's hook). */
export function onDriveChange(fn) { listeners.push(fn); }

/** @type {DriveHooks | null} */
let hooks = null;
let me = "";                    // this page's driver name, as the server named it in its hello
/** @type {Map<number, DriveState>} */
const states = new Map();       // chair id -> its agent's last drive state (chairs that accept a driver)
let seq = 0;
let taking = false;             // the next inputs ask to take the chair over
let awaitingFree = false;       // opened on a chair another drove: taken once it is free
let pendingGoto = /** @type {number[] | null} */ (null);
let pendingAssist = /** @type {string | null} */ (null);
let armedGoto = false;          // the next click on the map is where to go
let wantFromUrl = /** @type {number | null} */ (null);
let hidden = false;
let timer = /** @type {number | null} */ (null);
const held = new Set();         // direction keys held
const stick = { x: 0, y: 0, active: false };
let padIndex = /** @type {number | null} */ (null);
let padButtons = /** @type {boolean[]} */ ([]);
let lastSent = "";
let lastSentAt = -Infinity;    // when (performance.now ms)
let polling = false;           // the stick is looked at every animation frame while driving
let refusedWhy = "";            // why the viewer refused this page's last drive (shown until it drives again)

const $ = (/** @type {string} */ id) => document.getElementById(id);

function changed() {
  const s = driveState.robot === null ? undefined : states.get(driveState.robot);
  driveState.accepting = s !== undefined;
  if (s) {
    driveState.driver = s.driver; driveState.you = me !== "" && s.driver === me;
    driveState.assist = s.assist; driveState.v_mps = s.v_mps; driveState.w_radps = s.w_radps;
    driveState.intervened = s.intervened; driveState.nearest_m = s.nearest_m; driveState.stale = s.stale;
    driveState.goal = s.goal;
    if (driveState.you) { taking = false; awaitingFree = false; }
    else if (awaitingFree && s.driver === "") { awaitingFree = false; taking = true; }  // free now: taken at once
  }
  panel();
  for (const fn of listeners) fn(driveState);
}

/** Whether chair ``id``'s agent accepts a driver (it tells its drive state). */
export function accepts(id) { return states.has(id); }

/** Starts driving chair ``id`` (its drive panel opens; the first person view is the page's choice). */
export function startDriving(id) {
  if (driveState.robot !== null && driveState.robot !== id) stopDriving();
  refusedWhy = "";
  const s = states.get(id);
  driveState.robot = id;
  driveState.level = s ? s.level : driveState.level;
  taking = !s || s.driver === "";  // a free chair is taken at once; another's only by "take over"
  awaitingFree = !taking;  // (or once its driver leaves it: the first state told may be one from before a release)
  if (timer === null) timer = window.setInterval(tick, SEND_MS);
  if (!polling) { polling = true; requestAnimationFrame(poll); }
  if (hooks) hooks.setView("first");  // the driver's seat: first person, following this chair
  changed();
  tick();
}

/** Leaves the chair: a release, and no more input. */
export function stopDriving() {
  if (driveState.robot === null) return;
  if (mine()) send({ release: true });
  driveState.robot = null; driveState.you = false; driveState.driver = "";
  taking = false; awaitingFree = false; armedGoto = false;
  if (timer !== null) { clearInterval(timer); timer = null; }
  changed();
}

/** Asks to take the chair over from whoever drives it. */
export function takeOver() { taking = true; tick(); }

function mine() { return driveState.robot !== null && (driveState.you || taking); }

/** @param {{x?: number, y?: number, buttons?: number, release?: boolean}} over */
function send(over) {
  if (!hooks || driveState.robot === null) return;
  const input = current();
  const drive = {
    seq: (seq = (seq + 1) % 2147483647), x: input.x, y: input.y, buttons: input.buttons,
    level: driveState.level, take: taking, release: false, goto: pendingGoto, assist: pendingAssist, ...over,
  };
  pendingGoto = null; pendingAssist = null;
  lastSent = `${drive.x},${drive.y},${drive.buttons},${drive.level}`;
  lastSentAt = performance.now();
  hooks.send({ cmd: "drive", robot_id: driveState.robot, drive });
}

function clamp(v) { return Math.max(-1, Math.min(1, Number.isFinite(v) ? v : 0)); }

/** The input now: the joystick while dragged, else the keys held, else the gamepad (dead-man held). */
function current() {
  if (hidden) return { x: 0, y: 0, buttons: 0 };
  if (stick.active) return { x: clamp(stick.x), y: clamp(stick.y), buttons: 1 };
  if (held.size) {
    const y = (held.has("up") ? 1 : 0) - (held.has("down") ? 1 : 0);
    const x = (held.has("right") ? 1 : 0) - (held.has("left") ? 1 : 0);
    return { x, y, buttons: 1 };
  }
  const pad = gamepad();
  if (pad) {
    const dead = DEADMAN_BUTTONS.some((b) => pad.buttons[b] && pad.buttons[b].pressed);
    if (dead) return { x: clamp(pad.axes[0] || 0), y: clamp(-(pad.axes[1] || 0)), buttons: 1 };
  }
  return { x: 0, y: 0, buttons: 0 };
}

/** The gamepad in use (the first connected one), or null; a level change on its d-pad. */
function gamepad() {
  const pads = navigator.getGamepads ? [...navigator.getGamepads()].filter((p) => p && p.connected) : [];
  const pad = padIndex !== null ? pads.find((p) => p && p.index === padIndex) || null : pads[0] || null;
  if (!pad) {
    if (padIndex !== null) unplugged();
    return null;
  }
  padIndex = pad.index;
  const now = pad.buttons.map((b) => b.pressed);
  if (now[LEVEL_UP_BUTTON] && !padButtons[LEVEL_UP_BUTTON]) level(+1);
  if (now[LEVEL_DOWN_BUTTON] && !padButtons[LEVEL_DOWN_BUTTON]) level(-1);
  padButtons = now;
  return pad;
}

function unplugged() {
  padIndex = null; padButtons = [];
  if (mine()) send({ x: 0, y: 0, buttons: 0 });  // at once, not at the next tick
  if (hooks && driveState.robot !== null) hooks.toast("the gamepad was unplugged: the chair stops");
}

/** Every animation frame while driving: a stick (on-screen or gamepad) that moved is sent at once,
 * not at the next 20 Hz tick (at most every CHANGE_MS). */
function poll() {
  if (timer === null) { polling = false; return; }  // not driving: the loop ends
  requestAnimationFrame(poll);
  if (!mine() || hidden || performance.now() - lastSentAt < CHANGE_MS) return;
  const input = current();
  if (`${input.x},${input.y},${input.buttons},${driveState.level}` !== lastSent) send({});
}

/** Every SEND_MS while driving: the input, if this page drives (or asks to). */
function tick() {
  if (!mine() || hidden) return;
  send({});
}

function level(step) {
  driveState.level = Math.max(1, Math.min(LEVELS, driveState.level + step));
  changed();
  tick();
}

function setKey(e, down) {
  const t = /** @type {HTMLElement | null} */ (e.target);
  if (t && (t.tagName === "INPUT" || t.tagName === "TEXTAREA")) return;  // typing, not driving
  if (driveState.robot === null) return;
  const dir = KEYS[e.code];
  if (dir) {
    if (t && t.tagName === "SELECT") t.blur();  // the arrows drive, not a menu that has the focus
    e.preventDefault();
    e.stopImmediatePropagation();  // WASD drive the chair, not the free camera
    const had = held.has(dir);
    if (down) held.add(dir); else held.delete(dir);
    if (had !== down) tick();  // at once: the latency is the key's, not the 20 Hz tick's
    return;
  }
  if (!down) return;
  if (e.key === "+" || e.key === "=" || e.code === "NumpadAdd") level(+1);
  else if (e.key === "-" || e.code === "NumpadSubtract") level(-1);
  else if (e.code === "KeyG") armGoto();
  else if (e.code === "Escape" && armedGoto) { armedGoto = false; panel(); }
}

function armGoto() {
  armedGoto = !armedGoto;
  if (armedGoto && hooks) hooks.setView("2d");  // the spot is clicked on the 2D map
  panel();
}

function setHidden(now) {
  if (now === hidden) return;
  hidden = now;
  if (hidden) {
    held.clear(); stick.active = false;
    if (mine()) send({ x: 0, y: 0, buttons: 0 });  // zero at once: a hidden page sends nothing more
  } else tick();
}

// --- the drive panel and its joystick ------------------------------------------------------------

const PANEL = `
<div id="drive-head"><b id="drive-title"></b><button id="drive-leave" title="stop driving (Esc twice)">leave</button></div>
<div id="drive-status"></div>
<button id="drive-take" hidden title="take the chair from whoever drives it">take over</button>
<div id="drive-row">
  <span>level <button id="drive-down" title="slower (-)">-</button> <b id="drive-level"></b>/${LEVELS} <button id="drive-up" title="faster (+)">+</button></span>
  <select id="drive-assist" title="shared control: off (as given), safe (never into what the chair sees), assist (steers round obstacles)">
    ${ASSISTS.map((a) => `<option value="${a}">${a}</option>`).join("")}
  </select>
  <button id="drive-goto" title="then click a spot on the 2D map: the chair's planner takes it there (G)">go there</button>
</div>
<div id="drive-read"></div>
<div id="drive-stick" title="drag: forward, back, turn"><div id="drive-knob"></div></div>
<div id="drive-help">arrows / WASD drive, + - speed level, G go there; a gamepad: left stick, hold A or LB</div>`;

function panel() {
  const p = $("drive");
  if (!p) return;
  p.hidden = driveState.robot === null && !refusedWhy;
  if (driveState.robot === null) return;
  const id = driveState.robot;
  const r = world.robots.get(id);
  const name = r ? r.name : "";
  const t = $("drive-title");
  if (t) t.textContent = `driving chair ${id}${name ? ` \u00b7 ${name}` : ""}`;
  let status = "waiting for the chair's agent (does it accept a driver?)";
  if (driveState.accepting) {
    if (driveState.you) status = "you drive";
    else if (taking) status = "taking the chair...";
    else if (driveState.driver) status = `${driveState.driver} drives: take over to drive`;
    else status = "nobody drives";
  }
  if (driveState.stale && driveState.you) status += " \u00b7 stopped: no input (dead-man)";
  if (armedGoto) status += " \u00b7 click the map where to go (Esc: no)";
  $("drive-status").textContent = status;
  $("drive-take").hidden = !driveState.accepting || driveState.you || taking || driveState.driver === "";
  $("drive-level").textContent = String(driveState.level);
  const sel = /** @type {HTMLSelectElement} */ ($("drive-assist"));
  if (document.activeElement !== sel) sel.value = driveState.assist;
  $("drive-goto").classList.toggle("active", armedGoto);
  const near = driveState.nearest_m === null ? "-" : `${driveState.nearest_m.toFixed(2)} m`;
  $("drive-read").textContent = `v ${driveState.v_mps.toFixed(2)} m/s \u00b7 w ${driveState.w_radps.toFixed(2)} rad/s \u00b7 nearest ${near}` +
    (driveState.intervened ? " \u00b7 assistance stepped in" : "") +
    (driveState.goal ? ` \u00b7 going to ${driveState.goal[0].toFixed(1)}, ${driveState.goal[1].toFixed(1)}` : "");
}

function makePanel() {
  const stage = $("stage") || document.body;
  const p = document.createElement("div");
  p.id = "drive";
  p.hidden = true;
  p.innerHTML = PANEL;
  stage.appendChild(p);
  $("drive-leave").onclick = () => { refusedWhy = ""; stopDriving(); panel(); };
  $("drive-take").onclick = () => takeOver();
  $("drive-up").onclick = () => level(+1);
  $("drive-down").onclick = () => level(-1);
  $("drive-goto").onclick = () => armGoto();
  const sel = /** @type {HTMLSelectElement} */ ($("drive-assist"));
  sel.onchange = () => { pendingAssist = sel.value; sel.blur(); tick(); };
  const pad = /** @type {HTMLElement} */ ($("drive-stick"));
  const knob = /** @type {HTMLElement} */ ($("drive-knob"));
  const move = (/** @type {PointerEvent} */ e) => {
    const r = pad.getBoundingClientRect();
    const radius = r.width / 2;
    let x = (e.clientX - r.left - radius) / radius;
    let y = -(e.clientY - r.top - radius) / radius;
    const n = Math.hypot(x, y);
    if (n > 1) { x /= n; y /= n; }
    stick.x = x; stick.y = y;
    knob.style.transform = `translate(${x * radius}px, ${-y * radius}px)`;
  };
  const end = () => {
    if (!stick.active) return;
    stick.active = false; stick.x = 0; stick.y = 0;
    knob.style.transform = "";
    tick();
  };
  pad.addEventListener("pointerdown", (e) => {
    e.preventDefault();
    pad.setPointerCapture(e.pointerId);
    stick.active = true;
    move(e);
    tick();
  });
  pad.addEventListener("pointermove", (e) => { if (stick.active) move(e); });
  pad.addEventListener("pointerup", end);
  pad.addEventListener("pointercancel", end);
  pad.addEventListener("lostpointercapture", end);
}

/** A click on the 2D map (no robot there) while "go there" is armed: where to go. @returns {boolean} taken */
function mapClick(/** @type {number} */ x, /** @type {number} */ y) {
  if (!armedGoto || driveState.robot === null) return false;
  armedGoto = false;
  pendingGoto = [Math.round(x * 1000) / 1000, Math.round(y * 1000) / 1000];
  send({});
  panel();
  return true;
}

// --- what the server says ------------------------------------------------------------------------

/** The server's hello: this page's driver name. */
function onHello(m) { me = m.driver || ""; changed(); }

/** A chair's drive state (``drive`` message): ``state`` null when its agent no longer accepts a driver. */
function onDrive(m) {
  const id = m.robot_id;
  if (m.state) states.set(id, m.state); else states.delete(id);
  if (wantFromUrl === id && m.state) { wantFromUrl = null; startDriving(id); return; }
  if (id === driveState.robot) changed();
  else for (const fn of listeners) fn(driveState);
}

/** A refused command: a refused drive of the chair driven ends the driving (the panel says why). */
function onError(m) {
  if (m.drive_robot === null || m.drive_robot === undefined || m.drive_robot !== driveState.robot) return;
  stopDriving();
  refusedWhy = m.error;
  const p = $("drive");
  if (p) { p.hidden = false; $("drive-status").textContent = m.error; $("drive-take").hidden = true; }
}

/** The roster changed: chairs no longer in the world are forgotten (and left, if driven). */
function onRoster(ids) {
  const have = new Set(ids);
  for (const id of [...states.keys()]) if (!have.has(id)) states.delete(id);
  if (driveState.robot !== null && !have.has(driveState.robot)) stopDriving();
}

/** The robot panel's drive button: for a chair whose agent accepts a driver, not driven from here already. */
function driveButton() {
  const b = $("btn-drive");
  if (!b) return;
  const sel = world.selected;
  b.hidden = !sel || sel.kind !== "robot" || !states.has(sel.id) || driveState.robot === sel.id;
}

/** Wires the inputs; ``?drive=ID`` in the address drives chair ID as soon as its agent says it accepts a driver. */
export function initDrive(/** @type {DriveHooks} */ h) {
  hooks = h;
  makePanel();
  on("hello", onHello);
  on("drive", onDrive);
  on("error", onError);
  on("frame", (m) => { if (m.ids !== null) onRoster(m.ids); });
  on("select", driveButton);
  onDriveChange(driveButton);
  h.onMapClick(mapClick);
  const b = $("btn-drive");
  if (b) b.onclick = () => { const sel = world.selected; if (sel && sel.kind === "robot") startDriving(sel.id); };
  const want = new URLSearchParams(location.search).get("drive");
  if (want !== null && /^\d+$/.test(want)) wantFromUrl = Number(want);
  window.addEventListener("keydown", (e) => setKey(e, true), true);
  window.addEventListener("keyup", (e) => setKey(e, false), true);
  window.addEventListener("blur", () => { if (held.size) { held.clear(); tick(); } });
  document.addEventListener("visibilitychange", () => setHidden(document.visibilityState === "hidden"));
  window.addEventListener("pagehide", () => {  // the page closes: the chair is released, and nothing more is sent
    if (mine()) send({ x: 0, y: 0, buttons: 0, release: true });
    taking = false; driveState.you = false;
    if (timer !== null) { clearInterval(timer); timer = null; }
  });
  window.addEventListener("gamepaddisconnected", (e) => {
    const g = /** @type {GamepadEvent} */ (e).gamepad;
    if (padIndex !== null && (!g || g.index === padIndex)) unplugged();
  });
}

/** What was last sent (for the page's own checks): "x,y,buttons,level". */
export function lastInput() { return lastSent; }
