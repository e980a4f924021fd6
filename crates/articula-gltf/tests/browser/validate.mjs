// Validates .glb files with the Khronos glTF validator; prints one JSON line per file:
// {"file", "errors", "warnings", "infos", "messages": [first few error/warning messages]}.
// Exit status 1 when any file has an error.
import { readFileSync } from "node:fs";
import validator from "gltf-validator";

let failed = false;
for (const file of process.argv.slice(2)) {
  const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
    maxIssues: 1000,
  });
  const issues = report.issues;
  const messages = issues.messages
    .filter((m) => m.severity <= 1)
    .slice(0, 10)
    .map((m) => `${m.severity === 0 ? "error" : "warning"} ${m.code} ${m.pointer ?? ""}: ${m.message}`);
  console.log(
    JSON.stringify({
      file,
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      infos: issues.numInfos,
      messages,
    }),
  );
  if (issues.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
