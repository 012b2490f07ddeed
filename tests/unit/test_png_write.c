/* SPDX-License-Identifier: MIT */
/* The PNG writer's compression modes (png_write.c) and the zlib encoders under them
 * (deflate_fast.c): every mode's files read back exactly through libpng (its own reader, not
 * through OpenImageIO) for 8- and 16-bit gray, gray+alpha, RGB and RGBA, odd sizes, flat, noisy
 * and run-heavy images, one that needs a length-limited Huffman code and one large enough to be
 * counted on a sample; the zlib streams inflate through zlib's uncompress, inputs the sample
 * misjudges included; stored blocks split at 65535 bytes; the Huffman code lengths are a
 * complete code within the limit. A stream coded in pieces (any split, empty pieces, pieces that
 * fall back to stored blocks) inflates as one; an image filtered and coded in pieces on other
 * threads, in any order, gives the same file as on one thread, its whole filtered image (not in
 * the fast mode, which codes each piece as it is filtered) taken from and given back to the
 * workers' memory, and a runner that stops early fails the encoding; the pieces' Adler-32s
 * combine to the whole's; the wide coder gives the scalar coder's bits; an
 * image whose rows are all the same, filtered once a piece, gives the same file. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <png.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

static uint32_t rng = 12345;
static uint32_t next_rand(void)
{
    rng = rng * 1664525u + 1013904223u;
    return rng >> 8;
}

/* Fibonacci counts: 1, 1, 2, 3, 5, ... for `n` symbols; Huffman's code for them alone is n - 1
 * bits deep, far past 15 for n = 25. */
static void fibonacci(uint32_t *f, int n)
{
    for (int i = 0; i < n; i++) f[i] = i < 2 ? 1 : f[i - 1] + f[i - 2];
}

/* Bytes whose counts are powers of two: 2^18 zeros, 2^17 ones, ..., one 18, shuffled; returns
 * the count (2^19 - 1, under the size from which counts are sampled). Each count is more than
 * all smaller ones together, a few more symbols (end of block, runs) included, so Huffman's code
 * for them is about 18 bits deep: coding them needs the 15-bit limit. */
static size_t skewed_bytes(unsigned char **out)
{
    size_t n = (1u << 19) - 1, at = 0;
    unsigned char *b = malloc(n);
    assert_non_null(b);
    for (int i = 0; i < 19; i++)
        for (size_t k = 0; k < (size_t)1 << (18 - i); k++) b[at++] = (unsigned char)i;
    for (size_t i = n - 1; i > 0; i--) {
        size_t j = next_rand() % (i + 1);
        unsigned char t = b[i];
        b[i] = b[j];
        b[j] = t;
    }
    *out = b;
    return n;
}

/* The deepest code Huffman's tree (no limit) gives the bytes and one end-of-block symbol. */
static int unlimited_depth(const unsigned char *b, size_t n)
{
    uint32_t freq[286] = {0};
    uint8_t len[286];
    for (size_t i = 0; i < n; i++) freq[b[i]]++;
    freq[256] = 1;
    wg__huffman_lengths(freq, 286, 30, len);
    int max = 0;
    for (int s = 0; s < 286; s++) max = len[s] > max ? len[s] : max;
    return max;
}

/* ---- the zlib streams --------------------------------------------------------------------- */

/* in[0..n) through wg__zlib_fast (dist > 0) or wg__zlib_stored (dist 0), inflated by zlib. */
static size_t deflate_round_trip(const unsigned char *in, size_t n, int dist, unsigned char **z)
{
    /* bytes past the bound must stay untouched */
    size_t cap = wg__zlib_fast_bound(n), guard = 4096;
    unsigned char *o = malloc(cap + guard), *back = malloc(n + 1);
    assert_non_null(o);
    assert_non_null(back);
    memset(o + cap, 0xa5, guard);
    size_t zn = dist ? wg__zlib_fast(in, n, dist, o, cap) : wg__zlib_stored(in, n, o, cap);
    if (!zn || zn > cap)
        fail_msg("n %zu dist %d: stream of %zu bytes, bound %zu", n, dist, zn, cap);
    for (size_t i = 0; i < guard; i++)
        if (o[cap + i] != 0xa5) fail_msg("n %zu dist %d: written past the bound", n, dist);
    uLongf bn = n + 1;
    int rc = uncompress(back, &bn, o, zn);
    if (rc != Z_OK || bn != n || (n && memcmp(back, in, n)))
        fail_msg("n %zu dist %d: zlib says %d, %lu bytes back", n, dist, rc, (unsigned long)bn);
    free(back);
    if (z)
        *z = o;
    else
        free(o);
    return zn;
}

