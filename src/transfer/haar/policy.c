/* policy.c - Haar's policy for the sparse store (policy.h): the hooks transport_store and
 * transport_finish call, tying the expected-error selection (select.c), the corrections
 * (corrections.c) and the refit to a light prior (refit.c) to the set's parameters.
 *
 * Per vector, one thread: select computes the faces' shapes (which faces are smooth, and their
 * transport, when the prior's selection or the smooth correction reads them) into the policy's scratch
 * and selects; correct then reads them (refit faces first, the corrections for the rest); quantize
 * rounds the refit faces. The scratch (TRANSPORT_POLICY_SCRATCH bytes) is laid out by scratch_of. */
#include "policy.h"
#include "corrections.h"
#include "refit.h"
#include "select.h"
#include <stdlib.h>
#include <string.h>

enum { FACE = CUBE_RES * CUBE_RES };

/* The policy's scratch: a 64-byte head (the faces' shape select found), W (2 x FACE floats: a face's
 * transform scratch), wc (3 x CUBE_TEXELS: the weighted copy, then the corrections' scratch), Hc
 * (CUBE_TEXELS: haar_face_shapes' H) and the refit's (refit_scratch_size(REFIT_MAX_N) bytes). */
typedef struct haar_scratch {
    unsigned *shape;
    float *W, *wc, *Hc;
    void *refit;
} haar_scratch;

static haar_scratch scratch_of(void *scratch) {
    haar_scratch sc = { .shape = scratch };
    sc.W = (float *)(void *)((char *)scratch + 64);
    sc.wc = sc.W + 2 * FACE;
    sc.Hc = sc.wc + 3 * CUBE_TEXELS;
    sc.refit = sc.Hc + CUBE_TEXELS;
    return sc;
}

/* The tables (corrections.h), once the scratch is known to hold the layout above. */
static void *haar_create(const prt_transport *t, prt_error *err) {
    (void)t;
    size_t need = 64 + (2 * FACE + 3 * CUBE_TEXELS + CUBE_TEXELS) * sizeof(float) + refit_scratch_size(REFIT_MAX_N);
    PRT_CHECK(need <= TRANSPORT_POLICY_SCRATCH);
    return haar_tables_create(err);
}

static void haar_destroy(void *state) { free(state); }

/* Whether the kept values are refit (refit.h) rather than corrected: the refit's tables with the
 * solid-angle measure and a per-vector budget. */
static bool refits(const prt_transport *t) { return t->refit && t->solid_angle && !t->budget; }

/* The faces' shapes into the head (haar_face_shapes, when the prior's selection or the smooth correction
 * reads them; a refit face needs no correction), then the selection: expected error or magnitude. */
static int haar_select(const prt_transport *t, const float *const ch[3], uint32_t *idx, float *keys, void *scratch) {
    const haar_tables *tb = t->policy_state;
    haar_scratch sc = scratch_of(scratch);
    bool want_H = t->solid_angle && t->smooth_faces && !refits(t);
    *sc.shape = t->prior || want_H ? haar_face_shapes(ch, tb->w, want_H, sc.W, sc.Hc) : 0;
    return t->select == TRANSPORT_SELECT_EXPECTED ? haar_select_expected(ch[0], ch[1], ch[2], t, tb->sigma, *sc.shape, idx, keys, sc.wc)
                                                  : sparse_select(ch[0], ch[1], ch[2], CUBE_TEXELS, t->N, idx, keys);
}

/* Each face's kept values val[3 k + c] (the n kept idx, increasing) refit to the prior's light (refit.h),
 * face by face; a face refit_face declines keeps what it had. Returns the faces refit (bit f). */
static unsigned refit_vector(const refit_tables *rt, const float *const ch[3], const uint32_t *idx, int n, float *val,
                             void *scratch) {
    float out[3 * REFIT_MAX_N];
    unsigned done = 0;
    for (int k0 = 0, k1; k0 < n; k0 = k1) {
        uint32_t f = idx[k0] / FACE;
        for (k1 = k0; k1 < n && idx[k1] / FACE == f; k1++) {}
        if (!refit_face(rt, (int)f, ch[0], ch[1], ch[2], idx + k0, k1 - k0, out, scratch)) continue;
        memcpy(val + 3 * (size_t)k0, out, 3 * (size_t)(k1 - k0) * sizeof *out);
        done |= 1u << f;
    }
    return done;
}

/* The refit faces' values (refit_vector), then the other faces' corrections into adj (haar_block_corrections;
 * zeros when every kept face is refit). With a refit, select left the smooth faces' transport out, so it
 * is made here for the faces the refit declined. */
static unsigned haar_correct(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, float *val,
                             float *adj, void *scratch) {
    const haar_tables *tb = t->policy_state;
    haar_scratch sc = scratch_of(scratch);
    unsigned refit = refits(t) ? refit_vector(t->refit, ch, idx, n, val, sc.refit) : 0, faces = 0;
    for (int k = 0; k < n; k++) faces |= 1u << (idx[k] / FACE);
    memset(adj, 0, TRANSPORT_BLK * sizeof *adj);
    if (!(faces & ~refit)) return refit;
    unsigned shape = *sc.shape;
    if (refits(t) && t->smooth_faces) shape = haar_face_shapes(ch, tb->w, true, sc.W, sc.Hc);
    haar_block_corrections(t, ch, idx, n, shape, sc.Hc, sc.wc, adj);   /* wc is free once selected */
    return refit;
}

/* A refit face's values rounded by the refit's quadratic form (refit_quantize). */
static void haar_quantize(const prt_transport *t, int f, const uint32_t *idx, int n, const float step[3], int qmax,
                          float *val, void *scratch) {
    refit_quantize(t->refit, f, idx, n, step, qmax, val, scratch_of(scratch).refit);
}

/* With the solid-angle measure, what the non-candidates drop (haar_block_stage). */
static void haar_stage(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, void *scratch,
                       float *blk) {
    if (!t->solid_angle) return;
    haar_scratch sc = scratch_of(scratch);
    haar_block_stage(t, ch, idx, n, *sc.shape, sc.Hc, sc.wc, blk);
}

const transport_policy haar_transport_policy = {
    .create = haar_create,
    .destroy = haar_destroy,
    .select = haar_select,
    .correct = haar_correct,
    .quantize = haar_quantize,
    .stage = haar_stage,
    .budget_correct = haar_budget_corrections,
};
