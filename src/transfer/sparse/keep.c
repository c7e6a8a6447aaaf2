/* keep.c - a finished set cut to each vector's n largest coefficients (transport_keep_largest), so a
 * runtime can trade accuracy for time without a new precompute (the viewer's coefficient knob).
 *
 * Contract (transport.h): a file stores each vector's coefficients in index order (the runs need it),
 * not by importance; the importance order is recomputed here from the stored values: coefficient c's
 * energy r^2 + g^2 + b^2 (the channel sum of section 4.1.1's selection, taken over the dequantized
 * values the kernel multiplies), ties to the lower index. The copy keeps the source's qbits, scales
 * and packed words bit for bit, only fewer of them, re-cut into runs, so T x L over it is the source's
 * sum restricted to the kept coefficients (the L2-best n-term approximation of the stored vector). */
#include "build.h"
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* Dequantized energy of coefficient c of vector i (any qbits). */
static float coef_energy(const prt_transport *t, int i, size_t c) {
    const float *sc = t->scale + 3 * (size_t)i;
    float v[3];
    if (t->qbits == 8) {
        uint32_t off;
        int q[3];
        sparse_unpack8(t->packed[c], &off, &q[0], &q[1], &q[2]);
        for (int k = 0; k < 3; k++) v[k] = (float)q[k] * sc[k];
    } else if (t->qbits == 16) {
        for (int k = 0; k < 3; k++) v[k] = t->q16[3 * c + k] * sc[k];
    } else {
        for (int k = 0; k < 3; k++) v[k] = t->f32[3 * c + k];
    }
    return v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
}

/* Marks in keep[0..m) the n largest energies of vector i's m coefficients (ties: lower index); returns
 * how many it keeps. e, work: scratch of t->N floats each. */
static int choose(const prt_transport *t, int i, int n, float *e, float *work, uint8_t *keep) {
    size_t c0 = t->coef_first[i];
    int m = (int)(t->coef_first[i + 1] - c0);
    if (m > n)   /* else every one is kept: no energy needed */
        for (int k = 0; k < m; k++) e[k] = coef_energy(t, i, c0 + (size_t)k);
    return sparse_mark_largest(e, m, n, work, keep);
}

/* Appends the kept coefficients of source vector i to out at coefficient c and run r. */
static void copy_vector(const prt_transport *t, int i, const uint8_t *keep, prt_transport *o, size_t *c, size_t *r) {
    size_t s = t->coef_first[i];
    for (uint32_t run = t->run_first[i]; run < t->run_first[i + 1]; run++) {
        int cnt = t->runs[2 * run + 1] + 1, kept = 0;
        for (int k = 0; k < cnt; k++, s++) {
            if (!keep[s - t->coef_first[i]]) continue;
            if (t->qbits == 8) o->packed[*c] = t->packed[s];
            else o->offs[*c] = t->offs[s];
            if (t->qbits == 16) memcpy(o->q16 + 3 * *c, t->q16 + 3 * s, 3 * sizeof *o->q16);
            if (t->qbits == 32) memcpy(o->f32 + 3 * *c, t->f32 + 3 * s, 3 * sizeof *o->f32);
            (*c)++;
            kept++;
        }
        if (kept) { o->runs[2 * *r] = t->runs[2 * run]; o->runs[2 * *r + 1] = (uint8_t)(kept - 1); (*r)++; }
    }
}

