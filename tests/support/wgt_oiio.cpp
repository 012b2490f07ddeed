// SPDX-License-Identifier: MIT
// OpenImageIO for the image I/O tests (wgt_oiio.h): tiled, MIP-mapped and windowed files
// written with ImageOutput, and files read with ImageInput::read_image as the reference. MIP
// levels below the first are box-filtered halvings; the tests read only the first level.
#include "wgt_oiio.h"

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

using namespace OIIO;

static void say(char *msg, int size, const std::string &text)
{
    if (msg && size > 0) std::snprintf(msg, (size_t)size, "%s", text.c_str());
}

static TypeDesc type_of(const char *t)
{
    if (!t || !std::strcmp(t, "float")) return TypeDesc::FLOAT;
    if (!std::strcmp(t, "half")) return TypeDesc::HALF;
    if (!std::strcmp(t, "uint8")) return TypeDesc::UINT8;
    return TypeDesc::UINT16;
}

/* One MIP level down: each pixel the mean of up to 2x2 of the level above. */
static std::vector<float> halve(const std::vector<float> &src, int w, int h, int c, int *nw,
                                int *nh)
{
    *nw = w > 1 ? w / 2 : 1;
    *nh = h > 1 ? h / 2 : 1;
    std::vector<float> out((size_t)*nw * (size_t)*nh * (size_t)c);
    for (int y = 0; y < *nh; y++)
        for (int x = 0; x < *nw; x++)
            for (int k = 0; k < c; k++) {
                double sum = 0;
                int n = 0;
                for (int dy = 0; dy < 2; dy++)
                    for (int dx = 0; dx < 2; dx++) {
                        int sx = 2 * x + dx, sy = 2 * y + dy;
                        if (sx >= w || sy >= h) continue;
                        sum += src[((size_t)sy * (size_t)w + (size_t)sx) * (size_t)c + (size_t)k];
                        n++;
                    }
                out[((size_t)y * (size_t)*nw + (size_t)x) * (size_t)c + (size_t)k] =
                    (float)(sum / n);
            }
    return out;
}

extern "C" int wgt_oiio_write(const char *path, const WgtOiioSpec *s, const float *data, char *msg,
                              int msg_size)
{
    auto out = ImageOutput::create(path);
    if (!out) {
        say(msg, msg_size, OIIO::geterror());
        return -1;
    }
    ImageSpec spec(s->w, s->h, s->c, type_of(s->type));
    spec.x = s->x;
    spec.y = s->y;
    spec.full_x = s->full_w ? s->full_x : s->x;
    spec.full_y = s->full_w ? s->full_y : s->y;
    spec.full_width = s->full_w ? s->full_w : s->w;
    spec.full_height = s->full_w ? s->full_h : s->h;
    spec.tile_width = s->tile_w;
    spec.tile_height = s->tile_h;
    if (s->c == 4) spec.alpha_channel = 3;
    if (s->c == 2) {
        spec.channelnames = {"Y", "A"};
        spec.alpha_channel = 1;
    }
    spec.attribute("oiio:UnassociatedAlpha", 1);
    spec.attribute("compression", "zip");
    bool mip = s->mipmap && s->tile_w > 0;
    /* OpenImageIO's EXR writer makes a MIP-mapped file only for a texture */
    if (mip) spec.attribute("textureformat", "Plain Texture");
    if (s->parts > 1) {
        /* every part alike, each holding the data plus its index */
        std::vector<ImageSpec> specs((size_t)s->parts, spec);
        size_t n = (size_t)s->w * (size_t)s->h * (size_t)s->c;
        std::vector<float> part(data, data + n);
        for (int k = 0; k < s->parts; k++) {
            if ((k == 0 && !out->open(path, s->parts, specs.data())) ||
                (k > 0 && !out->open(path, spec, ImageOutput::AppendSubimage)) ||
                !out->write_image(TypeDesc::FLOAT, part.data())) {
                say(msg, msg_size, out->geterror());
                return -1;
            }
            for (float &v : part) v += 1.0f;
        }
        if (!out->close()) {
            say(msg, msg_size, out->geterror());
            return -1;
        }
        return 0;
    }
    if (!out->open(path, spec, ImageOutput::Create)) {
        say(msg, msg_size, out->geterror());
        return -1;
    }
    std::vector<float> level(data, data + (size_t)s->w * (size_t)s->h * (size_t)s->c);
    int w = s->w, h = s->h;
    for (;;) {
        if (!out->write_image(TypeDesc::FLOAT, level.data())) {
            say(msg, msg_size, out->geterror());
            return -1;
        }
        if (!mip || (w == 1 && h == 1)) break;
        int nw, nh;
        level = halve(level, w, h, s->c, &nw, &nh);
        w = nw;
        h = nh;
        ImageSpec ls = spec;
        ls.width = ls.full_width = w;
        ls.height = ls.full_height = h;
        ls.x = ls.y = ls.full_x = ls.full_y = 0;
        if (!out->open(path, ls, ImageOutput::AppendMIPLevel)) {
            say(msg, msg_size, out->geterror());
            return -1;
        }
    }
    if (!out->close()) {
        say(msg, msg_size, out->geterror());
        return -1;
    }
    return 0;
}

extern "C" float *wgt_oiio_read(const char *path, WgtOiioSpec *s, char *msg, int msg_size)
{
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = ImageInput::open(path, &config);
    if (!in) {
        say(msg, msg_size, OIIO::geterror());
        return nullptr;
    }
    const ImageSpec &spec = in->spec();
    std::memset(s, 0, sizeof *s);
    s->w = spec.width;
    s->h = spec.height;
    s->c = spec.nchannels;
    s->x = spec.x;
    s->y = spec.y;
    s->full_x = spec.full_x;
    s->full_y = spec.full_y;
    s->full_w = spec.full_width;
    s->full_h = spec.full_height;
    s->tile_w = spec.tile_width;
    s->tile_h = spec.tile_height;
    s->mipmap = in->seek_subimage(0, 1);
    in->seek_subimage(0, 0);
    size_t n = (size_t)s->w * (size_t)s->h * (size_t)s->c;
    float *px = (float *)std::malloc(n * sizeof(float));
    if (!px) {
        say(msg, msg_size, "out of memory");
        return nullptr;
    }
    /* Scanline files a scanline at a time: read_image (through read_scanlines) allocates a
     * 64 MiB buffer per call, which meson's MALLOC_PERTURB_ fills every time; read_scanline
     * converts the same way through a buffer of one row. */
    bool ok = true;
    size_t row = (size_t)s->w * (size_t)s->c;
    if (spec.tile_width == 0)
        for (int y = 0; y < s->h && ok; y++)
            ok = in->read_scanline(spec.y + y, spec.z, TypeDesc::FLOAT, px + row * (size_t)y);
    else
        ok = in->read_image(0, 0, 0, s->c, TypeDesc::FLOAT, px);
    if (!ok) {
        say(msg, msg_size, in->geterror());
        std::free(px);
        return nullptr;
    }
    in->close();
    return px;
}
