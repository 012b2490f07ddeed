/* SPDX-License-Identifier: MIT */
/* `wetgraph render FILE --batch LIST`: one engine renders the graph once per row of LIST (its
 * input images, parameter values and output folder; cli/batch_list.c reads it), so its memory
 * cache hands every row the results of the nodes whose inputs and parameters are equal to an
 * earlier row's and only what differs is recomputed. The whole LIST is read and its names
 * checked against the graph before anything is rendered (a mistake there is a usage error);
 * then a row that fails is reported with its LIST line and the others go on, and the exit
 * status is 1 if any failed. Each row's files are written all or none, as a single render's.
 * --shard I/N keeps the I-th of N blocks of consecutive rows, so that several processes or
 * machines share one LIST (with --shard-by COLUMN, whole groups of rows with one value in
 * COLUMN); --batch-json prints one JSON line per row on stdout. */
#include "batch_list.h"
#include "render.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

/* Every name in the LIST is a parameter or an image input of the graph. */
static int check_names(const char *list, const BatchList *l, const WgGraph *g, WgError *err)
{
    int np = wg_graph_param_count(g), ni = wg_graph_input_count(g);
    const char **params = calloc((size_t)np + 1, sizeof *params);
    const char **inputs = calloc((size_t)ni + 1, sizeof *inputs);
    int rc = WG_OK;
    if (!params || !inputs) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; !rc && i < np; i++) params[i] = wg_graph_param_info(g, i)->name;
    for (int i = 0; !rc && i < ni; i++) inputs[i] = wg_graph_input_info(g, i)->name;
    /* the header's columns first (a list may have no row filling one), then the rows' names */
    for (int r = -1; !rc && r < l->n_rows; r++) {
        const BatchField *fields = r < 0 ? l->columns : l->rows[r].fields;
        int n_fields = r < 0 ? l->n_columns : l->rows[r].n_fields;
        for (int k = 0; !rc && k < n_fields; k++) {
            const BatchField *f = &fields[k];
            if (f->kind != BATCH_INPUT && f->kind != BATCH_SET) continue;
            bool input = f->kind == BATCH_INPUT;
            const char *const *names = input ? inputs : params;
            int n = input ? ni : np, found = 0;
            for (int i = 0; i < n && !found; i++) found = !strcmp(names[i], f->name);
            if (found) continue;
            const char *near = wg_suggest(f->name, names, n);
            char hint[300] = "", shown[300];
            if (near) snprintf(hint, sizeof hint, "; did you mean '%s'?", near);
            rc = wg_error_set_at(err, WG_ERR_USAGE, list, f->name_line, f->name_column,
                                 "the graph %s has no %s '%s'%s", wg_graph_name(g),
                                 input ? "image input" : "parameter",
                                 batch_shown(f->name, shown, sizeof shown), hint);
        }
    }
    free(params);
    free(inputs);
    return rc;
}

/* The value a row has in COLUMN ("input:NAME", "set:NAME", "out" or "#NAME"; "" when it has
 * none), or NULL when COLUMN is no column name. */
static const char *column_value(const BatchRow *row, const char *column)
{
    if (!strcmp(column, "out")) return row->out ? row->out : "";
    int kind = !strncmp(column, "input:", 6) ? BATCH_INPUT
               : !strncmp(column, "set:", 4) ? BATCH_SET
               : column[0] == '#'            ? BATCH_NOTE
                                             : -1;
    if (kind < 0) return NULL;
    const char *name = kind == BATCH_INPUT ? column + 6 : kind == BATCH_SET ? column + 4 : column;
    for (int k = 0; k < row->n_fields; k++)
        if (row->fields[k].kind == kind && !strcmp(row->fields[k].name, name))
            return row->fields[k].value;
    return "";
}

/* Which rows are this shard's: the I-th of N blocks of consecutive rows, rows
 * [⌊I·n/N⌋, ⌊(I+1)·n/N⌋); with --shard-by, the groups of rows with one value in the column, in
 * the order of their first row, laid end to end, each going whole to the block its middle row
 * falls in. Every shard works this out alike from the whole LIST. */
