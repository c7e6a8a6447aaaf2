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
 * sum_j L_j T_j for band-limited signals. */
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
#endif
