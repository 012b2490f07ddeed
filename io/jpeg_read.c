/* SPDX-License-Identifier: MIT */
/* JPEG pixels decoded with libjpeg-turbo's libjpeg API, without OpenImageIO: the files
 * jpeg_header.c answers for (8-bit gray or colour frames, baseline or progressive), the same
 * decoder OpenImageIO drives with the same settings (accurate integer IDCT, fancy upsampling), so
 * both give the same codes; every other JPEG (CMYK, 12-bit) still goes to OpenImageIO. A file can
 * be decoded at n/8 of its size (n = 1..8, libjpeg's DCT scaling: the IDCT itself produces the
 * smaller picture, which costs a fraction of a full decode). libjpeg's default error handler
 * exits the process and its warnings go to stderr: here an error longjmps back with its message,
 * and so does a warning, since libjpeg reports a truncated or corrupt file only as a warning and
 * fills in the rest. */
#include "internal.h"
#include "wgio.h"

#include <jpeglib.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>

typedef struct {
    struct jpeg_error_mgr pub;
    jmp_buf jump;
    char text[JMSG_LENGTH_MAX];
} ErrorMgr;

static void error_exit(j_common_ptr cinfo)
{
    ErrorMgr *e = (ErrorMgr *)cinfo->err;
    e->pub.format_message(cinfo, e->text);
    longjmp(e->jump, 1);
}

/* Level -1 is a warning (corrupt data that libjpeg recovers from); higher levels are trace
 * messages, which are dropped. */
static void emit_message(j_common_ptr cinfo, int level)
{
    if (level < 0) error_exit(cinfo);
}

static void output_message(j_common_ptr cinfo)
{
    (void)cinfo;
}

int wg__jpeg_scaled_side(int side, int scale)
{
    return (int)(((long)side * scale + 7) / 8);
}

/* The largest DCT scale (1..8) at which a w x h file decodes to the sink's size, or 0. */
static int scale_for(int w, int h, const WgPngSink *sink)
{
    for (int s = 8; s >= 1; s--)
        if (wg__jpeg_scaled_side(w, s) == sink->width && wg__jpeg_scaled_side(h, s) == sink->height)
            return s;
    return 0;
}

int wg__jpeg_read(const char *path, const WgPngSink *sink, int *channels, char *msg, size_t size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 1;
    int w, h, c, frame, scale;
    if (wg__jpeg_probe_file(f, &w, &h, &c, &frame) || !(scale = scale_for(w, h, sink)) ||
        fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return 1;
    }
    struct jpeg_decompress_struct cinfo;
    ErrorMgr jerr;
    /* volatile: changed between setjmp and a longjmp back to it */
    unsigned char *volatile strip = NULL;
    volatile int rc = -1;
    cinfo.err = jpeg_std_error(&jerr.pub);
    jerr.pub.error_exit = error_exit;
    jerr.pub.emit_message = emit_message;
    jerr.pub.output_message = output_message;
    jerr.text[0] = 0;
    if (setjmp(jerr.jump)) {
        snprintf(msg, size, "the data is damaged or incomplete (%s)", jerr.text);
        goto out;
    }
    jpeg_create_decompress(&cinfo);
    jpeg_stdio_src(&cinfo, f);
    jpeg_read_header(&cinfo, TRUE);
    /* the header libjpeg reads is the one jpeg_header.c walked; a file rewritten in between
     * is refused rather than written out of bounds */
    cinfo.out_color_space = c == 1 ? JCS_GRAYSCALE : JCS_RGB;
    cinfo.dct_method = JDCT_ISLOW;
    cinfo.do_fancy_upsampling = TRUE;
    cinfo.scale_num = (unsigned)scale;
    cinfo.scale_denom = 8;
    jpeg_calc_output_dimensions(&cinfo);
    if ((int)cinfo.output_width != sink->width || (int)cinfo.output_height != sink->height ||
        cinfo.output_components != c) {
        snprintf(msg, size,
                 "the file changed while it was being read (decodes to %ux%u, %d channels)",
                 cinfo.output_width, cinfo.output_height, cinfo.output_components);
        goto out;
    }
    *channels = c;
    jpeg_start_decompress(&cinfo);
    int rows = cinfo.rec_outbuf_height > 0 ? cinfo.rec_outbuf_height : 1;
    size_t row = (size_t)sink->width * (size_t)c;
    strip = wg_malloc(row * (size_t)rows);
    if (!strip) {
        snprintf(msg, size, "out of memory");
        goto out;
    }
    JSAMPROW ptr[16];
    for (int i = 0; i < rows && i < 16; i++) ptr[i] = strip + row * (size_t)i;
    while (cinfo.output_scanline < cinfo.output_height) {
        int y = (int)cinfo.output_scanline;
        int got = (int)jpeg_read_scanlines(&cinfo, ptr, (JDIMENSION)(rows < 16 ? rows : 16));
        for (int i = 0; i < got; i++) sink->row(sink->user, y + i, ptr[i], 8);
    }
    jpeg_finish_decompress(&cinfo);
    rc = 0;
out:
    jpeg_destroy_decompress(&cinfo);
    wg_free(strip);
    fclose(f);
    return rc;
}
