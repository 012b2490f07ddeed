// SPDX-License-Identifier: MIT
// The page's 3D view: the material lit in real time by docs/shaders/wet_layered.frag itself
// (loaded from /shaders/wet_layered.frag, the shipped file), on the tile's plane seen by the
// `preview` node's camera (elevation and azimuth in degrees, zoom 1 showing the whole tile from
// straight above, a 35 degree vertical field of view, the tile 2 x 2 with tiling 2), in a WebGL2
// canvas. Two more shapes: a sphere (the shader compiled with WG_TANGENT_FRAME, given each
// point's tangent frame so that it reads the environment in world space; the relief by parallax
// as on the plane, taken as locally flat) and a displaced grid (the plane subdivided, raised to
// the top of the layers, the shader told so with `displaced`: the relief drawn by the mesh, not
// again by parallax). The shader is GLSL 3.30; WebGL2 takes GLSL ES 3.00, so the page changes
// only what the language needs (web/glsl.js: the version line, the uniforms' initial values),
// and main, renamed, called by a main that adds what the preview node does after the shader:
// Narkowicz's ACES fit and sRGB encoding. Directions off the tile show the environment (the prefiltered
// level of roughness 0, as the preview node's background).
//
// Lighting: the environment's env_prefilter atlas (/env/K, half floats, made once per
// environment by the server and kept for the session; the page keeps each one it loaded) split
// as the shader wants it: blocks 0-5 as one mip chain (level l = block l; see loadEnv), block 6
// the irradiance, block 7's left square the split-sum table. Maps (/map/NAME, half floats at the previews' size) are the render's
// outputs, loaded again when a render made them anew; the material is bound as
// graphs/wet_preview.wetgraph gives it to its `preview` nodes: the wet side reads the layer
// maps under the liquid (underbasecolor, underroughness, underheight, undermetallic,
// underspecular; each falling back to the output without under, then to a neutral value),
// the normal as wet_preview's blend (undernormal where the liquid stands, mixed by
// watermask, over normal) and the liquid's own maps (waterheight, waternormal,
// waterroughness, waterspecular, watermask); the dry side reads the graph's image inputs
// given as files ($basecolor, $normal, ...; else the outputs of the same names) with no
// liquid. Heights are normalised by the range of the height map (the output height, which the
// graph renders at its own size, else $height),
// and height_scale, the liquid's tint, absorption depth and index come from the graph's
// height_scale, liquid, tint_r/g/b and absorption_depth parameters as in wet_preview (the
// liquid presets below are that file's, which tests/cli/presets_match.js checks).
//
// Controls: drag to orbit (elevation 1-90 degrees), the wheel to zoom, shift-drag (or drag
// with the right button) to turn the environment; the shape menu (plane, sphere, grid); the
// split slider puts the dry material left of the line and the wet one right of it; tiling 1 x 1
// or 2 x 2 (on the sphere, 2 or 4 tiles around); exposure in stops; the environment menu. The
// address takes ?view=ELEVATION,AZIMUTH,ZOOM,ENV_ROTATION, ?shape=plane|sphere|grid, ?split=S
// (0: all wet, 1: all dry), ?tiling=2, ?exposure=E, ?env=K, ?frame_ms=MS (the moving view's
// budget a picture, below; 0: always full resolution) and ?probe=N (after each picture, an
// N x N picture of the same view is read back into data-probe, hex RGB from the top row, and
// data-cover, '1' where the shape was drawn and '0' where the background shows, for tests). The
// figure's data-state says where the view is: loading, ready, no-webgl2 or error (with
// data-error); data-shape is the shape shown, data-version the render whose maps it shows,
// data-draws counts the pictures drawn, data-scale is the last picture's resolution (1, or the
// fraction it was drawn at while the view moved) and data-frame-ms what the last timed picture
// cost. The page starts the view for a graph whose outputs
// include a base colour (basecolor or underbasecolor): a material.
'use strict';

