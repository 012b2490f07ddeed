/* SPDX-License-Identifier: MIT */
/* Reader of `render --batch` LIST files. CSV follows RFC 4180: fields separated by commas,
 * records by LF or CRLF, a field in double quotes may hold commas, line breaks and doubled
 * quotes (""), a quote anywhere else is an error; spaces around unquoted fields are dropped,
 * empty lines skipped, a UTF-8 byte order mark at the start ignored. The header names the
 * columns: `input:NAME`, `set:NAME`, `out`. JSON lines hold one object per line with the keys
 * "inputs" (object of strings), "set" (object of strings, numbers or booleans; a number keeps
 * its text as written) and "out" (a string). The JSON parser is a small hand-written one limited
 * to this flat schema: it needs no library, and it can name the line and column of every
 * mistake. Errors name the LIST file, the line and the column where the mistake is, and show
 * the LIST's control characters escaped, so each is one line. batch_list_check_outs refuses
 * rows that would write into one folder, compared as normalised absolute paths. */
#include "batch_list.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

typedef struct {
    const char *path;
    char *folder; /* with a trailing slash, "" for the current folder */
    WgError *err;
} Reader;

static char *dup_n(const char *s, size_t n)
{
    char *p = malloc(n + 1);
    if (p) {
        memcpy(p, s, n);
        p[n] = '\0';
    }
    return p;
}

const char *batch_shown(const char *s, char *buf, size_t size)
{
    size_t n = 0;
    for (; *s && n + 8 < size; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '\n')
            n += (size_t)snprintf(buf + n, size - n, "\\n");
        else if (c == '\r')
            n += (size_t)snprintf(buf + n, size - n, "\\r");
        else if (c == '\t')
            n += (size_t)snprintf(buf + n, size - n, "\\t");
        else if (c < 0x20 || c == 0x7f)
            n += (size_t)snprintf(buf + n, size - n, "\\x%02x", c);
        else
            buf[n++] = (char)c;
    }
    if (*s) n += (size_t)snprintf(buf + n, size - n, "...");
    buf[n] = '\0';
    return buf;
}

static int nomem(Reader *rd)
{
    return wg_error_set(rd->err, WG_ERR_NOMEM, NULL, "out of memory");
}

/* A path from the LIST: relative ones are relative to the LIST's folder. */
static char *resolve(const Reader *rd, const char *p)
{
    if (p[0] == '/' || !rd->folder[0]) return strdup(p);
    size_t n = strlen(rd->folder) + strlen(p) + 1;
    char *s = malloc(n);
    if (s) snprintf(s, n, "%s%s", rd->folder, p);
    return s;
}

static int add_row(BatchList *l, int line)
{
    BatchRow *rows = realloc(l->rows, sizeof *rows * (size_t)(l->n_rows + 1));
    if (!rows) return WG_ERR_NOMEM;
    l->rows = rows;
    l->rows[l->n_rows++] = (BatchRow){line, NULL, 0, NULL};
    return WG_OK;
}

/* Add a field to the last row, taking ownership of name and value (freed on failure). */
static int add_field(Reader *rd, BatchList *l, int kind, char *name, char *value, int line,
                     int column, int name_line, int name_column)
{
    BatchRow *r = &l->rows[l->n_rows - 1];
    if (kind == BATCH_INPUT && value) {
        char *full = resolve(rd, value);
        free(value);
        value = full;
    }
    BatchField *f = realloc(r->fields, sizeof *f * (size_t)(r->n_fields + 1));
    if (!f || !name || !value) {
        if (f) r->fields = f;
        free(name);
        free(value);
        return nomem(rd);
    }
    r->fields = f;
    r->fields[r->n_fields++] =
        (BatchField){kind, name, value, line, column, name_line, name_column};
    return WG_OK;
}

/* ---- CSV ---- */

typedef struct {
    char *text;
    int line, column;
} Cell;

typedef struct {
    Cell *cells;
    int n, cap;
    int line;
} Record;

static void record_clear(Record *r)
{
    for (int i = 0; i < r->n; i++) free(r->cells[i].text);
    r->n = 0;
}

