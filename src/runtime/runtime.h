/* runtime.h - the runtime seam: relighting a precomputed .prt file under an
 * environment light, on any backend, through one interface (section 4.3).
 *
 * Usage:
 *     runtime_desc desc = { .backend = "gl" };          // zero = defaults: "cpu", all threads, all terms
 *     prt_runtime *rt = runtime_create(&data, &desc, &err);   // data is SHARED: keep it alive
 *     runtime_set_light(rt, &probe, R, &err);          // light change: probe (rotated by R) -> T x L
 *     runtime_shade_vertices(rt, eye, rgb, &err);      // view change as vertex colours, or
 *     runtime_render(rt, &rd, &img, &err);             // view change as an image (rd: size, camera, background)
 *     runtime_timing t; runtime_get_timing(rt, &t);    // the same fields for every backend
 *     runtime_destroy(rt);
 *
 * Backends (the table in runtime.c lists every one):
 *   cpu  relight.h: sparse T x L on the CPU threads, h(view) . g per vertex
 *        (Eq. 5); images are those vertex colours rasterized (Gouraud) by OSMesa
 *        (headless; render.h) or into desc.ctx (the viewer's window), a file's
 *        textures multiplied per pixel (runtime_raster.set_textures). Its view
 *        model is per vertex only.
 *   gl   glrt.h: the same T x L and h . g in GLSL; per pixel (default, the view
 *        maps looked up at every pixel) or per vertex (the CPU's model).
 *        Vertex colours: the GPU's K-vectors g are read back and h . g is
 *        finished per vertex on the CPU (relight.h), i.e. the per-vertex model,
 *        equal to the cpu backend's to float rounding.
 *   null runtime_null.c: does every step but draw, as sokol's dummy backend:
 *        checks every call as the others do, the light vector still computed
 *        (runtime.c), timings kept (zeros); vertex colours are zeros and images
 *        black at the asked size. For testing the seam, and callers that need
 *        no pixels.
 * A backend is chosen by name; an unknown name is an error listing the known
 * ones. Callers take names and capabilities from the table
 * (runtime_backend_count / _at / _find: a runtime_backend_info each, its
 * RUNTIME_CAP_* flags), never by comparing names. Adding a backend is one
 * module (runtime_NAME.c, a runtime_backend with its info) and one line in
 * runtime.c's list; nothing else switches on it.
 *
 * A build without GL (make NO_GL=1, -DPRT_NO_GL): the table has no gl backend,
 * and the cpu backend draws no images (it lacks RUNTIME_CAP_IMAGES and
 * RUNTIME_CAP_WINDOW): its vertex colours and timings are whole, runtime_render
 * with out NULL is its view change, and asking it for an image (out, or
 * runtime_read) fails with one line. This header includes no GL header.
 *
 * Several transfers: a file holds one or more transfers (prtfile.h), each over
 * the materials of its mask, and a vertex's radiance is the sum over the
 * transfers whose mask holds its material: a sparse transfer (haar, sh) gives
 * h(view) . (T x L) with the material's factors (Eq. 5), a non-linear one (vmf:
 * ops->view->shade_vertices) its own view-dependent sum of lobes looked up in the
 * prefiltered probe. Lambert-only and SVD-only files have one sparse transfer
 * and shade by Eq. 5 alone.
 *
 * The light: runtime_set_light makes a runtime_light and hands it to the
 * backend's light change: the probe resampled once to the 6x64x64 cube
 * (probe_to_cube, rotated by R so that a light at d appears at R d), then per
 * transfer with ops->linear->project_light its light vector (transfer.h); and when
 * some transfer has ops->view->shade_vertices, the probe prefiltered by vMF lobes
 * (prefilter.h), made once per probe (~1 s: prefilter_create) and only rotated
 * (prefilter_set_rotation: free) while the probe stays the same (pointer and
 * pixels), so rotating the light stays interactive. A linear transfer with the open
 * sky split also gets runtime_light.open, the open sky's irradiance at each split
 * vertex's normal times its constant light map (opensky.h): from the unrotated probe's grid, made once per
 * probe, read at R^T n (turning the light costs the lookups), or from the cube given alone. The runtime owns the
 * prefiltered probe; a backend may keep the pointer until the next light
 * change or runtime_destroy. The backend then runs its light-change kernels.
 * A new representation needs nothing here: its ops say which of the two it
 * takes. The probe is only read during the call. Images show rd->background (rotated by rd->background_rotation) behind
 * the scene; a backend that keeps the background on the GPU uploads it again
 * only when the probe (pointer or pixels) differs from the last one drawn, so a
 * caller that changes a probe's pixels in place must pass another prt_probe.
 * rd->direct_only is ignored: direct-only lighting is runtime_desc.direct_only
 * or runtime_use_direct.
 *
 * Frames and targets: runtime_render draws a frame into the runtime's target
 * and, when out is non-NULL, reads it back. With a GL context (desc.ctx, or
 * the gl backend's own) the target is a float framebuffer that runtime_present
 * blits to the window and runtime_read reads. The cpu backend without a context
 * has no framebuffer: runtime_render(out NULL) computes the vertex colours (its
 * view change) and the raster happens when an image is asked for (out, or
 * runtime_read), so `prt bench` times each backend's own view change.
 *
 * Timings (runtime_timing): wall clock of the last light vector (with the
 * prefiltering of a new probe), light change (every sparse T x L), view change
 * (h . g and every non-linear transfer's shade_vertices) and raster, finished (GL calls glFinish); GPU timer queries where
 * the backend has them (0 otherwise); the bytes the backend holds for the
 * scene; the backend's name, light kernel and device in words.
 *
 * Threads and contexts: a runtime is used from one thread at a time. A gl
 * runtime, or a cpu runtime given desc.ctx, makes its context current in every
 * call that draws, so other users of the context (the viewer's text) may draw
 * in between.
 *
 * Local lights: runtime_set_local_lights hands the point and spot
 * lights (lights.h) to the backend, which adds their direct light with shadows,
 * shaded with the analytic BRDFs (not the factorization), to the probe's PRT
 * result at every later view change: cpu per vertex with Embree shadow rays
 * (direct.h), gl per pixel with a shadow map per light. Calling it again is a
 * light move (timed as local_ms); zero lights turns them off. Probe and local
 * lights add up.
 *
 * Errors: every call that can fail returns 0, or -1 with one line in err
 * (unknown backend, no GL context, GL too old, out of memory, a file that keeps
 * no direct-only set). Bugs (NULL runtime, bad sizes from the library) are
 * PRT_CHECKs. Ownership: the runtime owns its backend state and, when it made
 * one, its GL context; prt_data, probes, the desc's context and images passed
 * in stay the caller's; images read back are the caller's (image_free). */
