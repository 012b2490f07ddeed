// SPDX-License-Identifier: MIT
// The 3D view's liquid presets (web/view3d.js, PRESET) are graphs/wet_preview.wetgraph's: the
// tint of its `tint` node (r, g, b), the absorption depth and the index of refraction its
// wet_view passes to the preview node, and the order of its `liquid` enum. Prints what differs
// and exits 1, or exits 0. Usage: node presets_match.js SOURCE_ROOT
'use strict';
const fs = require('fs');
const root = process.argv[2];
const graph = fs.readFileSync(root + '/graphs/wet_preview.wetgraph', 'utf8');
const view = fs.readFileSync(root + '/web/view3d.js', 'utf8');

// "liquid == 0 ? A : liquid == 1 ? B : ... : F" after `attr="` in the graph: [A, ..., F]
function chain(attr) {
  const m = new RegExp('\\b' + attr + '="[^"]*?\\(liquid == 0 \\? ([^"]*?)\\)').exec(graph);
  if (!m) throw new Error('wet_preview.wetgraph: no preset chain in ' + attr);
  const values = m[1].split(/ : (?:liquid == \d \? )?/).map(Number);
  if (values.length !== 6 || values.some(x => !Number.isFinite(x)))
    throw new Error('wet_preview.wetgraph: ' + attr + ': cannot read ' + m[1]);
  return values;
}
const liquids = /<param name="liquid" type="enum" values="([^"]*)"/.exec(graph)[1].split('|');
const m = /const PRESET = (\{[\s\S]*?\n {2}\});/.exec(view);
if (!m) throw new Error('web/view3d.js: no PRESET');
const preset = Function('return ' + m[1])();
const want = {
  tint: [0, 1, 2].map(c => chain(['r', 'g', 'b'][c])),
  depth: chain('absorption_depth'),
  ior: chain('water_ior'),
};
let bad = 0;
if (liquids.join('|') !== 'water|muddy_water|tea|milk|blood|oil') {
  console.log('wet_preview.wetgraph lists the liquids ' + liquids.join('|') +
              ', the view expects water|muddy_water|tea|milk|blood|oil');
  bad++;
}
for (let k = 0; k < 6; k++) {
  const tint = want.tint.map(t => t[k]);
  if (tint.join() !== preset.tint[k].join()) {
    console.log(liquids[k] + ': tint ' + preset.tint[k] + ' in the view, ' + tint + ' in the graph');
    bad++;
  }
  for (const key of ['depth', 'ior'])
    if (preset[key][k] !== want[key][k]) {
      console.log(liquids[k] + ': ' + key + ' ' + preset[key][k] + ' in the view, ' + want[key][k] +
                  ' in the graph');
      bad++;
    }
}
process.exit(bad ? 1 : 0);
