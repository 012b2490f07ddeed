/* SPDX-License-Identifier: MIT */
/* The error of `preview` (split-sum image-based lighting from the env_prefilter atlas) against a
 * brute-force Monte-Carlo reference of the same BRDF. A flat tile (height_scale 0) of one base
 * colour, roughness rising 0 → 1 from left to right and metallic 0 → 1 from top to bottom, is
 * rendered by `preview` (no tone mapping, linear) at N × N (the atlas's size, 512, by default,
 * so it reaches the preview as it is); for every (N/64)th pixel of each axis that sees the tile
 * the reference integrates the full-resolution environment (the HDR file at 1024 × 512, read
 * through the `image` node, bilinear) against GGX with height-correlated Smith visibility and
 * the preview's Fresnel term (f0 + (1 − f0)·w, w the exact curve of a dielectric of index 1.5
 * rescaled), S importance samples of the half vector (Hammersley, rotated per pixel),
 * plus the multiple-scattering term the preview adds, Ems·Fms · irradiance/π (Fdez-Agüera 2019,
 * from this lobe's own albedo), and the diffuse colour · (1 − E − Ems·Fms) · irradiance/π with E
 * the lobe's directional albedo (the preview's energy split) and the irradiance from S
 * cosine-distributed samples. Prints the
 * mean and maximum relative error (|preview − reference| summed over RGB, over the reference's
 * sum) and the error relative to the mean radiance of the tile.
 *
 *   bench/preview_reference ENV.hdr [N=512] [S=4096] */
#define _DEFAULT_SOURCE /* realpath */
#include "wetgraph/wetgraph.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const double ELEVATION = 40, AZIMUTH = 20, FOV = 35, ZOOM = 1;

static const char *GRAPH =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <node id=\"envfile\" type=\"image\" path=\"%s\" size=\"1024x512\"/>\n"
    "  <node id=\"env\" type=\"env_prefilter\" size=\"512\"><in name=\"environment\" "
    "from=\"envfile\"/></node>\n"
    "  <node id=\"base\" type=\"uniform\" kind=\"color\" color=\"0.8 0.45 0.25 1\"/>\n"
    "  <node id=\"rough\" type=\"gradient\" angle=\"0\"/>\n"
    "  <node id=\"metal\" type=\"gradient\" angle=\"90\"/>\n"
    "  <node id=\"view\" type=\"preview\" elevation=\"%g\" azimuth=\"%g\" fov=\"%g\" zoom=\"%g\" "
    "height_scale=\"0\" tonemap=\"none\" encoding=\"linear\">\n"
    "    <in name=\"environment\" from=\"env\"/><in name=\"basecolor\" from=\"base\"/>\n"
    "    <in name=\"roughness\" from=\"rough\"/><in name=\"metallic\" from=\"metal\"/>\n"
    "  </node>\n"
    "  <output name=\"view\" from=\"view\" format=\"exr32\"/>\n"
    "  <output name=\"rough\" from=\"rough\" format=\"exr32\"/>\n"
    "  <output name=\"metal\" from=\"metal\" format=\"exr32\"/>\n"
    "  <output name=\"env\" from=\"envfile\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static const WgImage *output(const WgResult *r, const char *name)
{
    for (int i = 0; i < wg_result_output_count(r); i++)
        if (!strcmp(wg_result_output_name(r, i), name)) return wg_result_output_image(r, i);
    return NULL;
}

/* bilinear, wrapping, tile coordinates (x right, y up), channel k */
static double tex(const WgImage *img, double x, double y, int k)
{
    int w = img->width, h = img->height, c = img->channels;
    double fx = x * w - 0.5, fy = (1 - y) * h - 0.5;
    fx -= floor(fx / w) * w, fy -= floor(fy / h) * h;
    int x0 = (int)fx % w, y0 = (int)fy % h, x1 = (x0 + 1) % w, y1 = (y0 + 1) % h;
    double ax = fx - floor(fx), ay = fy - floor(fy);
    const float *r0 = wg_image_row(img, y0), *r1 = wg_image_row(img, y1);
    return (r0[x0 * c + k] * (1 - ax) + r0[x1 * c + k] * ax) * (1 - ay) +
           (r1[x0 * c + k] * (1 - ax) + r1[x1 * c + k] * ax) * ay;
}

/* the environment in direction d (env_prefilter's convention), bilinear */
static void env_at(const WgImage *env, const double d[3], double out[3])
{
    double u = 0.5 - atan2(d[1], d[0]) / (2 * M_PI);
    u -= floor(u);
    double v = acos(fmax(-1, fmin(1, d[2]))) / M_PI;
    int w = env->width, h = env->height;
    double fx = u * w - 0.5, fy = v * h - 0.5;
    fx -= floor(fx / w) * w;
    fy = fmax(0, fmin(h - 1, fy));
    int x0 = (int)fx % w, y0 = (int)fy, x1 = (x0 + 1) % w, y1 = y0 + 1 < h ? y0 + 1 : y0;
    double ax = fx - floor(fx), ay = fy - y0;
    const float *r0 = wg_image_row(env, y0), *r1 = wg_image_row(env, y1);
    for (int k = 0; k < 3; k++)
        out[k] = (r0[4 * x0 + k] * (1 - ax) + r0[4 * x1 + k] * ax) * (1 - ay) +
                 (r1[4 * x0 + k] * (1 - ax) + r1[4 * x1 + k] * ax) * ay;
}

