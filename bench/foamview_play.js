// SPDX-License-Identifier: MIT
// Steps for tests/cli/page_driver.js, run by bench/run_view3d.sh: once the real-time foam
// (foam.frag in the page) plays, the pictures it draws in 4 s (each one a new data-time);
// returns the canvas's size, the pictures and the pictures a second.
const f = () => document.getElementById('foamview');
await until(() => f() && f().dataset.state === 'ready' && f().dataset.time, 'the foam view');
const c = f().querySelector('canvas');
let n = 0, last = f().dataset.time;
const t0 = performance.now();
while (performance.now() - t0 < 4000) {
  await new Promise(r => requestAnimationFrame(r));
  if (f().dataset.time !== last) { n++; last = f().dataset.time; }
}
return [c.width, c.height, n, +(1000 * n / (performance.now() - t0)).toFixed(1)];
