/* SPDX-License-Identifier: MIT */
/* The pixel node: exact values on tiny images (coordinates, inputs, colour channels, extras,
 * graph parameters, $time, $width), the name resolution order, agreement with the double
 * evaluator wg_expr_eval over random expressions (tolerance 2e-6 * (1 + S), S the largest
 * intermediate magnitude; samples within 1e-5 * (1 + S) of a discontinuity are skipped),
 * sample() against a float64 bilinear reference, noise() periodicity / determinism / seed,
 * colours, every error class with its column, non-finite results, thread-count invariance,
 * cache keys, and the compiled program itself (folding, sharing, registers). */
#include "wgtest.h"

#include "../../nodes/pixel_program.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static void xml_escape(char *dst, size_t cap, const char *src)
{
    size_t n = 0;
    for (; *src && n + 8 < cap; src++) {
        const char *rep = *src == '&'   ? "&amp;"
                          : *src == '<' ? "&lt;"
                          : *src == '"' ? "&quot;"
                                        : NULL;
        if (rep) {
            strcpy(dst + n, rep);
            n += strlen(rep);
        } else {
            dst[n++] = *src;
        }
    }
    dst[n] = '\0';
}

static void attrs_for(char *buf, size_t cap, const char *expr, const char *more)
{
    char e[4096];
    xml_escape(e, sizeof e, expr);
    snprintf(buf, cap, "expr=\"%s\" %s", e, more ? more : "");
}

/* The pixel node on named inputs, one thread. */
static WgImage *px_in(const char *expr, const char *more, int w, int h, int n, const char **names,
                      const WgImage **images, int threads)
{
    char attrs[8192];
    attrs_for(attrs, sizeof attrs, expr, more);
    return wgt_node("pixel", attrs, w, h, n, names, images, 0, threads);
}

static WgImage *px(const char *expr, const char *more, int w, int h)
{
    return px_in(expr, more, w, h, 0, NULL, NULL, 1);
}

static float at(const WgImage *img, int x, int y)
{
    return wgt_px(img, x, y, 0);
}

/* Render output "out" of a graph text with an optional parameter override and $time. */
static WgImage *render_xml(const char *xml, double time, const char *set_name,
                           const char *set_value, int threads)
{
    WgGraph *g = wgt_load(xml);
    WgError err = {0};
    WgEngineOptions opt = {threads, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    wg_request_set_time(r, time);
    if (set_name && wg_request_set(r, set_name, set_value, &err)) fail_msg("set: %s", err.message);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("render: %s", buf);
    }
    WgImage *out = wg_image_ref(wgt_output(res, "out"));
    wg_result_free(res);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
    return out;
}

/* Expect the node to be rejected, with `code`, the column in expr and a message part. The node
 * is on line 2 + n of the generated graph. */
static void px_fails(const char *expr, const char *more, int n, const char **names,
                     const WgImage **images, int code, int column, const char *needle)
{
    char attrs[8192];
    attrs_for(attrs, sizeof attrs, expr, more);
    WgError err;
    int rc = wgt_node_error("pixel", attrs, 4, 4, n, names, images, &err);
    char buf[2048];
    wg_error_format(&err, buf, sizeof buf);
    if (rc != code) fail_msg("'%s': code %d, expected %d: %s", expr, rc, code, buf);
    wgt_assert_error(&err, code, 2 + n, needle);
    if (err.column != column)
        fail_msg("'%s': column %d, expected %d: %s", expr, err.column, column, buf);
    char where[64];
    snprintf(where, sizeof where, "expr column %d:", column);
    if (!strstr(buf, where)) fail_msg("'%s': no '%s' in: %s", expr, where, buf);
}

typedef struct {
    uint64_t s;
} Rng;

static uint32_t rnd(Rng *r)
{
    r->s = r->s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (uint32_t)(r->s >> 33);
}

static double rndf(Rng *r) /* [0, 1) */
{
    return rnd(r) / 2147483648.0;
}

/* ---- exact values ------------------------------------------------------------------------ */

static void test_coordinates(void **state)
{
    (void)state;
    WgImage *u = px("u", "", 4, 2), *v = px("v", "", 4, 2), *x = px("x", "", 4, 2);
    WgImage *y = px("y", "", 4, 2), *wh = px("$width * 10 + $height", "", 4, 2);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 4; i++) {
            assert_float_equal(at(u, i, j), (i + 0.5) / 4, 0);
            assert_float_equal(at(v, i, j), (j + 0.5) / 2, 0);
            assert_float_equal(at(x, i, j), i, 0);
            assert_float_equal(at(y, i, j), j, 0);
            assert_float_equal(at(wh, i, j), 42, 0);
        }
    wg_image_unref(u);
    wg_image_unref(v);
    wg_image_unref(x);
    wg_image_unref(y);
    wg_image_unref(wh);
    /* rows longer than one span (256 pixels), row-uniform and varying parts mixed */
    WgImage *big = px("x + 1000 * y + v", "", 600, 3);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 600; i++)
            assert_float_equal(at(big, i, j), (float)(i + 1000 * j + (float)((j + 0.5) / 3)), 0);
    wg_image_unref(big);
}

static const float gray_a[6] = {0.5f, -1.25f, 2, 0.125f, 3, -0.75f};
static const float color_c[24] = {
    0.0625f, 0.125f, 0.25f, 1,    0.5f,  0.75f, 1,     0.5f,  1, 0, 0.375f, 0.25f,
    0.875f,  0.625f, 0,     0.5f, 0.25f, 0.25f, 0.25f, 0.75f, 0, 1, 0.5f,   0.125f,
};

static void test_inputs_and_channels(void **state)
{
    (void)state;
    WgImage *a = wgt_image(3, 2, 1, gray_a), *c = wgt_image(3, 2, 4, color_c);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    WgImage *o = px_in("a * 2 + c.g - c.a + c.r * c.b", "", 3, 2, 2, names, imgs, 1);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 3; i++) {
            const float *p = &color_c[(j * 3 + i) * 4];
            assert_float_equal(at(o, i, j), gray_a[j * 3 + i] * 2 + p[1] - p[3] + p[0] * p[2], 0);
        }
    wg_image_unref(o);
    wg_image_unref(a);
    wg_image_unref(c);
}

