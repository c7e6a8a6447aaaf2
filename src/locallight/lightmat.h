/* lightmat.h - the scene's materials as the local-light modules see them: diffuse
 * reflectance, and for glossy models one vMF lobe per view fitted once.
 *
 * Usage:
 *     lightmat *lm = lightmat_create(&scene, &err);           // fits each glossy material once
 *     vmf_lobe g; float alpha[3];
 *     if (lightmat_lobe(lm, m, n, wo, &g, alpha)) ...          // f_s(wi, wo) cos(theta_i) ~ alpha g(wi)
 *     float f[3]; lightmat_spec_eval(lm, m, n, wi, wo, f);      // the exact specular f_s, no cosine
 *     lightmat_destroy(lm);
 *
 * Glossy models are the four lobefit.h fits (phong, blinn, ggx, beckmann): their lobe and
 * colour alpha (the specular slice's hemispherical integral, so the lobe carries its
 * energy) come from lobefit_lookup in the local frame of brdf_frame(n), rotated to world.
 * By reciprocity the same lobe, looked up with wo := wi, is the lobe a surface lit from
 * wi reflects over outgoing directions (tokuyoshi Eq. 2: R_s = alpha, the normalized SG
 * of sharpness kappa = the vMF, vmf_to_sg) and the lobe a surface seen from wo gathers
 * (laurijssen-2010 Eq. 9's rho~(q, s', -s)). Lambert, Ashikhmin-Shirley and Lafortune are
 * diffuse-only here (their kd; AS's coupled diffuse and Lafortune's lobes are not fitted).
 * The specular part of f is brdf_eval minus kd/pi (the plain diffuse term of the four models).
 *
 * Cost: one lobefit_fit per glossy material (16 views, res 128: ~0.1 s each).
 * Ownership: lightmat_create copies the material parameters; the scene may be freed.
 * Errors: out of memory or a failed fit: NULL and one line in err. Lookups are pure
 * reads (thread-safe). */
#ifndef PRT_LIGHTMAT_H
#define PRT_LIGHTMAT_H
#include "scene.h"
#include "lobe.h"
#include "visibility.h"

typedef struct lightmat lightmat;

/* Copies the scene's materials and fits the glossy ones; NULL with err on failure. */
lightmat *lightmat_create(const prt_scene *s, prt_error *err);
/* Frees it (NULL is fine). */
void lightmat_destroy(lightmat *lm);
/* Number of materials. */
int lightmat_count(const lightmat *lm);
/* Material m's parameters. */
const brdf_params *lightmat_brdf(const lightmat *lm, int m);
/* True when material m has a fitted lobe. */
bool lightmat_glossy(const lightmat *lm, int m);
/* Material m's lobe table (lobefit.h), NULL when m is not glossy: what a GPU runtime uploads to
 * evaluate lightmat_lobe in a shader (gpu/glvsgl.c). */
const struct lobefit_table *lightmat_fit(const lightmat *lm, int m);
/* The world-frame lobe over wi of f_s(wi, wo) cos(theta_i) at normal n and its colour alpha
 * (rgb); false (alpha 0) when m is not glossy or wo is below the horizon of n. */
bool lightmat_lobe(const lightmat *lm, int m, const float n[3], const float wo[3], vmf_lobe *lobe, float alpha[3]);
/* The specular part of f_r(wi, wo) (world directions, normal n), no cosine; 0 for diffuse-only
 * materials or directions below the horizon. */
void lightmat_spec_eval(const lightmat *lm, int m, const float n[3], const float wi[3], const float wo[3],
                        float rgb[3]);
/* The surface at a ray hit on mesh: barycentric position, interpolated vertex normal
 * (the geometric one where they cancel), and the material of the triangle's first vertex,
 * as the path tracer reads them (src/reference). Returns the material index (0 when the
 * mesh has none or it is out of lm's range). */
int lightmat_surface(const lightmat *lm, const prt_mesh *m, const vis_hit *h, float pos[3], float nrm[3]);
#endif
