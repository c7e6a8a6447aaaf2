/* runtime.c - the runtime seam (runtime.h): the list of every backend, and what
 * all of them share: argument checks, the light (probe -> rotated cube -> each
 * linear transfer's light vector, transfer.h; and the probe prefiltered by vMF lobes
 * for the view-dependent transfers, prefilter.h, kept per probe and only rotated),
 * its timing, and the number of BRDF terms view changes use. Each backend
 * module implements the runtime_backend operations; nothing here knows what a
 * backend does, nor which representation a transfer is (it asks its kind). */
#include "runtime.h"
#include "check.h"
#include "cubemap.h"
#include "lights.h"
#include "opensky.h"
#include "prefilter.h"
#include "probecube.h"
#include "transfer.h"
#include <stdlib.h>
#include <string.h>

/* Every backend, found by name (the first is the default). Adding one: a module and a line here.
 * A build without GL (PRT_NO_GL) has no gl backend: its module is not compiled. */
static const runtime_backend *const k_backends[] = {
    &runtime_cpu,
#ifndef PRT_NO_GL
    &runtime_gl,
#endif
    &runtime_null,
};
#define NBACKENDS ((int)(sizeof k_backends / sizeof k_backends[0]))

struct prt_runtime {
    const runtime_backend *be;
    void *self;
    const prt_data *d;
    int kmax;
    double light_vector_ms;
    prefilter_env *env;         /* the last probe prefiltered (non-linear transfers), or NULL */
    const prt_probe *env_probe; /* which probe (pointer and pixels) env was made from */
    const float *env_pixels;
    runtime_probe *lent;        /* runtime_lend_probe's, or NULL */
    const prefilter_env *env_shown; /* the env the backend got last (another one is new to it), or NULL */
    int threads;                /* desc.threads */
    opensky *sky;               /* the open sky's irradiance grid when a linear transfer has the split, or NULL */
    uint8_t *sky_need;          /* [OPENSKY_NORMALS] the grid normals its vertices read (opensky_need) */
    const prt_probe *sky_probe; /* the probe (pointer and pixels) whose unrotated light the grid holds, or NULL */
    const float *sky_pixels;
    float sky_Rt[9];            /* the light's rotation transposed: E_R(n) = E(R^T n) for the unrotated grid */
    float *open[PRT_MAX_TRANSFERS];     /* [3 * nvecs] per such transfer: g E(n) per vector (a folded one's plus
                                         * T . (L' - L), rt_fold_light), 0 for the others */
    float lambert_g[PRT_MAX_MATERIALS][3];  /* constant light map of each Lambertian factor */
    float *fold_c;              /* [CUBE_TEXELS] the floor's texel mean cosines when a transfer folds (rt_fold_create), or NULL */
    float *fold_g[PRT_MAX_TRANSFERS];   /* [3 * nvecs] per folding transfer: scratch of the folded vectors' products */
};

/* The open sky of transfer i's Lambertian vectors for the grid's light (opensky.h), per vertex range. */
typedef struct rt_open_job { prt_runtime *rt; int i; } rt_open_job;
static void rt_open_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    const rt_open_job *j = ctx;
    const prt_data *d = j->rt->d;
    const prt_transfer *tr = &d->transfers[j->i];
    const prt_mesh *m = &d->scene.mesh;
    const float *Rt = j->rt->sky_Rt;
    for (int v = begin; v < end; v++) {
        int mat = m->mat ? m->mat[v] : 0;
        if (!tr->open_vert[v]) continue;
        float e[3], n[3], *o = j->rt->open[j->i] + 3 * (size_t)tr->transport.vec_first[v];
        const float *nv = m->nrm + 3 * (size_t)v;
        for (int r = 0; r < 3; r++) n[r] = Rt[3 * r] * nv[0] + Rt[3 * r + 1] * nv[1] + Rt[3 * r + 2] * nv[2];
        opensky_eval(j->rt->sky, n, e);
        for (int c = 0; c < 3; c++) o[c] = j->rt->lambert_g[mat][c] * e[c];
    }
}

static runtime_probe *rt_lent(const prt_runtime *rt, const prt_probe *p);

