// Builds the Stanford bunny meshes in this folder from the npm package `bunny` (mikolalysenko/bunny,
// 1839 vertices, 3674 triangles, Y up, open at the base).
//
//   cd /tmp && npm pack bunny && tar xzf bunny-1.0.1.tgz        # -> /tmp/package/index.js
//   node assets/meshes/make_bunny.mjs /tmp/package/index.js
//
// Steps: merge duplicate vertices, drop degenerate/duplicate triangles, find the boundary loops (the
// holes in the base) and close each with a fan to its centroid, check that the result is a closed,
// consistently oriented 2-manifold with outward normals (every undirected edge in exactly two
// triangles, every directed edge in exactly one), scale to SI (0.04 m per unit: about 0.39 m tall,
// feet at y = 0), write bunny_closed.obj, then tetrahedralize it with TetGen (`tetgen -pq1.414a<vol>`)
// at a preview (<= 3e4 tets) and a full (~5.2e5 tets, paper Table 1) resolution. TetGen's .node is
// rewritten with 7 significant digits to keep the files small (sub-micrometre rounding on a 0.4 m
// model; tets are ~1e-2 m).
import { createRequire } from 'node:module';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const src = process.argv[2];
if (!src) { console.error('usage: node make_bunny.mjs <path to bunny/index.js>'); process.exit(1); }
const bunny = createRequire(import.meta.url)(path.resolve(src));
const SCALE = 0.04;

// --- merge duplicate vertices -------------------------------------------------------------------
const key = (p) => p.map((v) => v.toFixed(7)).join(',');
const remap = new Map();
const pos = [];
const vid = bunny.positions.map((p) => {
  const k = key(p);
  if (!remap.has(k)) { remap.set(k, pos.length); pos.push(p.slice()); }
  return remap.get(k);
});
let tris = [];
const seenTri = new Set();
for (const c of bunny.cells) {
  const t = c.map((i) => vid[i]);
  if (t[0] === t[1] || t[1] === t[2] || t[0] === t[2]) continue;
  const s = [...t].sort((a, b) => a - b).join(',');
  if (seenTri.has(s)) continue;
  seenTri.add(s);
  tris.push(t);
}

// --- boundary loops --------------------------------------------------------------------------------
function directedEdges(ts) {
  const m = new Map();
  for (const t of ts) for (let k = 0; k < 3; k++) {
    const e = t[k] + ',' + t[(k + 1) % 3];
    m.set(e, (m.get(e) || 0) + 1);
  }
  return m;
}
const dir = directedEdges(tris);
const next = new Map();  // boundary: directed edge a->b with no b->a; the hole runs b->a
for (const [e] of dir) {
  const [a, b] = e.split(',').map(Number);
  if (!dir.has(b + ',' + a)) {
    if (next.has(b)) throw new Error('boundary vertex ' + b + ' on two boundary loops (non-manifold)');
    next.set(b, a);
  }
}
const loops = [];
const used = new Set();
for (const start of next.keys()) {
  if (used.has(start)) continue;
  const loop = [];
  let v = start;
  while (!used.has(v)) { used.add(v); loop.push(v); v = next.get(v); }
  if (v !== start) throw new Error('open boundary chain');
  loops.push(loop);
}
console.log(`input: ${bunny.positions.length} vertices, ${bunny.cells.length} triangles; merged: ${pos.length} vertices, ${tris.length} triangles; ${loops.length} boundary loops of sizes ${loops.map((l) => l.length).join(', ')}`);

// Fill each hole with a fan to its centroid. The loop runs b->a along the hole, i.e. opposite to the
// neighbouring triangles' edges, so triangles (loop[i], loop[i+1], c) are consistently oriented.
for (const loop of loops) {
  const c = [0, 0, 0];
  for (const v of loop) for (let k = 0; k < 3; k++) c[k] += pos[v][k] / loop.length;
  const ci = pos.length;
  pos.push(c);
  for (let i = 0; i < loop.length; i++) tris.push([loop[i], loop[(i + 1) % loop.length], ci]);
}

