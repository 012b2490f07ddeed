/* SPDX-License-Identifier: MIT */
/* A fast zlib encoder for PNG's filtered rows, in the spirit of Google's fpnge: no search for
 * matches, only Huffman coding of the bytes plus runs (a run of at least 8 bytes each equal to
 * the one `dist` bytes before it, found 8 bytes at a time, coded as matches at that distance), in
 * one final dynamic block (RFC 1951). The block's code comes from a histogram of the input (for
 * inputs from 1 MiB of 16 KiB stretches spread over it, a quarter of it or 512 KiB, whichever is
 * less; every symbol counted once more so that each has a code): Huffman's tree, limited by the
 * heuristic of zlib and miniz (overlong codes are cut to the limit and the Kraft sum repaired by
 * lengthening the longest shorter code) to 14 bits for literals and lengths, so that four
 * literals always fit the 64-bit bit buffer in one put (on the wet material's outputs the files
 * are 0.3% larger than with deflate's 15), and 15 for distances. Literals go four to a write,
 * and where the processor has AVX-512 with VBMI, the literals and the runs between them go
 * through the wide coder below, with the same bits. One pass counts, one pass codes; when the
 * block would not be smaller than stored blocks (known from the count, and checked while coding)
 * the input goes in stored blocks instead, so the output never exceeds wg__zlib_fast_bound. A
 * stream can also be coded in pieces, each on its own thread: one code made from the histogram of
 * the whole (wg__deflate_code, or wg__deflate_code_of given the stretches to count, for a caller
 * that makes the stream a piece at a time and samples it itself), then each piece a block of its
 * own with that code (wg__deflate_piece), ended on a byte boundary by an empty stored block (as
 * zlib's full flush ends one), so that the pieces are simply concatenated; a piece that would not
 * be smaller than stored goes in stored blocks alone. Measured on the filtered rows of the wet
 * material's 23 outputs at 2048² (218 MB; AMD EPYC, one core), filtering included: 1600 MB/s
 * (1200 without the wide coder), against 232 MB/s for libdeflate's level 1, for streams 0.3%
 * smaller than its. Stored blocks (wg__zlib_stored) write the bytes as they are, 5 bytes more per
 * 65535. */
#include "internal.h"
#include "wgio.h"

#include <libdeflate.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

/* The wide coder (AVX-512 with VBMI's byte permutes, chosen at run time): see wide_literals. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#include <immintrin.h>
#define WIDE_CODER 1
#define WIDE __attribute__((target("avx512f,avx512bw,avx512vl,avx512vbmi")))
#define HAS_WIDE (__builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vbmi"))
#else
#define WIDE_CODER 0
#define HAS_WIDE 0
#endif
#define WIDE_BYTES 32 /* literals a block of the wide coder */

#define MAX_BITS 15   /* literal/length and distance codes */
#define MAX_CL_BITS 7 /* the code lengths' code */
#define LIT_BITS 14   /* literals and lengths: four literals fit the bit buffer in one put */
#define STORED_MAX 65535
#define SAMPLE_MIN (1 << 20) /* inputs from this size are counted on a sample: */
#define SAMPLE_BYTES 16384   /* stretches of SAMPLE_BYTES spread evenly, */
#define SAMPLE_STEP 4        /* every SAMPLE_STEP-th at least, */
#define SAMPLE_STRETCHES 32  /* about SAMPLE_STRETCHES of them */

/* ---- canonical, length-limited Huffman codes ------------------------------------------------ */

static void sort_by_freq(int *sym, const uint32_t *freq, int n)
{
    for (int i = 1; i < n; i++) { /* insertion sort: n <= 286, and mostly sorted */
        int s = sym[i], j = i;
        while (j > 0 && freq[sym[j - 1]] > freq[s]) {
            sym[j] = sym[j - 1];
            j--;
        }
        sym[j] = s;
    }
}

