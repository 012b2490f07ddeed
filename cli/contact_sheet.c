/* SPDX-License-Identifier: MIT */
/* The contact sheet of a frame sequence: each frame shrunk by box averaging into one cell of a
 * grid (frames in reading order, left to right then top to bottom), so an animation can be
 * looked at without a video player. Only the small copies are kept while the frames render. */
#include "contact_sheet.h"

#include <math.h>
#include <stdlib.h>

enum { GAP = 4, MAX_CELL = 256, MAX_SHEET = 8192 };

struct ContactSheet {
    int frames, columns, rows;
    int cell_w, cell_h, channels;
    WgImage *sheet;
};

ContactSheet *contact_sheet_new(int frames, int width, int height, int channels)
{
    ContactSheet *cs = calloc(1, sizeof *cs);
    if (!cs) return NULL;
    cs->frames = frames;
    cs->columns = (int)ceil(sqrt((double)frames));
    cs->rows = (frames + cs->columns - 1) / cs->columns;
    int cw = width < MAX_CELL ? width : MAX_CELL;
    int fit = (MAX_SHEET - GAP) / cs->columns - GAP; /* the sheet stays within MAX_SHEET wide */
    if (cw > fit) cw = fit > 1 ? fit : 1;
    cs->cell_w = cw;
    cs->cell_h = (int)fmax(1.0, round((double)height * cw / width));
    if (cs->cell_h > MAX_CELL * 4) cs->cell_h = MAX_CELL * 4; /* very tall frames */
    cs->channels = channels;
    int sw = GAP + cs->columns * (cs->cell_w + GAP), sh = GAP + cs->rows * (cs->cell_h + GAP);
    cs->sheet = wg_image_new(sw, sh, channels);
    if (!cs->sheet) {
        free(cs);
        return NULL;
    }
    for (int y = 0; y < sh; y++) { /* a dark grey background shows the cells apart */
        float *row = wg_image_row(cs->sheet, y);
        for (int x = 0; x < sw; x++)
            for (int c = 0; c < channels; c++) row[x * channels + c] = c == 3 ? 1.0f : 0.05f;
    }
    return cs;
}

/* Cell i gets frame f (of the sheet's channel count) averaged over boxes of about
 * (w / cell_w) × (h / cell_h) pixels. */
void contact_sheet_add(ContactSheet *cs, int i, const WgImage *f)
{
    if (!cs || i < 0 || i >= cs->frames || f->channels != cs->channels) return;
    int x0 = GAP + (i % cs->columns) * (cs->cell_w + GAP);
    int y0 = GAP + (i / cs->columns) * (cs->cell_h + GAP);
    int w = f->width, h = f->height, c = f->channels;
    for (int ty = 0; ty < cs->cell_h; ty++) {
        int sy0 = (int)((long long)ty * h / cs->cell_h);
        int sy1 = (int)((long long)(ty + 1) * h / cs->cell_h);
        if (sy1 <= sy0) sy1 = sy0 + 1;
        float *out = wg_image_row(cs->sheet, y0 + ty) + (size_t)x0 * c;
        for (int tx = 0; tx < cs->cell_w; tx++) {
            int sx0 = (int)((long long)tx * w / cs->cell_w);
            int sx1 = (int)((long long)(tx + 1) * w / cs->cell_w);
            if (sx1 <= sx0) sx1 = sx0 + 1;
            double acc[4] = {0};
            for (int y = sy0; y < sy1; y++) {
                const float *r = wg_image_row(f, y);
                for (int x = sx0; x < sx1; x++)
                    for (int k = 0; k < c; k++) acc[k] += r[(size_t)x * c + k];
            }
            double n = (double)(sy1 - sy0) * (sx1 - sx0);
            for (int k = 0; k < c; k++) out[(size_t)tx * c + k] = (float)(acc[k] / n);
        }
    }
}

const WgImage *contact_sheet_image(const ContactSheet *cs)
{
    return cs ? cs->sheet : NULL;
}

void contact_sheet_free(ContactSheet *cs)
{
    if (!cs) return;
    wg_image_unref(cs->sheet);
    free(cs);
}
