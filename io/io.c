/* SPDX-License-Identifier: MIT */
/* Image file reading and writing: single-layer EXR natively (io_exr.c), most PNGs natively
 * (png_check.c; written by png_write.c), JPEG headers natively (jpeg_header.c), everything else
 * through the
 * OpenImageIO module (io_oiio.cpp, loaded on first use by io_module.c). Decoders write straight
 * into the image's rows when every file channel has its place there, integer files go through
 * tables of their codes, else a strip at a time through a float buffer. Here: channel
 * mapping, sRGB transfer, quantisation, and replacement of target files. Integer formats are
 * quantised here, not by the library, so rounding is exactly round-to-nearest of
 * clamp(v, 0, 1) * (2^bits - 1) and a 16-bit file round-trips bit for bit. Every write goes
 * through a write set: each file is written whole and flushed to a temporary beside its target,
 * then all the temporaries are renamed over their targets in one loop, so a set of files is
 * replaced together or (barring a failing rename in that loop) not at all. The temporaries'
 * names carry the writer's host and process id, so the ones a killed process left can be told
 * from a running writer's and removed, also in a folder that several machines share.
 * PNG files are checked (png_check.c) before the library sees them, because libpng prints its
 * own errors to stderr. */
#include "internal.h"
#include "hot.h"
#include "wgio.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <xxhash.h>
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#include <tmmintrin.h>
#endif

static const char *const format_names[] = {"default", "png",   "png16", "tif16",
                                           "exr",     "exr32", "jpeg",  "tga"};
enum { FORMAT_COUNT = 8 };

static atomic_int jpeg_quality = 92;

void wg_set_jpeg_quality(int quality)
{
    atomic_store(&jpeg_quality, quality < 1 ? 1 : quality > 100 ? 100 : quality);
}

static const char *const png_compression_names[] = {"fast", "deflate", "none"};

int wg_png_compression_parse(const char *name)
{
    for (int i = 0; i < 3; i++)
        if (!strcmp(name, png_compression_names[i])) return i;
    return -1;
}

const char *wg_png_compression_name(WgPngCompression c)
{
    return (unsigned)c < 3 ? png_compression_names[c] : "?";
}

int wg_format_parse(const char *name)
{
    for (int i = 1; i < FORMAT_COUNT; i++)
        if (!strcmp(name, format_names[i])) return i;
    if (!strcmp(name, "jpg")) return WG_FORMAT_JPEG;
    return -1;
}

const char *wg_format_name(WgFormat f)
{
    return (unsigned)f < FORMAT_COUNT ? format_names[f] : "?";
}

const char *wg_format_extension(WgFormat f)
{
    switch (f) {
    case WG_FORMAT_TIF16:
        return "tif";
    case WG_FORMAT_JPEG:
        return "jpg";
    case WG_FORMAT_TGA:
        return "tga";
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

static int quantize8_formula(float v, bool srgb)
{
    if (isnan(v)) v = 0;
    if (srgb) v = wg_linear_to_srgb(v);
    double x = v < 0 ? 0 : v > 1 ? 1 : v;
    return (int)floor(x * 255.0 + 0.5);
}

/* Encoding to 8-bit sRGB: the code grows with the value (checked over every float from 0 to 2),
 * so it is the number of thresholds at or below it, threshold[k] being the smallest float
 * whose code is k; each is found by bisection over the bit patterns of the positive floats,
 * which order as the floats do. The thresholds are kept as those bit patterns (as int32, with
 * threshold[256] above every float below 1), so that the packing loop compares integers. */
static int32_t srgb8_threshold[257];
/* The code of the smallest float of each run of 2^16 floats (same sign, exponent and top 7
 * mantissa bits) below 1: no run holds more than one threshold past its first float (the codes
 * are far apart; srgb8_build checks it, srgb8_one_step), so one compare with the next threshold
 * settles the code, without a loop: the packing loop below is vectorised. 63.5 KiB, as int32
 * for the vectoriser. */
#define SRGB8_SHIFT 16
#define SRGB8_RUNS (0x3f800000u >> SRGB8_SHIFT)
static int32_t srgb8_run_code[SRGB8_RUNS];
static bool srgb8_one_step;
static pthread_once_t srgb8_once = PTHREAD_ONCE_INIT;

static void srgb8_build(void)
{
    for (int k = 1; k < 256; k++) {
        uint32_t lo = 0, hi = 0x40000000u; /* code(0) = 0 < k <= 255 = code(2) */
        while (lo + 1 < hi) {
            uint32_t mid = lo + (hi - lo) / 2;
            float f;
            memcpy(&f, &mid, sizeof f);
            if (quantize8_formula(f, true) >= k)
                hi = mid;
            else
                lo = mid;
        }
        srgb8_threshold[k] = (int32_t)hi;
    }
    srgb8_threshold[256] = INT32_MAX;
    int k = 0; /* the last threshold at or below the run's first float, which only grows */
    srgb8_one_step = true;
    for (uint32_t run = 0; run < SRGB8_RUNS; run++) {
        int32_t first = (int32_t)(run << SRGB8_SHIFT), last = first + (1 << SRGB8_SHIFT) - 1;
        while (k < 255 && srgb8_threshold[k + 1] <= first) k++;
        srgb8_run_code[run] = k;
        if (k < 254 && srgb8_threshold[k + 2] <= last) srgb8_one_step = false;
    }
}

/* After pthread_once(&srgb8_once, srgb8_build). */
static inline uint8_t quantize8_srgb(float v)
{
    if (!(v > 0)) return 0; /* NaN, zero and negative values */
    if (v >= 1) return 255;
    int32_t bits;
    memcpy(&bits, &v, sizeof bits);
    int k = srgb8_run_code[bits >> SRGB8_SHIFT];
    while (k < 255 && srgb8_threshold[k + 1] <= bits) k++;
    return (uint8_t)k;
}

/* quantize8_formula without sRGB, in float compares and one multiply (the same rounding) */
static inline uint8_t quantize8_linear(float v)
{
    double d = v > 0 ? (v < 1 ? (double)v : 1.0) : 0.0;
    return (uint8_t)(uint32_t)(d * 255.0 + 0.5);
}

uint8_t wg_quantize8(float v, bool srgb)
{
    if (!srgb) return quantize8_linear(v);
    pthread_once(&srgb8_once, srgb8_build);
    return quantize8_srgb(v);
}

/* Temporary files. A write to "<dir>/<stem><ext>" (<ext>: the last ".suffix" of the file name,
 * or empty) first goes to "<dir>/.<stem>.tmp<pid>-<n>-<host><ext>": hidden, in the target's
 * folder so the final rename() never crosses file systems, with the target's extension because
 * the encoders choose the format by it; <pid> is the writing process and <n> a per-process
 * counter, both decimal without leading zeros, and <host> the writing machine (wg__temp_host),
 * 8 lowercase hex digits: process ids repeat across the machines sharing a cache folder on a
 * network file system. Names without "-<host>" were written by earlier versions.
 * wg__temp_path_for makes these names and wg__temp_name_parse recognises them; nothing else
 * spells the pattern out. */
uint32_t wg__temp_host(void)
{
    /* computed once; threads that race compute the same value */
    static atomic_uint value;
    static atomic_bool known;
    if (atomic_load(&known)) return (uint32_t)atomic_load(&value);
    /* the host name tells containers apart, the machine id hosts that share a name */
    char id[512] = "";
    if (gethostname(id, 256)) id[0] = '\0';
    id[255] = '\0';
    size_t n = strlen(id);
    FILE *f = fopen("/etc/machine-id", "r");
    if (f) {
        id[n++] = '\n';
        n += fread(id + n, 1, sizeof id - n - 1, f);
        fclose(f);
    }
    uint32_t h = (uint32_t)XXH3_64bits(id, n);
    atomic_store(&value, h);
    atomic_store(&known, true);
    return h;
}

char *wg__temp_path_for(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *ext = strrchr(base, '.');
    if (!ext) ext = "";
    static unsigned counter;
    unsigned c = __atomic_add_fetch(&counter, 1, __ATOMIC_RELAXED);
    size_t n = strlen(path) + 80;
    char *tmp = wg_malloc(n);
    if (!tmp) return NULL;
    snprintf(tmp, n, "%.*s.%.*s.tmp%ld-%u-%08x%s", (int)(base - path), path, (int)(ext - base),
             base, (long)getpid(), c, (unsigned)wg__temp_host(), ext);
    return tmp;
}

/* A run of decimal digits without a leading zero, at most `max`. */
static bool take_number(const char **p, unsigned long long max, unsigned long long *out)
{
    const char *s = *p;
    unsigned long long v = 0;
    if (*s < '0' || *s > '9' || (s[0] == '0' && s[1] >= '0' && s[1] <= '9')) return false;
    for (; *s >= '0' && *s <= '9'; s++) {
        v = v * 10 + (unsigned)(*s - '0');
        if (v > max) return false;
    }
    *p = s;
    *out = v;
    return true;
}

/* "-" and exactly 8 lowercase hex digits. */
static bool take_host(const char **p, uint32_t *out)
{
    const char *s = *p;
    if (*s++ != '-') return false;
    uint32_t v = 0;
    for (int i = 0; i < 8; i++, s++) {
        if (*s >= '0' && *s <= '9')
            v = v << 4 | (uint32_t)(*s - '0');
        else if (*s >= 'a' && *s <= 'f')
            v = v << 4 | (uint32_t)(*s - 'a' + 10);
        else
            return false;
    }
    *p = s;
    *out = v;
    return true;
}

long wg__temp_name_parse(const char *name, long long *host)
{
    if (host) *host = -1;
    if (name[0] != '.' || strchr(name, '/')) return 0;
    for (const char *m = strstr(name + 1, ".tmp"); m; m = strstr(m + 1, ".tmp")) {
        const char *p = m + 4;
        unsigned long long pid, n;
        if (!take_number(&p, INT_MAX, &pid) || *p++ != '-' || !take_number(&p, UINT_MAX, &n))
            continue;
        uint32_t h = 0;
        bool has_host = take_host(&p, &h);
        /* the rest is the target's extension: empty (then the stem has no dot) or one suffix */
        bool ext_ok =
            *p ? *p == '.' && !strchr(p + 1, '.') : !memchr(name + 1, '.', (size_t)(m - name - 1));
        if (!ext_ok || pid < 1) continue;
        if (host) *host = has_host ? (long long)h : -1;
        return (long)pid;
    }
    return 0;
}

long wg__temp_name_pid(const char *name)
{
    return wg__temp_name_parse(name, NULL);
}

int wg_remove_stale_temporaries(const char *dir)
{
    DIR *d = opendir(dir && dir[0] ? dir : ".");
    if (!d) return 0;
    int removed = 0;
    time_t now = time(NULL);
    long long self = wg__temp_host();
    struct dirent *e;
    while ((e = readdir(d))) {
        long long host;
        long pid = wg__temp_name_parse(e->d_name, &host);
        if (pid < 1) continue;
        struct stat st;
        if (fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) || !S_ISREG(st.st_mode))
            continue;
        if (host == self) {
            /* only a process that does not exist is gone: EPERM means alive (another user's) */
            if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        } else {
            /* another machine's (or an earlier version's, which did not say): its process
             * cannot be asked, so only a file left untouched for long is taken for stale */
            if (!(st.st_mtime < now - WG_TEMP_FOREIGN_AGE)) continue;
        }
        if (unlinkat(dirfd(d), e->d_name, 0) == 0) removed++;
    }
    closedir(d);
    return removed;
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

/* Image files are regular files: a FIFO or a device would block the decoder or never end. */
static int check_regular(const char *path, WgError *err)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot open the image: %s",
                               strerror(errno));
    if (!S_ISREG(st.st_mode))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "not a regular file");
    return WG_OK;
}

