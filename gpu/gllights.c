/* gllights.c - local lights on the GPU: shadow cubes, the BRDFs in GLSL (gllights.h).
 *
 * The GLSL BRDF mirrors brdf.c's brdf_eval case by case (the same guards: cosines floored at
 * 1e-7, pow as exp(n log x) clamped at exp(80), the symmetric half vector), in float; the
 * parameters of every material sit in a buffer texture, GLLIGHTS_TEXELS vec4 per material. */
#include "gllights.h"
#include "brdf.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GLLIGHTS_TEXELS 7     /* (type, n, nu, nv), (kd, alpha), (ks, nlobes), 4 lobes */

struct gllights {
    const gl_api *gl;
    const prt_scene *scene;
    GLuint buf_brdf, tex_brdf;
    GLuint prog_shadow, fbo, depth;
    GLuint cube[GLLIGHTS_MAX];
    GLuint spot[GLLIGHTS_MAX];  /* a spot light's one perspective distance map */
    float spot_vp[GLLIGHTS_MAX][16];
    bool use_spot[GLLIGHTS_MAX];
    prt_lights lights;
    float scene_size;
};

/* BRDF_TYPES: the models the scene uses, bit 1 << brdf_type (glrt.c defines it; all of them when not):
 * llvmpipe runs a branch that no pixel takes at the cost of one that every pixel takes (under a mask),
 * so the models a scene lacks are left out of the program rather than branched around. */
