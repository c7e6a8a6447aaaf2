/* glrt.h - the GLSL runtime: all-frequency relighting on the GPU (section 4.3.1).
 *
 * Usage (headless):
 *     glrt *rt = glrt_create(&data, NULL, &err);      // data is SHARED: keep it alive
 *     glrt_set_light(rt, L, &err);                    // light change: sparse T x L on the GPU
 *     glrt_set_background(rt, &probe, NULL, &err);    // optional
 *     glrt_render(rt, &cam, 800, 600, 0, &img, &err); // view change: per-pixel h(view) . g
 *     glrt_destroy(rt);
 * or in one call: glrt_render_image(&data, L, &render_desc, kmax, &img, &err).
 *
 * Upload (once, at create): the quantized transport exactly as the file keeps
 * it (8-bit packed offset|r|g|b words, with the block byte of every
 * coefficient expanded from the runs; or 16-bit / float values with their
 * indices), the per-vector dequantization steps, the view maps of every
 * material, and the mesh (positions, normals, first vector and term count,
 * material per vertex).
 *
 * Light change (glrt_set_light): the light vector (CUBE_TEXELS x RGBA float,
 * the 16-bit dequantized values light.h makes, so CPU and GPU use identical
 * numbers) is uploaded, then one GPU pass computes every light-dependent
 * K-vector g_i = scale_i * sum_c q_c L[index_c] (Eq. 5's T x L) into a buffer;
 * the kernels' GLSL is the transfer representation's (transfer.h, ops->linear->glsl).
 * Three kernels exist; GLRT_LIGHT_AUTO times each once at create and keeps the
 * fastest (the paper chose its layout by measurement too):
 *   fragment  one fragment per vector looping over its coefficients, written to
 *             a float texture and copied into the g buffer through a pixel-pack
 *             buffer (GL 3.3: the paper's fragment-shader reduction; a modern
 *             loop replaces its P buffer + 4x4/4x2 downsampling passes);
 *   thread    compute shader, one invocation per vector (GL 4.3);
 *   warp      compute shader, 32 invocations per vector striding over its
 *             coefficients (coalesced reads) and a shared-memory tree sum.
 *
 * View change (glrt_draw / glrt_render): the vertex shader fetches each vertex's
 * g (from the g buffer as a buffer texture, i.e. vertex texture fetch, 5.3);
 * GLRT_VIEW_PIXEL (default) interpolates g, the normal and the position, and
 * the fragment shader computes the pixel's own view direction, Eq. 10's frame
 * from the normal, and looks up the K view maps (bilinear, as brdf_factor_view)
 * for colour = sum_k h_k . g_k. Because the lookup is per pixel, the polar
 * parameterization (Eq. 11) works too (the paper's seam problem, section 6, is
 * a per-vertex texture-coordinate interpolation problem). GLRT_VIEW_VERTEX
 * evaluates h . g per vertex in the vertex shader and interpolates colours:
 * the CPU runtime's exact per-vertex model (relight_view + Gouraud), used to
 * check GPU against CPU.
 *
 * On this project's 2-core llvmpipe machine AUTO picks the fragment kernel
 * (bunny + floor, 21M coefficients: fragment 147 ms, thread 301 ms, warp 813 ms);
 * on a GPU the compute kernels are expected to win. glrt_render_image, a single
 * light change, skips the timing and uses the fragment kernel.
 *
 * A linear transfer without GLSL kernels (ops->linear->glsl NULL: a representation
 * whose light change is its own CPU code, transfer.h) gets the fourth method,
 * GLRT_LIGHT_CPU, and only it, whatever glrt_desc.light asks: nothing of its
 * transport is uploaded and no light program built; glrt_set_light computes
 * g = T x L with transfer_light on the CPU (all cores, the set glrt_use_direct
 * chose), pads it to the g buffer's vec4 layout and uploads it (BufferSubData).
 * The view programs read g as for the GL kernels. light_ms covers both steps.
 *
 * Several transfers: glrt draws the data's one sparse transfer (prt_data_transfer; a file with
 * more than one is refused) and adds, per vertex, a radiance computed elsewhere
 * (glrt_set_vertex_add: the vmf transfer's lobes from ops->view->shade_vertices on the CPU, per view
 * change). Per pixel (GLRT_VIEW_PIXEL), a transfer with ops->view->glsl (vmf) is evaluated in the
 * fragment shader instead, on every triangle with a corner of its materials: its GLSL
 * (tv_radiance: vmft_radiance_point, vmf.h, i.e. laurijssen-2011 Eq. 7 over the pixel's triangle
 * and grid views, stored slices from the perfect hash) reads the transfer's data as two buffer
 * textures (view->glsl->data) and looks lobes up in the prefiltered probe uploaded by
 * glrt_set_prefilter (one seamless cube map per ladder level, GLRT_PF_LEVELS at most); the caller
 * then leaves that transfer out of glrt_set_vertex_add (glrt_shades_per_pixel). A context whose
 * buffer textures or texture units cannot hold the data (17 units are used) keeps the per-vertex
 * radiance for every vertex. The element buffer is then ordered in three classes, each drawn by its
 * own program: no corner of the transfer's materials (no tv code), every corner with vattr 1 (the
 * tv's fast path, TV_FULL 0), the rest (TV_FULL 1); llvmpipe runs a masked branch's body for every
 * pixel, so one program for all would take the paper-phong sphere's frame from ~150 to ~365 ms.
 * Measured (tests/test_runtime.c): vmf_pixel, paper-phong sphere, 24 x 48, smooth sky with an 8-degree
 * sun: per pixel 0.7% from quadrature at 18 pixels where the per-vertex image is 12.7% off;
 * vmf_pixel_point: per pixel against vmft_radiance_point on the CPU at every pixel of a glossy sphere
 * over a floor with stored slices (see the case for the figures).
 *
 * Contexts: with desc->ctx NULL, glrt makes its own headless context (OSMesa, or
 * EGL on an NVIDIA machine; $PRT_GL=osmesa|egl overrides) and owns it; with a
 * caller's context (the viewer's window) glrt makes it current in every call
 * (so other contexts may be used in between). kmax limits the BRDF terms
 * (0 = all). At most GLRT_MAX_TERMS terms. A file that keeps its direct-only
 * transport can be switched to it (glrt_use_direct), one re-upload.
 *
 * Errors: -1 / NULL with one line in err (no context, GL too old, out of GPU
 * memory, more than GLRT_MAX_TERMS terms). Ownership: the glrt owns its GL
 * objects (and its context when it made it); glrt_destroy frees them. */
