/* direct.h - direct light from local lights at the vertices, with Embree shadow rays
 * (the CPU runtime's local light, and the per-vertex truth the tests use).
 *
 * Usage:
 *     direct_ctx *dc = direct_create(&scene, 0, &err);   // scene is SHARED: keep it alive
 *     direct_set_lights(dc, &scene.lights, &err);       // light move: one shadow ray per vertex and light
 *     direct_shade_vertices(dc, eye, rgb);              // view change: ADDS each light's radiance to rgb
 *     direct_destroy(dc);
 *
 * What it computes. For a delta light the rendering equation's integral is one term:
 * L_o(v, wo) = sum_l f_r(wi, wo) I_l(-wi) (n . wi) / d^2 V(v, l) (lights.h: light_shade),
 * the analytic BRDF of the vertex's material (brdf_eval), never the PRT factorization.
 * V is one Embree occlusion ray from p + eps n (the offset vis_cube and prt reference
 * use at a vertex) toward the light, stopping eps short of it; lights that send nothing
 * to a vertex (behind its horizon, outside a spot's cone) trace no ray.
 *
 * Cost split (the runtime's light and view changes): direct_set_lights traces the rays on
 * every thread (prt_parallel_for) and keeps one visibility byte per vertex and light; the
 * Lambert vertices' radiance, independent of the view, is summed there too. A view change
 * evaluates the BRDF again only at non-Lambert vertices.
 *
 * Textures (texture.h): a textured material's kd is multiplied by its texture at the vertex
 * (scene_vertex_albedo), as the PRT colour's sparse sum is (relight.h) and prt reference's kd at
 * each hit; the raster of a textured scene takes the kd part apart (direct_diffuse_vertices) to
 * multiply it per pixel.
 *
 * Vertices whose normal faces away from the eye get nothing added (one-sided surfaces, as
 * the runtimes and prt reference). Non-finite sums are never added.
 *
 * Ownership: the context owns its BVH and buffers; the scene is the caller's. Errors:
 * NULL / -1 with one line (empty scene, out of memory). */
#ifndef PRT_DIRECT_H
#define PRT_DIRECT_H
#include "common.h"
#include "scene.h"
#include "visibility.h"

typedef struct direct_ctx direct_ctx;

/* What the last direct_set_lights / direct_shade_vertices did. */
typedef struct direct_stats {
    int lights;             /* lights in use */
    long rays;              /* shadow rays traced by the last light move */
    double light_ms;        /* last direct_set_lights (rays + Lambert sums), wall clock */
    double view_ms;         /* last direct_shade_vertices */
    int glossy_vertices;    /* vertices re-evaluated at each view change */
} direct_stats;

/* Builds the BVH over scene->mesh (Embree). nthreads 0: all cores. NULL with err. */
direct_ctx *direct_create(const prt_scene *scene, int nthreads, prt_error *err);
/* The BVH it traces shadow rays in (owned by dc), for others to borrow while dc lives. */
const vis_scene *direct_vis(const direct_ctx *dc);
/* Frees it (NULL is fine). */
void direct_destroy(direct_ctx *dc);
/* Light move: copies ls (each validated) and traces the shadow rays. -1 with err (invalid light). */
int direct_set_lights(direct_ctx *dc, const prt_lights *ls, prt_error *err);
/* View change: adds every light's shadowed radiance toward eye to rgb[3 * nverts]. */
void direct_shade_vertices(direct_ctx *dc, const float eye[3], float *rgb);
/* The part of it kd gives before the texture (a raster multiplies it by the texture per pixel):
 * added to rgb[3 * nverts]; direct_shade_vertices = texture x this + the rest at every vertex. */
void direct_diffuse_vertices(direct_ctx *dc, const float eye[3], float *rgb);
/* Visibility (0 or 1) of light l from vertex v as the last light move found it. */
int direct_visible(const direct_ctx *dc, int l, int v);
/* The last calls' figures. */
void direct_get_stats(const direct_ctx *dc, direct_stats *st);
#endif
