/* SPDX-License-Identifier: MIT */
/* Image I/O internals: what the engine calls in io/ beyond the public wetgraph/io.h (temporary
 * names, file hashes), and what the format files in io/ call in one another (PNG, JPEG and EXR
 * read natively, the PNG writer, the OpenImageIO module). Not installed, not for nodes: a node
 * reads and writes images through wetgraph/io.h. */
#ifndef WETGRAPH_WGIO_H
#define WETGRAPH_WGIO_H

#include "wetgraph/wetgraph.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- for the engine: temporaries and file hashes (io.c) -------------------------------- */

/* Temporary path beside `path` for an atomic write, keeping the extension; caller frees. */
/* The loops that pack linear samples to codes, the same codes each way (for tests of each):
 * WG_PACK_WIDE (AVX-512 with FMA), WG_PACK_FMA (AVX2 with FMA) or WG_PACK_DOUBLE; a way the
 * processor lacks, or -1, gives the best it has (the default). Returns the way now used. */
enum { WG_PACK_DOUBLE, WG_PACK_FMA, WG_PACK_WIDE };
int wg__pack_loops(int way);
char *wg__temp_path_for(const char *path);
/* The process id in a file name (no folder) made by wg__temp_path_for, or 0 when the name does
 * not have exactly that form; with host: the writer's host id there (wg__temp_host), or -1 for
 * a name without one (written by an earlier version). */
long wg__temp_name_parse(const char *name, long long *host);
long wg__temp_name_pid(const char *name);
/* This machine's id in temporaries' names: a hash of its host name and /etc/machine-id. */
uint32_t wg__temp_host(void);
/* wg_remove_stale_temporaries removes another machine's temporaries (and those without a host
 * id) only when they have not been modified for this many seconds. */
#define WG_TEMP_FOREIGN_AGE (24 * 60 * 60)
/* Flushing a staged temporary to the disk on the process's flusher thread (flush.c), so that
 * the thread that wrote it goes on: NULL when it cannot be handed over (the queue is full, or
 * out of memory or descriptors): flush it yourself. */
typedef struct WgFlush WgFlush;
#define WG_FLUSH_QUEUE_MAX 64 /* flushes waiting at most (each holds its file open) */
WgFlush *wg__flush_start(const char *temp);
/* Waits for the flush and frees it: 0, the errno of a failed fsync, or -1 when it was handed
 * back unflushed (in a child made by fork meanwhile): flush it yourself. */
int wg__flush_wait(WgFlush *f);
/* The flush is no longer wanted (its temporary is being removed); NULL is ignored. */
void wg__flush_drop(WgFlush *f);
/* How many temporaries the flusher thread has flushed in this process. */
long wg__flush_count(void);
/* For tests: the flusher thread holds every flush while paused. */
void wg__flush_pause(bool on);
/* xxh3 of a whole file's content; false when it cannot be read. */
bool wg__hash_file(const char *path, uint64_t out[2]);

/* ---- between the format files of io/ (and for tests) -------------------------------------- */

/* 0 when `path` is not a PNG or is one libpng will read without complaint (structure and CRCs
 * up to the first IDAT, or with `whole` to IEND plus the image data itself); -1 with a one-line
 * message saying what is damaged and where. */
int wg__png_check(const char *path, bool whole, char *msg, size_t size);

/* OpenImageIO, through its module (io_oiio.h, loaded by io_module.c on first use; every call
 * fails with a message naming the module paths tried when it cannot be loaded). */
int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size);
/* Reading a file in strips of rows: *decoder_bytes is what the decoder itself holds meanwhile
 * (the whole file at its native type for formats decoded at once, such as PNG); *bits is 8 or
 * 16 when the file stores unsigned integers of that size, else 0. */
typedef struct WgOiioIn WgOiioIn;
int wg__oiio_open(const char *path, WgOiioIn **in, int *w, int *h, int *c, int *bits,
                  size_t *decoder_bytes, char *msg, size_t msg_size);
