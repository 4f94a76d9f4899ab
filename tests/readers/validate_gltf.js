// The Khronos glTF validator on one file: prints its report's counts and
// messages as JSON (tests/exports.rs asserts on them).
//     NODE_PATH=.../node_modules node validate_gltf.js FILE.glb
const fs = require('fs');
const validator = require('gltf-validator');
const file = process.argv[2];
validator
  .validateBytes(new Uint8Array(fs.readFileSync(file)), { uri: file, maxIssues: 0, writeTimestamp: false })
  .then((report) => {
    const issues = report.issues;
    console.log(JSON.stringify({
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      messages: issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ''} ${m.message}`),
    }));
  }, (error) => {
    console.log(JSON.stringify({ errors: -1, warnings: 0, messages: [String(error)] }));
  });
