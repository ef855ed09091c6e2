// @ts-check
// iwz view: the page. Connects to the server's WebSocket, hands its messages to the world
// (world.js, their one owner), and wires the bar, the panel, the views and the timeline.
// No build step, no library. Scripts and tests get their hooks only when the page's address
// says `?hooks=1` (hooks.js; docs/viewer.md).
import { world, apply, on, changed, select, setConnected, expireFlashes, forgetScans } from "./world.js";
import { View2D } from "./view2d.js";
import { View3D } from "./view3d.js";
import { Timeline } from "./timeline.js";
import { drawPanel } from "./panel.js";
import { Legend } from "./legend.js";
import { DriveHud } from "./drivehud.js";
import { driveState, onDriveChange, initDrive } from "./drive.js";

/** @typedef {import("./types.js").PageCommand} PageCommand */
/** @typedef {"2d" | "first" | "third" | "free"} ViewMode */

const RADIO_SHOWN = 8;        // radio lines shown at once
const PANEL_EVERY_MS = 250;   // how often the open robot panel asks for its reading
const SCANS_ALL_MAX = 100;    // past this many robots the scans are drawn for the selected one only (until asked)
const KEY_VIEWS = /** @type {Record<string, ViewMode>} */ ({ 1: "first", 2: "2d", 3: "third", 4: "free" });

/** @param {string} id */
const $ = (id) => /** @type {HTMLElement} */ (document.getElementById(id));
/** @param {string} id */
const input = (id) => /** @type {HTMLInputElement} */ (document.getElementById(id));

/** @type {WebSocket | null} */
let ws = null;
/** @type {View2D} */
let view2d;
/** @type {View3D | null} */
let view3d = null;
/** @type {Timeline} */
let timeline;
/** @type {DriveHud} */
let driveHud;
/** @type {ViewMode} */
let last3d = "first";
/** @type {number | null} */
let followId = null;
let scansChosen = false;  // the scans toggle was set by hand: the roster's size no longer sets it
const SCANS_ALL = JSON.stringify({ cmd: "scans", scans: "all" });
let scansSaid = SCANS_ALL;  // whose scans the server was last told this page draws (every robot's until told)
/** @type {((cmd: PageCommand) => void)[]} */
const sendTaps = [];
/** @type {((x: number, y: number) => boolean)[]} */
const mapClicks = [];

/** Sends a command to the server (dropped while not connected). @param {PageCommand} cmd */
export function send(cmd) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(cmd));
  for (const fn of sendTaps) fn(cmd);
}

/** Calls `fn` with every command sent (hooks.js keeps the last ones). @param {(cmd: PageCommand) => void} fn */
export function tapSent(fn) { sendTaps.push(fn); }

/**
 * Calls `fn(x, y)` (metres) when the 2D map is clicked where there is no robot; `fn` returns true
 * when it took the click (go there while driving), and nothing is selected then.
 * @param {(x: number, y: number) => boolean} fn
 */
export function onMapClick(fn) { mapClicks.push(fn); }

/** Shows a line at the top of the map for five seconds. @param {string} text */
export function toast(text) {
  const t = $("toast");
  t.textContent = text;
  t.hidden = false;
  clearTimeout(/** @type {any} */ (toast).timer);
  /** @type {any} */ (toast).timer = setTimeout(() => { t.hidden = true; }, 5000);
}

/** The driving HUD over the 3D view (drive.js hands it the drive state: `hud3d().show(driveState)`). */
export function hud3d() { return driveHud; }

/**
 * The 3D cameras and the HUD follow this chair (drive.js: the one driven); null: the selected
 * one, else the first.
 * @param {number | null} id
 */
export function followChair(id) { followId = id; if (view3d) view3d.follow(id); }

// tells the server whose laser scans this page draws (every robot's, the selected one's, or none),
// so that it sends no others, and forgets the ones it no longer draws
function tellScans() {
  const sel = world.selected && world.selected.kind === "robot" ? world.selected.id : null;
  /** @type {PageCommand} */
  let want = { cmd: "scans", scans: "all" };
  if (!input("opt-scans").checked) want = sel === null ? { cmd: "scans", scans: "none" } : { cmd: "scans", scans: "selected", robot_id: sel };
  const key = JSON.stringify(want);
  if (key === scansSaid || !ws || ws.readyState !== WebSocket.OPEN) return;
  scansSaid = key;
  if (want.scans !== "all") forgetScans(sel);
  send(want);
}

