// SPDX-License-Identifier: MIT
// The only C++ in wetgraph: a C interface to OpenImageIO's ImageInput/ImageOutput. Alpha is
// kept unassociated both ways (OpenImageIO would otherwise premultiply PNG alpha on read and
// divide on write), and no colour conversion happens here: io.c does the sRGB transfer.
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstring>
#include <memory>

extern "C" {
struct WgOiioIn;
struct WgOiioOut;
int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size);
int wg__oiio_open(const char *path, WgOiioIn **in, int *w, int *h, int *c, size_t *decoder_bytes,
                  char *msg, size_t msg_size);
int wg__oiio_read_rows(WgOiioIn *in, int y0, int y1, float *data, char *msg, size_t msg_size);
void wg__oiio_close(WgOiioIn *in);
int wg__oiio_create(const char *path, const char *format_ext, int w, int h, int c, int bits,
                    WgOiioOut **out, char *msg, size_t msg_size);
int wg__oiio_write_rows(WgOiioOut *o, int y0, int y1, const void *data, char *msg, size_t msg_size);
int wg__oiio_finish(WgOiioOut *o, bool ok, char *msg, size_t msg_size);
int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size);
}

using namespace OIIO;

static void set_msg(char *msg, size_t size, const std::string &text)
{
    std::snprintf(msg, size, "%s", text.empty() ? "unknown error" : text.c_str());
}

static std::unique_ptr<ImageInput> open_input(const char *path, char *msg, size_t msg_size)
{
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = ImageInput::open(path, &config);
    if (!in) set_msg(msg, msg_size, OIIO::geterror());
    return in;
}

int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size)
{
    try {
        auto in = open_input(path, msg, msg_size);
        if (!in) return -1;
        const ImageSpec &spec = in->spec();
        *w = spec.width;
        *h = spec.height;
        *c = spec.nchannels;
        in->close();
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

struct WgOiioIn {
    std::unique_ptr<ImageInput> in;
    int c;
};

int wg__oiio_open(const char *path, WgOiioIn **out, int *w, int *h, int *c, size_t *decoder_bytes,
                  char *msg, size_t msg_size)
{
    *out = nullptr;
    try {
        auto in = open_input(path, msg, msg_size);
        if (!in) return -1;
        const ImageSpec &spec = in->spec();
        *w = spec.width;
        *h = spec.height;
        *c = spec.nchannels;
        /* Readers that decode scanline by scanline or chunk by chunk hold a few rows; the
         * others (PNG among them) decode the whole file into a buffer of its native type. */
        std::string fmt = in->format_name();
        size_t whole = (size_t)spec.width * (size_t)spec.height * spec.pixel_bytes(true);
        if (fmt == "jpeg" || (fmt == "openexr" && spec.tile_width == 0))
            whole = (size_t)spec.width * 64 * spec.pixel_bytes(true);
        if (decoder_bytes) *decoder_bytes = whole;
        WgOiioIn *r = new WgOiioIn;
        r->c = spec.nchannels;
        r->in = std::move(in);
        *out = r;
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

int wg__oiio_read_rows(WgOiioIn *r, int y0, int y1, float *data, char *msg, size_t msg_size)
{
    try {
        if (!r->in->read_scanlines(0, 0, y0, y1, 0, 0, r->c, TypeDesc::FLOAT, data)) {
            set_msg(msg, msg_size, r->in->geterror());
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

void wg__oiio_close(WgOiioIn *r)
{
    if (!r) return;
    try {
        r->in->close();
    } catch (const std::exception &) {
    }
    delete r;
}

struct WgOiioOut {
    std::unique_ptr<ImageOutput> out;
    TypeDesc in_type;
};

int wg__oiio_create(const char *path, const char *format_ext, int w, int h, int c, int bits,
                    WgOiioOut **result, char *msg, size_t msg_size)
{
    *result = nullptr;
    try {
        auto out = ImageOutput::create(format_ext);
        if (!out) {
            set_msg(msg, msg_size, OIIO::geterror());
            return -1;
        }
        TypeDesc in_type = bits == 8    ? TypeDesc::UINT8
                           : bits == 16 ? TypeDesc::UINT16
                                        : TypeDesc::FLOAT;
        TypeDesc file_type = bits == -16 ? TypeDesc::HALF : in_type;
        ImageSpec spec(w, h, c, file_type);
        if (c == 4) spec.alpha_channel = 3;
        spec.attribute("oiio:UnassociatedAlpha", 1);
        if (!std::strcmp(format_ext, "exr")) spec.attribute("compression", "zip");
        if (!std::strcmp(format_ext, "tif")) spec.attribute("compression", "zip");
        if (!out->open(path, spec)) {
            set_msg(msg, msg_size, out->geterror());
            return -1;
        }
        WgOiioOut *o = new WgOiioOut;
        o->out = std::move(out);
        o->in_type = in_type;
        *result = o;
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

int wg__oiio_write_rows(WgOiioOut *o, int y0, int y1, const void *data, char *msg, size_t msg_size)
{
    try {
        if (!o->out->write_scanlines(y0, y1, 0, o->in_type, data)) {
            set_msg(msg, msg_size, o->out->geterror());
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

int wg__oiio_finish(WgOiioOut *o, bool ok, char *msg, size_t msg_size)
{
    int rc = ok ? 0 : -1;
    try {
        if (!o->out->close() && ok) {
            set_msg(msg, msg_size, o->out->geterror());
            rc = -1;
        }
    } catch (const std::exception &e) {
        if (ok) set_msg(msg, msg_size, e.what());
        rc = -1;
    }
    delete o;
    return rc;
}

int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size)
{
    WgOiioOut *o;
    if (wg__oiio_create(path, format_ext, w, h, c, bits, &o, msg, msg_size)) return -1;
    bool ok = !wg__oiio_write_rows(o, 0, h, data, msg, msg_size);
    return wg__oiio_finish(o, ok, msg, msg_size);
}