static void test_fast_streams_inflate_through_zlib(void **state)
{
    (void)state;
    static const size_t sizes[] = {0, 1, 2, 7, 8, 9, 15, 16, 17, 100, 1000, 65535, 65536, 200000};
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
        for (int kind = 0; kind < 5; kind++) {
            size_t n = sizes[si];
            unsigned char *in = malloc(n + 1);
            assert_non_null(in);
            for (size_t i = 0; i < n; i++) {
                uint32_t r = next_rand();
                in[i] = kind == 0   ? (unsigned char)r                      /* noise */
                        : kind == 1 ? 0                                     /* flat */
                        : kind == 2 ? (unsigned char)(i / 300 % 3)          /* long runs */
                        : kind == 3 ? (unsigned char)(r % 7 ? i % 4 : r)    /* runs at distance 4 */
                                    : (unsigned char)(r % 3 ? r % 5 : 200); /* skewed */
            }
            for (int dist = 0; dist <= 8; dist++) deflate_round_trip(in, n, dist, NULL);
            free(in);
        }
}

/* Inputs from 1 MiB are counted on a sample: noise is stored; a sample that sees only four
 * symbols while the rest is noise gives a code that would make the block larger, which the coder
 * notices and stores; small symbols everywhere are coded in far less than stored. */
static void test_sampled_counts_never_overflow(void **state)
{
    (void)state;
    size_t n = 4u << 20;
    unsigned char *in = malloc(n);
    assert_non_null(in);
    for (size_t i = 0; i < n; i++) in[i] = (unsigned char)next_rand();
    assert_true(deflate_round_trip(in, n, 1, NULL) > n);
    for (size_t i = 0; i < n; i++)
        in[i] = (unsigned char)(i % 65536 < 16384 ? next_rand() & 3 : next_rand());
    assert_true(deflate_round_trip(in, n, 1, NULL) > n);
    for (size_t i = 0; i < n; i++) in[i] = i % 65536 < 16384 ? 0 : (unsigned char)next_rand();
    deflate_round_trip(in, n, 1, NULL);
    for (size_t i = 0; i < n; i++) in[i] = (unsigned char)(next_rand() & 3);
    assert_true(deflate_round_trip(in, n, 1, NULL) < n / 3);
    free(in);
}

/* Stored blocks: 65535 bytes each, the last one short and final, LEN and NLEN right. */
static void test_stored_blocks_split_at_65535(void **state)
{
    (void)state;
    size_t n = 2 * 65535 + 10;
    unsigned char *in = malloc(n), *z;
    assert_non_null(in);
    for (size_t i = 0; i < n; i++) in[i] = (unsigned char)(i * 7);
    size_t zn = deflate_round_trip(in, n, 0, &z);
    assert_int_equal(zn, 2 + 3 * 5 + n + 4);
    const unsigned char *p = z + 2;
    static const size_t lens[3] = {65535, 65535, 10};
    for (int b = 0; b < 3; b++) {
        assert_int_equal(p[0], b == 2); /* BFINAL on the last only, BTYPE 00 */
        size_t len = p[1] | (size_t)p[2] << 8, nlen = p[3] | (size_t)p[4] << 8;
        assert_int_equal(len, lens[b]);
        assert_int_equal(nlen, ~len & 0xffff);
        assert_memory_equal(p + 5, in + 65535 * (size_t)b, len);
        p += 5 + len;
    }
    /* an empty input is one empty final block */
    assert_int_equal(deflate_round_trip(in, 0, 0, NULL), 2 + 5 + 4);
    free(z);
    free(in);
}

/* Kraft's sum of the lengths in units of 2^-limit; the code is complete when it is 2^limit. */
static uint64_t kraft(const uint8_t *len, int n, int limit)
{
    uint64_t sum = 0;
    for (int s = 0; s < n; s++)
        if (len[s]) sum += 1ull << (limit - len[s]);
    return sum;
}

static void test_huffman_lengths_are_limited_and_complete(void **state)
{
    (void)state;
    uint32_t freq[286] = {0};
    uint8_t len[286];
    /* Fibonacci counts: 24 bits deep unlimited, cut to 15 (and 7 for the code lengths' code) */
    for (int limit = 7; limit <= 15; limit += 8) {
        int n = limit == 7 ? 19 : 286, used = limit == 7 ? 19 : 25;
        memset(freq, 0, sizeof freq);
        fibonacci(freq + (n - used), used);
        wg__huffman_lengths(freq, n, limit, len);
        int max = 0;
        for (int s = 0; s < n; s++) {
            if (len[s] > max) max = len[s];
            if (!freq[s] && len[s]) fail_msg("symbol %d has no count but a code", s);
            if (freq[s] && !len[s]) fail_msg("symbol %d has a count but no code", s);
        }
        assert_int_equal(max, limit);
        assert_int_equal(kraft(len, n, limit), 1ull << limit);
        /* more frequent, never longer */
        for (int s = n - used + 1; s < n; s++) assert_true(len[s] <= len[s - 1]);
    }
    /* counts Huffman needs no limit for: the code is Huffman's (here, 1, 2, 3, 3) */
    memset(freq, 0, sizeof freq);
    freq[3] = 10, freq[7] = 5, freq[8] = 2, freq[9] = 2;
    wg__huffman_lengths(freq, 286, 15, len);
    assert_int_equal(len[3], 1);
    assert_int_equal(len[7], 2);
    assert_int_equal(len[8], 3);
    assert_int_equal(len[9], 3);
    /* one symbol, or none: completed to two codes of one bit */
    memset(freq, 0, sizeof freq);
    freq[5] = 9;
    wg__huffman_lengths(freq, 30, 15, len);
    assert_int_equal(len[5], 1);
    assert_int_equal(kraft(len, 30, 15), 1u << 15);
    memset(freq, 0, sizeof freq);
    wg__huffman_lengths(freq, 30, 15, len);
    assert_int_equal(kraft(len, 30, 15), 1u << 15);
}

