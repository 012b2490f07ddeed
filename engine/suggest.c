/* SPDX-License-Identifier: MIT */
/* Spelling suggestions for error messages ("did you mean 'blur'?"): the candidate nearest to a
 * misspelt word by case-insensitive Levenshtein distance, within 1 edit for words of up to 3
 * characters and 2 edits otherwise, or else the first candidate the word is a prefix of (words
 * of 3 characters or more). A word or candidate over 64 characters is far from everything, so
 * only the prefix rule can suggest for it. */
#include "internal.h"

#include <ctype.h>
#include <string.h>

static int levenshtein(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64) return 99;
    int row[65];
    for (size_t j = 0; j <= lb; j++) row[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        int prev = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int cur = row[j];
            int cost = tolower((unsigned char)a[i - 1]) != tolower((unsigned char)b[j - 1]);
            int best = prev + cost;
            if (row[j] + 1 < best) best = row[j] + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            prev = cur;
        }
    }
    return row[lb];
}

const char *wg_suggest(const char *word, const char *const *candidates, int count)
{
    const char *best = NULL;
    int best_d = 3;
    size_t wl = strlen(word);
    for (int i = 0; i < count; i++) {
        if (!candidates[i]) continue;
        int d = levenshtein(word, candidates[i]);
        int limit = wl <= 3 ? 1 : 2;
        if (d <= limit && d < best_d) {
            best = candidates[i];
            best_d = d;
        }
    }
    if (!best && wl >= 3) {
        for (int i = 0; i < count; i++)
            if (candidates[i] && !strncmp(candidates[i], word, wl)) return candidates[i];
    }
    return best;
}
