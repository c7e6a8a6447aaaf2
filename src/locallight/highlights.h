/* highlights.h - indirect highlights: light that two glossy surfaces reflect in turn, from
 * local lights and the prefiltered probe, by merging the reflected vMF lobes
 * (laurijssen-2010 sections 4-6). Short prefix: hl_.
 *
 * Usage:
 *     hl_scene sc = { .vs = vs, .mesh = &scene.mesh, .lm = lm, .env = env };  // env may be NULL
 *     hl_desc d = { .samples = 32 };                          // zero = defaults (below)
 *     float L[3]; hl_shade(&sc, &d, lights, nlights, p, n, mat, wo, seed, L, NULL);
 *
 * At a glossy point p seen from wo (section 6.2): S secondary directions s_i are drawn from
 * p's fitted lobe (lightmat_lobe; vmf_sample at the S points ((i + a) / S, frac(i / phi + b))
 * of a rank-1 lattice shifted by a random (a, b) per point, Cranley-Patterson: unbiased) and
 * weighted w_i = f_s(s_i, wo) cos / gamma_p(s_i) with the exact specular BRDF (so the p-bounce
 * is unbiased); each ray's first hit q_i, when glossy and facing it, contributes the lobe
 * gamma_i over incoming directions s' of rho~(q_i, s', -s_i) (Eq. 9's inner factor; the fit's
 * colour alpha_i is its integral) with the colour c_i = w_i alpha_i. The lobes are clustered
 * by mean direction with Algorithm 4.1's hard EM into at most desc.clusters groups (initial
 * centres by farthest point from the heaviest lobe), and each group merged into one vMF
 * (Eq. 5, weights the luminance of c_i: vmf_accum_add_colour), with the energy E_j =
 * (1/S) sum c_i over its members (Eq. 10's scaling, exact per cluster) and the mean position
 * q_j of its members (weighted alike). Then Eq. 8:
 *   local light (default, our change, below): every lobe read at its own light direction,
 *     sum_i c_i gamma_i(w_l(q_i)) I / r_i^2 / S, a cluster's members sharing its one shadow ray
 *     from the member nearest q_j (a mean may lie under the surface, section 6.2);
 *   local light with desc.merged (the paper's read): E_j gamma_j(w_l) I(-w_l) / r^2 per merged
 *     lobe, w_l from q_j to the light, the same shadow ray; merged relative to the light
 *     unless desc.fixed_frame (below);
 *   probe: E_j prefilter_lookup(env, mu_j, kappa_j) (the vMF-filtered probe, section 6.4),
 *     the lobes merged for it being those whose one shadow ray along their mean direction
 *     escapes (section 6.4's visibility), clustered separately.
 * Each lobe at its own light direction (default). A point light is one direction per q_i, so
 * reading the S fitted lobes costs S vMF evaluations, no more than a merge's EM: merging pays
 * only where a lobe meets a whole environment (the probe). On data/chrome-point.json's 51
 * chrome vertices that mirror the red sphere, against an 8,192-spp reference (the per-vertex
 * relative RMS of the mean of 8 seeds, i.e. the bias), the merged read (K = 2) is 11% off at
 * S = 32 and 25% at S = 128 (the more lobes per cluster, the broader the merge), reading each
 * lobe 3% and 1%; the clusters still group the shadow rays (K per light). The lattice, because
 * a sampling stratified in the polar variable only leaves one seed 34% off, against 18% with
 * the lattice (merged read) and 11% (each lobe). docs/design/local-lights.md.
 * Light-relative merge (desc.merged; desc.fixed_frame gives the paper's). Section 6.3 reads every
 * lobe of a cluster at the one direction w_l(q_j), which is wrong by the angle d / r between
 * w_l(q_i) and w_l(q_j) (Eq. 11); with mirror-like lobes (kappa 300: 0.06 rad) and a light
 * 0.7 m from a wall whose q_i spread over 0.07 m, that angle exceeds a lobe's width and the
 * estimate is +265% at the peak (tests/test_highlights.c, highlights/near_light). So for each
 * point light every lobe is first turned by the rotation taking w_l(q_i) to w_ref, the light's
 * direction from the mean of all q_i, which makes gamma'_i(w_ref) = gamma_i(w_l(q_i)) exactly;
 * the turned lobes are clustered and merged as above, and each merged lobe is read at w_ref.
 * Measured there: +4.3% at the peak, -3.3% on its flank; with the light 20 m away (where the
 * paper's assumption holds) +1% to +4% against the paper's +5% to +10%. Its cost: one EM per light.
 * Diffuse at the hits: the kd/pi part of every hit's BRDF (a Lambert floor's, the glossy
 * models' kd) is gathered from the local lights per hit, w_i kd/pi cos I / r^2 V / S with one
 * shadow ray each (the final gather the paper's renderer traces for the diffuse component,
 * section 7): with sharp lobes at p these rays see a small, smooth patch, and a VSGL's one
 * Gaussian cannot draw a lit floor in a mirror (measured on data/chrome-point.json,
 * docs/design/local-lights.md).
 * So with highlights on, p's glossy lobe takes all its one-bounce local light from here and
 * its diffuse lobe from the VSGLs (indirect.h: vsgl_shade_diffuse); nothing is counted twice.
 * Rays that miss add nothing (the probe's direct reflection is PRT's), nor does the probe
 * at a diffuse hit (PRT's bounces).
 *
 * Cost per point: S rays and S lobe look-ups; per light one EM over the glossy hits (S K per
 * iteration) and K shadow rays, and one shadow ray per hit with a diffuse part; for the probe
 * up to S shadow rays and one more EM. Measured on data/chrome-point.json
 * (docs/design/local-lights.md): S = 32 at 6,898 glossy vertices, 100-180 ms a view change on
 * two loaded cores. Deterministic per seed.
 * Errors: none (a non-glossy material at p gives 0); bad desc values are clamped to their
 * ranges (samples 1..HL_MAX_SAMPLES, clusters 1..HL_MAX_CLUSTERS). Thread-safe: scene and
 * env are only read. Ownership: the caller keeps everything hl_scene points to alive. */