/* Rows [y0, y1), channels [cb, ce), as float (bits 0) or the file's integers (bits 8 or 16),
 * pixels xstride and rows ystride bytes apart. */
int wg__oiio_read_rows(WgOiioIn *in, int y0, int y1, int cb, int ce, int bits, void *data,
                       ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size);
void wg__oiio_close(WgOiioIn *in);
/* Whether this process has loaded the module (for tests). */
bool wg__oiio_loaded(void);
/* PNG (png_write.c) of w x h pixels of `c` channels (1-4) of `bits` (8 or 16), compressed as
 * `png` says, its rows asked for one at a time: pack(user, y, row) writes row y packed, 16-bit
 * samples in host order, so that no packed copy of the image is made. With same_rows (every row
 * is the same) a row is packed and filtered once a piece: the same file, sooner. The rows are
 * filtered (and in the fast mode coded) in pieces run by `workers` (NULL: all on this thread, in
 * new memory), so pack may be called from several threads at once, each row once, plus the row
 * above each piece; the file is the same either way. In memory: *out (wg_free it) holds *out_size
 * bytes. Nonzero with msg on failure. */
typedef void (*WgPngPack)(void *user, int y, void *row);
int wg__png_encode_rows(int w, int h, int c, int bits, WgPngCompression png, WgPngPack pack,
                        void *user, bool same_rows, const WgWorkers *workers, unsigned char **out,
                        size_t *out_size, char *msg, size_t msg_size);
/* The same from `samples`, the packed rows one after the other. */
int wg__png_encode(const void *samples, int w, int h, int c, int bits, WgPngCompression png,
                   unsigned char **out, size_t *out_size, char *msg, size_t msg_size);
/* Encoded with wg__png_encode_rows and written to path. Nonzero with msg (and errno where the
 * system refused) on failure. */
int wg__png_write_rows(const char *path, int w, int h, int c, int bits, WgPngCompression png,
                       WgPngPack pack, void *user, bool same_rows, const WgWorkers *workers,
                       char *msg, size_t msg_size);
/* Write n bytes to fd, again after short writes and EINTR; -1 with errno (EIO for a write of
 * nothing) on failure. */
int wg__write_all(int fd, const void *data, size_t n);
/* The zlib encoders of deflate_fast.c. wg__zlib_fast: in[0..n) Huffman-coded in one dynamic
 * block, runs of bytes equal to the byte `dist` (1..8) before as matches, or stored when that
 * is not smaller; wg__zlib_stored: stored blocks. Both write at most wg__zlib_fast_bound(n)
 * bytes and return the stream's size, 0 when cap is smaller than the bound (fast) or the
 * stream (stored). */
size_t wg__zlib_fast_bound(size_t n);
size_t wg__zlib_fast(const unsigned char *in, size_t n, int dist, unsigned char *out, size_t cap);
size_t wg__zlib_stored(const unsigned char *in, size_t n, unsigned char *out, size_t cap);
/* The same coding in pieces (raw deflate, no zlib header or trailer): the code made for all of
 * in[0..n) (NULL when out of memory; wg__deflate_code_free it), then any piece of it coded with
 * that code into at most wg__deflate_piece_bound(piece's size) bytes, the last piece with
 * `last` (BFINAL), each other ending on a byte boundary; the pieces' outputs concatenated in
 * order make one deflate stream. Returns the piece's size, 0 when cap is smaller than the
 * bound. Pieces may be coded concurrently: the code is only read. */
typedef struct WgDeflateCode WgDeflateCode;
WgDeflateCode *wg__deflate_code(const unsigned char *in, size_t n, int dist);
/* The same code made from the count of the given stretches of a stream of n bytes (a sample of
 * it, or all of it), for a caller that has the stream only in pieces. */
