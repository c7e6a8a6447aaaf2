/* test_glrt.c - the GLSL runtime (gpu/glrt.h) against CPU truths.
 *
 * 1. Synthetic transport, built here coefficient by coefficient in each of the
 *    three storage formats (8-bit packed words with block runs, 16-bit, float):
 *    every light kernel's K-vectors must equal the double-precision sparse
 *    inner product sum_c value_c L[index_c] (Eq. 5) to float rounding.
 * 2. With constant view maps h_k the colour is sum_k h_k g_k, linear in g, so
 *    both view modes must reproduce render_vertex_colors of the CPU colours.
 * 3. A precomputed scene (procedural sphere over a floor, Phong and Lambert):
 *    glrt in per-vertex view mode against the CPU runtime (relight_view +
 *    render_vertex_colors), per-pixel relative difference; the per-pixel view
 *    mode's difference from it is reported (it is a different, finer model).
 * 3b. A textured sphere: the per-vertex view model's texture at the vertex against the CPU's.
 * 4. A finite 1e37 sun through runtime.h on both backends: gl's colours and images
 *    finite, lit and equal to cpu's, and 1e7 times those of a 1e30 sun (bright_sun).
 * 5. A linear transfer without GLSL (cpu_light: --basis cpca, one bounce, the direct set kept):
 *    the CPU light method only; g uploaded equals transfer_light's, total, direct-only and under a
 *    1e37 light; gl's per-vertex images equal cpu's to the rounding of the scene case. */
#include "harness.h"
#include "transport_fixture.h"
#include "brdf.h"
#include "factor.h"
#include "glrt.h"
#include "light.h"
#include "precompute.h"
#include "probe.h"
#include "relight.h"
#include "runtime.h"
#include "scene.h"
#include "texture.h"
#include "vec3.h"
#include <float.h>
#include <stdlib.h>
#include <string.h>

/* Small deterministic generator (xorshift). */
typedef struct rng { uint64_t s; } rng;
static uint32_t rng_u32(rng *r) {
    r->s ^= r->s << 13;
    r->s ^= r->s >> 7;
    r->s ^= r->s << 17;
    return (uint32_t)(r->s >> 11);
}
static float rng_f(rng *r) { return (float)(rng_u32(r) & 0xffffff) / 16777216.0f; }

/* A synthetic prt_data: an n x n grid in the plane z = 0 facing +z; material 0 (left half) has
 * K = 3 glossy terms, material 1 (right half) K = 1 Lambertian; constant view maps h_k[ch]. */
typedef struct synth {
    prt_data d;
    double *gtrue;      /* [3*nvecs] */
    double *gabs;       /* [3*nvecs] sum of |value * L| (the rounding scale) */
    float (*L)[4];
    float hconst[2][4][3];
} synth;

static void synth_make(synth *s, int n, int N, int qbits, uint64_t seed) {
    memset(s, 0, sizeof *s);
    rng r = { seed };
    prt_data *d = &s->d;
    prt_mesh *m = &d->scene.mesh;
    m->nverts = n * n;
    m->ntris = 2 * (n - 1) * (n - 2); /* the column of quads between the materials is left open */
    m->pos = calloc(3 * (size_t)m->nverts, sizeof(float));
    m->nrm = calloc(3 * (size_t)m->nverts, sizeof(float));
    m->tris = calloc(3 * (size_t)m->ntris, sizeof(uint32_t));
    m->mat = calloc((size_t)m->nverts, sizeof(uint16_t));
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            int v = j * n + i;
            m->pos[3 * v] = 2.0f * i / (n - 1) - 1;
            m->pos[3 * v + 1] = 2.0f * j / (n - 1) - 1;
            m->nrm[3 * v + 2] = 1;
            m->mat[v] = i < n / 2 ? 0 : 1;
        }
    int t = 0;
    for (int j = 0; j + 1 < n; j++)
        for (int i = 0; i + 1 < n; i++) {
            if (i == n / 2 - 1) continue;
            uint32_t a = j * n + i, b = a + 1, c = a + n + 1, e = a + n;
            /* Each triangle lies within one material (in per-pixel mode the provoking vertex's decides). */
            uint32_t q[6] = { a, b, c, a, c, e };
            memcpy(m->tris + 3 * t, q, sizeof q);
            t += 2;
        }
    d->scene.nmaterials = 2;
    d->scene.bmin[0] = d->scene.bmin[1] = -1;
    d->scene.bmax[0] = d->scene.bmax[1] = 1;
    const int K[2] = { 3, 1 };
    for (int mi = 0; mi < 2; mi++) {
        brdf_factor *f = &d->factors[mi];
        f->K = K[mi];
        f->res = 8;
        f->lambertian = mi == 1;
        f->view = calloc((size_t)f->res * f->res * f->K * 3, sizeof(float));
        f->light = calloc((size_t)f->res * f->res * f->K * 3, sizeof(float));
        for (int k = 0; k < f->K; k++)
            for (int ch = 0; ch < 3; ch++) s->hconst[mi][k][ch] = (k ? -0.3f : 0.5f) + 0.1f * ch + 0.05f * mi;
        for (int x = 0; x < f->res * f->res; x++)
            for (int k = 0; k < f->K; k++)
                for (int ch = 0; ch < 3; ch++) f->view[3 * (x * f->K + k) + ch] = s->hconst[mi][k][ch];
    }
    /* Transport: vertex v has K of its material vectors; each vector a random number of coefficients
     * (0 included: an occluded vertex) at sorted random indices clustered into a few blocks. */
    transfer_config cfg = tfx_haar_cfg(N, qbits);
    prt_transport *tr = &prt_data_add_transfer(d, transfer_find("haar"), &cfg, 3)->transport;
    tr->nverts = m->nverts;
    tr->N = N;
    tr->qbits = qbits;
    tr->vec_first = calloc((size_t)m->nverts + 1, sizeof(uint32_t));
    for (int v = 0; v < m->nverts; v++) tr->vec_first[v + 1] = tr->vec_first[v] + K[m->mat[v]];
    tr->nvecs = (int)tr->vec_first[m->nverts];
    tr->coef_first = calloc((size_t)tr->nvecs + 1, sizeof(uint32_t));
    tr->run_first = calloc((size_t)tr->nvecs + 1, sizeof(uint32_t));
    size_t cap = (size_t)tr->nvecs * N;
    tr->runs = calloc(2 * cap + 2, 1);
    tr->scale = calloc(3 * (size_t)tr->nvecs, sizeof(float));
    if (qbits == 8) tr->packed = calloc(cap + 1, sizeof(uint32_t));
    else tr->offs = calloc(cap + 1, 1);
    if (qbits == 16) tr->q16 = calloc(3 * cap + 3, sizeof(int16_t));
    if (qbits == 32) tr->f32 = calloc(3 * cap + 3, sizeof(float));
    s->L = transfer_light_alloc();
    for (int i = 0; i < CUBE_TEXELS; i++) {
        for (int ch = 0; ch < 3; ch++) s->L[i][ch] = (rng_f(&r) - 0.3f) * (i < 256 ? 10.0f : 1.0f);
        s->L[i][3] = 0;
    }
    s->gtrue = calloc(3 * (size_t)tr->nvecs, sizeof(double));
    s->gabs = calloc(3 * (size_t)tr->nvecs, sizeof(double));
    uint32_t c = 0, run = 0;
    uint8_t used[CUBE_TEXELS];
    for (int i = 0; i < tr->nvecs; i++) {
        int cnt = (int)(rng_u32(&r) % (N + 1));
        if (i % 17 == 0) cnt = 0;
        if (i % 13 == 0) cnt = N;
        memset(used, 0, sizeof used);
        int nb = 1 + (int)(rng_u32(&r) % 4), blocks[4];
        for (int b = 0; b < nb; b++) blocks[b] = (int)(rng_u32(&r) % 96);
        uint32_t idx[1024];
        int got = 0;
        while (got < cnt) {
            uint32_t x = (uint32_t)blocks[rng_u32(&r) % nb] * 256 + rng_u32(&r) % 256;
            if (!used[x]) { used[x] = 1; idx[got++] = x; }
        }
        /* Sort (insertion: small). */
        for (int a = 1; a < got; a++)
            for (int b = a; b > 0 && idx[b - 1] > idx[b]; b--) { uint32_t tmp = idx[b]; idx[b] = idx[b - 1]; idx[b - 1] = tmp; }
        float step[3];
        for (int ch = 0; ch < 3; ch++) step[ch] = qbits == 32 ? 1.0f : (0.001f + rng_f(&r)) * (qbits == 8 ? 0.01f : 1e-4f);
        memcpy(&tr->scale[3 * i], step, sizeof step);
        tr->coef_first[i] = c;
        tr->run_first[i] = run;
        for (int a = 0; a < got; a++) {
            uint32_t blk = idx[a] >> 8, off = idx[a] & 255;
            if (a == 0 || (idx[a - 1] >> 8) != blk) {
                tr->runs[2 * run] = (uint8_t)blk;
                tr->runs[2 * run + 1] = 0;
                run++;
            } else tr->runs[2 * run - 1]++;
            double val[3];
            if (qbits == 8) {
                int q[3];
                for (int ch = 0; ch < 3; ch++) q[ch] = (int)(rng_u32(&r) % 255) - 127;
                tr->packed[c] = sparse_pack8(off, q[0], q[1], q[2]);
                for (int ch = 0; ch < 3; ch++) val[ch] = (double)q[ch] * step[ch];
            } else if (qbits == 16) {
                tr->offs[c] = (uint8_t)off;
                for (int ch = 0; ch < 3; ch++) {
                    int q = (int)(rng_u32(&r) % 65535) - 32767;
                    tr->q16[3 * c + ch] = (int16_t)q;
                    val[ch] = (double)q * step[ch];
                }
            } else {
                tr->offs[c] = (uint8_t)off;
                for (int ch = 0; ch < 3; ch++) {
                    float x = (rng_f(&r) - 0.5f) * 3;
                    tr->f32[3 * c + ch] = x;
                    val[ch] = x;
                }
            }
            for (int ch = 0; ch < 3; ch++) {
                s->gtrue[3 * i + ch] += val[ch] * s->L[idx[a]][ch];
                s->gabs[3 * i + ch] += fabs(val[ch] * s->L[idx[a]][ch]);
            }
            c++;
        }
    }
    tr->coef_first[tr->nvecs] = c;
    tr->run_first[tr->nvecs] = run;
}