#ifndef PRT_HIGHLIGHTS_H
#define PRT_HIGHLIGHTS_H
#include "lightmat.h"
#include "lights.h"
#include "visibility.h"
#include "prefilter.h"

#define HL_DEFAULT_SAMPLES 32      /* the paper's 32 secondary rays (Table 1) */
#define HL_DEFAULT_CLUSTERS 2      /* and two vMFs per mixture */
#define HL_MAX_SAMPLES 1024
#define HL_MAX_CLUSTERS 8

typedef struct hl_desc {
    int samples;    /* secondary rays S per point; 0: 32 */
    int clusters;   /* vMFs per merged mixture; 0: 2 */
    int iters;      /* EM iterations (stops early when stable); 0: 8 */
    bool merged;      /* local lights: read the merged lobes (section 6.3; light-relative unless
                       * fixed_frame) instead of every lobe at its own light direction (header) */
    bool fixed_frame; /* with merged: the paper's merge in world directions, read at the mean
                       * position's light direction (else the light-relative merge, header) */
} hl_desc;

/* What the rays see: the scene's BVH (built from mesh), its materials, the probe (or NULL). */
typedef struct hl_scene {
    const vis_scene *vs;
    const prt_mesh *mesh;
    const lightmat *lm;
    const prefilter_env *env;
} hl_scene;

/* Counts of one call (for benchmarks and tests). */
typedef struct hl_stats { int rays, glossy_hits, clusters, shadow_rays; } hl_stats;

/* Indirect highlight radiance (rgb) leaving p (normal n, material mat) toward wo, from the
 * nl lights and the probe; stats may be NULL. */
void hl_shade(const hl_scene *sc, const hl_desc *d, const prt_light *lights, int nl, const float p[3],
              const float n[3], int mat, const float wo[3], uint64_t seed, float out[3], hl_stats *stats);
#endif