/* What a file's first bytes say it is, so that only its own reader opens it; each reader
 * checks the signature again. */
typedef enum { FILE_OTHER, FILE_PNG, FILE_EXR, FILE_JPEG } FileKind;

static FileKind file_kind(const char *path)
{
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static const unsigned char exr[4] = {0x76, 0x2f, 0x31, 0x01};
    unsigned char head[8] = {0};
    FILE *f = fopen(path, "rb");
    if (!f) return FILE_OTHER; /* the reader reports it */
    size_t n = fread(head, 1, sizeof head, f);
    fclose(f);
    if (n == 8 && !memcmp(head, png, 8)) return FILE_PNG;
    if (n >= 4 && !memcmp(head, exr, 4)) return FILE_EXR;
    if (n >= 2 && head[0] == 0xff && head[1] == 0xd8) return FILE_JPEG;
    return FILE_OTHER;
}

/* wg_image_probe, with what the file is and whether its header was read natively (*native). */
static int probe(const char *path, int *width, int *height, int *channels, FileKind *kind,
                 bool *native, WgError *err)
{
    char msg[512];
    int rc = check_regular(path, err);
    if (rc) return rc;
    *kind = file_kind(path);
    /* PNG, EXR and JPEG headers are read here: checking a graph needs no OpenImageIO */
    rc = 1;
    if (*kind == FILE_PNG) {
        if (wg__png_check(path, false, msg, sizeof msg))
            return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
        rc = wg__png_probe(path, width, height, channels, msg, sizeof msg);
    } else if (*kind == FILE_EXR) {
        if (wg__exr_check(path, msg, sizeof msg))
            return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
        WgExrIn *in;
        int strip;
        rc = wg__exr_open(path, &in, width, height, channels, &strip, msg, sizeof msg);
        wg__exr_close(in);
    } else if (*kind == FILE_JPEG) {
        rc = wg__jpeg_probe(path, width, height, channels);
    }
    *native = rc == 0;
    if (rc > 0) rc = wg__oiio_probe(path, width, height, channels, msg, sizeof msg);
    if (rc) return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    if (*width < 1 || *height < 1 || *width > WG_MAX_SIDE || *height > WG_MAX_SIDE)
        return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0, "image is %dx%d; sides must be 1..%d",
                               *width, *height, WG_MAX_SIDE);
    return WG_OK;
}

int wg_image_probe(const char *path, int *width, int *height, int *channels, WgError *err)
{
    FileKind kind;
    bool native;
    return probe(path, width, height, channels, &kind, &native, err);
}

/* Rows decoded and converted at a time, so reading and writing hold a strip, not an image. */
#define STRIP_ROWS 16

/* A file being read: natively (single-layer EXR) or through OpenImageIO. */
typedef struct {
    WgExrIn *exr;
    WgOiioIn *oiio;
    int w, h, c, strip;
    int bits; /* 8 or 16: an integer file read as its codes; 0: read as float */
} Reader;

static int reader_open(const char *path, Reader *r, size_t *decoder, char *msg, size_t msg_size)
{
    memset(r, 0, sizeof *r);
    r->strip = STRIP_ROWS;
    /* the EXR header is walked first: OpenEXR and OpenImageIO allocate what it declares */
    bool exr = wg__exr_is_exr(path);
    if (exr && wg__exr_check(path, msg, msg_size)) return -1;
    if (exr && !wg__exr_open(path, &r->exr, &r->w, &r->h, &r->c, &r->strip, msg, msg_size)) {
        if (decoder) *decoder = wg__exr_decoder_bytes(r->exr, r->strip);
        return 0;
    }
    return wg__oiio_open(path, &r->oiio, &r->w, &r->h, &r->c, &r->bits, decoder, msg, msg_size);
}

/* Rows as float (bits 0) or, for an integer file, as its codes (bits r->bits). */
static int reader_rows(Reader *r, int y0, int y1, int cb, int ce, int bits, void *data,
                       ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size)
{
    if (r->exr)
        return wg__exr_read_rows(r->exr, y0, y1, cb, ce, data, xstride, ystride, msg, msg_size);
    return wg__oiio_read_rows(r->oiio, y0, y1, cb, ce, bits, data, xstride, ystride, msg, msg_size);
}

static void reader_close(Reader *r)
{
    wg__exr_close(r->exr);
    wg__oiio_close(r->oiio);
}