/* The grid of the light: for a probe p turned by R, the unrotated probe's at every grid normal, made
 * once per probe, read at R^T n (E_R(n) = E(R^T n): turning the light costs the lookups alone, as the
 * prefiltered probe's rotation does); for a cube alone (p NULL), the cube's at the normals the vertices
 * read. -1 with err. */
static int rt_open_grid(prt_runtime *rt, const float *cube, const prt_probe *p, const float R[9], prt_error *err) {
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    const float *M = p && R ? R : I;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) rt->sky_Rt[3 * r + c] = M[3 * c + r];
    if (!p) {
        rt->sky_probe = NULL;
        opensky_set_light(rt->sky, cube, rt->sky_need, rt->threads);
        return 0;
    }
    if (rt->sky_probe == p && rt->sky_pixels == p->img.data) return 0;
    float *cube0 = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    if (!cube0) return prt_fail(err, "out of memory");
    const runtime_probe *lp = rt_lent(rt, p);
    if (lp && lp->cube) probe_cube_resample(lp->cube, NULL, cube0);
    else probe_to_cube(p, CUBE_RES, NULL, 0, cube0);
    opensky_set_light(rt->sky, cube0, NULL, rt->threads);
    free(cube0);
    rt->sky_probe = p;
    rt->sky_pixels = p->img.data;
    return 0;
}

/* light->open[i] for every transfer with the open sky split (the light: rt_open_grid's). -1 with err. */
static int rt_open_light(prt_runtime *rt, const float *cube, const prt_probe *p, const float R[9], runtime_light *light,
                         prt_error *err) {
    if (!rt->sky) return 0;
    if (rt_open_grid(rt, cube, p, R, err)) return -1;
    for (int i = 0; i < rt->d->ntransfers; i++) {
        if (!rt->open[i]) continue;
        rt_open_job j = { rt, i };
        prt_parallel_for(rt->d->scene.mesh.nverts, 1024, rt->threads, rt_open_range, &j);
        light->open[i] = rt->open[i];
    }
    return 0;
}

/* The open sky's grid and per-transfer arrays when some linear transfer has the split; -1 with err. */
static int rt_open_create(prt_runtime *rt, prt_error *err) {
    const prt_data *d = rt->d;
    for (int i = 0; i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        if (tr->ops->kind != TRANSFER_LINEAR || !tr->open_sky) continue;
        if (!rt->sky && (!(rt->sky = opensky_create(err)) || !(rt->sky_need = prt_calloc(OPENSKY_NORMALS, 1, err)))) return -1;
        if (!(rt->open[i] = prt_calloc(3 * (size_t)tr->transport.nvecs + 1, sizeof(float), err))) return -1;
        const prt_mesh *m = &d->scene.mesh;
        for (int v = 0; v < m->nverts; v++)
            if (tr->open_vert[v]) opensky_need(m->nrm + 3 * (size_t)v, rt->sky_need);
    }
    for (int k = 0; k < d->scene.nmaterials && k < PRT_MAX_MATERIALS; k++)
        if (d->factors[k].lambertian) brdf_factor_lambert_light(&d->factors[k], rt->lambert_g[k]);
    return 0;
}

/* c_j of rt_fold_create into a new [CUBE_TEXELS] array: (sum over texel j's sub-texels s of the vis_res cube
 * of max(d_s.y, 0) dw_s) times 1 / Omega_j, as pc_box_filter and pc_transport_cubes form it. -1 with err. */
static int rt_fold_cosines(int vis_res, float **out, prt_error *err) {
    const int R = vis_res > 0 && vis_res % CUBE_RES == 0 ? vis_res : CUBE_RES, ss = R / CUBE_RES;
    float *dw = prt_calloc((size_t)R * R, sizeof(float), err), *c = dw ? prt_calloc(CUBE_TEXELS, sizeof(float), err) : NULL;
    float om[CUBE_RES * CUBE_RES];
    if (!c) { free(dw); return -1; }
    cube_face_solid_angles(R, dw);
    cube_face_solid_angles(CUBE_RES, om);
    for (int f = 0; f < 6; f++)
        for (int j = 0; j < CUBE_RES * CUBE_RES; j++) {
            int ti = j % CUBE_RES, tj = j / CUBE_RES;
            float a = 0;
            for (int b = 0; b < ss; b++)
                for (int q = 0; q < ss; q++) {
                    int si = (tj * ss + b) * R + ti * ss + q;
                    float dir[3];
                    cube_texel_dir(R, f * R * R + si, dir);
                    a += (dir[1] > 0.f ? dir[1] : 0.f) * dw[si];
                }
            c[f * CUBE_RES * CUBE_RES + j] = a * (1.f / om[j]);
        }
    free(dw);
    *out = c;
    return 0;
}

