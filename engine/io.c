/* SPDX-License-Identifier: MIT */
/* Image file reading and writing on top of the OpenImageIO bridge (io_oiio.cpp): channel
 * mapping, sRGB transfer, quantisation, and atomic replacement of the target file. Integer
 * formats are quantised here, not by the library, so rounding is exactly round-to-nearest of
 * clamp(v, 0, 1) * (2^bits - 1) and a 16-bit file round-trips bit for bit.
 * PNG files are checked here before the library sees them: the chunk structure (lengths,
 * CRC-32 of every chunk, IHDR first, IEND present) up to the first IDAT chunk when probing and
 * to IEND when reading. libpng prints its errors to stderr itself ("libpng error: ...") before
 * OpenImageIO gets them, so a truncated or damaged file must be refused before libpng runs; the
 * check also gives the byte offset of the damage. */
#include "internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

static const char *const format_names[] = {"default", "png", "png16", "tif16", "exr", "exr32"};

int wg_format_parse(const char *name)
{
    for (int i = 1; i < 6; i++)
        if (!strcmp(name, format_names[i])) return i;
    return -1;
}

const char *wg_format_name(WgFormat f)
{
    return (unsigned)f < 6 ? format_names[f] : "?";
}

const char *wg_format_extension(WgFormat f)
{
    switch (f) {
    case WG_FORMAT_TIF16:
        return "tif";
    case WG_FORMAT_EXR:
    case WG_FORMAT_EXR32:
        return "exr";
    default:
        return "png";
    }
}

float wg_srgb_to_linear(float v)
{
    double x = v;
    return (float)(x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4));
}

/* Decoding integer files: every 8- and 16-bit code k/255 or k/65535 is one of the 65536 values
 * i/65535 (k/255 = 257k/65535 exactly), so a table gives the same floats as the formula. */
static float srgb_lut[65536];
static pthread_once_t srgb_once = PTHREAD_ONCE_INIT;

static void srgb_lut_build(void)
{
    for (int i = 0; i < 65536; i++) srgb_lut[i] = wg_srgb_to_linear((float)(i / 65535.0));
}

static float srgb_decode(float v)
{
    if (v >= 0 && v <= 1) {
        int i = (int)lrintf(v * 65535.0f);
        if ((float)(i / 65535.0) == v) return srgb_lut[i];
    }
    float r = wg_srgb_to_linear(v);
    return r > FLT_MAX ? FLT_MAX : r; /* from about 1e16 on, the curve leaves the float range */
}

float wg_linear_to_srgb(float v)
{
    double x = v;
    if (x <= 0) return 0;
    return (float)(x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1 / 2.4) - 0.055);
}

char *wg__temp_path_for(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *ext = strrchr(base, '.');
    if (!ext) ext = "";
    static unsigned counter;
    unsigned c = __atomic_add_fetch(&counter, 1, __ATOMIC_RELAXED);
    size_t n = strlen(path) + 64;
    char *tmp = wg_malloc(n);
    if (!tmp) return NULL;
    /* hidden, unique per process and call, same folder and extension as the target */
    snprintf(tmp, n, "%.*s.%.*s.tmp%ld-%u%s", (int)(base - path), path, (int)(ext - base), base,
             (long)getpid(), c, ext);
    return tmp;
}

bool wg__hash_file(const char *path, uint64_t out[2])
{
    FILE *f = fopen(path, "rb");
    if (!f) return false;
    XXH3_state_t *st = XXH3_createState();
    if (!st) {
        fclose(f);
        return false;
    }
    XXH3_128bits_reset(st);
    char buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) XXH3_128bits_update(st, buf, n);
    bool ok = !ferror(f);
    fclose(f);
    XXH128_hash_t h = XXH3_128bits_digest(st);
    XXH3_freeState(st);
    out[0] = h.low64;
    out[1] = h.high64;
    return ok;
}

static uint32_t crc_table[256];
static pthread_once_t crc_once = PTHREAD_ONCE_INIT;

static void crc_table_build(void)
{
    for (uint32_t n = 0; n < 256; n++) {
        uint32_t c = n;
        for (int k = 0; k < 8; k++) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
        crc_table[n] = c;
    }
}