static void synth_free(synth *s) {
    prt_data *d = &s->d;
    prt_mesh *m = &d->scene.mesh;
    free(m->pos); free(m->nrm); free(m->tris); free(m->mat);
    for (int i = 0; i < 2; i++) { free(d->factors[i].view); free(d->factors[i].light); }
    prt_transport *t = &d->transfers[0].transport;
    free(t->vec_first); free(t->coef_first); free(t->run_first); free(t->runs); free(t->scale);
    free(t->packed); free(t->offs); free(t->q16); free(t->f32);
    free(s->gtrue); free(s->gabs); free(s->L);
}

/* CPU colours of the synthetic scene: sum_k h_k g_k with the true g. */
static void synth_colors(const synth *s, float *rgb, int kmax) {
    const prt_data *d = &s->d;
    for (int v = 0; v < d->scene.mesh.nverts; v++) {
        int mi = d->scene.mesh.mat[v];
        uint32_t f = d->transfers[0].transport.vec_first[v], n = d->transfers[0].transport.vec_first[v + 1] - f;
        for (int ch = 0; ch < 3; ch++) {
            double acc = 0;
            for (uint32_t k = 0; k < n && (kmax == 0 || (int)k < kmax); k++) acc += s->hconst[mi][k][ch] * s->gtrue[3 * (f + k) + ch];
            rgb[3 * v + ch] = (float)acc;
        }
    }
}

/* The tolerance of a float dot product of n terms (Eq. 5's T x L) against the exact one or another
 * float one, relative to the sum of |terms|: each product and each addition rounds once (u =
 * FLT_EPSILON / 2), and a decoded 8- or 16-bit value q x step once more, on either side and in any
 * summation order (the kernels' differ): 2 (n + 2) u. Derived, so it holds for any GL driver and CPU;
 * a wrong coefficient is off by ~1 / n of the sum, far above it. */
static double dot_tol(int n) { return (n + 2) * (double)FLT_EPSILON; }

static double image_max_rel(const prt_image *a, const prt_image *b, double floor_) {
    double worst = 0;
    for (size_t i = 0; i < (size_t)a->w * a->h * 3; i++)
        worst = fmax(worst, fabs(a->data[i] - b->data[i]) / (fabs(b->data[i]) + floor_));
    return worst;
}

