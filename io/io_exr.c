/* SPDX-License-Identifier: MIT */
/* EXR through OpenEXR's C API (openexr.h), without OpenImageIO.
 * Writing: one ZIP-compressed scanline part, half or float, either a single layer with the
 * channels OpenImageIO gives such images (Y for gray, R G B or R G B A for colour) or several
 * layers whose channels are "<layer>.Y" for gray images and "<layer>.R/G/B/A" for colour ones.
 * The library converts our float rows to half while encoding (round to nearest even, as
 * OpenImageIO does); the ZIP chunks are deflated here with libdeflate (zip_compress), and a
 * chunk that ZIP does not make smaller is stored raw. The chunks are encoded in windows of 64 on
 * the caller's workers (a render's: an RGBA float output at 2048² is written in three quarters of
 * the time), each window then written in order, so the file is the same on any number of
 * threads. The file is written as a temporary of a write set (io.c) and renamed over the target
 * when complete.
 * Checking: before any library reads an EXR, wg__exr_check walks its header (the OpenEXR file
 * layout: magic, version, attributes as name, type, size, value) and refuses a declared size
 * beyond the end of the file, windows whose sides are outside 1..WG_MAX_SIDE, and windows that
 * call for more chunk offsets than the file has bytes: OpenEXR and OpenImageIO allocate what a
 * header declares before they read it.
 * Reading: single-part scanline files with the channels Y, Y A, R G B or R G B A (half or
 * float) are decoded here, chunk by chunk straight into the caller's rows with the caller's
 * strides, in the channel order OpenImageIO gives. The image is the display window; when the
 * data window differs (shifted, smaller, larger, partly or wholly outside), chunks are decoded
 * into a buffer of their own and their part inside the display window copied, the rest being 0.
 * Any other EXR (tiled, multi-part, layers, integer channels, subsampled, or a header this
 * reader refuses) is left to OpenImageIO (io_oiio.cpp), which places the data window the same
 * way. */
#include "internal.h"
#include "hot.h"
#include "wgio.h"

#include <errno.h>
#include <libdeflate.h>
#include <openexr.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    (void)code;
    (void)msg;
}

static int exr_fail(WgError *err, const char *path, exr_result_t rv, const char *what)
{
    const char *cause = wg__write_cause(errno);
    if (cause)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the EXR (%s): %s (%s)",
                               what, cause, exr_get_default_error_message(rv));
    return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the EXR (%s): %s", what,
                           exr_get_default_error_message(rv));
}

/* ZIP chunks are compressed here, not by OpenEXR 3.1: its compressor runs zlib at level 6,
 * which took two thirds of the time of a frame sequence writing float EXRs, and it keeps its
 * output when that is exactly as long as the raw chunk, though a chunk whose stored size equals
 * its raw size is raw by the file format's rule (every reader, OpenEXR's own and
 * OpenImageIO's, would take those compressed bytes for pixels). The format's ZIP is: the
 * chunk's bytes split into the even- and the odd-numbered ones, each byte replaced by its
 * difference to the one before plus 128 (mod 256), and a zlib stream of that; libdeflate makes
 * the stream at level 1 (float data: files about 3 % larger than zlib's level 6, several times
 * faster). A chunk that does not get smaller is stored raw. The buffers are ours: they are taken
 * back from the pipeline after each chunk, so the library never frees them. */
#define EXR_DEFLATE_LEVEL 1

typedef struct {
    struct libdeflate_compressor *z;
    uint8_t *scratch, *out;
    size_t scratch_size, out_size;
} ZipState;

static void zip_state_free(ZipState *st)
{
    if (st->z) libdeflate_free_compressor(st->z);
    wg_free(st->scratch);
    wg_free(st->out);
}

static bool grow(uint8_t **buf, size_t *size, size_t want)
{
    if (*size >= want) return true;
    uint8_t *b = wg_malloc(want);
    if (!b) return false;
    wg_free(*buf);
    *buf = b;
    *size = want;
    return true;
}

/* ZIP's predictor: src[0..n)'s even-numbered bytes, then its odd-numbered ones, each but the
 * first the difference to the byte before it there plus 128 (mod 256). Each difference is taken
 * from src, so the loops carry nothing from one byte to the next and are vectorised (HOT,
 * hot.h). */
HOT static void zip_predict(const uint8_t *restrict src, uint8_t *restrict t, size_t n)
{
    size_t half = (n + 1) / 2, odd = n / 2;
    if (!n) return;
    t[0] = src[0];
    for (size_t i = 1; i < half; i++) t[i] = (uint8_t)(src[2 * i] - src[2 * i - 2] + 128);
    if (odd) t[half] = (uint8_t)(src[1] - src[2 * half - 2] + 128);
    for (size_t i = 1; i < odd; i++) t[half + i] = (uint8_t)(src[2 * i + 1] - src[2 * i - 1] + 128);
}