static const char *k_glsl =
    /* KD_SCALE: what kd is multiplied by (glrt.c: the texture at the point being shaded, texture.h) */
    "#ifndef KD_SCALE\n"
    "#define KD_SCALE vec3(1.0)\n"
    "#endif\n"
    "#ifndef BRDF_TYPES\n"
    "#define BRDF_TYPES 127\n"
    "#endif\n"
    "uniform samplerBuffer t_brdf;\n"
    "float pow_c(float x, float n) {\n"
    "    if (!(x > 0.0)) return 0.0;\n"
    "    if (n == 0.0) return 1.0;\n"
    "    float l = n * log(x);\n"
    "    return l < -87.0 ? 0.0 : exp(min(l, 80.0));\n"
    "}\n"
    "float half_v(vec3 wi, vec3 wo, out vec3 h) {\n"
    "    h = normalize(wi + wo);\n"
    "    return max(0.5 * (dot(wi, h) + dot(wo, h)), 1e-7);\n"
    "}\n"
    "float schlick_f(float f0, float c) { float m = max(1.0 - c, 0.0); float m2 = m * m; return f0 + (1.0 - f0) * m2 * m2 * m; }\n"
    /* as_lobe: (n.h)^((nu hx^2 + nv hy^2)/(1 - hz^2)), log(hz)/(1 - hz^2) = 0.5 log1p(-s2)/s2 (series when small) */
    "float as_lobe_f(float nu, float nv, vec3 h) {\n"
    "    float s2 = h.x * h.x + h.y * h.y;\n"
    "    if (s2 >= 1.0) return 0.0;\n"
    "    float r = s2 < 1e-3 ? -0.5 * (1.0 + s2 * (0.5 + s2 / 3.0)) : 0.5 * log(1.0 - s2) / s2;\n"
    "    float l = (nu * h.x * h.x + nv * h.y * h.y) * r;\n"
    "    return l < -87.0 ? 0.0 : exp(min(l, 80.0));\n"
    "}\n"
    "float beck_lambda(float a, float c) {\n"
    "    float s = sqrt(max(0.0, 1.0 - c * c));\n"
    "    if (s <= 0.0) return 0.0;\n"
    "    float x = c / (a * s);\n"
    "    if (x >= 1.6) return 0.0;\n"
    "    return (1.0 - 1.259 * x + 0.396 * x * x) / (3.535 * x + 2.181 * x * x);\n"
    "}\n"
    /* brdf_eval (brdf.c): f_r per channel, no cosine, local frame; 0 below the horizon. */
    "vec3 brdf_glsl(int m, vec3 wi, vec3 wo) {\n"
    "    if (!(wi.z > 0.0) || !(wo.z > 0.0)) return vec3(0.0);\n"
    "    const float PI = 3.14159265358979;\n"
    "    int b = m * 7;\n"
    "    vec4 p0 = texelFetch(t_brdf, b), p1 = texelFetch(t_brdf, b + 1), p2 = texelFetch(t_brdf, b + 2);\n"
    "    int type = int(p0.x + 0.5);\n"
    "    float ci = max(wi.z, 1e-7), co = max(wo.z, 1e-7);\n"
    "    vec3 kd = p1.rgb * KD_SCALE, ks = p2.rgb, out_c = kd / PI, h;\n"
    "#if (BRDF_TYPES & 2) != 0\n"
    "    if (type == 1) {\n"                      /* phong */
    "        float c = -wi.x * wo.x - wi.y * wo.y + wi.z * wo.z;\n"
    "        out_c += ks * ((p0.y + 2.0) / (2.0 * PI) * pow_c(c, p0.y));\n"
    "    }\n"
    "#endif\n"
    "#if (BRDF_TYPES & 4) != 0\n"
    "    if (type == 2) {\n"                      /* blinn */
    "        half_v(wi, wo, h);\n"
    "        out_c += ks * ((p0.y + 8.0) / (8.0 * PI) * pow_c(h.z, p0.y));\n"
    "    }\n"
    "#endif\n"
    "#if (BRDF_TYPES & 8) != 0\n"
    "    if (type == 3) {\n"                      /* Ashikhmin-Shirley, Eq. 4 and 5 */
    "        float kh = half_v(wi, wo, h);\n"
    "        float spec = sqrt((p0.z + 1.0) * (p0.w + 1.0)) / (8.0 * PI) * as_lobe_f(p0.z, p0.w, h) / (kh * max(ci, co));\n"
    "        float di = 1.0 - ci * 0.5, dout = 1.0 - co * 0.5;\n"
    "        float di5 = di * di * di * di * di, do5 = dout * dout * dout * dout * dout;\n"
    "        float dif = 28.0 / (23.0 * PI) * (1.0 - di5) * (1.0 - do5);\n"
    "        for (int k = 0; k < 3; k++) out_c[k] = kd[k] * (1.0 - ks[k]) * dif + spec * schlick_f(ks[k], kh);\n"
    "    }\n"
    "#endif\n"
    "#if (BRDF_TYPES & 16) != 0\n"
    "    if (type == 4) {\n"                      /* lafortune */
    "        float s = 0.0;\n"
    "        int nl = int(p2.w + 0.5);\n"
    "        for (int l = 0; l < 4; l++) {\n"
    "            if (l >= nl) break;\n"
    "            vec4 c = texelFetch(t_brdf, b + 3 + l);\n"
    "            s += pow_c(c.x * wi.x * wo.x + c.y * wi.y * wo.y + c.z * wi.z * wo.z, c.w);\n"
    "        }\n"
    "        out_c += vec3(s);\n"
    "    }\n"
    "#endif\n"
    "#if (BRDF_TYPES & 96) != 0\n"
    "    if (type == 5 || type == 6) {\n"         /* Cook-Torrance, height-correlated Smith */
    "        float kh = half_v(wi, wo, h);\n"
    "        float a = p1.w, a2 = a * a, c2 = h.z * h.z, s2 = h.x * h.x + h.y * h.y, dg;\n"
    "        if (type == 5) {\n"
    "            float d = a2 * c2 + s2;\n"
    "            float den = co * sqrt(ci * ci * (1.0 - a2) + a2) + ci * sqrt(co * co * (1.0 - a2) + a2);\n"
    "            dg = a2 / (PI * d * d) * 0.5 / den;\n"
    "        } else {\n"
    "            float D = c2 > 0.0 ? exp(max(-s2 / (c2 * a2), -87.0)) / (PI * a2 * c2 * c2) : 0.0;\n"
    "            dg = D / (1.0 + beck_lambda(a, ci) + beck_lambda(a, co)) / (4.0 * ci * co);\n"
    "        }\n"
    "        for (int k = 0; k < 3; k++) out_c[k] += dg * schlick_f(ks[k], kh);\n"
    "    }\n"
    "#endif\n"
    "    return clamp(out_c, vec3(0.0), vec3(3.4e38));\n"
    "}\n"
    "#if LMAX > 0\n"
    "uniform int u_nlocal;\n"
    "uniform vec4 u_lpos[LMAX];\n"   /* xyz position, w: 1 spot, 0 point */
    "uniform vec4 u_ldir[LMAX];\n"   /* xyz spot axis, w: cos(inner) */
    "uniform vec4 u_lcol[LMAX];\n"   /* rgb intensity * colour (W/sr), w: cos(outer) */
    "uniform vec4 u_lbias[LMAX];\n"  /* x: normal offset per unit distance, y: distance bias */
    "uniform samplerCube t_shadow0, t_shadow1, t_shadow2, t_shadow3;\n"
    "uniform sampler2D t_spot0, t_spot1, t_spot2, t_spot3;\n"
    "uniform mat4 u_lvp[LMAX];\n"   /* a spot's map: projection * view from the light */
    /* light_shade (lights.h) times the shadow map's test (u_lbias.z: 1 the spot's map, 0 the cube). */
    "vec3 one_light(int i, samplerCube sh, sampler2D sp, int m, vec3 p, vec3 n, vec3 s, vec3 t, vec3 wol) {\n"
    "    vec3 d = u_lpos[i].xyz - p;\n"
    "    float dist2 = dot(d, d), dist = sqrt(dist2);\n"
    "    if (!(dist2 >= 1.17549435e-38)) return vec3(0.0);\n"   /* at the light: FLT_MIN, as light_shade (any scale) */
    "    vec3 wi = d / dist;\n"
    "    vec3 wil = vec3(dot(wi, s), dot(wi, t), dot(wi, n));\n"
    "    if (wil.z <= 0.0 || wol.z <= 0.0) return vec3(0.0);\n"
    "    float f = 1.0;\n"
    "    if (u_lpos[i].w > 0.5) {\n"   /* light_falloff: smoothstep in cos between the cones */
    "        float c = dot(u_ldir[i].xyz, -wi), cin = u_ldir[i].w, cout = u_lcol[i].w;\n"
    "        if (c >= cin) f = 1.0; else if (c <= cout) f = 0.0;\n"
    "        else { float x = (c - cout) / (cin - cout); f = x * x * (3.0 - 2.0 * x); }\n"
    "    }\n"
    "    if (f <= 0.0) return vec3(0.0);\n"
    "    vec3 q = p + n * (u_lbias[i].x * dist) - u_lpos[i].xyz;\n"
    "    float stored;\n"
    "    if (u_lbias[i].z > 0.5) {\n"   /* inside the cone (f > 0), so inside the map's frustum */
    "        vec4 c = u_lvp[i] * vec4(q + u_lpos[i].xyz, 1.0);\n"
    "        if (c.w <= 0.0) return vec3(0.0);\n"
    "        stored = texture(sp, c.xy / c.w * 0.5 + 0.5).r;\n"
    "    } else stored = texture(sh, q).r;\n"
    "    if (length(q) - u_lbias[i].y > stored) return vec3(0.0);\n"
    "    return brdf_glsl(m, wil, wol) * u_lcol[i].rgb * (f * wil.z / dist2);\n"
    "}\n"
    "vec3 local_lights(int m, vec3 p, vec3 n, vec3 eye) {\n"
    "    if (u_nlocal <= 0) return vec3(0.0);\n"
    "    vec3 s, t;\n"
    "    frame(n, s, t);\n"
    "    vec3 wo = toward(eye - p), wol = vec3(dot(wo, s), dot(wo, t), dot(wo, n));\n"
    "    vec3 c = one_light(0, t_shadow0, t_spot0, m, p, n, s, t, wol);\n"
    "#if LMAX > 1\n"
    "    if (u_nlocal > 1) c += one_light(1, t_shadow1, t_spot1, m, p, n, s, t, wol);\n"
    "    if (u_nlocal > 2) c += one_light(2, t_shadow2, t_spot2, m, p, n, s, t, wol);\n"
    "    if (u_nlocal > 3) c += one_light(3, t_shadow3, t_spot3, m, p, n, s, t, wol);\n"
    "#endif\n"
    "    return c;\n"
    "}\n"
    "#else\n"
    "vec3 local_lights(int m, vec3 p, vec3 n, vec3 eye) { return vec3(0.0); }\n"
    "#endif\n";

