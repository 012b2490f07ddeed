/* SPDX-License-Identifier: MIT */
/* The GLSL shaders of docs/shaders executed on Mesa's llvmpipe through a headless EGL context
 * (tests/support/wggl.h), rendered into a float framebuffer and read back unquantised, against
 * the engine on the CPU:
 * - foam.frag on the `maps` that graphs/foam.wetgraph bakes, at several times, unlooped and
 *   looped (a 2 s loop where a speed snaps from 2.5 waves, a 1 s loop with the default speeds,
 *   the sine waves warped as the texture is, a third stroke layer, noise on the waves' speed):
 *   the same mask (foam > 1/2) as the graph's `foam` at every pixel off the graph's anti-aliased
 *   edge; only the edges may differ (fwidth in the shader, half the Sobel gradient in the
 *   graph), and few pixels by more than 0.5.
 * - rain_ripples.frag on the static maps graphs/rain_ripples.wetgraph bakes, at several times,
 *   unlooped and looped: the same ring heights, and normals close to the graph's.
 * - wet_layered.frag on a small scene whose maps (relief, normals, colour, roughness, metal, ao,
 *   a water layer with its own height, normal, roughness, F0 and mask) and lighting atlas
 *   (env_prefilter) are baked by the engine, drawn as the tile's plane through the `preview`
 *   node's camera: the mean difference to the `preview` node's linear radiance stays within
 *   0.25% of the mean radiance (check_layered says why), with and without the sun; and built
 *   with WG_TANGENT_FRAME on the tile turned by 75 degrees in the world, the environment and
 *   the sun given in world space, within the same bound (the frame is applied to both).
 * Without a GL driver every test is skipped with the reason (exit status 77, meson's SKIP);
 * WETGRAPH_REQUIRE_GL=1 makes that a failure instead (CI, where the driver is installed). */
#include "wggl.h"
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static bool gl_ok;

/* With WETGRAPH_GL_DUMP=folder, the pictures compared are written there (PPM, values x scale,
 * clamped), to look at a failure. */
static void dump(const char *name, const WgImage *img, double scale)
{
    const char *dir = getenv("WETGRAPH_GL_DUMP");
    if (!dir) return;
    char path[2048];
    snprintf(path, sizeof path, "%s/%s.ppm", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f) fail_msg("WETGRAPH_GL_DUMP: cannot write %s", path);
    fprintf(f, "P6 %d %d 255\n", img->width, img->height);
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int c = 0; c < 3; c++) {
                double v = wgt_px(img, x, y, img->channels == 1 ? 0 : c) * scale;
                fputc(v < 0 ? 0 : v > 1 ? 255 : (int)(v * 255 + 0.5), f);
            }
    fclose(f);
}

static const char *shader_path(const char *name)
{
    static char path[2048];
    snprintf(path, sizeof path, "%s/docs/shaders/%s", getenv("WETGRAPH_SOURCE"), name);
    return path;
}

/* ---- foam.frag ------------------------------------------------------------------------------ */

enum { N = 128 };

static double shore_fn(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / N, v = (y + 0.5) / N;
    return cos(2 * M_PI * u) + 0.6 * sin(4 * M_PI * v) > 0.3 ? 1.0 : 0.0;
}

/* uv = the pixel centre in tiles, image row y at t = (y + 0.5) / N: the graph's sample(u, v) */
static const char foam_vs[] = "#version 330 core\n"
                              "layout(location = 0) in vec2 pos;\n"
                              "out vec2 uv;\n"
                              "void main() { uv = pos * 0.5 + 0.5; gl_Position = vec4(pos, 0.0, "
                              "1.0); }\n";
static const float screen[] = {-1, -1, 1, -1, 1, 1, -1, -1, 1, 1, -1, 1};

typedef struct {
    const char *name;
    float value;
} Setting;