#ifndef PRT_RUNTIME_H
#define PRT_RUNTIME_H
#include "common.h"
#include "prtfile.h"
#include "probe.h"
#include "frame.h"

struct glctx;

/* What a backend can do (runtime_backend_info.caps). */
enum {
    RUNTIME_CAP_IMAGES = 1u << 0,       /* runtime_render / runtime_read give images (else vertex colours only) */
    RUNTIME_CAP_VIEW_PIXEL = 1u << 1,   /* the per-pixel view model (every backend has per vertex) */
    RUNTIME_CAP_WINDOW = 1u << 2,       /* draws into a caller's GL context (desc.ctx: the viewer's window) */
    RUNTIME_CAP_GL = 1u << 3,           /* needs GL for every frame: makes a headless context when given none */
    RUNTIME_CAP_LOCAL_LIGHTS = 1u << 4, /* adds local lights' light (runtime_set_local_lights) */
    RUNTIME_CAP_GPU_TIMERS = 1u << 5,   /* fills light_gpu_ms / view_gpu_ms from GPU timer queries */
};

/* One entry of the backend table, for callers choosing or describing a backend. */
typedef struct runtime_backend_info {
    const char *name;           /* runtime_desc.backend: "cpu" */
    const char *title;          /* in words, for overlays and messages: "CPU" */
    const char *summary;        /* one line for --help: what it computes and how it draws */
    unsigned caps;              /* RUNTIME_CAP_* */
    const char *kernels;        /* its light kernels by name (runtime_desc.kernel), the default first */
    const char *quick_kernel;   /* the kernel for a single light change (one image): NULL, the default */
    const char *indirect_view;  /* what runtime_timing.indirect_view_ms holds, in words */
} runtime_backend_info;