/* A stream whose literal code needs the limit inflates. */
static void test_skewed_stream_inflates(void **state)
{
    (void)state;
    unsigned char *in;
    size_t n = skewed_bytes(&in);
    assert_true(unlimited_depth(in, n) > 15);
    deflate_round_trip(in, n, 1, NULL);
    deflate_round_trip(in, n, 3, NULL);
    free(in);
}

/* ---- PNG files, read by libpng -------------------------------------------------------------- */

typedef struct {
    const unsigned char *data;
    size_t size, at;
} Mem;

static void mem_read(png_structp png, png_bytep out, png_size_t n)
{
    Mem *m = png_get_io_ptr(png);
    if (m->at + n > m->size) png_error(png, "read past the end");
    memcpy(out, m->data + m->at, n);
    m->at += n;
}

/* The file's pixels through libpng's reader, 16-bit samples in host order (malloc'ed); fails
 * the test on any complaint of libpng's. */
static unsigned char *libpng_decode(const unsigned char *file, size_t size, int *w, int *h, int *c,
                                    int *bits)
{
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    assert_non_null(png);
    assert_non_null(info);
    Mem m = {file, size, 0};
    unsigned char *px = NULL;
    png_bytep *rows = NULL;
    if (setjmp(png_jmpbuf(png))) fail_msg("libpng refused the file");
    png_set_user_limits(png, 0x7fffffff, 0x7fffffff);
    png_set_read_fn(png, &m, mem_read);
    png_read_info(png, info);
    *w = (int)png_get_image_width(png, info);
    *h = (int)png_get_image_height(png, info);
    *c = png_get_channels(png, info);
    *bits = png_get_bit_depth(png, info);
    if (*bits == 16) {
        uint16_t probe = 1;
        unsigned char first;
        memcpy(&first, &probe, 1);
        if (first) png_set_swap(png); /* little-endian host */
    }
    png_read_update_info(png, info);
    size_t row = png_get_rowbytes(png, info);
    px = malloc(row * (size_t)*h + 1);
    rows = malloc(sizeof *rows * (size_t)*h + 1);
    assert_non_null(px);
    assert_non_null(rows);
    for (int y = 0; y < *h; y++) rows[y] = px + row * (size_t)y;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    return px;
}

enum { FLAT, NOISE, RUNS, GRADIENT, SKEWED, CONTENTS };
static const char *const content_names[] = {"flat", "noise", "runs", "gradient", "skewed"};

/* Samples of one content: bytes per sample `bytes`, host order. */
static void fill(unsigned char *px, int w, int h, int c, int bytes, int content)
{
    size_t n = (size_t)w * (size_t)h * (size_t)c;
    unsigned char *skew = NULL;
    size_t skew_n = content == SKEWED ? skewed_bytes(&skew) : 0;
    for (size_t i = 0; i < n; i++) {
        size_t x = i / (size_t)c % (size_t)w, y = i / (size_t)c / (size_t)w, k = i % (size_t)c;
        uint32_t v = content == FLAT       ? 0x9a5e
                     : content == NOISE    ? next_rand()
                     : content == RUNS     ? (uint32_t)((x / 37 + y / 5) % 3) * 0x5151
                     : content == GRADIENT ? (uint32_t)(x * 517 + y * 1031 + k * 77)
                                           : skew[i % skew_n];
        if (bytes == 1) {
            px[i] = (unsigned char)(content == SKEWED ? v : v >> 4);
        } else {
            uint16_t s = (uint16_t)v;
            memcpy(px + 2 * i, &s, 2);
        }
    }
    free(skew);
}

static const char *const mode_names[] = {"fast", "deflate", "none"};

