// Runs the Khronos glTF validator on one file and prints its report's
// issues as JSON. Usage: node validate.js NODE_MODULES_DIR FILE
const path = require('path');
const fs = require('fs');
const validator = require(path.join(process.argv[2], 'gltf-validator'));
const file = process.argv[3];
const dir = path.dirname(file);
const data = new Uint8Array(fs.readFileSync(file));
validator
  .validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        try {
          resolve(new Uint8Array(fs.readFileSync(path.resolve(dir, decodeURIComponent(uri)))));
        } catch (e) {
          reject(e.toString());
        }
      }),
  })
  .then((report) => {
    console.log(JSON.stringify(report.issues));
  })
  .catch((e) => {
    console.error('validator failed: ' + e);
    process.exit(2);
  });
