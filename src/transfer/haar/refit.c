/* refit.c - kept Haar coefficients refit to a light prior's expected light (refit.h).
 *
 * The normal equations' matrix Psi' V Psi over the kept Haar functions of a face is built entry by
 * entry from tables made once: each function of the orthonormal 2D Haar basis (haar.h) is constant
 * on the four quadrants of its square support, so for two functions a, b either their supports are
 * disjoint (0), the same square (the sum over the quadrants of a's value times b's times v summed over
 * the quadrant), or b's square lies in one quadrant of a's, where a is a constant: a's value there
 * times <v, psi_b>, the Haar coefficient of v. The tables hold the supports and quadrant values of
 * every function (read off their inverse transforms, so they follow haar.c whatever its order), the
 * quadrant sums of v at every size, and the Haar coefficients of v and of each probe's mean. */
#include "refit.h"
#include "haar.h"
#include "sparse.h"
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* OpenBLAS's own API (brdf/factor.c says why): one thread per call, so the result never depends on
 * the cores and concurrent calls from the precompute's threads stay on theirs. */
void openblas_set_num_threads(int num_threads);

enum { FACE = CUBE_RES * CUBE_RES, LOG_RES = 6, PYR = (FACE * 4 - 4) / 3 + 1 };

/* Haar function m of a face: square support of side 1 << lg at (x0, y0), value v[qy * 2 + qx] on its
 * quadrant (qx, qy). */
typedef struct refit_basis {
    uint16_t x0, y0;
    uint8_t lg;
    float v[4];
} refit_basis;

struct refit_tables {
    refit_basis basis[FACE];                 /* by morton index within a face */
    double qsum[6][PYR];                     /* per face, v summed over each square of side 2^h, the
                                              * levels h = 0 .. LOG_RES - 1 one after another (pyr_at) */
    float Iv[CUBE_TEXELS];                   /* <v, psi_m> per face, wavelet index order */
    int n;                                   /* probes */
    float Im[PRIOR_MAX_PROBES][CUBE_TEXELS]; /* <m_p, psi_m> */
    float v[CUBE_TEXELS], m[PRIOR_MAX_PROBES][CUBE_TEXELS];   /* the prior's texels */
};

/* Offset in a face's pyramid of the square of side 2^h at (x, y) (in units of its side). */
static size_t pyr_at(int h, int x, int y) {
    size_t o = 0;
    for (int k = 0; k < h; k++) o += (size_t)(FACE >> (2 * k));
    return o + (size_t)y * (size_t)(CUBE_RES >> h) + (size_t)x;
}

/* The support and quadrant values of every Haar function, from the inverse transform of a unit
 * coefficient (tmp: 2 x FACE floats). */
static void basis_table(refit_basis *B, float *tmp) {
    float *img = tmp, *t2 = tmp + FACE, unit[FACE];
    for (int m = 0; m < FACE; m++) {
        memset(unit, 0, sizeof unit);
        unit[m] = 1;
        haar_face_from_morton(unit, CUBE_RES, img);
        haar_inverse(img, CUBE_RES, t2);
        int x0 = CUBE_RES, y0 = CUBE_RES, x1 = -1;
        for (int j = 0; j < FACE; j++)
            if (img[j] != 0) {
                x0 = j % CUBE_RES < x0 ? j % CUBE_RES : x0;
                y0 = j / CUBE_RES < y0 ? j / CUBE_RES : y0;
                x1 = j % CUBE_RES > x1 ? j % CUBE_RES : x1;
            }
        int side = x1 - x0 + 1, lg = 0;
        while ((1 << lg) < side) lg++;
        PRT_CHECK(x1 >= 0 && (1 << lg) == side && lg >= 1);   /* a square of side 2^lg, lg >= 1 */
        B[m] = (refit_basis){ .x0 = (uint16_t)x0, .y0 = (uint16_t)y0, .lg = (uint8_t)lg };
        for (int q = 0; q < 4; q++)
            B[m].v[q] = img[(y0 + (q >> 1) * (side / 2)) * CUBE_RES + x0 + (q & 1) * (side / 2)];
    }
}

