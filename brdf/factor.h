/* factor.h - separable BRDF approximation by SVD (section 3.3, Eq. 1, 10, 11).
 *
 * Usage:
 *     brdf_factor f; prt_error err;
 *     brdf_factor_desc d = { .max_terms = 4 };          // zero fields mean defaults
 *     if (brdf_factorize(&params, &d, &f, &err)) puts(err.msg);
 *     float g[f.K * 3]; brdf_factor_light(&f, wi_local, g);   // light maps at wi
 *     brdf_factor_free(&f);
 *
 * Tabulation: incident and view directions are sampled on the res x res grid
 * (48 by default) over the projected unit disk (Eq. 10: x = (w.s+1)/2,
 * y = (w.t+1)/2), texel centres outside the disk are left out, giving the
 * matrix M[view][light] = f_r(wi, wo) with the cosine left out (section 4) so M
 * stays symmetric. Because the grid is uniform on the projected disk, each
 * sample carries equal projected solid angle: the Frobenius norm of M is the
 * cosine-weighted L2 norm of the BRDF, so truncated SVD is optimal in that norm.
 * With BRDF_PARAM_POLAR (Eq. 11), x = atan2(w.t, w.s)/(2 pi) in [0,1), y = sqrt(1 - w.n).
 *
 * Each colour channel is factored separately with LAPACK (by default the
 * symmetric eigensolver, see brdf_solver; channels that are identical or
 * proportional, and rank-1 channels, are shortcut):
 * light map k = sqrt(sigma_k) u_k, view map k = sqrt(sigma_k) v_k. K is
 * desc.max_terms, or with error_target > 0 the smallest K <= max_terms whose
 * relative cosine-weighted RMS error is at most the target. A Lambertian BRDF
 * (rank 1) gets K = 1.
 *
 * Polar maps are weighted by each texel's projected solid angle before the SVD
 * (and unweighted after), so rel_rms means the same cosine-weighted norm there.
 *
 * Lookups are bilinear (x wraps around for the polar parameterization). Texels
 * outside the disk are filled from their nearest inside texel after
 * factorization, so lookups near the horizon do not fade to zero. A direction
 * below the horizon returns zeros. Lookups allocate nothing and are safe to call
 * from many threads at once.
 *
 * Ownership: light/view arrays belong to the factor; brdf_factor_free frees them. */
#ifndef PRT_FACTOR_H
#define PRT_FACTOR_H
#include "brdf.h"

#define BRDF_MAX_SIGMA 64      /* singular values kept per channel for reports */
#define BRDF_DEFAULT_RES 48

typedef enum brdf_param { BRDF_PARAM_GRID = 0, BRDF_PARAM_POLAR = 1 } brdf_param;

/* Which LAPACK path factors a channel. AUTO is the fastest correct one measured on
 * the 1810 x 1810 matrix of res 48 (see factor.c): the symmetric eigensolver in double.
 * The others are kept for cross-checks and timing (tests/test_factor.c). */
typedef enum brdf_solver {
    BRDF_SOLVER_AUTO = 0,
    BRDF_SOLVER_SYM_D,    /* dsytrd + dsterf + dstemr + dormtr: top-K |eigenvalues| of symmetric M */
    BRDF_SOLVER_SYM_S,    /* the same in single precision */
    BRDF_SOLVER_GESDD_D,  /* full SVD, dgesdd */
    BRDF_SOLVER_GESDD_S   /* full SVD, sgesdd */
} brdf_solver;

typedef struct brdf_factor_desc {
    int max_terms;        /* 0: 4 */
    float error_target;   /* 0: exactly max_terms (or rank, if smaller); > 0: smallest K meeting it */
    int res;              /* 0: 48 */
    brdf_param param;     /* grid (default) or polar */
    brdf_solver solver;   /* 0: AUTO */
} brdf_factor_desc;

typedef struct brdf_factor {
    int K;                /* terms kept */
    int res;
    brdf_param param;
    float *light;         /* [res*res][K][3]: texel-major (texel y*res + x), term, channel */
    float *view;          /* [res*res][K][3] */
    int nsigma;           /* valid entries in sigma[c][] */
    float sigma[3][BRDF_MAX_SIGMA];   /* singular values per channel, descending */
    float rel_rms[BRDF_MAX_SIGMA + 1];/* relative cosine-weighted RMS error with k terms, k = 0..nsigma */
    bool lambertian;      /* K == 1 and the view map is constant: the runtime can skip view lookups */
    double seconds;       /* time spent tabulating + factoring */
} brdf_factor;

/* Tabulates and factors p. Returns 0, or -1 with err set (LAPACK failure, OOM). */
int brdf_factorize(const brdf_params *p, const brdf_factor_desc *desc, brdf_factor *out, prt_error *err);
void brdf_factor_free(brdf_factor *f);
/* Deep copy (for prt_data). */
int brdf_factor_copy(brdf_factor *dst, const brdf_factor *src, prt_error *err);

/* Texture coordinates in [0,1]^2 for local direction w; false below the horizon (w.z <= 0). */
bool brdf_factor_uv(const brdf_factor *f, const float w[3], float *x, float *y);
/* All K light-map (g_k) values x 3 channels at local incident direction w into out[K*3]. */
void brdf_factor_light(const brdf_factor *f, const float w[3], float *out);
/* A Lambertian factor's constant light map (K = 1: its value at the pole) into g[3]. */
void brdf_factor_lambert_light(const brdf_factor *f, float g[3]);
/* All K view-map (h_k) values x 3 channels at local view direction w into out[K*3]. */
void brdf_factor_view(const brdf_factor *f, const float w[3], float *out);
/* sum_{k<K} g_k(wi) h_k(wo) per channel (K <= f->K), to compare with brdf_eval. */
void brdf_factor_eval(const brdf_factor *f, const float wi[3], const float wo[3], int K, float rgb[3]);
#endif