/* How many backends this build has. */
int runtime_backend_count(void);
/* Backend i of the table, 0 <= i < runtime_backend_count(); the first is the default. */
const runtime_backend_info *runtime_backend_at(int i);
/* The backend called name, or NULL (NULL name: the default). */
const runtime_backend_info *runtime_backend_find(const char *name);
/* The position of the backend called name in the table, or -1. */
int runtime_backend_index(const char *name);
/* Whether d's shading depends on the view beyond a Lambertian colour: a view transfer (vMF lobes) or a
 * material with K > 1 BRDF terms. */
bool runtime_view_dependent(const prt_data *d);
/* The first backend that draws its images with GL per pixel (gl), or NULL in a build without GL. */
const runtime_backend_info *runtime_backend_pixel(void);
/* The backend that draws d's images best: the first drawing with GL per pixel (gl) when d is view
 * dependent and the build has one, else the default (the first); prt render's without --backend. */
const runtime_backend_info *runtime_backend_for(const prt_data *d);
/* The names of the backends with every capability in need (0: all), "cpu, gl, null", into buf
 * (cap bytes, cut to fit); returns buf. */
const char *runtime_backend_names(char *buf, size_t cap, unsigned need);

/* How view-dependent shading is evaluated. */
typedef enum runtime_view {
    RUNTIME_VIEW_DEFAULT = 0,   /* the backend's own: gl per pixel, cpu per vertex */
    RUNTIME_VIEW_PIXEL,         /* view maps looked up per pixel (gl) */
    RUNTIME_VIEW_VERTEX,        /* h . g per vertex, colours interpolated (both) */
} runtime_view;

/* What to create; zero means default everywhere. */
typedef struct runtime_desc {
    const char *backend;        /* a name of the table (runtime_backend_at; NULL: the first, "cpu") */
    int threads;                /* cpu: worker threads (0: all cores); also the gl backend's vertex finish */
    int terms;                  /* BRDF terms used by view changes (0: all the file has) */
    bool direct_only;           /* light with the file's direct-only set (if it keeps one; else ignored) */
    struct glctx *ctx;          /* draw into this context (the viewer's window); NULL: headless, owned */
    runtime_view view;          /* view model (a backend refuses one it lacks) */
    const char *kernel;         /* light-change kernel by name (NULL: the backend's default; gl: "auto"
                                   times fragment/thread/warp once at create and keeps the fastest) */
    bool local_bounce;          /* local lights: add their one bounce by two VSGLs per light (cpu: indirect.h,
                                   per vertex; gl: glvsgl.h, per pixel; both lobes of the receiver) */
    int highlight_samples;      /* local lights: indirect-highlight rays per glossy vertex (0: none); per vertex
                                   on the CPU for both backends (gl: added as a vertex attribute) */
} runtime_desc;

