/* direct.c - per-vertex direct light from local lights with shadow rays (direct.h).
 *
 * The split between light move and view change follows the PRT runtime's own (Eq. 5: the
 * light-dependent part once per light change, the view-dependent part per view): the
 * visibility and, for Lambert vertices, the whole radiance belong to the light; only a
 * glossy BRDF needs the eye. */
#include "direct.h"
#include "brdf.h"
#include "visibility.h"
#include "vec3.h"
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

struct direct_ctx {
    const prt_scene *scene;
    int nthreads;
    vis_scene *vs;
    float eps;
    prt_lights lights;
    uint8_t *vis;           /* [light][nverts]: 1 when the light reaches the vertex unoccluded */
    float *lambert;         /* [3 * nverts]: the view-independent radiance of Lambert vertices, before the texture */
    uint8_t *glossy;        /* [nverts]: 1 where the material's BRDF depends on the view */
    int *vmat;              /* [nverts]: the vertex's material, clamped to the scene's (vertex_brdf's rule) */
    float *kd_pi;           /* [3 * nmaterials]: a Lambert BRDF's value, (float)(kd / pi) as brdf_eval gives it */
    float *albedo;          /* [3 * nverts]: a textured scene's texture at each vertex (texture.h); NULL: none */
    int nglossy;
    atomic_long rays;
    direct_stats st;
};

/* The BVH, the buffers and which vertices are glossy. */
direct_ctx *direct_create(const prt_scene *scene, int nthreads, prt_error *err) {
    const prt_mesh *m = &scene->mesh;
    if (m->nverts <= 0 || m->ntris <= 0) return prt_fail(err, "local lights: the scene has no triangles"), NULL;
    direct_ctx *dc = prt_calloc(1, sizeof *dc, err);
    if (!dc) return NULL;
    dc->scene = scene;
    dc->nthreads = nthreads;
    size_t nv = (size_t)m->nverts;
    dc->vis = prt_calloc(nv * PRT_MAX_LIGHTS, 1, err);
    dc->lambert = dc->vis ? prt_calloc(3 * nv, sizeof(float), err) : NULL;
    dc->glossy = dc->lambert ? prt_calloc(nv, 1, err) : NULL;
    dc->vmat = dc->glossy ? prt_calloc(nv, sizeof(int), err) : NULL;
    dc->kd_pi = dc->vmat ? prt_calloc(3 * (size_t)(scene->nmaterials > 0 ? scene->nmaterials : 1), sizeof(float), err) : NULL;
    dc->vs = dc->kd_pi ? vis_create(m, err) : NULL;
    if (!dc->vs) { direct_destroy(dc); return NULL; }
    if (scene->ntextures > 0 && m->uv) {   /* the texture multiplies kd (scene_vertex_albedo: 1 untextured) */
        if (!(dc->albedo = prt_calloc(3 * nv, sizeof(float), err))) { direct_destroy(dc); return NULL; }
        for (int v = 0; v < m->nverts; v++) scene_vertex_albedo(scene, v, dc->albedo + 3 * (size_t)v);
    }
    dc->eps = vis_eps(dc->vs);
    for (int i = 0; i < scene->nmaterials; i++) {
        float wz[3] = { 0, 0, 1 };
        brdf_eval(&(brdf_params){ .type = BRDF_LAMBERT, .kd = { scene->materials[i].kd[0], scene->materials[i].kd[1],
                                                                 scene->materials[i].kd[2] } }, wz, wz, dc->kd_pi + 3 * i);
    }
    for (size_t v = 0; v < nv; v++) {
        int mat = m->mat ? m->mat[v] : 0;
        dc->vmat[v] = mat < scene->nmaterials ? mat : 0;
        dc->glossy[v] = scene->materials[dc->vmat[v]].type != BRDF_LAMBERT;
        dc->nglossy += dc->glossy[v];
    }
    return dc;
}

const vis_scene *direct_vis(const direct_ctx *dc) { return dc->vs; }

void direct_destroy(direct_ctx *dc) {
    if (!dc) return;
    if (dc->vs) vis_destroy(dc->vs);
    free(dc->vis);
    free(dc->lambert);
    free(dc->glossy);
    free(dc->vmat);
    free(dc->kd_pi);
    free(dc->albedo);
    free(dc);
}

