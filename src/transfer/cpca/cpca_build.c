/* cpca_build.c - building a CPCA model (cpca.h): k-means clustering of the vectors, each
 * cluster's principal directions by subspace iteration, the rows kept sparse and quantized, and
 * the weights refit to them. */
#include "cpca.h"
#include "sparse.h"
#include <lapacke.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* ---- k-means (Lloyd) on the channel mean of each vector --------------------------------------- */

/* The clustering sees each vector's CPCA_FEATURE largest channel-mean coefficients: the distances are
 * dominated by them, and the assignment costs vectors x clusters x CPCA_FEATURE per iteration. */
#define CPCA_FEATURE 256

typedef struct km_ctx {
    int n, C;
    const uint32_t *ff;     /* [n + 1] feature offsets */
    const uint16_t *fi;     /* feature indices */
    const float *fv;        /* feature values */
    const float *cen;       /* [CUBE_TEXELS][C]: index-major, so one coefficient meets every centre at once */
    const double *cnorm;    /* [C] |centre|^2 */
    uint16_t *cl;           /* [n] */
    int *changed;           /* [n] 1 when the vector moved this iteration */
} km_ctx;

/* The nearest centre of each vector in [b, e): argmin |c|^2 - 2 f.c (the lowest index on a tie). */
static void km_assign(void *ctx, int b, int e, int thread) {
    (void)thread;
    km_ctx *c = ctx;
    float dot[4096];
    for (int i = b; i < e; i++) {
        memset(dot, 0, sizeof(float) * (size_t)c->C);
        for (uint32_t j = c->ff[i]; j < c->ff[i + 1]; j++) {
            const float *row = c->cen + (size_t)c->fi[j] * c->C;
            float x = c->fv[j];
            for (int k = 0; k < c->C; k++) dot[k] += x * row[k];
        }
        double best = INFINITY;
        int bk = 0;
        for (int k = 0; k < c->C; k++) {
            double d = c->cnorm[k] - 2.0 * dot[k];
            if (d < best) best = d, bk = k;
        }
        c->changed[i] = c->cl[i] != bk;
        c->cl[i] = (uint16_t)bk;
    }
}

/* Centres as the means of their vectors' features, summed in vector order (an empty cluster keeps
 * its own). */
static void km_update(const km_ctx *c, float *cen, double *acc, int *cnt, double *cnorm) {
    int C = c->C;
    memset(acc, 0, sizeof(double) * (size_t)C * CUBE_TEXELS);
    memset(cnt, 0, sizeof(int) * (size_t)C);
    for (int i = 0; i < c->n; i++) {
        cnt[c->cl[i]]++;
        for (uint32_t j = c->ff[i]; j < c->ff[i + 1]; j++) acc[(size_t)c->fi[j] * C + c->cl[i]] += c->fv[j];
    }
    for (size_t t = 0; t < CUBE_TEXELS; t++)
        for (int k = 0; k < C; k++)
            if (cnt[k]) cen[t * C + k] = (float)(acc[t * C + k] / cnt[k]);
    for (int k = 0; k < C; k++) cnorm[k] = 0;
    for (size_t t = 0; t < CUBE_TEXELS; t++)
        for (int k = 0; k < C; k++) cnorm[k] += (double)cen[t * C + k] * cen[t * C + k];
}

/* Each vector's feature: its CPCA_FEATURE largest channel means. */
static int features(const cpca_vectors *v, uint32_t *ff, uint16_t *fi, float *fv) {
    float *key = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    uint8_t *keep = malloc(CUBE_TEXELS);
    if (!key || !keep) { free(key); free(keep); return -1; }
    float *m = key + CUBE_TEXELS, *scratch = key + 2 * CUBE_TEXELS;
    ff[0] = 0;
    for (int i = 0; i < v->n; i++) {
        int n = (int)(v->first[i + 1] - v->first[i]), c = 0;
        for (int j = 0; j < n; j++) {
            const float *x = v->val + 3 * (size_t)(v->first[i] + (uint32_t)j);
            m[j] = (x[0] + x[1] + x[2]) / 3;
            key[j] = fabsf(m[j]);
        }
        sparse_mark_largest(key, n, CPCA_FEATURE, scratch, keep);
        for (int j = 0; j < n; j++)
            if (keep[j]) fi[ff[i] + (uint32_t)c] = (uint16_t)v->idx[v->first[i] + (uint32_t)j], fv[ff[i] + (uint32_t)c++] = m[j];
        ff[i + 1] = ff[i] + (uint32_t)c;
    }
    free(key); free(keep);
    return 0;
}

