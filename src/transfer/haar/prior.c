/* prior.c - the light prior of the expected-error selection (prior.h): the RMS light vector
 * over a probe's yaw orbit, normalised, with a floor. The light vector is the one the runtime
 * builds (Haar's project_light with the solid-angle measure, haar_light_vector), so the weights are
 * in the index space and measure of the transport they select. */
#include "prior.h"
#include "cubemap.h"
#include "haar.h"
#include "haar_run.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Adds l_j (prior.h: the channels' sum of L_j w_j, w: haar_face_solid_angle's, the measure
 * project_light weighs with) of the cube's texels to tex[j] and its square to tex[CUBE_TEXELS + j]. */
static void texel_add(const float *cube, const float *w, double *tex) {
    const int F = CUBE_RES * CUBE_RES;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double l = ((double)cube[3 * j] + cube[3 * j + 1] + cube[3 * j + 2]) * w[j % F];
        l = isfinite(l) ? l : 0;
        tex[j] += l;
        tex[CUBE_TEXELS + j] += l * l;
    }
}

/* Adds the squared light vector of p turned by yaw (degrees, about +y) to acc[CUBE_TEXELS * 3].
 * cube: [CUBE_TEXELS][3] scratch; L: a light vector; tex: NULL, or texel_add's sums (w its weights). */
static void prior_add(const prt_probe *p, double yaw, float *cube, float (*L)[4],
                      double *acc, const float *w, double *tex) {
    float R[9];
    probe_rotation(yaw, 0, R);
    probe_to_cube(p, CUBE_RES, R, 0, cube);
    if (tex) texel_add(cube, w, tex);
    haar_light_vector(cube, true, L);
    for (int i = 0; i < CUBE_TEXELS; i++)
        for (int ch = 0; ch < 3; ch++) acc[3 * i + ch] += (double)L[i][ch] * L[i][ch];
}

/* The largest of the 3 x CUBE_TEXELS mean squares a, or 0 when none is positive and finite: no light. */
static double prior_largest(const double *a) {
    double mx = 0;
    for (int i = 0; i < 3 * CUBE_TEXELS; i++)
        if (a[i] > mx) mx = a[i];
    return mx > 0 && isfinite(mx) ? mx : 0;
}

/* acc (mean squares, the probes' sum, each over its own largest: prior_orbit, so the largest is at
 * least 1) -> w: square roots over the largest, plus floor x the channel's RMS weight. */
static void prior_finish(const double *acc, float floor, float (*w)[4]) {
    double mx = prior_largest(acc), ms[3] = { 0 };
    for (int i = 0; i < CUBE_TEXELS; i++)
        for (int ch = 0; ch < 3; ch++) ms[ch] += acc[3 * i + ch] / mx / CUBE_TEXELS;
    for (int i = 0; i < CUBE_TEXELS; i++) {
        for (int ch = 0; ch < 3; ch++) w[i][ch] = (float)(sqrt(acc[3 * i + ch] / mx) + floor * sqrt(ms[ch]));
        w[i][3] = 0;
    }
}

/* Adds probe p's mean squared light vector over its yaw orbit, over its own largest, to acc:
 * each probe of a prior counts the same, whatever its brightness; with tex, its texel sums as well
 * (texel_add). Returns 0, or -1 with err. */
static int prior_orbit(const prt_probe *p, int steps, const prior_desc *desc,
                       double frac0, double frac1, double *acc, double *tex, prt_error *err) {
    float w[CUBE_RES * CUBE_RES];
    haar_face_solid_angle(w, CUBE_RES, false);
    double *one = prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *one, err);
    float *cube = one ? prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *cube, err) : NULL;
    float (*L)[4] = cube ? transfer_light_alloc() : NULL;
    if (cube && !L) prt_fail(err, "light prior: out of memory");
    int rc = L ? 0 : -1;
    for (int k = 0; k < steps && rc == 0; k++) {
        prior_add(p, 360.0 * k / steps, cube, L, one, w, tex);
        double f = frac0 + (frac1 - frac0) * (k + 1.0) / steps;
        if (desc && desc->progress && !desc->progress(desc->progress_user, "light prior", f))
            rc = prt_fail(err, "cancelled");
    }
    double mx = rc == 0 ? prior_largest(one) : 0;
    if (rc == 0 && mx == 0) rc = prt_fail(err, "light prior: the probe has no light (every coefficient is zero)");
    for (int i = 0; rc == 0 && i < 3 * CUBE_TEXELS; i++) acc[i] += one[i] / mx;
    free(one);
    free(cube);
    free(L);
    return rc;
}