static void test_colour_results(void **state)
{
    (void)state;
    WgImage *a = wgt_image(3, 2, 1, gray_a), *c = wgt_image(3, 2, 4, color_c);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    const char *col = "kind=\"color\"";
    WgImage *o1 = px_in("rgb(u, v, a)", col, 3, 2, 2, names, imgs, 1);
    WgImage *o2 = px_in("rgba(1, 0.5, 0.25, 0.125)", col, 3, 2, 2, names, imgs, 1);
    WgImage *o3 = px_in("c * 0.5", col, 3, 2, 2, names, imgs, 1);
    WgImage *o4 = px_in("a", col, 3, 2, 2, names, imgs, 1);
    WgImage *o5 = px_in("c", col, 3, 2, 2, names, imgs, 1);
    WgImage *o6 = px_in("u < 0.5 ? c : rgb(0, 0, 1)", col, 3, 2, 2, names, imgs, 1);
    WgImage *o7 = px_in("lerp(c, rgb(1, 1, 1), 0.25)", col, 3, 2, 2, names, imgs, 1);
    WgImage *o8 = px_in("min(-c, -0.5) + abs(c)", col, 3, 2, 2, names, imgs, 1);
    WgImage *o9 = px_in("sample(c, u, v)", col, 3, 2, 2, names, imgs, 1);
    wgt_assert_identical(o5, c);
    /* at pixel centres up to the float rounding of u = (x + 0.5) / 3 */
    wgt_assert_near(o9, c, 1e-6);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 3; i++) {
            const float *p = &color_c[(j * 3 + i) * 4];
            float av = gray_a[j * 3 + i], u = (float)((i + 0.5) / 3), v = (j + 0.5f) / 2;
            const float e1[4] = {u, v, av, 1}, e2[4] = {1, 0.5f, 0.25f, 0.125f};
            const float e6[4] = {0, 0, 1, 1};
            for (int k = 0; k < 4; k++) {
                assert_float_equal(wgt_px(o1, i, j, k), e1[k], 0);
                assert_float_equal(wgt_px(o2, i, j, k), e2[k], 0);
                assert_float_equal(wgt_px(o3, i, j, k), p[k] * 0.5f, 0);
                assert_float_equal(wgt_px(o4, i, j, k), k == 3 ? 1 : av, 0);
                assert_float_equal(wgt_px(o6, i, j, k), u < 0.5f ? p[k] : e6[k], 0);
                assert_float_equal(wgt_px(o7, i, j, k), p[k] + (1 - p[k]) * 0.25f, 0);
                assert_float_equal(wgt_px(o8, i, j, k), fminf(-p[k], -0.5f) + p[k], 0);
            }
        }
    WgImage *outs[] = {o1, o2, o3, o4, o5, o6, o7, o8, o9};
    for (int i = 0; i < 9; i++) {
        assert_int_equal(outs[i]->channels, 4);
        wg_image_unref(outs[i]);
    }
    wg_image_unref(a);
    wg_image_unref(c);
}

static void test_extras_params_time(void **state)
{
    (void)state;
    const char *xml =
        "<wetgraph version=\"1\" size=\"4x2\">\n"
        "  <param name=\"k\" type=\"float\" default=\"0.25\"/>\n"
        "  <node id=\"n\" type=\"pixel\" freq=\"3\" b=\"=k*2\" expr=\"freq*x + b + $time + k\"/>\n"
        "  <output name=\"out\" from=\"n\"/>\n"
        "</wetgraph>\n";
    WgImage *o = render_xml(xml, 0.5, NULL, NULL, 1);
    WgImage *o2 = render_xml(xml, 2, "k", "1", 1);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 4; i++) {
            assert_float_equal(at(o, i, j), 3 * i + 0.5 + 0.5 + 0.25, 0);
            assert_float_equal(at(o2, i, j), 3 * i + 2 + 2 + 1, 0);
        }
    wg_image_unref(o);
    wg_image_unref(o2);
}

/* Inputs, then extras, then graph parameters, then u v x y. */
static void test_shadowing(void **state)
{
    (void)state;
    float seven[8] = {7, 7, 7, 7, 7, 7, 7, 7};
    WgImage *img = wgt_image(4, 2, 1, seven);
    const char *names[] = {"v"};
    const WgImage *imgs[] = {img};
    WgImage *o = px_in("v", "", 4, 2, 1, names, imgs, 1); /* the input, not the coordinate */
    const char *names2[] = {"freq"};
    WgImage *o2 = px_in("freq", "freq=\"3\"", 4, 2, 1, names2, imgs, 1); /* input over extra */
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 4; i++) {
            assert_float_equal(at(o, i, j), 7, 0);
            assert_float_equal(at(o2, i, j), 7, 0);
        }
    wg_image_unref(o);
    wg_image_unref(o2);
    wg_image_unref(img);
    const char *xml = "<wetgraph version=\"1\" size=\"4x2\">\n"
                      "  <param name=\"k\" type=\"float\" default=\"5\"/>\n"
                      "  <param name=\"u\" type=\"float\" default=\"9\"/>\n"
                      "  <node id=\"n\" type=\"pixel\" k=\"2\" expr=\"k * 100 + u + x\"/>\n"
                      "  <output name=\"out\" from=\"n\"/>\n"
                      "</wetgraph>\n";
    WgImage *o3 = render_xml(xml, 0, NULL, NULL, 1); /* extra k over param k; param u over u */
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 4; i++) assert_float_equal(at(o3, i, j), 200 + 9 + i, 0);
    wg_image_unref(o3);
}

/* ---- agreement with the double evaluator ------------------------------------------------- */

enum { S_A, S_B, S_CR, S_CG, S_CB, S_CA, S_U, S_V, S_X, S_Y, S_E1, S_E2, S_COUNT };
static const char *const slot_names[S_COUNT] = {"a", "b", "c.r", "c.g", "c.b", "c.a",
                                                "u", "v", "x",   "y",   "e1",  "e2"};

static bool ref_resolve(void *user, const char *name, size_t len, int *slot)
{
    (void)user;
    for (int i = 0; i < S_COUNT; i++)
        if (strlen(slot_names[i]) == len && !strncmp(slot_names[i], name, len)) {
            *slot = i;
            return true;
        }
    return false;
}

typedef struct {
    char s[8192];
    size_t n;
} Sb;

