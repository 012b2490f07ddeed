/* SPDX-License-Identifier: MIT */
/* Source nodes: `uniform` (a constant gray value or colour) and `image` (a picture file,
 * decoded to linear float and resampled to the node's size with the engine's wrapping tent
 * filter, see wg_image_convert; a JPEG larger than the node is decoded at the DCT scale just
 * above its size first). */
#include "wetgraph/node.h"

#include <string.h>

/* ---- uniform ----------------------------------------------------------------------------- */

typedef struct {
    int kind; /* 0 gray, 1 color */
    float value;
    float color[4];
} UniformParams;

static const char *const kind_values[] = {"gray", "color", NULL};

static const WgParamSpec uniform_params[] = {
    WG_PARAM_ENUM(UniformParams, kind, "Output kind", 0, kind_values),
    WG_PARAM_FLOAT_UI(UniformParams, value, "Gray value", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_COLOR(UniformParams, color, "Colour (linear RGBA; #hex is sRGB)", "0 0 0 1"),
    WG_PARAM_END,
};
static const WgPortSpec uniform_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

static int uniform_channels(const WgNodeContext *ctx, int port)
{
    (void)port;
    return ((const UniformParams *)ctx->params)->kind == 1 ? 4 : 1;
}

static int uniform_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const UniformParams *p = ctx->params;
    WgImage *out = ctx->outputs[0];
    /* rows sharing one row of memory (how the engine gives it its output) take one */
    int rows = out->stride ? out->height : 1;
    for (int y = 0; y < rows; y++) {
        float *r = wg_image_row(out, y);
        if (out->channels == 1)
            for (int x = 0; x < out->width; x++) r[x] = p->value;
        else
            for (int x = 0; x < out->width; x++) memcpy(r + 4 * x, p->color, sizeof p->color);
    }
    return WG_OK;
}

const WgNodeType wg_node_uniform = {
    .name = "uniform",
    .summary = "A constant gray value or colour",
    .category = "source",
    .doc = "`kind=\"gray\"` outputs `value` everywhere; `kind=\"color\"` outputs `color`. "
           "Hex colours (`#ff8000`) are sRGB and converted to linear; colours written as "
           "numbers (`0.5 0.2 0.1 1`) are linear.",
    .params = uniform_params,
    .params_size = sizeof(UniformParams),
    .outputs = uniform_out,
    .flags = WG_NODE_SOURCE | WG_NODE_POINT | WG_NODE_CHEAP | WG_NODE_UNIFORM | WG_NODE_SERIAL,
    .output_channels = uniform_channels,
    .eval = uniform_eval,
};

/* ---- image ------------------------------------------------------------------------------- */

typedef struct {
    const char *path;
    int colorspace; /* 0 linear, 1 srgb */
    int kind;       /* 0 auto, 1 gray, 2 color */
} ImageParams;

static const char *const colorspace_values[] = {"linear", "srgb", NULL};
static const char *const image_kind_values[] = {"auto", "gray", "color", NULL};

static const WgParamSpec image_params[] = {
    WG_PARAM_PATH_STRING(ImageParams, path, "Image file (relative to the graph file)"),
    WG_PARAM_ENUM(ImageParams, colorspace, "Encoding of the file's colour channels", 0,
                  colorspace_values),
    WG_PARAM_ENUM(ImageParams, kind, "Output kind", 0, image_kind_values),
    WG_PARAM_END,
};
static const WgPortSpec image_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

static int image_check(const WgNodeContext *ctx, WgError *err)
{
    const ImageParams *p = ctx->params;
    if (!p->path || !p->path[0])
        return wg_error_set(err, WG_ERR_PARSE, NULL, "needs a path=\"file.png\"");
    int w, h, c;
    return wg_image_probe(p->path, &w, &h, &c, err);
}

