/* SPDX-License-Identifier: MIT */
/* The PNG writer: 8- and 16-bit gray, gray+alpha, RGB and RGBA, non-interlaced, written as
 * IHDR, IDAT chunks of 8 KiB and IEND (PNG specification, ISO/IEC 15948). With the deflate
 * compression each row gets the filter of the five whose output has the smallest sum of absolute
 * values taken as signed bytes (libpng's own heuristic), and libdeflate compresses the whole
 * filtered image into the zlib stream in one call: several times faster than zlib at a similar
 * size. The fast compression, the default, makes that choice on one row in FAST_CHOICE_ROWS and
 * codes the stream with deflate_fast.c (Huffman coding and runs, about 4x faster in all); none
 * writes the rows unfiltered in stored blocks. The caller packs the rows
 * one at a time as they are filtered (16-bit samples in host order); readers of every kind
 * decode the files, the tests check them with libpng. */
#include "internal.h"
#include "wgio.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <libdeflate.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* libdeflate's level 1: for the wet material's outputs at 2048², files 7% smaller than zlib's
 * level 1 (which OpenImageIO wrote them with), 10% faster than libdeflate's level 2 for files
 * 1% larger */
#define PNG_DEFLATE_LEVEL 1
/* The stream is cut into IDAT chunks of this size, as libpng cuts it: a reader checks each
 * chunk's CRC before it inflates much past a damaged byte, so damage is reported as such. */
#define IDAT_BYTES 8192
/* The fast mode's runs: bytes equal to the one before (runs of equal pixels, distance bytes per
 * pixel, gave files 0.1% larger at the same speed on the wet material's outputs) */
#define FAST_DIST 1
/* The fast mode chooses the filter as deflate does on every FAST_CHOICE_ROWS-th row and
 * keeps it for the rows up to the next choice: on the wet material's outputs the files are 0.5%
 * larger than with a choice on every row, and encoding takes a quarter less time. */
#define FAST_CHOICE_ROWS 32

static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* The filters' loops compiled for AVX2 too (GCC's function multiversioning), picked at load
 * time: filtering takes half the time of the baseline SSE2 code. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HOT __attribute__((target_clones("avx2", "default")))
#else
#define HOT
#endif

/* The filter heuristic's cost: the sum of the bytes taken as signed, |x| being the smaller of x
 * and -x as bytes (128 for 128), summed in 32 bits: a row has at most 2^17 bytes. */
static uint32_t cost(const unsigned char *d, size_t n)
{
    uint32_t sum = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned char x = d[i], y = (unsigned char)-x;
        sum += x < y ? x : y;
    }
    return sum;
}

/* The row `cur` (n bytes, bpp per pixel; `prev` is the row above, zeros for the first) through
 * filter `type` (1 to 4) into o[0..n). One loop per filter type without branches, so that the
 * compiler vectorises every one of them: Paeth's predictor reads only unfiltered bytes, and its
 * choice (a on ties with b or c, then b on a tie with c) is two selects. */
HOT static void filter_as(const unsigned char *cur, const unsigned char *prev, size_t n, int bpp,
                          int type, unsigned char *o)
{
    size_t k = (size_t)bpp < n ? (size_t)bpp : n;
    switch (type) {
    case 1:
        for (size_t i = 0; i < k; i++) o[i] = cur[i];
        for (size_t i = k; i < n; i++) o[i] = (unsigned char)(cur[i] - cur[i - k]);
        break;
    case 2:
        for (size_t i = 0; i < n; i++) o[i] = (unsigned char)(cur[i] - prev[i]);
        break;
    case 3:
        for (size_t i = 0; i < k; i++) o[i] = (unsigned char)(cur[i] - (prev[i] >> 1));
        for (size_t i = k; i < n; i++)
            o[i] = (unsigned char)(cur[i] - ((cur[i - k] + prev[i]) >> 1));
        break;
    default:
        for (size_t i = 0; i < k; i++) o[i] = (unsigned char)(cur[i] - prev[i]);
        for (size_t i = k; i < n; i++) {
            /* in 16 bits (|a + b - 2c| <= 510), so that a vector holds 16 of them, not 8 */
            int16_t a = cur[i - k], b = prev[i], c = prev[i - k];
            /* |p - a|, |p - b| and |p - c| for p = a + b - c */
            int16_t pa = (int16_t)(b - c), pb = (int16_t)(a - c), pc = (int16_t)(a + b - 2 * c);
            pa = pa < 0 ? (int16_t)-pa : pa;
            pb = pb < 0 ? (int16_t)-pb : pb;
            pc = pc < 0 ? (int16_t)-pc : pc;
            int16_t pred = pb <= pc ? b : c;
            pred = (pa <= pb) & (pa <= pc) ? a : pred;
            o[i] = (unsigned char)(cur[i] - pred);
        }
    }
}