static void put(Sb *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(Sb *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(b->s + b->n, sizeof b->s - b->n, fmt, ap);
    va_end(ap);
    if (k > 0) b->n += (size_t)k;
    if (b->n >= sizeof b->s) fail_msg("expression too long");
}

/* A random expression without NaN sources (divisors, sqrt/log/pow/asin arguments are made
 * safe), using every operator and maths function. */
static void gen(Rng *r, int depth, Sb *b)
{
    if (depth == 0 || rnd(r) % 5 == 0) {
        int k = (int)(rnd(r) % 13);
        if (k == 12)
            put(b, "%.2f", rndf(r) * 4 - 2);
        else if (k == S_X || k == S_Y)
            put(b, "%s*0.1", slot_names[k]);
        else
            put(b, "%s", slot_names[k]);
        return;
    }
    static const char *const forms[] = {
        "(# + #)",
        "(# - #)",
        "(# * #)",
        "(# / (1.5 + abs(#)))",
        "(-#)",
        "sin(#)",
        "cos(#)",
        "atan(#)",
        "abs(#)",
        "exp(sin(#))",
        "sqrt(1 + abs(#))",
        "log(1 + abs(#))",
        "pow(1 + abs(#), sin(#))",
        "min(#, #)",
        "max(#, #, #)",
        "clamp(#, -0.5, 0.5)",
        "lerp(#, #, #)",
        "smoothstep(-1, 1, #)",
        "step(#, #)",
        "floor(#)",
        "ceil(#)",
        "fract(#)",
        "round(#)",
        "mod(#, 1.7)",
        "(# % 2)",
        "sign(#)",
        "(# < #)",
        "(# >= #)",
        "(# > # ? # : #)",
        "(# && #)",
        "(# || #)",
        "(!#)",
        "atan2(#, #)",
        "asin(clamp(#, -1, 1) * 0.9)",
        "acos(clamp(#, -1, 1) * 0.9)",
        "tan(clamp(#, -1.2, 1.2))",
        "(# ^ 2)",
        "pow(abs(#), 1.5)",
        "(round(#) == round(#))",
        "(floor(#) != #)",
        "(# <= #)",
        "min(#, #, #, #)",
        "mix(#, #, #)",
    };
    const char *f = forms[rnd(r) % (sizeof forms / sizeof forms[0])];
    for (; *f; f++) {
        if (*f == '#')
            gen(r, depth - 1, b);
        else
            put(b, "%c", *f);
    }
}

static bool is_boolean(const WgExprNode *n)
{
    return n->op >= WG_EX_LT && n->op <= WG_EX_OR ? true : n->op == WG_EX_NOT;
}

static double dist_int(double x)
{
    return fabs(x - floor(x + 0.5));
}

/* The value is a float: float evaluation gets it exactly when its operands were exact. */
static bool is_float(double v)
{
    return (double)(float)v == v;
}

static bool same_tree(const WgExprNode *p, const WgExprNode *q)
{
    if (p->op != q->op || p->nargs != q->nargs) return false;
    if (p->op == WG_EX_NUM) return p->value == q->value;
    if (p->op == WG_EX_VAR) return p->slot == q->slot;
    if (p->op == WG_EX_CALL && p->func != q->func) return false;
    for (int i = 0; i < p->nargs; i++)
        if (!same_tree(p->args[i], q->args[i])) return false;
    return true;
}

/* Double evaluation that also tracks the largest intermediate magnitude (*big) and the
 * distance to the nearest discontinuity (*margin). *exact tells that float evaluation gets
 * this very value (floats combined without rounding, integers from floor or comparisons...):
 * a discontinuity at an exact value is no risk, float lands on the same side. The value must
 * equal wg_expr_eval's. */
static double walk(const WgExprNode *n, const double *slots, double *big, double *margin,
                   bool *exact)
{
    double a[4] = {0}, r;
    bool ex[4] = {false};
#define NEAR(d, exact_arg)                                                                         \
    do {                                                                                           \
        if (!(exact_arg)) *margin = fmin(*margin, (d));                                            \
    } while (0)
    if (n->op == WG_EX_NUM) {
        r = n->value;
        *exact = is_float(r);
    } else if (n->op == WG_EX_VAR) {
        r = slots[n->slot];
        *exact = n->slot != S_E1 && n->slot != S_E2; /* images, u v x y (power-of-two size) */
    } else if (n->op == WG_EX_COND) {
        double c = walk(n->args[0], slots, big, margin, &ex[0]);
        if (!is_boolean(n->args[0])) NEAR(fabs(c), ex[0]);
        double t = walk(n->args[1], slots, big, margin, &ex[1]);
        double e = walk(n->args[2], slots, big, margin, &ex[2]);
        r = c != 0 ? t : e;
        *exact = c != 0 ? ex[1] : ex[2];
    } else {
        bool all = true;
        for (int i = 0; i < n->nargs; i++) {
            a[i] = walk(n->args[i], slots, big, margin, &ex[i]);
            all &= ex[i];
        }
        if (n->op == WG_EX_CALL) {
            r = wg_expr_call(n->func, a, n->nargs);
            *exact = false;
            switch (n->func) {
            case WG_FN_FLOOR:
            case WG_FN_CEIL:
                NEAR(dist_int(a[0]), ex[0]);
                *exact = true;
                break;
            case WG_FN_ROUND:
                NEAR(dist_int(a[0] + 0.5), ex[0]);
                *exact = true;
                break;
            case WG_FN_FRACT:
                NEAR(dist_int(a[0]), ex[0]);
                *exact = all && is_float(r);
                break;
            case WG_FN_MOD:
                NEAR(dist_int(a[0] / a[1]) * fabs(a[1]), all || (ex[0] && a[0] == 0));
                *exact = all && is_float(r);
                break;
            case WG_FN_SIGN:
                NEAR(fabs(a[0]), ex[0]);
                *exact = true;
                break;
            case WG_FN_STEP:
                NEAR(fabs(a[1] - a[0]), all || same_tree(n->args[0], n->args[1]));
                *exact = true;
                break;
            case WG_FN_ATAN2:
                if (a[1] < 0) NEAR(fabs(a[0]), false);
                NEAR(hypot(a[0], a[1]), false);
                break;
            case WG_FN_ABS:
                *exact = ex[0];
                break;
            case WG_FN_MIN:
            case WG_FN_MAX:
            case WG_FN_CLAMP: /* the result is one of the arguments */
                for (int i = 0; i < n->nargs && !*exact; i++) *exact = a[i] == r && ex[i];
                break;
            default:
                break;
            }
        } else {
            r = wg_expr_apply(n->op, a[0], a[1]);
            *exact = all && is_float(r);
            if (n->op == WG_EX_MUL && ((ex[0] && a[0] == 0) || (ex[1] && a[1] == 0)))
                *exact = true; /* 0 * x is 0 in float too */
            if (n->op == WG_EX_MOD)
                NEAR(dist_int(a[0] / a[1]) * fabs(a[1]), all || (ex[0] && a[0] == 0));
            if (n->op == WG_EX_POW) *exact = false;
            if (n->op >= WG_EX_LT && n->op <= WG_EX_NE)
                NEAR(fabs(a[0] - a[1]), all || same_tree(n->args[0], n->args[1]));
            if (n->op >= WG_EX_LT && n->op <= WG_EX_OR) *exact = true;
            if (n->op == WG_EX_AND || n->op == WG_EX_OR || n->op == WG_EX_NOT) {
                *exact = true;
                for (int i = 0; i < n->nargs; i++)
                    if (!is_boolean(n->args[i])) NEAR(fabs(a[i]), ex[i]);
            }
        }
    }
#undef NEAR
    if (fabs(r) > *big) *big = fabs(r);
    return r;
}

static double rand_gray(int x, int y, int k)
{
    (void)k;
    Rng r = {(uint64_t)(y * 131 + x) * 2654435761u + 17};
    rnd(&r);
    return (float)(rndf(&r) * 4 - 2);
}

static double rand_color(int x, int y, int k)
{
    Rng r = {(uint64_t)((y * 131 + x) * 4 + k) * 2246822519u + 5};
    rnd(&r);
    return (float)rndf(&r);
}

static double rand_gray2(int x, int y, int k)
{
    return rand_gray(y + 40, x + 3, k);
}

static void test_random_expressions_match_double_evaluator(void **state)
{
    (void)state;
    enum { W = 16, H = 8, N = 400 };
    WgImage *a = wgt_image_fn(W, H, 1, rand_gray), *b = wgt_image_fn(W, H, 1, rand_gray2);
    WgImage *c = wgt_image_fn(W, H, 4, rand_color);
    const char *names[] = {"a", "b", "c"};
    const WgImage *imgs[] = {a, b, c};
    const double e1 = 0.7, e2 = -1.3;
    Rng r = {12345};
    long compared = 0, skipped = 0;
    double worst = 0;
    char worst_expr[8192] = "";
    for (int t = 0; t < N; t++) {
        Sb sb = {.n = 0};
        gen(&r, 2 + (int)(rnd(&r) % 4), &sb);
        WgImage *o = px_in(sb.s, "e1=\"0.7\" e2=\"-1.3\"", W, H, 3, names, imgs, 1);
        WgExprOptions opt = {ref_resolve, NULL, false};
        WgExpr *e = NULL;
        WgError err = {0};
        if (wg_expr_parse(sb.s, &opt, &e, &err))
            fail_msg("reference parse of '%s': %s", sb.s, err.message);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double s[S_COUNT] = {at(a, x, y),
                                     at(b, x, y),
                                     wgt_px(c, x, y, 0),
                                     wgt_px(c, x, y, 1),
                                     wgt_px(c, x, y, 2),
                                     wgt_px(c, x, y, 3),
                                     (x + 0.5) / W,
                                     (y + 0.5) / H,
                                     x,
                                     y,
                                     e1,
                                     e2};
                double big = 0, margin = INFINITY;
                double ref = wg_expr_eval(e, s);
                bool exact;
                double w = walk(e->root, s, &big, &margin, &exact);
                if (memcmp(&w, &ref, sizeof w)) fail_msg("walker disagrees on '%s'", sb.s);
                if (!isfinite(ref)) fail_msg("generator made a non-finite value: '%s'", sb.s);
                if (margin < 1e-5 * (1 + big)) {
                    skipped++;
                    continue;
                }
                compared++;
                double got = at(o, x, y), rel = fabs(got - ref) / (1 + big);
                if (rel > worst) {
                    worst = rel;
                    snprintf(worst_expr, sizeof worst_expr, "%s at (%d,%d): %.9g vs %.9g", sb.s, x,
                             y, got, ref);
                }
                if (!(rel <= 2e-6))
                    fail_msg("'%s' at (%d,%d): %.9g vs double %.17g (S = %g)", sb.s, x, y, got, ref,
                             big);
            }
        wg_expr_free(e);
        wg_image_unref(o);
    }
    print_message("random expressions: %ld samples compared, %ld skipped near a discontinuity, "
                  "max |error| / (1 + S) = %.3g\n  worst: %s\n",
                  compared, skipped, worst, worst_expr);
    assert_true(skipped * 20 < compared); /* the skip rule must not hollow the test out */
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(c);
}

