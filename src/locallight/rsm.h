/* rsm.h - a reflective shadow map of one local light, traced with Embree on the CPU
 * (Dachsbacher and Stamminger 2005; tokuyoshi section 2's set of VPLs S).
 *
 * Usage:
 *     rsm *r = rsm_create(&(rsm_desc){ .res = 64 }, &err);
 *     rsm_render(r, &light, vs, &scene.mesh, lm);      // again whenever the light moves
 *     for (int i = 0; i < rsm_count(r); i++) { const rsm_texel *t = rsm_texels(r) + i; ... }
 *     rsm_destroy(r);
 *
 * Each texel is one photon of the light: a ray from the light's position through the
 * texel centre, its flux the power the light sends into the texel's solid angle,
 * Phi_i = I(w) Omega_i (W; I from light_intensity_toward, so the spot falloff is the one
 * every runtime uses), and at its first hit x_i the VPL's data: position, shading normal
 * (interpolated vertex normals, as the path tracer uses), the unit direction back to the
 * light, diffuse reflectance R_d = kd, the glossy lobe of the hit material reflected over
 * outgoing directions (lightmat_lobe with wo := wi, reciprocity) and its reflectance R_s,
 * and the footprint area Omega_i r^2 / cos, which vsgl.h turns into the VPL's own spread.
 * A miss, or a hit from behind the shading normal (one-sided, like brdf_eval), keeps its
 * flux but reflects nothing (mat = -1 or R = 0).
 *
 * Layout: a spot light whose outer cone is under RSM_SQUARE_MAX_DEG maps its cone to one
 * res x res square on the plane at unit distance along its axis (side 2 tan(outer));
 * a point light, or a wider spot, gets a cube map of six res x res faces (cubemap.h's
 * order and directions). Texel solid angles are exact (cube_texel_solid_angle scaled by
 * the square's side: the gnomonic area formula), so the fluxes of a point light sum to
 * 4 pi I exactly and a spot's to its cone's power up to the texels' quadrature.
 *
 * Threads: the rows are traced with vis_closest_many (packets of 16 rays from the light)
 * on desc.threads (0: all cores) with prt_parallel_for.
 * Ownership: the rsm owns its texels; vs, mesh and lm are only read during rsm_render.
 * Errors: a res outside [4, 1024] or out of memory: NULL from rsm_create and one line in err. */
#ifndef PRT_RSM_H
#define PRT_RSM_H
#include "lights.h"
#include "lightmat.h"
#include "visibility.h"

#define RSM_DEFAULT_RES 64
#define RSM_SQUARE_MAX_DEG 75.0f

typedef struct rsm_desc {
    int res;       /* texels per side of the square or of each cube face; 0: 64 */
    int threads;   /* 0: prt_thread_count(0) */
} rsm_desc;

typedef struct rsm_texel {
    float pos[3];     /* hit position x_i */
    float nrm[3];     /* unit shading normal n_i */
    float wi[3];      /* unit direction from x_i to the light (the photon's incoming w_i', reversed) */
    float flux[3];    /* Phi_i: W carried by the photon (rgb) */
    float kd[3];      /* R_d, the diffuse reflectance (0 when back-facing or a miss) */
    float ks[3];      /* R_s, the glossy lobe's reflectance (0 when none) */
    vmf_lobe spec;    /* the glossy lobe over outgoing directions (world), when ks > 0 */
    float area;       /* footprint on the surface, Omega_i r^2 / cos (m^2) */
    int mat;          /* material index, -1 for a miss */
} rsm_texel;

typedef struct rsm rsm;

/* Allocates an empty map; NULL with err on a bad res or no memory. */
rsm *rsm_create(const rsm_desc *desc, prt_error *err);
/* Frees it (NULL is fine). */
void rsm_destroy(rsm *r);
/* Traces the map for light l over the scene (vs built from mesh); seconds it took. */
double rsm_render(rsm *r, const prt_light *l, const vis_scene *vs, const prt_mesh *mesh, const lightmat *lm);
/* Texels of the last render: rsm_count of them (0 before the first). */
int rsm_count(const rsm *r);
const rsm_texel *rsm_texels(const rsm *r);
/* The sum of the photons' fluxes (W, rgb): the light's power inside the map. */
void rsm_total_flux(const rsm *r, double out[3]);
#endif
