/* test_precompute.c - the direct transport pass against analytic answers and brute force.
 *
 * (1) An unoccluded upward Lambert vertex of albedo a under a constant environment L
 *     has radiance a L (Wang et al. Eq. 2 with V = 1: the cosine integrates to pi).
 * (2) A plane above the vertex covering exactly the directions with x > 0 (an edge
 *     straight above it) halves the cosine-weighted integral: radiance a L / 2.
 *     Both hold within a bound computed from the 8-bit transport step and the
 *     16-bit light step (and the cube's quadrature of the cosine), for Haar and SH.
 * (3) End to end: a glossy sphere over a Lambert plane precomputed at N = 24,576 in
 *     float (uncompressed), relit under the procedural sky, against a brute-force
 *     Eq. 2 integral of the same probe with the factorized BRDF and vis_occluded
 *     rays over a fine direction grid; then the 8-bit N = 128 default the same way.
 * (4) Light-weighted texels (prior.h, through Haar's light prior of a probe file): a 1-degree sun
 *     inside one 1.6-degree lighting texel, an occluder's edge crossing the sun, uncompressed: the
 *     vertex's radiance against a fine quadrature of the probe with the occluder's exact
 *     visibility, with and without the rays.
 * (5) Scale (docs/design/scale.md): a glossy sphere over a floor with one bounce, built at scales
 *     2^-100 to 2^96 and 1e-6, 1e6: every vertex's radiance toward an eye scaled with it is the
 *     scale-1 scene's bit for bit at the powers of two (the scaling is exact and the pipeline
 *     computes in scaled units), and within a few flipped rays' worth at the decimal scales. */
#include "harness.h"
#include "cubemap.h"
#include "haar.h"
#include "haar_run.h"
#include "image.h"
#include "light.h"
#include "linear.h"
#include "mesh.h"
#include "precompute.h"
#include "driver.h"
#include "prior.h"
#include "probe.h"
#include "scene.h"
#include "refine.h"
#include "prtfile.h"
#include "relight.h"
#include "shbasis.h"
#include "visibility.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Haar's options for the paper's transfer (texel measure, N largest per vector), which make_light's
 * light vector matches. */
#define PAPER_HAAR "measure=texels,budget=vector"

/* Light vector of a probe: cube resample, then Haar of the texels (light.h) or SH (shbasis.h). */
static float (*make_light(const prt_probe *pr, int qbits, int sh_bands, light_stats *st))[4] {
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    float (*L)[4] = transfer_light_alloc();
    probe_to_cube(pr, CUBE_RES, NULL, 0, cube);
    memset(st, 0, sizeof *st);
    if (sh_bands > 0) {
        sh_light_from_cube(cube, CUBE_RES, sh_bands, L);
    } else {
        light_desc ld = { .threshold = 0, .qbits = qbits };
        light_from_cube(cube, &ld, L, st);
    }
    free(cube);
    return L;
}

/* Sum over upper-hemisphere texels of the cube at res of (n.w) dw, restricted to w.x <= 0 when half:
 * the cube quadrature of pi (or pi/2) the pipeline can reach at best. */
static double cube_cosine_sum(int res, bool half) {
    float *sa = malloc(sizeof(float) * res * res);
    cube_face_solid_angles(res, sa);
    double s = 0;
    for (int i = 0; i < 6 * res * res; i++) {
        float d[3];
        cube_texel_dir(res, i, d);
        if (d[1] > 0 && (!half || d[0] <= 0)) s += d[1] * sa[i % (res * res)];
    }
    free(sa);
    return s;
}

/* Precomputes `mesh` with one Lambert material of albedo a, relights it under a constant L and
 * checks vertex v (normal +y) against a L frac within the quantization bound. */