const char *gllights_glsl(void) { return k_glsl; }

static const char *k_shadow_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec3 a_pos;\n"
    "uniform mat4 u_vp;\n"
    "out vec3 v_w;\n"
    "void main() { v_w = a_pos; gl_Position = u_vp * vec4(a_pos, 1.0); }\n";
static const char *k_shadow_fs =
    "#version 330 core\n"
    "in vec3 v_w;\n"
    "uniform vec3 u_lp;\n"
    "out vec4 o;\n"
    "void main() { o = vec4(length(v_w - u_lp)); }\n";

bool gllights_supported(const gl_api *gl) {
    GLint fu = 0, vu = 0;
    gl->GetIntegerv(GL_MAX_TEXTURE_IMAGE_UNITS, &fu);
    gl->GetIntegerv(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS, &vu);
    return fu > GLLIGHTS_UNIT + 2 * GLLIGHTS_MAX && vu > GLLIGHTS_UNIT + 2 * GLLIGHTS_MAX;
}

/* The materials' parameters as GLLIGHTS_TEXELS vec4 each (the layout brdf_glsl reads). */
static int upload_brdfs(gllights *L, prt_error *err) {
    const gl_api *gl = L->gl;
    int nm = L->scene->nmaterials;
    float *t = prt_calloc((size_t)(nm > 0 ? nm : 1) * GLLIGHTS_TEXELS * 4, sizeof(float), err);
    if (!t) return -1;
    for (int m = 0; m < nm; m++) {
        const brdf_params *p = &L->scene->materials[m];
        float *q = t + (size_t)m * GLLIGHTS_TEXELS * 4;
        float v[12] = { (float)p->type, p->n, p->nu, p->nv, p->kd[0], p->kd[1], p->kd[2], p->alpha,
                        p->ks[0], p->ks[1], p->ks[2], (float)p->nlobes };
        memcpy(q, v, sizeof v);
        for (int l = 0; l < BRDF_MAX_LOBES && l < 4; l++) memcpy(q + 12 + 4 * l, p->lobe[l], 4 * sizeof(float));
    }
    gl->GenBuffers(1, &L->buf_brdf);
    gl->BindBuffer(GL_TEXTURE_BUFFER, L->buf_brdf);
    gl->BufferData(GL_TEXTURE_BUFFER, (GLsizeiptr)(sizeof(float) * 4 * GLLIGHTS_TEXELS * (size_t)(nm > 0 ? nm : 1)), t, GL_STATIC_DRAW);
    gl->GenTextures(1, &L->tex_brdf);
    gl->BindTexture(GL_TEXTURE_BUFFER, L->tex_brdf);
    gl->TexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, L->buf_brdf);
    gl->BindTexture(GL_TEXTURE_BUFFER, 0);
    gl->BindBuffer(GL_TEXTURE_BUFFER, 0);
    free(t);
    return glctx_check(gl, "local lights: BRDF table", err);
}

