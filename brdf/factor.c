/* factor.c - separable BRDF approximation by SVD (section 3.3, Eq. 1, 10, 11).
 *
 * The BRDF is tabulated as M[view][light] over the texel centres inside the
 * projected unit disk (Eq. 10) or over the whole polar grid (Eq. 11), cosine
 * left out so M is symmetric (section 4). Each colour channel is factored and
 * the K largest terms give light maps sqrt(sigma) u and view maps sqrt(sigma) v.
 *
 * Why a symmetric eigensolver: by reciprocity M = Q D Q' (section 3.3.1), so
 * sigma = |lambda|, u = q, v = sign(lambda) q. We only need the K eigenpairs of
 * largest magnitude plus all eigenvalues (for the error curve), so we reduce to
 * tridiagonal form once (dsytrd), get every eigenvalue in O(n^2) (dsterf), then
 * the K wanted vectors (dstemr on the two ends of the spectrum) and back-
 * transform only those (dormtr). Measured on this 2-core machine (shared, so
 * minimum of 5 runs; one 1810 x 1810 channel, paper-as at res 48, K = 4):
 *     dsytrd+dstemr (double) 0.35 s    ssytrd+sstemr (single) 0.24 s
 *     dgesdd                 1.8 s     sgesdd                 0.8 s (29 s, and a
 *                                      rank-3 answer, on a rank-1 Lambert matrix)
 * AUTO uses the double eigensolver: single precision's backward error (~n eps
 * ||M||, up to 1e-5 of sigma_1) blurs the numerical rank (a Lambert matrix came
 * out rank 2 with one BLAS thread; exact-rank Lafortune lobes keep a 10x margin
 * instead of 2000x) and breaks the 1e-5 reconstruction bound, for ~0.1 s saved.
 * Two shortcuts make common cases cheap: channels whose tabulations are identical
 * or proportional (grey or uniformly tinted BRDFs) are factored once, and a
 * rank-1 channel (Lambertian) is detected in O(n^2) and factored exactly.
 *
 * Texels outside the disk are filled from their nearest inside texel so
 * bilinear lookups near the horizon do not fade to zero. Lookups are plain
 * bilinear fetches from [res*res][K][3] arrays: no allocation, no trigonometry
 * for the grid parameterization.
 *
 * Why one BLAS thread: OpenBLAS sizes its pool by the cores the process may use, and a blocked
 * reduction (dsytrd's symmetric matrix-vector products) sums in an order that depends on the
 * thread count, so the last bits of the factors, and of every transport vector after them, would
 * move with taskset or an MPI rank's core binding. brdf_factorize fixes OpenBLAS at one
 * thread: the factors are then the same bits on any core count (tests/test_shard.c, "binding").
 * It costs no time: one 1810 x 1810 reduction is too small for a second thread to pay off. */
#include "factor.h"
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* OpenBLAS's own API (its cblas.h, which Debian's alternatives may point elsewhere): the one
 * library the Makefile links for BLAS, and liblapack's BLAS calls land in it. */
void openblas_set_num_threads(int num_threads);

#define PI 3.14159265358979323846
#define RANK_TOL 1e-5   /* singular values below this fraction of the largest count as zero */

/* ---------------------------------------------------------------- sampling grid */

/* Sample set: the texel centres used as directions, with sqrt of their projected solid angle. */
typedef struct fac_grid {
    int res, n;            /* grid resolution, number of samples */
    int *texel;            /* [n] texel index y*res + x of sample i */
    int *sample;           /* [res*res] sample index of a texel, -1 outside the disk */
    float (*dir)[3];       /* [n] local directions */
    double *sw;            /* [n] sqrt of relative projected solid angle (1 on the grid) */
} fac_grid;

static void grid_free(fac_grid *g) {
    free(g->texel), free(g->sample), free(g->dir), free(g->sw);
    memset(g, 0, sizeof *g);
}