static exr_result_t zip_compress(exr_encode_pipeline_t *enc)
{
    ZipState *st = enc->encoding_user_data;
    size_t n = enc->packed_bytes;
    const uint8_t *src = enc->packed_buffer;
    if (!st->z && !(st->z = libdeflate_alloc_compressor(EXR_DEFLATE_LEVEL)))
        return EXR_ERR_OUT_OF_MEMORY;
    size_t bound = libdeflate_zlib_compress_bound(st->z, n);
    if (!grow(&st->scratch, &st->scratch_size, n) || !grow(&st->out, &st->out_size, bound))
        return EXR_ERR_OUT_OF_MEMORY;
    uint8_t *t = st->scratch;
    zip_predict(src, t, n);
    size_t m = n ? libdeflate_zlib_compress(st->z, t, n, st->out, st->out_size) : 0;
    if (m == 0 || m >= n) { /* stored raw */
        enc->compressed_buffer = enc->packed_buffer;
        enc->compressed_bytes = n;
    } else {
        enc->compressed_buffer = st->out;
        enc->compressed_bytes = m;
    }
    enc->compressed_alloc_size = 0;
    return EXR_ERR_SUCCESS;
}

/* The chunks are encoded (converted, packed and compressed) in windows of WINDOW_CHUNKS, each
 * window's chunks on whichever threads the caller's WgWorkers gives them (every thread with a
 * pipeline of its own, as OpenEXR's C API allows), their bytes kept until the window is done and
 * then written in order: the file is the same on any number of threads, and writing holds one
 * window of chunks (a thousand rows at 16 a chunk), not the whole file. */
#define WINDOW_CHUNKS 64

typedef struct {
    exr_context_t ctx;
    int part, h, count;
    int32_t lines;
    const char *const *names;
    const WgImage *const *images;
    int first;      /* the window's first chunk */
    uint8_t **data; /* each chunk of the window: its bytes as written */
    uint64_t *size;
    atomic_int failed; /* 0, or the window's first failure: */
    exr_result_t rv;   /* OpenEXR's error, */
    const char *what;  /* the step, */
    char channel[300]; /* or a channel with no image */
} Window;

/* A thread's pipeline state: the compressor's, and where its chunk's bytes go */
typedef struct {
    ZipState zip;
    Window *win;
    int index; /* in the window */
} Coder;

static exr_result_t zip_compress_coder(exr_encode_pipeline_t *enc)
{
    Coder *co = enc->encoding_user_data;
    enc->encoding_user_data = &co->zip;
    exr_result_t rv = zip_compress(enc);
    enc->encoding_user_data = co;
    return rv;
}

/* The chunk's bytes (compressed, or packed when the part or the chunk is not) kept for the
 * window's writing, instead of written now: the compressor's buffer itself (it makes a new one
 * for the next chunk), a copy of the packed one */
static exr_result_t keep_chunk(exr_encode_pipeline_t *enc)
{
    Coder *co = enc->encoding_user_data;
    const void *bytes = enc->compressed_buffer ? enc->compressed_buffer : enc->packed_buffer;
    uint64_t n = enc->compressed_buffer ? enc->compressed_bytes : enc->packed_bytes;
    uint8_t *copy;
    if (bytes == co->zip.out) { /* the compressor's output: taken, not copied */
        copy = co->zip.out;
        co->zip.out = NULL;
        co->zip.out_size = 0;
    } else if ((copy = wg_malloc(n ? n : 1))) {
        memcpy(copy, bytes, n);
    } else {
        return EXR_ERR_OUT_OF_MEMORY;
    }
    wg_free(co->win->data[co->index]);
    co->win->data[co->index] = copy;
    co->win->size[co->index] = n;
    return EXR_ERR_SUCCESS;
}

static void window_fail(Window *w, exr_result_t rv, const char *what, const char *channel)
{
    int expected = 0;
    if (!atomic_compare_exchange_strong(&w->failed, &expected, 1)) return;
    w->rv = rv;
    w->what = what;
    if (channel) snprintf(w->channel, sizeof w->channel, "%s", channel);
}

/* Chunks [i0, i1) of the window encoded into w->data. With layer names, channel "name.X" comes
 * from the image of that name; without (names NULL, one image), channel "X" from images[0]. X is
 * R, G, B, A, or Y for gray (component 0). */
