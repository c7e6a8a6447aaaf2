/* gather_fixture.h - small procedural scenes and an independent direct-transport
 * builder for the gathering tests (test_gather.c, test_furnace.c). Header only,
 * static functions; no /work/shared.
 *
 * The direct builder is deliberately simple (one visibility ray per 64-res
 * lighting texel, Eq. 3 at the texel centre), then goes through the transfer
 * representation interface (transfer.h: ops->linear->project_transport per
 * channel, ops->linear->compress), so the tests do not depend on the precompute
 * pipeline but do exercise the same seam it uses (fx_direct: Haar of the texels,
 * the paper's; fx_direct_ops: any linear representation, with its options). */
#ifndef GATHER_FIXTURE_H
#define GATHER_FIXTURE_H
#include "harness.h"
#include "cubemap.h"
#include "factor.h"
#include "gather.h"
#include "haar.h"
#include "transfer.h"
#include "mesh.h"
#include "scene.h"
#include "transport.h"
#include "vec3.h"
#include "visibility.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Helpers unused by one of the two tests must not warn. */
#define FX_FN static __attribute__((unused))

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Turns a mesh inside out: negated normals, reversed winding. */
FX_FN void fx_flip(prt_mesh *m) {
    for (int i = 0; i < 3 * m->nverts; i++) m->nrm[i] = -m->nrm[i];
    for (int t = 0; t < m->ntris; t++) {
        uint32_t a = m->tris[3 * t + 1];
        m->tris[3 * t + 1] = m->tris[3 * t + 2];
        m->tris[3 * t + 2] = a;
    }
}

/* Fills d->factors for every scene material (max_terms terms). Returns 0 or -1. */
FX_FN int fx_factor_all(prt_data *d, int max_terms) {
    prt_error err;
    brdf_factor_desc fd = { .max_terms = max_terms };
    for (int i = 0; i < d->scene.nmaterials; i++)
        if (brdf_factorize(&d->scene.materials[i], &fd, &d->factors[i], &err)) {
            fprintf(stderr, "factorize: %s\n", err.msg);
            return -1;
        }
    return 0;
}

FX_FN void fx_free(prt_data *d) {
    for (int i = 0; i < d->scene.nmaterials; i++) brdf_factor_free(&d->factors[i]);
    for (int i = 0; i < d->ntransfers; i++) d->transfers[i].ops->release(&d->transfers[i]);
    scene_free(&d->scene);
    memset(d, 0, sizeof *d);
}

/* ---- direct transport (Eq. 3) ----------------------------------------- */

typedef struct fx_direct_ctx {
    const prt_data *d;
    const vis_scene *vs;
    prt_transport *t;
    const transfer_ops *ops;
    const transfer_config *cfg;
    const float *dir, *dw;      /* 64-res texel directions and solid angles */
} fx_direct_ctx;

FX_FN void fx_direct_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    fx_direct_ctx *c = ctx;
    const prt_mesh *m = &c->d->scene.mesh;
    uint8_t *vis = malloc(CUBE_TEXELS);
    float *pix = malloc(sizeof(float) * CUBE_TEXELS * 3), *wav = malloc(sizeof(float) * CUBE_TEXELS * 3);
    float *tmp = malloc(sizeof(float) * TRANSFER_SCRATCH_FLOATS);
    void *scratch = malloc(transport_scratch_size());
    for (int v = begin; v < end; v++) {
        const float *p = m->pos + 3 * v, *n = m->nrm + 3 * v;
        const brdf_factor *f = &c->d->factors[m->mat[v]];
        float s[3], t[3];
        brdf_frame(n, s, t);
        vis_cube(c->vs, p, n, CUBE_RES, vis, NULL, NULL);
        int nk = (int)(c->t->vec_first[v + 1] - c->t->vec_first[v]);
        for (int k = 0; k < nk; k++) {
            for (int j = 0; j < CUBE_TEXELS; j++) {
                const float *w = c->dir + 3 * j;
                float cw = v3_dot(n, w), g[3 * BRDF_MAX_SIGMA];
                if (!vis[j] || cw <= 0.f) { pix[j] = pix[CUBE_TEXELS + j] = pix[2 * CUBE_TEXELS + j] = 0.f; continue; }
                float wl[3];
                brdf_to_local(s, t, n, w, wl);
                brdf_factor_light(f, wl, g);
                for (int ch = 0; ch < 3; ch++) pix[ch * CUBE_TEXELS + j] = g[3 * k + ch] * cw * c->dw[j];
            }
            for (int ch = 0; ch < 3; ch++)
                c->ops->linear->project_transport(c->cfg, pix + ch * CUBE_TEXELS, wav + ch * CUBE_TEXELS, tmp);
            c->ops->linear->compress(c->t, (int)c->t->vec_first[v] + k, wav, wav + CUBE_TEXELS, wav + 2 * CUBE_TEXELS, scratch);
        }
    }
    free(vis); free(pix); free(wav); free(tmp); free(scratch);
}

/* Builds the direct transport of d's scene (K of each vertex's material) into out through linear
 * representation ops (configured from N, qbits and its options text; its set as its init_set makes it
 * with no run: no light prior). Returns 0 or -1. */
