/* SPDX-License-Identifier: MIT */
/* `distance`, `dilate` and `erode`: an exact Euclidean distance transform of a gray mask (a pixel
 * is a site when its value is >= 0.5), periodic by default, and the morphology built on it.
 * Algorithm: Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled Functions", Theory of
 * Computing 8 (2012): a 1-D pass down each column gives, for every pixel, the nearest site row
 * in its column; a 1-D lower envelope of parabolas along each row then gives the nearest site.
 * All of it is exact integer arithmetic on squared distances between pixel centres (an envelope
 * breakpoint is a rational whose floor a multiplication by a reciprocal and an integer check get
 * exactly, see breakpoint()); the square root is taken once, per output pixel. Wrap-around: the
 * column pass walks each column as a ring; the row pass puts each column's site at its images x -
 * W, x, x + W as well, keeping those that can matter (within W/2 of the row, and beyond an edge no
 * further than the row's nearest in-image site, see reach()), so every pixel sees the nearest image
 * of every site, across the tile edges and corners too. Without wrap the image edges are not
 * crossed. Ties (several nearest sites) go to the site with the smallest (y, x), its row then its
 * column in the image: the column pass keeps the smallest tied row and the envelope orders equal
 * parabolas by that key at their breakpoints, so the result is the brute-force answer, whatever the
 * thread count (columns and rows are independent, split in chunks fixed by the size). Cost: O(W·H)
 * whatever the mask and the distance; each row's values are painted a parabola at a time over the
 * columns where it is lowest. Measured at 2048², 2 threads, release build, median of 15 on an AMD
 * EPYC VM with 2 cores (bench/bench_distance, node time only): random blobs (half covered)
 * 16.7-17.1 ms in pixels or falloff mode, 16.0-16.2 without wrap, 16.3-16.7 for dilate and
 * erode; 411 sparse seeds 8.1 ms; signed mode runs the transform twice (33.7-34.2 ms); the
 * Voronoi fill of a colour source 21.1-21.2 ms (blobs) and 9.3-9.4 ms (seeds), mostly the 64 MB
 * colour output and source. */
#include "wetgraph/node.h"
#include "hot.h"

#include <math.h>
#include <stdatomic.h>
#include <string.h>

enum { MODE_FALLOFF, MODE_PIXELS, MODE_SIGNED };
static const char *const mode_values[] = {"falloff", "pixels", "signed", NULL};

typedef struct {
    int mode;
    float distance;
    bool wrap;
} DistanceParams;

typedef struct {
    float radius;
    bool wrap;
} MorphParams;

/* What the row pass writes for each pixel. */
enum { EMIT_PIXELS, EMIT_SUBTRACT, EMIT_FALLOFF, EMIT_FILL, EMIT_DILATE, EMIT_ERODE };

typedef struct {
    const WgImage *mask;
    const WgImage *source; /* EMIT_FILL */
    WgImage *out;
    int w, h;
    bool wrap, invert; /* invert: the sites are the pixels below 0.5 */
    int emit;
    double scale;  /* EMIT_FALLOFF: 1 / R in pixels; EMIT_DILATE / ERODE: r² in pixels */
    int16_t *near; /* w*h: nearest site row in the pixel's column (< 16384), -1 for none */
    double *inv;   /* inv[d] = 1 / d for the breakpoints' denominators d < 4 w */
    atomic_int nonempty_columns;
    atomic_int failed;
} Job;

enum { BAND = 512 };

/* Columns [x0, x1): forward sweep records the last site at or above each row, backward sweep the
 * first at or below; the nearer wins, a tie the smaller row. With wrap the sweeps continue from
 * the other end of the column (the last site minus H, the first plus H). */
