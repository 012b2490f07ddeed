// SPDX-License-Identifier: MIT
// The only C++ in wetgraph: a C interface to OpenImageIO's ImageInput/ImageOutput, built as the
// shared module wetgraph-oiio.so that the library loads only when a file needs it (io_oiio.h,
// io_module.c), so programs that read and write only EXR files, or none, never load
// OpenImageIO and its hundreds of libraries. Alpha is kept unassociated both ways (OpenImageIO
// would otherwise premultiply PNG alpha on read and divide on write), and no colour conversion
// happens here: io.c does the sRGB transfer.
// Tiled files (and MIP-mapped ones, of which the first level is read) are read a row of tiles
// at a time, since OpenImageIO 2.4 cannot read them as scanlines (it divides by zero). The image
// is the data window, except for OpenEXR, where it is the display window with the data
// window's pixels in place and 0 around them, as in the native reader (io_exr.c).
// A read that OpenImageIO completes but with errors recorded (libjpeg reports a truncated or
// corrupt JPEG only as a warning and fills in the missing part) is a failure. Files are written
// through an I/O proxy of our own that checks every write, because some encoders (PNG) ignore a
// failed write and would report a truncated file as written; a failed write names its cause
// (errno). Library messages are reduced to one line.
#include "io_oiio.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <memory>
#include <cstdlib>
#include <string>
#include <unistd.h>
#include <vector>

using namespace OIIO;

// OpenImageIO's error text can span several lines, repeat itself, quote the file name (which
// the caller reports anyway) and end in generic lines ("PNG library error"); keep one line of
// the distinct, specific parts.
static std::string one_line(const std::string &text, const char *path)
{
    std::vector<std::string> parts;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        std::string line = text.substr(start, end - start);
        start = end + 1;
        if (path && path[0]) {
            for (const std::string &q : {std::string(" (\"") + path + "\")",
                                         std::string("\"") + path + "\"", std::string(path)}) {
                for (size_t at; (at = line.find(q)) != std::string::npos;) line.erase(at, q.size());
            }
        }
        /* OpenImageIO hands OpenEXR a stream without a name, so OpenEXR's messages quote an
         * empty one ("Cannot read image file \"\". ...", " is not an OpenEXR file"); the
         * caller names the file */
        for (const char *empty : {"Cannot read image file \"\". ", "Cannot read image file . "})
            for (size_t at; (at = line.find(empty)) != std::string::npos;)
                line.erase(at, std::strlen(empty));
        for (const char *prefix : {"JPEG error: ", "PNG read error: ", "OpenEXR exception: "})
            if (line.compare(0, std::strlen(prefix), prefix) == 0)
                line.erase(0, std::strlen(prefix));
        while (!line.empty() && line[0] == ' ') line.erase(0, 1);
        if (line.compare(0, 7, "is not ") == 0) line.erase(0, 3);
        while (!line.empty() && (line.back() == ' ' || line.back() == '.' || line.back() == ':'))
            line.pop_back();
        if (line.empty() || line == "PNG library error") continue;
        bool dup = false;
        for (std::string &p : parts) {
            if (p.find(line) != std::string::npos) {
                dup = true;
            } else if (line.find(p) != std::string::npos) {
                p = line; // the longer line says more
                dup = true;
            }
        }
        if (!dup) parts.push_back(line);
    }
    std::string out;
    for (const std::string &p : parts) out += (out.empty() ? "" : "; ") + p;
    return out;
}

static void set_msg(char *msg, size_t size, const std::string &text, const char *path = nullptr)
{
    std::string line = one_line(text, path);
    std::snprintf(msg, size, "%s", line.empty() ? "unknown error" : line.c_str());
}

static std::unique_ptr<ImageInput> open_input(const char *path, char *msg, size_t msg_size)
{
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = ImageInput::open(path, &config);
    if (!in) set_msg(msg, msg_size, OIIO::geterror(), path);
    return in;
}