#ifndef PRT_GLRT_H
#define PRT_GLRT_H
#include "glctx.h"
#include "prtfile.h"
#include "render.h"

#define GLRT_MAX_TERMS 16
#define GLRT_PF_LEVELS 13   /* prefilter ladder levels the per-pixel program samples (prefilter.h's default) */

typedef enum glrt_light_method {
    GLRT_LIGHT_AUTO = 0, GLRT_LIGHT_FRAGMENT, GLRT_LIGHT_THREAD, GLRT_LIGHT_WARP,
    GLRT_LIGHT_CPU,             /* transfer_light on the CPU, g uploaded: the transfers without GLSL, and only those */
    GLRT_LIGHT_COUNT
} glrt_light_method;

typedef enum glrt_view_mode { GLRT_VIEW_PIXEL = 0, GLRT_VIEW_VERTEX = 1 } glrt_view_mode;

typedef struct glrt_desc {
    glctx *ctx;                 /* NULL: a headless context owned by the glrt */
    glrt_light_method light;    /* AUTO: the fastest, measured at create (a transfer without GLSL: CPU, whatever this asks) */
    glrt_view_mode view;
    bool local_bounce;          /* local lights: add their one bounce by VSGLs (glvsgl.h: both lobes of the receiver) */
} glrt_desc;

typedef struct glrt_timing {
    double upload_ms;           /* create: uploading transport, view maps, mesh */
    double light_ms;            /* last light change, wall clock: upload L + kernel, finished (CPU method: the
                                 * CPU light change + the upload of g) */
    double light_gpu_ms;        /* GPU time of the last light kernel (timer query) */
    double view_ms;             /* last glrt_draw or glrt_draw_vertex_colors, wall clock (finished) */
    double view_gpu_ms;         /* GPU time of the last glrt_draw */
    double local_ms;            /* last glrt_set_local_lights (shadow cubes), wall clock, finished */
    double bounce_ms;           /* of local_ms: the VSGLs (RSM and sums on the CPU, glvsgl.h) */
    double method_ms[GLRT_LIGHT_COUNT]; /* AUTO: measured kernel time per method (0: not run / unavailable) */
    size_t gpu_bytes;           /* bytes uploaded for transport, view maps and mesh */
    glrt_light_method light_method;
    const char *light_method_name;
    const char *context;        /* "osmesa", "egl", "glfw" */
    const char *renderer, *version; /* GL_RENDERER / GL_VERSION (owned by the glrt) */
} glrt_timing;

typedef struct glrt glrt;

glrt *glrt_create(const prt_data *d, const glrt_desc *desc, prt_error *err);
void glrt_destroy(glrt *rt);
/* Light change. L: [CUBE_TEXELS][4] in the file's transfer representation (transfer_light_vector). */
int glrt_set_light(glrt *rt, const float (*L)[4], prt_error *err);
/* The same, adding open[3 * nvecs] to g (runtime_light.open: a transfer with the open sky split, whose light
 * change then runs on the CPU; NULL for one without). */
