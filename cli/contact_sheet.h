/* SPDX-License-Identifier: MIT */
/* A grid of shrunk frames (cli/contact_sheet.c). */
#ifndef WETGRAPH_CLI_CONTACT_SHEET_H
#define WETGRAPH_CLI_CONTACT_SHEET_H

#include <wetgraph/wetgraph.h>

typedef struct ContactSheet ContactSheet;

/* A sheet for `frames` frames of width × height with `channels` (1 or 4); NULL when out of
 * memory. */
ContactSheet *contact_sheet_new(int frames, int width, int height, int channels);
/* Shrink frame image f into cell i (0-based, reading order). */
void contact_sheet_add(ContactSheet *cs, int i, const WgImage *f);
const WgImage *contact_sheet_image(const ContactSheet *cs);
void contact_sheet_free(ContactSheet *cs);

#endif