static const brdf_params *vertex_brdf(const direct_ctx *dc, int v) {
    const prt_scene *s = dc->scene;
    int mat = s->mesh.mat ? s->mesh.mat[v] : 0;
    return &s->materials[mat < s->nmaterials ? mat : 0];
}

/* Whether anything blocks the segment from vertex v (offset along its normal) to the light at dist along wi. */
static bool vertex_occluded(const direct_ctx *dc, int v, const float wi[3], float dist) {
    const prt_mesh *m = &dc->scene->mesh;
    float o[3];
    v3_madd(o, m->pos + 3 * (size_t)v, m->nrm + 3 * (size_t)v, dc->eps);
    float tfar = dist - 2 * dc->eps;
    return tfar > dc->eps && vis_occluded(dc->vs, o, wi, dc->eps, tfar);
}

/* light_shade (lights.h) with wo = n, unrolled for the light move: for a Lambert vertex f_r is
 * kd / pi whatever the directions, so the local frame light_shade builds (brdf_frame: two thirds
 * of its cost) is not needed; the same float operations in the same order give the same value.
 * A glossy vertex needs only whether the light reaches it (wi above the horizon, the light
 * sending something its way): its BRDF is evaluated at the view change. Returns the distance
 * (0: the light is at the vertex), writes wi and, for Lambert, L; *any: a shadow ray is due. */
static float direct_toward(const direct_ctx *dc, const prt_light *l, int v, float wi[3], float L[3], bool *any) {
    const prt_mesh *m = &dc->scene->mesh;
    const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
    float d[3] = { l->pos[0] - p[0], l->pos[1] - p[1], l->pos[2] - p[2] };
    float dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], dist = sqrtf(dist2);
    L[0] = L[1] = L[2] = 0;
    *any = false;
    if (!(dist2 >= FLT_MIN)) return wi[0] = wi[1] = wi[2] = 0, 0;   /* at the vertex (any scale) */
    for (int k = 0; k < 3; k++) wi[k] = d[k] / dist;
    float c = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2], I[3], away[3] = { -wi[0], -wi[1], -wi[2] };
    if (!(c > 0)) return dist;
    light_intensity_toward(l, away, I);
    *any = I[0] > 0 || I[1] > 0 || I[2] > 0;
    if (dc->glossy[v] || !*any) return dist;
    const float *f = dc->kd_pi + 3 * (size_t)dc->vmat[v];
    float k = c / dist2;
    for (int ch = 0; ch < 3; ch++) L[ch] = f[ch] * I[ch] * k;
    return dist;
}

/* Light move over vertices [b, e): visibility bytes and the Lambert sums. */
static void light_range(void *ctx, int b, int e, int thread) {
    direct_ctx *dc = ctx;
    size_t nv = (size_t)dc->scene->mesh.nverts;
    long rays = 0;
    for (int v = b; v < e; v++) {
        float sum[3] = { 0, 0, 0 };
        for (int l = 0; l < dc->lights.count; l++) {
            float wi[3], L[3];
            bool any;
            float dist = direct_toward(dc, &dc->lights.light[l], v, wi, L, &any);
            bool vis = any && !vertex_occluded(dc, v, wi, dist);
            rays += any;
            dc->vis[(size_t)l * nv + v] = vis;
            if (vis && !dc->glossy[v])
                for (int c = 0; c < 3; c++) sum[c] += L[c];
        }
        for (int c = 0; c < 3; c++) dc->lambert[3 * (size_t)v + c] = isfinite(sum[c]) ? sum[c] : 0;
    }
    atomic_fetch_add(&dc->rays, rays);
}

/* Copies and validates the lights, then traces. */
int direct_set_lights(direct_ctx *dc, const prt_lights *ls, prt_error *err) {
    PRT_CHECK(dc != NULL && ls != NULL);
    if (ls->count < 0 || ls->count > PRT_MAX_LIGHTS) return prt_fail(err, "local lights: bad count %d", ls->count);
    for (int i = 0; i < ls->count; i++)
        if (light_validate(&ls->light[i], "local lights", err)) return -1;
    double t0 = prt_now();
    dc->lights = *ls;
    atomic_store(&dc->rays, 0);
    prt_parallel_for(dc->scene->mesh.nverts, 256, dc->nthreads, light_range, dc);
    dc->st.lights = ls->count;
    dc->st.rays = atomic_load(&dc->rays);
    dc->st.light_ms = 1e3 * (prt_now() - t0);
    return 0;
}