void wg__huffman_lengths(const uint32_t *freq, int n, int limit, uint8_t *len)
{
    int sym[320], m = 0;
    uint64_t w[640];
    int parent[640], depth[640], count[64] = {0};
    memset(len, 0, (size_t)n);
    for (int s = 0; s < n; s++)
        if (freq[s]) sym[m++] = s;
    /* a code of one symbol is incomplete: add one (of length 1 too) so that every code is
     * complete, which every inflater takes */
    for (int s = 0; m < 2 && s < n; s++)
        if (!freq[s] && (m == 0 || sym[0] != s)) sym[m++] = s;
    sort_by_freq(sym, freq, m);
    for (int i = 0; i < m; i++) w[i] = freq[sym[i]] ? freq[sym[i]] : 1;
    /* Huffman's tree on two queues: the sorted leaves, and the internal nodes as made (their
     * weights grow) */
    int leaf = 0, node = m;
    for (int next = m; next < 2 * m - 1; next++) {
        int pick[2];
        for (int k = 0; k < 2; k++)
            pick[k] = leaf < m && (node >= next || w[leaf] <= w[node]) ? leaf++ : node++;
        w[next] = w[pick[0]] + w[pick[1]];
        parent[pick[0]] = parent[pick[1]] = next;
    }
    depth[2 * m - 2] = 0;
    for (int k = 2 * m - 3; k >= 0; k--) depth[k] = depth[parent[k]] + 1;
    int max = 0;
    for (int i = 0; i < m; i++) {
        count[depth[i] < limit ? depth[i] : limit]++;
        if (depth[i] > max) max = depth[i];
    }
    if (max > limit) {
        /* the leaves cut to `limit` overfill the code: each step takes one leaf of length
         * `limit` out and puts it beside the longest shorter one (which becomes two one bit
         * longer), lowering the Kraft sum by one unit of 2^-limit */
        uint32_t total = 0;
        for (int i = 1; i <= limit; i++) total += (uint32_t)count[i] << (limit - i);
        while (total > (1u << limit)) {
            count[limit]--;
            for (int i = limit - 1; i > 0; i--)
                if (count[i]) {
                    count[i]--;
                    count[i + 1] += 2;
                    break;
                }
            total--;
        }
    }
    /* the most frequent symbols (the end of sym) get the shortest codes */
    int at = m - 1;
    for (int l = 1; l <= limit; l++)
        for (int k = 0; k < count[l]; k++) len[sym[at--]] = (uint8_t)l;
}

/* Canonical codes (RFC 1951 3.2.2) of the lengths, bit-reversed for a writer that fills bytes
 * from their least significant bit. */
static void canonical_codes(const uint8_t *len, int n, uint16_t *code)
{
    int count[MAX_BITS + 1] = {0};
    uint32_t next[MAX_BITS + 2];
    for (int s = 0; s < n; s++) count[len[s]]++;
    count[0] = 0;
    uint32_t c = 0;
    for (int l = 1; l <= MAX_BITS; l++) {
        c = (c + (uint32_t)count[l - 1]) << 1;
        next[l] = c;
    }
    for (int s = 0; s < n; s++) {
        if (!len[s]) {
            code[s] = 0;
            continue;
        }
        uint32_t v = next[len[s]]++, r = 0;
        for (int b = 0; b < len[s]; b++) r |= ((v >> b) & 1u) << (len[s] - 1 - b);
        code[s] = (uint16_t)r;
    }
}

/* ---- bits ------------------------------------------------------------------------------------ */

typedef struct {
    uint64_t buf;
    unsigned n;        /* bits in buf, < 64 */
    unsigned char *at; /* 8 bytes writable past the end of the bits */
} Bits;

/* bits must fit: n + k <= 63 (flush shifts the buffer by whole bytes below 64). Every put is
 * followed by a flush, which leaves at most 7 bits, and no put is longer than 56 bits (four
 * literals, or two fours that fit). */
static inline void put(Bits *b, uint64_t v, unsigned k)
{
    b->buf |= v << b->n;
    b->n += k;
}

/* Writes the whole bytes of buf (an 8-byte store, little-endian), keeping the rest. */
static inline void flush(Bits *b)
{
    uint64_t v = b->buf;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    v = __builtin_bswap64(v);
#endif
    memcpy(b->at, &v, 8);
    b->at += b->n >> 3;
    b->buf >>= b->n & 56;
    b->n &= 7;
}

/* The first k of the four literals at p (k <= 4; all four are read) in one put: codes of at most
 * LIT_BITS bits, so that the four fit beside the 7 bits the buffer may hold. */
static inline void put_quad(Bits *b, const uint64_t *lit, const unsigned char *p, unsigned k)
{
    uint64_t v = 0;
    unsigned len = 0;
    for (unsigned j = 0; j < 4; j++) {
        uint64_t e = lit[p[j]], m = -(uint64_t)(j < k);
        v |= (e & 0xffffffff & m) << len;
        len += (unsigned)(e >> 32) & (unsigned)m;
    }
    put(b, v, len);
    flush(b);
}

/* ---- the parse: literals and runs ------------------------------------------------------------ */

static inline uint64_t load64(const unsigned char *p)
{
    uint64_t v;
    memcpy(&v, p, 8);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    v = __builtin_bswap64(v);
#endif
    return v;
}