/* The last call's timings; the same fields for every backend. */
typedef struct runtime_timing {
    const char *backend;        /* the backend's name ("cpu", "gl", "null") */
    double light_vector_ms;     /* last runtime_set_light: probe -> cube -> light vector (CPU) */
    double light_ms;            /* last light change: T x L for every vector, finished */
    double view_ms;             /* last view change: h(view) . g per vertex or per pixel, finished */
    double raster_ms;           /* last image: drawing beyond the view change (background, raster, read) */
    double light_gpu_ms, view_gpu_ms; /* GPU timer queries of the last light / view change (0: none) */
    double local_ms;            /* last local-light move (runtime_set_local_lights): shadow rays / maps */
    double bounce_ms;           /* of local_ms: RSMs, VSGLs and the Lambert vertices' bounce (cpu, indirect.h);
                                   RSMs and VSGLs (gl) */
    double indirect_view_ms;    /* of view_ms: VSGL light at glossy vertices and indirect highlights (cpu); the
                                   highlights (gl) */
    size_t bytes;               /* memory the backend holds for the scene (gl: uploaded to the GPU) */
    const char *kernel;         /* the light-change kernel in use ("sparse T x L", "fragment", ...) */
    char device[256];           /* "2 threads" / "GL renderer, version (context)" */
    char detail[256];           /* backend extras, e.g. the gl kernels measured at create */
} runtime_timing;

typedef struct prt_runtime prt_runtime;

/* Creates a runtime of desc->backend for d (d must outlive it). NULL with err. */
prt_runtime *runtime_create(const prt_data *d, const runtime_desc *desc, prt_error *err);
/* Frees the runtime and what it owns; NULL is fine. */
void runtime_destroy(prt_runtime *rt);
/* Light change: probe p rotated by R (row-major 3x3, NULL: none) through every transfer of the file. */
int runtime_set_light(prt_runtime *rt, const prt_probe *p, const float R[9], prt_error *err);
/* Light change from a cube already resampled, cube[3*CUBE_TEXELS] = probe_to_cube(p, CUBE_RES, R, 0, .):
 * the same as runtime_set_light(rt, p, R) without resampling, for many files under one light (the
 * fuzz harness relights every input). -1 with err when a transfer shades with the probe itself (vmf). */
int runtime_set_light_cube(prt_runtime *rt, const float *cube, prt_error *err);
/* Light change from light vectors already projected: L[i] = transfers[i].ops->linear->project_light(cfg, cube)
 * for every transfer with a projection (the others' entries are not read); runtime_set_light_cube
 * without the projection, for many files whose transfers share configurations (the fuzz harness
 * keeps one vector per configuration). Only read during the call. -1 with err as runtime_set_light_cube, and
 * for a transfer with the open sky split (prt_transfer.open_sky), whose addend needs the cube. */
int runtime_set_light_vectors(prt_runtime *rt, const float (*const L[PRT_MAX_TRANSFERS])[4], prt_error *err);
/* ---------------------------------------------------------------- probes prepared once
 * What runtime_set_light makes of a probe before any rotation can be made once per probe, apart:
 * runtime_probe_prepare (slow: the probe's fine cube, probecube.h, ~0.1-0.2 s; the prefiltered
 * probe, prefilter.h, 1-3 s, when the file has a transfer that shades with it) touches no runtime,
 * so it may run on a worker thread while the runtime keeps drawing; runtime_lend_probe then hands
 * it to a runtime on the runtime's thread. While it is lent, runtime_set_light of that probe (pointer
 * and pixels) resamples the light cube from the fine cube under R (probe_cube_resample: ~2 ms on two
 * cores where probe_to_cube takes ~30 ms; a filter one fine texel wider, probecube.h) and rotates the
 * prefiltered probe instead of making it. Without a lent probe runtime_set_light resamples the probe
 * itself (probe_to_cube), as a single light change should. */
typedef struct runtime_probe {
    const prt_probe *probe;         /* the probe it was made from: lent, it serves this probe only */
    const float *pixels;            /* ... with these pixels */
    struct probe_cube *cube;        /* the fine cube rotations are resampled from */
    struct prefilter_env *env;      /* prefiltered by vMF lobes (runtime_needs_prefilter), else NULL */
    double ms;                      /* the wall time runtime_probe_prepare took */
} runtime_probe;

/* Whether a light change of d needs the probe prefiltered (a transfer of kind TRANSFER_VIEW). */
bool runtime_needs_prefilter(const prt_data *d);
/* Prepares p for d's runtimes into out (threads 0: all cores); reads d and p only, so any thread may
 * run it while other threads read them. -1 with err (out of memory). */