/* Probe pi's texel sums tex (texel_add's, over `steps` yaws) into out->mean[pi] and var (prior.h: each
 * over the probe's largest mean square). Returns 0, or -1 with err when it has no light. */
static int texel_probe(const double *tex, int steps, int pi, int n, double *var, prior_texels *out, prt_error *err) {
    double mx = 0;
    for (int j = 0; j < CUBE_TEXELS; j++) mx = tex[CUBE_TEXELS + j] / steps > mx ? tex[CUBE_TEXELS + j] / steps : mx;
    if (!(mx > 0) || !isfinite(mx)) return prt_fail(err, "light prior: the probe has no light (every texel is zero)");
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double m = tex[j] / steps, v = tex[CUBE_TEXELS + j] / steps - m * m;
        out->mean[pi][j] = (float)(m / sqrt(mx * n));
        var[j] += (v > 0 ? v : 0) / mx / n;
    }
    return 0;
}

/* var (the probes' average variance per texel) plus its floor into out->var. */
static void texel_finish(const double *var, int n, prior_texels *out) {
    double mean = 0;
    for (int j = 0; j < CUBE_TEXELS; j++) mean += var[j] / CUBE_TEXELS;
    for (int j = 0; j < CUBE_TEXELS; j++) out->var[j] = (float)(var[j] + PRIOR_TEXEL_FLOOR * mean);
    out->n = n;
}

/* See prior.h. */
int prior_build(const prt_probe *const *ps, int n, const prior_desc *desc, float (*w)[4], prior_texels *texels,
                prt_error *err) {
    int steps = desc && desc->steps > 0 ? desc->steps : PRIOR_STEPS;
    float floor = !desc || desc->floor == 0 ? PRIOR_FLOOR : desc->floor < 0 ? 0 : desc->floor;
    if (texels) memset(texels, 0, sizeof *texels);
    if (n < 1 || n > PRIOR_MAX_PROBES) return prt_fail(err, "light prior: %d probes (1..%d)", n, PRIOR_MAX_PROBES);
    double *acc = prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *acc, err);
    double *tex = acc && texels ? prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *tex, err) : NULL;
    int rc = acc && (tex || !texels) ? 0 : -1;
    for (int j = 0; j < n && rc == 0; j++) {
        if (tex) memset(tex, 0, 2 * sizeof(double) * CUBE_TEXELS);
        rc = prior_orbit(ps[j], steps, desc, (double)j / n, (j + 1.0) / n, acc, tex, err);
        if (rc == 0 && tex) rc = texel_probe(tex, steps, j, n, tex + 2 * CUBE_TEXELS, texels, err);
    }
    if (rc == 0) prior_finish(acc, floor, w);
    if (rc == 0 && tex) texel_finish(tex + 2 * CUBE_TEXELS, n, texels);
    if (rc && texels) memset(texels, 0, sizeof *texels);
    free(acc);
    free(tex);
    return rc;
}

/* See prior.h. */
int prior_from_probes(const prt_probe *const *ps, int n, const prior_desc *desc, float (*w)[4], prt_error *err) {
    return prior_build(ps, n, desc, w, NULL, err);
}

/* See prior.h. */
int prior_from_probe(const prt_probe *p, const prior_desc *desc, float (*w)[4], prt_error *err) {
    return prior_from_probes(&p, 1, desc, w, err);
}

/* Adds probe p's share of its light per lighting texel (L Omega over its sum) to share[CUBE_TEXELS].
 * cube: [CUBE_TEXELS][3] scratch; fa: one face's texel solid angles. Returns the sum (0: no light). */