/* The floor's fold (opensky.h, prt_transfer.open_vert): where some transfer's vertices are folded, the
 * mean cosine c_j = a0_j((0, 1, 0)) / Omega_j of every lighting texel for the floor's normal, summed over
 * the file's visibility sub-texels as the precompute summed a0 (pc_box_filter), so both sides divide and
 * multiply by the same c_j to float rounding at any --vis-res; and each such transfer's scratch. -1 with err. */
static int rt_fold_create(prt_runtime *rt, prt_error *err) {
    const prt_data *d = rt->d;
    for (int i = 0; i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        bool any = false;
        for (int v = 0; tr->open_sky && v < d->scene.mesh.nverts && !any; v++) any = tr->open_vert[v] == OPENSKY_FOLDED;
        if (any && !(rt->fold_g[i] = prt_calloc(3 * (size_t)tr->transport.nvecs, sizeof(float), err))) return -1;
        if (any && !rt->fold_c && rt_fold_cosines(d->vis_res, &rt->fold_c, err)) return -1;
    }
    return 0;
}

/* The folded vectors of transfer i over a vertex range: open += T . (L' - L) (rt_fold_light). */
typedef struct rt_fold_job { const prt_transfer *tr; const float (*D)[4]; float *g, *open; } rt_fold_job;
static void rt_fold_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    const rt_fold_job *j = ctx;
    const prt_transport *t = &j->tr->transport;
    for (int v = begin; v < end; v++) {
        if (j->tr->open_vert[v] != OPENSKY_FOLDED) continue;
        int q0 = (int)t->vec_first[v], q1 = (int)t->vec_first[v + 1];
        transport_light_range(t, j->D, j->g, q0, q1);
        for (size_t k = 3 * (size_t)q0; k < 3 * (size_t)q1; k++) j->open[k] += j->g[k];
    }
}

/* A folded vector F holds the blocked part over c_j and reads the light L'_j = L_j c_j (the cube times
 * the floor's mean cosines, projected like any light): the backends' kernels take T . L for every
 * vector, so the open sky term of a folded one gets T . (L' - L) besides g E(n). -1 with err. */
static int rt_fold_light(prt_runtime *rt, const float *cube, runtime_light *light, prt_error *err) {
    if (!rt->fold_c) return 0;
    float *c2 = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    if (!c2) return prt_fail(err, "out of memory");
    for (int j = 0; j < CUBE_TEXELS; j++)
        for (int ch = 0; ch < 3; ch++) c2[3 * j + ch] = cube[3 * j + ch] * rt->fold_c[j];
    for (int i = 0; i < rt->d->ntransfers; i++) {
        const prt_transfer *tr = &rt->d->transfers[i];
        if (!rt->fold_g[i]) continue;
        float (*D)[4] = transfer_light_vector(tr, c2);
        if (!D) { free(c2); return prt_fail(err, "out of memory"); }
        for (int j = 0; j < CUBE_TEXELS; j++)
            for (int k = 0; k < 4; k++) D[j][k] -= light->L[i][j][k];
        rt_fold_job job = { tr, (const float (*)[4])D, rt->fold_g[i], rt->open[i] };
        prt_parallel_for(rt->d->scene.mesh.nverts, 1024, rt->threads, rt_fold_range, &job);
        free(D);
    }
    free(c2);
    return 0;
}

/* See runtime.h. */
int runtime_backend_count(void) { return NBACKENDS; }

/* Entry i of the table (a bug when out of range). */
const runtime_backend_info *runtime_backend_at(int i) {
    PRT_CHECK(i >= 0 && i < NBACKENDS);
    return &k_backends[i]->info;
}

