/* SPDX-License-Identifier: MIT */
/* PNG files checked, and the common ones decoded, without OpenImageIO. libpng prints its errors
 * to stderr itself ("libpng error: ...") before OpenImageIO sees them, so a file libpng would
 * refuse must be refused here first, with one clear message that also says where the damage is.
 * Checked (PNG specification, 2nd edition, sections 5, 10, 11.2.2): the signature; the chunk
 * structure (lengths, the CRC-32 of every chunk, IHDR first, IEND present) up to the first
 * IDAT chunk when probing (which also reads the size and channels from the IHDR and tRNS
 * chunks, so that checking a graph needs no OpenImageIO) and to IEND when reading; the IHDR
 * values; the chunk rules libpng enforces as errors (one IHDR, at most one PLTE of 1 to 256
 * colours, a PLTE before the image data of a palette image, the IDAT chunks consecutive, no
 * chunk longer than libpng's limit) and the PNG rule that an unknown critical chunk (uppercase
 * first letter) makes the file undecodable; and, when reading, the zlib stream of the IDAT chunks,
 * inflated into a small window: it must decode (zlib's own checks, with its Adler-32), give at
 * least the bytes the IHDR promises, and every row (of every Adam7 pass when interlaced) must start
 * with a filter type 0..4. Decoding (wg__png_read: 8- and 16-bit gray, gray-alpha, RGB and RGBA,
 * not interlaced, no tRNS) happens in the same pass: each row of the window is unfiltered (section
 * 9) and handed over as soon as it is complete, so a PNG is inflated once, with two rows of memory.
 * Other PNGs are only checked (one inflate thrown away) and then read by OpenImageIO. */
#include "internal.h"
#include "wgio.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* What the IHDR promises, the inflate state of the image data, and when decoding, the rows
 * being unfiltered (the current one filling up, and the one above it). */
typedef struct ImageData {
    bool have_header;
    uint64_t expected;  /* bytes of filtered rows */
    uint64_t row_bytes; /* filter byte + one row, non-interlaced */
    uint64_t next_row;  /* offset of the next row's filter byte */
    /* the rows of each pass (one pass when not interlaced, Adam7's seven when interlaced, empty
     * ones left out), and the row next_row is in */
    uint64_t pass_rows[7], pass_bytes[7], row_in_pass, row_number;
    int passes, pass;
    uint64_t got;
    z_stream z;
    bool z_open, z_end;
    const WgPngSink *sink;
    unsigned char *cur, *prev;
    size_t fill, bpp; /* bytes in cur; bytes per pixel (at least 1) */
    int y, depth;
} ImageData;

#if defined(__SSE2__) && defined(__x86_64__)
#include <emmintrin.h>
/* Paeth on one pixel at a time (bpp bytes in 16-bit lanes) instead of one byte at a time: the
 * same operations as the scalar loop, so the same bytes. */
static inline __attribute__((always_inline)) void
paeth_pixels(unsigned char *x, const unsigned char *above, size_t n, size_t bpp)
{
    const __m128i zero = _mm_setzero_si128(), low = _mm_set1_epi16(0xff);
    __m128i a = zero, c = zero;
    for (size_t i = 0; i + bpp <= n; i += bpp) {
        uint64_t bv = 0, xv = 0;
        memcpy(&bv, above + i, bpp);
        memcpy(&xv, x + i, bpp);
        __m128i b = _mm_unpacklo_epi8(_mm_cvtsi64_si128((long long)bv), zero);
        __m128i d = _mm_unpacklo_epi8(_mm_cvtsi64_si128((long long)xv), zero);
        __m128i pa = _mm_sub_epi16(b, c), pb = _mm_sub_epi16(a, c);
        __m128i pc = _mm_add_epi16(pa, pb);
        pa = _mm_max_epi16(pa, _mm_sub_epi16(zero, pa));
        pb = _mm_max_epi16(pb, _mm_sub_epi16(zero, pb));
        pc = _mm_max_epi16(pc, _mm_sub_epi16(zero, pc));
        __m128i m = _mm_min_epi16(pc, _mm_min_epi16(pa, pb));
        __m128i use_a = _mm_cmpeq_epi16(pa, m);
        __m128i use_b = _mm_andnot_si128(use_a, _mm_cmpeq_epi16(pb, m));
        __m128i pred = _mm_or_si128(_mm_and_si128(use_a, a), _mm_and_si128(use_b, b));
        pred = _mm_or_si128(pred, _mm_andnot_si128(_mm_or_si128(use_a, use_b), c));
        d = _mm_and_si128(_mm_add_epi16(d, pred), low);
        uint64_t out = (uint64_t)_mm_cvtsi128_si64(_mm_packus_epi16(d, d));
        memcpy(x + i, &out, bpp);
        a = d;
        c = b;
    }
}

