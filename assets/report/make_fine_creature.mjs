// A finer tet mesh of the procedural creature, for the FEM reference of the Fig. 13 accuracy runs
// (assets/report/accuracy.md). It is the same body as assets/meshes/creature_vib.{node,ele} (same
// implicit function, voxel Kuhn tets, boundary nodes moved to the surface), with the voxel size of
// creature_vib divided by FACTOR:
//
//   node assets/report/make_fine_creature.mjs OUT_DIR [FACTOR=1.5]
//
// writes OUT_DIR/creature_vib_fine.node/.ele. It reuses the mesher of make_creature.mjs without
// running that script's own outputs: it copies the script's code up to its final loop into
// OUT_DIR/creature_mesher.mjs and calls voxelize/build/write from there (the script does not export
// them, and importing it would rewrite the committed meshes).
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const outDir = path.resolve(process.argv[2] || '.');
const factor = Number(process.argv[3] || 1.5);
const source = fs.readFileSync(path.join(here, '..', 'meshes', 'make_creature.mjs'), 'utf8');
const cut = source.indexOf('for (const [stem, target] of');
if (cut < 0) throw new Error('make_creature.mjs: its final loop was not found; update make_fine_creature.mjs');
fs.mkdirSync(outDir, { recursive: true });
const mesher = path.join(outDir, 'creature_mesher.mjs');
fs.writeFileSync(mesher, source.slice(0, cut) + `
// Appended by assets/report/make_fine_creature.mjs: creature_vib's voxel size (the same search as
// meshFor(2.0e4)), divided by the factor.
export function fine(factor) {
  let h = 0.02, vox;
  for (let it = 0; it < 8; it++) {
    vox = voxelize(h);
    const tets = vox.count * 6;
    if (Math.abs(tets / 2.0e4 - 1) < 0.05) break;
    h *= Math.cbrt(tets / 2.0e4);
  }
  const m = build(voxelize(vox.h / factor));
  write(m, 'creature_vib_fine');
  return { hVib: vox.h, h: vox.h / factor, nodes: m.x.length, tets: m.tets.length, minV: m.minV };
}
`);
const { fine } = await import(pathToFileURL(mesher).href);
const r = fine(factor);
console.log(`creature_vib voxel ${r.hVib.toPrecision(4)} m -> ${r.h.toPrecision(4)} m: ${r.nodes} nodes, ${r.tets} tets, ` +
  `min tet volume ${r.minV.toFixed(2)} of a voxel tet; written to ${path.join(outDir, 'creature_vib_fine.node/.ele')}`);
