/* test_refit.c - the kept coefficients refit to a light prior (refit.h), against independent truths:
 * with a uniform light model the refit is the orthogonal projection (the coefficients themselves,
 * Parseval); with any model its values solve the normal equations built by brute force from the
 * texel values of the Haar functions; its rounding never raises the expected error over rounding to
 * the nearest; and an open floor under a turning sun keeps its T.L within 0.5% of the exact sum over
 * texels at every one-degree step (the shimmer of tools/shimmer.sh), where plain truncation does not. */
#include "harness.h"
#include "cubemap.h"
#include "haar.h"
#include "light.h"
#include "prior.h"
#include "probe.h"
#include "refit.h"
#include "sparse.h"
#include "transfer.h"
#include "transport.h"
#include "transport_fixture.h"
#include <lapacke.h>
#include <stdlib.h>
#include <string.h>

enum { T = CUBE_TEXELS, F = CUBE_RES * CUBE_RES };

/* A deterministic pseudo-random float in [-1, 1). */
static float rnd(unsigned *s) {
    *s = *s * 1664525u + 1013904223u;
    return (float)(*s >> 8) / (float)(1u << 23) - 1.f;
}

/* n kept wavelet indices on face f, increasing: every coarse index below 16 and then every step-th. */
static int kept_set(int f, int step, uint32_t *K) {
    int n = 0;
    for (int m = 0; m < F && n < REFIT_MAX_N; m += m < 16 ? 1 : step) K[n++] = (uint32_t)(f * F + m);
    return n;
}

/* Uniform variance and zero means: E[l_j l_k] = delta_jk, so the best values are the coefficients. */
static void identity(void) {
    static prior_texels pt;
    memset(&pt, 0, sizeof pt);
    pt.n = 1;
    for (int j = 0; j < T; j++) pt.var[j] = 2.5f;
    prt_error err;
    refit_tables *rt = refit_create(&pt, &err);
    CHECK(rt != NULL, "%s", err.msg);
    static float c[3][T];
    unsigned s = 7;
    for (int ch = 0; ch < 3; ch++)
        for (int j = 0; j < T; j++) c[ch][j] = rnd(&s);
    uint32_t K[REFIT_MAX_N];
    int n = kept_set(3, 37, K);
    float out[3 * REFIT_MAX_N];
    void *scr = malloc(refit_scratch_size(n));
    CHECK(refit_face(rt, 3, c[0], c[1], c[2], K, n, out, scr), "refit");
    double worst = 0;
    for (int k = 0; k < n; k++)
        for (int ch = 0; ch < 3; ch++) worst = fmax(worst, fabs(out[3 * k + ch] - c[ch][K[k]]));
    printf("  %d kept: largest change %.2e\n", n, worst);
    CHECK_LE(worst, 1e-4, "the orthogonal projection keeps the coefficients");
    free(scr);
    refit_destroy(rt);
}

/* The texel values of Haar function m of a face into psi (F floats). */
static void psi_of(uint32_t m, float *psi) {
    static float unit[F], tmp[F];
    memset(unit, 0, sizeof unit);
    unit[m] = 1;
    haar_face_from_morton(unit, CUBE_RES, psi);
    haar_inverse(psi, CUBE_RES, tmp);
}

/* A random model (2 probes' means, positive variances) and a random vector: refit_face's values must
 * solve the normal equations of refit.h built from the Haar functions' texels (double sums, LAPACK). */
