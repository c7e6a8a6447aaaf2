/* store.c - transport_store: one vector's selection, values and quantization into its staging.
 *
 * Contract (transport.h): transport_store writes only vector i's own staging slots, so threads may
 * store distinct vectors at once, each with its own scratch (transport_scratch_size). Per vector
 * budget: it keeps the n <= N coefficients the selection picks, gives them their values (the input's,
 * plus the policy's corrections of each face's 16 coarsest, or the policy's own fit of a face), rounds
 * each channel to its step max|x| / qmax (section 4.1.2) and returns the squared L2 error of what it
 * kept. Shared budget: it stages the N candidates unquantized with their weights for budget.c.
 *
 * Why a policy: section 4.1.1 keeps the largest energies r^2 + g^2 + b^2 (sparse_select), the L2-best
 * approximation in an orthonormal basis, which is what SH and Haar's texel measure use. Haar's
 * solid-angle measure also weighs the selection by the light it expects and corrects what truncation
 * drops (haar/policy.h); those are Haar's, reached through the set's transport_policy, so this file
 * names no basis. Without a policy the parameters that ask for one must be 0 (PRT_CHECK). */
#include "build.h"
#include <float.h>
#include <math.h>
#include <string.h>

static double sq(double x) { return x * x; }

/* Entry j of the weights sparse_select leaves in its scratch (float bits, read without aliasing). */
static float key_at(const float *keys, int j) {
    float e;
    memcpy(&e, keys + j, sizeof e);
    return e;
}

/* transport_store's scratch: the selection's keys (2 x CUBE_TEXELS floats) and idx (CUBE_TEXELS), then
 * the policy's TRANSPORT_POLICY_SCRATCH bytes. */
typedef struct store_scratch {
    float *keys;
    uint32_t *idx;
    void *policy;
} store_scratch;

static store_scratch scratch_of(void *scratch) {
    store_scratch sc = { .keys = scratch };
    sc.idx = (uint32_t *)(void *)((char *)scratch + 2 * CUBE_TEXELS * sizeof(float));
    sc.policy = sc.idx + CUBE_TEXELS;
    return sc;
}

/* Bytes of scratch transport_store needs (store_scratch's layout). */
size_t transport_scratch_size(void) {
    return 2 * CUBE_TEXELS * sizeof(float) + CUBE_TEXELS * sizeof(uint32_t) + TRANSPORT_POLICY_SCRATCH;
}

/* The selection of vector ch into sc->idx and sc->keys: the policy's, else the largest energies (a set
 * whose parameters ask for a policy has one). Returns how many. */
static int select_vector(const prt_transport *t, const float *const ch[3], const store_scratch *sc) {
    if (t->policy && t->policy->select) return t->policy->select(t, ch, sc->idx, sc->keys, sc->policy);
    PRT_CHECK(t->policy || (!t->solid_angle && t->select == TRANSPORT_SELECT_MAGNITUDE && !t->refit));
    return sparse_select(ch[0], ch[1], ch[2], CUBE_TEXELS, t->N, sc->idx, sc->keys);
}

/* Shared budget: stages vector i's t->N best candidates (by the selection weight, unquantized) with
 * their weights (RELATIVE: over the vector's total) for transport_finish. Returns the squared norm of
 * the coefficients outside them. */
static double store_candidates(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch) {
    const float *ch[3] = { r, g, b };
    store_scratch sc = scratch_of(scratch);
    float *keys = sc.keys;
    uint32_t *idx = sc.idx;
    int n = select_vector(t, ch, &sc);
    double total = 0, err = 0;   /* keys[0 .. CUBE_TEXELS) hold the weights' float bits (sparse.h) */
    if (t->budget_kind == TRANSPORT_BUDGET_RELATIVE)
        for (int j = 0; j < CUBE_TEXELS; j++) total += key_at(keys, j);
    size_t o = (size_t)i * t->N;
    const double w = t->weight ? t->weight[i] : 1.0;
    for (int k = 0; k < n; k++) {
        double e = w * key_at(keys, (int)idx[k]) / (total > 0 ? total : 1.0);
        t->stage_key[o + k] = e < FLT_MAX / 2 ? (float)e : FLT_MAX / 2;   /* FLT_MAX marks budget_min's */
        t->stage_idx[o + k] = idx[k];
        for (int c = 0; c < 3; c++) t->stage_val[3 * (o + k) + c] = isfinite(ch[c][idx[k]]) ? ch[c][idx[k]] : 0.f;
    }
    if (t->budget_min > 0 && n > 0) transport_keep_minimum(t, i, n, (uint64_t *)(void *)keys);   /* keys are read: free */
    t->stage_count[i] = (uint32_t)n;
    double norm = 0;   /* one pass: the whole vector's squared norm, and the part outside the candidates */
    for (int j = 0, k = 0; j < CUBE_TEXELS; j++) {
        double e = sq(r[j]) + sq(g[j]) + sq(b[j]);
        bool cand = k < n && idx[k] == (uint32_t)j;
        k += cand;
        if (!isfinite(e)) continue;
        norm += e;
        if (!cand) err += e;
    }
    t->stage_blk[(size_t)i * TRANSPORT_STAGE + TRANSPORT_BLK] = (float)norm;
    if (t->policy && t->policy->stage) t->policy->stage(t, ch, idx, n, sc.policy, t->stage_blk + (size_t)i * TRANSPORT_STAGE);
    return err;
}

