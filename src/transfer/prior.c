/* prior.c - the light prior of the expected-error selection (prior.h): the RMS light vector
 * over a probe's yaw orbit, normalised, with a floor. The light vector is the one the runtime
 * builds (transfer_haar's project_light with the solid-angle measure), so the weights are in
 * the index space and measure of the transport they select. */
#include "prior.h"
#include "cubemap.h"
#include "light.h"
#include "transfer.h"
#include <math.h>
#include <stdlib.h>

/* Adds the squared light vector of p turned by yaw (degrees, about +y) to acc[CUBE_TEXELS * 3].
 * cube: [CUBE_TEXELS][3] scratch; L: a light vector. */
static void prior_add(const prt_probe *p, const transfer_config *cfg, double yaw, float *cube, float (*L)[4],
                      double *acc) {
    float R[9];
    probe_rotation(yaw, 0, R);
    probe_to_cube(p, CUBE_RES, R, 0, cube);
    transfer_haar.project_light(cfg, cube, L);
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
 * each probe of a prior counts the same, whatever its brightness. Returns 0, or -1 with err. */
static int prior_orbit(const prt_probe *p, const transfer_config *cfg, int steps, const prior_desc *desc,
                       double frac0, double frac1, double *acc, prt_error *err) {
    double *one = prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *one, err);
    float *cube = one ? prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *cube, err) : NULL;
    float (*L)[4] = cube ? light_alloc() : NULL;
    if (cube && !L) prt_fail(err, "light prior: out of memory");
    int rc = L ? 0 : -1;
    for (int k = 0; k < steps && rc == 0; k++) {
        prior_add(p, cfg, 360.0 * k / steps, cube, L, one);
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

/* See prior.h. */
int prior_from_probes(const prt_probe *const *ps, int n, const prior_desc *desc, float (*w)[4], prt_error *err) {
    int steps = desc && desc->steps > 0 ? desc->steps : PRIOR_STEPS;
    float floor = !desc || desc->floor == 0 ? PRIOR_FLOOR : desc->floor < 0 ? 0 : desc->floor;
    if (n < 1) return prt_fail(err, "light prior: no probe");
    transfer_config cfg = { .measure = TRANSFER_MEASURE_SOLID_ANGLE };
    if (transfer_haar.configure(&cfg, err)) return -1;
    double *acc = prt_calloc(3 * (size_t)CUBE_TEXELS, sizeof *acc, err);
    int rc = acc ? 0 : -1;
    for (int j = 0; j < n && rc == 0; j++) rc = prior_orbit(ps[j], &cfg, steps, desc, (double)j / n, (j + 1.0) / n, acc, err);
    if (rc == 0) prior_finish(acc, floor, w);
    free(acc);
    return rc;
}

/* See prior.h. */
int prior_from_probe(const prt_probe *p, const prior_desc *desc, float (*w)[4], prt_error *err) {
    return prior_from_probes(&p, 1, desc, w, err);
}