/* Clusters v into C (C <= n, C <= 4096) by Lloyd's iterations from the vectors at (2k + 1) n / 2C
 * (seeded by index: the vector order is the mesh's, so the seeds spread over the surface). 0 or -1. */
static int kmeans(const cpca_vectors *v, int C, int nthreads, uint16_t *cl) {
    size_t nf = (size_t)v->n * CPCA_FEATURE;
    km_ctx c = { v->n, C, malloc(sizeof(uint32_t) * ((size_t)v->n + 1)), malloc(sizeof(uint16_t) * nf), malloc(sizeof(float) * nf),
                 NULL, NULL, cl, calloc((size_t)v->n + 1, sizeof(int)) };
    float *cen = calloc((size_t)C * CUBE_TEXELS, sizeof *cen);
    double *acc = calloc((size_t)C * CUBE_TEXELS, sizeof *acc), *cnorm = calloc((size_t)C, sizeof *cnorm);
    int *cnt = calloc((size_t)C, sizeof *cnt), rc = -1;
    if (c.ff && c.fi && c.fv && c.changed && cen && acc && cnorm && cnt && !features(v, (uint32_t *)c.ff, (uint16_t *)c.fi, (float *)c.fv)) {
        c.cen = cen, c.cnorm = cnorm;
        for (int k = 0; k < C; k++) {
            int i = (int)(((2 * (long long)k + 1) * v->n) / (2 * (long long)C));
            for (uint32_t j = c.ff[i]; j < c.ff[i + 1]; j++) {
                cen[(size_t)c.fi[j] * C + k] = c.fv[j];
                cnorm[k] += (double)c.fv[j] * c.fv[j];
            }
        }
        for (int i = 0; i < v->n; i++) cl[i] = UINT16_MAX;   /* every vector counts as moved in the first assignment */
        for (int it = 0; it < CPCA_KMEANS_ITERS; it++) {
            prt_parallel_for(v->n, 64, nthreads, km_assign, &c);
            int moved = 0;
            for (int i = 0; i < v->n; i++) moved += c.changed[i];
            if (it > 0 && moved == 0) break;
            km_update(&c, cen, acc, cnt, cnorm);
        }
        rc = 0;
    }
    free((void *)c.ff); free((void *)c.fi); free((void *)c.fv); free(c.changed);
    free(cen); free(acc); free(cnorm); free(cnt);
    return rc;
}

/* ---- one cluster's principal directions ------------------------------------------------------- */

/* A cluster's centred samples in its own dense index space: sample s = 3j + c of member j. */
typedef struct cl_data {
    const cpca_vectors *v;
    const int *mem;         /* [nm] member vectors, ascending */
    int nm, ns, D, l;
    const int *map;         /* [CUBE_TEXELS] index -> column (-1: none) */
    double *mu;             /* [D] the mean */
} cl_data;

/* Z = Xc V (Z [ns][l], V [D][l]). */
static void mul_xv(const cl_data *d, const double *V, double *Z) {
    double muv[CPCA_MAX_TERMS + CPCA_OVERSAMPLE] = { 0 };
    for (int t = 0; t < d->D; t++)
        for (int a = 0; a < d->l; a++) muv[a] += d->mu[t] * V[(size_t)t * d->l + a];
    for (int j = 0; j < d->nm; j++) {
        const cpca_vectors *v = d->v;
        int i = d->mem[j];
        for (int c = 0; c < 3; c++) {
            double *z = Z + (size_t)(3 * j + c) * d->l;
            for (int a = 0; a < d->l; a++) z[a] = -muv[a];
            for (uint32_t q = v->first[i]; q < v->first[i + 1]; q++) {
                const double *vr = V + (size_t)d->map[v->idx[q]] * d->l;
                double x = v->val[3 * (size_t)q + c];
                for (int a = 0; a < d->l; a++) z[a] += x * vr[a];
            }
        }
    }
}