static void lambert_case(const char *label, prt_mesh *mesh, int v, float a, float Lc, bool half, int sh_bands, int vis_res) {
    prt_error err;
    prt_scene sc;
    char spec[64];
    snprintf(spec, sizeof spec, "lambert:kd=%g", a);
    CHECK(scene_from_mesh(mesh, spec, &sc, &err) == 0, "%s", err.msg);
    char order[32];
    snprintf(order, sizeof order, "order=%d", sh_bands);
    precompute_desc d = { .no_open_sky = true, .N = 128, .vis_res = vis_res, .quiet = true, .basis = sh_bands ? "sh" : NULL,
                          .basis_options = sh_bands ? order : PAPER_HAAR, .nthreads = 2 };
    prt_data out;
    int rc = precompute_run(&sc, &d, &out, &err);
    CHECK(rc == 0, "%s: %s", label, err.msg);
    if (rc) return;
    CHECK(out.factors[0].K == 1 && out.factors[0].lambertian, "%s: Lambert factor K = %d", label, out.factors[0].K);
    CHECK(out.ntransfers == 1 && out.transfers[0].ops == transfer_find(sh_bands ? "sh" : "haar") &&
          linear_config_of(&out.transfers[0].cfg).order == sh_bands && out.transfers[0].materials == 1, "%s: one %s transfer",
          label, sh_bands ? "sh" : "haar");
    CHECK(out.transfers[0].transport.nvecs == out.scene.mesh.nverts, "%s: one vector per vertex", label);
    CHECK_NEAR(out.scene.mesh.nrm[3 * v + 1], 1.0, 1e-6, "%s: vertex normal is +y", label);

    prt_probe pr;
    float rgb[3] = { Lc, 0.5f * Lc, 2 * Lc };
    CHECK(probe_make_constant(rgb, &pr, &err) == 0, "%s", err.msg);
    light_stats ls;
    float (*L)[4] = make_light(&pr, 16, sh_bands, &ls);
    relight_ctx *rc2 = relight_create(&out, 2, &err);
    CHECK(rc2 != NULL, "%s", err.msg);
    if (!rc2) { free(L); probe_free(&pr); prt_data_free(&out); return; }
    relight_set_light(rc2, (const float (*)[4])L);
    float up[3] = { 0, 1, 0 }, got[3];
    relight_vertex(rc2, v, up, 0, got);

    /* Bound: |h| (sum_i |L_i| dT/2 + sum_i |T_i| dL/2) with dT the transport's 8-bit step and dL
     * the light's 16-bit step (section 4.1.2 and 4.3), plus the cube quadrature of the cosine
     * (texel centres with exact solid angles) and 1e-4 for float arithmetic. */
    int vec = (int)out.transfers[0].transport.vec_first[v];
    float *T = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    transport_decode(&out.transfers[0].transport, vec, T, T + CUBE_TEXELS, T + 2 * CUBE_TEXELS);
    float hv[3], wl[3] = { 0, 0, 1 };
    brdf_factor_view(&out.factors[0], wl, hv);
    double frac = half ? 0.5 : 1.0;
    double quad = cube_cosine_sum(vis_res, half) / M_PI - frac;
    for (int ch = 0; ch < 3; ch++) {
        double dT = out.transfers[0].transport.scale[3 * vec + ch], dL = sh_bands > 0 ? 0 : ls.step[ch];
        double sL = 0, sT = 0;
        for (int i = 0; i < CUBE_TEXELS; i++) {
            sL += fabs(L[i][ch]);
            sT += fabs(T[ch * CUBE_TEXELS + i]);
        }
        double expect = a * rgb[ch] * frac;
        double bound = fabs(hv[ch]) * (sL * dT / 2 + sT * dL / 2) + a * rgb[ch] * (fabs(quad) + 1e-4);
        CHECK_NEAR(got[ch], expect, bound, "%s channel %d", label, ch);
        if (ch == 0)
            printf("%s: radiance %.6f, expected a L x %.1f = %.6f, |error| %.2e <= bound %.2e\n", label, got[ch],
                   frac, expect, fabs(got[ch] - expect), bound);
    }
    CHECK(out.stats.rays_traced > 0 && out.stats.t_total > 0 && out.stats.peak_rss_bytes > 0, "%s: stats filled", label);
    CHECK(out.stats.trunc_rel_err >= 0 && out.stats.trunc_rel_err < 0.5, "%s: truncation error %g", label,
          out.stats.trunc_rel_err);
    free(T);
    free(L);
    relight_destroy(rc2);
    probe_free(&pr);
    prt_data_free(&out);
}

/* (1) a small plane alone: its centre vertex sees the whole upper hemisphere */
static void lambert_open(void) {
    prt_error err;
    for (int q = 0; q < 3; q++) {
        prt_mesh m = { 0 };
        CHECK(mesh_make_plane(&m, -0.1f, 0.1f, -0.1f, 0.1f, 0, 3, 3, &err) == 0, "%s", err.msg);
        int sh = q == 2 ? 3 : 0, vr = q == 0 ? 128 : 64;
        lambert_case(q == 0 ? "open, Haar, vis 128" : q == 1 ? "open, Haar, vis 64" : "open, SH order 3", &m, 4, 0.7f,
                     2.0f, false, sh, vr);
    }
}

/* (2) the same vertex under a plane y = 1 covering x in [0, 1000], z in [-1000, 1000]: every
 * direction with x > 0 above the horizon hits it except those below 1/1000 rad of elevation,
 * which carry sin^2 of that (1e-6) of the cosine-weighted integral. */
static void lambert_half(void) {
    prt_error err;
    for (int q = 0; q < 2; q++) {
        prt_mesh m = { 0 }, cover = { 0 };
        CHECK(mesh_make_plane(&m, -0.1f, 0.1f, -0.1f, 0.1f, 0, 3, 3, &err) == 0, "%s", err.msg);
        CHECK(mesh_make_plane(&cover, 0, 1000, -1000, 1000, 1, 2, 2, &err) == 0, "%s", err.msg);
        CHECK(mesh_append(&m, &cover, &err) == 0, "%s", err.msg);
        mesh_free(&cover);
        lambert_case(q == 0 ? "half-covered, Haar" : "half-covered, SH order 3", &m, 4, 0.7f, 2.0f, true, q ? 3 : 0, 128);
    }
}

/* ---- (3) end to end against brute force ---- */

typedef struct bf_ctx {
    const prt_data *d;
    const vis_scene *vs;
    const prt_probe *pr;
    int res;                 /* brute-force direction grid (cube of res) */
    const float *dirs;       /* [6 res^2][3] */
    const float *sa;         /* [res^2] */
    const float *Lp;         /* [6 res^2][3] probe radiance at dirs */
    const int *verts;
    const float *eye;
    float *truth;            /* [nv][3] */
} bf_ctx;

