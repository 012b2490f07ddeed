/* SPDX-License-Identifier: MIT */
/* 8-bit PNG previews of images, encoded in memory for `wetgraph watch --serve` (cli/serve.c). */
#ifndef WETGRAPH_CLI_PNG_PREVIEW_H
#define WETGRAPH_CLI_PNG_PREVIEW_H

#include <wetgraph/wetgraph.h>
#include <stddef.h>

/* Encode img as an 8-bit PNG in memory with the conversions of wg_image_write's png format:
 * gray images as gray, colour images as RGB when every alpha is 1 else RGBA, NaN as 0, values
 * clamped to [0,1] and rounded to nearest, colour channels sRGB-encoded when cs is WG_SRGB.
 * reduce > 1 makes it that many times smaller (rounded up), each pixel the mean of a block of
 * reduce x reduce pixels (cut at the right and bottom edges) before the conversion.
 * On success *out (malloc'd, owned by the caller) holds *size bytes; returns WG_OK or
 * WG_ERR_NOMEM. */
int wg_png_preview(const WgImage *img, int reduce, WgColorspace cs, unsigned char **out,
                   size_t *size);

#endif
