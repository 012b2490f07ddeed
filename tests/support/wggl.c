/* SPDX-License-Identifier: MIT */
/* The headless GL context of wggl.h. libEGL.so.1 is opened with dlopen and every EGL and GL entry
 * point is looked up by name, so the test binaries link against nothing of GL and a machine
 * without a driver gets a reason to print instead of a loader error. The display is Mesa's
 * surfaceless platform (no window system, no device files needed by llvmpipe), else the
 * first device of EGL_EXT_device_enumeration, else the default display; the context is OpenGL
 * 3.3 core without a config or surface (EGL_KHR_surfaceless_context), drawing into its own
 * framebuffer object. One context per process, current on the thread that opened it. */
#include "wggl.h"

#include "wgtest.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>
#include <dlfcn.h>
#include <link.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EGL_FUNCS(X)                                                                               \
    X(PFNEGLGETPROCADDRESSPROC, eglGetProcAddress)                                                 \
    X(PFNEGLGETERRORPROC, eglGetError)                                                             \
    X(PFNEGLQUERYSTRINGPROC, eglQueryString)                                                       \
    X(PFNEGLGETDISPLAYPROC, eglGetDisplay)                                                         \
    X(PFNEGLINITIALIZEPROC, eglInitialize)                                                         \
    X(PFNEGLTERMINATEPROC, eglTerminate)                                                           \
    X(PFNEGLBINDAPIPROC, eglBindAPI)                                                               \
    X(PFNEGLCREATECONTEXTPROC, eglCreateContext)                                                   \
    X(PFNEGLDESTROYCONTEXTPROC, eglDestroyContext)                                                 \
    X(PFNEGLMAKECURRENTPROC, eglMakeCurrent)                                                       \
    X(PFNEGLRELEASETHREADPROC, eglReleaseThread)

#define GL_FUNCS(X)                                                                                \
    X(PFNGLGETSTRINGPROC, glGetString)                                                             \
    X(PFNGLGETERRORPROC, glGetError)                                                               \
    X(PFNGLCREATESHADERPROC, glCreateShader)                                                       \
    X(PFNGLSHADERSOURCEPROC, glShaderSource)                                                       \
    X(PFNGLCOMPILESHADERPROC, glCompileShader)                                                     \
    X(PFNGLGETSHADERIVPROC, glGetShaderiv)                                                         \
    X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)                                               \
    X(PFNGLDELETESHADERPROC, glDeleteShader)                                                       \
    X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                                                     \
    X(PFNGLATTACHSHADERPROC, glAttachShader)                                                       \
    X(PFNGLLINKPROGRAMPROC, glLinkProgram)                                                         \
    X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                                                       \
    X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)                                             \
    X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                                                     \
    X(PFNGLUSEPROGRAMPROC, glUseProgram)                                                           \
    X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)                                           \
    X(PFNGLGETACTIVEUNIFORMPROC, glGetActiveUniform)                                               \
    X(PFNGLUNIFORM1FPROC, glUniform1f)                                                             \
    X(PFNGLUNIFORM3FPROC, glUniform3f)                                                             \
    X(PFNGLUNIFORM1IPROC, glUniform1i)                                                             \
    X(PFNGLGENTEXTURESPROC, glGenTextures)                                                         \
    X(PFNGLDELETETEXTURESPROC, glDeleteTextures)                                                   \
    X(PFNGLBINDTEXTUREPROC, glBindTexture)                                                         \
    X(PFNGLACTIVETEXTUREPROC, glActiveTexture)                                                     \
    X(PFNGLTEXIMAGE2DPROC, glTexImage2D)                                                           \
    X(PFNGLTEXPARAMETERIPROC, glTexParameteri)                                                     \
    X(PFNGLPIXELSTOREIPROC, glPixelStorei)                                                         \
    X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                                                 \
    X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)                                           \
    X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                                                 \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, glFramebufferTexture2D)                                       \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus)                                   \
    X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                                                 \
    X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)                                           \
    X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                                                 \
    X(PFNGLGENBUFFERSPROC, glGenBuffers)                                                           \
    X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                                                     \
    X(PFNGLBINDBUFFERPROC, glBindBuffer)                                                           \
    X(PFNGLBUFFERDATAPROC, glBufferData)                                                           \
    X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)                                         \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray)                                 \
    X(PFNGLVIEWPORTPROC, glViewport)                                                               \
    X(PFNGLCLEARCOLORPROC, glClearColor)                                                           \
    X(PFNGLCLEARPROC, glClear)                                                                     \
    X(PFNGLDISABLEPROC, glDisable)                                                                 \
    X(PFNGLDRAWARRAYSPROC, glDrawArrays)                                                           \
    X(PFNGLREADPIXELSPROC, glReadPixels)                                                           \
    X(PFNGLFINISHPROC, glFinish)