FX_FN int fx_direct_ops(const prt_data *d, const vis_scene *vs, const transfer_ops *ops, int N, int qbits, const char *options,
                        prt_transport *out) {
    const prt_mesh *m = &d->scene.mesh;
    prt_error err;
    transfer_config cfg;
    transfer_setup setup = { .options = options, .N = N, .qbits = qbits };
    if (ops->configure(&setup, &cfg, &err)) { fprintf(stderr, "configure: %s\n", err.msg); return -1; }
    int *cnt = malloc(sizeof(int) * (size_t)m->nverts);
    for (int v = 0; v < m->nverts; v++) cnt[v] = d->factors[m->mat[v]].K;
    int rc = ops->linear->init_set(&cfg, &(transfer_linear_run){ 0 }, out, m->nverts, cnt, &err);
    free(cnt);
    if (rc) { fprintf(stderr, "transport_init: %s\n", err.msg); return -1; }
    float *dir = malloc(sizeof(float) * 3 * CUBE_TEXELS), *dw = malloc(sizeof(float) * CUBE_TEXELS);
    for (int j = 0; j < CUBE_TEXELS; j++) {
        cube_texel_dir(CUBE_RES, j, dir + 3 * j);
        int ij = j % (CUBE_RES * CUBE_RES);
        dw[j] = (float)cube_texel_solid_angle(CUBE_RES, ij % CUBE_RES, ij / CUBE_RES);
    }
    fx_direct_ctx c = { d, vs, out, ops, &cfg, dir, dw };
    prt_parallel_for(m->nverts, 4, 0, fx_direct_range, &c);
    free(dir); free(dw);
    if (transport_finish(out, &err)) { fprintf(stderr, "transport_finish: %s\n", err.msg); return -1; }
    return 0;
}

/* The Haar direct transport of the texels (the paper's representation) of d's scene into out. 0 or -1. */
FX_FN int fx_direct(const prt_data *d, const vis_scene *vs, int N, int qbits, prt_transport *out) {
    return fx_direct_ops(d, vs, transfer_find("haar"), N, qbits, "measure=texels", out);
}

/* A probe set: every vector i holds the single coefficient (index idx_of[i] or 0) with per-channel
 * values val[3*i..] (float storage, N coefficients kept per vector later on). */
FX_FN int fx_probe_set(const prt_transport *layout, const uint32_t *idx_of, const float *val, int N, prt_transport *out) {
    prt_error err;
    int *cnt = malloc(sizeof(int) * (size_t)layout->nverts);
    for (int v = 0; v < layout->nverts; v++) cnt[v] = (int)(layout->vec_first[v + 1] - layout->vec_first[v]);
    int rc = transport_init(out, layout->nverts, cnt, N, 32, &err);
    free(cnt);
    if (rc) return -1;
    float *pl = calloc((size_t)CUBE_TEXELS * 3, sizeof(float));
    void *scratch = malloc(transport_scratch_size());
    for (int i = 0; i < layout->nvecs; i++) {
        uint32_t idx = idx_of ? idx_of[i] : 0;
        for (int ch = 0; ch < 3; ch++) pl[ch * CUBE_TEXELS + idx] = val[3 * i + ch];
        transport_store(out, i, pl, pl + CUBE_TEXELS, pl + 2 * CUBE_TEXELS, scratch);
        for (int ch = 0; ch < 3; ch++) pl[ch * CUBE_TEXELS + idx] = 0.f;
    }
    free(pl); free(scratch);
    return transport_finish(out, &err);
}

/* Wavelet-domain light vector of a constant environment of radiance L (all channels). */
FX_FN void fx_const_light(float L, float *Lw /* [3][CUBE_TEXELS] */) {
    float *pix = malloc(sizeof(float) * CUBE_TEXELS), *tmp = malloc(sizeof(float) * 2 * CUBE_RES * CUBE_RES);
    for (int j = 0; j < CUBE_TEXELS; j++) pix[j] = L;
    for (int ch = 0; ch < 3; ch++) haar_cube_forward(pix, CUBE_RES, Lw + ch * CUBE_TEXELS, tmp);
    free(pix); free(tmp);
}

/* T_i . L per channel (dense decode). */
FX_FN void fx_dot(const prt_transport *t, int i, const float *Lw, double out[3], float *buf /* [3][CUBE_TEXELS] */) {
    transport_decode(t, i, buf, buf + CUBE_TEXELS, buf + 2 * CUBE_TEXELS);
    for (int ch = 0; ch < 3; ch++) {
        double s = 0;
        for (int j = 0; j < CUBE_TEXELS; j++) s += (double)buf[ch * CUBE_TEXELS + j] * Lw[ch * CUBE_TEXELS + j];
        out[ch] = s;
    }
}

/* Outgoing radiance of a Lambertian vertex v (K = 1) under the light Lw: h . (T . L) (Eq. 5). */
FX_FN void fx_lambert_radiance(const prt_data *d, const prt_transport *t, int v, const float *Lw, double rgb[3], float *buf) {
    const brdf_factor *f = &d->factors[d->scene.mesh.mat[v]];
    const float up[3] = { 0, 0, 1 };
    float h[3 * BRDF_MAX_SIGMA];
    brdf_factor_view(f, up, h);
    double g[3];
    fx_dot(t, (int)t->vec_first[v], Lw, g, buf);
    for (int ch = 0; ch < 3; ch++) rgb[ch] = h[ch] * g[ch];
}
#endif