/* Special values through the exact functions: same bits as the double evaluator rounded to
 * float, including NaN ordering in min/max, signed zeros and huge values. */
static void test_special_values(void **state)
{
    (void)state;
    static const float vals[] = {
        0.0f,        -0.0f,        0.5f,       -0.5f,       1.5f,       -1.5f, 2.5f,   -2.5f,
        0.49999997f, -0.49999997f, 8388607.5f, -8388607.5f, 8388608.0f, 1e30f, -1e30f, 1e-40f,
        -1e-40f,     INFINITY,     -INFINITY,  NAN,         3.0f,       -3.0f, 0.7f,   -0.7f};
    enum { N = sizeof vals / sizeof vals[0] };
    WgImage *a = wgt_image(N, 1, 1, vals);
    float rev[N];
    for (int i = 0; i < N; i++) rev[i] = vals[N - 1 - i];
    WgImage *b = wgt_image(N, 1, 1, rev);
    const char *names[] = {"a", "b"};
    const WgImage *imgs[] = {a, b};
    static const struct {
        const char *expr;
        WgExprFunc f;
        int nargs;
    } cases[] = {
        {"floor(a)", WG_FN_FLOOR, 1},
        {"ceil(a)", WG_FN_CEIL, 1},
        {"round(a)", WG_FN_ROUND, 1},
        {"sign(a)", WG_FN_SIGN, 1},
        {"abs(a)", WG_FN_ABS, 1},
        {"min(a, b)", WG_FN_MIN, 2},
        {"max(a, b)", WG_FN_MAX, 2},
        {"step(a, b)", WG_FN_STEP, 2},
        {"clamp(a, -1, b)", WG_FN_CLAMP, 3},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        WgImage *o = px_in(cases[k].expr, "allow_nonfinite=\"true\"", N, 1, 2, names, imgs, 1);
        for (int i = 0; i < N; i++) {
            double args[3] = {vals[i], cases[k].nargs == 3 ? -1 : rev[i], rev[i]};
            float want = (float)wg_expr_call(cases[k].f, args, cases[k].nargs);
            float got = at(o, i, 0);
            if (memcmp(&want, &got, sizeof got) && !(isnan(want) && isnan(got)))
                fail_msg("%s with a = %a, b = %a: %a, expected %a", cases[k].expr, vals[i], rev[i],
                         got, want);
        }
        wg_image_unref(o);
    }
    /* fract and mod: within one float ulp of the double result (one rounding vs two) */
    WgImage *f = px_in("fract(a)", "allow_nonfinite=\"true\"", N, 1, 2, names, imgs, 1);
    WgImage *m = px_in("mod(a, 0.75)", "allow_nonfinite=\"true\"", N, 1, 2, names, imgs, 1);
    for (int i = 0; i < N; i++) {
        double x = vals[i];
        float wf = (float)(x - floor(x)), wm = (float)(x - 0.75 * floor(x / 0.75));
        float gf = at(f, i, 0), gm = at(m, i, 0);
        if (isnan(wf))
            assert_true(isnan(gf));
        else if (!(fabsf(gf - wf) <= fmaxf(nextafterf(fabsf(wf), INFINITY) - fabsf(wf), 0)))
            fail_msg("fract(%a) = %a, expected %a", vals[i], gf, wf);
        if (isnan(wm))
            assert_true(isnan(gm));
        else if (fabs(x) < 1e6 && !(fabsf(gm - wm) <= 1e-6f)) /* float32: x/0.75 < 2^21 */
            fail_msg("mod(%a, 0.75) = %a, expected %a", vals[i], gm, wm);
    }
    wg_image_unref(f);
    wg_image_unref(m);
    wg_image_unref(a);
    wg_image_unref(b);
}

/* ---- sample() and noise() ---------------------------------------------------------------- */

