// @ts-check
// For tests, benchmarks and scripts only: loaded when the page's address says `?hooks=1`, never
// otherwise. Puts `window.iwz` on the page: the world, conversions between map and screen, what
// was drawn and sent, and the 2D view's delay from a tick to its drawing.

const SENT_KEPT = 50;

/**
 * @param {{world: any, view2d: import("./view2d.js").View2D, view3d: () => import("./view3d.js").View3D | null,
 *   timeline: import("./timeline.js").Timeline, tapSent: (fn: (cmd: any) => void) => void,
 *   driveHud: import("./drivehud.js").DriveHud, follow: (id: number | null) => void}} p
 */
export function install(p) {
  const { world, view2d } = p;
  /** @type {any[]} */
  const sent = [];
  p.tapSent((cmd) => { sent.push(cmd); if (sent.length > SENT_KEPT) sent.shift(); });
  view2d.measure = { latencies: [], scanPoints: [] };
  const m = view2d.measure;
  /** @type {any} */ (window).iwz = {
    world,
    robots: () => world.ids.map((/** @type {number} */ id, /** @type {number} */ i) => ({ id, x: world.x[i], y: world.y[i], heading: world.heading[i], state: world.states[i] })),
    toScreen: (/** @type {number} */ x, /** @type {number} */ y) => view2d.toScreen(x, y),
    stats: () => { const v = p.view3d(); return { drawn: view2d.drawn + (v ? v.drawn : 0), latencies: m.latencies.slice() }; },
    scanPoints: () => m.scanPoints.slice(),  // [x, y] in metres of every scan hit drawn last
    pixel: (/** @type {number} */ x, /** @type {number} */ y) => {  // [r, g, b, a] of the 2D view where (x, y) m is drawn
      const [sx, sy] = view2d.toScreen(x, y);
      return Array.from(view2d.ctx.getImageData(Math.round(sx * view2d.dpr), Math.round(sy * view2d.dpr), 1, 1).data);
    },
    view3d: p.view3d,
    follow: p.follow,
    scale: () => view2d.scale,            // px per m of the map
    scaleBar: () => view2d.scaleShown,    // the length (m) the scale bar shows
    pixel3d: (/** @type {number} */ fx, /** @type {number} */ fy) => {  // [r, g, b, a] of the 3D view at a fraction of its width, height (from the top)
      const v = p.view3d();
      if (!v || !v.gl) return null;
      const out = new Uint8Array(4);
      v.gl.readPixels(Math.round(fx * (v.canvas.width - 1)), Math.round((1 - fy) * (v.canvas.height - 1)), 1, 1, v.gl.RGBA, v.gl.UNSIGNED_BYTE, out);
      return Array.from(out);
    },
    count3d: (/** @type {(r: number, g: number, b: number) => boolean} */ test) => {  // the share of the 3D view's pixels that pass
      const v = p.view3d();
      if (!v || !v.gl) return 0;
      const px = new Uint8Array(v.canvas.width * v.canvas.height * 4);
      v.gl.readPixels(0, 0, v.canvas.width, v.canvas.height, v.gl.RGBA, v.gl.UNSIGNED_BYTE, px);
      let n = 0;
      for (let i = 0; i < px.length; i += 4) if (test(px[i], px[i + 1], px[i + 2])) n += 1;
      return n / (px.length / 4);
    },
    coverage: () => { const v = p.view3d(); return v ? coverage(v) : { drawn: 0, covered: 0, colours: 0 }; },
    timeline: () => p.timeline,
    driveHud: p.driveHud,
    animate: (/** @type {boolean} */ on) => { view2d.animate = on; },
    resetStats: () => { m.latencies.length = 0; },
    sent,
  };
}

/**
 * How much of the 3D canvas is not the sky, and how many colours it shows.
 * @param {import("./view3d.js").View3D} v
 */
function coverage(v) {
  const gl = v.gl;
  if (!gl) return { drawn: 0, covered: 0, colours: 0 };
  const w = v.canvas.width;
  const h = v.canvas.height;
  const px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  const bg = v.clearRgb().map((c) => Math.round(c * 255));
  let covered = 0;
  const colours = new Set();
  for (let i = 0; i < px.length; i += 4) {
    if (Math.abs(px[i] - bg[0]) + Math.abs(px[i + 1] - bg[1]) + Math.abs(px[i + 2] - bg[2]) > 6) covered += 1;
    if (i % 64 === 0) colours.add((px[i] << 16) | (px[i + 1] << 8) | px[i + 2]);
  }
  return { drawn: v.drawn, covered: covered / (w * h), colours: colours.size };
}
