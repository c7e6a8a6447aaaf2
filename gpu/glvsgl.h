/* glvsgl.h - the local lights' one bounce on the GPU: the two VSGLs of each light (vsgl.h,
 * built on the CPU from an Embree RSM at each light move) as uniforms, and their light on
 * the receiver's diffuse lobe in GLSL (issue 11, item 3 on the GLSL runtime).
 *
 * Usage (glrt.c does this when glrt_desc.local_bounce is set):
 *     glvsgl *V = glvsgl_create(&scene, &err);        // BVH, material lobes, an RSM (scene SHARED)
 *     glvsgl_set(V, &lights, &err);                     // light move: RSM + two VSGLs per light
 *     ... a program built with glvsgl_glsl() after gllights_glsl() (it reads t_brdf's kd):
 *     glvsgl_bind(V, gl, prog);                         // the uniforms, before drawing
 *     vec3 c = vsgl_lights(material, p, n);             // in GLSL
 *     glvsgl_destroy(V);
 *
 * What the GLSL computes: vsgl_shade_diffuse (vsgl.h) per pixel: Eq. 7's incoming SG of each
 * VSGL (tokuyoshi 3.1) met by Eq. 1's SG of the receiver's clamped cosine through the exact SG
 * product integral, times kd; the exponents in the cancellation-free form of lobe.h. The
 * receiver's glossy lobe (the ASG of section 3.2 needs the fitted lobe per view) and the
 * indirect highlights stay on the cpu runtime: on gl a glossy surface gets only the VSGL light
 * on its kd. The per-vertex view model (gl_shade_vertices) has no VSGL term.
 * A program whose u_nvsgl is never set (0) adds nothing.
 *
 * Ownership: the glvsgl owns its CPU objects (no GL objects). Errors: NULL / -1 with one line. */
#ifndef PRT_GLVSGL_H
#define PRT_GLVSGL_H
#include "glctx.h"
#include "vsgl.h"
#include "gllights.h"

#define GLVSGL_MAX GLLIGHTS_MAX   /* the GLSL takes 2 VSGLs per light of LMAX */

typedef struct glvsgl glvsgl;

/* BVH, material lobes and an RSM (default resolution) over scene (kept). NULL with err. */
glvsgl *glvsgl_create(const prt_scene *scene, prt_error *err);
void glvsgl_destroy(glvsgl *V);
/* Light move: an RSM and two VSGLs per light (at most GLVSGL_MAX). -1 with err. */
int glvsgl_set(glvsgl *V, const prt_lights *ls, prt_error *err);
/* u_nvsgl and u_vsgl on program prog (in use). */
void glvsgl_bind(const glvsgl *V, const gl_api *gl, GLuint prog);
/* The GLSL: vec3 vsgl_lights(int m, vec3 p, vec3 n); needs LMAX and gllights_glsl() before it. */
const char *glvsgl_glsl(void);
/* Milliseconds of the last glvsgl_set. */
double glvsgl_ms(const glvsgl *V);
#endif
