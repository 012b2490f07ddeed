// SPDX-License-Identifier: MIT
// Steps for tests/cli/page_driver.js, run by bench/run_view3d.sh: once the 3D view is drawn and
// has been still for 3 s, a drag with the mouse moving 1 pixel every 16 ms (as a person's does)
// for 6 s; returns the canvas's size, the pictures drawn during the drag, the drag's time, the
// pictures a second, the smallest scale seen while moving and, 3 s after letting go, the scale
// and the cost of the last timed picture (data-frame-ms: its draw to its fence's signal).
const f = () => document.getElementById('view3d');
await until(() => f() && f().dataset.state === 'ready' && f().dataset.draws, 'the 3D view');
await new Promise(res => setTimeout(res, 3000));
const c = f().querySelector('canvas'), r = c.getBoundingClientRect();
const ev = (t, x) => c.dispatchEvent(new PointerEvent(t, { clientX: r.left + x, clientY: r.top + 100,
  button: 0, buttons: 1, pointerId: 1, bubbles: true }));
ev('pointerdown', 100);
const d0 = +f().dataset.draws, t0 = performance.now();
let x = 100, least = 1;
await new Promise(done => {
  const id = setInterval(() => {
    ev('pointermove', ++x);
    least = Math.min(least, +f().dataset.scale);
    if (performance.now() - t0 > 6000) { clearInterval(id); done(); }
  }, 16);
});
const t1 = performance.now(), d1 = +f().dataset.draws;
ev('pointerup', x);
await new Promise(res => setTimeout(res, 3000));
return [c.width, c.height, d1 - d0, Math.round(t1 - t0), +(1000 * (d1 - d0) / (t1 - t0)).toFixed(1),
  least, +f().dataset.scale, +f().dataset.frameMs || null];