/* The arrays of out sized as src's (an upper bound). -1 with err. */
static int alloc_like(const prt_transport *t, prt_transport *o, prt_error *err) {
    size_t nc = transport_ncoefs(t), nr = transport_nruns(t), nv = (size_t)t->nvecs;
    o->vec_first = prt_calloc((size_t)t->nverts + 1, sizeof *o->vec_first, err);
    o->coef_first = o->vec_first ? prt_calloc(nv + 1, sizeof *o->coef_first, err) : NULL;
    o->run_first = o->coef_first ? prt_calloc(nv + 1, sizeof *o->run_first, err) : NULL;
    o->scale = o->run_first ? prt_calloc(3 * nv + 1, sizeof *o->scale, err) : NULL;
    o->runs = o->scale ? prt_calloc(2 * nr + 1, 1, err) : NULL;
    if (!o->runs) return -1;
    if (t->qbits == 8) o->packed = prt_calloc(nc + 1, sizeof *o->packed, err);
    else o->offs = prt_calloc(nc + 1, 1, err);
    if (t->qbits == 16) o->q16 = prt_calloc(3 * nc + 1, sizeof *o->q16, err);
    if (t->qbits == 32) o->f32 = prt_calloc(3 * nc + 1, sizeof *o->f32, err);
    bool ok = t->qbits == 8 ? o->packed != NULL : o->offs && (t->qbits == 16 ? o->q16 != NULL : o->f32 != NULL);
    return ok ? 0 : -1;
}

/* The two passes over vectors [begin, end): choose and count (each source coefficient's flag into
 * keep[], the kept coefficients and runs into out's coef_first[i+1], run_first[i+1]), or copy (to the
 * prefix-summed places). */
typedef struct keep_job { const prt_transport *t; prt_transport *o; int n; bool copy; uint8_t *keep; atomic_bool oom; } keep_job;
static void keep_range(void *p, int begin, int end, int thread) {
    keep_job *j = p;
    const prt_transport *t = j->t;
    if (j->copy) {
        for (int i = begin; i < end; i++) {
            size_t c = j->o->coef_first[i], r = j->o->run_first[i];
            copy_vector(t, i, j->keep + t->coef_first[i], j->o, &c, &r);
        }
        return;
    }
    float *e = malloc(2 * sizeof(float) * ((size_t)t->N + 1));
    if (!e) { atomic_store(&j->oom, true); return; }
    for (int i = begin; i < end; i++) {
        uint8_t *keep = j->keep + t->coef_first[i];
        choose(t, i, j->n, e, e + t->N + 1, keep);
        uint32_t kept = 0, runs = 0;
        size_t s = 0;
        for (uint32_t run = t->run_first[i]; run < t->run_first[i + 1]; run++) {
            uint32_t cnt = t->runs[2 * run + 1] + 1u, k0 = kept;
            for (uint32_t k = 0; k < cnt; k++) kept += keep[s++];
            runs += kept > k0;
        }
        j->o->coef_first[i + 1] = kept;
        j->o->run_first[i + 1] = runs;
    }
    free(e);
}

/* See transport.h. */
int transport_keep_largest(const prt_transport *t, int n, prt_transport *out, prt_error *err) {
    PRT_CHECK(t->coef_first && n >= 1);
    memset(out, 0, sizeof *out);
    out->nverts = t->nverts;
    out->nvecs = t->nvecs;
    out->N = n < t->N ? n : t->N;
    out->qbits = t->qbits;
    uint8_t *keep = alloc_like(t, out, err) ? NULL : prt_calloc(transport_ncoefs(t) + 1, 1, err);
    if (!keep) { transport_free(out); return -1; }
    memcpy(out->vec_first, t->vec_first, ((size_t)t->nverts + 1) * sizeof *out->vec_first);
    memcpy(out->scale, t->scale, 3 * (size_t)t->nvecs * sizeof *out->scale);
    keep_job j = { .t = t, .o = out, .n = n, .keep = keep };
    atomic_init(&j.oom, false);
    prt_parallel_for(t->nvecs, 256, 0, keep_range, &j);
    for (int i = 0; i < t->nvecs; i++) {   /* counts -> starts */
        out->coef_first[i + 1] += out->coef_first[i];
        out->run_first[i + 1] += out->run_first[i];
    }
    j.copy = true;
    if (!atomic_load(&j.oom)) prt_parallel_for(t->nvecs, 256, 0, keep_range, &j);
    free(keep);
    if (atomic_load(&j.oom)) { transport_free(out); return prt_fail(err, "out of memory"); }
    return 0;
}
