/* glvsgl.c - VSGL uniforms and their GLSL (glvsgl.h).
 *
 * The VSGLs are a handful of numbers per light, so the GPU gets them as uniforms: the RSM and
 * the sums stay on the CPU (Embree), as in the cpu runtime, and cost the same there. */
#include "glvsgl.h"
#include <stdlib.h>

struct glvsgl {
    const prt_scene *scene;
    vis_scene *vs;
    lightmat *lm;
    rsm *r;
    int n;                               /* VSGLs in use: 2 per light */
    float u[2 * GLVSGL_MAX][3][4];       /* per VSGL: (axis, sharpness), (c, var), (mean, 0) */
    double ms;
};

static const char *k_glsl =
    "#if LMAX > 0\n"
    "uniform int u_nvsgl;\n"
    "uniform vec4 u_vsgl[6 * LMAX];\n"
    /* sg_product (lobe.h): axis, sharpness lm and amplitude e^{lm - la - lb}, the exponent as
     * -2 la lb (1 - cos) / (la + lb + lm) with 1 - cos = |a - b|^2 / 2 (no cancellation). */
    "float sg_prod(vec3 a, float la, vec3 b, float lb, out vec3 axis, out float lm) {\n"
    "    vec3 v = la * a + lb * b;\n"
    "    lm = length(v);\n"
    "    axis = lm > 0.0 ? v / lm : a;\n"
    "    vec3 d = a - b;\n"
    "    return exp(-la * lb * dot(d, d) / max(la + lb + lm, 1e-20));\n"
    "}\n"
    "float sg_area(float l) { return l > 1e-4 ? 6.2831853 * (1.0 - exp(-2.0 * l)) / l : 12.566371; }\n"
    /* vsgl_shade_diffuse: Eq. 6-7's incoming SG, then its product integral with G(n, 2) / A(2). */
    "vec3 vsgl_one(int j, vec3 kd, vec3 p, vec3 n) {\n"
    "    vec4 A = u_vsgl[3 * j], C = u_vsgl[3 * j + 1], M = u_vsgl[3 * j + 2];\n"
    "    vec3 dm = M.xyz - p;\n"
    "    float d2 = dot(dm, dm);\n"
    "    if (!(C.w > 0.0) || !(d2 > 0.0)) return vec3(0.0);\n"
    "    float var = max(C.w, d2 * 1e-8);\n"
    "    vec3 xin, x2;\n"
    "    float lin, l2;\n"
    "    float cin = sg_prod(-A.xyz, A.w, dm * inversesqrt(d2), d2 / var, xin, lin) / (6.2831853 * var);\n"
    "    float I = sg_prod(xin, lin, n, 2.0, x2, l2) * sg_area(l2) / sg_area(2.0);\n"
    "    return C.rgb * kd * (cin * I);\n"
    "}\n"
    "vec3 vsgl_lights(int m, vec3 p, vec3 n) {\n"
    "    vec3 kd = texelFetch(t_brdf, m * 7 + 1).rgb, c = vec3(0.0);\n"
    "    for (int j = 0; j < u_nvsgl; j++) c += vsgl_one(j, kd, p, n);\n"
    "    return c;\n"
    "}\n"
    "#else\n"
    "vec3 vsgl_lights(int m, vec3 p, vec3 n) { return vec3(0.0); }\n"
    "#endif\n";

const char *glvsgl_glsl(void) { return k_glsl; }

glvsgl *glvsgl_create(const prt_scene *scene, prt_error *err)
{
    glvsgl *V = prt_calloc(1, sizeof *V, err);
    if (!V) return NULL;
    V->scene = scene;
    if (!(V->vs = vis_create(&scene->mesh, err)) || !(V->lm = lightmat_create(scene, err)) ||
        !(V->r = rsm_create(&(rsm_desc){ 0 }, err))) {
        glvsgl_destroy(V);
        return NULL;
    }
    return V;
}

void glvsgl_destroy(glvsgl *V)
{
    if (!V) return;
    rsm_destroy(V->r);
    lightmat_destroy(V->lm);
    if (V->vs) vis_destroy(V->vs);
    free(V);
}

/* One RSM and vsgl_build per light, packed into the uniform layout. */
int glvsgl_set(glvsgl *V, const prt_lights *ls, prt_error *err)
{
    double t0 = prt_now();
    if (ls->count > GLVSGL_MAX) return prt_fail(err, "gl runtime: %d local lights for the VSGLs, at most %d", ls->count, GLVSGL_MAX);
    V->n = 0;
    for (int l = 0; l < ls->count; l++) {
        if (light_validate(&ls->light[l], "gl runtime", err)) return -1;
        rsm_render(V->r, &ls->light[l], V->vs, &V->scene->mesh, V->lm);
        vsgl_pair v;
        vsgl_build(V->r, &v);
        const vsgl_light *two[2] = { &v.diffuse, &v.specular };
        for (int j = 0; j < 2; j++, V->n++)
            for (int k = 0; k < 4; k++) {
                V->u[V->n][0][k] = k < 3 ? two[j]->axis[k] : two[j]->sharpness;
                V->u[V->n][1][k] = k < 3 ? two[j]->c[k] : two[j]->var;
                V->u[V->n][2][k] = k < 3 ? two[j]->mean[k] : 0;
            }
    }
    V->ms = 1e3 * (prt_now() - t0);
    return 0;
}

void glvsgl_bind(const glvsgl *V, const gl_api *gl, GLuint prog)
{
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_nvsgl"), V->n);
    if (V->n > 0) gl->Uniform4fv(gl->GetUniformLocation(prog, "u_vsgl"), 3 * V->n, &V->u[0][0][0]);
}

double glvsgl_ms(const glvsgl *V) { return V->ms; }
