/* SPDX-License-Identifier: MIT */
/* Image file reading and writing on top of the OpenImageIO bridge (io_oiio.cpp): channel
 * mapping, sRGB transfer, quantisation, and atomic replacement of the target file. Integer
 * formats are quantised here, not by the library, so rounding is exactly round-to-nearest of
 * clamp(v, 0, 1) * (2^bits - 1) and a 16-bit file round-trips bit for bit. */
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

int wg_image_probe(const char *path, int *width, int *height, int *channels, WgError *err)
{
    char msg[512];
    struct stat st;
    if (stat(path, &st) != 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot open the image: %s",
                               strerror(errno));
    if (!S_ISREG(st.st_mode))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "not a regular file");
    if (wg__oiio_probe(path, width, height, channels, msg, sizeof msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    if (*width < 1 || *height < 1 || *width > WG_MAX_SIDE || *height > WG_MAX_SIDE)
        return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0, "image is %dx%d; sides must be 1..%d",
                               *width, *height, WG_MAX_SIDE);
    return WG_OK;
}

/* Rows decoded and converted at a time, so reading and writing hold a strip, not an image. */
#define STRIP_ROWS 16

size_t wg_image_read_scratch(const char *path)
{
    WgOiioIn *in;
    int w, h, c;
    size_t decoder = 0;
    char msg[512];
    if (wg__oiio_open(path, &in, &w, &h, &c, &decoder, msg, sizeof msg)) return 0;
    wg__oiio_close(in);
    return decoder + (size_t)w * STRIP_ROWS * (size_t)c * sizeof(float);
}

/* One decoded row (c file channels) to the destination's channels: gray files and 1-2 channel
 * files are gray, 3-4 channel files colour, then gray to colour copies the value with alpha 1
 * and colour to gray takes the luminance, exactly as wg_image_convert does. */
static void convert_row(const float *src, int c, WgColorspace cs, float *dst, int w, int channels)
{
    int native = c <= 2 ? 1 : 4;
    for (int x = 0; x < w; x++) {
        const float *p = src + (size_t)x * (size_t)c;
        float px[4];
        if (native == 1) {
            px[0] = cs == WG_SRGB ? srgb_decode(p[0]) : p[0];
        } else {
            for (int k = 0; k < 3; k++) px[k] = cs == WG_SRGB ? srgb_decode(p[k]) : p[k];
            px[3] = c >= 4 ? p[3] : 1.0f;
        }
        if (channels == 1) {
            dst[x] = native == 1 ? px[0] : wg__luminance(px);
        } else if (native == 1) {
            dst[4 * x] = dst[4 * x + 1] = dst[4 * x + 2] = px[0];
            dst[4 * x + 3] = 1.0f;
        } else {
            memcpy(dst + 4 * x, px, sizeof px);
        }
    }
}

int wg_image_read_into(const char *path, WgColorspace cs, WgImage *dst, WgError *err)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot open the image: %s",
                               strerror(errno));
    if (!S_ISREG(st.st_mode))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "not a regular file");
    char msg[512];
    WgOiioIn *in;
    int w, h, c;
    if (wg__oiio_open(path, &in, &w, &h, &c, NULL, msg, sizeof msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    int rc = WG_OK;
    float *buf = NULL;
    if (w != dst->width || h != dst->height) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0,
                             "the file changed while it was being read (now %dx%d, was %dx%d)", w,
                             h, dst->width, dst->height);
        goto out;
    }
    if (c < 1) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "image has no channels");
        goto out;
    }
    if (cs == WG_SRGB) pthread_once(&srgb_once, srgb_lut_build);
    size_t row = (size_t)w * (size_t)c;
    buf = wg_malloc(row * STRIP_ROWS * sizeof(float));
    if (!buf) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
        goto out;
    }
    size_t bad = 0, first_bad = 0;
    for (int y0 = 0; y0 < h; y0 += STRIP_ROWS) {
        int y1 = h - y0 < STRIP_ROWS ? h : y0 + STRIP_ROWS;
        if (wg__oiio_read_rows(in, y0, y1, buf, msg, sizeof msg)) {
            rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
            goto out;
        }
        size_t count = row * (size_t)(y1 - y0);
        for (size_t i = 0; i < count; i++) {
            if (!isfinite(buf[i])) {
                if (!bad) first_bad = row * (size_t)y0 + i;
                bad++;
            }
        }
        for (int y = y0; y < y1 && !bad; y++)
            convert_row(buf + row * (size_t)(y - y0), c, cs, wg_image_row(dst, y), w,
                        dst->channels);
    }
    if (bad) {
        size_t px = first_bad / (size_t)c;
        rc = wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0,
                             "image has %zu non-finite values (NaN or infinity), the first at "
                             "pixel (%zu, %zu)",
                             bad, px % (size_t)w, px / (size_t)w);
    }
out:
    wg_free(buf);
    wg__oiio_close(in);
    return rc;
}

int wg_image_read(const char *path, int channels, WgColorspace cs, WgImage **out, WgError *err)
{
    *out = NULL;
    int w, h, c;
    int rc = wg_image_probe(path, &w, &h, &c, err);
    if (rc) return rc;
    if (c < 1) return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "image has no channels");
    WgImage *img = wg_image_new(w, h, channels ? channels : c <= 2 ? 1 : 4);
    if (!img) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
    rc = wg_image_read_into(path, cs, img, err);
    if (rc) {
        wg_image_unref(img);
        return rc;
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
    size_t row = (size_t)img->width * (size_t)c;
    size_t elem = bits == 8 ? 1 : bits == 16 ? 2 : 4;
    void *buf = wg_malloc(row * STRIP_ROWS * elem);
    char *tmp = wg__temp_path_for(path);
    if (!buf || !tmp) {
        wg_free(buf);
        wg_free(tmp);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory writing '%s'", path);
    }
    char msg[512];
    int rc = WG_OK;
    WgOiioOut *out;
    bool ok = !wg__oiio_create(tmp, wg_format_extension(format), img->width, img->height, c, bits,
                               &out, msg, sizeof msg);
    for (int y0 = 0; ok && y0 < img->height; y0 += STRIP_ROWS) {
        int y1 = img->height - y0 < STRIP_ROWS ? img->height : y0 + STRIP_ROWS;
        size_t i = 0;
        for (int y = y0; y < y1; y++) {
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
        ok = !wg__oiio_write_rows(out, y0, y1, buf, msg, sizeof msg);
        if (!ok) {
            wg__oiio_finish(out, false, msg, 0);
            out = NULL;
        }
    }
    if (ok && wg__oiio_finish(out, true, msg, sizeof msg)) ok = false;
    if (!ok) {
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