/* Length 3..258 -> symbol 257..285 and its extra bits (RFC 1951 3.2.5). */
static void length_code(int length, int *sym, int *extra_bits, int *extra)
{
    static const uint16_t base[29] = {3,  4,  5,  6,   7,   8,   9,   10,  11, 13,
                                      15, 17, 19, 23,  27,  31,  35,  43,  51, 59,
                                      67, 83, 99, 115, 131, 163, 195, 227, 258};
    static const uint8_t bits[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                     2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
    int k = 28;
    while (base[k] > length) k--;
    *sym = 257 + k;
    *extra_bits = bits[k];
    *extra = length - base[k];
}

/* Distance 1..8 -> symbol and extra bits. */
static void distance_code(int dist, int *sym, int *extra_bits, int *extra)
{
    static const uint8_t base[6] = {1, 2, 3, 4, 5, 7};
    int k = dist <= 4 ? dist - 1 : dist <= 6 ? 4 : 5;
    *sym = k;
    *extra_bits = k >= 4;
    *extra = dist - base[k];
}

/* A run of `run` (>= 8) bytes as matches of at most 258, none shorter than 3. */
#define RUN_PIECES(run, EMIT)                                                                      \
    do {                                                                                           \
        size_t left_ = (run);                                                                      \
        while (left_) {                                                                            \
            size_t l_ = left_ > 258 ? 258 : left_;                                                 \
            if (left_ - l_ > 0 && left_ - l_ < 3) l_ = left_ - 3;                                  \
            EMIT(l_);                                                                              \
            left_ -= l_;                                                                           \
        }                                                                                          \
    } while (0)

/* The parse, shared by the counting and the coding pass: for each stretch of literals
 * LITS(from, count), for each run RUN(from, to) (at least 8 bytes). Runs are looked for a
 * word at a time: when the 8 bytes at i equal those `dist` before, a run starts there; otherwise
 * the bytes up to the last one that differs are literals. */
#define PARSE(in, n, dist, LITS, RUN, BLOCK)                                                       \
    do {                                                                                           \
        size_t i_ = 0, d_ = (dist);                                                                \
        size_t head_ = d_ < (n) ? d_ : (n);                                                        \
        if (head_) LITS(0, head_);                                                                 \
        i_ = head_;                                                                                \
        while (i_ + 8 <= (n)) {                                                                    \
            BLOCK(i_);                                                                             \
            uint64_t x_ = load64((in) + i_) ^ load64((in) + i_ - d_);                              \
            if (x_) {                                                                              \
                size_t k_ = (size_t)(63 - __builtin_clzll(x_)) / 8 + 1;                            \
                LITS(i_, k_);                                                                      \
                i_ += k_;                                                                          \
                continue;                                                                          \
            }                                                                                      \
            size_t j_ = i_ + 8;                                                                    \
            while (j_ + 8 <= (n) && load64((in) + j_) == load64((in) + j_ - d_)) j_ += 8;          \
            while (j_ < (n) && (in)[j_] == (in)[j_ - d_]) j_++;                                    \
            RUN(i_, j_);                                                                           \
            i_ = j_;                                                                               \
        }                                                                                          \
        if (i_ < (n)) LITS(i_, (n)-i_);                                                            \
    } while (0)

/* ---- the zlib stream --------------------------------------------------------------------------
 */

size_t wg__zlib_fast_bound(size_t n)
{
    /* stored blocks (the fallback) plus the zlib header and trailer, and the 8 bytes the bit
     * writer stores past its end */
    return n + 5 * (n / STORED_MAX + 1) + 6 + 8;
}

static size_t zlib_tail(const unsigned char *in, size_t n, unsigned char *out)
{
    uint32_t a = libdeflate_adler32(1, in, n);
    out[0] = (unsigned char)(a >> 24);
    out[1] = (unsigned char)(a >> 16);
    out[2] = (unsigned char)(a >> 8);
    out[3] = (unsigned char)a;
    return 4;
}

/* Stored blocks of in[0..n), at least one (empty for n = 0), BFINAL on the last when `last`.
 * Byte-aligned already: nothing needs flushing. */
static unsigned char *stored_blocks(const unsigned char *in, size_t n, bool last, unsigned char *p)
{
    size_t at = 0;
    do {
        size_t k = n - at < STORED_MAX ? n - at : STORED_MAX;
        *p++ = last && at + k == n; /* BFINAL, BTYPE 00, padded to the byte */
        p[0] = (unsigned char)k, p[1] = (unsigned char)(k >> 8);
        p[2] = (unsigned char)~k, p[3] = (unsigned char)(~k >> 8);
        memcpy(p + 4, in + at, k);
        p += 4 + k;
        at += k;
    } while (at < n);
    return p;
}

size_t wg__zlib_stored(const unsigned char *in, size_t n, unsigned char *out, size_t cap)
{
    size_t blocks = n / STORED_MAX + 1;
    if (cap < n + 5 * blocks + 6) return 0;
    out[0] = 0x78, out[1] = 0x01; /* deflate, 32 KiB window, fastest */
    unsigned char *p = stored_blocks(in, n, true, out + 2);
    p += zlib_tail(in, n, p);
    return (size_t)(p - out);
}

struct WgDeflateCode {
    bool stored; /* coding would not be smaller than stored blocks */
    int dist, hlit, hdist, hclen, nc;
    size_t header_bytes; /* a block's header: its code lengths, coded */
    uint8_t cl_len[19], cl_sym[286 + 30], cl_extra[286 + 30];
    uint16_t cl_code[19], lit_code[286];
    uint8_t lit_len[286];
    uint64_t mcode[259]; /* a match of length l in one put: length and distance, codes and extra */
    uint8_t mlen[259];
    uint64_t lit[256]; /* a literal's code in the low 32 bits, its length above */
    /* the wide coder's tables: each literal's code length and the code's low and high bytes */
    uint8_t wide_len[256], wide_lo[256], wide_hi[256];
};

WgDeflateCode *wg__deflate_code(const unsigned char *in, size_t n, int dist)
{
    /* Large inputs are counted on a sample, every SAMPLE_STEP-th SAMPLE_BYTES or sparser, 512
     * KiB in all for large images (on the wet material's outputs at 2048², a fifth less time to
     * encode than a quarter of the bytes, for files as large); the coding then checks that each
     * block stays below the stored size. */
    WgBytes sample[SAMPLE_STRETCHES + SAMPLE_STRETCHES / SAMPLE_STEP + 1]; /* ceil(n / step) */
    int k = 0;
    bool sampled = n >= SAMPLE_MIN;
    size_t stride = n / SAMPLE_STRETCHES / SAMPLE_BYTES;
    size_t step = !sampled ? n : (stride > SAMPLE_STEP ? stride : SAMPLE_STEP) * SAMPLE_BYTES;
    for (size_t c0 = 0; c0 < n; c0 += step) {
        size_t c1 = sampled && n - c0 > SAMPLE_BYTES ? c0 + SAMPLE_BYTES : n;
        sample[k++] = (WgBytes){in + c0, c1 - c0};
    }
    return wg__deflate_code_of(sample, k, n, dist);
}

WgDeflateCode *wg__deflate_code_of(const WgBytes *sample, int stretches, size_t n, int dist)
{
    WgDeflateCode *c = wg_calloc(1, sizeof *c);
    if (!c) return NULL;
    if (dist < 1 || dist > 8) dist = 1;
    c->dist = dist;
    size_t counted = 0;
    for (int k = 0; k < stretches; k++) counted += sample[k].n;
    if (!n || !counted) {
        c->stored = true;
        return c;
    }
    /* the count */
    uint32_t lit_freq[4][286] = {{0}}, dist_freq[30] = {0};
    int msym[259], mbits[259], mextra[259], dsym, dbits, dextra;
    for (int l = 3; l <= 258; l++) length_code(l, &msym[l], &mbits[l], &mextra[l]);
    distance_code(dist, &dsym, &dbits, &dextra);
    uint64_t matches = 0;
    /* Every byte counted as a literal, then the bytes of runs taken off again: the counting
     * loop runs without the parse's branches. */
    for (int k = 0; k < stretches; k++) {
        const unsigned char *ch = sample[k].p;
        size_t cn = sample[k].n, q = 0;
        for (; q + 4 <= cn; q += 4) { /* four tables: no wait on the same counter */
            lit_freq[0][ch[q]]++;
            lit_freq[1][ch[q + 1]]++;
            lit_freq[2][ch[q + 2]]++;
            lit_freq[3][ch[q + 3]]++;
        }
        for (; q < cn; q++) lit_freq[0][ch[q]]++;
#define COUNT_LITS(from, k) (void)0
#define COUNT_MATCH(l)                                                                             \
    do {                                                                                           \
        lit_freq[1][msym[l]]++;                                                                    \
        matches++;                                                                                 \
    } while (0)
#define COUNT_RUN(from, to)                                                                        \
    do {                                                                                           \
        if (dist == 1) {                                                                           \
            lit_freq[2][ch[(from)-1]] -= (uint32_t)((to) - (from));                                \
        } else {                                                                                   \
            for (size_t t_ = (from); t_ < (to); t_++) lit_freq[2][ch[t_]]--;                       \
        }                                                                                          \
        RUN_PIECES((to) - (from), COUNT_MATCH);                                                    \
    } while (0)
#define COUNT_BLOCK(i) (void)0
        PARSE(ch, cn, (size_t)dist, COUNT_LITS, COUNT_RUN, COUNT_BLOCK);
    }
    /* Every symbol counted once more, so that each has a code: the bytes a sample missed, and
     * the run lengths and the distance of a piece whose runs the whole's parse cut otherwise
     * (a run across a piece's end is two shorter runs, or none). */
    for (int s = 0; s < 286; s++)
        lit_freq[0][s] += lit_freq[1][s] + lit_freq[2][s] + lit_freq[3][s] + 1;
    lit_freq[0][256] = 1; /* end of block */
    dist_freq[dsym] = (uint32_t)matches + 1;
    uint8_t lens[286 + 30];
    uint8_t *lit_len = lens, *dist_len = lens + 286;
    wg__huffman_lengths(lit_freq[0], 286, LIT_BITS, lit_len);
    wg__huffman_lengths(dist_freq, 30, MAX_BITS, dist_len);
    int hlit = 286, hdist = 30;
    while (hlit > 257 && !lit_len[hlit - 1]) hlit--;
    while (hdist > 1 && !dist_len[hdist - 1]) hdist--;
    /* the code lengths, run-length coded (RFC 1951 3.2.7): symbols 0..18 with extra bits */
    uint8_t seq[286 + 30];
    int ns = 0, nc = 0;
    memcpy(seq, lit_len, (size_t)hlit);
    memcpy(seq + hlit, dist_len, (size_t)hdist);
    ns = hlit + hdist;
    uint32_t cl_freq[19] = {0};
    for (int i = 0; i < ns;) {
        int j = i + 1;
        while (j < ns && seq[j] == seq[i]) j++;
        int run = j - i;
        if (seq[i] == 0 && run >= 3) {
            int k = run > 138 ? 138 : run;
            c->cl_sym[nc] = k >= 11 ? 18 : 17;
            c->cl_extra[nc++] = (uint8_t)(k >= 11 ? k - 11 : k - 3);
            i += k;
        } else if (seq[i] != 0 && run >= 4) {
            c->cl_sym[nc] = seq[i];
            c->cl_extra[nc++] = 0;
            int k = run - 1 > 6 ? 6 : run - 1;
            c->cl_sym[nc] = 16;
            c->cl_extra[nc++] = (uint8_t)(k - 3);
            i += 1 + k;
        } else {
            c->cl_sym[nc] = seq[i];
            c->cl_extra[nc++] = 0;
            i++;
        }
    }
    for (int k = 0; k < nc; k++) cl_freq[c->cl_sym[k]]++;
    uint16_t dist_code_[30];
    wg__huffman_lengths(cl_freq, 19, MAX_CL_BITS, c->cl_len);
    canonical_codes(c->cl_len, 19, c->cl_code);
    canonical_codes(lit_len, 286, c->lit_code);
    canonical_codes(dist_len, 30, dist_code_);
    memcpy(c->lit_len, lit_len, sizeof c->lit_len);
    static const uint8_t order[19] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                      11, 4,  12, 3, 13, 2, 14, 1, 15};
    int hclen = 19;
    while (hclen > 4 && !c->cl_len[order[hclen - 1]]) hclen--;
    c->hlit = hlit, c->hdist = hdist, c->hclen = hclen, c->nc = nc;
    /* the block's size in bits, known before it is written: stored blocks when not smaller */
    static const uint8_t cl_extra_bits[19] = {[16] = 2, [17] = 3, [18] = 7};
    uint64_t bits = 3 + 5 + 5 + 4 + 3 * (uint64_t)hclen;
    for (int k = 0; k < nc; k++) bits += c->cl_len[c->cl_sym[k]] + cl_extra_bits[c->cl_sym[k]];
    c->header_bytes = (size_t)(bits + 7) / 8;
    for (int s = 0; s < 286; s++) {
        uint64_t extra = s >= 265 && s < 285 ? (uint64_t)(s - 261) / 4 : 0;
        bits += (uint64_t)lit_freq[0][s] * (lit_len[s] + extra);
    }
    bits += matches * (uint64_t)(dist_len[dsym] + dbits);
    size_t stored = n + 5 * (n / STORED_MAX + 1);
    if ((double)bits / 8 * ((double)n / (double)counted) + 1 >= (double)stored) {
        c->stored = true;
        return c;
    }
    for (int l = 3; l <= 258; l++) {
        int s = msym[l];
        uint64_t v = c->lit_code[s];
        unsigned k = lit_len[s];
        v |= (uint64_t)mextra[l] << k;
        k += (unsigned)mbits[l];
        v |= (uint64_t)dist_code_[dsym] << k;
        k += dist_len[dsym];
        v |= (uint64_t)dextra << k;
        k += (unsigned)dbits;
        c->mcode[l] = v;
        c->mlen[l] = (uint8_t)k;
    }
    for (int s = 0; s < 256; s++) c->lit[s] = c->lit_code[s] | (uint64_t)lit_len[s] << 32;
    for (int s = 0; s < 256; s++) {
        c->wide_len[s] = lit_len[s];
        c->wide_lo[s] = (uint8_t)c->lit_code[s];
        c->wide_hi[s] = (uint8_t)(c->lit_code[s] >> 8);
    }
    return c;
}

