/* SPDX-License-Identifier: MIT */
/* The LIST file of `wetgraph render --batch`: rows of input images, parameter values and an
 * output folder, read from CSV (header `input:NAME`, `set:NAME`, `out`) or JSON lines
 * ({"inputs": {...}, "set": {...}, "out": "..."}), chosen by the extension (cli/batch_list.c).
 * A CSV column whose name starts with '#' (an id, a comment) is carried along and ignored. */
#ifndef WETGRAPH_CLI_BATCH_LIST_H
#define WETGRAPH_CLI_BATCH_LIST_H

#include "cli.h"

/* a value for a graph input, a parameter; a column the renders ignore (#NAME, kept for
 * --shard-by); the output folder (only in BatchList.columns: a row's is BatchRow.out) */
enum { BATCH_INPUT, BATCH_SET, BATCH_NOTE, BATCH_OUT };

typedef struct {
    int kind; /* BATCH_INPUT, BATCH_SET or BATCH_NOTE */
    char *name, *value;
    int line, column;           /* where the value starts in the LIST */
    int name_line, name_column; /* where the name is: the CSV header's cell or the JSON key */
} BatchField;

typedef struct {
    int line; /* where the row starts in the LIST (1-based) */
    BatchField *fields;
    int n_fields;
    char *out; /* NULL when the row names no folder */
} BatchRow;

typedef struct {
    BatchRow *rows;
    int n_rows;
    BatchField *columns; /* the CSV header's columns (value NULL; name "#..." for a note,
                            NULL for out), so that a column is checked against the graph even
                            when no row fills it */
    int n_columns;
} BatchList;

/* Read a LIST. Input paths and `out` that are relative are resolved against the LIST's folder;
 * an empty CSV cell leaves that input or parameter as the command line or graph has it. A
 * malformed file is a WG_ERR_PARSE with the LIST's name, line and column. */
int batch_list_load(const char *path, BatchList *out, WgError *err);
/* The same from text already read: `text` holds `size` bytes and a NUL after them, and is
 * changed while it is read; `path` chooses the format (.csv, or else JSON lines), names the
 * file in errors and anchors relative paths. */
int batch_list_parse(const char *path, char *text, size_t size, BatchList *out, WgError *err);
/* Two rows writing to one folder would overwrite each other's files: a WG_ERR_USAGE naming both
 * rows and their lines. A row without `out` writes to `default_out` (NULL: the current folder);
 * folders are compared as absolute paths without ".", ".." and repeated or trailing slashes. */
int batch_list_check_outs(const char *path, const BatchList *l, const char *default_out,
                          WgError *err);
void batch_list_free(BatchList *l);
/* `s` for an error message of one line: control characters escaped (\n, \x1b, ...), cut
 * with "..." to fit `size`. Returns buf. */
const char *batch_shown(const char *s, char *buf, size_t size);

#endif