static void brute_force(void) {
    static prior_texels pt;
    memset(&pt, 0, sizeof pt);
    pt.n = 2;
    unsigned s = 11;
    for (int j = 0; j < T; j++) {
        pt.var[j] = 0.05f + fabsf(rnd(&s)) * (j % 97 == 0 ? 50.f : 1.f);   /* a few bright texels */
        pt.mean[0][j] = 0.5f + 0.3f * rnd(&s);
        pt.mean[1][j] = 0.2f * rnd(&s);
    }
    prt_error err;
    refit_tables *rt = refit_create(&pt, &err);
    CHECK(rt != NULL, "%s", err.msg);
    static float c[3][T], img[3][F], psi[REFIT_MAX_N][F], tmp[F];
    for (int ch = 0; ch < 3; ch++)
        for (int j = 0; j < T; j++) c[ch][j] = rnd(&s);
    const int f = 2;
    uint32_t K[REFIT_MAX_N];
    int n = kept_set(f, 53, K);
    for (int ch = 0; ch < 3; ch++) {
        haar_face_from_morton(c[ch] + f * F, CUBE_RES, img[ch]);
        haar_inverse(img[ch], CUBE_RES, tmp);
    }
    for (int k = 0; k < n; k++) psi_of(K[k] % F, psi[k]);
    double *G = calloc((size_t)n * n, sizeof *G), *B = calloc(3 * (size_t)n, sizeof *B);
    const float *v = pt.var + f * F;
    for (int k = 0; k < n; k++) {
        for (int l = 0; l < n; l++) {
            double g = 0, pk[2] = { 0 }, pl[2] = { 0 };
            for (int j = 0; j < F; j++) {
                g += (double)v[j] * psi[k][j] * psi[l][j];
                for (int p = 0; p < 2; p++) { pk[p] += (double)pt.mean[p][f * F + j] * psi[k][j]; pl[p] += (double)pt.mean[p][f * F + j] * psi[l][j]; }
            }
            G[k * n + l] = g + pk[0] * pl[0] + pk[1] * pl[1];
        }
        for (int ch = 0; ch < 3; ch++) {
            double b = 0, pk[2] = { 0 }, mt[2] = { 0 };
            for (int j = 0; j < F; j++) {
                b += (double)v[j] * psi[k][j] * img[ch][j];
                for (int p = 0; p < 2; p++) { pk[p] += (double)pt.mean[p][f * F + j] * psi[k][j]; mt[p] += (double)pt.mean[p][f * F + j] * img[ch][j]; }
            }
            B[3 * k + ch] = b + pk[0] * mt[0] + pk[1] * mt[1];
        }
    }
    CHECK(LAPACKE_dposv(LAPACK_ROW_MAJOR, 'L', n, 3, G, n, B, 3) == 0, "brute force solve");
    float out[3 * REFIT_MAX_N];
    void *scr = malloc(refit_scratch_size(n));
    CHECK(refit_face(rt, f, c[0], c[1], c[2], K, n, out, scr), "refit");
    double worst = 0, big = 0;
    for (int k = 0; k < 3 * n; k++) { worst = fmax(worst, fabs(out[k] - B[k])); big = fmax(big, fabs(B[k])); }
    printf("  %d kept: largest difference %.2e of the largest value %.3f\n", n, worst, big);
    CHECK_LE(worst, 1e-4 * big, "the tables' normal equations are the brute-force ones");
    float bad[3 * REFIT_MAX_N];
    memcpy(bad, out, sizeof bad);
    c[1][f * F + 5] = NAN;
    /* exact: a declined face leaves out as it was (a copy of the last result) */
    CHECK(!refit_face(rt, f, c[0], c[1], c[2], K, n, bad, scr) && memcmp(bad, out, sizeof bad) == 0,
          "a non-finite channel is declined, out untouched");
    pt.var[4] = -1;
    CHECK(refit_create(&pt, &err) == NULL && strstr(err.msg, "texel 4"), "a negative variance is refused: %s", err.msg);
    free(G); free(B); free(scr);
    refit_destroy(rt);
}

/* (x - y)' G (x - y) for G rebuilt by brute force is what refit_quantize lowers; here it is compared
 * through refit_face's model directly: the quantized values' expected error (the quadratic form, from
 * a unit-step probe of refit_face's normal equations) must not exceed nearest rounding's. */
static double form(const double *G, int n, const float *a, const float *b, int ch) {
    double s = 0;
    for (int k = 0; k < n; k++)
        for (int l = 0; l < n; l++) s += ((double)a[3 * k + ch] - b[3 * k + ch]) * G[k * n + l] * ((double)a[3 * l + ch] - b[3 * l + ch]);
    return s;
}

static void quantize(void) {
    static prior_texels pt;
    memset(&pt, 0, sizeof pt);
    pt.n = 1;
    unsigned s = 5;
    for (int j = 0; j < T; j++) { pt.var[j] = 0.1f + fabsf(rnd(&s)); pt.mean[0][j] = 1.f + 0.1f * rnd(&s); }
    prt_error err;
    refit_tables *rt = refit_create(&pt, &err);
    CHECK(rt != NULL, "%s", err.msg);
    static float c[3][T], psi[REFIT_MAX_N][F];
    for (int ch = 0; ch < 3; ch++)
        for (int j = 0; j < T; j++) c[ch][j] = rnd(&s) * (j % F < 16 ? 40.f : 1.f);
    uint32_t K[REFIT_MAX_N];
    int n = kept_set(0, 61, K);
    float x[3 * REFIT_MAX_N], near[3 * REFIT_MAX_N], q[3 * REFIT_MAX_N];
    void *scr = malloc(refit_scratch_size(n));
    CHECK(refit_face(rt, 0, c[0], c[1], c[2], K, n, x, scr), "refit");
    float mx = 0, step[3];
    for (int k = 0; k < 3 * n; k++) mx = fmaxf(mx, fabsf(x[k]));
    for (int ch = 0; ch < 3; ch++) step[ch] = sparse_step(mx, 127) * (1 + 0.5f * ch);
    memcpy(q, x, sizeof q);
    refit_quantize(rt, 0, K, n, step, 127, q, scr);
    for (int k = 0; k < 3 * n; k++) near[k] = (float)sparse_quantize(x[k], step[k % 3], 127) * step[k % 3];
    for (int k = 0; k < n; k++) psi_of(K[k] % F, psi[k]);
    double *G = calloc((size_t)n * n, sizeof *G);
    for (int k = 0; k < n; k++)
        for (int l = 0; l < n; l++) {
            double g = 0, pk = 0, pl = 0;
            for (int j = 0; j < F; j++) { g += (double)pt.var[j] * psi[k][j] * psi[l][j]; pk += (double)pt.mean[0][j] * psi[k][j]; pl += (double)pt.mean[0][j] * psi[l][j]; }
            G[k * n + l] = g + pk * pl;
        }
    for (int ch = 0; ch < 3; ch++) {
        double eq = form(G, n, q, x, ch), en = form(G, n, near, x, ch);
        bool on_grid = true;
        for (int k = 0; k < n; k++) on_grid &= fabsf(q[3 * k + ch] / step[ch] - rintf(q[3 * k + ch] / step[ch])) < 1e-3f;
        printf("  channel %d: expected error %.4g rounded to the nearest, %.4g by refit_quantize\n", ch, en, eq);
        CHECK(on_grid, "values are multiples of the step (channel %d)", ch);
        CHECK_LE(eq, en, "never worse than the nearest (channel %d)", ch);
        CHECK_LE(eq, 0.8 * en, "and better on this vector (channel %d)", ch);
    }
    free(G); free(scr);
    refit_destroy(rt);
}

