// Validates glTF files with the Khronos glTF validator (npm gltf-validator).
// Usage: node validate.mjs FILE...   Prints one JSON line per file:
// {"file", "errors", "warnings", "infos", "messages": [first few issues]}.
import { createRequire } from "module";
import { readFile } from "fs/promises";
import path from "path";

const require = createRequire(import.meta.url);
const modulePath = process.env.GLTF_VALIDATOR_MODULE || "gltf-validator";
const validator = require(modulePath);

for (const file of process.argv.slice(2)) {
  const data = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    externalResourceFunction: (uri) =>
      readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  const issues = report.issues;
  console.log(JSON.stringify({
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    messages: issues.messages.filter((m) => m.severity <= 1).slice(0, 10),
  }));
}