static void encode_window(void *user, int i0, int i1)
{
    static const char *const rgba[] = {"R", "G", "B", "A"};
    Window *w = user;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool initialised = false;
    Coder co = {.win = w};
    exr_result_t rv;
    for (int i = i0; i < i1 && !atomic_load(&w->failed); i++) {
        exr_chunk_info_t cinfo;
        if ((rv = exr_write_scanline_chunk_info(w->ctx, w->part, (w->first + i) * w->lines,
                                                &cinfo))) {
            window_fail(w, rv, "chunk", NULL);
            break;
        }
        rv = initialised ? exr_encoding_update(w->ctx, w->part, &cinfo, &enc)
                         : exr_encoding_initialize(w->ctx, w->part, &cinfo, &enc);
        if (rv) {
            window_fail(w, rv, "encoder", NULL);
            break;
        }
        initialised = true;
        bool ok = true;
        for (int c = 0; c < enc.channel_count && ok; c++) {
            exr_coding_channel_info_t *ci = &enc.channels[c];
            /* channel names come back sorted: map each to its image and component */
            const char *suffix = ci->channel_name;
            int img = w->names ? -1 : 0, comp = 0;
            if (w->names) {
                const char *dot = strrchr(ci->channel_name, '.');
                for (int k = 0; dot && k < w->count && img < 0; k++)
                    if ((size_t)(dot - ci->channel_name) == strlen(w->names[k]) &&
                        !strncmp(ci->channel_name, w->names[k], strlen(w->names[k])))
                        img = k;
                suffix = dot ? dot + 1 : suffix;
            }
            if (img < 0) {
                window_fail(w, EXR_ERR_SUCCESS, NULL, ci->channel_name);
                ok = false;
                break;
            }
            for (int k = 0; k < 4; k++)
                if (!strcmp(suffix, rgba[k])) comp = k;
            const WgImage *im = w->images[img];
            ci->user_bytes_per_element = 4;
            ci->user_data_type = EXR_PIXEL_FLOAT;
            ci->user_pixel_stride = 4 * im->channels;
            ci->user_line_stride = (int32_t)(im->stride * sizeof(float));
            ci->encode_from_ptr = (const uint8_t *)(wg_image_row(im, cinfo.start_y) + comp);
        }
        if (!ok) break;
        if (!enc.convert_and_pack_fn) {
            if ((rv = exr_encoding_choose_default_routines(w->ctx, w->part, &enc))) {
                window_fail(w, rv, "encoder", NULL);
                break;
            }
            if (enc.compress_fn) enc.compress_fn = zip_compress_coder; /* the part is ZIP */
            /* kept, not written: no waiting for the chunks before to be written */
            enc.yield_until_ready_fn = NULL;
            enc.write_fn = keep_chunk;
            enc.encoding_user_data = &co;
        }
        co.index = i;
        rv = exr_encoding_run(w->ctx, w->part, &enc);
        /* the compressed buffer is zip's (or the packed one): never the library's to free */
        enc.compressed_buffer = NULL;
        enc.compressed_alloc_size = 0;
        if (rv) window_fail(w, rv, "encoding", NULL);
    }
    if (initialised) exr_encoding_destroy(w->ctx, &enc);
    zip_state_free(&co.zip);
}

/* Encode and write every scanline chunk of `part` from `images`, the encoding on `workers`
 * (NULL: here). */
static int encode_chunks(exr_context_t ctx, int part, const char *path, int h, int32_t lines,
                         int count, const char *const *names, const WgImage *const *images,
                         const WgWorkers *workers, WgError *err)
{
    int chunks = (int)((h + lines - 1) / lines);
    Window w = {ctx, part, h, count, lines, names, images};
    w.data = wg_calloc(WINDOW_CHUNKS, sizeof *w.data);
    w.size = wg_calloc(WINDOW_CHUNKS, sizeof *w.size);
    int rc = WG_OK;
    if (!w.data || !w.size) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (w.first = 0; !rc && w.first < chunks; w.first += WINDOW_CHUNKS) {
        int n = chunks - w.first < WINDOW_CHUNKS ? chunks - w.first : WINDOW_CHUNKS;
        atomic_init(&w.failed, 0);
        if (workers && workers->run) {
            if (workers->run(workers->ctx, n, encode_window, &w))
                rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the EXR: cancelled");
        } else {
            encode_window(&w, 0, n);
        }
        if (!rc && atomic_load(&w.failed))
            rc = w.what ? exr_fail(err, path, w.rv, w.what)
                        : wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "internal: channel '%s'",
                                          w.channel);
        for (int i = 0; i < n && !rc; i++)
            if (!w.data[i])
                rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0,
                                     "cannot write the EXR: a chunk was not encoded (the workers "
                                     "ran only some of the parts)");
        for (int i = 0; i < n; i++) {
            exr_result_t rv;
            if (!rc && (rv = exr_write_scanline_chunk(ctx, part, (w.first + i) * lines, w.data[i],
                                                      w.size[i])))
                rc = exr_fail(err, path, rv, "chunk");
            wg_free(w.data[i]);
            w.data[i] = NULL;
        }
    }
    wg_free(w.data);
    wg_free(w.size);
    return rc;
}

