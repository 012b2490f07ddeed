/* SPDX-License-Identifier: MIT */
/* Typed parameter values: parsing literal text (numbers, booleans, enum names, colours,
 * strings), range checks and formatting. Colours written as hex (#rgb, #rrggbb, #rrggbbaa) are
 * sRGB and decoded to linear; colours written as 1, 3 or 4 numbers are linear already. */
#include "internal.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

const char *wg_param_type_name(WgParamType t)
{
    switch (t) {
    case WG_PARAM_FLOAT_T:
        return "float";
    case WG_PARAM_INT_T:
        return "int";
    case WG_PARAM_BOOL_T:
        return "bool";
    case WG_PARAM_ENUM_T:
        return "enum";
    case WG_PARAM_COLOR_T:
        return "color";
    case WG_PARAM_STRING_T:
        return "string";
    }
    return "?";
}

void wg__param_desc_from_spec(WgParamDesc *d, const WgParamSpec *s)
{
    memset(d, 0, sizeof *d);
    d->name = s->name;
    d->type = s->type;
    d->values = s->values;
    d->flags = s->flags;
    if (s->type == WG_PARAM_FLOAT_T || s->type == WG_PARAM_INT_T) {
        d->has_min = d->has_max = true;
        d->min = s->min;
        d->max = s->max;
    }
}

