/* SPDX-License-Identifier: MIT */
/* The node registry: every descriptor is well formed (unique lowercase names, a summary and a
 * category, at least one output, unique port and parameter names, defaults within their ranges,
 * valid enum defaults, colour defaults that parse, parameter fields inside the params struct,
 * flags consistent with the ports), and docs/nodes.md is what `wetgraph nodes --markdown`
 * prints. */
#include "wgtest.h"

#include "internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool lowercase_identifier(const char *s)
{
    if (!s || !islower((unsigned char)s[0])) return false;
    for (; *s; s++)
        if (!islower((unsigned char)*s) && !isdigit((unsigned char)*s) && *s != '_') return false;
    return true;
}

static int count_ports(const WgPortSpec *p)
{
    int n = 0;
    while (p && p[n].name) n++;
    return n;
}

static void check_ports(const WgNodeType *t, const WgPortSpec *ports, bool inputs)
{
    int n = count_ports(ports);
    for (int i = 0; i < n; i++) {
        const WgPortSpec *p = &ports[i];
        if (!lowercase_identifier(p->name))
            fail_msg("%s: port name '%s' is not a lowercase identifier", t->name, p->name);
        if (p->kind != WG_ANY && p->kind != WG_GRAY && p->kind != WG_COLOR)
            fail_msg("%s: port '%s' has kind %d", t->name, p->name, p->kind);
        if (!inputs && p->optional) fail_msg("%s: output '%s' is optional", t->name, p->name);
        for (int k = 0; k < i; k++)
            if (!strcmp(ports[k].name, p->name)) fail_msg("%s: port '%s' twice", t->name, p->name);
    }
}

static void check_param(const WgNodeType *t, const WgParamSpec *s)
{
    const char *n = t->name;
    if (!lowercase_identifier(s->name))
        fail_msg("%s: parameter '%s' is not a lowercase identifier", n, s->name);
    static const char *const reserved[] = {"id", "type", "size", "seed", "label", "pos"};
    for (int i = 0; i < 6; i++)
        if (!strcmp(s->name, reserved[i]))
            fail_msg("%s: parameter '%s' is a reserved attribute", n, s->name);
    if (!s->label || !s->label[0]) fail_msg("%s.%s: no label", n, s->name);
    size_t size = 0;
    switch (s->type) {
    case WG_PARAM_FLOAT_T:
    case WG_PARAM_INT_T:
        size = s->type == WG_PARAM_FLOAT_T ? sizeof(float) : sizeof(int);
        if (!(s->min <= s->max)) fail_msg("%s.%s: range [%g, %g]", n, s->name, s->min, s->max);
        if (!(s->def >= s->min && s->def <= s->max))
            fail_msg("%s.%s: default %g outside [%g, %g]", n, s->name, s->def, s->min, s->max);
        if (!(s->ui_min >= s->min && s->ui_max <= s->max && s->ui_min <= s->ui_max))
            fail_msg("%s.%s: UI range [%g, %g] not within [%g, %g]", n, s->name, s->ui_min,
                     s->ui_max, s->min, s->max);
        if (s->type == WG_PARAM_INT_T && s->def != floor(s->def))
            fail_msg("%s.%s: int default %g", n, s->name, s->def);
        break;
    case WG_PARAM_BOOL_T:
        size = sizeof(bool);
        if (s->def != 0 && s->def != 1) fail_msg("%s.%s: bool default %g", n, s->name, s->def);
        break;
    case WG_PARAM_ENUM_T: {
        size = sizeof(int);
        if (!s->values || !s->values[0]) fail_msg("%s.%s: enum without values", n, s->name);
        int count = 0;
        for (; s->values[count]; count++) {
            if (!lowercase_identifier(s->values[count]))
                fail_msg("%s.%s: enum value '%s'", n, s->name, s->values[count]);
            for (int k = 0; k < count; k++)
                if (!strcmp(s->values[k], s->values[count]))
                    fail_msg("%s.%s: enum value '%s' twice", n, s->name, s->values[count]);
        }
        if (!(s->def >= 0 && s->def < count && s->def == floor(s->def)))
            fail_msg("%s.%s: enum default index %g of %d values", n, s->name, s->def, count);
        break;
    }
    case WG_PARAM_COLOR_T: {
        size = 4 * sizeof(float);
        float c[4];
        if (!s->def_string || wg__color_parse(s->def_string, c))
            fail_msg("%s.%s: colour default '%s' does not parse", n, s->name,
                     s->def_string ? s->def_string : "(null)");
        break;
    }
    case WG_PARAM_STRING_T:
        size = sizeof(const char *);
        if (!s->def_string) fail_msg("%s.%s: string without a default", n, s->name);
        break;
    default:
        fail_msg("%s.%s: unknown type %d", n, s->name, s->type);
    }
    if (s->offset + size > t->params_size)
        fail_msg("%s.%s: field at %zu (+%zu) is outside the %zu-byte params struct", n, s->name,
                 s->offset, size, t->params_size);
    if (s->offset % (s->type == WG_PARAM_BOOL_T ? 1 : 4))
        fail_msg("%s.%s: misaligned field offset %zu", n, s->name, s->offset);
}