static int write_part(exr_context_t ctx, const char *path, int count, const char *const *names,
                      const WgImage *const *images, bool half, const WgWorkers *workers,
                      WgError *err)
{
    int w = images[0]->width, h = images[0]->height, part;
    exr_result_t rv = exr_add_part(ctx, "layers", EXR_STORAGE_SCANLINE, &part);
    if (rv) return exr_fail(err, path, rv, "part");
    rv = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP);
    if (rv) return exr_fail(err, path, rv, "header");
    static const char *const rgba[] = {"R", "G", "B", "A"};
    for (int i = 0; i < count; i++) {
        for (int k = 0; k < images[i]->channels; k++) {
            char ch[300];
            snprintf(ch, sizeof ch, "%s.%s", names[i], images[i]->channels == 1 ? "Y" : rgba[k]);
            rv = exr_add_channel(ctx, part, ch, half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                                 EXR_PERCEPTUALLY_LINEAR, 1, 1);
            if (rv) return exr_fail(err, path, rv, ch);
        }
    }
    if ((rv = exr_write_header(ctx))) return exr_fail(err, path, rv, "header");
    int32_t lines;
    if ((rv = exr_get_scanlines_per_chunk(ctx, part, &lines)))
        return exr_fail(err, path, rv, "chunks");
    return encode_chunks(ctx, part, path, h, lines, count, names, images, workers, err);
}

int wg__exr_check_layers(const char *path, int count, const char *const *names,
                         const WgImage *const *images, WgError *err)
{
    if (count < 1) return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "no layers to write");
    for (int i = 1; i < count; i++) {
        if (images[i]->width != images[0]->width || images[i]->height != images[0]->height)
            return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                                   "layer '%s' is %dx%d but '%s' is %dx%d: the layers of one EXR "
                                   "must have the same size",
                                   names[i], images[i]->width, images[i]->height, names[0],
                                   images[0]->width, images[0]->height);
        for (int k = 0; k < i; k++)
            if (!strcmp(names[i], names[k]))
                return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "layer '%s' given twice",
                                       names[i]);
    }
    return WG_OK;
}

int wg__exr_write_file(const char *file, const char *path, int count, const char *const *names,
                       const WgImage *const *images, bool half, const WgWorkers *workers,
                       WgError *err)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t ctx = NULL;
    int rc;
    errno = 0;
    exr_result_t rv = exr_start_write(&ctx, file, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv) {
        rc = exr_fail(err, path, rv, "open");
    } else {
        rc = write_part(ctx, path, count, names, images, half, workers, err);
        rv = exr_finish(&ctx);
        if (!rc && rv) rc = exr_fail(err, path, rv, "finish");
    }
    return rc;
}

int wg_exr_write_layers(const char *path, int count, const char *const *names,
                        const WgImage *const *images, bool half, WgError *err)
{
    WgWriteSet *s = wg_write_set_new();
    if (!s) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    int rc = wg_write_set_exr_layers(s, path, count, names, images, half, err);
    if (!rc) rc = wg_write_set_commit(s, err);
    wg_write_set_free(s);
    return rc;
}

/* ---- checking the header ----------------------------------------------------------------- */

/* What the header walk keeps of one part: the windows, the chunking and the part's type. */
typedef struct {
    bool have_data, have_display, tiled, deep;
    int32_t data[4], display[4]; /* xmin ymin xmax ymax */
    uint32_t tile_w, tile_h;
    int compression;
} PartHeader;

static int32_t le32(const unsigned char *p)
{
    return (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                     (uint32_t)p[3] << 24);
}

/* A NUL-terminated name of 1..255 bytes at the file's position; false at the end of the
 * file or when it is longer. An empty name (a lone NUL) ends a header. */
static bool read_name(FILE *f, char name[256], long long *at)
{
    for (int i = 0; i < 256; i++) {
        int ch = fgetc(f);
        if (ch == EOF) return false;
        (*at)++;
        name[i] = (char)ch;
        if (!ch) return true;
    }
    return false;
}

/* The scanlines one chunk holds for each compression (OpenEXR file layout); 256 (the most any
 * has) for a compression this table does not know, so the chunk count below stays a lower
 * bound. */
static int lines_per_chunk(int compression)
{
    static const int lines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    return compression >= 0 && compression < 10 ? lines[compression] : 256;
}

static int64_t side(const int32_t box[4], int axis)
{
    return (int64_t)box[axis + 2] - (int64_t)box[axis] + 1;
}