static void round_trip(int w, int h, int c, int bits, int content, WgPngCompression mode)
{
    size_t raw = (size_t)w * (size_t)h * (size_t)c * (size_t)(bits / 8);
    unsigned char *px = malloc(raw + 1), *file;
    assert_non_null(px);
    fill(px, w, h, c, bits / 8, content);
    size_t size;
    char msg[256];
    if (wg__png_encode(px, w, h, c, bits, mode, &file, &size, msg, sizeof msg))
        fail_msg("%s %dx%d c%d %d-bit %s: %s", mode_names[mode], w, h, c, bits,
                 content_names[content], msg);
    int rw, rh, rc, rbits;
    unsigned char *back = libpng_decode(file, size, &rw, &rh, &rc, &rbits);
    if (rw != w || rh != h || rc != c || rbits != bits || memcmp(back, px, raw))
        fail_msg("%s %dx%d c%d %d-bit %s: read back as %dx%d c%d %d-bit%s", mode_names[mode], w, h,
                 c, bits, content_names[content], rw, rh, rc, rbits,
                 rw == w && rh == h && rc == c && rbits == bits ? ", other samples" : "");
    /* none: the raw rows, a filter byte each, in stored blocks (5 bytes each), the zlib stream
     * (6 bytes) in IDAT chunks of 8192 (12 bytes each), after the signature and IHDR and before
     * IEND (45 bytes) */
    size_t filtered = raw + (size_t)h, blocks = (filtered + 65534) / 65535;
    size_t zn = filtered + 6 + 5 * (blocks ? blocks : 1);
    if (mode == WG_PNG_COMPRESSION_NONE)
        assert_int_equal(size, 45 + 12 * ((zn + 8191) / 8192) + zn);
    free(back);
    wg_free(file);
    free(px);
}

static void test_every_mode_reads_back_through_libpng(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {3, 7}, {257, 5}, {64, 48}};
    int files = 0;
    for (int mode = 0; mode < 3; mode++)
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
            for (int c = 1; c <= 4; c++)
                for (int bits = 8; bits <= 16; bits += 8)
                    for (int content = 0; content < CONTENTS; content++) {
                        round_trip(sizes[si][0], sizes[si][1], c, bits, content,
                                   (WgPngCompression)mode);
                        files++;
                    }
    assert_int_equal(files, 3 * 4 * 4 * 2 * CONTENTS);
}

/* One row of the skewed bytes: its filter is none (the bytes are small), so the literal code
 * needs the 15-bit limit; and images large enough to be counted on a sample, with the pair and
 * four-literal coding. */
static void test_limited_and_sampled_images_read_back(void **state)
{
    (void)state;
    int w = (1 << 19) - 1;
    for (int mode = 0; mode < 3; mode++) {
        round_trip(w, 1, 1, 8, SKEWED, (WgPngCompression)mode);
        round_trip(w / 4, 2, 2, 8, SKEWED, (WgPngCompression)mode);
        round_trip(1024, 520, 4, 8, GRADIENT, (WgPngCompression)mode);
        round_trip(700, 400, 3, 16, NOISE, (WgPngCompression)mode);
        round_trip(1000, 300, 1, 16, RUNS, (WgPngCompression)mode);
        /* the fast mode's sample of rows: rows longer than a stretch and fewer rows than
         * stretches (stretches starting on the same row taken once), and rows so short that a
         * stretch runs past the next row that chooses its filter */
        round_trip(12000, 40, 3, 8, NOISE, (WgPngCompression)mode);
        round_trip(37, 30000, 1, 8, GRADIENT, (WgPngCompression)mode);
    }
}

/* in[0..n) coded in pieces cut at cuts[0..k) (ascending, within [0, n]) with one code for the
 * whole, concatenated behind a zlib header and before its Adler-32: zlib inflates it to in. */
static void pieces_round_trip(const unsigned char *in, size_t n, const size_t *cuts, int k)
{
    WgDeflateCode *code = wg__deflate_code(in, n, 1);
    assert_non_null(code);
    size_t guard = 64, total = 6;
    for (int i = 0; i <= k; i++) {
        size_t a = i ? cuts[i - 1] : 0, b = i < k ? cuts[i] : n;
        total += wg__deflate_piece_bound(b - a) + guard;
    }
    unsigned char *z = malloc(total), *back = malloc(n + 1), *piece = malloc(n + 128 + guard);
    assert_non_null(z);
    assert_non_null(back);
    assert_non_null(piece);
    z[0] = 0x78, z[1] = 0x01;
    size_t zn = 2;
    for (int i = 0; i <= k; i++) {
        size_t a = i ? cuts[i - 1] : 0, b = i < k ? cuts[i] : n;
        size_t cap = wg__deflate_piece_bound(b - a);
        memset(piece + cap, 0xa5, guard);
        size_t pn = wg__deflate_piece(code, in + a, b - a, i == k, piece, cap);
        if (!pn || pn > cap) fail_msg("piece [%zu, %zu): %zu bytes, bound %zu", a, b, pn, cap);
        for (size_t g = 0; g < guard; g++)
            if (piece[cap + g] != 0xa5) fail_msg("piece [%zu, %zu): written past the bound", a, b);
        memcpy(z + zn, piece, pn);
        zn += pn;
    }
    uLong adler = adler32(1, in, (uInt)n);
    z[zn++] = (unsigned char)(adler >> 24), z[zn++] = (unsigned char)(adler >> 16);
    z[zn++] = (unsigned char)(adler >> 8), z[zn++] = (unsigned char)adler;
    uLongf bn = n + 1;
    int rc = uncompress(back, &bn, z, zn);
    if (rc != Z_OK || bn != n || (n && memcmp(back, in, n)))
        fail_msg("n %zu in %d pieces: zlib says %d, %lu bytes back", n, k + 1, rc,
                 (unsigned long)bn);
    wg__deflate_code_free(code);
    free(z);
    free(back);
    free(piece);
}

