// @ts-check
// Chair models for the 3D view: a built-in low-poly wheelchair, or a model file per robot type
// (`iwz view --models DIR`: DIR/<type>.stl, .gltf or .glb, the type lower-case, e.g. simulated.stl)
// read here (STL ASCII or binary; glTF 2.0's first mesh, its POSITION and indices). A model is
// fitted to the robot's footprint: its x along the heading, z up, scaled so that its plan fills
// the robot's length and width, standing on the floor, centred on the robot's centre of movement.

/** A model: triangles as x, y, z (three vertices, nine numbers each) in its own units.
 * @typedef {{tris: Float32Array}} Model */

/** @param {ArrayBuffer} buf @returns {Model} */
export function parseStl(buf) {
  const bytes = new Uint8Array(buf);
  const head = new TextDecoder().decode(bytes.subarray(0, Math.min(512, bytes.length)));
  const dv = new DataView(buf);
  const n = bytes.length >= 84 ? dv.getUint32(80, true) : 0;
  if (bytes.length >= 84 && 84 + n * 50 === bytes.length) {  // binary: 80 bytes, count, 50 bytes a triangle
    const tris = new Float32Array(n * 9);
    for (let i = 0; i < n; i++) for (let k = 0; k < 9; k++) tris[i * 9 + k] = dv.getFloat32(84 + i * 50 + 12 + k * 4, true);
    return { tris };
  }
  if (!/^\s*solid/.test(head)) throw new Error("not an STL file (neither ASCII 'solid ...' nor binary)");
  const text = new TextDecoder().decode(bytes);
  const v = [...text.matchAll(/vertex\s+(\S+)\s+(\S+)\s+(\S+)/g)].flatMap((m) => [Number(m[1]), Number(m[2]), Number(m[3])]);
  if (!v.length || v.length % 9 || v.some((x) => !Number.isFinite(x))) throw new Error("an ASCII STL with no whole triangles");
  return { tris: new Float32Array(v) };
}

/**
 * glTF 2.0: the first mesh's triangles (every primitive), its node transforms ignored.
 * @param {any} gltf  the JSON @param {ArrayBuffer[]} buffers  its buffers, loaded @returns {Model}
 */
export function gltfTriangles(gltf, buffers) {
  const mesh = gltf.meshes && gltf.meshes[0];
  if (!mesh) throw new Error("a glTF with no mesh");
  /** @type {number[]} */
  const out = [];
  /** @param {number} i @param {number} comps */
  const read = (i, comps) => {
    const acc = gltf.accessors[i];
    const view = gltf.bufferViews[acc.bufferView];
    const buf = buffers[view.buffer];
    const off = (view.byteOffset || 0) + (acc.byteOffset || 0);
    const type = acc.componentType;
    const size = { 5126: 4, 5125: 4, 5123: 2, 5121: 1 }[/** @type {5126 | 5125 | 5123 | 5121} */ (type)];
    if (!size) throw new Error(`a glTF accessor of component type ${type}, not read`);
    const stride = view.byteStride || size * comps;
    const dv = new DataView(buf, off);
    const vals = [];
    for (let e = 0; e < acc.count; e++) {
      for (let c = 0; c < comps; c++) {
        const at = e * stride + c * size;
        vals.push(type === 5126 ? dv.getFloat32(at, true) : type === 5125 ? dv.getUint32(at, true) : type === 5123 ? dv.getUint16(at, true) : dv.getUint8(at));
      }
    }
    return vals;
  };
  for (const prim of mesh.primitives) {
    if (prim.mode !== undefined && prim.mode !== 4) continue;  // triangles only
    const pos = read(prim.attributes.POSITION, 3);
    const idx = prim.indices !== undefined ? read(prim.indices, 1) : pos.map((_, i) => i).filter((i) => i < pos.length / 3);
    for (const i of idx) out.push(pos[i * 3], pos[i * 3 + 1], pos[i * 3 + 2]);
  }
  if (!out.length) throw new Error("a glTF whose first mesh has no triangles");
  // glTF is y up: turn it z up (x stays forward)
  for (let i = 0; i < out.length; i += 3) { const y = out[i + 1]; out[i + 1] = -out[i + 2]; out[i + 2] = y; }
  return { tris: new Float32Array(out) };
}

/** @param {string} uri @param {string} base */
async function loadBuffer(uri, base) {
  const r = await fetch(uri.startsWith("data:") ? uri : new URL(uri, base).href);
  if (!r.ok) throw new Error(`${uri}: HTTP ${r.status}`);
  return r.arrayBuffer();
}