void wg__deflate_code_free(WgDeflateCode *c)
{
    wg_free(c);
}

/* ---- the wide coder --------------------------------------------------------------------------
 * Literals coded WIDE_BYTES at a time with AVX-512: each byte's code length and code looked up by
 * VBMI's byte permutes (each 256-entry table in four registers), the codes joined in pairs and
 * then fours by variable shifts, and a block's eight fours put through the bit buffer (the scalar
 * coder puts fours too, but reaches them through a table lookup and the parse's branches a word
 * at a time). A block is coded up to the first position where a run can start (8 bytes from
 * there equal to the bytes `dist` before them, the 7 bytes after the block taken into account),
 * all of it when there is none; the parse then codes the run. The scalar parse finds a run
 * exactly where one can start and codes every other byte as a literal, so the bits are the same
 * as the scalar coder's (tested): the wide coder is an equivalent fast path, not another parse.
 * On the filtered rows of the wet material's outputs at 2048² (AMD EPYC, one core) the encoder
 * takes 133-138 ms with it, 180-185 ms without. */

static atomic_int wide_mode = -1; /* -1: not decided yet */
static _Thread_local unsigned long wide_blocks; /* blocks the wide coder coded on this thread,
                                                   for the tests */

bool wg__deflate_wide(bool on)
{
    atomic_store(&wide_mode, on && WIDE_CODER && HAS_WIDE);
    return atomic_load(&wide_mode);
}