typedef struct {
    const unsigned char *p;
    size_t n;
} WgBytes;
WgDeflateCode *wg__deflate_code_of(const WgBytes *sample, int stretches, size_t n, int dist);
void wg__deflate_code_free(WgDeflateCode *c);
/* The fast coder's wide path (AVX-512 with VBMI, where the processor has it) on or off; returns
 * whether it is on. It gives the same bits as the scalar coder; for the tests, which also count
 * the blocks it coded on the calling thread. */
bool wg__deflate_wide(bool on);
unsigned long wg__deflate_wide_blocks(void);
/* The Adler-32 of a stream from those of its two parts (b's of b_bytes bytes), as zlib's
 * adler32_combine: pieces checked on their own threads. */
uint32_t wg__adler32_combine(uint32_t a, uint32_t b, size_t b_bytes);
size_t wg__deflate_piece_bound(size_t n);
size_t wg__deflate_piece(const WgDeflateCode *c, const unsigned char *in, size_t n, bool last,
                         unsigned char *out, size_t cap);
/* Code lengths (at most `limit` bits, limit <= 30) of a complete prefix code for the n (<= 320)
 * symbols of freq: Huffman's, limited by the heuristic of zlib and miniz; symbols of frequency 0
 * get 0, except that a code of fewer than two symbols is completed with one or two of them. */
void wg__huffman_lengths(const uint32_t *freq, int n, int limit, uint8_t *len);
/* Writing a file in strips of rows. bits: 8, 16 (unsigned integers), -16 (half), 32 (float);
 * rows packed, `c` channels of that type for 8/16, float for -16/32. finish closes and frees;
 * with ok false it only cleans up. */
typedef struct WgOiioOut WgOiioOut;
int wg__oiio_create(const char *path, const char *format_ext, int w, int h, int c, int bits,
                    WgOiioOut **out, char *msg, size_t msg_size);
int wg__oiio_write_rows(WgOiioOut *o, int y0, int y1, const void *data, char *msg, size_t msg_size);
int wg__oiio_finish(WgOiioOut *o, bool ok, char *msg, size_t msg_size);
/* The whole image at once (for tests). */
int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size);
/* Single-layer EXR read natively (io_exr.c): 1 when `path` starts with the EXR magic number. A
 * file is read natively when it is one scanline part with the half or float channels Y, Y+A,
 * R+G+B or R+G+B+A (the layouts OpenImageIO gives in that order); the image is its display
 * window, pixels outside the data window 0. wg__exr_open returns 1 (and opens nothing) for
 * other EXR files, which go to OpenImageIO. */
int wg__exr_is_exr(const char *path);
typedef struct WgExrIn WgExrIn;
/* The header of an EXR file walked before any library reads it: 0 when its structure holds
 * (every attribute's declared size within the file, both windows' sides 1..WG_MAX_SIDE, the
 * offset tables the windows call for within the file), -1 with a one-line message. */
int wg__exr_check(const char *path, char *msg, size_t size);
/* Bytes the reader holds beside the decoder's own chunk (a data window that is not the image
 * is decoded through one chunk of its own). */
size_t wg__exr_chunk_bytes(const WgExrIn *in);
/* What the decoder holds reading strips of `strip` rows: a chunk compressed and unpacked, both
 * as wide as the data window, which may be wider than the image, and wg__exr_chunk_bytes. */
size_t wg__exr_decoder_bytes(const WgExrIn *in, int strip);
/* Chunks decoded so far (for tests: each chunk once, also when strips share one). */
long wg__exr_decodes(const WgExrIn *in);
int wg__exr_open(const char *path, WgExrIn **in, int *w, int *h, int *c, int *strip_rows, char *msg,
                 size_t msg_size);
/* Rows [y0, y1) (y0 a multiple of the strip height, y1 too or the height), channels [cb, ce),
 * as wg__oiio_read_rows. */
int wg__exr_read_rows(WgExrIn *in, int y0, int y1, int cb, int ce, float *data, ptrdiff_t xstride,
                      ptrdiff_t ystride, char *msg, size_t msg_size);