static void synthetic(void) {
    const int qb[3] = { 8, 16, 32 };
    for (int q = 0; q < 3; q++) {
        synth s;
        synth_make(&s, 24, 96, qb[q], 1234 + q);
        prt_error err = { { 0 } };
        glrt *rt = glrt_create(&s.d, NULL, &err);
        CHECK(rt != NULL, "qbits %d: %s", qb[q], err.msg);
        if (!rt) { synth_free(&s); continue; }
        glrt_timing tm;
        glrt_get_timing(rt, &tm);
        CHECK(tm.light_method > GLRT_LIGHT_AUTO && tm.light_method < GLRT_LIGHT_COUNT, "no kernel chosen");
        int nv = s.d.transfers[0].transport.nvecs;
        float *g = calloc(3 * (size_t)nv, sizeof(float));
        for (int m = GLRT_LIGHT_FRAGMENT; m < GLRT_LIGHT_CPU; m++) {   /* the GL kernels (CPU: transfers without GLSL) */
            int rc = glrt_set_light_method(rt, (glrt_light_method)m, &err);
            CHECK(rc == 0, "qbits %d, %s: %s", qb[q], glrt_light_method_name((glrt_light_method)m), err.msg);
            if (rc) continue;
            CHECK(glrt_set_light(rt, (const float (*)[4])s.L, &err) == 0, "%s", err.msg);
            CHECK(glrt_read_gvec(rt, g, &err) == 0, "%s", err.msg);
            double worst = 0;
            int nonzero = 0;
            for (int i = 0; i < 3 * nv; i++) {
                worst = fmax(worst, fabs(g[i] - s.gtrue[i]) / (s.gabs[i] + 1e-30));
                nonzero += s.gabs[i] > 0;
            }
            /* Float accumulation of <= 96 products: relative to sum |terms|, dot_tol. */
            CHECK_LE(worst, dot_tol(96), "qbits %d, kernel %s: K-vectors differ from the sparse inner product", qb[q],
                     glrt_light_method_name((glrt_light_method)m));
            CHECK(nonzero > nv, "qbits %d: degenerate synthetic data", qb[q]);
        }
        /* View modes against render_vertex_colors of the CPU colours (constant view maps: linear in g). */
        prt_camera cam = { .eye = { 0.4f, -0.3f, 2.6f }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 50 };
        float *rgb = calloc(3 * (size_t)s.d.scene.mesh.nverts, sizeof(float));
        float *clamped = calloc(3 * (size_t)s.d.scene.mesh.nverts, sizeof(float));
        for (int kmax = 0; kmax <= 2; kmax += 2) {
            synth_colors(&s, rgb, kmax);
            for (int i = 0; i < 3 * s.d.scene.mesh.nverts; i++) clamped[i] = rgb[i] > 0 ? rgb[i] : 0;
            render_desc rd = { .width = 120, .height = 90, .camera = cam };
            /* Radiance is clamped at zero: per vertex before Gouraud (vertex mode, as the CPU runtime),
             * per pixel after interpolation (pixel mode; with constant h the interpolated colour is exact). */
            prt_image ref[2], img;
            int rc = render_vertex_colors(&s.d.scene.mesh, rgb, &rd, &ref[0], &err);
            CHECK(rc == 0, "%s", err.msg);
            rc |= render_vertex_colors(&s.d.scene.mesh, clamped, &rd, &ref[1], &err);
            CHECK(rc == 0, "%s", err.msg);
            if (rc) continue;
            double cmax = 0;
            for (size_t i = 0; i < (size_t)120 * 90 * 3; i++) {
                ref[0].data[i] = ref[0].data[i] > 0 ? ref[0].data[i] : 0;
                cmax = fmax(cmax, fabs(ref[0].data[i]));
            }
            for (int mode = 0; mode < 2; mode++) {
                glrt_set_view_mode(rt, (glrt_view_mode)mode);
                rc = glrt_render(rt, &cam, 120, 90, kmax, &img, &err);
                CHECK(rc == 0, "%s", err.msg);
                if (rc) continue;
                /* Relative to the image's largest value: the random g of mixed signs makes colours cross
                 * zero inside triangles, where a pointwise relative error means nothing. */
                double e = image_max_rel(&img, &ref[mode], cmax);
                CHECK_LE(e, 1e-5, "qbits %d, kmax %d, view mode %d: GPU image differs from the CPU raster", qb[q], kmax, mode);
                image_free(&img);
            }
            CHECK(cmax > 0, "black reference");
            image_free(&ref[0]);
            image_free(&ref[1]);
        }
        free(clamped);
        free(rgb);
        free(g);
        glrt_destroy(rt);
        synth_free(&s);
    }
}

/* A file that keeps the direct-only set too (precompute --keep-direct): glrt_use_direct switches the
 * uploaded set (here also its quantization, 16-bit direct vs 8-bit full, so the kernels are rebuilt). */
static void direct_switch(void) {
    synth full, dir;
    synth_make(&full, 14, 40, 8, 31);
    synth_make(&dir, 14, 40, 16, 32);
    full.d.transfers[0].direct = dir.d.transfers[0].transport;
    prt_error err = { { 0 } };
    glrt *rt = glrt_create(&full.d, NULL, &err);
    CHECK(rt != NULL, "%s", err.msg);
    int nv = full.d.transfers[0].transport.nvecs;
    float *g = calloc(3 * (size_t)nv, sizeof(float));
    for (int step = 0; rt && step < 3; step++) {
        bool direct = step == 1;
        const synth *truth = direct ? &dir : &full;
        CHECK(glrt_use_direct(rt, direct, &err) == 0, "step %d: %s", step, err.msg);
        CHECK(glrt_set_light(rt, (const float (*)[4])truth->L, &err) == 0, "%s", err.msg);
        CHECK(glrt_read_gvec(rt, g, &err) == 0, "%s", err.msg);
        double worst = 0;
        for (int i = 0; i < 3 * nv; i++) worst = fmax(worst, fabs(g[i] - truth->gtrue[i]) / (truth->gabs[i] + 1e-30));
        CHECK_LE(worst, dot_tol(40), "step %d (%s): K-vectors of the wrong set", step, direct ? "direct" : "full");
    }
    free(g);
    glrt_destroy(rt);
    memset(&full.d.transfers[0].direct, 0, sizeof full.d.transfers[0].direct);
    /* No direct set: the switch is refused with a message. */
    rt = glrt_create(&full.d, NULL, &err);
    CHECK(rt && glrt_use_direct(rt, true, &err) == -1 && strstr(err.msg, "direct"), "%s", err.msg);
    glrt_destroy(rt);
    synth_free(&full);
    synth_free(&dir);
}

/* View maps with real lookups: material 0 gets random smooth view maps in the grid or the polar
 * parameterization (its seam crosses the image: the eye is above the plane's middle, so the local
 * view azimuths go all the way round), normals are tilted at random. The per-vertex view model
 * must reproduce sum_k brdf_factor_view(wl)_k g_k with brdf_frame's frames, clamped at zero. */