static uint32_t crc_update(uint32_t crc, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++) crc = crc_table[(crc ^ p[i]) & 0xff] ^ (crc >> 8);
    return crc;
}

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* The chunk structure of a PNG file (PNG specification, section 5), up to the first IDAT chunk
 * or, with `whole`, to IEND. Other files pass. 0, or -1 with a message. */
static int png_check(const char *path, bool whole, char *msg, size_t size)
{
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    FILE *f = fopen(path, "rb");
    if (!f) return 0; /* the reader reports it */
    unsigned char head[8];
    if (fread(head, 1, 8, f) != 8 || memcmp(head, signature, 8)) {
        fclose(f);
        return 0;
    }
    pthread_once(&crc_once, crc_table_build);
    int rc = 0;
    long long at = 8;
    for (int index = 0;; index++) {
        size_t got = fread(head, 1, 8, f);
        if (got != 8) {
            snprintf(msg, size, "the file is truncated: it ends at byte %lld, before its %s chunk",
                     at + (long long)got,
                     index == 0 ? "IHDR"
                     : whole    ? "IEND"
                                : "IDAT");
            rc = -1;
            break;
        }
        uint32_t len = be32(head);
        char type[5] = {0};
        bool letters = true;
        for (int k = 0; k < 4; k++) {
            type[k] = (char)head[4 + k];
            letters = letters &&
                      ((type[k] >= 'A' && type[k] <= 'Z') || (type[k] >= 'a' && type[k] <= 'z'));
        }
        if (!letters || len > 0x7fffffffu) {
            snprintf(msg, size, "the file is damaged: no valid chunk at byte %lld", at);
            rc = -1;
            break;
        }
        if (index == 0 && strcmp(type, "IHDR")) {
            snprintf(msg, size, "the file is damaged: its first chunk is %s, not IHDR", type);
            rc = -1;
            break;
        }
        if (!whole && !strcmp(type, "IDAT")) break;
        uint32_t crc = crc_update(0xffffffffu, head + 4, 4);
        unsigned char buf[1 << 14];
        uint32_t left = len;
        while (left > 0) {
            size_t want = left < sizeof buf ? left : sizeof buf;
            size_t n = fread(buf, 1, want, f);
            crc = crc_update(crc, buf, n);
            left -= (uint32_t)n;
            if (n != want) break;
        }
        unsigned char stored[4];
        if (left > 0 || fread(stored, 1, 4, f) != 4) {
            long end = ftell(f);
            snprintf(msg, size,
                     "the file is truncated: it ends at byte %ld, inside its %s chunk that starts "
                     "at byte %lld",
                     end, type, at);
            rc = -1;
            break;
        }
        if ((crc ^ 0xffffffffu) != be32(stored)) {
            snprintf(msg, size,
                     "the file is damaged: the CRC of its %s chunk at byte %lld does not match",
                     type, at);
            rc = -1;
            break;
        }
        at += 12 + (long long)len;
        if (!strcmp(type, "IEND")) break;
    }
    fclose(f);
    return rc;
}

