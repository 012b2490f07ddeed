/* SPDX-License-Identifier: MIT */
/* Is a node type descriptor well formed: what the engine, the CLI and the docs generator rely on
 * before they read one (built-in types are held to it by the registry test, plugins' types by
 * the loader). The first fault found is reported. */
#include "internal.h"

#include <ctype.h>
#include <math.h>
#include <string.h>
#include <wetgraph/plugin.h>

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

#define FAULT(...) wg_error_set(err, WG_ERR_TYPE, NULL, __VA_ARGS__)

static int check_ports(const WgNodeType *t, const WgPortSpec *ports, bool inputs, WgError *err)
{
    const char *what = inputs ? "input" : "output";
    int n = count_ports(ports);
    for (int i = 0; i < n; i++) {
        const WgPortSpec *p = &ports[i];
        if (!lowercase_identifier(p->name))
            return FAULT("node type '%s': %s name '%s' is not a lowercase identifier", t->name,
                         what, p->name);
        if (p->kind != WG_ANY && p->kind != WG_GRAY && p->kind != WG_COLOR)
            return FAULT("node type '%s': %s '%s' has kind %d (WG_GRAY, WG_COLOR or WG_ANY)",
                         t->name, what, p->name, p->kind);
        if (!inputs && p->optional)
            return FAULT("node type '%s': output '%s' is optional", t->name, p->name);
        for (int k = 0; k < i; k++)
            if (!strcmp(ports[k].name, p->name))
                return FAULT("node type '%s': %s '%s' twice", t->name, what, p->name);
    }
    return WG_OK;
}

static int check_param(const WgNodeType *t, const WgParamSpec *s, WgError *err)
{
    const char *n = t->name;
    if (!lowercase_identifier(s->name))
        return FAULT("node type '%s': parameter '%s' is not a lowercase identifier", n,
                     s->name);
    static const char *const reserved[] = {"id", "type", "size", "seed", "label", "pos"};
    for (int i = 0; i < 6; i++)
        if (!strcmp(s->name, reserved[i]))
            return FAULT("node type '%s': parameter '%s' is a reserved attribute", n, s->name);
    if (!s->label || !s->label[0]) return FAULT("node type '%s': parameter '%s' has no label", n, s->name);
    size_t size = 0;
    switch (s->type) {
    case WG_PARAM_FLOAT_T:
    case WG_PARAM_INT_T:
        size = s->type == WG_PARAM_FLOAT_T ? sizeof(float) : sizeof(int);
        if (!(s->min <= s->max))
            return FAULT("node type '%s': parameter '%s': range %g .. %g", n, s->name, s->min,
                         s->max);
        if (!(s->def >= s->min && s->def <= s->max))
            return FAULT("node type '%s': parameter '%s': default %g outside %g .. %g", n,
                         s->name, s->def, s->min, s->max);
        if (!(s->ui_min >= s->min && s->ui_max <= s->max && s->ui_min <= s->ui_max))
            return FAULT("node type '%s': parameter '%s': UI range %g .. %g not within %g .. %g",
                         n, s->name, s->ui_min, s->ui_max, s->min, s->max);
        if (s->type == WG_PARAM_INT_T && s->def != floor(s->def))
            return FAULT("node type '%s': parameter '%s': integer default %g", n, s->name,
                         s->def);
        break;
    case WG_PARAM_BOOL_T:
        size = sizeof(bool);
        if (s->def != 0 && s->def != 1)
            return FAULT("node type '%s': parameter '%s': bool default %g", n, s->name, s->def);
        break;
    case WG_PARAM_ENUM_T: {
        size = sizeof(int);
        if (!s->values || !s->values[0])
            return FAULT("node type '%s': parameter '%s': an enum without values", n, s->name);
        int count = 0;
        for (; s->values[count]; count++) {
            if (!lowercase_identifier(s->values[count]))
                return FAULT("node type '%s': parameter '%s': enum value '%s' is not a "
                             "lowercase identifier",
                             n, s->name, s->values[count]);
            for (int k = 0; k < count; k++)
                if (!strcmp(s->values[k], s->values[count]))
                    return FAULT("node type '%s': parameter '%s': enum value '%s' twice", n,
                                 s->name, s->values[count]);
        }
        if (!(s->def >= 0 && s->def < count && s->def == floor(s->def)))
            return FAULT("node type '%s': parameter '%s': enum default index %g of %d values", n,
                         s->name, s->def, count);
        break;
    }
    case WG_PARAM_COLOR_T: {
        size = 4 * sizeof(float);
        float c[4];
        if (!s->def_string || wg__color_parse(s->def_string, c))
            return FAULT("node type '%s': parameter '%s': colour default '%s' does not parse", n,
                         s->name, s->def_string ? s->def_string : "(none)");
        break;
    }
    case WG_PARAM_STRING_T:
        size = sizeof(const char *);
        if (!s->def_string)
            return FAULT("node type '%s': parameter '%s': a string without a default", n,
                         s->name);
        break;
    default:
        return FAULT("node type '%s': parameter '%s': unknown type %d", n, s->name, (int)s->type);
    }
    if (s->offset + size > t->params_size)
        return FAULT("node type '%s': parameter '%s': its field at %zu (+%zu bytes) is outside "
                     "the %zu-byte params struct",
                     n, s->name, s->offset, size, t->params_size);
    if (s->offset % (s->type == WG_PARAM_BOOL_T ? 1 : 4))
        return FAULT("node type '%s': parameter '%s': misaligned field offset %zu", n, s->name,
                     s->offset);
    return WG_OK;
}

