/* rsm.c - a reflective shadow map traced with Embree (rsm.h).
 *
 * One photon per texel, traced from the light: the CPU stand-in for a rasterized RSM,
 * exact in the texel directions and solid angles, so the VSGLs built from it (vsgl.h)
 * carry exactly the power the light sends into the scene. */
#include "rsm.h"
#include "cubemap.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>

struct rsm {
    int res;
    int threads;
    int count;          /* texels of the last render */
    int cap;            /* texels allocated (six faces) */
    rsm_texel *texel;
};

typedef struct rsm_job {
    rsm *r;
    const prt_light *l;
    const vis_scene *vs;
    const prt_mesh *mesh;
    const lightmat *lm;
    bool square;
    float axis[3], u[3], v[3], a;   /* square layout: dir = axis + a (sc u + tc v) */
} rsm_job;

/* Allocates six faces of res^2 texels (the square layout uses the first). */
rsm *rsm_create(const rsm_desc *desc, prt_error *err)
{
    int res = desc && desc->res ? desc->res : RSM_DEFAULT_RES;
    if (res < 4 || res > 1024) {
        prt_fail(err, "rsm: resolution %d is outside [4, 1024]", res);
        return NULL;
    }
    rsm *r = prt_calloc(1, sizeof *r, err);
    if (!r) return NULL;
    r->res = res;
    r->threads = prt_thread_count(desc ? desc->threads : 0);
    r->cap = 6 * res * res;
    r->texel = prt_calloc((size_t)r->cap, sizeof *r->texel, err);
    if (!r->texel) {
        free(r);
        return NULL;
    }
    return r;
}

/* Frees the texels and the map. */
void rsm_destroy(rsm *r)
{
    if (!r) return;
    free(r->texel);
    free(r);
}

/* Solid angle of [x0,x1] x [y0,y1] on the plane at unit distance (gnomonic area formula). */
static double rect_solid_angle(double x0, double x1, double y0, double y1)
{
#define F_(x, y) atan2((x) * (y), sqrt((x) * (x) + (y) * (y) + 1.0))
    return F_(x1, y1) - F_(x0, y1) - F_(x1, y0) + F_(x0, y0);
#undef F_
}

/* Texel (i, j) of face f: unit direction and exact solid angle. */
static void rsm_texel_dir(const rsm_job *j, int f, int i, int jj, float dir[3], float *omega)
{
    int res = j->r->res;
    if (!j->square) {
        cube_texel_dir(res, f * res * res + jj * res + i, dir);
        *omega = (float)cube_texel_solid_angle(res, i, jj);
        return;
    }
    double h = 2.0 / res, x0 = -1 + i * h, y0 = -1 + jj * h, a = j->a;
    float sc = (float)(x0 + h / 2), tc = (float)(y0 + h / 2);
    for (int k = 0; k < 3; k++) dir[k] = j->axis[k] + j->a * (sc * j->u[k] + tc * j->v[k]);
    v3_normalize(dir);
    *omega = (float)rect_solid_angle(a * x0, a * (x0 + h), a * y0, a * (y0 + h));
}

/* The VPL at a hit: interpolated position and normal, material of the first vertex (as the
 * path tracer), its reflectances, glossy lobe and footprint. */
static void rsm_fill_hit(const rsm_job *j, const vis_hit *h, const float dir[3], float omega, rsm_texel *t)
{
    t->mat = lightmat_surface(j->lm, j->mesh, h, t->pos, t->nrm);
    float ng[3];
    v3_copy(ng, h->ng);
    v3_normalize(ng);
    v3_scale(t->wi, dir, -1.f);
    float cg = fmaxf(fabsf(v3_dot(ng, t->wi)), 0.05f);
    t->area = omega * h->t * h->t / cg;
    if (v3_dot(t->nrm, t->wi) <= 0.f) return;       /* lit from behind: reflects nothing */
    v3_copy(t->kd, lightmat_brdf(j->lm, t->mat)->kd);
    if (!lightmat_lobe(j->lm, t->mat, t->nrm, t->wi, &t->spec, t->ks)) t->ks[0] = t->ks[1] = t->ks[2] = 0;
}

/* One row of one face: res rays from the light in packets (vis_closest_many). */
static void rsm_row(void *ctx, int begin, int end, int thread)
{
    const rsm_job *j = ctx;
    int res = j->r->res;
    float *dirs = malloc(sizeof(float) * 3 * res), *omega = malloc(sizeof(float) * res);
    vis_hit *hits = malloc(sizeof *hits * res);
    PRT_CHECK(dirs && omega && hits);
    for (int row = begin; row < end; row++) {
        int f = row / res, jj = row % res;
        for (int i = 0; i < res; i++) rsm_texel_dir(j, f, i, jj, dirs + 3 * i, omega + i);
        vis_closest_many(j->vs, j->l->pos, dirs, res, 0.f, hits);
        for (int i = 0; i < res; i++) {
            rsm_texel *t = j->r->texel + (size_t)row * res + i;
            *t = (rsm_texel){ .mat = -1 };
            float I[3];
            light_intensity_toward(j->l, dirs + 3 * i, I);
            v3_scale(t->flux, I, omega[i]);
            if (hits[i].tri >= 0) rsm_fill_hit(j, hits + i, dirs + 3 * i, omega[i], t);
        }
    }
    free(dirs);
    free(omega);
    free(hits);
}

/* Picks the layout, then traces every row on the map's threads. */
double rsm_render(rsm *r, const prt_light *l, const vis_scene *vs, const prt_mesh *mesh, const lightmat *lm)
{
    double t0 = prt_now();
    rsm_job j = { .r = r, .l = l, .vs = vs, .mesh = mesh, .lm = lm };
    j.square = l->type == PRT_LIGHT_SPOT && l->outer_deg < RSM_SQUARE_MAX_DEG;
    if (j.square) {
        v3_copy(j.axis, l->dir);
        v3_normalize(j.axis);
        float s[3], t[3];
        brdf_frame(j.axis, s, t);
        v3_copy(j.u, s);
        v3_copy(j.v, t);
        j.a = tanf(l->outer_deg * (float)(M_PI / 180.0));
    }
    int rows = (j.square ? 1 : 6) * r->res;
    r->count = rows * r->res;
    prt_parallel_for(rows, 4, r->threads, rsm_row, &j);
    return prt_now() - t0;
}

int rsm_count(const rsm *r) { return r->count; }
const rsm_texel *rsm_texels(const rsm *r) { return r->texel; }

/* Sums the photons' flux in double. */
void rsm_total_flux(const rsm *r, double out[3])
{
    out[0] = out[1] = out[2] = 0;
    for (int i = 0; i < r->count; i++)
        for (int k = 0; k < 3; k++) out[k] += r->texel[i].flux[k];
}
