/* relight.c - CPU relighting with Eq. 5: colour = h(view) . g(light) per vertex.
 *
 * A light change recomputes the light-dependent K-vectors g = T x L for every
 * transport vector (the transfer representation's CPU kernel, transfer_light, both
 * cores) and caches them. A view change
 * then costs, per vertex, one normalization, a frame change into the vertex's
 * Eq. 10 tangent frame (precomputed here once), a bilinear lookup of the K view
 * maps h_k (brdf_factor_view) and a K-term dot product per channel. Lambertian
 * materials have a constant view map, so their h is read once per material and
 * their vertices skip the lookup. A back-facing vertex is never seen itself, but
 * Gouraud interpolation carries its colour into the silhouette's front-facing
 * triangles; so glossy vertices seen from below the horizon are shaded at a grazing
 * view (local z clamped to RELIGHT_MIN_COS), like Lambertian ones keep their
 * value, and silhouettes do not darken. (prt compare skips back-facing vertices.)
 *
 * Output policy: the truncated wavelet approximation can ring slightly below
 * zero near hard shadow edges; negative radiance has no physical meaning and
 * would wrap in 8-bit output, so relight_view and relight_vertex clamp it to 0.
 * Non-finite results (impossible with valid data) are also written as 0.
 *
 * Textures (texture.h): the transport is stored without a texture's albedo, so each textured
 * vertex's sparse sum is multiplied by its material's texture sampled at its UV (the per-vertex
 * model; images multiply per pixel: render.h).
 *
 * Per-vertex data is packed into one 48-byte record (position and the frame s,
 * t, n) so the view loop streams a single array. */
#include "relight.h"
#include "check.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The smallest view cosine used for glossy shading (see the header comment). */
#define RELIGHT_MIN_COS 0.02f

typedef struct relight_vert {
    float pos[3], s[3], t[3], n[3];
} relight_vert;

/* One sparse transfer's part: its light-dependent K-vectors. */
typedef struct relight_part {
    const prt_transfer *tr;
    int index;                    /* in d->transfers */
    int nvecs;
    float *g;                     /* [3 * nvecs] light-dependent K-vectors (Eq. 5's T x L) */
} relight_part;

struct relight_ctx {
    const prt_data *d;
    relight_part part[PRT_MAX_TRANSFERS];   /* the sparse transfers (ops->linear->light_range), in d's order */
    int nparts;
    int nthreads;
    bool use_direct;       /* light changes use d->direct (see relight_use_direct) */
    int nverts;
    relight_vert *verts;          /* [nverts] */
    float lambert_h[PRT_MAX_MATERIALS][3];   /* constant view map of Lambertian factors */
    float *albedo;                /* [3 * nverts] textured vertices' albedo multiplier (texture.h); NULL: none */
    bool no_albedo;               /* relight_apply_albedo(false): leave it out */
};