/* Builds the sample set for res/param; returns 0 or -1 (OOM) with err. */
static int grid_build(fac_grid *g, int res, brdf_param param, prt_error *err) {
    memset(g, 0, sizeof *g);
    int nt = res * res;
    g->res = res;
    g->texel = prt_calloc((size_t)nt, sizeof *g->texel, err);
    g->sample = prt_calloc((size_t)nt, sizeof *g->sample, err);
    g->dir = prt_calloc((size_t)nt, sizeof *g->dir, err);
    g->sw = prt_calloc((size_t)nt, sizeof *g->sw, err);
    if (!g->texel || !g->sample || !g->dir || !g->sw) return grid_free(g), -1;
    double wsum = 0;
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++) {
            int t = y * res + x;
            double u = (x + 0.5) / res, v = (y + 0.5) / res, d[3], w;
            if (param == BRDF_PARAM_POLAR) {
                /* Eq. 11 inverted: phi = 2 pi x, cos(theta) = 1 - y^2. Projected solid angle
                 * cos dOmega = (1 - y^2) 2y dy 2pi dx, so the texel weight is y (1 - y^2). */
                double z = 1 - v * v, st = sqrt(fmax(0.0, 1 - z * z)), ph = 2 * PI * u;
                d[0] = st * cos(ph), d[1] = st * sin(ph), d[2] = z;
                w = v * (1 - v * v);
            } else {
                /* Eq. 10 inverted; only centres strictly inside the unit disk */
                d[0] = 2 * u - 1, d[1] = 2 * v - 1;
                double r2 = d[0] * d[0] + d[1] * d[1];
                if (r2 >= 1) { g->sample[t] = -1; continue; }
                d[2] = sqrt(1 - r2);
                w = 1;
            }
            g->sample[t] = g->n;
            g->texel[g->n] = t;
            for (int k = 0; k < 3; k++) g->dir[g->n][k] = (float)d[k];
            g->sw[g->n] = w;
            wsum += w;
            g->n++;
        }
    for (int i = 0; i < g->n; i++) g->sw[i] = sqrt(g->sw[i] * g->n / wsum);
    return 0;
}

/* ---------------------------------------------------------------- tabulation */

typedef struct tab_ctx {
    const brdf_params *p;
    const fac_grid *g;
    float *M[3];          /* [n][n] per channel, row = view, column = light */
} tab_ctx;

/* Rows [b,e) of the upper triangle, mirrored: M is exactly symmetric by construction. */
static void tab_rows(void *vctx, int b, int e, int thread) {
    tab_ctx *c = vctx;
    const fac_grid *g = c->g;
    size_t n = (size_t)g->n;
    for (int a = b; a < e; a++)
        for (int l = a; l < g->n; l++) {
            float rgb[3];
            brdf_eval(c->p, g->dir[l], g->dir[a], rgb);
            double s = g->sw[a] * g->sw[l];
            for (int k = 0; k < 3; k++) {
                float v = (float)(rgb[k] * s);
                c->M[k][(size_t)a * n + l] = v;
                c->M[k][(size_t)l * n + a] = v;
            }
        }
}

/* ---------------------------------------------------------------- solvers */

/* One channel's factorization: all n singular values (descending), and for the top k:
 * unit light vectors L[j][n] and view vectors V[j][n] with M ~ sum_j sig_j V_j L_j'. */
typedef struct chan_fac {
    double *sig;   /* [n] */
    double *L, *V; /* [k][n] */
    double rest2;  /* squared Frobenius norm beyond sig[0] not listed in sig (rank-1 path's residual) */
} chan_fac;

static void chan_free(chan_fac *c) {
    free(c->sig), free(c->L), free(c->V);
    memset(c, 0, sizeof *c);
}

/* Orders all n eigenvalues (ascending in w) by magnitude, two pointers from the ends.
 * order[j] = index into w of the j-th largest |lambda|. Returns how many of the first k
 * come from the low end (they are indices 0..nlow-1; the rest are the top k - nlow). */
static int order_by_magnitude(const double *w, int n, int k, int *order) {
    int lo = 0, hi = n - 1, nlow = 0;
    for (int j = 0; j < n; j++) {
        if (fabs(w[lo]) > fabs(w[hi])) order[j] = lo++;
        else order[j] = hi--;
        if (j == k - 1) nlow = lo;
    }
    return nlow;
}