/* Value of kept coefficient index of channel c before quantization: the input, plus the policy's
 * correction on a face's 16 coarsest (adj[(c * 6 + face) * 16 + m], m < 16; TRANSPORT_BLK). */
static float kept_value(const float *x, uint32_t index, const float *adj, int c) {
    if (!isfinite(x[index])) return 0.f;
    uint32_t m = index % TRANSPORT_FACE;
    return m < 16 ? x[index] + adj[(c * 6 + index / TRANSPORT_FACE) * 16 + m] : x[index];
}

/* The faces of the n kept indices idx (bit f: face f holds one). */
static unsigned kept_faces(const uint32_t *idx, int n) {
    unsigned faces = 0;
    for (int k = 0; k < n; k++) faces |= 1u << (idx[k] / TRANSPORT_FACE);
    return faces;
}

/* The kept values val[3 k + c] of vector ch's n kept idx, unquantized: the policy fits the faces it returns
 * (bit f) itself; the others get the input plus the policy's corrections (zeros without a policy). */
static unsigned kept_values(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n,
                            const store_scratch *sc, float *val) {
    float adj[TRANSPORT_BLK];
    unsigned own = 0;
    if (t->policy && t->policy->correct) own = t->policy->correct(t, ch, idx, n, val, adj, sc->policy);
    else memset(adj, 0, sizeof adj);
    if (kept_faces(idx, n) & ~own)
        for (int k = 0; k < n; k++)
            if (!(own >> (idx[k] / TRANSPORT_FACE) & 1))
                for (int c = 0; c < 3; c++) val[3 * k + c] = kept_value(ch[c], idx[k], adj, c);
    return own;
}

/* The kept values val[3 k + c] quantized in place to multiples of step[c] (qmax > 0): the faces of `own`
 * (kept_values') by the policy, the others to the nearest. */
static void quantize_vector(const prt_transport *t, unsigned own, const uint32_t *idx, int n, const float step[3],
                            int qmax, float *val, void *scratch) {
    for (int k0 = 0, k1; k0 < n; k0 = k1) {
        uint32_t f = idx[k0] / TRANSPORT_FACE;
        for (k1 = k0; k1 < n && idx[k1] / TRANSPORT_FACE == f; k1++) {}
        if (own >> f & 1) {
            t->policy->quantize(t, (int)f, idx + k0, k1 - k0, step, qmax, val + 3 * (size_t)k0, scratch);
            continue;
        }
        for (int k = k0; k < k1; k++)
            for (int c = 0; c < 3; c++) val[3 * k + c] = (float)sparse_quantize(val[3 * k + c], step[c], qmax) * step[c];
    }
}

/* Selects, quantizes and stages vector i; returns the squared L2 error of what is kept. */
double transport_store(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch) {
    PRT_CHECK(t->stage_count && i >= 0 && i < t->nvecs);
    if (t->budget) return store_candidates(t, i, r, g, b, scratch);
    const float *ch[3] = { r, g, b };
    store_scratch sc = scratch_of(scratch);
    uint32_t *idx = sc.idx;
    int n = select_vector(t, ch, &sc);
    float *val = t->stage_val + (size_t)i * t->N * 3;
    uint32_t *sidx = t->stage_idx + (size_t)i * t->N;
    unsigned own = kept_values(t, ch, idx, n, &sc, val);
    int qmax = sparse_qmax(t->qbits);
    float step[3] = { 1.f, 1.f, 1.f };
    for (int c = 0; c < 3 && qmax; c++) {
        float m = 0;
        for (int k = 0; k < n; k++) {
            float a = fabsf(val[3 * k + c]);
            if (a > m && isfinite(a)) m = a;
        }
        step[c] = sparse_step(m, qmax);
    }
    for (int c = 0; c < 3; c++) t->scale[3 * i + c] = step[c];
    if (qmax) quantize_vector(t, own, idx, n, step, qmax, val, sc.policy);
    else
        for (int k = 0; k < 3 * n; k++) val[k] = isfinite(val[k]) ? val[k] : 0.f;
    memcpy(sidx, idx, sizeof(uint32_t) * (size_t)n);
    t->stage_count[i] = (uint32_t)n;
    /* Error: dropped coefficients' energy plus the kept ones' quantization error
     * (summed directly, not as total - kept, to avoid cancellation). Non-finite
     * inputs count as zero, as sparse_select treats them. */
    double err = 0;
    int k = 0;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double e;
        if (k < n && idx[k] == (uint32_t)j) {
            e = sq((double)r[j] - val[3 * k]) + sq((double)g[j] - val[3 * k + 1]) + sq((double)b[j] - val[3 * k + 2]);
            k++;
        } else {
            e = sq(r[j]) + sq(g[j]) + sq(b[j]);
        }
        if (isfinite(e)) err += e;
    }
    return err;
}
