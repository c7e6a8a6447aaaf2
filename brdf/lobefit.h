/* lobefit.h - one vMF lobe and a colour per view elevation for an isotropic BRDF
 * (laurijssen-2011 section 3 and 5.1, after Green et al. 2007).
 *
 * Usage:
 *     lobefit_table t; prt_error err;
 *     if (lobefit_fit(&params, &(lobefit_desc){ 0 }, &t, &err)) puts(err.msg);
 *     printf("%.1f%% mean, %.1f%% max\n", 100 * t.err_mean, 100 * t.err_max);
 *     vmf_lobe v; float alpha[3];
 *     lobefit_lookup(&t, wo_local, &v, alpha);   // f_s(wi, wo) cos(theta_i) ~ alpha gamma_v(wi)
 *     lobefit_fit(&params, &(lobefit_desc){ .lobes = 2 }, &t, &err);   // two lobes where one errs
 *     vmf_lobe m[2]; float a[2][3];
 *     int n = lobefit_lookup_mix(&t, wo_local, m, a); // ~ a[0] gamma_m0 + a[1] gamma_m1 (n = 1: a[1] = 0)
 *
 * What is fitted: the specular slice h(wi) = f_s(wi, wo) cos(theta_i) of a Phong, Blinn,
 * GGX or Beckmann BRDF (the diffuse kd/pi is left out: it stays in the Haar K = 1
 * transfer) at view elevations theta_k = 90 deg * k / views (k = 0..views-1, wo in the
 * x-z plane). As in the paper, the colour alpha is the slice's hemispherical integral
 * (so a lobe carries exactly the slice's energy, which gathering relies on, Eq. 11), and
 * the lobe starts as the vMF with the slice's mean unnormalized direction (Eq. 2 on the
 * slice normalized to a distribution, then Eq. 3 exactly: the "moment" lobe); kappa and
 * the axis elevation are then refined to minimize the L2 error at that fixed alpha
 * (desc.moments_only skips this). The refinement matters for heavy-tailed lobes, whose
 * mean direction is set by the tails: GGX alpha 0.05 goes from 72% to 37% mean error,
 * Phong n = 50 from 3.3% to 2.7% (tests/test_lobe.c). Mapping: at normal incidence the
 * modified Phong slice is ks (n+2)/(2 pi) cos^{n+1}, whose mean length is (n+2)/(n+3),
 * so the moment kappa is n + 3 (tested; least squares gives 52.3 at n = 50); Phong
 * n = 10,000 gives kappa ~ 1e4. Off normal incidence the axis leaves the mirror
 * direction toward the normal by ~tan(theta_o)/kappa (the cosine factor's pull, tested).
 *
 * Error measure: per view, the relative L2 error over the whole sphere (lobe mass below
 * the horizon counts as error) of alpha gamma against h, summed over the colour
 * channels: err against the specular slice alone, err_whole against the whole slice
 * h + kd/pi cos(theta_i) (the denominator `prt brdf` uses for the SVD). This is the
 * radiance-weighted measure: the SVD's cosine-weighted measure int (f - f~)^2 cos dwi
 * cannot be used for a lobe, whose f~ = alpha gamma / cos(theta_i) is unbounded at the
 * horizon. lobefit_factor_error puts an SVD approximation in this same measure.
 * The integrals use a quadrature around the mirror direction, rings graded
 * geometrically from 2e-4 rad to pi (resolves kappa up to 1e6) by res/2 azimuths.
 * Cost: ~0.3 s per BRDF at the defaults (16 views, res 256) on this machine.
 *
 * Two lobes (desc.lobes = 2; the paper's I lobes of a slice, section 5.1): where one lobe errs by
 * more than LOBEFIT_MIX_THRESHOLD (5%), the slice is fitted again by two lobes of colours s alpha and
 * (1 - s) alpha (the slice's energy stays exact), both axes in the plane of incidence: from the better
 * in L2 of a core-and-tail start (the one lobe's axis, kappa x2 and /4: heavy microfacet tails) and a
 * split start (axes 0.7 / sqrt(kappa) either side, kappa x1.5: a stretched or cut lobe), two rounds of
 * golden sections on each lobe's kappa and axis, with s solved in closed form (the cost is quadratic
 * in s; the lobes' products are analytic, vmf_product_integral). They are kept (mixed[v]) where they
 * lower the error by at least LOBEFIT_MIX_GAIN (2 points), since a second lobe costs a second lookup
 * wherever it is used. Why these values (tools/lobe_mix.sh: 13 BRDFs fitted twice at all 208 views): where
 * one lobe is within 5%, the median ratio of the two-lobe error to it is 1.00; 0.78 between 5% and
 * 10%, 0.27 to 0.67 above. Measured, mean (max) error over 16 views, one lobe -> as used: GGX alpha
 * 0.05 36.7% (84.6%) -> 22.2% (70.5%), alpha 0.2 31.3% -> 17.7%, alpha 0.4 22.5% -> 13.2%; Beckmann
 * alpha 0.05 24.4% -> 14.5%, alpha 0.3 19.6% -> 9.8%; Blinn n = 20 14.2% -> 6.2%, n = 80 19.2% -> 9.5%,
 * n = 400 22.8% -> 12.8%; Phong (n = 10 to 1,000, paper-phong) keeps one lobe at every view: its
 * grazing error is the horizon's cut, which two vMFs fit no better (16.12% -> 16.05% at 84 degrees).
 * Cost: 3 to 5 times the one-lobe fit on a microfacet or Blinn BRDF (every view fitted twice).
 *
 * Ownership: a lobefit_table is a plain value (fixed arrays, nothing to free); the fit
 * allocates its quadrature scratch and frees it before returning.
 * Errors: lobefit_fit fails with one line naming the model when it is not one of the
 * four isotropic lobe models (lambert has no lobe; as and lafortune are refused), or
 * when out of memory. */
