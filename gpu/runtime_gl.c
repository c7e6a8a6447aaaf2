/* runtime_gl.c - the "gl" runtime backend (runtime.h) over the GLSL runtime (glrt.h).
 *
 * Light change: glrt_set_light, the sparse T x L in a GPU pass (the kernel
 * chosen by name, "auto" timing each once at create; a transfer without GLSL
 * kernels: on the CPU and g uploaded, the kernel "cpu", glrt.h). View change: glrt_draw,
 * per pixel (the default) or per vertex. Images are read back from glrt's float
 * target; runtime_present blits it to the caller's window.
 *
 * Non-linear transfers (vmf): per vertex on the CPU through their ops->view->shade_vertices
 * at every view change (toward the camera's eye), the colours uploaded to glrt
 * (glrt_set_vertex_add) and added to the sparse transfer's shading per pixel or per
 * vertex; their time is part of view_ms. Per pixel, a transfer with ops->view->glsl is shaded
 * per pixel on the GPU instead (glrt.h) and not on the CPU (glrt_shades_per_pixel): the
 * prefiltered probe is uploaded once per probe (glrt_set_prefilter); a rotation only updates a
 * uniform.
 *
 * Vertex colours: the GPU has no per-vertex output buffer here, so the K-vectors
 * g are read back (glrt_read_gvec) and h(view) . g is finished per vertex on the
 * CPU by relight_view (relight_set_gvec): the per-vertex model, so the colours
 * equal the cpu backend's to the float rounding of the GPU's sums. The relight
 * context for that is made on the first such call.
 *
 * Local lights - the hooks, for whoever adds more local-light effects:
 *   light move:  gl_set_local_lights -> glrt_set_local_lights (gpu/glrt.c) -> gllights_set
 *                (gpu/gllights.c: one distance cube map per light, rendered from the mesh's VAO).
 *   view change: glrt_draw binds them (gllights_bind: uniforms u_nlocal, u_lpos, u_ldir, u_lcol,
 *                u_lbias, samplers t_shadow0..3 and t_brdf on units GLLIGHTS_UNIT..) and the view
 *                programs add the GLSL function local_lights(material, p, n, eye) (gllights_glsl)
 *                to the probe's shading: per pixel in k_view_fs, per vertex in k_view_vs (glrt.c).
 *                A per-vertex effect computed on the CPU can go through glrt_set_vertex_add instead:
 *                the indirect highlights do (desc.highlight_samples: an indirect_ctx without its
 *                VSGLs, its light move in gl_set_local_lights, indirect_shade_vertices per view
 *                change in gl_render), while glrt's VSGLs (glvsgl.h) then light the diffuse lobe only.
 *   toggles:     gl_set_local_effects (runtime_set_local_effects, the viewer's keys o and i).
 *   vertex colours (gl_shade_vertices): the per-vertex model on the CPU, so the local lights there
 *                are direct.h's (Embree shadow rays) and indirect.h's VSGLs and highlights, exactly
 *                the cpu backend's. */
#include "runtime.h"
#include "direct.h"
#include "glrt.h"
#include "indirect.h"
#include "relight.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct gl_rt {
    const prt_data *d;
    glrt *rt;
    int nthreads;
    bool direct;
    relight_ctx *finish;        /* vertex colours: made on first use */
    float *g;                   /* [3*nvecs] read back */
    int sparse;                 /* index of the sparse transfer in d->transfers */
    bool nonlinear;             /* some transfer has ops->view->shade_vertices */
    const struct prefilter_env *env;    /* the last light's prefiltered probe (the runtime's) */
    float *add;                 /* [3*nverts] the non-linear transfers' radiance of the last view */
    const prt_probe *bg;        /* the probe uploaded as background (and its pixels) */
    const float *bg_pixels;
    bool bg_set, has_frame;
    double view_ms, raster_ms;  /* the last view change (draw or vertex finish) and read-back */
    double local_ms;            /* the last local-light move: glrt's and the highlights' */
    prt_lights lights;          /* the local lights */
    direct_ctx *local;          /* vertex colours with local lights: made on first use */
    bool direct_stale;          /* lights moved since direct's last light move */
    int hl_samples;             /* indirect highlights: rays per glossy vertex (0: off) */
    int hl_made;                /* the sample count g->hl was made with */
    bool add_used;              /* the last vertex add uploaded was not all zeros */
    bool bounce;                /* the VSGLs (glrt, per pixel) */
    indirect_ctx *hl;           /* the highlights per vertex on the CPU (indirect.h without its VSGLs) */
    indirect_ctx *vind;         /* vertex colours: the VSGLs and highlights as the cpu backend (first use) */
    double hl_ms;               /* the last view change's highlights */
} gl_rt;

