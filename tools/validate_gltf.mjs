// Prints the Khronos glTF-Validator's JSON report of one .glb/.gltf file on stdout.
// Usage: node tools/validate_gltf.mjs FILE.glb   (exit 0 when the report was produced, 2 on usage/IO errors)
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate_gltf.mjs FILE.glb');
  process.exit(2);
}
try {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 100,
    // rgbdcast GLBs are self-contained; an external reference is reported, never fetched.
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource not allowed: ${uri}`)),
  });
  process.stdout.write(JSON.stringify(report, null, 1) + '\n');
} catch (e) {
  console.error(`validate_gltf: ${e.message ?? e}`);
  process.exit(2);
}