/* Read the record starting at *p (line *line). Returns 1 when one was read, 0 at the end of
 * the text, or an error. */
static int csv_record(Reader *rd, const char **p, const char *end, int *line, Record *rec)
{
    record_clear(rec);
    if (*p >= end) return 0;
    rec->line = *line;
    const char *s = *p, *line_start = s;
    for (;;) {
        if (rec->n == rec->cap) {
            int cap = rec->cap ? 2 * rec->cap : 8;
            Cell *c = realloc(rec->cells, sizeof *c * (size_t)cap);
            if (!c) return nomem(rd);
            rec->cells = c;
            rec->cap = cap;
        }
        Cell *cell = &rec->cells[rec->n];
        cell->line = *line;
        cell->column = (int)(s - line_start) + 1;
        cell->text = NULL;
        size_t cap = 64, n = 0;
        char *buf = malloc(cap);
        if (!buf) return nomem(rd);
        while (s < end && (*s == ' ' || *s == '\t')) s++;
        if (s < end && *s == '"') {
            int qline = *line, qcol = (int)(s - line_start) + 1;
            s++;
            for (;;) {
                if (s >= end) {
                    free(buf);
                    return wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, qline, qcol,
                                           "the quoted field is not closed (a \" is missing)");
                }
                char c = *s++;
                if (c == '"') {
                    if (s < end && *s == '"')
                        s++;
                    else
                        break;
                } else if (c == '\n') {
                    ++*line;
                    line_start = s;
                }
                if (c == '\0') {
                    free(buf);
                    return wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, *line,
                                           (int)(s - line_start), "a NUL byte in the file");
                }
                if (n + 1 >= cap) {
                    char *b = realloc(buf, cap *= 2);
                    if (!b) {
                        free(buf);
                        return nomem(rd);
                    }
                    buf = b;
                }
                buf[n++] = c;
            }
            while (s < end && (*s == ' ' || *s == '\t')) s++;
            if (s < end && *s != ',' && *s != '\n' &&
                !(*s == '\r' && (s + 1 == end || s[1] == '\n'))) {
                free(buf);
                char c[2] = {*s, '\0'}, shown[16];
                return wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, *line,
                                       (int)(s - line_start) + 1,
                                       "unexpected '%s' after a quoted field (a comma or the end "
                                       "of the line must follow the closing \")",
                                       batch_shown(c, shown, sizeof shown));
            }
        } else {
            while (s < end && *s != ',' && *s != '\n' &&
                   !(*s == '\r' && (s + 1 == end || s[1] == '\n'))) {
                if (*s == '"' || *s == '\0') {
                    free(buf);
                    return wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, *line,
                                           (int)(s - line_start) + 1,
                                           *s ? "a \" inside an unquoted field (quote the whole "
                                                "field and double the \" inside it)"
                                              : "a NUL byte in the file");
                }
                if (n + 1 >= cap) {
                    char *b = realloc(buf, cap *= 2);
                    if (!b) {
                        free(buf);
                        return nomem(rd);
                    }
                    buf = b;
                }
                buf[n++] = *s++;
            }
            while (n > 0 && (buf[n - 1] == ' ' || buf[n - 1] == '\t')) n--;
        }
        buf[n] = '\0';
        cell->text = buf;
        rec->n++;
        if (s < end && *s == ',') {
            s++;
            continue;
        }
        if (s < end && *s == '\r') s++;
        if (s < end && *s == '\n') s++;
        ++*line;
        break;
    }
    *p = s;
    return 1;
}

static bool record_is_empty(const Record *r)
{
    return r->n == 1 && !r->cells[0].text[0];
}

enum { COLUMN_OUT = -1 };
typedef struct {
    int kind; /* BATCH_INPUT, BATCH_SET, BATCH_NOTE (named #...) or COLUMN_OUT */
    const char *name;
    int line, column; /* of the header's cell */
} Column;