/* false when bpp has no vector loop (1 and 2 bytes: the scalar loop is as fast) */
static bool paeth_vector(unsigned char *x, const unsigned char *above, size_t n, size_t bpp)
{
    switch (bpp) {
    case 3:
        paeth_pixels(x, above, n, 3);
        return true;
    case 4:
        paeth_pixels(x, above, n, 4);
        return true;
    case 6:
        paeth_pixels(x, above, n, 6);
        return true;
    case 8:
        paeth_pixels(x, above, n, 8);
        return true;
    default:
        return false;
    }
}
#else
static bool paeth_vector(unsigned char *x, const unsigned char *above, size_t n, size_t bpp)
{
    (void)x;
    (void)above;
    (void)n;
    (void)bpp;
    return false;
}
#endif

/* Undo a row's filter (PNG specification, section 9.2) given the unfiltered row above. The
 * first pixel has no left neighbour (a = c = 0), so each loop starts past it. */
static void unfilter(unsigned char *x, const unsigned char *above, size_t n, size_t bpp, int type)
{
    size_t first = bpp < n ? bpp : n;
    switch (type) {
    case 1:
        for (size_t i = bpp; i < n; i++) x[i] = (unsigned char)(x[i] + x[i - bpp]);
        break;
    case 2:
        for (size_t i = 0; i < n; i++) x[i] = (unsigned char)(x[i] + above[i]);
        break;
    case 3:
        for (size_t i = 0; i < first; i++) x[i] = (unsigned char)(x[i] + above[i] / 2);
        for (size_t i = bpp; i < n; i++) x[i] = (unsigned char)(x[i] + (x[i - bpp] + above[i]) / 2);
        break;
    case 4:
        if (paeth_vector(x, above, n, bpp)) break;
        /* with a = c = 0 the Paeth predictor is b */
        for (size_t i = 0; i < first; i++) x[i] = (unsigned char)(x[i] + above[i]);
        for (size_t i = bpp; i < n; i++) {
            int a = x[i - bpp], b = above[i], c = above[i - bpp];
            int pa = abs(b - c), pb = abs(a - c), pc = abs(a + b - 2 * c);
            x[i] = (unsigned char)(x[i] + (pa <= pb && pa <= pc ? a : pb <= pc ? b : c));
        }
        break;
    default:
        break;
    }
}

/* Inflated bytes to rows: each complete row is unfiltered and handed to the sink. */
static void feed(ImageData *d, const unsigned char *p, size_t n)
{
    size_t rb = (size_t)d->row_bytes;
    while (n > 0 && d->y < d->sink->height) {
        size_t take = rb - d->fill < n ? rb - d->fill : n;
        memcpy(d->cur + d->fill, p, take);
        d->fill += take;
        p += take;
        n -= take;
        if (d->fill < rb) break;
        unfilter(d->cur + 1, d->prev + 1, rb - 1, d->bpp, d->cur[0]);
        d->sink->row(d->sink->user, d->y++, d->cur + 1, d->depth);
        unsigned char *t = d->prev;
        d->prev = d->cur;
        d->cur = t;
        d->fill = 0;
    }
}

static uint64_t row_size(uint64_t width, int bits_per_pixel)
{
    return (width * (uint64_t)bits_per_pixel + 7) / 8;
}

