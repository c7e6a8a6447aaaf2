/* vsgl.h - two virtual spherical-Gaussian lights from a reflective shadow map, and the
 * one bounce of local light they give a surface point (tokuyoshi supplement, sections 1-3).
 *
 * Usage:
 *     vsgl_pair v; vsgl_build(r, &v);                  // after rsm_render, each time the light moves
 *     float L[3]; vsgl_shade(&v, lm, mat, x, n, wo, L); // reflected radiance toward wo (W/(sr m^2))
 *
 * Building (section 2): every RSM texel is a VPL of power Phi_i; its reflection lobe is
 * split into a diffuse part, R_d G(w, n_i, 2) / A(2) (Eq. 1, lambda_d = VSGL_LAMBDA_D), and a
 * glossy one, R_s G(w, xi_i, kappa_i) / A(kappa_i) (Eq. 2; the fitted vMF of lightmat.h is that
 * normalized SG). Each part's VPLs are summed into one VSGL: total power P = sum Phi_i R_i
 * (rgb); Toksvig's filtering of the lobes, xi~_v = sum w_i lambda_i / (lambda_i + 1) xi_i /
 * sum w_i, xi_v = xi~_v / |xi~_v|, lambda_v = |xi~_v| / (1 - |xi~_v|) (section 2.1), c_v = P /
 * A(lambda_v) per channel, so the radiant intensity I_v(w) = c_v G(w, xi_v, lambda_v)
 * integrates to exactly P; and the positional Gaussian mu_v = sum w_i x_i / sum w_i (2.2).
 * The weights w_i are the luminances of Phi_i R_i (a direction and a position need a scalar).
 * Variance: Eq. 3 and 6 use g(r, s^2) = e^{-r^2 / 2 s^2}, a Gaussian on a plane with s^2 per
 * axis, while E|x|^2 - |mu|^2 (2.2's formula) is the sum over both in-plane axes, so
 * sigma_v^2 = (E|x|^2 - |mu|^2) / 2; and each VPL stands for its texel's footprint A_i,
 * a Gaussian of equal area (2 pi s_i^2 = A_i), so sigma_v^2 also adds sum w_i A_i / 2 pi / sum w_i.
 * This makes a VSGL of one VPL a small area light, not a singularity.
 *
 * Shading (section 3): the incoming radiance at x is Eq. 7's SG, c_in G(w, xi_in, lambda_in),
 * the product of I_v(-w) / (2 pi sigma_v^2) and Eq. 6's G(w, xi_mu, |mu_v - x|^2 / sigma_v^2).
 * Diffuse reflection (3.2): R_d / A(lambda_d) times the exact SG product integral
 * (sg_product_integral; the poster's Iwasaki approximation and A(2) ~ pi are not needed on
 * the CPU). Glossy reflection (3.2): the shading point's specular lobe f_s(w, wo) cos as
 * M(w) ASG(w), an ASG about the fitted lobe's axis z (lightmat_lobe) times
 * c_in M(xi_m) asg_sg_product_integral, xi_m = (lambda_in xi_in + kappa z) / |.|, M(xi_m) =
 * f_s(xi_m, wo) cos / ASG(xi_m) (the exact BRDF at the integrand's axis, clamped to four
 * times its value at z where the ASG's tail is small). Bandwidths: a Phong lobe is
 * isotropic about the mirror direction, eta_x = eta_y = (kappa - 1) / 2 (the ASG's own
 * max(w.z, 0) takes e^{-theta^2/2} of the vMF's e^{-kappa theta^2 / 2}); the half-vector
 * models (blinn, ggx, beckmann) warp D(h) to w-space (Wang et al. 2009): tilting h by e in
 * the plane of incidence turns w by 2e, across it by 2 cos(theta_o) e, so the lobe is
 * cos(theta_o) times narrower across: eta_x = kappa cos / 2, eta_y = kappa / (2 cos), the
 * fitted kappa kept as their geometric mean, minus 1/2 each as for Phong.
 * Both VSGLs light both lobes of the receiver: L = sum over {diffuse, glossy} VSGL of
 * L_d + L_s. No visibility (the poster has none): a VSGL lights through walls.
 *
 * Bound (tests/test_vsgl.c, vsgl/one_vpl): a VSGL of one diffuse VPL of tiny footprint
 * equals the VPL's exact contribution I cos_r / d^2 kd / pi times r(theta_e) r(theta_r), where
 * r(theta) = (G(theta; 2) / A(2)) / (cos theta / pi) is Eq. 1's error at the emitting and the
 * receiving end: 1.019 at 0, 0.900 at 30, 0.750 at 60 degrees, so a VSGL of one VPL is 4% high
 * with both normals facing, 19% low at 30 degrees at both ends and 44% low at 60 (measured
 * to 0.01%: the rest of the pipeline, Toksvig, Eq. 6-7 and the product integral, is exact here).
 *
 * Everything is a pure function of plain structs: thread-safe, no allocation. */
