/* glctx.c - OpenGL context creation (OSMesa, EGL device platform, GLFW window)
 * and per-context loading of the GL function table (see glctx.h for why the
 * table exists: libOSMesa and glvnd's libGL both export gl* symbols).
 *
 * OSMesa renders into a tiny client buffer that prt never reads: all real
 * rendering goes to framebuffer objects, so the same code runs on every kind.
 * EGL uses the device platform (EGL_EXT_platform_device) with no surface
 * (EGL_KHR_surfaceless_context, else a 1x1 pbuffer), which is how NVIDIA
 * drivers render with no X server. */
#include "glctx.h"
#include <GL/osmesa.h>
#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <ctype.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

/* LeakSanitizer: Mesa keeps per-process caches that it never frees (OSMesa's framebuffer list,
 * llvmpipe's JIT state, EGL's device list); under SAN=1 they would be reported as leaks of every
 * program that draws. This hook (read by LSan only, a constant string) suppresses leaks whose
 * stack lies inside those libraries, never prt's own allocations. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) {
    return "leak:libOSMesa.so\nleak:libgallium\nleak:libLLVM\nleak:libEGL_mesa.so\nleak:libGLX_mesa.so\n"
           "leak:libglapi.so\nleak:libglfw.so\nleak:libX11.so\nleak:libEGL.so\nleak:libGLdispatch.so\n";
}

typedef void (*glctx_proc)(void);
typedef glctx_proc (*glctx_loader)(const char *name);

static glctx_proc load_osmesa(const char *name) { return (glctx_proc)OSMesaGetProcAddress(name); }
static glctx_proc load_egl(const char *name) { return (glctx_proc)eglGetProcAddress(name); }
static glctx_proc load_glfw(const char *name) { return (glctx_proc)glfwGetProcAddress(name); }

/* Static name of a kind. */
/* See glctx.h: Mesa names its software rasterizers in GL_RENDERER ("llvmpipe (LLVM 15.0.6, 256 bits)"). */
bool glctx_software(const glctx *ctx) {
    static const char *const k_soft[] = { "llvmpipe", "softpipe", "swrast", "Software Rasterizer" };
    for (size_t i = 0; i < sizeof k_soft / sizeof k_soft[0]; i++)
        if (strstr(ctx->renderer, k_soft[i])) return true;
    return false;
}

const char *glctx_kind_name(glctx_kind k) {
    switch (k) {
    case GLCTX_OSMESA: return "osmesa";
    case GLCTX_EGL: return "egl";
    case GLCTX_GLFW: return "glfw";
    default: return "auto";
    }
}

/* Kind from its name; -1 if unknown (*out untouched). */
int glctx_parse_kind(const char *s, glctx_kind *out) {
    if (!s) return -1;
    if (!strcasecmp(s, "osmesa")) *out = GLCTX_OSMESA;
    else if (!strcasecmp(s, "egl")) *out = GLCTX_EGL;
    else if (!strcasecmp(s, "auto") || !*s) *out = GLCTX_AUTO;
    else return -1;
    return 0;
}

/* True when an NVIDIA GPU device node exists (EGL is then the headless path). */
static bool have_nvidia(void) { return access("/dev/nvidia0", F_OK) == 0; }

/* What GLCTX_AUTO means here: $PRT_GL, else EGL with /dev/nvidia0, else OSMesa. */
int glctx_resolve_auto(glctx_kind *out, prt_error *err) {
    const char *e = getenv("PRT_GL");
    if (e && *e) {
        glctx_kind k;
        if (glctx_parse_kind(e, &k)) return prt_fail(err, "PRT_GL=%s: unknown GL backend (use osmesa or egl)", e);
        if (k != GLCTX_AUTO) { *out = k; return 0; }
    }
    *out = have_nvidia() ? GLCTX_EGL : GLCTX_OSMESA;
    return 0;
}