/* Cube textures (R32F, nearest) and the depth renderbuffer and framebuffer they are drawn with. */
static int make_cubes(gllights *L, prt_error *err) {
    const gl_api *gl = L->gl;
    gl->GenTextures(GLLIGHTS_MAX, L->cube);
    for (int i = 0; i < GLLIGHTS_MAX; i++) {
        gl->BindTexture(GL_TEXTURE_CUBE_MAP, L->cube[i]);
        for (int f = 0; f < 6; f++)
            gl->TexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, GL_R32F, GLLIGHTS_RES, GLLIGHTS_RES, 0, GL_RED, GL_FLOAT, NULL);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    }
    gl->BindTexture(GL_TEXTURE_CUBE_MAP, 0);
    gl->GenTextures(GLLIGHTS_MAX, L->spot);
    for (int i = 0; i < GLLIGHTS_MAX; i++) {
        gl->BindTexture(GL_TEXTURE_2D, L->spot[i]);
        gl->TexImage2D(GL_TEXTURE_2D, 0, GL_R32F, GLLIGHTS_RES, GLLIGHTS_RES, 0, GL_RED, GL_FLOAT, NULL);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    gl->BindTexture(GL_TEXTURE_2D, 0);
    gl->GenRenderbuffers(1, &L->depth);
    gl->BindRenderbuffer(GL_RENDERBUFFER, L->depth);
    gl->RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, GLLIGHTS_RES, GLLIGHTS_RES);
    gl->BindRenderbuffer(GL_RENDERBUFFER, 0);
    gl->GenFramebuffers(1, &L->fbo);
    return glctx_check(gl, "local lights: shadow cubes", err);
}