static double bilinear_ref(const WgImage *img, int ch, double u, double v)
{
    int w = img->width, h = img->height;
    double px = u * w - 0.5, py = v * h - 0.5;
    double fx = floor(px), fy = floor(py), tx = px - fx, ty = py - fy;
    long x0 = (long)fx % w, y0 = (long)fy % h;
    if (x0 < 0) x0 += w;
    if (y0 < 0) y0 += h;
    long x1 = (x0 + 1) % w, y1 = (y0 + 1) % h;
    return (1 - tx) * (1 - ty) * wgt_px(img, (int)x0, (int)y0, ch) +
           tx * (1 - ty) * wgt_px(img, (int)x1, (int)y0, ch) +
           (1 - tx) * ty * wgt_px(img, (int)x0, (int)y1, ch) +
           tx * ty * wgt_px(img, (int)x1, (int)y1, ch);
}

static void test_sample(void **state)
{
    (void)state;
    enum { W = 5, H = 3 }; /* inputs arrive at the node's size: keep them the same */
    WgImage *a = wgt_image_fn(W, H, 1, rand_color), *c = wgt_image_fn(W, H, 4, rand_color);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    WgImage *a2 = wgt_image_fn(13, 7, 1, rand_color), *c2 = wgt_image_fn(13, 7, 4, rand_color);
    const WgImage *imgs2[] = {a2, c2};
    /* whole-pixel shifts wrap exactly */
    WgImage *s = px_in("sample(a, u + 0.2, v - 1/3)", "", W, H, 2, names, imgs, 1);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            assert_float_equal(at(s, x, y), at(a, (x + 1) % W, (y + H - 1) % H), 1e-6);
    wg_image_unref(s);
    /* arbitrary coordinates, far outside [0,1), against float64; and a row-uniform sample */
    struct {
        const char *expr;
        int ch;
        double ku, cu, kv, cv;
    } cases[] = {
        {"sample(a, u*3.7 - 1.2, v*2.3 + 5.1)", 0, 3.7, -1.2, 2.3, 5.1},
        {"sample(c.b, -u*0.61 + 0.05, v*1.9 - 7.25)", 2, -0.61, 0.05, 1.9, -7.25},
        {"sample(a, 0.3, v*0.5)", 0, 0, 0.3, 0.5, 0},
        {"sample(c.a, 123.456, -u)", 3, 0, 123.456, 0, 0},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        WgImage *o = px_in(cases[k].expr, "", 13, 7, 2, names, imgs2, 1);
        const WgImage *src = k == 0 || k == 2 ? a2 : c2;
        for (int y = 0; y < 7; y++)
            for (int x = 0; x < 13; x++) {
                double u = (x + 0.5) / 13, v = (y + 0.5) / 7;
                double su = cases[k].ku * u + cases[k].cu, sv = cases[k].kv * v + cases[k].cv;
                if (k == 3) sv = -u;
                double want = bilinear_ref(src, cases[k].ch, su, sv);
                if (!(fabs(at(o, x, y) - want) <= 2e-5))
                    fail_msg("%s at (%d,%d): %.9g, float64 %.9g", cases[k].expr, x, y, at(o, x, y),
                             want);
            }
        wg_image_unref(o);
    }
    /* non-finite coordinates give 0 */
    WgImage *nf = px_in("sample(a, 1/0, v) + sample(a, u, 0/0)", "", 4, 4, 2, names, imgs, 1);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) assert_float_equal(at(nf, x, y), 0, 0);
    wg_image_unref(nf);
    wg_image_unref(a);
    wg_image_unref(c);
    wg_image_unref(a2);
    wg_image_unref(c2);
}

static void test_noise(void **state)
{
    (void)state;
    const char *raw = "allow_nonfinite=\"true\"";
    WgImage *n = px("noise(u, v, 4)", raw, 64, 64);
    WgImage *shifted = px("noise(u + 3, v - 2, 4)", raw, 64, 64);
    WgImage *rounded = px("noise(u, v, 4.3)", raw, 64, 64);
    WgImage *again = px("noise(u, v, 4)", raw, 64, 64);
    WgImage *seeded = px("noise(u, v, 4)", "seed=\"99\"", 64, 64);
    wgt_assert_near(n, shifted, 2e-6);              /* periodic: tiles */
    wgt_assert_identical(n, rounded);               /* the period is round(scale) */
    wgt_assert_identical(n, again);                 /* deterministic */
    assert_true(wgt_max_abs_diff(n, seeded) > 0.2); /* depends on the seed */
    wgt_assert_range(n, 0, 1);
    double sum = 0, sum2 = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            sum += at(n, x, y);
            sum2 += at(n, x, y) * at(n, x, y);
        }
    double mean = sum / 4096, sd = sqrt(sum2 / 4096 - mean * mean);
    assert_true(mean > 0.35 && mean < 0.65);
    assert_true(sd > 0.05);
    /* lattice points are exactly 0.5 (gradient noise is zero there) */
    WgImage *lattice = px("noise(floor(u*4)/4, 0.75, 4)", "", 8, 2);
    for (int x = 0; x < 8; x++) assert_float_equal(at(lattice, x, 0), 0.5, 0);
    /* seamless across the edge: the last column continues into the first */
    WgImage *edge = px("noise(1 - 1e-4, v, 8) - noise(-1e-4, v, 8)", raw, 2, 32);
    for (int y = 0; y < 32; y++) assert_float_equal(at(edge, 0, y), 0, 1e-5);
    /* the same as the shared scalar function */
    uint32_t s = wg__px_seed(0);
    for (int y = 0; y < 64; y += 7)
        for (int x = 0; x < 64; x += 5)
            assert_float_equal(at(n, x, y),
                               wg__px_noise(s, (float)((x + 0.5) / 64), (float)((y + 0.5) / 64), 4),
                               0);
    WgImage *imgs[] = {n, shifted, rounded, again, seeded, lattice, edge};
    for (int i = 0; i < 7; i++) wg_image_unref(imgs[i]);
}

/* ---- errors ------------------------------------------------------------------------------ */

/* `name = expression;` statements before the result: the same pixels as the expression with
 * each name written out, colours as well as numbers, and a name reused by later statements. */
static void test_statements(void **state)
{
    (void)state;
    WgImage *c = wgt_image_fn(7, 5, 4, rand_color);
    const char *names[] = {"c"};
    const WgImage *imgs[] = {c};
    static const char *const pairs[][2] = {
        {"a = x * 2.5 + y; b = sin(a) * a; b - a / (1 + b * b)",
         "sin(x * 2.5 + y) * (x * 2.5 + y) - (x * 2.5 + y) / (1 + (sin(x * 2.5 + y) * "
         "(x * 2.5 + y)) * (sin(x * 2.5 + y) * (x * 2.5 + y)))"},
        {"  k2 =u*u ;\n k3 = k2 * u;k3 + k2", "u * u * u + u * u"},
        {"t = c.g > 0.5; t ? c.r : c.b == 0.25", "c.g > 0.5 ? c.r : c.b == 0.25"},
        {"m = (u + v) / 2; m == 0.5 ? 1 : m", "(u + v) / 2 == 0.5 ? 1 : (u + v) / 2"},
    };
    for (int i = 0; i < 4; i++) {
        WgImage *a = px_in(pairs[i][0], "", 7, 5, 1, names, imgs, 1);
        WgImage *b = px_in(pairs[i][1], "", 7, 5, 1, names, imgs, 1);
        wgt_assert_identical(a, b);
        wg_image_unref(a);
        wg_image_unref(b);
    }
    WgImage *a =
        px_in("h = c * 0.5; g = rgb(u, v, 0); h + g", "kind=\"color\"", 7, 5, 1, names, imgs, 2);
    WgImage *b = px_in("c * 0.5 + rgb(u, v, 0)", "kind=\"color\"", 7, 5, 1, names, imgs, 2);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(c);
}

