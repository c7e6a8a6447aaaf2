/* transport_fixture.h - one texel vector stored as a one-vector transport set, as precompute stores
 * it, for the tests that measure a stored vector's T.L against the exact sum over texels
 * (test_transport.c, test_prior.c, test_refit.c). Header only, static functions; no /work/shared. */
#ifndef TRANSPORT_FIXTURE_H
#define TRANSPORT_FIXTURE_H
#include "harness.h"
#include "transfer.h"
#include "transport.h"
#include "policy.h"
#include <stdlib.h>
#include <string.h>

/* tex (Eq. 3's texels, CUBE_TEXELS; the same in the three channels) projected by Haar with cfg (N, qbits,
 * measure; configured here) and stored into *t, a set of one vector, finished. With like, its choices
 * are copied before the store (transport_init_like's: solid_angle, select, prior, block_level,
 * smooth_faces, refit: precompute's settings); without, the set's defaults. Either way the set has
 * Haar's policy (policy.h), as precompute gives Haar's sets. t is the caller's
 * (transport_free). */
static __attribute__((unused)) void tfx_store(const float *tex, transfer_config cfg, const prt_transport *like,
                                              prt_transport *t) {
    static float coef[3][CUBE_TEXELS], scr[TRANSFER_SCRATCH_FLOATS];
    prt_error err;
    CHECK(transfer_haar.configure(&cfg, &err) == 0, "%s", err.msg);
    transfer_haar.project_transport(&cfg, tex, coef[0], scr);
    memcpy(coef[1], coef[0], sizeof coef[0]);
    memcpy(coef[2], coef[0], sizeof coef[0]);
    int one = 1;
    prt_transport l = like ? *like : (prt_transport){ 0 };   /* transport_init_like copies the choices */
    l.nverts = 1;
    l.N = cfg.N;
    l.qbits = cfg.qbits;
    l.budget = 0;
    l.policy = &haar_transport_policy;   /* Haar's sets carry Haar's policy (precompute.c) */
    CHECK(transport_init_like(t, &l, &one, &err) == 0, "%s", err.msg);
    void *tscr = malloc(transport_scratch_size());
    transport_store(t, 0, coef[0], coef[1], coef[2], tscr);
    free(tscr);
    CHECK(transport_finish(t, &err) == 0, "%s", err.msg);
}
#endif