gllights *gllights_create(const gl_api *gl, const prt_scene *scene, prt_error *err) {
    if (!gllights_supported(gl))
        return prt_fail(err, "gl runtime: local lights need %d texture units per stage", GLLIGHTS_UNIT + 2 * GLLIGHTS_MAX + 1), NULL;
    gllights *L = prt_calloc(1, sizeof *L, err);
    if (!L) return NULL;
    L->gl = gl;
    L->scene = scene;
    float ext[3];
    v3_sub(ext, scene->bmax, scene->bmin);
    L->scene_size = v3_len(ext);   /* no absolute floor: a scene 1e-12 across is as good as any */
    if (!(L->scene_size > 0) || !isfinite(L->scene_size)) L->scene_size = 1;
    if (upload_brdfs(L, err) || make_cubes(L, err) ||
        !(L->prog_shadow = glctx_program(gl, k_shadow_vs, k_shadow_fs, "local-light shadow", err))) {
        gllights_destroy(L);
        return NULL;
    }
    return L;
}

void gllights_destroy(gllights *L) {
    if (!L) return;
    const gl_api *gl = L->gl;
    gl->DeleteTextures(GLLIGHTS_MAX, L->cube);
    gl->DeleteTextures(GLLIGHTS_MAX, L->spot);
    if (L->tex_brdf) gl->DeleteTextures(1, &L->tex_brdf);
    if (L->buf_brdf) gl->DeleteBuffers(1, &L->buf_brdf);
    if (L->depth) gl->DeleteRenderbuffers(1, &L->depth);
    if (L->fbo) gl->DeleteFramebuffers(1, &L->fbo);
    if (L->prog_shadow) gl->DeleteProgram(L->prog_shadow);
    free(L);
}

/* Column-major projection * view from p looking along unit F (up: a hint), a square frustum of
 * half-angle atan(tan_half): view x = s.(x-p), y = u.(x-p), z = -F.(x-p); clip.w = -z. */
static void persp_matrix(const float p[3], const float F[3], const float up[3], float tan_half, float near, float far,
                         float out[16]) {
    float s[3], u[3];
    v3_cross(s, F, up);
    v3_normalize(s);
    v3_cross(u, s, F);
    float k = 1 / tan_half, a = (far + near) / (near - far);
    float b = (float)(2.0 * far * near / ((double)near - far));   /* double: far * near leaves float at extreme scales */
    float rows[4][4] = { { k * s[0], k * s[1], k * s[2], -k * v3_dot(s, p) },
                         { k * u[0], k * u[1], k * u[2], -k * v3_dot(u, p) },
                         { -a * F[0], -a * F[1], -a * F[2], a * v3_dot(F, p) + b },
                         { F[0], F[1], F[2], -v3_dot(F, p) } };
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) out[c * 4 + r] = rows[r][c];
}