int wg_node_type_validate(const WgNodeType *t, WgError *err)
{
    if (!t) return FAULT("a NULL node type");
    if (!lowercase_identifier(t->name))
        return FAULT("node type name '%s' is not a lowercase identifier",
                     t->name ? t->name : "(none)");
    if (!t->summary || !t->summary[0]) return FAULT("node type '%s': no summary", t->name);
    size_t sl = strlen(t->summary);
    if (t->summary[sl - 1] == '.' || strchr(t->summary, '\n'))
        return FAULT("node type '%s': the summary is one line without a final period: '%s'",
                     t->name, t->summary);
    if (!t->category || !t->category[0]) return FAULT("node type '%s': no category", t->name);
    if (!t->eval) return FAULT("node type '%s': no eval function", t->name);
    const unsigned known = WG_NODE_POINT | WG_NODE_NEIGHBOURHOOD | WG_NODE_GLOBAL |
                           WG_NODE_SOURCE | WG_NODE_SEEDED | WG_NODE_TIMED |
                           WG_NODE_DYNAMIC_INPUTS | WG_NODE_EXTRA_PARAMS | WG_NODE_CHEAP |
                           WG_NODE_SCOPED | WG_NODE_SERIAL | WG_NODE_UNIFORM;
    if (t->flags & ~known)
        return FAULT("node type '%s': unknown flags 0x%x", t->name, t->flags & ~known);
    if ((!t->prepare) != (!t->finish))
        return FAULT("node type '%s': prepare and finish go together", t->name);
    int n_out = count_ports(t->outputs), n_in = count_ports(t->inputs), rc;
    if (n_out < 1) return FAULT("node type '%s': no outputs", t->name);
    if ((rc = check_ports(t, t->outputs, false, err)) || (rc = check_ports(t, t->inputs, true, err)))
        return rc;
    if ((t->flags & WG_NODE_SOURCE) && n_in > 0)
        return FAULT("node type '%s': flagged as a source but has inputs", t->name);
    if (!(t->flags & WG_NODE_SOURCE) && n_in == 0 && !(t->flags & WG_NODE_DYNAMIC_INPUTS))
        return FAULT("node type '%s': no inputs but not flagged as a source", t->name);
    for (int o = 0; o < n_out; o++)
        if (t->outputs[o].kind == WG_ANY && n_in == 0 && !t->output_channels &&
            !(t->flags & WG_NODE_DYNAMIC_INPUTS))
            return FAULT("node type '%s': output '%s' has no way to decide its kind", t->name,
                         t->outputs[o].name);
    int n_params = 0;
    for (; t->params && t->params[n_params].name; n_params++) {
        if ((rc = check_param(t, &t->params[n_params], err))) return rc;
        for (int k = 0; k < n_params; k++)
            if (!strcmp(t->params[k].name, t->params[n_params].name))
                return FAULT("node type '%s': parameter '%s' twice", t->name, t->params[k].name);
    }
    if (n_params > 0 && t->params_size == 0)
        return FAULT("node type '%s': parameters but no params struct (params_size 0)", t->name);
    return WG_OK;
}