static double smoothstep(double a, double b, double x)
{
    double t = (x - a) / (b - a);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

/* The foam graph and foam.frag with the same settings at time t. Both give foam = aa(mix) x
 * band(v), aa(mix) = clamp(mix / width + 0.5, 0, 1), with only the width differing (fwidth
 * against half the Sobel gradient), so the masks foam > band / 2 (mix > 0) are the same but
 * where the mix is near 0. Returns the pixels away from the graph's anti-aliased edge (its
 * aa(mix) <= 0.02 or >= 0.98) where the two masks differ, and counts such pixels with foam and
 * without, and the share of all pixels whose values differ by more than 0.5. */
static int foam_mismatch(WgEngine *e, WgGraph *g, const WgImage *shore, unsigned prog,
                         unsigned *maps_tex, const Setting *sets, int n_sets, double t, int *foam,
                         int *clear, double *far_share)
{
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    if (wg_request_set_input_image(r, "shore", shore, &err)) fail_msg("%s", err.message);
    float inland = 0.1f;
    for (int i = 0; i < n_sets; i++) {
        char value[64];
        snprintf(value, sizeof value, "%.9g", sets[i].value);
        if (wg_request_set(r, sets[i].name, value, &err))
            fail_msg("%s: %s", sets[i].name, err.message);
        if (!wgt_gl_set1f(prog, sets[i].name, sets[i].value))
            fail_msg("foam.frag has no uniform %s", sets[i].name);
        if (!strcmp(sets[i].name, "inland_reach")) inland = sets[i].value;
    }
    wg_request_set_time(r, t);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *f = wgt_output(res, "foam"), *maps = wgt_output(res, "maps");
    if (!*maps_tex) *maps_tex = wgt_gl_texture(maps, 0, NULL, 0); /* the maps do not change */
    wgt_gl_bind(prog, "maps", 0, *maps_tex);
    wgt_gl_set1f(prog, "time", (float)t);
    WgImage *gf = wgt_gl_draw(prog, screen, 6, N, N, false);
    char name[64];
    snprintf(name, sizeof name, "foam_graph_t%g", t);
    dump(name, f, 1);
    snprintf(name, sizeof name, "foam_glsl_t%g", t);
    dump(name, gf, 1);
    int bad = 0, far = 0;
    *foam = *clear = 0;
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            float a = wgt_px(f, x, y, 0), b = wgt_px(gf, x, y, 0);
            far += fabsf(a - b) > 0.5f;
            double v = 2 * wgt_px(maps, x, y, 0);
            double band =
                smoothstep(0, 0.04, v) * (1 - smoothstep(1 + inland - 0.02, 1 + inland + 0.02, v));
            if (band < 1e-3) { /* outside the band: no foam in either */
                if (a != 0 || b != 0)
                    fail_msg("t=%g (%d,%d): foam %g / %g outside the band", t, x, y, a, b);
                continue;
            }
            double aa = a / band;
            if (aa > 0.02 && aa < 0.98) continue; /* on the graph's anti-aliased edge */
            *foam += aa >= 0.98, *clear += aa <= 0.02;
            if ((a > 0.5 * band) != (b > 0.5 * band)) {
                if (bad < 5)
                    print_message("  (%d,%d): graph %g, shader %g, band %g\n", x, y, a, b, band);
                bad++;
            }
        }
    *far_share = (double)far / (N * N);
    wg_image_unref(gf);
    wg_result_free(res);
    wg_request_free(r);
    return bad;
}

static void run_foam(const Setting *sets, int n_sets, const double *times, int n_times)
{
    const char *src = getenv("WETGRAPH_SOURCE");
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/foam.wetgraph", src);
    WgGraph *g;
    WgError err = {0};
    if (wg_graph_load(path, &g, &err)) fail_msg("%s", err.message);
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    unsigned prog = wgt_gl_program(foam_vs, shader_path("foam.frag"));
    unsigned maps = 0;
    for (int i = 0; i < n_times; i++) {
        int foam, clear;
        double far;
        int bad =
            foam_mismatch(e, g, shore, prog, &maps, sets, n_sets, times[i], &foam, &clear, &far);
        print_message("foam.frag t=%g: masks differ at %d of %d pixels off the edges (%d foam, %d "
                      "clear); values differ by more than 0.5 at %.2f%% of all pixels\n",
                      times[i], bad, foam + clear, foam, clear, 100 * far);
        if (bad)
            fail_msg("t=%g: foam.frag's mask differs from the graph's at %d pixels off the edges",
                     times[i], bad);
        assert_true(foam > 300 && clear > 300); /* both kinds are there to compare */
        /* the edges: anti-aliased alike but for the filter's width, so few pixels far apart */
        if (far > 0.02)
            fail_msg("t=%g: %.1f%% of the pixels differ by more than 0.5", times[i], 100 * far);
    }
    wgt_gl_delete_texture(maps);
    wgt_gl_delete_program(prog);
    wg_engine_free(e);
    wg_image_unref(shore);
    wg_graph_free(g);
}

static void test_foam_unlooped(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const double times[] = {0.4, 3.3, 11.7};
    run_foam(NULL, 0, times, 3);
}

/* A 2 s loop where the wave speed is 2.5 waves per loop: floor(2.5 + 0.5) = 3, as the graph;
 * GLSL's round(2.5) may give 2 (Mesa rounds halves to even). */
static void test_foam_loop_half_waves(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const Setting sets[] = {{"loop_seconds", 2}, {"speed", 1.25f}, {"tex_speed_x", 0.75f}};
    const double times[] = {0.3, 1.1, 1.75};
    run_foam(sets, 3, times, 3);
}

/* A 1 s loop with the default speeds: every one snaps to one whole cycle per loop. */
static void test_foam_short_loop(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const Setting sets[] = {{"loop_seconds", 1}};
    const double times[] = {0.25, 0.5};
    run_foam(sets, 1, times, 2);
}

/* The sine waves warped as the texture is (sine_warp 1.5), unlooped and in a 2 s loop. */
static void test_foam_sine_warp(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const Setting sets[] = {{"sine_warp", 1.5f}};
    const double times[] = {0.7, 5.1};
    run_foam(sets, 1, times, 2);
    const Setting looped[] = {{"sine_warp", 1.5f}, {"loop_seconds", 2}};
    const double at[] = {0.9};
    run_foam(looped, 2, at, 1);
}

