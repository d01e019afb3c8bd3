// The Khronos glTF validator (npm gltf-validator) over .glb/.gltf files.
//   node validate.mjs FILE...   prints one JSON report per file: {file, errors, warnings, messages}
// (messages: every issue as {code, severity (0 error, 1 warning, 2 info, 3 hint), pointer, message}).
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const validator = require('gltf-validator');

const reports = [];
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: (uri) => Promise.resolve(
      new Uint8Array(fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(uri))))),
  });
  reports.push({
    file, errors: report.issues.numErrors, warnings: report.issues.numWarnings,
    messages: report.issues.messages.map((m) => ({ code: m.code, severity: m.severity, pointer: m.pointer, message: m.message })),
  });
}
process.stdout.write(JSON.stringify(reports));
