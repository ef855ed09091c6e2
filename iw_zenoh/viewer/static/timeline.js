// @ts-check
// The replay's timeline: where the recording is, seek by dragging, incidents marked (hover one for
// what happened, click it to jump a second before it) and explained beside the track (each kind's
// colour and how many), the rate. Play, pause and step are the bar's own buttons.

/** @typedef {import("./types.js").PageTimeline} PageTimeline */
/** @typedef {import("./types.js").TimelineMark} TimelineMark */

const BEFORE_MARK_NS = 1e9;  // a mark jumps to a second before its incident

/** An incident's kind (`iwz incidents`), its colour on the track and what it means. */
export const MARK_KINDS = /** @type {Record<string, [string, string]>} */ ({
  collision: ["#e53935", "collision"],
  "near-miss": ["#fb8c00", "near miss"],
  watchdog: ["#9c4dcc", "watchdog stop"],
  "agent-lost": ["#ffea00", "agent lost"],
  holding: ["#e0a000", "robots held"],
  removed: ["#8d6e63", "robot removed"],
  refused: ["#90a4ae", "registration refused"],
});
const OTHER = "#b0bec5";

/** @param {string} kind */
export function markColour(kind) { return (MARK_KINDS[kind] || [OTHER])[0]; }

export class Timeline {
  /**
   * @param {HTMLElement} el  the footer holding #tl-range, #tl-marks, #tl-pos, #tl-end, #tl-explain, #rate
   * @param {(cmd: import("./types.js").PageCommand) => void} send
   */
  constructor(el, send) {
    this.el = el;
    this.send = send;
    /** @param {string} s */
    const q = (s) => /** @type {HTMLElement} */ (el.querySelector(s));
    this.range = /** @type {HTMLInputElement} */ (q("#tl-range"));
    this.marks = q("#tl-marks");
    this.explain = q("#tl-explain");
    this.pos = q("#tl-pos");
    this.end = q("#tl-end");
    this.rate = /** @type {HTMLSelectElement} */ (q("#rate"));
    /** @type {(PageTimeline & {marks: TimelineMark[]}) | null} */
    this.tl = null;
    this.dragging = false;
    this.markKey = "";
    this.range.addEventListener("input", () => { this.dragging = true; this.showPos(this.rangeNs()); });
    this.range.addEventListener("change", () => { this.dragging = false; this.seek(this.rangeNs()); });
  }

  rangeNs() {
    const t = this.tl;
    return t ? Math.round(t.start_ns + (t.end_ns - t.start_ns) * Number(this.range.value) / 1000) : 0;
  }

  /** @param {number} ns */
  seek(ns) { this.send({ cmd: "seek", at_ns: Math.max(0, Math.round(ns)) }); }

  /** @param {number} ns */
  showPos(ns) { this.pos.textContent = `${(ns / 1e9).toFixed(1)} s`; }

  /** @param {PageTimeline & {marks: TimelineMark[]}} t */
  update(t) {
    this.tl = t;
    const span = Math.max(1, t.end_ns - t.start_ns);
    if (!this.dragging) {
      this.range.value = String(Math.round(1000 * (t.position_ns - t.start_ns) / span));
      this.showPos(t.position_ns);
    }
    this.end.textContent = `${(t.end_ns / 1e9).toFixed(1)} s`;
    if (document.activeElement !== this.rate) this.rate.value = String(t.rate);
    const key = `${t.start_ns}:${t.end_ns}:${t.marks.length}`;
    if (key === this.markKey) return;
    this.markKey = key;
    this.marks.textContent = "";
    /** @type {Map<string, number>} */
    const count = new Map();
    for (const m of t.marks) {
      const s = document.createElement("span");
      s.className = `mark ${m.kind}`;
      s.style.left = `${(100 * (m.t_ns - t.start_ns)) / span}%`;
      s.style.background = markColour(m.kind);
      s.title = `${(m.t_ns / 1e9).toFixed(1)} s ${m.kind}: ${m.what}${m.robots.length ? ` (robots ${m.robots.join(", ")})` : ""}\nclick: jump to a second before it`;
      s.onclick = () => this.seek(Math.max(t.start_ns, m.t_ns - BEFORE_MARK_NS));
      this.marks.appendChild(s);
      count.set(m.kind, (count.get(m.kind) || 0) + 1);
    }
    const said = [...count].map(([k, n]) => `<span><i style="background:${markColour(k)}"></i>${n} ${(MARK_KINDS[k] || [OTHER, k])[1]}${n > 1 ? "s" : ""}</span>`);
    this.explain.innerHTML = said.length
      ? `incidents: ${said.join(" ")} <em>(hover a mark for what happened, click it to jump a second before)</em>`
      : "no incidents in this recording";
  }
}