/* Frees the glrt (and its context when it made one) and the vertex-finish state. */
static void gl_destroy(void *self) {
    gl_rt *g = self;
    if (!g) return;
    glrt_destroy(g->rt);
    indirect_destroy(g->hl);
    indirect_destroy(g->vind);   /* before g->local: it borrows its BVH */
    relight_destroy(g->finish);
    direct_destroy(g->local);
    free(g->g);
    free(g->add);
    free(g);
}

/* The light kernel named s (NULL: auto; glrt's own names too); -1 with err listing the known ones. */
static int parse_kernel(const char *s, glrt_light_method *out, prt_error *err) {
    static const struct { const char *name; glrt_light_method m; } k_names[] = {
        { "auto", GLRT_LIGHT_AUTO }, { "fragment", GLRT_LIGHT_FRAGMENT }, { "thread", GLRT_LIGHT_THREAD },
        { "warp", GLRT_LIGHT_WARP },
    };
    *out = GLRT_LIGHT_AUTO;
    if (!s) return 0;
    for (size_t i = 0; i < sizeof k_names / sizeof k_names[0]; i++)
        if (!strcmp(s, k_names[i].name) || !strcmp(s, glrt_light_method_name(k_names[i].m))) {
            *out = k_names[i].m;
            return 0;
        }
    return prt_fail(err, "gl runtime: unknown light kernel '%s' (auto, fragment, thread, warp)", s);
}

/* The glrt view mode of a runtime view model (default: per pixel). */
static glrt_view_mode view_mode(runtime_view v) { return v == RUNTIME_VIEW_VERTEX ? GLRT_VIEW_VERTEX : GLRT_VIEW_PIXEL; }

/* glrt_create with the kernel and view model asked for, the direct set if asked. NULL with err. */
static void *gl_create(const prt_data *d, const runtime_desc *desc, prt_error *err) {
    glrt_desc gd = { .ctx = desc->ctx, .view = view_mode(desc->view), .local_bounce = desc->local_bounce };
    if (parse_kernel(desc->kernel, &gd.light, err)) return NULL;
    gl_rt *g = prt_calloc(1, sizeof *g, err);
    if (!g) return NULL;
    g->d = d;
    g->nthreads = desc->threads;
    g->rt = glrt_create(d, &gd, err);
    if (!g->rt) { gl_destroy(g); return NULL; }
    g->sparse = (int)(prt_data_transfer(d) - d->transfers);
    for (int i = 0; i < d->ntransfers; i++) g->nonlinear |= d->transfers[i].ops->kind == TRANSFER_VIEW;
    g->bounce = desc->local_bounce;
    g->hl_samples = desc->highlight_samples > 0 ? desc->highlight_samples : 0;
    /* with the highlights, the glossy lobe's one bounce is theirs (indirect.h): the VSGLs light the diffuse lobe */
    if (g->hl_samples && glrt_set_local_effects(g->rt, g->bounce, false, err)) { gl_destroy(g); return NULL; }
    if (!(g->add = prt_calloc(3 * (size_t)d->scene.mesh.nverts + 3, sizeof(float), err))) { gl_destroy(g); return NULL; }
    if (desc->direct_only && prt_data_transfer(d)->direct.nvecs > 0) {
        if (glrt_use_direct(g->rt, true, err)) { gl_destroy(g); return NULL; }
        g->direct = true;
    }
    return g;
}