/* Draws the mesh's distances from light i into the attached colour target with matrix vp. */
static void draw_distances(gllights *L, const float vp[16], GLuint vao, int ntris) {
    const gl_api *gl = L->gl;
    gl->ClearColor(3e38f, 0, 0, 0);
    gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl->UniformMatrix4fv(gl->GetUniformLocation(L->prog_shadow, "u_vp"), 1, GL_FALSE, vp);
    gl->BindVertexArray(vao);
    if (ntris > 0) gl->DrawElements(GL_TRIANGLES, ntris * 3, GL_UNSIGNED_INT, 0);
    gl->BindVertexArray(0);
}

/* Light i's shadow: one perspective map for a spot whose cone fits in it (outer <= GLLIGHTS_SPOT_MAX_DEG),
 * else a cube of six 90-degree faces in GL's face orientation. */
static void render_shadow(gllights *L, int i, GLuint vao, int ntris) {
    static const float fwd[6][3] = { { 1, 0, 0 }, { -1, 0, 0 }, { 0, 1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 } };
    static const float up[6][3] = { { 0, -1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 }, { 0, -1, 0 }, { 0, -1, 0 } };
    const gl_api *gl = L->gl;
    const prt_light *l = &L->lights.light[i];
    float near = 1e-4f * L->scene_size, far = 4 * L->scene_size + v3_len(l->pos);
    gl->Uniform3fv(gl->GetUniformLocation(L->prog_shadow, "u_lp"), 1, l->pos);
    L->use_spot[i] = l->type == PRT_LIGHT_SPOT && l->outer_deg <= GLLIGHTS_SPOT_MAX_DEG;
    if (L->use_spot[i]) {
        /* 2 degrees beyond the outer cone, so every point the falloff lets through lies inside. */
        float hint[3] = { 0, 1, 0 };
        if (fabsf(l->dir[1]) > 0.9f) hint[0] = 1, hint[1] = 0;
        persp_matrix(l->pos, l->dir, hint, tanf((l->outer_deg + 2) * (float)(M_PI / 180)), near, far, L->spot_vp[i]);
        gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, L->spot[i], 0);
        draw_distances(L, L->spot_vp[i], vao, ntris);
        return;
    }
    for (int f = 0; f < 6; f++) {
        gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, L->cube[i], 0);
        float vp[16];
        persp_matrix(l->pos, fwd[f], up[f], 1, near, far, vp);
        draw_distances(L, vp, vao, ntris);
    }
}

int gllights_set(gllights *L, const prt_lights *ls, GLuint vao, int ntris, prt_error *err) {
    const gl_api *gl = L->gl;
    if (ls->count > GLLIGHTS_MAX)
        return prt_fail(err, "gl runtime: %d local lights; the GLSL runtime takes at most %d", ls->count, GLLIGHTS_MAX);
    for (int i = 0; i < ls->count; i++)
        if (light_validate(&ls->light[i], "gl runtime", err)) return -1;
    L->lights = *ls;
    gl->BindFramebuffer(GL_FRAMEBUFFER, L->fbo);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, L->depth);
    gl->Viewport(0, 0, GLLIGHTS_RES, GLLIGHTS_RES);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->DepthMask(GL_TRUE);
    gl->ClearDepth(1.0);
    gl->UseProgram(L->prog_shadow);
    for (int i = 0; i < ls->count; i++) render_shadow(L, i, vao, ntris);
    gl->UseProgram(0);
    gl->Disable(GL_DEPTH_TEST);
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    return glctx_check(gl, "local lights: shadow maps", err);
}

void gllights_init_program(const gl_api *gl, GLuint prog) {
    gl->Uniform1i(gl->GetUniformLocation(prog, "t_brdf"), GLLIGHTS_UNIT + GLLIGHTS_MAX);
    for (int i = 0; i < GLLIGHTS_MAX; i++) {
        char name[32];
        snprintf(name, sizeof name, "t_shadow%d", i);
        gl->Uniform1i(gl->GetUniformLocation(prog, name), GLLIGHTS_UNIT + i);
        snprintf(name, sizeof name, "t_spot%d", i);
        gl->Uniform1i(gl->GetUniformLocation(prog, name), GLLIGHTS_UNIT + GLLIGHTS_MAX + 1 + i);
    }
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_nlocal"), 0);
}

