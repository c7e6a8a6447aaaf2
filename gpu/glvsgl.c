/* glvsgl.c - VSGL uniforms and their GLSL (glvsgl.h).
 *
 * The VSGLs are a handful of numbers per light, so the GPU gets them as uniforms: the RSM and
 * the sums stay on the CPU (Embree), as in the cpu runtime, and cost the same there. */
#include "glvsgl.h"
#include "lobefit.h"
#include <stdlib.h>

struct glvsgl {
    const prt_scene *scene;
    vis_scene *vs;
    lightmat *lm;
    rsm *r;
    int n;                               /* VSGLs in use: 2 per light */
    float u[2 * GLVSGL_MAX][3][4];       /* per VSGL: (axis, sharpness), (c, var), (mean, 0) */
    double ms;
    int nfit;                            /* rows of the glossy materials' lobe tables (0: no glossy material) */
    int fit_of[PRT_MAX_MATERIALS][4];    /* u_lfit_of: first row or -1, views, 0, 0 */
    float fit[GLVSGL_MAX_FIT_ROWS][4];   /* u_lfit: local lobe axis, kappa per view elevation */
    bool spec;                           /* u_vsgl_spec: the glossy lobe's term (glvsgl_set_glossy) */
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
    "#if VSGL_SPEC\n"
    /* The receiver's glossy lobe (vsgl_spec_asg, vsgl_glossy: tokuyoshi 3.2), compiled only when the
     * scene has a glossy material (glvsgl_fit_rows > 0); u_vsgl_spec 0 (the highlights light that lobe
     * instead) skips it. u_lfit_of[m]: (first row of m's lobe table in u_lfit, or -1; its views). */
    "uniform int u_vsgl_spec;\n"
    "uniform ivec4 u_lfit_of[NMAT];\n"
    "uniform vec4 u_lfit[VSGL_NFIT];\n"   /* per view elevation: the local lobe axis (wo in the x-z plane), kappa */
    "struct vsgl_asg { vec3 X, Y, Z; float ex, ey, kappa; vec3 fzaz; };\n"
    /* lightmat_lobe: lobefit_lookup (laurijssen-2011 Eq. 7 between the two nearest elevations, turned
     * to wo's azimuth) in frame(n), to world. */
    "bool vsgl_lobe(int m, vec3 n, vec3 s, vec3 t, vec3 wol, out vec3 mu, out float kappa) {\n"
    "    ivec4 f = u_lfit_of[m];\n"
    "    if (f.x < 0 || wol.z <= 1e-4) return false;\n"
    "    float rxy = length(wol.xy), x = atan(rxy, wol.z) / 1.5707963 * float(f.y);\n"
    "    int i = int(floor(x));\n"
    "    float a = x - float(i);\n"
    "    if (i < 0) { i = 0; a = 0.0; }\n"
    "    if (i >= f.y - 1) { i = f.y - 1; a = 0.0; }\n"
    "    vec4 A = u_lfit[f.x + i], B = u_lfit[f.x + min(i + 1, f.y - 1)];\n"
    "    vec3 l = mix(A.xyz, B.xyz, a);\n"
    "    float ll = length(l);\n"
    "    l = ll > 0.0 ? l / ll : vec3(0.0, 0.0, 1.0);\n"
    "    float cp = rxy > 0.0 ? wol.x / rxy : 1.0, sp = rxy > 0.0 ? wol.y / rxy : 0.0;\n"
    "    mu = normalize(s * (cp * l.x - sp * l.y) + t * (sp * l.x + cp * l.y) + n * l.z);\n"
    "    kappa = mix(A.w, B.w, a);\n"
    "    return true;\n"
    "}\n"
    /* lightmat_spec_eval: brdf_eval minus kd / pi, world wi, local wo. */
    "vec3 vsgl_fs(int m, vec3 kd, vec3 n, vec3 s, vec3 t, vec3 wi, vec3 wol) {\n"
    "    vec3 il = vec3(dot(wi, s), dot(wi, t), dot(wi, n));\n"
    "    if (il.z <= 0.0 || wol.z <= 0.0) return vec3(0.0);\n"
    "    return max(brdf_glsl(m, il, wol) - kd * 0.31830989, vec3(0.0));\n"
    "}\n"
    "float asg_shape(vsgl_asg a, float ex, float ey, vec3 w) {\n"
    "    float z = dot(a.Z, w), x = dot(a.X, w), y = dot(a.Y, w);\n"
    "    return z > 0.0 ? z * exp(-ex * x * x - ey * y * y) : 0.0;\n"
    "}\n"
    /* vsgl_spec_asg: the fitted lobe as an ASG, isotropic for Phong, the half-vector models' warp
     * aspect cos(theta_o) otherwise (vsgl.h); fzaz = f_s(z, wo) cos / ASG(z) (M's clamp). */
    "bool vsgl_spec_asg(int m, vec3 kd, vec3 n, vec3 s, vec3 t, vec3 wol, out vsgl_asg a) {\n"
    "    if (!vsgl_lobe(m, n, s, t, wol, a.Z, a.kappa)) return false;\n"
    "    a.X = n - a.Z * dot(n, a.Z);\n"
    "    float lx = length(a.X);\n"
    "    if (lx < 1e-5) { vec3 ty; frame(a.Z, a.X, ty); } else a.X /= lx;\n"
    "    a.Y = cross(a.Z, a.X);\n"
    "    float c = max(wol.z, 0.05), ex = 0.5 * a.kappa, ey = 0.5 * a.kappa;\n"
    "    if (int(texelFetch(t_brdf, m * 7).x + 0.5) != 1) { ex = 0.5 * a.kappa * c; ey = 0.5 * a.kappa / c; }\n"
    "    a.ex = max(ex - 0.5, 0.0); a.ey = max(ey - 0.5, 0.0);\n"
    "    a.fzaz = vsgl_fs(m, kd, n, s, t, a.Z, wol) * max(dot(n, a.Z), 0.0);\n"
    "    return true;\n"
    "}\n"
    /* vsgl_glossy: M(xi_m) times Xu et al.'s ASG-SG product integral with the incoming SG (xin, lin). */
    "vec3 vsgl_glossy(vsgl_asg a, int m, vec3 kd, vec3 n, vec3 s, vec3 t, vec3 wol, vec3 xin, float lin) {\n"
    "    vec3 xm = lin * xin + a.kappa * a.Z;\n"
    "    float lm = length(xm);\n"
    "    if (!(lm > 0.0)) return vec3(0.0);\n"
    "    xm /= lm;\n"
    "    float am = asg_shape(a, a.ex, a.ey, xm);\n"
    "    am = am > 1e-6 ? max(dot(n, xm), 0.0) / am : 0.0;\n"
    "    vec3 M = min(vsgl_fs(m, kd, n, s, t, xm, wol) * am, 4.0 * a.fzaz);\n"
    "    float v = 0.5 * min(lin, 1e8), den = (a.ex + v) * (a.ey + v);\n"
    "    float I = den > 0.0 ? 3.1415927 * asg_shape(a, a.ex * v / (a.ex + v), a.ey * v / (a.ey + v), xin) * inversesqrt(den)\n"
    "                        : 3.1415927;\n"
    "    return M * I;\n"
    "}\n"
    "#endif\n"
    /* vsgl_incoming (Eq. 6-7): the incoming SG (xin, lin) of VSGL j at p and its rgb; false when empty. */
    "bool vsgl_in(int j, vec3 p, out vec3 rgb, out vec3 xin, out float lin) {\n"
    "    vec4 A = u_vsgl[3 * j], C = u_vsgl[3 * j + 1], M = u_vsgl[3 * j + 2];\n"
    "    vec3 dm = M.xyz - p;\n"
    "    float d2 = dot(dm, dm);\n"
    "    if (!(C.w > 0.0) || !(d2 > 0.0)) return false;\n"
    "    float var = max(C.w, d2 * 1e-8);\n"
    "    rgb = C.rgb * (sg_prod(-A.xyz, A.w, dm * inversesqrt(d2), d2 / var, xin, lin) / (6.2831853 * var));\n"
    "    return true;\n"
    "}\n"
    /* vsgl_shade (vsgl.h, section 3.2): each VSGL's incoming SG met by Eq. 1's SG of the clamped
     * cosine (the exact product integral, times kd) and, with VSGL_SPEC, by the glossy lobe's ASG. */
    "vec3 vsgl_lights(int m, vec3 p, vec3 n, vec3 eye) {\n"
    "    vec3 kd = texelFetch(t_brdf, m * 7 + 1).rgb, c = vec3(0.0), rgb, xin, x2;\n"
    "    float lin, l2;\n"
    "#if VSGL_SPEC\n"
    "    vec3 s, t;\n"
    "    frame(n, s, t);\n"
    "    vec3 wo = toward(eye - p), wol = vec3(dot(wo, s), dot(wo, t), dot(wo, n));\n"
    "    vsgl_asg a;\n"
    "    bool spec = u_vsgl_spec != 0 && vsgl_spec_asg(m, kd, n, s, t, wol, a);\n"
    "#endif\n"
    "    for (int j = 0; j < u_nvsgl; j++) {\n"
    "        if (!vsgl_in(j, p, rgb, xin, lin)) continue;\n"
    "        vec3 r = kd * (sg_prod(xin, lin, n, 2.0, x2, l2) * sg_area(l2) / sg_area(2.0));\n"
    "#if VSGL_SPEC\n"
    "        if (spec) r += vsgl_glossy(a, m, kd, n, s, t, wol, xin, lin);\n"
    "#endif\n"
    "        c += rgb * r;\n"
    "    }\n"
    "    for (int k = 0; k < 3; k++) c[k] = isnan(c[k]) || isinf(c[k]) || c[k] < 0.0 ? 0.0 : c[k];\n"   /* as vsgl_shade */
    "    return c;\n"
    "}\n"
    "#else\n"
    "vec3 vsgl_lights(int m, vec3 p, vec3 n, vec3 eye) { return vec3(0.0); }\n"
    "#endif\n";

const char *glvsgl_glsl(void) { return k_glsl; }

/* The glossy materials' lobe tables (lightmat_fit) in u_lfit's layout; -1 with err past the rows. */
static int pack_fits(glvsgl *V, prt_error *err)
{
    for (int m = 0; m < V->scene->nmaterials; m++) {
        const lobefit_table *t = lightmat_fit(V->lm, m);
        V->fit_of[m][0] = -1;
        V->fit_of[m][1] = t ? t->views : 0;
        if (!t) continue;
        if (V->nfit + t->views > GLVSGL_MAX_FIT_ROWS)
            return prt_fail(err, "gl runtime: --local-bounce shades at most %d glossy materials per pixel",
                            GLVSGL_MAX_FIT_ROWS / t->views);
        V->fit_of[m][0] = V->nfit;
        for (int v = 0; v < t->views; v++, V->nfit++)
            for (int k = 0; k < 4; k++) V->fit[V->nfit][k] = k < 3 ? t->lobe[v].mu[k] : t->lobe[v].kappa;
    }
    return 0;
}

glvsgl *glvsgl_create(const prt_scene *scene, prt_error *err)
{
    glvsgl *V = prt_calloc(1, sizeof *V, err);
    if (!V) return NULL;
    V->scene = scene;
    V->spec = true;
    if (!(V->vs = vis_create(&scene->mesh, err)) || !(V->lm = lightmat_create(scene, err)) ||
        !(V->r = rsm_create(&(rsm_desc){ 0 }, err)) || pack_fits(V, err)) {
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

int glvsgl_fit_rows(const glvsgl *V) { return V->nfit; }

bool glvsgl_glossy(const glvsgl *V, int m) { return m >= 0 && m < V->scene->nmaterials && V->fit_of[m][0] >= 0; }

void glvsgl_set_glossy(glvsgl *V, bool on) { V->spec = on; }

/* The lobe tables, once per program (a program without VSGL_SPEC has no such uniforms: GL ignores -1). */
void glvsgl_init_program(const glvsgl *V, const gl_api *gl, GLuint prog)
{
    if (V->nfit == 0) return;
    gl->Uniform4iv(gl->GetUniformLocation(prog, "u_lfit_of"), V->scene->nmaterials, &V->fit_of[0][0]);
    gl->Uniform4fv(gl->GetUniformLocation(prog, "u_lfit"), V->nfit, &V->fit[0][0]);
}

void glvsgl_bind(const glvsgl *V, const gl_api *gl, GLuint prog)
{
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_nvsgl"), V->n);
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_vsgl_spec"), V->spec);
    if (V->n > 0) gl->Uniform4fv(gl->GetUniformLocation(prog, "u_vsgl"), 3 * V->n, &V->u[0][0][0]);
}

double glvsgl_ms(const glvsgl *V) { return V->ms; }