unsigned long wg__deflate_wide_blocks(void)
{
    return wide_blocks;
}

static bool wide_on(void)
{
    int v = atomic_load_explicit(&wide_mode, memory_order_relaxed);
    if (v < 0) atomic_store(&wide_mode, v = WIDE_CODER && HAS_WIDE);
    return v;
}

#if WIDE_CODER
/* The 256-entry byte table t at the bytes of x */
WIDE static inline __m512i wide_lookup(const __m512i t[4], __m512i x)
{
    __m512i low = _mm512_permutex2var_epi8(t[0], x, t[1]);  /* bytes 0..127: index bits 0..6 */
    __m512i high = _mm512_permutex2var_epi8(t[2], x, t[3]); /* bytes 128..255 */
    return _mm512_mask_blend_epi8(_mm512_movepi8_mask(x), low, high);
}

/* 32 literals' codes (16-bit lanes) and lengths joined into 8 fours (64-bit lanes): each pair
 * as the first code then the second shifted by the first's length, then each pair of pairs. */
WIDE static inline void wide_fours(__m512i code, __m512i len, uint64_t *codes, uint64_t *lens)
{
    __m512i lo16 = _mm512_set1_epi32(0xffff), lo32 = _mm512_set1_epi64(0xffffffff);
    __m512i l1 = _mm512_and_si512(len, lo16);
    code = _mm512_or_si512(_mm512_and_si512(code, lo16),
                           _mm512_sllv_epi32(_mm512_srli_epi32(code, 16), l1));
    len = _mm512_add_epi32(l1, _mm512_srli_epi32(len, 16));
    __m512i l2 = _mm512_and_si512(len, lo32);
    code = _mm512_or_si512(_mm512_and_si512(code, lo32),
                           _mm512_sllv_epi64(_mm512_srli_epi64(code, 32), l2));
    len = _mm512_add_epi64(l2, _mm512_srli_epi64(len, 32));
    _mm512_storeu_si512(codes, code);
    _mm512_storeu_si512(lens, len);
}