/* Eq. 2 with the factorized BRDF: sum_k h_k(wo) sum_w L(w) g_k(w) V(w) (n.w) dw per vertex. */
static void bf_fn(void *ctx, int b, int e, int th) {
    bf_ctx *c = ctx;
    const prt_mesh *m = &c->d->scene.mesh;
    float eps = vis_eps(c->vs);
    for (int q = b; q < e; q++) {
        int v = c->verts[q];
        const float *p = m->pos + 3 * v, *n = m->nrm + 3 * v;
        const brdf_factor *f = &c->d->factors[m->mat[v]];
        float s[3], t[3];
        brdf_frame(n, s, t);
        float wo[3] = { c->eye[0] - p[0], c->eye[1] - p[1], c->eye[2] - p[2] };
        float wl = sqrtf(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]);
        for (int k = 0; k < 3; k++) wo[k] /= wl;
        float wol[3], h[BRDF_MAX_SIGMA * 3], g[BRDF_MAX_SIGMA * 3];
        brdf_to_local(s, t, n, wo, wol);
        brdf_factor_view(f, wol, h);
        double acc[BRDF_MAX_SIGMA * 3] = { 0 };
        float org[3] = { p[0] + eps * n[0], p[1] + eps * n[1], p[2] + eps * n[2] };
        for (int i = 0; i < 6 * c->res * c->res; i++) {
            const float *w = c->dirs + 3 * i;
            float nw = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
            if (!(nw > 0)) continue;
            if (vis_occluded(c->vs, org, w, eps, INFINITY)) continue;
            float loc[3];
            brdf_to_local(s, t, n, w, loc);
            brdf_factor_light(f, loc, g);
            double wgt = nw * c->sa[i % (c->res * c->res)];
            for (int k = 0; k < f->K; k++)
                for (int ch = 0; ch < 3; ch++) acc[3 * k + ch] += wgt * c->Lp[3 * i + ch] * g[3 * k + ch];
        }
        for (int ch = 0; ch < 3; ch++) {
            double r = 0;
            for (int k = 0; k < f->K; k++) r += h[3 * k + ch] * acc[3 * k + ch];
            c->truth[3 * q + ch] = (float)r;
        }
    }
}

/* Builds the sphere-over-plane scene (plane Lambert, sphere glossy Phong). */
static int make_sphere_plane(prt_scene *sc, prt_error *err) {
    prt_mesh plane = { 0 }, sph = { 0 };
    float c[3] = { 0, 0.8f, 0 };
    if (mesh_make_plane(&plane, -2, 2, -2, 2, 0, 21, 21, err) || mesh_make_sphere(&sph, c, 0.6f, 20, 40, err)) return -1;
    int first = plane.nverts;
    if (mesh_append(&plane, &sph, err)) return -1;
    mesh_free(&sph);
    if (scene_from_mesh(&plane, "lambert:kd=0.6,0.55,0.5", sc, err)) return -1;
    if (scene_material(sc, "phong:kd=0.3,0.1,0.1;ks=0.4;n=20", err) != 1) return -1;
    for (int v = first; v < sc->mesh.nverts; v++) sc->mesh.mat[v] = 1;
    return 0;
}