int runtime_probe_prepare(const prt_data *d, const prt_probe *p, int threads, runtime_probe *out, prt_error *err);
/* Frees what out holds (no runtime may hold it lent any more) and zeroes it. */
void runtime_probe_free(runtime_probe *rp);
/* Lends rp to rt for the light changes of rp->probe (NULL: none); rp stays the caller's and must
 * outlive the lending (until another runtime_lend_probe or runtime_destroy). Call it on rt's thread. */
void runtime_lend_probe(prt_runtime *rt, runtime_probe *rp);

/* View change as vertex colours: rgb[3*nverts] = radiance of every vertex toward eye, clamped >= 0. */
int runtime_shade_vertices(prt_runtime *rt, const float eye[3], float *rgb, prt_error *err);
/* View change as a frame rd->width x rd->height (0 x 0: 800 x 600) into the target; out non-NULL:
 * also read back (linear RGB, top row first, allocated here). */
int runtime_render(prt_runtime *rt, const render_desc *rd, prt_image *out, prt_error *err);
/* The last frame as an image (allocated here). -1 with err when no frame was rendered. */
int runtime_read(prt_runtime *rt, prt_image *out, prt_error *err);
/* Blits the last frame to the current window (win_w x win_h) with exposure (clamp, sRGB), as image_write's
 * PNG; nothing without a window context. */
void runtime_present(prt_runtime *rt, int win_w, int win_h, float exposure_stops);
/* Direct-only lighting (true) or direct + bounces (false); -1 with err when the file keeps no direct
 * set. Takes effect at the next runtime_set_light. It switches the sparse transfer only: a vmf
 * transfer keeps all its passes (no op selects its passes yet). */
int runtime_use_direct(prt_runtime *rt, bool direct, prt_error *err);
/* Local lights (lights.h) for the next view changes, replacing the previous ones (count 0: none);
 * a light move. -1 with err (invalid light, a backend without local lights). */
int runtime_set_local_lights(prt_runtime *rt, const prt_lights *ls, prt_error *err);
/* Turns the local lights' one bounce (desc.local_bounce) and indirect highlights (desc.highlight_samples
 * rays per glossy vertex, 0: off) on or off from now on, as if the runtime had been created with them;
 * with lights held, a light move (timed as local_ms). The viewer's keys. -1 with err. */
int runtime_set_local_effects(prt_runtime *rt, bool bounce, int highlight_samples, prt_error *err);
/* BRDF terms used by the next view changes (0: all). */
void runtime_set_terms(prt_runtime *rt, int kmax);
/* Switches the view model; -1 with err when the backend lacks it (cpu: per pixel). */
int runtime_set_view(prt_runtime *rt, runtime_view view, prt_error *err);
/* Fills t with the last calls' timings and the backend's description. */
void runtime_get_timing(const prt_runtime *rt, runtime_timing *t);
/* The backend's name ("cpu", "gl", "null"). */
const char *runtime_backend_name(const prt_runtime *rt);
/* The runtime's entry of the backend table. */
const runtime_backend_info *runtime_info(const prt_runtime *rt);

/* ---------------------------------------------------------------- backend interface
 * What a backend module implements (runtime_cpu.c, gpu/runtime_gl.c). runtime.c
 * validates arguments, computes the light vector, times it and holds kmax;
 * the ops see a valid self. Optional ops may be NULL (the call then fails with
 * one line naming the backend). */
struct prefilter_env;
/* What a backend's light change gets (made by runtime_set_light, valid during the call; env until the
 * next light change or runtime_destroy). Indexed like d->transfers. */
