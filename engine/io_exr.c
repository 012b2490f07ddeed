/* SPDX-License-Identifier: MIT */
/* EXR through OpenEXR's C API (openexr.h), without OpenImageIO.
 * Writing: one ZIP-compressed scanline part, half or float, either a single layer with the
 * channels OpenImageIO gives such images (Y for gray, R G B or R G B A for colour) or several
 * layers whose channels are "<layer>.Y" for gray images and "<layer>.R/G/B/A" for colour ones.
 * The library converts our float rows to half while encoding (round to nearest even, as
 * OpenImageIO does). The file is written as a temporary of a write set (io.c) and renamed over
 * the target when complete.
 * Reading: single-part scanline files with the channels Y, Y A, R G B or R G B A (half or
 * float) are decoded here, chunk by chunk straight into the caller's rows with the caller's
 * strides, in the channel order OpenImageIO gives; any other EXR (tiled, multi-part, layers,
 * integer channels, subsampled, a data window not at 0,0, or a header this reader refuses) is
 * left to OpenImageIO, so those files read exactly as before. */
#include "internal.h"

#include <errno.h>
#include <openexr.h>
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

/* Encode every scanline chunk of `part` from `images`. With layer names, channel "name.X" comes
 * from the image of that name; without (names NULL, one image), channel "X" from images[0]. X is
 * R, G, B, A, or Y for gray (component 0). */
static int encode_chunks(exr_context_t ctx, int part, const char *path, int h, int32_t lines,
                         int count, const char *const *names, const WgImage *const *images,
                         WgError *err)
{
    static const char *const rgba[] = {"R", "G", "B", "A"};
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool initialised = false;
    int rc = WG_OK;
    exr_result_t rv;
    for (int y = 0; y < h && !rc; y += lines) {
        exr_chunk_info_t cinfo;
        if ((rv = exr_write_scanline_chunk_info(ctx, part, y, &cinfo))) {
            rc = exr_fail(err, path, rv, "chunk");
            break;
        }
        rv = initialised ? exr_encoding_update(ctx, part, &cinfo, &enc)
                         : exr_encoding_initialize(ctx, part, &cinfo, &enc);
        if (rv) {
            rc = exr_fail(err, path, rv, "encoder");
            break;
        }
        initialised = true;
        for (int c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ci = &enc.channels[c];
            /* channel names come back sorted: map each to its image and component */
            const char *suffix = ci->channel_name;
            int img = names ? -1 : 0, comp = 0;
            if (names) {
                const char *dot = strrchr(ci->channel_name, '.');
                for (int i = 0; dot && i < count && img < 0; i++)
                    if ((size_t)(dot - ci->channel_name) == strlen(names[i]) &&
                        !strncmp(ci->channel_name, names[i], strlen(names[i])))
                        img = i;
                suffix = dot ? dot + 1 : suffix;
            }
            if (img < 0) {
                rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "internal: channel '%s'",
                                     ci->channel_name);
                break;
            }
            for (int k = 0; k < 4; k++)
                if (!strcmp(suffix, rgba[k])) comp = k;
            const WgImage *im = images[img];
            ci->user_bytes_per_element = 4;
            ci->user_data_type = EXR_PIXEL_FLOAT;
            ci->user_pixel_stride = 4 * im->channels;
            ci->user_line_stride = (int32_t)(im->stride * sizeof(float));
            ci->encode_from_ptr = (const uint8_t *)(wg_image_row(im, cinfo.start_y) + comp);
        }
        if (rc) break;
        if (!enc.convert_and_pack_fn &&
            (rv = exr_encoding_choose_default_routines(ctx, part, &enc))) {
            rc = exr_fail(err, path, rv, "encoder");
            break;
        }
        if ((rv = exr_encoding_run(ctx, part, &enc))) rc = exr_fail(err, path, rv, "encoding");
    }
    if (initialised) exr_encoding_destroy(ctx, &enc);
    return rc;
}

static int write_part(exr_context_t ctx, const char *path, int count, const char *const *names,
                      const WgImage *const *images, bool half, WgError *err)
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
    return encode_chunks(ctx, part, path, h, lines, count, names, images, err);
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
                       const WgImage *const *images, bool half, WgError *err)
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
        rc = write_part(ctx, path, count, names, images, half, err);
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
};