/* V = Xc^T Z. */
static void mul_xtz(const cl_data *d, const double *Z, double *V) {
    double zs[CPCA_MAX_TERMS + CPCA_OVERSAMPLE] = { 0 };
    memset(V, 0, sizeof(double) * (size_t)d->D * d->l);
    for (int j = 0; j < d->nm; j++) {
        const cpca_vectors *v = d->v;
        int i = d->mem[j];
        for (int c = 0; c < 3; c++) {
            const double *z = Z + (size_t)(3 * j + c) * d->l;
            for (int a = 0; a < d->l; a++) zs[a] += z[a];
            for (uint32_t q = v->first[i]; q < v->first[i + 1]; q++) {
                double *vr = V + (size_t)d->map[v->idx[q]] * d->l;
                double x = v->val[3 * (size_t)q + c];
                for (int a = 0; a < d->l; a++) vr[a] += x * z[a];
            }
        }
    }
    for (int t = 0; t < d->D; t++)
        for (int a = 0; a < d->l; a++) V[(size_t)t * d->l + a] -= d->mu[t] * zs[a];
}

/* Orthonormalizes V's l columns in place (modified Gram-Schmidt, twice); a column that vanishes
 * (rank below l) becomes zero. */
static void orthonormalize(double *V, int D, int l) {
    for (int pass = 0; pass < 2; pass++)
        for (int a = 0; a < l; a++) {
            for (int b = 0; b < a; b++) {
                double dot = 0;
                for (int t = 0; t < D; t++) dot += V[(size_t)t * l + a] * V[(size_t)t * l + b];
                for (int t = 0; t < D; t++) V[(size_t)t * l + a] -= dot * V[(size_t)t * l + b];
            }
            double n = 0;
            for (int t = 0; t < D; t++) n += V[(size_t)t * l + a] * V[(size_t)t * l + a];
            double s = n > 1e-300 ? 1 / sqrt(n) : 0;
            for (int t = 0; t < D; t++) V[(size_t)t * l + a] *= s;
        }
}

/* A hash of (sample, column) in [-1, 1): the start Omega, the same for any thread count. */
static double omega(uint64_t s, uint64_t a) {
    uint64_t x = s * 0x9E3779B97F4A7C15ull ^ (a + 1) * 0xBF58476D1CE4E5B9ull;
    x ^= x >> 31; x *= 0x94D049BB133111EBull; x ^= x >> 29;
    return (double)(x >> 11) / (double)(1ull << 52) - 1;
}

/* The M leading principal directions of d's centred samples into B [M][D] (unit, or zero beyond
 * the rank: Rayleigh-Ritz on the iterated subspace). 0 or -1 (OOM). */
static int principal(const cl_data *d, int M, double *B) {
    int l = d->l, ns = d->ns;
    double *V = malloc(sizeof(double) * (size_t)d->D * l), *Z = malloc(sizeof(double) * (size_t)ns * l);
    double H[(CPCA_MAX_TERMS + CPCA_OVERSAMPLE) * (CPCA_MAX_TERMS + CPCA_OVERSAMPLE)], ev[CPCA_MAX_TERMS + CPCA_OVERSAMPLE];
    if (!V || !Z) { free(V); free(Z); return -1; }
    for (int s = 0; s < ns; s++)
        for (int a = 0; a < l; a++) Z[(size_t)s * l + a] = omega((uint64_t)(3 * d->mem[s / 3] + s % 3), (uint64_t)a);
    mul_xtz(d, Z, V);
    for (int it = 0; it < CPCA_POWER; it++) {
        orthonormalize(V, d->D, l);
        mul_xv(d, V, Z);
        mul_xtz(d, Z, V);
    }
    orthonormalize(V, d->D, l);
    mul_xv(d, V, Z);
    for (int a = 0; a < l; a++)
        for (int b = 0; b < l; b++) {
            double s = 0;
            for (int r = 0; r < ns; r++) s += Z[(size_t)r * l + a] * Z[(size_t)r * l + b];
            H[a * l + b] = s;
        }
    int rc = LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'V', 'U', l, H, l, ev);   /* ascending */
    for (int m = 0; m < M; m++) {
        int a = l - 1 - m;
        double *b = B + (size_t)m * d->D;
        for (int t = 0; t < d->D; t++) {
            double s = 0;
            for (int k = 0; k < l && m < l && rc == 0; k++) s += V[(size_t)t * l + k] * H[k * l + a];
            b[t] = s;
        }
    }
    free(V); free(Z);
    return 0;
}