static void test_statement_errors(void **state)
{
    (void)state;
    WgImage *a = wgt_image(4, 4, 1, NULL), *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    px_fails("k = 1;", "", 2, names, imgs, WG_ERR_PARSE, 7, "must end with its result");
    px_fails("k = 1; j = 2", "", 2, names, imgs, WG_ERR_PARSE, 7, "must end with its result");
    px_fails("u + 1; 2", "", 2, names, imgs, WG_ERR_PARSE, 1, "must define a name");
    px_fails("k = 1; k = 2; k", "", 2, names, imgs, WG_ERR_PARSE, 8, "already defined");
    px_fails("k = 1; a = 2; k", "", 2, names, imgs, WG_ERR_PARSE, 8, "already names an input");
    px_fails("u = 1; u", "", 2, names, imgs, WG_ERR_PARSE, 1, "already names");
    px_fails("f = 1; f", "f=\"3\"", 2, names, imgs, WG_ERR_PARSE, 1, "already names");
    /* columns count in the whole expr: the error in the second statement's right side */
    px_fails("k = 1; j = k + zz; j", "", 2, names, imgs, WG_ERR_PARSE, 16, "unknown name 'zz'");
    px_fails("k = 1; j = c; j > 0", "", 2, names, imgs, WG_ERR_TYPE, 15,
             "'j' is a colour but '>' needs a number");
    px_fails("s = 1; sample(s, u, v)", "", 2, names, imgs, WG_ERR_TYPE, 15, "a local name");
    px_fails("k = c; k", "", 2, names, imgs, WG_ERR_TYPE, 8, "kind is \"gray\"");
    wg_image_unref(a);
    wg_image_unref(c);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *a = wgt_image(4, 4, 1, NULL), *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    /* undefined names */
    px_fails("1 + fre * 2", "freq=\"1\"", 2, names, imgs, WG_ERR_PARSE, 5, "unknown name 'fre'");
    px_fails("a.r", "", 2, names, imgs, WG_ERR_PARSE, 1, "input 'a' is gray");
    px_fails("c.x", "", 2, names, imgs, WG_ERR_PARSE, 1, "unknown name 'c.x'");
    /* arity */
    px_fails("u + clamp(u, 0)", "", 2, names, imgs, WG_ERR_PARSE, 5,
             "'clamp' takes 3 arguments, got 2");
    px_fails("noise(u, v)", "", 2, names, imgs, WG_ERR_PARSE, 1, "'noise' takes 3 arguments");
    px_fails("rgb(u, v, 0, 1)", "", 2, names, imgs, WG_ERR_PARSE, 1, "'rgb' takes 3 arguments");
    /* a colour where a number is needed */
    px_fails("c > 0.5", "", 2, names, imgs, WG_ERR_TYPE, 1,
             "'c' is a colour but '>' needs a number");
    px_fails("u + noise(c, v, 4)", "", 2, names, imgs, WG_ERR_TYPE, 11,
             "argument 1 of noise() needs a number");
    px_fails("c ? 1 : 0", "", 2, names, imgs, WG_ERR_TYPE, 1, "the condition of '?:'");
    px_fails("rgb(c, 0, 0)", "kind=\"color\"", 2, names, imgs, WG_ERR_TYPE, 5,
             "argument 1 of rgb()");
    px_fails("u < 0.5 ? 1 : c", "kind=\"color\"", 2, names, imgs, WG_ERR_TYPE, 15,
             "other branch of '?:' is a number");
    px_fails("sample(a, c, v)", "", 2, names, imgs, WG_ERR_TYPE, 11, "u coordinate of sample()");
    /* sample of something that is not an input */
    px_fails("sample(freq, u, v)", "freq=\"2\"", 2, names, imgs, WG_ERR_TYPE, 8,
             "'freq' is an extra parameter");
    px_fails("1 + sample(u, u, v)", "", 2, names, imgs, WG_ERR_TYPE, 12, "'u' is a coordinate");
    px_fails("sample((a)*2, u, v)", "", 2, names, imgs, WG_ERR_TYPE, 9, "it is an expression");
    /* kind mismatch */
    px_fails("0.5 * rgb(u, v, 0)", "", 2, names, imgs, WG_ERR_TYPE, 7,
             "gives a colour (from 'rgb(...)') but kind is \"gray\"");
    px_fails("x + c", "kind=\"gray\"", 2, names, imgs, WG_ERR_TYPE, 5, "from 'c'");
    /* plain syntax */
    px_fails("u +", "", 2, names, imgs, WG_ERR_PARSE, 4, "unexpected end");
    /* reported by the check, before any evaluation */
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"8\">\n"
                          "  <node id=\"p\" type=\"pixel\" expr=\"u * speeed\" speed=\"2\"/>\n"
                          "  <output name=\"out\" from=\"p\"/>\n</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_check(r, &err), WG_ERR_PARSE);
    wgt_assert_error(&err, WG_ERR_PARSE, 2,
                     "node 'p' (pixel): expr column 5: unknown name 'speeed'");
    assert_int_equal(err.column, 5);
    wg_request_free(r);
    wg_graph_free(g);
    wg_image_unref(a);
    wg_image_unref(c);
}

/* ---- non-finite values ------------------------------------------------------------------- */

