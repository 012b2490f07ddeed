/* SPDX-License-Identifier: MIT */
/* A headless OpenGL 3.3 core context for the tests that execute the GLSL shaders of
 * docs/shaders: EGL without a window (Mesa's surfaceless platform, else the first EGL device),
 * on Mesa's software rasteriser llvmpipe (the test environment sets LIBGL_ALWAYS_SOFTWARE and
 * GALLIUM_DRIVER). libEGL is opened at run time and every GL function comes from
 * eglGetProcAddress, so a machine without a GL driver still runs the test binary, which then
 * skips with the reason wgt_gl_open gives. Renders go to a float framebuffer (GL_RGBA32F, colour-
 * renderable in core GL 3.0 and later) that is read back unquantised. */
#ifndef WGGL_H
#define WGGL_H

#include <stdbool.h>
#include <stddef.h>

#include <wetgraph/wetgraph.h>

/* Create the context and make it current on this thread. Returns false with a one-line reason
 * in why (no libEGL, no display, no OpenGL 3.3 core context, no float render target). */
bool wgt_gl_open(char *why, size_t why_size);
/* Release the context (safe when wgt_gl_open failed). */
void wgt_gl_close(void);
/* "renderer, version" of the current context, for the test log. */
const char *wgt_gl_describe(void);

/* Program from a vertex shader's text and a fragment shader's file; fails the test with the
 * compiler's log on an error. */
unsigned wgt_gl_program(const char *vertex_text, const char *fragment_path);
/* The program's active sampler uniforms, by name, for checking that a test binds every one:
 * fills names (up to max) and returns how many there are. Names point into a static buffer valid
 * until the next call. */
int wgt_gl_samplers(unsigned program, const char **names, int max);

enum {
    WGT_GL_FLIP = 1,    /* upload the image's last row first (row 0 at the texture's top) */
    WGT_GL_CLAMP_T = 2, /* clamp t (default: repeat both) */
    WGT_GL_CLAMP = 4,   /* clamp s and t */
    WGT_GL_NEAREST = 8, /* nearest filtering (default: linear) */
};
/* RGBA32F texture of a 1- or 4-channel image (gray goes to r; g, b = r, a = 1). levels (may be
 * NULL, n_levels 0) are the mip levels 1.. in order, each half the previous (trilinear filtering
 * then). Returns the texture name. */
unsigned wgt_gl_texture(const WgImage *img, int flags, const WgImage *const *levels, int n_levels);
/* Bind texture tex to the program's sampler `name` on texture unit `unit`; fails the test if the
 * program has no such active sampler. */
void wgt_gl_bind(unsigned program, const char *name, int unit, unsigned tex);
/* Set a float/vec3/int uniform by name; returns false when the program does not use it. */
bool wgt_gl_set1f(unsigned program, const char *name, float x);
bool wgt_gl_set3f(unsigned program, const char *name, float x, float y, float z);
bool wgt_gl_set1i(unsigned program, const char *name, int x);

/* Draw triangles (n_vertices 2D positions, attribute location 0) with the program into a w x h
 * float framebuffer cleared to 0 and read it back: a new 4-channel image whose row 0 is the
 * framebuffer's top row when flip, its bottom row otherwise (glReadPixels order). */
WgImage *wgt_gl_draw(unsigned program, const float *xy, int n_vertices, int w, int h, bool flip);
/* Delete a program or texture made above. */
void wgt_gl_delete_program(unsigned program);
void wgt_gl_delete_texture(unsigned tex);

#endif
