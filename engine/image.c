/* SPDX-License-Identifier: MIT */
/* WgImage allocation, reference counting and conversion (resampling, channel changes), and the
 * allocation hook. Resampling is separable with a tent filter of support max(1, scale) source
 * pixels, wrapping around the edges: exact bilinear interpolation when enlarging, a triangle
 * average when shrinking. The weights are normalised per output sample, and a sample whose taps
 * all read the same value is that value, so a constant image stays exactly constant (a float sum
 * of weights times v can be off by an ulp). Other samples saturate at ±FLT_MAX. Pixel buffers
 * come from a buffer pool (mempool.c): an engine's, which keeps freed buffers for reuse, or none
 * (wg_image_new), in which case buffers of 1 MiB and more are mappings of their own, returned to
 * the system as soon as the image is freed. */
#include "internal.h"
#include "hot.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

static WgAllocFn alloc_hook;
static WgFreeFn free_hook;
static void *hook_user;

void wg_set_allocator(WgAllocFn alloc, WgFreeFn free_fn, void *user)
{
    alloc_hook = alloc;
    free_hook = free_fn;
    hook_user = user;
}

bool wg__alloc_hooked(void)
{
    return alloc_hook != NULL;
}

/* 64-byte aligned memory: image rows start on a cache line. */
void *wg__malloc_aligned(size_t size)
{
    if (size == 0) size = 1;
    if (alloc_hook) return alloc_hook(size, hook_user);
    size_t rounded = (size + 63) & ~(size_t)63;
    if (rounded < size) return NULL;
    return aligned_alloc(64, rounded);
}

void *wg_malloc(size_t size)
{
    /* Small blocks (names, port tables) need no cache-line alignment, and glibc's aligned_alloc
     * sorts its free lists on every call: with it, loading a 100,000-node graph spent half its
     * time in the allocator. free() takes both kinds of block. */
    if (!alloc_hook && size <= 256) return malloc(size ? size : 1);
    return wg__malloc_aligned(size);
}

void *wg_calloc(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size) return NULL;
    size_t total = count * size;
    void *p = wg_malloc(total);
    if (p) memset(p, 0, total ? total : 1);
    return p;
}

void *wg_realloc_array(void *ptr, size_t old_count, size_t new_count, size_t size)
{
    if (size && new_count > SIZE_MAX / size) return NULL;
    void *p = wg_malloc(new_count * size);
    if (!p) return NULL;
    if (ptr) {
        memcpy(p, ptr, (old_count < new_count ? old_count : new_count) * size);
        wg_free(ptr);
    }
    return p;
}

void wg_free(void *ptr)
{
    if (!ptr) return;
    if (free_hook)
        free_hook(ptr, hook_user);
    else
        free(ptr);
}

char *wg_strndup(const char *s, size_t n)
{
    char *d = wg_malloc(n + 1);
    if (!d) return NULL;
    memcpy(d, s, n);
    d[n] = '\0';
    return d;
}

char *wg_strdup(const char *s)
{
    return s ? wg_strndup(s, strlen(s)) : NULL;
}

size_t wg_image_bytes_for(int width, int height, int channels)
{
    size_t row = ((size_t)width * (size_t)channels + 15) & ~(size_t)15;
    return row * (size_t)height * sizeof(float);
}

static size_t row_floats(int width, int channels)
{
    return ((size_t)width * (size_t)channels + 15) & ~(size_t)15;
}

/* With SSE2 (x86-64's baseline) four pixels a step: whole pixels compared with 1, the alpha
 * lane kept at the end. */
int wg_image_row_alpha_one(const WgImage *img, int y)
{
    if (img->channels != 4) return 1;
    const float *r = wg_image_row(img, y);
    int w = img->width, x = 0;
    bool one = true;
#ifdef __SSE2__
    const __m128 ones = _mm_set1_ps(1.0f);
    __m128 all = _mm_castsi128_ps(_mm_set1_epi32(-1));
    for (; x + 4 <= w; x += 4) {
        const float *p = r + 4 * (size_t)x;
        __m128 a = _mm_and_ps(_mm_cmpeq_ps(_mm_loadu_ps(p), ones),
                              _mm_cmpeq_ps(_mm_loadu_ps(p + 4), ones));
        __m128 b = _mm_and_ps(_mm_cmpeq_ps(_mm_loadu_ps(p + 8), ones),
                              _mm_cmpeq_ps(_mm_loadu_ps(p + 12), ones));
        all = _mm_and_ps(all, _mm_and_ps(a, b));
    }
    one = _mm_movemask_ps(all) & 8;
#endif
    for (; x < w; x++) one &= r[4 * x + 3] == 1.0f;
    return one;
}

