// SPDX-License-Identifier: MIT
// Rain drop rings for real-time engines: the model of graphs/rain_ripples.wetgraph, animated on
// the GPU from the two static maps that graph bakes (its `sites` and `open` outputs).
//
// sites: RGBA float, r, g, b = the site value w of lattices 1, 2, 3 at the texel's cell; open:
//   r, g, b = 1 - the shelter where that site's drop lands. Both sampled with GL_NEAREST (they
//   are constant over each cell) and GL_REPEAT, row 0 of the image at t = 0.
// uv: texture coordinates in tiles (1 = one tile), v down the image as the graph's v (row 0 at
//   t = 0). The uniforms are the graph's parameters of the same names; aspect = height / width
//   of the texture; time is $time in seconds.
// Output: r = the ring height h (length units: pixels of a 256-wide texture), g, b, a = the
// rings' normal encoded n * 0.5 + 0.5 (OpenGL convention, y towards the top of the image, a
// height of 1 standing for 1 length unit as the graph's `normal` node takes it), from the
// analytic gradient of h (the graph takes finite differences). Add it to a water normal as the
// graph does: slopes add (x / z and y / z of both).
//
// The drop choices use only whole numbers below 2^24 and a division by 65521, exact in float, so
// the GPU drops the same drops as the graph; the rest agrees to float rounding
// (tests/graphs/test_glsl.c runs this shader on llvmpipe against the graph). The graph folds
// the snapped cycle count in double: where loop_seconds / ripple_seconds lies within float
// rounding of a half (2 / 0.8), the two may snap to neighbouring whole numbers.
#version 330 core
uniform sampler2D sites;
uniform sampler2D open;
uniform float time;
uniform float rain = 0.5;
uniform float drop_size = 6.0;
uniform float ripple_seconds = 1.0;
uniform float strength = 0.6;
uniform float loop_seconds = 0.0;
uniform float aspect = 1.0;
in vec2 uv;
out vec4 ripple_out;
const float TAU = 6.283185307179586;

// One lattice: cell size factor f, shift (ox, oy) in cells, hash multiplier m, its site value w
// and open share o at this texel. Adds the height of its drop to h and its gradient (per length
// unit, x right, y down the image) to g.
void lattice(float f, float ox, float oy, float m, float w, float o, float tt, float kc,
             float nc, inout float h, inout vec2 g)
{
    float n = max(1.0, floor(256.0 / (f * drop_size / 0.28) + 0.5));
    float mm = max(1.0, floor(n * aspect + 0.5));
    float lx = 256.0 / n, ly = 256.0 * aspect / mm, l = min(lx, ly);
    float p = tt + w;
    float a = fract(p);
    float k = mod(kc + floor(p), nc);
    float dx = (fract(uv.x * n + ox) - 0.5 - (fract(w * 64.0) - 0.5) * (1.0 - 0.7 * l / lx)) * lx;
    float dy = (fract(uv.y * mm + oy) - 0.5 - (fract(w * 4096.0) - 0.5) * (1.0 - 0.7 * l / ly)) * ly;
    float r = sqrt(dx * dx + dy * dy);
    float lambda = 0.28 / 3.0 * l;
    float x = (r - 0.28 * l * a) / lambda;
    float on = (mod(floor(w * 65536.0) * m + k * 7919.0 + 12345.0, 65521.0) / 65521.0 < rain ? 1.0 : 0.0) * o;
    float e = on * smoothstep(0.0, 0.1, a) * (1.0 - a) * (1.0 - a);
    float env = exp(-x * x);
    float s = sin(TAU * x), c = cos(TAU * x);
    float t = clamp((r - 0.3 * l) / (0.05 * l), 0.0, 1.0);
    float cut = 1.0 - t * t * (3.0 - 2.0 * t);
    float dcut = r > 0.3 * l && r < 0.35 * l ? -6.0 * t * (1.0 - t) / (0.05 * l) : 0.0;
    h += e * lambda * s * env * cut;
    float dhdr = e * ((TAU * c - 2.0 * x * s) * env * cut + lambda * s * env * dcut);
    g += dhdr * vec2(dx, dy) / max(r, 1e-6);
}

void main()
{
    float nc = loop_seconds > 0.0 ? max(1.0, floor(loop_seconds / ripple_seconds + 0.5)) : 97.0;
    float cycles = loop_seconds > 0.0 ? time * nc / loop_seconds : time / ripple_seconds;
    float tt = fract(cycles);
    float kc = mod(floor(cycles), nc);
    vec3 w = texture(sites, uv).rgb;
    vec3 o = texture(open, uv).rgb;
    float h = 0.0;
    vec2 g = vec2(0.0);
    lattice(1.0, 0.0, 0.0, 13.0, w.r, o.r, tt, kc, nc, h, g);
    lattice(1.13, 0.5, 0.5, 17.0, w.g, o.g, tt, kc, nc, h, g);
    lattice(1.29, 0.25, 0.75, 19.0, w.b, o.b, tt, kc, nc, h, g);
    h *= strength / TAU;
    g *= strength / TAU;
    // y towards the top of the image: the slope up the image is -dh/dy
    vec3 n = normalize(vec3(-g.x, g.y, 1.0));
    ripple_out = vec4(h, n * 0.5 + 0.5);
}
