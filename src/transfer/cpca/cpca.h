/* cpca.h - clustered principal component analysis of transport vectors in Haar space (Sloan et
 * al. 2003, "Clustered principal components for precomputed radiance transfer"; Liu et al. 2004
 * apply it to all-frequency transfer in a wavelet basis): the model transfer_cpca.c stores.
 *
 * The samples are the transport vectors' channels x_s (vector i, channel c: s = 3i + c), each a
 * sparse vector of Haar coefficients of T/w (the representation's index space, CUBE_TEXELS). The
 * vectors are clustered by their transport (Lloyd's k-means on each vector's 256 largest channel-mean
 * coefficients, at most CPCA_KMEANS_ITERS iterations, seeded by index; every channel of a vector in
 * its vector's cluster), and each cluster k approximated as (Sloan Eq. 2)
 *     x_s ~ mu_k + sum_{m<M} w_sm b_km
 * with mu_k the cluster mean and b_km the M leading principal directions of its centred samples.
 * The mean and each basis vector are kept sparse (their `coeffs` largest coefficients), quantized
 * to 16 bits with a step per row, and the weights refit by least squares against what is kept, so
 * that the stored rows are the ones whose error is minimised. Unquantized and with every
 * coefficient kept, the squared error summed over a cluster's samples is the PCA energy dropped,
 * sum_{m>=M} lambda_m of its scatter matrix (what tests/test_cpca.c checks).
 *
 * Light change (Sloan Eq. 5): P_r = row_r . L per channel, once for each of the C (M + 1) rows
 * (sparse dot products), then per sample g_s = P_{k,0} + sum_m w_sm P_{k,m}: M multiply-adds.
 *
 * PCA. The leading directions come from a block subspace iteration on the centred samples (Halko,
 * Martinsson & Tropp 2011, Alg. 4.4, then Rayleigh-Ritz): l = M + CPCA_OVERSAMPLE columns, started
 * from X^T Omega with Omega a hash of (sample, column), CPCA_POWER iterations; each product costs
 * nnz(X) x l, where the Gram or covariance matrix of a cluster would cost its samples squared
 * times its union of indices. Exact when l covers the samples' rank, and within
 * (sigma_{l+1} / sigma_M)^(2q+1) of it otherwise.
 *
 * Determinism: every step reads vectors in index order and no sum depends on how the vectors or
 * clusters were shared out among threads, so the model is the same bits for any thread count.
 *
 * Ownership: a cpca_model owns its arrays (cpca_model_free). */
#ifndef PRT_CPCA_H
#define PRT_CPCA_H
#include "common.h"
#include "cubemap.h"
#include "prtio.h"

#define CPCA_OVERSAMPLE 4
#define CPCA_POWER 2
#define CPCA_KMEANS_ITERS 12
#define CPCA_MAX_TERMS 32

/* Sparse input vectors: vector i holds coefficients first[i] .. first[i+1]-1, indices ascending
 * below CUBE_TEXELS, values r, g, b at val[3c .. 3c+2]. */
typedef struct cpca_vectors {
    int n;
    const uint32_t *first;
    const uint32_t *idx;
    const float *val;
} cpca_vectors;

typedef struct cpca_params {
    int clusters;       /* C (at most the vectors) */
    int terms;          /* M, 1..CPCA_MAX_TERMS */
    int coeffs;         /* coefficients kept per row (mean or basis vector) */
    bool quantize;      /* 16-bit rows (what a file stores); false: floats (the tests' exact case) */
    int nthreads;       /* 0: all cores */
} cpca_params;

/* Row r = k (M + 1) + m of cluster k: m = 0 its mean, m >= 1 its basis vector m - 1. */
typedef struct cpca_model {
    int nvecs, C, M;
    uint16_t *cluster;  /* [nvecs] */
    float *w;           /* [3 nvecs M]: sample s = 3i + c, term m at s M + m */
    uint32_t *first;    /* [C (M + 1) + 1] row offsets */
    uint16_t *idx;      /* [first[R]] ascending within a row, < CUBE_TEXELS */
    float *val;         /* [first[R]] values (q x step when quantized) */
    float *step;        /* [C (M + 1)] 16-bit step of each row (0: unquantized or empty) */
    double err2, norm2; /* sums over the samples of |x - x^|^2 (the input's x, before the weights are
                         * rounded to float) and of |x|^2: the model's relative L2 error, for prt info */
} cpca_model;

/* Rows of m: C (M + 1). */
static inline int cpca_rows(const cpca_model *m) { return m->C * (m->M + 1); }

/* Clusters, analyses and compresses v into out (zeroed first). 0, or -1 with err (out of memory). */
int cpca_build(const cpca_vectors *v, const cpca_params *p, cpca_model *out, prt_error *err);
/* g[3i + c] = x_ic . L_c for every vector (the model's approximation of Eq. 5), nthreads 0: all. */
void cpca_light(const cpca_model *m, const float (*L)[4], float *g, int nthreads);
/* Vector i's channel c decoded densely into x[CUBE_TEXELS] (the model's x_s). */
void cpca_decode(const cpca_model *m, int i, int c, float *x);
/* Bytes the model takes in a file. */
size_t cpca_bytes(const cpca_model *m);

/* File layout (little-endian): i32 nvecs, C, M; u64 ncoefs; u16 cluster[nvecs]; f32 w[3 nvecs M];
 * u32 first[R + 1]; f32 step[R]; u16 idx[ncoefs]; i16 q[ncoefs] (val = q x step); f64 err2, norm2. The model must be
 * quantized (cpca_params.quantize). */
void cpca_write(prt_writer *w, const cpca_model *m);
/* Reads a model: sizes and allocation only (false with why[256] on a short or oversized one). */
bool cpca_read(prt_reader *r, cpca_model *m, char *why);
/* Every index and count of m against nvecs vectors: cluster ids < C, row offsets increasing and
 * ending at the total, indices ascending below CUBE_TEXELS, finite values. False with why[256]. */
bool cpca_check(const cpca_model *m, int nvecs, char *why);
void cpca_model_free(cpca_model *m);
#endif