static double radical_inverse(unsigned i)
{
    i = (i << 16) | (i >> 16);
    i = ((i & 0x55555555u) << 1) | ((i & 0xAAAAAAAAu) >> 1);
    i = ((i & 0x33333333u) << 2) | ((i & 0xCCCCCCCCu) >> 2);
    i = ((i & 0x0F0F0F0Fu) << 4) | ((i & 0xF0F0F0F0u) >> 4);
    i = ((i & 0x00FF00FFu) << 8) | ((i & 0xFF00FF00u) >> 8);
    return i * 2.3283064365386963e-10;
}

/* The preview's Fresnel shape (nodes/preview.c, fresnel_w): the exact reflectance of a
 * dielectric of index 1.5, rescaled from 0 at normal incidence to 1 at grazing. */
static double fresnel_w(double c)
{
    c = c > 0 ? (c < 1 ? c : 1) : 0;
    double g = sqrt(1.25 + c * c);
    double a = (g - c) / (g + c), b = (c * (g + c) - 1) / (c * (g - c) + 1);
    return (0.5 * a * a * (1 + b * b) - 0.04) / 0.96;
}

static double vis_smith(double nv, double nl, double a)
{
    double a2 = a * a;
    return 0.5 / (nl * sqrt(nv * nv * (1 - a2) + a2) + nv * sqrt(nl * nl * (1 - a2) + a2));
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s ENV.hdr [N=512] [SAMPLES=4096]\n", argv[0]);
        return 2;
    }
    int n = argc > 2 ? atoi(argv[2]) : 512, samples = argc > 3 ? atoi(argv[3]) : 4096;
    int step = n / 64 > 1 ? n / 64 : 1; /* the reference at 64 x 64 pixels of the picture */
    char xml[8192], path[4096];
    if (!realpath(argv[1], path)) {
        fprintf(stderr, "preview_reference: %s: cannot open\n", argv[1]);
        return 1;
    }
    snprintf(xml, sizeof xml, GRAPH, path, ELEVATION, AZIMUTH, FOV, ZOOM);
    WgError err = {0};
    WgGraph *g = NULL;
    WgEngine *e = NULL;
    WgResult *res = NULL;
    char msg[1024];
    if (wg_graph_load_memory(xml, strlen(xml), "preview_reference.wetgraph", &g, &err) ||
        wg_engine_new(NULL, &e, &err))
        goto fail;
    WgRequest *req = wg_request_new(g);
    wg_request_set_size(req, n, n);
    if (wg_render(e, req, &res, &err)) goto fail;
    wg_request_free(req);
    const WgImage *view = output(res, "view"), *rough = output(res, "rough");
    const WgImage *metal = output(res, "metal"), *env = output(res, "env");
    const double base[3] = {0.8, 0.45, 0.25};

    /* the preview's camera */
    double deg = M_PI / 180, el = ELEVATION * deg, az = AZIMUTH * deg;
    double back[3] = {sin(az) * cos(el), -cos(az) * cos(el), sin(el)};
    double right[3] = {cos(az), sin(az), 0};
    double up[3] = {back[1] * right[2] - back[2] * right[1],
                    back[2] * right[0] - back[0] * right[2],
                    back[0] * right[1] - back[1] * right[0]};
    double th = tan(FOV * deg / 2), dist = 0.5 / ZOOM / th;
    double cam[3] = {0.5 + back[0] * dist, 0.5 + back[1] * dist, back[2] * dist};

    double sum_err = 0, sum_ref = 0, max_rel = 0, sum_rel = 0, band_err[4] = {0}, band_ref[4] = {0};
    double metal_err[2] = {0}, metal_ref[2] = {0};
    int count = 0;
    for (int py = step / 2; py < n; py += step)
        for (int px = step / 2; px < n; px += step) {
            double u = 2 * (px + 0.5) / n - 1, v = 1 - 2 * (py + 0.5) / n, d[3];
            for (int k = 0; k < 3; k++) d[k] = -back[k] + th * (u * right[k] + v * up[k]);
            double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int k = 0; k < 3; k++) d[k] /= l;
            if (d[2] >= 0) continue;
            double t = -cam[2] / d[2], x = cam[0] + t * d[0], y = cam[1] + t * d[1];
            if (x < 0 || y < 0 || x > 1 || y > 1) continue;
            double r = fmin(1, fmax(0, tex(rough, x, y, 0)));
            double m = fmin(1, fmax(0, tex(metal, x, y, 0)));
            double a = r * r, f0[3], dc[3];
            for (int k = 0; k < 3; k++) f0[k] = 0.04 * (1 - m) + base[k] * m;
            for (int k = 0; k < 3; k++) dc[k] = base[k] * (1 - m);
            double vv[3] = {-d[0], -d[1], -d[2]}, nv = fmax(vv[2], 1e-4);
            double spec[3] = {0, 0, 0}, ea = 0, eb = 0, irr[3] = {0, 0, 0};
            unsigned hsh = (unsigned)(py * 7919 + px * 104729 + 17);
            hsh ^= hsh >> 13, hsh *= 0x5bd1e995u, hsh ^= hsh >> 15;
            double rot1 = (hsh & 0xffff) / 65536.0, rot2 = (hsh >> 16) / 65536.0;
            for (int s = 0; s < samples; s++) {
                double u1 = fmod((s + 0.5) / samples + rot1, 1);
                double u2 = fmod(radical_inverse((unsigned)s) + rot2, 1);
                /* GGX half vector around n = +z */
                double phi = 2 * M_PI * u1;
                double ct = sqrt((1 - u2) / (1 + (a * a - 1) * u2)), st = sqrt(1 - ct * ct);
                double h[3] = {st * cos(phi), st * sin(phi), ct};
                double vh = vv[0] * h[0] + vv[1] * h[1] + vv[2] * h[2];
                double ld[3] = {2 * vh * h[0] - vv[0], 2 * vh * h[1] - vv[1],
                                2 * vh * h[2] - vv[2]};
                if (ld[2] > 0 && vh > 0) {
                    double gw = vis_smith(nv, ld[2], a) * 4 * ld[2] * vh / h[2];
                    double fc = fresnel_w(vh), c[3];
                    env_at(env, ld, c);
                    for (int k = 0; k < 3; k++) spec[k] += c[k] * (f0[k] + (1 - f0[k]) * fc) * gw;
                    ea += (1 - fc) * gw, eb += fc * gw;
                }
                /* cosine-distributed direction for the irradiance */
                double cr = sqrt(u2), cphi = 2 * M_PI * u1;
                double cd[3] = {cr * cos(cphi), cr * sin(cphi), sqrt(1 - u2)}, c[3];
                env_at(env, cd, c);
                for (int k = 0; k < 3; k++) irr[k] += c[k];
            }
            double ref_sum = 0, got_err = 0;
            for (int k = 0; k < 3; k++) {
                /* multiple scattering as the preview models it (Fdez-Agüera 2019): what a white
                 * lobe loses, ems, returned as fms · ems, leaving like the irradiance */
                double e_k = (f0[k] * ea + eb) / samples, ems = 1 - (ea + eb) / samples;
                double favg = f0[k] + (1 - f0[k]) * 0.0539354; /* the preview's W_AVG */
                double ms = e_k * favg / (1 - ems * favg) * ems;
                double ref = spec[k] / samples + (ms + dc[k] * (1 - e_k - ms)) * irr[k] / samples;
                double got = wg_image_row(view, py)[4 * px + k];
                ref_sum += ref, got_err += fabs(got - ref);
            }
            double rel = got_err / fmax(ref_sum, 1e-9);
            max_rel = fmax(max_rel, rel), sum_rel += rel;
            sum_err += got_err, sum_ref += ref_sum;
            int band = r < 0.25 ? 0 : r < 0.5 ? 1 : r < 0.75 ? 2 : 3;
            band_err[band] += got_err, band_ref[band] += ref_sum;
            metal_err[m >= 0.5] += got_err, metal_ref[m >= 0.5] += ref_sum;
            count++;
        }
    printf("preview vs Monte-Carlo reference (%d samples per pixel), %dx%d, %d tile pixels "
           "compared:\n",
           samples, n, n, count);
    printf("  relative error per pixel: mean %.4f, max %.4f\n", sum_rel / count, max_rel);
    printf("  mean absolute error over the mean radiance: %.4f\n", sum_err / sum_ref);
    for (int b = 0; b < 4; b++)
        printf("    roughness %.2f-%.2f: %.4f\n", b * 0.25, (b + 1) * 0.25,
               band_err[b] / fmax(band_ref[b], 1e-9));
    printf("    metallic < 0.5: %.4f, >= 0.5: %.4f\n", metal_err[0] / fmax(metal_ref[0], 1e-9),
           metal_err[1] / fmax(metal_ref[1], 1e-9));
    wg_result_free(res);
    wg_engine_free(e);
    wg_graph_free(g);
    return 0;
fail:
    wg_error_format(&err, msg, sizeof msg);
    fprintf(stderr, "preview_reference: %s\n", msg);
    return 1;
}
