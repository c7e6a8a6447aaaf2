/* prefilter.h - the light probe prefiltered by vMF lobes over a ladder of kappa:
 * E(d, k) = int L(w) gamma(w; d, k) dw, gamma the vMF of brdf/lobe.h (laurijssen-2011 Eq. 1,
 * the filtered-environment lookup of its section 7.1), for any unit direction d and kappa >= 0.
 *
 * Usage:
 *     prefilter_desc d = { 0 };                               // zero = defaults (below)
 *     prefilter_env *e = prefilter_create(&probe, R, &d, &err);   // R may be NULL (identity)
 *     float rgb[3]; prefilter_lookup(e, dir, kappa, rgb);        // dir: world frame, unit; the ladder + the lights
 *     prefilter_set_rotation(e, R2);                            // rotate the light: free
 *     prefilter_destroy(e);
 *
 * The ladder (defaults): levels l = 0..levels-1 of kappa_l = kappa_max / ratio^l, i.e.
 * 1600, 800, 400, ..., 0.78 (kappa_max 1600, ratio 2, 12 levels), then one last level of
 * kappa 0: the uniform mean of the probe over the sphere (E(d, 0) = its mean radiance).
 * Resolution rule: with texels of pi / (2 res) (a face centre's), level l is a cube of res_l =
 * the power of two nearest (in log) 4 texels per lobe width 1/sqrt(kappa_l), i.e. nearest
 * 2 pi sqrt(kappa_l), in [8, base_res] (bilinear lookups of a map sampled 3 to 6 texels per
 * width); at base 128: 128, 128, 128, 64, 64, 32, 32, 16, 16, 8, 8, 8, and kappa 1600 is
 * clamped to 2 texels per width (the sharpest that 128 holds at all).
 *
 * Cascade: the probe is resampled once to the base cube (probe_to_cube, area filtered,
 * unrotated), and a pyramid is made from it by 2x2 solid-angle-weighted means (each exact in
 * power). Level l convolves the pyramid's cube at half the rule's density (2 texels per
 * width, in [32, base_res]: a wide kernel still varies by e^{kappa h} across a texel h):
 * E_l(d_i) = sum_j Omega_j e^{k' (d_i.w_j - 1)} L_j / sum_j Omega_j e^{k' (d_i.w_j - 1)}
 * over the source texels j where the kernel is above 1e-5 of its peak, normalized by the
 * discrete sum (a constant probe gives the constant exactly); a source texel is an area
 * mean, a box of per-axis variance h^2 / 12 that the kernel's 1/kappa per axis adds to, so
 * k' = 1 / (1/kappa - h^2/12), h^2 the mean texel's solid angle. Each level thus costs about
 * the same per output texel, and the sharp levels (three at 128) dominate.
 * Measured (tests/test_prefilter.c, prefilter/cost, city.exr, base 128, 2 cores shared):
 * 0.7 to 1.0 s per prefilter_create, 0.12 us per lookup. That is not interactive, and need
 * not be: the env holds the unrotated probe, so rotating the light is free (below); a new
 * probe costs one create. A SIMD exp (the taps are scalar expf), fewer levels at the base
 * resolution, or a GPU pass would cut it; coarser ladders cost accuracy (ratio 4 at 2 texels
 * per width is 5-8% off on the ladder and up to 22% between levels).
 *
 * Lights: the probe's few brightest pixels are taken out of the ladder and added back exactly,
 *     E(d, k) = E_rest(d, k) + sum_s sum_c Phi_{s,c} int gamma_{s,c}(w) gamma(w; d, k) dw   (per channel c),
 * E_rest the ladder of the probe with those pixels zeroed (an exact split: probe_eval's bilinear
 * reconstruction is linear in the pixels) and the integral the product of two vMFs in closed form
 * (lobe.h vmf_product_integral), at any kappa. Why: a sun holds a large share of a probe's light in a
 * few pixels (sunrise.exr: 53% in 4 pixels of 0.35 degree) that the 128 cube's sharp levels hold in 2
 * texels; the ladder alone is up to 4.7% of the peak off on a 0.5-degree sun of 34,000 and 5.6%
 * between levels (prefilter/sun), 2.9% to 15% at the shared probes' brightest spots (below; sunrise
 * 5.8% at paper-phong's kappa 52).
 * Which pixels: luminance above light_threshold (1,000) times the probe's mean, brightest first; each
 * joins the first light whose brightest pixel lies within 1 degree, or seeds a new one while there are
 * fewer than `lights` (8), else stays in the ladder. A light's vMF per channel is the merge
 * (laurijssen-2011 Eq. 4, weighted by that channel's power) of its pixels' own vMFs, each the bilinear
 * tent probe_eval reads about the pixel's centre (per-axis variance h^2/6, h the spacing of the
 * neighbouring centres, averaged over the two image axes): so a light keeps its pixels' power, mean
 * direction and spread per channel (a sun's pixels differ in colour: sunrise.exr's blue centroid is a
 * third of a pixel from its luminance's, 2.7% of the peak at kappa 1600 if one vMF served the three
 * channels), and the lookup is exact to second order in the light's extent, (kappa var)^2. A term
 * below e^{-20} of its own peak is skipped (kappa (1 - cos) ks / (kappa + ks) > 20). Above kappa_max
 * the lights stay exact (kappa clamped to VMF_KAPPA_MAX) while the rest reads the finest level.
 * Threshold and count, measured (tools/prefilter_lights.sh: at the brightest pixel and 0.5 to 2.5
 * lobe widths around it, kappa 6 to 1600, against quadrature of the bilinear probe; worst error over
 * kappa in % of the peak, lights in parentheses):
 *     probe        no lights   threshold 1,000   300           100
 *     sunrise      12.1        0.33 (2)
 *     city         6.1         0.32 (1)          0.32 (2)      0.32 (2)
 *     interior     9.2         0.80 (3)          0.81 (6)      0.81 (8)
 *     night        15.2        1.14 (7)          0.45 (8)      0.45 (8)
 *     sunset       10.6        1.43 (1)          0.78 (1)      0.78 (1)
 *     forest       2.9         1.63 (2)          1.40 (4)      0.98 (8)
 *     studio       6.2         6.2 (0)           5.4 (8)       4.4 (8)
 *     courtyard    5.0         5.0 (0)
 * 1,000 brings every sun and lamp within 2% with at most 7 lights (the share of the light they take:
 * sunrise 58%, city 23%, interior 35%, night 41%, sunset 1.9%, forest 2.7%); lower thresholds gain
 * little and cost lights, each three exps more per lookup within its reach; the studio's softboxes
 * and the courtyard's bright sky are wide, the ladder's (its 4-6% there is its own resolution).
 * Cost (one thread, CPU time on this 2-core machine): prefilter_create 1.26 s without lights, 1.29 s
 * with (sunrise, 2 lights; the extraction is one pass over the probe); a lookup costs three float exps
 * per light within reach more: 85 -> 106 ns at kappa 52 and 89 -> 139 ns at kappa 5 on sunrise (2
 * lights), 87 -> 149 and 90 -> 239 ns on night (7 lights), the same on studio (none).
 *
 * Rotation: the env keeps the unrotated probe and the rotation R (a light at direction d
 * moves to R d, as probe_to_cube); the lookup at world direction d reads the unrotated
 * levels at R^T d. So rotating the light is prefilter_set_rotation: no recomputation.
 *
 * Lookup: bilinear within a level (seamless across face edges: a tap beyond an edge reads
 * the neighbouring face's texel under the extrapolated direction), linear between the two
 * levels bracketing kappa in log kappa (chosen by measured error on a 0.5-degree sun of
 * 34,000 against quadrature, prefilter/interp: mean worst error 1.9% of the peak in log kappa,
 * 3.5% in kappa, 4.0% in the width 1/sqrt kappa), and linear in kappa between the last vMF
 * level and kappa 0 (the convolution is linear in kappa there to first order:
 * gamma ~ (1 + kappa d.w) / 4 pi). kappa >= kappa_max reads the finest level alone (clamped:
 * a sharper lobe is not represented in the ladder); kappa <= 0 the mean. The lights are added to
 * every lookup (above).
 * Accuracy (tests): the sun within 0.11% of its peak on the ladder, 0.17% between levels (the ladder
 * alone: 4.7%, 5.6%); a one-pixel light within kappa v of the exact vMF-convolved delta (v its tent's
 * variance); a smooth quadratic probe within 0.44% / 0.84% (no light: the same bits as lights = -1);
 * a vMF lobe within 4.8% of its peak.
 *
 * Errors: a bad desc (base_res not a power of two in [4, 1024], kappa_max not in (0, 1e6],
 * ratio <= 1, levels > 32, lights > PREFILTER_MAX_LIGHTS, light_threshold below 1) or out of memory:
 * NULL and one line in err. A NULL probe or a zero
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
#define PREFILTER_MAX_LIGHTS 8      /* lights taken out of the ladder, at most (desc.lights; glrt uploads as many) */
#define PREFILTER_LIGHTS 8          /* ... by default */
#define PREFILTER_LIGHT_THRESHOLD 1000.0f  /* a light's pixels: luminance above this multiple of the mean */

