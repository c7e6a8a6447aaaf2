/* gllights.h - local lights on the GPU: a distance cube map per light for its
 * shadows, the analytic BRDFs in GLSL, and the per-pixel (or per-vertex) direct light the
 * GLSL runtime adds to the probe's PRT result.
 *
 * Usage (glrt.c does this; a caller only needs glrt_set_local_lights):
 *     gllights *L = gllights_create(gl, &scene, &err);          // the scene is SHARED
 *     gllights_set(L, &lights, vao, ntris, &err);                // light move: the shadow cubes
 *     ... a program built with gllights_glsl() after glrt's common view code:
 *     gllights_bind(L, prog);                                    // uniforms + textures, before drawing
 *     vec3 c = local_lights(material, p, n, eye);                // in GLSL: sum over the lights
 *     gllights_destroy(L);
 *
 * Shadows: a point light renders the scene into a GLLIGHTS_RES^2 x 6 cube of distances
 * |x - light| (R32F, nearest); a spot light into one GLLIGHTS_RES^2 perspective map along its
 * axis, 2 degrees wider than its outer cone (a sixth of the cube's drawing; a spot wider than
 * GLLIGHTS_SPOT_MAX_DEG takes a cube, where one map's texels would stretch). A point is lit when its distance, taken
 * from the point offset along its normal by 1.5 texels, is within a small bias of the stored
 * one: the shadow test is per pixel, the CPU's is one ray per vertex.
 * Shading: local_lights() is light_shade (lights.h) in GLSL: brdf_eval of the material (every
 * model of brdf.h, ported from brdf.c line by line in float; tests/test_locallight.c checks it
 * against brdf_eval at random directions), light_falloff's smoothstep, times the shadow test.
 * The GLSL needs glrt's frame() (Eq. 10's tangent frame, as brdf_frame) defined before it.
 *
 * Limits: at most GLLIGHTS_MAX lights (a set with more is refused with one line); texture
 * units GLLIGHTS_UNIT .. GLLIGHTS_UNIT + 2 GLLIGHTS_MAX (the cubes, the BRDF table, the spot
 * maps), so the context needs 2 GLLIGHTS_MAX + GLLIGHTS_UNIT + 1 texture image units per stage
 * (gllights_supported).
 *
 * Ownership: the gllights owns its GL objects (destroy with the context current). Errors:
 * NULL / -1 with one line. */
#ifndef PRT_GLLIGHTS_H
#define PRT_GLLIGHTS_H
#include "glctx.h"
#include "scene.h"

#define GLLIGHTS_MAX 4
#define GLLIGHTS_UNIT 17   /* after glrt.c's units (GLRT_UNIT_TVU = 16) */
#define GLLIGHTS_RES 512
#define GLLIGHTS_SPOT_MAX_DEG 75   /* a spot of wider outer angle takes a cube, as a point light */

typedef struct gllights gllights;

/* True when the context has the texture units local lights need (vertex and fragment stages). */
bool gllights_supported(const gl_api *gl);
/* The BRDF table of scene's materials uploaded, the shadow program built. NULL with err. */
gllights *gllights_create(const gl_api *gl, const prt_scene *scene, prt_error *err);
void gllights_destroy(gllights *L);
/* Light move: copies ls and renders each light's shadow cube from the mesh in vao (positions at
 * attribute 0, ntris indexed triangles bound to it). Leaves framebuffer 0 bound. -1 with err. */
int gllights_set(gllights *L, const prt_lights *ls, GLuint vao, int ntris, prt_error *err);
/* Sets the lights' uniforms on program prog (in use) and binds the textures to their units. */
void gllights_bind(const gllights *L, GLuint prog);
/* Binds the sampler uniforms of prog (in use) to their units and sets no light: call once after linking. */
void gllights_init_program(const gl_api *gl, GLuint prog);
/* The GLSL: BRDF evaluation (brdf_glsl(m, wi, wo), local frame) and local_lights(m, p, n, eye). Needs
 * LMAX defined (0: local_lights returns 0 and no sampler is declared) and frame() before it. */
const char *gllights_glsl(void);
/* Test hook: brdf_glsl of material m of the gllights' scene at n direction pairs (local frame;
 * wi, wo [3n]) into rgb [3n], through a float framebuffer. -1 with err. */
int gllights_eval_brdf(gllights *L, int m, const float *wi, const float *wo, int n, float *rgb, prt_error *err);
#endif
