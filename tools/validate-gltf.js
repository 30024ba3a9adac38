#!/usr/bin/env node
// Runs the Khronos glTF-Validator (npm gltf-validator, pinned in package.json) on glTF/GLB
// files: node tools/validate-gltf.js FILE...
//
// The validator is a library without an executable, so this wraps it. External buffers and
// images (relative URIs) are read relative to the file that names them. For each file it
// prints every issue as "[severity] CODE pointer: message" (severity 0 error, 1 warning,
// 2 info, 3 hint), after one summary line:
//   FILE: N errors, N warnings, N infos, N hints
// Exit status: 0 when no file has an error, 1 when any file has an error or cannot be read,
// 2 on bad usage. Install once with `npm ci` in tools/.
'use strict';

const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

function readExternal(file, uri) {
  const resolved = path.resolve(path.dirname(file), decodeURIComponent(uri));
  return fs.promises.readFile(resolved).then((data) => new Uint8Array(data));
}

async function validateFile(file) {
  let bytes;
  try {
    bytes = new Uint8Array(fs.readFileSync(file));
  } catch (err) {
    console.log(`${file}: cannot read (${err.message})`);
    return false;
  }
  let report;
  try {
    report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0,  // 0 = unlimited
      writeTimestamp: false,
      externalResourceFunction: (uri) => readExternal(file, uri),
    });
  } catch (err) {
    console.log(`${file}: validator failed (${err})`);
    return false;
  }
  const issues = report.issues;
  console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
              `${issues.numInfos} infos, ${issues.numHints} hints`);
  for (const m of issues.messages) console.log(`  [${m.severity}] ${m.code} ${m.pointer || ''}: ${m.message}`);
  return issues.numErrors === 0;
}

async function main(files) {
  if (files.length === 0) {
    console.error('usage: node validate-gltf.js FILE.gltf|FILE.glb...');
    return 2;
  }
  let ok = true;
  for (const file of files) ok = (await validateFile(file)) && ok;
  return ok ? 0 : 1;
}

main(process.argv.slice(2)).then((code) => { process.exitCode = code; });