/* $PRT_GL when set, else dflt; -1 with err for an unknown name. */
int glctx_kind_from_env(glctx_kind dflt, glctx_kind *out, prt_error *err) {
    const char *e = getenv("PRT_GL");
    if (!e || !*e) { *out = dflt; return 0; }
    if (glctx_parse_kind(e, out)) return prt_fail(err, "PRT_GL=%s: unknown GL backend (use osmesa or egl)", e);
    return 0;
}

/* Loads every entry point of the table; returns -1 naming the first missing required one. */
static int load_table(glctx *c, glctx_loader load, prt_error *err) {
    gl_api *gl = &c->gl;
#define GLCTX_LOAD_(type, name) gl->name = (type)load("gl" #name); \
    if (!gl->name) return prt_fail(err, "GL context (%s): missing entry point gl%s", glctx_kind_name(c->kind), #name);
    GLCTX_FUNCS(GLCTX_LOAD_)
#undef GLCTX_LOAD_
#define GLCTX_LOAD43_(type, name) gl->name = (type)load("gl" #name);
    GLCTX_FUNCS_43(GLCTX_LOAD43_)
#undef GLCTX_LOAD43_
    return 0;
}

/* After the table is loaded: reads the version and refuses contexts below 3.3. */
static int query_version(glctx *c, prt_error *err) {
    const gl_api *gl = &c->gl;
    const char *v = (const char *)gl->GetString(GL_VERSION);
    const char *r = (const char *)gl->GetString(GL_RENDERER);
    snprintf(c->version, sizeof c->version, "%s", v ? v : "?");
    snprintf(c->renderer, sizeof c->renderer, "%s", r ? r : "?");
    GLint ma = 0, mi = 0, mask = 0;
    gl->GetIntegerv(GL_MAJOR_VERSION, &ma);
    gl->GetIntegerv(GL_MINOR_VERSION, &mi);
    if (gl->GetError() != GL_NO_ERROR || ma == 0) {
        ma = 0; mi = 0;
        if (v) sscanf(v, "%d.%d", &ma, &mi);
    }
    c->major = ma;
    c->minor = mi;
    if (ma > 3 || (ma == 3 && mi >= 2)) {
        gl->GetIntegerv(GL_CONTEXT_PROFILE_MASK, &mask);
        c->core = (mask & GL_CONTEXT_CORE_PROFILE_BIT) != 0;
    }
    while (gl->GetError() != GL_NO_ERROR) {}
    if (ma < 3 || (ma == 3 && mi < 3))
        return prt_fail(err, "GL context (%s): OpenGL %d.%d (%s) is below the 3.3 prt needs",
                        glctx_kind_name(c->kind), ma, mi, c->renderer);
    c->has_compute = (ma > 4 || (ma == 4 && mi >= 3)) && c->gl.DispatchCompute && c->gl.MemoryBarrier;
    return 0;
}

static const int k_versions[][2] = { { 4, 5 }, { 4, 3 }, { 3, 3 } };
#define NVERSIONS ((int)(sizeof k_versions / sizeof k_versions[0]))

/* OSMesa context, core 4.5/4.3/3.3 else legacy, made current; -1 with err. */
static int create_osmesa(glctx *c, prt_error *err) {
    OSMesaContext ctx = NULL;
    for (int i = 0; i < NVERSIONS && !ctx; i++) {
        const int attr[] = { OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                             OSMESA_CONTEXT_MAJOR_VERSION, k_versions[i][0], OSMESA_CONTEXT_MINOR_VERSION,
                             k_versions[i][1], 0 };
        ctx = OSMesaCreateContextAttribs(attr, NULL);
    }
    if (!ctx) ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, NULL); /* legacy: compat profile */
    if (!ctx) return prt_fail(err, "GL context (osmesa): OSMesaCreateContext failed (is libosmesa6 installed?)");
    c->osmesa = ctx;
    /* A 4x4 client buffer: rendering goes to FBOs, this only satisfies MakeCurrent. */
    c->osmesa_buf = calloc(4 * 4 * 4, 1);
    if (!c->osmesa_buf) return prt_fail(err, "GL context (osmesa): out of memory");
    if (!OSMesaMakeCurrent(ctx, c->osmesa_buf, GL_UNSIGNED_BYTE, 4, 4))
        return prt_fail(err, "GL context (osmesa): OSMesaMakeCurrent failed");
    if (load_table(c, load_osmesa, err)) return -1;
    return query_version(c, err);
}