static int read_csv(Reader *rd, const char *text, size_t size, BatchList *l)
{
    const char *p = text, *end = text + size;
    if (size >= 3 && !memcmp(p, "\xef\xbb\xbf", 3)) p += 3;
    int line = 1, rc;
    Record header = {0}, rec = {0};
    Column *cols = NULL;
    while ((rc = csv_record(rd, &p, end, &line, &header)) == 1 && record_is_empty(&header)) {
    }
    if (rc == 0)
        rc = wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, 1, 0,
                             "the file is empty: it needs a header row naming the "
                             "columns (input:NAME, set:NAME, out)");
    if (rc < 0) goto out;
    cols = calloc((size_t)header.n, sizeof *cols);
    if (!cols) {
        rc = nomem(rd);
        goto out;
    }
    /* a list saved with ';' between its fields reads as one column named by all of them */
    if (header.n == 1 && strchr(header.cells[0].text, ';')) {
        char shown[300];
        rc = wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, header.cells[0].line,
                             header.cells[0].column,
                             "the header '%s' is one column: its names are separated by ';', but "
                             "LIST is read as CSV, with ',' between fields",
                             batch_shown(header.cells[0].text, shown, sizeof shown));
        goto out;
    }
    bool has_out = false;
    for (int i = 0; i < header.n; i++) {
        const Cell *c = &header.cells[i];
        const char *t = c->text;
        if (!strncmp(t, "input:", 6) && t[6])
            cols[i] = (Column){BATCH_INPUT, t + 6, c->line, c->column};
        else if (!strncmp(t, "set:", 4) && t[4])
            cols[i] = (Column){BATCH_SET, t + 4, c->line, c->column};
        else if (!strcmp(t, "out") && !has_out)
            cols[i] = (Column){COLUMN_OUT, NULL, c->line, c->column}, has_out = true;
        else if (t[0] == '#')
            cols[i] = (Column){BATCH_NOTE, t, c->line, c->column};
        else {
            char shown[300];
            rc = wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, c->line, c->column,
                                 !strcmp(t, "out") ? "the column 'out' appears twice"
                                                   : "unknown column '%s' (the header names "
                                                     "columns input:NAME, set:NAME and out, and "
                                                     "#NAME for columns to ignore)",
                                 batch_shown(t, shown, sizeof shown));
            goto out;
        }
        for (int j = 0; j < i; j++)
            if (cols[j].kind == cols[i].kind && cols[i].name &&
                !strcmp(cols[j].name, cols[i].name)) {
                char shown[300];
                rc = wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, c->line, c->column,
                                     "the column '%s' appears twice",
                                     batch_shown(t, shown, sizeof shown));
                goto out;
            }
        {
            BatchField *f = realloc(l->columns, sizeof *f * (size_t)(l->n_columns + 1));
            char *name = cols[i].name ? strdup(cols[i].name) : NULL;
            if (!f || (cols[i].name && !name)) {
                if (f) l->columns = f;
                free(name);
                rc = nomem(rd);
                goto out;
            }
            l->columns = f;
            l->columns[l->n_columns++] =
                (BatchField){cols[i].kind == COLUMN_OUT ? BATCH_OUT : cols[i].kind,
                             name,
                             NULL,
                             c->line,
                             c->column,
                             c->line,
                             c->column};
        }
    }
    while ((rc = csv_record(rd, &p, end, &line, &rec)) == 1) {
        if (record_is_empty(&rec)) continue;
        if (rec.n != header.n) {
            rc = wg_error_set_at(rd->err, WG_ERR_PARSE, rd->path, rec.line, 0,
                                 "the row has %d field%s, the header has %d", rec.n,
                                 rec.n == 1 ? "" : "s", header.n);
            goto out;
        }
        if (add_row(l, rec.line)) {
            rc = nomem(rd);
            goto out;
        }
        for (int i = 0; i < rec.n; i++) {
            Cell *c = &rec.cells[i];
            if (!c->text[0]) continue; /* empty: as the command line or the graph has it */
            if (cols[i].kind == COLUMN_OUT) {
                BatchRow *r = &l->rows[l->n_rows - 1];
                if (!(r->out = resolve(rd, c->text))) {
                    rc = nomem(rd);
                    goto out;
                }
                continue;
            }
            rc = add_field(rd, l, cols[i].kind, strdup(cols[i].name), c->text, c->line, c->column,
                           cols[i].line, cols[i].column);
            c->text = NULL; /* the row took it */
            if (rc) goto out;
        }
    }
