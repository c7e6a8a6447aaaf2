/* haar.h - orthonormal 2D Haar wavelets on cube-map faces (section 4.1.1).
 *
 * The nonstandard decomposition: at each level, every 2x2 block of averages
 * becomes one average and three details (horizontal, vertical, diagonal), with
 * the orthonormal factor 1/2, so the transform preserves the L2 norm and inner
 * products (Parseval) and <light, transport> may be computed in either domain.
 *
 * Coefficient order. After the in-place transform a res x res face holds the
 * usual quadrant layout (the 2^l x 2^l top-left square holds levels < l). The
 * "wavelet index" of quadrant position (i, j) is face*res*res + morton(i, j)
 * (bits of i and j interleaved, i in the even bits), so coarse levels are
 * contiguous at the start of each face: index 0 of a face is its scaling
 * coefficient, the first 256 indices of a face are all levels up to 16x16.
 * Light vectors and transport vectors use the same wavelet index space, which
 * keeps sparse transport vectors' indices clustered into few 256-blocks.
 *
 * res must be a power of two. Pure functions, thread-safe. */
#ifndef PRT_HAAR_H
#define PRT_HAAR_H
#include "common.h"

/* In-place forward transform of one row-major res x res face; tmp holds res*res floats. */
void haar_forward(float *face, int res, float *tmp);
/* In-place inverse of haar_forward. */
void haar_inverse(float *face, int res, float *tmp);
/* Morton (Z-order) index of (i, j): i in even bits, j in odd bits. */
uint32_t haar_morton(uint32_t i, uint32_t j);
/* Inverse of haar_morton. */
void haar_unmorton(uint32_t m, uint32_t *i, uint32_t *j);

/* One face's coefficients between haar_forward's quadrant layout (row-major) and morton order
 * (res*res floats each; in and out may not alias). */
void haar_face_to_morton(const float *face, int res, float *morton);
void haar_face_from_morton(const float *morton, int res, float *face);

/* Whole cube: row-major texels (cubemap.h indexing) of one channel -> wavelet-index order.
 * in and out may not alias; tmp holds 2*res*res floats. */
void haar_cube_forward(const float *texels, int res, float *wavelet, float *tmp);
/* The same of each face's texels times w[res*res] (the same on every face): with w the reciprocal
 * solid angle (haar_face_solid_angle, inverse), the Haar coefficients of T/w. */
void haar_cube_forward_weighted(const float *texels, int res, const float *w, float *wavelet, float *tmp);
/* Wavelet-index order -> row-major texels. */
void haar_cube_inverse(const float *wavelet, int res, float *texels, float *tmp);

/* The differential solid angle of a res x res cube face at each texel centre, row-major
 * (the same on every face): w[j*res+i] = (2/res)^2 (1 + x^2 + y^2)^-3/2, within 0.025% of
 * the texel's exact solid angle at res 64; its reciprocal when inverse is set. */
void haar_face_solid_angle(float *w, int res, bool inverse);
/* The Haar coefficients of haar_face_solid_angle (not inverted) in morton order:
 * W[m] = <w, psi_m>, so a face's wavelet coefficients c of T/w integrate to
 * sum_j T_j = sum_m c_m W[m]. tmp holds res*res floats. */
void haar_face_solid_angle_coeffs(float *W, int res, float *tmp);
#endif