/* A sky with a 0.27-degree sun at 47 degrees of elevation (city's: on the cube's top face, where its
 * ring crosses blocks of every size) and radiance 20,000. */
static void sun_sky(prt_probe *p) {
    const float e = (float)(47 * M_PI / 180);
    sky_desc sd = { .width = 1024, .sun_dir = { cosf(e), sinf(e), 0 }, .sun_radius_deg = 0.27f, .sun_radiance = 20000 };
    prt_error err;
    CHECK(probe_make_sky(&sd, p, &err) == 0, "%s", err.msg);
}

/* The open floor vertex stored at N = 128, 8-bit, with the prior w (and the refit's tables rt, or NULL:
 * the corrections); returns the worst |T.L / exact - 1| over 91 one-degree yaw steps (exact: the sum over
 * texels of T_j L_j). */
static double open_floor_worst(const prt_probe *p, const float (*w)[4], const refit_tables *rt) {
    static float tex[T], cube[3 * T], dw[F];
    cube_face_solid_angles(CUBE_RES, dw);
    for (int i = 0; i < T; i++) {
        float d[3];
        cube_texel_dir(CUBE_RES, i, d);
        tex[i] = d[1] > 0 ? d[1] * dw[i % F] : 0.f;
    }
    transfer_config cfg;
    tfx_haar(128, 8, true, &cfg);
    const prt_transport like = { .solid_angle = true, .select = TRANSPORT_SELECT_EXPECTED, .prior = w,
                                 .block_level = TRANSPORT_BLOCK_LEVEL, .smooth_faces = true, .refit = rt };
    prt_transport t;
    tfx_store(tex, cfg, &like, &t);
    float (*L)[4] = transfer_light_alloc();
    double worst = 0;
    for (int k = 0; k <= 90; k++) {
        float R[9];
        probe_rotation(k, 0, R);
        probe_to_cube(p, CUBE_RES, R, 0, cube);
        tfx_light(&cfg, cube, L);
        double exact = 0;
        for (int i = 0; i < T; i++) exact += (double)tex[i] * cube[3 * i];
        float g[3];
        transport_light(&t, (const float (*)[4])L, g, 1);
        worst = fmax(worst, fabs(g[0] / exact - 1));
    }
    free(L);
    transport_free(&t);
    return worst;
}

/* Issue 10's shimmer on an open floor: with the refit every one-degree step is within 0.5% of the exact
 * product (printed beside the corrections' worst). */
static void open_floor(void) {
    prt_probe p;
    sun_sky(&p);
    float (*w)[4] = transfer_light_alloc();
    static prior_texels pt;
    prt_error err;
    const prt_probe *pp = &p;
    CHECK(prior_build(&pp, 1, NULL, w, &pt, &err) == 0, "%s", err.msg);   /* 360 steps: the ring without gaps */
    refit_tables *rt = refit_create(&pt, &err);
    CHECK(rt != NULL, "%s", err.msg);
    double e0 = open_floor_worst(&p, (const float (*)[4])w, NULL), e1 = open_floor_worst(&p, (const float (*)[4])w, rt);
    printf("  worst |T.L / exact - 1| over 91 one-degree steps: %.3f%% with the corrections, %.3f%% refit\n", 100 * e0, 100 * e1);
    CHECK_LE(e1, 0.005, "within 0.5%% at every step");
    refit_destroy(rt);
    free(w);
    probe_free(&p);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(identity);
    CHECK_CASE(brute_force);
    CHECK_CASE(quantize);
    CHECK_CASE(open_floor);
    return check_summary();
}