out:
    record_clear(&header);
    record_clear(&rec);
    free(header.cells);
    free(rec.cells);
    free(cols);
    return rc < 0 ? rc : WG_OK;
}

/* ---- JSON lines ---- */

typedef struct {
    Reader *rd;
    const char *s, *start; /* position, start of the line */
    int line;
} Json;

static int jerr(Json *j, const char *what)
{
    return wg_error_set_at(j->rd->err, WG_ERR_PARSE, j->rd->path, j->line,
                           (int)(j->s - j->start) + 1, "%s", what);
}

static void jws(Json *j)
{
    while (*j->s == ' ' || *j->s == '\t' || *j->s == '\r') j->s++;
}

static void put_utf8(char *buf, size_t *n, unsigned cp)
{
    if (cp < 0x80) {
        buf[(*n)++] = (char)cp;
    } else if (cp < 0x800) {
        buf[(*n)++] = (char)(0xc0 | cp >> 6);
        buf[(*n)++] = (char)(0x80 | (cp & 0x3f));
    } else if (cp < 0x10000) {
        buf[(*n)++] = (char)(0xe0 | cp >> 12);
        buf[(*n)++] = (char)(0x80 | (cp >> 6 & 0x3f));
        buf[(*n)++] = (char)(0x80 | (cp & 0x3f));
    } else {
        buf[(*n)++] = (char)(0xf0 | cp >> 18);
        buf[(*n)++] = (char)(0x80 | (cp >> 12 & 0x3f));
        buf[(*n)++] = (char)(0x80 | (cp >> 6 & 0x3f));
        buf[(*n)++] = (char)(0x80 | (cp & 0x3f));
    }
}

static bool hex4(const char *s, unsigned *out)
{
    unsigned v = 0;
    for (int i = 0; i < 4; i++) {
        char c = s[i];
        v <<= 4;
        if (c >= '0' && c <= '9')
            v |= (unsigned)(c - '0');
        else if (c >= 'a' && c <= 'f')
            v |= (unsigned)(c - 'a' + 10);
        else if (c >= 'A' && c <= 'F')
            v |= (unsigned)(c - 'A' + 10);
        else
            return false;
    }
    *out = v;
    return true;
}

/* A JSON string at j->s; the caller owns *out. */
static int jstring(Json *j, char **out)
{
    if (*j->s != '"') return jerr(j, "a string in double quotes was expected here");
    j->s++;
    size_t n = 0;
    char *buf = malloc(strlen(j->s) + 1); /* escapes never make the text longer */
    if (!buf) return nomem(j->rd);
    for (;;) {
        unsigned char c = (unsigned char)*j->s;
        if (c == '"') break;
        if (c == '\0' || c == '\n') {
            free(buf);
            return jerr(j, "the string is not closed (a \" is missing)");
        }
        if (c < 0x20) {
            free(buf);
            return jerr(j, "a control character inside a string (write it as \\n, \\t, ...)");
        }
        if (c != '\\') {
            buf[n++] = (char)c;
            j->s++;
            continue;
        }
        char e = j->s[1];
        const char *simple = strchr("\"\\/bfnrt", e);
        if (e && simple) {
            buf[n++] = "\"\\/\b\f\n\r\t"[simple - "\"\\/bfnrt"];
            j->s += 2;
            continue;
        }
        unsigned cp, lo;
        if (e != 'u' || !hex4(j->s + 2, &cp)) {
            free(buf);
            return jerr(j, "a bad escape in a string (\\\" \\\\ \\/ \\b \\f \\n \\r \\t or "
                           "\\uXXXX)");
        }
        j->s += 6;
        if (cp >= 0xd800 && cp < 0xdc00 && j->s[0] == '\\' && j->s[1] == 'u' &&
            hex4(j->s + 2, &lo) && lo >= 0xdc00 && lo < 0xe000) {
            cp = 0x10000 + ((cp - 0xd800) << 10) + (lo - 0xdc00);
            j->s += 6;
        } else if (cp >= 0xd800 && cp < 0xe000) {
            free(buf);
            return jerr(j, "a lone UTF-16 surrogate in a \\u escape");
        }
        if (cp == 0) {
            free(buf);
            return jerr(j, "\\u0000 is not allowed in a string");
        }
        put_utf8(buf, &n, cp);
    }
    j->s++;
    buf[n] = '\0';
    *out = buf;
    return WG_OK;
}