/* Noise on the waves' speed (speed_noise 0.4), unlooped and in a 2 s loop. */
static void test_foam_speed_noise(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const Setting sets[] = {{"speed_noise", 0.4f}, {"come_go_period", 2}};
    const double times[] = {0.5, 6.6};
    run_foam(sets, 2, times, 2);
    const Setting looped[] = {{"speed_noise", 0.4f}, {"loop_seconds", 2}};
    const double at[] = {1.4};
    run_foam(looped, 2, at, 1);
}

/* A third stroke layer (layer3 0.7), unlooped and in a 2 s loop where its drift snaps. */
static void test_foam_layer3(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const Setting sets[] = {{"layer3", 0.7f}, {"layer3_scale", 3}, {"layer3_speed", 0.04f}};
    const double times[] = {0.6, 4.2};
    run_foam(sets, 3, times, 2);
    const Setting looped[] = {{"layer3", 0.7f}, {"layer3_speed", 0.3f}, {"loop_seconds", 2}};
    const double at[] = {1.3};
    run_foam(looped, 3, at, 1);
}

/* ---- rain_ripples.frag ---------------------------------------------------------------------- */

/* rain_ripples.frag on the `sites` and `open` maps rain_ripples bakes, on a non-square tile with
 * a sheltered corner, at three times unlooped and in a 2 s loop: the ring heights agree with the
 * graph's `ripples` to float rounding at nearly every pixel (the same drops fall), and the
 * shader's analytic normals with the graph's finite-difference ones to the difference of the
 * two (rings about 8 pixels from crest to crest). */
static double corner_fn(int x, int y, int k)
{
    (void)k;
    return x < 64 && y < 48 ? 1.0 : 0.0;
}

