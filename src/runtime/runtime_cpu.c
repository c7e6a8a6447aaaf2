/* runtime_cpu.c - the "cpu" runtime backend (runtime.h) over relight.h.
 *
 * Light change: relight_set_light_at per sparse transfer, the T x L of Eq. 5 on
 * every thread; the prefiltered probe is kept for the non-linear transfers.
 * View change: relight_view, h(view) . g per vertex (the per-vertex model; the
 * paper's CPU path), plus ops->view->shade_vertices of every view-dependent transfer
 * (vmf: its lobes looked up in the prefiltered probe), non-finite sums written as 0. Images are those colours drawn with Gouraud interpolation
 * by the vertex raster (runtime_raster, gpu/render.c): headless through
 * render_vertex_colors (OSMesa, a context per image), or into the caller's
 * context (the viewer's window), whose float target runtime_present blits.
 * Without a context the raster waits for the image to be asked for (see
 * runtime.h: bench times the view change alone). A build without GL has no
 * raster: the colours and timings are whole, an image is refused with one line.
 *
 * Local lights - the hooks, for whoever adds more local-light effects:
 *   light move:  cpu_set_local_lights -> direct_set_lights (src/locallight/direct.h: Embree
 *                shadow rays per vertex on every thread; the direct_ctx is made at the first call,
 *                so runs without local lights build no BVH); timed into local_ms.
 *                Then indirect_set_lights (src/locallight/indirect.h: an RSM and two VSGLs per light,
 *                the Lambert vertices' bounce), timed into bounce_ms (part of local_ms).
 *   view change: cpu_shade_vertices, after the PRT sum (relight_view + non-linear transfers):
 *                direct_shade_vertices ADDS each light's shadowed radiance to rgb per vertex;
 *                indirect_shade_vertices ADDS the VSGL light at the glossy vertices and the
 *                indirect highlights (desc.highlight_samples rays per glossy vertex), timed
 *                into indirect_view_ms (part of view_ms);
 *                an effect computed per vertex adds its own rgb at the same place. */
#include "runtime.h"
#include "check.h"
#include "direct.h"
#include "indirect.h"
#include <math.h>
#include "relight.h"
#include <stdlib.h>
#include <string.h>

/* The vertex raster of this build, and the capabilities it gives the backend. */
#ifdef PRT_NO_GL
static const runtime_raster *const k_raster = NULL;
#define CPU_CAPS RUNTIME_CAP_LOCAL_LIGHTS
#else
static const runtime_raster *const k_raster = &runtime_raster_gl;
#define CPU_CAPS (RUNTIME_CAP_IMAGES | RUNTIME_CAP_WINDOW | RUNTIME_CAP_LOCAL_LIGHTS)
#endif

typedef struct cpu_rt {
    const prt_data *d;
    relight_ctx *rc;
    int nthreads;
    float *rgb;                 /* [3*nverts] the last view change's colours */
    float *rgb2;                /* textured scenes: [6*nverts] the raster's, the textured part then the rest */
    struct glctx *ctx;          /* the caller's, or NULL: headless */
    const runtime_raster *raster;   /* draws the colours (NULL: a build without GL) */
    void *draw;                 /* its state */
    bool has_frame;
    const struct prefilter_env *env;    /* the last light's prefiltered probe (the runtime's), or NULL */
    double light_ms, view_ms, raster_ms;
    double nonlinear_ms;        /* the non-linear transfers' part of the last view change */
    direct_ctx *direct;         /* local lights' direct light (made at the first light move), or NULL */
    double local_ms;            /* the last local-light move */
    indirect_ctx *indirect;     /* local lights' VSGL bounce and indirect highlights (made with direct), or NULL */
    indirect_desc ind_desc;
    prt_lights lights;          /* the last local lights (set_local_effects moves them again) */
    double bounce_ms, indirect_view_ms;
} cpu_rt;

/* Frees the relight context, the colours and the raster (its GL objects in the caller's context). */
static void cpu_destroy(void *self) {
    cpu_rt *c = self;
    if (!c) return;
    if (c->draw) c->raster->destroy(c->draw);
    relight_destroy(c->rc);
    indirect_destroy(c->indirect);   /* first: it borrows c->direct's BVH */
    direct_destroy(c->direct);
    free(c->rgb);
    free(c->rgb2);
    free(c);
}