/* A JSON number, true or false: its text as written. */
static int jscalar(Json *j, char **out)
{
    const char *s = j->s;
    if (!strncmp(s, "true", 4) || !strncmp(s, "false", 5)) {
        size_t n = s[0] == 't' ? 4 : 5;
        j->s += n;
        return (*out = dup_n(s, n)) ? WG_OK : nomem(j->rd);
    }
    const char *p = s;
    if (*p == '-') p++;
    if (*p == '0')
        p++;
    else if (*p >= '1' && *p <= '9')
        while (*p >= '0' && *p <= '9') p++;
    else
        return jerr(j, "a string, a number, true or false was expected here");
    if (*p == '.') {
        p++;
        if (*p < '0' || *p > '9') {
            j->s = p;
            return jerr(j, "a digit must follow the decimal point");
        }
        while (*p >= '0' && *p <= '9') p++;
    }
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-') p++;
        if (*p < '0' || *p > '9') {
            j->s = p;
            return jerr(j, "a digit must follow the exponent");
        }
        while (*p >= '0' && *p <= '9') p++;
    }
    j->s = p;
    return (*out = dup_n(s, (size_t)(p - s))) ? WG_OK : nomem(j->rd);
}

/* {"NAME": value, ...} into fields of the last row; values are strings (inputs) or strings,
 * numbers and booleans (set). */
static int jmembers(Json *j, BatchList *l, int kind)
{
    if (*j->s != '{') return jerr(j, "an object {...} was expected here");
    j->s++;
    jws(j);
    if (*j->s == '}') {
        j->s++;
        return WG_OK;
    }
    for (;;) {
        char *name = NULL, *value = NULL;
        jws(j);
        int name_column = (int)(j->s - j->start) + 1;
        int rc = jstring(j, &name);
        if (rc) return rc;
        jws(j);
        if (*j->s != ':') {
            free(name);
            return jerr(j, "a ':' was expected after the name");
        }
        j->s++;
        jws(j);
        int column = (int)(j->s - j->start) + 1;
        if (*j->s == '"')
            rc = jstring(j, &value);
        else if (kind == BATCH_INPUT)
            rc = jerr(j, "an input's value is a file path in double quotes");
        else
            rc = jscalar(j, &value);
        if (rc) {
            free(name);
            return rc;
        }
        BatchRow *r = &l->rows[l->n_rows - 1];
        for (int i = 0; i < r->n_fields; i++)
            if (r->fields[i].kind == kind && !strcmp(r->fields[i].name, name)) {
                j->s = j->start + column - 1;
                free(name);
                free(value);
                return jerr(j, "this name appears twice in the object");
            }
        if ((rc = add_field(j->rd, l, kind, name, value, j->line, column, j->line, name_column)))
            return rc;
        jws(j);
        if (*j->s == ',') {
            j->s++;
            continue;
        }
        if (*j->s == '}') {
            j->s++;
            return WG_OK;
        }
        return jerr(j, "a ',' or '}' was expected here");
    }
}