int glrt_set_light_open(glrt *rt, const float (*L)[4], const float *open, prt_error *err);
/* Local lights (gllights.h): their direct light with shadow cubes is added per pixel (or per
 * vertex in GLRT_VIEW_VERTEX) to every later draw; count 0 turns them off. At most GLLIGHTS_MAX. */
int glrt_set_local_lights(glrt *rt, const prt_lights *ls, prt_error *err);
/* Local lights' one bounce on (the VSGLs, glvsgl.h) or off, and with glossy, their light on the receivers'
 * glossy lobe too (false when the indirect highlights light that lobe, as the cpu runtime's indirect.h).
 * The view programs are rebuilt when the glossy term's code must come or go; with lights held, a light
 * move follows. -1 with err. */
int glrt_set_local_effects(glrt *rt, bool bounce, bool glossy, prt_error *err);
/* Probe shown behind the scene (NULL: black); R as render_desc.background_rotation (may be NULL). */
int glrt_set_background(glrt *rt, const prt_probe *p, const float R[9], prt_error *err);
/* Changes only the background's rotation (R NULL: none); the probe stays uploaded. */
void glrt_set_background_rotation(glrt *rt, const float R[9]);
/* Renders into the glrt's float target (w x h): background, then the scene relit with the
 * current light. kmax 0 = all terms. */
int glrt_draw(glrt *rt, const prt_camera *cam, int w, int h, int kmax, prt_error *err);
/* The same target, with per-vertex colours rgb[3*nverts] computed elsewhere (the CPU runtime). */
int glrt_draw_vertex_colors(glrt *rt, const prt_camera *cam, int w, int h, const float *rgb, prt_error *err);
/* Radiance added to every vertex's shading in both view modes (rgb[3 * nverts], interpolated across
 * triangles; NULL: zeros, the default): the non-linear transfers' part, computed elsewhere
 * (runtime_gl.c: ops->view->shade_vertices per view change). */
int glrt_set_vertex_add(glrt *rt, const float *rgb, prt_error *err);
/* Per-pixel mode: the prefiltered probe (prefilter.h) the transfer with ops->view->glsl is looked up in
 * (its levels uploaded as seamless cube maps, its rotation as a uniform); NULL, or a ladder of more than
 * GLRT_PF_LEVELS levels: none, every pixel takes the per-vertex radiance. Call it once per probe. */
struct prefilter_env;
int glrt_set_prefilter(glrt *rt, const struct prefilter_env *env, prt_error *err);
/* True when the per-pixel program shades tr in the current view mode (so its per-vertex radiance
 * must not be added too): tr has view->glsl, its data fit the context, a ladder is uploaded, per pixel. */
bool glrt_shades_per_pixel(const glrt *rt, const prt_transfer *tr);
/* Takes env's rotation for the ladder uploaded last (same probe, turned): no upload. */
void glrt_set_prefilter_rotation(glrt *rt, const struct prefilter_env *env);
/* Antialiasing of the next draws' target: n samples per pixel (gldraw_set_samples; 0 or 1: none). */
void glrt_set_samples(glrt *rt, int n);
/* Reads the target back (linear RGB, top row first; allocated here). */
int glrt_read(glrt *rt, prt_image *out, prt_error *err);
/* glrt_draw + glrt_read. */
int glrt_render(glrt *rt, const prt_camera *cam, int w, int h, int kmax, prt_image *out, prt_error *err);
/* Blits the target to the current window's framebuffer with exposure (clamp + sRGB). */
void glrt_present(glrt *rt, int win_w, int win_h, float exposure_stops);
/* Copies the light-dependent K-vectors back: g[3*i + ch] for every vector (as relight_gvec). */
int glrt_read_gvec(glrt *rt, float *g, prt_error *err);
/* Direct-only lighting (true; the file's direct-only set, kept by `precompute --keep-direct`) or
 * direct + bounces (false, the default): re-uploads that transport set (the CPU method: lights it from
 * then on). Call glrt_set_light again to see the change. -1 with err when the file keeps no direct set. */
int glrt_use_direct(glrt *rt, bool direct, prt_error *err);
/* Switches the view mode / light kernel (a method the context or the transfer cannot run fails: the GL
 * kernels need the transfer's GLSL, CPU its lack; AUTO picks what it has). */
void glrt_set_view_mode(glrt *rt, glrt_view_mode mode);
int glrt_set_light_method(glrt *rt, glrt_light_method m, prt_error *err);
void glrt_get_timing(const glrt *rt, glrt_timing *out);
const char *glrt_light_method_name(glrt_light_method m);

/* One-shot headless render (what `prt render --backend gl` calls): creates a runtime, sets the
 * light L, renders rd (size, camera, background), returns the image. */
int glrt_render_image(const prt_data *d, const float (*L)[4], const render_desc *rd, int kmax, prt_image *out,
                      prt_error *err);
#endif
