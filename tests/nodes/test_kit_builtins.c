/* SPDX-License-Identifier: MIT */
/* Every built-in node through the public test kit (wetgraph/testkit.h), as a plugin's node would
 * be: the same bits for any thread count and band height, the battery of hard inputs (empty,
 * full, flat, huge, negative, NaN, Inf, 1x1, non-square) without a crash, a refused finite input
 * or a non-finite output, and tiling: a rolled input gives the rolled output (the nodes that
 * are translation-invariant), a generator's picture is seamless. Each node is fed a noise on
 * every input port (its kind's channels) with its default parameters, and the parameters below
 * where the defaults would leave nothing to check. */
#include "wgtest.h"

#include <stdio.h>
#include <string.h>
#include <wetgraph/testkit.h>

typedef struct {
    const char *type;
    const char *const *params;
    const char *const *dynamic_inputs; /* for nodes of named inputs of their choice */
    int side;                          /* a square size the node needs, else 40x28 */
    int tiling_inputs;                 /* the first ports fed in the tiling check, 0: all */
} Setup;

static const char *const pixel_params[] = {"expr=a * 2 - b + sqrt(abs(a))", NULL};
static const char *const pixel_inputs[] = {"a", "b", NULL};
static const char *const blur_params[] = {"sigma=40", NULL}; /* wider than the image */
static const char *const distance_params[] = {"mode=signed", NULL};
static const char *const gradient_params[] = {"repeat=mirror", NULL}; /* tiles (its doc) */

static const Setup setups[] = {
    {"pixel", pixel_params, pixel_inputs},
    {"blur", blur_params, NULL},
    /* the Voronoi fill from `source` breaks ties between equally near mask pixels by their row
     * and column (its doc): translation-invariant for the distance alone */
    {"distance", distance_params, NULL, 0, 1},
    {"gradient", gradient_params, NULL},
    {"env_prefilter", NULL, NULL, 16},
};

/* Translation-invariant nodes: the output of a rolled input is the rolled output. */
static const char *const equivariant[] = {
    "blend", "levels", "invert", "grayscale", "blur", "curve", "clamp", "threshold",
    "auto_levels", "statistics", "gradient_map", "hsl", "colorspace", "split", "merge",
    "shuffle", "pixel", "normal", "slope", "curvature", "ambient_occlusion", "distance",
    "dilate", "erode", "warp", "directional_warp", "transform", "sharpen", "emboss",
    "edge_detect", "directional_blur", "normal_blend", "normal_normalize", NULL};

static bool in_list(const char *const *list, const char *name)
{
    for (; *list; list++)
        if (!strcmp(*list, name)) return true;
    return false;
}

typedef struct {
    WgTestkitNode node;
    const char *names[16];
    const WgImage *images[16];
    const char *params[8];
} Fed;

/* The node fed a 40x28 noise on every input port. */
static void feed(const WgNodeType *t, Fed *f)
{
    memset(f, 0, sizeof *f);
    const Setup *s = NULL;
    for (size_t i = 0; i < sizeof setups / sizeof *setups; i++)
        if (!strcmp(setups[i].type, t->name)) s = &setups[i];
    int n = 0;
    if (s && s->dynamic_inputs)
        for (; s->dynamic_inputs[n]; n++) f->names[n] = s->dynamic_inputs[n];
    else
        for (; t->inputs && t->inputs[n].name; n++) f->names[n] = t->inputs[n].name;
    for (int i = 0; i < n; i++) {
        int kind = s && s->dynamic_inputs ? WG_GRAY : t->inputs[i].kind;
        f->images[i] = wg_testkit_image_noise(40, 28, kind == WG_COLOR ? 4 : 1, (uint32_t)(11 + i));
    }
    f->node.type = t->name;
    f->node.params = s ? s->params : NULL;
    f->node.input_names = n ? f->names : NULL;
    f->node.inputs = n ? f->images : NULL;
    f->node.width = s && s->side ? s->side : 40;
    f->node.height = s && s->side ? s->side : 28;
    f->node.seed = 5;
}

static const Setup *setup_of(const char *type)
{
    for (size_t i = 0; i < sizeof setups / sizeof *setups; i++)
        if (!strcmp(setups[i].type, type)) return &setups[i];
    return NULL;
}

static void unfeed(Fed *f)
{
    for (int i = 0; f->images[i]; i++) wg_image_unref(f->images[i]);
}

static bool skipped(const WgNodeType *t)
{
    /* `image` reads a file (its own tests decode real and damaged files); `uniform` and the
     * preview's pair are checked here like the rest */
    return !strcmp(t->name, "image");
}

static void test_invariance(void **state)
{
    (void)state;
    int checked = 0;
    for (int i = 0; wg_node_types[i]; i++) {
        if (skipped(wg_node_types[i])) continue;
        Fed f;
        feed(wg_node_types[i], &f);
        WgTestkitReport rep;
        if (!wg_testkit_check_invariance(&f.node, &rep))
            fail_msg("%s: %s", wg_node_types[i]->name, rep.message);
        unfeed(&f);
        checked++;
    }
    assert_true(checked >= 40);
}

static void test_hard_inputs(void **state)
{
    (void)state;
    char failures[8192] = "";
    size_t at = 0;
    for (int i = 0; wg_node_types[i]; i++) {
        if (skipped(wg_node_types[i])) continue;
        Fed f;
        feed(wg_node_types[i], &f);
        WgTestkitHardReport rep;
        if (!wg_testkit_check_hard_inputs(&f.node, &rep)) {
            int k = snprintf(failures + at, sizeof failures - at, "%s:\n%s", wg_node_types[i]->name,
                             rep.summary);
            if (k > 0 && at + (size_t)k < sizeof failures) at += (size_t)k;
        }
        unfeed(&f);
    }
    if (at) fail_msg("hard inputs:\n%s", failures);
}

static void test_tiling(void **state)
{
    (void)state;
    int rolled = 0, seamless = 0;
    for (int i = 0; wg_node_types[i]; i++) {
        const WgNodeType *t = wg_node_types[i];
        if (skipped(t)) continue;
        Fed f;
        feed(t, &f);
        WgTestkitReport rep;
        if (in_list(equivariant, t->name)) {
            const Setup *s = setup_of(t->name);
            if (s && s->tiling_inputs) {
                for (int k = s->tiling_inputs; f.images[k]; k++) {
                    wg_image_unref(f.images[k]);
                    f.images[k] = NULL;
                    f.names[k] = NULL;
                }
            }
            if (!wg_testkit_check_tiling(&f.node, 13, -9, 2e-5, &rep))
                fail_msg("%s: %s", t->name, rep.message);
            rolled++;
        } else if ((t->flags & WG_NODE_SOURCE) && !strcmp(t->category, "generator")) {
            WgImage *out = NULL;
            WgError err = {0};
            if (wg_testkit_run(&f.node, 2, &out, &err)) fail_msg("%s: %s", t->name, err.message);
            if (!wg_testkit_check_seamless(out, 1.0, &rep))
                fail_msg("%s: %s", t->name, rep.message);
            wg_image_unref(out);
            seamless++;
        }
        unfeed(&f);
    }
    assert_true(rolled >= 30);
    assert_true(seamless >= 5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_invariance),
        cmocka_unit_test(test_hard_inputs),
        cmocka_unit_test(test_tiling),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
