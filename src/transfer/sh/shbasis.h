/* shbasis.h - real spherical harmonics as an alternative basis for transport and
 * light vectors: the low-frequency baseline that all-frequency PRT replaces.
 *
 * order n (bands l < n) gives n^2 coefficients (n = 3..10: 9 to 100). The
 * coefficients are stored in the same sparse transport set as the wavelet ones,
 * at indices 0..n^2-1 (index l*(l+1)+m), so the runtime inner product is unchanged.
 *
 * Transport texels already include the solid angle (Eq. 3 integrated), so their
 * projection is c_i = sum_j T_j Y_i(w_j); radiance texels (light) are projected with
 * the solid angle: L_i = sum_j L_j Y_i(w_j) dw_j. Then sum_i L_i c_i approximates
 * sum_j L_j T_j for band-limited signals.
 *
 * Convention (shbasis.c): polar axis +z, no Condon-Shortley phase; band 1 is
 * sqrt(3/(4 pi)) (y, z, x). Evaluated by a normalized Legendre recurrence, stable to order 16.
 *
 * Repeated projections (one per transport vector) should use an sh_table: the basis
 * is tabulated once per (res, order), so a projection is a sparse mat-vec with no
 * function evaluation. The table is immutable after sh_table_init and may be shared by
 * threads; sh_table_free frees it. */
#ifndef PRT_SHBASIS_H
#define PRT_SHBASIS_H
#include "common.h"

#define SH_MAX_ORDER 16

/* Real SH Y_i(d) for all i < order^2 into y[]. */
void sh_eval(int order, const float d[3], float *y);
/* Projects a cube of res (cubemap.h indexing) of one channel; with_solid_angle selects the light form. */
void sh_project_cube(const float *texels, int res, int order, bool with_solid_angle, float *coeffs);
/* Light vector in SH: cube_rgb [texels][3] -> L[i][4] for i < order^2, zeros beyond (L has CUBE_TEXELS rows). */
void sh_light_from_cube(const float *cube_rgb, int res, int order, float (*L)[4]);

/* Tabulated basis on a cube of res: y[texel * n + i] = Y_i(w_texel) (n = order^2), dw[texel] = solid angle. */
typedef struct sh_table {
    int res, order, n;
    float *y;     /* [6*res*res][n] */
    float *dw;    /* [6*res*res] */
} sh_table;
/* Builds the table (both cores not needed: a few ms at res 64, order 10). Returns 0 or -1 (OOM, order out of 1..16). */
int sh_table_init(sh_table *t, int res, int order, prt_error *err);
/* As sh_project_cube with the table's res and order; texels[idx * stride] is texel idx's value. */
void sh_table_project(const sh_table *t, const float *texels, int stride, bool with_solid_angle, float *coeffs);
void sh_table_free(sh_table *t);
#endif
