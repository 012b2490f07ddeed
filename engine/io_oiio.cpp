// SPDX-License-Identifier: MIT
// The only C++ in wetgraph: a C interface to OpenImageIO's ImageInput/ImageOutput. Alpha is
// kept unassociated both ways (OpenImageIO would otherwise premultiply PNG alpha on read and
// divide on write), and no colour conversion happens here: io.c does the sRGB transfer.
// A read that OpenImageIO completes but with errors recorded (libjpeg reports a truncated or
// corrupt JPEG only as a warning and fills in the missing part) is a failure. Files are written
// through an I/O proxy of our own that checks every write, because some encoders (PNG) ignore a
// failed write and would report a truncated file as written; a failed write names its cause
// (errno). Library messages are reduced to one line.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

extern "C" {
int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size);
int wg__oiio_read(const char *path, float *data, int w, int h, int c, char *msg, size_t msg_size);
int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size);
}

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
        for (const char *prefix : {"JPEG error: ", "PNG read error: "})
            if (line.compare(0, std::strlen(prefix), prefix) == 0)
                line.erase(0, std::strlen(prefix));
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
        bool ok = in->read_image(0, 0, 0, c, TypeDesc::FLOAT, data);
        if (!ok || in->has_error()) {
            std::string text = in->geterror();
            // a decoder that recovered from damaged data reports it only as a message
            if (ok) text = "the data is damaged or incomplete (" + one_line(text, path) + ")";
            set_msg(msg, msg_size, text, path);
            return -1;
        }
        in->close();
        return 0;
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        return -1;
    }
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

static int encode_to(CheckedFile &file, const char *path, const char *format_ext, const void *data,
                     int w, int h, int c, int bits, char *msg, size_t msg_size)
{
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
    Filesystem::IOProxy *proxy = &file;
    spec.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
    if (!out->open(path, spec)) {
        set_msg(msg, msg_size, out->geterror(), path);
        return -1;
    }
    if (!out->write_image(in_type, data)) {
        set_msg(msg, msg_size, out->geterror(), path);
        out->close();
        return -1;
    }
    if (!out->close()) {
        set_msg(msg, msg_size, out->geterror(), path);
        return -1;
    }
    return 0;
}

int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size)
{
    int fd = open(path, O_RDWR | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) {
        std::string e = std::strerror(errno);
        if (!e.empty()) e[0] = (char)std::tolower((unsigned char)e[0]);
        set_msg(msg, msg_size, e);
        return -1;
    }
    int rc, failure;
    try {
        CheckedFile file(path, fd);
        rc = encode_to(file, path, format_ext, data, w, h, c, bits, msg, msg_size);
        failure = file.failure();
    } catch (const std::exception &e) {
        set_msg(msg, msg_size, e.what());
        rc = -1;
        failure = 0;
    }
    if (close(fd) != 0 && !failure) failure = errno;
    if (failure) {
        /* the system's reason replaces whatever the encoder made of it */
        std::string e = std::strerror(failure);
        if (!e.empty()) e[0] = (char)std::tolower((unsigned char)e[0]);
        set_msg(msg, msg_size, e);
        errno = failure;
        return -1;
    }
    return rc;
}