/* The symmetric path in double or float: T is the element type, P the LAPACK prefix. */
#define SYM_SOLVER(NAME, T, SYTRD, STERF, STEMR, ORMTR)                                                              \
    static int NAME(const float *M, int n, int k, chan_fac *out, prt_error *err) {                                    \
        size_t nn = (size_t)n * n;                                                                                    \
        T *A = malloc(nn * sizeof *A), *d = malloc(n * sizeof *d), *e = malloc(n * sizeof *e);                      \
        T *tau = malloc(n * sizeof *tau), *d2 = malloc(n * sizeof *d2), *e2 = malloc(n * sizeof *e2);               \
        T *w = malloc(n * sizeof *w), *Z = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *Z);                         \
        T *wz = malloc(n * sizeof *wz), *Zs = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *Zs);                     \
        double *wd = malloc(n * sizeof *wd);                                                                          \
        int *order = malloc(n * sizeof *order);                                                                       \
        lapack_int *isup = malloc(2 * (size_t)n * sizeof *isup);                                                      \
        int rc = -1;                                                                                                  \
        if (!A || !d || !e || !tau || !d2 || !e2 || !w || !Z || !wz || !Zs || !wd || !order || !isup) {             \
            prt_fail(err, "brdf_factorize: out of memory (%d x %d matrix)", n, n);                                  \
            goto done;                                                                                                \
        }                                                                                                             \
        for (size_t i = 0; i < nn; i++) A[i] = (T)M[i];                                                               \
        lapack_int info = SYTRD(LAPACK_COL_MAJOR, 'L', n, A, n, d, e, tau);                                           \
        if (info) { prt_fail(err, "brdf_factorize: " #SYTRD " failed (info %d)", (int)info); goto done; }            \
        memcpy(w, d, n * sizeof *w);                                                                                  \
        memcpy(e2, e, n * sizeof *e2);                                                                                \
        info = STERF(n, w, e2);                                                                                       \
        if (info) { prt_fail(err, "brdf_factorize: " #STERF " failed (info %d)", (int)info); goto done; }            \
        for (int i = 0; i < n; i++) wd[i] = w[i];                                                                     \
        int nlow = order_by_magnitude(wd, n, k, order);                                                               \
        /* eigenvectors of the two ends of the spectrum: indices [0,nlow) and [n-nhigh, n) */                       \
        int nhigh = k - nlow;                                                                                         \
        for (int part = 0; part < 2; part++) {                                                                        \
            int cnt = part ? nhigh : nlow, il = part ? n - nhigh + 1 : 1, off = part ? nlow : 0;                    \
            if (!cnt) continue;                                                                                       \
            lapack_int m = 0;                                                                                         \
            lapack_logical tryrac = 1;                                                                                \
            memcpy(d2, d, n * sizeof *d2);                                                                            \
            memcpy(e2, e, n * sizeof *e2);                                                                            \
            info = STEMR(LAPACK_COL_MAJOR, 'V', 'I', n, d2, e2, 0, 0, il, il + cnt - 1, &m, wz, Zs, n, cnt, isup,     \
                         &tryrac);                                                                                    \
            if (info || m != cnt) {                                                                                   \
                prt_fail(err, "brdf_factorize: " #STEMR " failed (info %d)", (int)info);                            \
                goto done;                                                                                            \
            }                                                                                                         \
            memcpy(Z + (size_t)off * n, Zs, (size_t)cnt * n * sizeof *Z);                                            \
        }                                                                                                             \
        if (k > 0) {                                                                                                  \
            info = ORMTR(LAPACK_COL_MAJOR, 'L', 'L', 'N', n, k, A, n, tau, Z, n);                                    \
            if (info) { prt_fail(err, "brdf_factorize: " #ORMTR " failed (info %d)", (int)info); goto done; }        \
        }                                                                                                             \
        out->sig = malloc(n * sizeof *out->sig);                                                                      \
        out->L = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *out->L);                                               \
        out->V = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *out->V);                                               \
        if (!out->sig || !out->L || !out->V) {                                                                        \
            prt_fail(err, "brdf_factorize: out of memory");                                                           \
            goto done;                                                                                                \
        }                                                                                                             \
        for (int j = 0; j < n; j++) out->sig[j] = fabs(wd[order[j]]);                                                 \
        for (int j = 0; j < k; j++) {                                                                                 \
            /* column of Z: low-end vectors first (ascending), then the high end (ascending) */                      \
            int idx = order[j], col = idx < nlow ? idx : nlow + (idx - (n - nhigh));                                  \
            double sgn = wd[idx] < 0 ? -1 : 1;                                                                        \
            for (int i = 0; i < n; i++) {                                                                             \
                double q = Z[(size_t)col * n + i];                                                                    \
                out->L[(size_t)j * n + i] = q;                                                                        \
                out->V[(size_t)j * n + i] = sgn * q;                                                                  \
            }                                                                                                         \
        }                                                                                                             \
        rc = 0;                                                                                                       \
    done:                                                                                                             \
        free(A), free(d), free(e), free(tau), free(d2), free(e2), free(w), free(Z), free(wz), free(Zs), free(wd);    \
        free(order), free(isup);                                                                                      \
        if (rc) chan_free(out);                                                                                       \
        return rc;                                                                                                    \
    }

SYM_SOLVER(solve_sym_d, double, LAPACKE_dsytrd, LAPACKE_dsterf, LAPACKE_dstemr, LAPACKE_dormtr)
SYM_SOLVER(solve_sym_s, float, LAPACKE_ssytrd, LAPACKE_ssterf, LAPACKE_sstemr, LAPACKE_sormtr)

/* Full SVD (gesdd) in double or float. M[a][b] = M(view a, light b), so with M = U S V'
 * the view vectors are U's columns and the light vectors V's columns (VT's rows). */
#define SVD_SOLVER(NAME, T, GESDD)                                                                                    \
    static int NAME(const float *M, int n, int k, chan_fac *out, prt_error *err) {                                    \
        size_t nn = (size_t)n * n;                                                                                    \
        T *A = malloc(nn * sizeof *A), *U = malloc(nn * sizeof *U), *VT = malloc(nn * sizeof *VT);                  \
        T *S = malloc(n * sizeof *S);                                                                                 \
        int rc = -1;                                                                                                  \
        out->sig = malloc(n * sizeof *out->sig);                                                                      \
        out->L = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *out->L);                                               \
        out->V = malloc((size_t)n * (k > 0 ? k : 1) * sizeof *out->V);                                               \
        if (!A || !U || !VT || !S || !out->sig || !out->L || !out->V) {                                               \
            prt_fail(err, "brdf_factorize: out of memory (%d x %d SVD)", n, n);                                     \
            goto done;                                                                                                \
        }                                                                                                             \
        /* column-major A(a,b) = M[b][a]: the transpose, i.e. M(light, view) */                                       \
        for (size_t i = 0; i < nn; i++) A[i] = (T)M[i];                                                               \
        lapack_int info = GESDD(LAPACK_COL_MAJOR, 'S', n, n, A, n, S, U, n, VT, n);                                   \
        if (info) { prt_fail(err, "brdf_factorize: " #GESDD " failed (info %d)", (int)info); goto done; }            \
        for (int j = 0; j < n; j++) out->sig[j] = S[j];                                                               \
        /* A = M' = U S VT: U(:,j) is a function of the light (row of M'), VT(j,:) of the view */                    \
        for (int j = 0; j < k; j++)                                                                                   \
            for (int i = 0; i < n; i++) {                                                                             \
                out->L[(size_t)j * n + i] = U[(size_t)j * n + i];                                                     \
                out->V[(size_t)j * n + i] = VT[(size_t)i * n + j];                                                    \
            }                                                                                                         \
        rc = 0;                                                                                                       \
    done:                                                                                                             \
        free(A), free(U), free(VT), free(S);                                                                          \
        if (rc) chan_free(out);                                                                                       \
        return rc;                                                                                                    \
    }

SVD_SOLVER(solve_svd_d, double, LAPACKE_dgesdd)
SVD_SOLVER(solve_svd_s, float, LAPACKE_sgesdd)

/* Rank-1 shortcut (Lambertian channels, section 3.3.1): if M = m m'/M_pp up to 1e-6 of ||M||
 * for the largest diagonal entry p and its column m (or M = 0), writes the exact one-term
 * factorization and returns 1; otherwise 0. O(n^2) instead of a tridiagonal reduction. */
static int try_rank1(const float *M, int n, int k, chan_fac *out, prt_error *err) {
    int p = 0;
    double norm2 = 0;
    for (int i = 0; i < n; i++)
        if (M[(size_t)i * n + i] > M[(size_t)p * n + p]) p = i;
    double mpp = M[(size_t)p * n + p], resid2 = 0;
    const float *m = M + (size_t)p * n; /* row p = column p */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double a = M[(size_t)i * n + j], r = mpp > 0 ? a - (double)m[i] * m[j] / mpp : a;
            norm2 += a * a, resid2 += r * r;
        }
    if (norm2 > 0 && (!(mpp > 0) || resid2 > 1e-12 * norm2)) return 0;
    out->sig = calloc((size_t)n, sizeof *out->sig);
    out->L = calloc((size_t)n * (k > 0 ? k : 1), sizeof *out->L);
    out->V = calloc((size_t)n * (k > 0 ? k : 1), sizeof *out->V);
    if (!out->sig || !out->L || !out->V) {
        chan_free(out);
        return prt_fail(err, "brdf_factorize: out of memory");
    }
    if (norm2 > 0) {
        /* M ~ sigma q q' with q = m / |m|, sigma = |m|^2 / M_pp */
        double mm = 0;
        for (int i = 0; i < n; i++) mm += (double)m[i] * m[i];
        out->sig[0] = mm / mpp;
        out->rest2 = resid2;
        for (int i = 0; i < n && k > 0; i++) out->L[i] = out->V[i] = m[i] / sqrt(mm);
    }
    return 1;
}

/* Factors one channel with the chosen solver (or the rank-1 shortcut); flips each term so
 * its light vector sums >= 0. */
static int solve_channel(brdf_solver s, const float *M, int n, int k, chan_fac *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    int rc = try_rank1(M, n, k, out, err);
    if (rc < 0) return -1;
    if (rc > 0) return 0;
    switch (s) {
    case BRDF_SOLVER_SYM_S: rc = solve_sym_s(M, n, k, out, err); break;
    case BRDF_SOLVER_GESDD_D: rc = solve_svd_d(M, n, k, out, err); break;
    case BRDF_SOLVER_GESDD_S: rc = solve_svd_s(M, n, k, out, err); break;
    default: rc = solve_sym_d(M, n, k, out, err); break;
    }
    if (rc) return rc;
    for (int j = 0; j < k; j++) {
        double *L = out->L + (size_t)j * n, *V = out->V + (size_t)j * n, sum = 0;
        for (int i = 0; i < n; i++) sum += L[i];
        if (sum < 0)
            for (int i = 0; i < n; i++) L[i] = -L[i], V[i] = -V[i];
    }
    return 0;
}

/* ---------------------------------------------------------------- factorize */

/* Copies each outside-the-disk texel's K*3 values from the nearest inside texel (grid only). */
static void fill_outside(const fac_grid *g, float *map, int K) {
    int res = g->res, m = K * 3;
    for (int t = 0; t < res * res; t++) {
        if (g->sample[t] >= 0) continue;
        int tx = t % res, ty = t / res, best = -1;
        long bd = 0;
        for (int i = 0; i < g->n; i++) {
            int s = g->texel[i], dx = s % res - tx, dy = s / res - ty;
            long d2 = (long)dx * dx + (long)dy * dy;
            if (best < 0 || d2 < bd) best = s, bd = d2;
        }
        if (best >= 0) memcpy(map + (size_t)t * m, map + (size_t)best * m, (size_t)m * sizeof *map);
    }
}

/* True if a = s b (s >= 0) to within 1e-6 of max|a| (tabulation rounding is ~1e-7):
 * grey BRDFs (s = 1, bitwise) and e.g. coloured Lambert or coloured-metal Phong. */
static bool channels_proportional(const float *a, const float *b, size_t nn, double *s) {
    if (!memcmp(a, b, nn * sizeof *a)) return *s = 1, true;
    size_t p = 0;
    double amax = 0;
    for (size_t i = 0; i < nn; i++) {
        if (fabsf(b[i]) > fabsf(b[p])) p = i;
        amax = fmax(amax, fabs(a[i]));
    }
    if (b[p] == 0) return amax == 0 ? (*s = 0, true) : false;
    double r = (double)a[p] / b[p];
    if (!(r >= 0)) return false;
    for (size_t i = 0; i < nn; i++)
        if (fabs(a[i] - r * b[i]) > 1e-6 * amax) return false;
    *s = r;
    return true;
}

/* The three channels' factorizations: channel c is scale[c] times cf[src[c]] (src[c] == c
 * when it was factored itself). */
typedef struct fac_channels {
    chan_fac cf[3];
    int src[3];
    double scale[3];
} fac_channels;

/* Copies desc (NULL: defaults) into *d with zero fields defaulted, and validates p and *d.
 * Returns 0, or -1 with err set. */
static int factor_desc_resolve(const brdf_params *p, const brdf_factor_desc *desc, brdf_factor_desc *d, prt_error *err) {
    memset(d, 0, sizeof *d);
    if (desc) *d = *desc;
    if (d->max_terms == 0) d->max_terms = 4;
    if (d->res == 0) d->res = BRDF_DEFAULT_RES;
    if (!p || (unsigned)p->type > BRDF_BECKMANN) return prt_fail(err, "brdf_factorize: invalid BRDF parameters");
    if (d->max_terms < 1 || d->max_terms > BRDF_MAX_SIGMA)
        return prt_fail(err, "brdf_factorize: max_terms %d out of range [1,%d]", d->max_terms, BRDF_MAX_SIGMA);
    if (d->res < 4 || d->res > 256) return prt_fail(err, "brdf_factorize: resolution %d out of range [4,256]", d->res);
    if (!(d->error_target >= 0) || !isfinite(d->error_target))
        return prt_fail(err, "brdf_factorize: error target %g must be >= 0", d->error_target);
    if (d->param != BRDF_PARAM_GRID && d->param != BRDF_PARAM_POLAR)
        return prt_fail(err, "brdf_factorize: unknown parameterization %d", (int)d->param);
    if ((unsigned)d->solver > BRDF_SOLVER_GESDD_S) return prt_fail(err, "brdf_factorize: unknown solver %d", (int)d->solver);
    return 0;
}

/* Tabulates p on grid g and factors each channel into kmax terms; channels with identical or
 * proportional tabulations share one factorization. Returns 0, or -1 with err set (what was
 * factored stays in ch for the caller to free). */
static int factor_channels(const brdf_params *p, const fac_grid *g, brdf_solver solver, int kmax, fac_channels *ch,
                           prt_error *err) {
    int n = g->n;
    size_t nn = (size_t)n * n;
    float *M = malloc(3 * nn * sizeof *M);
    if (!M) return prt_fail(err, "brdf_factorize: out of memory tabulating %d x %d directions", n, n);
    tab_ctx tc = { p, g, { M, M + nn, M + 2 * nn } };
    prt_parallel_for(n, 16, 0, tab_rows, &tc);
    for (int c = 0; c < 3; c++) ch->src[c] = c, ch->scale[c] = 1;
    for (int c = 1; c < 3; c++)
        for (int o = 0; o < c; o++)
            if (ch->src[o] == o && channels_proportional(tc.M[c], tc.M[o], nn, &ch->scale[c])) { ch->src[c] = o; break; }
    int rc = 0;
    for (int c = 0; c < 3 && !rc; c++)
        if (ch->src[c] == c && solve_channel(solver, tc.M[c], n, kmax, &ch->cf[c], err)) rc = -1;
    free(M);
    return rc;
}

/* Fills out->nsigma, sigma and rel_rms: the relative error of k terms from the full spectra
 * of n singular values (tails summed small-first). */
static void factor_spectra(const fac_channels *ch, int n, brdf_factor *out) {
    out->nsigma = n < BRDF_MAX_SIGMA ? n : BRDF_MAX_SIGMA;
    double total = 0, tail[BRDF_MAX_SIGMA + 1] = { 0 };
    for (int c = 0; c < 3; c++) {
        const chan_fac *f = &ch->cf[ch->src[c]];
        const double *sg = f->sig, sc = ch->scale[c], s2 = sc * sc;
        double acc = 0;
        for (int j = n - 1; j >= 0; j--) {
            acc += sg[j] * sg[j] * s2;
            if (j == 0) acc += f->rest2 * s2;
            if (j <= out->nsigma) tail[j] += acc;
        }
        /* the rank-1 residual belongs to every tail from k = 1 on */
        for (int j = 1; j <= out->nsigma; j++) tail[j] += f->rest2 * s2;
        total += acc;
        for (int j = 0; j < out->nsigma; j++) out->sigma[c][j] = (float)(sg[j] * sc);
    }
    for (int k = 0; k <= out->nsigma; k++) out->rel_rms[k] = total > 0 ? (float)sqrt(tail[k] / total) : 0.0f;
}

/* K: the error target's smallest K (0: none), or kmax; never above the numerical rank, never 0. */
static int factor_terms(const fac_channels *ch, int kmax, double error_target, const brdf_factor *out) {
    double smax = 0;
    for (int c = 0; c < 3; c++) smax = fmax(smax, ch->cf[ch->src[c]].sig[0] * ch->scale[c]);
    int rank = 0;
    for (int c = 0; c < 3; c++) {
        int r = 0;
        while (r < kmax && ch->cf[ch->src[c]].sig[r] * ch->scale[c] > RANK_TOL * smax) r++;
        if (r > rank) rank = r;
    }
    int K = kmax;
    if (error_target > 0) {
        for (int k = 1; k <= kmax; k++)
            if (out->rel_rms[k] <= error_target) { K = k; break; }
    }
    if (rank < K) K = rank > 0 ? rank : 1;
    return K;
}

/* Allocates and fills out->light and out->view with K terms: light = sqrt(sigma) L, view =
 * sqrt(sigma) V, unweighted by the sample's sqrt weight; sets out->lambertian. Returns 0 or -1. */
static int factor_maps(const fac_channels *ch, const fac_grid *g, int K, brdf_param param, brdf_factor *out,
                       prt_error *err) {
    int n = g->n, nt = g->res * g->res;
    out->light = prt_calloc((size_t)nt * K * 3, sizeof *out->light, err);
    out->view = prt_calloc((size_t)nt * K * 3, sizeof *out->view, err);
    if (!out->light || !out->view) return -1;
    for (int c = 0; c < 3; c++) {
        const chan_fac *f = &ch->cf[ch->src[c]];
        for (int j = 0; j < K; j++) {
            double s = sqrt(f->sig[j] * ch->scale[c]);
            const double *L = f->L + (size_t)j * n, *V = f->V + (size_t)j * n;
            for (int i = 0; i < n; i++) {
                size_t at = ((size_t)g->texel[i] * K + j) * 3 + c;
                out->light[at] = (float)(s * L[i] / g->sw[i]);
                out->view[at] = (float)(s * V[i] / g->sw[i]);
            }
        }
    }
    if (param == BRDF_PARAM_GRID) {
        fill_outside(g, out->light, K);
        fill_outside(g, out->view, K);
    }
    /* Lambertian: one term whose view map is constant over the sampled texels */
    out->lambertian = K == 1;
    for (int c = 0; c < 3 && out->lambertian; c++) {
        float lo = out->view[(size_t)g->texel[0] * 3 + c], hi = lo;
        for (int i = 1; i < n; i++) {
            float v = out->view[(size_t)g->texel[i] * 3 + c];
            lo = v < lo ? v : lo, hi = v > hi ? v : hi;
        }
        if (hi - lo > 1e-4f * fmaxf(fabsf(hi), fabsf(lo))) out->lambertian = false;
    }
    return 0;
}

/* Tabulates and factors p (see factor.h): tabulate and factor each channel, spectra and
 * errors, choose K, build the maps. Returns 0, or -1 with err set. */
int brdf_factorize(const brdf_params *p, const brdf_factor_desc *desc, brdf_factor *out, prt_error *err) {
    double t0 = prt_now();
    memset(out, 0, sizeof *out);
    /* the same bits whatever cores this process has (see the top); nothing else in prt calls BLAS,
     * and setting it every call (never restoring) keeps concurrent calls on one thread too */
    openblas_set_num_threads(1);
    brdf_factor_desc d;
    if (factor_desc_resolve(p, desc, &d, err)) return -1;
    fac_grid g;
    if (grid_build(&g, d.res, d.param, err)) return -1;
    int kmax = d.max_terms < g.n ? d.max_terms : g.n, rc = -1;
    fac_channels ch;
    memset(&ch, 0, sizeof ch);
    if (!factor_channels(p, &g, d.solver, kmax, &ch, err)) {
        factor_spectra(&ch, g.n, out);
        int K = factor_terms(&ch, kmax, d.error_target, out);
        if (!factor_maps(&ch, &g, K, d.param, out, err)) {
            out->K = K;
            out->res = d.res;
            out->param = d.param;
            rc = 0;
        }
    }
    for (int c = 0; c < 3; c++) chan_free(&ch.cf[c]);
    grid_free(&g);
    if (rc) brdf_factor_free(out);
    else out->seconds = prt_now() - t0;
    return rc;
}

/* Frees the maps and zeroes f. */
void brdf_factor_free(brdf_factor *f) {
    if (!f) return;
    free(f->light), free(f->view);
    memset(f, 0, sizeof *f);
}

/* Deep copy of src into dst (dst's old contents are not freed). Returns 0 or -1 (OOM). */
int brdf_factor_copy(brdf_factor *dst, const brdf_factor *src, prt_error *err) {
    *dst = *src;
    dst->light = dst->view = NULL;
    size_t cnt = (size_t)src->res * src->res * src->K * 3;
    if (src->light) {
        if (!(dst->light = prt_calloc(cnt, sizeof *dst->light, err))) return -1;
        memcpy(dst->light, src->light, cnt * sizeof *dst->light);
    }
    if (src->view) {
        if (!(dst->view = prt_calloc(cnt, sizeof *dst->view, err))) {
            free(dst->light), dst->light = NULL;
            return -1;
        }
        memcpy(dst->view, src->view, cnt * sizeof *dst->view);
    }
    return 0;
}

/* ---------------------------------------------------------------- lookups */

/* Texture coordinates of local w (Eq. 10 or Eq. 11); false below the horizon. */
bool brdf_factor_uv(const brdf_factor *f, const float w[3], float *x, float *y) {
    if (!(w[2] > 0)) {
        *x = *y = 0;
        return false;
    }
    float u, v;
    if (f->param == BRDF_PARAM_POLAR) {
        u = atan2f(w[1], w[0]) * (float)(0.5 / PI);
        if (u < 0) u += 1;
        if (!(u < 1)) u = 0;
        v = sqrtf(fmaxf(0.0f, 1 - w[2]));
    } else {
        u = 0.5f * (w[0] + 1), v = 0.5f * (w[1] + 1);
        u = u < 0 ? 0 : u > 1 ? 1 : u;
    }
    v = v < 0 ? 0 : v > 1 ? 1 : v;
    *x = u, *y = v;
    return true;
}

/* Bilinear fetch of all K*3 values of map at (x, y); x wraps for the polar parameterization. */
static void fetch(const brdf_factor *f, const float *restrict map, float x, float y, float *restrict out) {
    int res = f->res, m = f->K * 3;
    float fx = x * res - 0.5f, fy = y * res - 0.5f;
    float flx = floorf(fx), fly = floorf(fy), tx = fx - flx, ty = fy - fly;
    int x0 = (int)flx, y0 = (int)fly, x1 = x0 + 1, y1 = y0 + 1;
    if (f->param == BRDF_PARAM_POLAR) {
        x0 = x0 < 0 ? x0 + res : x0 >= res ? x0 - res : x0;
        x1 = x1 < 0 ? x1 + res : x1 >= res ? x1 - res : x1;
    } else {
        x0 = x0 < 0 ? 0 : x0 > res - 1 ? res - 1 : x0;
        x1 = x1 < 0 ? 0 : x1 > res - 1 ? res - 1 : x1;
    }
    y0 = y0 < 0 ? 0 : y0 > res - 1 ? res - 1 : y0;
    y1 = y1 < 0 ? 0 : y1 > res - 1 ? res - 1 : y1;
    const float *restrict a = map + ((size_t)y0 * res + x0) * m, *restrict b = map + ((size_t)y0 * res + x1) * m;
    const float *restrict c = map + ((size_t)y1 * res + x0) * m, *restrict d = map + ((size_t)y1 * res + x1) * m;
    float w00 = (1 - tx) * (1 - ty), w01 = tx * (1 - ty), w10 = (1 - tx) * ty, w11 = tx * ty;
    for (int i = 0; i < m; i++) out[i] = w00 * a[i] + w01 * b[i] + w10 * c[i] + w11 * d[i];
}

/* Light maps g_k(w) for all K terms and 3 channels into out[K*3]; zeros below the horizon. */
void brdf_factor_light(const brdf_factor *f, const float w[3], float *out) {
    float x, y;
    if (!brdf_factor_uv(f, w, &x, &y)) {
        memset(out, 0, (size_t)f->K * 3 * sizeof *out);
        return;
    }
    fetch(f, f->light, x, y, out);
}

void brdf_factor_lambert_light(const brdf_factor *f, float g[3]) {
    const float up[3] = { 0, 0, 1 };
    float all[BRDF_MAX_SIGMA * 3];
    brdf_factor_light(f, up, all);
    memcpy(g, all, 3 * sizeof *g);
}

/* View maps h_k(w) for all K terms and 3 channels into out[K*3]; zeros below the horizon. */
void brdf_factor_view(const brdf_factor *f, const float w[3], float *out) {
    float x, y;
    if (!brdf_factor_uv(f, w, &x, &y)) {
        memset(out, 0, (size_t)f->K * 3 * sizeof *out);
        return;
    }
    fetch(f, f->view, x, y, out);
}

/* sum_{k<K} g_k(wi) h_k(wo) per channel (K clamped to [0, f->K]). */
void brdf_factor_eval(const brdf_factor *f, const float wi[3], const float wo[3], int K, float rgb[3]) {
    float g[BRDF_MAX_SIGMA * 3], h[BRDF_MAX_SIGMA * 3];
    rgb[0] = rgb[1] = rgb[2] = 0;
    if (K > f->K) K = f->K;
    if (K <= 0 || !(wi[2] > 0) || !(wo[2] > 0)) return;
    brdf_factor_light(f, wi, g);
    brdf_factor_view(f, wo, h);
    for (int k = 0; k < K; k++)
        for (int c = 0; c < 3; c++) rgb[c] += g[k * 3 + c] * h[k * 3 + c];
}
