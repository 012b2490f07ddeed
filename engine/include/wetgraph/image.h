/* SPDX-License-Identifier: MIT */
/* WgImage: a float32 image with 1 (gray) or 4 (RGBA, linear) channels, rows aligned to 64
 * bytes, reference-counted. An image is mutable only by the code that created it and only until
 * it is handed on (returned from a node, put in a cache): after that it is immutable.
 * All engine allocation goes through one hook so tests can inject failures. */
#ifndef WETGRAPH_IMAGE_H
#define WETGRAPH_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define WG_MAX_SIDE 16384

typedef struct WgImage {
    int width, height;
    int channels;  /* 1 or 4 */
    size_t stride; /* floats between the starts of two rows; 0 when every row is the same
                      memory (an image of one value, as a WG_NODE_UNIFORM node outputs) */
    float *data;
    int refcount_;                /* private: use wg_image_ref / wg_image_unref */
    int mapped_;                  /* private: data is a memory mapping of its own */
    struct WgMemPool *pool_;      /* private: the buffer pool data goes back to, or NULL */
    void (*release_)(void *user); /* private: wg_image_wrap's release, or NULL */
    void *release_user_;          /* private: its argument */
} WgImage;

/* New image with undefined pixels; the caller owns the returned reference. NULL when out of
 * memory or when the size is invalid (side < 1 or > WG_MAX_SIDE, channels not 1 or 4). */
WgImage *wg_image_new(int width, int height, int channels);
/* New image filled with zeros. */
WgImage *wg_image_new_zero(int width, int height, int channels);
/* An image over pixels the caller holds, without copying them: `stride` floats between the
 * starts of two rows (at least width * channels; any alignment of float). The pixels must stay
 * valid and unchanged until the last reference is dropped, which calls release(user) (when
 * release is not NULL) from whatever thread drops it. The caller owns the returned reference.
 * NULL when out of memory or when the size or stride is invalid (then release is not called).
 * For handing an application's buffer (a Python array, a frame of a video) to a request as an
 * input image (wg_request_set_input_image). */
WgImage *wg_image_wrap(int width, int height, int channels, size_t stride, float *data,
                       void (*release)(void *user), void *user);
/* Takes one more reference; returns img. NULL-safe. */
WgImage *wg_image_ref(const WgImage *img);
/* Drops one reference and frees the image with the last one. NULL-safe. */
void wg_image_unref(const WgImage *img);

static inline float *wg_image_row(const WgImage *img, int y)
{
    return img->data + (size_t)y * img->stride;
}

/* Bytes of pixel memory the image holds. */
size_t wg_image_bytes(const WgImage *img);
/* Whether every alpha of row y of a colour image is exactly 1 (1 for a gray image; 0 where an
 * alpha is not 1, NaN included). Fast enough to call on a row just read for something else. */
int wg_image_row_alpha_one(const WgImage *img, int y);
/* Bytes an image of that size would hold (for budgeting before allocation). */
size_t wg_image_bytes_for(int width, int height, int channels);

/* A new image of another size and/or channel count. Resampling wraps around the edges and uses
 * a separable tent filter whose support is max(1, source/target) pixels per axis: bilinear when
 * enlarging; when shrinking by k, a triangle k source pixels wide on each side (for 2x, weights
 * 1 3 3 1 / 8 per axis), which keeps the mean and suppresses aliasing. Gray to colour copies the
 * value to R, G, B with alpha 1; colour to gray takes Rec.709 luminance (exactly R when
 * R = G = B).
 * The caller owns the result. */
WgImage *wg_image_convert(const WgImage *src, int width, int height, int channels);

/* Allocation hook used for all engine memory. `alloc` must return 64-byte aligned memory.
 * Passing NULLs restores the default: image pixels are 64-byte aligned (their own memory
 * mapping from 1 MiB on, 2 MiB aligned and advised as huge pages from 2 MiB on; an engine keeps
 * freed ones for reuse within its memory budget), other blocks above 256 bytes come from
 * aligned_alloc and smaller ones from malloc (no alignment beyond malloc's); all are released with
 * free or munmap. Not thread-safe to change while a render runs. */
typedef void *(*WgAllocFn)(size_t size, void *user);
typedef void (*WgFreeFn)(void *ptr, void *user);
void wg_set_allocator(WgAllocFn alloc, WgFreeFn free_fn, void *user);
void *wg_malloc(size_t size);
void *wg_calloc(size_t count, size_t size);
void *wg_realloc_array(void *ptr, size_t old_count, size_t new_count, size_t size);
void wg_free(void *ptr);
char *wg_strdup(const char *s);
char *wg_strndup(const char *s, size_t n);

#ifdef __cplusplus
}
#endif
#endif