size_t wg_image_read_scratch(const char *path)
{
    Reader r;
    size_t decoder = 0;
    char msg[512];
    int w, h, c;
    /* a PNG decoded here holds two rows of the file */
    if (wg__png_decodable(path) && !wg__png_probe(path, &w, &h, &c, msg, sizeof msg))
        return (size_t)w * (size_t)c * 2 * 3 + 2;
    /* a JPEG decoded here: libjpeg's buffers and a row of codes */
    if (!wg__jpeg_probe(path, &w, &h, &c))
        return wg__jpeg_decoder_bytes(path) + (size_t)w * (size_t)c * 16;
    if (reader_open(path, &r, &decoder, msg, sizeof msg)) return 0;
    reader_close(&r);
    /* the strip of the general path; a direct read needs none */
    return decoder + (size_t)r.w * (size_t)r.strip * (size_t)r.c * sizeof(float);
}

/* One decoded row (c file channels) to the destination's channels. The channel count says what
 * a file holds: 1 gray, 2 gray and alpha, 3 RGB, 4 (or more: the first four) RGBA. To colour:
 * gray is copied to R, G and B, alpha is the file's or 1; to gray: gray as it is, colour as its
 * luminance (as wg_image_convert does), alpha dropped. */
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
            dst[4 * x + 3] = c == 2 ? p[1] : 1.0f;
        } else {
            memcpy(dst + 4 * x, px, sizeof px);
        }
    }
}

/* Non-finite values: how many, and the first in file order. */
typedef struct {
    size_t count, x, y;
} BadValues;

static void count_bad(BadValues *b, const float *v, size_t n, int c, int w, int y0)
{
    for (size_t i = 0; i < n; i++) {
        if (isfinite(v[i])) continue;
        if (!b->count++) {
            size_t px = i / (size_t)c;
            b->x = px % (size_t)w;
            b->y = (size_t)y0 + px / (size_t)w;
        }
    }
}

/* The general path: strips of the file's channels, converted row by row. */
static int read_strips(Reader *r, WgColorspace cs, WgImage *dst, BadValues *bad, char *msg,
                       size_t msg_size)
{
    int w = r->w, h = r->h, c = r->c;
    size_t row = (size_t)w * (size_t)c;
    float *buf = wg_malloc(row * (size_t)r->strip * sizeof(float));
    if (!buf) return WG_ERR_NOMEM;
    for (int y0 = 0; y0 < h; y0 += r->strip) {
        int y1 = h - y0 < r->strip ? h : y0 + r->strip;
        if (reader_rows(r, y0, y1, 0, c, 0, buf, c * (ptrdiff_t)sizeof(float),
                        (ptrdiff_t)(row * sizeof(float)), msg, msg_size)) {
            wg_free(buf);
            return WG_ERR_IO;
        }
        count_bad(bad, buf, row * (size_t)(y1 - y0), c, w, y0);
        for (int y = y0; y < y1 && !bad->count; y++)
            convert_row(buf + row * (size_t)(y - y0), c, cs, wg_image_row(dst, y), w,
                        dst->channels);
    }
    wg_free(buf);
    return WG_OK;
}

/* The direct path, when every file channel has its place in the destination (gray to gray or
 * colour, RGB or RGBA to colour): the decoder writes straight into the image's rows, then each
 * row is finished in place (non-finite check, sRGB decoding, gray copied to G and B, alpha 1). */
static int read_direct(Reader *r, WgColorspace cs, WgImage *dst, BadValues *bad, char *msg,
                       size_t msg_size)
{
    int w = r->w, c = r->c, dc = dst->channels;
    ptrdiff_t ystride = (ptrdiff_t)(dst->stride * sizeof(float));
    for (int y0 = 0; y0 < r->h; y0 += r->strip) {
        int y1 = r->h - y0 < r->strip ? r->h : y0 + r->strip;
        if (reader_rows(r, y0, y1, 0, c, 0, wg_image_row(dst, y0), dc * (ptrdiff_t)sizeof(float),
                        ystride, msg, msg_size))
            return WG_ERR_IO;
        for (int y = y0; y < y1; y++) {
            float *p = wg_image_row(dst, y);
            for (int x = 0; x < w; x++, p += dc) {
                for (int k = 0; k < c; k++) {
                    if (isfinite(p[k])) continue;
                    if (!bad->count++) {
                        bad->x = (size_t)x;
                        bad->y = (size_t)y;
                    }
                }
                if (bad->count) continue;
                if (cs == WG_SRGB)
                    for (int k = 0; k < c && k < 3; k++) p[k] = srgb_decode(p[k]);
                if (dc == 4 && c == 1) p[1] = p[2] = p[0];
                if (dc == 4 && c < 4) p[3] = 1.0f;
            }
        }
    }
    return WG_OK;
}

/* Integer files: the decoder hands over its 8- or 16-bit codes (a quarter or half of the bytes
 * of floats) and each becomes a float through a table: the value OpenImageIO gives the code
 * (k times the float reciprocal of 255 or 65535, which is not always the float nearest
 * k/255), and for sRGB colour channels srgb_decode of that value, so every path, native or
 * OpenImageIO, gives the same floats. */
static float code_lin8[256], code_srgb8[256], code_lin16[65536], code_srgb16[65536];
static pthread_once_t code_once = PTHREAD_ONCE_INIT, code8_once = PTHREAD_ONCE_INIT;

/* The 8-bit tables alone for 8-bit files (every JPEG): 256 curve evaluations, where the 16-bit
 * ones take 65536 and the sRGB table 65536 more, a few milliseconds a process would pay on its
 * first image. srgb_decode of a value in [0, 1] is wg_srgb_to_linear of it, through its table
 * or not. */
static void code8_tables_build(void)
{
    volatile float r8 = 1.0f / 255.0f; /* rounded to float first */
    for (int i = 0; i < 256; i++) code_lin8[i] = (float)i * r8;
    for (int i = 0; i < 256; i++) code_srgb8[i] = wg_srgb_to_linear(code_lin8[i]);
}

static void code_tables_build(void)
{
    pthread_once(&code8_once, code8_tables_build);
    pthread_once(&srgb_once, srgb_lut_build);
    volatile float r16 = 1.0f / 65535.0f; /* rounded to float first */
    for (int i = 0; i < 65536; i++) code_lin16[i] = (float)i * r16;
    for (int i = 0; i < 65536; i++) code_srgb16[i] = srgb_decode(code_lin16[i]);
}

/* One row of codes to the destination's channels, as convert_row does for floats. */
#define CONVERT_CODES(T)                                                                           \
    for (int x = 0; x < w; x++) {                                                                  \
        const T *p = (const T *)src + (size_t)x * (size_t)c;                                       \
        if (c <= 2) {                                                                              \
            float v = col[p[0]];                                                                   \
            if (channels == 1) {                                                                   \
                dst[x] = v;                                                                        \
            } else {                                                                               \
                dst[4 * x] = dst[4 * x + 1] = dst[4 * x + 2] = v;                                  \
                dst[4 * x + 3] = c == 2 ? lin[p[1]] : 1.0f;                                        \
            }                                                                                      \
        } else {                                                                                   \
            float px[4] = {col[p[0]], col[p[1]], col[p[2]], c >= 4 ? lin[p[3]] : 1.0f};            \
            if (channels == 1)                                                                     \
                dst[x] = wg__luminance(px);                                                        \
            else                                                                                   \
                memcpy(dst + 4 * x, px, sizeof px);                                                \
        }                                                                                          \
    }

static void convert_codes(const void *src, int bits, int c, WgColorspace cs, float *dst, int w,
                          int channels)
{
    const float *lin = bits == 8 ? code_lin8 : code_lin16;
    const float *col = cs != WG_SRGB ? lin : bits == 8 ? code_srgb8 : code_srgb16;
    if (bits == 8) {
        CONVERT_CODES(uint8_t)
    } else {
        CONVERT_CODES(uint16_t)
    }
}

static int read_codes(Reader *r, WgColorspace cs, WgImage *dst, char *msg, size_t msg_size)
{
    pthread_once(&code_once, code_tables_build);
    size_t b = (size_t)r->bits / 8, row = (size_t)r->w * (size_t)r->c * b;
    unsigned char *buf = wg_malloc(row * (size_t)r->strip);
    if (!buf) return WG_ERR_NOMEM;
    for (int y0 = 0; y0 < r->h; y0 += r->strip) {
        int y1 = r->h - y0 < r->strip ? r->h : y0 + r->strip;
        if (reader_rows(r, y0, y1, 0, r->c, r->bits, buf, (ptrdiff_t)((size_t)r->c * b),
                        (ptrdiff_t)row, msg, msg_size)) {
            wg_free(buf);
            return WG_ERR_IO;
        }
        for (int y = y0; y < y1; y++)
            convert_codes(buf + row * (size_t)(y - y0), r->bits, r->c, cs, wg_image_row(dst, y),
                          r->w, dst->channels);
    }
    wg_free(buf);
    return WG_OK;
}