static void run_ripples(float loop, const double *times, int n_times)
{
    enum { RW = 256, RH = 160 };
    const char *src = getenv("WETGRAPH_SOURCE");
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/rain_ripples.wetgraph", src);
    WgGraph *g;
    WgError err = {0};
    if (wg_graph_load(path, &g, &err)) fail_msg("%s", err.message);
    WgImage *shelter = wgt_image_fn(RW, RH, 1, corner_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    unsigned prog = wgt_gl_program(foam_vs, shader_path("rain_ripples.frag"));
    unsigned sites = 0, open = 0;
    const Setting sets[] = {{"rain", 0.7f},
                            {"drop_size", 24},
                            {"ripple_seconds", 0.7f},
                            {"strength", 0.8f},
                            {"loop_seconds", loop}};
    for (int i = 0; i < n_times; i++) {
        WgRequest *r = wg_request_new(g);
        wg_request_set_size(r, RW, RH);
        if (wg_request_set_input_image(r, "shelter", shelter, &err)) fail_msg("%s", err.message);
        for (size_t k = 0; k < sizeof sets / sizeof *sets; k++) {
            char value[64];
            snprintf(value, sizeof value, "%.9g", sets[k].value);
            if (wg_request_set(r, sets[k].name, value, &err)) fail_msg("%s", err.message);
            if (!wgt_gl_set1f(prog, sets[k].name, sets[k].value))
                fail_msg("rain_ripples.frag has no uniform %s", sets[k].name);
        }
        wg_request_set_time(r, times[i]);
        WgResult *res = wgt_render_request(e, r);
        if (!sites) sites = wgt_gl_texture(wgt_output(res, "sites"), WGT_GL_NEAREST, NULL, 0);
        if (!open) open = wgt_gl_texture(wgt_output(res, "open"), WGT_GL_NEAREST, NULL, 0);
        wgt_gl_bind(prog, "sites", 0, sites);
        wgt_gl_bind(prog, "open", 1, open);
        wgt_gl_set1f(prog, "time", (float)times[i]);
        wgt_gl_set1f(prog, "aspect", (float)RH / RW);
        WgImage *out = wgt_gl_draw(prog, screen, 6, RW, RH, false);
        const WgImage *h = wgt_output(res, "ripples"), *nrm = wgt_output(res, "ripplenormal");
        dump("ripples_graph", h, 2);
        dump("ripples_glsl", out, 2);
        int off = 0;
        double maxd = 0, energy = 0, nd = 0, nn = 0;
        for (int y = 0; y < RH; y++)
            for (int x = 0; x < RW; x++) {
                double a = wgt_px(h, x, y, 0), b = wgt_px(out, x, y, 0);
                energy += fabs(a);
                maxd = fmax(maxd, fabs(a - b));
                off += fabs(a - b) > 1e-3;
                double gx = 2 * wgt_px(nrm, x, y, 0) - 1, gy = 2 * wgt_px(nrm, x, y, 1) - 1;
                double sx = 2 * wgt_px(out, x, y, 1) - 1, sy = 2 * wgt_px(out, x, y, 2) - 1;
                nd += fabs(gx - sx) + fabs(gy - sy);
                nn += fabs(gx) + fabs(gy);
            }
        print_message("rain_ripples.frag t=%g (loop %g): heights differ by more than 1e-3 at %d of "
                      "%d pixels (at most %.2g); normals: mean |difference| %.3f of their mean "
                      "tilt\n",
                      times[i], loop, off, RW * RH, maxd, nd / fmax(nn, 1e-9));
        assert_true(energy > 100);
        if (off > RW * RH / 1000)
            fail_msg("t=%g: the shader's heights differ from the graph's at %d pixels", times[i],
                     off);
        if (!(nd < 0.2 * nn))
            fail_msg("t=%g: the shader's normals differ from the graph's by %.2f of their tilt",
                     times[i], nd / nn);
        wg_image_unref(out);
        wg_result_free(res);
        wg_request_free(r);
    }
    wgt_gl_delete_texture(sites);
    wgt_gl_delete_texture(open);
    wgt_gl_delete_program(prog);
    wg_engine_free(e);
    wg_image_unref(shelter);
    wg_graph_free(g);
}

static void test_rain_ripples(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const double times[] = {0.3, 2.45, 17.9};
    run_ripples(0, times, 3);
    const double looped[] = {0.7, 1.9};
    run_ripples(2, looped, 2);
}

/* ---- wet_layered.frag ----------------------------------------------------------------------- */

enum { S = 128 }; /* the scene's maps, the atlas and both renders */

/* The scene: a sky, its env_prefilter atlas, a relief (heights exactly 0..1), normals from the
 * `normal` node, colour, roughness 0.05..0.95, a metallic band, ao, a specular level map (used
 * where the node and the shader take one), and water standing at height 0.55 over the low half
 * with a soft mask. The preview node renders it (PREVIEW_ATTRS: linear
 * radiance, no tone mapping; the environment turned 30 degrees and the exposure at -0.5 stops, so
 * both conventions are compared too). */
#define PREVIEW_ATTRS                                                                              \
    "elevation=\"50\" azimuth=\"20\" zoom=\"2.5\" env_rotation=\"30\" exposure=\"-0.5\" "          \
    "tonemap=\"none\" encoding=\"linear\" sun_elevation=\"35\" sun_azimuth=\"120\" "               \
    "sun_intensity=\"3\" sun_color=\"1 0.95 0.9\" "
static const char scene_xml[] =
    "<wetgraph version=\"1\" size=\"128\">\n"
    "  <node id=\"sky\" type=\"pixel\" kind=\"color\"\n"
    "        expr=\"rgb(0.2 + 1.8 * (1 - v) * (1 - v), 0.5 + 0.3 * cos(6.283185307179586 * u),"
    " 0.4 + 0.6 * (1 - v) + 2 * (abs(u - 0.3) &lt; 0.03) * (abs(v - 0.35) &lt; 0.04))\"/>\n"
    "  <node id=\"atlas\" type=\"env_prefilter\"><in name=\"environment\" from=\"sky\"/></node>\n"
    "  <node id=\"height\" type=\"pixel\"\n"
    "        expr=\"clamp(0.5 + 0.55 * sin(12.566370614359172 * u) * cos(12.566370614359172 * v), "
    "0, 1)\"/>\n"
    "  <node id=\"normal\" type=\"normal\" intensity=\"12\"><in name=\"height\" "
    "from=\"height\"/></node>\n"
    "  <node id=\"basecolor\" type=\"pixel\" kind=\"color\" expr=\"rgb(0.2 + 0.6 * u, 0.45, 0.75 - "
    "0.5 * v)\"/>\n"
    "  <node id=\"roughness\" type=\"pixel\" expr=\"0.05 + 0.9 * v\"/>\n"
    "  <node id=\"metallic\" type=\"pixel\" expr=\"smoothstep(0.55, 0.8, u)\"/>\n"
    "  <node id=\"ao\" type=\"pixel\" expr=\"0.6 + 0.4 * hh\"><in name=\"hh\" "
    "from=\"height\"/></node>\n"
    "  <node id=\"water_height\" type=\"pixel\" expr=\"max(hh, 0.55)\"><in name=\"hh\" "
    "from=\"height\"/></node>\n"
    "  <node id=\"water_mask\" type=\"pixel\" expr=\"clamp((0.6 - hh) * 10, 0, 1)\"><in "
    "name=\"hh\" from=\"height\"/></node>\n"
    "  <node id=\"water_normal\" type=\"normal\" intensity=\"12\"><in name=\"height\" "
    "from=\"water_height\"/></node>\n"
    "  <node id=\"water_roughness\" type=\"pixel\" expr=\"0.05\"/>\n"
    "  <node id=\"specular\" type=\"pixel\" expr=\"0.1 + 0.9 * (1 - u) * (1 - v)\"/>\n"
    "  <node id=\"water_specular\" type=\"pixel\" expr=\"0.02\"/>\n"
    "  <output name=\"atlas\" from=\"atlas\" format=\"exr32\"/>\n"
    "  <output name=\"basecolor\" from=\"basecolor\"/><output name=\"normal\" from=\"normal\"/>\n"
    "  <output name=\"roughness\" from=\"roughness\"/><output name=\"height\" from=\"height\"/>\n"
    "  <output name=\"ao\" from=\"ao\"/><output name=\"metallic\" from=\"metallic\"/>\n"
    "  <output name=\"water_height\" from=\"water_height\"/><output name=\"water_normal\" "
    "from=\"water_normal\"/>\n"
    "  <output name=\"water_roughness\" from=\"water_roughness\"/><output name=\"water_specular\" "
    "from=\"water_specular\"/>\n"
    "  <output name=\"water_mask\" from=\"water_mask\"/><output name=\"specular\" "
    "from=\"specular\"/>\n"
    "</wetgraph>\n";

/* The plane z = 0 of the tile through the preview node's camera (preview_eval in
 * nodes/preview.c): clip x, y = the point's offsets along right and up over its depth along the
 * view times tan(fov/2) (x also over the aspect), w = that depth; uv is the point, view_ts the
 * direction to the camera, both interpolated with perspective correction, so exact per pixel. */
static const char layered_vs[] =
    "#version 330 core\n"
    "layout(location = 0) in vec2 pos;\n"
    "uniform vec3 cam, right, up, fwd;\n"
    "uniform float tan_half, aspect;\n"
    "out vec2 uv;\n"
    "out vec3 view_ts;\n"
    "void main()\n"
    "{\n"
    "    vec3 p = vec3(pos, 0.0), r = p - cam;\n"
    "    uv = pos;\n"
    "    view_ts = cam - p;\n"
    "    gl_Position = vec4(dot(r, right) / (tan_half * aspect), dot(r, up) / tan_half, 0.0, "
    "dot(r, fwd));\n"
    "}\n";

static const float tile[] = {0, 0, 1, 0, 1, 1, 0, 0, 1, 1, 0, 1};

/* The same plane with a tangent frame, for the shader built with WG_TANGENT_FRAME: T, B and N
 * the world's x, y and z turned by `turn` radians about the vertical, as though the tile lay
 * turned in a world whose environment is read in world space. */
static const char layered_frame_vs[] =
    "#version 330 core\n"
    "layout(location = 0) in vec2 pos;\n"
    "uniform vec3 cam, right, up, fwd;\n"
    "uniform float tan_half, aspect, turn;\n"
    "out vec2 uv;\n"
    "out vec3 view_ts;\n"
    "out mat3 tangent_to_world;\n"
    "void main()\n"
    "{\n"
    "    vec3 p = vec3(pos, 0.0), r = p - cam;\n"
    "    uv = pos;\n"
    "    view_ts = cam - p;\n"
    "    tangent_to_world = mat3(cos(turn), sin(turn), 0.0, -sin(turn), cos(turn), 0.0, 0.0, 0.0, "
    "1.0);\n"
    "    gl_Position = vec4(dot(r, right) / (tan_half * aspect), dot(r, up) / tan_half, 0.0, "
    "dot(r, fwd));\n"
    "}\n";

/* wet_layered.frag with `#define WG_TANGENT_FRAME` after its version line, written to the
 * test's temporary folder: its path. */
static const char *framed_shader_path(void)
{
    static char path[2048];
    char *src = wgt_read_file(shader_path("wet_layered.frag"), NULL);
    char *v = strstr(src, "\n#version 330 core\n");
    if (!v) fail_msg("wet_layered.frag has no line #version 330 core");
    v += strlen("\n#version 330 core\n");
    snprintf(path, sizeof path, "%s/wet_layered_framed.frag", wgt_tmpdir());
    FILE *f = fopen(path, "wb");
    if (!f) fail_msg("cannot write %s", path);
    fprintf(f, "%.*s#define WG_TANGENT_FRAME\n%s", (int)(v - src), src, v);
    fclose(f);
    free(src);
    return path;
}

/* The top-left w0 x h0 pixels of block `block` of the env_prefilter atlas (2 across, 4 down),
 * box-filtered down by 2^level (to at least 1 x 1), as a GL mip level. */
static WgImage *atlas_block(const WgImage *atlas, int block, int level, int w0, int h0)
{
    int bw = atlas->width / 2, bh = atlas->height / 4;
    int w = w0 >> level, h = h0 >> level;
    if (w < 1) w = 1;
    if (h < 1) h = 1;
    int kx = w0 / w, ky = h0 / h;
    WgImage *out = wg_image_new(w, h, 4);
    assert_non_null(out);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 4; c++) {
                double s = 0;
                for (int j = 0; j < ky; j++)
                    for (int i = 0; i < kx; i++)
                        s += wgt_px(atlas, block % 2 * bw + x * kx + i, block / 2 * bh + y * ky + j,
                                    c);
                wg_image_row(out, y)[4 * x + c] = (float)(s / (kx * ky));
            }
    return out;
}

