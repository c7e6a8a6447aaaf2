/* build.h - what the sparse set's build-time files share (internal to src/transfer/sparse/).
 *
 * transport.c owns the set's staging (transport_free_staging frees it and the policy's tables),
 * store.c stages vectors, budget.c makes a shared budget's choice at finish (transport_budget_finish)
 * and ranks a vector's guaranteed candidates when it is staged (transport_keep_minimum), pack.c packs
 * the staged vectors into the set's final arrays. */
#ifndef PRT_SPARSE_BUILD_H
#define PRT_SPARSE_BUILD_H
#include "transport.h"

/* Coefficients of one face of the cube (CUBE_RES^2): the policy corrections' unit (TRANSPORT_BLK). */
enum { TRANSPORT_FACE = CUBE_RES * CUBE_RES };

/* Frees the staging arrays (an unmap when streamed) and the policy's tables. */
void transport_free_staging(prt_transport *t);
/* Shared budget: gives vector i's budget_min best of its n staged candidates the largest finite weight,
 * so the threshold keeps them. order: scratch of n 64-bit words. */
void transport_keep_minimum(prt_transport *t, int i, int n, uint64_t *order);
/* The shared budget's choice: at most budget x nvecs candidates in all, the largest weights, each vector's
 * corrected and quantized in its staging. Returns 0 or -1 (OOM). */
int transport_budget_finish(prt_transport *t, prt_error *err);
#endif