static void test_pieces_inflate_as_one_stream(void **state)
{
    (void)state;
    /* runs, then noise: the code made for the whole fits neither half, and the noise's pieces
     * are not smaller coded than stored */
    size_t n = 300000;
    unsigned char *in = malloc(n);
    assert_non_null(in);
    for (size_t i = 0; i < n; i++)
        in[i] = i < n / 2 ? (unsigned char)(i / 1000 % 7) : (unsigned char)next_rand();
    const size_t one[] = {0}, ends[] = {n}, two[] = {n / 2}, empty[] = {5, 5, 5, 100000, 100000};
    size_t many[40];
    for (int i = 0; i < 40; i++) many[i] = (size_t)i * 7001 + (size_t)(i % 3);
    pieces_round_trip(in, n, one, 1);  /* an empty first piece */
    pieces_round_trip(in, n, ends, 1); /* an empty last piece */
    pieces_round_trip(in, n, two, 1);
    pieces_round_trip(in, n, empty, 5); /* empty pieces between */
    pieces_round_trip(in, n, many, 40);
    pieces_round_trip(in, n, NULL, 0);            /* one piece: as wg__zlib_fast */
    pieces_round_trip(in, 0, NULL, 0);            /* nothing at all */
    pieces_round_trip(in + n / 2, n / 2, two, 1); /* all noise: stored blocks */
    /* one piece makes wg__zlib_fast's stream, byte for byte */
    unsigned char *whole;
    size_t zn = deflate_round_trip(in, n, 1, &whole);
    WgDeflateCode *code = wg__deflate_code(in, n, 1);
    assert_non_null(code);
    unsigned char *piece = malloc(wg__deflate_piece_bound(n));
    assert_non_null(piece);
    size_t pn = wg__deflate_piece(code, in, n, true, piece, wg__deflate_piece_bound(n));
    assert_int_equal(pn + 6, zn);
    assert_memory_equal(piece, whole + 2, pn);
    wg__deflate_code_free(code);
    free(piece);
    free(whole);
    free(in);
}

/* Packed rows one after the other, handed out one at a time */
typedef struct {
    const unsigned char *px;
    size_t row;
} Rows;

static void row_of(void *user, int y, void *row)
{
    const Rows *r = user;
    memcpy(row, r->px + r->row * (size_t)y, r->row);
}

/* Scratch memory that counts what is out */
static atomic_long scratch_out;
static atomic_int scratch_taken;

static void *counted_alloc(const void *ctx, size_t bytes)
{
    (void)ctx;
    atomic_fetch_add(&scratch_out, (long)bytes);
    atomic_fetch_add(&scratch_taken, 1);
    return malloc(bytes);
}

static void counted_free(const void *ctx, void *p, size_t bytes)
{
    (void)ctx;
    atomic_fetch_sub(&scratch_out, (long)bytes);
    free(p);
}

/* A byte of a skewed distribution: short codes and, rarely, codes of the limit's length */
static unsigned char skewed_byte(void)
{
    uint32_t r = next_rand();
    int k = 0;
    while (k < 14 && (r & 1)) k++, r >>= 1;
    return (unsigned char)(k * 17 + (next_rand() % 17));
}

/* in[0..n) of one kind: 0 literals only (no byte equal to the one before), 1 literals with runs
 * of every length from 1 to 40 and of 70 at every offset, 2 mostly runs with short stretches of
 * literals between them, 3 uniform random bytes */
static void wide_input(unsigned char *in, size_t n, int kind)
{
    for (size_t i = 0; i < n;) {
        unsigned char b = kind == 3 ? (unsigned char)next_rand() : skewed_byte();
        if (kind == 0 && i && b == in[i - 1]) b++;
        in[i++] = b;
        if (kind == 1 && next_rand() % 24 == 0) {
            size_t run = next_rand() % 8 == 0 ? 70 : 1 + next_rand() % 40;
            for (size_t k = 0; k < run && i < n; k++, i++) in[i] = b;
        }
        if (kind == 2 && next_rand() % 3 == 0) {
            size_t run = 8 + next_rand() % 120;
            for (size_t k = 0; k < run && i < n; k++, i++) in[i] = b;
        }
    }
}