/* PNG stores 16-bit samples most significant byte first: the n bytes' pairs swapped (a vector
 * of shifts, not a byte at a time). */
HOT static void swap_bytes16(unsigned char *p, size_t n)
{
    for (size_t i = 0; i + 2 <= n; i += 2) {
        uint16_t v;
        memcpy(&v, p + i, 2);
        v = (uint16_t)(v << 8 | v >> 8);
        memcpy(p + i, &v, 2);
    }
}

/* The row filtered into out[0..n] with the filter type first: `type` (the fast mode's rows
 * between choices), or with -1 the type of the five whose output costs least; `tries` holds 4
 * rows of n bytes. */
static void filter_row(const unsigned char *cur, const unsigned char *prev, size_t n, int bpp,
                       int type, unsigned char *out, unsigned char *tries)
{
    if (type >= 0) {
        out[0] = (unsigned char)type;
        if (type == 0)
            memcpy(out + 1, cur, n);
        else
            filter_as(cur, prev, n, bpp, type, out + 1);
        return;
    }
    const unsigned char *best = cur;
    uint32_t best_sum = cost(cur, n);
    type = 0;
    for (int t = 1; t < 5; t++) {
        unsigned char *try = tries + (size_t)(t - 1) * n;
        filter_as(cur, prev, n, bpp, t, try);
        uint32_t sum = cost(try, n);
        if (sum < best_sum) {
            best_sum = sum;
            best = try;
            type = t;
        }
    }
    out[0] = (unsigned char)type;
    memcpy(out + 1, best, n);
}

