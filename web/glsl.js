// SPDX-License-Identifier: MIT
// What the page's WebGL2 views share (web/view3d.js, web/foamview.js): the shaders of
// docs/shaders made GLSL ES 3.00, and the server's half-float images.
// The shaders are GLSL 3.30; WebGL2 takes GLSL ES 3.00, so only what the language needs is
// changed: the version line (moved to the first line, before the file's opening comment, with
// float precision) and the uniforms' initial values, which ES does not allow: they are taken out
// and set by wgSetDefaults after linking, from the same text.
'use strict';

// src made GLSL ES 3.00: {source, defaults: [[type, name, initial value text], ...]}
function wgGlslEs(src, what) {
  const version = src.split('\n').find(l => l.startsWith('#version')) || '';
  if (!/^#version 330/.test(version)) throw new Error(what + ': expected #version 330 core');
  const defaults = [];
  let out = '#version 300 es\n' + src.replace(/^#version 330 core/m,
    'precision highp float;\nprecision highp int;\nprecision highp sampler2D;');
  out = out.replace(/^(uniform\s+(\w+)\s+(\w+))\s*=\s*([^;]+);/gm, (all, decl, type, name, v) => {
    defaults.push([type, name, v.trim()]);
    return decl + ';';
  });
  return { source: out, defaults };
}

// a program of the vertex and fragment sources, attribute 0 bound to `pos`; errors name `what`
function wgLink(gl, vs, fs, what) {
  const compile = (type, src, label) => {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS))
      throw new Error(label + ': ' + gl.getShaderInfoLog(s));
    return s;
  };
  const p = gl.createProgram();
  gl.attachShader(p, compile(gl.VERTEX_SHADER, vs, what + ' (vertex)'));
  gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fs, what));
  gl.bindAttribLocation(p, 0, 'pos');
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(what + ': ' + gl.getProgramInfoLog(p));
  return p;
}

// set the initial values wgGlslEs took out (a number, true/false or a vecN(...) of numbers) on
// the program in use
function wgSetDefaults(gl, prog, defaults, what) {
  for (const [type, name, text] of defaults) {
    const loc = gl.getUniformLocation(prog, name);
    if (!loc) continue;
    const inner = text.replace(/^\w+\s*\(/, '').replace(/\)\s*$/, ''); // vec3(...) -> ...
    const nums = (inner.match(/-?[0-9.]+(?:e-?[0-9]+)?|true|false/g) || [])
      .map(x => x === 'true' ? 1 : x === 'false' ? 0 : +x);
    if (type === 'float') gl.uniform1f(loc, nums[0]);
    else if (type === 'int' || type === 'bool') gl.uniform1i(loc, nums[0]);
    else if (type === 'vec3') gl.uniform3f(loc, nums[0], nums.length > 1 ? nums[1] : nums[0],
      nums.length > 2 ? nums[2] : nums[0]);
    else throw new Error(what + ': cannot set the initial value of ' + type + ' ' + name);
  }
}

// an n x n RGBA8 picture drawn by draw(n, n, framebuffer) into an offscreen framebuffer (made
// once, kept in holder.fbo, with a depth buffer for views that draw meshes), read back: GL's
// rows, from the bottom, 4 bytes a pixel
function wgReadBack(gl, holder, n, draw) {
  if (!holder.fbo) {
    holder.fbo = gl.createFramebuffer();
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, n, n, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
    gl.bindFramebuffer(gl.FRAMEBUFFER, holder.fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t, 0);
    const depth = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, n, n);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
  }
  draw(n, n, holder.fbo);
  const px = new Uint8Array(n * n * 4);
  gl.readPixels(0, 0, n, n, gl.RGBA, gl.UNSIGNED_BYTE, px);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  return px;
}

const WG_HALF = (function () { // IEEE half float to number, for every 16-bit code
  const t = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const e = (h >> 10) & 31, m = h & 1023, s = h & 32768 ? -1 : 1;
    t[h] = e === 0 ? s * m * 5.960464477539063e-8 : e === 31 ? (m ? NaN : s * Infinity)
      : s * (1 + m / 1024) * Math.pow(2, e - 15);
  }
  return t;
})();

// an image of /map/ or /env/: {w, h, c, data: Float32Array, rows from the top}
async function wgFetchPixels(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(url + ': ' + r.status);
  const [w, h, c] = (r.headers.get('X-Wetgraph-Size') || '').split(' ').map(Number);
  const raw = new Uint8Array(await r.arrayBuffer());
  if (!(w > 0 && h > 0 && c > 0) || raw.length !== w * h * c * 2) throw new Error(url + ': bad size');
  const data = new Float32Array(w * h * c);
  for (let i = 0; i < data.length; i++) data[i] = WG_HALF[raw[2 * i] | raw[2 * i + 1] << 8];
  return { w, h, c, data };
}
