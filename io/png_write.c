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
 * decode the files, the tests check them with libpng. Rows are filtered, and in the fast mode
 * coded, in pieces of rows that the caller's WgWorkers may run on several threads (a render's
 * idle workers): the pieces depend on the image alone, so the file does too. */
#include "internal.h"
#include "hot.h"
#include "wgio.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <libdeflate.h>
#include <stdatomic.h>
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

/* The filters' loops are HOT (hot.h): filtering takes half the time of the baseline SSE2
 * code. */

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

/* The image is filtered and coded in pieces of whole rows, each on whichever thread the caller's
 * WgWorkers gives it: pieces of at least PIECE_BYTES of filtered rows, a multiple of
 * FAST_CHOICE_ROWS rows each (so every piece starts on a row that chooses its filter, and the
 * filtered rows are those of one pass down the image). In the fast mode a piece's rows are
 * packed, filtered, coded and checked (Adler-32) while they are in the cache, in a buffer of the
 * piece's size: the filtered image is never held whole. The pieces depend on the image alone,
 * so the file is the same whatever runs them. */
#define PIECE_BYTES (512 * 1024)
/* The fast mode's code is made from a sample of the filtered rows: images of less than
 * SAMPLE_ALL bytes filtered whole, larger ones SAMPLE_STRETCHES stretches of rows spread down the
 * image, each of at least SAMPLE_BYTES and starting on a row that chooses its filter, and none
 * closer than SAMPLE_GAP bytes to the next (as deflate_fast.c samples a stream it holds whole). */
#define SAMPLE_ALL (1 << 20)
#define SAMPLE_STRETCHES 32
#define SAMPLE_BYTES 16384
#define SAMPLE_GAP (4 * SAMPLE_BYTES)

typedef struct {
    int w, h, c, bits, bpp;
    WgPngCompression mode;
    WgPngPack pack;
    void *user;
    bool same_rows; /* every row is the same (an image of one value) */
    size_t row;     /* bytes of a packed row */
    int piece_rows; /* rows of a piece (the last may have fewer) */
    unsigned char *filtered;   /* deflate and none: the whole filtered image */
    const WgDeflateCode *code; /* fast: the code of every piece */
    unsigned char *zbuf;       /* fast: the pieces' streams, piece i's at i * zcap (new memory:
                                  only the streams' pages are touched) */
    size_t zcap, *zsize;       /* the bound of a piece's stream; their sizes */
    uint32_t *adler;           /* the Adler-32 of each piece's filtered rows */
    atomic_int failed;
    atomic_int pieces_done; /* by the last run: fewer than the pieces when the workers left some */
} Encode;

/* A thread's rows while it filters: the row being filtered, the one above (packed), and the
 * filter heuristic's four tries */
typedef struct {
    unsigned char *cur, *prev, *tries;
} Rows;

static int pieces_of(const Encode *e)
{
    return (e->h + e->piece_rows - 1) / e->piece_rows;
}

static void piece_rows(const Encode *e, int i, int *y0, int *y1)
{
    *y0 = i * e->piece_rows;
    *y1 = *y0 + e->piece_rows < e->h ? *y0 + e->piece_rows : e->h;
}

static bool rows_new(Rows *r, size_t row)
{
    r->cur = wg_malloc(row ? row : 1);
    r->prev = wg_malloc(row ? row : 1);
    r->tries = wg_malloc(4 * row + 1);
    return r->cur && r->prev && r->tries;
}

static void rows_free(Rows *r)
{
    wg_free(r->cur);
    wg_free(r->prev);
    wg_free(r->tries);
}

/* The filter type row y is given: none's 0; fast's the type chosen on the last choice row
 * (`type`); -1 (choose) on the others. */
static int given_type(const Encode *e, int y, int type)
{
    return e->mode == WG_PNG_COMPRESSION_NONE                           ? 0
           : e->mode == WG_PNG_COMPRESSION_FAST && y % FAST_CHOICE_ROWS ? type
                                                                        : -1;
}

/* Rows [y0, y1) of an image whose rows are all the same, as filter_rows makes them: the row
 * packed once, and a filtered row below the first copied from the one above when both were
 * given the same type (their bytes and the bytes above them are the same). */
