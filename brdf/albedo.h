/* albedo.h - directional albedo of a BRDF by quadrature, and the energy warning.
 *
 * Usage:
 *     float a[3]; brdf_albedo(&p, 30, a);             // a(wo) per channel, wo 30 degrees from the normal
 *     float m[3], deg; brdf_albedo_max(&p, m, &deg);  // the largest over BRDF_ALBEDO_ANGLES
 *     char msg[512];
 *     if (brdf_energy_warning(&p, "phong:kd=2;ks=3", msg, sizeof msg)) fprintf(stderr, "warning: %s\n", msg);
 *
 * The directional albedo a(wo) = int_H f(wi, wo) cos(theta_i) dwi is the share of light arriving
 * from every direction that leaves toward wo (equally, by reciprocity, the share of light from wo
 * that is reflected at all). A physical BRDF has a(wo) <= 1 everywhere; above 1 the surface makes
 * light, and every interreflection pass multiplies what it gathers by up to a(wo): the passes gain
 * energy instead of converging. The models of brdf.h do not all enforce it: Phong's kd + ks (the
 * albedo at normal incidence is exactly kd + ks), the microfacet models' kd/pi added to a
 * Fresnel-weighted lobe, Lafortune's free lobes.
 *
 * Quadrature: the sphere in spherical coordinates about the mirror direction of wo (where every
 * specular lobe of brdf.h peaks; a Lafortune lobe's own peak C*wo), polar angle theta' = pi t^3
 * with BRDF_ALBEDO_NT midpoints in t and BRDF_ALBEDO_NP in phi', so the steps near the axis are
 * ~1e-7 rad and a lobe of exponent 1e6 (width ~1.4e-3 rad) gets ~7 of them. The integrand f cos
 * is continuous across the horizon (cos -> 0), so the midpoint rule converges there too.
 * Measured against closed forms (tests/test_brdf.c albedo_quadrature): Lambert kd within 2.6e-5
 * (the horizon's kink at normal incidence), Phong's kd + ks at normal incidence within 3e-5 for n
 * up to 1e4 and 4e-4 at n = 1e6 (brdf_eval's float directions), Blinn's at normal incidence
 * within 1e-6. About 10 ms a material for BRDF_ALBEDO_ANGLES on one core.
 *
 * The warning is a warning, not an error: a user may want a surface that glows under its own
 * reflections (a stylized look, a test of convergence). */
#ifndef PRT_ALBEDO_H
#define PRT_ALBEDO_H
#include "brdf.h"

#define BRDF_ALBEDO_NT 256
#define BRDF_ALBEDO_NP 128
/* The incident angles brdf_albedo_max looks at (degrees from the normal). Grazing angles past 60
 * are left out: there the microfacet models with kd > 0 exceed 1 by design (brdf.h), and light
 * arriving that flat carries little (cos 75 = 0.26). */
#define BRDF_ALBEDO_ANGLES { 0.0f, 15.0f, 30.0f, 45.0f, 60.0f }
/* Above 1 by more than this (the quadrature is within 1e-4; Blinn's normalization overshoots by
 * up to 4%, brdf.h, and is left unwarned at ks <= 1 with kd + ks <= 1), a material is warned of. */
#define BRDF_ALBEDO_SLACK 0.05f

/* Directional albedo per channel for wo theta_deg from the normal (in the xz plane). */
void brdf_albedo(const brdf_params *p, float theta_deg, float rgb[3]);
/* The largest directional albedo over BRDF_ALBEDO_ANGLES: rgb per channel (each its own
 * maximum), *theta_deg the angle of the largest channel's. */
void brdf_albedo_max(const brdf_params *p, float rgb[3], float *theta_deg);
/* True when some channel's directional albedo exceeds 1 + BRDF_ALBEDO_SLACK; msg then gets one
 * line (no "warning:" prefix, no newline) naming spec, the albedo and the angle:
 * "phong:kd=2;ks=3 reflects up to 5 of the light (directional albedo above 1 at 0 deg):
 * interreflections will gain energy". spec NULL: the canonical spec (brdf_format). */
bool brdf_energy_warning(const brdf_params *p, const char *spec, char *msg, size_t cap);
#endif
