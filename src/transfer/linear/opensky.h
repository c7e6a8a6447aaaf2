/* opensky.h - the open-sky part of a Lambertian transport vector, exact under any light.
 *
 * A vertex of a Lambertian factor (K = 1, constant light map g per channel) has the transport
 * texels T_j = g a_j, a_j = sum_s V(w_s) max(n.w_s, 0) dw_s over the texel's visibility sub-texels
 * (precompute.c, Eq. 3). Split it as
 *     T_j = g a0_j(n) - g (a0_j(n) - a_j),    a0_j(n) = sum_s max(n.w_s, 0) dw_s   (V = 1),
 * the open sky minus what the occluders block. With the split on (prt_transfer.open_sky) the stored
 * vector is the second term alone, and the runtime adds g E(n) back, E(n) = sum_j L_j a0_j(n) the
 * cube's irradiance at normal n. Why: a truncated vector holds the cosine's fall to the horizon only
 * as coarse blocks, so a low sun (a few degrees up, where the cosine is small and steep) reads a
 * block's mean, tens of percent off on an open floor; the blocked part is zero on an open vertex and
 * an occluder's silhouette on a shadowed one, which the coefficients then spend on (the measurements:
 * docs/design/shadows.md "The open sky").
 *
 * E(n) exactly at a grid of normals, interpolated between them: the grid points are the corners of a
 * G x G split of each cube face, normals p / |p| with p = (u, v, 1) on the face plane. Per light
 * change, at each grid normal, sum_j L_j a0_j(n) is summed exactly down a quadtree per face (a face,
 * its quarters, ..., its texels): a node wholly above n's horizon contributes n . sum L_j m_j over its
 * texels (m_j = sum_s w_s dw_s, the texel's first moment: the clamp is inactive, so the sum is linear in
 * n), one wholly below nothing, one across it its four children, a texel across it its sub-texels.
 * The lookup interpolates |p| E bilinearly on the face and divides by |p|: |p| E(p / |p|) = sum L (p . m)
 * over the texels above the horizon is linear in (u, v), so only texels that cross the horizon of some
 * normal in the cell add error: at most 2 h^2/8 of a uniform sky's irradiance (h = 2/G; 0.4% at G = 16)
 * and, across a sun's terminator, h/2 of the sun's (tests/test_opensky.c measures both).
 * The sub-texels are those of the default visibility cube (CUBE_RES x 2 per face): files ray cast at
 * another --vis-res differ from them at second order in the sub-texel size.
 *
 * The floor's fold. The blocked part of a floor vertex (normal (0, 1, 0)) is still its texels' cosine where
 * the occluders are, and a low sun sits where that cosine falls steeply to the horizon: truncated, the
 * blocked part's coarse blocks over-subtract the sun and the long shadow turns dark and blotchy. A file
 * without interreflections therefore stores the floor's blocked part over each texel's mean cosine,
 *     F_j = g (a_j - a0_j) / c_j,    c_j = a0_j((0, 1, 0)) / Omega_j,
 * an occluder's plain silhouette (prt_transfer.open_vert OPENSKY_FOLDED), and the runtime lights it with
 * L'_j = L_j c_j, the cube times the floor's mean cosines projected like any light: sum F_j L'_j is the
 * blocked light exactly before truncation. The backends' kernels take T . L for every vector, so the
 * runtime adds F . (L' - L) to such a vector's open sky term (runtime.c rt_fold_light); both sides sum
 * c_j over the file's visibility sub-texels alike (precompute.c pc_box_filter, runtime.c rt_fold_cosines).
 *
 * Usage:
 *     opensky *o = opensky_create(&err);
 *     opensky_need(n, need);                       // once per normal that will be looked up (optional)
 *     opensky_set_light(o, cube_rgb, need, nthreads);  // per light change: [CUBE_TEXELS][3] mean radiance
 *     float e[3]; opensky_eval(o, n, e);           // E(n) per channel, n unit
 *     opensky_destroy(o);
 * Ownership: the opensky owns its tables. Thread safety: opensky_eval is read-only (any threads);
 * opensky_set_light writes the grid (not concurrently with eval). */
#ifndef PRT_OPENSKY_H
#define PRT_OPENSKY_H
#include "common.h"

#define OPENSKY_GRID 16   /* grid cells per face edge: (OPENSKY_GRID + 1)^2 normals per face */
#define OPENSKY_NORMALS (6 * (OPENSKY_GRID + 1) * (OPENSKY_GRID + 1))
#define OPENSKY_SUB 2     /* visibility sub-texels per lighting texel edge (128 / CUBE_RES) */

typedef struct opensky opensky;

/* The texel and block tables (a few MB); NULL with err when out of memory. */
opensky *opensky_create(prt_error *err);
void opensky_destroy(opensky *o);
/* E at the grid normals for the light cube_rgb ([CUBE_TEXELS][3] mean radiance per texel) on nthreads
 * (0: all cores): those with need[q] set (need [OPENSKY_NORMALS], opensky_need), or all (need NULL). A
 * scene's normals use few of them when its Lambertian surfaces are planes (a floor: one), and each costs
 * about 12 us (a walk down the quadtree along its horizon). */
void opensky_set_light(opensky *o, const float *cube_rgb, const uint8_t *need, int nthreads);
/* Marks in need [OPENSKY_NORMALS] the grid normals opensky_eval reads for n. */
void opensky_need(const float n[3], uint8_t *need);
/* E(n) per channel for a unit normal n from the grid of the last set_light. */
void opensky_eval(const opensky *o, const float n[3], float rgb[3]);
/* The grid normals (OPENSKY_NORMALS of them) and weights that give E at n: E(n) = sum_k w[k] |p_q| E(n_q)
 * over q = q[k] (each weight holds the 1 / |p| of n). The same weights interpolate a0(n) from the
 * grid's |p_q| a0(n_q) (opensky_grid_texels): gathering uses them for a neighbour's open sky. */
void opensky_weights(const float n[3], int q[4], float w[4]);
/* Grid normal q (unit). */
void opensky_grid_normal(int q, float n[3]);
/* |p_q| a0_j(n_q) for every lighting texel j into a0[CUBE_TEXELS] (from o's tables). */
void opensky_grid_texels(const opensky *o, int q, float *a0);
/* E(n) summed over every sub-texel of cube_rgb (the definition; tests and the grid's check). */
void opensky_exact(const float *cube_rgb, const float n[3], double rgb[3]);
#endif
