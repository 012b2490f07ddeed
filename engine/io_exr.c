/* SPDX-License-Identifier: MIT */
/* Multi-layer EXR through OpenEXR's C API (openexr.h): one scanline part whose channels are
 * "<layer>.Y" for gray images and "<layer>.R/G/B/A" for colour ones, ZIP-compressed, half or
 * float. The library converts our float rows to half while encoding. The file is written as a
 * temporary of a write set (io.c) and renamed over the target when complete. */
#include "internal.h"

#include <errno.h>
#include <openexr.h>
#include <stdio.h>
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
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool initialised = false;
    int rc = WG_OK;
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
            const char *dot = strrchr(ci->channel_name, '.');
            int img = -1, comp = 0;
            for (int i = 0; i < count && img < 0; i++)
                if ((size_t)(dot - ci->channel_name) == strlen(names[i]) &&
                    !strncmp(ci->channel_name, names[i], strlen(names[i])))
                    img = i;
            if (img < 0) {
                rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "internal: channel '%s'",
                                     ci->channel_name);
                break;
            }
            for (int k = 0; k < 4; k++)
                if (!strcmp(dot + 1, rgba[k])) comp = k;
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
