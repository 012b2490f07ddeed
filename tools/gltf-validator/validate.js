// SPDX-License-Identifier: MIT
// Validates glTF assets with Khronos' glTF-Validator (the npm package installed beside this
// file by scripts/install-deps.sh): `node validate.js FILE...` (.gltf with its external buffers
// and images, or .glb). Prints each file's counts of errors, warnings, infos and hints, and the
// errors and warnings themselves; exits 1 when any file has an error or a warning, 2 when a
// file cannot be read.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, {
        uri: path.basename(file),
        maxIssues: 100,
        externalResourceFunction: (uri) => new Promise((resolve, reject) => {
            const full = path.resolve(path.dirname(file), decodeURIComponent(uri));
            fs.readFile(full, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
        }),
    });
    const n = report.issues;
    console.log(`${file}: ${n.numErrors} errors, ${n.numWarnings} warnings, ${n.numInfos} infos, ` +
                `${n.numHints} hints`);
    for (const m of n.messages)
        if (m.severity <= 1)
            console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ${m.message}`);
    return n.numErrors + n.numWarnings;
}

(async () => {
    if (process.argv.length < 3) {
        console.error('usage: node validate.js FILE.gltf|FILE.glb...');
        process.exit(2);
    }
    let bad = 0;
    for (const file of process.argv.slice(2)) {
        try {
            bad += await validate(file);
        } catch (e) {
            console.error(`${file}: ${e}`);
            process.exit(2);
        }
    }
    process.exit(bad ? 1 : 0);
})();
