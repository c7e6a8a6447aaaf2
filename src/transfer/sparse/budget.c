/* budget.c - a shared budget's choice (transport_share_budget, docs/design/shadows.md): which of all the
 * vectors' staged candidates the set keeps, and each vector's corrected, quantized values.
 *
 * Contract (transport.h): transport_store stages each vector's N_max best candidates raw with their
 * selection weights (RELATIVE: over the vector's total); transport_finish keeps the budget x nvecs of
 * largest weight over the whole set (ties to the lower vector, then the lower index: deterministic,
 * on any threads), every vector at least its budget_min best, then corrects (the set's policy) and
 * quantizes each vector's kept ones in its staging for pack.c.
 *
 * Why one threshold: the summed expected squared error of T.L is the sum of the dropped weights, so
 * the best B candidates of all vectors are those above one weight, found by a radix select over the
 * weights' float bits (non-negative floats order like their bits) in two streamed passes. A vector
 * whose transport has detail (a shadow edge crossing its cube) keeps more, a smooth one fewer. */
#include "build.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t bits_of(float x) { uint32_t u; memcpy(&u, &x, sizeof u); return u; }
static double sq(double x) { return x * x; }

/* qsort order of 64-bit words, largest first. */
static int by_weight(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x < y) - (x > y);   /* descending */
}

/* See build.h. Why: a water-filling on absolute weights starves the darkest vertices (a floor vertex
 * under a model can keep nothing: black). Each vector's budget_min best candidates get the largest
 * finite weight, so the threshold keeps them whatever the others hold (budget_min <= budget keeps the total within it).
 * They are the best of all its coefficients, since the candidates are (sparse_select's order: larger
 * weight first, ties to the lower index, zeros never), so they are picked among the n staged ones.
 * order: scratch of n 64-bit words. */
void transport_keep_minimum(prt_transport *t, int i, int n, uint64_t *order) {
    size_t o = (size_t)i * t->N;
    int m = 0;
    for (int k = 0; k < n; k++) {   /* weight bits high, then the complement of k: ties to the lower index */
        uint32_t u = bits_of(t->stage_key[o + k]);
        if (u) order[m++] = (uint64_t)u << 32 | (UINT32_MAX - (uint32_t)k);
    }
    if (m > t->budget_min) qsort(order, (size_t)m, sizeof *order, by_weight);
    for (int q = 0; q < m && q < t->budget_min; q++) t->stage_key[o + (UINT32_MAX - (uint32_t)order[q])] = FLT_MAX;
}

/* Why: the best B candidates of all vectors (largest weights: the least expected error, summed) are those
 * above one threshold, so a radix select over the weights' float bits (non-negative floats order like
 * their bits) finds it in two passes: the top 16 bits, then the low 16 within that bin. Sets *T to the
 * B-th largest weight's bits and *need_eq to how many equal to it are kept (ties go to the lower vector,
 * then the lower index: deterministic). */
static void budget_threshold(const prt_transport *t, uint64_t B, uint64_t *hist, uint32_t *T, uint64_t *need_eq) {
    uint64_t above = 0;   /* hist: 65536 counts of scratch */
    uint32_t hi = 0, lo = 0;
    for (int pass = 0; pass < 2; pass++) {
        memset(hist, 0, 65536 * sizeof *hist);
        for (int i0 = 0; i0 < t->nvecs; i0 += 4096) {   /* streamed: a chunk at a time in memory */
            int i1 = t->nvecs - i0 < 4096 ? t->nvecs : i0 + 4096;
            for (int i = i0; i < i1; i++)
                for (uint32_t k = 0; k < t->stage_count[i]; k++) {
                    uint32_t u = bits_of(t->stage_key[(size_t)i * t->N + k]);
                    if (pass == 0) hist[u >> 16]++;
                    else if ((u >> 16) == hi) hist[u & 65535u]++;
                }
            transport_release(t, i0, i1);
        }
        uint32_t bin = 65535;
        while (above + hist[bin] < B) above += hist[bin--];
        if (pass == 0) hi = bin; else lo = bin;
    }
    *T = hi << 16 | lo;
    *need_eq = B - above;
}

typedef struct budget_ctx {
    prt_transport *t;
    uint32_t T;           /* weights above T are kept */
    const uint32_t *take; /* [nvecs] how many of vector i's weights equal to T are kept */
    double *err;          /* [nvecs] squared error the choice adds (dropped candidates, quantization) */
} budget_ctx;

/* Marks which of vector i's staged candidates the threshold keeps (keep[k]: ties at T to the lower
 * index, c->take[i] of them), asks the set's policy for the corrections of what it drops (adj, before
 * compacting: the policy reads the candidates in place), then keeps the chosen ones in place (index
 * order) and adds the dropped ones' squares to c->err[i]. Returns how many it keeps. */