/* GL_LINEAR sampling of an RGBA image at (u, v) in [0, 1] (rows from the top), u wrapping and
 * v clamped, into o. */
static void bilinear(const WgImage *img, double u, double v, float o[4])
{
    int w = img->width, h = img->height;
    double fx = u * w - 0.5, fy = v * h - 0.5;
    fy = fy < 0 ? 0 : fy > h - 1 ? h - 1 : fy;
    int x0 = (int)floor(fx), y0 = (int)floor(fy);
    double ax = fx - x0, ay = fy - y0;
    int y1 = y0 + 1 < h ? y0 + 1 : y0, xa = ((x0 % w) + w) % w, xb = (xa + 1) % w;
    for (int c = 0; c < 4; c++)
        o[c] =
            (float)((wgt_px(img, xa, y0, c) * (1 - ax) + wgt_px(img, xb, y0, c) * ax) * (1 - ay) +
                    (wgt_px(img, xa, y1, c) * (1 - ax) + wgt_px(img, xb, y1, c) * ax) * ay);
}

typedef struct {
    double mean_abs, mean_cpu, wet_effect;
    double dry_abs, dry_cpu; /* over the pixels the water leaves untouched */
    int covered, dry;
} LayeredStats;

/* Set a uniform of the layered shader: one it no longer has is an error, not a silent default. */
#define NEED(set, name, ...)                                                                       \
    if (!set(prog, name, __VA_ARGS__)) fail_msg("wet_layered.frag has no uniform %s", name)