int wg__exr_check(const char *path, char *msg, size_t size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0; /* the reader reports it */
    int rc = -1;
    long long at = 8, file_size = -1;
    unsigned char head[8];
    PartHeader parts[64];
    int nparts = 0;
    if (fseek(f, 0, SEEK_END) == 0) file_size = ftell(f);
    rewind(f);
    if (fread(head, 1, 8, f) != 8) {
        snprintf(msg, size, "the EXR file is truncated: it ends at byte %lld, inside its header",
                 file_size);
        goto out;
    }
    uint32_t version = (uint32_t)le32(head + 4);
    bool multipart = version & 0x1000;
    if ((version & 0xff) != 2 || (version & ~0x1effu)) {
        snprintf(msg, size,
                 "an OpenEXR file of version %u (flags 0x%x), where version 2 (flags 0x200 to "
                 "0x1000) exists",
                 version & 0xff, version & ~0xffu);
        goto out;
    }
    for (;;) {
        PartHeader *p = &parts[nparts];
        memset(p, 0, sizeof *p);
        p->compression = -1;
        p->tiled = !multipart && (version & 0x200);
        p->deep = !multipart && (version & 0x800);
        int attrs = 0;
        char name[256], type[256];
        for (;;) {
            long long name_at = at;
            if (!read_name(f, name, &at)) goto bad_name;
            if (!name[0]) break;
            if (!read_name(f, type, &at) || !type[0]) goto bad_name;
            unsigned char sz[4];
            if (fread(sz, 1, 4, f) != 4) goto truncated;
            at += 4;
            int32_t n = le32(sz);
            /* a declared size is allocated by the readers before the bytes are read: it must
             * fit in what the file has left */
            if (n < 0 || n > file_size - at) {
                snprintf(msg, size,
                         "the EXR header is damaged: its attribute '%s' at byte %lld declares "
                         "%d bytes but the file has %lld left",
                         name, name_at, n, file_size - at);
                goto out;
            }
            unsigned char v[16] = {0};
            size_t keep = n < 16 ? (size_t)n : 16;
            if (fread(v, 1, keep, f) != keep || fseek(f, n - (long)keep, SEEK_CUR) != 0)
                goto truncated;
            at += n;
            bool box = !strcmp(type, "box2i") && n == 16;
            if (!strcmp(name, "dataWindow") && box) {
                for (int k = 0; k < 4; k++) p->data[k] = le32(v + 4 * k);
                p->have_data = true;
            } else if (!strcmp(name, "displayWindow") && box) {
                for (int k = 0; k < 4; k++) p->display[k] = le32(v + 4 * k);
                p->have_display = true;
            } else if (!strcmp(name, "tiles") && !strcmp(type, "tiledesc") && n == 9) {
                p->tile_w = (uint32_t)le32(v);
                p->tile_h = (uint32_t)le32(v + 4);
            } else if (!strcmp(name, "compression") && n == 1) {
                p->compression = v[0];
            } else if (!strcmp(name, "type") && !strcmp(type, "string")) {
                p->tiled = n == 10 && !memcmp(v, "tiledimage", 10);
                p->deep = n >= 4 && !memcmp(v, "deep", 4);
            }
            attrs++;
        }
        if (!attrs) {
            if (multipart && nparts > 0) break; /* the empty header that ends the list */
            snprintf(msg, size, "the EXR header is damaged: it has no attributes");
            goto out;
        }
        for (int w = 0; w < 2; w++) {
            const int32_t *b = w ? p->display : p->data;
            if (!(w ? p->have_display : p->have_data)) continue;
            int64_t bw = side(b, 0), bh = side(b, 1);
            if (bw < 1 || bh < 1 || bw > WG_MAX_SIDE || bh > WG_MAX_SIDE) {
                snprintf(msg, size,
                         "its %s window (%d,%d)-(%d,%d) is %lldx%lld; sides must be 1..%d",
                         w ? "display" : "data", b[0], b[1], b[2], b[3], (long long)bw,
                         (long long)bh, WG_MAX_SIDE);
                goto out;
            }
        }
        if (++nparts == (int)(sizeof parts / sizeof parts[0]) || !multipart) break;
    }
    /* Every chunk has an 8-byte entry in the offset tables after the headers, so the chunks the
     * windows call for (at least those of the first level of a tiled part) must fit in the rest
     * of the file: the readers allocate those tables before reading them. */
    long long chunks = 0;
    for (int i = 0; i < nparts; i++) {
        const PartHeader *p = &parts[i];
        if (!p->have_data || p->deep) continue;
        int64_t w = side(p->data, 0), h = side(p->data, 1);
        if (p->tiled) {
            if (p->tile_w < 1 || p->tile_h < 1) continue; /* the readers refuse it */
            chunks += ((w + p->tile_w - 1) / p->tile_w) * ((h + p->tile_h - 1) / p->tile_h);
        } else {
            int lines = lines_per_chunk(p->compression);
            chunks += (h + lines - 1) / lines;
        }
    }
    if (chunks * 8 > file_size - at) {
        snprintf(msg, size,
                 "the EXR file is truncated or damaged: its header calls for %lld chunks, whose "
                 "offsets alone take %lld bytes, but the file has %lld bytes after its header",
                 chunks, chunks * 8, file_size - at);
        goto out;
    }
    rc = 0;
    goto out;
bad_name:
    if (!feof(f)) {
        snprintf(msg, size,
                 "the EXR header is damaged: an attribute name at byte %lld is longer than 255 "
                 "bytes or empty",
                 at);
        goto out;
    }
truncated:
    snprintf(msg, size, "the EXR file is truncated: it ends at byte %lld, inside its header",
             file_size);
out:
    fclose(f);
    return rc;
}

