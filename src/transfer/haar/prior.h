/* prior.h - a light prior for the expected-error selection: how much light each Haar
 * coefficient of the light vector carries, on average, as a given probe turns about +y.
 *
 * Usage:
 *     float (*w)[4] = transfer_light_alloc();              // [CUBE_TEXELS][4], caller owns
 *     prior_desc pd = { 0 };                               // zero fields mean defaults
 *     if (prior_from_probe(&probe, &pd, w, &err)) puts(err.msg);
 *     // haar_run.c builds it from precompute_desc.light_prior (probe files) for the selection
 *
 * Why (docs/design/shadows.md has the measurements). transport_store keeps the coefficients c_i of a vector
 * whose expected share of T.L is largest: sum over dropped i of c_i^2 E[L_i^2] is the expected
 * squared error of T.L when the light coefficients are uncorrelated. Without a prior E[L_i^2]
 * is one figure per Haar level and elevation band (transport_sigma), the same at every azimuth,
 * so a floor vertex at a shadow edge spends its budget along the whole
 * edge. Under a probe turned about the vertical (the viewer's and --light-rotation's yaw) a
 * sun stays on one ring of elevation: the coefficients whose support the ring crosses carry
 * the sun, the others only sky. With the probe named at precompute time the selection keeps
 * the edge where the sun can be. On the reduced bunny + floor under city the floor's
 * sun-shadow error is 3.1% with the prior against 4.9% without, on the full bunny 3.1% against
 * 7.35%, near the 2.5% of keeping 4,096 coefficients in float. It must be the probe the file will see: a prior of the
 * seven other shared probes did worse under city than none (5.85% against 4.88%), so there is no
 * default prior; a JSON scene names its own ("light_prior", scene.h).
 *
 * What it computes: w[i][ch] = sqrt(mean over `steps` yaw angles 360 k / steps of L_i(yaw)^2),
 * L the Haar light vector with the solid-angle measure (haar_light_vector, Haar's project_light, the
 * light the runtime builds), scaled so that the largest w is 1 (a sun of 1e37 stays finite in
 * the weights c_i w_i), plus `floor` times the channel's RMS w, so that no coefficient weighs
 * nothing: a pitched light or another probe still finds what the prior's probe left dark.
 *
 * Several probes (prior_from_probes): each probe's mean squares over its own largest, summed, so a
 * dim probe counts as much as one with a sun; then normalised and floored as above.
 *
 * Errors: a probe with no light (every w zero) is refused with one line in err. */
#ifndef PRT_PRIOR_H
#define PRT_PRIOR_H
#include "common.h"
#include "cubemap.h"
#include "probe.h"
#include "transfer.h"

/* The yaw steps and the floor by default (docs/design/shadows.md: 360 steps, the sun's ring without
 * gaps at 1.4-degree texels; floors 0.1 / 0.3 / 1 / 3 measured 3.18 / 3.16 / 3.10 / 2.85% in city's
 * shadow with city's prior and 5.09 / 3.23 / 2.77 / 2.63% in forest's, the level prior 2.65%). */
#define PRIOR_STEPS 360
#define PRIOR_FLOOR 3.0f
#define PRIOR_MAX_PROBES 16   /* probes one prior averages (the CLI's list) */

typedef struct prior_desc {
    int steps;      /* yaw angles averaged over; 0: PRIOR_STEPS */
    float floor;    /* added share of each channel's RMS weight; 0: PRIOR_FLOOR, < 0: none */
    prt_progress_fn progress;   /* called with ("light prior", fraction); false cancels */
    void *progress_user;
} prior_desc;

/* The prior of probe p into w[CUBE_TEXELS][4] (w[i][3] = 0). Returns 0, or -1 with err (no light,
 * cancelled, out of memory). Uses both cores (probe_to_cube). */
int prior_from_probe(const prt_probe *p, const prior_desc *desc, float (*w)[4], prt_error *err);

/* The prior of several probes ps[0..n-1]: each probe's mean squares over its orbit, over its own
 * largest (each probe counts the same), summed, then as above. Returns 0, or -1 with err (any
 * probe with no light, n < 1 or over PRIOR_MAX_PROBES, cancelled, out of memory). */
int prior_from_probes(const prt_probe *const *ps, int n, const prior_desc *desc, float (*w)[4], prt_error *err);