static double prior_ray_shares(const prt_probe *p, float *cube, const float *fa, double *share) {
    const int F = CUBE_RES * CUBE_RES;
    probe_to_cube(p, CUBE_RES, NULL, 0, cube);
    double tot = 0;
    for (int i = 0; i < CUBE_TEXELS; i++) tot += prt_luminance(cube + 3 * i) * fa[i % F];
    if (!(tot > 0) || !isfinite(tot)) return 0;
    for (int i = 0; i < CUBE_TEXELS; i++) share[i] += prt_luminance(cube + 3 * i) * fa[i % F] / tot;
    return tot;
}

/* Texel t's PRIOR_RAYS directions into out->dir[k]: the probes' light (each over its sum tot[j], 0:
 * skipped) on a PRIOR_RAY_GRID^2 grid of the texel, times each cell's exact solid angle (a texel of
 * the CUBE_RES x PRIOR_RAY_GRID cube), read at the stratified quantiles (m + 1/2) / PRIOR_RAYS.
 * cw: PRIOR_RAY_GRID^2 scratch. */
static void prior_ray_texel(const prt_probe *const *ps, int n, const double *tot, int t, double *cw, prior_rays *out,
                            int k) {
    const int F = CUBE_RES * CUBE_RES, G = PRIOR_RAY_GRID, f = t / F, i = t % F % CUBE_RES, j = t % F / CUBE_RES;
    double sum = 0;
    for (int c = 0; c < G * G; c++) {
        float d[3], rgb[3];
        cube_dir(CUBE_RES, f, i + (c % G + 0.5f) / G, j + (c / G + 0.5f) / G, d);
        double l = 0;
        for (int p = 0; p < n; p++) {
            if (tot[p] <= 0) continue;
            probe_eval(ps[p], d, rgb);
            l += prt_luminance(rgb) / tot[p];
        }
        cw[c] = l * cube_texel_solid_angle(CUBE_RES * G, i * G + c % G, j * G + c / G);
        sum += cw[c];
    }
    out->texel[k] = t;
    out->omega[k] = (float)cube_texel_solid_angle(CUBE_RES, i, j);
    double run = 0;
    int c = 0;
    for (int m = 0; m < PRIOR_RAYS; m++) {
        double u = (m + 0.5) / PRIOR_RAYS * sum;   /* sum > 0: the texel was chosen for its light */
        while (c < G * G - 1 && run + cw[c] < u) run += cw[c++];
        cube_dir(CUBE_RES, f, i + (c % G + 0.5f) / G, j + (c / G + 0.5f) / G, out->dir[k][m]);
    }
}

/* See prior.h. */
int prior_rays_from_probes(const prt_probe *const *ps, int n, prior_rays *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (n < 1) return prt_fail(err, "light prior: no probe");
    double *share = prt_calloc((size_t)CUBE_TEXELS, sizeof *share, err);
    double *tot = share ? prt_calloc((size_t)n, sizeof *tot, err) : NULL;
    double *cw = tot ? prt_calloc((size_t)PRIOR_RAY_GRID * PRIOR_RAY_GRID, sizeof *cw, err) : NULL;
    float *cube = cw ? prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *cube, err) : NULL;
    float *fa = cube ? prt_calloc((size_t)CUBE_RES * CUBE_RES, sizeof *fa, err) : NULL;
    if (!fa) { free(share); free(tot); free(cw); free(cube); return -1; }
    cube_face_solid_angles(CUBE_RES, fa);
    for (int p = 0; p < n; p++) tot[p] = prior_ray_shares(ps[p], cube, fa, share);
    while (out->n < PRIOR_RAY_TEXELS) {   /* the brightest left, while it holds its share */
        int best = 0;
        for (int t = 1; t < CUBE_TEXELS; t++)
            if (share[t] > share[best]) best = t;
        if (!(share[best] >= PRIOR_RAY_SHARE)) break;
        share[best] = -1;
        prior_ray_texel(ps, n, tot, best, cw, out, out->n);
        out->n++;
    }
    free(share); free(tot); free(cw); free(cube); free(fa);
    return 0;
}