/* pass 0: uncompressed (N = all, float): the discretization alone; pass 1: the 8-bit default */
static void end_to_end(int pass) {
    prt_error err;
    prt_probe sky;
    sky_desc sd = { 0 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    const int res = 192;   /* brute-force grid: 0.6 degree texels, ~20 samples across the 1.5 degree sun */
    float *dirs = malloc(sizeof(float) * 3 * 6 * res * res), *sa = malloc(sizeof(float) * res * res);
    float *Lp = malloc(sizeof(float) * 3 * 6 * res * res);
    for (int i = 0; i < 6 * res * res; i++) {
        cube_texel_dir(res, i, dirs + 3 * i);
        probe_eval(&sky, dirs + 3 * i, Lp + 3 * i);
    }
    cube_face_solid_angles(res, sa);
    const float eye[3] = { 2.5f, 3.0f, 3.5f };

    {
        prt_scene sc;
        CHECK(make_sphere_plane(&sc, &err) == 0, "%s", err.msg);
        /* the direct pass with the SVD is what this checks: no bounces, glossy svd, the input's vertices */
        precompute_desc d = { .no_open_sky = true, .N = pass == 0 ? CUBE_TEXELS : 128, .qbits = pass == 0 ? 32 : 8, .vis_res = 128,
                              .quiet = true, .nthreads = 2, .force_bounces = -1, .force_refine = -1, .glossy = PRECOMPUTE_GLOSSY_SVD,
                              .basis_options = PAPER_HAAR };
        prt_data out;
        int rc = precompute_run(&sc, &d, &out, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) goto done;
        const prt_mesh *m = &out.scene.mesh;
        CHECK(out.factors[1].K == 4 && !out.factors[1].lambertian, "glossy K = %d", out.factors[1].K);
        CHECK(out.transfers[0].transport.nvecs == 441 + 4 * (m->nverts - 441), "vectors: %d", out.transfers[0].transport.nvecs);
        /* Every vertex traces exactly half of the cube: texel centres come in antipodal pairs. */
        CHECK_NEAR((double)out.stats.rays_traced, (double)m->nverts * 3 * 128 * 128, m->nverts * 8.0, "rays traced");
        CHECK(out.stats.hit_fraction > 0.01 && out.stats.hit_fraction < 0.5, "hit fraction %g", out.stats.hit_fraction);

        light_stats ls;
        float (*L)[4] = make_light(&sky, pass == 0 ? 32 : 16, 0, &ls);
        relight_ctx *rl = relight_create(&out, 2, &err);
        CHECK(rl != NULL, "%s", err.msg);
        if (!rl) { free(L); prt_data_free(&out); goto done; }
        relight_set_light(rl, (const float (*)[4])L);
        vis_scene *vs = vis_create(m, &err);
        CHECK(vs != NULL, "%s", err.msg);

        /* vertices facing the eye, every 9th */
        int *verts = malloc(sizeof(int) * m->nverts), nv = 0;
        for (int v = 0; v < m->nverts; v += 9) {
            const float *p = m->pos + 3 * v, *n = m->nrm + 3 * v;
            float wo[3] = { eye[0] - p[0], eye[1] - p[1], eye[2] - p[2] };
            if (wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2] > 0.2f * sqrtf(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]))
                verts[nv++] = v;
        }
        float *truth = malloc(sizeof(float) * 3 * nv);
        bf_ctx bc = { &out, vs, &sky, res, dirs, sa, Lp, verts, eye, truth };
        prt_parallel_for(nv, 2, 2, bf_fn, &bc);
        double se[2] = { 0, 0 }, st[2] = { 0, 0 };
        int cnt[2] = { 0, 0 };
        for (int q = 0; q < nv; q++) {
            int v = verts[q], g = m->mat[v];
            const float *p = m->pos + 3 * v;
            float wo[3] = { eye[0] - p[0], eye[1] - p[1], eye[2] - p[2] }, rgb[3];
            float wl = sqrtf(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]);
            for (int k = 0; k < 3; k++) wo[k] /= wl;
            relight_vertex(rl, v, wo, 0, rgb);
            for (int ch = 0; ch < 3; ch++) {
                se[g] += (rgb[ch] - truth[3 * q + ch]) * (double)(rgb[ch] - truth[3 * q + ch]);
                st[g] += truth[3 * q + ch] * (double)truth[3 * q + ch];
            }
            cnt[g]++;
        }
        double rel_plane = sqrt(se[0] / st[0]), rel_sphere = sqrt(se[1] / st[1]);
        double rel_all = sqrt((se[0] + se[1]) / (st[0] + st[1]));
        printf("end to end (%s): rel RMS error vs brute force: %.2f%% (plane %.2f%% over %d vertices, glossy sphere %.2f%% over %d)\n",
               pass == 0 ? "N=24576 float" : "N=128 8-bit", 100 * rel_all, 100 * rel_plane, cnt[0], 100 * rel_sphere, cnt[1]);
        /* Tolerances. Uncompressed, the difference is the discretization alone (64-res lighting
         * texels and texel-centre g_k against 192-res point samples, 2x2-filtered visibility at
         * the sun's shadow edges): measured 0.3%, asserted 1.5%. The N = 128 8-bit default adds
         * the non-linear truncation, which under a sun-dominated probe is a pointwise error of
         * the 128-term transport at the sun's texel (measured: N = 128 float 13.5%, all
         * coefficients 8-bit 4.3%, N = 128 8-bit 14%): asserted 20%. */
        CHECK_LE(rel_all, pass == 0 ? 0.015 : 0.20, "relative RMS error");
        CHECK(cnt[0] > 20 && cnt[1] > 20, "enough vertices: %d %d", cnt[0], cnt[1]);
        free(verts);
        free(truth);
        vis_destroy(vs);
        relight_destroy(rl);
        free(L);
        prt_data_free(&out);
    }
done:
    free(dirs); free(sa); free(Lp);
    probe_free(&sky);
}

static void end_to_end_float(void) { end_to_end(0); }
static void end_to_end_8bit(void) { end_to_end(1); }

/* A constant probe (radiance rgb) written to path as a float EXR, for a light prior. Returns 0 or -1. */
static int write_probe(const prt_probe *p, const char *path) {
    prt_error err;
    int rc = image_write(path, &p->img, NULL, &err);
    CHECK(rc == 0, "%s", err.msg);
    return rc;
}

/* Haar's budget=auto (its default, what `prt precompute` does) below HAAR_SHARED_MAX_VECS vectors is the
 * shared budget, coefficient for coefficient, and the plan says so; an explicit per-vector budget
 * differs (at most N per vector) and its plan has no shared line. With a light prior auto is per vector.
 * (Refinement off: the glossy sphere's would only lengthen its vMF pass, which this does not check.) */