static void test_nonfinite(void **state)
{
    (void)state;
    enum { SAME, NAN_, PINF, NINF };
    static const struct {
        const char *expr;
        float clean;
        int raw; /* what allow_nonfinite="true" writes */
    } cases[] = {
        {"1 / (u - u)", FLT_MAX, PINF}, /* varying inf */
        {"-1 / (x - x)", -FLT_MAX, NINF},
        {"0 / (u - u)", 0, NAN_}, /* varying NaN */
        {"0 / 0", 0, NAN_},       /* folded NaN */
        {"log(u - 1)", 0, NAN_},  /* NaN from the domain */
        {"log(u - u)", -FLT_MAX, NINF},
        {"exp(100 + u)", FLT_MAX, PINF}, /* float overflow */
        {"sqrt(-u)", 0, NAN_},
        {"clamp(1 / (u - u), 0, 1)", 1, SAME},  /* inf inside is fine */
        {"(0 / (u - u)) > 1 ? 1 : 2", 2, SAME}, /* comparisons with NaN are false */
        {"(0 / (u - u)) ? 3 : 4", 3, SAME},     /* NaN counts as true */
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        WgImage *o = px(cases[k].expr, "", 3, 2);
        WgImage *raw = px(cases[k].expr, "allow_nonfinite=\"true\"", 3, 2);
        wgt_assert_range(o, -FLT_MAX, FLT_MAX);
        for (int y = 0; y < 2; y++)
            for (int x = 0; x < 3; x++) {
                float v = at(o, x, y), r = at(raw, x, y);
                if (v != cases[k].clean)
                    fail_msg("%s: %g, expected %g", cases[k].expr, v, cases[k].clean);
                bool ok = cases[k].raw == SAME   ? r == v
                          : cases[k].raw == NAN_ ? isnan(r)
                          : cases[k].raw == PINF ? isinf(r) && r > 0
                                                 : isinf(r) && r < 0;
                if (!ok) fail_msg("%s with allow_nonfinite: %g", cases[k].expr, r);
            }
        wg_image_unref(o);
        wg_image_unref(raw);
    }
    /* colour outputs are sanitised per channel */
    WgImage *c = px("rgba(1 / (u - u), 0 / (u - u), -1 / (u - u), 0.5)", "kind=\"color\"", 2, 2);
    for (int k = 0; k < 4; k++) {
        const float want[4] = {FLT_MAX, 0, -FLT_MAX, 0.5f};
        assert_float_equal(wgt_px(c, 1, 1, k), want[k], 0);
    }
    wg_image_unref(c);
}

/* ---- threads, cache ---------------------------------------------------------------------- */

static void test_thread_count_invariance(void **state)
{
    (void)state;
    WgImage *a = wgt_image_fn(300, 70, 1, rand_gray), *c = wgt_image_fn(300, 70, 4, rand_color);
    const char *names[] = {"a", "c"};
    const WgImage *imgs[] = {a, c};
    const char *gray = "sample(a, u*1.3 + 0.1, v - 0.2) * noise(u, v, 8) + sin(x*0.01) * c.g + "
                       "(y % 7 == 3 ? 1 : 0) + smoothstep(0.2, 0.8, v) * a";
    const char *colour = "lerp(c, sample(c, u + 0.3, v*2), noise(u*2, v, 3)) * (1 + a)";
    WgImage *g1 = px_in(gray, "", 300, 70, 2, names, imgs, 1);
    WgImage *g4 = px_in(gray, "", 300, 70, 2, names, imgs, 4);
    WgImage *c1 = px_in(colour, "kind=\"color\"", 300, 70, 2, names, imgs, 1);
    WgImage *c4 = px_in(colour, "kind=\"color\"", 300, 70, 2, names, imgs, 4);
    wgt_assert_identical(g1, g4);
    wgt_assert_identical(c1, c4);
    wg_image_unref(g1);
    wg_image_unref(g4);
    wg_image_unref(c1);
    wg_image_unref(c4);
    wg_image_unref(a);
    wg_image_unref(c);
}

static WgImage *render_with(WgEngine *e, const WgGraph *g, const char *k, int *evaluated)
{
    WgError err = {0};
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    if (k && wg_request_set(r, "k", k, &err)) fail_msg("set: %s", err.message);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) fail_msg("render: %s", err.message);
    WgImage *out = wg_image_ref(wgt_output(res, "out"));
    *evaluated = wg_result_evaluated_count(res);
    wg_result_free(res);
    wg_request_free(r);
    return out;
}

/* Only the names the expression reads are in the node's key: a change of another graph
 * parameter or of $time reuses it; a change of one it reads (also as $time) recomputes it. */
static void test_key_holds_only_names_read(void **state)
{
    (void)state;
    WgError err = {0};
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"4x2\">\n"
                          "  <param name=\"k\" type=\"float\" default=\"0.25\"/>\n"
                          "  <param name=\"kk\" type=\"float\" default=\"1\"/>\n"
                          "  <node id=\"a\" type=\"pixel\" expr=\"x + kk\"/>\n"
                          "  <node id=\"b\" type=\"pixel\" expr=\"x * $time\"/>\n"
                          "  <output name=\"out\" from=\"a\"/>\n"
                          "  <output name=\"timed\" from=\"b\"/>\n</wetgraph>\n");
    const struct {
        const char *k;
        double time;
        int evaluated; /* nodes computed */
    } steps[] = {{"0.25", 0, 2}, {"0.5", 0, 0}, {"0.5", 2, 1}, {"0.75", 2, 0}};
    for (int i = 0; i < 4; i++) {
        WgRequest *r = wg_request_new(g);
        if (wg_request_set(r, "k", steps[i].k, &err)) fail_msg("set: %s", err.message);
        wg_request_set_time(r, steps[i].time);
        WgResult *res = NULL;
        if (wg_render(e, r, &res, &err)) fail_msg("render: %s", err.message);
        if (wg_result_evaluated_count(res) != steps[i].evaluated)
            fail_msg("step %d: %d nodes computed, expected %d", i, wg_result_evaluated_count(res),
                     steps[i].evaluated);
        assert_float_equal(at(wgt_output(res, "timed"), 3, 0), 3 * steps[i].time, 0);
        wg_result_free(res);
        wg_request_free(r);
    }
    /* kk (read) changes: recomputed */
    WgRequest *r = wg_request_new(g);
    if (wg_request_set(r, "kk", "5", &err)) fail_msg("set: %s", err.message);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) fail_msg("render: %s", err.message);
    assert_float_equal(at(wgt_output(res, "out"), 2, 0), 7, 0);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    wg_engine_free(e);
}

static void test_cache_key(void **state)
{
    (void)state;
    WgError err = {0};
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"4x2\">\n"
                          "  <param name=\"k\" type=\"float\" default=\"0.25\"/>\n"
                          "  <node id=\"n\" type=\"pixel\" f=\"=k*4\" expr=\"x + k + f\"/>\n"
                          "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n");
    int ev;
    WgImage *o1 = render_with(e, g, NULL, &ev);
    assert_int_equal(ev, 1);
    WgImage *o2 = render_with(e, g, "0.5", &ev); /* graph param used directly and by an extra */
    assert_int_equal(ev, 1);
    WgImage *o3 = render_with(e, g, "0.25", &ev); /* back: from the cache */
    assert_int_equal(ev, 0);
    for (int x = 0; x < 4; x++) {
        assert_float_equal(at(o1, x, 1), x + 0.25 + 1, 0);
        assert_float_equal(at(o2, x, 1), x + 0.5 + 2, 0);
    }
    wgt_assert_identical(o1, o3);
    wg_graph_free(g);
    /* the same graph but for one extra attribute, same file, same engine */
    const char *fmt = "<wetgraph version=\"1\" size=\"4x2\">\n"
                      "  <node id=\"n\" type=\"pixel\" f=\"%s\" expr=\"x * f\"/>\n"
                      "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n";
    char xml[512];
    snprintf(xml, sizeof xml, fmt, "2");
    g = wgt_load(xml);
    WgImage *o4 = render_with(e, g, NULL, &ev);
    wg_graph_free(g);
    snprintf(xml, sizeof xml, fmt, "3");
    g = wgt_load(xml);
    WgImage *o5 = render_with(e, g, NULL, &ev);
    assert_int_equal(ev, 1);
    wg_graph_free(g);
    for (int x = 0; x < 4; x++) {
        assert_float_equal(at(o4, x, 0), 2 * x, 0);
        assert_float_equal(at(o5, x, 0), 3 * x, 0);
    }
    WgImage *all[] = {o1, o2, o3, o4, o5};
    for (int i = 0; i < 5; i++) wg_image_unref(all[i]);
    wg_engine_free(e);
}