/* Validates the desc's choices for this backend (one kernel, per-vertex view). */
static int cpu_check_desc(const runtime_desc *desc, prt_error *err) {
    if (desc->kernel && strcmp(desc->kernel, "auto") && strcmp(desc->kernel, "sparse"))
        return prt_fail(err, "cpu runtime: unknown light kernel '%s' (the cpu backend has one: sparse)", desc->kernel);
    if (desc->view == RUNTIME_VIEW_PIXEL)
        return prt_fail(err, "cpu runtime: shades per vertex only (it has no per-pixel view model)");
    return 0;
}

/* relight_create, the colour buffer and the raster (with a context: its GL objects). NULL with err. */
static void *cpu_create(const prt_data *d, const runtime_desc *desc, prt_error *err) {
    if (cpu_check_desc(desc, err)) return NULL;
    if (desc->ctx && !k_raster)
        return prt_fail(err, "cpu runtime: this build has no GL (NO_GL=1): it cannot draw into a GL context"), NULL;
    cpu_rt *c = prt_calloc(1, sizeof *c, err);
    if (!c) return NULL;
    c->d = d;
    c->nthreads = desc->threads;
    c->ctx = desc->ctx;
    c->raster = k_raster;
    c->ind_desc = (indirect_desc){ .hl_samples = desc->highlight_samples, .no_highlights = desc->highlight_samples <= 0,
                                   .no_bounce = !desc->local_bounce, .threads = desc->threads };
    c->rc = relight_create(d, desc->threads, err);
    c->rgb = c->rc ? prt_calloc(3 * (size_t)(d->scene.mesh.nverts > 0 ? d->scene.mesh.nverts : 1), sizeof(float), err) : NULL;
    if (!c->rgb) { cpu_destroy(c); return NULL; }
    if (desc->direct_only && prt_data_transfer(d)->direct.nvecs > 0) relight_use_direct(c->rc, true);
    if (c->raster && !(c->draw = c->raster->create(&d->scene.mesh, c->ctx, err))) { cpu_destroy(c); return NULL; }
    if (c->draw && relight_albedo(c->rc)) {   /* textures: the raster multiplies them per pixel */
        if (c->raster->set_textures(c->draw, &d->scene, err) ||
            !(c->rgb2 = prt_calloc(6 * (size_t)d->scene.mesh.nverts, sizeof(float), err))) { cpu_destroy(c); return NULL; }
    }
    return c;
}