static void budget_auto(void) {
    prt_error err;
    prt_data out[3];
    const char *kinds[3] = { NULL, "budget=shared", "budget=vector" };
    int ok = 0;
    for (int k = 0; k < 3; k++) {
        prt_scene sc;
        CHECK(make_sphere_plane(&sc, &err) == 0, "%s", err.msg);
        precompute_desc d = { .no_open_sky = true, .N = 32, .qbits = 8, .vis_res = 64, .quiet = true, .nthreads = 2, .force_bounces = -1,
                              .force_refine = -1, .basis_options = kinds[k] };
        int rc = precompute_run(&sc, &d, &out[k], &err);
        CHECK(rc == 0, "budget %s: %s", kinds[k] ? kinds[k] : "auto", err.msg);
        ok += rc == 0;
    }
    if (ok < 3) return;
    const prt_transport *a = &out[0].transfers[0].transport, *s = &out[1].transfers[0].transport, *v = &out[2].transfers[0].transport;
    size_t n = transport_ncoefs(a);
    /* exact by construction: auto resolves to the shared budget, the same code on the same inputs
     * in one process (and below, with a prior, to the per-vector one) */
    CHECK(a->nvecs < HAAR_SHARED_MAX_VECS && n == transport_ncoefs(s) && a->N == s->N &&
              !memcmp(a->coef_first, s->coef_first, sizeof(uint32_t) * (a->nvecs + 1)) &&
              !memcmp(a->packed, s->packed, sizeof(uint32_t) * n), "auto differs from shared (%zu coefficients)", n);
    CHECK(strstr(out[0].plan, "N x vectors shared") && !strstr(out[2].plan, "N x vectors shared"), "plans: %s / %s",
          out[0].plan, out[2].plan);
    CHECK(v->N == 32 && a->N == TRANSPORT_SHARED_CAP * 32 && n <= (size_t)32 * a->nvecs, "N per vector %d, shared up to %d", v->N, a->N);
    for (int k = 0; k < 3; k++) prt_data_free(&out[k]);
    /* With a light prior (a constant probe's, which turning does not change: one yaw angle) auto is the
     * per-vector budget, coefficient for coefficient. */
    prt_probe pr;
    const float grey[3] = { 0.5f, 0.5f, 0.5f };
    char path[600];
    snprintf(path, sizeof path, "%s/prior_grey.exr", check_tmpdir());
    if (probe_make_constant(grey, &pr, &err) || write_probe(&pr, path)) { CHECK(0, "%s", err.msg); return; }
    probe_free(&pr);
    ok = 0;
    for (int k = 0; k < 2; k++) {
        prt_scene sc;
        CHECK(make_sphere_plane(&sc, &err) == 0, "%s", err.msg);
        precompute_desc d = { .no_open_sky = true, .N = 32, .qbits = 8, .vis_res = 64, .quiet = true, .nthreads = 2, .force_bounces = -1,
                              .force_refine = -1, .light_prior = path, .basis_options = k ? "budget=vector,prior_yaws=1" : "prior_yaws=1" };
        int rc = precompute_run(&sc, &d, &out[k], &err);
        CHECK(rc == 0, "prior, budget %s: %s", k ? "vector" : "auto", err.msg);
        ok += rc == 0;
    }
    if (ok == 2) {
        a = &out[0].transfers[0].transport, v = &out[1].transfers[0].transport;
        n = transport_ncoefs(a);
        CHECK(a->N == 32 && n == transport_ncoefs(v) && !memcmp(a->packed, v->packed, sizeof(uint32_t) * n),
              "with a prior auto is per vector (N %d, %zu coefficients)", a->N, n);
        CHECK(strstr(out[0].plan, "N per vector (with a light prior") != NULL, "the plan says so: %s", out[0].plan);
        for (int k = 0; k < 2; k++) prt_data_free(&out[k]);
    }
}

/* What `prt precompute SCENE.json` does is a zeroed desc with the scene's own keys applied
 * (precompute_desc_apply_scene), run by precompute_file (driver.h): a small scene naming a light prior
 * (a sky written here) and asking for refinement, precomputed by the library so and by the prt binary
 * with no flag, gives the same refined mesh and the same transport, vector for vector (exact: the same
 * library code on the same inputs; the thread count changes nothing, precompute.h), and leaves no
 * checkpoint behind. Also the defaults' plan lines: Haar per steradian, the prior named, the
 * per-vector budget it implies, the refit; and a missing scene: status 1, one line naming it. */