static int hexval(int c)
{
    if (c >= '0' && c <= '9') return c - '0';
    c = tolower(c);
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

int wg__color_parse(const char *text, float out[4])
{
    while (isspace((unsigned char)*text)) text++;
    if (*text == '#') {
        const char *h = text + 1;
        size_t n = strlen(h);
        while (n && isspace((unsigned char)h[n - 1])) n--;
        int digits = (n == 3 || n == 4) ? 1 : (n == 6 || n == 8) ? 2 : 0;
        if (!digits) return -1;
        int comps = (int)n / digits;
        float c[4] = {0, 0, 0, 1};
        for (int i = 0; i < comps; i++) {
            int v = 0;
            for (int k = 0; k < digits; k++) {
                int d = hexval((unsigned char)h[i * digits + k]);
                if (d < 0) return -1;
                v = v * 16 + d;
            }
            if (digits == 1) v *= 17;
            c[i] = (float)v / 255.0f;
        }
        for (int i = 0; i < 3; i++) out[i] = wg_srgb_to_linear(c[i]);
        out[3] = c[3];
        return 0;
    }
    double v[4];
    int n = 0;
    const char *p = text;
    while (*p) {
        while (isspace((unsigned char)*p) || *p == ',') p++;
        if (!*p) break;
        if (n == 4) return -1;
        size_t len = (size_t)(*p == '+' || *p == '-');
        len += len ? wg__number_length(p + 1) : wg__number_length(p);
        if (len <= (size_t)(*p == '+' || *p == '-')) return -1;
        v[n] = strtod(p, NULL);
        if (!(fabs(v[n]) <= FLT_MAX)) return -1; /* also what float cannot hold */
        n++;
        p += len;
        if (*p && !isspace((unsigned char)*p) && *p != ',') return -1;
    }
    if (n == 1) {
        out[0] = out[1] = out[2] = (float)v[0];
        out[3] = 1;
    } else if (n == 3 || n == 4) {
        for (int i = 0; i < n; i++) out[i] = (float)v[i];
        if (n == 3) out[3] = 1;
    } else {
        return -1;
    }
    return 0;
}

size_t wg__number_length(const char *s)
{
    const char *p = s;
    size_t digits = 0;
    while (isdigit((unsigned char)*p)) p++, digits++;
    if (*p == '.') {
        p++;
        while (isdigit((unsigned char)*p)) p++, digits++;
    }
    if (!digits) return 0;
    if (*p == 'e' || *p == 'E') {
        const char *e = p + 1;
        if (*e == '+' || *e == '-') e++;
        if (isdigit((unsigned char)*e)) {
            while (isdigit((unsigned char)*e)) e++;
            p = e;
        }
    }
    return (size_t)(p - s);
}

bool wg_parse_number(const char *text, double *out)
{
    const char *p = text + (*text == '+' || *text == '-');
    size_t n = wg__number_length(p);
    if (!n || p[n]) return false;
    char *end;
    double v = strtod(text, &end);
    if (end != p + n || !isfinite(v)) return false;
    *out = v;
    return true;
}

bool wg_parse_whole(const char *text, uint64_t *out)
{
    if (!isdigit((unsigned char)*text)) return false;
    uint64_t v = 0;
    for (const char *p = text; *p; p++) {
        if (!isdigit((unsigned char)*p)) return false;
        unsigned d = (unsigned)(*p - '0');
        if (v > (UINT64_MAX - d) / 10) return false;
        v = v * 10 + d;
    }
    *out = v;
    return true;
}

int wg__value_parse(const WgParamDesc *d, const char *text, WgValue *out, WgError *err)
{
    memset(out, 0, sizeof *out);
    out->type = d->type;
    switch (d->type) {
    case WG_PARAM_FLOAT_T:
    case WG_PARAM_INT_T: {
        double v;
        if (!wg_parse_number(text, &v)) {
            /* inf, nan and 1e999 read as numbers but not as finite ones: say so */
            char *end;
            double x = strtod(text, &end);
            if (end != text && !*end && !isfinite(x) && !isspace((unsigned char)*text) &&
                !strpbrk(text, "xX"))
                return wg_error_set(err, WG_ERR_RANGE, NULL, "'%s' is %s, not a finite number",
                                    d->name, isnan(x) ? "NaN" : "infinite");
            return wg_error_set(err, WG_ERR_TYPE, NULL, "'%s' expects a number, got '%s'%s",
                                d->name, text,
                                strpbrk(text, "0123456789")
                                    ? " (written in decimal, like -2, 0.5 or 1e-3, no spaces)"
                                    : "");
        }
        if (d->type == WG_PARAM_INT_T && isfinite(v) && v != floor(v))
            return wg_error_set(err, WG_ERR_TYPE, NULL, "'%s' expects a whole number, got '%s'",
                                d->name, text);
        out->num = v;
        return wg__value_check(d, out, err);
    }
    case WG_PARAM_BOOL_T:
        if (!strcasecmp(text, "true") || !strcmp(text, "1") || !strcasecmp(text, "yes"))
            out->num = 1;
        else if (!strcasecmp(text, "false") || !strcmp(text, "0") || !strcasecmp(text, "no"))
            out->num = 0;
        else
            return wg_error_set(err, WG_ERR_TYPE, NULL, "'%s' expects true or false, got '%s'",
                                d->name, text);
        return WG_OK;
    case WG_PARAM_ENUM_T: {
        int count = 0;
        for (; d->values && d->values[count]; count++) {
            if (!strcmp(d->values[count], text)) {
                out->num = count;
                out->str = wg_strdup(text);
                return out->str ? WG_OK : wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
            }
        }
        char list[512] = "";
        for (int i = 0; i < count; i++) {
            size_t l = strlen(list);
            snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", d->values[i]);
        }
        const char *s = wg_suggest(text, d->values, count);
        if (s)
            return wg_error_set(err, WG_ERR_TYPE, NULL,
                                "'%s' has no value '%s'; did you mean '%s'? (one of: %s)", d->name,
                                text, s, list);
        return wg_error_set(err, WG_ERR_TYPE, NULL, "'%s' has no value '%s' (one of: %s)", d->name,
                            text, list);
    }
    case WG_PARAM_COLOR_T:
        if (wg__color_parse(text, out->color))
            return wg_error_set(err, WG_ERR_TYPE, NULL,
                                "'%s' expects a colour (#rrggbb, #rrggbbaa, 'r g b', 'r g b a' "
                                "or one gray value), got '%s'",
                                d->name, text);
        return WG_OK;
    case WG_PARAM_STRING_T:
        out->str = wg_strdup(text);
        return out->str ? WG_OK : wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    return WG_ERR_TYPE;
}

int wg__value_check(const WgParamDesc *d, WgValue *v, WgError *err)
{
    if (d->type != WG_PARAM_FLOAT_T && d->type != WG_PARAM_INT_T && d->type != WG_PARAM_BOOL_T)
        return WG_OK;
    if (!isfinite(v->num))
        return wg_error_set(err, WG_ERR_RANGE, NULL, "'%s' is %s, not a finite number", d->name,
                            isnan(v->num) ? "NaN" : "infinite");
    if (d->type == WG_PARAM_INT_T) v->num = floor(v->num + 0.5);
    if (d->type == WG_PARAM_BOOL_T) v->num = v->num != 0;
    if ((d->has_min && v->num < d->min) || (d->has_max && v->num > d->max)) {
        char num[32], lo[32], hi[32];
        wg__number_text(v->num, num, sizeof num);
        wg__number_text(d->min, lo, sizeof lo);
        wg__number_text(d->max, hi, sizeof hi);
        if (d->has_min && d->has_max)
            return wg_error_set(err, WG_ERR_RANGE, NULL, "'%s' = %s is outside [%s, %s]", d->name,
                                num, lo, hi);
        if (d->has_min)
            return wg_error_set(err, WG_ERR_RANGE, NULL, "'%s' = %s is below its minimum %s",
                                d->name, num, lo);
        return wg_error_set(err, WG_ERR_RANGE, NULL, "'%s' = %s is above its maximum %s", d->name,
                            num, hi);
    }
    return WG_OK;
}

void wg__number_text(double v, char *buf, size_t size)
{
    /* from %g's 6 digits up, so that 10 stays "10", not "1e+01" */
    for (int digits = 6; digits <= 17; digits++) {
        snprintf(buf, size, "%.*g", digits, v);
        if (strtod(buf, NULL) == v || !isfinite(v)) return;
    }
}

int wg__value_copy(WgValue *dst, const WgValue *src)
{
    *dst = *src;
    dst->str = NULL;
    if (src->str && !(dst->str = wg_strdup(src->str))) return WG_ERR_NOMEM;
    return WG_OK;
}

void wg__value_clear(WgValue *v)
{
    wg_free(v->str);
    v->str = NULL;
}

void wg__value_format(const WgValue *v, char *buf, size_t size)
{
    switch (v->type) {
    case WG_PARAM_FLOAT_T:
        snprintf(buf, size, "%.9g", v->num);
        break;
    case WG_PARAM_INT_T:
        snprintf(buf, size, "%.0f", v->num);
        break;
    case WG_PARAM_BOOL_T:
        snprintf(buf, size, "%s", v->num != 0 ? "true" : "false");
        break;
    case WG_PARAM_COLOR_T:
        snprintf(buf, size, "%.9g %.9g %.9g %.9g", v->color[0], v->color[1], v->color[2],
                 v->color[3]);
        break;
    default:
        snprintf(buf, size, "%s", v->str ? v->str : "");
        break;
    }
}
