/* SPDX-License-Identifier: MIT */
/* Hash indexes that keep loading, planning and caching linear in the size of a graph: names to
 * positions (node ids, outputs, inputs, params) and 128-bit keys to positions (merged
 * instances, cache entries). Open addressing with linear probing, at most half full; removal
 * shifts the following run back, so there are no tombstones. Keys are borrowed: a name index
 * points at strings that must outlive it. */
#include "internal.h"

#include <string.h>
#include <xxhash.h>

static size_t next_pow2(size_t n)
{
    size_t c = 16;
    while (c < n) c *= 2;
    return c;
}

/* ---- names ------------------------------------------------------------------------------- */

static size_t name_slot(const WgNameIndex *ix, const char *name, size_t len)
{
    size_t mask = ix->cap - 1;
    size_t i = (size_t)XXH3_64bits(name, len) & mask;
    while (ix->slots[i].name && !(ix->slots[i].len == len && !memcmp(ix->slots[i].name, name, len)))
        i = (i + 1) & mask;
    return i;
}

static int name_grow(WgNameIndex *ix)
{
    size_t cap = next_pow2(2 * (ix->count + 1) + 1);
    if (cap <= ix->cap) return WG_OK;
    WgNameSlot *old = ix->slots;
    size_t old_cap = ix->cap;
    ix->slots = wg_calloc(cap, sizeof *ix->slots);
    if (!ix->slots) {
        ix->slots = old;
        return WG_ERR_NOMEM;
    }
    ix->cap = cap;
    for (size_t i = 0; i < old_cap; i++)
        if (old[i].name) ix->slots[name_slot(ix, old[i].name, old[i].len)] = old[i];
    wg_free(old);
    return WG_OK;
}

int wg__name_index_put(WgNameIndex *ix, const char *name, size_t len, int value)
{
    if (2 * (ix->count + 1) > ix->cap && name_grow(ix)) return WG_ERR_NOMEM;
    size_t i = name_slot(ix, name, len);
    if (!ix->slots[i].name) ix->count++;
    ix->slots[i] = (WgNameSlot){name, len, value};
    return WG_OK;
}

int wg__name_index_get(const WgNameIndex *ix, const char *name, size_t len)
{
    if (!ix->cap) return -1;
    size_t i = name_slot(ix, name, len);
    return ix->slots[i].name ? ix->slots[i].value : -1;
}

void wg__name_index_free(WgNameIndex *ix)
{
    wg_free(ix->slots);
    memset(ix, 0, sizeof *ix);
}

/* ---- keys -------------------------------------------------------------------------------- */

static bool key_equal(const WgKeySlot *s, const uint64_t key[2], int aux)
{
    return s->key[0] == key[0] && s->key[1] == key[1] && s->aux == aux;
}

static size_t key_home(const WgKeyIndex *ix, const uint64_t key[2], int aux)
{
    /* the keys are xxh3 digests already: mixing in aux is enough */
    uint64_t h = key[0] ^ (key[1] * 0x9E3779B97F4A7C15ull) ^ ((uint64_t)(unsigned)aux << 17);
    h ^= h >> 29;
    return (size_t)h & (ix->cap - 1);
}

static size_t key_slot(const WgKeyIndex *ix, const uint64_t key[2], int aux)
{
    size_t i = key_home(ix, key, aux);
    while (ix->slots[i].value >= 0 && !key_equal(&ix->slots[i], key, aux))
        i = (i + 1) & (ix->cap - 1);
    return i;
}

static int key_grow(WgKeyIndex *ix)
{
    size_t cap = next_pow2(2 * (ix->count + 1) + 1);
    if (cap <= ix->cap) return WG_OK;
    WgKeySlot *old = ix->slots;
    size_t old_cap = ix->cap;
    WgKeySlot *slots = wg_malloc(cap * sizeof *slots);
    if (!slots) return WG_ERR_NOMEM;
    for (size_t i = 0; i < cap; i++) slots[i].value = -1;
    ix->slots = slots;
    ix->cap = cap;
    for (size_t i = 0; i < old_cap; i++)
        if (old[i].value >= 0) ix->slots[key_slot(ix, old[i].key, old[i].aux)] = old[i];
    wg_free(old);
    return WG_OK;
}

int wg__key_index_put(WgKeyIndex *ix, const uint64_t key[2], int aux, int value)
{
    if (2 * (ix->count + 1) > ix->cap && key_grow(ix)) return WG_ERR_NOMEM;
    size_t i = key_slot(ix, key, aux);
    if (ix->slots[i].value < 0) ix->count++;
    ix->slots[i] = (WgKeySlot){{key[0], key[1]}, aux, value};
    return WG_OK;
}

int wg__key_index_get(const WgKeyIndex *ix, const uint64_t key[2], int aux)
{
    if (!ix->cap) return -1;
    return ix->slots[key_slot(ix, key, aux)].value;
}

void wg__key_index_remove(WgKeyIndex *ix, const uint64_t key[2], int aux)
{
    if (!ix->cap) return;
    size_t mask = ix->cap - 1;
    size_t i = key_slot(ix, key, aux);
    if (ix->slots[i].value < 0) return;
    ix->count--;
    /* shift back every later entry of the run that may sit at i (its home is not in (i, j]) */
    size_t j = i;
    for (;;) {
        ix->slots[i].value = -1;
        for (;;) {
            j = (j + 1) & mask;
            if (ix->slots[j].value < 0) return;
            size_t home = key_home(ix, ix->slots[j].key, ix->slots[j].aux);
            bool between = i <= j ? (i < home && home <= j) : (i < home || home <= j);
            if (!between) break;
        }
        ix->slots[i] = ix->slots[j];
        i = j;
    }
}

void wg__key_index_free(WgKeyIndex *ix)
{
    wg_free(ix->slots);
    memset(ix, 0, sizeof *ix);
}
