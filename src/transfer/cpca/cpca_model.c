/* cpca_model.c - what a CPCA model does once built (cpca.h): the light change, decoding, its bytes,
 * the file layout and the check of every index it holds. */
#include "cpca.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

typedef struct light_ctx {
    const cpca_model *m;
    const float (*L)[4];
    float *P;       /* [R][3] rows projected on the light */
    float *g;
} light_ctx;

/* P_r = row_r . L per channel for rows [b, e) (Sloan Eq. 5's per-cluster projections). */
static void project_rows(void *ctx, int b, int e, int thread) {
    (void)thread;
    light_ctx *c = ctx;
    for (int r = b; r < e; r++) {
        float s[3] = { 0, 0, 0 };
        for (uint32_t q = c->m->first[r]; q < c->m->first[r + 1]; q++) {
            const float *l = c->L[c->m->idx[q]];
            float v = c->m->val[q];
            s[0] += v * l[0], s[1] += v * l[1], s[2] += v * l[2];
        }
        memcpy(c->P + 3 * (size_t)r, s, sizeof s);
    }
}

/* g_s = P_{k,0} + sum_m w_sm P_{k,m} for the vectors [b, e). */
static void weigh(void *ctx, int b, int e, int thread) {
    (void)thread;
    light_ctx *c = ctx;
    int M = c->m->M;
    for (int i = b; i < e; i++) {
        const float *P = c->P + 3 * (size_t)c->m->cluster[i] * (M + 1);
        for (int ch = 0; ch < 3; ch++) {
            const float *w = c->m->w + ((size_t)3 * i + ch) * M;
            float s = P[ch];
            for (int a = 0; a < M; a++) s += w[a] * P[3 * (a + 1) + ch];
            c->g[3 * (size_t)i + ch] = s;
        }
    }
}

/* One vector's rows projected on the spot (no P array: out of memory for it). */
static void light_one(const cpca_model *m, const float (*L)[4], int i, float *g) {
    int M = m->M, r0 = m->cluster[i] * (M + 1);
    float P[3 * (CPCA_MAX_TERMS + 1)];
    for (int a = 0; a <= M; a++) {
        float s[3] = { 0, 0, 0 };
        for (uint32_t q = m->first[r0 + a]; q < m->first[r0 + a + 1]; q++)
            for (int ch = 0; ch < 3; ch++) s[ch] += m->val[q] * L[m->idx[q]][ch];
        memcpy(P + 3 * a, s, sizeof s);
    }
    for (int ch = 0; ch < 3; ch++) {
        float s = P[ch];
        for (int a = 0; a < M; a++) s += m->w[((size_t)3 * i + ch) * M + a] * P[3 * (a + 1) + ch];
        g[3 * (size_t)i + ch] = s;
    }
}

void cpca_light(const cpca_model *m, const float (*L)[4], float *g, int nthreads) {
    int R = cpca_rows(m);
    light_ctx c = { m, L, malloc(sizeof(float) * 3 * (size_t)(R ? R : 1)), g };
    if (!c.P) {
        for (int i = 0; i < m->nvecs; i++) light_one(m, L, i, g);
        return;
    }
    prt_parallel_for(R, 16, nthreads, project_rows, &c);
    prt_parallel_for(m->nvecs, 1024, nthreads, weigh, &c);
    free(c.P);
}

void cpca_decode(const cpca_model *m, int i, int c, float *x) {
    int M = m->M, r0 = m->cluster[i] * (M + 1);
    memset(x, 0, sizeof(float) * CUBE_TEXELS);
    for (int a = 0; a <= M; a++) {
        float w = a ? m->w[((size_t)3 * i + c) * M + a - 1] : 1.f;
        for (uint32_t q = m->first[r0 + a]; q < m->first[r0 + a + 1]; q++) x[m->idx[q]] += w * m->val[q];
    }
}

size_t cpca_bytes(const cpca_model *m) {
    size_t R = (size_t)cpca_rows(m), nc = m->first ? m->first[R] : 0;
    return 36 + 2 * (size_t)m->nvecs + 12 * (size_t)m->nvecs * m->M + 4 * (R + 1) + 4 * R + 4 * nc;
}

void cpca_write(prt_writer *w, const cpca_model *m) {
    size_t R = (size_t)cpca_rows(m), nc = m->first[R];
    prtio_put_i32(w, m->nvecs);
    prtio_put_i32(w, m->C);
    prtio_put_i32(w, m->M);
    prtio_put_u64(w, nc);
    prtio_put_arr(w, m->cluster, (size_t)m->nvecs, 2);
    prtio_put_arr(w, m->w, 3 * (size_t)m->nvecs * m->M, 4);
    prtio_put_arr(w, m->first, R + 1, 4);
    prtio_put_arr(w, m->step, R, 4);
    prtio_put_arr(w, m->idx, nc, 2);
    int16_t q[1024];   /* the values as their 16-bit codes, a chunk at a time */
    size_t k = 0;
    for (size_t r = 0; r < R; r++)
        for (uint32_t c = m->first[r]; c < m->first[r + 1]; c++) {
            float s = m->step[r];
            q[k++] = (int16_t)(s > 0 ? lrintf(m->val[c] / s) : 0);
            if (k == 1024) prtio_put_arr(w, q, k, 2), k = 0;
        }
    prtio_put_arr(w, q, k, 2);
    prtio_put_f64(w, m->err2);
    prtio_put_f64(w, m->norm2);
}