/* Face f's texels of x (texel layout) summed over every square (pyr_at) into P. */
static void pyramid(const float *x, double *P) {
    for (int j = 0; j < FACE; j++) P[pyr_at(0, j % CUBE_RES, j / CUBE_RES)] = x[j];
    for (int h = 1; h < LOG_RES; h++)
        for (int y = 0; y < CUBE_RES >> h; y++)
            for (int xx = 0; xx < CUBE_RES >> h; xx++)
                P[pyr_at(h, xx, y)] = P[pyr_at(h - 1, 2 * xx, 2 * y)] + P[pyr_at(h - 1, 2 * xx + 1, 2 * y)] +
                                      P[pyr_at(h - 1, 2 * xx, 2 * y + 1)] + P[pyr_at(h - 1, 2 * xx + 1, 2 * y + 1)];
}

/* The Haar coefficients of the texels x (CUBE_TEXELS, texel layout) in wavelet index order into H.
 * tmp: 2 x FACE floats. */
static void to_haar(const float *x, float *H, float *tmp) {
    for (int f = 0; f < 6; f++) {
        memcpy(tmp, x + (size_t)f * FACE, FACE * sizeof *tmp);
        haar_forward(tmp, CUBE_RES, tmp + FACE);
        haar_face_to_morton(tmp, CUBE_RES, H + (size_t)f * FACE);
    }
}

/* See refit.h. */
refit_tables *refit_create(const prior_texels *pt, prt_error *err) {
    if (pt->n < 1 || pt->n > PRIOR_MAX_PROBES) return prt_fail(err, "refit: %d probes (1..%d)", pt->n, PRIOR_MAX_PROBES), NULL;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        bool ok = pt->var[j] > 0 && isfinite(pt->var[j]);
        for (int p = 0; p < pt->n; p++) ok &= isfinite(pt->mean[p][j]);
        if (!ok) return prt_fail(err, "refit: prior texel %d is %g (must be positive and finite)", j, pt->var[j]), NULL;
    }
    openblas_set_num_threads(1);
    refit_tables *rt = prt_calloc(1, sizeof *rt, err);
    float *tmp = rt ? prt_calloc(2 * FACE, sizeof *tmp, err) : NULL;
    if (!tmp) { free(rt); return NULL; }
    basis_table(rt->basis, tmp);
    memcpy(rt->v, pt->var, sizeof rt->v);
    rt->n = pt->n;
    for (int f = 0; f < 6; f++) pyramid(pt->var + (size_t)f * FACE, rt->qsum[f]);
    to_haar(pt->var, rt->Iv, tmp);
    for (int p = 0; p < pt->n; p++) {
        memcpy(rt->m[p], pt->mean[p], sizeof rt->m[p]);
        to_haar(pt->mean[p], rt->Im[p], tmp);
    }
    free(tmp);
    return rt;
}

void refit_destroy(refit_tables *rt) { free(rt); }

/* See refit.h: the matrix, the right-hand sides (3 x FACE texels for the channels, then FACE x 2 of
 * transform scratch) and the probes' dot products. */
size_t refit_scratch_size(int n) {
    return (size_t)n * n * sizeof(double) + 3 * (size_t)n * sizeof(double) + 5 * (size_t)FACE * sizeof(float);
}

/* <v psi_a, psi_b> on face f, wavelet indices a, b within the face (the file's header says how). */
static double gram_v(const refit_tables *rt, int f, uint32_t a, uint32_t b) {
    const refit_basis *A = &rt->basis[a], *B = &rt->basis[b];
    if (A->lg < B->lg) {
        const refit_basis *t = A; A = B; B = t;
        uint32_t u = a; a = b; b = u;
    }
    int sa = 1 << A->lg, half = sa / 2;
    if (A->lg == B->lg) {
        if (A->x0 != B->x0 || A->y0 != B->y0) return 0;
        int h = A->lg - 1;
        double s = 0;
        for (int q = 0; q < 4; q++)
            s += (double)A->v[q] * B->v[q] * rt->qsum[f][pyr_at(h, (A->x0 >> h) + (q & 1), (A->y0 >> h) + (q >> 1))];
        return s;
    }
    if (B->x0 < A->x0 || B->x0 >= A->x0 + sa || B->y0 < A->y0 || B->y0 >= A->y0 + sa) return 0;
    int q = (B->x0 >= A->x0 + half) + 2 * (B->y0 >= A->y0 + half);
    return (double)A->v[q] * rt->Iv[(size_t)f * FACE + b];
}