/* ---- single-layer files ------------------------------------------------------------------ */

int wg__exr_is_exr(const char *path)
{
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    unsigned char head[4];
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    bool is = fread(head, 1, 4, f) == 4 && !memcmp(head, magic, 4);
    fclose(f);
    return is;
}

struct WgExrIn {
    exr_context_t ctx;
    int w, h, c, lines;
    int file_index[4]; /* for output channel k, its index in the file's (sorted) channel list */
    exr_decode_pipeline_t dec;
    bool dec_ready;
    float *alpha; /* one chunk of the fourth channel (see wg__exr_read_rows) */
    /* The image is the display window. The data window (dw x dh pixels, its first row at
     * data_y in the file's coordinates) starts at (x0, y0) of it; when the two differ
     * (`windowed`) each chunk is decoded into `chunk` (one plane per channel) and its part
     * inside the display window copied over pixels set to 0. */
    bool windowed;
    int64_t x0, y0;
    int dw, dh;
    int32_t data_y;
    float *chunk;
    /* what `chunk` holds: the chunk from data row chunk_r, channels [chunk_cb, chunk_ce), when
     * chunk_ok; a chunk that two strips share (the data window's offset in the image is not a
     * multiple of the chunk height) is decoded once */
    bool chunk_ok;
    int64_t chunk_r;
    int chunk_cb, chunk_ce, chunk_h;
    long decodes; /* chunks decoded (for tests) */
};

void wg__exr_close(WgExrIn *in)
{
    if (!in) return;
    if (in->dec_ready) exr_decoding_destroy(in->ctx, &in->dec);
    exr_finish(&in->ctx);
    free(in->alpha);
    free(in->chunk);
    free(in);
}