/* The values q x step of every row (rows whose offsets are broken are left zero: cpca_check refuses them). */
static bool read_values(prt_reader *r, cpca_model *m, size_t nc) {
    int16_t *q = prtio_get_arr(r, nc, 2);
    m->val = q ? calloc(nc ? nc : 1, sizeof *m->val) : NULL;
    if (!m->val) { free(q); return false; }
    size_t R = (size_t)cpca_rows(m);
    for (size_t k = 0; k < R; k++)
        for (uint32_t c = m->first[k]; c < m->first[k + 1] && c < nc && m->first[k + 1] <= nc; c++)
            m->val[c] = (float)q[c] * m->step[k];
    free(q);
    return true;
}

bool cpca_read(prt_reader *r, cpca_model *m, char *why) {
    memset(m, 0, sizeof *m);
    m->nvecs = prtio_get_i32(r), m->C = prtio_get_i32(r), m->M = prtio_get_i32(r);
    uint64_t nc = prtio_get_u64(r);
    if (r->bad) return BAD(why, "cpca section too short");
    if (m->nvecs < 0 || m->nvecs > INT32_MAX / 3 - 1) return BAD(why, "cpca: bad vector count %d", m->nvecs);
    if (m->C < 1 || m->C > UINT16_MAX || m->M < 1 || m->M > CPCA_MAX_TERMS)
        return BAD(why, "cpca: bad cluster count %d or terms %d (1..%d)", m->C, m->M, CPCA_MAX_TERMS);
    size_t R = (size_t)cpca_rows(m);
    if (nc > R * CUBE_TEXELS) return BAD(why, "cpca: %llu coefficients exceed %zu rows of %d", (unsigned long long)nc, R, CUBE_TEXELS);
    m->cluster = prtio_get_arr(r, (size_t)m->nvecs, 2);
    m->w = prtio_get_arr(r, 3 * (size_t)m->nvecs * m->M, 4);
    m->first = prtio_get_arr(r, R + 1, 4);
    m->step = prtio_get_arr(r, R, 4);
    m->idx = prtio_get_arr(r, (size_t)nc, 2);
    bool values = !r->bad && read_values(r, m, (size_t)nc);
    m->err2 = prtio_get_f64(r), m->norm2 = prtio_get_f64(r);
    if (r->bad || !values) return BAD(why, r->oom ? "cpca: out of memory" : "cpca section too short for %d vectors, %llu coefficients", m->nvecs, (unsigned long long)nc);
    if (m->first[R] != nc) return BAD(why, "cpca: row offsets end at %u, not at the %llu coefficients", m->first[R], (unsigned long long)nc);
    return true;
}

bool cpca_check(const cpca_model *m, int nvecs, char *why) {
    if (m->nvecs != nvecs) return BAD(why, "cpca: %d weight vectors for %d transport vectors", m->nvecs, nvecs);
    for (int i = 0; i < m->nvecs; i++)
        if (m->cluster[i] >= m->C) return BAD(why, "cpca: vector %d in cluster %u of %d", i, m->cluster[i], m->C);
    int R = cpca_rows(m);
    if (m->first[0] != 0) return BAD(why, "cpca: row offsets do not start at 0");
    for (int r = 0; r < R; r++) {
        if (m->first[r + 1] < m->first[r] || m->first[r + 1] > m->first[R] || m->first[r + 1] - m->first[r] > CUBE_TEXELS)
            return BAD(why, "cpca: row %d: bad coefficient offsets", r);
        for (uint32_t q = m->first[r]; q < m->first[r + 1]; q++) {
            if (m->idx[q] >= CUBE_TEXELS) return BAD(why, "cpca: row %d: coefficient index %u beyond the basis (%d)", r, m->idx[q], CUBE_TEXELS);
            if (q > m->first[r] && m->idx[q] <= m->idx[q - 1]) return BAD(why, "cpca: row %d: coefficient indices not ascending", r);
        }
        if (!(m->step[r] >= 0) || !isfinite(m->step[r])) return BAD(why, "cpca: row %d: bad quantization step", r);
    }
    if (!prtio_all_finite(m->w, 3 * (size_t)m->nvecs * m->M) || !prtio_all_finite(m->val, m->first[R]))
        return BAD(why, "cpca: non-finite weights or coefficients");
    return true;
}

void cpca_model_free(cpca_model *m) {
    free(m->cluster); free(m->w); free(m->first); free(m->idx); free(m->val); free(m->step);
    memset(m, 0, sizeof *m);
}
