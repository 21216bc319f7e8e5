// Runs the Khronos glTF Validator (npm package gltf-validator) on .glb files and prints, per file,
// the counts of errors, warnings, infos and hints and every message; exits 1 when any file has an
// error or a warning. Usage: GLTF_VALIDATOR=<dir of the package> node validate_gltf.js FILE.glb...
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require(process.env.GLTF_VALIDATOR ? path.resolve(process.env.GLTF_VALIDATOR) : 'gltf-validator');

async function main(files) {
  let bad = 0;
  console.log(`gltf-validator ${validator.version()}`);
  for (const file of files) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
      uri: path.basename(file), maxIssues: 0, writeTimestamp: false,
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints` +
                ` (${report.info.drawCallCount} primitives, ${report.info.animationCount ?? 0} animations,` +
                ` ${report.info.totalTriangleCount ?? '?'} triangles)`);
    for (const m of i.messages) console.log(`  [${['error', 'warning', 'info', 'hint'][m.severity]}] ${m.code} ${m.pointer || ''}: ${m.message}`);
    if (i.numErrors > 0 || i.numWarnings > 0) bad++;
  }
  process.exit(bad ? 1 : 0);
}

main(process.argv.slice(2)).catch((e) => { console.error(e); process.exit(2); });