/** @param {ArrayBuffer} buf @param {string} url @returns {Promise<Model>} */
export async function parseGltf(buf, url) {
  const dv = new DataView(buf);
  if (buf.byteLength >= 12 && dv.getUint32(0, true) === 0x46546c67) {  // "glTF": binary, JSON chunk then BIN chunk
    const jsonLen = dv.getUint32(12, true);
    const gltf = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 20, jsonLen)));
    const binAt = 20 + jsonLen;
    const bin = buf.byteLength > binAt + 8 ? buf.slice(binAt + 8, binAt + 8 + dv.getUint32(binAt, true)) : new ArrayBuffer(0);
    const buffers = await Promise.all((gltf.buffers || []).map((/** @type {any} */ b, /** @type {number} */ i) => (b.uri ? loadBuffer(b.uri, url) : Promise.resolve(i === 0 ? bin : new ArrayBuffer(0)))));
    return gltfTriangles(gltf, buffers);
  }
  const gltf = JSON.parse(new TextDecoder().decode(buf));
  const buffers = await Promise.all((gltf.buffers || []).map((/** @type {any} */ b) => loadBuffer(b.uri, url)));
  return gltfTriangles(gltf, buffers);
}

/**
 * Each robot type's model file, from the viewer's /models/ (none when it serves no models).
 * @returns {Promise<Map<string, Model>>} type (lower case) -> model
 */
export async function loadModels() {
  /** @type {Map<string, Model>} */
  const out = new Map();
  let names = [];
  try {
    const r = await fetch("/models/index.json");
    if (!r.ok) return out;
    names = await r.json();
  } catch { return out; }
  for (const name of names) {
    const m = /^([a-z0-9_-]+)\.(stl|gltf|glb)$/i.exec(name);
    if (!m) continue;
    const url = new URL(`/models/${name}`, location.href).href;
    try {
      const r = await fetch(url);
      if (!r.ok) throw new Error(`HTTP ${r.status}`);
      const buf = await r.arrayBuffer();
      out.set(m[1].toLowerCase(), m[2].toLowerCase() === "stl" ? parseStl(buf) : await parseGltf(buf, url));
    } catch (e) {
      console.error(`iwz view: the model ${name} was not read (${e}); the built-in chair stands in for it`);
    }
  }
  return out;
}

/**
 * A model fitted to a footprint: `length` along x (its front `front` ahead of the centre of
 * movement), `width` along y, standing on z = 0, as triangles in the robot's frame.
 * @param {Model} m @param {number} length @param {number} width @param {number} front @returns {Float32Array}
 */
export function fitted(m, length, width, front) {
  const t = m.tris;
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < t.length; i += 3) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], t[i + k]); hi[k] = Math.max(hi[k], t[i + k]); }
  const sx = length / Math.max(1e-9, hi[0] - lo[0]);
  const sy = width / Math.max(1e-9, hi[1] - lo[1]);
  const sz = Math.min(sx, sy);  // its height keeps the model's proportions
  const out = new Float32Array(t.length);
  for (let i = 0; i < t.length; i += 3) {
    out[i] = front - (hi[0] - t[i]) * sx;
    out[i + 1] = (t[i + 1] - (lo[1] + hi[1]) / 2) * sy;
    out[i + 2] = (t[i + 2] - lo[2]) * sz;
  }
  return out;
}

// the built-in chair, in a unit footprint: x from -0.5 (rear) to 0.5 (front), y from -0.5 to 0.5,
// as boxes [x0, y0, z0, x1, y1, z1, part] and wheels [x, y, radius, thickness, part]
/** @type {[number, number, number, number, number, number, string][]} */
export const CHAIR_BOXES = [
  [-0.35, -0.36, 0.42, 0.25, 0.36, 0.52, "seat"],      // the seat
  [-0.42, -0.36, 0.5, -0.32, 0.36, 1.05, "seat"],      // the backrest
  [-0.35, -0.42, 0.62, 0.2, -0.36, 0.68, "frame"],     // armrests
  [-0.35, 0.36, 0.62, 0.2, 0.42, 0.68, "frame"],
  [-0.35, -0.4, 0.3, 0.35, -0.36, 0.36, "frame"],      // side rails
  [-0.35, 0.36, 0.3, 0.35, 0.4, 0.36, "frame"],
  [0.3, -0.3, 0.08, 0.5, 0.3, 0.12, "frame"],          // the footrest
  [-0.5, -0.2, 0.7, -0.42, 0.2, 0.95, "frame"],        // handles (the rear)
];
/** @type {[number, number, number, number, string][]} */
export const CHAIR_WHEELS = [
  [-0.1, -0.46, 0.32, 0.06, "wheel"],   // the drive wheels on the axis' side
  [-0.1, 0.46, 0.32, 0.06, "wheel"],
  [0.38, -0.34, 0.08, 0.05, "wheel"],   // casters
  [0.38, 0.34, 0.08, 0.05, "wheel"],
];
