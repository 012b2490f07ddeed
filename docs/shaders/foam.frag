// SPDX-License-Identifier: MIT
// Shore foam for real-time engines: the model of graphs/foam.wetgraph, animated on the GPU from
// the static maps that graph bakes (its `maps` output), so a game pays one texture and a few
// samples per pixel.
//
// maps: RGBA, linear (store it as a float or 16-bit texture; 8 bits band v), sampled with
//   GL_LINEAR filtering and GL_REPEAT wrapping, row 0 of the image at t = 0:
//   r = v / 2 (v: 0 at the band's sea-side edge, 1 on the shoreline, 2 inland; clamped),
//   g = T (the foam stroke distance texture), b = N1, a = N2 (tileable noises in [0, 1]).
// uv: texture coordinates of the fragment in tiles (1 = one tile; any real number, it wraps).
// The uniforms are the graph's parameters of the same names (lengths in pixels of a 256-wide
// texture, speeds in waves or tiles per second); `time` is $time in seconds.
//
// Differences from the graph: the anti-aliasing width is fwidth() of the mix (the graph uses
// half its Sobel gradient magnitude per pixel), so edges may differ by a pixel; with a float
// `maps` texture the rest agrees with the graph to float rounding (tests/graphs/test_glsl.c runs
// this shader on Mesa's llvmpipe and compares it with the graph at several times).
#version 330 core

uniform sampler2D maps;
uniform float time;
uniform float frequency = 4.0;
uniform float noise_amp = 1.0;
uniform float speed = 0.25;
uniform float come_go = 0.15;
uniform float come_go_period = 6.0;
uniform float a = 0.9;
uniform float b = -0.75;
uniform float reach_noise = 0.25;
uniform float ratio_sine = 0.55;
uniform float ratio_tex = 0.8;
uniform float threshold = 0.45;
uniform float threshold_noise = 0.1;
uniform float warp_amp = 6.0;
uniform float warp_speed = 0.02;
uniform float tex_speed_x = 0.01;
uniform float tex_speed_y = -0.005;
uniform float layer2 = 0.8;
uniform float layer2_scale = 2.0;
uniform float layer2_speed = -0.015;
uniform float inland_reach = 0.1;
uniform float loop_seconds = 0.0;
uniform float sine_warp = 0.0;
uniform float speed_noise = 0.0;
uniform float layer3 = 0.0;
uniform float layer3_scale = 3.0;
uniform float layer3_speed = 0.02;

in vec2 uv;
out vec4 foam_out;

const float TAU = 6.283185307179586;

// A speed snapped, when the animation loops, to the nearest whole number of units per loop that
// is not zero, keeping its sign (0 stays 0), so a short loop never freezes. floor(x + 0.5), not
// round(): GLSL lets round(0.5) go either way (Mesa rounds halves to even), the graph rounds
// halves up.
float snapped(float s)
{
    return loop_seconds > 0.0 ? sign(s) * max(1.0, floor(abs(s) * loop_seconds + 0.5)) / loop_seconds
                              : s;
}

void main()
{
    vec4 m = texture(maps, uv);
    float v = m.r * 2.0;
    // drifts as fract(speed * t), as the graph computes them
    float wd = fract(snapped(warp_speed) * time);
    float tx = fract(snapped(tex_speed_x) * time);
    float ty = fract(snapped(tex_speed_y) * time);
    float l2 = fract(snapped(layer2_speed) * time);
    float l3 = fract(snapped(layer3_speed) * time);
    float sp = fract(snapped(speed) * time);
    float cg_freq = loop_seconds > 0.0 ? max(1.0, floor(loop_seconds / come_go_period + 0.5)) / loop_seconds
                                       : 1.0 / come_go_period;
    float cg = sin(TAU * fract(cg_freq * time));

    // the warp: N2 and N2 half a tile along the diagonal, read wd tiles along it
    float wk = 2.0 * warp_amp / 256.0;
    vec2 d = wk * (vec2(texture(maps, uv + wd).a, texture(maps, uv + wd + 0.5).a) - 0.5);
    float t1 = texture(maps, uv + d + vec2(tx, ty)).g;
    float t2 = texture(maps, (uv + d) * layer2_scale + vec2(l2, 0.0)).g;
    float t3 = layer3 > 0.0 ? layer3 * texture(maps, (uv + d) * layer3_scale + vec2(0.0, l3)).g : 0.0;

    // N3 and N3' are N1 a quarter and three quarters of a tile along the diagonal
    float n3 = texture(maps, uv + 0.25).b;
    float n3s = texture(maps, uv + 0.75).b;
    float reach = a * v + b + reach_noise * (2.0 * n3 - 1.0);
    // the sine waves moved by sine_warp times the texture's warp (v read there)
    float vw = sine_warp > 0.0 ? texture(maps, uv + sine_warp * d).r * 2.0 : v;
    float mixv = ratio_sine * (sin(TAU * ((frequency + noise_amp * (2.0 * m.b - 1.0)) * vw - sp - come_go * cg
                                  - speed_noise * (2.0 * texture(maps, uv + vec2(0.25, 0.75)).a - 1.0) * cg)) + reach)
               + ratio_tex * (max(max(t1, layer2 * t2), t3) + reach)
               - threshold - threshold_noise * (2.0 * n3s - 1.0);

    float f = clamp(mixv / max(fwidth(mixv), 1e-4) + 0.5, 0.0, 1.0);
    f *= smoothstep(0.0, 0.04, v) * (1.0 - smoothstep(1.0 + inland_reach - 0.02, 1.0 + inland_reach + 0.02, v));
    foam_out = vec4(f, f, f, 1.0);
}