/* Native PNG rows: big-endian samples to codes, then as read_codes. */
typedef struct {
    WgImage *dst;
    WgColorspace cs;
    int c;
    uint16_t *row16;
} PngRows;

static void png_row(void *user, int y, const unsigned char *data, int depth)
{
    PngRows *p = user;
    const void *codes = data;
    if (depth == 16) {
        size_t n = (size_t)p->dst->width * (size_t)p->c;
        for (size_t i = 0; i < n; i++) p->row16[i] = (uint16_t)(data[2 * i] << 8 | data[2 * i + 1]);
        codes = p->row16;
    }
    convert_codes(codes, depth, p->c, p->cs, wg_image_row(p->dst, y), p->dst->width,
                  p->dst->channels);
}

/* 1 when the file is not a PNG decoded natively. */
static int read_png(const char *path, WgColorspace cs, WgImage *dst, WgError *err)
{
    char msg[512];
    int w, h, c;
    if (wg__png_probe(path, &w, &h, &c, msg, sizeof msg)) return 1;
    pthread_once(&code_once, code_tables_build);
    PngRows rows = {dst, cs, c, NULL};
    rows.row16 = wg_malloc((size_t)w * (size_t)c * sizeof(uint16_t));
    if (!rows.row16)
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
    WgPngSink sink = {dst->width, dst->height, c, png_row, &rows};
    int rc = wg__png_read(path, &sink, msg, sizeof msg);
    wg_free(rows.row16);
    if (rc < 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    return rc;
}

int wg_image_decode_size(const char *path, int width, int height, int *dw, int *dh, WgError *err)
{
    int w, h, c;
    FileKind kind;
    bool native;
    int rc = probe(path, &w, &h, &c, &kind, &native, err);
    if (rc) return rc;
    *dw = w;
    *dh = h;
    if (kind != FILE_JPEG || !native) return WG_OK;
    for (int s = 1; s < 8; s++) {
        int sw = wg__jpeg_scaled_side(w, s), sh = wg__jpeg_scaled_side(h, s);
        if (sw >= width && sh >= height) {
            *dw = sw;
            *dh = sh;
            break;
        }
    }
    return WG_OK;
}

/* JPEG rows are 8-bit gray or RGB codes; the two common cases (gray to gray, RGB to colour)
 * in loops of their own, the values convert_codes gives. */
static void jpeg_row(void *user, int y, const unsigned char *data, int depth)
{
    PngRows *p = user;
    float *dst = wg_image_row(p->dst, y);
    int w = p->dst->width;
    const float *col = p->cs == WG_SRGB ? code_srgb8 : code_lin8;
    /* linear values are the table's own arithmetic, code times the float reciprocal of 255,
     * which vectorises where the lookup does not */
    const float r8 = code_lin8[1];
    if (p->cs != WG_SRGB && p->c == 1 && p->dst->channels == 1) {
        for (int x = 0; x < w; x++) dst[x] = (float)data[x] * r8;
    } else if (p->cs != WG_SRGB && p->c == 3 && p->dst->channels == 4) {
        for (int x = 0; x < w; x++, data += 3, dst += 4) {
            dst[0] = (float)data[0] * r8;
            dst[1] = (float)data[1] * r8;
            dst[2] = (float)data[2] * r8;
            dst[3] = 1.0f;
        }
    } else if (p->c == 3 && p->dst->channels == 4) {
        for (int x = 0; x < w; x++, data += 3, dst += 4) {
            dst[0] = col[data[0]];
            dst[1] = col[data[1]];
            dst[2] = col[data[2]];
            dst[3] = 1.0f;
        }
    } else if (p->c == 1 && p->dst->channels == 1) {
        for (int x = 0; x < w; x++) dst[x] = col[data[x]];
    } else {
        convert_codes(data, depth, p->c, p->cs, dst, w, p->dst->channels);
    }
}

/* 1 when the file is not a JPEG decoded natively at the destination's size (then the general
 * path reads it, or says that it changed). */
static int read_jpeg(const char *path, WgColorspace cs, WgImage *dst, WgError *err)
{
    pthread_once(&code8_once, code8_tables_build);
    PngRows rows = {dst, cs, 0, NULL};
    WgPngSink sink = {dst->width, dst->height, 0, jpeg_row, &rows};
    char msg[512];
    int rc = wg__jpeg_read(path, &sink, &rows.c, msg, sizeof msg);
    if (rc < 0)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    return rc;
}

int wg_image_read_into(const char *path, WgColorspace cs, WgImage *dst, WgError *err)
{
    int rc = check_regular(path, err);
    if (rc) return rc;
    FileKind kind = file_kind(path);
    if (kind == FILE_PNG && (rc = read_png(path, cs, dst, err)) <= 0) return rc;
    if (kind == FILE_JPEG && (rc = read_jpeg(path, cs, dst, err)) <= 0) return rc;
    char msg[512];
    Reader r;
    if (wg__png_check(path, true, msg, sizeof msg) || reader_open(path, &r, NULL, msg, sizeof msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    if (r.w != dst->width || r.h != dst->height) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0,
                             "the file changed while it was being read (now %dx%d, was %dx%d)", r.w,
                             r.h, dst->width, dst->height);
        goto out;
    }
    if (r.c < 1) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "image has no channels");
        goto out;
    }
    if (cs == WG_SRGB) pthread_once(&srgb_once, srgb_lut_build);
    BadValues bad = {0};
    bool direct = r.c == 1 || (dst->channels == 4 && (r.c == 3 || r.c == 4));
    if (r.bits)
        rc = read_codes(&r, cs, dst, msg, sizeof msg);
    else if (direct)
        rc = read_direct(&r, cs, dst, &bad, msg, sizeof msg);
    else
        rc = read_strips(&r, cs, dst, &bad, msg, sizeof msg);
    if (rc == WG_ERR_NOMEM)
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory reading '%s'", path);
    else if (rc)
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the image: %s", msg);
    else if (bad.count)
        rc = wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0,
                             "image has %zu non-finite values (NaN or infinity), the first at "
                             "pixel (%zu, %zu)",
                             bad.count, bad.x, bad.y);
out:
    reader_close(&r);
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

/* Is every alpha of a colour image 1? Its rows in bands, on whichever worker takes a band; a
 * band stops once any band has found an alpha that is not 1. */
#define OPAQUE_BANDS 64

typedef struct {
    const WgImage *img;
    int rows, bands; /* rows: the image's, or 1 when all are the same memory */
    atomic_bool transparent;
} OpaqueJob;

static void opaque_bands(void *user, int b0, int b1)
{
    OpaqueJob *j = user;
    const WgImage *img = j->img;
    for (int b = b0; b < b1 && !atomic_load_explicit(&j->transparent, memory_order_relaxed); b++) {
        int y0 = (int)((long long)b * j->rows / j->bands);
        int y1 = (int)((long long)(b + 1) * j->rows / j->bands);
        for (int y = y0; y < y1; y++) {
            if (!wg_image_row_alpha_one(img, y)) {
                atomic_store_explicit(&j->transparent, true, memory_order_relaxed);
                return;
            }
        }
    }
}

static bool opaque(const WgImage *img, const WgWorkers *workers)
{
    int rows = img->stride == 0 ? 1 : img->height; /* rows all the same memory: one is enough */
    OpaqueJob j = {img, rows, rows < OPAQUE_BANDS ? rows : OPAQUE_BANDS};
    atomic_init(&j.transparent, false);
    if (!workers || !workers->run || workers->run(workers->ctx, j.bands, opaque_bands, &j))
        opaque_bands(&j, 0, j.bands);
    return !atomic_load(&j.transparent);
}

/* The file layout of `img`: RGB when every alpha is 1 (alpha_one, when the caller knows: 1 or
 * 0; -1: looked at here), and the sample type of the format. */
