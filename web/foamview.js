// SPDX-License-Identifier: MIT
// The page's real-time foam: docs/shaders/foam.frag itself (loaded from /shaders/foam.frag, the
// shipped file, made GLSL ES by web/glsl.js) animating in a WebGL2 canvas beside the frames the
// graph renders, for a graph whose outputs include `maps` (graphs/foam.wetgraph bakes the
// shader's texture there) and `foam`. The texture is the render's `maps` (/map/maps, half
// floats, loaded again when a render made it anew), drawn once across the canvas (uv 0..1, row
// 0 of the image at the bottom as the shader wants it), with GL_LINEAR filtering and GL_REPEAT;
// each uniform the shader has is set from the graph's float parameter of the same name, and
// `time` runs with the page's clock (pause stops it). The address takes ?foamtime=T (a still
// picture at $time T, for tests and screenshots) and ?probe=N (as the 3D view: the N x N
// picture read back into data-probe, hex gray, row 0 of the image first). The figure's data-state says
// where it is (loading, ready, no-webgl2, error with data-error).
'use strict';

const foamView = (function () {
  const args = new URLSearchParams(location.search);
  const probeN = Math.max(0, Math.min(1024, +args.get('probe') || 0));
  const still = args.get('foamtime') !== null ? +args.get('foamtime') || 0 : null;
  let fig, canvas, gl = null, prog, vao, tex = null, shownVersion = -1, params = {};
  let started = null, playing = still === null, t0 = performance.now(), tPaused = 0, probeTarget = {};
  const VS = `#version 300 es
layout(location = 0) in vec2 pos;
out vec2 uv;
void main() { uv = pos * 0.5 + 0.5; gl_Position = vec4(pos, 0.0, 1.0); }`;

  function setState(s, err) {
    fig.dataset.state = s;
    if (err) fig.dataset.error = err; else delete fig.dataset.error;
    const m = fig.querySelector('.msg');
    m.textContent = s === 'ready' ? '' : s === 'loading' ? 'loading…' : err || s;
    m.hidden = s === 'ready';
  }
  function now() { return still !== null ? still : playing ? (performance.now() - t0) / 1000 : tPaused; }

  function drawTo(w, h, fbo) {
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(0, 0, w, h);
    gl.useProgram(prog);
    for (const [name, v] of Object.entries(params)) {
      const loc = gl.getUniformLocation(prog, name);
      if (loc) gl.uniform1f(loc, v);
    }
    gl.uniform1f(gl.getUniformLocation(prog, 'time'), now());
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.uniform1i(gl.getUniformLocation(prog, 'maps'), 0);
    gl.bindVertexArray(vao);
    gl.drawArrays(gl.TRIANGLES, 0, 6);
    gl.bindVertexArray(null);
  }
  function probe() {
    const px = wgReadBack(gl, probeTarget, probeN, drawTo);
    let hex = '';
    for (let y = 0; y < probeN; y++) // GL's rows from the bottom: the image's rows in order
      for (let x = 0; x < probeN; x++) hex += px[(y * probeN + x) * 4].toString(16).padStart(2, '0');
    fig.dataset.probe = hex;
  }
  function frame() {
    if (!gl || !tex) return;
    const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    drawTo(w, h, null);
    fig.dataset.time = now().toFixed(3);
    if (playing) requestAnimationFrame(frame);
  }

  function build(main) {
    fig = document.createElement('figure');
    fig.id = 'foamview';
    canvas = document.createElement('canvas');
    const msg = document.createElement('div');
    msg.className = 'msg';
    const cap = document.createElement('figcaption');
    const title = document.createElement('span');
    title.textContent = 'foam.frag, real time';
    const play = document.createElement('button');
    play.id = 'foam-play';
    const label = () => { play.textContent = playing ? 'pause' : 'play'; };
    label();
    play.onclick = () => {
      if (still !== null) return;
      if (playing) tPaused = now(); else t0 = performance.now() - tPaused * 1000;
      playing = !playing;
      label();
      if (playing) requestAnimationFrame(frame); else frame();
    };
    cap.append(title, play);
    fig.append(canvas, msg, cap);
    const after = document.getElementById('view3d');
    main.insertBefore(fig, after ? after.nextSibling : main.firstChild);
  }

  async function begin(main) {
    build(main);
    gl = canvas.getContext('webgl2', { antialias: false });
    if (!gl) {
      setState('no-webgl2', 'this browser gives the page no WebGL2 context: the foam view needs one');
      return;
    }
    setState('loading');
    try {
      const r = await fetch('/shaders/foam.frag');
      if (!r.ok) throw new Error('/shaders/foam.frag: ' + r.status);
      const es = wgGlslEs(await r.text(), 'foam.frag');
      prog = wgLink(gl, VS, es.source, 'foam.frag');
      gl.useProgram(prog);
      wgSetDefaults(gl, prog, es.defaults, 'foam.frag');
      vao = gl.createVertexArray();
      gl.bindVertexArray(vao);
      gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
      gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, 1, 1, -1, -1, 1, 1, -1, 1]), gl.STATIC_DRAW);
      gl.enableVertexAttribArray(0);
      gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
      gl.bindVertexArray(null);
    } catch (e) {
      gl = null;
      setState('error', String(e.message || e));
    }
  }

  // a new state: the parameters, and the maps of a render that made them anew
  let loading = Promise.resolve();
  function update(s) {
    return (loading = loading.then(async () => {
      await started;
      if (!gl) return;
      params = {};
      for (const p of s.params) if (p.type === 'float' || p.type === 'int') params[p.name] = +p.value;
      const o = s.outputs.find(x => x.name === 'maps');
      try {
        if (o && o.version !== shownVersion) {
          const img = await wgFetchPixels('/map/maps');
          if (img.c !== 4) throw new Error('maps: 4 channels expected, ' + img.c + ' given');
          tex = tex || gl.createTexture();
          gl.bindTexture(gl.TEXTURE_2D, tex);
          gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
          // row 0 of the image at t = 0, as foam.frag reads it: the rows as they come
          gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA16F, img.w, img.h, 0, gl.RGBA, gl.FLOAT, img.data);
          gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
          gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
          gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.REPEAT);
          gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.REPEAT);
          shownVersion = o.version;
          fig.dataset.version = o.version;
        }
        setState('ready');
        if (probeN) probe();
        if (!playing) frame(); else if (!frame.running) { frame.running = true; requestAnimationFrame(frame); }
      } catch (e) {
        setState('error', String(e.message || e));
      }
    }));
  }
  return {
    start: main => (started = begin(main)),
    started: () => started !== null,
    update,
  };
})();
