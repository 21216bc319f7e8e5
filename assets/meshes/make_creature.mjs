// A procedural armadillo-like creature (the Stanford armadillo is not available to us): torso, head
// with snout and ears, two arms, two legs with feet, and a tail, as a smooth union of capsules and
// ellipsoids (an implicit function, negative inside). Metres, Y up, feet at y ~ 0, about 0.75 m
// tall and 0.66 m across the hands.
//
//   node assets/meshes/make_creature.mjs
//
// The tet mesh is built directly from the implicit function, without TetGen: voxels whose centre is
// inside are split into 6 tets each (Kuhn/Freudenthal subdivision, conforming between voxels, so the
// boundary is always closed), then the boundary nodes are moved towards the implicit surface (at
// most half a voxel, never inverting or flattening a tet below 20% of its volume) to soften the
// staircase. The voxel size is searched so the tet count hits the target: preview ~2.4e4 tets
// (<= 3e4 particles), vib ~2.0e4 (paper Fig. 13), full ~4.2e5 (paper Table 1, Fig. 3/14), and coarse
// ~1.0e4 (the 2-minute previews of Fig. 3 and 14, which need thousands of steps at dt 1e-4).
// Also writes creature_surface.obj (the boundary triangles of the full mesh, outward oriented).
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));

// --- implicit creature ------------------------------------------------------------------------------
function capsule(p, a, b, ra, rb) {
  const ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
  const ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
  const L2 = ab[0] ** 2 + ab[1] ** 2 + ab[2] ** 2;
  const t = Math.max(0, Math.min(1, (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / L2));
  const d = Math.hypot(ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]);
  return d - (ra + (rb - ra) * t);
}
function ellipsoid(p, c, r) {  // approximate SDF (exact for spheres)
  const q = [(p[0] - c[0]) / r[0], (p[1] - c[1]) / r[1], (p[2] - c[2]) / r[2]];
  const k = Math.hypot(q[0], q[1], q[2]);
  return (k - 1) * Math.min(r[0], r[1], r[2]);
}
function smin(a, b, k) {
  const h = Math.max(0, Math.min(1, 0.5 + (0.5 * (b - a)) / k));
  return b * (1 - h) + a * h - k * h * (1 - h);
}
export const LANDMARKS = {
  back: [0, 0.40, -0.10],     // the middle of the back (Fig. 3 anchor)
  hands: [[-0.30, 0.50, 0.10], [0.30, 0.50, 0.10]],
  feet: [[-0.11, 0.025, 0.05], [0.11, 0.025, 0.05]],
};
function creature(p) {
  const parts = [];
  parts.push(ellipsoid(p, [0, 0.38, 0], [0.13, 0.17, 0.10]));                 // torso
  parts.push(ellipsoid(p, [0, 0.25, -0.01], [0.12, 0.08, 0.09]));             // hips
  parts.push(ellipsoid(p, [0, 0.60, 0.02], [0.075, 0.07, 0.07]));             // head
  parts.push(capsule(p, [0, 0.59, 0.05], [0, 0.56, 0.14], 0.04, 0.025));      // snout
  for (const s of [-1, 1]) {
    parts.push(capsule(p, [s * 0.035, 0.64, 0], [s * 0.07, 0.74, -0.03], 0.022, 0.012));   // ears
    parts.push(capsule(p, [s * 0.10, 0.46, 0], [s * 0.21, 0.42, 0.05], 0.045, 0.038));     // upper arm
    parts.push(capsule(p, [s * 0.21, 0.42, 0.05], [s * 0.29, 0.49, 0.10], 0.038, 0.032));  // forearm
    parts.push(ellipsoid(p, [s * 0.30, 0.50, 0.10], [0.04, 0.035, 0.04]));                 // hand
    parts.push(capsule(p, [s * 0.07, 0.24, 0], [s * 0.11, 0.13, 0.04], 0.06, 0.05));       // thigh
    parts.push(capsule(p, [s * 0.11, 0.13, 0.04], [s * 0.11, 0.04, -0.01], 0.05, 0.04));   // shin
    parts.push(ellipsoid(p, [s * 0.11, 0.025, 0.04], [0.05, 0.025, 0.08]));                // foot
  }
  parts.push(capsule(p, [0, 0.24, -0.08], [0, 0.10, -0.24], 0.04, 0.015));   // tail
  let d = parts[0];
  for (let i = 1; i < parts.length; i++) d = smin(d, parts[i], 0.02);
  return d;
}
const BOX = { min: [-0.36, 0.0, -0.27], max: [0.36, 0.76, 0.18] };

