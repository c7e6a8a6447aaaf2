/* indirect.c - VSGL bounce and indirect highlights per vertex (indirect.h).
 *
 * The split follows direct.h: what does not depend on the view (a Lambert vertex's VSGL
 * light) is summed at the light move; a view change re-shades only the glossy vertices. */
#include "indirect.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define IC_MAX_THREADS 64

struct indirect_ctx {
    const prt_scene *scene;
    indirect_desc d;
    int nthreads;
    const vis_scene *vs;  /* desc.vs (borrowed) or own_vs */
    vis_scene *own_vs;
    lightmat *lm;
    rsm *r;
    const prefilter_env *env;
    prt_lights lights;
    vsgl_pair vsgl[PRT_MAX_LIGHTS];
    float *lambert_rgb;          /* [3 nverts] view-independent VSGL light of the Lambert vertices */
    uint8_t *glossy;             /* [nverts] material has a lobe */
    const float *eye;            /* the view change's eye (during indirect_shade_vertices) */
    float *out;                  /* its target */
    long rays[IC_MAX_THREADS];
    indirect_stats st;
};

/* BVH, lobes, an RSM of the desc's resolution, and the per-vertex buffers. */
indirect_ctx *indirect_create(const prt_scene *scene, const indirect_desc *desc, prt_error *err)
{
    indirect_ctx *ic = prt_calloc(1, sizeof *ic, err);
    if (!ic) return NULL;
    ic->scene = scene;
    if (desc) ic->d = *desc;
    ic->nthreads = prt_thread_count(ic->d.threads);
    if (ic->nthreads > IC_MAX_THREADS) ic->nthreads = IC_MAX_THREADS;
    int n = scene->mesh.nverts;
    if (!ic->d.vs) ic->vs = ic->own_vs = vis_create(&scene->mesh, err);
    else ic->vs = ic->d.vs;
    if (!ic->vs || !(ic->lm = lightmat_create(scene, err)) ||
        !(ic->r = rsm_create(&(rsm_desc){ .res = ic->d.rsm_res, .threads = ic->nthreads }, err)) ||
        !(ic->lambert_rgb = prt_calloc(3 * (size_t)n, sizeof(float), err)) ||
        !(ic->glossy = prt_calloc((size_t)n, 1, err))) {
        indirect_destroy(ic);
        return NULL;
    }
    for (int v = 0; v < n; v++) {
        ic->glossy[v] = lightmat_glossy(ic->lm, scene->mesh.mat ? scene->mesh.mat[v] : 0);
        ic->st.glossy_vertices += ic->glossy[v];
    }
    return ic;
}

/* Frees what indirect_create made. */
void indirect_destroy(indirect_ctx *ic)
{
    if (!ic) return;
    rsm_destroy(ic->r);
    lightmat_destroy(ic->lm);
    if (ic->own_vs) vis_destroy(ic->own_vs);
    free(ic->lambert_rgb);
    free(ic->glossy);
    free(ic);
}

void indirect_set_env(indirect_ctx *ic, const prefilter_env *env) { ic->env = env; }

const vsgl_pair *indirect_vsgls(const indirect_ctx *ic, int l)
{
    PRT_CHECK(l >= 0 && l < ic->lights.count);
    return &ic->vsgl[l];
}

void indirect_get_stats(const indirect_ctx *ic, indirect_stats *st) { *st = ic->st; }

static int ic_mat(const indirect_ctx *ic, int v) { return ic->scene->mesh.mat ? ic->scene->mesh.mat[v] : 0; }

/* The Lambert vertices' VSGL light from every light (the receiver's diffuse lobe only). */
static void ic_lambert(void *ctx, int begin, int end, int thread)
{
    indirect_ctx *ic = ctx;
    const prt_mesh *m = &ic->scene->mesh;
    for (int v = begin; v < end; v++) {
        float *o = ic->lambert_rgb + 3 * (size_t)v, L[3];
        o[0] = o[1] = o[2] = 0;
        if (ic->glossy[v] || ic->d.no_bounce) continue;
        const float *kd = lightmat_brdf(ic->lm, ic_mat(ic, v))->kd;
        for (int l = 0; l < ic->lights.count; l++) {
            vsgl_shade_lambert(&ic->vsgl[l], kd, m->pos + 3 * (size_t)v, m->nrm + 3 * (size_t)v, L);
            v3_add(o, o, L);
        }
    }
}