static void viewmaps(void) {
    for (int param = 0; param < 2; param++) {
        synth s;
        synth_make(&s, 28, 32, 16, 777 + param);
        rng r = { 4242 + param };
        brdf_factor *f = &s.d.factors[0];
        f->param = param ? BRDF_PARAM_POLAR : BRDF_PARAM_GRID;
        for (int x = 0; x < f->res * f->res * f->K * 3; x++) f->view[x] = rng_f(&r) * (x % 3 == 1 ? -0.5f : 1.0f);
        prt_mesh *m = &s.d.scene.mesh;
        for (int v = 0; v < m->nverts; v++) {
            float *n = m->nrm + 3 * v;
            n[0] = (rng_f(&r) - 0.5f) * 0.8f;
            n[1] = (rng_f(&r) - 0.5f) * 0.8f;
            n[2] = 1;
            v3_normalize(n);
        }
        prt_camera cam = { .eye = { 0.1f, 0.15f, 1.2f }, .target = { 0, 0.1f, 0 }, .up = { 0, 1, 0 }, .fov_deg = 100 };
        float *rgb = calloc(3 * (size_t)m->nverts, sizeof(float));
        int below = 0;
        for (int v = 0; v < m->nverts; v++) {
            int mi = m->mat[v];
            const brdf_factor *fv = &s.d.factors[mi];
            float sv[3], tv[3], wo[3], wl[3], h[3 * 16];
            brdf_frame(m->nrm + 3 * v, sv, tv);
            v3_sub(wo, cam.eye, m->pos + 3 * v);
            v3_normalize(wo);
            brdf_to_local(sv, tv, m->nrm + 3 * v, wo, wl);
            if (fv->lambertian) {
                const float up[3] = { 0, 0, 1 };
                brdf_factor_view(fv, up, h);
            } else brdf_factor_view(fv, wl, h);
            below += wl[2] <= 0;
            uint32_t first = s.d.transfers[0].transport.vec_first[v];
            for (int ch = 0; ch < 3; ch++) {
                double acc = 0;
                for (int k = 0; k < fv->K; k++) acc += h[3 * k + ch] * s.gtrue[3 * (first + k) + ch];
                rgb[3 * v + ch] = acc > 0 ? (float)acc : 0;
            }
        }
        prt_error err = { { 0 } };
        render_desc rd = { .width = 128, .height = 96, .camera = cam };
        prt_image ref = { 0 }, img = { 0 };
        glrt_desc desc = { .view = GLRT_VIEW_VERTEX };
        glrt *rt = glrt_create(&s.d, &desc, &err);
        CHECK(rt != NULL, "%s", err.msg);
        int rc = rt ? render_vertex_colors(m, rgb, &rd, &ref, &err) : -1;
        CHECK(rc == 0, "%s", err.msg);
        if (rc == 0) {
            CHECK(glrt_set_light(rt, (const float (*)[4])s.L, &err) == 0, "%s", err.msg);
            CHECK(glrt_render(rt, &cam, 128, 96, 0, &img, &err) == 0, "%s", err.msg);
            double cmax = 0;
            for (size_t i = 0; i < (size_t)128 * 96 * 3; i++) cmax = fmax(cmax, ref.data[i]);
            double e = img.data ? image_max_rel(&img, &ref, cmax) : 1;
            CHECK_LE(e, 2e-5, "%s view maps: per-vertex GL differs from brdf_factor_view", param ? "polar" : "grid");
            CHECK(cmax > 0, "black reference");
        }
        CHECK(below < m->nverts / 4, "too many vertices facing away (%d)", below);
        image_free(&ref);
        image_free(&img);
        glrt_destroy(rt);
        free(rgb);
        synth_free(&s);
    }
}

/* sum_c |value_c L[index_c]| per vector and channel (the rounding scale of g). */
typedef struct abs_ctx { const float (*L)[4]; double acc[3]; } abs_ctx;
static void abs_fn(void *p, uint32_t index, float r, float g, float b) {
    abs_ctx *a = p;
    a->acc[0] += fabs(r * a->L[index][0]);
    a->acc[1] += fabs(g * a->L[index][1]);
    a->acc[2] += fabs(b * a->L[index][2]);
}