#ifndef PRT_VSGL_H
#define PRT_VSGL_H
#include "rsm.h"

#define VSGL_LAMBDA_D 2.0f     /* Eq. 1's sharpness of the SG for a clamped cosine */

/* One VSGL: radiant intensity c G(w, axis, sharpness) (W/sr) emitted from the Gaussian N(mean, var). */
typedef struct vsgl_light {
    float axis[3];      /* xi_v */
    float sharpness;    /* lambda_v */
    float c[3];         /* c_v (rgb) */
    float power[3];     /* sum Phi_i R_i (W, rgb) */
    float mean[3];      /* mu_v */
    float var;          /* sigma_v^2 per axis (m^2) */
} vsgl_light;

typedef struct vsgl_pair { vsgl_light diffuse, specular; } vsgl_pair;

/* Running sums of section 2 (zero-initialize). */
typedef struct vsgl_accum { double w, power[3], dir[3], pos[3], pos2, spread; } vsgl_accum;

/* Adds one VPL: position x, lobe axis and sharpness, Phi_i R_i (rgb), footprint area (m^2). */
void vsgl_accum_add(vsgl_accum *a, const float x[3], const float axis[3], float sharpness, const float phi_r[3],
                    float area);
/* The VSGL of the VPLs added; false (and a zero light) when their power is zero. */
bool vsgl_accum_result(const vsgl_accum *a, vsgl_light *out);
/* Both VSGLs of the map's VPLs (diffuse from R_d, glossy from R_s). */
void vsgl_build(const rsm *r, vsgl_pair *out);
/* Eq. 7: incoming radiance at x from v, rgb * G(w; g) (g's amplitude 1); false when v is empty. */
bool vsgl_incoming(const vsgl_light *v, const float x[3], sg_lobe *g, float rgb[3]);
/* Radiance reflected toward wo at x (normal n, material m of lm) from both VSGLs (section 3.2). */
void vsgl_shade(const vsgl_pair *v, const lightmat *lm, int m, const float x[3], const float n[3], const float wo[3],
                float out[3]);
/* vsgl_shade's receiver-diffuse part alone (the SG product with Eq. 1's lobe): what indirect.h
 * uses at a glossy vertex whose glossy lobe the highlights' gather lights instead. */
void vsgl_shade_diffuse(const vsgl_pair *v, const lightmat *lm, int m, const float x[3], const float n[3], float out[3]);
/* vsgl_shade_diffuse for a Lambert receiver of reflectance kd (a BRDF with no glossy lobe), the
 * same value to float rounding, in one closed form per VSGL: the three SGs of Eq. 6, 7 and 1
 * (I_v(-w), the positional G(w, xi_mu, lambda_s), the receiver's G(w, n, 2)) integrate to
 * e^{-(sum l_i - r)} A(r), r = |sum l_i a_i| (what sg_product then sg_product_integral give
 * in two steps). The indirect stage's per-vertex sum at each light move. */
void vsgl_shade_lambert(const vsgl_pair *v, const float kd[3], const float x[3], const float n[3], float out[3]);
/* The glossy lobe at a shading point as an ASG of amplitude 1 and its vMF sharpness kappa;
 * false when m is not glossy or wo is below the horizon (see header for the bandwidths). */
bool vsgl_spec_asg(const lightmat *lm, int m, const float n[3], const float wo[3], asg_lobe *a, float *kappa);
#endif