typedef struct shade_job {
    direct_ctx *dc;
    float eye[3];
    float *rgb;
    bool diffuse;           /* direct_diffuse_vertices: the kd part before the texture */
} shade_job;

/* Light l's radiance at glossy vertex v toward wo with the texture on kd (a the vertex's albedo, or
 * NULL), or (diffuse) the part kd contributes before the texture: the BRDF less itself at kd = 0,
 * every model of brdf.h being linear in kd. */
static void glossy_light(const direct_ctx *dc, const prt_light *l, int v, const float wo[3], const float *a, bool diffuse,
                         float out[3]) {
    const prt_mesh *m = &dc->scene->mesh;
    const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
    brdf_params b = *vertex_brdf(dc, v);
    float wi[3], L0[3] = { 0, 0, 0 };
    for (int c = 0; c < 3 && a && !diffuse; c++) b.kd[c] *= a[c];
    light_shade(l, &b, p, n, wo, wi, out);
    if (!diffuse) return;
    b.kd[0] = b.kd[1] = b.kd[2] = 0;
    light_shade(l, &b, p, n, wo, wi, L0);
    for (int c = 0; c < 3; c++) out[c] -= L0[c];
}

/* View change over [b, e): Lambert sums added (times the texture unless diffuse), glossy vertices
 * evaluated toward the eye. */
static void shade_range(void *ctx, int b, int e, int thread) {
    shade_job *j = ctx;
    const direct_ctx *dc = j->dc;
    const prt_mesh *m = &dc->scene->mesh;
    size_t nv = (size_t)m->nverts;
    for (int v = b; v < e; v++) {
        const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
        float wo[3] = { j->eye[0] - p[0], j->eye[1] - p[1], j->eye[2] - p[2] };
        if (v3_dot(wo, n) <= 0 || v3_normalize(wo) == 0) continue;   /* one-sided */
        float *out = j->rgb + 3 * (size_t)v;
        const float *a = dc->albedo && !j->diffuse ? dc->albedo + 3 * (size_t)v : NULL;
        if (!dc->glossy[v]) {
            for (int c = 0; c < 3; c++) out[c] += dc->lambert[3 * (size_t)v + c] * (a ? a[c] : 1.f);
            continue;
        }
        for (int l = 0; l < dc->lights.count; l++) {
            if (!dc->vis[(size_t)l * nv + v]) continue;
            float L[3];
            glossy_light(dc, &dc->lights.light[l], v, wo, a, j->diffuse, L);
            for (int c = 0; c < 3; c++)
                if (isfinite(L[c])) out[c] += L[c];
        }
    }
}

/* The view change of direct_shade_vertices (diffuse false) or direct_diffuse_vertices. */
static void shade_all(direct_ctx *dc, const float eye[3], float *rgb, bool diffuse) {
    PRT_CHECK(dc != NULL && eye != NULL);
    double t0 = prt_now();
    if (dc->lights.count > 0) {
        shade_job j = { .dc = dc, .eye = { eye[0], eye[1], eye[2] }, .rgb = rgb, .diffuse = diffuse };
        prt_parallel_for(dc->scene->mesh.nverts, 1024, dc->nthreads, shade_range, &j);
    }
    if (!diffuse) dc->st.view_ms = 1e3 * (prt_now() - t0);   /* the view change's figure, not the raster's split */
}

void direct_shade_vertices(direct_ctx *dc, const float eye[3], float *rgb) { shade_all(dc, eye, rgb, false); }

void direct_diffuse_vertices(direct_ctx *dc, const float eye[3], float *rgb) { shade_all(dc, eye, rgb, true); }

int direct_visible(const direct_ctx *dc, int l, int v) {
    PRT_CHECK(l >= 0 && l < dc->lights.count && v >= 0 && v < dc->scene->mesh.nverts);
    return dc->vis[(size_t)l * dc->scene->mesh.nverts + v];
}

void direct_get_stats(const direct_ctx *dc, direct_stats *st) {
    *st = dc->st;
    st->glossy_vertices = dc->nglossy;
}