static void filter_same_rows(const Encode *e, int y0, int y1, unsigned char *out, Rows *r)
{
    size_t row = e->row;
    e->pack(e->user, y0, r->cur);
    if (e->bits == 16) swap_bytes16(r->cur, row);
    memset(r->prev, 0, row);
    int type = 0, last = -2;
    for (int y = y0; y < y1; y++) {
        unsigned char *f = out + (row + 1) * (size_t)(y - y0);
        int given = given_type(e, y, type);
        if (y > y0 && y > 1 && given == last)
            memcpy(f, f - (row + 1), row + 1);
        else
            filter_row(r->cur, y ? r->cur : r->prev, row, e->bpp, given, f, r->tries);
        type = f[0];
        last = given;
    }
}

/* Rows [y0, y1) packed and filtered into out, (row + 1) bytes each; y0 is 0 or a row that
 * chooses its filter. */
static void filter_rows(const Encode *e, int y0, int y1, unsigned char *out, Rows *r)
{
    size_t row = e->row;
    if (e->same_rows) {
        filter_same_rows(e, y0, y1, out, r);
        return;
    }
    if (y0 > 0) { /* the row above, which the filters read */
        e->pack(e->user, y0 - 1, r->prev);
        if (e->bits == 16) swap_bytes16(r->prev, row);
    } else {
        memset(r->prev, 0, row);
    }
    int type = 0;
    for (int y = y0; y < y1; y++) {
        e->pack(e->user, y, r->cur);
        if (e->bits == 16) swap_bytes16(r->cur, row);
        unsigned char *f = out + (row + 1) * (size_t)(y - y0);
        filter_row(r->cur, r->prev, row, e->bpp, given_type(e, y, type), f, r->tries);
        type = f[0];
        unsigned char *t = r->prev;
        r->prev = r->cur;
        r->cur = t;
    }
}

/* Pieces [i0, i1) filtered into their places in e->filtered (deflate and none). */
static void filter_pieces(void *user, int i0, int i1)
{
    Encode *e = user;
    Rows r;
    if (!rows_new(&r, e->row)) {
        atomic_store(&e->failed, 1);
        goto done;
    }
    for (int i = i0; i < i1; i++) {
        int y0, y1;
        piece_rows(e, i, &y0, &y1);
        filter_rows(e, y0, y1, e->filtered + (e->row + 1) * (size_t)y0, &r);
        atomic_fetch_add(&e->pieces_done, 1);
    }
done:
    rows_free(&r);
}

/* Pieces [i0, i1) filtered, each into one buffer in turn, and coded with e->code into its place
 * in e->zbuf (fast). */
static void code_pieces(void *user, int i0, int i1)
{
    Encode *e = user;
    int n = pieces_of(e);
    size_t cap = (e->row + 1) * (size_t)e->piece_rows;
    unsigned char *buf = wg_malloc(cap ? cap : 1);
    Rows r;
    if (!rows_new(&r, e->row) || !buf) {
        atomic_store(&e->failed, 1);
        goto done;
    }
    for (int i = i0; i < i1; i++) {
        int y0, y1;
        piece_rows(e, i, &y0, &y1);
        size_t len = (e->row + 1) * (size_t)(y1 - y0);
        filter_rows(e, y0, y1, buf, &r);
        e->zsize[i] = wg__deflate_piece(e->code, buf, len, i == n - 1,
                                        e->zbuf + (size_t)i * e->zcap, e->zcap);
        e->adler[i] = (uint32_t)libdeflate_adler32(1, buf, len);
        if (!e->zsize[i]) atomic_store(&e->failed, 1);
        atomic_fetch_add(&e->pieces_done, 1);
    }
done:
    rows_free(&r);
    wg_free(buf);
}

/* The fast mode's code, from a sample of the filtered rows (see SAMPLE_ALL): NULL when out of
 * memory. */
