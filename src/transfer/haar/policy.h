/* policy.h - Haar's policy for the sparse store (transport.h's transport_policy): which of a vector's
 * Haar coefficients to keep and what values they get, as `prt precompute` stores Haar transfers.
 *
 * Usage (after transport_init, with the set's parameters set):
 *     t.solid_angle = true; t.select = TRANSPORT_SELECT_EXPECTED; t.block_level = TRANSPORT_BLOCK_LEVEL; ...
 *     if (transport_set_policy(&t, &haar_transport_policy, &err)) ...   // makes its tables
 *     transport_store(&t, i, r, g, b, scratch);                       // per vector, any thread
 *
 * What it does with the set's parameters (transport.h; Wang et al. 2006 section 4.1 is the plain path
 * it extends): select EXPECTED keeps the N largest |c_i| sigma_i (select.h), sigma from the level
 * spectrum or the set's prior; with solid_angle what truncation drops is put back into the kept coarse
 * coefficients per block of block_level, or on a smooth face weighted by the transport (smooth_faces;
 * corrections.h); with refit (a per-vector budget) each face's kept values are refit to the prior's
 * light and rounded by its quadratic form (refit.h) instead. With every parameter 0 it stores what the
 * plain path stores. Its tables (the solid angle per texel, its Haar coefficients and block sums) are
 * made once per set; its hooks are pure functions of their arguments and the tables. */
#ifndef PRT_HAAR_POLICY_H
#define PRT_HAAR_POLICY_H
#include "transport.h"

extern const transport_policy haar_transport_policy;
#endif