/* The file's channels as OpenImageIO orders them, or false for a layout left to it. */
static bool native_channels(const exr_attr_chlist_t *cl, int *c, int index[4])
{
    static const char *const layouts[4][4] = {
        {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
    static const int counts[4] = {1, 2, 3, 4};
    for (int i = 0; i < cl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &cl->entries[i];
        if ((e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT) ||
            e->x_sampling != 1 || e->y_sampling != 1)
            return false;
    }
    for (int l = 0; l < 4; l++) {
        if (cl->num_channels != counts[l]) continue;
        bool all = true;
        for (int k = 0; k < counts[l] && all; k++) {
            index[k] = -1;
            for (int i = 0; i < cl->num_channels; i++)
                if (!strcmp(cl->entries[i].name.str, layouts[l][k])) index[k] = i;
            all = index[k] >= 0;
        }
        if (all) {
            *c = counts[l];
            return true;
        }
    }
    return false;
}

int wg__exr_open(const char *path, WgExrIn **out, int *w, int *h, int *c, int *strip_rows,
                 char *msg, size_t msg_size)
{
    (void)msg;
    (void)msg_size;
    *out = NULL;
    WgExrIn *in = calloc(1, sizeof *in);
    if (!in) return 1;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    int parts = 0;
    exr_storage_t storage;
    exr_attr_box2i_t dw, disp;
    const exr_attr_chlist_t *cl = NULL;
    int32_t lines = 0;
    /* wg__exr_check has bounded both windows' sides to 1..WG_MAX_SIDE */
    if (exr_start_read(&in->ctx, path, &init) || exr_get_count(in->ctx, &parts) || parts != 1 ||
        exr_get_storage(in->ctx, 0, &storage) || storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(in->ctx, 0, &dw) || exr_get_display_window(in->ctx, 0, &disp) ||
        (int64_t)dw.max.x - dw.min.x + 1 < 1 || (int64_t)dw.max.x - dw.min.x + 1 > WG_MAX_SIDE ||
        (int64_t)dw.max.y - dw.min.y + 1 < 1 || (int64_t)dw.max.y - dw.min.y + 1 > WG_MAX_SIDE ||
        (int64_t)disp.max.x - disp.min.x + 1 < 1 ||
        (int64_t)disp.max.x - disp.min.x + 1 > WG_MAX_SIDE ||
        (int64_t)disp.max.y - disp.min.y + 1 < 1 ||
        (int64_t)disp.max.y - disp.min.y + 1 > WG_MAX_SIDE || exr_get_channels(in->ctx, 0, &cl) ||
        !cl || !native_channels(cl, &in->c, in->file_index) ||
        exr_get_scanlines_per_chunk(in->ctx, 0, &lines) || lines < 1 || lines > 256) {
        if (in->ctx) exr_finish(&in->ctx);
        free(in);
        return 1;
    }
    in->w = (int)((int64_t)disp.max.x - disp.min.x + 1);
    in->h = (int)((int64_t)disp.max.y - disp.min.y + 1);
    in->dw = (int)((int64_t)dw.max.x - dw.min.x + 1);
    in->dh = (int)((int64_t)dw.max.y - dw.min.y + 1);
    in->x0 = (int64_t)dw.min.x - disp.min.x;
    in->y0 = (int64_t)dw.min.y - disp.min.y;
    in->data_y = dw.min.y;
    in->windowed = in->x0 || in->y0 || in->dw != in->w || in->dh != in->h;
    in->lines = lines;
    *w = in->w;
    *h = in->h;
    *c = in->c;
    /* a multiple of the chunk height, so strips never split a chunk */
    *strip_rows = lines < 16 ? 16 : lines;
    *out = in;
    return 0;
}

size_t wg__exr_chunk_bytes(const WgExrIn *in)
{
    return in->windowed ? (size_t)in->dw * (size_t)in->lines * (size_t)in->c * sizeof(float) : 0;
}

size_t wg__exr_decoder_bytes(const WgExrIn *in, int strip)
{
    /* one chunk compressed and unpacked, rows of the data window, whatever the image's width */
    return 2 * (size_t)in->dw * (size_t)strip * (size_t)in->c * sizeof(float) +
           wg__exr_chunk_bytes(in);
}

long wg__exr_decodes(const WgExrIn *in)
{
    return in->decodes;
}

/* Set up the decoder for the chunk holding file row y; channel k of [cb, ce) is decoded to
 * `to(k)`: base + (k - cb) * kstep, pixels xstride and rows ystride bytes apart. */
static exr_result_t decode_chunk(WgExrIn *in, int32_t y, int cb, int ce, uint8_t *base,
                                 ptrdiff_t kstep, ptrdiff_t xstride, ptrdiff_t ystride,
                                 bool split_alpha, exr_chunk_info_t *ci)
{
    exr_result_t rv = exr_read_scanline_chunk_info(in->ctx, 0, y, ci);
    if (!rv)
        rv = in->dec_ready ? exr_decoding_update(in->ctx, 0, ci, &in->dec)
                           : exr_decoding_initialize(in->ctx, 0, ci, &in->dec);
    if (rv) return rv;
    in->dec_ready = true;
    for (int i = 0; i < in->dec.channel_count; i++) {
        exr_coding_channel_info_t *ch = &in->dec.channels[i];
        ch->decode_to_ptr = NULL; /* channels outside [cb, ce) are skipped */
        ch->user_pixel_stride = (int32_t)xstride;
        ch->user_line_stride = (int32_t)ystride;
        for (int k = cb; k < ce; k++) {
            if (in->file_index[k] != i) continue;
            ch->decode_to_ptr = base + (ptrdiff_t)(k - cb) * kstep;
            if (split_alpha && k == cb + 3) {
                ch->decode_to_ptr = (uint8_t *)in->alpha;
                ch->user_pixel_stride = (int32_t)sizeof(float);
                ch->user_line_stride = (int32_t)((size_t)in->w * sizeof(float));
            }
        }
        ch->user_bytes_per_element = 4;
        ch->user_data_type = EXR_PIXEL_FLOAT;
    }
    rv = exr_decoding_choose_default_routines(in->ctx, 0, &in->dec);
    if (!rv) rv = exr_decoding_run(in->ctx, 0, &in->dec);
    return rv;
}

static int damaged(WgExrIn *in, int64_t r, exr_result_t rv, char *msg, size_t msg_size)
{
    int64_t last = r + in->lines - 1 < in->dh ? r + in->lines - 1 : in->dh - 1;
    snprintf(msg, msg_size, "the EXR data is damaged: rows %lld to %lld: %s",
             (long long)(r + in->data_y), (long long)(last + in->data_y),
             exr_get_default_error_message(rv));
    return -1;
}

/* Rows of a file whose data window is not the display window: zeros, then the chunks that
 * cross [y0, y1) decoded one at a time into planes and their part inside the image copied. */
static int read_windowed(WgExrIn *in, int y0, int y1, int cb, int ce, float *data,
                         ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size)
{
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < in->w; x++)
            memset((uint8_t *)data + (ptrdiff_t)(y - y0) * ystride + x * xstride, 0,
                   (size_t)(ce - cb) * sizeof(float));
    /* the data rows (from the data window's top) that land in [y0, y1) */
    int64_t r0 = y0 - in->y0, r1 = y1 - in->y0;
    if (r0 < 0) r0 = 0;
    if (r1 > in->dh) r1 = in->dh;
    if (r0 >= r1) return 0;
    size_t plane = (size_t)in->dw * (size_t)in->lines;
    if (!in->chunk && !(in->chunk = malloc(plane * (size_t)in->c * sizeof(float)))) {
        snprintf(msg, msg_size, "out of memory");
        return -1;
    }
    int64_t xa = in->x0 < 0 ? -in->x0 : 0, xb = in->w - in->x0 < in->dw ? in->w - in->x0 : in->dw;
    for (int64_t r = r0 - r0 % in->lines; r < r1; r += in->lines) {
        if (!in->chunk_ok || in->chunk_r != r || in->chunk_cb != cb || in->chunk_ce != ce) {
            exr_chunk_info_t ci;
            in->chunk_ok = false;
            exr_result_t rv =
                decode_chunk(in, (int32_t)(in->data_y + r), cb, ce, (uint8_t *)in->chunk,
                             (ptrdiff_t)(plane * sizeof(float)), sizeof(float),
                             (ptrdiff_t)in->dw * sizeof(float), false, &ci);
            if (rv) return damaged(in, r, rv, msg, msg_size);
            in->decodes++;
            in->chunk_ok = true;
            in->chunk_r = r;
            in->chunk_cb = cb;
            in->chunk_ce = ce;
            in->chunk_h = ci.height;
        }
        for (int rr = 0; rr < in->chunk_h; rr++) {
            int64_t row = r + rr;
            if (row < r0 || row >= r1) continue;
            uint8_t *dst = (uint8_t *)data + (ptrdiff_t)(in->y0 + row - y0) * ystride;
            for (int64_t x = xa; x < xb; x++)
                for (int k = 0; k < ce - cb; k++)
                    memcpy(dst + (ptrdiff_t)(in->x0 + x) * xstride + k * (ptrdiff_t)sizeof(float),
                           in->chunk + (size_t)k * plane + (size_t)rr * (size_t)in->dw + (size_t)x,
                           sizeof(float));
        }
    }
    return 0;
}

/* Four channels decoded into one interleaved buffer take a fast path in OpenEXR 3.1 that puts
 * them in the wrong places for half data (alpha lands in red). Decoding the fourth channel into
 * a buffer of its own makes the layout non-interleaved, which the general routine handles; it is
 * copied into place afterwards. */
int wg__exr_read_rows(WgExrIn *in, int y0, int y1, int cb, int ce, float *data, ptrdiff_t xstride,
                      ptrdiff_t ystride, char *msg, size_t msg_size)
{
    if (in->windowed)
        return read_windowed(in, y0, y1, cb, ce, data, xstride, ystride, msg, msg_size);
    bool split = ce - cb == 4;
    if (split && !in->alpha) {
        in->alpha = malloc((size_t)in->w * (size_t)in->lines * sizeof(float));
        if (!in->alpha) {
            snprintf(msg, msg_size, "out of memory");
            return -1;
        }
    }
    for (int y = y0; y < y1; y += in->lines) {
        /* y is the first row of a chunk: strips are whole chunks */
        exr_chunk_info_t ci;
        exr_result_t rv = decode_chunk(in, in->data_y + y, cb, ce,
                                       (uint8_t *)data + (ptrdiff_t)(y - y0) * ystride,
                                       (ptrdiff_t)sizeof(float), xstride, ystride, split, &ci);
        in->decodes++;
        for (int r = 0; !rv && split && r < ci.height; r++) {
            uint8_t *row = (uint8_t *)data + (ptrdiff_t)(y - y0 + r) * ystride;
            const float *a = in->alpha + (size_t)r * (size_t)in->w;
            for (int x = 0; x < in->w; x++) memcpy(row + x * xstride + 3 * sizeof(float), a + x, 4);
        }
        if (rv) return damaged(in, y, rv, msg, msg_size);
    }
    return 0;
}

int wg__exr_write_image(const char *file, const char *path, const WgImage *img, int c, bool half,
                        const WgWorkers *workers, WgError *err)
{
    static const char *const gray[] = {"Y"}, *const rgba[] = {"R", "G", "B", "A"};
    const char *const *names = c == 1 ? gray : rgba;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t ctx = NULL;
    errno = 0;
    exr_result_t rv = exr_start_write(&ctx, file, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv) return exr_fail(err, path, rv, "open");
    int part, rc = WG_OK, w = img->width, h = img->height;
    int32_t lines = 1;
    if ((rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part)) ||
        (rv = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP))) {
        rc = exr_fail(err, path, rv, "header");
        goto done;
    }
    for (int k = 0; k < c; k++) {
        rv = exr_add_channel(ctx, part, names[k], half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LINEAR, 1, 1);
        if (rv) {
            rc = exr_fail(err, path, rv, names[k]);
            goto done;
        }
    }
    if ((rv = exr_write_header(ctx)) || (rv = exr_get_scanlines_per_chunk(ctx, part, &lines))) {
        rc = exr_fail(err, path, rv, "header");
        goto done;
    }
    rc = encode_chunks(ctx, part, path, h, lines, 1, NULL, &img, workers, err);
done:
    rv = exr_finish(&ctx);
    if (!rc && rv) rc = exr_fail(err, path, rv, "finish");
    return rc;
}
