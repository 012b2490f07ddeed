/* SPDX-License-Identifier: MIT */
/* HOT marks a hot loop's function to be compiled twice, for AVX2 and for the baseline, the loader
 * picking one when the library is loaded (GCC's function multiversioning, on x86-64 Linux).
 * Neither clone contracts a multiply and an add (no FMA), so both run the same IEEE operations
 * and give the same bits. Elsewhere it marks nothing. */
#ifndef WG_HOT_H
#define WG_HOT_H

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define HOT __attribute__((target_clones("avx2", "default")))
#else
#define HOT
#endif

#endif