typedef struct runtime_light {
    const float (*L[PRT_MAX_TRANSFERS])[4]; /* transfer i's light vector ([CUBE_TEXELS][4], ops->linear->project_light);
                                             * NULL where the transfer has none (non-linear) */
    const struct prefilter_env *env;        /* the probe prefiltered by vMF lobes, rotated as the light; NULL
                                             * when no transfer has ops->view->shade_vertices */
    bool env_new;                           /* env was made in this call (a new probe); false: only its
                                             * rotation changed, so a backend's copy of its texels still holds */
    const float *open[PRT_MAX_TRANSFERS];   /* transfer i with the open sky split (prt_transfer.open_sky): what
                                             * to add to g = T x L, [3 * nvecs] (opensky.h: g E(n), and a folded
                                             * vector's T . (L' - L)); NULL: nothing */
} runtime_light;

typedef struct runtime_backend {
    runtime_backend_info info;  /* its name (runtime_create finds it by it), title and capabilities */
    /* Creates the state; desc is complete (backend resolved). NULL with err. */
    void *(*create)(const prt_data *d, const runtime_desc *desc, prt_error *err);
    void (*destroy)(void *self);
    /* Light change: every sparse transfer's T x L with light->L[i]; keeps light->env for the
     * non-linear transfers' view changes. */
    int (*set_light)(void *self, const runtime_light *light, prt_error *err);
    int (*shade_vertices)(void *self, const float eye[3], int kmax, float *rgb, prt_error *err);
    /* Draws a frame into the target (size resolved, > 0). */
    int (*render)(void *self, const render_desc *rd, int kmax, prt_error *err);
    int (*read)(void *self, prt_image *out, prt_error *err);
    void (*present)(void *self, int win_w, int win_h, float exposure_stops);
    int (*use_direct)(void *self, bool direct, prt_error *err);
    int (*set_view)(void *self, runtime_view view, prt_error *err);
    /* Fills everything but backend and light_vector_ms. */
    void (*get_timing)(const void *self, runtime_timing *t);
    /* Local lights: keeps ls (copied) and prepares their shadows; view changes add them. */
    int (*set_local_lights)(void *self, const prt_lights *ls, prt_error *err);
    /* The one bounce and the highlights on or off (runtime_set_local_effects), lights kept. */
    int (*set_local_effects)(void *self, bool bounce, int highlight_samples, prt_error *err);
} runtime_backend;

/* Vertex colours drawn into images, for a backend whose view change ends in vertex colours (cpu):
 * implemented where GL lives (gpu/render.c), absent from a build without GL. */
typedef struct runtime_raster {
    /* State drawing mesh m into ctx, or headless with ctx NULL (a GL context per image). NULL with err. */
    void *(*create)(const prt_mesh *m, struct glctx *ctx, prt_error *err);
    void (*destroy)(void *self);
    /* A frame (size resolved) of the colours rgb[3*nverts]: drawn into ctx's float target now, or
     * headless kept (copied) to be rasterized at read. */
    int (*draw)(void *self, const render_desc *rd, const float *rgb, prt_error *err);
    /* The last frame as an image: ctx's target read back, or headless rasterized now of rgb. */
    int (*read)(void *self, const float *rgb, prt_image *out, prt_error *err);
    /* Tone-mapped blit of ctx's target to its window; nothing headless. */
    void (*present)(void *self, int win_w, int win_h, float exposure_stops);
    /* Textures (texture.h) of sc, whose mesh the raster draws: from then on draw and read take
     * rgb[6*nverts], the colours a texture multiplies per pixel, then the rest (A, then B: each pixel
     * tex(uv) A + B). 0 without textures (rgb stays [3*nverts]), or -1 with err. */
    int (*set_textures)(void *self, const struct prt_scene *sc, prt_error *err);
} runtime_raster;

extern const runtime_backend runtime_cpu;   /* src/runtime/runtime_cpu.c */
extern const runtime_backend runtime_null;  /* src/runtime/runtime_null.c */
#ifndef PRT_NO_GL
extern const runtime_backend runtime_gl;    /* gpu/runtime_gl.c */
extern const runtime_raster runtime_raster_gl;   /* gpu/render.c: OSMesa / EGL headless, or the caller's context */
#endif
#endif
