// The replay's timeline: where the recording is, seek by dragging, incidents marked (click one to
// jump a second before it), the rate. Play, pause and step are the bar's own buttons.

const BEFORE_MARK_NS = 1e9;  // a mark jumps to a second before its incident

export class Timeline {
  constructor(el, send) {
    this.el = el;
    this.send = send;
    this.range = el.querySelector("#tl-range");
    this.marks = el.querySelector("#tl-marks");
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

  seek(ns) { this.send({ cmd: "seek", at_ns: Math.max(0, Math.round(ns)) }); }

  showPos(ns) { this.el.querySelector("#tl-pos").textContent = `${(ns / 1e9).toFixed(1)} s`; }

  update(t) {
    this.tl = t;
    const span = Math.max(1, t.end_ns - t.start_ns);
    if (!this.dragging) {
      this.range.value = String(Math.round(1000 * (t.position_ns - t.start_ns) / span));
      this.showPos(t.position_ns);
    }
    this.el.querySelector("#tl-end").textContent = `${(t.end_ns / 1e9).toFixed(1)} s`;
    const rate = this.el.querySelector("#rate");
    if (document.activeElement !== rate) rate.value = String(t.rate);
    const key = `${t.start_ns}:${t.end_ns}:${t.marks.length}`;
    if (key === this.markKey) return;
    this.markKey = key;
    this.marks.textContent = "";
    for (const m of t.marks) {
      const s = document.createElement("span");
      s.className = m.kind;
      s.style.left = `${(100 * (m.t_ns - t.start_ns)) / span}%`;
      s.title = `${(m.t_ns / 1e9).toFixed(1)} s ${m.kind}: ${m.what}`;
      s.onclick = () => this.seek(Math.max(t.start_ns, m.t_ns - BEFORE_MARK_NS));
      this.marks.appendChild(s);
    }
  }
}