void gllights_bind(const gllights *L, GLuint prog) {
    const gl_api *gl = L->gl;
    float pos[GLLIGHTS_MAX][4] = { { 0 } }, dir[GLLIGHTS_MAX][4] = { { 0 } }, col[GLLIGHTS_MAX][4] = { { 0 } };
    float bias[GLLIGHTS_MAX][4] = { { 0 } };
    for (int i = 0; i < L->lights.count; i++) {
        const prt_light *l = &L->lights.light[i];
        for (int k = 0; k < 3; k++) {
            pos[i][k] = l->pos[k];
            dir[i][k] = l->dir[k];
            col[i][k] = l->intensity * l->colour[k];
        }
        pos[i][3] = l->type == PRT_LIGHT_SPOT;
        dir[i][3] = cosf(l->inner_deg * (float)(M_PI / 180));
        col[i][3] = cosf(l->outer_deg * (float)(M_PI / 180));
        /* 1.5 texels of normal offset (a texel spans about 2/RES radians at the face centre), and a
         * distance bias of 0.1% of the scene for the remaining depth quantization. */
        bias[i][0] = 1.5f * 2.0f / GLLIGHTS_RES;
        bias[i][1] = 1e-3f * L->scene_size;
        bias[i][2] = L->use_spot[i];
        if (L->use_spot[i]) bias[i][0] = 1.5f * 2.0f * tanf((l->outer_deg + 2) * (float)(M_PI / 180)) / GLLIGHTS_RES;
    }
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_nlocal"), L->lights.count);
    gl->Uniform4fv(gl->GetUniformLocation(prog, "u_lpos"), GLLIGHTS_MAX, &pos[0][0]);
    gl->Uniform4fv(gl->GetUniformLocation(prog, "u_ldir"), GLLIGHTS_MAX, &dir[0][0]);
    gl->Uniform4fv(gl->GetUniformLocation(prog, "u_lcol"), GLLIGHTS_MAX, &col[0][0]);
    gl->Uniform4fv(gl->GetUniformLocation(prog, "u_lbias"), GLLIGHTS_MAX, &bias[0][0]);
    gl->UniformMatrix4fv(gl->GetUniformLocation(prog, "u_lvp"), GLLIGHTS_MAX, GL_FALSE, &L->spot_vp[0][0]);
    for (int i = 0; i < GLLIGHTS_MAX; i++) {
        gl->ActiveTexture(GL_TEXTURE0 + GLLIGHTS_UNIT + i);
        gl->BindTexture(GL_TEXTURE_CUBE_MAP, L->cube[i]);
        gl->ActiveTexture(GL_TEXTURE0 + GLLIGHTS_UNIT + GLLIGHTS_MAX + 1 + i);
        gl->BindTexture(GL_TEXTURE_2D, L->spot[i]);
    }
    gl->ActiveTexture(GL_TEXTURE0 + GLLIGHTS_UNIT + GLLIGHTS_MAX);
    gl->BindTexture(GL_TEXTURE_BUFFER, L->tex_brdf);
    gl->ActiveTexture(GL_TEXTURE0);
}

/* ---------------------------------------------------------------- test hook */

static const char *k_eval_vs =
    "#version 330 core\n"
    "layout(location = 0) in vec3 a_wi;\n"
    "layout(location = 1) in vec3 a_wo;\n"
    "uniform int u_n;\n"
    "flat out vec3 v_wi, v_wo;\n"
    "void main() {\n"
    "    v_wi = a_wi; v_wo = a_wo;\n"
    "    gl_Position = vec4((float(gl_VertexID) + 0.5) / float(u_n) * 2.0 - 1.0, 0.0, 0.0, 1.0);\n"
    "}\n";