static void file_layout(const WgImage *img, WgFormat format, const WgWorkers *workers,
                        int alpha_one, int *channels, int *bits)
{
    int c = img->channels;
    if (c == 4 && (alpha_one >= 0 ? alpha_one : opaque(img, workers))) c = 3;
    if (format == WG_FORMAT_JPEG && c == 4) c = 3; /* JPEG keeps no alpha */
    *channels = c;
    *bits = format == WG_FORMAT_PNG || format == WG_FORMAT_JPEG || format == WG_FORMAT_TGA ? 8
            : format == WG_FORMAT_EXR                                                      ? -16
            : format == WG_FORMAT_EXR32                                                    ? 32
                                                                                           : 16;
}

/* The linear packing loops come in three kinds, with the same codes: in float with FMA, 16
 * samples to an instruction where the processor has AVX-512 (x86-64-v4 on x86) or 8 where it has
 * AVX2 (x86-64-v3), chosen at run time, else in double. FMA_LOOPS and WIDE_LOOPS compile a
 * function for those; HAS_FMA and HAS_WIDE say whether the processor runs it. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define FMA_LOOPS __attribute__((target("arch=x86-64-v3")))
#define WIDE_LOOPS __attribute__((target("arch=x86-64-v4")))
#define HAS_FMA (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
#define HAS_WIDE __builtin_cpu_supports("x86-64-v4")
#elif defined(__FMA__) || defined(__ARM_FEATURE_FMA)
#define FMA_LOOPS
#define WIDE_LOOPS
#define HAS_FMA 1
#define HAS_WIDE 0
#else
#define FMA_LOOPS
#define WIDE_LOOPS
#define HAS_FMA 0
#define HAS_WIDE 0
#endif

static _Atomic int pack_way = -1; /* WG_PACK_*; -1: not decided yet */

static int best_pack_way(void)
{
    return HAS_WIDE ? WG_PACK_WIDE : HAS_FMA ? WG_PACK_FMA : WG_PACK_DOUBLE;
}

int wg__pack_loops(int way)
{
    int best = best_pack_way();
    pack_way = way < 0 || way > best ? best : way;
    return pack_way;
}

static int pack_loops(void)
{
    int v = pack_way;
    if (v < 0) pack_way = v = best_pack_way();
    return v;
}

/* The linear code of a sample for `max` (255 or 65535): floor(clamp(v, 0, 1) * max + 0.5),
 * quantize()'s rounding, in float with one correction. The clamp is done on the bit pattern
 * (negatives, zeros and NaNs to 0, from 1 up to 1). fma(x, max, 0.5), rounded once, is never
 * below the exact value's floor and at most one above it (an integer is a float, so rounding
 * to nearest cannot cross it downwards); the exact sign of x * max + 0.5 - code, which fma
 * keeps, says when it is one above. No branch and no double: the loops below are vectorised,
 * 8 samples to an instruction. Checked against the double formula on all 2^32 floats when
 * written; the tests check the floats around every code boundary, both ways. */
static inline int32_t linear_code(float v, float max)
{
    int32_t b;
    memcpy(&b, &v, sizeof b);
    int32_t c = b > 0 ? b : 0;
    c = c < 0x3f800000 ? c : 0x3f800000;
    c = (b & 0x7fffffff) > 0x7f800000 ? 0 : c;
    float x;
    memcpy(&x, &c, sizeof x);
    int32_t code = (int32_t)__builtin_fmaf(x, max, 0.5f);
    float rest = __builtin_fmaf(x, max, 0.5f - (float)code);
    int32_t sign;
    memcpy(&sign, &rest, sizeof sign);
    return code + (sign >> 31);
}

/* The same code in double, for processors without FMA: v * max + 0.5 is exact in double (a
 * float has 24 bits, max 16), so clamping it to [0.5, max + 0.5] gives what clamping v to
 * [0, 1] first gives, NaN failing the first compare and becoming 0. */
static inline int32_t linear_code_double(float v, double max)
{
    double m = (double)v * max + 0.5;
    m = m > 0.5 ? m : 0.5;
    m = m < max + 0.5 ? m : max + 0.5;
    return (int32_t)m;
}

FMA_LOOPS static void pack16_fma(const float *restrict r, uint16_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint16_t)linear_code(r[j], 65535.0f);
}

FMA_LOOPS static void pack8_fma(const float *restrict r, uint8_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint8_t)linear_code(r[j], 255.0f);
}

WIDE_LOOPS static void pack16_wide(const float *restrict r, uint16_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint16_t)linear_code(r[j], 65535.0f);
}

WIDE_LOOPS static void pack8_wide(const float *restrict r, uint8_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint8_t)linear_code(r[j], 255.0f);
}

HOT static void pack16_double(const float *restrict r, uint16_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint16_t)linear_code_double(r[j], 65535.0);
}

HOT static void pack8_double(const float *restrict r, uint8_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) o[j] = (uint8_t)linear_code_double(r[j], 255.0);
}

/* n linear samples to 16-bit codes with quantize()'s rounding. */
static void pack16_linear(const float *restrict r, uint16_t *restrict o, size_t n)
{
    int way = pack_loops();
    if (way == WG_PACK_WIDE)
        pack16_wide(r, o, n);
    else if (way == WG_PACK_FMA)
        pack16_fma(r, o, n);
    else
        pack16_double(r, o, n);
}

/* n linear samples to 8-bit codes (quantize8_linear's). */
static void pack8_linear(const float *restrict r, uint8_t *restrict o, size_t n)
{
    int way = pack_loops();
    if (way == WG_PACK_WIDE)
        pack8_wide(r, o, n);
    else if (way == WG_PACK_FMA)
        pack8_fma(r, o, n);
    else
        pack8_double(r, o, n);
}

/* n samples to 8-bit sRGB codes (quantize8_srgb's), in integers on the floats' bit patterns,
 * without a branch: the vectoriser gathers the run codes. Negative values, zeros and negative
 * NaNs (negative as int32) go to 0, values from 1 up to the run below 1 (code 255), positive
 * NaNs to 0 at the end. Needs srgb8_one_step. */
HOT static void pack8_srgb(const float *restrict r, uint8_t *restrict o, size_t n)
{
    for (size_t j = 0; j < n; j++) {
        int32_t b;
        memcpy(&b, &r[j], sizeof b);
        int32_t v = b > 0 ? b : 0;
        v = v < 0x3f800000 ? v : 0x3f7fffff;
        int32_t k = srgb8_run_code[v >> SRGB8_SHIFT];
        k += srgb8_threshold[k + 1] <= v;
        k = (b & 0x7fffffff) > 0x7f800000 ? 0 : k;
        o[j] = (uint8_t)k;
    }
}

/* m pixels of RGBA codes to RGB codes: where the processor has SSSE3, four pixels a byte
 * shuffle, each 16-byte store's last 4 bytes written again by the next (the loop stops while
 * they are still inside out); the rest, and other processors, a byte at a time. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HAS_SSSE3 __builtin_cpu_supports("ssse3")
__attribute__((target("ssse3"))) static int rgb_of_rgba_ssse3(const uint8_t *in, uint8_t *out,
                                                              int m)
{
    const __m128i drop_alpha =
        _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);
    int i = 0;
    for (; i + 6 <= m; i += 4) {
        __m128i four = _mm_loadu_si128((const __m128i *)(in + 4 * i));
        _mm_storeu_si128((__m128i *)(out + 3 * i), _mm_shuffle_epi8(four, drop_alpha));
    }
    return i;
}
#else
#define HAS_SSSE3 0
static int rgb_of_rgba_ssse3(const uint8_t *in, uint8_t *out, int m)
{
    (void)in, (void)out, (void)m;
    return 0;
}
#endif

static void rgb_of_rgba(const uint8_t *in, uint8_t *out, int m)
{
    int i = HAS_SSSE3 ? rgb_of_rgba_ssse3(in, out, m) : 0;
    for (; i < m; i++) {
        out[3 * i] = in[4 * i];
        out[3 * i + 1] = in[4 * i + 1];
        out[3 * i + 2] = in[4 * i + 2];
    }
}

/* A row of 8-bit codes from 4-channel samples, in stretches of PACK8_PIXELS through the
 * vectorised loops: the first three channels (sRGB or linear), then alpha (always linear) when
 * c is 4, else dropped (c 3). */