// --- checks: closed, manifold, consistently oriented, outward ----------------------------------------
const d2 = directedEdges(tris);
let bad = 0;
for (const [e, n] of d2) {
  const [a, b] = e.split(',');
  if (n !== 1 || d2.get(b + ',' + a) !== 1) bad++;
}
if (bad) throw new Error(`${bad} directed edges are not matched exactly once: surface not closed/oriented`);
let vol = 0;
for (const [a, b, c] of tris) {
  const p = pos[a], q = pos[b], r = pos[c];
  vol += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) + p[2] * (q[0] * r[1] - q[1] * r[0])) / 6;
}
if (vol < 0) { tris = tris.map(([a, b, c]) => [a, c, b]); vol = -vol; }
const V = pos.length, E = d2.size / 2, F = tris.length;
console.log(`closed surface: ${V} vertices, ${F} triangles, Euler characteristic ${V - E + F} (2 = sphere), volume ${(vol * SCALE ** 3).toExponential(4)} m^3`);
if (V - E + F !== 2) console.warn('warning: Euler characteristic is not 2 (handles?)');

// --- write OBJ ------------------------------------------------------------------------------------
const obj = ['# Stanford bunny (npm package `bunny`), holes in the base closed by centroid fans; metres, Y up',
  ...pos.map((p) => 'v ' + p.map((x) => (x * SCALE).toFixed(6)).join(' ')),
  ...tris.map((t) => 'f ' + t.map((i) => i + 1).join(' '))].join('\n') + '\n';
const objPath = path.join(here, 'bunny_closed.obj');
fs.writeFileSync(objPath, obj);

// --- TetGen ----------------------------------------------------------------------------------------
// TetGen cannot read OBJ; give it the same surface as a .poly-free .off file in a temp dir.
export function tetrahedralize(offText, stem, flags, maxVol, outStem) {
  const tmp = fs.mkdtempSync('/tmp/perifx_mesh_');
  const off = path.join(tmp, stem + '.off');
  fs.writeFileSync(off, offText);
  console.log(`tetgen ${flags}a${maxVol.toExponential(3)} ${stem}.off`);
  execFileSync('tetgen', [flags + 'a' + maxVol.toExponential(3), '-Q', off], { stdio: 'inherit' });
  const node = fs.readFileSync(path.join(tmp, stem + '.1.node'), 'utf8').split('\n');
  const ele = fs.readFileSync(path.join(tmp, stem + '.1.ele'), 'utf8').split('\n');
  const out = [];
  for (const line of node) {
    const t = line.trim().split(/\s+/);
    if (!line.trim() || line.trim().startsWith('#')) continue;
    if (out.length === 0) { out.push(`${t[0]} 3 0 0`); continue; }
    out.push(`${t[0]} ${(+t[1]).toPrecision(7)} ${(+t[2]).toPrecision(7)} ${(+t[3]).toPrecision(7)}`);
  }
  const outE = [];
  for (const line of ele) {
    const t = line.trim().split(/\s+/);
    if (!line.trim() || line.trim().startsWith('#')) continue;
    outE.push(outE.length === 0 ? `${t[0]} 4 0` : t.slice(0, 5).join(' '));
  }
  fs.writeFileSync(outStem + '.node', out.join('\n') + '\n');
  fs.writeFileSync(outStem + '.ele', outE.join('\n') + '\n');
  fs.rmSync(tmp, { recursive: true });
  return { nodes: out.length - 1, tets: outE.length - 1 };
}
const off = ['OFF', `${pos.length} ${tris.length} 0`,
  ...pos.map((p) => p.map((x) => (x * SCALE).toFixed(6)).join(' ')),
  ...tris.map((t) => '3 ' + t.join(' '))].join('\n') + '\n';
const volume = vol * SCALE ** 3;
// TetGen's -a is a maximum volume, not a target: iterate it (a few runs) until the tet count is
// within 10% of the target. The preview adds -Y (keep the input surface triangles, no Steiner points
// on the boundary): with -q alone the 3674 surface triangles already force ~4.4e4 tets.
for (const [name, flags, target] of [['preview', '-pYq1.414', 2.4e4], ['full', '-pq1.414', 5.2e5]]) {
  let a = (volume / target) * 2.65;
  let r;
  for (let it = 0; it < 5; it++) {
    r = tetrahedralize(off, 'bunny', flags, a, path.join(here, 'bunny_' + name));
    console.log(`bunny_${name}: ${r.nodes} nodes, ${r.tets} tets`);
    if (Math.abs(r.tets / target - 1) < 0.1) break;
    a *= r.tets / target;
  }
}
