/* glctx.h - OpenGL contexts (headless OSMesa / EGL, or a GLFW window) and the
 * GL function table every GL-facing module of prt calls through.
 *
 * Usage:
 *     prt_error err;
 *     glctx *ctx = glctx_create(GLCTX_AUTO, NULL, &err);   // headless
 *     if (!ctx) { puts(err.msg); ... }
 *     const gl_api *gl = &ctx->gl;
 *     gl->ClearColor(0, 0, 0, 1);  ...
 *     glctx_destroy(ctx);
 *
 * Why a function table: prt links libOSMesa (a complete GL implementation that
 * exports every gl* symbol) and libGL/libEGL (glvnd) into one program. Which of
 * the two a direct glClear() call reaches depends on link order, so code that
 * called gl* directly would work with one kind of context and crash with the
 * other. Every function is therefore loaded per context (OSMesaGetProcAddress,
 * eglGetProcAddress, glfwGetProcAddress) into ctx->gl, and prt never calls a gl*
 * symbol directly. The table lives in the context (no global state).
 *
 * Kinds: GLCTX_OSMESA (software, Mesa llvmpipe; needs no display: the CI path),
 * GLCTX_EGL (EGL device platform, surfaceless: NVIDIA GPUs headless, or Mesa's
 * software device), GLCTX_GLFW (a window; needs a display or Xvfb).
 * GLCTX_AUTO picks $PRT_GL ("osmesa" or "egl") when set, else EGL when the
 * machine has /dev/nvidia0, else OSMesa. When EGL is picked because of the GPU
 * there is deliberately no silent fallback to software: a failure is an error
 * that names PRT_GL=osmesa as the way out (so GPU timings are never secretly
 * software timings).
 *
 * Versions: a core profile 4.5, 4.3 or 3.3 is requested (in that order; OSMesa
 * then tries its legacy entry point), and the context is refused below 3.3.
 * has_compute is true for 4.3+ (compute shaders and SSBOs).
 *
 * A context is current on the thread that created it (glctx_make_current moves
 * it). Errors: glctx_create returns NULL with one line in err. Ownership:
 * glctx_destroy frees everything, including a window. */
#ifndef PRT_GLCTX_H
#define PRT_GLCTX_H
#include "common.h"
#include <GL/glcorearb.h>

/* X-macro list of the GL entry points prt uses: X(type, Name) for glName. */
#define GLCTX_FUNCS(X) \
    X(PFNGLGETSTRINGPROC, GetString) X(PFNGLGETINTEGERVPROC, GetIntegerv) X(PFNGLGETERRORPROC, GetError) \
    X(PFNGLENABLEPROC, Enable) X(PFNGLDISABLEPROC, Disable) X(PFNGLVIEWPORTPROC, Viewport) \
    X(PFNGLSCISSORPROC, Scissor) X(PFNGLCLEARPROC, Clear) X(PFNGLCLEARCOLORPROC, ClearColor) \
    X(PFNGLCLEARDEPTHPROC, ClearDepth) X(PFNGLDEPTHFUNCPROC, DepthFunc) X(PFNGLDEPTHMASKPROC, DepthMask) \
    X(PFNGLBLENDFUNCPROC, BlendFunc) X(PFNGLFINISHPROC, Finish) X(PFNGLFLUSHPROC, Flush) \
    X(PFNGLREADPIXELSPROC, ReadPixels) X(PFNGLPIXELSTOREIPROC, PixelStorei) X(PFNGLREADBUFFERPROC, ReadBuffer) \
    X(PFNGLDRAWBUFFERPROC, DrawBuffer) X(PFNGLGENTEXTURESPROC, GenTextures) \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures) X(PFNGLBINDTEXTUREPROC, BindTexture) \
    X(PFNGLTEXIMAGE2DPROC, TexImage2D) X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D) \
    X(PFNGLTEXPARAMETERIPROC, TexParameteri) X(PFNGLACTIVETEXTUREPROC, ActiveTexture) \
    X(PFNGLTEXBUFFERPROC, TexBuffer) X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers) \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers) X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer) \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D) \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus) \
    X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers) X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers) \
    X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer) X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage) \
    X(PFNGLRENDERBUFFERSTORAGEMULTISAMPLEPROC, RenderbufferStorageMultisample) \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer) \
    X(PFNGLBLITFRAMEBUFFERPROC, BlitFramebuffer) X(PFNGLGENBUFFERSPROC, GenBuffers) \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers) X(PFNGLBINDBUFFERPROC, BindBuffer) \
    X(PFNGLBUFFERDATAPROC, BufferData) X(PFNGLBUFFERSUBDATAPROC, BufferSubData) \
    X(PFNGLBINDBUFFERBASEPROC, BindBufferBase) X(PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData) \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays) X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays) \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray) X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray) \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer) X(PFNGLVERTEXATTRIBIPOINTERPROC, VertexAttribIPointer) \
    X(PFNGLDRAWARRAYSPROC, DrawArrays) X(PFNGLDRAWELEMENTSPROC, DrawElements) \
    X(PFNGLCREATESHADERPROC, CreateShader) X(PFNGLSHADERSOURCEPROC, ShaderSource) \
    X(PFNGLCOMPILESHADERPROC, CompileShader) X(PFNGLGETSHADERIVPROC, GetShaderiv) \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog) X(PFNGLDELETESHADERPROC, DeleteShader) \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram) X(PFNGLATTACHSHADERPROC, AttachShader) \
    X(PFNGLLINKPROGRAMPROC, LinkProgram) X(PFNGLGETPROGRAMIVPROC, GetProgramiv) \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog) X(PFNGLDELETEPROGRAMPROC, DeleteProgram) \
    X(PFNGLUSEPROGRAMPROC, UseProgram) X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation) \
    X(PFNGLBINDFRAGDATALOCATIONPROC, BindFragDataLocation) \
    X(PFNGLUNIFORM1IPROC, Uniform1i) X(PFNGLUNIFORM1UIPROC, Uniform1ui) X(PFNGLUNIFORM1FPROC, Uniform1f) X(PFNGLUNIFORM2FPROC, Uniform2f) \
    X(PFNGLUNIFORM3FVPROC, Uniform3fv) X(PFNGLUNIFORM4FVPROC, Uniform4fv) X(PFNGLUNIFORM4IVPROC, Uniform4iv) \
    X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv) X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv) \
    X(PFNGLGENQUERIESPROC, GenQueries) X(PFNGLDELETEQUERIESPROC, DeleteQueries) \
    X(PFNGLBEGINQUERYPROC, BeginQuery) X(PFNGLENDQUERYPROC, EndQuery) \
    X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)