static WgDeflateCode *sampled_code(const Encode *e)
{
    size_t row = e->row + 1, size = row * (size_t)e->h;
    int ys[SAMPLE_STRETCHES], ye[SAMPLE_STRETCHES], k = 0;
    if (size < SAMPLE_ALL) {
        ys[k] = 0, ye[k++] = e->h;
    } else {
        int count =
            size / SAMPLE_GAP < SAMPLE_STRETCHES ? (int)(size / SAMPLE_GAP) : SAMPLE_STRETCHES;
        int rows = (int)((SAMPLE_BYTES + row - 1) / row);
        for (int j = 0; j < count; j++) {
            int y = (int)((int64_t)j * e->h / count) / FAST_CHOICE_ROWS * FAST_CHOICE_ROWS;
            if (k && y < ye[k - 1]) continue; /* a stretch of rows already taken */
            ys[k] = y;
            ye[k++] = y + rows < e->h ? y + rows : e->h;
        }
    }
    size_t total = 0;
    for (int j = 0; j < k; j++) total += row * (size_t)(ye[j] - ys[j]);
    unsigned char *buf = wg_malloc(total ? total : 1);
    WgBytes sample[SAMPLE_STRETCHES];
    Rows r;
    WgDeflateCode *code = NULL;
    if (rows_new(&r, e->row) && buf) {
        unsigned char *at = buf;
        for (int j = 0; j < k; j++) {
            filter_rows(e, ys[j], ye[j], at, &r);
            sample[j] = (WgBytes){at, row * (size_t)(ye[j] - ys[j])};
            at += sample[j].n;
        }
        code = wg__deflate_code_of(sample, k, size, FAST_DIST);
    }
    rows_free(&r);
    wg_free(buf);
    return code;
}

/* A stretch of the zlib stream */
typedef struct {
    const unsigned char *p;
    size_t n;
} Span;

/* Where the file goes: into one buffer of its size (fd < 0), or to fd through a buffer of at
 * most STAGE_BYTES, written out whenever the next chunk would not fit (no copy of the file). */
#define STAGE_BYTES (256 * 1024)
typedef struct {
    int fd;
    unsigned char *buf;
    size_t cap, len;
    int err; /* errno of a write that failed */
} Out;

/* Room for n more bytes at buf + len (n <= cap), after writing out what is there when they
 * would not fit. */
static unsigned char *room(Out *o, size_t n)
{
    if (o->fd >= 0 && o->len + n > o->cap) {
        if (!o->err && wg__write_all(o->fd, o->buf, o->len)) o->err = errno ? errno : EIO;
        o->len = 0;
    }
    return o->buf + o->len;
}

/* The stream, given as spans in order, in IDAT chunks of IDAT_BYTES. */
static void put_idats(Out *o, const Span *span, int spans, size_t total)
{
    int s = 0;
    size_t off = 0;
    for (size_t at = 0; at < total;) {
        size_t k = total - at < IDAT_BYTES ? total - at : IDAT_BYTES;
        unsigned char *chunk = room(o, k + 12), *p = chunk + 8;
        for (size_t left = k; left;) {
            size_t take = span[s].n - off < left ? span[s].n - off : left;
            memcpy(p, span[s].p + off, take);
            p += take, left -= take, off += take;
            if (off == span[s].n) s++, off = 0;
        }
        put32(chunk, (uint32_t)k);
        memcpy(chunk + 4, "IDAT", 4);
        put32(p, (uint32_t)libdeflate_crc32(0, chunk + 4, k + 4));
        o->len += k + 12;
        at += k;
    }
}

/* fn over pieces [0, n): by workers, or here. Nonzero with msg when the workers stopped early
 * ("cancelled") or a piece failed (`failure`). */
static int run_pieces(const WgWorkers *workers, int n, void (*fn)(void *, int, int), Encode *e,
                      const char *failure, char *msg, size_t msg_size)
{
    int stopped = 0;
    atomic_store(&e->pieces_done, 0);
    if (workers && workers->run)
        stopped = workers->run(workers->ctx, n, fn, e);
    else
        fn(e, 0, n);
    if (stopped) {
        snprintf(msg, msg_size, "cancelled");
        return -1;
    }
    if (atomic_load(&e->failed)) {
        snprintf(msg, msg_size, "%s", failure);
        return -1;
    }
    if (atomic_load(&e->pieces_done) != n) {
        snprintf(msg, msg_size,
                 "a piece of the image was not coded (the workers ran only some of the parts)");
        return -1;
    }
    return 0;
}

/* Large scratch buffers: the workers' (touched before, when they have a pool), or new memory */
static void *scratch_alloc(const WgWorkers *workers, size_t bytes)
{
    return workers && workers->alloc ? workers->alloc(workers->ctx, bytes) : wg_malloc(bytes);
}

static void scratch_free(const WgWorkers *workers, void *p, size_t bytes)
{
    if (!p) return;
    if (workers && workers->alloc)
        workers->free(workers->ctx, p, bytes);
    else
        wg_free(p);
}

