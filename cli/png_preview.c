/* SPDX-License-Identifier: MIT */
/* In-memory 8-bit PNG encoder for the previews `wetgraph watch --serve` serves: the samples
 * are quantised exactly as wg_image_write quantises an 8-bit PNG (round to nearest of the
 * clamped, optionally sRGB-encoded value), each row gets filter type 0 (none), and zlib
 * compresses the whole scanline buffer into one IDAT chunk (PNG specification, ISO/IEC 15948)
 * with run-length matches only (zlib's Z_RLE): a preview is made while the page waits for it. */
#include "png_preview.h"

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static uint8_t quantize8(float v, bool srgb)
{
    return wg_quantize8(v, srgb);
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

/* Row y of the reduced image (k x k blocks of img), as floats: c per pixel into sum. */
static void reduced_row(const WgImage *img, int k, int y, int w, float *sum)
{
    int c = img->channels, y0 = y * k, y1 = y0 + k < img->height ? y0 + k : img->height;
    memset(sum, 0, sizeof *sum * (size_t)w * (size_t)c);
    for (int sy = y0; sy < y1; sy++) {
        const float *r = wg_image_row(img, sy);
        for (int x = 0; x < w; x++) {
            int x0 = x * k, x1 = x0 + k < img->width ? x0 + k : img->width;
            float *a = sum + (size_t)x * c;
            if (c == 4)
                for (int sx = x0; sx < x1; sx++) {
                    a[0] += r[4 * sx];
                    a[1] += r[4 * sx + 1];
                    a[2] += r[4 * sx + 2];
                    a[3] += r[4 * sx + 3];
                }
            else
                for (int sx = x0; sx < x1; sx++) a[0] += r[sx];
        }
    }
    for (int x = 0; x < w; x++) {
        int x1 = (x + 1) * k < img->width ? (x + 1) * k : img->width;
        float n = (float)((x1 - x * k) * (y1 - y0));
        for (int ch = 0; ch < c; ch++) sum[(size_t)x * c + ch] /= n;
    }
}

int wg_png_preview(const WgImage *img, int reduce, WgColorspace cs, unsigned char **out,
                   size_t *size)
{
    int k = reduce > 1 ? reduce : 1, c = img->channels;
    int w = (img->width + k - 1) / k, h = (img->height + k - 1) / k;
    bool alpha = false; /* an alpha below 1 somewhere (then every block mean is checked) */
    for (int y = 0; c == 4 && y < img->height && !alpha; y++)
        for (int x = 0; x < img->width && !alpha; x++)
            alpha = wg_image_row(img, y)[4 * x + 3] != 1.0f;
    int pc = c == 1 ? 1 : alpha ? 4 : 3;
    size_t row = (size_t)w * (size_t)pc + 1, raw_size = row * (size_t)h;
    unsigned char *raw = malloc(raw_size);
    uLong bound = compressBound((uLong)raw_size);
    unsigned char *z = malloc(bound);
    unsigned char *png = malloc(bound + 64);
    float *sum = k > 1 ? malloc(sizeof *sum * (size_t)w * (size_t)c) : NULL;
    if (!raw || !z || !png || (k > 1 && !sum)) {
        free(raw);
        free(z);
        free(png);
        free(sum);
        return WG_ERR_NOMEM;
    }
    for (int y = 0; y < h; y++) {
        const float *src = wg_image_row(img, y);
        if (k > 1) {
            reduced_row(img, k, y, w, sum);
            src = sum;
        }
        unsigned char *dst = raw + row * (size_t)y;
        *dst++ = 0;
        for (int x = 0; x < w; x++)
            for (int q = 0; q < pc; q++) *dst++ = quantize8(src[c * x + q], cs == WG_SRGB && q < 3);
    }
    free(sum);
    /* run-length matches only: three times as fast as level 1 on grainy textures (and smaller),
       still good on flat masks */
    z_stream zs = {0};
    int zrc = deflateInit2(&zs, 1, Z_DEFLATED, 15, 8, Z_RLE);
    if (zrc == Z_OK) {
        zs.next_in = raw;
        zs.avail_in = (uInt)raw_size;
        zs.next_out = z;
        zs.avail_out = (uInt)bound;
        zrc = deflate(&zs, Z_FINISH) == Z_STREAM_END ? Z_OK : Z_BUF_ERROR;
    }
    uLongf zlen = zs.total_out;
    deflateEnd(&zs);
    if (zrc != Z_OK) {
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