static int jrow(Json *j, BatchList *l)
{
    if (*j->s != '{') return jerr(j, "each line holds one JSON object {...}");
    j->s++;
    bool seen[3] = {false, false, false};
    jws(j);
    if (*j->s == '}') {
        j->s++;
        return WG_OK;
    }
    for (;;) {
        jws(j);
        const char *key_at = j->s;
        char *key = NULL;
        int rc = jstring(j, &key);
        if (rc) return rc;
        int k = !strcmp(key, "inputs") ? 0 : !strcmp(key, "set") ? 1 : !strcmp(key, "out") ? 2 : -1;
        free(key);
        if (k < 0 || seen[k]) {
            j->s = key_at;
            return jerr(j, k < 0 ? "unknown key (a row has \"inputs\", \"set\" and \"out\")"
                                 : "this key appears twice in the row");
        }
        seen[k] = true;
        jws(j);
        if (*j->s != ':') return jerr(j, "a ':' was expected after the key");
        j->s++;
        jws(j);
        if (k == 2) {
            char *out = NULL;
            if (*j->s != '"') return jerr(j, "\"out\" is a folder path in double quotes");
            if ((rc = jstring(j, &out))) return rc;
            BatchRow *r = &l->rows[l->n_rows - 1];
            r->out = resolve(j->rd, out);
            free(out);
            if (!r->out) return nomem(j->rd);
        } else if ((rc = jmembers(j, l, k == 0 ? BATCH_INPUT : BATCH_SET))) {
            return rc;
        }
        jws(j);
        if (*j->s == ',') {
            j->s++;
            continue;
        }
        if (*j->s == '}') {
            j->s++;
            return WG_OK;
        }
        return jerr(j, "a ',' or '}' was expected here");
    }
}

static int read_jsonl(Reader *rd, char *text, BatchList *l)
{
    char *p = text;
    if (!strncmp(p, "\xef\xbb\xbf", 3)) p += 3;
    for (int line = 1; *p; line++) {
        char *nl = strchr(p, '\n');
        if (nl) *nl = '\0';
        Json j = {rd, p, p, line};
        jws(&j);
        if (*j.s) {
            if (add_row(l, line)) return nomem(rd);
            int rc = jrow(&j, l);
            if (!rc) {
                jws(&j);
                if (*j.s) rc = jerr(&j, "unexpected text after the row's object");
            }
            if (rc) return rc;
        }
        if (!nl) break;
        p = nl + 1;
    }
    return WG_OK;
}

int batch_list_load(const char *path, BatchList *out, WgError *err)
{
    *out = (BatchList){0};
    size_t n = strlen(path);
    bool csv = n > 4 && !strcasecmp(path + n - 4, ".csv");
    bool jsonl = n > 6 && !strcasecmp(path + n - 6, ".jsonl");
    if (!csv && !jsonl)
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                               "a batch list is a .csv or a .jsonl file");
    FILE *f = fopen(path, "rb");
    if (!f)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot open the batch list: %s",
                               strerror(errno));
    size_t cap = 1 << 16, size = 0, got;
    char *text = malloc(cap);
    while (text && (got = fread(text + size, 1, cap - size - 1, f)) > 0) {
        size += got;
        if (size + 1 == cap) {
            char *t = realloc(text, cap *= 2);
            if (!t) free(text);
            text = t;
        }
    }
    bool bad = ferror(f);
    fclose(f);
    if (!text) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (bad) {
        free(text);
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the batch list");
    }
    text[size] = '\0';
    int rc = batch_list_parse(path, text, size, out, err);
    free(text);
    return rc;
}

int batch_list_parse(const char *path, char *text, size_t size, BatchList *out, WgError *err)
{
    *out = (BatchList){0};
    size_t n = strlen(path);
    bool csv = n > 4 && !strcasecmp(path + n - 4, ".csv");
    Reader rd = {path, NULL, err};
    const char *slash = strrchr(path, '/');
    rd.folder = slash ? dup_n(path, (size_t)(slash - path) + 1) : strdup("");
    int rc;
    if (!rd.folder)
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    else if (!csv && memchr(text, '\0', size))
        rc = wg_error_set_at(err, WG_ERR_PARSE, path, 0, 0, "a NUL byte in the file");
    else
        rc = csv ? read_csv(&rd, text, size, out) : read_jsonl(&rd, text, out);
    free(rd.folder);
    if (rc) batch_list_free(out);
    return rc;
}

/* ---- output folders ---- */

/* `p` as an absolute path with no "." or ".." components, no repeated or trailing slash:
 * two spellings of one folder become one string (symbolic links are not followed: the folders
 * need not exist yet). Relative paths are taken from `cwd`. */