/* The table position of the backend called name (NULL: the default), or -1. */
int runtime_backend_index(const char *name) {
    if (!name) return 0;
    for (int i = 0; i < NBACKENDS; i++)
        if (!strcmp(k_backends[i]->info.name, name)) return i;
    return -1;
}

/* The entry called name (NULL: the default), or NULL. */
const runtime_backend_info *runtime_backend_find(const char *name) {
    int i = runtime_backend_index(name);
    return i < 0 ? NULL : &k_backends[i]->info;
}

/* See runtime.h: a view transfer, or a material whose BRDF keeps K > 1 view-map terms. */
bool runtime_view_dependent(const prt_data *d) {
    bool any = runtime_needs_prefilter(d);
    for (int k = 0; k < d->scene.nmaterials && k < PRT_MAX_MATERIALS; k++) any |= d->factors[k].K > 1;
    return any;
}

/* See runtime.h. GL is asked for too: the null backend's black images also have both caps. */
const runtime_backend_info *runtime_backend_pixel(void) {
    const unsigned need = RUNTIME_CAP_IMAGES | RUNTIME_CAP_VIEW_PIXEL | RUNTIME_CAP_GL;
    for (int i = 0; i < NBACKENDS; i++)
        if ((k_backends[i]->info.caps & need) == need) return &k_backends[i]->info;
    return NULL;
}

/* See runtime.h. Per vertex, a highlight narrower than the vertex spacing is smeared over its
 * triangles (Gouraud) or missed between vertices; per pixel its lobes are interpolated instead. */
const runtime_backend_info *runtime_backend_for(const prt_data *d) {
    const runtime_backend_info *px = runtime_view_dependent(d) ? runtime_backend_pixel() : NULL;
    return px ? px : &k_backends[0]->info;
}

/* "cpu, gl, null": the names with every capability in need, cut to cap bytes. */
const char *runtime_backend_names(char *buf, size_t cap, unsigned need) {
    PRT_CHECK(buf != NULL && cap > 0);
    buf[0] = 0;
    size_t n = 0;
    for (int i = 0; i < NBACKENDS && n < cap; i++) {
        const runtime_backend_info *b = &k_backends[i]->info;
        if ((b->caps & need) != need) continue;
        int w = snprintf(buf + n, cap - n, "%s%s", n ? ", " : "", b->name);
        n += w > 0 ? (size_t)w : 0;
    }
    return buf;
}

/* A view model the enum has; -1 with err (the backend says whether it has it). */
static int check_view(const runtime_backend *be, runtime_view view, prt_error *err) {
    if (view < RUNTIME_VIEW_DEFAULT || view > RUNTIME_VIEW_VERTEX)
        return prt_fail(err, "%s runtime: bad view model %d", be->info.name, (int)view);
    return 0;
}

static void runtime_destroy_parts(prt_runtime *rt);

/* See runtime.h; the caller owns the runtime (runtime_destroy). */
prt_runtime *runtime_create(const prt_data *d, const runtime_desc *desc, prt_error *err) {
    PRT_CHECK(d != NULL);
    runtime_desc dd = desc ? *desc : (runtime_desc){ 0 };
    if (!dd.backend) dd.backend = k_backends[0]->info.name;
    int bi = runtime_backend_index(dd.backend);
    if (bi < 0) {
        char names[256];
        return prt_fail(err, "unknown backend '%s' (known: %s)", dd.backend, runtime_backend_names(names, sizeof names, 0)), NULL;
    }
    const runtime_backend *be = k_backends[bi];
    if (dd.terms < 0) return prt_fail(err, "%s runtime: bad term count %d", be->info.name, dd.terms), NULL;
    if (check_view(be, dd.view, err)) return NULL;
    prt_runtime *rt = prt_calloc(1, sizeof *rt, err);
    if (!rt) return NULL;
    rt->be = be;
    rt->d = d;
    rt->threads = dd.threads;
    if (rt_open_create(rt, err) || rt_fold_create(rt, err)) {
        runtime_destroy_parts(rt);
        return NULL;
    }
    rt->kmax = dd.terms;
    rt->self = be->create(d, &dd, err);
    if (!rt->self) { runtime_destroy_parts(rt); return NULL; }
    return rt;
}