const view3d = (function () {
  const args = new URLSearchParams(location.search);
  const deg = Math.PI / 180;
  // the liquid presets of graphs/wet_preview.wetgraph, in the order of its `liquid` enum:
  // water, muddy_water, tea, milk, blood, oil
  const PRESET = {
    tint: [[1.0, 1.0, 1.0], [0.62, 0.52, 0.38], [0.8, 0.4, 0.1], [0.97, 0.95, 0.88],
      [0.55, 0.03, 0.03], [0.92, 0.78, 0.35]],
    depth: [16.0, 0.8, 2.4, 3.2, 0.48, 4.8],
    ior: [1.333, 1.335, 1.334, 1.347, 1.4, 1.47],
  };
  // neutral values of maps a graph does not make
  const NEUTRAL = {
    basecolor: [0.5, 0.5, 0.5, 1], normal_map: [0.5, 0.5, 1, 1], roughness: [0.5], height: [1],
    ao: [1], metallic: [0], specular: [0.5], water_height: [0], water_normal: [0.5, 0.5, 1, 1],
    water_roughness: [0.02], water_specular: [0.02], water_mask: [0],
  };
  const SAMPLERS = Object.keys(NEUTRAL);

  const cam = { elevation: 50, azimuth: 20, zoom: 1, envRotation: 0 };
  const opt = { split: 0.5, tiling: 1, exposure: 0, env: 0, shape: 'plane' };
  const SHAPES = ['plane', 'sphere', 'grid'];
  let fig, canvas, gl, prog, bgProg, bgVao, fsSource, probeTarget = {};
  const progs = {}; // shape -> its program, linked when the shape is first drawn
  const probeN = Math.max(0, Math.min(1024, +args.get('probe') || 0));
  const uniformDefaults = [];
  const maps = {}; // name -> {version, w, h, c, data: Float32Array}
  const envs = {}; // index -> {prefiltered, irradiance, lut}
  const tex = { dry: {}, wet: {} };
  let params = {}, stateVersion = -1, shown = -1, loading = null, pending = null, draws = 0;
  let queued = false, drawFailed = false;

  // Moving the view (a drag, the wheel) draws at a fraction of the canvas's resolution, scaled
  // up, so that a slow renderer (software WebGL, such as SwiftShader) still follows the mouse;
  // SETTLE_MS after the last move the view is drawn again at full resolution. The fraction comes
  // from what frames cost: each picture's time from its draw to its fence's signal, the pixels'
  // cost scaling with the fraction squared, aimed at frameMs a frame (?frame_ms=, 0 for always
  // full resolution), from MIN_SCALE to 1.
  const SETTLE_MS = 250, MIN_SCALE = 0.25;
  const frameMs = args.get('frame_ms') !== null ? Math.max(0, +args.get('frame_ms') || 0) : 50;
  const motion = { moving: false, timer: 0, scale: 1, fence: null, target: {} };

  function setState(s, err) {
    fig.dataset.state = s;
    if (err) fig.dataset.error = err; else delete fig.dataset.error;
    const m = fig.querySelector('.msg');
    m.textContent = s === 'ready' ? '' : s === 'loading' ? 'loading…' : err || s;
    m.hidden = s === 'ready';
  }

  // ---- the shader, made GLSL ES 3.00 -------------------------------------------------------
  function adapt(src) {
    const es = wgGlslEs(src, 'wet_layered.frag');
    uniformDefaults.push(...es.defaults);
    let out = es.source;
    if (!/\bvoid main\(\)/.test(out)) throw new Error('wet_layered.frag: no main()');
    out = out.replace(/\bvoid main\(\)/, 'void layered_main()');
    return out + `
uniform bool view_tonemap; // Narkowicz's ACES fit and sRGB encoding, as the preview node
vec3 view_finish(vec3 x)
{
    x = max(x, vec3(0.0));
    x = clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), x));
}
void main()
{
    layered_main();
    frag_color = vec4(view_finish(frag_color.rgb), 1.0);
}
`;
  }

  const VS = `#version 300 es
layout(location = 0) in vec2 pos;
uniform vec3 cam, right, up, fwd;
uniform float tan_half, aspect;
out vec2 uv;
out vec3 view_ts;
// the preview node's camera: clip x, y = the point's offsets along right and up over its
// depth along the view times tan(fov/2) (x also over the aspect), w = that depth
void main()
{
    vec3 p = vec3(pos, 0.0), r = p - cam;
    uv = pos;
    view_ts = cam - p;
    gl_Position = vec4(dot(r, right) / (tan_half * aspect), dot(r, up) / tan_half, 0.0, dot(r, fwd));
}`;
  // The sphere, of radius SPHERE_R about the origin, from pos = (longitude in turns, latitude
  // from the south pole in half turns): T along +u (east), B = N x T along +v (north), N outward;
  // view_ts is the eye's direction in that frame, and the frame goes to the shader, which reads
  // the environment in world space through it (WG_TANGENT_FRAME). The texture wraps 2 x tiling
  // times around and tiling times from pole to pole, so its tiles are square on the equator;
  // towards the poles they narrow (cos(latitude)) and pinch to a point at each pole. Clip z from
  // the depth (near 0.01, far 1000) for the depth test.
  const SPHERE_R = 0.4;
  const SPHERE_VS = `#version 300 es
layout(location = 0) in vec2 pos;
uniform vec3 cam, right, up, fwd;
uniform float tan_half, aspect, radius;
uniform vec2 repeat, depth_ab;
out vec2 uv;
out vec3 view_ts;
out mat3 tangent_to_world;
const float PI = 3.141592653589793;
void main()
{
    float lon = 2.0 * PI * pos.x, lat = PI * (pos.y - 0.5);
    vec3 n = vec3(cos(lat) * cos(lon), cos(lat) * sin(lon), sin(lat));
    vec3 t = vec3(-sin(lon), cos(lon), 0.0), b = cross(n, t);
    vec3 p = radius * n, r = p - cam, e = cam - p;
    uv = pos * repeat;
    view_ts = vec3(dot(e, t), dot(e, b), dot(e, n));
    tangent_to_world = mat3(t, b, n);
    float depth = dot(r, fwd);
    gl_Position = vec4(dot(r, right) / (tan_half * aspect), dot(r, up) / tan_half,
                       depth * depth_ab.x + depth_ab.y, depth);
}`;
  // The displaced grid: the tile's plane subdivided (GRID_CELLS a tile), each vertex raised to
  // the top of the layers the side draws (the shader's own surface_top, taken from the shipped
  // file: the water's surface where there is water, else the relief) through height_scale, in
  // the tile's flat frame; the shader, told the mesh is displaced, starts its search there.
  const GRID_CELLS = 256;
  const gridVs = top => `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
layout(location = 0) in vec2 pos;
uniform vec3 cam, right, up, fwd;
uniform float tan_half, aspect, height_scale;
uniform vec2 depth_ab;
uniform sampler2D height, water_height, water_mask;
out vec2 uv;
out vec3 view_ts;
${top}
void main()
{
    vec3 p = vec3(pos, height_scale * (surface_top(pos) - 1.0)), r = p - cam;
    uv = pos;
    view_ts = cam - p;
    float depth = dot(r, fwd);
    gl_Position = vec4(dot(r, right) / (tan_half * aspect), dot(r, up) / tan_half,
                       depth * depth_ab.x + depth_ab.y, depth);
}`;
  const NEAR = 0.01, FAR = 1000, DEPTH_AB = [(FAR + NEAR) / (FAR - NEAR), -2 * FAR * NEAR / (FAR - NEAR)];
  const BG_VS = `#version 300 es
layout(location = 0) in vec2 pos;
out vec2 ndc;
void main() { ndc = pos; gl_Position = vec4(pos, 0.0, 1.0); }`;
  // the environment seen past the tile: the preview node's background (roughness 0)
  const BG_FS = `#version 300 es
precision highp float;
uniform sampler2D prefiltered;
uniform vec3 right, up, fwd;
uniform float tan_half, aspect, env_rotation, exposure;
in vec2 ndc;
out vec4 frag_color;
const float PI = 3.141592653589793;
vec3 view_finish(vec3 x)
{
    x = max(x, vec3(0.0));
    x = clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), x));
}
void main()
{
    vec3 d = normalize(fwd + (right * (ndc.x * aspect) + up * ndc.y) * tan_half);
    float phi = atan(d.y, d.x) + env_rotation;
    vec2 st = vec2(fract(0.5 - phi / (2.0 * PI)), 1.0 - acos(clamp(d.z, -1.0, 1.0)) / PI);
    // alpha 0: the background (the probe's data-cover tells it from the surface)
    frag_color = vec4(view_finish(textureLod(prefiltered, st, 0.0).rgb * exp2(exposure)), 0.0);
}`;

  const link = (vs, fs, what) => wgLink(gl, vs, fs, what);
  function quad(points) {
    const v = gl.createVertexArray();
    gl.bindVertexArray(v);
    const b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(points), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    return v;
  }

  // An indexed grid of (cols + 1) x (rows + 1) vertices over [0, sx] x [0, sy], two triangles a
  // cell: {vao, count}.
  function mesh(cols, rows, sx, sy) {
    const v = new Float32Array((cols + 1) * (rows + 1) * 2), ix = new Uint32Array(cols * rows * 6);
    for (let j = 0, k = 0; j <= rows; j++)
      for (let i = 0; i <= cols; i++, k += 2) { v[k] = i / cols * sx; v[k + 1] = j / rows * sy; }
    for (let j = 0, k = 0; j < rows; j++)
      for (let i = 0; i < cols; i++, k += 6) {
        const a = j * (cols + 1) + i, b = a + cols + 1;
        ix.set([a, a + 1, b + 1, a, b + 1, b], k);
      }
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, v, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, ix, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, count: ix.length };
  }
  const meshes = {};
  // coarse: the grid with GRID_CELLS / 4 cells a tile, drawn while the view moves (its vertices,
  // each reading the maps, are most of its cost on a software renderer)
  function shapeMesh(shape, span, coarse) {
    const cells = coarse ? GRID_CELLS / 4 : GRID_CELLS;
    const key = shape + span + (shape === 'grid' ? '/' + cells : '');
    if (!meshes[key])
      meshes[key] = shape === 'sphere' ? mesh(128, 64, 1, 1) :
        shape === 'grid' ? mesh(cells * span, cells * span, span, span) :
          { vao: quad([0, 0, span, 0, span, span, 0, 0, span, span, 0, span]), count: 6, flat: true };
    return meshes[key];
  }

  // the shape's program, linked the first time it is drawn: the plane's is the shipped shader as
  // it is; the sphere's defines WG_TANGENT_FRAME; the grid's sets displaced
  function shapeProgram(shape) {
    if (progs[shape]) return progs[shape];
    let p;
    if (shape === 'sphere')
      p = link(SPHERE_VS, fsSource.replace(/^#version 300 es\n/, '#version 300 es\n#define WG_TANGENT_FRAME\n'),
        'wet_layered.frag (sphere)');
    else if (shape === 'grid') {
      const top = fsSource.match(/\nfloat surface_top\(vec2 st\)\n\{[\s\S]*?\n\}\n/);
      if (!top) throw new Error('wet_layered.frag: no surface_top()');
      p = link(gridVs(top[0]), fsSource, 'wet_layered.frag (grid)');
    } else p = link(VS, fsSource, 'wet_layered.frag');
    gl.useProgram(p);
    wgSetDefaults(gl, p, uniformDefaults, 'wet_layered.frag');
    if (shape === 'grid') gl.uniform1i(gl.getUniformLocation(p, 'displaced'), 1);
    return (progs[shape] = p);
  }

  // ---- textures ------------------------------------------------------------------------------
  const fetchPixels = wgFetchPixels;

  // rows from the bottom (flip: the image's top row at t = 1), as GL wants them
  function rowsUp(img, flip) {
    if (!flip) return img.data;
    const { w, h, c, data } = img, out = new Float32Array(data.length), n = w * c;
    for (let y = 0; y < h; y++) out.set(data.subarray(y * n, y * n + n), (h - 1 - y) * n);
    return out;
  }
  function upload(t, levels, opts) {
    t = t || gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    const c = levels[0].c;
    const ifmt = c === 1 ? gl.R16F : gl.RGBA16F, fmt = c === 1 ? gl.RED : gl.RGBA;
    levels.forEach((img, l) => gl.texImage2D(gl.TEXTURE_2D, l, ifmt, img.w, img.h, 0, fmt, gl.FLOAT,
      rowsUp(img, opts.flip)));
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAX_LEVEL, levels.length - 1);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER,
      levels.length > 1 ? gl.LINEAR_MIPMAP_LINEAR : gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, opts.clampS ? gl.CLAMP_TO_EDGE : gl.REPEAT);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, opts.clampT ? gl.CLAMP_TO_EDGE : gl.REPEAT);
    return t;
  }

  // block b of the atlas (2 across, 4 down) as a w x h image: box-filtered where that is
  // smaller than the block, sampled bilinearly (u wrapping, v clamped, as the preview node reads
  // it) at the texel centres where it is larger
  function block(atlas, b, w, h) {
    const bw = atlas.w / 2, bh = atlas.h / 4, bx = (b % 2) * bw, by = Math.floor(b / 2) * bh;
    const out = new Float32Array(w * h * 4);
    const at = (x, y, c) => atlas.data[((by + y) * atlas.w + bx + x) * 4 + c];
    if (w <= bw && h <= bh) {
      const kx = bw / w, ky = bh / h;
      for (let y = 0; y < h; y++)
        for (let x = 0; x < w; x++)
          for (let c = 0; c < 4; c++) {
            let s = 0;
            for (let j = 0; j < ky; j++) for (let i = 0; i < kx; i++) s += at(x * kx + i, y * ky + j, c);
            out[(y * w + x) * 4 + c] = s / (kx * ky);
          }
    } else {
      for (let y = 0; y < h; y++) {
        const fy = Math.min(bh - 1, Math.max(0, (y + 0.5) / h * bh - 0.5));
        const y0 = Math.floor(fy), y1 = Math.min(bh - 1, y0 + 1), ay = fy - y0;
        for (let x = 0; x < w; x++) {
          const fx = (x + 0.5) / w * bw - 0.5, x0 = Math.floor(fx), ax = fx - x0;
          const xa = ((x0 % bw) + bw) % bw, xb = (xa + 1) % bw;
          for (let c = 0; c < 4; c++)
            out[(y * w + x) * 4 + c] = (at(xa, y0, c) * (1 - ax) + at(xb, y0, c) * ax) * (1 - ay) +
              (at(xa, y1, c) * (1 - ax) + at(xb, y1, c) * ax) * ay;
        }
      }
    }
    return { w, h, c: 4, data: out };
  }

  // The prefiltered blocks as one mip chain whose level l is block l (the shader reads level
  // roughness x 5). Level 0 is 4 times a block's size, so that the rough levels keep texels
  // enough (level 5, block 5, at 1/8 of the block; at the block's size it would be 8 x 4
  // texels, bilinear over 45 degrees a texel) while the sharp ones are the blocks magnified,
  // which bilinear filtering reads as it reads the block.
  async function loadEnv(k) {
    if (envs[k]) return envs[k];
    const atlas = await fetchPixels('/env/' + k);
    const bw = atlas.w / 2, bh = atlas.h / 4, levels = [];
    for (let l = 0; l < 6; l++) levels.push(block(atlas, l, Math.max(1, 4 * bw >> l), Math.max(1, 4 * bh >> l)));
    envs[k] = {
      prefiltered: upload(null, levels, { flip: true, clampT: true }),
      irradiance: upload(null, [block(atlas, 6, bw, bh)], { flip: true, clampT: true }),
      lut: upload(null, [lutBlock(atlas)], { clampS: true, clampT: true }),
    };
    return envs[k];
  }
  // the split-sum table: the left square of block 7
  function lutBlock(atlas) {
    const bw = atlas.w / 2, bh = atlas.h / 4, out = new Float32Array(bh * bh * 4);
    for (let y = 0; y < bh; y++)
      out.set(atlas.data.subarray(((3 * bh + y) * atlas.w + bw) * 4, ((3 * bh + y) * atlas.w + bw + bh) * 4), y * bh * 4);
    return { w: bh, h: bh, c: 4, data: out };
  }

  // ---- the material --------------------------------------------------------------------------
  function constant(v) { return { w: 1, h: 1, c: v.length === 1 ? 1 : 4, data: new Float32Array(v) }; }
  function pick(...names) {
    for (const n of names) if (maps[n]) return maps[n];
    return null;
  }
  function heightRange() {
    const h = pick('height', '$height');
    if (!h) return [0, 1];
    let lo = Infinity, hi = -Infinity;
    for (let i = 0; i < h.data.length; i += h.c) {
      const v = h.data[i];
      if (v < lo) lo = v;
      if (v > hi) hi = v;
    }
    return hi > lo ? [lo, hi] : [lo - 1, lo];
  }
  function normalised(img, lo, hi) {
    if (!img) return null;
    const d = new Float32Array(img.data.length), k = 1 / Math.max(hi - lo, 1e-30);
    for (let i = 0; i < d.length; i++) d[i] = (img.data[i] - lo) * k;
    return { w: img.w, h: img.h, c: img.c, data: d, name: img.name + ' (normalised)' };
  }
  // wet_preview's under_normal: a copy of undernormal over normal through watermask
  function wetNormal() {
    const n = maps.normal, u = maps.undernormal, m = maps.watermask;
    if (!n || !u || !m || n.w !== u.w || n.h !== u.h || m.w !== n.w || m.h !== n.h) return n || u;
    const d = new Float32Array(n.data.length);
    for (let i = 0; i < n.w * n.h; i++)
      for (let c = 0; c < 4; c++) d[4 * i + c] = n.data[4 * i + c] + (u.data[4 * i + c] - n.data[4 * i + c]) * m.data[i];
    return { w: n.w, h: n.h, c: 4, data: d, name: 'undernormal over normal' };
  }
  function material() {
    const [lo, hi] = heightRange();
    const wet = {
      basecolor: pick('underbasecolor', 'basecolor'), normal_map: wetNormal(),
      roughness: pick('underroughness', 'roughness'),
      height: normalised(pick('underheight', 'height'), lo, hi), ao: pick('ao'),
      metallic: pick('undermetallic', 'metallic'), specular: pick('underspecular', 'specular'),
      water_height: normalised(pick('waterheight'), lo, hi), water_normal: pick('waternormal'),
      water_roughness: pick('waterroughness'), water_specular: pick('waterspecular'),
      water_mask: pick('watermask'),
    };
    const dry = {
      basecolor: pick('$basecolor', 'basecolor'), normal_map: pick('$normal', 'normal'),
      roughness: pick('$roughness', 'roughness'), height: normalised(pick('$height', 'height'), lo, hi),
      ao: pick('$ao', 'ao'), metallic: pick('$metallic', 'metallic'),
      specular: pick('$specular', 'specular'), water_mask: null,
    };
    for (const [side, m] of [['wet', wet], ['dry', dry]])
      for (const s of SAMPLERS) {
        const img = m[s] || constant(NEUTRAL[s]);
        if (img.c !== 1 && img.c !== 4) continue;
        tex[side][s] = upload(tex[side][s], [img], { flip: true });
      }
    // which map each sampler reads, for the page's readers (and tests)
    const named = m => SAMPLERS.map(x => x + '=' + (m[x] ? m[x].name : '-')).join(' ');
    fig.dataset.wetMaps = named(wet);
    fig.dataset.dryMaps = named(dry);
    tex.wetSpecularMap = !!pick('underspecular', 'specular');
    tex.drySpecularMap = !!pick('$specular', 'specular');
  }

  // the maps of the render shown in the state s, loaded again where a render made them anew
  async function loadMaps(s) {
    const want = ['basecolor', 'normal', 'roughness', 'height', 'ao', 'metallic', 'specular',
      'waterheight', 'waternormal', 'waterroughness', 'waterspecular', 'watermask',
      'underbasecolor', 'undernormal', 'underroughness', 'underheight', 'undermetallic',
      'underspecular'];
    const list = s.outputs.filter(o => want.includes(o.name)).concat(
      (s.inputs || []).filter(o => want.includes(o.name.slice(1))));
    const names = new Set(list.map(o => o.name));
    for (const n of Object.keys(maps)) if (!names.has(n)) delete maps[n];
    await Promise.all(list.filter(o => !maps[o.name] || maps[o.name].version !== o.version)
      .map(async o => {
        const img = await fetchPixels('/map/' + encodeURIComponent(o.name));
        img.version = o.version;
        img.name = o.name;
        maps[o.name] = img;
      }));
  }

  // ---- drawing -------------------------------------------------------------------------------
  function camera(aspect) {
    const el = cam.elevation * deg, az = cam.azimuth * deg, tanHalf = Math.tan(35 * deg / 2);
    const back = [Math.sin(az) * Math.cos(el), -Math.cos(az) * Math.cos(el), Math.sin(el)];
    const right = [Math.cos(az), Math.sin(az), 0];
    let up = [back[1] * right[2] - back[2] * right[1], back[2] * right[0] - back[0] * right[2],
      back[0] * right[1] - back[1] * right[0]];
    const ul = Math.hypot(...up);
    up = up.map(x => x / ul);
    // the sphere about the origin, the same size for any tiling; the tile's plane (and the grid)
    // about the middle of its tiles
    const sphere = opt.shape === 'sphere';
    const span = sphere ? 1 : opt.tiling, dist = 0.5 * span / cam.zoom / tanHalf, mid = sphere ? 0 : 0.5 * span;
    return {
      cam: [mid + back[0] * dist, mid + back[1] * dist, back[2] * dist],
      right, up, fwd: back.map(x => -x), tanHalf, aspect,
    };
  }
  function setCamera(p, c) {
    gl.uniform3fv(gl.getUniformLocation(p, 'right'), c.right);
    gl.uniform3fv(gl.getUniformLocation(p, 'up'), c.up);
    gl.uniform3fv(gl.getUniformLocation(p, 'fwd'), c.fwd);
    gl.uniform1f(gl.getUniformLocation(p, 'tan_half'), c.tanHalf);
    gl.uniform1f(gl.getUniformLocation(p, 'aspect'), c.aspect);
    gl.uniform1f(gl.getUniformLocation(p, 'env_rotation'), cam.envRotation * deg);
    gl.uniform1f(gl.getUniformLocation(p, 'exposure'), opt.exposure);
  }
  function num(name, fallback) {
    const p = params[name];
    const v = p === undefined ? NaN : +p;
    return Number.isFinite(v) ? v : fallback;
  }
  // the liquid's uniforms from the graph's parameters, as wet_preview computes them
  function liquid() {
    const values = (params.$liquidValues || []);
    let k = values.indexOf(params.liquid);
    if (k < 0) k = 0;
    const hs = num('height_scale', NaN);
    const depth = num('absorption_depth', 0) > 0 ? num('absorption_depth', 0) : PRESET.depth[k];
    const tint = ['tint_r', 'tint_g', 'tint_b'].map((n, c) => num(n, -1) >= 0 ? num(n, -1) : PRESET.tint[k][c]);
    return {
      heightScale: Number.isFinite(hs) ? hs / 256 : null,
      absorption: Number.isFinite(hs) ? depth / hs : null, tint, ior: PRESET.ior[k],
    };
  }
  function bindSide(side, e) {
    let unit = 0;
    const bind = (name, t) => {
      const loc = gl.getUniformLocation(prog, name);
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, t);
      if (loc) gl.uniform1i(loc, unit);
      unit++;
    };
    bind('prefiltered', e.prefiltered);
    bind('irradiance', e.irradiance);
    bind('brdf_lut', e.lut);
    for (const s of SAMPLERS) bind(s, tex[side][s]);
    const sp = gl.getUniformLocation(prog, 'specular_from_map');
    if (sp) gl.uniform1i(sp, side === 'wet' ? tex.wetSpecularMap : tex.drySpecularMap);
  }
  function drawTo(w, h, fbo, moving) {
    const e = envs[opt.env];
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(0, 0, w, h);
    gl.disable(gl.SCISSOR_TEST);
    gl.clearColor(0.07, 0.07, 0.08, 0);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    const c = camera(w / h);
    gl.useProgram(bgProg);
    setCamera(bgProg, c);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, e.prefiltered);
    gl.uniform1i(gl.getUniformLocation(bgProg, 'prefiltered'), 0);
    gl.bindVertexArray(bgVao);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    prog = shapeProgram(opt.shape);
    gl.useProgram(prog);
    setCamera(prog, c);
    gl.uniform3fv(gl.getUniformLocation(prog, 'cam'), c.cam);
    gl.uniform1i(gl.getUniformLocation(prog, 'view_tonemap'), 1);
    const lq = liquid();
    if (lq.heightScale !== null) gl.uniform1f(gl.getUniformLocation(prog, 'height_scale'), lq.heightScale);
    if (lq.absorption !== null) gl.uniform1f(gl.getUniformLocation(prog, 'absorption_depth'), lq.absorption);
    gl.uniform3fv(gl.getUniformLocation(prog, 'water_tint'), lq.tint);
    gl.uniform1f(gl.getUniformLocation(prog, 'water_ior'), lq.ior);
    const m = shapeMesh(opt.shape, opt.tiling, moving);
    if (!m.flat) {
      gl.uniform2fv(gl.getUniformLocation(prog, 'depth_ab'), DEPTH_AB);
      gl.enable(gl.DEPTH_TEST);
    }
    if (opt.shape === 'sphere') {
      gl.uniform1f(gl.getUniformLocation(prog, 'radius'), SPHERE_R);
      gl.uniform2f(gl.getUniformLocation(prog, 'repeat'), 2 * opt.tiling, opt.tiling);
    }
    gl.bindVertexArray(m.vao);
    // the dry material left of the split line, the wet one right of it
    const cut = Math.round(opt.split * w);
    gl.enable(gl.SCISSOR_TEST);
    for (const [side, x0, x1] of [['dry', 0, cut], ['wet', cut, w]]) {
      if (x1 <= x0) continue;
      gl.scissor(x0, 0, x1 - x0, h);
      bindSide(side, e);
      if (m.flat) gl.drawArrays(gl.TRIANGLES, 0, 6);
      else gl.drawElements(gl.TRIANGLES, m.count, gl.UNSIGNED_INT, 0);
    }
    gl.disable(gl.SCISSOR_TEST);
    gl.disable(gl.DEPTH_TEST);
    gl.bindVertexArray(null);
  }

  function probe() {
    const px = wgReadBack(gl, probeTarget, probeN, drawTo);
    let hex = '', cover = '';
    for (let y = probeN - 1; y >= 0; y--) // GL's rows are from the bottom
      for (let x = 0; x < probeN; x++) {
        for (let c = 0; c < 3; c++) hex += px[(y * probeN + x) * 4 + c].toString(16).padStart(2, '0');
        cover += px[(y * probeN + x) * 4 + 3] > 127 ? '1' : '0';
      }
    fig.dataset.probe = hex;
    fig.dataset.cover = cover;
  }

  // A view that moves: drawn at motion.scale until SETTLE_MS pass without another move.
  function moved() {
    motion.moving = true;
    clearTimeout(motion.timer);
    motion.timer = setTimeout(() => { motion.moving = false; redraw(); }, SETTLE_MS);
    redraw();
  }
  // The picture at scale s of w x h into motion.target's framebuffer (the moving view's: the
  // grid coarse), then stretched onto the canvas (linear filtering).
  function drawScaled(w, h, s) {
    const t = motion.target, lw = Math.max(1, Math.round(w * s)), lh = Math.max(1, Math.round(h * s));
    if (!t.fbo || t.w !== lw || t.h !== lh) {
      if (t.fbo) { gl.deleteFramebuffer(t.fbo); gl.deleteTexture(t.tex); gl.deleteRenderbuffer(t.depth); }
      t.fbo = gl.createFramebuffer();
      t.tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t.tex);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, lw, lh, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
      gl.bindFramebuffer(gl.FRAMEBUFFER, t.fbo);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t.tex, 0);
      t.depth = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, t.depth);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, lw, lh);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, t.depth);
      Object.assign(t, { w: lw, h: lh });
    }
    drawTo(lw, lh, t.fbo, true);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, t.fbo);
    gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
    gl.blitFramebuffer(0, 0, lw, lh, 0, 0, w, h, gl.COLOR_BUFFER_BIT, gl.LINEAR);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  }
  // What the picture just drawn at scale s costs: a fence polled until the renderer signals it
  // (one at a time); the next moving frames' scale follows from it.
  function timeFrame(s) {
    if (motion.fence || !frameMs) return;
    const f = gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
    if (!f) return;
    gl.flush();
    motion.fence = f;
    const t0 = performance.now();
    const poll = () => {
      if (!gl || gl.getSyncParameter(f, gl.SYNC_STATUS) !== gl.SIGNALED) { setTimeout(poll, 2); return; }
      const ms = performance.now() - t0;
      gl.deleteSync(f);
      motion.fence = null;
      const want = s * Math.sqrt(frameMs / Math.max(ms, 1e-3));
      // at most 1.5x up or 3x down a step, so that one odd frame does not swing it
      motion.scale = Math.min(1, Math.max(MIN_SCALE, Math.min(1.5 * s, Math.max(s / 3, want))));
      fig.dataset.frameMs = ms.toFixed(1);
    };
    setTimeout(poll, 0);
  }

  function draw() {
    queued = false;
    if (!gl || shown < 0 || !envs[opt.env]) return;
    const r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    const s = motion.moving && frameMs ? motion.scale : 1;
    try {
      if (s < 1) drawScaled(w, h, s);
      else drawTo(w, h, null);
      timeFrame(s);
      fig.dataset.scale = +s.toFixed(3);
      if (probeN) probe();
    } catch (e) { // a shape's program that does not link
      setState('error', String(e.message || e));
      drawFailed = true;
      return;
    }
    if (drawFailed) { drawFailed = false; setState('ready'); }
    draws++;
    fig.dataset.draws = draws;
    fig.dataset.shape = opt.shape;
    fig.dataset.camera = [cam.elevation, cam.azimuth, cam.zoom, cam.envRotation].map(x => +x.toFixed(3)).join(',');
  }
  function redraw() {
    if (!queued) { queued = true; requestAnimationFrame(draw); }
  }

  // ---- the page's side -----------------------------------------------------------------------
  function control(label, input, out) {
    const d = document.createElement('label');
    d.className = 'vc';
    d.append(label + ' ', input);
    if (out) d.append(out);
    return d;
  }
  function build() {
    fig = document.createElement('figure');
    fig.id = 'view3d';
    fig.className = 'big';
    canvas = document.createElement('canvas');
    canvas.id = 'view3d-canvas';
    const msg = document.createElement('div');
    msg.className = 'msg';
    const cap = document.createElement('figcaption');
    const env = document.createElement('select');
    env.id = 'view-env';
    env.onchange = () => { opt.env = +env.value; refreshEnv(); };
    const split = Object.assign(document.createElement('input'),
      { id: 'view-split', type: 'range', min: 0, max: 1, step: 0.01, value: opt.split });
    split.oninput = () => { opt.split = +split.value; redraw(); };
    const shape = document.createElement('select');
    shape.id = 'view-shape';
    for (const v of SHAPES) shape.add(new Option(v, v));
    shape.value = opt.shape;
    shape.onchange = () => { opt.shape = shape.value; redraw(); };
    const tiling = document.createElement('select');
    tiling.id = 'view-tiling';
    for (const [v, t] of [[1, '1 x 1'], [2, '2 x 2']]) tiling.add(new Option(t, v));
    tiling.value = opt.tiling;
    tiling.onchange = () => { opt.tiling = +tiling.value; redraw(); };
    const expo = Object.assign(document.createElement('input'),
      { id: 'view-exposure', type: 'range', min: -6, max: 6, step: 0.1, value: opt.exposure });
    const expoOut = document.createElement('span');
    expoOut.textContent = ' ' + opt.exposure.toFixed(1);
    expo.oninput = () => { opt.exposure = +expo.value; expoOut.textContent = ' ' + opt.exposure.toFixed(1); redraw(); };
    const reset = Object.assign(document.createElement('button'), { id: 'view-reset', textContent: 'reset view' });
    reset.onclick = () => { Object.assign(cam, { elevation: 50, azimuth: 20, zoom: 1, envRotation: 0 }); redraw(); };
    const title = document.createElement('span');
    title.textContent = '3D view';
    cap.append(title, control('shape', shape), control('environment', env), control('dry | wet', split),
      control('tiling', tiling), control('exposure', expo, expoOut), reset);
    fig.append(canvas, msg, cap);
    fig.title = 'drag: orbit · wheel: zoom · shift-drag or right-drag: turn the environment';
    // the mouse: orbit, zoom, environment rotation
    let drag = null;
    canvas.addEventListener('contextmenu', e => e.preventDefault());
    canvas.addEventListener('pointerdown', e => {
      drag = { x: e.clientX, y: e.clientY, env: e.shiftKey || e.button === 2 };
      canvas.setPointerCapture(e.pointerId);
    });
    canvas.addEventListener('pointermove', e => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      if (drag.env) cam.envRotation = (cam.envRotation + dx * 0.5 + 540) % 360 - 180;
      else {
        cam.azimuth = (cam.azimuth - dx * 0.4 + 540) % 360 - 180;
        cam.elevation = Math.min(90, Math.max(1, cam.elevation + dy * 0.3));
      }
      moved();
    });
    canvas.addEventListener('pointerup', () => { drag = null; });
    canvas.addEventListener('wheel', e => {
      e.preventDefault();
      cam.zoom = Math.min(20, Math.max(0.05, cam.zoom * Math.exp(-e.deltaY * 0.001)));
      moved();
    }, { passive: false });
    new ResizeObserver(redraw).observe(canvas);
    return fig;
  }

  async function refreshEnv() {
    try {
      await loadEnv(opt.env);
      redraw();
    } catch (e) {
      setState('error', String(e.message || e));
    }
  }

  let envList = '';
  // a new state: the environments' menu, the liquid's parameters, and the maps of a new render
  async function update(s) {
    await started;
    if (!gl) return;
    params = {};
    for (const p of s.params) {
      params[p.name] = p.value;
      if (p.name === 'liquid') params.$liquidValues = p.values;
    }
    const envs = s.environments || [];
    const list = envs.map(e => e.name + e.ready).join('|');
    if (list !== envList) {
      envList = list;
      // without ?env=, the first environment that could be read
      const first = envs.findIndex(e => e.ready);
      if (args.get('env') === null && first >= 0 && !(envs[opt.env] && envs[opt.env].ready)) opt.env = first;
      const sel = fig.querySelector('#view-env');
      sel.innerHTML = '';
      envs.forEach((e, k) => { const o = new Option(e.name + (e.ready ? '' : e.error ? ' (cannot be read)' : ' (…)'), k); o.disabled = !e.ready; sel.add(o); });
      if (opt.env >= envs.length) opt.env = 0;
      sel.value = opt.env;
    }
    if (!envs[opt.env] || !envs[opt.env].ready) {
      // prefiltered after the first render: the state of the next render has it
      if (envs[opt.env] && envs[opt.env].error) setState('error', envs[opt.env].error);
      return;
    }
    if (s.version === stateVersion) return;
    stateVersion = s.version;
    pending = s;
    if (loading) return loading;
    loading = (async () => {
      while (pending) {
        const st = pending;
        pending = null;
        try {
          await loadEnv(opt.env);
          await loadMaps(st);
          material();
          shown = st.version;
          fig.dataset.version = shown;
          setState('ready');
          draw();
        } catch (e) {
          setState('error', String(e.message || e));
        }
      }
      loading = null;
    })();
    return loading;
  }

  let started = null;
  function start(main) {
    return (started = begin(main));
  }
  async function begin(main) {
    main.prepend(build());
    const v = (args.get('view') || '').split(',').map(Number);
    ['elevation', 'azimuth', 'zoom', 'envRotation'].forEach((k, i) => { if (Number.isFinite(v[i]) && args.get('view')) cam[k] = v[i]; });
    if (args.get('split') !== null) opt.split = Math.min(1, Math.max(0, +args.get('split') || 0));
    if (args.get('tiling') === '2') opt.tiling = 2;
    if (SHAPES.includes(args.get('shape'))) opt.shape = args.get('shape');
    if (args.get('exposure') !== null) opt.exposure = +args.get('exposure') || 0;
    if (args.get('env') !== null) opt.env = Math.max(0, Math.floor(+args.get('env') || 0));
    fig.querySelector('#view-split').value = opt.split;
    fig.querySelector('#view-tiling').value = opt.tiling;
    fig.querySelector('#view-shape').value = opt.shape;
    fig.querySelector('#view-exposure').value = opt.exposure;
    fig.querySelector('#view-exposure').nextSibling.textContent = ' ' + opt.exposure.toFixed(1);
    // no alpha in the canvas: the background's alpha 0 only marks it in the probe's read-back
    gl = canvas.getContext('webgl2', { antialias: false, alpha: false });
    if (!gl) {
      setState('no-webgl2', 'this browser gives the page no WebGL2 context: the 3D view needs one');
      return;
    }
    setState('loading');
    try {
      const r = await fetch('/shaders/wet_layered.frag');
      if (!r.ok) throw new Error('/shaders/wet_layered.frag: ' + r.status);
      fsSource = adapt(await r.text());
      shapeProgram('plane');
      if (opt.shape !== 'plane') shapeProgram(opt.shape);
      bgProg = link(BG_VS, BG_FS, 'the background');
      bgVao = quad([-1, -1, 3, -1, -1, 3]);
    } catch (e) {
      gl = null;
      setState('error', String(e.message || e));
    }
  }
  return { start, update, started: () => started !== null };
})();
