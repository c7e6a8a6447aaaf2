/* runtime_null.c - the "null" runtime backend (runtime.h): every step but drawing.
 *
 * As sokol's dummy backend: it takes every call the other backends take and
 * refuses what they refuse (runtime.c checks the arguments and computes the
 * light vector, and the prefiltered probe where a transfer needs it, exactly as
 * for them), keeps the bookkeeping a caller can observe (a frame drawn and its
 * size, a light change made before a non-linear transfer shades) and reports
 * zero times. Vertex colours are zeros and images black at the asked size, so
 * a caller's whole path runs without GL, threads or a GPU: a test of the seam,
 * and a build without GL can still take every runtime call. */
#include "runtime.h"
#include "check.h"
#include <stdlib.h>
#include <string.h>

typedef struct null_rt {
    const prt_data *d;
    const struct prefilter_env *env;    /* the last light's prefiltered probe (the runtime's), or NULL */
    int width, height;          /* the last frame's size (resolved by runtime.c) */
    bool has_frame;
} null_rt;

/* Frees the state. */
static void null_destroy(void *self) { free(self); }

/* The state; a light kernel it does not know is refused as the others refuse theirs. NULL with err. */
static void *null_create(const prt_data *d, const runtime_desc *desc, prt_error *err) {
    if (desc->kernel && strcmp(desc->kernel, "auto") && strcmp(desc->kernel, "none"))
        return prt_fail(err, "null runtime: unknown light kernel '%s' (the null backend has one: none)", desc->kernel), NULL;
    null_rt *n = prt_calloc(1, sizeof *n, err);
    if (n) n->d = d;
    return n;
}

/* A light change: the vectors were made (runtime.c); nothing is multiplied. The env kept. */
static int null_set_light(void *self, const runtime_light *light, prt_error *err) {
    null_rt *n = self;
    n->env = light->env;
    return 0;
}

/* -1 with err when a non-linear transfer would shade before any light change (the cpu backend's rule). */
static int unlit(const null_rt *n, prt_error *err) {
    for (int i = 0; i < n->d->ntransfers; i++)
        if (n->d->transfers[i].ops->kind == TRANSFER_VIEW && !n->env)
            return prt_fail(err, "null runtime: the %s transfer needs a light change first", n->d->transfers[i].ops->name);
    return 0;
}

/* Zero radiance at every vertex; -1 with err when a non-linear transfer is asked to shade before any
 * light change, as the cpu backend. */
static int null_shade_vertices(void *self, const float eye[3], int kmax, float *rgb, prt_error *err) {
    null_rt *n = self;
    if (unlit(n, err)) return -1;
    if (n->d->scene.mesh.nverts > 0) memset(rgb, 0, sizeof(float) * 3 * (size_t)n->d->scene.mesh.nverts);
    return 0;
}

/* A frame: the view change (zeros), its size kept. */
static int null_render(void *self, const render_desc *rd, int kmax, prt_error *err) {
    null_rt *n = self;
    if (unlit(n, err)) return -1;
    n->width = rd->width;
    n->height = rd->height;
    n->has_frame = true;
    return 0;
}

/* The last frame: black at its size; -1 with err before any frame, as every backend. */
static int null_read(void *self, prt_image *out, prt_error *err) {
    null_rt *n = self;
    if (!n->has_frame) return prt_fail(err, "null runtime: no frame rendered yet");
    return image_alloc(out, n->width, n->height, 3, err);
}

/* Nothing to switch (runtime.c checked that the file has a direct set). */
static int null_use_direct(void *self, bool direct, prt_error *err) { return 0; }

/* Either view model: neither draws anything. */
static int null_set_view(void *self, runtime_view view, prt_error *err) { return 0; }

/* Zero times and bytes; the names. */
static void null_get_timing(const void *self, runtime_timing *t) {
    t->kernel = "none";
    snprintf(t->device, sizeof t->device, "nothing (draws nothing)");
}

/* Nothing to light (runtime.c validated the lights). */
static int null_set_local_lights(void *self, const prt_lights *ls, prt_error *err) { return 0; }

/* Nothing to switch. */
static int null_set_local_effects(void *self, bool bounce, int highlight_samples, prt_error *err) { return 0; }

const runtime_backend runtime_null = {
    .info = { .name = "null", .title = "null", .caps = RUNTIME_CAP_IMAGES | RUNTIME_CAP_VIEW_PIXEL | RUNTIME_CAP_LOCAL_LIGHTS,
              .summary = "every step but drawing: zero colours, black images, zero times (tests)",
              .kernels = "none", .indirect_view = "nothing (it draws nothing)" },
    .create = null_create,
    .destroy = null_destroy,
    .set_light = null_set_light,
    .shade_vertices = null_shade_vertices,
    .render = null_render,
    .read = null_read,
    .present = NULL,
    .use_direct = null_use_direct,
    .set_view = null_set_view,
    .get_timing = null_get_timing,
    .set_local_lights = null_set_local_lights,
    .set_local_effects = null_set_local_effects,
};