static void scene_keys(void) {
    prt_error err;
    char probe[600], json[600], cli_out[600], cmd[2400], buf[8192];
    snprintf(probe, sizeof probe, "%s/keys-sky.exr", check_tmpdir());
    snprintf(json, sizeof json, "%s/keys.json", check_tmpdir());
    snprintf(cli_out, sizeof cli_out, "%s/keys-cli.prt", check_tmpdir());
    prt_probe sky;
    sky_desc sd = { .width = 128 };
    if (probe_make_sky(&sd, &sky, &err) || write_probe(&sky, probe)) { CHECK(0, "%s", err.msg); return; }
    probe_free(&sky);
    FILE *f = fopen(json, "w");
    if (!f) { CHECK(0, "cannot write %s", json); return; }
    fputs("{ \"models\": [ { \"box\": { \"min\": [-0.2, 0.3, -0.2], \"max\": [0.2, 0.5, 0.2], \"n\": 1 } },\n"
          "    { \"plane\": { \"x\": [-1, 1], \"z\": [-1, 1], \"height\": 0, \"nx\": 6, \"nz\": 6 }, \"material\": \"lambert:kd=0.5\" } ],\n"
          "  \"light_prior\": \"keys-sky.exr\", \"refine\": { \"budget\": 80, \"models\": true } }\n", f);
    fclose(f);
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet --threads 2", check_prt_bin(), json, cli_out);
    int rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 0, "prt precompute: %s", buf);
    prt_scene sc;
    prt_data lib, cli;
    if (rc || scene_load(json, &(scene_desc){ .floor = -1 }, &sc, &err)) { CHECK(0, "%s", err.msg); return; }
    precompute_desc d = { 0 };
    CHECK(precompute_desc_apply_scene(&d, &sc, PRECOMPUTE_SCENE_ALL, &err) == 0 && d.light_prior && d.light_prior_scene &&
          d.refine_threshold > 0 && d.refine_budget == 80 && d.refine_parts == REFINE_ALL, "the scene's keys applied");
    scene_free(&sc);
    char lib_out[700], ck[720];
    snprintf(lib_out, sizeof lib_out, "%s/keys-lib.prt", check_tmpdir());
    snprintf(ck, sizeof ck, "%s.ckpt", lib_out);
    precompute_desc zero = { 0 };
    precompute_job job = { .scene_path = json, .scene = &(scene_desc){ .floor = -1 }, .out_path = lib_out,
                           .scene_keys = PRECOMPUTE_SCENE_ALL, .checkpoint = true, .quiet = true };
    precompute_outcome o;
    if (precompute_file(&job, &zero, &o, &err)) { CHECK(0, "precompute_file (status %d): %s", o.status, err.msg); return; }
    CHECK(access(ck, F_OK) != 0, "the checkpoint is removed once the file is whole");
    if (prtfile_read(lib_out, &lib, &err)) { CHECK(0, "%s", err.msg); return; }
    if (prtfile_read(cli_out, &cli, &err)) { CHECK(0, "%s", err.msg); prt_data_free(&lib); return; }
    const prt_mesh *a = &lib.scene.mesh, *b = &cli.scene.mesh;
    CHECK(a->nverts == b->nverts && a->nverts > 6 * 6 && !memcmp(a->pos, b->pos, sizeof(float) * 3 * (size_t)a->nverts),
          "the same refined mesh: %d and %d vertices", a->nverts, b->nverts);
    const prt_transport *x = &prt_data_transfer(&lib)->transport, *y = &prt_data_transfer(&cli)->transport;
    size_t nc = transport_ncoefs(x);
    CHECK(x->nvecs == y->nvecs && nc == transport_ncoefs(y) && x->N == y->N && x->qbits == y->qbits &&
              !memcmp(x->coef_first, y->coef_first, sizeof(uint32_t) * ((size_t)x->nvecs + 1)) &&
              !memcmp(x->scale, y->scale, sizeof(float) * 3 * (size_t)x->nvecs) &&
              !memcmp(x->packed, y->packed, sizeof(uint32_t) * nc),
          "the same transport: %d / %d vectors, %zu / %zu coefficients", x->nvecs, y->nvecs, nc, transport_ncoefs(y));
    CHECK(strstr(lib.plan, "per steradian") && strstr(lib.plan, "light prior: keys-sky.exr turned about +y") &&
              strstr(lib.plan, "N per vector (with a light prior") && strstr(lib.plan, "kept values: refit"),
          "the defaults in the plan: %s", lib.plan);
    prt_data_free(&lib);
    prt_data_free(&cli);
    job.scene_path = "no-such-scene.json";
    CHECK(precompute_file(&job, &zero, &o, &err) == -1 && o.status == 1 && o.say && strstr(err.msg, "no-such-scene.json"),
          "a missing scene: status 1, one line naming it (%d: %s)", o.status, err.msg);
}

/* ---- (4) light-weighted texels against the probe's pixels ---- */

/* kd / pi times the integral of the probe's light (its bilinear radiance, probe_eval, which the
 * runtime's cube and the reference integrate) over the 3.4-degree square about the sun s (a black sky
 * elsewhere), seen from (0, eps, 0) (the rays' origin, visibility.h), the directions through the cover
 * y = 1, x0 <= x <= 4, |z| <= 1/4 hidden when x0 > 0: a 400^2 gnomonic grid (0.0086 degree) with its
 * exact Jacobian, an independent quadrature. Channel 0. */
static double sun_truth(const prt_probe *p, const float s[3], float kd, double x0, double eps) {
    const int G = 400;
    const double h = 0.03, du = 2 * h / G;
    double e1[3] = { -s[2], 0, s[0] }, l = sqrt(e1[0] * e1[0] + e1[2] * e1[2]);
    e1[0] /= l; e1[2] /= l;
    double e2[3] = { s[1] * e1[2], s[2] * e1[0] - s[0] * e1[2], -s[1] * e1[0] }, sum = 0;
    for (int b = 0; b < G; b++)
        for (int a = 0; a < G; a++) {
            double u = -h + (a + 0.5) * du, v = -h + (b + 0.5) * du, q = 1 + u * u + v * v, r = 1 / sqrt(q);
            float d[3], rgb[3];
            for (int k = 0; k < 3; k++) d[k] = (float)((s[k] + u * e1[k] + v * e2[k]) * r);
            double x = (1 - eps) * d[0] / d[1], z = (1 - eps) * d[2] / d[1];
            if (d[1] <= 0 || (x0 > 0 && x >= x0 && x <= 4 && fabs(z) <= 0.25)) continue;
            probe_eval(p, d, rgb);
            sum += rgb[0] * (double)d[1] * du * du / (q * sqrt(q));
        }
    return kd / M_PI * sum;
}

/* The centre vertex of a small +y plane, under the cover when x0 > 0, precomputed uncompressed
 * (every coefficient, float) with the light prior of the probe file prior (Haar's: its light-weighted
 * texels) or none (every texel box-filtered), relit by p: channel 0 of its radiance; *eps: the rays'
 * offset in that scene. */
