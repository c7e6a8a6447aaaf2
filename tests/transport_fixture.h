/* transport_fixture.h - one texel vector stored as a one-vector transport set, as precompute stores
 * it, for the tests that measure a stored vector's T.L against the exact sum over texels
 * (test_transport.c, test_prior.c, test_refit.c), and the table's Haar configured for the tests that
 * build a prt_data by hand. Header only, static functions; no /work/shared. */
#ifndef TRANSPORT_FIXTURE_H
#define TRANSPORT_FIXTURE_H
#include "harness.h"
#include "linear.h"
#include "transfer.h"
#include "transport.h"
#include "policy.h"
#include <stdlib.h>
#include <string.h>

/* The table's Haar configured with N, qbits and the measure (solid angle, Haar's default, or the
 * texels) into *cfg; its ops. */
static __attribute__((unused)) const transfer_ops *tfx_haar(int N, int qbits, bool solid_angle, transfer_config *cfg) {
    const transfer_ops *h = transfer_find("haar");
    transfer_setup s = { .options = solid_angle ? NULL : "measure=texels", .N = N, .qbits = qbits };
    prt_error err;
    CHECK(h && h->configure(&s, cfg, &err) == 0, "%s", err.msg);
    return h;
}

/* The table's Haar of the texels (the paper's measure) with N and qbits: its configuration (the tests
 * that build a prt_data by hand). */
static __attribute__((unused)) transfer_config tfx_haar_cfg(int N, int qbits) {
    transfer_config c;
    tfx_haar(N, qbits, false, &c);
    return c;
}

/* Haar's light vector of the cube (cube_rgb [CUBE_TEXELS][3]) under cfg (tfx_haar's): its project_light. */
static __attribute__((unused)) void tfx_light(const transfer_config *cfg, const float *cube, float (*L)[4]) {
    transfer_find("haar")->linear->project_light(cfg, cube, L);
}

/* Haar's projection of one channel's texels under cfg (tfx_haar's): its project_transport. */
static __attribute__((unused)) void tfx_project(const transfer_config *cfg, const float *tex, float *coef, float *scratch) {
    transfer_find("haar")->linear->project_transport(cfg, tex, coef, scratch);
}

/* tex (Eq. 3's texels, CUBE_TEXELS; the same in the three channels) projected by Haar with cfg
 * (tfx_haar's: N, qbits, measure) and stored into *t, a set of one vector, finished. With like, its
 * choices are copied before the store (transport_init_like's: solid_angle, select, prior, block_level,
 * smooth_faces, refit: precompute's settings); without, the set's defaults. Either way the set has
 * Haar's policy (policy.h), as Haar's init_set gives its sets. t is the caller's
 * (transport_free). */
static __attribute__((unused)) void tfx_store(const float *tex, transfer_config cfg, const prt_transport *like,
                                              prt_transport *t) {
    static float coef[3][CUBE_TEXELS], scr[TRANSFER_SCRATCH_FLOATS];
    prt_error err;
    tfx_project(&cfg, tex, coef[0], scr);
    memcpy(coef[1], coef[0], sizeof coef[0]);
    memcpy(coef[2], coef[0], sizeof coef[0]);
    int one = 1;
    prt_transport l = like ? *like : (prt_transport){ 0 };   /* transport_init_like copies the choices */
    l.nverts = 1;
    l.N = linear_config_of(&cfg).N;
    l.qbits = linear_config_of(&cfg).qbits;
    l.budget = 0;
    l.policy = &haar_transport_policy;   /* Haar's sets carry Haar's policy (haar_run.c) */
    CHECK(transport_init_like(t, &l, &one, &err) == 0, "%s", err.msg);
    void *tscr = malloc(transport_scratch_size());
    transport_store(t, 0, coef[0], coef[1], coef[2], tscr);
    free(tscr);
    CHECK(transport_finish(t, &err) == 0, "%s", err.msg);
}
#endif