/* The wide coder (AVX-512 with VBMI, where the processor has it) gives the scalar coder's bits:
 * literals only, runs of many lengths at every offset of a block, at distances 1 to 8, lengths
 * around the block's size, a piece that outgrows stored blocks while the wide coder runs, and
 * long runs that start ever nearer that limit (both fall back to stored blocks, within the
 * bound). */
static void test_wide_coder_matches_scalar(void **state)
{
    (void)state;
    bool wide = wg__deflate_wide(true);
    if (!wide) print_message("no AVX-512 with VBMI here: the scalar coder alone is checked\n");
    unsigned long blocks = wg__deflate_wide_blocks();
    static const size_t sizes[] = {65536, 65536 + 31, 65536 + 64, 65536 + 65, 300000};
    static const int dists[] = {1, 3, 4, 8};
    size_t max = 300000, cap = wg__zlib_fast_bound(max);
    unsigned char *in = malloc(max), *a = malloc(cap), *b = malloc(cap), *back = malloc(max);
    assert_non_null(in);
    assert_non_null(a);
    assert_non_null(b);
    assert_non_null(back);
    for (int kind = 0; kind < 3; kind++)
        for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
            for (size_t di = 0; di < sizeof dists / sizeof *dists; di++) {
                size_t n = sizes[si];
                wide_input(in, n, kind);
                wg__deflate_wide(true);
                size_t an = wg__zlib_fast(in, n, dists[di], a, cap);
                wg__deflate_wide(false);
                size_t bn = wg__zlib_fast(in, n, dists[di], b, cap);
                if (!an || an != bn || memcmp(a, b, an))
                    fail_msg("kind %d, %zu bytes, distance %d: %zu bytes wide, %zu scalar", kind, n,
                             dists[di], an, bn);
                uLongf back_n = max;
                assert_int_equal(uncompress(back, &back_n, a, an), Z_OK);
                assert_int_equal(back_n, n);
                assert_memory_equal(back, in, n);
            }
    /* a code made for skewed bytes, a piece of uniform ones: longer than stored blocks */
    size_t n = 200000, guard = 64, pcap = wg__deflate_piece_bound(n);
    wide_input(in, n, 0);
    WgDeflateCode *code = wg__deflate_code(in, n, 1);
    assert_non_null(code);
    wide_input(in, n, 3);
    unsigned char *pa = malloc(pcap + guard), *pb = malloc(pcap + guard);
    assert_non_null(pa);
    assert_non_null(pb);
    memset(pa + pcap, 0xa5, guard);
    wg__deflate_wide(true);
    size_t an = wg__deflate_piece(code, in, n, true, pa, pcap);
    wg__deflate_wide(false);
    size_t bn = wg__deflate_piece(code, in, n, true, pb, pcap);
    assert_int_equal(an, bn);
    assert_memory_equal(pa, pb, an);
    assert_true(an >= n); /* stored */
    for (size_t g = 0; g < guard; g++) assert_int_equal(pa[pcap + g], 0xa5);
    /* the same code, uniform bytes (1.4 bytes each in it) and then a long run (a byte repeated,
     * about 1,500 bytes of matches) and a few more: from the fewest uniform bytes that make the
     * piece stored blocks on, the run starts ever closer to the limit, where the run's matches
     * would pass the piece's bound (the wide coder leaves such a run to the scalar parse) */
    size_t tail = 200, run_len = 200000, most = 700000;
    unsigned char *uni = malloc(most), *big = malloc(most + run_len + tail);
    assert_non_null(uni);
    assert_non_null(big);
    wide_input(uni, most, 3);
    size_t bcap = wg__deflate_piece_bound(most + run_len + tail);
    unsigned char *ba = malloc(bcap + guard), *bb = malloc(bcap + guard);
    assert_non_null(ba);
    assert_non_null(bb);
    size_t lo = 1000, hi = most; /* stored from hi on, not at lo */
    while (lo + 1 < hi) {
        size_t head = lo + (hi - lo) / 2, m = head + run_len + tail;
        memcpy(big, uni, head);
        memset(big + head, big[head - 1], run_len);
        memcpy(big + head + run_len, uni + head, tail);
        wg__deflate_wide(false);
        if (wg__deflate_piece(code, big, m, true, bb, wg__deflate_piece_bound(m)) >= m)
            hi = head;
        else
            lo = head;
    }
    assert_true(hi < most);
    for (size_t head = hi > 200 ? hi - 200 : 1; head < hi + 2000 && head < most; head += 25) {
        size_t m = head + run_len + tail, mcap = wg__deflate_piece_bound(m);
        memcpy(big, uni, head);
        memset(big + head, big[head - 1], run_len);
        memcpy(big + head + run_len, uni + head, tail);
        memset(ba + mcap, 0xa5, guard);
        wg__deflate_wide(true);
        an = wg__deflate_piece(code, big, m, true, ba, mcap);
        wg__deflate_wide(false);
        bn = wg__deflate_piece(code, big, m, true, bb, mcap);
        if (an != bn || memcmp(ba, bb, an))
            fail_msg("%zu uniform bytes, a run of %zu, %zu more: %zu bytes wide, %zu scalar", head,
                     run_len, tail, an, bn);
        for (size_t g = 0; g < guard; g++)
            if (ba[mcap + g] != 0xa5) fail_msg("%zu uniform bytes: written past the bound", head);
    }
    free(uni);
    free(big);
    free(ba);
    free(bb);
    wg__deflate_code_free(code);
    /* the wide coder ran where it can */
    if (wg__deflate_wide(true)) assert_true(wg__deflate_wide_blocks() > blocks + 1000);
    free(pa);
    free(pb);
    free(in);
    free(a);
    free(b);
    free(back);
}