static int oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size)
{
    try {
        auto in = open_input(path, msg, msg_size);
        if (!in) return -1;
        const ImageSpec &spec = in->spec();
        bool exr = !std::strcmp(in->format_name(), "openexr");
        /* the size oiio_open gives */
        *w = exr ? spec.full_width : spec.width;
        *h = exr ? spec.full_height : spec.height;
        *c = spec.nchannels;
        in->close();
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

/* A file being read. The image is the data window, except for OpenEXR files, where it is the
 * display window with the data window's pixels at (x0, y0) in it and 0 elsewhere (OpenEXR's
 * own convention: the display window is the picture, the data window what the file stores).
 * `direct`: the rows are the file's scanlines, read straight into the caller's buffer; else
 * they go through `rows` (scanlines) or the cached `band` of whole tile rows (tiled files,
 * which OpenImageIO cannot read as scanlines). */
struct WgOiioIn {
    std::unique_ptr<ImageInput> in;
    std::string path;
    ImageSpec spec;
    int c, w, h;
    int64_t x0, y0;
    bool direct;
    std::vector<unsigned char> band, rows;
    int band_y = -1, band_cb = -1, band_ce = -1, band_bits = -1; /* what `band` holds */
};

static TypeDesc sample_type(int bits)
{
    return bits == 8 ? TypeDesc::UINT8 : bits == 16 ? TypeDesc::UINT16 : TypeDesc::FLOAT;
}

static int oiio_open(const char *path, WgOiioIn **out, int *w, int *h, int *c, int *bits,
                     size_t *decoder_bytes, char *msg, size_t msg_size)
{
    *out = nullptr;
    try {
        auto in = open_input(path, msg, msg_size);
        if (!in) return -1;
        const ImageSpec &spec = in->spec();
        std::string fmt = in->format_name();
        bool exr = fmt == "openexr";
        int64_t iw = exr ? spec.full_width : spec.width, ih = exr ? spec.full_height : spec.height;
        if (spec.depth > 1) {
            set_msg(msg, msg_size,
                    "the file holds a volume (" + std::to_string(spec.depth) +
                        " slices); only flat images are read");
            return -1;
        }
        if (iw < 1 || ih < 1 || iw > INT32_MAX || ih > INT32_MAX || spec.width < 1 ||
            spec.height < 1 || spec.nchannels < 1) {
            set_msg(msg, msg_size,
                    "the image has no pixels (" + std::to_string(iw) + "x" + std::to_string(ih) +
                        ", " + std::to_string(spec.nchannels) + " channels)");
            return -1;
        }
        std::unique_ptr<WgOiioIn> r(new WgOiioIn);
        r->spec = spec;
        r->c = spec.nchannels;
        r->w = (int)iw;
        r->h = (int)ih;
        r->x0 = exr ? (int64_t)spec.x - spec.full_x : 0;
        r->y0 = exr ? (int64_t)spec.y - spec.full_y : 0;
        r->direct = spec.tile_width == 0 && r->x0 == 0 && r->y0 == 0 && spec.width == r->w &&
                    spec.height == r->h;
        *w = r->w;
        *h = r->h;
        *c = spec.nchannels;
        /* Readers that decode scanline by scanline or chunk by chunk hold a few rows; the
         * others (PNG among them) decode the whole file into a buffer of its native type.
         * Tiled files hold a row of tiles, twice (as decoded, and as floats here); a data
         * window that is not the image, a strip of its rows. */
        size_t px = spec.pixel_bytes(true), row = (size_t)spec.width * px;
        size_t whole = row * (size_t)spec.height;
        if (fmt == "jpeg" || (exr && spec.tile_width == 0)) whole = row * 64;
        if (spec.tile_width > 0)
            whole = 2 * (size_t)spec.width * (size_t)spec.tile_height * (size_t)spec.nchannels *
                    sizeof(float);
        else if (!r->direct)
            whole += (size_t)spec.width * 64 * (size_t)spec.nchannels * sizeof(float);
        if (decoder_bytes) *decoder_bytes = whole;
        *bits = 0;
        if (spec.channelformats.empty() && spec.format == TypeDesc::UINT8) *bits = 8;
        if (spec.channelformats.empty() && spec.format == TypeDesc::UINT16) *bits = 16;
        r->path = path;
        r->in = std::move(in);
        *out = r.release();
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

/* The failure of the last read, or of a read that completed with errors recorded. */
static int read_failed(WgOiioIn *r, bool ok, char *msg, size_t msg_size)
{
    std::string text = r->in->geterror();
    // a decoder that recovered from damaged data reports it only as a message
    if (ok) text = "the data is damaged or incomplete (" + one_line(text, r->path.c_str()) + ")";
    set_msg(msg, msg_size, text, r->path.c_str());
    return -1;
}

/* Rows [r0, r1) of the data window (from its top), channels [cb, ce), packed in r->rows. Tiled
 * files are read a row of tiles at a time (read_tiles wants whole tiles, or the image's edge),
 * kept for the strips that follow. */
static int data_rows(WgOiioIn *r, int r0, int r1, int cb, int ce, int bits, char *msg,
                     size_t msg_size)
{
    const ImageSpec &s = r->spec;
    TypeDesc type = sample_type(bits);
    size_t px = (size_t)(ce - cb) * type.size(), row = (size_t)s.width * px;
    r->rows.resize(row * (size_t)(r1 - r0));
    if (s.tile_width == 0) {
        bool ok =
            r->in->read_scanlines(0, 0, s.y + r0, s.y + r1, s.z, cb, ce, type, r->rows.data());
        return ok && !r->in->has_error() ? 0 : read_failed(r, ok, msg, msg_size);
    }
    int th = s.tile_height > 0 ? s.tile_height : s.height;
    for (int y = r0; y < r1;) {
        int by = y - y % th, bn = std::min(th, s.height - by);
        if (by != r->band_y || cb != r->band_cb || ce != r->band_ce || bits != r->band_bits) {
            r->band_y = -1;
            r->band.resize(row * (size_t)bn);
            bool ok = r->in->read_tiles(0, 0, s.x, s.x + s.width, s.y + by, s.y + by + bn, s.z,
                                        s.z + std::max(1, s.depth), cb, ce, type, r->band.data());
            if (!ok || r->in->has_error()) return read_failed(r, ok, msg, msg_size);
            r->band_y = by;
            r->band_cb = cb;
            r->band_ce = ce;
            r->band_bits = bits;
        }
        int end = std::min(r1, by + bn);
        std::memcpy(r->rows.data() + row * (size_t)(y - r0),
                    r->band.data() + row * (size_t)(y - by), row * (size_t)(end - y));
        y = end;
    }
    return 0;
}

static int oiio_read_rows(WgOiioIn *r, int y0, int y1, int cb, int ce, int bits, void *data,
                          ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size)
{
    try {
        const ImageSpec &s = r->spec;
        if (r->direct) {
            bool ok = r->in->read_scanlines(0, 0, s.y + y0, s.y + y1, s.z, cb, ce,
                                            sample_type(bits), data, xstride, ystride);
            return ok && !r->in->has_error() ? 0 : read_failed(r, ok, msg, msg_size);
        }
        size_t px = (size_t)(ce - cb) * sample_type(bits).size();
        for (int y = y0; y < y1; y++)
            for (int x = 0; x < r->w; x++)
                std::memset((char *)data + (y - y0) * ystride + x * xstride, 0, px);
        int64_t r0 = std::max<int64_t>(0, y0 - r->y0), r1 = std::min<int64_t>(s.height, y1 - r->y0);
        if (r0 >= r1) return 0;
        if (data_rows(r, (int)r0, (int)r1, cb, ce, bits, msg, msg_size)) return -1;
        int64_t xa = std::max<int64_t>(0, -r->x0), xb = std::min<int64_t>(s.width, r->w - r->x0);
        for (int64_t row = r0; row < r1; row++) {
            const unsigned char *src = r->rows.data() + (size_t)(row - r0) * s.width * px;
            char *dst = (char *)data + (r->y0 + row - y0) * ystride;
            for (int64_t x = xa; x < xb; x++)
                std::memcpy(dst + (r->x0 + x) * xstride, src + (size_t)x * px, px);
        }
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

static void oiio_close(WgOiioIn *r)
{
    if (!r) return;
    try {
        r->in->close();
    } catch (const std::exception &) {
    }
    delete r;
}

/* The encoders write through this: plain pwrite()s on a descriptor that remember the first
 * failure. Some encoders (PNG) ignore a short write, so on a full disk they would report success
 * for a truncated file; the caller checks failure() instead of trusting them. */
class CheckedFile final : public Filesystem::IOProxy
{
  public:
    CheckedFile(const char *path, int fd) : IOProxy(path, Write), m_fd(fd) {}
    const char *proxytype() const override { return "wetgraph"; }
    size_t write(const void *buf, size_t size) override
    {
        size_t n = pwrite(buf, size, m_pos);
        m_pos += (int64_t)n;
        return n;
    }
    size_t pwrite(const void *buf, size_t size, int64_t offset) override
    {
        size_t done = 0;
        while (done < size) {
            ssize_t n = ::pwrite(m_fd, (const char *)buf + done, size - done, offset + (off_t)done);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                if (!m_failure) m_failure = n < 0 ? errno : ENOSPC;
                break;
            }
            done += (size_t)n;
        }
        if ((size_t)offset + done > m_size) m_size = (size_t)offset + done;
        return done;
    }
    size_t read(void *buf, size_t size) override
    {
        size_t n = pread(buf, size, m_pos);
        m_pos += (int64_t)n;
        return n;
    }
    size_t pread(void *buf, size_t size, int64_t offset) override
    {
        ssize_t n;
        do n = ::pread(m_fd, buf, size, offset);
        while (n < 0 && errno == EINTR);
        return n < 0 ? 0 : (size_t)n;
    }
    size_t size() const override { return m_size; }
    int failure() const { return m_failure; }

  private:
    int m_fd;
    int m_failure = 0;
    size_t m_size = 0;
};

struct WgOiioOut {
    std::unique_ptr<ImageOutput> out;
    std::unique_ptr<CheckedFile> file;
    std::string path;
    int fd;
    TypeDesc in_type;
};

static void set_errno_msg(char *msg, size_t msg_size, int e)
{
    std::string text = std::strerror(e);
    if (!text.empty()) text[0] = (char)std::tolower((unsigned char)text[0]);
    set_msg(msg, msg_size, text);
}

static int oiio_create(const char *path, const char *format_ext, int w, int h, int c, int bits,
                       WgOiioOut **result, char *msg, size_t msg_size)
{
    *result = nullptr;
    int fd = open(path, O_RDWR | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) {
        set_errno_msg(msg, msg_size, errno);
        return -1;
    }
    WgOiioOut *o = nullptr;
    try {
        o = new WgOiioOut;
        o->fd = fd;
        o->path = path;
        o->file.reset(new CheckedFile(path, fd));
        /* "jpg:Q": a JPEG of quality Q */
        std::string ext = format_ext;
        int quality = 0;
        if (ext.rfind("jpg:", 0) == 0) {
            quality = std::atoi(ext.c_str() + 4);
            ext = "jpg";
        }
        o->out = ImageOutput::create(ext);
        if (!o->out) {
            set_msg(msg, msg_size, OIIO::geterror());
            goto fail;
        }
        o->in_type = bits == 8 ? TypeDesc::UINT8 : bits == 16 ? TypeDesc::UINT16 : TypeDesc::FLOAT;
        TypeDesc file_type = bits == -16 ? TypeDesc::HALF : o->in_type;
        ImageSpec spec(w, h, c, file_type);
        if (c == 4) spec.alpha_channel = 3;
        spec.attribute("oiio:UnassociatedAlpha", 1);
        /* OpenEXR's C++ writer, which OpenImageIO uses, stores a chunk that ZIP does not make
         * smaller raw, so ZIP is safe here (unlike OpenEXR 3.1's C writer: io_exr.c) */
        if (!std::strcmp(format_ext, "exr")) spec.attribute("compression", "zip");
        if (!std::strcmp(format_ext, "tif")) spec.attribute("compression", "zip");
        /* zlib level 1: writing the wet material's 16 outputs at 2048² took 3.6 s instead of 8.4 s
         * at the default 6, for files 10% larger */
        if (!std::strcmp(format_ext, "png")) spec.attribute("png:compressionLevel", 1);
        if (quality > 0) spec.attribute("Compression", "jpeg:" + std::to_string(quality));
        Filesystem::IOProxy *proxy = o->file.get();
        spec.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
        if (!o->out->open(path, spec)) {
            if (o->file->failure())
                set_errno_msg(msg, msg_size, o->file->failure());
            else
                set_msg(msg, msg_size, o->out->geterror(), path);
            goto fail;
        }
        *result = o;
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
    }
fail:
    delete o;
    close(fd);
    return -1;
}

static int oiio_write_rows(WgOiioOut *o, int y0, int y1, const void *data, char *msg,
                           size_t msg_size)
{
    try {
        if (!o->out->write_scanlines(y0, y1, 0, o->in_type, data)) {
            if (o->file->failure())
                set_errno_msg(msg, msg_size, o->file->failure());
            else
                set_msg(msg, msg_size, o->out->geterror(), o->path.c_str());
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
}

static int oiio_finish(WgOiioOut *o, int ok, char *msg, size_t msg_size)
{
    int rc = ok ? 0 : -1;
    try {
        // Only the status counts: OpenImageIO 2.4's TIFF writer records "failed
        // TIFFWriteCustomDirectory() of the Exif data" on every successful write.
        if (!o->out->close() && ok) {
            if (msg) set_msg(msg, msg_size, o->out->geterror(), o->path.c_str());
            rc = -1;
        }
    } catch (const std::exception &e) {
        if (ok && msg) set_msg(msg, msg_size, e.what());
        rc = -1;
    }
    int failure = o->file->failure();
    o->out.reset();
    if (close(o->fd) != 0 && !failure) failure = errno;
    if (failure && ok) {
        /* the system's reason replaces whatever the encoder made of it */
        if (msg) set_errno_msg(msg, msg_size, failure);
        errno = failure;
        rc = -1;
    }
    delete o;
    return rc;
}

extern "C" __attribute__((visibility("default"))) const WgOiioModule *wg_oiio_module_get(void)
{
    /* no OpenImageIO worker pool: the engine parallelises over images and rows itself, and a
     * pool of threads left running at exit upsets LeakSanitizer's tracer */
    OIIO::attribute("threads", 1);
    /* The largest image the engine takes (WG_MAX_SIDE squared, four float channels) bounds
     * what a file's header may make OpenImageIO allocate for pixels; a larger claim is refused
     * when the file is opened. */
    OIIO::attribute("limits:imagesize_MB", 4096);
    static const WgOiioModule table = {
        WG_OIIO_MODULE_ABI, sizeof(WgOiioModule), oiio_probe,      oiio_open,   oiio_read_rows,
        oiio_close,         oiio_create,          oiio_write_rows, oiio_finish,
    };
    return &table;
}