int wg__png_encode_rows(int w, int h, int c, int bits, WgPngCompression mode, WgPngPack pack,
                        void *user, unsigned char **out, size_t *out_size, char *msg,
                        size_t msg_size)
{
    *out = NULL, *out_size = 0;
    int bpp = c * bits / 8;
    size_t row = (size_t)w * (size_t)bpp, filtered_size = (row + 1) * (size_t)h;
    unsigned char *filtered = wg_malloc(filtered_size);
    unsigned char *cur = wg_malloc(row), *prev = wg_calloc(row ? row : 1, 1),
                  *scratch = wg_malloc(4 * row + 1);
    struct libdeflate_compressor *z =
        mode == WG_PNG_COMPRESSION_DEFLATE ? libdeflate_alloc_compressor(PNG_DEFLATE_LEVEL) : NULL;
    unsigned char *file = NULL;
    int rc = -1;
    if (!filtered || !cur || !prev || !scratch || (mode == WG_PNG_COMPRESSION_DEFLATE && !z)) {
        snprintf(msg, msg_size, "out of memory");
        goto done;
    }
    int type = 0;
    for (int y = 0; y < h; y++) {
        pack(user, y, cur);
        if (bits == 16) swap_bytes16(cur, row);
        unsigned char *f = filtered + (row + 1) * (size_t)y;
        /* none: filter type 0, the bytes as they are; fast: the type chosen on the last choice row
         */
        int given = mode == WG_PNG_COMPRESSION_NONE                           ? 0
                    : mode == WG_PNG_COMPRESSION_FAST && y % FAST_CHOICE_ROWS ? type
                                                                              : -1;
        filter_row(cur, prev, row, bpp, given, f, scratch);
        type = f[0];
        unsigned char *t = prev;
        prev = cur;
        cur = t;
    }
    size_t bound =
        z ? libdeflate_zlib_compress_bound(z, filtered_size) : wg__zlib_fast_bound(filtered_size);
    size_t chunks = bound / IDAT_BYTES + 1;
    /* signature 8, IHDR 25, IDATs 12 each + data, IEND 12: the stream is compressed into the
     * end of the buffer, then moved forward chunk by chunk */
    file = wg_malloc(45 + 12 * chunks + bound);
    if (!file) {
        snprintf(msg, msg_size, "out of memory");
        goto done;
    }
    unsigned char *zbuf = file + 45 + 12 * chunks;
    size_t zn = mode == WG_PNG_COMPRESSION_FAST
                    ? wg__zlib_fast(filtered, filtered_size, FAST_DIST, zbuf, bound)
                : mode == WG_PNG_COMPRESSION_NONE
                    ? wg__zlib_stored(filtered, filtered_size, zbuf, bound)
                    : libdeflate_zlib_compress(z, filtered, filtered_size, zbuf, bound);
    if (!zn) {
        snprintf(msg, msg_size, "cannot compress the image");
        goto done;
    }
    static const unsigned char signature[8] = {137, 'P', 'N', 'G', '\r', '\n', 26, '\n'};
    static const unsigned char color_type[5] = {0, 0, 4, 2, 6};
    unsigned char *p = file;
    memcpy(p, signature, 8);
    put32(p + 8, 13);
    memcpy(p + 12, "IHDR", 4);
    put32(p + 16, (uint32_t)w);
    put32(p + 20, (uint32_t)h);
    p[24] = (unsigned char)bits;
    p[25] = color_type[c];
    p[26] = p[27] = p[28] = 0; /* deflate, filter set 0, no interlace */
    put32(p + 29, (uint32_t)libdeflate_crc32(0, p + 12, 17));
    p += 33;
    for (size_t at = 0; at < zn; at += IDAT_BYTES) {
        size_t k = zn - at < IDAT_BYTES ? zn - at : IDAT_BYTES;
        put32(p, (uint32_t)k);
        memcpy(p + 4, "IDAT", 4);
        memmove(p + 8, zbuf + at, k); /* never overtakes: the output trails the stream */
        put32(p + 8 + k, (uint32_t)libdeflate_crc32(0, p + 4, k + 4));
        p += 12 + k;
    }
    put32(p, 0);
    memcpy(p + 4, "IEND", 4);
    put32(p + 8, (uint32_t)libdeflate_crc32(0, p + 4, 4));
    *out_size = (size_t)(p + 12 - file);
    *out = file;
    file = NULL;
    rc = 0;
done:
    if (z) libdeflate_free_compressor(z);
    wg_free(filtered);
    wg_free(cur);
    wg_free(prev);
    wg_free(scratch);
    wg_free(file);
    return rc;
}

typedef struct {
    const unsigned char *samples;
    size_t row;
} Packed;

static void copy_row(void *user, int y, void *row)
{
    const Packed *p = user;
    memcpy(row, p->samples + p->row * (size_t)y, p->row);
}

int wg__png_encode(const void *samples, int w, int h, int c, int bits, WgPngCompression png,
                   unsigned char **out, size_t *out_size, char *msg, size_t msg_size)
{
    Packed p = {samples, (size_t)w * (size_t)c * (size_t)(bits / 8)};
    return wg__png_encode_rows(w, h, c, bits, png, copy_row, &p, out, out_size, msg, msg_size);
}

int wg__png_write_rows(const char *path, int w, int h, int c, int bits, WgPngCompression png,
                       WgPngPack pack, void *user, char *msg, size_t msg_size)
{
    unsigned char *file;
    size_t total;
    if (wg__png_encode_rows(w, h, c, bits, png, pack, user, &file, &total, msg, msg_size))
        return -1;
    int rc = -1;
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0 || wg__write_all(fd, file, total)) {
        int err = errno;
        snprintf(msg, msg_size, "%s", strerror(err));
        msg[0] = (char)tolower((unsigned char)msg[0]); /* as the other writers' messages */
        if (fd >= 0) close(fd);
        errno = err;
        goto done;
    }
    if (close(fd)) {
        int err = errno;
        snprintf(msg, msg_size, "%s", strerror(err));
        msg[0] = (char)tolower((unsigned char)msg[0]);
        errno = err;
        goto done;
    }
    rc = 0;
done:
    wg_free(file);
    return rc;
}
