/* SPDX-License-Identifier: MIT */
/* libFuzzer target for the LIST files of `render --batch` (cli/batch_list.c). The first byte of
 * an input chooses the format (even: CSV, odd: JSON lines), the rest is the file's text; it is
 * parsed from memory under a made-up path (nothing is opened). A failure must be clean: a
 * negative status equal to err.code, with a message, the LIST's name and a line no greater than
 * the file has. A success must hold what the batch runner relies on: rows in the order of their
 * lines, each field with a name, a value and a position, no name twice in a row; and
 * batch_list_check_outs (rows without `out` writing to "out" or, when the first byte has bit 1
 * set, the current folder) must refuse rows sharing a folder cleanly. Anything else, and any
 * sanitizer report, is a crash for libFuzzer. Run it through scripts/fuzz.sh. */
#include "batch_list.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void fail(const char *what, const WgError *err)
{
    fprintf(stderr, "fuzz_batch_list: %s (code %d, %s:%d:%d: '%s')\n", what, err->code, err->file,
            err->line, err->column, err->message);
    abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0) return 0;
    const char *path = data[0] & 1 ? "/fuzz/list/rows.jsonl" : "/fuzz/list/rows.csv";
    size_t n = size - 1;
    char *text = malloc(n + 1);
    if (!text) return 0;
    memcpy(text, data + 1, n);
    text[n] = '\0';
    int lines = 1;
    for (size_t i = 0; i < n; i++) lines += text[i] == '\n';
    BatchList l;
    WgError err = {0};
    int rc = batch_list_parse(path, text, n, &l, &err);
    free(text);
    if (rc) {
        if (rc > 0 || err.code != rc || !err.message[0]) fail("an unclean failure", &err);
        if (rc != WG_ERR_NOMEM && strcmp(err.file, path)) fail("an error without the file", &err);
        if (err.line < 0 || err.line > lines || err.column < 0)
            fail("an error out of the file", &err);
        if (strchr(err.message, '\n')) fail("an error of several lines", &err);
        if (l.rows || l.n_rows || l.columns || l.n_columns) fail("rows left after a failure", &err);
        return 0;
    }
    WgError out_err = {0};
    rc = batch_list_check_outs(path, &l, data[0] & 2 ? NULL : "out", &out_err);
    if (rc && (rc != out_err.code || strcmp(out_err.file, path) || out_err.line < 1 ||
               out_err.line > lines || strchr(out_err.message, '\n')))
        fail("an unclean refusal of shared output folders", &out_err);
    for (int i = 0; i < l.n_rows; i++) {
        const BatchRow *r = &l.rows[i];
        for (int k = 0; !rc && k < i; k++)
            if (r->out && l.rows[k].out && !strcmp(r->out, l.rows[k].out))
                fail("two rows with one output folder passed", &out_err);
        if (r->line < 1 || r->line > lines || (i && r->line <= l.rows[i - 1].line))
            fail("a row out of order", &err);
        if (r->out && !r->out[0]) fail("an empty output folder", &err);
        if (r->out && r->out[0] != '/') fail("a relative output folder not resolved", &err);
        for (int k = 0; k < r->n_fields; k++) {
            const BatchField *f = &r->fields[k];
            if (!f->name || !f->value || f->line < r->line || f->line > lines || f->column < 1 ||
                f->name_line < 1 || f->name_column < 1)
                fail("a field without a name, value or position", &err);
            if (f->kind != BATCH_INPUT && f->kind != BATCH_SET && f->kind != BATCH_NOTE)
                fail("a field of no kind", &err);
            if (f->kind == BATCH_NOTE && f->name[0] != '#') fail("a note not named #...", &err);
            for (int j = 0; j < k; j++)
                if (r->fields[j].kind == f->kind && !strcmp(r->fields[j].name, f->name))
                    fail("a name twice in one row", &err);
        }
    }
    for (int c = 0; c < l.n_columns; c++) {
        const BatchField *f = &l.columns[c];
        if (f->value || (f->kind == BATCH_OUT) != !f->name || f->name_line < 1 ||
            f->name_line > lines || f->name_column < 1)
            fail("a header column without its name or place", &err);
    }
    batch_list_free(&l);
    return 0;
}