/* The Adler-32 of pieces checked apart, combined, is zlib's of the whole: splits at the ends,
 * around the modulus (65521), bytes of 255 (the sums' largest) and random ones. */
static void test_adler32_of_pieces_combined(void **state)
{
    (void)state;
    enum { N = 300000 };
    unsigned char *in = malloc(N);
    assert_non_null(in);
    static const size_t splits[] = {0, 1, 5552, 65520, 65521, 65522, 131042, 200000, N - 1, N};
    for (int kind = 0; kind < 2; kind++) {
        for (size_t i = 0; i < N; i++) in[i] = kind ? (unsigned char)next_rand() : 255;
        uint32_t whole = (uint32_t)adler32(1, in, N);
        for (size_t s = 0; s < sizeof splits / sizeof *splits; s++) {
            size_t k = splits[s];
            uint32_t a = (uint32_t)adler32(1, in, (uInt)k),
                     b = (uint32_t)adler32(1, in + k, (uInt)(N - k));
            if (wg__adler32_combine(a, b, N - k) != whole)
                fail_msg("split at %zu of %s bytes", k, kind ? "random" : "255");
        }
        /* in three, combined left to right as the writer does */
        uint32_t check = 1;
        size_t cut[4] = {0, 70000, 70001, N};
        for (int j = 0; j < 3; j++)
            check = wg__adler32_combine(
                check, (uint32_t)adler32(1, in + cut[j], (uInt)(cut[j + 1] - cut[j])),
                cut[j + 1] - cut[j]);
        assert_int_equal(check, whole);
    }
    free(in);
}

static void test_pieces_on_threads_make_the_same_file(void **state)
{
    (void)state;
    static const int shapes[][4] = {/* w, h, channels, bits: several pieces, a short last one */
                                    {700, 900, 3, 8},
                                    {333, 2100, 1, 16},
                                    {1024, 300, 4, 8}};
    WgWorkers threads = {.run = wgt_run_backwards, .alloc = counted_alloc, .free = counted_free},
              stops = {.run = wgt_run_backwards, .ctx = &wgt_parts_run};
    for (size_t si = 0; si < sizeof shapes / sizeof *shapes; si++) {
        int w = shapes[si][0], h = shapes[si][1], c = shapes[si][2], bits = shapes[si][3];
        size_t raw = (size_t)w * (size_t)h * (size_t)c * (size_t)(bits / 8);
        unsigned char *px = malloc(raw);
        assert_non_null(px);
        fill(px, w, h, c, bits / 8, si == 1 ? NOISE : GRADIENT);
        Rows p = {px, (size_t)w * (size_t)c * (size_t)(bits / 8)};
        for (int mode = 0; mode < 3; mode++) {
            unsigned char *one, *many, *none = (unsigned char *)"";
            size_t one_n, many_n, none_n = 7;
            char msg[256];
            wgt_parts_run = 0;
            atomic_store(&scratch_taken, 0);
            assert_int_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode, row_of, &p,
                                                 false, NULL, &one, &one_n, msg, sizeof msg),
                             0);
            assert_int_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode, row_of, &p,
                                                 false, &threads, &many, &many_n, msg, sizeof msg),
                             0);
            /* filtered (and in the fast mode coded) in several pieces */
            if (wgt_parts_run < 2) fail_msg("%dx%d: %d parts", w, h, wgt_parts_run);
            /* the whole filtered image in the workers' memory, given back; the fast mode codes
             * each piece as it is filtered, and never holds the filtered image */
            assert_int_equal(atomic_load(&scratch_taken), mode == WG_PNG_COMPRESSION_FAST ? 0 : 1);
            assert_int_equal(atomic_load(&scratch_out), 0);
            assert_int_equal(many_n, one_n);
            assert_memory_equal(many, one, one_n);
            int rw, rh, rc, rbits;
            unsigned char *back = libpng_decode(many, many_n, &rw, &rh, &rc, &rbits);
            assert_int_equal(rw, w);
            assert_int_equal(rh, h);
            assert_memory_equal(back, px, raw);
            free(back);
            assert_int_not_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode, row_of,
                                                     &p, false, &stops, &none, &none_n, msg,
                                                     sizeof msg),
                                 0);
            assert_null(none);
            assert_int_equal(none_n, 0);
            /* a runner that leaves a piece out fails the encoding */
            WgWorkers skips = {.run = wgt_run_skipping_one};
            assert_int_not_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode, row_of,
                                                     &p, false, &skips, &none, &none_n, msg,
                                                     sizeof msg),
                                 0);
            assert_non_null(strstr(msg, "not coded"));
            wg_free(one);
            wg_free(many);
        }
        free(px);
    }
}