/* True when the space-separated extension list holds name exactly. */
static bool has_ext(const char *list, const char *name) {
    if (!list) return false;
    size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)); p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == 0)) return true;
    return false;
}

/* Tries one EGL display: initialize, create a core context, make it current. */
static int egl_try_display(glctx *c, EGLDisplay dpy, prt_error *err) {
    EGLint ma = 0, mi = 0;
    if (!eglInitialize(dpy, &ma, &mi)) return prt_fail(err, "GL context (egl): eglInitialize failed (0x%x)", eglGetError());
    if (!eglBindAPI(EGL_OPENGL_API)) return prt_fail(err, "GL context (egl): desktop OpenGL API not available");
    const char *ext = eglQueryString(dpy, EGL_EXTENSIONS);
    EGLConfig cfg = NULL;
    EGLint ncfg = 0;
    const EGLint cattr[] = { EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                             EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE };
    if (!eglChooseConfig(dpy, cattr, &cfg, 1, &ncfg) || ncfg < 1) {
        if (!has_ext(ext, "EGL_KHR_no_config_context") && !has_ext(ext, "EGL_MESA_configless_context"))
            return prt_fail(err, "GL context (egl): no pbuffer-capable OpenGL config");
        cfg = (EGLConfig)0; /* EGL_NO_CONFIG_KHR */
    }
    EGLContext ctx = EGL_NO_CONTEXT;
    for (int i = 0; i < NVERSIONS && ctx == EGL_NO_CONTEXT; i++) {
        const EGLint attr[] = { EGL_CONTEXT_MAJOR_VERSION, k_versions[i][0], EGL_CONTEXT_MINOR_VERSION, k_versions[i][1],
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE };
        ctx = eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, attr);
    }
    if (ctx == EGL_NO_CONTEXT) return prt_fail(err, "GL context (egl): eglCreateContext failed (0x%x)", eglGetError());
    EGLSurface surf = EGL_NO_SURFACE;
    if (!has_ext(ext, "EGL_KHR_surfaceless_context") && cfg) {
        const EGLint pattr[] = { EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE };
        surf = eglCreatePbufferSurface(dpy, cfg, pattr);
    }
    if (!eglMakeCurrent(dpy, surf, surf, ctx)) {
        eglDestroyContext(dpy, ctx);
        return prt_fail(err, "GL context (egl): eglMakeCurrent failed (0x%x)", eglGetError());
    }
    c->egl_display = dpy;
    c->egl_context = ctx;
    if (load_table(c, load_egl, err)) return -1;
    return query_version(c, err);
}

