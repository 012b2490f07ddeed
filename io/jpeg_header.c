/* SPDX-License-Identifier: MIT */
/* The size and channels of a JPEG file from its header, without OpenImageIO, so that checking a
 * graph whose images are JPEGs loads no image library. The marker segments (ITU-T T.81, annex
 * B.1) are walked from SOI to the first SOS: every segment's length must lie within the file,
 * and exactly one frame header (SOF0-3, 5-7, 9-11, 13-15) must come before the scan. Answered
 * here: 8-bit frames of 1 component (gray) or 3 (colour), with a height in the frame header. Any
 * other file (not a JPEG, damaged, 12-bit, CMYK, a height given later by a DNL marker) is left to
 * OpenImageIO, so it is refused or read exactly as before. The tables' contents are not checked
 * here; a JPEG whose tables are damaged is refused when it is read. */
#include "internal.h"
#include "wgio.h"

#include <stdio.h>

static bool is_frame(int m)
{
    return m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc;
}

/* The frame's marker in *frame (0xc2, 0xc6, 0xca and 0xce are progressive). */
int wg__jpeg_probe_file(FILE *f, int *w, int *h, int *c, int *frame)
{
    unsigned char b[8];
    int rc = 1, frames = 0;
    int fw = 0, fh = 0, fc = 0, precision = 0;
    if (fread(b, 1, 2, f) != 2 || b[0] != 0xff || b[1] != 0xd8) goto out;
    for (int segments = 0; segments < 4096; segments++) {
        int m = fgetc(f);
        if (m != 0xff) goto out;
        while ((m = fgetc(f)) == 0xff) continue; /* fill bytes */
        if (m == EOF || m == 0 || m == 0xd8 || m == 0xd9) goto out;
        if (m == 0x01 || (m >= 0xd0 && m <= 0xd7)) continue; /* no length */
        if (fread(b, 1, 2, f) != 2) goto out;
        long len = (long)b[0] << 8 | b[1];
        if (len < 2) goto out;
        if (m == 0xda) { /* the scan: the header is complete */
            if (frames == 1 && precision == 8 && fw > 0 && fh > 0 && (fc == 1 || fc == 3)) {
                *w = fw;
                *h = fh;
                *c = fc;
                rc = 0;
            }
            goto out;
        }
        if (is_frame(m)) {
            if (len < 8 || fread(b, 1, 6, f) != 6) goto out;
            *frame = m;
            precision = b[0];
            fh = b[1] << 8 | b[2];
            fw = b[3] << 8 | b[4];
            fc = b[5];
            frames++;
            len -= 6;
        }
        /* the rest of the segment must be in the file */
        if (fseek(f, len - 3, SEEK_CUR) != 0 || fgetc(f) == EOF) goto out;
    }
out:
    return rc;
}

static int probe(const char *path, int *w, int *h, int *c, int *frame)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 1;
    int rc = wg__jpeg_probe_file(f, w, h, c, frame);
    fclose(f);
    return rc;
}

int wg__jpeg_probe(const char *path, int *w, int *h, int *c)
{
    int frame;
    return probe(path, w, h, c, &frame);
}

size_t wg__jpeg_decoder_bytes(const char *path)
{
    int w, h, c, m;
    if (probe(path, &w, &h, &c, &m)) return 0;
    /* a progressive file's coefficients for the whole image (16 bits each, at most one per
     * sample, blocks padded to 16x16 pixels); otherwise libjpeg holds a few rows of blocks */
    size_t padded = (size_t)(w + 15) / 16 * 16 * (size_t)c, rows = (size_t)(h + 15) / 16 * 16;
    if (m == 0xc2 || m == 0xc6 || m == 0xca || m == 0xce) return padded * rows * 2;
    return padded * (rows < 64 ? rows : 64);
}
