// iwz view: the page. Connects to the server's WebSocket, keeps the world as the server tells it
// (docs/viewer.md: the messages), and hands it to the 2D or 3D view. No build step, no library.
import { View2D, laserAngle } from "./view2d.js";
import { View3D } from "./view3d.js";
import { Timeline } from "./timeline.js";
import * as drive from "./drive.js";

const TRAIL_POINTS = 80;      // positions kept per robot
const TRAIL_EVERY = 3;        // frames between two trail points
const FLASH_MS = 2500;        // how long an incident flashes
const RADIO_SHOWN = 8;        // radio lines shown at once
const PANEL_EVERY_MS = 250;   // how often the open robot panel asks for its reading
const SCANS_ALL_MAX = 100;    // past this many robots the scans are drawn for the selected one only (until asked)

export const world = {
  live: true, sim: "", connected: false,
  scene: null, robots: new Map(),          // id -> PageRobot (outline, sensors, spec)
  ids: [], x: [], y: [], heading: [], state: "", tick: 0, t_ns: 0, heldReason: "",
  sentMs: 0, tickWallMs: 0, frameAt: 0,     // when the last frame was sent, and when it arrived
  prox: new Map(),                          // id -> distances, one per sensor
  scans: new Map(),                         // id -> one list of ranges per laser scanner (PageRobot.lasers)
  trails: new Map(), frames: 0,
  flashes: [],                              // {x, y, kind, until}
  status: null, timeline: null,
  selected: null,                           // {kind: "robot", id} or {kind: "obstacle", name}
  reading: null, version: 0,
};

const $ = (id) => document.getElementById(id);
let ws = null;
let view2d = null;
let view3d = null;
let timeline = null;
let scansChosen = false;  // the scans toggle was set by hand: the roster's size no longer sets it
const SCANS_ALL = JSON.stringify({ cmd: "scans", scans: "all" });
let scansSaid = SCANS_ALL;  // whose scans the server was last told this page draws (every robot's until told)

const sent = [];  // the last commands sent (for tests and scripts: window.iwz.sent)

export function send(cmd) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(cmd));
  sent.push(cmd);
  if (sent.length > 50) sent.shift();
}

function toast(text) {
  const t = $("toast");
  t.textContent = text;
  t.hidden = false;
  clearTimeout(toast.timer);
  toast.timer = setTimeout(() => { t.hidden = true; }, 5000);
}

// tells the server whose laser scans this page draws (every robot's, the selected one's, or none),
// so that it sends no others, and forgets the ones it no longer draws
function tellScans() {
  const sel = world.selected && world.selected.kind === "robot" ? world.selected.id : null;
  let want = { cmd: "scans", scans: "all" };
  if (!$("opt-scans").checked) want = sel === null ? { cmd: "scans", scans: "none" } : { cmd: "scans", scans: "selected", robot_id: sel };
  const key = JSON.stringify(want);
  if (key === scansSaid || !ws || ws.readyState !== WebSocket.OPEN) return;
  scansSaid = key;
  if (want.scans !== "all") for (const id of [...world.scans.keys()]) if (id !== sel) world.scans.delete(id);
  send(want);
}

function onScene(m) {
  world.scene = m;
  world.robots = new Map(m.robots.map((r) => [r.id, r]));
  for (const id of [...world.trails.keys()]) if (!world.robots.has(id)) world.trails.delete(id);
  for (const id of [...world.scans.keys()]) if (!world.robots.has(id)) world.scans.delete(id);
  if (!scansChosen) $("opt-scans").checked = m.robots.length <= SCANS_ALL_MAX;
  tellScans();
  if (world.selected && world.selected.kind === "obstacle" &&
      !m.obstacles.some((o) => o.name === world.selected.name)) select(null);
  if (view2d && !view2d.fitted) view2d.fit();
  if (view3d) view3d.sceneChanged();
}