/* EGL device-platform context (hardware devices first; software only when allowed); -1 with err. */
static int create_egl(glctx *c, bool require_hw, prt_error *err) {
    PFNEGLQUERYDEVICESEXTPROC query_devices = (PFNEGLQUERYDEVICESEXTPROC)eglGetProcAddress("eglQueryDevicesEXT");
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_display =
        (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
    PFNEGLQUERYDEVICESTRINGEXTPROC device_string =
        (PFNEGLQUERYDEVICESTRINGEXTPROC)eglGetProcAddress("eglQueryDeviceStringEXT");
    prt_error last = { "GL context (egl): no EGL device found" };
    if (query_devices && get_display) {
        EGLDeviceEXT devs[16];
        EGLint n = 0;
        if (!query_devices(16, devs, &n)) n = 0;
        /* Hardware devices first; Mesa's software device only when no GPU is required. */
        for (int pass = 0; pass < 2; pass++) {
            for (int i = 0; i < n; i++) {
                const char *dext = device_string ? device_string(devs[i], EGL_EXTENSIONS) : NULL;
                bool sw = has_ext(dext, "EGL_MESA_device_software");
                if (sw != (pass == 1) || (sw && require_hw)) continue;
                EGLDisplay dpy = get_display(EGL_PLATFORM_DEVICE_EXT, devs[i], NULL);
                if (dpy == EGL_NO_DISPLAY) continue;
                if (egl_try_display(c, dpy, &last) == 0) return 0;
                if (c->egl_context) return prt_fail(err, "%s", last.msg); /* context made but unusable */
            }
        }
    }
    if (require_hw)
        return prt_fail(err, "%s (an NVIDIA GPU is present but its EGL device did not work; set PRT_GL=osmesa for software)",
                        last.msg);
    if (get_display) {
        EGLDisplay dpy = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
        if (dpy != EGL_NO_DISPLAY && egl_try_display(c, dpy, &last) == 0) return 0;
    }
    return prt_fail(err, "%s", last.msg);
}

/* GLFW window with a core context, made current; -1 with err (no display, no GL 3.3). */
static int create_glfw(glctx *c, const glctx_window_desc *wd, prt_error *err) {
    const char *desc = NULL;
    if (!getenv("DISPLAY") && !getenv("WAYLAND_DISPLAY"))
        return prt_fail(err, "cannot open a window: no display (DISPLAY is not set; use xvfb-run on a machine without one)");
    if (!glfwInit()) {
        glfwGetError(&desc);
        return prt_fail(err, "cannot open a window: %s", desc ? desc : "glfwInit failed");
    }
    int w = wd && wd->width > 0 ? wd->width : 1024, h = wd && wd->height > 0 ? wd->height : 768;
    GLFWwindow *win = NULL;
    for (int i = 0; i < NVERSIONS && !win; i++) {
        glfwDefaultWindowHints();
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, k_versions[i][0]);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, k_versions[i][1]);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        glfwWindowHint(GLFW_VISIBLE, wd && !wd->visible ? GLFW_FALSE : GLFW_TRUE);
        glfwWindowHint(GLFW_DEPTH_BITS, 24);
        win = glfwCreateWindow(w, h, wd && wd->title ? wd->title : "prt", NULL, NULL);
    }
    if (!win) {
        glfwGetError(&desc);
        prt_fail(err, "cannot open a window: %s", desc ? desc : "glfwCreateWindow failed");
        glfwTerminate();
        return -1;
    }
    c->window = win;
    glfwMakeContextCurrent(win);
    if (load_table(c, load_glfw, err)) return -1;
    return query_version(c, err);
}

/* See glctx.h. The caller owns the context (glctx_destroy). */
glctx *glctx_create(glctx_kind kind, const glctx_window_desc *window, prt_error *err) {
    bool require_hw = false;
    if (kind == GLCTX_AUTO) {
        if (glctx_resolve_auto(&kind, err)) return NULL;
        const char *e = getenv("PRT_GL");
        require_hw = kind == GLCTX_EGL && !(e && *e) && have_nvidia();
    }
    glctx *c = prt_calloc(1, sizeof *c, err);
    if (!c) return NULL;
    c->kind = kind;
    int rc;
    switch (kind) {
    case GLCTX_OSMESA: rc = create_osmesa(c, err); break;
    case GLCTX_EGL: rc = create_egl(c, require_hw, err); break;
    case GLCTX_GLFW: rc = create_glfw(c, window, err); break;
    default: rc = prt_fail(err, "GL context: unknown kind %d", (int)kind); break;
    }
    if (rc) {
        glctx_destroy(c);
        return NULL;
    }
    return c;
}

/* Makes c current on this thread; -1 with err (err may be NULL). */
int glctx_make_current(glctx *c, prt_error *err) {
    bool ok = true;
    switch (c->kind) {
    case GLCTX_OSMESA: ok = OSMesaMakeCurrent((OSMesaContext)c->osmesa, c->osmesa_buf, GL_UNSIGNED_BYTE, 4, 4); break;
    case GLCTX_EGL: ok = eglMakeCurrent(c->egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, c->egl_context); break;
    case GLCTX_GLFW: glfwMakeContextCurrent((GLFWwindow *)c->window); break;
    default: ok = false;
    }
    return ok ? 0 : prt_fail(err, "GL context (%s): cannot make current", glctx_kind_name(c->kind));
}