/* The file into o (o->buf made here, the caller's to free). */
static int encode(int w, int h, int c, int bits, WgPngCompression mode, WgPngPack pack, void *user,
                  bool same_rows, const WgWorkers *workers, Out *o, char *msg, size_t msg_size)
{
    int bpp = c * bits / 8;
    size_t row = (size_t)w * (size_t)bpp, filtered_size = (row + 1) * (size_t)h;
    size_t rows = PIECE_BYTES / (row + 1) + 1;
    rows = (rows + FAST_CHOICE_ROWS - 1) / FAST_CHOICE_ROWS * FAST_CHOICE_ROWS;
    Encode e = {.w = w,
                .h = h,
                .c = c,
                .bits = bits,
                .bpp = bpp,
                .mode = mode,
                .pack = pack,
                .user = user,
                .same_rows = same_rows,
                .row = row,
                .piece_rows = rows < (size_t)h ? (int)rows : h};
    if (e.piece_rows < 1) e.piece_rows = 1;
    atomic_init(&e.failed, 0);
    atomic_init(&e.pieces_done, 0);
    int n = h > 0 ? pieces_of(&e) : 0;
    WgDeflateCode *code = NULL;
    struct libdeflate_compressor *z = NULL;
    unsigned char *zbuf = NULL, zlib_head[2] = {0x78, 0x01}, adler[4]; /* deflate, fastest */
    size_t bound = 0, zn = 0;
    Span *spans = NULL;
    int nspans = 0;
    int rc = -1;
    spans = wg_calloc((size_t)n + 2, sizeof *spans);
    if (!spans) {
        snprintf(msg, msg_size, "out of memory");
        goto done;
    }
    if (mode == WG_PNG_COMPRESSION_FAST) {
        /* the pieces' streams side by side, each in a slot of its bound (new memory, touched
         * only where a stream goes) */
        e.zcap = wg__deflate_piece_bound((row + 1) * (size_t)e.piece_rows);
        e.zsize = wg_calloc((size_t)n + 1, sizeof *e.zsize);
        e.adler = wg_calloc((size_t)n + 1, sizeof *e.adler);
        zbuf = wg_malloc((size_t)n * e.zcap + 1);
        if (!e.zsize || !e.adler || !zbuf || !(code = sampled_code(&e))) {
            snprintf(msg, msg_size, "out of memory");
            goto done;
        }
        e.code = code;
        e.zbuf = zbuf;
        if (run_pieces(workers, n, code_pieces, &e, "cannot compress the image", msg, msg_size))
            goto done;
        /* the stream: the zlib header, the pieces in order, the Adler-32 of the filtered rows */
        spans[0] = (Span){zlib_head, 2};
        uint32_t check = 1;
        for (int i = 0; i < n; i++) {
            int y0, y1;
            piece_rows(&e, i, &y0, &y1);
            spans[1 + i] = (Span){zbuf + (size_t)i * e.zcap, e.zsize[i]};
            check = wg__adler32_combine(check, e.adler[i], (row + 1) * (size_t)(y1 - y0));
        }
        put32(adler, check);
        spans[1 + n] = (Span){adler, 4};
        nspans = n + 2;
    } else {
        /* the filtered rows, the size of the raw image, in the workers' scratch memory (touched
         * before, where they have a pool); the stream is the file's size */
        e.filtered = scratch_alloc(workers, filtered_size ? filtered_size : 1);
        if (!e.filtered) {
            snprintf(msg, msg_size, "out of memory");
            goto done;
        }
        if (run_pieces(workers, n, filter_pieces, &e, "out of memory", msg, msg_size)) goto done;
        z = mode == WG_PNG_COMPRESSION_DEFLATE ? libdeflate_alloc_compressor(PNG_DEFLATE_LEVEL)
                                               : NULL;
        if (mode == WG_PNG_COMPRESSION_DEFLATE && !z) {
            snprintf(msg, msg_size, "out of memory");
            goto done;
        }
        bound = z ? libdeflate_zlib_compress_bound(z, filtered_size)
                  : wg__zlib_fast_bound(filtered_size);
        if (!(zbuf = wg_malloc(bound ? bound : 1))) {
            snprintf(msg, msg_size, "out of memory");
            goto done;
        }
        zn = mode == WG_PNG_COMPRESSION_NONE
                 ? wg__zlib_stored(e.filtered, filtered_size, zbuf, bound)
                 : libdeflate_zlib_compress(z, e.filtered, filtered_size, zbuf, bound);
        if (!zn) {
            snprintf(msg, msg_size, "cannot compress the image");
            goto done;
        }
        spans[0] = (Span){zbuf, zn};
        nspans = 1;
        scratch_free(workers, e.filtered, filtered_size ? filtered_size : 1);
        e.filtered = NULL;
    }
    zn = 0;
    for (int i = 0; i < nspans; i++) zn += spans[i].n;
    /* signature 8, IHDR 25, IDATs 12 each + data, IEND 12 */
    size_t total = 45 + 12 * ((zn + IDAT_BYTES - 1) / IDAT_BYTES) + zn;
    o->cap = o->fd >= 0 && total > STAGE_BYTES ? STAGE_BYTES : total;
    if (!(o->buf = wg_malloc(o->cap))) {
        snprintf(msg, msg_size, "out of memory");
        goto done;
    }
    static const unsigned char signature[8] = {137, 'P', 'N', 'G', '\r', '\n', 26, '\n'};
    static const unsigned char color_type[5] = {0, 0, 4, 2, 6};
    unsigned char *p = room(o, 33);
    memcpy(p, signature, 8);
    put32(p + 8, 13);
    memcpy(p + 12, "IHDR", 4);
    put32(p + 16, (uint32_t)w);
    put32(p + 20, (uint32_t)h);
    p[24] = (unsigned char)bits;
    p[25] = color_type[c];
    p[26] = p[27] = p[28] = 0; /* deflate, filter set 0, no interlace */
    put32(p + 29, (uint32_t)libdeflate_crc32(0, p + 12, 17));
    o->len += 33;
    put_idats(o, spans, nspans, zn);
    p = room(o, 12);
    put32(p, 0);
    memcpy(p + 4, "IEND", 4);
    put32(p + 8, (uint32_t)libdeflate_crc32(0, p + 4, 4));
    o->len += 12;
    rc = 0;
done:
    if (z) libdeflate_free_compressor(z);
    wg__deflate_code_free(code);
    scratch_free(workers, e.filtered, filtered_size ? filtered_size : 1);
    wg_free(zbuf);
    wg_free(spans);
    wg_free(e.zsize);
    wg_free(e.adler);
    return rc;
}