HOT static void column_band(Job *j, int x0, int x1)
{
    int w = j->w, h = j->h, n = x1 - x0;
    int32_t first[BAND], last[BAND], next[BAND];
    for (int i = 0; i < n; i++) first[i] = last[i] = -1;
    for (int y = 0; y < h; y++) {
        const float *m = wg_image_row(j->mask, y) + x0;
        int16_t *o = j->near + (size_t)y * (size_t)w + x0;
        bool inv = j->invert;
        for (int i = 0; i < n; i++) { /* branch-free, so it vectorises */
            int site = (m[i] >= 0.5f) != inv;
            first[i] = site && first[i] < 0 ? y : first[i];
            last[i] = site ? y : last[i];
            o[i] = (int16_t)last[i];
        }
    }
    int nonempty = 0;
    for (int i = 0; i < n; i++) {
        nonempty += first[i] >= 0;
        next[i] = first[i] < 0 ? -1 : j->wrap ? first[i] + h : INT32_MAX;
        if (first[i] >= 0 && !j->wrap) last[i] = INT32_MIN / 2; /* no site above the first */
    }
    if (nonempty) atomic_fetch_add(&j->nonempty_columns, nonempty);
    for (int y = h - 1; y >= 0; y--) {
        int16_t *o = j->near + (size_t)y * (size_t)w + x0;
        for (int i = 0; i < n; i++) {
            if (first[i] < 0) continue; /* o[i] is already -1 */
            if (o[i] == y) {            /* a site */
                next[i] = y;
                continue;
            }
            long long a = o[i] >= 0 ? o[i] : (long long)last[i] - (j->wrap ? h : 0);
            long long b = next[i];
            long long da = y - a, db = b - y;
            long long ra = a < 0 ? a + h : a, rb = b >= h ? b - h : b;
            if (db < da || (db == da && rb < ra))
                o[i] = (int16_t)rb;
            else
                o[i] = (int16_t)ra;
        }
    }
}

/* Bands [b0, b1) of BAND columns: wide enough that each row visit reads whole cache lines and
 * pages, fixed by the width alone (never by the thread count). */
static void column_pass(void *user, int b0, int b1)
{
    Job *j = user;
    for (int b = b0; b < b1; b++) {
        int x0 = b * BAND, x1 = x0 + BAND < j->w ? x0 + BAND : j->w;
        column_band(j, x0, x1);
    }
}

/* One parabola of the lower envelope: site image at column q with squared vertical distance f,
 * the first column z where it wins, and the site's position in the image as the tie key
 * row << KEY_BITS | column (sides are at most 2^14, so comparing keys compares (row, column)). */
typedef struct {
    int q, z;
    int f;
    int key;
} Parabola;

enum { KEY_BITS = 14 };

/* First integer x where parabola b beats a (a.q < b.q): b is lower, or equal with a smaller key.
 * They are equal at s = num / den, den = 2 (b.q - a.q); the integer numerator is below 2^53, so
 * num times the double reciprocal of den (inv[den], from a table: a multiplication where a
 * division would stand on the envelope's chain of dependent steps) is within 1 of s, and the
 * integer steps after it give floor(s) exactly. */
static inline int breakpoint(const Parabola *a, const Parabola *b, const double *inv)
{
    if (a->f == b->f) { /* s = (a.q + b.q) / 2: common on the mask (f = 0), no division */
        int sum = a->q + b->q, t = sum >= 0 ? sum / 2 : -((1 - sum) / 2);
        return 2 * t == sum && b->key < a->key ? t : t + 1;
    }
    long long num = (long long)b->f + (long long)b->q * b->q - a->f - (long long)a->q * a->q;
    if (b->q - a->q == 1) { /* neighbouring columns (dense masks): s = num / 2 */
        long long t = (num - (num & 1)) / 2;
        return !(num & 1) && b->key < a->key ? (int)t : (int)t + 1;
    }
    long long den = 2 * (long long)(b->q - a->q);
    long long t = (long long)((double)num * inv[den]);
    while (t * den > num) t--;
    while ((t + 1) * den <= num) t++;
    return t * den == num && b->key < a->key ? (int)t : (int)t + 1;
}