static uint32_t budget_keep(const budget_ctx *c, int i, uint8_t *keep, float *adj) {
    prt_transport *t = c->t;
    size_t o = (size_t)i * t->N;
    uint32_t *idx = t->stage_idx + o, n = 0, take = c->take[i];
    float *val = t->stage_val + 3 * o;
    for (uint32_t k = 0; k < t->stage_count[i]; k++) {
        uint32_t u = bits_of(t->stage_key[o + k]);
        keep[k] = u > c->T || (u == c->T && take > 0);
        take -= keep[k] && u == c->T;
    }
    if (t->policy && t->policy->budget_correct) t->policy->budget_correct(t, i, keep, adj);
    else memset(adj, 0, TRANSPORT_BLK * sizeof *adj);
    for (uint32_t k = 0; k < t->stage_count[i]; k++) {
        if (keep[k]) {
            idx[n] = idx[k];
            memmove(val + 3 * n, val + 3 * k, 3 * sizeof *val);
            n++;
        } else {
            for (int ch = 0; ch < 3; ch++) c->err[i] += sq(val[3 * k + ch]);
        }
    }
    return n;
}

/* prt_parallel_for body: each vector's choice, corrected and quantized in its staging (as transport_store
 * leaves a vector under the per-vector budget). */
static void budget_vectors(void *p, int begin, int end, int thread) {
    const budget_ctx *c = p;
    prt_transport *t = c->t;
    int qmax = sparse_qmax(t->qbits);
    uint8_t keep[CUBE_TEXELS];
    for (int i = begin; i < end; i++) {
        float adj[TRANSPORT_BLK];
        uint32_t n = budget_keep(c, i, keep, adj), *idx = t->stage_idx + (size_t)i * t->N;
        float *val = t->stage_val + 3 * (size_t)i * t->N;
        for (int ch = 0; ch < 3; ch++) {
            float mx = 0, step = 1.f;
            for (uint32_t k = 0; k < n && qmax; k++) {
                uint32_t m = idx[k] % TRANSPORT_FACE;
                float x = fabsf(val[3 * k + ch] + (m < 16 ? adj[(ch * 6 + idx[k] / TRANSPORT_FACE) * 16 + m] : 0.f));
                if (x > mx && isfinite(x)) mx = x;
            }
            if (qmax) step = t->scale[3 * i + ch] = sparse_step(mx, qmax);
            for (uint32_t k = 0; k < n; k++) {
                uint32_t m = idx[k] % TRANSPORT_FACE;
                float raw = val[3 * k + ch], x = raw + (m < 16 ? adj[(ch * 6 + idx[k] / TRANSPORT_FACE) * 16 + m] : 0.f);
                val[3 * k + ch] = qmax ? (float)sparse_quantize(x, step, qmax) * step : x;
                c->err[i] += sq((double)raw - val[3 * k + ch]);
            }
        }
        float norm = t->stage_blk[(size_t)i * TRANSPORT_STAGE + TRANSPORT_BLK];
        c->err[i] = norm > 0 ? c->err[i] / norm : 0;
        t->stage_count[i] = n;
    }
    transport_release(t, begin, end);
}

/* See build.h. */
int transport_budget_finish(prt_transport *t, prt_error *err) {
    uint64_t B = (uint64_t)t->budget * (uint64_t)t->nvecs, S = 0, need_eq = UINT64_MAX;
    for (int i = 0; i < t->nvecs; i++) S += t->stage_count[i];
    budget_ctx *c = prt_calloc(1, sizeof *c, err);
    uint32_t *take = c ? prt_calloc((size_t)t->nvecs + 1, sizeof *take, err) : NULL;
    double *verr = take ? prt_calloc((size_t)t->nvecs + 1, sizeof *verr, err) : NULL;
    uint64_t *hist = verr && S > B ? prt_calloc(65536, sizeof *hist, err) : NULL;
    if (!verr || (S > B && !hist)) {
        free(verr); free(take); free(c);
        return prt_fail(err, "transport: out of memory choosing a shared budget");
    }
    c->t = t;
    c->take = take;
    c->err = verr;
    if (S > B) budget_threshold(t, B, hist, &c->T, &need_eq);
    free(hist);
    for (int i = 0; i < t->nvecs; i++) {   /* ties to the lower vector, in order */
        uint32_t eq = 0;
        for (uint32_t k = 0; k < t->stage_count[i] && need_eq; k++) eq += bits_of(t->stage_key[(size_t)i * t->N + k]) == c->T;
        take[i] = eq < need_eq ? eq : (uint32_t)need_eq;
        need_eq -= take[i];
    }
    prt_parallel_for(t->nvecs, 4096, 0, budget_vectors, c);
    t->chosen_err = 0;
    for (int i = 0; i < t->nvecs; i++) t->chosen_err += c->err[i];   /* in order: the same sum on any threads */
    free(c->err);
    free(take);
    free(c);
    if (!t->stage_mapped) { free(t->stage_key); free(t->stage_blk); }   /* mapped: unmapped with the rest */
    t->stage_key = NULL;   /* chosen: a retried finish (after OOM) packs what is staged */
    t->stage_blk = NULL;
    return 0;
}