/* The matrix of refit.h's normal equations for the n kept functions K (within-face indices) into G. */
static void normal_matrix(const refit_tables *rt, int f, const uint32_t *K, int n, double *G) {
    const size_t o = (size_t)f * FACE;
    for (int k = 0; k < n; k++)
        for (int l = 0; l <= k; l++) {
            double s = gram_v(rt, f, K[k], K[l]);
            for (int p = 0; p < rt->n; p++) s += (double)rt->Im[p][o + K[k]] * rt->Im[p][o + K[l]];
            G[(size_t)k * n + l] = G[(size_t)l * n + k] = s;
        }
}

/* Channel x's face f as T/w texels into img; false when not finite. tmp: FACE floats. */
static bool face_texels(const float *x, int f, float *img, float *tmp) {
    const float *c = x + (size_t)f * FACE;
    for (int m = 0; m < FACE; m++)
        if (!isfinite(c[m])) return false;
    haar_face_from_morton(c, CUBE_RES, img);
    haar_inverse(img, CUBE_RES, tmp);
    return true;
}

/* Column c of the right-hand sides B (n x 3, row-major): Psi' V T + sum_p (Psi' m_p)(m_p . T) for the
 * texels T of one channel (used up). tmp: 2 x FACE floats. */
static void rhs(const refit_tables *rt, int f, float *T, const uint32_t *K, int n, int c, double *B, float *tmp) {
    const size_t o = (size_t)f * FACE;
    double mt[PRIOR_MAX_PROBES];
    for (int p = 0; p < rt->n; p++) {
        double s = 0;
        for (int j = 0; j < FACE; j++) s += (double)rt->m[p][o + j] * T[j];
        mt[p] = s;
    }
    for (int j = 0; j < FACE; j++) T[j] *= rt->v[o + j];
    haar_forward(T, CUBE_RES, tmp);
    haar_face_to_morton(T, CUBE_RES, tmp);
    for (int k = 0; k < n; k++) {
        double s = tmp[K[k]];
        for (int p = 0; p < rt->n; p++) s += (double)rt->Im[p][o + K[k]] * mt[p];
        B[3 * k + c] = s;
    }
}

/* Whether y = *a x on a face (FACE floats each), to float rounding (1e-6 of the largest |y|): a
 * material of one colour's channels, whose refit is then one solve (linear in T). Why: the direct pass
 * of a Lambert or single-colour material gives such vectors, and the right-hand sides' transforms are
 * most of the refit's time. */
static bool proportional(const float *x, const float *y, double *a) {
    if (!memcmp(x, y, FACE * sizeof *x)) {   /* a grey material: the same bits */
        *a = 1;
        return true;
    }
    float mx = 0, my = 0;
    int big = 0;
    for (int m = 0; m < FACE; m++) {   /* no libm calls: this runs per face and channel */
        float ax = fabsf(x[m]), ay = fabsf(y[m]);
        big = ax > mx ? m : big;
        mx = ax > mx ? ax : mx;
        my = ay > my ? ay : my;
    }
    if (!(mx > 0) || !isfinite(mx) || !isfinite(my)) return false;
    float r = y[big] / x[big], tol = 1e-6f * my;
    bool ok = true;
    for (int m = 0; m < FACE; m++) ok &= fabsf(y[m] - r * x[m]) <= tol;
    if (ok) *a = r;
    return ok;
}