static double sun_prt(const prt_probe *p, float kd, double x0, const char *prior, double *eps) {
    prt_error err;
    prt_mesh m = { 0 }, cover = { 0 };
    CHECK(mesh_make_plane(&m, -0.01f, 0.01f, -0.01f, 0.01f, 0, 3, 3, &err) == 0, "%s", err.msg);
    if (x0 > 0) {
        CHECK(mesh_make_plane(&cover, (float)x0, 4, -0.25f, 0.25f, 1, 2, 2, &err) == 0, "%s", err.msg);
        CHECK(mesh_append(&m, &cover, &err) == 0, "%s", err.msg);
        mesh_free(&cover);
    }
    vis_scene *vs = vis_create(&m, &err);
    CHECK(vs != NULL, "%s", err.msg);
    *eps = vs ? vis_eps(vs) : 0;
    vis_destroy(vs);
    prt_scene sc;
    char spec[64];
    snprintf(spec, sizeof spec, "lambert:kd=%g", kd);
    CHECK(scene_from_mesh(&m, spec, &sc, &err) == 0, "%s", err.msg);
    /* the prior's weights do not matter with every coefficient kept: one yaw angle is enough */
    precompute_desc d = { .no_open_sky = true, .N = CUBE_TEXELS, .qbits = 32, .vis_res = 128, .quiet = true, .nthreads = 2,
                          .force_bounces = -1, .light_prior = prior, .basis_options = prior ? "prior_yaws=1" : NULL };
    prt_data out;
    if (precompute_run(&sc, &d, &out, &err)) { CHECK(0, "%s", err.msg); return 0; }
    CHECK(!prior || strstr(out.plan, "light-weighted texels"), "the plan names the light-weighted texels: %s", out.plan);
    /* the light of the solid-angle measure (Haar's default), unquantized */
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), w[CUBE_RES * CUBE_RES];
    float (*L)[4] = transfer_light_alloc(), up[3] = { 0, 1, 0 }, rgb[3] = { 0, 0, 0 };
    probe_to_cube(p, CUBE_RES, NULL, 0, cube);
    haar_face_solid_angle(w, CUBE_RES, false);
    light_from_cube(cube, &(light_desc){ .qbits = 32, .face_weight = w }, L, NULL);
    free(cube);
    relight_ctx *rl = relight_create(&out, 1, &err);
    CHECK(rl != NULL, "%s", err.msg);
    if (rl) {
        relight_set_light(rl, (const float (*)[4])L);
        relight_vertex(rl, 4, up, 0, rgb);
        relight_destroy(rl);
    }
    free(L);
    prt_data_free(&out);
    return rgb[0];
}

/* The sun (radius 0.5 degree, on a black sky) lies inside texel (32, 20) of the +x face, whose two
 * rows of 128-res visibility texels meet near the sun's centre. Edges: none, then across the sun
 * at three heights (d.y / d.x = 0.352, 0.358, 0.3635: the sun 84%, 52%, 20% open). With the rays
 * the radiance must be within 1% of the open sun's of the truth (measured 0.02-0.22%: 64 rays, each
 * 1/64 of the texel's light, on a 128^2 grid of it); the box filter must miss somewhere by 10% (it
 * reads the edge per visibility row: measured -34%, -1.4%, +30%), else this case would not tell
 * them apart. */
static void weighted_texels(void) {
    prt_error err;
    const float tiny[3] = { 1e-7f, 1e-7f, 1e-7f };
    float sun[3] = { 1, 0.358f, -0.0156f };
    const float sl = sqrtf(sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]);
    for (int k = 0; k < 3; k++) sun[k] /= sl;
    sky_desc sd = { .width = 1024, .sun_dir = { sun[0], sun[1], sun[2] }, .sun_radius_deg = 0.5f, .sun_radiance = 1e4f };
    memcpy(sd.sky_zenith, tiny, sizeof tiny); memcpy(sd.sky_horizon, tiny, sizeof tiny); memcpy(sd.ground, tiny, sizeof tiny);
    prt_probe p;
    CHECK(probe_make_sky(&sd, &p, &err) == 0, "%s", err.msg);
    prior_rays *rays = calloc(1, sizeof *rays);
    const prt_probe *pp = &p;
    CHECK(prior_rays_from_probes(&pp, 1, rays, &err) == 0, "%s", err.msg);
    CHECK(rays->n >= 1 && rays->texel[0] == 20 * CUBE_RES + 32, "the sun's texel first: %d texels, texel %d", rays->n,
          rays->texel[0]);
    char path[600];   /* the probe as the light prior names it: a float EXR */
    snprintf(path, sizeof path, "%s/sun.exr", check_tmpdir());
    write_probe(&p, path);
    const double edges[4] = { 0, 1 / 0.352, 1 / 0.358, 1 / 0.3635 }, open = sun_truth(&p, sun, 0.8f, 0, 0);
    double box_worst = 0;
    for (int q = 0; q < 4; q++) {
        double eps, w = sun_prt(&p, 0.8f, edges[q], path, &eps), b = sun_prt(&p, 0.8f, edges[q], NULL, &eps);
        double t = sun_truth(&p, sun, 0.8f, edges[q], eps);
        printf("  edge %d: truth %.5f (%.0f%% of the open sun), light-weighted %.5f (%+.2f%% of it), box %.5f (%+.2f%%)\n", q, t,
               100 * t / open, w, 100 * (w - t) / open, b, 100 * (b - t) / open);
        CHECK_NEAR(w, t, 0.01 * open, "edge %d: light-weighted texels", q);
        box_worst = fmax(box_worst, fabs(b - t) / open);
    }
    CHECK(box_worst >= 0.10, "the box filter misses by %.1f%% at worst: the case tells them apart", 100 * box_worst);
    free(rays);
    probe_free(&p);
}