/* Validates d and precomputes frames; returns a context (free with relight_destroy) or NULL with err set. */
relight_ctx *relight_create(const prt_data *d, int nthreads, prt_error *err) {
    const prt_mesh *m = &d->scene.mesh;
    const char *bad = NULL;
    char why[256];
    int nsparse = 0;
    for (int i = 0; !bad && i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        if (!tr->ops) bad = "a transfer has no representation";
        else if (tr->ops->kind != TRANSFER_LINEAR) continue;   /* view-dependent: the runtime calls its shade_vertices */
        else if (!tr->transport.coef_first || !tr->transport.vec_first) bad = "the transport set is not finished";
        else if (tr->transport.nverts != m->nverts) {
            snprintf(why, sizeof why, "transport has %d vertices but the mesh has %d", tr->transport.nverts, m->nverts);
            bad = why;
        }
        nsparse++;
    }
    if (!bad && nsparse == 0) bad = "the data has no transfer with a CPU light kernel";
    else if (!bad && m->nverts > 0 && (!m->pos || !m->nrm)) bad = "the mesh has no positions or normals";
    else if (d->scene.nmaterials < 1 || d->scene.nmaterials > PRT_MAX_MATERIALS) {
        snprintf(why, sizeof why, "bad material count %d", d->scene.nmaterials);
        bad = why;
    }
    for (int k = 0; !bad && k < d->scene.nmaterials; k++) {
        const brdf_factor *f = &d->factors[k];
        if (f->K < 1 || f->K > BRDF_MAX_SIGMA || f->res < 1 || !f->view) {
            snprintf(why, sizeof why, "material %d has no usable BRDF factorization (K = %d)", k, f->K);
            bad = why;
        }
    }
    for (int v = 0; !bad && m->mat && v < m->nverts; v++)
        if (m->mat[v] >= d->scene.nmaterials) {
            snprintf(why, sizeof why, "vertex %d uses material %d of %d", v, m->mat[v], d->scene.nmaterials);
            bad = why;
        }
    if (bad) {
        prt_fail(err, "relight: %s", bad);
        return NULL;
    }

    relight_ctx *rc = prt_calloc(1, sizeof *rc, err);
    if (!rc) return NULL;
    rc->d = d;
    rc->nthreads = nthreads;
    rc->nverts = m->nverts;
    rc->verts = prt_calloc((size_t)m->nverts, sizeof *rc->verts, err);
    if (!rc->verts) { relight_destroy(rc); return NULL; }
    for (int i = 0; i < d->ntransfers; i++) {
        const prt_transfer *tr = &d->transfers[i];
        if (tr->ops->kind != TRANSFER_LINEAR) continue;
        relight_part *pt = &rc->part[rc->nparts++];
        pt->tr = tr;
        pt->index = i;
        pt->nvecs = tr->transport.nvecs;
        pt->g = prt_calloc(3 * (size_t)pt->nvecs + 3, sizeof *pt->g, err);
        if (!pt->g) { relight_destroy(rc); return NULL; }
    }
    for (int v = 0; v < m->nverts; v++) {
        relight_vert *rv = &rc->verts[v];
        memcpy(rv->pos, m->pos + 3 * (size_t)v, sizeof rv->pos);
        memcpy(rv->n, m->nrm + 3 * (size_t)v, sizeof rv->n);
        brdf_frame(rv->n, rv->s, rv->t);
    }
    if (d->scene.ntextures > 0 && m->uv) {   /* the texture sampled at each vertex multiplies its sparse transfer */
        rc->albedo = prt_calloc(3 * (size_t)m->nverts, sizeof *rc->albedo, err);
        if (!rc->albedo) { relight_destroy(rc); return NULL; }
        for (int v = 0; v < m->nverts; v++) scene_vertex_albedo(&d->scene, v, rc->albedo + 3 * (size_t)v);
    }
    for (int k = 0; k < d->scene.nmaterials; k++) {
        const brdf_factor *f = &d->factors[k];
        if (!f->lambertian) continue;
        float h[BRDF_MAX_SIGMA * 3];
        const float up[3] = { 0, 0, 1 };
        brdf_factor_view(f, up, h);
        memcpy(rc->lambert_h[k], h, sizeof rc->lambert_h[k]);
    }
    return rc;
}

/* Frees the context (not the shared prt_data). NULL is fine. */
void relight_destroy(relight_ctx *rc) {
    if (!rc) return;
    free(rc->verts);
    free(rc->albedo);
    for (int i = 0; i < rc->nparts; i++) free(rc->part[i].g);
    free(rc);
}

/* Light change of one part: g = T x L for every vector (Eq. 5) with its kernel, on rc->nthreads threads. */
static void part_light(const relight_ctx *rc, const relight_part *pt, const float (*L)[4]) {
    const prt_transport *t = rc->use_direct && pt->tr->direct.nvecs ? &pt->tr->direct : &pt->tr->transport;
    transfer_light(pt->tr, t, L, pt->g, rc->nthreads);
}

/* Light change of the first sparse transfer (prt_data_transfer). */
void relight_set_light(relight_ctx *rc, const float (*L)[4]) { part_light(rc, &rc->part[0], L); }

/* Light change of transfer i of the data (a sparse one). */
void relight_set_light_at(relight_ctx *rc, int i, const float (*L)[4]) {
    for (int p = 0; p < rc->nparts; p++)
        if (rc->part[p].index == i) { part_light(rc, &rc->part[p], L); return; }
    PRT_CHECK(!"relight_set_light_at: not a sparse transfer");
}

/* See relight.h. */
void relight_add_open(relight_ctx *rc, int i, const float *open) {
    for (int p = 0; p < rc->nparts; p++)
        if (rc->part[p].index == i) {
            const prt_transport *t = &rc->part[p].tr->transport;
            float *g = rc->part[p].g;
            for (size_t k = 0; k < 3 * (size_t)t->nvecs; k++) g[k] += open[k];
            return;
        }
    PRT_CHECK(!"relight_add_open: not a sparse transfer");
}

/* Chooses the direct-only set (when the first sparse transfer keeps one) or the total; true if available. */
bool relight_use_direct(relight_ctx *rc, bool direct) {
    if (direct && !rc->part[0].tr->direct.nvecs) return false;
    rc->use_direct = direct;
    return true;
}

/* The first sparse transfer's cached K-vectors, [3 * nvecs]; owned by rc. */
const float *relight_gvec(const relight_ctx *rc) { return rc->part[0].g; }