/* See refit.h. */
bool refit_face(const refit_tables *rt, int f, const float *r, const float *g, const float *b, const uint32_t *kept,
                int n, float *out, void *scratch) {
    if (n < 1 || n > REFIT_MAX_N) return false;
    double *G = scratch, *B = G + (size_t)n * n;
    float *img = (float *)(void *)(B + 3 * (size_t)n), *tmp = img + 3 * FACE;
    uint32_t K[REFIT_MAX_N];
    for (int k = 0; k < n; k++) {
        PRT_CHECK(kept[k] / FACE == (uint32_t)f);
        K[k] = kept[k] % FACE;
    }
    const float *ch[3] = { r, g, b };
    double a[3] = { 1, 1, 1 };
    int src[3] = { 0, 1, 2 };   /* the channel whose solution each takes, times a[c] */
    for (int c = 1; c < 3; c++)
        if (proportional(ch[0] + (size_t)f * FACE, ch[c] + (size_t)f * FACE, &a[c])) src[c] = 0;
    for (int c = 0; c < 3; c++)
        if (src[c] == c && !face_texels(ch[c], f, img + (size_t)c * FACE, tmp)) return false;
    for (int c = 0; c < 3; c++)
        if (src[c] == c) rhs(rt, f, img + (size_t)c * FACE, K, n, c, B, tmp);
    for (int k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            if (src[c] != c) B[3 * k + c] = 0;
    normal_matrix(rt, f, K, n, G);
    if (LAPACKE_dpotrf(LAPACK_ROW_MAJOR, 'L', n, G, n) != 0) return false;
    if (LAPACKE_dpotrs(LAPACK_ROW_MAJOR, 'L', n, 3, G, n, B, 3) != 0) return false;
    for (int k = 0; k < 3 * n; k++)
        if (!isfinite(B[k])) return false;
    for (int k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) out[3 * k + c] = (float)(a[c] * B[3 * k + src[c]]);
    return true;
}

/* One channel's coordinate descent (refit_quantize): q the integer multiples, x the ideal values over
 * the step (stride 3), G the matrix, g scratch (n). At most REFIT_SWEEPS passes over the coordinates. */
#define REFIT_SWEEPS 8
static void descend(const double *G, int n, const float *x, int qmax, int *q, double *g) {
    for (int k = 0; k < n; k++) {   /* g = G (q - x): half the gradient of (q - x)' G (q - x) */
        double s = 0;
        for (int l = 0; l < n; l++) s += G[(size_t)k * n + l] * (q[l] - (double)x[3 * l]);
        g[k] = s;
    }
    for (int sweep = 0; sweep < REFIT_SWEEPS; sweep++) {
        bool moved = false;
        for (int k = 0; k < n; k++) {
            int d = g[k] > 0 ? -1 : 1;   /* the change is 2 d g_k + G_kk: taken when negative */
            if (!(2 * d * g[k] + G[(size_t)k * n + k] < 0) || abs(q[k] + d) > qmax) continue;
            q[k] += d;
            for (int l = 0; l < n; l++) g[l] += d * G[(size_t)l * n + k];
            moved = true;
        }
        if (!moved) break;
    }
}

/* See refit.h. */
void refit_quantize(const refit_tables *rt, int f, const uint32_t *kept, int n, const float step[3], int qmax, float *val,
                    void *scratch) {
    PRT_CHECK(n >= 1 && n <= REFIT_MAX_N && qmax > 0);
    double *G = scratch, *g = G + (size_t)n * n;
    uint32_t K[REFIT_MAX_N];
    for (int k = 0; k < n; k++) K[k] = kept[k] % FACE;
    normal_matrix(rt, f, K, n, G);
    int q[REFIT_MAX_N], q0[REFIT_MAX_N];
    float x0[3 * REFIT_MAX_N];
    for (int c = 0; c < 3; c++) {
        float x[3 * REFIT_MAX_N];
        bool same = c > 0;   /* a channel the same over its step as channel 0 (one colour) takes its q */
        for (int k = 0; k < n; k++) {
            x[3 * k] = step[c] > 0 && isfinite(val[3 * k + c]) ? val[3 * k + c] / step[c] : 0.f;
            q[k] = sparse_quantize(val[3 * k + c], step[c], qmax);
            same &= c > 0 && fabsf(x[3 * k] - x0[3 * k]) <= 1e-5f * qmax;
        }
        if (same) memcpy(q, q0, sizeof(int) * (size_t)n);
        else descend(G, n, x, qmax, q, g);
        if (c == 0) {
            memcpy(x0, x, sizeof x0);
            memcpy(q0, q, sizeof(int) * (size_t)n);
        }
        for (int k = 0; k < n; k++) val[3 * k + c] = (float)q[k] * step[c];
    }
}