#define PACK8_PIXELS 256
static void pack8_rgba_row(const float *r, int w, int c, bool srgb, uint8_t *o)
{
    uint8_t codes[4 * PACK8_PIXELS];
    for (int x0 = 0; x0 < w; x0 += PACK8_PIXELS) {
        int m = w - x0 < PACK8_PIXELS ? w - x0 : PACK8_PIXELS;
        const float *s = r + 4 * (size_t)x0;
        uint8_t *p = o + (size_t)c * (size_t)x0;
        if (srgb) {
            pack8_srgb(s, codes, 4 * (size_t)m);
            if (c == 4)
                for (int i = 0; i < m; i++) codes[4 * i + 3] = quantize8_linear(s[4 * i + 3]);
        } else {
            pack8_linear(s, codes, 4 * (size_t)m);
        }
        if (c == 4)
            memcpy(p, codes, 4 * (size_t)m);
        else
            rgb_of_rgba(codes, p, m);
    }
}

/* Quantise rows [y0, y1) of `img` into buf, packed: `c` channels of `bits` each. */
static void pack_rows(const WgImage *img, WgColorspace cs, int c, int bits, int y0, int y1,
                      void *buf)
{
    size_t i = 0;
    if (bits == 16 && cs != WG_SRGB) {
        /* linear 16-bit samples, most of what is written, in a loop without calls: the same
         * rounding as quantize(), NaN to 0 by the comparisons */
        size_t n = (size_t)img->width * (size_t)c;
        for (int y = y0; y < y1; y++) {
            const float *r = wg_image_row(img, y);
            uint16_t *o = (uint16_t *)buf + (size_t)(y - y0) * n;
            if (c == img->channels) {
                pack16_linear(r, o, n);
                continue;
            }
            for (int x = 0; x < img->width; x++)
                for (int k = 0; k < c; k++) {
                    float v = r[x * img->channels + k];
                    double d = v > 0 ? (v < 1 ? (double)v : 1.0) : 0.0;
                    o[x * c + k] = (uint16_t)(uint32_t)(d * 65535.0 + 0.5);
                }
        }
        return;
    }
    if (bits == 8) { /* wg_quantize8's codes, without a call per sample */
        pthread_once(&srgb8_once, srgb8_build);
        int srgb = cs == WG_SRGB ? (c < 3 ? c : 3) : 0; /* channels encoded as sRGB */
        uint8_t *o = buf;
        size_t n = (size_t)img->width * (size_t)c;
        for (int y = y0; y < y1; y++, o += n) {
            const float *r = wg_image_row(img, y);
            if (!srgb && c == img->channels) {
                pack8_linear(r, o, n);
                continue;
            }
            if (srgb && c == 1 && img->channels == 1 && srgb8_one_step) {
                pack8_srgb(r, o, n);
                continue;
            }
            if (img->channels == 4 && c >= 3 && (!srgb || srgb8_one_step)) {
                pack8_rgba_row(r, img->width, c, srgb, o);
                continue;
            }
            uint8_t *p = o;
            for (int x = 0; x < img->width; x++, r += img->channels) {
                int k = 0;
                for (; k < srgb; k++) *p++ = quantize8_srgb(r[k]);
                for (; k < c; k++) *p++ = quantize8_linear(r[k]);
            }
        }
        return;
    }
    for (int y = y0; y < y1; y++) {
        const float *r = wg_image_row(img, y);
        for (int x = 0; x < img->width; x++) {
            for (int k = 0; k < c; k++, i++) {
                float v = r[x * img->channels + k];
                bool colour = k < 3; /* gray is a colour channel too; alpha never is */
                if (bits == 8)
                    ((uint8_t *)buf)[i] = wg_quantize8(v, cs == WG_SRGB && colour);
                else if (bits == 16)
                    ((uint16_t *)buf)[i] = (uint16_t)quantize(v, cs, colour, 65535.0);
                else
                    ((float *)buf)[i] = v;
            }
        }
    }
}

/* PNG: the whole image packed, then png_write.c filters and compresses it in one go. */
typedef struct {
    const WgImage *img;
    WgColorspace cs;
    int c, bits;
} PngPack;

static void png_pack_row(void *user, int y, void *row)
{
    const PngPack *p = user;
    pack_rows(p->img, p->cs, p->c, p->bits, y, y + 1, row);
}

static int encode_png(const char *path, const WgImage *img, WgColorspace cs, int c, int bits,
                      WgPngCompression png, const WgWorkers *workers, char *msg, size_t msg_size)
{
    PngPack p = {img, cs, c, bits};
    return wg__png_write_rows(path, img->width, img->height, c, bits, png, png_pack_row, &p,
                              img->stride == 0, workers, msg, msg_size);
}

/* Other formats go through OpenImageIO, STRIP_ROWS rows at a time, so writing holds a strip of
 * packed pixels, not a packed copy of the image. Nonzero with msg on failure. */
static int encode_to_file(const char *path, const WgImage *img, WgFormat format, WgColorspace cs,
                          int c, int bits, WgPngCompression png, const WgWorkers *workers,
                          char *msg, size_t msg_size)
{
    if (format == WG_FORMAT_PNG || format == WG_FORMAT_PNG16)
        return encode_png(path, img, cs, c, bits, png, workers, msg, msg_size);
    size_t row = (size_t)img->width * (size_t)c;
    size_t elem = bits == 8 ? 1 : bits == 16 ? 2 : 4;
    void *buf = wg_malloc(row * STRIP_ROWS * elem);
    if (!buf) {
        snprintf(msg, msg_size, "out of memory");
        return -1;
    }
    WgOiioOut *out;
    char ext[32]; /* a JPEG's quality travels with its extension: "jpg:92" */
    if (format == WG_FORMAT_JPEG)
        snprintf(ext, sizeof ext, "jpg:%d", atomic_load(&jpeg_quality));
    else
        snprintf(ext, sizeof ext, "%s", wg_format_extension(format));
    bool ok = !wg__oiio_create(path, ext, img->width, img->height, c, bits, &out, msg, msg_size);
    for (int y0 = 0; ok && y0 < img->height; y0 += STRIP_ROWS) {
        int y1 = img->height - y0 < STRIP_ROWS ? img->height : y0 + STRIP_ROWS;
        pack_rows(img, cs, c, bits, y0, y1, buf);
        ok = !wg__oiio_write_rows(out, y0, y1, buf, msg, msg_size);
        if (!ok) {
            wg__oiio_finish(out, false, NULL, 0);
            out = NULL;
        }
    }
    if (ok && wg__oiio_finish(out, true, msg, msg_size)) ok = false;
    wg_free(buf);
    return ok ? 0 : -1;
}

/* ---- write sets: temporaries first, then renames ----------------------------------------- */

typedef struct {
    char *path, *temp;
    WgFlush *flush; /* its flush to the disk, until the commit has waited for it (NULL: none) */
} Staged;

struct WgWriteSet {
    Staged *files;
    int count, cap;
};

WgWriteSet *wg_write_set_new(void)
{
    return wg_calloc(1, sizeof(WgWriteSet));
}

/* Before anything is created: a target named like a temporary would be deleted later by
 * wg_remove_stale_temporaries, and an array slot for the file. */
static int stage_begin(WgWriteSet *s, const char *path, char **temp, WgError *err)
{
    const char *slash = strrchr(path, '/');
    if (wg__temp_name_pid(slash ? slash + 1 : path))
        return wg_error_set_at(
            err, WG_ERR_USAGE, path, 0, 0,
            "the name has the form of a temporary file (.NAME.tmpPID-N-HOST.EXT)");
    if (s->count == s->cap) {
        int cap = s->cap ? 2 * s->cap : 8;
        Staged *f = wg_realloc_array(s->files, (size_t)s->cap, (size_t)cap, sizeof *f);
        if (!f) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        s->files = f;
        s->cap = cap;
    }
    char *copy = wg_strdup(path);
    *temp = wg__temp_path_for(path);
    if (!copy || !*temp) {
        wg_free(copy);
        wg_free(*temp);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    s->files[s->count] = (Staged){copy, *temp, NULL};
    return WG_OK;
}

/* Flush a written temporary to the disk; `path` is its target, named in the error. */
static int sync_temp(const char *temp, const char *path, WgError *err)
{
    int fd = open(temp, O_RDONLY | O_CLOEXEC);
    int rc = WG_OK;
    if (fd < 0 || fsync(fd) != 0)
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the file: %s",
                             strerror(errno));
    if (fd >= 0) close(fd);
    return rc;
}