/* Light-weighted texels: the prior's light inside its brightest lighting texels, for the direct pass.
 *
 *     prior_rays *pr = prt_calloc(1, sizeof *pr, &err);     // caller owns; plain struct, no pointers
 *     if (prior_rays_from_probes(pps, n, pr, &err)) puts(err.msg);
 *     // haar_begin hands them to the direct pass (transfer_linear_run.rays)
 *
 * Why. The runtime's light is a texel mean L_j and the transport a
 * texel integral a_j = sum over sub-texels of V (n.w) dw (Eq. 3), so the product L_j a_j is right
 * only where L or V is flat inside the texel. A 0.53-degree sun inside a 1.4-degree texel, where an
 * occluder's edge crosses it, is neither: the floor's penumbra vertices come out 20-25% too bright or
 * too dark whatever the budget, the visibility resolution (--vis-res 256) or the coefficient count
 * (4,096 in float). If instead a_j = Omega_j E[V (n.w)] with w drawn as the light inside texel j,
 * then L_j a_j = integral over j of L V (n.w) dw exactly when the light inside j is the prior's, and
 * stays a convex mix of the texel's visibility (as the box filter is) when it is not. The rays go
 * where the prior's probes, unturned, have their light: with the light turned, the sun sits in other
 * texels, which keep the box filter, as without this.
 *
 * Which texels: those holding at least PRIOR_RAY_SHARE of a probe's light (its energy sum L Omega,
 * luminance), at most PRIOR_RAY_TEXELS, brightest first; several probes count each over its own
 * total. Inside a texel the light is read on a PRIOR_RAY_GRID^2 grid (probe_eval, weighted by the
 * grid cell's solid angle) and PRIOR_RAYS directions are placed at the stratified quantiles
 * (m + 1/2) / PRIOR_RAYS of that distribution, so each ray stands for the same share of the light.
 * Deterministic. A probe whose light is spread out (no texel over the share) gives none. */
#define PRIOR_RAY_TEXELS TRANSFER_RAY_TEXELS   /* at most; a sun and its glow take 2-6 at 64^2 */
#define PRIOR_RAYS TRANSFER_RAYS                 /* per texel: 1/64 of the texel's light each */
#define PRIOR_RAY_SHARE 0.005    /* of a probe's light */
#define PRIOR_RAY_GRID 128       /* 0.011-degree cells on a 1.4-degree texel */

/* The texels and their rays, as the direct pass takes them (transfer.h). */
typedef transfer_texel_rays prior_rays;

/* The light-weighted texels of probes ps[0..n-1] (above) into *out. Returns 0, or -1 with err
 * (n < 1, out of memory). */
int prior_rays_from_probes(const prt_probe *const *ps, int n, prior_rays *out, prt_error *err);
/* The prior's light per texel, for refitting the kept coefficients (refit.h).
 *
 *     prior_texels *pt = prt_calloc(1, sizeof *pt, &err);   // caller owns; plain struct, no pointers
 *     if (prior_build(pps, n, &pd, w, pt, &err)) puts(err.msg);   // w: prior_from_probes' weights
 *     precompute_desc d = { ..., .prior_texels = pt };      // precompute.h: the Haar sets read it
 *
 * What it holds: l_j = the channels' sum of L_j w_j (the light the runtime's vector carries, per
 * texel j of the solid-angle measure) for each probe p turned through `steps` yaw angles. mean[p][j]
 * is its mean over the orbit, var[j] the variance about it averaged over the probes, each probe's
 * figures over its own largest mean square (each counts the same, as in the coefficient prior), with
 * mean[p] over sqrt(n) so that sum_p mean[p] mean[p]^T is the probes' average. Then var[j] gains
 * PRIOR_TEXEL_FLOOR times var's mean, so every texel weighs something (a pitched light, another
 * probe). E[l_j l_k] = var_j delta_jk + sum_p mean[p][j] mean[p][k] is refit.h's model of the light. */
#define PRIOR_TEXEL_FLOOR 0.01f
typedef struct prior_texels {
    int n;                                        /* probes */
    float var[CUBE_TEXELS];                       /* texel layout (cubemap.h indexing) */
    float mean[PRIOR_MAX_PROBES][CUBE_TEXELS];
} prior_texels;

/* prior_from_probes' weights into w and, from the same turns of the probes, their texel statistics
 * (above) into *texels (NULL: not asked for). Returns 0, or -1 with err as prior_from_probes. */
int prior_build(const prt_probe *const *ps, int n, const prior_desc *desc, float (*w)[4], prior_texels *texels,
                prt_error *err);
#endif