/* Light change on the GPU (timed by glrt, finished); the prefiltered probe kept for the view changes. */
static int gl_set_light(void *self, const runtime_light *light, prt_error *err) {
    gl_rt *g = self;
    g->env = light->env;
    /* The ladder's texels go to the GPU once per probe; a rotation only is one uniform. */
    if (g->nonlinear && light->env_new && glrt_set_prefilter(g->rt, g->env, err)) return -1;
    if (g->nonlinear && !light->env_new) glrt_set_prefilter_rotation(g->rt, g->env);
    return glrt_set_light_open(g->rt, light->L[g->sparse], light->open[g->sparse], err);
}

/* Adds every non-linear transfer's radiance toward eye (ops->view->shade_vertices) to rgb, non-finite
 * values written as 0, but for those glrt shades per pixel when pixel is set; -1 with err before a
 * light change. */
static int add_nonlinear(gl_rt *g, const float eye[3], bool pixel, float *rgb, prt_error *err) {
    for (int i = 0; i < g->d->ntransfers; i++) {
        const prt_transfer *tr = &g->d->transfers[i];
        if (tr->ops->kind != TRANSFER_VIEW || (pixel && glrt_shades_per_pixel(g->rt, tr))) continue;
        if (!g->env) return prt_fail(err, "gl runtime: the %s transfer needs a light change first", tr->ops->name);
        tr->ops->view->shade_vertices(g->d, tr, g->env, eye, rgb, g->nthreads);
    }
    for (size_t k = 0; k < 3 * (size_t)g->d->scene.mesh.nverts; k++)
        if (!(rgb[k] >= 0) || !isfinite(rgb[k])) rgb[k] = 0;
    return 0;
}

/* The vertex colours' VSGLs and highlights: the cpu backend's indirect_ctx (its desc, direct's BVH),
 * made on first use, its lights moved when they are stale. -1 with err. */
static int vertex_indirect(gl_rt *g, prt_error *err) {
    if (!g->vind) {
        indirect_desc id = { .hl_samples = g->hl_samples, .no_highlights = g->hl_samples <= 0, .no_bounce = !g->bounce,
                             .threads = g->nthreads, .vs = direct_vis(g->local) };
        if (!(g->vind = indirect_create(&g->d->scene, &id, err))) return -1;
        g->direct_stale = true;
    }
    return g->direct_stale ? indirect_set_lights(g->vind, &g->lights, err) : 0;
}