/* The temporary is written (rc says how): keep it, its flush to the disk handed to the flusher
 * thread (or done here when it cannot be), or remove it. */
static int stage_end(WgWriteSet *s, int rc, WgError *err)
{
    Staged *f = &s->files[s->count];
    if (!rc && !(f->flush = wg__flush_start(f->temp))) rc = sync_temp(f->temp, f->path, err);
    if (rc) {
        unlink(f->temp);
        wg_free(f->path);
        wg_free(f->temp);
        return rc;
    }
    s->count++;
    return WG_OK;
}

/* The encoders' messages rarely say why the system refused a write ("File output failed"), but
 * errno still holds it; only causes a write itself can have are trusted, not left-overs. */
const char *wg__write_cause(int e)
{
    switch (e) {
    case ENOSPC:
        return "no space left on device";
    case EDQUOT:
        return "disk quota exceeded";
    case EFBIG:
        return "file too large";
    case EIO:
        return "input/output error";
    case EROFS:
        return "read-only file system";
    case EACCES:
        return "permission denied";
    default:
        return NULL;
    }
}

static int write_failed(WgError *err, const char *path, const char *msg)
{
    const char *cause = wg__write_cause(errno);
    if (cause && strcasecmp(cause, msg))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the image: %s (%s)", cause,
                               msg);
    return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the image: %s", msg);
}

/* Encode one image into the temporary `tmp` of target `path`. */
static int encode_one(const char *tmp, const char *path, const WgImage *img, WgFormat format,
                      WgColorspace cs, WgPngCompression png, const WgWorkers *workers,
                      int alpha_one, WgError *err)
{
    if (format == WG_FORMAT_DEFAULT) format = img->channels == 4 ? WG_FORMAT_PNG : WG_FORMAT_PNG16;
    int c, bits;
    file_layout(img, format, workers, alpha_one, &c, &bits);
    char msg[512];
    int rc = WG_OK;
    errno = 0;
    if (format == WG_FORMAT_EXR || format == WG_FORMAT_EXR32)
        rc = wg__exr_write_image(tmp, path, img, c, format == WG_FORMAT_EXR, workers, err);
    else if (encode_to_file(tmp, img, format, cs, c, bits, png, workers, msg, sizeof msg))
        rc = write_failed(err, path, msg);
    return rc;
}

int wg__write_all(int fd, const void *data, size_t n)
{
    const unsigned char *p = data;
    while (n) {
        ssize_t k = write(fd, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) {
            if (k == 0) errno = EIO;
            return -1;
        }
        p += k;
        n -= (size_t)k;
    }
    return 0;
}

/* The rest of file `in` appended to file `out`: in the kernel, without passing the bytes through
 * this process, or with read and write where the file system cannot. -1 with errno on failure. */
static int copy_fd(int in, int out)
{
    for (;;) {
        ssize_t n = copy_file_range(in, NULL, out, NULL, (size_t)1 << 30, 0);
        if (n == 0) return 0;
        if (n > 0 || errno == EINTR) continue;
        if (errno != EXDEV && errno != ENOSYS && errno != EOPNOTSUPP && errno != EINVAL) return -1;
        break;
    }
    char buf[1 << 16];
    for (;;) {
        ssize_t r = read(in, buf, sizeof buf);
        if (r == 0) return 0;
        if (r < 0 && errno == EINTR) continue;
        if (r < 0 || wg__write_all(out, buf, (size_t)r)) return -1;
    }
}

/* The staged temporary written by fill (rc: 0 or -1 with errno) and closed, or the error, worded
 * `what`, naming path. */
static int stage_fd_done(int fd, int fill, const char *path, const char *what, WgError *err)
{
    int rc = fd < 0 ? -1 : fill, e = errno;
    if (fd >= 0 && close(fd) != 0 && !rc) rc = -1, e = errno;
    if (!rc) return WG_OK;
    const char *cause = wg__write_cause(e);
    return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot write the %s: %s", what,
                           cause ? cause : strerror(e));
}

int wg_write_set_bytes(WgWriteSet *s, const char *path, const void *data, size_t size, WgError *err)
{
    char *tmp = NULL;
    int rc = stage_begin(s, path, &tmp, err);
    if (rc) return rc;
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    int fill = fd >= 0 ? wg__write_all(fd, data, size) : -1;
    return stage_end(s, stage_fd_done(fd, fill, path, "file", err), err);
}

/* Stage path with the bytes of the file `source`. */
static int stage_copy(WgWriteSet *s, const char *path, const char *source, WgError *err)
{
    char *tmp = NULL;
    int rc = stage_begin(s, path, &tmp, err);
    if (rc) return rc;
    int in = open(source, O_RDONLY | O_CLOEXEC);
    if (in < 0) {
        rc = wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read %s to copy it: %s", source,
                             strerror(errno));
        return stage_end(s, rc, err);
    }
    int out = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0666);
    int fill = out >= 0 ? copy_fd(in, out) : -1, e = errno;
    close(in);
    errno = e;
    /* worded as an encoder's failure: the file is an image's, written another way */
    rc = stage_fd_done(out, fill, path, "image", err);
    return stage_end(s, rc, err);
}

int wg_write_set_copy(WgWriteSet *s, const char *path, const WgWriteSet *from, int k, WgError *err)
{
    if (k < 0 || k >= from->count)
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "no staged file %d to copy", k);
    return stage_copy(s, path, from->files[k].temp, err);
}

int wg_write_set_copy_file(WgWriteSet *s, const char *path, const char *source, WgError *err)
{
    return stage_copy(s, path, source, err);
}

int wg_write_set_image_alpha_on(WgWriteSet *s, const char *path, const WgImage *img,
                                WgFormat format, WgColorspace cs, WgPngCompression png,
                                const WgWorkers *workers, int alpha_one, WgError *err)
{
    char *tmp = NULL;
    int rc = stage_begin(s, path, &tmp, err);
    if (rc) return rc;
    int k = img->channels == 4 && alpha_one >= 0 ? alpha_one != 0 : -1;
    return stage_end(s, encode_one(tmp, path, img, format, cs, png, workers, k, err), err);
}

int wg_write_set_image_png_on(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                              WgColorspace cs, WgPngCompression png, const WgWorkers *workers,
                              WgError *err)
{
    return wg_write_set_image_alpha_on(s, path, img, format, cs, png, workers, -1, err);
}

int wg_write_set_image_png(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                           WgColorspace cs, WgPngCompression png, WgError *err)
{
    return wg_write_set_image_png_on(s, path, img, format, cs, png, NULL, err);
}

int wg_write_set_image(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                       WgColorspace cs, WgError *err)
{
    return wg_write_set_image_png(s, path, img, format, cs, WG_PNG_COMPRESSION_FAST, err);
}

/* ---- threads of their own --------------------------------------------------------------- */

typedef struct {
    void (*fn)(void *user, int i0, int i1);
    void *user;
    int n;
    atomic_int next;
} ThreadRun;

static void *take_parts(void *arg)
{
    ThreadRun *r = arg;
    for (int i; (i = atomic_fetch_add(&r->next, 1)) < r->n;) r->fn(r->user, i, i + 1);
    return NULL;
}

static int run_on_threads(const void *ctx, int n, void (*fn)(void *user, int i0, int i1),
                          void *user)
{
    int threads = *(const int *)ctx;
    if (threads <= 0) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        threads = cores > 0 ? (int)cores : 1;
    }
    if (threads > n) threads = n;
    if (threads > 256) threads = 256;
    ThreadRun r = {fn, user, n};
    atomic_init(&r.next, 0);
    pthread_t tids[256];
    int started = 0;
    /* the calling thread is one of them; a thread that cannot start leaves its share to the
     * others */
    for (int t = 1; t < threads; t++)
        if (!pthread_create(&tids[started], NULL, take_parts, &r)) started++;
    take_parts(&r);
    for (int t = 0; t < started; t++) pthread_join(tids[t], NULL);
    return 0;
}

WgWorkers wg_workers_threads(const int *threads)
{
    return (WgWorkers){.run = run_on_threads, .ctx = threads};
}

typedef struct {
    WgWriteSet *s;
    int base;
    const WgImage *const *images;
    const WgFormat *formats;
    const WgColorspace *cs;
    const WgPngCompression *png;
    int *rc;
    WgError *errs;
} Batch;