/* The shader against the preview node on the scene; with turn not NULL, the shader built with
 * WG_TANGENT_FRAME on the tile turned by *turn radians (layered_frame_vs), the environment's
 * rotation and the sun's direction given in world space so that in the tile's frame they are
 * the plain run's: the same picture only if the shader reads the environment and the sun
 * through the frame. */
static LayeredStats run_layered(bool sun, const float *turn)
{
    WgGraph *g = wgt_load(scene_xml);
    WgRequest *r = wg_request_new(g);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *atlas = wgt_output(res, "atlas");
    unsigned prog = turn ? wgt_gl_program(layered_frame_vs, framed_shader_path())
                         : wgt_gl_program(layered_vs, shader_path("wet_layered.frag"));

    /* the lighting: prefiltered blocks 0-5 as one mip chain (level l = block l at 1/2^l of its
     * size), irradiance (block 6), the BRDF table (block 7's left square, u = n·v, v =
     * roughness from the top row: not flipped) */
    int bw = atlas->width / 2, bh = atlas->height / 4;
    WgImage *lv[6];
    for (int l = 0; l < 6; l++) lv[l] = atlas_block(atlas, l, l, bw, bh);
    /* The GPU reads level l of the chain, a box-filtered block l at 1/2^l of its size, with
     * bilinear filtering; the node reads block l at full size. So that the comparison is of the
     * shaders and not of the chain, the node gets an atlas whose blocks 1-5 are what the GPU
     * reads: each level sampled bilinearly (u wrapping, v clamped) at the block's texel
     * centres. */
    WgImage *gpu_atlas = wg_image_new(atlas->width, atlas->height, 4);
    assert_non_null(gpu_atlas);
    for (int y = 0; y < atlas->height; y++)
        memcpy(wg_image_row(gpu_atlas, y), wg_image_row(atlas, y),
               sizeof(float) * 4 * atlas->width);
    for (int l = 1; l < 6; l++)
        for (int y = 0; y < bh; y++)
            for (int x = 0; x < bw; x++) {
                float o[4];
                bilinear(lv[l], (x + 0.5) / bw, (y + 0.5) / bh, o);
                memcpy(wg_image_row(gpu_atlas, l / 2 * bh + y) + 4 * (l % 2 * bw + x), o, sizeof o);
            }
    /* A specular level map (F0 = 0.08 x specular) is compared when both the node (an input
     * port `specular`) and the shader (a sampler `specular`) take one; otherwise each side uses
     * its default 0.5, the shader's sampler (if any) reading a constant 0.5. */
    const char *names[64];
    int ns = wgt_gl_samplers(prog, names, 64);
    bool shader_spec = false, node_spec = false;
    for (int i = 0; i < ns; i++) shader_spec |= !strcmp(names[i], "specular");
    for (const WgPortSpec *ps = wg_node_type_find("preview")->inputs; ps->name; ps++)
        node_spec |= !strcmp(ps->name, "specular");
    bool with_spec = shader_spec && node_spec;

    /* the maps, material first (the dry render takes those alone), then the water's */
    static const char *const maps[] = {
        "basecolor",    "normal",          "roughness",      "height",
        "ao",           "metallic",        "specular",       "water_height",
        "water_normal", "water_roughness", "water_specular", "water_mask"};
    const char *in_names[13] = {"environment"};
    const WgImage *in_images[13] = {gpu_atlas};
    int n_in = 1, n_dry = 0;
    for (int i = 0; i < 12; i++) {
        if (!strcmp(maps[i], "specular") && !with_spec) continue;
        if (!strcmp(maps[i], "water_height")) n_dry = n_in;
        in_names[n_in] = maps[i], in_images[n_in++] = wgt_output(res, maps[i]);
    }
    char attrs[1024];
    snprintf(attrs, sizeof attrs, PREVIEW_ATTRS "sun=\"%s\"", sun ? "true" : "false");
    WgImage *dry = wgt_node("preview", attrs, S, S, n_dry, in_names, in_images, 0, 2);
    snprintf(attrs, sizeof attrs,
             PREVIEW_ATTRS "sun=\"%s\" water_tint=\"0.3 0.7 0.6\" absorption_depth=\"0.3\"",
             sun ? "true" : "false");
    WgImage *cpu = wgt_node("preview", attrs, S, S, n_in, in_names, in_images, 0, 2);

    unsigned tex[20];
    int nt = 0;
    tex[nt++] =
        wgt_gl_texture(lv[0], WGT_GL_FLIP | WGT_GL_CLAMP_T, (const WgImage *const *)lv + 1, 5);
    wgt_gl_bind(prog, "prefiltered", 0, tex[0]);
    WgImage *irr = atlas_block(atlas, 6, 0, bw, bh), *lut = atlas_block(atlas, 7, 0, bh, bh);
    tex[nt] = wgt_gl_texture(irr, WGT_GL_FLIP | WGT_GL_CLAMP_T, NULL, 0);
    wgt_gl_bind(prog, "irradiance", 1, tex[nt++]);
    tex[nt] = wgt_gl_texture(lut, WGT_GL_CLAMP, NULL, 0);
    wgt_gl_bind(prog, "brdf_lut", 2, tex[nt++]);
    /* the maps: tile y up, so the image's top row goes to t = 1 */
    for (int i = 0; i < 12; i++) {
        const char *sampler = strcmp(maps[i], "normal") ? maps[i] : "normal_map";
        if (!strcmp(maps[i], "specular")) {
            if (!shader_spec) continue;
            if (!with_spec) {
                float half[4] = {0.5f, 0.5f, 0.5f, 1};
                WgImage *sp = wgt_image(1, 1, 4, half);
                tex[nt] = wgt_gl_texture(sp, 0, NULL, 0);
                wg_image_unref(sp);
                wgt_gl_bind(prog, sampler, 3 + i, tex[nt++]);
                continue;
            }
            wgt_gl_set1i(prog, "specular_from_map", 1); /* where the shader has the switch */
        }
        tex[nt] = wgt_gl_texture(wgt_output(res, maps[i]), WGT_GL_FLIP, NULL, 0);
        wgt_gl_bind(prog, sampler, 3 + i, tex[nt++]);
    }
    /* every sampler the shader reads must be one bound here: a new map in the shader needs its
     * counterpart in this test (and in the preview node) */
    for (int i = 0; i < ns; i++) {
        bool known = !strcmp(names[i], "prefiltered") || !strcmp(names[i], "irradiance") ||
                     !strcmp(names[i], "brdf_lut") || !strcmp(names[i], "normal_map");
        for (int k = 0; k < 12; k++) known |= !strcmp(names[i], maps[k]);
        if (!known)
            fail_msg("wet_layered.frag samples %s, which tests/graphs/test_glsl.c does not bind",
                     names[i]);
    }
    print_message("wet_layered.frag: specular level map %s\n",
                  with_spec ? "compared" : "not taken by both (each side at 0.5)");
    /* the preview node's parameters (its defaults where the scene leaves them) */
    const float deg = (float)(M_PI / 180);
    float el = 50 * deg, az = 20 * deg, tan_half = tanf(35 * deg / 2);
    float back[3] = {sinf(az) * cosf(el), -cosf(az) * cosf(el), sinf(el)};
    float right[3] = {cosf(az), sinf(az), 0};
    float up[3] = {back[1] * right[2] - back[2] * right[1], back[2] * right[0] - back[0] * right[2],
                   back[0] * right[1] - back[1] * right[0]};
    float ul = sqrtf(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    float dist = 0.5f / 2.5f / tan_half; /* span 1, zoom 2.5 */
    NEED(wgt_gl_set3f, "cam", 0.5f + back[0] * dist, 0.5f + back[1] * dist, back[2] * dist);
    NEED(wgt_gl_set3f, "right", right[0], right[1], right[2]);
    NEED(wgt_gl_set3f, "up", up[0] / ul, up[1] / ul, up[2] / ul);
    NEED(wgt_gl_set3f, "fwd", -back[0], -back[1], -back[2]);
    NEED(wgt_gl_set1f, "tan_half", tan_half);
    NEED(wgt_gl_set1f, "aspect", 1);
    NEED(wgt_gl_set1f, "prefiltered_levels", 5);
    NEED(wgt_gl_set1f, "height_scale", 0.04f);
    NEED(wgt_gl_set1i, "pom_steps", 48);
    float t = turn ? *turn : 0;
    if (turn) NEED(wgt_gl_set1f, "turn", t);
    NEED(wgt_gl_set1f, "env_rotation", 30 * deg - t);
    NEED(wgt_gl_set1f, "exposure", -0.5f);
    NEED(wgt_gl_set1i, "sun", sun);
    float se = 35 * deg, sa = 120 * deg;
    NEED(wgt_gl_set3f, "sun_dir", cosf(se) * cosf(sa + t), cosf(se) * sinf(sa + t), sinf(se));
    NEED(wgt_gl_set3f, "sun_radiance", 3, 3 * 0.95f, 3 * 0.9f);
    NEED(wgt_gl_set1f, "water_ior", 1.33f);
    NEED(wgt_gl_set3f, "water_tint", 0.3f, 0.7f, 0.6f);
    NEED(wgt_gl_set1f, "absorption_depth", 0.3f);

    WgImage *gl = wgt_gl_draw(prog, tile, 6, S, S, true);
    dump(sun ? "layered_glsl_sun" : "layered_glsl", gl, 1);
    dump(sun ? "layered_cpu_sun" : "layered_cpu", cpu, 1);
    LayeredStats st = {0};
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            if (wgt_px(gl, x, y, 3) < 0.5f) continue; /* off the tile: the CPU's background */
            st.covered++;
            bool untouched = true;
            for (int c = 0; c < 3; c++) untouched &= wgt_px(dry, x, y, c) == wgt_px(cpu, x, y, c);
            st.dry += untouched;
            for (int c = 0; c < 3; c++) {
                double d = fabs(wgt_px(gl, x, y, c) - wgt_px(cpu, x, y, c));
                st.mean_abs += d;
                st.mean_cpu += wgt_px(cpu, x, y, c);
                st.wet_effect += fabs(wgt_px(dry, x, y, c) - wgt_px(cpu, x, y, c));
                if (untouched) st.dry_abs += d, st.dry_cpu += wgt_px(cpu, x, y, c);
            }
        }
    if (st.covered) {
        st.mean_abs /= 3.0 * st.covered;
        st.mean_cpu /= 3.0 * st.covered;
        st.wet_effect /= 3.0 * st.covered;
    }
    wg_image_unref(gl);
    wg_image_unref(cpu);
    wg_image_unref(dry);
    wg_image_unref(gpu_atlas);
    for (int i = 0; i < nt; i++) wgt_gl_delete_texture(tex[i]);
    for (int l = 0; l < 6; l++) wg_image_unref(lv[l]);
    wg_image_unref(irr);
    wg_image_unref(lut);
    wgt_gl_delete_program(prog);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    return st;
}