/* Light move: an RSM and two VSGLs per light, then the Lambert vertices. */
int indirect_set_lights(indirect_ctx *ic, const prt_lights *ls, prt_error *err)
{
    double t0 = prt_now(), trsm = 0;
    PRT_CHECK(ls->count >= 0 && ls->count <= PRT_MAX_LIGHTS);
    for (int l = 0; l < ls->count; l++)
        if (light_validate(&ls->light[l], "local light", err)) return -1;
    ic->lights = *ls;
    for (int l = 0; l < ls->count && !ic->d.no_bounce; l++) {
        trsm += rsm_render(ic->r, &ls->light[l], ic->vs, &ic->scene->mesh, ic->lm);
        vsgl_build(ic->r, &ic->vsgl[l]);
    }
    prt_parallel_for(ic->scene->mesh.nverts, 1024, ic->nthreads, ic_lambert, ic);
    ic->st.lights = ls->count;
    ic->st.rsm_ms = 1e3 * trsm;
    ic->st.light_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* View change for a range of vertices: Lambert sums, glossy VSGL light and highlights. */
static void ic_view(void *ctx, int begin, int end, int thread)
{
    indirect_ctx *ic = ctx;
    const prt_mesh *m = &ic->scene->mesh;
    hl_scene sc = { .vs = ic->vs, .mesh = m, .lm = ic->lm, .env = ic->env };
    hl_desc hd = { .samples = ic->d.hl_samples, .clusters = ic->d.hl_clusters };
    for (int v = begin; v < end; v++) {
        const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
        float wo[3], acc[3] = { 0, 0, 0 }, L[3];
        v3_sub(wo, ic->eye, p);
        if (v3_normalize(wo) == 0.f || v3_dot(wo, n) <= 0) continue;
        if (!ic->glossy[v]) {
            v3_copy(acc, ic->lambert_rgb + 3 * (size_t)v);
        } else {
            for (int l = 0; l < ic->lights.count && !ic->d.no_bounce; l++) {   /* glossy lobe: see highlights.h */
                if (ic->d.no_highlights) vsgl_shade(&ic->vsgl[l], ic->lm, ic_mat(ic, v), p, n, wo, L);
                else vsgl_shade_diffuse(&ic->vsgl[l], ic->lm, ic_mat(ic, v), p, n, L);
                v3_add(acc, acc, L);
            }
            if (!ic->d.no_highlights) {
                hl_stats hs;
                hl_shade(&sc, &hd, ic->lights.light, ic->lights.count, p, n, ic_mat(ic, v), wo, (uint64_t)v, L, &hs);
                v3_add(acc, acc, L);
                ic->rays[thread] += hs.rays + hs.shadow_rays;
            }
        }
        for (int k = 0; k < 3; k++)
            if (isfinite(acc[k]) && acc[k] > 0) ic->out[3 * (size_t)v + k] += acc[k];
    }
}

/* View change on every thread. */
void indirect_shade_vertices(indirect_ctx *ic, const float eye[3], float *rgb)
{
    double t0 = prt_now();
    ic->eye = eye;
    ic->out = rgb;
    memset(ic->rays, 0, sizeof ic->rays);
    if (ic->lights.count > 0) prt_parallel_for(ic->scene->mesh.nverts, 256, ic->nthreads, ic_view, ic);
    ic->st.hl_rays = 0;
    for (int t = 0; t < IC_MAX_THREADS; t++) ic->st.hl_rays += ic->rays[t];
    ic->st.view_ms = 1e3 * (prt_now() - t0);
    ic->eye = NULL;
    ic->out = NULL;
}
