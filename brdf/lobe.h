/* lobe.h - spherical lobes: von Mises-Fisher distributions, spherical Gaussians and
 * anisotropic spherical Gaussians (prefixes vmf_, sg_, asg_: one module, three lobe families).
 *
 * Usage:
 *     vmf_lobe v = { { 0, 0, 1 }, 50 };                 // unit mean direction mu, concentration kappa
 *     float d = vmf_eval(&v, s);                         // gamma(s), integrates to 1 over the sphere
 *     double r[3]; vmf_to_mean(&v, r);                   // mean unnormalized direction (Eq. 2)
 *     vmf_accum acc = { 0 };                             // merging (Eq. 4, 10): weighted mean of r
 *     vmf_accum_add(&acc, &a, wa); vmf_accum_add(&acc, &b, wb);
 *     vmf_lobe m; vmf_accum_result(&acc, &m);            // back to (mu, kappa) (Eq. 3)
 *     float w[3]; vmf_sample(&v, u1, u2, w);             // exact inversion (Eq. 8)
 *     sg_lobe g = { { 0, 0, 1 }, 10, 2 };                // axis, sharpness lambda, amplitude
 *     double e = sg_product_integral(&g, &h);            // int G_g G_h dw, exact
 *
 * Definitions (laurijssen-2011 Eq. 1, tokuyoshi supplement section 1):
 *   vMF  gamma(s) = c(k) e^{k mu.s},  c(k) = k / (4 pi sinh k)
 *               = C(k) e^{k (mu.s - 1)},  C(k) = k / (2 pi (1 - e^{-2k}))   (vmf_norm)
 *   SG   G(s) = a e^{l (xi.s - 1)},  int G = a A(l),  A(l) = 2 pi (1 - e^{-2l}) / l   (sg_integral)
 *   ASG  G(s) = a max(s.z, 0) e^{-ex (s.x)^2 - ey (s.y)^2}   (Xu et al. 2013, tokuyoshi 3.2)
 * So a vMF is the SG of sharpness k and amplitude C(k) (vmf_to_sg). Its mean direction
 * E[s] = A3(k) mu with A3(k) = coth k - 1/k (vmf_mean_length): the length of the mean
 * unnormalized direction r of Eq. 2 says how wide the lobe is, and Eq. 3 inverts it.
 *
 * Numerics (every function is finite for kappa, lambda in [0, VMF_KAPPA_MAX]):
 *   - the exponent is k (mu.s - 1) = -k |mu - s|^2 / 2 on directions normalized in double,
 *     so a lobe of kappa 1e6 (width 1e-3 rad) keeps full precision near its peak, and
 *     the normalization is C(k), which tends to 1/(4 pi) as k -> 0 (series below 1e-4)
 *     and to k / (2 pi) for large k; neither sinh nor e^k is ever formed;
 *   - the mean length and its inverse use series for k -> 0 and the exact 1 - 1/k tail
 *     for k > 20 (r -> 1), with double-precision mean vectors: float cannot hold
 *     1 - r = 1e-6 (kappa 1e6) to better than 6%;
 *   - products of lobes use 1 - cos = |a - b|^2 / 2 and the exponent
 *     l_m - l_a - l_b = -2 l_a l_b (1 - cos) / (l_a + l_b + l_m) <= 0, so no overflow.
 * Exponents map to kappa by cos^n t = e^{n log cos t} ~ e^{n (cos t - 1)} (second order in t):
 * a Phong lobe of exponent n is a vMF of kappa ~ n (n + 3 by moments, lobefit.h), so
 * n = 10,000 is kappa ~ 1e4; Blinn's half-vector cos^n(t/2) is kappa ~ n/4 about the mirror.
 *
 * Directions are unit 3-vectors (s is normalized by the caller; mu and axes are
 * renormalized in double where precision matters). Everything here is a pure function
 * of small structs: no allocation, no state, safe from any thread. Bad parameters are
 * bugs of the caller (PRT_CHECK on n >= 0 only); degenerate but valid inputs (kappa 0,
 * zero mean vector, zero weights) give the uniform lobe or report false. */
#ifndef PRT_LOBE_H
#define PRT_LOBE_H
#include <stdbool.h>

#define VMF_KAPPA_MAX 1e8     /* concentrations are clamped here (a mean length of 1 - 1e-8) */

/* von Mises-Fisher distribution: unit mean direction mu, concentration kappa >= 0. */
typedef struct vmf_lobe { float mu[3]; float kappa; } vmf_lobe;
/* Spherical Gaussian a e^{l (xi.s - 1)}: unit axis xi, sharpness l >= 0, amplitude a. */
typedef struct sg_lobe { float axis[3]; float sharpness; float amplitude; } sg_lobe;
/* Anisotropic SG a max(s.z,0) e^{-ex (s.x)^2 - ey (s.y)^2} on an orthonormal frame x, y, z. */
typedef struct asg_lobe { float x[3], y[3], z[3]; float eta_x, eta_y; float amplitude; } asg_lobe;
/* Running weighted sum of mean unnormalized directions (Eq. 4, 10) and of colours (Eq. 11);
 * zero-initialize. */
typedef struct vmf_accum { double r[3]; double w; double alpha[3]; int n; } vmf_accum;

/* ---------------------------------------------------------------- vMF (laurijssen-2011 section 2.1) */