function onFrame(m) {
  if (m.ids !== null) {
    world.ids = m.ids;
    const have = new Set(m.ids);
    for (const id of [...world.trails.keys()]) if (!have.has(id)) world.trails.delete(id);
    if (world.selected && world.selected.kind === "robot" && !have.has(world.selected.id)) select(null);
    drive.onRoster(m.ids);
  }
  world.x = m.x; world.y = m.y; world.heading = m.heading; world.state = m.state;
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
  hud();
}

function onEvent(m) {
  if (m.where && ["collision", "watchdog", "removed", "agent-lost", "refused", "holding"].includes(m.kind)) {
    world.flashes.push({ x: m.where[0], y: m.where[1], kind: m.kind, until: performance.now() + FLASH_MS });
  }
  if (m.kind === "bad-control") toast(`the world refused: ${m.reason}`);
}

function onHeard(m) {
  const box = $("radio");
  for (const [to, from, d, text] of m.messages) {
    const line = document.createElement("div");
    line.textContent = `${from} \u2192 ${to} (${d} m): ${text}`;
    box.appendChild(line);
  }
  while (box.children.length > RADIO_SHOWN) box.removeChild(box.firstChild);
}

const handlers = {
  hello(m) {
    world.live = m.live; world.sim = m.sim;
    document.body.classList.toggle("replay", !m.live);
    document.body.classList.toggle("watch", m.steer === false);  // a watch key: no control is shown
    $("timeline").hidden = m.live;
    $("title").textContent = `iwz view \u00b7 ${m.live ? "live" : "replay"} \u00b7 ${m.sim}`;
    drive.onHello(m);
  },
  drive(m) { drive.onDrive(m); driveButton(); },
  scene: onScene,
  frame: onFrame,
  status(m) { world.status = m; hud(); },
  readings(m) { for (const [id, v] of Object.entries(m.prox)) world.prox.set(Number(id), v); },
  scans(m) { for (const [id, v] of Object.entries(m.scans)) world.scans.set(Number(id), v); },
  reading(m) { world.reading = m; panel(); },
  heard: onHeard,
  event: onEvent,
  timeline(m) {
    const marks = m.marks === null && world.timeline ? world.timeline.marks : m.marks;
    world.timeline = { ...m, marks: marks || [] };
    if (timeline) timeline.update(world.timeline);
    hud();
  },
  error(m) { toast(m.error); drive.onError(m); },
};

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${location.search}`);  // its key, if any
  ws.onopen = () => { world.connected = true; scansSaid = SCANS_ALL; tellScans(); hud(); };
  ws.onmessage = (e) => {
    const m = JSON.parse(e.data);
    const h = handlers[m.type];
    if (h) { h(m); world.version += 1; }
  };
  ws.onclose = () => {
    world.connected = false; hud();
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

export function select(sel) {
  world.selected = sel;
  world.reading = null;
  const p = $("panel");
  p.hidden = sel === null;
  $("btn-remove").hidden = !sel || sel.kind !== "robot";
  $("btn-obstacle-delete").hidden = !sel || sel.kind !== "obstacle";
  driveButton();
  if (sel && sel.kind === "robot") send({ cmd: "reading", robot_id: sel.id });
  tellScans();
  panel();
  world.version += 1;
}

// the robot panel's drive button: for a chair whose agent accepts a driver (it tells its drive state)
function driveButton() {
  const sel = world.selected;
  $("btn-drive").hidden = !sel || sel.kind !== "robot" || !drive.accepts(sel.id) || drive.driveState.robot === sel.id;
}

function row(k, v) { return `<tr><td>${k}</td><td>${v}</td></tr>`; }
function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]); }
function num(v, d = 3) { return v === null || v === undefined ? "-" : Number(v).toFixed(d); }

// a scan's nearest range, and the direction of its beam from the heading
function nearest(scan, robot) {
  let best = -1;
  scan.ranges.forEach((v, k) => { if (v !== null && (best < 0 || v < scan.ranges[best])) best = k; });
  if (best < 0) return "nothing in range";
  const l = robot && robot.lasers.find((a) => a.id === scan.id);
  const at = l ? ` at ${num(laserAngle(l, best), 1)}\u00b0` : "";
  return `nearest ${num(scan.ranges[best], 2)} m${at}`;
}

function panel() {
  const sel = world.selected;
  const body = $("panel-body");
  if (!sel) { body.innerHTML = ""; return; }
  if (sel.kind === "obstacle") {
    const o = world.scene && world.scene.obstacles.find((ob) => ob.name === sel.name);
    $("panel-title").textContent = `obstacle ${sel.name}`;
    body.innerHTML = o ? `<table>${row("from", `${num(o.x0, 2)}, ${num(o.y0, 2)}`)}${row("to", `${num(o.x1, 2)}, ${num(o.y1, 2)}`)}${row("height", num(o.height, 2))}</table><p>Drag it on the map to move it.</p>` : "";
    return;
  }
  const r = world.robots.get(sel.id);
  $("panel-title").textContent = `robot ${sel.id}${r ? ` \u00b7 ${r.name}` : ""}`;
  const m = world.reading && world.reading.robot_id === sel.id ? world.reading : null;
  let h = "<table>";
  const agent = (m && m.reading && m.reading.agent) || (r && r.agent);
  if (m || r) h += row("agent", esc(agent || "(none known)"));
  if (m) {
    const rd = m.reading || {};
    h += row("pose", m.pose ? `${num(m.pose[0])}, ${num(m.pose[1])}, ${num(m.pose[2] * 180 / Math.PI, 1)}\u00b0` : "-");
    h += row("speed", `${num(m.speed)} m/s`);
    h += row("motors", m.motors ? `L ${num(m.motors[0], 4)} R ${num(m.motors[1], 4)}` : "-");
    if (m.reading) {
      h += row("proximity", rd.proximity_ids.map((id, i) => `${id}: ${num(rd.proximity_m[i], 2)}`).join("<br>"));
      h += row("compass", `${num(rd.compass_deg, 1)}\u00b0`);
      h += row("beacons", (rd.beacons_deg || []).map((b) => (b === null ? "not seen" : `${num(b, 1)}\u00b0`)).join(", ") || "-");
      h += row("gps", rd.gps.map((v) => num(v, 2)).join(", "));
      h += row("ground", rd.ground);
      h += row("collision", rd.collision ? "yes" : "no");
      h += row("bumpers", (rd.bumpers || []).map((b) => (b ? "hit" : "-")).join(" ") || "-");
      h += row("encoders", rd.encoders.join(", "));
      for (const scan of rd.lasers || []) h += row(`laser ${scan.id}`, nearest(scan, r));
      h += row("reading of tick", rd.tick);
    }
  }
  h += "</table>";
  if (r) {
    h += "<h4>spec</h4><table>";
    for (const [k, v] of Object.entries(r.spec)) {
      if (v === null || (Array.isArray(v) && v.length === 0)) continue;
      h += row(k, esc(typeof v === "object" ? JSON.stringify(v) : v));
    }
    h += "</table>";
  }
  if (m && m.events.length) {
    h += "<h4>recent events</h4><table>";
    for (const e of m.events.slice().reverse()) h += row(`${(e.t_ns / 1e9).toFixed(1)} s`, `${esc(e.kind)}: ${esc(e.reason)}`);
    h += "</table>";
  }
  body.innerHTML = h;
}

function viewMode() {
  const mode = $("view-mode").value;
  const three = mode !== "2d";
  $("view2d").hidden = three;
  $("view3d").hidden = !three;
  if (three) {
    if (!view3d) view3d = new View3D($("view3d"), world);
    view3d.setCamera(mode);
  }
  world.version += 1;
}

function controls() {
  $("btn-start").onclick = () => send({ cmd: "start" });
  $("btn-pause").onclick = () => send({ cmd: "pause" });
  $("btn-step").onclick = () => send({ cmd: "step", steps: 1 });
  $("btn-stop").onclick = () => { if (confirm("Stop the simulation for good?")) send({ cmd: "stop" }); };
  $("btn-obstacle").onclick = () => view2d.toggleDrawing();
  $("btn-remove").onclick = () => {
    if (world.selected && world.selected.kind === "robot") send({ cmd: "remove", robot_id: world.selected.id });
  };
  $("btn-obstacle-delete").onclick = () => {
    const s = world.selected;
    if (s && s.kind === "obstacle") {
      send({ cmd: "remove_obstacle", obstacle: { name: s.name, x0: 0, y0: 0, x1: 0, y1: 0 } });
      select(null);
    }
  };
  $("panel-close").onclick = () => select(null);
  $("btn-drive").onclick = () => { if (world.selected && world.selected.kind === "robot") drive.startDriving(world.selected.id); };
  $("view-mode").onchange = viewMode;
  for (const id of ["opt-trails", "opt-cones", "opt-labels"]) $(id).onchange = () => { world.version += 1; };
  $("opt-scans").onchange = () => { scansChosen = true; tellScans(); world.version += 1; };
  $("rate").onchange = () => send({ cmd: "rate", rate: Number($("rate").value) });
  setInterval(() => {
    if (world.selected && world.selected.kind === "robot") send({ cmd: "reading", robot_id: world.selected.id });
  }, PANEL_EVERY_MS);
}

function draw() {
  const now = performance.now();
  world.flashes = world.flashes.filter((f) => f.until > now);
  if ($("view2d").hidden) view3d.draw(); else view2d.draw(now);
  requestAnimationFrame(draw);
}

function main() {
  view2d = new View2D($("view2d"), world, {
    select, send,
    options: () => ({
      trails: $("opt-trails").checked, cones: $("opt-cones").checked, labels: $("opt-labels").checked, scans: $("opt-scans").checked,
    }),
    drawingDone: () => $("btn-obstacle").classList.remove("active"),
    drawingStarted: () => $("btn-obstacle").classList.add("active"),
  });
  timeline = new Timeline($("timeline"), send);
  drive.initDrive({
    send, toast,
    toWorld: (sx, sy) => ($("view2d").hidden ? null : view2d.toWorld(sx, sy)),
    robotName: (id) => (world.robots.get(id) ? world.robots.get(id).name : ""),
    showMap: () => { $("view-mode").value = "2d"; viewMode(); },
    started: (id) => {  // driving: the driver's seat is first person, from this chair
      if (!world.selected || world.selected.kind !== "robot" || world.selected.id !== id) select({ kind: "robot", id });
      $("view-mode").value = "first";
      viewMode();
      driveButton();
    },
  }, $("view2d"));
  drive.onDriveChange(() => driveButton());
  controls();
  connect();
  requestAnimationFrame(draw);
  // for tests and scripts: the page's state, and map <-> screen conversions
  window.iwz = {
    world,
    robots: () => world.ids.map((id, i) => ({ id, x: world.x[i], y: world.y[i], heading: world.heading[i], state: world.state[i] })),
    toScreen: (x, y) => view2d.toScreen(x, y),
    stats: () => ({ drawn: view2d.drawn + (view3d ? view3d.drawn : 0), latencies: view2d.latencies.slice() }),
    scanPoints: () => view2d.scanPoints.slice(),  // [x, y] in metres of every scan hit drawn last
    pixel: (x, y) => view2d.pixel(x, y),          // [r, g, b, a] of the 2D view where (x, y) m is drawn
    view3d: () => view3d,
    timeline: () => timeline,
    animate: (on) => { view2d.animate = on; },
    resetStats: () => { view2d.latencies.length = 0; },
    sent,
  };
}

main();