/* Frees the runtime's own parts and the runtime (not the backend state). */
static void runtime_destroy_parts(prt_runtime *rt) {
    opensky_destroy(rt->sky);
    free(rt->sky_need);
    for (int i = 0; i < PRT_MAX_TRANSFERS; i++) free(rt->open[i]), free(rt->fold_g[i]);
    free(rt->fold_c);
    prefilter_destroy(rt->env);
    free(rt);
}

/* Frees the backend state and the runtime; NULL is fine. */
void runtime_destroy(prt_runtime *rt) {
    if (!rt) return;
    rt->be->destroy(rt->self);
    runtime_destroy_parts(rt);
}

/* light->L[i] for every linear transfer, from the cube (allocated: the caller frees them). */
static int rt_light_vectors(const prt_runtime *rt, const float *cube, runtime_light *light, prt_error *err) {
    for (int i = 0; i < rt->d->ntransfers; i++) {
        const prt_transfer *tr = &rt->d->transfers[i];
        if (tr->ops->kind != TRANSFER_LINEAR) continue;
        float (*L)[4] = transfer_light_vector(tr, cube);
        if (!L) return prt_fail(err, "out of memory");
        light->L[i] = (const float (*)[4])L;
    }
    return 0;
}

/* See runtime.h: a transfer shades with the prefiltered probe. */
bool runtime_needs_prefilter(const prt_data *d) {
    bool need = false;
    for (int i = 0; i < d->ntransfers; i++) need |= d->transfers[i].ops->kind == TRANSFER_VIEW;
    return need;
}

/* The lent probe when it is p (pointer and pixels), else NULL. */
static runtime_probe *rt_lent(const prt_runtime *rt, const prt_probe *p) {
    return rt->lent && p && rt->lent->probe == p && rt->lent->pixels == p->img.data ? rt->lent : NULL;
}

/* light->env when some transfer shades with the prefiltered probe: the lent one's, else made for a new
 * probe (pointer or pixels), else only rotated; new to the backend when it is not the one it got last.
 * -1 with err. */
static int rt_prefilter(prt_runtime *rt, const prt_probe *p, const float R[9], runtime_light *light, prt_error *err) {
    if (!runtime_needs_prefilter(rt->d)) return 0;
    runtime_probe *lp = rt_lent(rt, p);
    if (lp && lp->env) {
        prefilter_destroy(rt->env);   /* the lent one serves this probe: the runtime's own is not needed */
        rt->env = NULL;
        rt->env_probe = NULL;
        light->env = lp->env;
    } else if (rt->env && rt->env_probe == p && rt->env_pixels == p->img.data) {
        light->env = rt->env;
    } else {
        prefilter_destroy(rt->env);
        rt->env_probe = NULL;
        rt->env_shown = NULL;
        rt->env = prefilter_create(p, R, &(prefilter_desc){ 0 }, err);
        if (!rt->env) return -1;
        rt->env_probe = p;
        rt->env_pixels = p->img.data;
        light->env = rt->env;
    }
    prefilter_set_rotation((prefilter_env *)light->env, R);
    light->env_new = light->env != rt->env_shown;
    rt->env_shown = light->env;
    return 0;
}

/* The light vectors of cube (and the prefiltered probe p, when some transfer needs it), then the
 * backend's light change; t0 starts the light-vector timing. */
static int rt_set_light(prt_runtime *rt, const float *cube, const prt_probe *p, const float R[9], double t0, prt_error *err) {
    runtime_light light;
    memset(&light, 0, sizeof light);
    int rc = rt_light_vectors(rt, cube, &light, err);
    if (rc == 0) rc = rt_open_light(rt, cube, p, R, &light, err);
    if (rc == 0) rc = rt_fold_light(rt, cube, &light, err);
    if (rc == 0) rc = rt_prefilter(rt, p, R, &light, err);
    rt->light_vector_ms = 1e3 * (prt_now() - t0);
    if (rc == 0) rc = rt->be->set_light(rt->self, &light, err);
    for (int i = 0; i < PRT_MAX_TRANSFERS; i++) free((void *)light.L[i]);
    return rc;
}