/* Read back g, finish h . g per vertex on the CPU (see the header comment). */
static int gl_shade_vertices(void *self, const float eye[3], int kmax, float *rgb, prt_error *err) {
    gl_rt *g = self;
    double t0 = prt_now();
    if (!g->finish) {
        g->finish = relight_create(g->d, g->nthreads, err);
        g->g = g->finish ? prt_calloc(3 * (size_t)prt_data_transfer(g->d)->transport.nvecs + 3, sizeof(float), err) : NULL;
        if (!g->g) { relight_destroy(g->finish); g->finish = NULL; return -1; }
    }
    if (glrt_read_gvec(g->rt, g->g, err)) return -1;
    relight_set_gvec(g->finish, g->g);
    relight_view(g->finish, eye, kmax, rgb);
    if (g->nonlinear && add_nonlinear(g, eye, false, rgb, err)) return -1;
    if (g->lights.count > 0) {   /* the per-vertex model's local lights: direct.h, as the cpu backend */
        if (!g->local && !(g->local = direct_create(&g->d->scene, g->nthreads, err))) return -1;
        if (g->direct_stale && direct_set_lights(g->local, &g->lights, err)) return -1;
        if ((g->bounce || g->hl_samples) && vertex_indirect(g, err)) return -1;
        g->direct_stale = false;
        direct_shade_vertices(g->local, eye, rgb);
        if (g->vind) indirect_shade_vertices(g->vind, eye, rgb);
    }
    g->view_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* Background (uploaded again only for another probe), then the view change into the target. */
static int gl_render(void *self, const render_desc *rd, int kmax, prt_error *err) {
    gl_rt *g = self;
    const prt_probe *p = rd->background;
    if (!g->bg_set || p != g->bg || (p && p->img.data != g->bg_pixels)) {
        if (glrt_set_background(g->rt, p, rd->background_rotation, err)) return -1;
        g->bg = p;
        g->bg_pixels = p ? p->img.data : NULL;
        g->bg_set = true;
    } else glrt_set_background_rotation(g->rt, rd->background_rotation);
    double t0 = prt_now();
    bool hl = g->hl && g->hl_samples > 0 && g->lights.count > 0;
    g->hl_ms = 0;
    if (g->nonlinear || hl || g->add_used) {   /* the vMF lobes and the highlights per vertex on the CPU, added on the GPU */
        memset(g->add, 0, sizeof(float) * 3 * (size_t)g->d->scene.mesh.nverts);
        if (g->nonlinear && add_nonlinear(g, rd->camera.eye, true, g->add, err)) return -1;
        if (hl) {
            indirect_stats st;
            indirect_shade_vertices(g->hl, rd->camera.eye, g->add);
            indirect_get_stats(g->hl, &st);
            g->hl_ms = st.view_ms;
        }
        if (glrt_set_vertex_add(g->rt, g->add, err)) return -1;
        g->add_used = g->nonlinear || hl;
    }
    double t_add = 1e3 * (prt_now() - t0);
    glrt_set_samples(g->rt, rd->samples);
    if (glrt_draw(g->rt, &rd->camera, rd->width, rd->height, kmax, err)) return -1;
    glrt_timing t;
    glrt_get_timing(g->rt, &t);
    g->view_ms = t.view_ms + t_add;
    g->raster_ms = 0;
    g->has_frame = true;
    return 0;
}

/* The target read back, timed. */
static int gl_read(void *self, prt_image *out, prt_error *err) {
    gl_rt *g = self;
    if (!g->has_frame) return prt_fail(err, "gl runtime: no frame rendered yet");
    double t0 = prt_now();
    int rc = glrt_read(g->rt, out, err);
    g->raster_ms = 1e3 * (prt_now() - t0);
    return rc;
}

/* The highlights' per-vertex context (made again for another sample count) and its light move. -1 with err. */
static int gl_highlights_set(gl_rt *g, prt_error *err) {
    if (g->hl_samples <= 0 || (g->lights.count == 0 && !g->hl)) return 0;
    if (g->hl && g->hl_made != g->hl_samples) {
        indirect_destroy(g->hl);
        g->hl = NULL;
    }
    indirect_desc id = { .hl_samples = g->hl_samples, .no_bounce = true, .threads = g->nthreads };   /* VSGLs: glrt */
    if (!g->hl && !(g->hl = indirect_create(&g->d->scene, &id, err))) return -1;
    g->hl_made = g->hl_samples;
    return indirect_set_lights(g->hl, &g->lights, err);
}

/* Local-light move: the shadow cubes (and VSGLs) on the GPU (glrt_set_local_lights), the highlights' lights. */
static int gl_set_local_lights(void *self, const prt_lights *ls, prt_error *err) {
    gl_rt *g = self;
    double t0 = prt_now();
    if (glrt_set_local_lights(g->rt, ls, err)) return -1;
    g->lights = *ls;
    g->direct_stale = true;
    if (gl_highlights_set(g, err)) return -1;
    g->local_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* The viewer's toggles: the VSGLs (glrt) and the highlights (per vertex here), with a light move. */
static int gl_set_local_effects(void *self, bool bounce, int highlight_samples, prt_error *err) {
    gl_rt *g = self;
    g->bounce = bounce;
    g->hl_samples = highlight_samples > 0 ? highlight_samples : 0;
    indirect_destroy(g->vind);   /* the vertex colours' context is made again with these effects */
    g->vind = NULL;
    double t0 = prt_now();
    if (glrt_set_local_effects(g->rt, bounce, g->hl_samples == 0, err) || gl_highlights_set(g, err)) return -1;
    g->local_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* Tone-mapped blit to the window. */
static void gl_present(void *self, int win_w, int win_h, float exposure_stops) {
    gl_rt *g = self;
    glrt_present(g->rt, win_w, win_h, exposure_stops);
}

/* Uploads the direct-only (or total) transport; -1 with err. */
static int gl_use_direct(void *self, bool direct, prt_error *err) {
    gl_rt *g = self;
    if (glrt_use_direct(g->rt, direct, err)) return -1;
    g->direct = direct;
    return 0;
}

/* Per pixel or per vertex from the next frame on. */
static int gl_set_view(void *self, runtime_view view, prt_error *err) {
    gl_rt *g = self;
    glrt_set_view_mode(g->rt, view_mode(view));
    return 0;
}

/* glrt's timings in the runtime's fields; the kernels measured at create as detail. */
static void gl_get_timing(const void *self, runtime_timing *t) {
    const gl_rt *g = self;
    glrt_timing gt;
    glrt_get_timing(g->rt, &gt);
    t->light_ms = gt.light_ms;
    t->light_gpu_ms = gt.light_gpu_ms;
    t->view_ms = g->view_ms;
    t->view_gpu_ms = gt.view_gpu_ms;
    t->raster_ms = g->raster_ms;
    t->local_ms = g->local_ms;
    t->bounce_ms = gt.bounce_ms;
    t->indirect_view_ms = g->hl_ms;
    t->bytes = gt.gpu_bytes;
    t->kernel = gt.light_method_name;
    snprintf(t->device, sizeof t->device, "%s, %s (%s context)", gt.renderer, gt.version, gt.context);
    size_t n = 0;
    for (int m = GLRT_LIGHT_FRAGMENT; m < GLRT_LIGHT_COUNT && n < sizeof t->detail; m++)
        if (gt.method_ms[m] > 0)
            n += (size_t)snprintf(t->detail + n, sizeof t->detail - n, "%s%s %.2f ms", n ? ", " : "kernels measured: ",
                                  glrt_light_method_name((glrt_light_method)m), gt.method_ms[m]);
}

const runtime_backend runtime_gl = {
    .info = { .name = "gl", .title = "GL",
              .caps = RUNTIME_CAP_IMAGES | RUNTIME_CAP_VIEW_PIXEL | RUNTIME_CAP_WINDOW | RUNTIME_CAP_GL |
                      RUNTIME_CAP_LOCAL_LIGHTS | RUNTIME_CAP_GPU_TIMERS,
              .summary = "the same sums in GLSL, per pixel (default) or per vertex; headless: OSMesa or EGL",
              /* one light change: fragment runs on every GL 3.3+ context, and timing each kernel
               * first (auto) would cost more than it saves */
              .kernels = "auto, fragment, thread, warp", .quick_kernel = "fragment",
              .indirect_view = "indirect highlights (per vertex on the CPU)" },
    .create = gl_create,
    .destroy = gl_destroy,
    .set_light = gl_set_light,
    .shade_vertices = gl_shade_vertices,
    .render = gl_render,
    .read = gl_read,
    .present = gl_present,
    .use_direct = gl_use_direct,
    .set_view = gl_set_view,
    .get_timing = gl_get_timing,
    .set_local_lights = gl_set_local_lights,
    .set_local_effects = gl_set_local_effects,
};