/* ---- rows: sparse, quantized, weights refit ---------------------------------------------------- */

typedef struct build_ctx {
    const cpca_vectors *v;
    const cpca_params *p;
    cpca_model *m;
    const int *mfirst, *mem;    /* members of cluster k: mem[mfirst[k] .. mfirst[k+1]) */
    uint16_t **ridx;            /* per row its kept indices and values (merged after) */
    float **rval;
    int *rcount;
    double *cerr;               /* [2 C] each cluster's squared error and squared norm (refit) */
    atomic_int failed;
} build_ctx;

/* Row r from dense x [D] over columns U [D]: its `coeffs` largest |x| (ties: lower index), in index
 * order, rounded to 16 bits when quantizing; the kept values back into x (the rest zero). tmp:
 * 2 D floats and D bytes of scratch. */
static int keep_row(const build_ctx *c, int r, double *x, const int *U, int D, float *tmp) {
    float *key = tmp, *scratch = tmp + D;
    uint8_t *keep = (uint8_t *)(tmp + 2 * D);
    double amax = 0;
    for (int t = 0; t < D; t++) key[t] = (float)fabs(x[t]);
    sparse_mark_largest(key, D, c->p->coeffs, scratch, keep);
    int n = 0;
    for (int t = 0; t < D; t++) {
        keep[t] = keep[t] && x[t] != 0;
        n += keep[t];
        if (keep[t]) amax = fmax(amax, fabs(x[t]));
    }
    float step = c->p->quantize && amax > 0 ? (float)(amax / 32767) : 0;
    c->ridx[r] = malloc(sizeof(uint16_t) * (size_t)(n ? n : 1));
    c->rval[r] = malloc(sizeof(float) * (size_t)(n ? n : 1));
    if (!c->ridx[r] || !c->rval[r]) return -1;
    for (int t = 0, k = 0; t < D; t++) {
        float val = 0;
        if (keep[t]) {
            val = (float)x[t];
            if (step > 0) val = (float)(int)lrintf(val / step) * step;
            c->ridx[r][k] = (uint16_t)U[t];
            c->rval[r][k++] = val;
        }
        x[t] = val;
    }
    c->rcount[r] = n;
    c->m->step[r] = step;
    return 0;
}

/* Solves G w = rhs (n x n, symmetric positive semidefinite) by Cholesky with a ridge of 1e-12 of
 * its trace (a zero row: a basis vector beyond the cluster's rank gets weight 0). */
static void solve_spd(const double *G, int n, double *rhs) {
    double A[CPCA_MAX_TERMS * CPCA_MAX_TERMS], tr = 0;
    for (int a = 0; a < n; a++) tr += G[a * n + a];
    memcpy(A, G, sizeof(double) * (size_t)n * n);
    for (int a = 0; a < n; a++) A[a * n + a] += 1e-12 * tr + 1e-300;
    if (LAPACKE_dposv(LAPACK_ROW_MAJOR, 'U', n, 1, A, n, rhs, 1) != 0)
        for (int a = 0; a < n; a++) rhs[a] = 0;
}

/* The weights of cluster k's samples against its kept rows R [M + 1][D] (least squares:
 * (R_b . R_b') w = R_b . (x - R_0)), and into err[2] the sums over its samples of the squared error
 * |x - R_0 - sum_b w_b R_b|^2 = |x - R_0|^2 - w . rhs (at the least-squares solution) and of |x|^2. */
