/* glvsgl.h - the local lights' one bounce on the GPU: the two VSGLs of each light (vsgl.h,
 * built on the CPU from an Embree RSM at each light move) as uniforms, and their light on
 * the receiver's lobes in GLSL (the GLSL runtime's counterpart of indirect.h's bounce).
 *
 * Usage (glrt.c does this when glrt_desc.local_bounce is set):
 *     glvsgl *V = glvsgl_create(&scene, &err);        // BVH, material lobes, an RSM (scene SHARED)
 *     ... programs built with glvsgl_glsl() after gllights_glsl() (it reads t_brdf's kd and the BRDF),
 *         VSGL_SPEC 1 and VSGL_NFIT glvsgl_fit_rows(V) when that is > 0; once each after linking:
 *     glvsgl_init_program(V, gl, prog);                 // the glossy materials' lobe tables
 *     glvsgl_set(V, &lights, &err);                     // light move: RSM + two VSGLs per light
 *     glvsgl_bind(V, gl, prog);                         // the uniforms, before drawing
 *     vec3 c = vsgl_lights(material, p, n, eye);        // in GLSL
 *     glvsgl_destroy(V);
 *
 * What the GLSL computes: vsgl_shade (vsgl.h) per pixel: Eq. 7's incoming SG of each VSGL
 * (tokuyoshi 3.1) met by Eq. 1's SG of the receiver's clamped cosine through the exact SG product
 * integral, times kd; and (VSGL_SPEC) by the receiver's glossy lobe (section 3.2): the material's
 * fitted vMF lobe looked up for the pixel's view as lightmat_lobe does (lobefit_lookup's
 * interpolation between the table's view elevations, uploaded as uniforms), made an ASG as
 * vsgl_spec_asg (isotropic for Phong, the half-vector warp for blinn, ggx, beckmann), times
 * M(xi_m) from the GLSL BRDF (brdf_glsl minus kd / pi, clamped at 4 M(z) as on the CPU) and Xu et
 * al.'s ASG-SG product integral; the exponents in the cancellation-free form of lobe.h. The lobe
 * is looked up once per pixel, not once per VSGL (the same numbers). glvsgl_set_glossy(V, false)
 * leaves the glossy lobe out (vsgl_shade_diffuse: the indirect highlights light it instead).
 * Programs without VSGL_SPEC (no glossy material) hold only the diffuse term: compiled in but
 * unused, code costs every pixel on llvmpipe (glrt.c, build_view_program).
 * Tested (tests/test_vsgl.c, vsgl/gl_glossy): the per-vertex GLSL against vsgl_shade at vertices.
 * A program whose u_nvsgl is never set (0) adds nothing. At most GLVSGL_MAX_FIT_ROWS rows of lobe
 * tables (16 glossy materials); a scene with more is refused with one line.
 *
 * Ownership: the glvsgl owns its CPU objects (no GL objects). Errors: NULL / -1 with one line. */
#ifndef PRT_GLVSGL_H
#define PRT_GLVSGL_H
#include "glctx.h"
#include "vsgl.h"
#include "gllights.h"

#define GLVSGL_MAX GLLIGHTS_MAX   /* the GLSL takes 2 VSGLs per light of LMAX */
#define GLVSGL_MAX_FIT_ROWS 256   /* uniform vec4 rows for the glossy materials' lobe tables (16 materials of 16 views) */

typedef struct glvsgl glvsgl;

/* BVH, material lobes and an RSM (default resolution) over scene (kept). NULL with err. */
glvsgl *glvsgl_create(const prt_scene *scene, prt_error *err);
void glvsgl_destroy(glvsgl *V);
/* Light move: an RSM and two VSGLs per light (at most GLVSGL_MAX). -1 with err. */
int glvsgl_set(glvsgl *V, const prt_lights *ls, prt_error *err);
/* u_nvsgl, u_vsgl and u_vsgl_spec on program prog (in use). */
void glvsgl_bind(const glvsgl *V, const gl_api *gl, GLuint prog);
/* Rows of the glossy materials' lobe tables (VSGL_NFIT; 0: no glossy material, no VSGL_SPEC). */
int glvsgl_fit_rows(const glvsgl *V);
/* True when material m has a lobe table (the glossy term shades it). */
bool glvsgl_glossy(const glvsgl *V, int m);
/* The lobe tables' uniforms on program prog (in use), once after linking one built with VSGL_SPEC. */
void glvsgl_init_program(const glvsgl *V, const gl_api *gl, GLuint prog);
/* The receiver's glossy lobe lit by the VSGLs (true, the default) or not (the highlights light it). */
void glvsgl_set_glossy(glvsgl *V, bool on);
/* The GLSL: vec3 vsgl_lights(int m, vec3 p, vec3 n, vec3 eye); needs LMAX, NMAT, VSGL_SPEC, VSGL_NFIT
 * defined and frame() and gllights_glsl() before it. */
const char *glvsgl_glsl(void);
/* Milliseconds of the last glvsgl_set. */
double glvsgl_ms(const glvsgl *V);
#endif