size_t wg_image_bytes(const WgImage *img)
{
    if (!img) return 0;
    if (img->stride == 0) return row_floats(img->width, img->channels) * sizeof(float);
    return img->stride * (size_t)img->height * sizeof(float);
}

static WgImage *image_new(WgMemPool *pool, int width, int height, int channels, bool uniform)
{
    if (width < 1 || height < 1 || width > WG_MAX_SIDE || height > WG_MAX_SIDE) return NULL;
    if (channels != 1 && channels != 4) return NULL;
    WgImage *img = wg_malloc(sizeof *img);
    if (!img) return NULL;
    img->width = width;
    img->height = height;
    img->channels = channels;
    img->stride = uniform ? 0 : row_floats(width, channels);
    img->pool_ = pool;
    img->data = wg__mempool_get(pool, wg_image_bytes(img), &img->mapped_);
    if (!img->data) {
        wg_free(img);
        return NULL;
    }
    img->release_ = NULL;
    img->release_user_ = NULL;
    img->refcount_ = 1;
    return img;
}

static void release_nothing(void *user)
{
    (void)user;
}

WgImage *wg_image_wrap(int width, int height, int channels, size_t stride, float *data,
                       void (*release)(void *user), void *user)
{
    if (width < 1 || height < 1 || width > WG_MAX_SIDE || height > WG_MAX_SIDE) return NULL;
    if ((channels != 1 && channels != 4) || !data) return NULL;
    if (stride < (size_t)width * (size_t)channels) return NULL;
    WgImage *img = wg_malloc(sizeof *img);
    if (!img) return NULL;
    *img = (WgImage){.width = width,
                     .height = height,
                     .channels = channels,
                     .stride = stride,
                     .data = data,
                     .refcount_ = 1,
                     .release_ = release ? release : release_nothing,
                     .release_user_ = user};
    return img;
}

WgImage *wg__image_new_in(WgMemPool *pool, int width, int height, int channels)
{
    return image_new(pool, width, height, channels, false);
}

WgImage *wg__image_new_uniform_in(WgMemPool *pool, int width, int height, int channels)
{
    return image_new(pool, width, height, channels, true);
}

WgImage *wg_image_new(int width, int height, int channels)
{
    return wg__image_new_in(NULL, width, height, channels);
}

WgImage *wg_image_new_zero(int width, int height, int channels)
{
    WgImage *img = wg_image_new(width, height, channels);
    if (img) memset(img->data, 0, wg_image_bytes(img));
    return img;
}

WgImage *wg_image_ref(const WgImage *img)
{
    WgImage *m = (WgImage *)img;
    if (m) atomic_fetch_add_explicit((_Atomic int *)&m->refcount_, 1, memory_order_relaxed);
    return m;
}

void wg_image_unref(const WgImage *img)
{
    WgImage *m = (WgImage *)img;
    if (!m) return;
    if (atomic_fetch_sub_explicit((_Atomic int *)&m->refcount_, 1, memory_order_acq_rel) == 1) {
        if (m->release_) { /* wg_image_wrap's: the pixels go back to their holder */
            m->release_(m->release_user_);
            wg_free(m);
            return;
        }
        wg__mempool_put(m->pool_, m->data, wg_image_bytes(m), m->mapped_);
        wg_free(m);
    }
}

/* Filter taps for one axis: for each output index o, n[o] <= `taps` source indices (wrapped)
 * and normalised weights, stored from o * taps. Only the taps of nonzero weight are kept: the
 * tent's ends carry none, and a zero-weight tap would only add work (and, reading an infinite
 * value, a NaN). */
typedef struct {
    int taps;
    int *n;
    int *index;
    float *weight;
    /* An enlargement by k = 2 or 4 repeats the same two taps every k outputs, one source pixel
     * further each time: output k·m + j reads sources m + d[j] and m + d[j] + 1 with weights
     * a[j] and b[j], for m in [lo, hi), where no tap wraps. k = 0: no such pattern. Found by
     * comparing every output's taps with it, so that the loop over it computes exactly the
     * table's sums. */
    int k, lo, hi;
    int d[4];
    float a[4], b[4];
} Axis;

/* The periodic pattern of an axis enlarged by 2 or 4, if every output in [lo, hi) follows it
 * (each output of such an axis has two taps: its centre is never on a source pixel's). */