/* Frees the context and its window; NULL is fine. */
void glctx_destroy(glctx *c) {
    if (!c) return;
    if (c->osmesa) {
        OSMesaMakeCurrent(NULL, NULL, 0, 0, 0); /* releases the client buffer's framebuffer */
        OSMesaDestroyContext((OSMesaContext)c->osmesa);
    }
    free(c->osmesa_buf);
    if (c->egl_context) {
        eglMakeCurrent(c->egl_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(c->egl_display, c->egl_context);
        eglReleaseThread();
        /* No eglTerminate: the display is a per-device singleton another context may still use. */
    }
    if (c->kind == GLCTX_GLFW) {
        if (c->window) glfwDestroyWindow((GLFWwindow *)c->window);
        /* No glfwTerminate: it closes the X display, which unloads Mesa's driver, whose own
         * allocations LeakSanitizer then reports as leaks (their owner is unmapped). GLFW stays
         * initialized (a later glfwInit is a no-op); the display closes at process exit. */
    }
    free(c);
}

/* Compiles one shader stage; returns 0 with err set on failure. */
static GLuint compile(const gl_api *gl, GLenum type, const char *src, const char *name, prt_error *err) {
    GLuint s = gl->CreateShader(type);
    gl->ShaderSource(s, 1, &src, NULL);
    gl->CompileShader(s);
    GLint ok = 0;
    gl->GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[2048] = "";
        gl->GetShaderInfoLog(s, sizeof log, NULL, log);
        gl->DeleteShader(s);
        prt_fail(err, "GL shader %s (%s) failed to compile: %.700s", name,
                 type == GL_VERTEX_SHADER ? "vertex" : type == GL_FRAGMENT_SHADER ? "fragment" : "compute", log);
        return 0;
    }
    return s;
}

/* Links the compiled stages (deleting them); 0 with err holding the log. */
static GLuint link_program(const gl_api *gl, GLuint *sh, int n, const char *name, prt_error *err) {
    GLuint p = gl->CreateProgram();
    for (int i = 0; i < n; i++) gl->AttachShader(p, sh[i]);
    gl->LinkProgram(p);
    for (int i = 0; i < n; i++) gl->DeleteShader(sh[i]);
    GLint ok = 0;
    gl->GetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[2048] = "";
        gl->GetProgramInfoLog(p, sizeof log, NULL, log);
        gl->DeleteProgram(p);
        prt_fail(err, "GL program %s failed to link: %.700s", name, log);
        return 0;
    }
    return p;
}

GLuint glctx_program(const gl_api *gl, const char *vs, const char *fs, const char *name, prt_error *err) {
    GLuint sh[2];
    if (!(sh[0] = compile(gl, GL_VERTEX_SHADER, vs, name, err))) return 0;
    if (!(sh[1] = compile(gl, GL_FRAGMENT_SHADER, fs, name, err))) {
        gl->DeleteShader(sh[0]);
        return 0;
    }
    return link_program(gl, sh, 2, name, err);
}

GLuint glctx_compute_program(const gl_api *gl, const char *cs, const char *name, prt_error *err) {
    GLuint sh[1];
    if (!(sh[0] = compile(gl, GL_COMPUTE_SHADER, cs, name, err))) return 0;
    return link_program(gl, sh, 1, name, err);
}

/* Drains glGetError; -1 with err naming `what` and the first error. */
int glctx_check(const gl_api *gl, const char *what, prt_error *err) {
    GLenum e = gl->GetError(), first = e;
    while (e != GL_NO_ERROR) e = gl->GetError();
    if (first == GL_NO_ERROR) return 0;
    const char *s = first == GL_OUT_OF_MEMORY ? "out of GPU memory" : first == GL_INVALID_OPERATION ? "invalid operation"
                  : first == GL_INVALID_VALUE ? "invalid value" : first == GL_INVALID_ENUM ? "invalid enum"
                  : first == GL_INVALID_FRAMEBUFFER_OPERATION ? "incomplete framebuffer" : "error";
    return prt_fail(err, "GL %s: %s (0x%x)", what, s, first);
}