int wg__png_encode_rows(int w, int h, int c, int bits, WgPngCompression png, WgPngPack pack,
                        void *user, bool same_rows, const WgWorkers *workers, unsigned char **out,
                        size_t *out_size, char *msg, size_t msg_size)
{
    Out o = {.fd = -1};
    int rc = encode(w, h, c, bits, png, pack, user, same_rows, workers, &o, msg, msg_size);
    if (rc) wg_free(o.buf);
    *out = rc ? NULL : o.buf;
    *out_size = rc ? 0 : o.len;
    return rc;
}

/* -1 with msg the system's reason for e, lower-cased as the other writers' messages, and errno
 * e */
static int system_error(char *msg, size_t msg_size, int e)
{
    snprintf(msg, msg_size, "%s", strerror(e));
    msg[0] = (char)tolower((unsigned char)msg[0]);
    errno = e;
    return -1;
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
    return wg__png_encode_rows(w, h, c, bits, png, copy_row, &p, false, NULL, out, out_size, msg,
                               msg_size);
}

int wg__png_write_rows(const char *path, int w, int h, int c, int bits, WgPngCompression png,
                       WgPngPack pack, void *user, bool same_rows, const WgWorkers *workers,
                       char *msg, size_t msg_size)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) return system_error(msg, msg_size, errno);
    /* written as it is put together, through a buffer of at most STAGE_BYTES: the file is
     * never held whole (a failure leaves a partial file, which the caller removes) */
    Out o = {.fd = fd};
    int rc = encode(w, h, c, bits, png, pack, user, same_rows, workers, &o, msg, msg_size);
    if (!rc && !o.err && wg__write_all(fd, o.buf, o.len)) o.err = errno ? errno : EIO;
    wg_free(o.buf);
    if (!rc && o.err) {
        close(fd);
        return system_error(msg, msg_size, o.err);
    }
    if (close(fd) && !rc) return system_error(msg, msg_size, errno);
    return rc;
}
