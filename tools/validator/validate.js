#!/usr/bin/env node
// Cross-checks prism's glTF loader with the Khronos glTF-Validator.
//   node validate.js --models DIR            every .gltf/.glb under DIR: errors expected 0
//   node validate.js --corpus DIR VERDICTS   the bad-input corpus tests/gltf/bad_input_test.cpp
//                                            leaves in DIR, with prism's verdict per file (a TSV
//                                            of "path<TAB>loaded|rejected", the last line per path
//                                            counting): how many files each tool rejects.
// A file is invalid for the validator when its report has errors (numErrors > 0);
// warnings and infos do not count. External buffers and images are read from disk.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

function listModels(dir) {
  const out = [];
  for (const e of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, e.name);
    if (e.isDirectory()) out.push(...listModels(p));
    else if (/\.(gltf|glb)$/i.test(e.name)) out.push(p);
  }
  return out.sort();
}

async function validate(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  try {
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          const p = path.resolve(path.dirname(file), decodeURIComponent(uri));
          fs.readFile(p, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
        }),
    });
    const codes = [...new Set(report.issues.messages.filter((m) => m.severity === 0).map((m) => m.code))];
    return { errors: report.issues.numErrors, warnings: report.issues.numWarnings, codes };
  } catch (e) {
    // The validator throws on input it cannot even start on (e.g. an empty file).
    return { errors: 1, warnings: 0, codes: ['THROWN: ' + String(e).slice(0, 80)] };
  }
}

async function models(dir) {
  let bad = 0;
  const files = listModels(dir);
  for (const f of files) {
    const r = await validate(f);
    if (r.errors > 0) bad++;
    console.log(`${r.errors > 0 ? 'INVALID' : 'valid  '} errors=${r.errors} warnings=${r.warnings} ${path.relative(dir, f)}` +
                (r.codes.length ? ' ' + r.codes.join(',') : ''));
  }
  console.log(`models: ${files.length} files, ${files.length - bad} valid, ${bad} with errors`);
  return bad === 0 ? 0 : 1;
}

async function corpus(dir, verdictsFile) {
  const verdict = new Map();
  for (const line of fs.readFileSync(verdictsFile, 'utf8').split('\n')) {
    const [p, v] = line.split('\t');
    if (p && v && p.startsWith(path.resolve(dir)) && fs.existsSync(p)) verdict.set(p, v);
  }
  // Per case folder: counts of (prism rejects, validator rejects).
  const groups = new Map();
  const table = { both: 0, prism_only: 0, validator_only: 0, neither: 0 };
  const disagreements = [];
  for (const [file, v] of [...verdict.entries()].sort()) {
    const r = await validate(file);
    const prismRejects = v === 'rejected', validatorRejects = r.errors > 0;
    const g = path.basename(path.dirname(file));
    if (!groups.has(g)) groups.set(g, { files: 0, prism: 0, validator: 0, both: 0 });
    const s = groups.get(g);
    s.files++;
    if (prismRejects) s.prism++;
    if (validatorRejects) s.validator++;
    if (prismRejects && validatorRejects) s.both++;
    if (prismRejects && validatorRejects) table.both++;
    else if (prismRejects) { table.prism_only++; disagreements.push(`prism only: ${path.relative(dir, file)}`); }
    else if (validatorRejects) {
      table.validator_only++;
      disagreements.push(`validator only: ${path.relative(dir, file)} ${r.codes.join(',')}`);
    } else table.neither++;
  }
  console.log('case folder                      files  prism-rejects  validator-rejects  both');
  for (const [g, s] of [...groups.entries()].sort())
    console.log(`${g.padEnd(32)} ${String(s.files).padStart(5)}  ${String(s.prism).padStart(13)}  ${String(s.validator).padStart(17)}  ${String(s.both).padStart(4)}`);
  const n = verdict.size;
  console.log(`corpus: ${n} files; prism rejects ${table.both + table.prism_only}, the validator flags ${table.both + table.validator_only} as invalid; ` +
              `both ${table.both}, prism only ${table.prism_only}, validator only ${table.validator_only}, neither ${table.neither}`);
  for (const d of disagreements) console.log('  ' + d);
  return 0;
}

(async () => {
  const [mode, a, b] = process.argv.slice(2);
  if (mode === '--models' && a) process.exit(await models(a));
  if (mode === '--corpus' && a && b) process.exit(await corpus(a, b));
  console.error('usage: validate.js --models DIR | --corpus DIR VERDICTS_TSV');
  process.exit(2);
})();