static void test_descriptors_are_well_formed(void **state)
{
    (void)state;
    int count = 0;
    for (; wg_node_types[count]; count++) {
        const WgNodeType *t = wg_node_types[count];
        if (!lowercase_identifier(t->name))
            fail_msg("node name '%s' is not a lowercase identifier", t->name);
        for (int k = 0; k < count; k++)
            if (!strcmp(wg_node_types[k]->name, t->name))
                fail_msg("node '%s' registered twice", t->name);
        if (wg_node_type_find(t->name) != t)
            fail_msg("wg_node_type_find('%s') finds another", t->name);
        if (!t->summary || !t->summary[0]) fail_msg("%s: no summary", t->name);
        size_t sl = strlen(t->summary);
        if (t->summary[sl - 1] == '.' || strchr(t->summary, '\n'))
            fail_msg("%s: the summary is one line without a final period: '%s'", t->name,
                     t->summary);
        if (!t->category || !t->category[0]) fail_msg("%s: no category", t->name);
        if (!t->eval) fail_msg("%s: no eval", t->name);
        int n_out = count_ports(t->outputs);
        if (n_out < 1) fail_msg("%s: no outputs", t->name);
        check_ports(t, t->outputs, false);
        check_ports(t, t->inputs, true);
        int n_in = count_ports(t->inputs);
        /* source nodes have no image inputs, and nodes without inputs are sources */
        if ((t->flags & WG_NODE_SOURCE) && n_in > 0) fail_msg("%s: a source with inputs", t->name);
        if (!(t->flags & WG_NODE_SOURCE) && n_in == 0 && !(t->flags & WG_NODE_DYNAMIC_INPUTS))
            fail_msg("%s: no inputs but not flagged as a source", t->name);
        /* an output of kind ANY needs inputs or an output_channels callback to decide */
        for (int o = 0; o < n_out; o++)
            if (t->outputs[o].kind == WG_ANY && n_in == 0 && !t->output_channels &&
                !(t->flags & WG_NODE_DYNAMIC_INPUTS))
                fail_msg("%s: output '%s' has no way to decide its kind", t->name,
                         t->outputs[o].name);
        int n_params = 0;
        for (; t->params && t->params[n_params].name; n_params++) {
            check_param(t, &t->params[n_params]);
            for (int k = 0; k < n_params; k++)
                if (!strcmp(t->params[k].name, t->params[n_params].name))
                    fail_msg("%s: parameter '%s' twice", t->name, t->params[k].name);
        }
        if (n_params > 0 && t->params_size == 0)
            fail_msg("%s: parameters but no params struct", t->name);
    }
    assert_true(count >= 7);
    assert_null(wg_node_type_find("no_such_node"));
    assert_null(wg_node_type_find(""));
}

static void test_issue2_nodes_are_registered(void **state)
{
    (void)state;
    static const char *const names[] = {"uniform", "image",     "blend", "levels",
                                        "invert",  "grayscale", "blur"};
    for (int i = 0; i < 7; i++)
        if (!wg_node_type_find(names[i])) fail_msg("'%s' is not registered", names[i]);
}

/* ---- docs/nodes.md ----------------------------------------------------------------------- */

static char *slurp_stream(FILE *f)
{
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    assert_non_null(buf);
    size_t k;
    while ((k = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += k;
        if (cap - n - 1 == 0) {
            cap *= 2;
            buf = realloc(buf, cap);
            assert_non_null(buf);
        }
    }
    buf[n] = '\0';
    return buf;
}

static void test_docs_nodes_md_is_up_to_date(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN"), *src = getenv("WETGRAPH_SOURCE");
    if (!bin || !src)
        fail_msg("WETGRAPH_BIN and WETGRAPH_SOURCE must be set (run through meson test)");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "'%s' nodes --markdown", bin);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char *generated = slurp_stream(p);
    assert_int_equal(pclose(p), 0);
    char path[4096];
    snprintf(path, sizeof path, "%s/docs/nodes.md", src);
    FILE *f = fopen(path, "rb");
    if (!f) {
        free(generated);
        fail_msg("%s is missing: run `build/cli/wetgraph nodes --markdown > docs/nodes.md`", path);
    }
    char *committed = slurp_stream(f);
    fclose(f);
    /* the line of the first difference, 0 when equal */
    size_t line = 0;
    if (strcmp(generated, committed)) {
        size_t i = 0;
        line = 1;
        while (generated[i] && generated[i] == committed[i]) {
            if (generated[i] == '\n') line++;
            i++;
        }
    }
    free(committed);
    free(generated);
    if (line)
        fail_msg("docs/nodes.md is out of date (first difference on line %zu): run "
                 "`build/cli/wetgraph nodes --markdown > docs/nodes.md`",
                 line);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_descriptors_are_well_formed),
        cmocka_unit_test(test_issue2_nodes_are_registered),
        cmocka_unit_test(test_docs_nodes_md_is_up_to_date),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