/* Squared distances fit an int: at most 2 × 16383². */
HOT static void emit_row(const Job *j, int y, const int *d2, const int *key)
{
    int w = j->w;
    float *o = wg_image_row(j->out, y);
    switch (j->emit) {
    case EMIT_PIXELS:
        for (int x = 0; x < w; x++) o[x] = (float)sqrt((double)d2[x]);
        break;
    case EMIT_SUBTRACT: /* one of the two distances is 0: the difference is exact */
        for (int x = 0; x < w; x++) o[x] = (float)((double)o[x] - sqrt((double)d2[x]));
        break;
    case EMIT_FALLOFF:
        if (j->scale > 0) {
            double sc = j->scale;
            for (int x = 0; x < w; x++) {
                double v = 1 - sqrt((double)d2[x]) * sc; /* <= 1 already */
                o[x] = (float)(v > 0 ? v : 0);
            }
        } else {
            for (int x = 0; x < w; x++) o[x] = d2[x] == 0 ? 1.0f : 0.0f;
        }
        break;
    case EMIT_FILL: {
        const int m = (1 << KEY_BITS) - 1;
        if (j->out->channels == 1) {
            for (int x = 0; x < w; x++)
                o[x] = wg_image_row(j->source, key[x] >> KEY_BITS)[key[x] & m];
        } else {
            for (int x = 0; x < w; x++) {
                const float *s =
                    wg_image_row(j->source, key[x] >> KEY_BITS) + (size_t)(key[x] & m) * 4;
                memcpy(o + (size_t)x * 4, s, sizeof(float) * 4);
            }
        }
        break;
    }
    case EMIT_DILATE:
        for (int x = 0; x < w; x++) o[x] = (double)d2[x] <= j->scale ? 1.0f : 0.0f;
        break;
    case EMIT_ERODE:
        for (int x = 0; x < w; x++) o[x] = (double)d2[x] > j->scale ? 1.0f : 0.0f;
        break;
    }
}

/* Does parabola b beat a at x: lower there, or equal with a smaller key? */
static inline bool beats(const Parabola *b, const Parabola *a, long long x)
{
    long long db = x - b->q, da = x - a->q;
    long long vb = db * db + b->f, va = da * da + a->f;
    return vb < va || (vb == va && b->key < a->key);
}

/* Squared vertical distance from row y to the site row r of a column. */
static inline int fy(int y, int r, int h, bool wrap)
{
    int dy = y > r ? y - r : r - y;
    if (wrap && h - dy < dy) dy = h - dy;
    return dy * dy;
}

/* How far beyond the left (or right) edge of row y site images can matter: an image at q < 0
 * is beaten at every x >= 0 by the in-image site p minimising p² + f(p) =: b0 once
 * q² + f(q) > b0 (their difference grows with x), so images further than sqrt(b0) are left out;
 * and no image further than W/2 is ever the nearest one. */
static int reach(const int16_t *nr, int w, int h, int y, bool right)
{
    long long best = -1;
    for (int i = 0; i < w; i++) {
        if ((long long)i * i > best && best >= 0) break;
        int r = nr[right ? w - 1 - i : i];
        if (r < 0) continue;
        long long b = (long long)i * i + fy(y, r, h, true);
        if (best < 0 || b < best) best = b;
    }
    if (best < 0) return 0; /* no site in the row: the mask is empty and the row is not run */
    long long s = (long long)sqrt((double)best);
    while (s * s > best) s--;
    while ((s + 1) * (s + 1) <= best) s++;
    return s < w / 2 ? (int)s : w / 2;
}

/* Is the site at column x of row y flanked by sites of the same row on both sides (an edge of
 * the image counts as a site without wrap)? Its parabola then wins only at x itself, where the
 * sweep answers 0 directly: a neighbour at x ± 1 is strictly nearer to every other pixel of the
 * row. Leaving such sites out keeps the envelope to the mask's boundary, which makes dense masks
 * as cheap as sparse ones. */
static inline bool interior(const int16_t *nr, int w, int x, int y, bool wrap)
{
    if (w < 3) return false;
    int l = x - 1, r = x + 1;
    if (wrap) {
        l = l < 0 ? w - 1 : l;
        r = r >= w ? 0 : r;
    }
    return (l < 0 || nr[l] == y) && (r >= w || nr[r] == y);
}