static int cmp_dbl(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Per-pixel relative differences |a - b| / (|b| + floor) sorted ascending into out (w*h*3). */
static void rel_diffs(const prt_image *a, const prt_image *b, double floor_, double *out) {
    size_t n = (size_t)a->w * a->h * 3;
    for (size_t i = 0; i < n; i++) out[i] = fabs(a->data[i] - b->data[i]) / (fabs(b->data[i]) + floor_);
    qsort(out, n, sizeof *out, cmp_dbl);
}

/* A precomputed scene (glossy Phong sphere over a Lambertian floor) under a procedural sky with a sun. */
static void scene(void) {
    prt_error err = { { 0 } };
    prt_mesh sphere = { 0 };
    prt_scene scene = { 0 };
    prt_data d;
    memset(&d, 0, sizeof d);
    const float c[3] = { 0, 0.5f, 0 };
    int rc = mesh_make_sphere(&sphere, c, 0.5f, 20, 32, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    rc = scene_from_mesh(&sphere, "phong:kd=0.4,0.25,0.15;ks=0.5;n=30", &scene, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) { mesh_free(&sphere); return; }
    rc = scene_add_floor(&scene, 1600, 3, NULL, &err);
    CHECK(rc == 0, "%s", err.msg);
    precompute_desc pd = { .no_open_sky = true, .N = 64, .max_terms = 3, .vis_res = 64, .quiet = true, .force_bounces = -1, .glossy = PRECOMPUTE_GLOSSY_SVD };
    rc = precompute_run(&scene, &pd, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) { scene_free(&scene); return; }
    CHECK(d.factors[0].K == 3 && !d.factors[0].lambertian, "sphere material K %d", d.factors[0].K);

    prt_probe sky;
    sky_desc sd = { .width = 256, .sun_dir = { 0.4f, 0.8f, 0.45f }, .sun_radius_deg = 5, .sun_radiance = 80 };
    rc = probe_make_sky(&sd, &sky, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) { prt_data_free(&d); return; }
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    float (*L)[4] = transfer_light_alloc();
    probe_to_cube(&sky, CUBE_RES, NULL, 0, cube);
    prt_data_transfer(&d)->ops->linear->project_light(&prt_data_transfer(&d)->cfg, cube, L);   /* the file's basis */
    free(cube);

    /* CPU runtime. */
    relight_ctx *rcx = relight_create(&d, 0, &err);
    CHECK(rcx != NULL, "%s", err.msg);
    glrt_desc desc = { .view = GLRT_VIEW_VERTEX };
    glrt *rt = glrt_create(&d, &desc, &err);
    CHECK(rt != NULL, "%s", err.msg);
    if (!rcx || !rt) goto done;
    relight_set_light(rcx, (const float (*)[4])L);
    CHECK(glrt_set_light(rt, (const float (*)[4])L, &err) == 0, "%s", err.msg);

    /* K-vectors: GPU against CPU, to float rounding of the same sums. */
    int nv = d.transfers[0].transport.nvecs;
    float *g = calloc(3 * (size_t)nv, sizeof(float));
    CHECK(glrt_read_gvec(rt, g, &err) == 0, "%s", err.msg);
    const float *gc = relight_gvec(rcx);
    double worst = 0;
    for (int i = 0; i < nv; i++) {
        abs_ctx a = { (const float (*)[4])L, { 0, 0, 0 } };
        transport_foreach(&d.transfers[0].transport, i, abs_fn, &a);
        for (int ch = 0; ch < 3; ch++) worst = fmax(worst, fabs(g[3 * i + ch] - gc[3 * i + ch]) / (a.acc[ch] + 1e-30));
    }
    CHECK_LE(worst, dot_tol(d.transfers[0].transport.N), "GPU K-vectors differ from relight_gvec");   /* N: the most a vector keeps */
    free(g);

    /* Images: CPU relight_view + render_vertex_colors vs glrt per-vertex view model. */
    const int w = 160, h = 120;
    prt_camera cam;
    camera_default(d.scene.bmin, d.scene.bmax, (float)w / h, &cam);
    const float sphere_cam[3] = { 1.1f, 1.0f, 1.4f };
    memcpy(cam.eye, sphere_cam, sizeof sphere_cam);
    memcpy(cam.target, c, sizeof c);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);
    relight_view(rcx, cam.eye, 0, rgb);
    render_desc rd = { .width = w, .height = h, .camera = cam, .background = &sky };
    prt_image ref = { 0 }, img = { 0 }, pix = { 0 }, one = { 0 };
    rc = render_vertex_colors(&d.scene.mesh, rgb, &rd, &ref, &err);
    CHECK(rc == 0, "%s", err.msg);
    CHECK(glrt_set_background(rt, &sky, NULL, &err) == 0, "%s", err.msg);
    rc |= glrt_render(rt, &cam, w, h, 0, &img, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        double cmax = 0;
        for (size_t i = 0; i < (size_t)w * h * 3; i++) cmax = fmax(cmax, ref.data[i]);
        double *rel = malloc(sizeof(double) * w * h * 3);
        rel_diffs(&img, &ref, 1e-3 * cmax, rel);
        size_t n = (size_t)w * h * 3;
        fprintf(stderr, "test_glrt: per-vertex GL vs CPU: median rel diff %.2e, 99.9%% %.2e, max %.2e\n", rel[n / 2],
                rel[n * 999 / 1000], rel[n - 1]);
        /* Same model, same numbers: float rounding of lookups and sums. Pixels at a vertex whose view
         * direction sits on the horizon within rounding may switch h on or off, hence the quantile. */
        CHECK_LE(rel[n * 999 / 1000], 1e-4, "per-vertex GL image differs from the CPU runtime's");
        CHECK_LE(rel[n / 2], 1e-5, "median");
        /* The per-pixel view model (the default): view maps looked up at every pixel. A finer model
         * than per-vertex Gouraud, so it differs on the glossy sphere; reported, loosely bounded. */
        glrt_set_view_mode(rt, GLRT_VIEW_PIXEL);
        CHECK(glrt_render(rt, &cam, w, h, 0, &pix, &err) == 0, "%s", err.msg);
        rel_diffs(&pix, &ref, 1e-2 * cmax, rel);
        double mean = 0;
        for (size_t i = 0; i < n; i++) mean += rel[i];
        mean /= (double)n;
        fprintf(stderr, "test_glrt: per-pixel GL vs per-vertex CPU (glossy): mean rel diff %.3f, median %.3f, 99%% %.3f\n",
                mean, rel[n / 2], rel[n * 99 / 100]);
        CHECK_LE(mean, 0.1, "per-pixel model far from the per-vertex one");
        /* The one-shot call that `prt render --backend gl` uses gives the per-pixel image. It runs the
         * fragment kernel; AUTO above may have kept another (timed at create: on a loaded machine the
         * choice varies), whose sums differ in order, so the image compared is made with that kernel. */
        CHECK(glrt_set_light_method(rt, GLRT_LIGHT_FRAGMENT, &err) == 0, "%s", err.msg);
        image_free(&pix);
        CHECK(glrt_render(rt, &cam, w, h, 0, &pix, &err) == 0, "%s", err.msg);
        CHECK(glrt_render_image(&d, (const float (*)[4])L, &rd, 0, &one, &err) == 0, "%s", err.msg);
        double diff = 0;
        for (size_t i = 0; i < n && one.data; i++) diff = fmax(diff, fabs(one.data[i] - pix.data[i]) / (pix.data[i] + 1e-3 * cmax));
        CHECK_LE(diff, 1e-5, "glrt_render_image differs from glrt_render");
        free(rel);
    }
    image_free(&ref);
    image_free(&img);
    image_free(&pix);
    image_free(&one);
    free(rgb);
done:
    glrt_destroy(rt);
    relight_destroy(rcx);
    free(L);
    probe_free(&sky);
    prt_data_free(&d);
}

/* A textured sphere (an 8 x 8 checker over u = x + 0.5, v = z + 0.5, Phong SVD K = 2): glrt's
 * per-vertex view model samples the texture at each vertex in its vertex shader, which must give the
 * CPU runtime's colours (relight_view: the texture at the vertex times the sparse sum) to float
 * rounding, as in scene(); and an untextured twin's image differs (the texture is in use). */
static void textured_vertex(void) {
    prt_error err = { { 0 } };
    prt_mesh sphere = { 0 };
    prt_scene scene = { 0 };
    prt_data d;
    memset(&d, 0, sizeof d);
    const float c[3] = { 0, 0.5f, 0 };
    int rc = mesh_make_sphere(&sphere, c, 0.5f, 16, 24, &err);
    if (!rc) rc = scene_from_mesh(&sphere, "phong:kd=0.6;ks=0.3;n=20", &scene, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) { mesh_free(&sphere); return; }
    uint8_t texels[8 * 8 * 3];
    for (int i = 0; i < 64; i++)
        for (int ch = 0; ch < 3; ch++) texels[3 * i + ch] = (uint8_t)((i / 8 + i % 8) & 1 ? 40 + 60 * ch : 230 - 50 * ch);
    prt_mesh *m = &scene.mesh;
    m->uv = malloc(2 * sizeof(float) * (size_t)m->nverts);
    CHECK(m->uv && texture_from_srgb(&scene.textures[0], "checker", 8, 8, texels, &err) == 0, "%s", err.msg);
    if (!m->uv) { scene_free(&scene); return; }
    scene.ntextures = 1;
    scene.material_texture[0] = 1;
    for (int v = 0; v < m->nverts; v++) m->uv[2 * v] = m->pos[3 * v] + 0.5f, m->uv[2 * v + 1] = m->pos[3 * v + 2] + 0.5f;
    precompute_desc pd = { .no_open_sky = true, .N = 64, .max_terms = 2, .vis_res = 64, .quiet = true, .glossy = PRECOMPUTE_GLOSSY_SVD };
    rc = precompute_run(&scene, &pd, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) { scene_free(&scene); return; }
    prt_probe sky;
    sky_desc sd = { .width = 128, .sun_dir = { 0.4f, 0.8f, 0.45f }, .sun_radius_deg = 10, .sun_radiance = 20 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    float (*L)[4] = transfer_light_alloc();
    probe_to_cube(&sky, CUBE_RES, NULL, 0, cube);
    prt_data_transfer(&d)->ops->linear->project_light(&prt_data_transfer(&d)->cfg, cube, L);
    free(cube);
    relight_ctx *rcx = relight_create(&d, 0, &err);
    glrt_desc desc = { .view = GLRT_VIEW_VERTEX };
    glrt *rt = rcx ? glrt_create(&d, &desc, &err) : NULL;
    CHECK(rcx && rt, "%s", err.msg);
    const int w = 96, h = 96;
    prt_camera cam;
    camera_default(d.scene.bmin, d.scene.bmax, 1.0f, &cam);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);   /* the scene is d's now */
    prt_image ref = { 0 }, img = { 0 };
    if (rcx && rt && rgb) {
        relight_set_light(rcx, (const float (*)[4])L);
        relight_view(rcx, cam.eye, 0, rgb);
        render_desc rd = { .width = w, .height = h, .camera = cam };
        CHECK(render_vertex_colors(&d.scene.mesh, rgb, &rd, &ref, &err) == 0, "%s", err.msg);
        CHECK(glrt_set_light(rt, (const float (*)[4])L, &err) == 0 && glrt_render(rt, &cam, w, h, 0, &img, &err) == 0, "%s", err.msg);
    }
    if (ref.data && img.data) {
        double cmax = 0, untex = 0;
        for (size_t i = 0; i < (size_t)w * h * 3; i++) cmax = fmax(cmax, ref.data[i]);
        double *rel = malloc(sizeof(double) * w * h * 3);
        size_t n = (size_t)w * h * 3;
        rel_diffs(&img, &ref, 1e-3 * cmax, rel);
        /* the bounds of scene(): the same model and numbers, float rounding */
        CHECK_LE(rel[n * 999 / 1000], 1e-4, "per-vertex GL image of a textured sphere differs from the CPU runtime's");
        CHECK_LE(rel[n / 2], 1e-5, "median");
        relight_apply_albedo(rcx, false);   /* the untextured colours: far from it */
        relight_view(rcx, cam.eye, 0, rgb);
        prt_image plain = { 0 };
        render_desc rd = { .width = w, .height = h, .camera = cam };
        CHECK(render_vertex_colors(&d.scene.mesh, rgb, &rd, &plain, &err) == 0, "%s", err.msg);
        for (size_t i = 0; i < n && plain.data; i++) untex = fmax(untex, fabs(plain.data[i] - img.data[i]) / (1e-3 * cmax + plain.data[i]));
        CHECK(untex > 0.2, "the texture made no difference (%g)", untex);
        image_free(&plain);
        free(rel);
    }
    image_free(&ref);
    image_free(&img);
    free(rgb);
    glrt_destroy(rt);
    relight_destroy(rcx);
    free(L);
    probe_free(&sky);
    prt_data_free(&d);
}

/* EGL (Mesa's software device here) runs the same kernels as OSMesa. */
static void egl(void) {
    synth s;
    synth_make(&s, 12, 48, 8, 99);
    const char *old = getenv("PRT_GL");
    char *saved = old ? strdup(old) : NULL;
    setenv("PRT_GL", "egl", 1);
    prt_error err = { { 0 } };
    glrt *rt = glrt_create(&s.d, NULL, &err);
    CHECK(rt != NULL, "EGL: %s", err.msg);
    if (rt) {
        glrt_timing t;
        glrt_get_timing(rt, &t);
        CHECK(!strcmp(t.context, "egl"), "context %s", t.context);
        int nv = s.d.transfers[0].transport.nvecs;
        float *g = calloc(3 * (size_t)nv, sizeof(float));
        CHECK(glrt_set_light(rt, (const float (*)[4])s.L, &err) == 0 && glrt_read_gvec(rt, g, &err) == 0, "%s", err.msg);
        double worst = 0;
        for (int i = 0; i < 3 * nv; i++) worst = fmax(worst, fabs(g[i] - s.gtrue[i]) / (s.gabs[i] + 1e-30));
        CHECK_LE(worst, dot_tol(48), "EGL K-vectors");
        free(g);
        glrt_destroy(rt);
    }
    if (saved) setenv("PRT_GL", saved, 1);
    else unsetenv("PRT_GL");
    free(saved);
    synth_free(&s);
}

/* A finite but huge sun: a probe with 2x2 texels of 1e37 over a dim sky lights the
 * gl runtime as the cpu one, whose light change runs scaled by a power of two (transfer.c). The
 * GL kernels summed codes x L in float before the vector's scale, so L near 1e37 overflowed to
 * Inf and every pixel came out black (or NaN). Both backends, per-vertex view model: vertex
 * colours and images finite, lit, and equal to float rounding of the same sums (1e-4, as the
 * scene case's per-vertex images), and the 1e37 light equals the 1e30 one x 1e7 on gl too,
 * per vertex and per pixel (gl's default view model; relative RMS 1e-4, as test_edges' cpu case). */
static void bright_sun(void) {
    prt_error err = { { 0 } };
    prt_mesh sphere = { 0 };
    prt_scene sc = { 0 };
    prt_data d;
    memset(&d, 0, sizeof d);
    const float c[3] = { 0, 0.5f, 0 };
    int rc = mesh_make_sphere(&sphere, c, 0.5f, 12, 16, &err);
    if (rc == 0) rc = scene_from_mesh(&sphere, "phong:kd=0.4,0.25,0.15;ks=0.5;n=30", &sc, &err);
    if (rc == 0) rc = scene_add_floor(&sc, 100, 3, NULL, &err);
    precompute_desc pd = { .no_open_sky = true, .N = 64, .max_terms = 3, .vis_res = 64, .quiet = true, .force_bounces = -1, .glossy = PRECOMPUTE_GLOSSY_SVD };
    if (rc == 0) rc = precompute_run(&sc, &pd, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    static const float k_sun[2] = { 1e30f, 1e37f };
    int nv = d.scene.mesh.nverts;
    const int w = 80, h = 60;
    float *col[2][2];
    prt_image img[2][2], pix[2];   /* [sun][cpu, gl] per vertex; gl per pixel */
    memset(img, 0, sizeof img);
    memset(pix, 0, sizeof pix);
    prt_camera cam;
    camera_default(d.scene.bmin, d.scene.bmax, (float)w / h, &cam);
    for (int s = 0; s < 2; s++) {
        prt_image im;
        prt_probe p;
        image_alloc(&im, 64, 32, 3, &err);
        for (int i = 0; i < 64 * 32 * 3; i++) im.data[i] = 0.3f;
        for (int y = 5; y < 7; y++)   /* the sun high in the sky, lighting the sphere's top and the floor */
            for (int x = 20; x < 22; x++)
                for (int k = 0; k < 3; k++) im.data[3 * (y * 64 + x) + k] = k_sun[s];
        CHECK(probe_from_image(&im, PROBE_LATLONG, "sun", &p, &err) == 0, "%s", err.msg);
        for (int b = 0; b < 2; b++) {
            col[s][b] = calloc(3 * (size_t)nv, sizeof(float));
            runtime_desc rdsc = { .backend = b ? "gl" : "cpu", .view = RUNTIME_VIEW_VERTEX };
            prt_runtime *rt = runtime_create(&d, &rdsc, &err);
            render_desc rd = { .width = w, .height = h, .camera = cam };
            CHECK(rt && runtime_set_light(rt, &p, NULL, &err) == 0 && runtime_shade_vertices(rt, cam.eye, col[s][b], &err) == 0 &&
                      runtime_render(rt, &rd, &img[s][b], &err) == 0,
                  "%s: %s", rdsc.backend, err.msg);
            if (rt && b) CHECK(runtime_set_view(rt, RUNTIME_VIEW_PIXEL, &err) == 0 && runtime_render(rt, &rd, &pix[s], &err) == 0, "%s", err.msg);
            runtime_destroy(rt);
        }
        probe_free(&p);
    }
    /* vertex colours and images of the 1e37 sun: finite, lit, gl = cpu; gl's 1e37 = its 1e30 x 1e7 */
    double lit = 0, cmax = 0, worst = 0, ratio = 0;
    bool finite = true;
    for (int i = 0; i < 3 * nv; i++) {
        float a = col[1][1][i], b = col[1][0][i];
        finite &= isfinite(a) && isfinite(b);
        lit += b > 0;
        cmax = fmax(cmax, b);
    }
    for (int i = 0; i < 3 * nv; i++) {
        worst = fmax(worst, fabs((double)col[1][1][i] - col[1][0][i]) / (fabs(col[1][0][i]) + 1e-3 * cmax));
        ratio = fmax(ratio, fabs((double)col[1][1][i] - 1e7 * (double)col[0][1][i]) / (fabs(col[1][0][i]) + 1e-3 * cmax));
    }
    fprintf(stderr, "test_glrt: 1e37 sun: %g lit vertex values, max %.3g; gl vs cpu %.2e; gl 1e37 vs 1e30 x 1e7 %.2e\n", lit, cmax,
            worst, ratio);
    CHECK(finite, "non-finite vertex colours under the 1e37 sun");
    CHECK(lit > nv && cmax > 1e34, "the 1e37 sun lights nothing (%g lit values, max %g)", lit, cmax);
    CHECK_LE(worst, 1e-4, "gl vertex colours differ from cpu's under the 1e37 sun");
    CHECK_LE(ratio, 1e-4, "gl: the 1e37 sun is not the 1e30 one x 1e7");
    if (img[1][0].data && img[1][1].data) {
        double pmax = 0, pw = 0, plit = 0;
        bool pfin = true;
        size_t n = (size_t)w * h * 3;
        for (size_t i = 0; i < n; i++) pmax = fmax(pmax, img[1][0].data[i]);
        for (size_t i = 0; i < n; i++) {
            pfin &= isfinite(img[1][1].data[i]);
            plit += img[1][1].data[i] > 0;
            pw = fmax(pw, fabs((double)img[1][1].data[i] - img[1][0].data[i]) / (img[1][0].data[i] + 1e-3 * pmax));
        }
        fprintf(stderr, "test_glrt: 1e37 sun images: %g lit values, gl vs cpu max rel %.2e\n", plit, pw);
        CHECK(pfin && plit > 1000, "gl image under the 1e37 sun: finite %d, %g lit values", pfin, plit);
        CHECK_LE(pw, 1e-3, "gl image differs from cpu's under the 1e37 sun");
    }
    if (pix[0].data && pix[1].data) {   /* per pixel (gl's default): finite, lit, 1e7 x the 1e30 image */
        double pmax = 0, num = 0, den = 0, plit = 0;
        bool pfin = true;
        for (size_t i = 0; i < (size_t)w * h * 3; i++) {
            double a = pix[1].data[i], b = 1e7 * (double)pix[0].data[i];
            pfin &= isfinite(pix[1].data[i]);
            plit += a > 0;
            pmax = fmax(pmax, a);
            num += (a - b) * (a - b);
            den += b * b;
        }
        fprintf(stderr, "test_glrt: 1e37 sun per pixel: %g lit values, max %.3g, against 1e30 x 1e7 rel RMS %.2e\n", plit, pmax,
                sqrt(num / den));
        CHECK(pfin && plit > 1000, "gl per-pixel image under the 1e37 sun: finite %d, %g lit values", pfin, plit);
        CHECK_LE(sqrt(num / den), 1e-4, "gl per pixel: the 1e37 image is not the 1e30 one x 1e7 (relative RMS)");
    }
    for (int s = 0; s < 2; s++)
        for (int b = 0; b < 2; b++) { free(col[s][b]); image_free(&img[s][b]); }
    image_free(&pix[0]);
    image_free(&pix[1]);
    prt_data_free(&d);
}

/* A transfer without GLSL kernels (ops->linear->glsl NULL; cpca is one) lit by the CPU method: g is
 * transfer_light's, uploaded. The g read back must equal transfer_light's bits (the same code on the
 * same inputs in one process; floats copied to the GPU and back unchanged), for the total, the direct
 * set (glrt_use_direct) and a 1e37 light (transfer_light scales it: no unshift on this path). The images:
 * per-vertex gl against cpu through runtime.h, the scene case's rule (same model, same g: float
 * rounding of GL's view lookups and raster). */
static void cpu_light(void) {
    prt_error err = { { 0 } };
    prt_mesh sphere = { 0 };
    prt_scene sc = { 0 };
    prt_data d;
    memset(&d, 0, sizeof d);
    const float c[3] = { 0, 0.5f, 0 };
    int rc = mesh_make_sphere(&sphere, c, 0.5f, 8, 12, &err);
    if (rc == 0) rc = scene_from_mesh(&sphere, "lambert:kd=0.8", &sc, &err);
    if (rc == 0) rc = scene_add_floor(&sc, 400, 3, NULL, &err);
    precompute_desc pd = { .no_open_sky = true, .vis_res = 64, .quiet = true, .bounces = 1, .force_bounces = 1, .gather_res = 16, .keep_direct = true,
                           .basis = "cpca", .basis_options = "clusters=6,terms=6,coeffs=1500,stage=3000" };
    if (rc == 0) rc = precompute_run(&sc, &pd, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    const prt_transfer *tr = prt_data_transfer(&d);
    CHECK(tr->ops->linear->glsl == NULL && tr->direct.nvecs == tr->transport.nvecs, "a transfer without GLSL, the direct set kept");
    prt_probe sky;
    sky_desc sd = { .width = 128, .sun_dir = { 0.4f, 0.8f, 0.45f }, .sun_radius_deg = 5, .sun_radiance = 80 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    probe_to_cube(&sky, CUBE_RES, NULL, 0, cube);
    float (*L)[4] = transfer_light_vector(tr, cube), (*big)[4] = transfer_light_alloc();
    for (int k = 0; k < CUBE_TEXELS; k++)
        for (int ch = 0; ch < 4; ch++) big[k][ch] = ldexpf(L[k][ch], 100);   /* a sun near 1e37: scaled in transfer_light */
    free(cube);
    int nv = tr->transport.nvecs;
    float *g = calloc(3 * (size_t)nv, sizeof(float)), *want = calloc(3 * (size_t)nv, sizeof(float)), *tot = calloc(3 * (size_t)nv, sizeof(float));
    glrt_desc desc = { .light = GLRT_LIGHT_FRAGMENT };   /* asked for a GL kernel: it gets the CPU method */
    glrt *rt = glrt_create(&d, &desc, &err);
    CHECK(rt != NULL, "%s", err.msg);
    if (rt) {
        glrt_timing tm;
        glrt_get_timing(rt, &tm);
        CHECK(tm.light_method == GLRT_LIGHT_CPU && !strcmp(tm.light_method_name, "cpu"), "method %s", tm.light_method_name);
        CHECK(glrt_set_light_method(rt, GLRT_LIGHT_THREAD, &err) == -1 && strstr(err.msg, "no GLSL") && !strchr(err.msg, '\n'),
              "a GL kernel refused in one line: '%s'", err.msg);
        CHECK(glrt_set_light_method(rt, GLRT_LIGHT_AUTO, &err) == 0, "auto: %s", err.msg);
        const float (*lights[3])[4] = { (const float (*)[4])L, (const float (*)[4])L, (const float (*)[4])big };
        for (int step = 0; step < 3; step++) {
            bool direct = step == 1;
            CHECK(glrt_use_direct(rt, direct, &err) == 0 && glrt_set_light(rt, lights[step], &err) == 0 &&
                  glrt_read_gvec(rt, g, &err) == 0, "step %d: %s", step, err.msg);
            transfer_light(tr, direct ? &tr->direct : &tr->transport, lights[step], want, 0);
            if (step == 0) memcpy(tot, want, sizeof(float) * 3 * (size_t)nv);
            double dt = 0, gmax = 0;
            for (int i = 0; i < 3 * nv; i++) dt = fmax(dt, fabs(want[i] - tot[i])), gmax = fmax(gmax, fabs(want[i]));
            if (step == 1) CHECK(dt > 1e-3 * gmax, "the direct set lit as the total (the bounce adds %g of %g)", dt, gmax);
            if (step == 2) CHECK(gmax > 1e30 && isfinite(gmax), "the 1e37 light: max g %g", gmax);
            CHECK(!memcmp(g, want, sizeof(float) * 3 * (size_t)nv), "step %d (%s): g differs from transfer_light's", step,
                  step == 0 ? "total" : step == 1 ? "direct" : "1e37 light");
        }
        glrt_get_timing(rt, &tm);
        CHECK(tm.light_ms > 0 && tm.gpu_bytes > 0, "light_ms %g, gpu bytes %zu", tm.light_ms, tm.gpu_bytes);
        glrt_destroy(rt);
    }
    /* per-vertex images, gl against cpu (runtime.h, the backends' own light change) */
    const int w = 120, h = 90;
    prt_camera cam;
    camera_default(d.scene.bmin, d.scene.bmax, (float)w / h, &cam);
    prt_image img[3] = { { 0 }, { 0 }, { 0 } };   /* cpu, gl per vertex, gl per pixel */
    for (int b = 0; b < 2; b++) {
        runtime_desc rdsc = { .backend = b ? "gl" : "cpu", .view = RUNTIME_VIEW_VERTEX };
        prt_runtime *rrt = runtime_create(&d, &rdsc, &err);
        render_desc rd = { .width = w, .height = h, .camera = cam };
        CHECK(rrt && runtime_set_light(rrt, &sky, NULL, &err) == 0 && runtime_render(rrt, &rd, &img[b], &err) == 0, "%s: %s",
              rdsc.backend, err.msg);
        if (rrt && b) {
            runtime_timing t;
            runtime_get_timing(rrt, &t);
            CHECK(t.kernel && !strcmp(t.kernel, "cpu"), "gl runtime's kernel: %s", t.kernel ? t.kernel : "(none)");
            CHECK(runtime_set_view(rrt, RUNTIME_VIEW_PIXEL, &err) == 0 && runtime_render(rrt, &rd, &img[2], &err) == 0, "%s", err.msg);
        }
        runtime_destroy(rrt);
    }
    /* Per pixel (gl's default) too: Lambertian, so h is one constant per material and h . g interpolated per
     * pixel is the Gouraud of the vertex colours to rounding (but for colours clamped at zero, hence the quantile). */
    for (int k = 1; k < 3 && img[0].data; k++) {
        size_t n = (size_t)w * h * 3;
        double cmax = 0, *rel = img[k].data ? malloc(sizeof(double) * n) : NULL;
        if (!rel) continue;
        for (size_t i = 0; i < n; i++) cmax = fmax(cmax, img[0].data[i]);
        rel_diffs(&img[k], &img[0], 1e-3 * cmax, rel);
        fprintf(stderr, "test_glrt: cpu light method, %s GL vs CPU: median rel diff %.2e, 99.9%% %.2e, max %.2e\n",
                k == 1 ? "per-vertex" : "per-pixel", rel[n / 2], rel[n * 999 / 1000], rel[n - 1]);
        CHECK(cmax > 0, "black image");
        CHECK_LE(rel[n * 999 / 1000], 1e-4, "%s GL image (cpu light method) differs from the CPU runtime's", k == 1 ? "per-vertex" : "per-pixel");
        CHECK_LE(rel[n / 2], 1e-5, "median");
        free(rel);
    }
    for (int k = 0; k < 3; k++) image_free(&img[k]);
    free(g); free(want); free(tot); free(L); free(big);
    probe_free(&sky);
    prt_data_free(&d);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(synthetic);
    CHECK_CASE(egl);
    CHECK_CASE(viewmaps);
    CHECK_CASE(direct_switch);
    CHECK_CASE(scene);
    CHECK_CASE(textured_vertex);
    CHECK_CASE(bright_sun);
    CHECK_CASE(cpu_light);
    return check_summary();
}