/* h . g of vertex v (material mi) in one part for local view direction wl (unit), added to acc. */
static void shade_part(const relight_ctx *rc, const relight_part *pt, int v, int mi, const float wl[3], int kmax, float acc[3]) {
    const brdf_factor *f = &rc->d->factors[mi];
    const uint32_t *vf = pt->tr->transport.vec_first;
    uint32_t v0 = vf[v], nk = vf[v + 1] - v0;
    int K = (int)nk < f->K ? (int)nk : f->K;
    if (kmax > 0 && kmax < K) K = kmax;
    const float *g = pt->g + 3 * (size_t)v0;
    if (K > 0) {
        if (f->lambertian) {
            for (int c = 0; c < 3; c++) acc[c] += rc->lambert_h[mi][c] * g[c];
        } else {
            float h[BRDF_MAX_SIGMA * 3], w[3] = { wl[0], wl[1], wl[2] };
            if (w[2] < RELIGHT_MIN_COS) {
                /* Below or at the horizon: the grazing direction with the same azimuth. */
                float r = sqrtf(w[0] * w[0] + w[1] * w[1]);
                float sxy = sqrtf(1.f - RELIGHT_MIN_COS * RELIGHT_MIN_COS) / (r > 1e-12f ? r : 1.f);
                if (r <= 1e-12f) { w[0] = 1.f; w[1] = 0.f; }
                else { w[0] *= sxy; w[1] *= sxy; }
                w[2] = RELIGHT_MIN_COS;
            }
            brdf_factor_view(f, w, h);
            for (int k = 0; k < K; k++)
                for (int c = 0; c < 3; c++) acc[c] += h[3 * k + c] * g[3 * k + c];
        }
    }
}

/* Sum over the sparse transfers whose mask holds v's material, clamped to >= 0 and finite. */
static void shade(const relight_ctx *rc, int v, const float wl[3], int kmax, float rgb[3]) {
    int mi = rc->d->scene.mesh.mat ? rc->d->scene.mesh.mat[v] : 0;
    float acc[3] = { 0, 0, 0 };
    for (int p = 0; p < rc->nparts; p++)
        if ((rc->part[p].tr->materials >> mi) & 1) shade_part(rc, &rc->part[p], v, mi, wl, kmax, acc);
    const float *a = rc->albedo && !rc->no_albedo ? rc->albedo + 3 * (size_t)v : NULL;   /* the texture: stored transport has none */
    for (int c = 0; c < 3; c++) rgb[c] = acc[c] > 0 && isfinite(acc[c]) ? (a ? a[c] * acc[c] : acc[c]) : 0.f;
}

/* Outgoing radiance of vertex v toward unit world direction wo. */
void relight_vertex(const relight_ctx *rc, int v, const float wo[3], int kmax, float rgb[3]) {
    const relight_vert *rv = &rc->verts[v];
    float wl[3];
    brdf_to_local(rv->s, rv->t, rv->n, wo, wl);
    shade(rc, v, wl, kmax, rgb);
}

typedef struct view_job {
    const relight_ctx *rc;
    float eye[3];
    int kmax;
    float *rgb;
} view_job;

/* prt_parallel_for body: shades vertices [begin, end) toward the eye. */
static void view_chunk(void *p, int begin, int end, int thread) {
    const view_job *j = p;
    const relight_vert *verts = j->rc->verts;
    for (int v = begin; v < end; v++) {
        const relight_vert *rv = &verts[v];
        float wo[3] = { j->eye[0] - rv->pos[0], j->eye[1] - rv->pos[1], j->eye[2] - rv->pos[2] };
        float len2 = wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2];
        if (!V3_SAFE_LEN2(len2)) {   /* an eye 1e20 away (or 1e-20): scaled first, exactly (vec3.h) */
            v3_prescale(wo);
            len2 = wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2];
        }
        float inv = len2 > 0 && isfinite(len2) ? 1.f / sqrtf(len2) : 0.f;   /* eye at the vertex: no direction, black unless Lambertian */
        wo[0] *= inv; wo[1] *= inv; wo[2] *= inv;
        float wl[3];
        brdf_to_local(rv->s, rv->t, rv->n, wo, wl);
        shade(j->rc, v, wl, j->kmax, j->rgb + 3 * (size_t)v);
    }
}

/* View change: rgb[3v..] = outgoing radiance of every vertex toward eye (both cores). */
void relight_view(relight_ctx *rc, const float eye[3], int kmax, float *rgb) {
    view_job j = { rc, { eye[0], eye[1], eye[2] }, kmax, rgb };
    prt_parallel_for(rc->nverts, 4096, rc->nthreads, view_chunk, &j);
}

void relight_apply_albedo(relight_ctx *rc, bool apply) { rc->no_albedo = !apply; }
const float *relight_albedo(const relight_ctx *rc) { return rc->albedo; }

/* Copies externally computed K-vectors into the cache. */
void relight_set_gvec(relight_ctx *rc, const float *g) {
    memcpy(rc->part[0].g, g, sizeof(float) * 3 * (size_t)rc->part[0].nvecs);
}
