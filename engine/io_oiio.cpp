// SPDX-License-Identifier: MIT
// The only C++ in wetgraph: a C interface to OpenImageIO's ImageInput/ImageOutput. Alpha is
// kept unassociated both ways (OpenImageIO would otherwise premultiply PNG alpha on read and
// divide on write), and no colour conversion happens here: io.c does the sRGB transfer.
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstring>
#include <memory>

extern "C" {
int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size);
int wg__oiio_read(const char *path, float *data, int w, int h, int c, char *msg, size_t msg_size);
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

int wg__oiio_read(const char *path, float *data, int w, int h, int c, char *msg, size_t msg_size)
{
    try {
        auto in = open_input(path, msg, msg_size);
        if (!in) return -1;
        const ImageSpec &spec = in->spec();
        if (spec.width != w || spec.height != h || spec.nchannels != c) {
            set_msg(msg, msg_size, "the file changed while it was being read");
            return -1;
        }
        if (!in->read_image(0, 0, 0, c, TypeDesc::FLOAT, data)) {
            set_msg(msg, msg_size, in->geterror());
            return -1;
        }
        in->close();
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size)
{
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
        if (!out->write_image(in_type, data)) {
            set_msg(msg, msg_size, out->geterror());
            out->close();
            return -1;
        }
        if (!out->close()) {
            set_msg(msg, msg_size, out->geterror());
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}