/* The light (timed: cube, light vectors, prefiltering), then the backend's light change. */
int runtime_set_light(prt_runtime *rt, const prt_probe *p, const float R[9], prt_error *err) {
    PRT_CHECK(rt != NULL && p != NULL);
    double t0 = prt_now();
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    if (!cube) return prt_fail(err, "out of memory");
    const runtime_probe *lp = rt_lent(rt, p);
    if (lp && lp->cube) probe_cube_resample(lp->cube, R, cube);
    else probe_to_cube(p, CUBE_RES, R, 0, cube);
    int rc = rt_set_light(rt, cube, p, R, t0, err);
    free(cube);
    return rc;
}

/* The light change of a cube already resampled; -1 with err when a transfer needs the probe itself. */
int runtime_set_light_cube(prt_runtime *rt, const float *cube, prt_error *err) {
    PRT_CHECK(rt != NULL && cube != NULL);
    for (int i = 0; i < rt->d->ntransfers; i++)
        if (rt->d->transfers[i].ops->kind == TRANSFER_VIEW)
            return prt_fail(err, "a %s transfer needs the probe itself, not its cube", rt->d->transfers[i].ops->name);
    return rt_set_light(rt, cube, NULL, NULL, prt_now(), err);
}

/* The light change of light vectors already projected; -1 with err when a transfer needs the probe. */
int runtime_set_light_vectors(prt_runtime *rt, const float (*const L[PRT_MAX_TRANSFERS])[4], prt_error *err) {
    PRT_CHECK(rt != NULL && L != NULL);
    runtime_light light;
    memset(&light, 0, sizeof light);
    for (int i = 0; i < rt->d->ntransfers; i++) {
        const transfer_ops *ops = rt->d->transfers[i].ops;
        if (ops->kind == TRANSFER_VIEW) return prt_fail(err, "a %s transfer needs the probe itself, not a light vector", ops->name);
        if (rt->d->transfers[i].open_sky)
            return prt_fail(err, "the %s transfer's open sky needs the light's cube, not its light vector", ops->name);
        PRT_CHECK(L[i] != NULL);
        light.L[i] = L[i];
    }
    rt->light_vector_ms = 0;   /* made by the caller */
    return rt->be->set_light(rt->self, &light, err);
}