static const char *k_eval_fs_main =
    "flat in vec3 v_wi, v_wo;\n"
    "uniform int u_m;\n"
    "out vec4 o;\n"
    "void main() { o = vec4(brdf_glsl(u_m, v_wi, v_wo), 1.0); }\n";

/* One point per pair into an n x 1 float target, read back. */
static int eval_points(gllights *L, GLuint prog, const float *wi, const float *wo, int n, float *rgb, prt_error *err) {
    const gl_api *gl = L->gl;
    GLuint vao, vbo[2], fbo, tex;
    gl->GenVertexArrays(1, &vao);
    gl->BindVertexArray(vao);
    gl->GenBuffers(2, vbo);
    for (int k = 0; k < 2; k++) {
        gl->BindBuffer(GL_ARRAY_BUFFER, vbo[k]);
        gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(sizeof(float) * 3 * (size_t)n), k ? wo : wi, GL_STATIC_DRAW);
        gl->EnableVertexAttribArray((GLuint)k);
        gl->VertexAttribPointer((GLuint)k, 3, GL_FLOAT, GL_FALSE, 0, 0);
    }
    gl->GenTextures(1, &tex);
    gl->BindTexture(GL_TEXTURE_2D, tex);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, n, 1, 0, GL_RGBA, GL_FLOAT, NULL);
    gl->GenFramebuffers(1, &fbo);
    gl->BindFramebuffer(GL_FRAMEBUFFER, fbo);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
    gl->Viewport(0, 0, n, 1);
    gl->ClearColor(0, 0, 0, 0);
    gl->Clear(GL_COLOR_BUFFER_BIT);
    gl->UseProgram(prog);
    gl->Uniform1i(gl->GetUniformLocation(prog, "u_n"), n);
    gl->ActiveTexture(GL_TEXTURE0 + GLLIGHTS_UNIT + GLLIGHTS_MAX);
    gl->BindTexture(GL_TEXTURE_BUFFER, L->tex_brdf);
    gl->Uniform1i(gl->GetUniformLocation(prog, "t_brdf"), GLLIGHTS_UNIT + GLLIGHTS_MAX);
    gl->DrawArrays(GL_POINTS, 0, n);
    float *px = prt_calloc(4 * (size_t)n, sizeof(float), err);
    if (px) {
        gl->ReadPixels(0, 0, n, 1, GL_RGBA, GL_FLOAT, px);
        for (int i = 0; i < n; i++) memcpy(rgb + 3 * i, px + 4 * i, 3 * sizeof(float));
    }
    free(px);
    gl->BindTexture(GL_TEXTURE_BUFFER, 0);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->UseProgram(0);
    gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->DeleteFramebuffers(1, &fbo);
    gl->DeleteTextures(1, &tex);
    gl->BindVertexArray(0);
    gl->DeleteBuffers(2, vbo);
    gl->DeleteVertexArrays(1, &vao);
    return px ? glctx_check(gl, "local lights: BRDF evaluation", err) : -1;
}

int gllights_eval_brdf(gllights *L, int m, const float *wi, const float *wo, int n, float *rgb, prt_error *err) {
    PRT_CHECK(m >= 0 && m < L->scene->nmaterials && n > 0);
    const char *head = "#version 330 core\n#define LMAX 0\n";
    size_t len = strlen(head) + strlen(k_glsl) + strlen(k_eval_fs_main) + 1;
    char *fs = prt_calloc(len, 1, err);
    if (!fs) return -1;
    snprintf(fs, len, "%s%s%s", head, k_glsl, k_eval_fs_main);
    GLuint prog = glctx_program(L->gl, k_eval_vs, fs, "BRDF evaluation", err);
    free(fs);
    if (!prog) return -1;
    L->gl->UseProgram(prog);
    L->gl->Uniform1i(L->gl->GetUniformLocation(prog, "u_m"), m);
    int rc = eval_points(L, prog, wi, wo, n, rgb, err);
    L->gl->DeleteProgram(prog);
    return rc;
}