#ifndef PRT_LOBEFIT_H
#define PRT_LOBEFIT_H
#include "brdf.h"
#include "factor.h"
#include "lobe.h"

#define LOBEFIT_MAX_VIEWS 64
#define LOBEFIT_DEFAULT_VIEWS 16

#define LOBEFIT_MIX_THRESHOLD 0.05f  /* two lobes are fitted where one lobe's error exceeds this ("Two lobes") */
#define LOBEFIT_MIX_GAIN 0.02f       /* ... and kept where they lower it by at least this much */

typedef struct lobefit_desc {
    int views;      /* view elevations over [0, 90 deg); 0: 16 */
    int res;        /* quadrature rings (res/2 azimuths); 0: 256; 16..1024 */
    bool moments_only; /* true: the paper's moment lobe (Eq. 2-3) without the least-squares refinement */
    int lobes;      /* 0 or 1: one lobe per view; 2: two where one errs by more than mix_threshold */
    float mix_threshold; /* 0: LOBEFIT_MIX_THRESHOLD */
} lobefit_desc;

typedef struct lobefit_table {
    brdf_type type;
    int views;
    int res;                             /* quadrature rings used */
    float theta[LOBEFIT_MAX_VIEWS];      /* view elevation (radians): wo = (sin, 0, cos) */
    vmf_lobe lobe[LOBEFIT_MAX_VIEWS];    /* local frame, for that wo (mu.y = 0 by symmetry) */
    float alpha[LOBEFIT_MAX_VIEWS][3];   /* int f_s(wi, wo) cos(theta_i) dwi per channel */
    float err[LOBEFIT_MAX_VIEWS];        /* relative L2 error against the specular slice */
    float err_whole[LOBEFIT_MAX_VIEWS];  /* the same error relative to the whole slice */
    float err_mean, err_max;             /* over views, of err */
    float err_whole_mean, err_whole_max; /* over views, of err_whole */
    /* The two-lobe fit ("Two lobes"; desc.lobes 2), at the views where it was made and errs less: */
    int lobes;                           /* desc.lobes: 1 or 2 */
    bool mixed[LOBEFIT_MAX_VIEWS];       /* view v's slice is the two lobes mix[v] */
    vmf_lobe mix[LOBEFIT_MAX_VIEWS][2];  /* local frame as lobe[], the sharper first */
    float mix_alpha[LOBEFIT_MAX_VIEWS][2][3];   /* their colours: shares of alpha[v], summing to it */
    float err_two[LOBEFIT_MAX_VIEWS];    /* the two-lobe fit's error where it was made (kept or not), else 0 */
    float err_mix[LOBEFIT_MAX_VIEWS];    /* the error of the lobes used at v (err[v] where not mixed) */
    float err_mix_whole[LOBEFIT_MAX_VIEWS];
    float err_mix_mean, err_mix_max, err_mix_whole_mean, err_mix_whole_max;
    double seconds;
} lobefit_table;

/* True when model t has a lobe fit (phong, blinn, ggx, beckmann). */
bool lobefit_supported(brdf_type t);
/* Fits one lobe and colour per view elevation. Returns 0, or -1 with err set (model). */
int lobefit_fit(const brdf_params *p, const lobefit_desc *desc, lobefit_table *out, prt_error *err);
/* The lobe and colour for local view direction wo (wo.z > 0): laurijssen-2011 Eq. 7's
 * interpolation between the two nearest elevations (mu normalized, kappa and alpha
 * linear; clamped past the last one), rotated to wo's azimuth. */
void lobefit_lookup(const lobefit_table *t, const float wo[3], vmf_lobe *lobe, float alpha[3]);
/* The lobes and colours for local view wo as lobefit_lookup, with the two-lobe fit where the two
 * bracketing views hold one: returns 1 (lobe[0] is lobefit_lookup's; lobe[1] empty, alpha 0) when neither
 * does, else 2, each lobe Eq. 7 over the two views with luminance weights (a view's one lobe is its lobe
 * 0, its lobe 1 empty), so the colours sum to lobefit_lookup's alpha. */
int lobefit_lookup_mix(const lobefit_table *t, const float wo[3], vmf_lobe lobe[2], float alpha[2][3]);
/* The error of f's K-term SVD approximation (K <= f->K) in the lobe fit's measure,
 * relative to the whole slice, at each of t's view elevations: out[t->views]. */
void lobefit_factor_error(const lobefit_table *t, const brdf_params *p, const brdf_factor *f, int K, float *out);
#endif