/* Rows all the same (an image of one value, or of one row repeated), packed and filtered once
 * a piece: the same file as row by row, in every mode, on one thread or several. */
static void test_same_rows_make_the_same_file(void **state)
{
    (void)state;
    static const int shapes[][4] = {{1, 1, 1, 8},      {5, 1, 3, 8},    {3, 2, 4, 16},
                                    {37, 33, 1, 8},    {64, 70, 2, 16}, {700, 900, 3, 8},
                                    {333, 2100, 1, 16}};
    WgWorkers threads = {.run = wgt_run_backwards};
    for (size_t si = 0; si < sizeof shapes / sizeof *shapes; si++) {
        int w = shapes[si][0], h = shapes[si][1], c = shapes[si][2], bits = shapes[si][3];
        size_t row = (size_t)w * (size_t)c * (size_t)(bits / 8), raw = row * (size_t)h;
        unsigned char *px = malloc(raw);
        assert_non_null(px);
        for (int value = 0; value < 2; value++) { /* one value, then one row repeated */
            fill(px, w, 1, c, bits / 8, value ? GRADIENT : FLAT);
            for (int y = 1; y < h; y++) memcpy(px + row * (size_t)y, px, row);
            Rows p = {px, row};
            for (int mode = 0; mode < 3; mode++)
                for (int t = 0; t < 2; t++) {
                    unsigned char *a, *b;
                    size_t an, bn;
                    char msg[256];
                    const WgWorkers *wk = t ? &threads : NULL;
                    assert_int_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode,
                                                         row_of, &p, false, wk, &a, &an, msg,
                                                         sizeof msg),
                                     0);
                    assert_int_equal(wg__png_encode_rows(w, h, c, bits, (WgPngCompression)mode,
                                                         row_of, &p, true, wk, &b, &bn, msg,
                                                         sizeof msg),
                                     0);
                    if (an != bn || memcmp(a, b, an))
                        fail_msg("%dx%d c%d %d-bit %s, %s: %zu bytes against %zu", w, h, c, bits,
                                 mode_names[mode], value ? "a row repeated" : "one value", bn, an);
                    wg_free(a);
                    wg_free(b);
                }
        }
        free(px);
    }
}

/* The fast mode on rendered-like content is far smaller than the raw rows. */
static void test_fast_mode_compresses(void **state)
{
    (void)state;
    int w = 512, h = 256, c = 4;
    unsigned char *px = malloc((size_t)w * h * c), *file;
    assert_non_null(px);
    fill(px, w, h, c, 1, GRADIENT);
    size_t size;
    char msg[256];
    assert_int_equal(
        wg__png_encode(px, w, h, c, 8, WG_PNG_COMPRESSION_FAST, &file, &size, msg, sizeof msg), 0);
    assert_true(size < (size_t)w * h * c / 4);
    wg_free(file);
    free(px);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fast_streams_inflate_through_zlib),
        cmocka_unit_test(test_sampled_counts_never_overflow),
        cmocka_unit_test(test_stored_blocks_split_at_65535),
        cmocka_unit_test(test_huffman_lengths_are_limited_and_complete),
        cmocka_unit_test(test_skewed_stream_inflates),
        cmocka_unit_test(test_every_mode_reads_back_through_libpng),
        cmocka_unit_test(test_limited_and_sampled_images_read_back),
        cmocka_unit_test(test_fast_mode_compresses),
        cmocka_unit_test(test_pieces_inflate_as_one_stream),
        cmocka_unit_test(test_adler32_of_pieces_combined),
        cmocka_unit_test(test_wide_coder_matches_scalar),
        cmocka_unit_test(test_pieces_on_threads_make_the_same_file),
        cmocka_unit_test(test_same_rows_make_the_same_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
