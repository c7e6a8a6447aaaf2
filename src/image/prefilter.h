/* prefilter.h - the light probe prefiltered by vMF lobes over a ladder of kappa (issue 9, step 4):
 * E(d, k) = int L(w) gamma(w; d, k) dw, gamma the vMF of brdf/lobe.h (laurijssen-2011 Eq. 1,
 * the filtered-environment lookup of its section 7.1), for any unit direction d and kappa >= 0.
 *
 * Usage:
 *     prefilter_desc d = { 0 };                               // zero = defaults (below)
 *     prefilter_env *e = prefilter_create(&probe, R, &d, &err);   // R may be NULL (identity)
 *     float rgb[3]; prefilter_lookup(e, dir, kappa, rgb);        // dir: world frame, unit
 *     prefilter_set_rotation(e, R2);                            // rotate the light: free
 *     prefilter_destroy(e);
 *
 * The ladder (defaults): levels l = 0..levels-1 of kappa_l = kappa_max / ratio^l, i.e.
 * 1600, 400, 100, 25, 6.25, 1.5625, 0.39 (kappa_max 1600, ratio 4, 7 levels), then one last
 * level of kappa 0: the uniform mean of the probe over the sphere (E(d, 0) = mean radiance).
 * Resolution rule: level l is a cube of res_l = the smallest power of two >= pi sqrt(kappa_l),
 * clamped to [4, base_res], so the lobe's width 1/sqrt(kappa) spans at least 2 texels of
 * angular size pi / (2 res) at a face centre; with ratio 4 each level halves the resolution
 * (128, 64, 32, 16, 8, 4, 4 at base 128), and kappa 1600 is the sharpest that 128 holds.
 *
 * Cascade: the probe is resampled once to the base cube (probe_to_cube, area filtered,
 * unrotated), and a pyramid of cubes is made from it by 2x2 solid-angle-weighted means (each
 * exact in power). Level l is the vMF convolution of kappa_l of the pyramid's cube at res_l:
 * E_l(d_i) = sum_j Omega_j e^{k (d_i.w_j - 1)} L_j / sum_j Omega_j e^{k (d_i.w_j - 1)} over
 * the source texels j within the cap where the kernel is above 1e-5 of its peak (normalized by
 * the discrete sum, so a constant probe gives the constant exactly). Every level thus costs
 * about the same per output texel (~(2 * 4.8)^2 taps) and the total is 4/3 of the finest.
 * Measured (tests/test_prefilter.c, prefilter/cost): ~50-60 ms for city.exr on 2 cores.
 *
 * Rotation: the env keeps the unrotated probe and the rotation R (a light at direction d
 * moves to R d, as probe_to_cube); the lookup at world direction d reads the unrotated
 * levels at R^T d. So rotating the light is prefilter_set_rotation: no recomputation.
 *
 * Lookup: bilinear within a level (seamless across face edges: a tap beyond an edge reads
 * the neighbouring face's texel under the extrapolated direction), linear between the two
 * levels bracketing kappa in log kappa (chosen by measured error against quadrature among
 * log kappa, kappa and the width 1/sqrt kappa, tests/test_prefilter.c, prefilter/interp), and
 * linear in kappa between the last vMF level and kappa 0 (the convolution is linear in kappa
 * there to first order: gamma ~ (1 + kappa d.w) / 4 pi). kappa >= kappa_max reads the finest
 * level alone (clamped: a sharper lobe is not represented); kappa <= 0 the mean.
 *
 * Errors: a bad desc (base_res not a power of two in [4, 1024], kappa_max not in (0, 1e6],
 * ratio <= 1, levels > 32) or out of memory: NULL and one line in err. A NULL probe or a zero
 * direction is a bug (PRT_CHECK). Lookups are pure reads: thread-safe on a shared env.
 * Ownership: the env owns its levels; the probe may be freed after prefilter_create. */
#ifndef PRT_PREFILTER_H
#define PRT_PREFILTER_H
#include "common.h"
#include "probe.h"

#define PREFILTER_BASE_RES 128
#define PREFILTER_KAPPA_MAX 1600.0f
#define PREFILTER_RATIO 2.0f
#define PREFILTER_LEVELS 12         /* vMF levels; the kappa-0 mean is one more */

/* Zero fields mean the defaults above. */
typedef struct prefilter_desc {
    int base_res;       /* base cube resolution (power of two, 4..1024) */
    int levels;         /* vMF levels (1..32), plus the kappa-0 level */
    float kappa_max;    /* kappa of level 0 */
    float ratio;        /* kappa_{l+1} = kappa_l / ratio (> 1) */
    int ss;             /* probe_to_cube sub-samples per texel side (0: its default) */
    int threads;        /* 0: prt_thread_count(0) */
} prefilter_desc;

typedef struct prefilter_env prefilter_env;

/* Prefilters probe p (Eq. 1 vMF convolution at every ladder level) with light rotation R
 * (row-major, NULL = identity); NULL and err on a bad desc or no memory. */
prefilter_env *prefilter_create(const prt_probe *p, const float R[9], const prefilter_desc *d, prt_error *err);
/* Frees the env and its levels (NULL is fine). */
void prefilter_destroy(prefilter_env *e);
/* Sets the light rotation R (NULL = identity); costs nothing (lookups read R^T d). */
void prefilter_set_rotation(prefilter_env *e, const float R[9]);
/* rgb = int L(w) vMF(w; dir, kappa) dw, dir a world unit direction, kappa >= 0 (see above). */
void prefilter_lookup(const prefilter_env *e, const float dir[3], float kappa, float rgb[3]);
/* Number of levels, the kappa-0 level included (levels + 1). */
int prefilter_level_count(const prefilter_env *e);
/* Level l's kappa and cube resolution (the last level: kappa 0, res 1). */
void prefilter_level_info(const prefilter_env *e, int l, float *kappa, int *res);
/* Bilinear lookup of level l alone at world direction dir (for the tests and GLSL ports). */
void prefilter_lookup_level(const prefilter_env *e, int l, const float dir[3], float rgb[3]);
#endif