/* ---- the compiled program ---------------------------------------------------------------- */

static WgPxProgram *compile(const char *src, int channels)
{
    static const char *const extra_names[] = {"freq"};
    static const double extra_values[] = {2};
    static const char *const scope_names[] = {"$time", "$width", "$height"};
    static const double scope_values[] = {0.5, 16, 8};
    WgNodeContext ctx = {
        .node_id = "t",
        .width = 16,
        .height = 8,
        .seed = 1,
        .n_extra = 1,
        .extra_names = extra_names,
        .extra_values = extra_values,
        .n_scope = 3,
        .scope_names = scope_names,
        .scope_values = scope_values,
    };
    WgPxProgram *p = NULL;
    WgError err = {0};
    if (wg__px_compile(&ctx, src, channels, NULL, &p, &err))
        fail_msg("compile '%s': %s", src, err.message);
    return p;
}

static void assert_ops(const WgPxProgram *p, const int *list, int n, const WgPxOp *want, int count,
                       const char *what)
{
    if (n != count) fail_msg("%s: %d operations, expected %d", what, n, count);
    for (int i = 0; i < n; i++)
        if (p->vals[list[i]].op != want[i])
            fail_msg("%s: operation %d is %s, expected %s", what, i,
                     wg__px_op_name(p->vals[list[i]].op), wg__px_op_name(want[i]));
}

static void test_compiled_program(void **state)
{
    (void)state;
    /* constants folded in double, with the scalar evaluator's functions */
    WgPxProgram *p = compile("sin(freq * $time) * u + (freq + 1) * $width", 1);
    const WgPxOp fold[] = {WG_PX_U, WG_PX_MUL, WG_PX_ADD};
    assert_ops(p, p->varying, p->n_varying, fold, 3, "folding");
    assert_int_equal(p->n_uniform, 0);
    const WgPxVal *mul = &p->vals[p->varying[1]], *add = &p->vals[p->varying[2]];
    assert_true(p->vals[mul->args[0]].value == sin(1.0));
    assert_true(p->vals[add->args[1]].value == 48);
    assert_int_equal(mul->scalars, 1); /* the constant is read as one float */
    wg__px_free(p);
    /* row-uniform parts run once per row */
    p = compile("sin(v * 2) + y + u", 1);
    const WgPxOp uni[] = {WG_PX_V, WG_PX_MUL, WG_PX_SIN, WG_PX_Y, WG_PX_ADD};
    const WgPxOp var[] = {WG_PX_U, WG_PX_ADD};
    assert_ops(p, p->uniform, p->n_uniform, uni, 5, "uniform");
    assert_ops(p, p->varying, p->n_varying, var, 2, "varying");
    wg__px_free(p);
    /* shared subexpressions, x^2 as a product, constant conditions, dead branches */
    p = compile("u*u + u^2 + (freq > 1 ? x : sin(x))", 1);
    const WgPxOp cse[] = {WG_PX_U, WG_PX_MUL, WG_PX_ADD, WG_PX_X, WG_PX_ADD};
    assert_ops(p, p->varying, p->n_varying, cse, 5, "sharing");
    wg__px_free(p);
    /* a long chain needs few registers */
    p = compile("((((((u + 1) * 2 + 3) * 4 + 5) * 6 + 7) * 8 + 9) * x + x * x) * u", 1);
    /* live at once at most: u, x, the chain and x*x */
    assert_int_equal(p->n_varying, 15);
    assert_int_equal(p->n_regs, 4);
    wg__px_free(p);
    /* colours are four scalar values; a number for kind="color" is gray, alpha 1 */
    p = compile("rgb(u, u * 2, u)", 4);
    assert_int_equal(p->out[0], p->out[2]);
    assert_true(p->vals[p->out[3]].op == WG_PX_CONST && p->vals[p->out[3]].value == 1);
    assert_int_equal(p->n_varying, 2);
    wg__px_free(p);
    p = compile("x", 4);
    assert_int_equal(p->out[0], p->out[1]);
    assert_int_equal(p->out[1], p->out[2]);
    assert_true(p->vals[p->out[3]].value == 1);
    wg__px_free(p);
}

/* A flat chain is a loop for the compiler, not recursion: 50,000 terms compile (sharing through
 * a hash set, so in linear time) and render; nesting is limited by the parser. */
static void test_long_expressions(void **state)
{
    (void)state;
    enum { TERMS = 50000 };
    size_t cap = 8 * TERMS + 512;
    char *xml = malloc(cap), *p = xml;
    assert_non_null(xml);
    p += sprintf(p, "<wetgraph version=\"1\" size=\"8x2\">\n"
                    "  <node id=\"n\" type=\"pixel\" expr=\"x");
    for (int i = 1; i < TERMS; i++) p += sprintf(p, i % 2 ? " + x" : " - y");
    sprintf(p, "\"/>\n  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n");
    WgImage *o = render_xml(xml, 0, NULL, NULL, 2);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 8; i++)
            assert_float_equal(at(o, i, j), (TERMS / 2 + 1) * i - (TERMS / 2 - 1) * j, 0);
    wg_image_unref(o);
    free(xml);
    /* each term is a new value: x, x + x, x + x - y, ... (y and the differences are uniform) */
    char *src = malloc(6 * TERMS);
    assert_non_null(src);
    p = src + sprintf(src, "x");
    for (int i = 1; i < TERMS; i++) p += sprintf(p, "+x");
    WgPxProgram *prog = compile(src, 1);
    assert_int_equal(prog->n_varying, TERMS);
    assert_int_equal(prog->n_regs, 3); /* x, the sum so far, the next sum */
    wg__px_free(prog);
    free(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_coordinates),
        cmocka_unit_test(test_inputs_and_channels),
        cmocka_unit_test(test_colour_results),
        cmocka_unit_test(test_extras_params_time),
        cmocka_unit_test(test_shadowing),
        cmocka_unit_test(test_random_expressions_match_double_evaluator),
        cmocka_unit_test(test_special_values),
        cmocka_unit_test(test_sample),
        cmocka_unit_test(test_noise),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_nonfinite),
        cmocka_unit_test(test_thread_count_invariance),
        cmocka_unit_test(test_cache_key),
        cmocka_unit_test(test_key_holds_only_names_read),
        cmocka_unit_test(test_statements),
        cmocka_unit_test(test_statement_errors),
        cmocka_unit_test(test_compiled_program),
        cmocka_unit_test(test_long_expressions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