static int shard_rows(const Options *o, const BatchList *l, bool *mine, WgError *err)
{
    int n = l->n_rows, N = o->has_shard ? o->shard_count : 1, I = o->has_shard ? o->shard_index : 0;
    if (!o->shard_by) {
        long long lo = (long long)I * n / N, hi = (long long)(I + 1) * n / N;
        for (int r = 0; r < n; r++) mine[r] = r >= lo && r < hi;
        return WG_OK;
    }
    if (!column_value(&(BatchRow){0}, o->shard_by))
        return wg_error_set(err, WG_ERR_USAGE, NULL,
                            "bad --shard-by '%s' (a column: input:NAME, set:NAME, out or #NAME)",
                            o->shard_by);
    bool declared = l->n_columns == 0; /* JSON lines declare no columns */
    for (int c = 0; c < l->n_columns && !declared; c++) {
        const BatchField *f = &l->columns[c];
        char name[4200];
        snprintf(name, sizeof name, "%s%s",
                 f->kind == BATCH_INPUT ? "input:"
                 : f->kind == BATCH_SET ? "set:"
                                        : "",
                 f->kind == BATCH_OUT ? "out" : f->name);
        declared = !strcmp(name, o->shard_by);
    }
    if (!declared)
        return wg_error_set_at(err, WG_ERR_USAGE, o->batch, 1, 0,
                               "--shard-by '%s': the list has no such column", o->shard_by);
    int *group = malloc(sizeof *group * (size_t)(n + 1)),
        *size = calloc((size_t)n + 1, sizeof *size);
    if (!group || !size) {
        free(group), free(size);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    int groups = 0;
    for (int r = 0; r < n; r++) { /* quadratic in the worst case; lists are thousands of rows */
        const char *v = column_value(&l->rows[r], o->shard_by);
        group[r] = -1;
        for (int q = 0; q < r && group[r] < 0; q++)
            if (!strcmp(column_value(&l->rows[q], o->shard_by), v)) group[r] = group[q];
        if (group[r] < 0) group[r] = groups++;
        size[group[r]]++;
    }
    long long before = 0; /* rows in the groups before this one */
    int *shard = size;    /* each group's shard, in place of its size */
    for (int gi = 0; gi < groups; gi++) {
        int rows = size[gi];
        long long middle = 2 * before + rows; /* twice the middle row's position */
        int k = 0;
        while (k + 1 < N && 2 * ((long long)(k + 1) * n / N) <= middle) k++;
        shard[gi] = k;
        before += rows;
    }
    for (int r = 0; r < n; r++) mine[r] = shard[group[r]] == I;
    free(group), free(size);
    return WG_OK;
}

/* The request of one row: the command line's values, then the row's. */
static int row_request(const Options *o, const WgGraph *g, const char *list, const BatchRow *row,
                       WgRequest **r, WgError *err)
{
    if (build_request(o, g, r, err)) return err->code;
    for (int k = 0; k < row->n_fields; k++) {
        const BatchField *f = &row->fields[k];
        int rc;
        if (f->kind == BATCH_NOTE) continue;
        if (f->kind == BATCH_SET) {
            rc = wg_request_set(*r, f->name, f->value, err);
        } else {
            struct stat st;
            char shown[600];
            if (stat(f->value, &st) != 0)
                return wg_error_set_at(err, WG_ERR_IO, list, f->line, f->column,
                                       "input '%s': cannot open %s: %s", f->name,
                                       batch_shown(f->value, shown, sizeof shown), strerror(errno));
            rc = wg_request_set_input_file(*r, f->name, f->value, err);
        }
        if (rc) {
            char msg[sizeof err->message + 300];
            snprintf(msg, sizeof msg, "%s '%s': %s", f->kind == BATCH_SET ? "set" : "input",
                     f->name, err->message);
            wg_error_clear(err);
            return wg_error_set_at(err, rc, list, f->line, f->column, "%s", msg);
        }
    }
    return wg_request_check(*r, err);
}

static void json_row(const Options *o, const WgGraph *g, int index, const BatchRow *row,
                     const WgResult *res, double ms, size_t cached, const char *error)
{
    printf("{\"row\": %d, \"line\": %d, \"status\": \"%s\", \"outputs\": [", index, row->line,
           error ? "failed" : "ok");
    for (int i = 0; !error && res && i < wg_result_output_count(res); i++) {
        char p[4096];
        output_path(o, g, res, i, -1, p, sizeof p);
        if (i) printf(", ");
        cli_json_string(stdout, p);
    }
    printf("], \"computed\": %d, \"ms\": %.3f, \"cached_bytes\": %zu, \"warnings\": [",
           res ? wg_result_evaluated_count(res) : 0, ms, cached);
    for (int i = 0; !error && res && i < wg_result_warning_count(res); i++) {
        if (i) printf(", ");
        cli_json_warning(stdout, wg_result_warning(res, i));
    }
    printf("], \"error\": ");
    if (error)
        cli_json_string(stdout, error);
    else
        printf("null");
    printf("}\n");
    fflush(stdout);
}

int render_batch(const Options *o, const WgGraph *g)
{
    BatchList list;
    WgError err = {0};
    WgEngine *e = NULL;
    if (batch_list_load(o->batch, &list, &err) || check_names(o->batch, &list, g, &err) ||
        batch_list_check_outs(o->batch, &list, o->out_dir, &err)) {
        cli_report(&err);
        batch_list_free(&list);
        return cli_exit_for(err.code);
    }
    /* results stay in memory between rows: that is what makes the batch cheaper than one
     * process per row */
    WgEngineOptions eo = {o->threads, o->budget, o->cache, false, o->no_fuse};
    if (wg_engine_new(&eo, &e, &err)) {
        cli_report(&err);
        batch_list_free(&list);
        return EXIT_FAILED;
    }
    bool *in_shard = calloc((size_t)list.n_rows + 1, sizeof *in_shard);
    if (!in_shard || shard_rows(o, &list, in_shard, &err)) {
        if (!in_shard) wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        cli_report(&err);
        free(in_shard);
        wg_engine_free(e);
        batch_list_free(&list);
        return cli_exit_for(err.code);
    }
    int mine = 0, done = 0, failed = 0;
    for (int i = 0; i < list.n_rows; i++) mine += in_shard[i];
    bool progress = !o->quiet && isatty(2);
    double start = now_ms();
    for (int i = 0; i < list.n_rows; i++) {
        if (!in_shard[i]) continue;
        const BatchRow *row = &list.rows[i];
        Options ro = *o;
        ro.quiet = o->quiet || o->batch_json; /* stdout holds only the JSON lines */
        if (row->out) ro.out_dir = row->out;
        /* the row as --name's placeholders see it: its number and its columns' values */
        char cols[64][300];
        const char *col_names[64], *col_values[64];
        int n_cols = 0;
        for (int k = 0; k < row->n_fields && n_cols < 63; k++) {
            const BatchField *f = &row->fields[k];
            snprintf(cols[n_cols], sizeof cols[n_cols], "%s%s",
                     f->kind == BATCH_INPUT ? "input:"
                     : f->kind == BATCH_SET ? "set:"
                                            : "",
                     f->name);
            col_names[n_cols] = cols[n_cols];
            col_values[n_cols++] = f->value;
        }
        if (row->out) col_names[n_cols] = "out", col_values[n_cols++] = row->out;
        BatchRowInfo info = {i, n_cols, col_names, col_values};
        ro.row = &info;
        WgRequest *r = NULL;
        WgResult *res = NULL;
        double t0 = now_ms();
        wg_error_clear(&err);
        int rc = row_request(&ro, g, o->batch, row, &r, &err);
        if (!rc) rc = output_files_check(&ro, g, r, -1, &err);
        /* each output written while the rest of the row renders, as a single render does; a
         * layered EXR wants them all */
        Stream *stream = NULL;
        if (!rc && !ro.layered && !(rc = stream_new(&ro, g, -1, false, &stream, &err))) {
            wg_request_set_output_fn(r, stream_output, stream);
            if (ro.cache) wg_request_set_output_held(r, stream_held, stream);
        }
        if (!rc) rc = wg_render(e, r, &res, &err);
        if (progress) fprintf(stderr, "\r%*s\r", 60, ""); /* the paths go to the same terminal */
        if (!rc && !o->quiet) {
            /* the row first, as for errors: the same warning may apply to some rows only */
            char row_at[4096 + 64];
            snprintf(row_at, sizeof row_at, "%s:%d: row %d: ", o->batch, row->line, i);
            for (int k = 0; k < wg_result_warning_count(res); k++)
                cli_warning(wg_result_warning(res, k), row_at);
        }
        if (stream)
            rc = stream_finish(stream, res, rc, &err);
        else if (!rc)
            rc = write_outputs(&ro, g, res, -1, &err);
        double ms = now_ms() - t0;
        char text[sizeof err.message + 4096] = "";
        if (rc) {
            /* the LIST's line (and column) first, then what went wrong where */
            failed++;
            if (!strcmp(err.file, o->batch)) {
                snprintf(text, sizeof text, "%s:%d:%d: row %d: %s", o->batch, err.line, err.column,
                         i, err.message);
            } else {
                char where[4096];
                wg_error_format(&err, where, sizeof where);
                snprintf(text, sizeof text, "%s:%d: row %d: %s", o->batch, row->line, i, where);
            }
            if (progress) fprintf(stderr, "\r%*s\r", 60, "");
            fprintf(stderr, "wetgraph: error: %s\n", text);
        }
        /* what rows share (a material's maps) is read by every row of it and stays; earlier
         * rows' own results go. Kept up to the budget instead, the cache would grow with every
         * row and each row would take new memory, which on some machines costs more than
         * computing what it holds. */
        if (res) cli_trim_after(e, res);
        WgMemoryStats mem;
        wg_engine_memory_stats(e, &mem);
        if (o->batch_json) json_row(&ro, g, i, row, res, ms, mem.cache_bytes, rc ? text : NULL);
        done++;
        if (progress) {
            fprintf(stderr, "\r[%d/%d] rows, %d failed", done, mine, failed);
            fflush(stderr);
        }
        wg_result_free(res);
        wg_request_free(r);
    }
    if (progress) fprintf(stderr, "\r%*s\r", 60, "");
    if (!o->quiet) {
        fprintf(stderr, "batch: %d row%s", done, done == 1 ? "" : "s");
        if (o->has_shard)
            fprintf(stderr, " (shard %d/%d of %d rows)", o->shard_index, o->shard_count,
                    list.n_rows);
        fprintf(stderr, ", %d rendered, %d failed, %.1f s\n", done - failed, failed,
                (now_ms() - start) / 1e3);
    }
    free(in_shard);
    wg_engine_free(e);
    batch_list_free(&list);
    return failed ? EXIT_FAILED : EXIT_OK;
}