void wg__exr_close(WgExrIn *in);
/* Single-layer EXR written natively: `c` channels (1: Y, 3: RGB, 4: RGBA) of img, half or float,
 * ZIP, straight to `file`, errors naming `path`; the chunks encoded on `workers` (NULL: on the
 * calling thread), the same file either way. */
int wg__exr_write_image(const char *file, const char *path, const WgImage *img, int c, bool half,
                        const WgWorkers *workers, WgError *err);
/* PNG header read natively (png_check.c): size and the channels OpenImageIO gives (palette
 * expanded to RGB, a tRNS chunk adding alpha). 1 when `path` is not a PNG. */
int wg__png_probe(const char *path, int *w, int *h, int *c, char *msg, size_t size);
/* PNG decoded natively while it is checked as wg__png_check does: 8- or 16-bit gray, gray-alpha,
 * RGB or RGBA, not interlaced, without tRNS. Each row goes to `row` unfiltered (samples
 * big-endian) as soon as it is inflated. 1 when the file is not such a PNG (nothing was
 * decoded; read it otherwise), -1 with msg when it is damaged or not of the expected size and
 * channels. */
typedef struct WgPngSink {
    int width, height, channels;
    void (*row)(void *user, int y, const unsigned char *data, int depth); /* depth 8 or 16 */
    void *user;
} WgPngSink;
int wg__png_read(const char *path, const WgPngSink *sink, char *msg, size_t size);
/* Whether wg__png_read decodes the file. */
bool wg__png_decodable(const char *path);
/* JPEG header read natively (jpeg_header.c): 0 with the size and channels of an 8-bit gray or
 * colour JPEG whose header is well formed; 1 for anything else, which OpenImageIO probes. */
int wg__jpeg_probe(const char *path, int *w, int *h, int *c);
/* The same, on an open file from its current position (left anywhere); *frame is the frame
 * header's marker (0xc2, 0xc6, 0xca and 0xce are progressive). */
int wg__jpeg_probe_file(FILE *f, int *w, int *h, int *c, int *frame);
/* JPEG pixels decoded natively (jpeg_read.c, libjpeg-turbo) for the files wg__jpeg_probe
 * answers for, at the largest scale/8 of the file's size (scale 1..8; each side
 * wg__jpeg_scaled_side) that gives the sink's size; the header is walked and the pixels decoded
 * on one open of the file. The file's channels (1 or 3; the sink's are not read) go to
 * *channels before the first row; each row of 8-bit codes goes to `row` as it is decoded. 1 when
 * the file is not such a JPEG or no scale gives the sink's size (nothing was decoded), -1 with
 * msg when it is damaged (a warning of libjpeg's included). */
int wg__jpeg_read(const char *path, const WgPngSink *sink, int *channels, char *msg, size_t size);
/* A side of `side` pixels decoded at scale/8: rounded up, as libjpeg does. */
int wg__jpeg_scaled_side(int side, int scale);
/* What libjpeg holds while it decodes such a file (0 for other files): a few rows of blocks, or
 * a progressive file's coefficients for the whole image. */
size_t wg__jpeg_decoder_bytes(const char *path);
/* Multi-layer EXR (io_exr.c): the layer checks, and the encoder writing straight to `file` with
 * errors naming `path`. */
int wg__exr_check_layers(const char *path, int count, const char *const *names,
                         const WgImage *const *images, WgError *err);
int wg__exr_write_file(const char *file, const char *path, int count, const char *const *names,
                       const WgImage *const *images, bool half, const WgWorkers *workers,
                       WgError *err);
/* strerror of errno after a failed write when it is a cause a write can have (no space, quota,
 * read-only, I/O error, ...), else NULL: encoders' messages rarely say why. */
const char *wg__write_cause(int e);

#ifdef __cplusplus
}
#endif

#endif
