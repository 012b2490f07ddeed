/* SPDX-License-Identifier: MIT */
/* libFuzzer target for reading images: each input is written to a temporary file named with
 * the extension its first bytes suggest (.png, .jpg, .exr, .tif, .hdr, as a user's file would
 * be; none otherwise, and OpenImageIO then tries every reader), probed and, when it claims at
 * most MAX_VALUES values (a 20-byte header can claim 16384x16384 RGBA, a legitimate 4 GiB
 * allocation), read as it is in linear and converted to gray or RGBA in sRGB. Every failure
 * must be clean (a negative status equal to err.code, with a message); every image read must
 * have the probed size and only finite values. Anything else, and any sanitizer report, is a
 * crash for libFuzzer. Run it through scripts/fuzz.sh. OpenImageIO and the codecs are not
 * instrumented: coverage guides only through the engine's side. */
#include <wetgraph/wetgraph.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_VALUES (1 << 20)

static char dir[400], path[512];

static void cleanup(void)
{
    rmdir(dir);
}

static const char *extension(const uint8_t *d, size_t n)
{
    static const struct {
        const char *magic, *ext;
    } kinds[] = {{"\x89PNG", ".png"}, {"\xff\xd8", ".jpg"}, {"v/1\x01", ".exr"},
                 {"II*", ".tif"},     {"MM", ".tif"},       {"#?", ".hdr"}};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        size_t k = strlen(kinds[i].magic);
        if (n >= k && !memcmp(d, kinds[i].magic, k)) return kinds[i].ext;
    }
    return "";
}

static int expect_clean(const char *what, int rc, const WgError *err)
{
    if (rc == WG_OK) return rc;
    if (rc > 0 || err->code != rc || !err->message[0]) {
        fprintf(stderr, "fuzz_image: %s returned %d with err.code %d and message '%s'\n", what, rc,
                err->code, err->message);
        abort();
    }
    return rc;
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/wgfuzz-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        perror("fuzz_image: mkdtemp");
        exit(1);
    }
    atexit(cleanup);
    return 0;
}

static void read_as(int channels, WgColorspace cs, int w, int h)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (expect_clean("read", wg_image_read(path, channels, cs, &img, &err), &err)) return;
    if (img->width != w || img->height != h || (channels && img->channels != channels)) {
        fprintf(stderr, "fuzz_image: read %dx%dx%d, probed %dx%d\n", img->width, img->height,
                img->channels, w, h);
        abort();
    }
    for (int y = 0; y < h; y++) {
        const float *row = wg_image_row(img, y);
        for (int x = 0; x < w * img->channels; x++)
            if (!isfinite(row[x])) {
                fprintf(stderr, "fuzz_image: %g at x=%d y=%d\n", row[x], x / img->channels, y);
                abort();
            }
    }
    wg_image_unref(img);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    snprintf(path, sizeof path, "%s/image%s", dir, extension(data, size));
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size || fclose(f)) {
        perror("fuzz_image: cannot write the temporary file");
        exit(1);
    }
    int w, h, c;
    WgError err = {0};
    if (!expect_clean("probe", wg_image_probe(path, &w, &h, &c, &err), &err) &&
        (double)w * h * (c > 4 ? c : 4) <= MAX_VALUES) {
        read_as(0, WG_LINEAR, w, h);
        read_as(size & 1 ? 1 : 4, WG_SRGB, w, h);
    }
    unlink(path);
    return 0;
}