static void refit(const build_ctx *c, const cl_data *d, const double *R, double *err) {
    int M = c->m->M, D = d->D;
    double G[CPCA_MAX_TERMS * CPCA_MAX_TERMS], r0[CPCA_MAX_TERMS], rhs[CPCA_MAX_TERMS], w[CPCA_MAX_TERMS], n00 = 0;
    for (int t = 0; t < D; t++) n00 += R[t] * R[t];
    for (int a = 0; a < M; a++) {
        r0[a] = 0;
        for (int t = 0; t < D; t++) r0[a] += R[(size_t)(a + 1) * D + t] * R[t];
        for (int b = 0; b < M; b++) {
            double s = 0;
            for (int t = 0; t < D; t++) s += R[(size_t)(a + 1) * D + t] * R[(size_t)(b + 1) * D + t];
            G[a * M + b] = s;
        }
    }
    err[0] = err[1] = 0;
    for (int j = 0; j < d->nm; j++) {
        int i = d->mem[j];
        for (int ch = 0; ch < 3; ch++) {
            double xx = 0, x0 = 0;
            for (uint32_t q = c->v->first[i]; q < c->v->first[i + 1]; q++) {
                double x = c->v->val[3 * (size_t)q + ch];
                xx += x * x, x0 += x * R[d->map[c->v->idx[q]]];
            }
            for (int a = 0; a < M; a++) {
                double s = -r0[a];
                for (uint32_t q = c->v->first[i]; q < c->v->first[i + 1]; q++)
                    s += c->v->val[3 * (size_t)q + ch] * R[(size_t)(a + 1) * D + d->map[c->v->idx[q]]];
                rhs[a] = w[a] = s;
            }
            solve_spd(G, M, w);
            double e = xx - 2 * x0 + n00;
            for (int a = 0; a < M; a++) e -= w[a] * rhs[a], c->m->w[((size_t)3 * i + ch) * M + a] = (float)w[a];
            err[0] += e > 0 ? e : 0, err[1] += xx;
        }
    }
}

/* The columns of cluster k's members (their union of indices, ascending) into U and map. */
static int columns(const build_ctx *c, int k, int *U, int *map) {
    int D = 0;
    for (int j = c->mfirst[k]; j < c->mfirst[k + 1]; j++) {
        int i = c->mem[j];
        for (uint32_t q = c->v->first[i]; q < c->v->first[i + 1]; q++) map[c->v->idx[q]] = 1;
    }
    for (int t = 0; t < CUBE_TEXELS; t++) {
        if (map[t] < 0) continue;
        U[D] = t;
        map[t] = D++;
    }
    return D;
}

/* Cluster k: mean, principal directions, kept rows, weights. -1 on OOM. */
static int build_cluster(build_ctx *c, int k) {
    int M = c->m->M, nm = c->mfirst[k + 1] - c->mfirst[k];
    int *map = malloc(sizeof(int) * CUBE_TEXELS), *U = malloc(sizeof(int) * CUBE_TEXELS);
    float *tmp = malloc((2 * sizeof(float) + 1) * CUBE_TEXELS + sizeof(float));
    if (!map || !U || !tmp) { free(map); free(U); free(tmp); return -1; }
    for (int t = 0; t < CUBE_TEXELS; t++) map[t] = -1;
    int D = nm ? columns(c, k, U, map) : 0;
    cl_data d = { c->v, c->mem + c->mfirst[k], nm, 3 * nm, D, 0, map, NULL };
    d.l = M + CPCA_OVERSAMPLE;
    if (d.l > d.ns) d.l = d.ns;
    if (d.l > D) d.l = D;
    double *R = calloc((size_t)(M + 1) * (D ? D : 1), sizeof *R);
    int rc = R ? 0 : -1;
    d.mu = R;
    for (int j = 0; j < nm && !rc; j++)
        for (uint32_t q = c->v->first[d.mem[j]]; q < c->v->first[d.mem[j] + 1]; q++)
            for (int ch = 0; ch < 3; ch++) R[map[c->v->idx[q]]] += c->v->val[3 * (size_t)q + ch];
    for (int t = 0; t < D && !rc; t++) R[t] /= d.ns;
    if (!rc && d.l > 0) rc = principal(&d, M, R + D);
    for (int m = 0; m <= M && !rc; m++) rc = keep_row(c, k * (M + 1) + m, R + (size_t)m * D, U, D, tmp);
    if (!rc) refit(c, &d, R, c->cerr + 2 * k);
    free(R); free(map); free(U); free(tmp);
    return rc;
}

static void build_range(void *ctx, int b, int e, int thread) {
    (void)thread;
    build_ctx *c = ctx;
    for (int k = b; k < e; k++)
        if (build_cluster(c, k)) atomic_store(&c->failed, 1);   /* any thread's failure fails the build */
}

/* ---- the model -------------------------------------------------------------------------------- */