function connect() {
  const key = new URLSearchParams(location.search).get("key");  // the address's key goes on to the socket
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${key ? `?key=${encodeURIComponent(key)}` : ""}`);
  ws.onopen = () => { scansSaid = SCANS_ALL; setConnected(true); tellScans(); };
  ws.onmessage = (e) => { apply(JSON.parse(e.data)); };
  ws.onclose = () => {
    setConnected(false);
    setTimeout(connect, 1000);  // the server restarted: come back
  };
}

function hud() {
  const s = world.status;
  $("hud-tick").textContent = String(world.tick);
  $("hud-time").textContent = (world.t_ns / 1e9).toFixed(1);
  $("hud-robots").textContent = `${world.ids.length} robots`;
  const mode = $("hud-mode");
  let text = "connecting";
  let cls = "";
  if (world.connected && !world.live && world.timeline) {
    const rate = world.timeline.rate ? `${world.timeline.rate}x` : "as fast as it goes";
    text = `replay ${world.timeline.playing ? "playing" : "paused"} ${rate}`;
    cls = world.timeline.playing ? "running" : "paused";
  } else if (world.connected && s) {
    text = `${s.mode} ${s.running ? "running" : "paused"}`;
    cls = s.running ? "running" : "paused";
  } else if (world.connected) {
    text = "waiting for the world";
  }
  if (world.heldReason) text += ` \u00b7 held: ${world.heldReason}`;
  mode.textContent = text;
  mode.className = cls;
  $("hud-rtf").textContent = s && world.live ? s.rtf.toFixed(2) : "-";
}

function panel() { drawPanel($("panel-title"), $("panel-body")); }

// the panel opened or closed: the map keeps its whole width in view (it re-fits once the stage has its new size)
function panelShown() {
  const open = world.selected !== null;
  const p = $("panel");
  if (p.hidden === !open) return;
  p.hidden = !open;
  requestAnimationFrame(() => view2d.fit());
}

function onSelect() {
  const sel = world.selected;
  panelShown();
  $("btn-remove").hidden = !sel || sel.kind !== "robot";
  $("btn-obstacle-delete").hidden = !sel || sel.kind !== "obstacle";
  if (sel && sel.kind === "robot") send({ cmd: "reading", robot_id: sel.id });
  tellScans();
  panel();
}

/** Shows the 2D map or a 3D camera. @param {ViewMode} mode */
export function setView(mode) {
  const sel = /** @type {HTMLSelectElement} */ ($("view-mode"));
  sel.value = mode;
  const three = mode !== "2d";
  $("view2d").hidden = three;
  $("view3d").hidden = !three;
  $("legend").hidden = three || !input("opt-legend").checked;
  $("cursor").hidden = three;
  driveHud.setShown(three);
  if (three) {
    last3d = mode;
    if (!view3d) { view3d = new View3D(/** @type {HTMLCanvasElement} */ ($("view3d")), world); view3d.follow(followId); }
    view3d.setCamera(mode);
  }
  changed();
}

/** the view now shown */
export function viewMode() { return /** @type {ViewMode} */ (/** @type {HTMLSelectElement} */ ($("view-mode")).value); }

/** @param {KeyboardEvent} e */
function viewKey(e) {
  const t = /** @type {HTMLElement} */ (e.target);
  if (e.ctrlKey || e.altKey || e.metaKey || (t && ["INPUT", "SELECT", "TEXTAREA"].includes(t.tagName))) return;
  if (KEY_VIEWS[e.key]) setView(KEY_VIEWS[e.key]);
  else if (e.key === "m" || e.key === "M") setView(viewMode() === "2d" ? last3d : "2d");
}

function controls() {
  $("btn-start").onclick = () => send({ cmd: "start" });
  $("btn-pause").onclick = () => send({ cmd: "pause" });
  $("btn-step").onclick = () => send({ cmd: "step", steps: 1 });
  $("btn-stop").onclick = () => { if (confirm("Stop the simulation for good? Every robot stops and the world ends; it cannot be resumed.")) send({ cmd: "stop" }); };
  $("btn-obstacle").onclick = () => view2d.toggleDrawing();
  $("btn-remove").onclick = () => {
    const s = world.selected;
    if (!s || s.kind !== "robot") return;
    const r = world.robots.get(s.id);
    if (confirm(`Remove robot ${s.id}${r ? ` (${r.name})` : ""} from the world? Its agent does not register it again.`)) send({ cmd: "remove", robot_id: s.id });
  };
  $("btn-obstacle-delete").onclick = () => {
    const s = world.selected;
    if (s && s.kind === "obstacle") {
      send({ cmd: "remove_obstacle", obstacle: { name: s.name, x0: 0, y0: 0, x1: 0, y1: 0 } });
      select(null);
    }
  };
  $("panel-close").onclick = () => select(null);
  $("view-mode").onchange = () => setView(viewMode());
  window.addEventListener("keydown", viewKey);
  for (const id of ["opt-trails", "opt-cones", "opt-labels"]) $(id).onchange = changed;
  $("opt-legend").onchange = () => { $("legend").hidden = !input("opt-legend").checked || viewMode() !== "2d"; };
  $("opt-scans").onchange = () => { scansChosen = true; tellScans(); changed(); };
  $("rate").onchange = () => send({ cmd: "rate", rate: Number(/** @type {HTMLSelectElement} */ ($("rate")).value) });
  setInterval(() => {
    if (world.selected && world.selected.kind === "robot") send({ cmd: "reading", robot_id: world.selected.id });
  }, PANEL_EVERY_MS);
}

function listen() {
  on("hello", (m) => {
    document.body.classList.toggle("replay", !m.live);
    document.body.classList.toggle("watch", m.steer === false);  // a watch key: no control is shown
    $("timeline").hidden = m.live;
    $("title").textContent = `iwz view \u00b7 ${m.live ? "live" : "replay"} \u00b7 ${m.sim}`;
  });
  on("scene", (m) => {
    if (!scansChosen) input("opt-scans").checked = m.robots.length <= SCANS_ALL_MAX;
    tellScans();
    if (!view2d.fitted) view2d.fit();
    if (view3d) view3d.sceneChanged();
  });
  on("frame", hud);
  on("status", hud);
  on("connected", hud);
  on("reading", panel);
  on("select", onSelect);
  on("timeline", () => { if (world.timeline) timeline.update(world.timeline); hud(); });
  on("error", (m) => toast(m.error));
  on("event", (m) => { if (m.kind === "bad-control") toast(`the world refused: ${m.reason}`); });
  on("heard", (m) => {
    const box = $("radio");
    for (const [to, from, d, text] of m.messages) {
      const line = document.createElement("div");
      line.textContent = `${from} \u2192 ${to} (${d} m): ${text}`;
      box.appendChild(line);
    }
    while (box.children.length > RADIO_SHOWN && box.firstChild) box.removeChild(box.firstChild);
  });
}

function draw() {
  const now = performance.now();
  expireFlashes(now);
  if ($("view2d").hidden) { if (view3d) { view3d.draw(); driveHud.follow(view3d.chair()); } } else view2d.draw(now);
  driveHud.draw();
  requestAnimationFrame(draw);
}

function main() {
  view2d = new View2D(/** @type {HTMLCanvasElement} */ ($("view2d")), world, {
    select,
    send,
    mapClick: (x, y) => mapClicks.some((fn) => fn(x, y)),
    cursor: (x, y) => { $("cursor").textContent = x === null ? "" : `x ${x.toFixed(2)} m  y ${/** @type {number} */ (y).toFixed(2)} m`; },
    options: () => ({
      trails: input("opt-trails").checked, cones: input("opt-cones").checked, labels: input("opt-labels").checked, scans: input("opt-scans").checked,
    }),
    drawingDone: () => $("btn-obstacle").classList.remove("active"),
    drawingStarted: () => $("btn-obstacle").classList.add("active"),
  });
  timeline = new Timeline($("timeline"), send);
  new Legend($("legend"));
  driveHud = new DriveHud($("drivehud"), world);
  listen();
  // driving a chair (drive.js): its HUD, the cameras following the driven chair, go there on the map
  initDrive({ send, toast, setView, onMapClick });
  onDriveChange(() => { driveHud.show(driveState); followChair(driveState.robot); });
  controls();
  connect();
  requestAnimationFrame(draw);
  if (new URLSearchParams(location.search).get("hooks") === "1") {
    import("./hooks.js").then((h) => h.install({ world, view2d, view3d: () => view3d, timeline, tapSent, driveHud, follow: followChair }));
  }
}

main();