static void axis_find_period(Axis *ax, int src, int dst)
{
    ax->k = 0;
    int k = dst == 2 * src ? 2 : dst == 4 * src ? 4 : 0;
    if (!k || src < 8) return;
    int mid = src / 2, lo = 0, hi = src;
    for (int j = 0; j < k; j++) {
        int o = k * mid + j;
        const int *idx = ax->index + (size_t)o * (size_t)ax->taps;
        const float *wt = ax->weight + (size_t)o * (size_t)ax->taps;
        if (ax->n[o] != 2 || idx[1] != idx[0] + 1) return;
        ax->d[j] = idx[0] - mid;
        ax->a[j] = wt[0];
        ax->b[j] = wt[1];
        if (-ax->d[j] > lo) lo = -ax->d[j];
        if (src - ax->d[j] - 1 < hi) hi = src - ax->d[j] - 1;
    }
    for (int m = lo; m < hi; m++)
        for (int j = 0; j < k; j++) {
            int o = k * m + j;
            const int *idx = ax->index + (size_t)o * (size_t)ax->taps;
            const float *wt = ax->weight + (size_t)o * (size_t)ax->taps;
            if (ax->n[o] != 2 || idx[0] != m + ax->d[j] || idx[1] != idx[0] + 1 ||
                memcmp(&wt[0], &ax->a[j], sizeof(float)) ||
                memcmp(&wt[1], &ax->b[j], sizeof(float)))
                return;
        }
    ax->lo = lo;
    ax->hi = hi;
    ax->k = k;
}

static int axis_build(Axis *a, int src, int dst)
{
    double scale = (double)src / dst;
    double support = scale > 1 ? scale : 1; /* half-width of the tent in source pixels */
    int taps = (int)ceil(2 * support) + 2;
    a->taps = taps;
    a->n = wg_malloc(sizeof(int) * (size_t)dst);
    a->index = wg_malloc(sizeof(int) * (size_t)taps * (size_t)dst);
    a->weight = wg_malloc(sizeof(float) * (size_t)taps * (size_t)dst);
    if (!a->n || !a->index || !a->weight) return WG_ERR_NOMEM;
    for (int o = 0; o < dst; o++) {
        double centre = (o + 0.5) * scale - 0.5; /* in source pixel coordinates */
        int first = (int)floor(centre - support) + 1;
        double sum = 0;
        double w[taps];
        for (int t = 0; t < taps; t++) {
            double d = fabs(first + t - centre) / support;
            w[t] = d < 1 ? 1 - d : 0;
            sum += w[t];
        }
        int n = 0;
        for (int t = 0; t < taps; t++) {
            if (w[t] == 0) continue;
            a->index[o * taps + n] = ((first + t) % src + src) % src;
            a->weight[o * taps + n] = (float)(w[t] / sum);
            n++;
        }
        a->n[o] = n;
    }
    axis_find_period(a, src, dst);
    return WG_OK;
}

static void axis_free(Axis *a)
{
    wg_free(a->n);
    wg_free(a->index);
    wg_free(a->weight);
}

/* Weights whose float sum rounds just above 1 can carry a sum of values near FLT_MAX past it. */
static inline float saturate(float v)
{
    return v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
}

/* Both passes band by band: the output rows are split between the workers, and for each band
 * of at most RESAMPLE_BAND of them the source rows its taps read are resampled horizontally into
 * a buffer of the band's own, then combined vertically into the output, so no intermediate image
 * of the output's width and the source's height is made (a source row that two bands read is
 * resampled in both). Every output value is a sum over its taps in tap order, whichever thread
 * computes it, so the result does not depend on the number of threads. */
#define RESAMPLE_BAND 32

typedef struct {
    const WgImage *src;
    WgImage *dst;
    Axis ax, ay;
    int band_rows; /* source rows a band reads, at most */
    atomic_int failed;
    /* band buffers no chunk is using: one per worker at most, made once per resampling */
    pthread_mutex_t mu;
    void *idle[64];
    int n_idle;
} Resample;

/* A band's buffer: band_rows rows of the output's width, then the source row -> slot map and
 * the rows in use. */
static size_t band_bytes(const Resample *r)
{
    size_t row = (size_t)r->dst->width * (size_t)r->dst->channels;
    return sizeof(float) * row * (size_t)r->band_rows +
           sizeof(int) * ((size_t)r->src->height + (size_t)r->band_rows);
}

