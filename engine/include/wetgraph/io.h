/* SPDX-License-Identifier: MIT */
/* Image files: reading any format OpenImageIO knows, writing PNG 8/16, TIFF 16 and EXR
 * half/float, and one multi-layer EXR through OpenEXR's C API. Every write goes to a temporary
 * file in the destination folder and is renamed over the target only when complete, so a failed
 * write never leaves a partial file or damages an existing one. */
#ifndef WETGRAPH_IO_H
#define WETGRAPH_IO_H

#include "error.h"
#include "image.h"
#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    WG_FORMAT_DEFAULT = 0, /* png16 for gray, png for colour */
    WG_FORMAT_PNG,         /* 8-bit */
    WG_FORMAT_PNG16,
    WG_FORMAT_TIF16,
    WG_FORMAT_EXR,   /* half */
    WG_FORMAT_EXR32, /* float */
} WgFormat;

typedef enum { WG_LINEAR = 0, WG_SRGB = 1 } WgColorspace;

/* "png", "png16", ... -> format; -1 when unknown. */
int wg_format_parse(const char *name);
const char *wg_format_name(WgFormat f);
const char *wg_format_extension(WgFormat f); /* "png", "tif", "exr" */

/* Size and channel count of an image file without decoding its pixels. */
int wg_image_probe(const char *path, int *width, int *height, int *channels, WgError *err);

/* Read a file as float. channels: 1 or 4 to convert, 0 to keep (1-2 channels -> gray, 3-4 ->
 * RGBA). SRGB decodes the colour channels to linear (values the curve takes past the float range
 * saturate at FLT_MAX). Non-finite values are an error.
 * The caller owns *out. */
int wg_image_read(const char *path, int channels, WgColorspace cs, WgImage **out, WgError *err);
/* Read a file into an existing image of the file's size, converting to its channel count as
 * wg_image_read does. Decodes a strip of rows at a time: beside `dst` it needs only what
 * wg_image_read_scratch says. */
int wg_image_read_into(const char *path, WgColorspace cs, WgImage *dst, WgError *err);
/* Memory that reading this file needs beyond the destination image: the decoder's own buffer
 * (the whole file at its native type for formats decoded at once, such as PNG) and a strip of
 * rows. 0 when the file cannot be opened. */
size_t wg_image_read_scratch(const char *path);

/* Write atomically, encoding a strip of rows at a time (no copy of the whole image). Gray images
 * are written with 1 channel; colour images as RGB when every alpha is 1, else RGBA. Integer
 * formats clamp to [0,1] and round to nearest; SRGB encodes the colour channels (EXR is always
 * linear and ignores it). NaN is written as 0 in integer files. */
int wg_image_write(const char *path, const WgImage *img, WgFormat format, WgColorspace cs,
                   WgError *err);

/* One EXR with a layer per image: gray images become channel "<name>.Y", colour images
 * "<name>.R/G/B/A". half or float, ZIP compression. Written atomically. */
int wg_exr_write_layers(const char *path, int count, const char *const *names,
                        const WgImage *const *images, bool half, WgError *err);

/* sRGB transfer functions (IEC 61966-2-1), exact formulas in double. */
float wg_srgb_to_linear(float v);
float wg_linear_to_srgb(float v);

/* Temporary path beside `path` for an atomic write, keeping the extension; caller frees. */
char *wg__temp_path_for(const char *path);

#ifdef __cplusplus
}
#endif
#endif