/* Entry points that only 4.3+ contexts must have (NULL otherwise). */
#define GLCTX_FUNCS_43(X) \
    X(PFNGLDISPATCHCOMPUTEPROC, DispatchCompute) X(PFNGLMEMORYBARRIERPROC, MemoryBarrier) \
    X(PFNGLMINSAMPLESHADINGPROC, MinSampleShading)

typedef struct gl_api {
#define GLCTX_MEMBER_(type, name) type name;
    GLCTX_FUNCS(GLCTX_MEMBER_)
    GLCTX_FUNCS_43(GLCTX_MEMBER_)
#undef GLCTX_MEMBER_
} gl_api;

typedef enum glctx_kind { GLCTX_AUTO = 0, GLCTX_OSMESA, GLCTX_EGL, GLCTX_GLFW } glctx_kind;

typedef struct glctx_window_desc {
    int width, height;      /* 0: 1024 x 768 */
    const char *title;      /* NULL: "prt" */
    bool visible;           /* false: hidden window (still needs a display) */
} glctx_window_desc;

typedef struct glctx {
    glctx_kind kind;        /* the kind actually created (never AUTO) */
    gl_api gl;
    int major, minor;       /* context version */
    bool core;              /* core profile */
    bool has_compute;       /* GL 4.3+: compute shaders, SSBOs */
    char version[128], renderer[128];
    /* Backend handles (opaque). */
    void *osmesa, *osmesa_buf;
    void *egl_display, *egl_context;
    void *window;           /* GLFWwindow */
} glctx;

/* Creates a context of the given kind (window may be NULL except for GLCTX_GLFW; AUTO is headless).
 * The context is current on return. Returns NULL with err set. */
glctx *glctx_create(glctx_kind kind, const glctx_window_desc *window, prt_error *err);
/* Makes ctx current on the calling thread. Returns 0 or -1. */
int glctx_make_current(glctx *ctx, prt_error *err);
void glctx_destroy(glctx *ctx);
/* "osmesa", "egl", "glfw", "auto". */
const char *glctx_kind_name(glctx_kind k);
/* Whether ctx's renderer rasterizes on the CPU (Mesa's llvmpipe, softpipe, swrast; GL_RENDERER):
 * there the GL backend's per-pixel programs run at a few frames per second. */
bool glctx_software(const glctx *ctx);
/* Parses "osmesa", "egl", "auto" (case-insensitive). Returns -1 if unknown. */
int glctx_parse_kind(const char *s, glctx_kind *out);
/* The kind GLCTX_AUTO resolves to on this machine ($PRT_GL, /dev/nvidia0). Returns -1 with err set
 * when $PRT_GL is set to something unknown. */
int glctx_resolve_auto(glctx_kind *out, prt_error *err);

/* The kind $PRT_GL names ("osmesa", "egl"; "auto" resolves as GLCTX_AUTO), else dflt. Returns -1
 * with err set when $PRT_GL is unknown. */
int glctx_kind_from_env(glctx_kind dflt, glctx_kind *out, prt_error *err);

/* Compiles and links a program from vertex + fragment source (each a complete shader, #version
 * included). Returns the program, or 0 with err holding the first line of the info log. */
GLuint glctx_program(const gl_api *gl, const char *vs, const char *fs, const char *name, prt_error *err);
/* Compiles and links a compute program (GL 4.3). Returns 0 with err set on failure. */
GLuint glctx_compute_program(const gl_api *gl, const char *cs, const char *name, prt_error *err);
/* Returns 0 if glGetError reports nothing, else -1 with err naming `what` and the GL error. */
int glctx_check(const gl_api *gl, const char *what, prt_error *err);
#endif
