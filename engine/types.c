/* SPDX-License-Identifier: MIT */
/* The node types graphs are read with: a NULL-terminated table handed to the engine
 * (nodes/registry.c hands it the built-in one when the library loads) and a hash index of
 * their names, so the engine never names the node registry itself. The index lives in a fixed
 * array: it is built before a program can set its allocator and building it must not fail;
 * a table too large for it (over 255 types) is searched linearly instead. Of two types with
 * the same name the first in the table wins, as in a linear search. */
#include "internal.h"

#include <wetgraph/plugin.h>

#include <string.h>

enum { TYPE_SLOTS = 512 }; /* a name index is at most half full */

static const WgNodeType *const *types;
static WgNameSlot type_slots[TYPE_SLOTS];
static WgNameIndex type_index; /* cap 0: no index, search `types` */

void wg_set_node_types(const WgNodeType *const *table)
{
    types = table;
    memset(type_slots, 0, sizeof type_slots);
    type_index = (WgNameIndex){0};
    int n = 0;
    while (table && table[n]) n++;
    if (2 * ((size_t)n + 1) > TYPE_SLOTS) return;
    type_index.slots = type_slots;
    type_index.cap = TYPE_SLOTS;
    for (int i = 0; i < n; i++) {
        size_t len = strlen(table[i]->name);
        /* never grows (so never allocates) at this load */
        if (wg__name_index_get(&type_index, table[i]->name, len) < 0)
            wg__name_index_put(&type_index, table[i]->name, len, i);
    }
}

const WgNodeType *wg__node_type_lookup(const char *name)
{
    if (!types) return NULL;
    if (type_index.cap) {
        int i = wg__name_index_get(&type_index, name, strlen(name));
        return i >= 0 ? types[i] : NULL;
    }
    for (int i = 0; types[i]; i++)
        if (!strcmp(types[i]->name, name)) return types[i];
    return NULL;
}

int wg__node_type_names(const char **names, int max)
{
    int count = 0;
    for (; types && types[count] && count < max; count++) names[count] = types[count]->name;
    return count;
}

const WgNodeType *const *wg_node_types_active(void)
{
    static const WgNodeType *const none[] = {NULL};
    return types ? types : none;
}