/* The bound: the mean |GL − CPU| over the pixels and channels within 0.25% of the mean radiance
 * (measured on llvmpipe: 0.02% without the sun, 0.01% with it, over roughness 0.05-0.95 and a
 * sky with a small bright patch). What remains is float rounding, the GPU's texture filtering
 * and the shader's parallax search over the whole relief range where the node searches the
 * range of each height map; the GPU's mip chain of the prefiltered blocks is given to the node
 * too (run_layered). For scale, each alone in the shader: an absorption depth 10% off gives
 * 1.45% (1.75% with the sun), a height scale 5% off 0.54% (0.94%), an index of refraction of
 * 1.30 instead of 1.33 0.09% (0.41%); the water layer itself changes the picture by about 35%,
 * checked to stay above 10 times the bound so that the scene does test the water. */
static void check_layered(bool sun, const float *turn)
{
    LayeredStats st = run_layered(sun, turn);
    print_message("wet_layered.frag (sun %s%s): mean |GL - CPU| %.5f, mean radiance %.4f (%.2f%%), "
                  "the water's own effect %.4f, %d pixels; where the water leaves the dry "
                  "render untouched (%d pixels): %.2f%%, elsewhere %.2f%%\n",
                  sun ? "on" : "off", turn ? ", WG_TANGENT_FRAME, the tile turned" : "",
                  st.mean_abs, st.mean_cpu, 100 * st.mean_abs / st.mean_cpu, st.wet_effect,
                  st.covered, st.dry, 100 * st.dry_abs / fmax(st.dry_cpu, 1e-9),
                  100 * (st.mean_abs * 3 * st.covered - st.dry_abs) /
                      fmax(st.mean_cpu * 3 * st.covered - st.dry_cpu, 1e-9));
    assert_int_equal(st.covered, S * S); /* zoom 2.5: the tile fills the picture */
    if (!(st.mean_abs <= 0.0025 * st.mean_cpu))
        fail_msg("wet_layered.frag differs from the preview node by %.3f%% of the mean radiance "
                 "(bound 0.25%%)",
                 100 * st.mean_abs / st.mean_cpu);
    assert_true(st.wet_effect >= 10 * 0.0025 * st.mean_cpu);
}

