/* SPDX-License-Identifier: MIT */
/* Small helpers shared by the tests of the colour and value nodes (tests/nodes/test_curve.c,
 * test_hsl.c, ...): a seeded random generator, images from value lists, one-node runs with the
 * usual input name, and the thread-count invariance check. Header-only, static functions. */
#ifndef COLORTEST_H
#define COLORTEST_H

#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Deterministic random numbers in [0, 1) (splitmix64). */
static inline double ct_rand(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1p-53;
}

/* w x h image with every value drawn uniformly from [lo, hi). */
static inline WgImage *ct_random_image(int w, int h, int channels, double lo, double hi,
                                       uint64_t seed)
{
    WgImage *img = wg_image_new(w, h, channels);
    assert_non_null(img);
    for (int y = 0; y < h; y++)
        for (int i = 0; i < w * channels; i++)
            wg_image_row(img, y)[i] = (float)(lo + (hi - lo) * ct_rand(&seed));
    return img;
}

/* A one-row image holding `n` values (gray) or n/4 pixels (colour). */
static inline WgImage *ct_row(int channels, int n, const float *values)
{
    return wgt_image(n / channels, 1, channels, values);
}

/* Run node `type` on `in` connected to port `port_name` ("source" for most), one output port,
 * at the input's size. */
static inline WgImage *ct_run(const char *type, const char *attrs, const char *port_name,
                              const WgImage *in, int threads)
{
    const char *names[] = {port_name};
    const WgImage *images[] = {in};
    return wgt_node(type, attrs, in->width, in->height, 1, names, images, 0, threads);
}

static inline WgImage *ct_source(const char *type, const char *attrs, const WgImage *in)
{
    return ct_run(type, attrs, "source", in, 1);
}

/* Expect the node to be rejected with `code`; the message names the node ('n'), its type and
 * contains `needle`. */
static inline void ct_fails(const char *type, const char *attrs, const WgImage *in, int code,
                            const char *needle)
{
    const char *names[] = {"source"};
    const WgImage *images[] = {in};
    WgError err;
    int rc = wgt_node_error(type, attrs, in->width, in->height, 1, names, images, &err);
    if (rc != code)
        fail_msg("%s %s: status %d, expected %d (%s)", type, attrs, rc, code, err.message);
    char buf[2048];
    wg_error_format(&err, buf, sizeof buf);
    char who[128];
    snprintf(who, sizeof who, "node 'n' (%s)", type);
    if (!strstr(buf, who)) fail_msg("%s %s: message does not name the node: %s", type, attrs, buf);
    wgt_assert_error(&err, code, 0, needle);
}

/* Every value finite (no NaN, no infinity). */
static inline void ct_assert_finite(const WgImage *img)
{
    for (int y = 0; y < img->height; y++)
        for (int i = 0; i < img->width * img->channels; i++)
            if (!isfinite(wg_image_row(img, y)[i]))
                fail_msg("non-finite value %g at x=%d y=%d channel %d", wg_image_row(img, y)[i],
                         i / img->channels, y, i % img->channels);
}

/* The node gives bit-identical output with 1 and 4 threads on a random image (values in
 * [lo, hi), sized so that the rows split into uneven chunks). */
static inline void ct_assert_thread_invariant(const char *type, const char *attrs,
                                              const char *port_name, int channels, double lo,
                                              double hi)
{
    WgImage *in = ct_random_image(97, 203, channels, lo, hi, 1234);
    WgImage *a = ct_run(type, attrs, port_name, in, 1);
    WgImage *b = ct_run(type, attrs, port_name, in, 4);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(in);
}

#endif