static void *band_take(Resample *r)
{
    void *b = NULL;
    pthread_mutex_lock(&r->mu);
    if (r->n_idle) b = r->idle[--r->n_idle];
    pthread_mutex_unlock(&r->mu);
    if (b) return b;
    b = wg_malloc(band_bytes(r));
    if (!b) return NULL;
    int *slot = (int *)((float *)b +
                        (size_t)r->dst->width * (size_t)r->dst->channels * (size_t)r->band_rows);
    for (int i = 0; i < r->src->height; i++) slot[i] = -1;
    return b;
}

/* Back to the idle list with every slot -1 again. */
static void band_give(Resample *r, void *b)
{
    pthread_mutex_lock(&r->mu);
    if (r->n_idle < 64) {
        r->idle[r->n_idle++] = b;
        b = NULL;
    }
    pthread_mutex_unlock(&r->mu);
    wg_free(b);
}

/* Colour pixels as one 4-wide vector per tap (GCC and Clang vector types: SSE on x86-64, NEON on
 * ARM, plain code elsewhere); gray samples one at a time. */
typedef float V4 __attribute__((vector_size(16)));
typedef int32_t I4 __attribute__((vector_size(16)));

static inline V4 load4(const float *p)
{
    V4 v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline V4 select4(I4 mask, V4 a, V4 b) /* mask ? a : b, lane by lane */
{
    return (V4)(((I4)a & mask) | ((I4)b & ~mask));
}

/* Outputs k·m + j for m in [m0, m1) of a row enlarged by K (2 or 4, a constant, so that the
 * phases are one vector loop): the sums of the generic loop below, in the same order, value by
 * value for gray (C 1) and lane by lane for colour (C 4). */
static inline __attribute__((always_inline)) void
period_row(const Axis *ax, const float *in, float *out, int m0, int m1, int K, int C)
{
    const V4 big = {FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX};
    for (int m = m0; m < m1; m++)
        for (int j = 0; j < K; j++) {
            const float *p = in + (size_t)C * (size_t)(m + ax->d[j]);
            if (C == 1) {
                float f = p[0], g = p[1];
                float v = ax->a[j] * f + ax->b[j] * g;
                v = v > FLT_MAX ? FLT_MAX : v;
                v = v < -FLT_MAX ? -FLT_MAX : v;
                out[K * m + j] = f != g ? v : f;
            } else {
                V4 f = load4(p), g = load4(p + 4), v = ax->a[j] * f + ax->b[j] * g;
                v = select4(v > big, big, v);
                v = select4(v < -big, -big, v);
                v = select4(f != g, v, f);
                memcpy(out + 4 * (size_t)(K * m + j), &v, sizeof v);
            }
        }
}

static void resample_row_x_generic(const Resample *r, const float *in, float *out, int x0, int x1);

/* Source row sy resampled horizontally into out (the output's width). */
static void resample_row_x(const Resample *r, int sy, float *out)
{
    const Axis *ax = &r->ax;
    const float *in = wg_image_row(r->src, sy);
    int c = r->src->channels;
    if ((c == 1 || c == 4) && ax->k) {
        resample_row_x_generic(r, in, out, 0, ax->k * ax->lo);
        if (ax->k == 2 && c == 1)
            period_row(ax, in, out, ax->lo, ax->hi, 2, 1);
        else if (ax->k == 2)
            period_row(ax, in, out, ax->lo, ax->hi, 2, 4);
        else if (c == 1)
            period_row(ax, in, out, ax->lo, ax->hi, 4, 1);
        else
            period_row(ax, in, out, ax->lo, ax->hi, 4, 4);
        resample_row_x_generic(r, in, out, ax->k * ax->hi, r->dst->width);
        return;
    }
    resample_row_x_generic(r, in, out, 0, r->dst->width);
}

/* Outputs [x0, x1) of a row, each over its own taps. */
static void resample_row_x_generic(const Resample *r, const float *in, float *out, int x0, int x1)
{
    const Axis *ax = &r->ax;
    int c = r->src->channels;
    const V4 big = {FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX};
    for (int x = x0; x < x1; x++) {
        const int *idx = ax->index + (size_t)x * (size_t)ax->taps;
        const float *wt = ax->weight + (size_t)x * (size_t)ax->taps;
        int n = ax->n[x];
        if (c == 1 && n == 2) { /* every output when enlarging */
            float f = in[idx[0]], g = in[idx[1]];
            out[x] = f != g ? saturate(wt[0] * f + wt[1] * g) : f;
        } else if (c == 4) {
            V4 f = load4(in + 4 * (size_t)idx[0]), s = wt[0] * f;
            I4 diff = {0, 0, 0, 0};
            for (int t = 1; t < n; t++) {
                V4 v = load4(in + 4 * (size_t)idx[t]);
                s += wt[t] * v;
                diff |= v != f;
            }
            s = select4(s > big, big, s);
            s = select4(s < -big, -big, s);
            s = select4(diff, s, f);
            memcpy(out + 4 * (size_t)x, &s, sizeof s);
        } else {
            float f = in[idx[0]], s = wt[0] * f;
            int diff = 0;
            for (int t = 1; t < n; t++) {
                float v = in[idx[t]];
                s += wt[t] * v;
                diff |= v != f;
            }
            out[x] = diff ? saturate(s) : f;
        }
    }
}

/* Output row y from its taps' rows, horizontally resampled: two taps (every row when
 * enlarging) in one loop; more in blocks of the row's values summed over the taps, then kept
 * only where some tap differs from the first. */
#define RESAMPLE_BLOCK 512

/* Compiled for AVX2 too (GCC's function multiversioning, picked at load time): 8 values a vector
 * instead of 4, the same operations in the same order, so the same bits. */
HOT static void resample_row_y(const Resample *r, int y, const float *const *rows, float *out)
{
    const Axis *ay = &r->ay;
    int count = r->dst->width * r->dst->channels;
    const float *wt = ay->weight + (size_t)y * (size_t)ay->taps;
    int n = ay->n[y];
    const float *f = rows[0];
    if (n == 2) {
        const float *g = rows[1];
        float w0 = wt[0], w1 = wt[1];
        for (int i = 0; i < count; i++) {
            float v = w0 * f[i] + w1 * g[i];
            v = v > FLT_MAX ? FLT_MAX : v;
            v = v < -FLT_MAX ? -FLT_MAX : v;
            out[i] = f[i] != g[i] ? v : f[i];
        }
        return;
    }
    float s[RESAMPLE_BLOCK];
    int diff[RESAMPLE_BLOCK];
    for (int b0 = 0; b0 < count; b0 += RESAMPLE_BLOCK) {
        int m = count - b0 < RESAMPLE_BLOCK ? count - b0 : RESAMPLE_BLOCK;
        const float *fb = f + b0;
        for (int i = 0; i < m; i++) {
            s[i] = wt[0] * fb[i];
            diff[i] = 0;
        }
        for (int t = 1; t < n; t++) {
            const float *v = rows[t] + b0;
            float w = wt[t];
            for (int i = 0; i < m; i++) {
                s[i] += w * v[i];
                diff[i] |= v[i] != fb[i];
            }
        }
        float *ob = out + b0;
        for (int i = 0; i < m; i++) {
            float v = s[i], e = fb[i];
            v = v > FLT_MAX ? FLT_MAX : v;
            v = v < -FLT_MAX ? -FLT_MAX : v;
            ob[i] = diff[i] != 0 ? v : e;
        }
    }
}

static void resample_rows(void *user, int y0, int y1)
{
    Resample *r = user;
    const Axis *ay = &r->ay;
    size_t row = (size_t)r->dst->width * (size_t)r->dst->channels;
    float *buf = band_take(r);
    const float **rows = wg_malloc(sizeof(float *) * (size_t)ay->taps);
    if (!buf || !rows) {
        atomic_store(&r->failed, 1);
        goto out;
    }
    int *slot = (int *)(buf + row * (size_t)r->band_rows), *used = slot + r->src->height;
    for (int b0 = y0; b0 < y1; b0 += RESAMPLE_BAND) {
        int b1 = y1 - b0 < RESAMPLE_BAND ? y1 : b0 + RESAMPLE_BAND, nused = 0;
        /* the source rows of the band's taps, each resampled once; a row of one tap (weight 1)
         * goes straight to its output */
        for (int y = b0; y < b1; y++) {
            const int *idx = ay->index + (size_t)y * (size_t)ay->taps;
            if (ay->n[y] == 1) {
                resample_row_x(r, idx[0], wg_image_row(r->dst, y));
                continue;
            }
            for (int t = 0; t < ay->n[y]; t++) {
                if (slot[idx[t]] >= 0) continue;
                slot[idx[t]] = nused;
                used[nused] = idx[t];
                resample_row_x(r, idx[t], buf + row * (size_t)nused);
                nused++;
            }
        }
        for (int y = b0; y < b1; y++) {
            if (ay->n[y] == 1) continue;
            const int *idx = ay->index + (size_t)y * (size_t)ay->taps;
            for (int t = 0; t < ay->n[y]; t++) rows[t] = buf + row * (size_t)slot[idx[t]];
            resample_row_y(r, y, rows, wg_image_row(r->dst, y));
        }
        for (int i = 0; i < nused; i++) slot[used[i]] = -1;
    }
out:
    if (buf) band_give(r, buf);
    wg_free(rows);
}

/* src resampled into dst (same channels), rows split over `workers` (NULL: this thread).
 * WG_ERR_NOMEM or WG_ERR_CANCELLED on failure. */
static int resample_into(WgPool *workers, volatile int *cancel, const WgImage *src, WgImage *dst)
{
    Resample r = {.src = src, .dst = dst};
    atomic_init(&r.failed, 0);
    pthread_mutex_init(&r.mu, NULL);
    int rc = WG_ERR_NOMEM;
    if (axis_build(&r.ax, src->width, dst->width) || axis_build(&r.ay, src->height, dst->height))
        goto done;
    /* a band of B output rows reads the taps from its first row's first to its last row's
     * last: (B - 1) * scale + taps source rows at most, and never more than there are */
    double rows = ceil((RESAMPLE_BAND - 1) * ((double)src->height / dst->height)) + r.ay.taps + 1;
    r.band_rows = rows < src->height ? (int)rows : src->height;
    rc = wg__pool_rows(workers, cancel, dst->height, resample_rows, &r);
    if (!rc && atomic_load(&r.failed)) rc = WG_ERR_NOMEM;
done:
    for (int i = 0; i < r.n_idle; i++) wg_free(r.idle[i]);
    pthread_mutex_destroy(&r.mu);
    axis_free(&r.ax);
    axis_free(&r.ay);
    return rc;
}

static WgImage *resample(WgMemPool *pool, const WgImage *src, int width, int height)
{
    WgImage *dst = wg__image_new_in(pool, width, height, src->channels);
    if (dst && resample_into(NULL, NULL, src, dst)) {
        wg_image_unref(dst);
        dst = NULL;
    }
    return dst;
}

int wg_image_resample_into(const WgNodeContext *ctx, const WgImage *src, WgImage *dst)
{
    if (!src || !dst || src->channels != dst->channels) return WG_ERR_TYPE;
    return resample_into(ctx ? ctx->pool_ : NULL, ctx ? ctx->cancel_ : NULL, src, dst);
}

float wg__luminance(const float *p)
{
    if (p[0] == p[1] && p[1] == p[2]) return p[0];
    return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
}

static WgImage *convert_channels(WgMemPool *pool, const WgImage *src, int channels)
{
    WgImage *dst = wg__image_new_in(pool, src->width, src->height, channels);
    if (!dst) return NULL;
    for (int y = 0; y < src->height; y++) {
        const float *in = wg_image_row(src, y);
        float *out = wg_image_row(dst, y);
        for (int x = 0; x < src->width; x++) {
            if (channels == 4) {
                out[4 * x] = out[4 * x + 1] = out[4 * x + 2] = in[x];
                out[4 * x + 3] = 1.0f;
            } else {
                out[x] = wg__luminance(in + 4 * x);
            }
        }
    }
    return dst;
}

WgImage *wg__image_convert_in(WgMemPool *pool, const WgImage *src, int width, int height,
                              int channels)
{
    if (!src || width < 1 || height < 1 || width > WG_MAX_SIDE || height > WG_MAX_SIDE ||
        (channels != 1 && channels != 4))
        return NULL;
    WgImage *sized = NULL;
    if (width != src->width || height != src->height) {
        sized = resample(pool, src, width, height);
        if (!sized) return NULL;
    } else {
        sized = wg_image_ref(src);
    }
    if (channels == sized->channels) {
        if (sized != src) return sized;
        /* a real copy so the caller may own and modify it */
        WgImage *copy = wg__image_new_in(pool, width, height, channels);
        if (copy && src->stride == copy->stride)
            memcpy(copy->data, src->data, wg_image_bytes(src));
        else if (copy) /* src has one row for all */
            for (int y = 0; y < height; y++)
                memcpy(wg_image_row(copy, y), wg_image_row(src, y),
                       sizeof(float) * (size_t)width * (size_t)channels);
        wg_image_unref(sized);
        return copy;
    }
    WgImage *out = convert_channels(pool, sized, channels);
    wg_image_unref(sized);
    return out;
}

WgImage *wg_image_convert(const WgImage *src, int width, int height, int channels)
{
    return wg__image_convert_in(NULL, src, width, height, channels);
}