/* Light change: g = T x L of every sparse transfer on every thread (Eq. 5), timed; the env kept. */
static int cpu_set_light(void *self, const runtime_light *light, prt_error *err) {
    cpu_rt *c = self;
    double t0 = prt_now();
    for (int i = 0; i < c->d->ntransfers; i++)
        if (c->d->transfers[i].ops->kind == TRANSFER_LINEAR) {
            PRT_CHECK(light->L[i] != NULL);
            relight_set_light_at(c->rc, i, light->L[i]);
            if (light->open[i]) relight_add_open(c->rc, i, light->open[i]);
        }
    c->env = light->env;
    c->light_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* View change: h(view) . g per vertex into rgb, plus every non-linear transfer's lobes, timed.
 * -1 with err when a non-linear transfer is asked to shade before any light change. */
static int cpu_shade_vertices(void *self, const float eye[3], int kmax, float *rgb, prt_error *err) {
    cpu_rt *c = self;
    double t0 = prt_now();
    relight_view(c->rc, eye, kmax, rgb);
    double t1 = prt_now();
    bool added = false;
    for (int i = 0; i < c->d->ntransfers; i++) {
        const prt_transfer *tr = &c->d->transfers[i];
        if (tr->ops->kind != TRANSFER_VIEW) continue;
        if (!c->env) return prt_fail(err, "cpu runtime: the %s transfer needs a light change first", tr->ops->name);
        tr->ops->view->shade_vertices(c->d, tr, c->env, eye, rgb, c->nthreads);
        added = true;
    }
    c->nonlinear_ms = 1e3 * (prt_now() - t1);
    if (c->direct) {   /* local lights: their direct light on top of the probe's PRT colour */
        direct_shade_vertices(c->direct, eye, rgb);
        added = true;
    }
    c->indirect_view_ms = 0;
    if (c->indirect) {   /* and their one bounce and indirect highlights (the probe's own interreflections
                          * are PRT's precomputed bounces: no env here, or they would count twice) */
        indirect_shade_vertices(c->indirect, eye, rgb);
        indirect_stats st;
        indirect_get_stats(c->indirect, &st);
        c->indirect_view_ms = st.view_ms;
    }
    if (added)   /* no NaN or Inf reaches an output, whatever a representation returns */
        for (size_t k = 0; k < 3 * (size_t)c->d->scene.mesh.nverts; k++)
            if (!(rgb[k] >= 0) || !isfinite(rgb[k])) rgb[k] = 0;
    c->view_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* Local-light move: shadow rays per vertex (direct.h), timed. */
static int cpu_set_local_lights(void *self, const prt_lights *ls, prt_error *err) {
    cpu_rt *c = self;
    double t0 = prt_now();
    if (!c->direct && ls->count == 0) return 0;
    if (!c->direct && !(c->direct = direct_create(&c->d->scene, c->nthreads, err))) return -1;
    int rc = direct_set_lights(c->direct, ls, err);
    c->lights = *ls;
    c->bounce_ms = 0;
    if (rc == 0 && !(c->ind_desc.no_bounce && c->ind_desc.no_highlights)) {   /* the one bounce, the highlights */
        indirect_desc id = c->ind_desc;
        id.vs = direct_vis(c->direct);   /* one BVH for the shadow rays and the bounce: c->direct outlives c->indirect */
        if (!c->indirect && !(c->indirect = indirect_create(&c->d->scene, &id, err))) return -1;
        double t1 = prt_now();
        rc = indirect_set_lights(c->indirect, ls, err);
        c->bounce_ms = 1e3 * (prt_now() - t1);
    }
    c->local_ms = 1e3 * (prt_now() - t0);
    return rc;
}

/* A textured scene's raster colours: the sparse sum and the local lights' kd part without the texture
 * (A, which the raster multiplies per pixel), then what the vertex colours hold beyond their
 * texture-sampled A (B: the vMF lobes, the lights' specular part, their bounce). */
static void raster_split(cpu_rt *c, const float eye[3], int kmax) {
    size_t n = 3 * (size_t)c->d->scene.mesh.nverts;
    float *A = c->rgb2, *B = c->rgb2 + n;
    const float *alb = relight_albedo(c->rc);
    relight_apply_albedo(c->rc, false);
    relight_view(c->rc, eye, kmax, A);
    relight_apply_albedo(c->rc, true);
    if (c->direct) direct_diffuse_vertices(c->direct, eye, A);
    for (size_t i = 0; i < n; i++) B[i] = fmaxf(c->rgb[i] - alb[i] * A[i], 0.f);
}

/* The view change, then the raster: into the context, timed, or headless kept for read. */
static int cpu_render(void *self, const render_desc *rd, int kmax, prt_error *err) {
    cpu_rt *c = self;
    if (cpu_shade_vertices(c, rd->camera.eye, kmax, c->rgb, err)) return -1;
    c->raster_ms = 0;
    c->has_frame = true;
    if (!c->draw) return 0;
    double t0 = prt_now();
    if (c->rgb2) raster_split(c, rd->camera.eye, kmax);
    int rc = c->raster->draw(c->draw, rd, c->rgb2 ? c->rgb2 : c->rgb, err);
    if (c->ctx) c->raster_ms = 1e3 * (prt_now() - t0);
    return rc;
}

/* The frame: the context's target, or rasterized now (headless, timed); -1 with err in a build
 * without GL. */
static int cpu_read(void *self, prt_image *out, prt_error *err) {
    cpu_rt *c = self;
    if (!c->has_frame) return prt_fail(err, "cpu runtime: no frame rendered yet");
    if (!c->draw)
        return prt_fail(err, "cpu runtime: this build has no GL (NO_GL=1): images need OSMesa; vertex colours "
                             "(runtime_shade_vertices, prt render --vertices) do not");
    if (c->ctx) return c->raster->read(c->draw, c->rgb2 ? c->rgb2 : c->rgb, out, err);
    double t0 = prt_now();
    int rc = c->raster->read(c->draw, c->rgb2 ? c->rgb2 : c->rgb, out, err);
    c->raster_ms = 1e3 * (prt_now() - t0);
    return rc;
}

/* The viewer's toggles: a new indirect context for the effects asked (its desc is fixed), then a light
 * move with the lights held. -1 with err. */
static int cpu_set_local_effects(void *self, bool bounce, int highlight_samples, prt_error *err) {
    cpu_rt *c = self;
    indirect_destroy(c->indirect);
    c->indirect = NULL;
    c->ind_desc.no_bounce = !bounce;
    c->ind_desc.hl_samples = highlight_samples;
    c->ind_desc.no_highlights = highlight_samples <= 0;
    return c->direct ? cpu_set_local_lights(c, &c->lights, err) : 0;
}

/* Tone-mapped blit of the target to the window (nothing headless). */
static void cpu_present(void *self, int win_w, int win_h, float exposure_stops) {
    cpu_rt *c = self;
    if (c->draw) c->raster->present(c->draw, win_w, win_h, exposure_stops);
}

/* relight_use_direct; -1 with err when the file keeps no direct set. */
static int cpu_use_direct(void *self, bool direct, prt_error *err) {
    cpu_rt *c = self;
    if (!relight_use_direct(c->rc, direct)) return prt_fail(err, "cpu runtime: the file keeps no direct-only transport");
    return 0;
}

/* Per vertex is the only model here. */
static int cpu_set_view(void *self, runtime_view view, prt_error *err) {
    runtime_desc want = { .view = view };
    return cpu_check_desc(&want, err);
}

/* Wall-clock timings of the last calls, the memory held, the thread count. */
static void cpu_get_timing(const void *self, runtime_timing *t) {
    const cpu_rt *c = self;
    t->light_ms = c->light_ms;
    t->view_ms = c->view_ms;
    t->raster_ms = c->raster_ms;
    t->local_ms = c->local_ms;
    t->bounce_ms = c->bounce_ms;
    t->indirect_view_ms = c->indirect_view_ms;
    /* Its own memory: the K-vector caches and the per-vertex position + frame records (relight.c), and
     * what the view-dependent transfers hold (ops->bytes: read at every view change). */
    size_t bytes = sizeof(float) * 12 * (size_t)c->d->scene.mesh.nverts;
    for (int i = 0; i < c->d->ntransfers; i++) {
        const prt_transfer *tr = &c->d->transfers[i];
        if (tr->ops->kind == TRANSFER_LINEAR) bytes += sizeof(float) * 3 * (size_t)tr->transport.nvecs;
        else bytes += tr->ops->bytes(tr);
    }
    t->bytes = bytes;
    t->kernel = "sparse";
    snprintf(t->device, sizeof t->device, "%d threads", prt_thread_count(c->nthreads));
    if (c->nonlinear_ms > 0)
        snprintf(t->detail, sizeof t->detail, "view change: non-linear transfers (vMF lobes) %.2f ms of it", c->nonlinear_ms);
}

const runtime_backend runtime_cpu = {
    .info = { .name = "cpu", .title = "CPU", .caps = CPU_CAPS, .kernels = "sparse",
              .summary = "T x L and h(view) . g per vertex on the CPU; images: those colours rasterized (OSMesa)",
              .indirect_view = "VSGL glossy + indirect highlights" },
    .create = cpu_create,
    .destroy = cpu_destroy,
    .set_light = cpu_set_light,
    .shade_vertices = cpu_shade_vertices,
    .render = cpu_render,
    .read = cpu_read,
    .present = cpu_present,
    .use_direct = cpu_use_direct,
    .set_view = cpu_set_view,
    .get_timing = cpu_get_timing,
    .set_local_lights = cpu_set_local_lights,
    .set_local_effects = cpu_set_local_effects,
};
