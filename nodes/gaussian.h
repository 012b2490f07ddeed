/* SPDX-License-Identifier: MIT */
/* The fast periodic Gaussian of `blur` (nodes/blur.c: a direct sum below 3 px, an FFT
 * convolution above; within a few 1e-7 of the largest |value| of the exact one), for nodes that
 * blur as one of their steps. */
#ifndef WG_NODES_GAUSSIAN_H
#define WG_NODES_GAUSSIAN_H

#include "wetgraph/node.h"

/* out = in blurred by σ = sigma_px pixels along both axes, wrapping; out has in's size and
 * channels and must not alias it. σ = 0 copies. */
int wg__gaussian_fast(WgNodeContext *ctx, const WgImage *in, WgImage *out, double sigma_px,
                      WgError *err);

/* Working memory wg__gaussian_fast takes beyond `out`, for a node's scratch_bytes. */
size_t wg__gaussian_fast_scratch(int width, int height, double sigma_px);

#endif