/* C(k) = c(k) e^k = k / (2 pi (1 - e^{-2k})) (Eq. 1 rescaled so it never overflows). */
double vmf_norm(double kappa);
/* gamma(s) = C(k) e^{k (mu.s - 1)} (Eq. 1); s a unit direction. */
float vmf_eval(const vmf_lobe *v, const float s[3]);
/* A3(k) = coth k - 1/k = |E[s]|, the mean resultant length (the length of r in Eq. 2). */
double vmf_mean_length(double kappa);
/* Eq. 3 as printed (Banerjee et al. 2005): k ~ (3r - r^3) / (1 - r^2), clamped to VMF_KAPPA_MAX.
 * It overestimates: by at most 4.94% (at kappa ~ 4.9), 0.5% at kappa 100, ~1/(2 kappa) beyond
 * (measured in tests/test_lobe.c); prefer vmf_kappa_from_length outside a shader. */
double vmf_kappa_banerjee(double r);
/* The exact inverse of vmf_mean_length for r in [0, 1) (Newton from Eq. 3); 0 for r <= 0,
 * VMF_KAPPA_MAX for r >= 1 - 1/VMF_KAPPA_MAX. */
double vmf_kappa_from_length(double r);
/* Mean unnormalized direction r = E[s] = A3(k) mu (Eq. 2's expectation), in double. */
void vmf_to_mean(const vmf_lobe *v, double r[3]);
/* (mu, kappa) from a mean unnormalized direction (Eq. 3, exact inverse); |r| = 0 gives the
 * uniform lobe (kappa 0, mu = +z). */
void vmf_from_mean(const double r[3], vmf_lobe *out);
/* Adds weight * r(v) to a merge (Eq. 10: weight = the luminance of the lobe's colour). */
void vmf_accum_add(vmf_accum *acc, const vmf_lobe *v, double weight);
/* Adds one sample direction s (Eq. 2: r = mean of the s_i), normalized in double first so
 * that float rounding of |s| (6e-8) does not swamp 1 - |r| (1e-6 at kappa 1e6). */
void vmf_accum_add_dir(vmf_accum *acc, const float s[3], double weight);
/* Gathering (laurijssen-2011 5.2): adds lobe v of colour alpha with Eq. 10's weight, the
 * luminance of alpha, and alpha to Eq. 11's sum. */
void vmf_accum_add_colour(vmf_accum *acc, const vmf_lobe *v, const float alpha[3]);
/* Eq. 11's colour of the merged lobe before the BRDF colour: (1/M) sum alpha_i over the M
 * lobes added with vmf_accum_add_colour (0 when none). */
void vmf_accum_colour(const vmf_accum *acc, float out[3]);
/* The merged lobe: r_m = sum w_i r_i / sum w_i (Eq. 4, 10), then Eq. 3. False (and the
 * uniform lobe) when the total weight is not positive. */
bool vmf_accum_result(const vmf_accum *acc, vmf_lobe *out);
/* Merges n lobes with weights w (NULL: equal weights, Eq. 4) into one (Eq. 10); false as above. */
bool vmf_merge(const vmf_lobe *in, const float *w, int n, vmf_lobe *out);
/* A direction distributed as gamma from u1, u2 in [0,1) (Eq. 8 without its large-kappa
 * approximation): cos t = 1 + log(u1 + (1 - u1) e^{-2k}) / k, phi = 2 pi u2 around mu. */
void vmf_sample(const vmf_lobe *v, float u1, float u2, float out[3]);
/* int gamma_a gamma_b ds = C(ka) C(kb) / C(km) e^{km - ka - kb}, km = |ka mu_a + kb mu_b|. */
double vmf_product_integral(const vmf_lobe *a, const vmf_lobe *b);
/* Spherical convolution of a with a zonal vMF kernel of concentration kb: a vMF about
 * mu_a whose mean length is A3(ka) A3(kb) (mean lengths multiply; the filtered-environment
 * lookup of laurijssen-2011 7.1, the equal-kappa merge of laurijssen-2010 section 5). */
void vmf_convolve(const vmf_lobe *a, double kappa_b, vmf_lobe *out);
/* The vMF weight * gamma as an SG: axis mu, sharpness k, amplitude weight * C(k). */
void vmf_to_sg(const vmf_lobe *v, float weight, sg_lobe *out);

/* ---------------------------------------------------------------- SG (tokuyoshi section 1, 3) */

/* a e^{l (xi.s - 1)}; s a unit direction. */
float sg_eval(const sg_lobe *g, const float s[3]);
/* A(l) = int e^{l (xi.s - 1)} ds = 2 pi (1 - e^{-2l}) / l (4 pi at l = 0). */
double sg_integral(double sharpness);
/* The product of two SGs is an SG (tokuyoshi Eq. 7): axis (la xa + lb xb)/|.|,
 * sharpness lm = |la xa + lb xb|, amplitude aa ab e^{lm - la - lb}. */
void sg_product(const sg_lobe *a, const sg_lobe *b, sg_lobe *out);
/* int G_a G_b ds, exact: the product's amplitude times A(lm). */
double sg_product_integral(const sg_lobe *a, const sg_lobe *b);
/* Iwasaki et al. 2012's approximation used in tokuyoshi 3.2 (diffuse):
 * 2 pi aa ab e^{(la lb / (la + lb)) (xa.xb - 1)} / (la + lb); exact as both lambdas grow. */
double sg_product_integral_approx(const sg_lobe *a, const sg_lobe *b);

/* ---------------------------------------------------------------- ASG (tokuyoshi 3.2, Xu et al. 2013) */

/* a max(s.z, 0) e^{-ex (s.x)^2 - ey (s.y)^2}. */
float asg_eval(const asg_lobe *g, const float s[3]);
/* int ASG(s) SG(s) ds ~ pi aa ag / sqrt((ex + v)(ey + v)) ASG'(xi_g), v = l_g / 2, where ASG'
 * has bandwidths ex v / (ex + v), ey v / (ey + v) and amplitude 1 (tokuyoshi 3.2's specular
 * term; an approximation that is accurate for sharp lobes, tested against quadrature). */
double asg_sg_product_integral(const asg_lobe *a, const sg_lobe *g);
#endif