/* The fine cube and, when d needs it, the prefiltered probe of p, timed; -1 with err. */
int runtime_probe_prepare(const prt_data *d, const prt_probe *p, int threads, runtime_probe *out, prt_error *err) {
    PRT_CHECK(d != NULL && p != NULL && out != NULL);
    memset(out, 0, sizeof *out);
    double t0 = prt_now();
    out->probe = p;
    out->pixels = p->img.data;
    out->cube = probe_cube_create(p, &(probe_cube_desc){ .res = CUBE_RES, .threads = threads }, err);
    if (!out->cube) return -1;
    if (runtime_needs_prefilter(d) && !(out->env = prefilter_create(p, NULL, &(prefilter_desc){ .threads = threads }, err))) {
        runtime_probe_free(out);
        return -1;
    }
    out->ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* Frees the fine cube and the prefiltered probe. */
void runtime_probe_free(runtime_probe *rp) {
    if (!rp) return;
    probe_cube_destroy(rp->cube);
    prefilter_destroy(rp->env);
    memset(rp, 0, sizeof *rp);
}

/* Lends rp (NULL: none) for its probe's light changes. */
void runtime_lend_probe(prt_runtime *rt, runtime_probe *rp) {
    PRT_CHECK(rt != NULL);
    if (rp != rt->lent) rt->env_shown = NULL;   /* another probe's env: the backend takes it as new */
    rt->lent = rp;
}

/* Vertex colours toward eye with the current term count; -1 with err when the backend has none. */
int runtime_shade_vertices(prt_runtime *rt, const float eye[3], float *rgb, prt_error *err) {
    PRT_CHECK(rt != NULL && eye != NULL);
    if (rt->d->scene.mesh.nverts > 0) PRT_CHECK(rgb != NULL);
    if (!rt->be->shade_vertices) return prt_fail(err, "the %s backend cannot shade vertex colours", rt->be->info.name);
    return rt->be->shade_vertices(rt->self, eye, rt->kmax, rgb, err);
}

/* Resolves the frame size, draws, and reads back when asked. */
int runtime_render(prt_runtime *rt, const render_desc *rd, prt_image *out, prt_error *err) {
    PRT_CHECK(rt != NULL && rd != NULL);
    if (out) memset(out, 0, sizeof *out);
    render_desc r = *rd;
    if (r.width == 0 && r.height == 0) { r.width = 800; r.height = 600; }
    if (r.width <= 0 || r.height <= 0 || r.width > 16384 || r.height > 16384)
        return prt_fail(err, "render: image size %dx%d out of range (1..16384)", r.width, r.height);
    if (rt->be->render(rt->self, &r, rt->kmax, err)) return -1;
    return out ? rt->be->read(rt->self, out, err) : 0;
}

/* The last frame, read back (the caller frees it); -1 with err. */
int runtime_read(prt_runtime *rt, prt_image *out, prt_error *err) {
    PRT_CHECK(rt != NULL && out != NULL);
    memset(out, 0, sizeof *out);
    return rt->be->read(rt->self, out, err);
}

/* Blits the last frame to the window (nothing without a window context). */
void runtime_present(prt_runtime *rt, int win_w, int win_h, float exposure_stops) {
    PRT_CHECK(rt != NULL);
    if (rt->be->present) rt->be->present(rt->self, win_w, win_h, exposure_stops);
}

/* Direct-only (true) or total (false) transport for the next light change; -1 with err. */
int runtime_use_direct(prt_runtime *rt, bool direct, prt_error *err) {
    PRT_CHECK(rt != NULL);
    if (direct && prt_data_transfer(rt->d)->direct.nvecs == 0)
        return prt_fail(err, "the file keeps no direct-only transport (precompute it with --keep-direct)");
    return rt->be->use_direct(rt->self, direct, err);
}

/* The backend's local-light move; -1 with err when it has none. */
int runtime_set_local_lights(prt_runtime *rt, const prt_lights *ls, prt_error *err) {
    PRT_CHECK(rt != NULL && ls != NULL);
    if (!rt->be->set_local_lights) return prt_fail(err, "the %s backend has no local lights yet", rt->be->info.name);
    if (ls->count < 0 || ls->count > PRT_MAX_LIGHTS) return prt_fail(err, "local lights: bad count %d", ls->count);
    for (int i = 0; i < ls->count; i++)
        if (light_validate(&ls->light[i], "local lights", err)) return -1;
    return rt->be->set_local_lights(rt->self, ls, err);
}

/* The local lights' one bounce and highlights on or off (the viewer's keys); a light move. */
int runtime_set_local_effects(prt_runtime *rt, bool bounce, int highlight_samples, prt_error *err) {
    PRT_CHECK(rt != NULL && highlight_samples >= 0);
    if (!rt->be->set_local_effects) return prt_fail(err, "the %s backend cannot switch local-light effects", rt->be->info.name);
    return rt->be->set_local_effects(rt->self, bounce, highlight_samples, err);
}

/* BRDF terms of the next view changes (0: all). */
void runtime_set_terms(prt_runtime *rt, int kmax) {
    PRT_CHECK(rt != NULL && kmax >= 0);
    rt->kmax = kmax;
}

/* The backend's view model; -1 with err when it lacks the one asked for. */
int runtime_set_view(prt_runtime *rt, runtime_view view, prt_error *err) {
    PRT_CHECK(rt != NULL);
    if (check_view(rt->be, view, err)) return -1;
    return rt->be->set_view(rt->self, view, err);
}

/* The backend's timings, plus the light vector time and the backend name kept here. */
void runtime_get_timing(const prt_runtime *rt, runtime_timing *t) {
    PRT_CHECK(rt != NULL && t != NULL);
    memset(t, 0, sizeof *t);
    rt->be->get_timing(rt->self, t);
    t->backend = rt->be->info.name;
    t->light_vector_ms = rt->light_vector_ms;
}

/* The name the backend was found by. */
const char *runtime_backend_name(const prt_runtime *rt) { return rt->be->info.name; }

/* The runtime's table entry. */
const runtime_backend_info *runtime_info(const prt_runtime *rt) { return &rt->be->info; }