/* IHDR (section 11.2.2): the numbers must be valid, as libpng requires. */
static int read_header(ImageData *d, const unsigned char *h, uint32_t len, char *msg, size_t size)
{
    static const int channels[7] = {1, 0, 3, 1, 2, 0, 4}; /* by colour type; 0: invalid */
    if (len != 13) goto bad;
    uint32_t w = be32(h), ht = be32(h + 4);
    int depth = h[8], type = h[9], interlace = h[12];
    if (w < 1 || ht < 1 || w > 0x7fffffffu || ht > 0x7fffffffu || type > 6 || !channels[type] ||
        h[10] != 0 || h[11] != 0 || interlace > 1)
        goto bad;
    bool depth_ok = type == 0 ? depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16
                    : type == 3 ? depth == 1 || depth == 2 || depth == 4 || depth == 8
                                : depth == 8 || depth == 16;
    if (!depth_ok) goto bad;
    int bpp = channels[type] * depth;
    if (!interlace) {
        d->row_bytes = 1 + row_size(w, bpp);
        d->expected = (uint64_t)ht * d->row_bytes;
        d->pass_rows[0] = ht;
        d->pass_bytes[0] = d->row_bytes;
        d->passes = 1;
    } else {
        static const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, y0[7] = {0, 0, 4, 0, 2, 0, 1};
        static const int dx[7] = {8, 8, 4, 4, 2, 2, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
        d->expected = 0;
        for (int p = 0; p < 7; p++) {
            uint64_t pw = w > (uint32_t)x0[p] ? (w - x0[p] + dx[p] - 1) / dx[p] : 0;
            uint64_t ph = ht > (uint32_t)y0[p] ? (ht - y0[p] + dy[p] - 1) / dy[p] : 0;
            if (!pw || !ph) continue;
            d->expected += ph * (1 + row_size(pw, bpp));
            d->pass_rows[d->passes] = ph;
            d->pass_bytes[d->passes++] = 1 + row_size(pw, bpp);
        }
    }
    d->have_header = true;
    return 0;
bad:
    snprintf(msg, size,
             "the file is damaged: its IHDR chunk (size, depth, colour type) is invalid");
    return -1;
}

/* Inflate one piece of IDAT data; the output is only counted and its filter bytes checked. */
static int inflate_piece(ImageData *d, const unsigned char *in, size_t n, char *msg, size_t size)
{
    if (!d->z_open) {
        memset(&d->z, 0, sizeof d->z);
        if (inflateInit(&d->z) != Z_OK) {
            snprintf(msg, size, "out of memory checking the image data");
            return -1;
        }
        d->z_open = true;
    }
    d->z.next_in = (Bytef *)in;
    d->z.avail_in = (uInt)n;
    while (d->z.avail_in > 0 && !d->z_end) {
        unsigned char out[1 << 15];
        d->z.next_out = out;
        d->z.avail_out = sizeof out;
        int r = inflate(&d->z, Z_NO_FLUSH);
        uint64_t produced = sizeof out - d->z.avail_out;
        /* every row, of every pass, starts with its filter type: libpng refuses others */
        while (d->pass < d->passes && d->next_row < d->got + produced) {
            unsigned char filter = out[d->next_row - d->got];
            if (filter > 4) {
                snprintf(msg, size,
                         "the file is damaged: row %llu of its image data has filter type %d "
                         "(0 to 4 exist)",
                         (unsigned long long)d->row_number, filter);
                return -1;
            }
            d->next_row += d->pass_bytes[d->pass];
            d->row_number++;
            if (++d->row_in_pass == d->pass_rows[d->pass]) {
                d->pass++;
                d->row_in_pass = 0;
            }
        }
        if (d->sink) feed(d, out, (size_t)produced);
        d->got += produced;
        if (r == Z_STREAM_END) {
            d->z_end = true;
        } else if (r != Z_OK && !(r == Z_BUF_ERROR && produced > 0)) {
            snprintf(msg, size, "the file is damaged: its compressed image data is corrupt (%s)",
                     d->z.msg ? d->z.msg : zError(r));
            return -1;
        }
    }
    return 0;
}

/* What a probe learns on the way: the IHDR and whether a tRNS chunk comes before the data. */
typedef struct PngInfo {
    uint32_t width, height;
    int depth, colour_type, interlace;
    bool trns;
} PngInfo;

/* The channels OpenImageIO gives (libpng as it sets it up: palette expanded to RGB, tRNS
 * expanded to alpha). */
static int info_channels(const PngInfo *info)
{
    static const int channels[7] = {1, 0, 3, 3, 2, 0, 4};
    return channels[info->colour_type] + (info->trns && !(info->colour_type & 4) ? 1 : 0);
}

/* Decoded here: 8 or 16 bits, gray, gray-alpha, RGB or RGBA, not interlaced, no tRNS. */
static bool decodable(const PngInfo *info)
{
    return (info->depth == 8 || info->depth == 16) && info->colour_type != 3 && !info->trns &&
           !info->interlace;
}

/* What the chunks after IHDR have shown so far. */
typedef struct ChunkOrder {
    bool plte, idat, after_idat;
} ChunkOrder;

/* The most libpng accepts in one chunk (png_check_chunk_length): 8,000,000 bytes
 * (PNG_USER_CHUNK_MALLOC_MAX), or for IDAT what the whole image could take compressed at
 * worst, whichever is larger. */
static uint64_t chunk_limit(const PngInfo *h, const char *type)
{
    static const int channels[7] = {1, 0, 3, 1, 2, 0, 4};
    uint64_t limit = 8000000;
    if (strcmp(type, "IDAT")) return limit;
    uint64_t factor =
        (uint64_t)h->width * (uint64_t)channels[h->colour_type] * (h->depth > 8 ? 2 : 1) + 1 +
        (h->interlace ? 6 : 0);
    uint64_t idat = h->height > 0xffffffffu / factor ? 0x7fffffffu : h->height * factor;
    if (factor > 32566) factor = 32566;
    idat += 6 + 5 * (idat / factor + 1);
    if (idat > 0x7fffffffu) idat = 0x7fffffffu;
    return idat > limit ? idat : limit;
}

/* The chunk rules libpng enforces as errors (which it prints to stderr itself), and the PNG
 * rule that a decoder must refuse a critical chunk it does not know (specification, 2nd
 * edition, section 5.4: an uppercase first letter makes a chunk critical). */
static int check_order(ChunkOrder *o, const PngInfo *h, const char *type, uint32_t len,
                       long long at, char *msg, size_t size)
{
    bool critical = type[0] >= 'A' && type[0] <= 'Z';
    if (!strcmp(type, "IHDR")) {
        snprintf(msg, size, "the file is damaged: a second IHDR chunk at byte %lld", at);
        return -1;
    }
    if (critical && strcmp(type, "PLTE") && strcmp(type, "IDAT") && strcmp(type, "IEND")) {
        snprintf(msg, size,
                 "its chunk %s at byte %lld is critical (its first letter is uppercase) and not "
                 "one this reader knows, so the image cannot be decoded",
                 type, at);
        return -1;
    }
    if (len > chunk_limit(h, type)) {
        snprintf(msg, size,
                 "the file is damaged: its %s chunk at byte %lld declares %u bytes, more than "
                 "this image can have (%llu)",
                 type, at, len, (unsigned long long)chunk_limit(h, type));
        return -1;
    }
    if (!strcmp(type, "PLTE")) {
        if (o->plte) {
            snprintf(msg, size, "the file is damaged: a second PLTE chunk at byte %lld", at);
            return -1;
        }
        o->plte = true;
        if (h->colour_type == 3 && (len == 0 || len > 768 || len % 3)) {
            snprintf(msg, size,
                     "the file is damaged: its PLTE chunk at byte %lld is %u bytes (3 per colour, "
                     "1 to 256 colours)",
                     at, len);
            return -1;
        }
    }
    /* the image data is one run of IDAT chunks (section 5.6): libpng stops at the first other
     * chunk and finds the data short */
    if (strcmp(type, "IDAT") && o->idat) o->after_idat = true;
    if (!strcmp(type, "IDAT") && o->after_idat) {
        snprintf(msg, size,
                 "the file is damaged: its image data is interrupted (an IDAT chunk at byte %lld "
                 "follows another chunk after the first IDAT; they must be consecutive)",
                 at);
        return -1;
    }
    if (!strcmp(type, "IDAT") && !o->idat) {
        o->idat = true;
        if (h->colour_type == 3 && !o->plte) {
            snprintf(msg, size,
                     "the file is damaged: it has a palette colour type but no PLTE chunk before "
                     "its image data (IDAT at byte %lld)",
                     at);
            return -1;
        }
    }
    return 0;
}

/* 1: not a PNG (or, with a sink, not one decoded here: nothing was read); 0: fine; -1: damaged,
 * with msg. With a sink, the rows go to it as they are inflated. */
static int walk(const char *path, bool whole, PngInfo *info, const WgPngSink *sink, char *msg,
                size_t size)
{
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    FILE *f = fopen(path, "rb");
    if (!f) return 1; /* the reader reports it */
    unsigned char head[8];
    if (fread(head, 1, 8, f) != 8 || memcmp(head, signature, 8)) {
        fclose(f);
        return 1;
    }
    ImageData data = {0};
    PngInfo hdr = {0};
    ChunkOrder order = {0};
    int rc = 0;
    long long at = 8;
    bool ended = false;
    for (int index = 0; !rc; index++) {
        size_t got = fread(head, 1, 8, f);
        if (got != 8) {
            snprintf(msg, size, "the file is truncated: it ends at byte %lld, before its %s chunk",
                     at + (long long)got,
                     index == 0 ? "IHDR"
                     : whole    ? "IEND"
                                : "IDAT");
            rc = -1;
            break;
        }
        uint32_t len = be32(head);
        char type[5] = {0};
        bool letters = true;
        for (int k = 0; k < 4; k++) {
            type[k] = (char)head[4 + k];
            letters = letters &&
                      ((type[k] >= 'A' && type[k] <= 'Z') || (type[k] >= 'a' && type[k] <= 'z'));
        }
        if (!letters || len > 0x7fffffffu) {
            snprintf(msg, size, "the file is damaged: no valid chunk at byte %lld", at);
            rc = -1;
            break;
        }
        if (index == 0 && strcmp(type, "IHDR")) {
            snprintf(msg, size, "the file is damaged: its first chunk is %s, not IHDR", type);
            rc = -1;
            break;
        }
        if (index > 0 && (rc = check_order(&order, &hdr, type, len, at, msg, size))) break;
        if (!whole && !strcmp(type, "IDAT")) break;
        if (sink && !data.sink && !strcmp(type, "IDAT")) {
            /* the header and tRNS are known: decode here or leave the file to OpenImageIO */
            if (!decodable(info)) {
                rc = 1;
                break;
            }
            if ((int)info->width != sink->width || (int)info->height != sink->height ||
                info_channels(info) != sink->channels) {
                snprintf(msg, size,
                         "the file changed while it was being read (now %ux%u, was %dx%d)",
                         info->width, info->height, sink->width, sink->height);
                rc = -1;
                break;
            }
            data.bpp = (size_t)(info_channels(info) * info->depth / 8);
            data.depth = info->depth;
            data.cur = calloc(2, (size_t)data.row_bytes);
            if (!data.cur) {
                snprintf(msg, size, "out of memory");
                rc = -1;
                break;
            }
            data.prev = data.cur + data.row_bytes;
            data.sink = sink;
        }
        bool is_header = index == 0, is_data = whole && !strcmp(type, "IDAT");
        unsigned char header[13];
        uLong crc = crc32(0, head + 4, 4);
        unsigned char buf[1 << 14];
        uint32_t left = len;
        while (left > 0) {
            size_t want = left < sizeof buf ? left : sizeof buf;
            size_t n = fread(buf, 1, want, f);
            crc = crc32(crc, buf, (uInt)n);
            if (is_header && left == len) memcpy(header, buf, n < 13 ? n : 13);
            if (is_data && !rc && n == want) rc = inflate_piece(&data, buf, n, msg, size);
            left -= (uint32_t)n;
            if (n != want) break;
        }
        if (rc) break;
        unsigned char stored[4];
        if (left > 0 || fread(stored, 1, 4, f) != 4) {
            long end = ftell(f);
            snprintf(msg, size,
                     "the file is truncated: it ends at byte %ld, inside its %s chunk that starts "
                     "at byte %lld",
                     end, type, at);
            rc = -1;
            break;
        }
        if (crc != be32(stored)) {
            snprintf(msg, size,
                     "the file is damaged: the CRC of its %s chunk at byte %lld does not match",
                     type, at);
            rc = -1;
            break;
        }
        if (is_header && (rc = read_header(&data, header, len, msg, size))) break;
        if (is_header) {
            hdr.width = be32(header);
            hdr.height = be32(header + 4);
            hdr.depth = header[8];
            hdr.colour_type = header[9];
            hdr.interlace = header[12];
        }
        if (is_header && info) {
            info->width = be32(header);
            info->height = be32(header + 4);
            info->depth = header[8];
            info->colour_type = header[9];
            info->interlace = header[12];
        }
        if (info && !strcmp(type, "tRNS")) info->trns = true;
        at += 12 + (long long)len;
        if (!strcmp(type, "IEND")) {
            ended = true;
            break;
        }
    }
    if (!rc && whole && ended && data.have_header && data.got < data.expected) {
        snprintf(msg, size, "the file is damaged: its image data ends early (%llu of %llu bytes)",
                 (unsigned long long)data.got, (unsigned long long)data.expected);
        rc = -1;
    }
    if (data.z_open) inflateEnd(&data.z);
    free(data.cur < data.prev ? data.cur : data.prev);
    fclose(f);
    return rc;
}

int wg__png_check(const char *path, bool whole, char *msg, size_t size)
{
    return walk(path, whole, NULL, NULL, msg, size) < 0 ? -1 : 0;
}

int wg__png_probe(const char *path, int *w, int *h, int *c, char *msg, size_t size)
{
    PngInfo info = {0};
    int rc = walk(path, false, &info, NULL, msg, size);
    if (rc) return rc;
    *w = (int)info.width;
    *h = (int)info.height;
    *c = info_channels(&info);
    return 0;
}

bool wg__png_decodable(const char *path)
{
    PngInfo info = {0};
    char msg[512];
    return walk(path, false, &info, NULL, msg, sizeof msg) == 0 && decodable(&info);
}

int wg__png_read(const char *path, const WgPngSink *sink, char *msg, size_t size)
{
    PngInfo info = {0};
    return walk(path, true, &info, sink, msg, size);
}