int wg_image_probe(const char *path, int *width, int *height, int *channels, WgError *err)
{
    char msg[512];
    struct stat st;
    if (stat(path, &st) != 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot open the image: %s",
                               strerror(errno));
    if (!S_ISREG(st.st_mode))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "not a regular file");
    if (png_check(path, false, msg, sizeof msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    if (wg__oiio_probe(path, width, height, channels, msg, sizeof msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    if (*width < 1 || *height < 1 || *width > WG_MAX_SIDE || *height > WG_MAX_SIDE)
        return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0, "image is %dx%d; sides must be 1..%d",
                               *width, *height, WG_MAX_SIDE);
    return WG_OK;
}

int wg_image_read(const char *path, int channels, WgColorspace cs, WgImage **out, WgError *err)
{
    *out = NULL;
    int w, h, c;
    int rc = wg_image_probe(path, &w, &h, &c, err);
    if (rc) return rc;
    if (c < 1) return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "image has no channels");
    size_t count = (size_t)w * (size_t)h * (size_t)c;
    float *buf = wg_malloc(count * sizeof(float));
    if (!buf) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
    char msg[512];
    if (png_check(path, true, msg, sizeof msg) ||
        wg__oiio_read(path, buf, w, h, c, msg, sizeof msg)) {
        wg_free(buf);
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    }
    size_t bad = 0, first_bad = 0;
    for (size_t i = 0; i < count; i++) {
        if (!isfinite(buf[i])) {
            if (!bad) first_bad = i;
            bad++;
        }
    }
    if (bad) {
        size_t px = first_bad / (size_t)c;
        wg_free(buf);
        return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0,
                               "image has %zu non-finite values (NaN or infinity), the first at "
                               "pixel (%zu, %zu)",
                               bad, px % (size_t)w, px / (size_t)w);
    }
    if (cs == WG_SRGB) pthread_once(&srgb_once, srgb_lut_build);
    int native = c <= 2 ? 1 : 4;
    WgImage *img = wg_image_new(w, h, native);
    if (!img) {
        wg_free(buf);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
    }
    for (int y = 0; y < h; y++) {
        const float *src = buf + (size_t)y * (size_t)w * (size_t)c;
        float *dst = wg_image_row(img, y);
        for (int x = 0; x < w; x++) {
            const float *p = src + (size_t)x * (size_t)c;
            if (native == 1) {
                dst[x] = cs == WG_SRGB ? srgb_decode(p[0]) : p[0];
                continue;
            }
            for (int k = 0; k < 3; k++) dst[4 * x + k] = cs == WG_SRGB ? srgb_decode(p[k]) : p[k];
            dst[4 * x + 3] = c >= 4 ? p[3] : 1.0f;
        }
    }
    wg_free(buf);
    if (channels && channels != native) {
        WgImage *conv = wg_image_convert(img, w, h, channels);
        wg_image_unref(img);
        if (!conv) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        img = conv;
    }
    *out = img;
    return WG_OK;
}

static double quantize(float v, WgColorspace cs, bool colour_channel, double scale)
{
    if (isnan(v)) v = 0;
    if (cs == WG_SRGB && colour_channel) v = wg_linear_to_srgb(v);
    double x = v < 0 ? 0 : v > 1 ? 1 : v;
    return floor(x * scale + 0.5);
}

int wg_image_write(const char *path, const WgImage *img, WgFormat format, WgColorspace cs,
                   WgError *err)
{
    if (format == WG_FORMAT_DEFAULT) format = img->channels == 4 ? WG_FORMAT_PNG : WG_FORMAT_PNG16;
    int c = img->channels;
    if (c == 4) {
        bool opaque = true;
        for (int y = 0; y < img->height && opaque; y++) {
            const float *r = wg_image_row(img, y);
            for (int x = 0; x < img->width && opaque; x++) opaque = r[4 * x + 3] == 1.0f;
        }
        if (opaque) c = 3;
    }
    int bits = format == WG_FORMAT_PNG     ? 8
               : format == WG_FORMAT_EXR   ? -16
               : format == WG_FORMAT_EXR32 ? 32
                                           : 16;
    size_t count = (size_t)img->width * (size_t)img->height * (size_t)c;
    size_t elem = bits == 8 ? 1 : bits == 16 ? 2 : 4;
    void *buf = wg_malloc(count * elem);
    if (!buf) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory writing '%s'", path);
    size_t i = 0;
    for (int y = 0; y < img->height; y++) {
        const float *r = wg_image_row(img, y);
        for (int x = 0; x < img->width; x++) {
            for (int k = 0; k < c; k++, i++) {
                float v = r[x * img->channels + k];
                bool colour = k < 3; /* gray is a colour channel too; alpha never is */
                if (bits == 8)
                    ((uint8_t *)buf)[i] = (uint8_t)quantize(v, cs, colour, 255.0);
                else if (bits == 16)
                    ((uint16_t *)buf)[i] = (uint16_t)quantize(v, cs, colour, 65535.0);
                else
                    ((float *)buf)[i] = v;
            }
        }
    }
    char *tmp = wg__temp_path_for(path);
    if (!tmp) {
        wg_free(buf);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    char msg[512];
    int rc = WG_OK;
    if (wg__oiio_write(tmp, wg_format_extension(format), buf, img->width, img->height, c, bits, msg,
                       sizeof msg)) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the image: %s", msg);
        unlink(tmp);
    } else if (rename(tmp, path) != 0) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot replace the file: %s",
                             strerror(errno));
        unlink(tmp);
    }
    wg_free(tmp);
    wg_free(buf);
    return rc;
}