/* Images [i0, i1) of the batch encoded and flushed */
static void batch_part(void *user, int i0, int i1)
{
    Batch *b = user;
    for (int i = i0; i < i1; i++) {
        const Staged *f = &b->s->files[b->base + i];
        int rc = encode_one(f->temp, f->path, b->images[i], b->formats[i], b->cs[i],
                            b->png ? b->png[i] : WG_PNG_COMPRESSION_FAST, NULL, -1, &b->errs[i]);
        b->rc[i] = rc ? rc : sync_temp(f->temp, f->path, &b->errs[i]);
    }
}

/* Drop the staged files from `from` on, removing their temporaries. */
static void unstage(WgWriteSet *s, int from)
{
    for (int i = from; i < s->count; i++) {
        unlink(s->files[i].temp);
        wg_free(s->files[i].path);
        wg_free(s->files[i].temp);
    }
    s->count = from;
}

int wg_write_set_images(WgWriteSet *s, int n, const char *const *paths,
                        const WgImage *const *images, const WgFormat *formats,
                        const WgColorspace *cs, const WgPngCompression *png, int threads,
                        WgError *err)
{
    int base = s->count, rc = WG_OK;
    for (int i = 0; i < n && !rc; i++) {
        char *tmp;
        if (!(rc = stage_begin(s, paths[i], &tmp, err))) s->count++;
    }
    if (rc) {
        unstage(s, base);
        return rc;
    }
    Batch b = {s,
               base,
               images,
               formats,
               cs,
               png,
               wg_calloc((size_t)n + 1, sizeof(int)),
               wg_calloc((size_t)n + 1, sizeof(WgError))};
    if (!b.rc || !b.errs) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    } else {
        WgWorkers workers = wg_workers_threads(&threads);
        workers.run(workers.ctx, n, batch_part, &b);
        for (int i = 0; i < n && !rc; i++)
            if (b.rc[i]) {
                rc = b.rc[i];
                if (err) *err = b.errs[i];
            }
    }
    if (rc) unstage(s, base);
    wg_free(b.rc);
    wg_free(b.errs);
    return rc;
}

int wg_write_set_exr_layers_on(WgWriteSet *s, const char *path, int count, const char *const *names,
                               const WgImage *const *images, bool half, const WgWorkers *workers,
                               WgError *err)
{
    int rc = wg__exr_check_layers(path, count, names, images, err);
    if (rc) return rc;
    char *tmp;
    if ((rc = stage_begin(s, path, &tmp, err))) return rc;
    rc = wg__exr_write_file(tmp, path, count, names, images, half, workers, err);
    return stage_end(s, rc, err);
}

int wg_write_set_exr_layers(WgWriteSet *s, const char *path, int count, const char *const *names,
                            const WgImage *const *images, bool half, WgError *err)
{
    return wg_write_set_exr_layers_on(s, path, count, names, images, half, NULL, err);
}

int wg_write_set_move(WgWriteSet *into, WgWriteSet *from, WgError *err)
{
    if (!from->count) return WG_OK;
    if (into->count + from->count > into->cap) {
        int cap = into->count + from->count;
        Staged *f = wg_realloc_array(into->files, (size_t)into->cap, (size_t)cap, sizeof *f);
        if (!f) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        into->files = f;
        into->cap = cap;
    }
    memcpy(into->files + into->count, from->files, (size_t)from->count * sizeof *from->files);
    into->count += from->count;
    from->count = 0;
    return WG_OK;
}

/* Append "a, b, c" (the targets [from, to)) to buf, cut with "..." when it does not fit. */
static void list_paths(char *buf, size_t size, const WgWriteSet *s, int from, int to)
{
    size_t len = strlen(buf);
    for (int i = from; i < to && len + 1 < size; i++) {
        int n = snprintf(buf + len, size - len, "%s%s", i > from ? ", " : "", s->files[i].path);
        len = n < 0 || (size_t)n >= size - len ? size - 1 : len + (size_t)n;
    }
    if (len + 1 >= size && size > 4) memcpy(buf + size - 4, "...", 4);
}

/* Make the renames durable: fsync each target folder once. Best effort (some file systems
 * refuse to sync a folder); the data itself was synced before the renames. */
static void sync_folders(const WgWriteSet *s, int n)
{
    for (int i = 0; i < n; i++) {
        const char *p = s->files[i].path, *slash = strrchr(p, '/');
        size_t len = slash ? (size_t)(slash - p) : 0;
        bool seen = false;
        for (int k = 0; k < i && !seen; k++) {
            const char *q = s->files[k].path, *qs = strrchr(q, '/');
            seen = (qs ? (size_t)(qs - q) : 0) == len && !strncmp(p, q, len) && !slash == !qs;
        }
        if (seen) continue;
        char dir[4096];
        snprintf(dir, sizeof dir, "%.*s", (int)len, p);
        if (!slash) snprintf(dir, sizeof dir, ".");
        if (slash == p) snprintf(dir, sizeof dir, "/");
        int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd >= 0) {
            fsync(fd);
            close(fd);
        }
    }
}

static void forget(WgWriteSet *s, int from)
{
    for (int i = 0; i < s->count; i++) {
        wg__flush_drop(s->files[i].flush);
        if (i >= from) unlink(s->files[i].temp);
        wg_free(s->files[i].path);
        wg_free(s->files[i].temp);
    }
    s->count = 0;
}

/* Every temporary on the disk before any is renamed; on a failure none is. */
static int wait_flushes(WgWriteSet *s, WgError *err)
{
    int rc = WG_OK;
    for (int i = 0; i < s->count; i++) {
        Staged *f = &s->files[i];
        if (!f->flush) continue;
        int e = wg__flush_wait(f->flush);
        f->flush = NULL;
        if (e < 0 && !rc)
            rc = sync_temp(f->temp, f->path, err);
        else if (e > 0 && !rc)
            rc = wg_error_set_at(err, WG_ERR_IO, f->path, 0, 0,
                                 "cannot write the file: %s; no file was replaced", strerror(e));
    }
    return rc;
}

int wg_write_set_commit(WgWriteSet *s, WgError *err)
{
    int flushed = wait_flushes(s, err);
    if (flushed) {
        forget(s, 0);
        return flushed;
    }
    /* a folder in a target's place would make its rename fail after others succeeded */
    for (int i = 0; i < s->count; i++) {
        struct stat st;
        if (lstat(s->files[i].path, &st) == 0 && S_ISDIR(st.st_mode)) {
            int rc = wg_error_set_at(err, WG_ERR_IO, s->files[i].path, 0, 0,
                                     "cannot replace the file: %s; no file was replaced",
                                     strerror(EISDIR));
            forget(s, 0);
            return rc;
        }
    }
    int done = 0;
    while (done < s->count && rename(s->files[done].temp, s->files[done].path) == 0) done++;
    int rc = WG_OK;
    if (done < s->count) {
        int e = errno;
        char msg[1024];
        snprintf(msg, sizeof msg, "cannot replace the file: %s; ", strerror(e));
        if (done) {
            strncat(msg, "replaced: ", sizeof msg - strlen(msg) - 1);
            list_paths(msg, sizeof msg, s, 0, done);
            strncat(msg, "; not replaced: ", sizeof msg - strlen(msg) - 1);
        } else {
            strncat(msg, "no file was replaced", sizeof msg - strlen(msg) - 1);
        }
        if (done) list_paths(msg, sizeof msg, s, done, s->count);
        rc = wg_error_set_at(err, WG_ERR_IO, s->files[done].path, 0, 0, "%s", msg);
    }
    sync_folders(s, done);
    forget(s, done);
    return rc;
}

void wg_write_set_free(WgWriteSet *s)
{
    if (!s) return;
    forget(s, 0);
    wg_free(s->files);
    wg_free(s);
}

int wg_image_write(const char *path, const WgImage *img, WgFormat format, WgColorspace cs,
                   WgError *err)
{
    WgWriteSet *s = wg_write_set_new();
    if (!s) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory writing '%s'", path);
    int rc = wg_write_set_image(s, path, img, format, cs, err);
    if (!rc) rc = wg_write_set_commit(s, err);
    wg_write_set_free(s);
    return rc;
}