static void test_layered_ambient(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    check_layered(false, NULL);
}

static void test_layered_sun(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    check_layered(true, NULL);
}

/* The shader's tangent frame (WG_TANGENT_FRAME): the tile turned by 75 degrees in the world,
 * the environment and the sun turned with it, is the preview node's picture within the same
 * bound, with the sun and without. Were the frame not applied to the environment, the
 * environment would stand 75 degrees off; were it not applied to the sun, the sun too. */
static void test_layered_tangent_frame(void **state)
{
    (void)state;
    if (!gl_ok) skip();
    const float turn = (float)(75 * M_PI / 180);
    check_layered(false, &turn);
    check_layered(true, &turn);
}

int main(void)
{
    char why[512] = "";
    gl_ok = wgt_gl_open(why, sizeof why);
    const char *require = getenv("WETGRAPH_REQUIRE_GL");
    if (!gl_ok) {
        printf("SKIPPED: the GLSL shaders cannot be executed here: %s\n", why);
        if (require && !strcmp(require, "1")) {
            fprintf(stderr, "WETGRAPH_REQUIRE_GL=1: %s\n", why);
            return 1;
        }
    } else {
        printf("GL: %s\n", wgt_gl_describe());
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_foam_unlooped),   cmocka_unit_test(test_foam_loop_half_waves),
        cmocka_unit_test(test_foam_short_loop), cmocka_unit_test(test_foam_sine_warp),
        cmocka_unit_test(test_foam_layer3),     cmocka_unit_test(test_foam_speed_noise),
        cmocka_unit_test(test_rain_ripples),    cmocka_unit_test(test_layered_ambient),
        cmocka_unit_test(test_layered_sun),     cmocka_unit_test(test_layered_tangent_frame),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    wgt_gl_close();
    if (failed) return failed;
    return gl_ok ? 0 : 77; /* meson's SKIP */
}
