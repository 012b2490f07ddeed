/* SPDX-License-Identifier: MIT */
/* In-memory 8-bit PNG encoder for the previews `wetgraph watch --serve` serves: the samples
 * are quantised exactly as wg_image_write quantises an 8-bit PNG (round to nearest of the
 * clamped, optionally sRGB-encoded value), each row gets filter type 0 (none), and zlib
 * compresses the whole scanline buffer into one IDAT chunk (PNG specification, ISO/IEC 15948).
 * Previews are small and made once per render, so speed is not a concern here. */
#include "png_preview.h"

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static uint8_t quantize8(float v, bool srgb)
{
    if (isnan(v)) v = 0;
    if (srgb) v = wg_linear_to_srgb(v);
    double x = v < 0 ? 0 : v > 1 ? 1 : v;
    return (uint8_t)floor(x * 255.0 + 0.5);
}

static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* Append chunk `type` with `len` bytes of data at p; returns the end. */
static unsigned char *chunk(unsigned char *p, const char *type, const unsigned char *data,
                            size_t len)
{
    put32(p, (uint32_t)len);
    memcpy(p + 4, type, 4);
    if (len) memcpy(p + 8, data, len);
    uLong crc = crc32(0L, p + 4, (uInt)(len + 4));
    put32(p + 8 + len, (uint32_t)crc);
    return p + 12 + len;
}

int wg_png_preview(const WgImage *img, WgColorspace cs, unsigned char **out, size_t *size)
{
    int w = img->width, h = img->height, c = img->channels;
    bool alpha = false;
    for (int y = 0; c == 4 && y < h && !alpha; y++)
        for (int x = 0; x < w && !alpha; x++) alpha = wg_image_row(img, y)[4 * x + 3] != 1.0f;
    int pc = c == 1 ? 1 : alpha ? 4 : 3;
    size_t row = (size_t)w * (size_t)pc + 1, raw_size = row * (size_t)h;
    unsigned char *raw = malloc(raw_size);
    uLong bound = compressBound((uLong)raw_size);
    unsigned char *z = malloc(bound);
    unsigned char *png = malloc(bound + 64);
    if (!raw || !z || !png) {
        free(raw);
        free(z);
        free(png);
        return WG_ERR_NOMEM;
    }
    for (int y = 0; y < h; y++) {
        const float *src = wg_image_row(img, y);
        unsigned char *dst = raw + row * (size_t)y;
        *dst++ = 0;
        for (int x = 0; x < w; x++)
            for (int k = 0; k < pc; k++) *dst++ = quantize8(src[c * x + k], cs == WG_SRGB && k < 3);
    }
    uLongf zlen = bound;
    if (compress2(z, &zlen, raw, (uLong)raw_size, 6) != Z_OK) {
        free(raw);
        free(z);
        free(png);
        return WG_ERR_NOMEM;
    }
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    unsigned char ihdr[13];
    put32(ihdr, (uint32_t)w);
    put32(ihdr + 4, (uint32_t)h);
    ihdr[8] = 8;                             /* bit depth */
    ihdr[9] = pc == 1 ? 0 : pc == 3 ? 2 : 6; /* gray, RGB, RGBA */
    ihdr[10] = ihdr[11] = ihdr[12] = 0;      /* deflate, filter set 0, no interlace */
    unsigned char *p = png;
    memcpy(p, sig, 8);
    p = chunk(p + 8, "IHDR", ihdr, sizeof ihdr);
    p = chunk(p, "IDAT", z, zlen);
    p = chunk(p, "IEND", NULL, 0);
    free(raw);
    free(z);
    *out = png;
    *size = (size_t)(p - png);
    return WG_OK;
}