/* From i, blocks of literals and the runs between them, as the scalar parse finds and codes
 * them, while the bits stay below `stop` and 2 x WIDE_BYTES bytes are left (the look past the
 * block): returns where it stopped, which is where a run starts when that run's matches might
 * pass `stop` (the scalar parse codes it, and sees the limit). Codes of at most LIT_BITS bits (a
 * four fits the bit buffer beside the 7 bits it may hold). */
WIDE static size_t wide_literals(const WgDeflateCode *c, const unsigned char *in, size_t i,
                                 size_t n, size_t dist, Bits *bits, const unsigned char *stop)
{
    __m512i tlen[4], tlo[4], thi[4];
    for (int k = 0; k < 4; k++) {
        tlen[k] = _mm512_loadu_si512(c->wide_len + 64 * k);
        tlo[k] = _mm512_loadu_si512(c->wide_lo + 64 * k);
        thi[k] = _mm512_loadu_si512(c->wide_hi + 64 * k);
    }
    Bits b = *bits;
    unsigned long blocks = 0;
    while (i + 2 * WIDE_BYTES <= n && b.at <= stop) {
        __m256i x32 = _mm256_loadu_si256((const void *)(in + i));
        uint64_t eq =
            _mm256_cmpeq_epi8_mask(x32, _mm256_loadu_si256((const void *)(in + i - dist)));
        uint64_t next =
            _mm256_cmpeq_epi8_mask(_mm256_loadu_si256((const void *)(in + i + WIDE_BYTES)),
                                   _mm256_loadu_si256((const void *)(in + i + WIDE_BYTES - dist)));
        /* positions whose 8 bytes from there all equal those before: where 8 ones in a row of
         * the 64 comparisons start (2 in a row, then 4, then 8) */
        uint64_t run = eq | next << 32;
        run &= run >> 1;
        run &= run >> 2;
        run &= run >> 4;
        run &= 0xffffffffu;
        /* the literals before the first run, all 32 when there is none */
        unsigned take = run ? (unsigned)__builtin_ctzll(run) : WIDE_BYTES;
        if (!take) goto run;
        __mmask32 keep = (__mmask32)((1ull << take) - 1);
        __m512i x = _mm512_zextsi256_si512(x32);
        __m256i lo = _mm256_maskz_mov_epi8(keep, _mm512_castsi512_si256(wide_lookup(tlo, x)));
        __m256i hi = _mm256_maskz_mov_epi8(keep, _mm512_castsi512_si256(wide_lookup(thi, x)));
        __m256i len = _mm256_maskz_mov_epi8(keep, _mm512_castsi512_si256(wide_lookup(tlen, x)));
        __m512i code = _mm512_or_si512(_mm512_cvtepu8_epi16(lo),
                                       _mm512_slli_epi16(_mm512_cvtepu8_epi16(hi), 8));
        uint64_t codes[8], lens[8];
        wide_fours(code, _mm512_cvtepu8_epi16(len), codes, lens);
        /* two fours in one put when they fit beside the 7 bits the buffer may hold (flush
         * takes at most 63 bits) */
        for (int q = 0; q < 8; q += 2) {
            unsigned l0 = (unsigned)lens[q], l1 = (unsigned)lens[q + 1];
            if (l0 + l1 <= 56) {
                put(&b, codes[q] | codes[q + 1] << l0, l0 + l1);
                flush(&b);
            } else {
                put(&b, codes[q], l0);
                flush(&b);
                put(&b, codes[q + 1], l1);
                flush(&b);
            }
        }
        i += take;
        blocks++;
        if (take == WIDE_BYTES || i + 2 * WIDE_BYTES > n || b.at > stop) continue;
    run:; /* a run starts at i: its end as the scalar parse finds it */
        size_t j = i + 8;
        while (j + 8 <= n && load64(in + j) == load64(in + j - dist)) j += 8;
        while (j < n && in[j] == in[j - dist]) j++;
        /* a match writes at most 36 bits, so at most 5 bytes with the 7 the buffer may hold */
        if ((size_t)(stop - b.at) < 5 * ((j - i) / 258 + 1)) break;
#define WIDE_MATCH(l)                                                                              \
    do {                                                                                           \
        put(&b, c->mcode[l], c->mlen[l]);                                                          \
        flush(&b);                                                                                 \
    } while (0)
        RUN_PIECES(j - i, WIDE_MATCH);
#undef WIDE_MATCH
        i = j;
    }
    *bits = b;
    wide_blocks += blocks;
    return i;
}
#else
static size_t wide_literals(const WgDeflateCode *c, const unsigned char *in, size_t i, size_t n,
                            size_t dist, Bits *bits, const unsigned char *stop)
{
    (void)c, (void)in, (void)n, (void)dist, (void)bits, (void)stop;
    return i;
}
#endif