/* Zero fields mean the defaults above. */
typedef struct prefilter_desc {
    int base_res;       /* base cube resolution (power of two, 4..1024) */
    int levels;         /* vMF levels (1..32), plus the kappa-0 level */
    float kappa_max;    /* kappa of level 0 */
    float ratio;        /* kappa_{l+1} = kappa_l / ratio (> 1) */
    int ss;             /* probe_to_cube sub-samples per texel side (0: its default) */
    int threads;        /* 0: prt_thread_count(0) */
    int lights;         /* lights taken out of the ladder, at most (0: PREFILTER_LIGHTS; < 0: none) */
    float light_threshold; /* their pixels' luminance over the probe's mean (0: PREFILTER_LIGHT_THRESHOLD) */
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
/* Level l's texels (6 res^2 RGB floats, cubemap.h's face order = OpenGL's, unrotated probe frame),
 * owned by the env: what a GPU runtime uploads as one cube map per level (gpu/glrt.c). */
const float *prefilter_level_texels(const prefilter_env *e, int l);
/* R^T (row-major): the lookup's world -> probe-frame rotation, for a GPU port of prefilter_lookup. */
void prefilter_rotation_t(const prefilter_env *e, float Rt[9]);
/* Number of lights taken out of the ladder (0 when none: the ladder holds the whole probe). */
int prefilter_light_count(const prefilter_env *e);
/* Light i per colour channel c: its vMF's unit direction dir[c] (unrotated probe frame) and kappa[c], and
 * its power[c] (radiance x solid angle); prefilter_lookup adds power[c] int gamma_c gamma(.; R^T d, kappa). */
void prefilter_light(const prefilter_env *e, int i, float dir[3][3], float kappa[3], float power[3]);
/* Bilinear lookup of level l alone at world direction dir (the probe less its lights; for the tests
 * and GLSL ports). */
void prefilter_lookup_level(const prefilter_env *e, int l, const float dir[3], float rgb[3]);
#endif