/* Rows [y0, y1): the lower envelope of the columns' parabolas, then a sweep along the row. */
HOT static void row_pass(void *user, int y0, int y1)
{
    Job *j = user;
    int w = j->w, h = j->h;
    size_t span = j->wrap ? (size_t)w + 2 * (size_t)(w / 2) : (size_t)w;
    Parabola *env = wg_malloc(sizeof(Parabola) * span);
    int *d2 = wg_malloc(sizeof(int) * 2 * (size_t)w), *key = d2 ? d2 + w : NULL;
    if (!env || !d2) {
        atomic_store(&j->failed, 1);
        goto done;
    }
    for (int y = y0; y < y1; y++) {
        const int16_t *nr = j->near + (size_t)y * (size_t)w;
        int lo = 0, hi = w - 1;
        if (j->wrap) {
            lo = -reach(nr, w, h, y, false);
            hi = w - 1 + reach(nr, w, h, y, true);
        }
        int k = -1;
        for (int q = lo; q <= hi; q++) {
            int x = q < 0 ? q + w : q >= w ? q - w : q;
            int r = nr[x];
            if (r < 0) continue;
            if (r == y && interior(nr, w, x, y, j->wrap)) continue;
            Parabola p = {q, 0, fy(y, r, h, j->wrap), r << KEY_BITS | x};
            /* env[k] never wins once p beats it where it starts: drop it (no division) */
            while (k > 0 && beats(&p, &env[k], env[k].z)) k--;
            p.z = k < 0 ? INT32_MIN : breakpoint(&env[k], &p, j->inv);
            env[++k] = p;
        }
        /* each parabola painted over the columns where it is lowest (its breakpoints grow),
         * then the sites: each its own nearest, whether or not it is in env */
        int n = k + 1;
        bool keys = j->emit == EMIT_FILL;
        for (k = 0; k < n; k++) {
            int x0 = env[k].z > 0 ? env[k].z : 0;
            int x1 = k + 1 < n && env[k + 1].z < w ? env[k + 1].z : w;
            if (x0 >= w) break;
            int q = env[k].q, f = env[k].f;
            for (int x = x0; x < x1; x++) d2[x] = (x - q) * (x - q) + f;
            if (keys)
                for (int x = x0; x < x1; x++) key[x] = env[k].key;
        }
        for (int x = 0; x < w; x++) d2[x] = nr[x] == y ? 0 : d2[x];
        if (keys)
            for (int x = 0; x < w; x++) key[x] = nr[x] == y ? y << KEY_BITS | x : key[x];
        emit_row(j, y, d2, key);
    }
done:
    wg_free(env);
    wg_free(d2);
}

/* The value a distance takes when there is no site at all: the periodic half-diagonal with wrap,
 * the full diagonal without (both beyond any real distance in the image). */
static double no_site_distance(int w, int h, bool wrap)
{
    return wrap ? sqrt(0.25 * w * w + 0.25 * h * h) : sqrt((double)w * w + (double)h * h);
}

static void fill(WgImage *out, float v)
{
    for (int y = 0; y < out->height; y++) {
        float *o = wg_image_row(out, y);
        for (size_t i = 0; i < (size_t)out->width * (size_t)out->channels; i++) o[i] = v;
    }
}

/* One transform: sites from the mask (or its complement), results written by j->emit. Without any
 * site nothing is written and *empty is set. */
static int transform(WgNodeContext *ctx, Job *j, bool *empty, WgError *err)
{
    atomic_store(&j->nonempty_columns, 0);
    atomic_store(&j->failed, 0);
    int rc = wg_parallel_rows(ctx, (j->w + BAND - 1) / BAND, column_pass, j);
    if (rc) return rc;
    *empty = atomic_load(&j->nonempty_columns) == 0;
    if (*empty) return WG_OK;
    rc = wg_parallel_rows(ctx, j->h, row_pass, j);
    if (!rc && atomic_load(&j->failed)) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    return rc;
}

static size_t near_bytes(const Job *j)
{
    return sizeof(int16_t) * (size_t)j->w * (size_t)j->h;
}

static void job_free(WgNodeContext *ctx, Job *j)
{
    wg_scratch_free(ctx, j->near, near_bytes(j));
    wg_free(j->inv);
}