uint32_t wg__adler32_combine(uint32_t a, uint32_t b, size_t b_bytes)
{
    /* Adler-32 is (1 + sum of the bytes, n + sum of the running sums) mod 65521: appending b's
     * bytes adds their sum to the first half, and to the second b's own second half plus
     * b_bytes times a's first half less the 1 that b's first half already holds */
    const uint64_t mod = 65521;
    uint64_t a1 = a & 0xffff, a2 = a >> 16, b1 = b & 0xffff, b2 = b >> 16;
    uint64_t s1 = (a1 + b1 + mod - 1) % mod;
    uint64_t s2 = (a2 + b2 + (b_bytes % mod) * ((a1 + mod - 1) % mod)) % mod;
    return (uint32_t)(s2 << 16 | s1);
}

size_t wg__deflate_piece_bound(size_t n)
{
    /* stored blocks (the fallback), the empty stored block that ends a piece that is not the
     * last, and the 8 bytes the bit writer stores past its end */
    return n + 5 * (n / STORED_MAX + 1) + 5 + 8;
}

size_t wg__deflate_piece(const WgDeflateCode *c, const unsigned char *in, size_t n, bool last,
                         unsigned char *out, size_t cap)
{
    if (cap < wg__deflate_piece_bound(n) - (last ? 5 : 0)) return 0;
    size_t stored = n + 5 * (n / STORED_MAX + 1);
    /* past `limit` the block would not be smaller than stored blocks (the margin holds what a
     * stretch of literals or a match writes before the next check, and the end); a piece too
     * small for the header and that margin is stored at once */
    if (c->stored || stored < c->header_bytes + 64 + 16)
        return (size_t)(stored_blocks(in, n, last, out) - out);
    const unsigned char *limit = out + stored - 64;
    static const uint8_t order[19] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                      11, 4,  12, 3, 13, 2, 14, 1, 15};
    static const uint8_t cl_extra_bits[19] = {[16] = 2, [17] = 3, [18] = 7};
    Bits b = {0, 0, out};
    put(&b, (uint64_t)last | 2u << 1, 3); /* BFINAL, BTYPE 10: dynamic codes */
    put(&b, (uint64_t)(c->hlit - 257), 5);
    put(&b, (uint64_t)(c->hdist - 1), 5);
    put(&b, (uint64_t)(c->hclen - 4), 4);
    flush(&b);
    for (int k = 0; k < c->hclen; k++) {
        put(&b, c->cl_len[order[k]], 3);
        flush(&b);
    }
    for (int k = 0; k < c->nc; k++) {
        put(&b, c->cl_code[c->cl_sym[k]], c->cl_len[c->cl_sym[k]]);
        put(&b, c->cl_extra[k], cl_extra_bits[c->cl_sym[k]]);
        flush(&b);
    }
    const uint64_t *lit = c->lit;
