/* SPDX-License-Identifier: MIT */
/* `statistics`: the minimum, maximum and mean of a gray image's finite values, each written as a
 * constant image (so a graph can use them in `pixel` expressions: normalise by the real range,
 * put a level relative to it, bring a result back to the input's own units). Each row is reduced
 * on its own (min and max exactly in float, the sum in double) and the rows are combined in row
 * order, so the result is bit-identical for any thread count. Non-finite values are ignored; an
 * image without a finite value gives 0 on every output. */
#include "wetgraph/node.h"

#include <math.h>

typedef struct {
    const WgImage *in;
    float *row_lo, *row_hi;
    double *row_sum;
    int64_t *row_count;
} StatsJob;

static void stats_measure(void *user, int y0, int y1)
{
    StatsJob *j = user;
    int w = j->in->width;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float lo = INFINITY, hi = -INFINITY;
        double sum = 0;
        int64_t n = 0;
        for (int x = 0; x < w; x++) {
            float v = s[x];
            if (!isfinite(v)) continue;
            if (v < lo) lo = v;
            if (v > hi) hi = v;
            sum += v;
            n++;
        }
        j->row_lo[y] = lo;
        j->row_hi[y] = hi;
        j->row_sum[y] = sum;
        j->row_count[y] = n;
    }
}

typedef struct {
    WgImage *const *out;
    float value[3];
} FillJob;

static void stats_fill(void *user, int y0, int y1)
{
    const FillJob *f = user;
    for (int k = 0; k < 3; k++) {
        const WgImage *o = f->out[k];
        for (int y = y0; y < y1; y++) {
            float *d = wg_image_row(o, y);
            for (int x = 0; x < o->width; x++) d[x] = f->value[k];
        }
    }
}

static int statistics_eval(WgNodeContext *ctx, WgError *err)
{
    StatsJob j = {ctx->inputs[0], NULL, NULL, NULL, NULL};
    int h = j.in->height;
    j.row_lo = wg_malloc(sizeof(float) * (size_t)h);
    j.row_hi = wg_malloc(sizeof(float) * (size_t)h);
    j.row_sum = wg_malloc(sizeof(double) * (size_t)h);
    j.row_count = wg_malloc(sizeof(int64_t) * (size_t)h);
    int rc = WG_OK;
    if (!j.row_lo || !j.row_hi || !j.row_sum || !j.row_count)
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc && j.in->stride == 0) {
        /* a uniform image (an unconnected graph input, another uniform node) shares one row:
           measure it once and give every row its result, which combines exactly as before */
        stats_measure(&j, 0, 1);
        for (int y = 1; y < h; y++) {
            j.row_lo[y] = j.row_lo[0];
            j.row_hi[y] = j.row_hi[0];
            j.row_sum[y] = j.row_sum[0];
            j.row_count[y] = j.row_count[0];
        }
    } else if (!rc)
        rc = wg_parallel_rows(ctx, h, stats_measure, &j);
    if (!rc) {
        /* combine the rows in row order: independent of threads and chunking */
        float lo = INFINITY, hi = -INFINITY;
        double sum = 0;
        int64_t n = 0;
        for (int y = 0; y < h; y++) {
            if (j.row_lo[y] < lo) lo = j.row_lo[y];
            if (j.row_hi[y] > hi) hi = j.row_hi[y];
            sum += j.row_sum[y];
            n += j.row_count[y];
        }
        FillJob f = {ctx->outputs, {0, 0, 0}};
        if (n > 0) {
            double mean = sum / (double)n;
            /* the float mean of values within [lo, hi] stays within it */
            float m = (float)mean;
            f.value[0] = lo;
            f.value[1] = hi;
            f.value[2] = m < lo ? lo : m > hi ? hi : m;
        }
        /* rows that share one row of memory (as the engine gives a uniform node) take one */
        int rows = ctx->outputs[0]->stride ? ctx->height : 1;
        if (rows > 1)
            rc = wg_parallel_rows(ctx, rows, stats_fill, &f);
        else
            stats_fill(&f, 0, 1);
    }
    wg_free(j.row_lo);
    wg_free(j.row_hi);
    wg_free(j.row_sum);
    wg_free(j.row_count);
    return rc;
}

static const WgPortSpec statistics_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec statistics_out[] = {
    WG_PORT("min", WG_GRAY),
    WG_PORT("max", WG_GRAY),
    WG_PORT("mean", WG_GRAY),
    WG_PORT_END,
};

const WgNodeType wg_node_statistics = {
    .name = "statistics",
    .summary = "Minimum, maximum and mean of an image, as constant images",
    .category = "adjust",
    .doc = "Measures the finite values of the gray `source` and writes three constant images: "
           "`min` and `max` (exactly the smallest and largest value) and `mean` (the average, "
           "summed in double per row and over the rows in row order, rounded once to float and "
           "kept within [min, max]). Use them in `pixel` expressions, e.g. "
           "`(h - lo) / max(hi - lo, 1e-9)` to normalise by the real range or `lo + t * (hi - lo)` "
           "to bring a value back to the source's units (`auto_levels` does the first in one "
           "node). Non-finite values are ignored; with no finite value every output is 0. The "
           "source is measured at the node's size (an input of another size is resampled "
           "first, which can narrow the range when shrinking). Bit-identical for any thread "
           "count.",
    .inputs = statistics_in,
    .outputs = statistics_out,
    .flags = WG_NODE_GLOBAL | WG_NODE_UNIFORM,
    .eval = statistics_eval,
};