// --- voxel tet mesh -----------------------------------------------------------------------------------
// Kuhn subdivision of the unit cube along the diagonal 0-6: 6 tets, all positively oriented.
const CUBE = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]];
const KUHN = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]];

function voxelize(h) {
  const n = [0, 1, 2].map((k) => Math.ceil((BOX.max[k] - BOX.min[k]) / h));
  const inside = new Uint8Array(n[0] * n[1] * n[2]);
  let count = 0;
  for (let k = 0; k < n[2]; k++) for (let j = 0; j < n[1]; j++) for (let i = 0; i < n[0]; i++) {
    const c = [BOX.min[0] + (i + 0.5) * h, BOX.min[1] + (j + 0.5) * h, BOX.min[2] + (k + 0.5) * h];
    if (creature(c) < 0) { inside[i + n[0] * (j + n[1] * k)] = 1; count++; }
  }
  // Keep the largest face-connected (6-neighbour) set of voxels: at coarse sizes a thin ear or the
  // tail tip can touch the body along a voxel edge only, which would make it a separate fragment.
  const label = new Int32Array(inside.length).fill(-1);
  let best = -1, bestSize = 0;
  for (let s0 = 0, lab = 0; s0 < inside.length; s0++) {
    if (!inside[s0] || label[s0] >= 0) continue;
    const stack = [s0];
    label[s0] = lab;
    let size = 0;
    while (stack.length) {
      const v = stack.pop();
      size++;
      const i = v % n[0], j = Math.floor(v / n[0]) % n[1], k = Math.floor(v / (n[0] * n[1]));
      for (const [di, dj, dk] of [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]) {
        const a = i + di, b = j + dj, c = k + dk;
        if (a < 0 || b < 0 || c < 0 || a >= n[0] || b >= n[1] || c >= n[2]) continue;
        const w = a + n[0] * (b + n[1] * c);
        if (inside[w] && label[w] < 0) { label[w] = lab; stack.push(w); }
      }
    }
    if (size > bestSize) { bestSize = size; best = lab; }
    lab++;
  }
  for (let v = 0; v < inside.length; v++) if (inside[v] && label[v] !== best) inside[v] = 0;
  return { h, n, inside, count: bestSize };
}
function tetVolume(x, t) {
  const [a, b, c, d] = t.map((i) => x[i]);
  const u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]], v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
  return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])) / 6;
}
function build(vox) {
  const { h, n, inside } = vox;
  const nodeId = new Map();
  const x = [];
  const tets = [];
  const node = (i, j, k) => {
    const key = i + (n[0] + 1) * (j + (n[1] + 1) * k);
    let id = nodeId.get(key);
    if (id === undefined) {
      id = x.length;
      nodeId.set(key, id);
      x.push([BOX.min[0] + i * h, BOX.min[1] + j * h, BOX.min[2] + k * h]);
    }
    return id;
  };
  for (let k = 0; k < n[2]; k++) for (let j = 0; j < n[1]; j++) for (let i = 0; i < n[0]; i++) {
    if (!inside[i + n[0] * (j + n[1] * k)]) continue;
    const c = CUBE.map(([a, b, d]) => node(i + a, j + b, k + d));
    for (const t of KUHN) tets.push(t.map((q) => c[q]));
  }
  // Boundary faces: faces used by one tet only.
  const faceCount = new Map();
  const faces = [];
  for (const t of tets) {
    for (const f of [[t[1], t[2], t[3]], [t[0], t[3], t[2]], [t[0], t[1], t[3]], [t[0], t[2], t[1]]]) {
      const s = [...f].sort((a, b) => a - b).join(',');
      const e = faceCount.get(s);
      if (e) e.n++; else { const o = { n: 1, f }; faceCount.set(s, o); faces.push(o); }
    }
  }
  const boundary = faces.filter((o) => o.n === 1).map((o) => o.f);  // outward (tets positively oriented)
  const onBoundary = new Set(boundary.flat());
  // Move boundary nodes towards the surface, guarding against inverted/flat tets.
  const V0 = h ** 3 / 6;
  const orig = x.map((p) => p.slice());
  const moved = new Map();
  for (const id of onBoundary) {
    const p = x[id];
    const f = creature(p);
    const e = 1e-4;
    const g = [0, 1, 2].map((k) => { const q = p.slice(); q[k] += e; return (creature(q) - f) / e; });
    const g2 = g[0] ** 2 + g[1] ** 2 + g[2] ** 2;
    if (g2 < 1e-12) continue;
    let s = -f / g2;
    const len = Math.abs(s) * Math.sqrt(g2);
    if (len > 0.5 * h) s *= (0.5 * h) / len;
    moved.set(id, [p[0] + s * g[0], p[1] + s * g[1], p[2] + s * g[2]]);
  }
  for (let pass = 0; pass < 6; pass++) {
    for (const [id, q] of moved) x[id] = q;
    let bad = 0;
    for (const t of tets) {
      if (tetVolume(x, t) < 0.2 * V0) {
        for (const id of t) if (moved.has(id)) { moved.delete(id); x[id] = orig[id]; bad++; }
      }
    }
    if (bad === 0) break;
  }
  let minV = Infinity;
  for (const t of tets) minV = Math.min(minV, tetVolume(x, t));
  return { x, tets, boundary, minV: minV / V0, moved: moved.size, nb: onBoundary.size };
}
function write(mesh, stem) {
  const node = [`${mesh.x.length} 3 0 0`, ...mesh.x.map((p, i) => `${i} ${p.map((v) => v.toPrecision(7)).join(' ')}`)];
  const ele = [`${mesh.tets.length} 4 0`, ...mesh.tets.map((t, i) => `${i} ${t.join(' ')}`)];
  fs.writeFileSync(path.join(here, stem + '.node'), node.join('\n') + '\n');
  fs.writeFileSync(path.join(here, stem + '.ele'), ele.join('\n') + '\n');
}
function meshFor(target) {
  let h = 0.02;
  let vox;
  for (let it = 0; it < 8; it++) {
    vox = voxelize(h);
    const tets = vox.count * 6;
    if (Math.abs(tets / target - 1) < 0.05) break;
    h *= Math.cbrt(tets / target);
  }
  return build(vox);
}
for (const [stem, target] of [['creature_coarse', 1.0e4], ['creature_preview', 2.4e4], ['creature_vib', 2.0e4], ['creature_full', 4.2e5]]) {
  const m = meshFor(target);
  write(m, stem);
  let vol = 0;
  for (const t of m.tets) vol += tetVolume(m.x, t);
  console.log(`${stem}: ${m.x.length} nodes, ${m.tets.length} tets, volume ${vol.toExponential(4)} m^3, ` +
    `${m.moved}/${m.nb} boundary nodes moved to the surface, min tet volume ${m.minV.toFixed(2)} of a voxel tet`);
  if (stem === 'creature_full') {
    const obj = ['# procedural armadillo-like creature: boundary of creature_full (metres, Y up)',
      ...m.x.map((p) => 'v ' + p.map((v) => v.toFixed(6)).join(' '))];
    // Keep only the vertices the surface uses.
    const used = new Map();
    const verts = [];
    const faces = m.boundary.map((f) => f.map((i) => {
      if (!used.has(i)) { used.set(i, verts.length + 1); verts.push(m.x[i]); }
      return used.get(i);
    }));
    fs.writeFileSync(path.join(here, 'creature_surface.obj'), [obj[0],
      ...verts.map((p) => 'v ' + p.map((v) => v.toFixed(6)).join(' ')),
      ...faces.map((f) => 'f ' + f.join(' '))].join('\n') + '\n');
  }
}
console.log('landmarks', JSON.stringify(LANDMARKS));