#define CODE_LITS(from, k)                                                                         \
    do {                                                                                           \
        const unsigned char *p_ = in + (from);                                                     \
        size_t q_ = 0;                                                                             \
        if (b.at > limit) goto overflow;                                                           \
        for (; q_ + 4 <= (k); q_ += 4) put_quad(&b, lit, p_ + q_, 4);                              \
        for (; q_ < (k); q_++) {                                                                   \
            uint64_t e_ = lit[p_[q_]];                                                             \
            put(&b, e_ & 0xffffffff, (unsigned)(e_ >> 32));                                        \
            flush(&b);                                                                             \
        }                                                                                          \
    } while (0)
#define CODE_MATCH(l)                                                                              \
    do {                                                                                           \
        if (b.at > limit) goto overflow;                                                           \
        put(&b, c->mcode[l], c->mlen[l]);                                                          \
        flush(&b);                                                                                 \
    } while (0)
#define CODE_RUN(from, to) RUN_PIECES((to) - (from), CODE_MATCH)
    /* the wide coder where it runs: tried at each step of the parse, but not again at the
     * position where it stopped (near the end or the limit, or where a run starts whose matches
     * might pass it, which the parse codes) */
    bool wide = stored >= 4 * WIDE_BYTES + 64 && wide_on();
    size_t retry = 0;
    /* a block writes at most 8 x 56 bits, and the bit buffer's store 8 bytes past them */
    const unsigned char *wide_stop = wide ? limit - 2 * WIDE_BYTES : out;
#define CODE_BLOCK(i)                                                                              \
    if (wide && (i) >= retry) {                                                                    \
        size_t j_ = wide_literals(c, in, (i), n, (size_t)c->dist, &b, wide_stop);                  \
        retry = j_ + 1;                                                                            \
        if (j_ != (i)) {                                                                           \
            (i) = j_;                                                                              \
            continue;                                                                              \
        }                                                                                          \
    }
    PARSE(in, n, (size_t)c->dist, CODE_LITS, CODE_RUN, CODE_BLOCK);
    if (b.at > limit) goto overflow;
    flush(&b);
    put(&b, c->lit_code[256], c->lit_len[256]);
    if (!last) put(&b, 0, 3); /* an empty stored block: the piece ends on a byte */
    b.n += 7;                 /* to the byte */
    b.n &= ~7u;
    flush(&b);
    unsigned char *p = b.at;
    if (!last) {
        p[0] = p[1] = 0x00;
        p[2] = p[3] = 0xff;
        p += 4;
    }
    return (size_t)(p - out);
overflow:
    return (size_t)(stored_blocks(in, n, last, out) - out);
}

size_t wg__zlib_fast(const unsigned char *in, size_t n, int dist, unsigned char *out, size_t cap)
{
    if (cap < wg__zlib_fast_bound(n)) return 0;
    WgDeflateCode *c = wg__deflate_code(in, n, dist);
    if (!c) return 0;
    out[0] = 0x78, out[1] = 0x01; /* deflate, 32 KiB window, fastest */
    size_t k = wg__deflate_piece(c, in, n, true, out + 2, cap - 6);
    wg__deflate_code_free(c);
    if (!k) return 0;
    return 2 + k + zlib_tail(in, n, out + 2 + k);
}