#define DECLARE(type, name) static type p_##name;
EGL_FUNCS(DECLARE)
GL_FUNCS(DECLARE)
#undef DECLARE

/* Textures are made and the render target bound on this unit, so that making one never unbinds
 * a texture a sampler reads (GL 3.3 has at least 48 units). */
#define SCRATCH_UNIT (GL_TEXTURE0 + 47)

static void *egl_lib;
static EGLDisplay display = EGL_NO_DISPLAY;
static EGLContext context = EGL_NO_CONTEXT;
static const char *display_kind = "";

static bool give_up(char *why, size_t n, const char *fmt, const char *arg)
{
    snprintf(why, n, fmt, arg);
    wgt_gl_close();
    return false;
}

static EGLDisplay open_display(char *why, size_t n)
{
    const char *ext = p_eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform =
        (PFNEGLGETPLATFORMDISPLAYEXTPROC)p_eglGetProcAddress("eglGetPlatformDisplayEXT");
    EGLint major, minor;
    if (ext && get_platform && strstr(ext, "EGL_MESA_platform_surfaceless")) {
        EGLDisplay d = get_platform(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
        if (d != EGL_NO_DISPLAY && p_eglInitialize(d, &major, &minor)) {
            display_kind = "surfaceless platform";
            return d;
        }
    }
    PFNEGLQUERYDEVICESEXTPROC query_devices =
        (PFNEGLQUERYDEVICESEXTPROC)p_eglGetProcAddress("eglQueryDevicesEXT");
    if (ext && get_platform && query_devices && strstr(ext, "EGL_EXT_platform_device")) {
        EGLDeviceEXT devices[16];
        EGLint count = 0;
        if (query_devices(16, devices, &count))
            for (EGLint i = 0; i < count; i++) {
                EGLDisplay d = get_platform(EGL_PLATFORM_DEVICE_EXT, devices[i], NULL);
                if (d != EGL_NO_DISPLAY && p_eglInitialize(d, &major, &minor)) {
                    display_kind = "EGL device";
                    return d;
                }
            }
    }
    EGLDisplay d = p_eglGetDisplay(EGL_DEFAULT_DISPLAY);
    if (d != EGL_NO_DISPLAY && p_eglInitialize(d, &major, &minor)) {
        display_kind = "default display";
        return d;
    }
    snprintf(why, n,
             "no EGL display (surfaceless, device or default) could be initialised "
             "(EGL error 0x%x): no GL driver; install libegl-mesa0 and libgl1-mesa-dri",
             (unsigned)p_eglGetError());
    return EGL_NO_DISPLAY;
}

/* Keep every library the driver loaded mapped until the process ends (RTLD_NODELETE): GLVND
 * unloads the vendor library at exit, and LeakSanitizer, which reports after that, could then
 * neither name nor suppress the allocations Mesa keeps for the process's life. */
static int pin_library(struct dl_phdr_info *info, size_t size, void *user)
{
    (void)size, (void)user;
    const char *name = info->dlpi_name;
    if (name && (strstr(name, "_dri.so") || strstr(name, "libEGL_mesa") ||
                 strstr(name, "libglapi") || strstr(name, "libgallium")))
        dlopen(name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    return 0;
}

bool wgt_gl_open(char *why, size_t n)
{
    /* llvmpipe: the same rasteriser on every machine, and no GPU device files needed */
    setenv("LIBGL_ALWAYS_SOFTWARE", "1", 0);
    setenv("GALLIUM_DRIVER", "llvmpipe", 0);
    setenv("MESA_SHADER_CACHE_DISABLE", "true", 0); /* nothing written under $HOME */
    egl_lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!egl_lib)
        return give_up(why, n, "cannot load libEGL.so.1 (%s): install libegl1", dlerror());
#define LOAD_EGL(type, name)                                                                       \
    if (!(p_##name = (type)dlsym(egl_lib, #name)))                                                 \
        return give_up(why, n, "libEGL.so.1 has no %s", #name);
    EGL_FUNCS(LOAD_EGL)
#undef LOAD_EGL
    display = open_display(why, n);
    if (display == EGL_NO_DISPLAY) {
        wgt_gl_close();
        return false;
    }
    const char *dext = p_eglQueryString(display, EGL_EXTENSIONS);
    if (!dext || !strstr(dext, "EGL_KHR_surfaceless_context") ||
        !strstr(dext, "EGL_KHR_no_config_context"))
        return give_up(why, n, "the EGL display (%s) lacks surfaceless or config-less contexts",
                       p_eglQueryString(display, EGL_VENDOR));
    if (!p_eglBindAPI(EGL_OPENGL_API))
        return give_up(why, n, "%s", "the EGL display has no desktop OpenGL");
    const EGLint attrs[] = {EGL_CONTEXT_MAJOR_VERSION,
                            3,
                            EGL_CONTEXT_MINOR_VERSION,
                            3,
                            EGL_CONTEXT_OPENGL_PROFILE_MASK,
                            EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                            EGL_NONE};
    context = p_eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attrs);
    if (context == EGL_NO_CONTEXT)
        return give_up(why, n, "%s", "no OpenGL 3.3 core context on the EGL display");
    if (!p_eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
        return give_up(why, n, "%s", "cannot make the OpenGL context current without a surface");
    dl_iterate_phdr(pin_library, NULL);
#define LOAD_GL(type, name)                                                                        \
    if (!(p_##name = (type)p_eglGetProcAddress(#name)))                                            \
        return give_up(why, n, "the GL driver has no %s", #name);
    GL_FUNCS(LOAD_GL)
#undef LOAD_GL
    return true;
}

void wgt_gl_close(void)
{
    if (display != EGL_NO_DISPLAY) {
        p_eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (context != EGL_NO_CONTEXT) p_eglDestroyContext(display, context);
        p_eglTerminate(display);
        p_eglReleaseThread();
    }
    context = EGL_NO_CONTEXT;
    display = EGL_NO_DISPLAY;
    /* libEGL stays loaded: Mesa registers exit handlers that unloading would leave dangling */
}

const char *wgt_gl_describe(void)
{
    static char text[256];
    snprintf(text, sizeof text, "%s, %s (EGL %s)", (const char *)p_glGetString(GL_RENDERER),
             (const char *)p_glGetString(GL_VERSION), display_kind);
    return text;
}

static GLuint compile(GLenum kind, const char *text, const char *what)
{
    GLuint s = p_glCreateShader(kind);
    p_glShaderSource(s, 1, &text, NULL);
    p_glCompileShader(s);
    GLint ok = 0;
    p_glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[4096] = "";
        p_glGetShaderInfoLog(s, sizeof log, NULL, log);
        fail_msg("%s does not compile on the GL driver: %s", what, log);
    }
    return s;
}

unsigned wgt_gl_program(const char *vertex_text, const char *fragment_path)
{
    char *frag = wgt_read_file(fragment_path, NULL);
    GLuint vs = compile(GL_VERTEX_SHADER, vertex_text, "the test's vertex shader");
    GLuint fs = compile(GL_FRAGMENT_SHADER, frag, fragment_path);
    free(frag);
    GLuint p = p_glCreateProgram();
    p_glAttachShader(p, vs);
    p_glAttachShader(p, fs);
    p_glLinkProgram(p);
    p_glDeleteShader(vs);
    p_glDeleteShader(fs);
    GLint ok = 0;
    p_glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[4096] = "";
        p_glGetProgramInfoLog(p, sizeof log, NULL, log);
        fail_msg("%s does not link with the test's vertex shader: %s", fragment_path, log);
    }
    return p;
}

int wgt_gl_samplers(unsigned program, const char **names, int max)
{
    static char buf[64][64];
    GLint count = 0, found = 0;
    p_glGetProgramiv(program, GL_ACTIVE_UNIFORMS, &count);
    for (GLint i = 0; i < count && found < max && found < 64; i++) {
        GLint size;
        GLenum type;
        p_glGetActiveUniform(program, (GLuint)i, sizeof buf[0], NULL, &size, &type, buf[found]);
        if (type == GL_SAMPLER_2D) names[found] = buf[found], found++;
    }
    return found;
}

unsigned wgt_gl_texture(const WgImage *img, int flags, const WgImage *const *levels, int n_levels)
{
    GLuint t;
    p_glGenTextures(1, &t);
    p_glActiveTexture(SCRATCH_UNIT); /* not a unit a sampler reads */
    p_glBindTexture(GL_TEXTURE_2D, t);
    p_glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    for (int l = 0; l <= n_levels; l++) {
        const WgImage *im = l ? levels[l - 1] : img;
        int w = im->width, h = im->height;
        float *px = malloc(sizeof(float) * 4 * (size_t)w * h);
        assert_non_null(px);
        for (int y = 0; y < h; y++) {
            const float *r = wg_image_row(im, (flags & WGT_GL_FLIP) ? h - 1 - y : y);
            float *o = px + 4 * (size_t)y * w;
            for (int x = 0; x < w; x++)
                if (im->channels == 1)
                    o[4 * x] = o[4 * x + 1] = o[4 * x + 2] = r[x], o[4 * x + 3] = 1;
                else
                    memcpy(o + 4 * x, r + 4 * x, 4 * sizeof(float));
        }
        p_glTexImage2D(GL_TEXTURE_2D, l, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, px);
        free(px);
    }
    GLint lin = (flags & WGT_GL_NEAREST) ? GL_NEAREST : GL_LINEAR;
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, 0);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, n_levels);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                      n_levels ? GL_LINEAR_MIPMAP_LINEAR : lin);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, lin);
    GLint ws = (flags & WGT_GL_CLAMP) ? GL_CLAMP_TO_EDGE : GL_REPEAT;
    GLint wt = (flags & (WGT_GL_CLAMP | WGT_GL_CLAMP_T)) ? GL_CLAMP_TO_EDGE : GL_REPEAT;
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, ws);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, wt);
    GLenum e = p_glGetError();
    if (e) fail_msg("GL error 0x%x making a %dx%d float texture", e, img->width, img->height);
    return t;
}