static int image_channels(const WgNodeContext *ctx, int port)
{
    (void)port;
    const ImageParams *p = ctx->params;
    if (p->kind == 1) return 1;
    if (p->kind == 2) return 4;
    int w, h, c;
    WgError err = {0};
    if (wg_image_probe(p->path, &w, &h, &c, &err)) return 1; /* check() reports it */
    return c <= 2 ? 1 : 4;
}

static int image_eval(WgNodeContext *ctx, WgError *err)
{
    const ImageParams *p = ctx->params;
    WgColorspace cs = p->colorspace ? WG_SRGB : WG_LINEAR;
    WgImage *out = ctx->outputs[0];
    int dw, dh;
    int rc = wg_image_decode_size(p->path, out->width, out->height, &dw, &dh, err);
    if (rc) return rc;
    if (dw == out->width && dh == out->height) return wg_image_read_into(p->path, cs, out, err);
    /* decoded at the file's size or, for a larger JPEG, at the DCT scale just above the node's,
     * then resampled on the render's threads */
    WgImage *img = wg_scratch_image(ctx, dw, dh, out->channels);
    if (!img) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", p->path);
    rc = wg_image_read_into(p->path, cs, img, err);
    if (!rc) {
        rc = wg_image_resample_into(ctx, img, out);
        if (rc == WG_ERR_NOMEM) rc = wg_error_set(err, rc, NULL, "out of memory resampling");
    }
    wg_image_unref(img);
    return rc;
}

/* Decoding (the decoder's buffer and a strip); when the file is decoded at another size than
 * the node's, also the decoded image and the resampling: the band buffers of its threads (rows of
 * the node's width, together no more than the decoded height of them unless the image is a few
 * rows high) and the filter taps. */
static size_t image_scratch(const WgNodeContext *ctx)
{
    const ImageParams *p = ctx->params;
    int dw, dh, oc = ctx->n_outputs > 0 && image_channels(ctx, 0) == 4 ? 4 : 1;
    WgError err = {0};
    if (!p->path || wg_image_decode_size(p->path, ctx->width, ctx->height, &dw, &dh, &err))
        return 0;
    size_t decode = wg_image_read_scratch(p->path);
    if (dw == ctx->width && dh == ctx->height) return decode;
    size_t file = wg_image_bytes_for(dw, dh, oc);
    size_t taps = (size_t)(2 * (dw / ctx->width + dh / ctx->height) + 8);
    size_t resample = file + wg_image_bytes_for(ctx->width, dh, oc) +
                      taps * 8 * ((size_t)ctx->width + (size_t)ctx->height);
    return decode + file > resample ? decode + file : resample;
}

const WgNodeType wg_node_image = {
    .name = "image",
    .summary = "A picture file, decoded to linear float",
    .category = "source",
    .doc = "Reads any format OpenImageIO reads (PNG 8/16-bit, JPEG, TIFF, EXR, HDR, ...). "
           "`colorspace=\"srgb\"` decodes the colour channels to linear (use it for base colour; "
           "data maps such as height, normal and roughness are linear). `kind=\"auto\"` gives "
           "gray for 1-2 channel files and colour for 3-4; `gray` takes Rec.709 luminance "
           "(exactly the value when R = G = B). The picture is resampled to the node's size "
           "with a wrapping tent filter (bilinear when enlarging; when shrinking by k, a triangle "
           "k source pixels wide on each side, e.g. weights 1 3 3 1 / 8 for 2x). A JPEG larger "
           "than the node is first decoded at the smallest of libjpeg's DCT scales (n/8 of "
           "each side) that is not smaller than the node, which takes a fraction of a full "
           "decode. "
           "Files with NaN or infinite values are rejected.",
    .params = image_params,
    .params_size = sizeof(ImageParams),
    .outputs = image_out,
    .flags = WG_NODE_SOURCE | WG_NODE_GLOBAL | WG_NODE_SERIAL,
    .output_channels = image_channels,
    .check = image_check,
    .eval = image_eval,
    .scratch_bytes = image_scratch,
};
