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

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

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
    img->refcount_ = 1;
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
        wg__mempool_put(m->pool_, m->data, wg_image_bytes(m), m->mapped_);
        wg_free(m);
    }
}

/* Filter taps for one axis: for each output index, `taps` source indices (wrapped) and
 * normalised weights. */
typedef struct {
    int taps;
    int *index;
    float *weight;
} Axis;

static int axis_build(Axis *a, int src, int dst)
{
    double scale = (double)src / dst;
    double support = scale > 1 ? scale : 1; /* half-width of the tent in source pixels */
    int taps = (int)ceil(2 * support) + 2;
    a->taps = taps;
    a->index = wg_malloc(sizeof(int) * (size_t)taps * (size_t)dst);
    a->weight = wg_malloc(sizeof(float) * (size_t)taps * (size_t)dst);
    if (!a->index || !a->weight) return WG_ERR_NOMEM;
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
        for (int t = 0; t < taps; t++) {
            int i = ((first + t) % src + src) % src;
            a->index[o * taps + t] = i;
            a->weight[o * taps + t] = (float)(w[t] / sum);
        }
    }
    return WG_OK;
}

static void axis_free(Axis *a)
{
    wg_free(a->index);
    wg_free(a->weight);
}

/* Weights whose float sum rounds just above 1 can carry a sum of values near FLT_MAX past it. */
static inline float saturate(float v)
{
    return v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
}

static WgImage *resample(WgMemPool *pool, const WgImage *src, int width, int height)
{
    int c = src->channels;
    Axis ax = {0}, ay = {0};
    WgImage *tmp = NULL, *dst = NULL;
    if (axis_build(&ax, src->width, width) || axis_build(&ay, src->height, height)) goto done;
    tmp = wg__image_new_in(pool, width, src->height, c);
    dst = wg__image_new_in(pool, width, height, c);
    if (!tmp || !dst) goto fail;
    for (int y = 0; y < src->height; y++) {
        const float *in = wg_image_row(src, y);
        float *out = wg_image_row(tmp, y);
        for (int x = 0; x < width; x++) {
            for (int k = 0; k < c; k++) {
                float s = 0, first = in[ax.index[x * ax.taps] * c + k];
                bool same = true;
                for (int t = 0; t < ax.taps; t++) {
                    float v = in[ax.index[x * ax.taps + t] * c + k];
                    same &= v == first;
                    s += ax.weight[x * ax.taps + t] * v;
                }
                out[x * c + k] = same ? first : saturate(s);
            }
        }
    }
    for (int y = 0; y < height; y++) {
        float *out = wg_image_row(dst, y);
        for (int i = 0; i < width * c; i++) out[i] = 0;
        for (int t = 0; t < ay.taps; t++) {
            float w = ay.weight[y * ay.taps + t];
            if (w == 0) continue;
            const float *in = wg_image_row(tmp, ay.index[y * ay.taps + t]);
            for (int i = 0; i < width * c; i++) out[i] += w * in[i];
        }
        const float *first = wg_image_row(tmp, ay.index[y * ay.taps]);
        for (int i = 0; i < width * c; i++) {
            bool same = true;
            for (int t = 1; t < ay.taps && same; t++)
                same = wg_image_row(tmp, ay.index[y * ay.taps + t])[i] == first[i];
            out[i] = same ? first[i] : saturate(out[i]);
        }
    }
    goto done;
fail:
    wg_image_unref(dst);
    dst = NULL;
done:
    wg_image_unref(tmp);
    axis_free(&ax);
    axis_free(&ay);
    return dst;
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