void wgt_gl_bind(unsigned program, const char *name, int unit, unsigned tex)
{
    p_glUseProgram(program);
    GLint loc = p_glGetUniformLocation(program, name);
    if (loc < 0) fail_msg("the shader has no active sampler %s", name);
    p_glActiveTexture(GL_TEXTURE0 + unit);
    p_glBindTexture(GL_TEXTURE_2D, tex);
    p_glUniform1i(loc, unit);
}

bool wgt_gl_set1f(unsigned program, const char *name, float x)
{
    p_glUseProgram(program);
    GLint loc = p_glGetUniformLocation(program, name);
    if (loc >= 0) p_glUniform1f(loc, x);
    return loc >= 0;
}

bool wgt_gl_set3f(unsigned program, const char *name, float x, float y, float z)
{
    p_glUseProgram(program);
    GLint loc = p_glGetUniformLocation(program, name);
    if (loc >= 0) p_glUniform3f(loc, x, y, z);
    return loc >= 0;
}

bool wgt_gl_set1i(unsigned program, const char *name, int x)
{
    p_glUseProgram(program);
    GLint loc = p_glGetUniformLocation(program, name);
    if (loc >= 0) p_glUniform1i(loc, x);
    return loc >= 0;
}

WgImage *wgt_gl_draw(unsigned program, const float *xy, int n_vertices, int w, int h, bool flip)
{
    GLuint target, fbo, vao, vbo;
    p_glGenTextures(1, &target);
    p_glActiveTexture(SCRATCH_UNIT);
    p_glBindTexture(GL_TEXTURE_2D, target);
    p_glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, w, h, 0, GL_RGBA, GL_FLOAT, NULL);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    p_glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    p_glGenFramebuffers(1, &fbo);
    p_glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    p_glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target, 0);
    GLenum status = p_glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        fail_msg("a GL_RGBA32F framebuffer is not complete (status 0x%x)", status);
    p_glGenVertexArrays(1, &vao);
    p_glBindVertexArray(vao);
    p_glGenBuffers(1, &vbo);
    p_glBindBuffer(GL_ARRAY_BUFFER, vbo);
    p_glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(sizeof(float) * 2 * n_vertices), xy,
                   GL_STATIC_DRAW);
    p_glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, NULL);
    p_glEnableVertexAttribArray(0);
    p_glViewport(0, 0, w, h);
    p_glDisable(GL_DEPTH_TEST);
    p_glDisable(GL_CULL_FACE);
    p_glDisable(GL_BLEND);
    p_glClearColor(0, 0, 0, 0);
    p_glClear(GL_COLOR_BUFFER_BIT);
    p_glUseProgram(program);
    p_glDrawArrays(GL_TRIANGLES, 0, n_vertices);
    WgImage *out = wg_image_new(w, h, 4);
    assert_non_null(out);
    float *px = malloc(sizeof(float) * 4 * (size_t)w * h);
    assert_non_null(px);
    p_glPixelStorei(GL_PACK_ALIGNMENT, 4);
    p_glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, px);
    p_glFinish();
    GLenum e = p_glGetError();
    for (int y = 0; y < h; y++)
        memcpy(wg_image_row(out, flip ? h - 1 - y : y), px + 4 * (size_t)y * w,
               sizeof(float) * 4 * w);
    free(px);
    p_glBindFramebuffer(GL_FRAMEBUFFER, 0);
    p_glDeleteFramebuffers(1, &fbo);
    p_glDeleteTextures(1, &target);
    p_glDeleteBuffers(1, &vbo);
    p_glDeleteVertexArrays(1, &vao);
    if (e) fail_msg("GL error 0x%x drawing %dx%d", e, w, h);
    return out;
}

void wgt_gl_delete_program(unsigned program)
{
    p_glDeleteProgram(program);
}

void wgt_gl_delete_texture(unsigned tex)
{
    p_glDeleteTextures(1, &tex);
}