void wg__exr_close(WgExrIn *in)
{
    if (!in) return;
    if (in->dec_ready) exr_decoding_destroy(in->ctx, &in->dec);
    exr_finish(&in->ctx);
    free(in->alpha);
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
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *cl = NULL;
    int32_t lines = 0;
    if (exr_start_read(&in->ctx, path, &init) || exr_get_count(in->ctx, &parts) || parts != 1 ||
        exr_get_storage(in->ctx, 0, &storage) || storage != EXR_STORAGE_SCANLINE ||
        exr_get_data_window(in->ctx, 0, &dw) || dw.min.x != 0 || dw.min.y != 0 || dw.max.x < 0 ||
        dw.max.y < 0 || exr_get_channels(in->ctx, 0, &cl) || !cl ||
        !native_channels(cl, &in->c, in->file_index) ||
        exr_get_scanlines_per_chunk(in->ctx, 0, &lines) || lines < 1 || lines > 256) {
        if (in->ctx) exr_finish(&in->ctx);
        free(in);
        return 1;
    }
    in->w = dw.max.x + 1;
    in->h = dw.max.y + 1;
    in->lines = lines;
    *w = in->w;
    *h = in->h;
    *c = in->c;
    /* a multiple of the chunk height, so strips never split a chunk */
    *strip_rows = lines < 16 ? 16 : lines;
    *out = in;
    return 0;
}

/* Four channels decoded into one interleaved buffer take a fast path in OpenEXR 3.1 that puts
 * them in the wrong places for half data (alpha lands in red). Decoding the fourth channel into
 * a buffer of its own makes the layout non-interleaved, which the general routine handles; it is
 * copied into place afterwards. */
int wg__exr_read_rows(WgExrIn *in, int y0, int y1, int cb, int ce, float *data, ptrdiff_t xstride,
                      ptrdiff_t ystride, char *msg, size_t msg_size)
{
    bool split = ce - cb == 4;
    if (split && !in->alpha) {
        in->alpha = malloc((size_t)in->w * (size_t)in->lines * sizeof(float));
        if (!in->alpha) {
            snprintf(msg, msg_size, "out of memory");
            return -1;
        }
    }
    for (int y = y0; y < y1; y += in->lines) {
        exr_chunk_info_t ci;
        exr_result_t rv = exr_read_scanline_chunk_info(in->ctx, 0, y, &ci);
        if (!rv)
            rv = in->dec_ready ? exr_decoding_update(in->ctx, 0, &ci, &in->dec)
                               : exr_decoding_initialize(in->ctx, 0, &ci, &in->dec);
        if (!rv) {
            in->dec_ready = true;
            for (int i = 0; i < in->dec.channel_count; i++) {
                exr_coding_channel_info_t *ch = &in->dec.channels[i];
                ch->decode_to_ptr = NULL; /* channels outside [cb, ce) are skipped */
                ch->user_pixel_stride = (int32_t)xstride;
                ch->user_line_stride = (int32_t)ystride;
                for (int k = cb; k < ce; k++) {
                    if (in->file_index[k] != i) continue;
                    ch->decode_to_ptr = (uint8_t *)data + (ptrdiff_t)(ci.start_y - y0) * ystride +
                                        (ptrdiff_t)(k - cb) * (ptrdiff_t)sizeof(float);
                    if (split && k == cb + 3) {
                        ch->decode_to_ptr = (uint8_t *)in->alpha;
                        ch->user_pixel_stride = (int32_t)sizeof(float);
                        ch->user_line_stride = (int32_t)((size_t)in->w * sizeof(float));
                    }
                }
                ch->user_bytes_per_element = 4;
                ch->user_data_type = EXR_PIXEL_FLOAT;
            }
            rv = exr_decoding_choose_default_routines(in->ctx, 0, &in->dec);
        }
        if (!rv) rv = exr_decoding_run(in->ctx, 0, &in->dec);
        for (int r = 0; !rv && split && r < ci.height; r++) {
            uint8_t *row = (uint8_t *)data + (ptrdiff_t)(ci.start_y - y0 + r) * ystride;
            const float *a = in->alpha + (size_t)r * (size_t)in->w;
            for (int x = 0; x < in->w; x++) memcpy(row + x * xstride + 3 * sizeof(float), a + x, 4);
        }
        if (rv) {
            snprintf(msg, msg_size, "the EXR data is damaged: rows %d to %d: %s", y,
                     y + in->lines - 1 < in->h ? y + in->lines - 1 : in->h - 1,
                     exr_get_default_error_message(rv));
            return -1;
        }
    }
    return 0;
}

int wg__exr_write_image(const char *file, const char *path, const WgImage *img, int c, bool half,
                        WgError *err)
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
    rc = encode_chunks(ctx, part, path, h, lines, 1, NULL, &img, err);
done:
    rv = exr_finish(&ctx);
    if (!rc && rv) rc = exr_fail(err, path, rv, "finish");
    return rc;
}