static int job_init(Job *j, WgNodeContext *ctx, bool wrap, WgError *err)
{
    memset(j, 0, sizeof *j);
    j->mask = ctx->inputs[0];
    j->out = ctx->outputs[0];
    j->w = ctx->width;
    j->h = ctx->height;
    j->wrap = wrap;
    j->near = wg_scratch_alloc(ctx, near_bytes(j));
    /* the columns q of a row's parabolas lie in [-w/2, w - 1 + w/2]: 2 (b.q - a.q) < 4 w */
    j->inv = wg_malloc(sizeof(double) * 4 * (size_t)j->w);
    if (!j->near || !j->inv) {
        job_free(ctx, j);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    for (int d = 1; d < 4 * j->w; d++) j->inv[d] = 1.0 / d;
    return WG_OK;
}

static int distance_eval(WgNodeContext *ctx, WgError *err)
{
    const DistanceParams *p = ctx->params;
    Job j;
    int rc = job_init(&j, ctx, p->wrap, err);
    if (rc) return rc;
    double none = no_site_distance(j.w, j.h, p->wrap);
    bool empty;
    j.source = ctx->n_inputs > 1 ? ctx->inputs[1] : NULL;
    if (j.source) {
        j.emit = EMIT_FILL;
        rc = transform(ctx, &j, &empty, err);
        if (!rc && empty) fill(j.out, 0);
    } else if (p->mode == MODE_FALLOFF) {
        double r = (double)p->distance * j.w / 256.0;
        j.emit = EMIT_FALLOFF;
        j.scale = r > 0 ? 1 / r : 0;
        rc = transform(ctx, &j, &empty, err);
        if (!rc && empty) fill(j.out, 0);
    } else {
        j.emit = EMIT_PIXELS;
        rc = transform(ctx, &j, &empty, err);
        if (!rc && empty) fill(j.out, (float)none);
        if (!rc && p->mode == MODE_SIGNED) {
            j.invert = true;
            j.emit = EMIT_SUBTRACT;
            rc = transform(ctx, &j, &empty, err);
            if (!rc && empty) fill(j.out, (float)-none); /* a full mask */
        }
    }
    job_free(ctx, &j);
    return rc;
}

static int morph_eval(WgNodeContext *ctx, WgError *err, bool erode)
{
    const MorphParams *p = ctx->params;
    Job j;
    int rc = job_init(&j, ctx, p->wrap, err);
    if (rc) return rc;
    double r = (double)p->radius * j.w / 256.0;
    j.scale = r * r;
    j.invert = erode;
    j.emit = erode ? EMIT_ERODE : EMIT_DILATE;
    bool empty;
    rc = transform(ctx, &j, &empty, err);
    if (!rc && empty) fill(j.out, erode ? 1.0f : 0.0f);
    job_free(ctx, &j);
    return rc;
}

static int dilate_eval(WgNodeContext *ctx, WgError *err)
{
    return morph_eval(ctx, err, false);
}

static int erode_eval(WgNodeContext *ctx, WgError *err)
{
    return morph_eval(ctx, err, true);
}

/* The nearest-row buffer (one int16 per pixel: rows are below WG_MAX_SIDE). The row pass's
 * per-chunk buffers (about ten rows' worth each) are part of the budget's fixed overhead. */
static size_t distance_scratch(const WgNodeContext *ctx)
{
    return sizeof(int16_t) * (size_t)ctx->width * (size_t)ctx->height;
}

static const WgParamSpec distance_params[] = {
    WG_PARAM_ENUM(DistanceParams, mode,
                  "falloff: clamp(1 - d/R, 0, 1); pixels: d in output pixels; signed: d outside, "
                  "minus the distance to the nearest non-mask pixel inside",
                  0, mode_values),
    WG_PARAM_FLOAT_UI(DistanceParams, distance,
                      "Falloff range, a length: in pixels of a 256-wide image, so it covers "
                      "distance x width / 256 pixels of the output",
                      10.0, 0.0, 65536.0, 0, 256),
    WG_PARAM_BOOL(DistanceParams, wrap, "Distances wrap around the image edges (tiles)", true),
    WG_PARAM_END,
};
static const WgPortSpec distance_in[] = {
    {"mask", WG_GRAY, false, "pixels >= 0.5 are the mask"},
    {"source", WG_ANY, true,
     "when connected, each pixel takes its value at the nearest mask pixel"},
    WG_PORT_END,
};
static const WgPortSpec distance_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

const WgNodeType wg_node_distance = {
    .name = "distance",
    .summary = "Exact Euclidean distance to a mask, with falloff, signed and Voronoi fill",
    .category = "filter",
    .doc = "Distances are between pixel centres, to the nearest pixel whose `mask` value is "
           ">= 0.5 (0 on the mask), exact (Felzenszwalb-Huttenlocher lower envelope on integer "
           "squared distances). With `wrap` (the default) they are measured on the torus, so the "
           "result tiles; without it the image edges are not crossed. `falloff` gives "
           "clamp(1 - d/R, 0, 1) with R = `distance` x width / 256 pixels (R = 0: 1 on the mask, "
           "0 elsewhere); `pixels` gives d; `signed` gives d outside the mask and minus the "
           "distance to the nearest non-mask pixel inside. An empty mask gives falloff 0 and, in "
           "pixels and signed modes, sqrt((W/2)² + (H/2)²) with wrap or sqrt(W² + H²) without "
           "(more than any real distance); a full mask gives falloff 1, pixels 0 and signed minus "
           "that same value. When `source` (gray or colour) is connected the output has its kind "
           "and each pixel takes the source value at its nearest mask pixel (a Voronoi fill; "
           "`mode` and `distance` do not apply); of several nearest mask pixels the one with the "
           "smallest row, then the smallest column wins; an empty mask gives 0 in every channel. "
           "O(W·H) for any mask and distance.",
    .params = distance_params,
    .params_size = sizeof(DistanceParams),
    .inputs = distance_in,
    .outputs = distance_out,
    .flags = WG_NODE_GLOBAL,
    .eval = distance_eval,
    .scratch_bytes = distance_scratch,
};

static const WgParamSpec morph_params[] = {
    WG_PARAM_FLOAT_UI(MorphParams, radius,
                      "Disc radius, a length: in pixels of a 256-wide image, so it covers "
                      "radius x width / 256 pixels of the output",
                      1.0, 0.0, 65536.0, 0, 64),
    WG_PARAM_BOOL(MorphParams, wrap, "The disc wraps around the image edges (tiles)", true),
    WG_PARAM_END,
};
static const WgPortSpec morph_in[] = {
    {"mask", WG_GRAY, false, "pixels >= 0.5 are the mask"},
    WG_PORT_END,
};
static const WgPortSpec morph_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

const WgNodeType wg_node_dilate = {
    .name = "dilate",
    .summary = "Grow a mask by an exact disc",
    .category = "filter",
    .doc = "Output 1 where the distance between pixel centres to the nearest mask pixel (value "
           ">= 0.5) is <= r, 0 elsewhere, with r = `radius` x width / 256 pixels; the exact "
           "Euclidean distance of `distance`, with the same `wrap`. radius 0 thresholds the mask; "
           "an empty mask stays 0.",
    .params = morph_params,
    .params_size = sizeof(MorphParams),
    .inputs = morph_in,
    .outputs = morph_out,
    .flags = WG_NODE_GLOBAL,
    .eval = dilate_eval,
    .scratch_bytes = distance_scratch,
};

const WgNodeType wg_node_erode = {
    .name = "erode",
    .summary = "Shrink a mask by an exact disc",
    .category = "filter",
    .doc = "Output 1 where the distance between pixel centres to the nearest non-mask pixel "
           "(value < 0.5) is > r, 0 elsewhere, with r = `radius` x width / 256 pixels: the "
           "complement of the complement dilated. Exact Euclidean distance, same `wrap` as "
           "`distance`. radius 0 thresholds the mask; a full mask stays 1.",
    .params = morph_params,
    .params_size = sizeof(MorphParams),
    .inputs = morph_in,
    .outputs = morph_out,
    .flags = WG_NODE_GLOBAL,
    .eval = erode_eval,
    .scratch_bytes = distance_scratch,
};