/* ---- (5) scale ---- */

/* The scale case's scene at scale s: a Phong sphere (SVD path, view maps) over scene_add_floor's
 * floor, uncompressed (N = all, float) with one forced bounce at gather res 16, relit under a
 * constant light; rgb[3 nverts] gets every vertex's radiance toward the eye s (1.5, 1.2, -2).
 * Returns the vertex count (0 on failure). */
static int scale_radiance(float s, float **rgb) {
    prt_error err;
    prt_mesh sph = { 0 };
    const float c[3] = { 0, 0.55f, 0 }, I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 }, zero[3] = { 0, 0, 0 };
    CHECK(mesh_make_sphere(&sph, c, 0.5f, 6, 12, &err) == 0, "%s", err.msg);
    mesh_transform(&sph, I, s, zero);
    prt_scene sc;
    CHECK(scene_from_mesh(&sph, "phong:kd=0.5,0.4,0.3;ks=0.3;n=12", &sc, &err) == 0, "%s", err.msg);
    CHECK(scene_add_floor(&sc, 100, 0, NULL, &err) == 0, "scale %g: floor: %s", s, err.msg);
    precompute_desc d = { .no_open_sky = true, .N = CUBE_TEXELS, .qbits = 32, .vis_res = 64, .quiet = true, .nthreads = 2, .bounces = 1,
                          .force_bounces = 1, .gather_res = 16, .glossy = PRECOMPUTE_GLOSSY_SVD, .basis_options = PAPER_HAAR };
    prt_data out;
    int rc = precompute_run(&sc, &d, &out, &err), nv = 0;
    CHECK(rc == 0, "scale %g: %s", s, err.msg);
    if (rc) return 0;
    nv = out.scene.mesh.nverts;
    prt_probe pr;
    const float white[3] = { 1, 1, 1 };
    CHECK(probe_make_constant(white, &pr, &err) == 0, "%s", err.msg);
    light_stats ls;
    float (*L)[4] = make_light(&pr, 32, 0, &ls);
    relight_ctx *rl = relight_create(&out, 2, &err);
    CHECK(rl != NULL, "%s", err.msg);
    *rgb = calloc(3 * (size_t)nv, sizeof(float));
    if (rl) {
        relight_set_light(rl, (const float (*)[4])L);
        const float eye[3] = { 1.5f * s, 1.2f * s, -2.0f * s };
        relight_view(rl, eye, 0, *rgb);
    }
    relight_destroy(rl);
    free(L);
    probe_free(&pr);
    prt_data_free(&out);
    return nv;
}

static void scale(void) {
    float *ref = NULL;
    int n1 = scale_radiance(1, &ref);
    CHECK(n1 > 100, "scale 1: %d vertices", n1);
    double mean = 0;
    for (int i = 0; i < 3 * n1; i++) mean += ref[i] / (3.0 * n1);
    CHECK(mean > 0.1 && mean < 1, "scale 1: mean radiance %g", mean);
    /* Decimal scales round every coordinate (relative 6e-8), so a ray passing within that of an
     * edge can go the other way. One flipped visibility ray moves a vertex by at most its texel's
     * share, kd/pi n.w dw <= 0.5/pi x 4 pi / (6 64^2) ~ 1.6e-4 at unit light; one flipped gathering
     * ray by its texel's share of the bounce, <= 0.5/pi x 4 pi / (6 16^2) x 1 ~ 2.6e-3; the glossy
     * lobe up to (n+2)/2 = 7 times these. Asserted: 2e-3 a vertex (a few flipped visibility rays or
     * one gathering ray on the diffuse part), and 1e-4 of the mean in RMS over the vertices. */
    const float scales[] = { 0x1p-100f, 0x1p-20f, 0x1p20f, 0x1p96f, 1e-6f, 1e6f };
    for (int q = 0; q < (int)(sizeof scales / sizeof scales[0]); q++) {
        float *got = NULL;
        int n = scale_radiance(scales[q], &got);
        CHECK(n == n1, "scale %g: %d vertices vs %d", scales[q], n, n1);
        if (n != n1 || !got) { free(got); continue; }
        int e;
        bool exact = frexpf(scales[q], &e) == 0.5f;
        double se = 0, worst = 0;
        for (int i = 0; i < 3 * n; i++) {
            double dd = (double)got[i] - ref[i];
            se += dd * dd;
            worst = fmax(worst, fabs(dd));
        }
        double rms = sqrt(se / (3.0 * n));
        printf("scale %g: RMS difference %.3g, worst %.3g (mean radiance %.4f)\n", scales[q], rms, worst, mean);
        if (exact) CHECK(memcmp(got, ref, sizeof(float) * 3 * (size_t)n) == 0, "scale 2^%d: radiance differs (worst %g)", e - 1, worst);
        else {
            CHECK(worst <= 2e-3, "scale %g: worst vertex differs by %g", scales[q], worst);
            CHECK(rms <= 1e-4 * mean, "scale %g: RMS difference %g", scales[q], rms);
        }
        free(got);
    }
    free(ref);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(lambert_open);
    CHECK_CASE(lambert_half);
    CHECK_CASE(end_to_end_float);
    CHECK_CASE(end_to_end_8bit);
    CHECK_CASE(budget_auto);
    CHECK_CASE(scene_keys);
    CHECK_CASE(weighted_texels);
    CHECK_CASE(scale);
    return check_summary();
}