static char *normal_path(const char *p, const char *cwd)
{
    size_t n = strlen(cwd) + strlen(p) + 3;
    char *joined = malloc(n), *out = malloc(n);
    if (!joined || !out) {
        free(joined);
        free(out);
        return NULL;
    }
    snprintf(joined, n, "%s/%s", p[0] == '/' ? "" : cwd, p);
    size_t len = 0;
    for (char *s = joined; *s;) {
        while (*s == '/') s++;
        char *e = s;
        while (*e && *e != '/') e++;
        size_t k = (size_t)(e - s);
        if (k == 1 && s[0] == '.') {
        } else if (k == 2 && s[0] == '.' && s[1] == '.') {
            while (len > 0 && out[len - 1] != '/') len--;
            if (len > 0) len--; /* the slash before the dropped part */
        } else if (k > 0) {
            out[len++] = '/';
            memcpy(out + len, s, k);
            len += k;
        }
        s = e;
    }
    if (len == 0) out[len++] = '/';
    out[len] = '\0';
    free(joined);
    return out;
}

typedef struct {
    char *path;
    int row;
} OutKey;

static int out_key_cmp(const void *a, const void *b)
{
    const OutKey *x = a, *y = b;
    int c = strcmp(x->path, y->path);
    return c ? c : (x->row > y->row) - (x->row < y->row);
}

int batch_list_check_outs(const char *path, const BatchList *l, const char *default_out,
                          WgError *err)
{
    if (l->n_rows < 2) return WG_OK;
    char cwd[4096];
    if (!getcwd(cwd, sizeof cwd)) snprintf(cwd, sizeof cwd, "/");
    OutKey *keys = calloc((size_t)l->n_rows, sizeof *keys);
    int rc = keys ? WG_OK : wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < l->n_rows && !rc; i++) {
        const char *o = l->rows[i].out ? l->rows[i].out : default_out ? default_out : ".";
        keys[i] = (OutKey){normal_path(o, cwd), i};
        if (!keys[i].path) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    if (!rc) {
        qsort(keys, (size_t)l->n_rows, sizeof *keys, out_key_cmp);
        /* of all rows sharing a folder with an earlier one, name the first in the LIST */
        int best = -1;
        for (int i = 1; i < l->n_rows; i++)
            if (!strcmp(keys[i].path, keys[i - 1].path) &&
                strcmp(i > 1 ? keys[i - 2].path : "", keys[i].path) &&
                (best < 0 || keys[i].row < keys[best].row))
                best = i;
        if (best >= 0) {
            const BatchRow *a = &l->rows[keys[best - 1].row], *b = &l->rows[keys[best].row];
            const char *oa = a->out ? a->out : default_out ? default_out : ".";
            const char *ob = b->out ? b->out : default_out ? default_out : ".";
            char same[320] = "", sa[300], sb[300];
            if (strcmp(oa, ob))
                snprintf(same, sizeof same, " (as '%s')", batch_shown(ob, sb, sizeof sb));
            rc = wg_error_set_at(err, WG_ERR_USAGE, path, b->line, 0,
                                 "rows %d (line %d) and %d (line %d) write to the same output "
                                 "folder '%s'%s%s: each row needs its own",
                                 keys[best - 1].row, a->line, keys[best].row, b->line,
                                 batch_shown(oa, sa, sizeof sa), same,
                                 a->out && b->out ? "" : " (a row without out writes to -o)");
        }
    }
    for (int i = 0; keys && i < l->n_rows; i++) free(keys[i].path);
    free(keys);
    return rc;
}

void batch_list_free(BatchList *l)
{
    for (int i = 0; i < l->n_rows; i++) {
        BatchRow *r = &l->rows[i];
        for (int k = 0; k < r->n_fields; k++) {
            free(r->fields[k].name);
            free(r->fields[k].value);
        }
        free(r->fields);
        free(r->out);
    }
    free(l->rows);
    for (int k = 0; k < l->n_columns; k++) free(l->columns[k].name);
    free(l->columns);
    *l = (BatchList){0};
}