/* Allocates the model's per-vector and per-row arrays. */
static int model_alloc(cpca_model *m, int n, int C, int M, prt_error *err) {
    memset(m, 0, sizeof *m);
    m->nvecs = n, m->C = C, m->M = M;
    size_t R = (size_t)C * (M + 1);
    m->cluster = prt_calloc((size_t)n + 1, sizeof *m->cluster, err);
    m->w = m->cluster ? prt_calloc(3 * (size_t)n * M + 1, sizeof *m->w, err) : NULL;
    m->first = m->w ? prt_calloc(R + 1, sizeof *m->first, err) : NULL;
    m->step = m->first ? prt_calloc(R, sizeof *m->step, err) : NULL;
    if (!m->step) { cpca_model_free(m); return -1; }
    return 0;
}

/* The rows' kept coefficients into one array per kind. */
static int merge_rows(cpca_model *m, build_ctx *c, prt_error *err) {
    int R = cpca_rows(m);
    for (int r = 0; r < R; r++) m->first[r + 1] = m->first[r] + (uint32_t)c->rcount[r];
    m->idx = prt_calloc((size_t)m->first[R] + 1, sizeof *m->idx, err);
    m->val = m->idx ? prt_calloc((size_t)m->first[R] + 1, sizeof *m->val, err) : NULL;
    if (!m->val) return -1;
    for (int r = 0; r < R; r++) {
        memcpy(m->idx + m->first[r], c->ridx[r], sizeof(uint16_t) * (size_t)c->rcount[r]);
        memcpy(m->val + m->first[r], c->rval[r], sizeof(float) * (size_t)c->rcount[r]);
    }
    return 0;
}

/* Members of each cluster in vector order: mem[mfirst[k] .. mfirst[k+1]). */
static void members(const uint16_t *cl, int n, int C, int *mfirst, int *mem) {
    memset(mfirst, 0, sizeof(int) * (size_t)(C + 1));
    for (int i = 0; i < n; i++) mfirst[cl[i] + 1]++;
    for (int k = 0; k < C; k++) mfirst[k + 1] += mfirst[k];
    int *pos = mfirst + C + 1;   /* scratch after mfirst (C + 1 more ints) */
    memcpy(pos, mfirst, sizeof(int) * (size_t)C);
    for (int i = 0; i < n; i++) mem[pos[cl[i]]++] = i;
}

int cpca_build(const cpca_vectors *v, const cpca_params *p, cpca_model *out, prt_error *err) {
    PRT_CHECK(p->terms >= 1 && p->terms <= CPCA_MAX_TERMS && p->clusters >= 1 && p->clusters <= 4096 && p->coeffs >= 1);
    int C = p->clusters < v->n ? p->clusters : (v->n > 0 ? v->n : 1), M = p->terms, R = C * (M + 1);
    if (model_alloc(out, v->n, C, M, err)) return -1;
    int *mfirst = prt_calloc(2 * (size_t)C + 2, sizeof *mfirst, err), *mem = mfirst ? prt_calloc((size_t)v->n + 1, sizeof *mem, err) : NULL;
    build_ctx c = { v, p, out, mfirst, mem, NULL, NULL, NULL, NULL, 0 };
    atomic_init(&c.failed, 0);
    c.ridx = mem ? calloc((size_t)R, sizeof *c.ridx) : NULL;
    c.rval = c.ridx ? calloc((size_t)R, sizeof *c.rval) : NULL;
    c.rcount = c.rval ? calloc((size_t)R, sizeof *c.rcount) : NULL;
    c.cerr = c.rcount ? calloc(2 * (size_t)C, sizeof *c.cerr) : NULL;
    int rc = c.cerr ? 0 : -1;
    if (!rc && v->n > 0) rc = kmeans(v, C, p->nthreads, out->cluster);
    if (!rc) {
        members(out->cluster, v->n, C, mfirst, mem);
        prt_parallel_for(C, 1, p->nthreads, build_range, &c);
        rc = atomic_load(&c.failed) ? -1 : merge_rows(out, &c, err);
        for (int k = 0; k < C; k++) out->err2 += c.cerr[2 * k], out->norm2 += c.cerr[2 * k + 1];   /* in cluster order */
    }
    for (int r = 0; c.rcount && r < R; r++) { free(c.ridx[r]); free(c.rval[r]); }
    free(c.ridx); free(c.rval); free(c.rcount); free(c.cerr); free(mfirst); free(mem);
    if (rc) {
        cpca_model_free(out);
        return prt_fail(err, "cpca: out of memory building %d clusters of %d vectors", C, v->n);
    }
    return 0;
}
