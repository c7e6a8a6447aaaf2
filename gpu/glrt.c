/* glrt.c - the GLSL runtime (glrt.h): the quantized transport lives on the GPU,
 * a light change is one GPU pass of sparse inner products (Eq. 5's T x L), and a
 * view change is one draw that multiplies the light-dependent K-vectors with the
 * BRDF view maps per pixel (section 4.3.1, 5.3).
 *
 * Data on the GPU (all plain buffers, viewed as SSBOs by the compute kernels
 * and as buffer textures by the fragment kernel and the view shaders):
 *   first   [nvecs+1] uint        coefficient range of each vector
 *   words   qbits 8:  [ncoefs] uint  offset | r<<8 | g<<16 | b<<24 (the file's words)
 *           qbits 16: [2*ncoefs]     index | r<<16, g | b<<16
 *           qbits 32: [4*ncoefs]     index, r, g, b (float bits)
 *   blocks  qbits 8:  [ncoefs] uint8 block of each coefficient (the runs expanded)
 *   scale   [3*nvecs] float        dequantization step per vector and channel
 *   L       [CUBE_TEXELS] vec4     light vector
 *   g       [nvecs] vec4           light-dependent K-vectors (output of a light change)
 *   view    per material [res*res][K] vec4: the view maps h_k
 * The 8-bit layout is the paper's (4.1.2): a 4-byte word per coefficient plus
 * its block byte, 5 bytes in all.
 * A transfer without GLSL kernels (ops->linear->glsl NULL) has only L's and g's buffers here and
 * the view data: its light change runs on the CPU (transfer_light) and g is uploaded
 * (GLRT_LIGHT_CPU, cpu_set_light). */
#include "glrt.h"
#include "prefilter.h"
#include "gldraw.h"
#include "gllights.h"
#include "glvsgl.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct glrt {
    glctx *ctx;
    bool own_ctx;
    const gl_api *gl;
    const prt_data *d;
    const prt_transfer *tr;     /* the file's sparse transfer: its transport and light kernels */
    gldraw draw;
    int nverts, nvecs, kmax_all, nmat, qbits;
    size_t ncoefs, transport_bytes, other_bytes;
    bool direct;                /* the direct-only transport set is uploaded (CPU method: is lit) */
    bool cpu;                   /* the transfer has no GLSL: GLRT_LIGHT_CPU, no transport on the GPU */
    float *open4;               /* [4 * nvecs] staging of the open sky's addend (buf_open), or NULL */
    float *cpu_g;               /* CPU method: [4 * nvecs], g = T x L as [3 * nvecs], then padded to vec4 in place */
    GLuint buf_first, buf_words, buf_blocks, buf_scale, buf_L, buf_g, buf_view, buf_open;
    GLuint tex_first, tex_words, tex_blocks, tex_scale, tex_L, tex_g, tex_view, tex_open;
    GLuint prog_light[GLRT_LIGHT_COUNT];
    GLuint frag_fbo, frag_tex;
    int frag_w, frag_h;
    GLuint prog_view[4];        /* per pixel (TV_FULL), per vertex, per pixel without tv (with no tv at all: per
                                 * pixel with the glossy VSGL term, spec_tris), per pixel tv fast path */
    int tv_tris[3];             /* triangles drawn by prog_view[2], [3], [0] in that order (per pixel with a tv) */
    int tv_perm;                /* word offset in t_tvu of the drawn order's triangle indices */
    GLuint vao, vbo_pos, vbo_nrm, vbo_vec, vbo_mat, vbo_add, vbo_pix, vbo_tva, vbo_uv, ebo;
    GLuint buf_alb, tex_alb;    /* textured scenes: every texture's linear texels (RGBA32F), see upload_textures */
    GLint tex_info[PRT_MAX_MATERIALS][4];   /* per material: first texel in t_alb (-1: untextured), width, height */
    const prt_transfer *tv;     /* the transfer shaded per pixel (ops->view->glsl), or NULL */
    GLuint buf_tv, tex_tv, buf_tvu, tex_tvu, tex_pf[GLRT_PF_LEVELS];
    int pf_n;                   /* prefilter levels uploaded (0: none, per-vertex radiance only) */
    float pf_kappa[16], pf_Rt[9];
    int pf_nl;                  /* the ladder's lights uploaded (prefilter.h "Lights") */
    float pf_light[4 * PREFILTER_MAX_LIGHTS][4];   /* per light: (dir, kappa) of r, g, b, then (power, 0) */
    GLuint query;
    GLint mat_info[PRT_MAX_MATERIALS][4];
    float bg_R[9];
    bool bg_rotated, light_set;
    glrt_view_mode view_mode;
    glrt_light_method method;
    float unshift;              /* 2^e: the uploaded light is L x 2^-e (transfer_light_scaled_copy), the kernels undo it */
    glrt_timing timing;
    int lmax;                   /* local lights the view programs take (GLLIGHTS_MAX, or 0: units lacking) */
    gllights *local;            /* local lights: made at the first glrt_set_local_lights */
    bool local_bounce;          /* glrt_desc.local_bounce: the VSGLs too (glrt_set_local_effects turns it) */
    bool vsgl_glossy;           /* the VSGLs light the glossy lobe too (false under the highlights) */
    glvsgl *vsgl;               /* their VSGLs (glvsgl.h), made at the first light move when asked */
    bool vsgl_spec;             /* the view programs hold the glossy lobe's VSGL term (VSGL_SPEC) */
    prt_lights lights;          /* the last local lights (glrt_set_local_effects moves them again) */
    int spec_tris[2];           /* without a tv, per pixel with VSGL_SPEC: the element buffer holds the triangles
                                 * with no glossy corner first (drawn by prog_view[0], no glossy term), then the
                                 * rest (prog_view[2], with it); 0, 0: not ordered yet */
};

/* Texture units of the per-pixel view program: t_view, t_g, t_tv, then one cube map per level, then t_tvu. */
#define GLRT_UNIT_TV 2
#define GLRT_UNIT_PF 3
#define GLRT_UNIT_TVU (GLRT_UNIT_PF + GLRT_PF_LEVELS)
/* The textures' texels: after the local lights' units (gllights.h). */
#define GLRT_UNIT_ALB (GLLIGHTS_UNIT + 2 * GLLIGHTS_MAX + 1)

/* Static name of a light kernel. */
const char *glrt_light_method_name(glrt_light_method m) {
    switch (m) {
    case GLRT_LIGHT_FRAGMENT: return "fragment";
    case GLRT_LIGHT_THREAD: return "compute-thread";
    case GLRT_LIGHT_WARP: return "compute-warp";
    case GLRT_LIGHT_CPU: return "cpu";
    default: return "auto";
    }
}

/* ---------------------------------------------------------------- shaders */

/* The light kernels (coefficient decoding, fragment, thread and warp) are the transfer
 * representation's (transfer.h: ops->linear->glsl; the linear family's live in linear.c). */

/* View-map lookups, mirroring brdf_factor_uv / brdf_factor_view (bilinear on texel centres; the
 * grid clamps at its edge, the polar angle wraps) and Eq. 10's frame (brdf_frame). */
static const char *k_view_common =
    "uniform samplerBuffer t_view;\n"
    /* toward: the direction of d whatever its length (a scene 1e20 or 1e-20 across squares d out of
     * float's range in normalize): scaled by its largest component first (docs/design/scale.md).
     * Branch-free, with the scale floored at FLT_MIN: the form with a ternary corrupted llvmpipe's
     * heap when it compiles for 128-bit vectors (LP_NATIVE_VECTOR_WIDTH=128, make test-portable). */
    "vec3 toward(vec3 d) {\n"
    "    float m = max(max(abs(d.x), abs(d.y)), abs(d.z));\n"
    "    return normalize(d * (1.0 / max(m, 1.17549435e-38)));\n"
    "}\n"
    "uniform ivec4 u_mat[NMAT];\n" /* x: first view texel, y: res, z: K, w: param | 2 * lambertian */
    /* brdf_frame: Eq. 10's s without cancellation near n.y = -1, the fixed limit within 1e-6 of
     * (0,-1,0), s made orthogonal to n; t = n x s. */
    "void frame(vec3 n, out vec3 s, out vec3 t) {\n"
    "    float r2 = n.x * n.x + n.z * n.z;\n"
    "    vec3 v;\n"
    "    if (n.y < 0.0 && r2 < 1e-12) v = vec3(1.0, 0.0, 0.0);\n"
    "    else {\n"
    "        float a = n.y >= 0.0 ? n.y + 1.0 : r2 / (1.0 - n.y);\n"
    "        v = vec3(a * a + n.z * n.z - n.x * n.x, -2.0 * a * n.x, -2.0 * n.x * n.z);\n"
    "    }\n"
    "    v -= dot(v, n) * n;\n"
    "    float l = length(v);\n"
    "    s = l > 1e-30 ? v / l : (abs(n.x) < 0.9 ? normalize(cross(n, vec3(1.0, 0.0, 0.0))) : normalize(cross(n, vec3(0.0, 1.0, 0.0))));\n"
    "    t = cross(n, s);\n"
    "}\n"
    /* Sum_k<kuse h_k(w) g[k]: w local view direction. */
    "vec3 shade(ivec4 mi, vec3 w, vec3 g[KMAX], int kuse) {\n"
    "    int res = mi.y, K = mi.z;\n"
    "    bool polar = (mi.w & 1) != 0, lambert = (mi.w & 2) != 0;\n"
    /* As relight.c: a view below the horizon is shaded at a grazing view (z = 0.02, same azimuth). */
    "    if (!lambert && w.z < 0.02) {\n"
    "        float r = length(w.xy);\n"
    "        w = vec3(r > 1e-12 ? w.xy * (0.99979998 / r) : vec2(0.99979998, 0.0), 0.02);\n"
    "    }\n"
    "    float x, y;\n"
    "    if (lambert) { x = 0.5; y = 0.5; }\n"
    "    else if (polar) { x = atan(w.y, w.x) * 0.15915494309189535; if (x < 0.0) x += 1.0;\n"
    "                      y = sqrt(max(1.0 - w.z, 0.0)); }\n"
    "    else { x = 0.5 * (w.x + 1.0); y = 0.5 * (w.y + 1.0); }\n"
    "    float fx = x * float(res) - 0.5, fy = y * float(res) - 0.5;\n"
    "    float ix = floor(fx), iy = floor(fy);\n"
    "    float ax = fx - ix, ay = fy - iy;\n"
    "    int x0 = int(ix), x1 = x0 + 1, y0 = int(iy), y1 = y0 + 1;\n"
    "    if (polar) { x0 = (x0 + res) % res; x1 = x1 % res; }\n"
    "    else { x0 = clamp(x0, 0, res - 1); x1 = clamp(x1, 0, res - 1); }\n"
    "    y0 = clamp(y0, 0, res - 1); y1 = clamp(y1, 0, res - 1);\n"
    "    int t00 = mi.x + (y0 * res + x0) * K, t10 = mi.x + (y0 * res + x1) * K;\n"
    "    int t01 = mi.x + (y1 * res + x0) * K, t11 = mi.x + (y1 * res + x1) * K;\n"
    "    float w00 = (1.0 - ax) * (1.0 - ay), w10 = ax * (1.0 - ay), w01 = (1.0 - ax) * ay, w11 = ax * ay;\n"
    "    vec3 c = vec3(0.0);\n"
    "    for (int k = 0; k < KMAX; k++) {\n"
    "        if (k >= kuse) break;\n"
    "        vec3 h = w00 * texelFetch(t_view, t00 + k).rgb + w10 * texelFetch(t_view, t10 + k).rgb\n"
    "               + w01 * texelFetch(t_view, t01 + k).rgb + w11 * texelFetch(t_view, t11 + k).rgb;\n"
    "        c += h * g[k];\n"
    "    }\n"
    "    return c;\n"
    "}\n"
    /* texture_sample (texture.h) of material m's texture at uv: bilinear between texel centres,
     * repeat, row 0 at v = 1; 1 untextured. g_albedo: the one being shaded, which brdf_glsl
     * (gllights.c) scales kd by for the local lights. */
    "vec3 g_albedo = vec3(1.0);\n"
    "#if HAS_TEX\n"
    "uniform samplerBuffer t_alb;\n"
    "uniform ivec4 u_tex[NMAT];\n"
    "vec3 albedo_at(int m, vec2 uv) {\n"
    "    ivec4 ti = u_tex[m];\n"
    "    if (ti.x < 0) return vec3(1.0);\n"
    "    if (isnan(uv.x) || isinf(uv.x) || isnan(uv.y) || isinf(uv.y)) uv = vec2(0.0);\n"
    "    float x = uv.x * float(ti.y) - 0.5, y = (1.0 - uv.y) * float(ti.z) - 0.5;\n"
    "    float fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;\n"
    "    int x0 = int(mod(fx, float(ti.y))), y0 = int(mod(fy, float(ti.z)));\n"
    "    x0 = clamp(x0, 0, ti.y - 1); y0 = clamp(y0, 0, ti.z - 1);\n"   /* mod's rounding can reach the size */
    "    int x1 = x0 + 1 < ti.y ? x0 + 1 : 0, y1 = y0 + 1 < ti.z ? y0 + 1 : 0;\n"
    "    vec3 a = texelFetch(t_alb, ti.x + y0 * ti.y + x0).rgb, b = texelFetch(t_alb, ti.x + y0 * ti.y + x1).rgb;\n"
    "    vec3 d = texelFetch(t_alb, ti.x + y1 * ti.y + x0).rgb, e = texelFetch(t_alb, ti.x + y1 * ti.y + x1).rgb;\n"
    "    return (1.0 - ay) * ((1.0 - ax) * a + ax * b) + ay * ((1.0 - ax) * d + ax * e);\n"
    "}\n"
    "#else\n"
    "vec3 albedo_at(int m, vec2 uv) { return vec3(1.0); }\n"
    "#endif\n"
    "vec3 shade_world(int m, vec3 n, vec3 pos, vec3 eye, vec3 g[KMAX], int kmax) {\n"
    "    ivec4 mi = u_mat[m];\n"
    "    vec3 s, t;\n"
    "    frame(n, s, t);\n"
    "    vec3 wo = toward(eye - pos);\n"
    "    int kuse = kmax > 0 ? min(kmax, mi.z) : mi.z;\n"
    /* Radiance is clamped at zero as the CPU runtime does (a truncated SVD can dip below). */
    "    return max(shade(mi, vec3(dot(wo, s), dot(wo, t), dot(wo, n)), g, kuse), vec3(0.0));\n"
    "}\n";

static const char *k_view_vs =
    "layout(location = 0) in vec3 a_pos;\n"
    "layout(location = 1) in vec3 a_nrm;\n"
    "layout(location = 2) in uvec2 a_vec;\n"
    "layout(location = 3) in uint a_mat;\n"
    "layout(location = 4) in vec3 a_add;\n"   /* radiance of the non-linear transfers (glrt_set_vertex_add) */
    "layout(location = 5) in float a_pix;\n"  /* 1: a vertex of the per-pixel transfer's materials (view->glsl) */
    "layout(location = 6) in float a_tva;\n"  /* the per-pixel transfer's own per-vertex value (view->glsl->data) */
    "layout(location = 7) in vec2 a_uv;\n"    /* texture coordinates (textured scenes) */
    "uniform mat4 u_mvp;\n"
    "uniform samplerBuffer t_g;\n"
    "uniform vec3 u_eye;\n"
    "uniform int u_kmax;\n"
    "out vec3 v_pos, v_nrm;\n"   /* both: the one-sided test per pixel */
    "#if PER_VERTEX\n"
    "out vec3 v_col;\n"
    "#else\n"
    "out vec3 v_add;\n"
    "out vec2 v_uv;\n"
    "out float v_pix, v_tva;\n"
    "out vec3 v_g[KMAX];\n"
    "flat out int v_mat;\n"
    "#endif\n"
    "void main() {\n"
    "    vec3 g[KMAX];\n"
    "    for (int k = 0; k < KMAX; k++) g[k] = uint(k) < a_vec.y ? texelFetch(t_g, int(a_vec.x) + k).rgb : vec3(0.0);\n"
    "#if PER_VERTEX\n"   /* the texture at the vertex times the sparse sum, as relight.c; kd's for the local lights */
    "    g_albedo = albedo_at(int(a_mat), a_uv);\n"
    "    v_col = g_albedo * shade_world(int(a_mat), normalize(a_nrm), a_pos, u_eye, g, u_kmax) + a_add\n"
    "          + local_lights(int(a_mat), a_pos, normalize(a_nrm), u_eye);\n"
    "    g_albedo = vec3(1.0);\n"   /* the VSGL bounce shades with the material's own kd, as indirect.c */
    "    v_col += vsgl_lights(int(a_mat), a_pos, normalize(a_nrm), u_eye);\n"
    "    v_pos = a_pos; v_nrm = a_nrm;\n"
    "#else\n"
    "    for (int k = 0; k < KMAX; k++) v_g[k] = g[k];\n"
    "    v_pos = a_pos; v_nrm = a_nrm; v_mat = int(a_mat); v_add = a_add; v_pix = a_pix; v_tva = a_tva; v_uv = a_uv;\n"
    "#endif\n"
    "    gl_Position = u_mvp * vec4(a_pos, 1.0);\n"
    "}\n";

static const char *k_view_fs =
    "uniform vec3 u_eye;\n"
    "uniform int u_kmax, u_tri0, u_tv_perm;\n"
    "out vec4 o_color;\n"
    /* one-sided, as prt reference and gldraw.c: a pixel whose interpolated normal faces away is black */
    "in vec3 v_pos, v_nrm;\n"
    "#if PER_VERTEX\n"
    "in vec3 v_col;\n"
    "void main() { o_color = vec4(dot(v_nrm, u_eye - v_pos) > 0.0 ? max(v_col, 0.0) : vec3(0.0), 1.0); }\n"   /* max: beyond a silhouette when multisampled (gldraw.c) */
    "#else\n"
    "in vec3 v_add;\n"
    "in vec2 v_uv;\n"
    "in float v_pix, v_tva;\n"
    "in vec3 v_g[KMAX];\n"
    "flat in int v_mat;\n"
    "void main() {\n"
    "    vec3 g[KMAX];\n"
    "    for (int k = 0; k < KMAX; k++) g[k] = v_g[k];\n"
    "    vec3 add = v_add;\n"
    "#if HAS_TV\n"   /* a corner of the transfer's materials: its radiance per pixel (the CPU left it out of v_add) */
    "    if (u_pf_n > 0 && v_pix > 0.0) {\n"
    "        int tri = int(texelFetch(t_tvu, u_tv_perm + u_tri0 + gl_PrimitiveID).r);\n"   /* the mesh's triangle index */
    "        vec3 r = tv_radiance(tri, v_pos, v_nrm, toward(u_eye - v_pos), v_tva);\n"
    "        for (int c = 0; c < 3; c++) add[c] += isnan(r[c]) || isinf(r[c]) || r[c] < 0.0 ? 0.0 : r[c];\n"   /* as the CPU */
    "    }\n"
    "#endif\n"
    "    vec3 n = normalize(v_nrm);\n"
    /* the texture at the pixel times the sparse sum (the transport is stored without it; the vMF lobes
     * in add are the specular part), and kd's for the local lights */
    "    g_albedo = albedo_at(v_mat, v_uv);\n"
    "    vec3 c = g_albedo * shade_world(v_mat, n, v_pos, u_eye, g, u_kmax) + add + local_lights(v_mat, v_pos, n, u_eye);\n"
    "    g_albedo = vec3(1.0);\n"   /* the VSGL bounce shades with the material's own kd, as indirect.c */
    "    o_color = vec4(dot(v_nrm, u_eye - v_pos) > 0.0 ? c + vsgl_lights(v_mat, v_pos, n, u_eye) : vec3(0.0), 1.0);\n"
    "}\n"
    "#endif\n";

/* prefilter_lookup (prefilter.h) on the GPU: one seamless cube map per ladder level (bilinear
 * within, GL's seamless corner filtering instead of the CPU's extrapolated tap), log kappa between
 * vMF levels, kappa towards the kappa-0 level, R^T applied to the direction; plus the lights taken out
 * of the ladder, each channel's vMF convolved exactly with the lookup's (pf_add_lights' arithmetic in
 * float: 1 - cos as |d - w|^2 / 2, the exponent -2 k ks (1 - cos) / (k + ks + km), C(k) by its series
 * below 1e-2). */
static const char *k_pf_glsl =
    "uniform samplerCube t_pf[PF_LEVELS];\n"
    "uniform vec4 u_pf_kappa[4];\n"
    "uniform int u_pf_n, u_pf_nl;\n"
    "uniform mat3 u_pf_Rt;\n"
    "uniform vec4 u_pf_light[4 * PF_LIGHTS];\n"
    "uniform samplerBuffer t_tv;\n"
    "uniform usamplerBuffer t_tvu;\n"
    "float pf_k(int l) { return u_pf_kappa[l / 4][l % 4]; }\n"
    "PF_LEVEL\n"   /* vec3 pf_pair(int l, vec3 d, float t): levels l and l + 1 mixed by t, one if chain
                      * (GLSL 3.3 indexes samplers by constants only) */
    "float pf_norm(float k) { return k < 1e-2 ? (1.0 + k + k * k / 3.0) * 0.0795774715 : k / (6.2831853 * (1.0 - exp(-2.0 * k))); }\n"
    "float pf_conv(vec4 l, vec3 d, float k, float ck) {\n"   /* int gamma(.; l.xyz, l.w) gamma(.; d, k), ck = C(k) */
    "    vec3 v = d - l.xyz;\n"
    "    float omc = 0.5 * dot(v, v), ks = l.w;\n"
    "    if (k * ks * omc > 20.0 * (k + ks)) return 0.0;\n"   /* PF_LIGHT_CUT */
    "    float km = sqrt(max((k + ks) * (k + ks) - 2.0 * k * ks * omc, 0.0));\n"
    "    return ck / pf_norm(km) * pf_norm(ks) * exp(-2.0 * k * ks * omc / (k + ks + km));\n"   /* C(k) / C(km) first: near 1 unless the exponential vanishes, so no float overflow */
    "}\n"
    "vec3 pf_lights(vec3 d, float kappa) {\n"
    "    float k = clamp(kappa, 0.0, 1e8), ck = pf_norm(k);\n"
    "    vec3 s = vec3(0.0);\n"
    "    for (int i = 0; i < u_pf_nl; i++)\n"
    "        s += u_pf_light[4 * i + 3].rgb * vec3(pf_conv(u_pf_light[4 * i], d, k, ck), pf_conv(u_pf_light[4 * i + 1], d, k, ck),\n"
    "                                               pf_conv(u_pf_light[4 * i + 2], d, k, ck));\n"
    "    return s;\n"
    "}\n"
    "vec3 pf_ladder(vec3 d, float kappa) {\n"
    "    int last = u_pf_n - 1;\n"
    "    if (kappa >= pf_k(0)) return pf_pair(0, d, 0.0);\n"
    "    if (!(kappa > 0.0)) return pf_pair(last, d, 0.0);\n"
    "    int l = 0;\n"
    "    while (l + 1 < last && pf_k(l + 1) > kappa) l++;\n"
    "    float t = l + 1 < last ? log(pf_k(l) / kappa) / log(pf_k(l) / pf_k(l + 1)) : 1.0 - kappa / pf_k(l);\n"
    "    return pf_pair(l, d, t);\n"
    "}\n"
    "vec3 pf_lookup(vec3 dir, float kappa) {\n"
    "    vec3 d = normalize(u_pf_Rt * dir);\n"
    "    return u_pf_nl > 0 ? pf_ladder(d, kappa) + pf_lights(d, kappa) : pf_ladder(d, kappa);\n"
    "}\n";

static const char *k_fullscreen_vs =
    "#version 330 core\n"
    "void main() {\n"
    "    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"
    "    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
    "}\n";

/* Joins parts into one malloc'd string, replacing the markers DECODE and BUFFERS by their text. */
static char *build_src(const char *head, const char *body, const char *decode, const char *buffers) {
    size_t cap = strlen(head) + strlen(body) + strlen(decode) + strlen(buffers) + 1;
    char *s = malloc(cap);
    if (!s) return NULL;
    strcpy(s, head);
    const char *p = body;
    while (*p) {
        if (!strncmp(p, "DECODE\n", 7)) { strcat(s, decode); p += 7; continue; }
        if (!strncmp(p, "BUFFERS\n", 8)) { strcat(s, buffers); p += 8; continue; }
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p + 1) : strlen(p);
        strncat(s, p, n);
        p += n;
    }
    return s;
}

/* ---------------------------------------------------------------- creation */

static GLuint make_buffer(const gl_api *gl, const void *data, size_t bytes, GLenum usage) {
    GLuint b;
    gl->GenBuffers(1, &b);
    gl->BindBuffer(GL_ARRAY_BUFFER, b);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(bytes ? bytes : 16), data, usage);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    return b;
}

/* A buffer texture viewing buf with format fmt. */
static GLuint make_texbuf(const gl_api *gl, GLuint buf, GLenum fmt) {
    GLuint t;
    gl->GenTextures(1, &t);
    gl->BindTexture(GL_TEXTURE_BUFFER, t);
    gl->TexBuffer(GL_TEXTURE_BUFFER, fmt, buf);
    gl->BindTexture(GL_TEXTURE_BUFFER, 0);
    return t;
}

/* -1 with err when set t does not fit the GL buffer-texture limit (texels): its words (none on the
 * CPU method: nothing of t is uploaded) and its vectors' g. */
static int check_limits(glrt *rt, const prt_transport *t, prt_error *err) {
    GLint maxtb = 0;
    rt->gl->GetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &maxtb);
    size_t words = rt->cpu ? 0 : (size_t)t->coef_first[t->nvecs] * (t->qbits == 8 ? 1 : t->qbits == 16 ? 2 : 4);
    if ((size_t)maxtb < words + 1 || (size_t)maxtb < (size_t)t->nvecs + 1)
        return prt_fail(err, "GL runtime: %zu transport words exceed the GL buffer-texture limit (%d texels)", words, maxtb);
    return 0;
}

/* Encodes transport set t into the GPU layout (see the file comment), replacing the coefficient
 * buffers; -1 with err. */
static int upload_transport(glrt *rt, const prt_transport *t, prt_error *err) {
    const gl_api *gl = rt->gl;
    rt->ncoefs = t->coef_first[t->nvecs];
    rt->qbits = t->qbits;
    size_t nc = rt->ncoefs;
    int wpc = t->qbits == 8 ? 1 : t->qbits == 16 ? 2 : 4;
    uint32_t *words = prt_calloc(nc * wpc + 1, sizeof(uint32_t), err);
    uint8_t *blocks = prt_calloc((nc + 4) & ~(size_t)3, 1, err);
    float *scale = prt_calloc((size_t)3 * rt->nvecs + 1, sizeof(float), err);
    if (!words || !blocks || !scale) { free(words); free(blocks); free(scale); return -1; }
    for (int i = 0; i < rt->nvecs; i++) {
        uint32_t c = t->coef_first[i];
        for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
            int blk = t->runs[2 * r], cnt = t->runs[2 * r + 1] + 1;
            for (int k = 0; k < cnt && c < t->coef_first[i + 1]; k++, c++) {
                uint32_t off = t->qbits == 8 ? (t->packed[c] & 255u) : t->offs[c];
                uint32_t idx = (uint32_t)blk * 256u + off;
                blocks[c] = (uint8_t)blk;
                if (t->qbits == 8) words[c] = t->packed[c];
                else if (t->qbits == 16) {
                    words[2 * c] = idx | (uint32_t)(uint16_t)t->q16[3 * c] << 16;
                    words[2 * c + 1] = (uint32_t)(uint16_t)t->q16[3 * c + 1] | (uint32_t)(uint16_t)t->q16[3 * c + 2] << 16;
                } else {
                    words[4 * c] = idx;
                    memcpy(&words[4 * c + 1], &t->f32[3 * c], 3 * sizeof(float));
                }
            }
        }
        for (int ch = 0; ch < 3; ch++) {
            float s = t->qbits == 32 || !t->scale ? 1.0f : t->scale[3 * i + ch];
            scale[3 * i + ch] = isfinite(s) ? s : 0.0f;
        }
    }
    GLuint old[8] = { rt->buf_first, rt->buf_words, rt->buf_blocks, rt->buf_scale,
                      rt->tex_first, rt->tex_words, rt->tex_blocks, rt->tex_scale };
    for (int i = 0; i < 4; i++)
        if (old[i]) gl->DeleteBuffers(1, &old[i]);
    for (int i = 4; i < 8; i++)
        if (old[i]) gl->DeleteTextures(1, &old[i]);
    rt->buf_first = make_buffer(gl, t->coef_first, sizeof(uint32_t) * ((size_t)rt->nvecs + 1), GL_STATIC_DRAW);
    rt->buf_words = make_buffer(gl, words, sizeof(uint32_t) * (nc * wpc + 1), GL_STATIC_DRAW);
    rt->buf_blocks = make_buffer(gl, blocks, (nc + 4) & ~(size_t)3, GL_STATIC_DRAW);
    rt->buf_scale = make_buffer(gl, scale, sizeof(float) * ((size_t)3 * rt->nvecs + 1), GL_STATIC_DRAW);
    rt->transport_bytes = sizeof(uint32_t) * ((size_t)rt->nvecs + 1 + nc * wpc) + ((nc + 4) & ~(size_t)3) +
                          sizeof(float) * 3 * (size_t)rt->nvecs;
    free(words);
    free(blocks);
    free(scale);
    rt->tex_first = make_texbuf(gl, rt->buf_first, GL_R32UI);
    rt->tex_words = make_texbuf(gl, rt->buf_words, GL_R32UI);
    rt->tex_blocks = make_texbuf(gl, rt->buf_blocks, GL_R8UI);
    rt->tex_scale = make_texbuf(gl, rt->buf_scale, GL_R32F);
    return glctx_check(gl, "uploading the transport", err);
}

/* The light vector and K-vector buffers (the same for every transport set); -1 with err. */
static int make_light_buffers(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    /* g is padded to the fragment kernel's rectangle so that a pixel-pack read fills it. */
    rt->frag_w = rt->nvecs < 2048 ? (rt->nvecs > 0 ? rt->nvecs : 1) : 2048;
    rt->frag_h = (rt->nvecs + rt->frag_w - 1) / rt->frag_w;
    if (rt->frag_h < 1) rt->frag_h = 1;
    size_t lsize = sizeof(float) * 4 * CUBE_TEXELS, gsize = sizeof(float) * 4 * (size_t)rt->frag_w * rt->frag_h;
    /* Both start at zero (the light kernels are timed on this zero light at create). */
    float *zero = prt_calloc(gsize > lsize ? gsize : lsize, 1, err);
    if (!zero) return -1;
    if (!rt->cpu) {   /* the CPU method uploads g, not L */
        rt->buf_L = make_buffer(gl, zero, lsize, GL_DYNAMIC_DRAW);
        rt->tex_L = make_texbuf(gl, rt->buf_L, GL_RGBA32F);
        /* the open sky's addend per vector, laid out as g (zero without the split); g is at least as long */
        rt->buf_open = make_buffer(gl, zero, gsize, GL_DYNAMIC_DRAW);
        rt->tex_open = make_texbuf(gl, rt->buf_open, GL_RGBA32F);
    }
    rt->buf_g = make_buffer(gl, zero, gsize, GL_DYNAMIC_COPY);
    free(zero);
    rt->tex_g = make_texbuf(gl, rt->buf_g, GL_RGBA32F);
    return glctx_check(gl, "allocating the light buffers", err);
}

/* All materials' view maps into one RGBA32F buffer texture; -1 with err. */
static int upload_view_maps(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    const prt_data *d = rt->d;
    size_t texels = 0;
    for (int m = 0; m < rt->nmat; m++) texels += (size_t)d->factors[m].res * d->factors[m].res * d->factors[m].K;
    float *v = prt_calloc(4 * (texels + 1), sizeof(float), err);
    if (!v) return -1;
    size_t off = 0;
    for (int m = 0; m < rt->nmat; m++) {
        const brdf_factor *f = &d->factors[m];
        size_t n = (size_t)f->res * f->res * f->K;
        for (size_t j = 0; j < n; j++)
            for (int ch = 0; ch < 3; ch++) {
                float x = f->view[3 * j + ch];
                v[4 * (off + j) + ch] = isfinite(x) ? x : 0.0f;
            }
        rt->mat_info[m][0] = (GLint)off;
        rt->mat_info[m][1] = f->res;
        rt->mat_info[m][2] = f->K;
        rt->mat_info[m][3] = (f->param == BRDF_PARAM_POLAR ? 1 : 0) | (f->lambertian ? 2 : 0);
        off += n;
    }
    rt->buf_view = make_buffer(gl, v, sizeof(float) * 4 * (texels + 1), GL_STATIC_DRAW);
    rt->tex_view = make_texbuf(gl, rt->buf_view, GL_RGBA32F);
    rt->other_bytes += sizeof(float) * 4 * texels;
    free(v);
    return glctx_check(gl, "uploading the view maps", err);
}

/* Vertex arrays of the view pass (position, normal, first vector + count, material); -1 with err. */
static int upload_mesh(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    const prt_mesh *m = &rt->d->scene.mesh;
    const prt_transport *t = &rt->tr->transport;
    uint32_t *vec = prt_calloc(2 * (size_t)m->nverts + 2, sizeof(uint32_t), err);
    uint32_t *mat = prt_calloc((size_t)m->nverts + 1, sizeof(uint32_t), err);
    if (!vec || !mat) { free(vec); free(mat); return -1; }
    for (int v = 0; v < m->nverts; v++) {
        vec[2 * v] = t->vec_first[v];
        vec[2 * v + 1] = t->vec_first[v + 1] - t->vec_first[v];
        if (vec[2 * v + 1] > GLRT_MAX_TERMS) vec[2 * v + 1] = GLRT_MAX_TERMS;
        mat[v] = m->mat ? m->mat[v] : 0;
        if ((int)mat[v] >= rt->nmat) mat[v] = 0;
    }
    gl->GenVertexArrays(1, &rt->vao);
    gl->BindVertexArray(rt->vao);
    rt->vbo_pos = make_buffer(gl, m->pos, sizeof(float) * 3 * (size_t)m->nverts, GL_STATIC_DRAW);
    rt->vbo_nrm = make_buffer(gl, m->nrm, sizeof(float) * 3 * (size_t)m->nverts, GL_STATIC_DRAW);
    rt->vbo_vec = make_buffer(gl, vec, sizeof(uint32_t) * 2 * (size_t)m->nverts, GL_STATIC_DRAW);
    rt->vbo_mat = make_buffer(gl, mat, sizeof(uint32_t) * (size_t)m->nverts, GL_STATIC_DRAW);
    free(vec);
    free(mat);
    float *zero = prt_calloc(3 * (size_t)m->nverts + 3, sizeof(float), err);
    if (!zero) return -1;
    rt->vbo_add = make_buffer(gl, zero, sizeof(float) * 3 * (size_t)m->nverts, GL_DYNAMIC_DRAW);
    free(zero);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_pos);
    gl->EnableVertexAttribArray(0);
    gl->VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_nrm);
    gl->EnableVertexAttribArray(1);
    gl->VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_vec);
    gl->EnableVertexAttribArray(2);
    gl->VertexAttribIPointer(2, 2, GL_UNSIGNED_INT, 0, 0);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_mat);
    gl->EnableVertexAttribArray(3);
    gl->VertexAttribIPointer(3, 1, GL_UNSIGNED_INT, 0, 0);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_add);
    gl->EnableVertexAttribArray(4);
    gl->VertexAttribPointer(4, 3, GL_FLOAT, GL_FALSE, 0, 0);
    gl->GenBuffers(1, &rt->ebo);
    gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, rt->ebo);
    gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)m->ntris * 3 * sizeof(uint32_t), m->tris, GL_STATIC_DRAW);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    rt->other_bytes += sizeof(float) * 11 * (size_t)m->nverts + sizeof(uint32_t) * 3 * (size_t)m->ntris;
    return glctx_check(gl, "uploading the mesh", err);
}

/* A textured scene (texture.h: materials with a texture and the mesh's coordinates): every texture's
 * linear texels into one RGBA32F buffer texture that albedo_at (the view programs) samples as
 * texture_sample does, each material's place in it, and the coordinates as attribute 7. Exact
 * texture_sample arithmetic in the shader instead of GL's filtering keeps GPU and CPU on one rule
 * (a GPU's bilinear weights have 8 fraction bits) and needs no grouping of triangles by texture.
 * Nothing for an untextured scene. -1 with err (the texels beyond the buffer-texture limit, or a
 * context without the texture unit). */
static int upload_textures(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    const prt_scene *sc = &rt->d->scene;
    size_t texels = 0, off[SCENE_MAX_TEXTURES];
    for (int t = 0; t < sc->ntextures && t < SCENE_MAX_TEXTURES; t++) {
        off[t] = texels;
        texels += (size_t)sc->textures[t].w * sc->textures[t].h;
    }
    bool any = false;
    for (int m = 0; m < rt->nmat; m++) {
        const scene_texture *tx = sc->mesh.uv ? scene_material_tex(sc, m) : NULL;
        rt->tex_info[m][0] = tx ? (GLint)off[tx - sc->textures] : -1;
        rt->tex_info[m][1] = tx ? tx->w : 1;
        rt->tex_info[m][2] = tx ? tx->h : 1;
        any |= tx != NULL;
    }
    if (!any) return 0;
    GLint maxtb = 0, units = 0, vunits = 0;
    gl->GetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &maxtb);
    gl->GetIntegerv(GL_MAX_TEXTURE_IMAGE_UNITS, &units);
    gl->GetIntegerv(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS, &vunits);
    if (texels >= (size_t)maxtb || texels > (size_t)INT32_MAX)
        return prt_fail(err, "GL runtime: the textures' %zu texels exceed the GL buffer-texture limit (%d)", texels, maxtb);
    if (units <= GLRT_UNIT_ALB || vunits <= GLRT_UNIT_ALB)
        return prt_fail(err, "GL runtime: textures need %d texture units (this context has %d)", GLRT_UNIT_ALB + 1, units);
    float *v = prt_calloc(4 * texels, sizeof(float), err);
    if (!v) return -1;
    for (int t = 0; t < sc->ntextures && t < SCENE_MAX_TEXTURES; t++) {
        const scene_texture *tx = &sc->textures[t];
        for (size_t i = 0; i < (size_t)tx->w * tx->h; i++) memcpy(v + 4 * (off[t] + i), tx->lin + 3 * i, 3 * sizeof(float));
    }
    rt->buf_alb = make_buffer(gl, v, sizeof(float) * 4 * texels, GL_STATIC_DRAW);
    rt->tex_alb = make_texbuf(gl, rt->buf_alb, GL_RGBA32F);
    free(v);
    gl->BindVertexArray(rt->vao);
    rt->vbo_uv = make_buffer(gl, sc->mesh.uv, sizeof(float) * 2 * (size_t)sc->mesh.nverts, GL_STATIC_DRAW);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_uv);
    gl->EnableVertexAttribArray(7);
    gl->VertexAttribPointer(7, 2, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    rt->other_bytes += sizeof(float) * (4 * texels + 2 * (size_t)sc->mesh.nverts);
    return glctx_check(gl, "uploading the textures", err);
}

/* The element buffer as a stable partition of the mesh's triangles into ncls classes (cls_of: a
 * triangle's class), class 0 first, the mesh's order within each; counts[c] += the triangles of class
 * c; perm (may be NULL): perm[i] = the mesh's index of drawn triangle i. -1 on OOM. */
static int partition_tris(glrt *rt, int ncls, int (*cls_of)(const glrt *rt, const uint32_t *t, const void *ctx),
                          const void *ctx, int *counts, uint32_t *perm, prt_error *err) {
    const prt_mesh *m = &rt->d->scene.mesh;
    uint32_t *idx = prt_calloc(3 * (size_t)m->ntris + 3, sizeof(uint32_t), err);
    if (!idx) return -1;
    int n = 0;
    for (int cls = 0; cls < ncls; cls++)
        for (int f = 0; f < m->ntris; f++) {
            const uint32_t *t = m->tris + 3 * (size_t)f;
            if (cls_of(rt, t, ctx) != cls) continue;
            memcpy(idx + 3 * (size_t)n, t, 3 * sizeof(uint32_t));
            if (perm) perm[n] = (uint32_t)f;
            n++;
            counts[cls]++;
        }
    rt->gl->BindVertexArray(rt->vao);   /* the element binding is the vertex array's (core profile) */
    rt->gl->BufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, (GLsizeiptr)m->ntris * 3 * sizeof(uint32_t), idx);
    rt->gl->BindVertexArray(0);
    free(idx);
    return 0;
}

/* What a triangle's pixels need of the tv (struct glrt: tv_tris): 0 no corner of the tv's materials,
 * 1 every corner at vattr 1 (its fast path), 2 the rest. ctx: the float arrays pix, tva. */
static int tv_class(const glrt *rt, const uint32_t *t, const void *ctx) {
    (void)rt;
    const float *const *a = ctx, *pix = a[0], *tva = a[1];
    bool none = pix[t[0]] == 0 && pix[t[1]] == 0 && pix[t[2]] == 0;
    bool fast = pix[t[0]] == 1 && pix[t[1]] == 1 && pix[t[2]] == 1 && tva[t[0]] == 1 && tva[t[1]] == 1 && tva[t[2]] == 1;
    return none ? 0 : fast ? 1 : 2;
}

/* The element buffer reordered by tv_class; perm[i] = the mesh's index of drawn triangle i. -1 on OOM. */
static int order_tris(glrt *rt, const float *pix, const float *tva, uint32_t *perm, prt_error *err) {
    const float *ctx[2] = { pix, tva };
    memset(rt->tv_tris, 0, sizeof rt->tv_tris);
    return partition_tris(rt, 3, tv_class, ctx, rt->tv_tris, perm, err);
}

/* The per-pixel transfer's data (rt->tv, ops->view->glsl): its two arrays as buffer textures (t_tv
 * RGBA32F, t_tvu R32UI) and attribute 5, 1 at the vertices of its materials. Where the context
 * cannot hold them (buffer-texture size, texture units) rt->tv is dropped: the CPU shades its
 * vertices (the per-vertex model). -1 with err (OOM, GL error). */
static int upload_tv(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (!rt->tv) return 0;
    float (*f)[4] = NULL;
    uint32_t *u = NULL;
    float *tva = NULL;
    size_t nf = 0, nu = 0;
    if (rt->tv->ops->view->glsl->data(rt->d, rt->tv, &f, &nf, &u, &nu, &tva, err)) return -1;
    GLint maxtb = 0, units = 0;
    gl->GetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &maxtb);
    gl->GetIntegerv(GL_MAX_TEXTURE_IMAGE_UNITS, &units);
    float *pix = prt_calloc((size_t)rt->nverts + 1, sizeof(float), err);
    if (!pix || !tva || nf >= (size_t)maxtb || nu >= (size_t)maxtb || nu >= (size_t)INT32_MAX || units <= GLRT_UNIT_TVU) {
        free(f), free(u), free(tva);
        rt->tv = NULL;
        return pix ? (free(pix), 0) : -1;
    }
    const prt_mesh *m = &rt->d->scene.mesh;
    for (int v = 0; v < rt->nverts; v++) pix[v] = (rt->tv->materials >> (m->mat ? m->mat[v] : 0)) & 1 ? 1.f : 0.f;
    uint32_t *u2 = realloc(u, sizeof *u * (nu + (size_t)m->ntris + 1));
    if (!u2 || order_tris(rt, pix, tva, u2 + nu, err)) {
        free(f), free(u2 ? u2 : u), free(pix), free(tva);
        return prt_fail(err, "out of memory");
    }
    u = u2, rt->tv_perm = (int)nu, nu += (size_t)m->ntris;
    rt->buf_tv = make_buffer(gl, f, sizeof *f * nf, GL_STATIC_DRAW);
    rt->tex_tv = make_texbuf(gl, rt->buf_tv, GL_RGBA32F);
    rt->buf_tvu = make_buffer(gl, u, sizeof *u * nu, GL_STATIC_DRAW);
    rt->tex_tvu = make_texbuf(gl, rt->buf_tvu, GL_R32UI);
    gl->BindVertexArray(rt->vao);
    rt->vbo_pix = make_buffer(gl, pix, sizeof(float) * (size_t)rt->nverts, GL_STATIC_DRAW);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_pix);
    gl->EnableVertexAttribArray(5);
    gl->VertexAttribPointer(5, 1, GL_FLOAT, GL_FALSE, 0, 0);
    rt->vbo_tva = make_buffer(gl, tva, sizeof(float) * (size_t)rt->nverts, GL_STATIC_DRAW);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_tva);
    gl->EnableVertexAttribArray(6);
    gl->VertexAttribPointer(6, 1, GL_FLOAT, GL_FALSE, 0, 0);
    gl->BindVertexArray(0);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    rt->other_bytes += sizeof *f * nf + sizeof *u * nu + 2 * sizeof(float) * (size_t)rt->nverts;
    free(f), free(u), free(pix), free(tva);
    return glctx_check(gl, "uploading the per-pixel transfer", err);
}

/* Compiles the light kernels this context can run for the current qbits (replacing any); -1 with err. */
static int build_light_programs(glrt *rt, prt_error *err) {
    const gl_api *gl = rt->gl;
    char head[64], decode[2048];
    for (int i = 0; i < GLRT_LIGHT_COUNT; i++)
        if (rt->prog_light[i]) {
            gl->DeleteProgram(rt->prog_light[i]);
            rt->prog_light[i] = 0;
        }
    const transfer_glsl *k = rt->tr->ops->linear->glsl;
    snprintf(decode, sizeof decode, "#define QBITS %d\n%s", rt->qbits, k->decode);
    snprintf(head, sizeof head, "#version 330 core\n");
    char *fs = build_src(head, k->fragment, decode, "");
    if (!fs) return prt_fail(err, "out of memory");
    rt->prog_light[GLRT_LIGHT_FRAGMENT] = glctx_program(gl, k_fullscreen_vs, fs, "light (fragment)", err);
    free(fs);
    if (!rt->prog_light[GLRT_LIGHT_FRAGMENT]) return -1;
    if (rt->ctx->has_compute) {
        snprintf(head, sizeof head, "#version 430 core\n");
        const char *bodies[2] = { k->thread, k->warp };
        for (int b = 0; b < 2; b++) {
            char *cs = build_src(head, bodies[b], decode, k->buffers);
            if (!cs) return prt_fail(err, "out of memory");
            GLuint p = glctx_compute_program(gl, cs, b ? "light (warp)" : "light (thread)", err);
            free(cs);
            if (!p) return -1;
            rt->prog_light[b ? GLRT_LIGHT_WARP : GLRT_LIGHT_THREAD] = p;
        }
    }
    return 0;
}

/* The per-pixel program's extra fragment source: the prefilter lookup with its pf_level chain,
 * then the transfer's tv_radiance (malloc'd; NULL on OOM). */
static char *tv_source(const glrt *rt) {
    const char *src = rt->tv->ops->view->glsl->source;
    size_t cap = strlen(k_pf_glsl) + strlen(src) + 256 * GLRT_PF_LEVELS + 256;
    char *chain = malloc(cap), *out = malloc(cap);
    if (!chain || !out) { free(chain); free(out); return NULL; }
    size_t n = (size_t)snprintf(chain, cap, "vec3 pf_pair(int l, vec3 d, float t) {\n");
    for (int l = 0; l + 1 < GLRT_PF_LEVELS; l++)   /* t = 0 at the last level: level l + 1 is unused (or unbound) */
        n += (size_t)snprintf(chain + n, cap - n,
                              "    if (l == %d) return t > 0.0 ? mix(textureLod(t_pf[%d], d, 0.0).rgb, textureLod(t_pf[%d], d, 0.0).rgb, t)"
                              " : textureLod(t_pf[%d], d, 0.0).rgb;\n", l, l, l + 1, l);
    snprintf(chain + n, cap - n, "    return textureLod(t_pf[%d], d, 0.0).rgb;\n}\n", GLRT_PF_LEVELS - 1);
    const char *mark = strstr(k_pf_glsl, "PF_LEVEL\n");
    snprintf(out, cap, "%.*s%s%s%s", (int)(mark - k_pf_glsl), k_pf_glsl, chain, mark + 9, src);
    free(chain);
    return out;
}

/* View program pv (struct glrt: 0 per pixel with the tv's full path, 1 per vertex, 2 per pixel without
 * the tv, 3 per pixel with its fast path only; llvmpipe runs both sides of a branch under a mask, so
 * the triangles that need less are drawn by programs that hold less, glrt_draw), with rt->lmax local
 * lights (0: none). The local lights' GLSL (gllights.h: local_lights()) follows the common view code;
 * with LMAX 0 it compiles to nothing, and even unused it doubled the per-pixel view change on
 * llvmpipe (bunny + floor, 800x600: 608 against 318 ms), so the programs are built without it and
 * again with it at the first local light (glrt_set_local_lights). -1 with err. */
static int build_view_program(glrt *rt, int pv, prt_error *err) {
    const gl_api *gl = rt->gl;
    char head[640];
    bool tvp = rt->tv && (pv == 0 || pv == 3);
    /* without a tv, the per-pixel program of the non-glossy triangles (0) holds no glossy term (spec_tris) */
    bool spec = rt->vsgl_spec && (rt->tv || pv != 0);
    int types = 0;   /* BRDF_TYPES (gllights.c): the scene's models only */
    for (int m = 0; m < rt->d->scene.nmaterials; m++) types |= 1 << rt->d->scene.materials[m].type;
    snprintf(head, sizeof head,
             "#version 330 core\n#define KMAX %d\n#define NMAT %d\n#define PER_VERTEX %d\n#define HAS_TV %d\n#define TV_FULL %d\n"
             "#define TV_ROWS %d\n#define PF_LEVELS %d\n#define PF_LIGHTS %d\n#define LMAX %d\n#define VSGL_SPEC %d\n#define VSGL_NFIT %d\n#define BRDF_TYPES %d\n"
             "#define HAS_TEX %d\n#define KD_SCALE g_albedo\n",
             rt->kmax_all, rt->nmat, pv == 1, tvp, pv == 0, rt->tv ? rt->tv->ops->view->glsl->rows : 1, GLRT_PF_LEVELS, PREFILTER_MAX_LIGHTS,
             rt->lmax, spec, spec ? glvsgl_fit_rows(rt->vsgl) : 1, types, rt->tex_alb != 0);
    char *vs = build_src(head, k_view_vs, "", "");
    char *vfs = build_src(head, k_view_fs, "", "");
    char *tv = tvp ? tv_source(rt) : NULL;
    size_t cv = strlen(k_view_common) + strlen(gllights_glsl()) + strlen(glvsgl_glsl()), hl = strlen(head);
    char *vs2 = vs ? malloc(strlen(vs) + cv + 1) : NULL, *fs2 = vfs ? malloc(strlen(vfs) + cv + (tv ? strlen(tv) : 0) + 1) : NULL;
    if (!vs2 || !fs2 || (tvp && !tv)) {
        free(vs); free(vfs); free(vs2); free(fs2); free(tv);
        return prt_fail(err, "out of memory");
    }
    /* head, then the common view functions, the local lights' and the VSGLs' (glvsgl.h: vsgl_lights(),
     * after gllights'), then the tv's, then the stage body. */
    sprintf(vs2, "%s%s%s%s%s", head, k_view_common, gllights_glsl(), glvsgl_glsl(), vs + hl);
    sprintf(fs2, "%s%s%s%s%s%s", head, k_view_common, gllights_glsl(), glvsgl_glsl(), tv ? tv : "", vfs + hl);
    static const char *names[4] = { "view (per pixel)", "view (per vertex)", "view (per pixel, no tv / glossy VSGL)",
                                    "view (per pixel, tv fast)" };
    rt->prog_view[pv] = glctx_program(gl, vs2, fs2, names[pv], err);
    free(vs); free(vfs); free(vs2); free(fs2); free(tv);
    if (!rt->prog_view[pv]) return -1;
    GLuint p = rt->prog_view[pv];
    gl->UseProgram(p);
    gl->Uniform4iv(gl->GetUniformLocation(p, "u_mat"), rt->nmat, &rt->mat_info[0][0]);
    gl->Uniform1i(gl->GetUniformLocation(p, "t_view"), 0);
    gl->Uniform1i(gl->GetUniformLocation(p, "t_g"), 1);
    if (rt->tex_alb) {
        gl->Uniform4iv(gl->GetUniformLocation(p, "u_tex"), rt->nmat, &rt->tex_info[0][0]);
        gl->Uniform1i(gl->GetUniformLocation(p, "t_alb"), GLRT_UNIT_ALB);
    }
    if (rt->lmax > 0) gllights_init_program(gl, p);
    if (spec) glvsgl_init_program(rt->vsgl, gl, p);
    if (tvp) {
        gl->Uniform1i(gl->GetUniformLocation(p, "t_tv"), GLRT_UNIT_TV);
        gl->Uniform1i(gl->GetUniformLocation(p, "t_tvu"), GLRT_UNIT_TVU);
        gl->Uniform1i(gl->GetUniformLocation(p, "u_tv_perm"), rt->tv_perm);
        for (int l = 0; l < GLRT_PF_LEVELS; l++) {
            char name[32];
            snprintf(name, sizeof name, "t_pf[%d]", l);
            gl->Uniform1i(gl->GetUniformLocation(p, name), GLRT_UNIT_PF + l);
        }
    }
    return 0;
}

/* Compiles the view programs this runtime draws with (build_view_program); -1 with err. */
static int build_view_programs(glrt *rt, prt_error *err) {
    for (int pv = 0; pv < (rt->tv ? 4 : rt->vsgl_spec ? 3 : 2); pv++)
        if (build_view_program(rt, pv, err)) return -1;
    rt->gl->UseProgram(0);
    return glctx_check(rt->gl, "building the shaders", err);
}

/* The light kernels (none on the CPU method) and the view programs; -1 with err. */
static int build_programs(glrt *rt, prt_error *err) {
    return (!rt->cpu && build_light_programs(rt, err)) || build_view_programs(rt, err) ? -1 : 0;
}

/* Runs the light kernel of method m on the current L into g. */
static void run_light(glrt *rt, glrt_light_method m) {
    const gl_api *gl = rt->gl;
    GLuint p = rt->prog_light[m];
    gl->UseProgram(p);
    gl->Uniform1f(gl->GetUniformLocation(p, "u_unshift"), rt->unshift > 0 ? rt->unshift : 1.f);
    if (m == GLRT_LIGHT_FRAGMENT) {
        if (!rt->frag_fbo) {
            gl->GenTextures(1, &rt->frag_tex);
            gl->BindTexture(GL_TEXTURE_2D, rt->frag_tex);
            gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, rt->frag_w, rt->frag_h, 0, GL_RGBA, GL_FLOAT, NULL);
            gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
            gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
            gl->BindTexture(GL_TEXTURE_2D, 0);
            gl->GenFramebuffers(1, &rt->frag_fbo);
            gl->BindFramebuffer(GL_FRAMEBUFFER, rt->frag_fbo);
            gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, rt->frag_tex, 0);
        }
        gl->BindFramebuffer(GL_FRAMEBUFFER, rt->frag_fbo);
        gl->Viewport(0, 0, rt->frag_w, rt->frag_h);
        gl->Disable(GL_DEPTH_TEST);
        const GLuint tex[6] = { rt->tex_first, rt->tex_words, rt->tex_blocks, rt->tex_scale, rt->tex_L, rt->tex_open };
        const char *names[6] = { "t_first", "t_words", "t_blocks", "t_scale", "t_L", "t_open" };
        for (int i = 0; i < 6; i++) {
            gl->ActiveTexture(GL_TEXTURE0 + i);
            gl->BindTexture(GL_TEXTURE_BUFFER, tex[i]);
            gl->Uniform1i(gl->GetUniformLocation(p, names[i]), i);
        }
        gl->Uniform1i(gl->GetUniformLocation(p, "u_width"), rt->frag_w);
        gl->Uniform1i(gl->GetUniformLocation(p, "u_nvecs"), rt->nvecs);
        gl->BindVertexArray(rt->draw.vao_empty);
        gl->DrawArrays(GL_TRIANGLES, 0, 3);
        gl->BindVertexArray(0);
        for (int i = 5; i >= 0; i--) {
            gl->ActiveTexture(GL_TEXTURE0 + i);
            gl->BindTexture(GL_TEXTURE_BUFFER, 0);
        }
        /* The paper's render-to-vertex-array step: copy the result into the g buffer on the GPU. */
        gl->ReadBuffer(GL_COLOR_ATTACHMENT0);
        gl->BindBuffer(GL_PIXEL_PACK_BUFFER, rt->buf_g);
        gl->ReadPixels(0, 0, rt->frag_w, rt->frag_h, GL_RGBA, GL_FLOAT, 0);
        gl->BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
        gl->BindFramebuffer(GL_FRAMEBUFFER, 0);
    } else {
        const GLuint bufs[7] = { rt->buf_first, rt->buf_words, rt->buf_blocks, rt->buf_scale, rt->buf_L, rt->buf_g, rt->buf_open };
        for (int i = 0; i < 7; i++) gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, i, bufs[i]);
        gl->Uniform1ui(gl->GetUniformLocation(p, "u_nvecs"), (GLuint)rt->nvecs);
        int per = m == GLRT_LIGHT_WARP ? 8 : 64;
        int groups = (rt->nvecs + per - 1) / per;
        int gx = groups < 65535 ? groups : 65535, gy = (groups + gx - 1) / gx;
        if (gx > 0) gl->DispatchCompute((GLuint)gx, (GLuint)gy, 1);
        gl->MemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
        for (int i = 0; i < 7; i++) gl->BindBufferBase(GL_SHADER_STORAGE_BUFFER, i, 0);
    }
    gl->UseProgram(0);
}

/* Every entry point makes the runtime's context current first: another context (for example
 * render_vertex_colors' own) may have been made current on this thread in between. */
static int current(glrt *rt, prt_error *err) { return glctx_make_current(rt->ctx, err); }

/* Runs method m once as a warm-up (software GL compiles the shader on first use), then once timed;
 * returns wall-clock milliseconds, finished. */
static double time_method(glrt *rt, glrt_light_method m) {
    const gl_api *gl = rt->gl;
    run_light(rt, m);
    gl->Finish();
    double t0 = prt_now();
    run_light(rt, m);
    gl->Finish();
    return 1e3 * (prt_now() - t0);
}

/* True when method m runs here: the CPU method on a transfer without GLSL, a GL kernel when it
 * compiled on this context (never on such a transfer: none is built). */
static bool method_available(const glrt *rt, glrt_light_method m) {
    if (m == GLRT_LIGHT_CPU) return rt->cpu;
    return m > GLRT_LIGHT_AUTO && m < GLRT_LIGHT_CPU && rt->prog_light[m] != 0;
}

/* Chooses (AUTO: times the GL kernels; a transfer without GLSL: the CPU method) the light method; -1
 * with err when unavailable. */
int glrt_set_light_method(glrt *rt, glrt_light_method m, prt_error *err) {
    if (current(rt, err)) return -1;
    if (m == GLRT_LIGHT_AUTO && rt->cpu) m = GLRT_LIGHT_CPU;
    if (m == GLRT_LIGHT_AUTO) {
        /* Time every kernel on the light currently uploaded (values do not change the cost). */
        glrt_light_method best = GLRT_LIGHT_AUTO;
        for (int k = GLRT_LIGHT_FRAGMENT; k < GLRT_LIGHT_CPU; k++) {
            rt->timing.method_ms[k] = 0;
            if (!method_available(rt, (glrt_light_method)k)) continue;
            rt->timing.method_ms[k] = time_method(rt, (glrt_light_method)k);
            if (best == GLRT_LIGHT_AUTO || rt->timing.method_ms[k] < rt->timing.method_ms[best]) best = (glrt_light_method)k;
        }
        m = best;
        if (glctx_check(rt->gl, "timing the light kernels", err)) return -1;
    }
    if (!method_available(rt, m) && (rt->cpu || m == GLRT_LIGHT_CPU))
        return prt_fail(err, "GL light method '%s' is not available: the %s transfer %s GLSL light kernels",
                        glrt_light_method_name(m), rt->tr->ops->name, rt->cpu ? "has no" : "has");
    if (!method_available(rt, m))
        return prt_fail(err, "GL light kernel '%s' is not available (needs OpenGL 4.3; this context is %d.%d)",
                        glrt_light_method_name(m), rt->ctx->major, rt->ctx->minor);
    rt->method = m;
    rt->timing.light_method = m;
    rt->timing.light_method_name = glrt_light_method_name(m);
    if (rt->light_set && m != GLRT_LIGHT_CPU) run_light(rt, m); /* keep g consistent with the chosen kernel */
    return 0;
}

/* See glrt.h. The caller owns the runtime (glrt_destroy); d must outlive it. */
glrt *glrt_create(const prt_data *d, const glrt_desc *desc, prt_error *err) {
    glrt_desc dd = desc ? *desc : (glrt_desc){ 0 };
    int nlinear = 0;
    for (int i = 0; i < d->ntransfers; i++) nlinear += d->transfers[i].ops && d->transfers[i].ops->kind == TRANSFER_LINEAR;
    if (nlinear != 1)
        return prt_fail(err, "GL runtime: the data has %d linear transfers (one supported)", nlinear), NULL;
    const prt_transfer *tr = prt_data_transfer(d);
    const prt_transport *t = &tr->transport;
    const prt_mesh *m = &d->scene.mesh;
    if (t->nverts != m->nverts || !t->vec_first || !t->coef_first)
        return prt_fail(err, "GL runtime: transport (%d vertices) does not match the mesh (%d)", t->nverts, m->nverts), NULL;
    if (tr->ops->linear->glsl && t->qbits != 8 && t->qbits != 16 && t->qbits != 32)
        return prt_fail(err, "GL runtime: unsupported quantization %d bits", t->qbits), NULL;
    int nmat = d->scene.nmaterials > 0 ? d->scene.nmaterials : 1, kmax = 1;
    if (nmat > PRT_MAX_MATERIALS) nmat = PRT_MAX_MATERIALS;
    for (int i = 0; i < nmat; i++) {
        if (!d->factors[i].view || d->factors[i].res < 1)
            return prt_fail(err, "GL runtime: material %d has no view maps", i), NULL;
        if (d->factors[i].K > kmax) kmax = d->factors[i].K;
    }
    if (kmax > GLRT_MAX_TERMS)
        return prt_fail(err, "GL runtime: %d BRDF terms, more than the %d the shaders carry (use the CPU backend)", kmax,
                        GLRT_MAX_TERMS), NULL;
    double t0 = prt_now();
    glrt *rt = prt_calloc(1, sizeof *rt, err);
    if (!rt) return NULL;
    rt->d = d;
    rt->local_bounce = dd.local_bounce;
    rt->vsgl_glossy = true;
    rt->tr = tr;
    rt->cpu = !tr->ops->linear->glsl;
    float **staging = rt->cpu ? &rt->cpu_g : tr->open_sky ? &rt->open4 : NULL;   /* g, or the open sky's addend */
    if (staging && !(*staging = prt_calloc(4 * (size_t)t->nvecs + 4, sizeof(float), err))) { free(rt); return NULL; }
    rt->nverts = m->nverts;
    rt->nvecs = t->nvecs;
    rt->ncoefs = t->coef_first[t->nvecs];
    rt->qbits = t->qbits;
    rt->nmat = nmat;
    rt->kmax_all = kmax;
    rt->view_mode = dd.view;
    for (int i = 0; i < d->ntransfers && !rt->tv; i++)
        if (d->transfers[i].ops->kind == TRANSFER_VIEW && d->transfers[i].ops->view->glsl) rt->tv = &d->transfers[i];
    if (dd.ctx) rt->ctx = dd.ctx;
    else {
        rt->ctx = glctx_create(GLCTX_AUTO, NULL, err);
        if (!rt->ctx) { free(rt->cpu_g); free(rt->open4); free(rt); return NULL; }
        rt->own_ctx = true;
    }
    rt->gl = &rt->ctx->gl;
    const gl_api *gl = rt->gl;
    rt->timing.context = glctx_kind_name(rt->ctx->kind);
    rt->timing.renderer = rt->ctx->renderer;
    rt->timing.version = rt->ctx->version;
    if (check_limits(rt, t, err)) {
        glrt_destroy(rt);
        return NULL;
    }
    if (gldraw_init(&rt->draw, gl, err) || gldraw_set_mesh(&rt->draw, m, err) || (!rt->cpu && upload_transport(rt, t, err)) ||
        make_light_buffers(rt, err) || upload_view_maps(rt, err) || upload_mesh(rt, err) || upload_textures(rt, err) ||
        upload_tv(rt, err) || build_programs(rt, err)) {
        glrt_destroy(rt);
        return NULL;
    }
    gl->GenQueries(1, &rt->query);
    if (glrt_set_light_method(rt, rt->cpu ? GLRT_LIGHT_CPU : dd.light, err)) {
        glrt_destroy(rt);
        return NULL;
    }
    /* Timing AUTO ran the kernels on the zero light, so g is zero (or untouched zeros): a draw before
     * the first light change shows black, not garbage. */
    gl->Finish();
    if (glctx_check(gl, "creating the runtime", err)) {
        glrt_destroy(rt);
        return NULL;
    }
    rt->timing.upload_ms = 1e3 * (prt_now() - t0);
    return rt;
}

/* Frees every GL object and an owned context; NULL is fine. */
void glrt_destroy(glrt *rt) {
    if (!rt) return;
    if (rt->gl && current(rt, NULL) == 0) {
        const gl_api *gl = rt->gl;
        GLuint bufs[] = { rt->buf_first, rt->buf_words, rt->buf_blocks, rt->buf_scale, rt->buf_L, rt->buf_g, rt->buf_view, rt->buf_open,
                          rt->vbo_pos, rt->vbo_nrm, rt->vbo_vec, rt->vbo_mat, rt->vbo_add, rt->ebo, rt->vbo_pix, rt->buf_tv,
                          rt->buf_tvu, rt->vbo_tva, rt->vbo_uv, rt->buf_alb };
        GLuint texs[] = { rt->tex_first, rt->tex_words, rt->tex_blocks, rt->tex_scale, rt->tex_L, rt->tex_g, rt->tex_view, rt->tex_open,
                          rt->frag_tex, rt->tex_tv, rt->tex_tvu, rt->tex_alb };
        gl->DeleteTextures(GLRT_PF_LEVELS, rt->tex_pf);
        for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
            if (bufs[i]) gl->DeleteBuffers(1, &bufs[i]);
        for (size_t i = 0; i < sizeof texs / sizeof texs[0]; i++)
            if (texs[i]) gl->DeleteTextures(1, &texs[i]);
        for (int i = 0; i < GLRT_LIGHT_COUNT; i++)
            if (rt->prog_light[i]) gl->DeleteProgram(rt->prog_light[i]);
        for (int i = 0; i < 4; i++)
            if (rt->prog_view[i]) gl->DeleteProgram(rt->prog_view[i]);
        if (rt->frag_fbo) gl->DeleteFramebuffers(1, &rt->frag_fbo);
        if (rt->vao) gl->DeleteVertexArrays(1, &rt->vao);
        if (rt->query) gl->DeleteQueries(1, &rt->query);
        gllights_destroy(rt->local);
        glvsgl_destroy(rt->vsgl);
        gldraw_free(&rt->draw);
    }
    if (rt->own_ctx) glctx_destroy(rt->ctx);
    free(rt->cpu_g);
    free(rt->open4);
    free(rt);
}

/* 1 when a corner of the triangle has a glossy material (the glossy lobe's VSGL term), else 0. */
static int spec_class(const glrt *rt, const uint32_t *t, const void *ctx) {
    (void)ctx;
    const prt_mesh *m = &rt->d->scene.mesh;
    bool g = false;
    for (int k = 0; k < 3; k++) g |= glvsgl_glossy(rt->vsgl, m->mat ? (int)m->mat[t[k]] : 0);
    return g;
}

/* Without a tv: the element buffer ordered by whether a triangle has a corner of a glossy material
 * (spec_tris), so that only those pixels run the glossy lobe's VSGL term: llvmpipe runs a branch's
 * body under a mask for every pixel, and the floor of bunny + floor paid for the bunny's term. A
 * stable partition: the draw order within each class stays the mesh's. -1 on OOM. */
static int order_spec_tris(glrt *rt, prt_error *err) {
    return partition_tris(rt, 2, spec_class, NULL, rt->spec_tris, NULL, err);
}

/* The view programs again when what they must hold changed: the local lights' code at the first local
 * light (LMAX), the glossy lobe's VSGL term when the VSGLs are on and a material is glossy (VSGL_SPEC;
 * compiled in only then, as the local lights' code: see build_view_program). -1 with err. */
static int rebuild_view_programs(glrt *rt, int lmax, prt_error *err) {
    bool spec = lmax > 0 && rt->local_bounce && rt->vsgl && glvsgl_fit_rows(rt->vsgl) > 0;
    if (lmax == rt->lmax && spec == rt->vsgl_spec) return 0;
    if (lmax > 0 && !gllights_supported(rt->gl))
        return prt_fail(err, "gl runtime: this GL context has too few texture units for local lights");
    for (int i = 0; i < 4; i++) {
        if (rt->prog_view[i]) rt->gl->DeleteProgram(rt->prog_view[i]);
        rt->prog_view[i] = 0;
    }
    rt->lmax = lmax;
    rt->vsgl_spec = spec;
    if (spec && !rt->tv && rt->spec_tris[0] + rt->spec_tris[1] == 0 && order_spec_tris(rt, err)) return -1;
    return build_view_programs(rt, err);
}

/* Local-light move: the shadow cubes rendered (gllights_set), the VSGLs when on, finished and timed; -1 with err. */
int glrt_set_local_lights(glrt *rt, const prt_lights *ls, prt_error *err) {
    if (current(rt, err)) return -1;
    double t0 = prt_now();
    /* the VSGLs' lobe tables before the programs that read them */
    if (rt->local_bounce && ls->count > 0 && !rt->vsgl) {
        if (!(rt->vsgl = glvsgl_create(&rt->d->scene, err))) return -1;
        glvsgl_set_glossy(rt->vsgl, rt->vsgl_glossy);
    }
    if (rebuild_view_programs(rt, rt->lmax > 0 || ls->count > 0 ? GLLIGHTS_MAX : 0, err)) return -1;
    if (!rt->local && !(rt->local = gllights_create(rt->gl, &rt->d->scene, err))) return -1;
    if (gllights_set(rt->local, ls, rt->vao, rt->d->scene.mesh.ntris, err)) return -1;
    rt->timing.bounce_ms = 0;
    if (rt->local_bounce && rt->vsgl) {   /* an RSM on the CPU (glvsgl.h) */
        if (glvsgl_set(rt->vsgl, ls, err)) return -1;
        rt->timing.bounce_ms = glvsgl_ms(rt->vsgl);
    }
    rt->lights = *ls;
    rt->gl->Finish();
    rt->timing.local_ms = 1e3 * (prt_now() - t0);
    return 0;
}

/* Turns the VSGLs and their glossy-lobe term on or off (the viewer's keys); a light move follows
 * (the VSGLs of the lights held). -1 with err. */
int glrt_set_local_effects(glrt *rt, bool bounce, bool glossy, prt_error *err) {
    if (current(rt, err)) return -1;
    bool was = rt->local_bounce;
    rt->local_bounce = bounce;
    rt->vsgl_glossy = glossy;
    if (rt->vsgl) glvsgl_set_glossy(rt->vsgl, glossy);
    if (bounce == was || rt->lights.count == 0) return rebuild_view_programs(rt, rt->lmax, err);
    return glrt_set_local_lights(rt, &rt->lights, err);
}

/* The CPU method's light change: g = T x L of the set in use by the transfer's own CPU kernel
 * (transfer_light: the unscaled L, scaled inside when huge, so no unshift here), padded to the g
 * buffer's vec4 per vector and uploaded; finished and timed (both steps). -1 with err. */
static int cpu_set_light(glrt *rt, const float (*L)[4], const float *open, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (rt->tr->open_sky && !open) return prt_fail(err, "GL runtime: the %s transfer's open sky needs the light's cube", rt->tr->ops->name);
    double t0 = prt_now();
    rt->unshift = 1.f;
    float *g = rt->cpu_g;
    transfer_light(rt->tr, rt->direct ? &rt->tr->direct : &rt->tr->transport, L, g, 0);
    if (open)
        for (size_t k = 0; k < 3 * (size_t)rt->nvecs; k++) g[k] += open[k];
    /* [3 * nvecs] -> [4 * nvecs] in place, from the last vector down: vector i's writes (4i..4i+3) reach no
     * value still to be read (those of vectors < i lie below 3i, and its own are read before written) */
    for (int i = rt->nvecs - 1; i >= 0; i--) {
        g[4 * (size_t)i + 3] = 0.f;
        for (int c = 2; c >= 0; c--) g[4 * (size_t)i + c] = g[3 * (size_t)i + c];
    }
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->buf_g);
    gl->BufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)(sizeof(float) * 4 * (size_t)rt->nvecs), g);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    gl->Finish();
    rt->timing.light_ms = 1e3 * (prt_now() - t0);
    rt->timing.light_gpu_ms = 0;
    rt->light_set = true;
    return glctx_check(gl, "light change (uploading g)", err);
}

/* Light change: uploads L (scaled when huge: transfer_light_scaled_copy) and runs the kernel, finished and timed;
 * the CPU method: cpu_set_light. -1 with err. */
int glrt_set_light(glrt *rt, const float (*L)[4], prt_error *err) { return glrt_set_light_open(rt, L, NULL, err); }

int glrt_set_light_open(glrt *rt, const float (*L)[4], const float *open, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (current(rt, err)) return -1;
    if (rt->cpu) return cpu_set_light(rt, L, open, err);
    if (rt->tr->open_sky && !open) return prt_fail(err, "GL runtime: the %s transfer's open sky needs the light's cube", rt->tr->ops->name);
    double t0 = prt_now();
    if (rt->tr->open_sky) {   /* the open sky's addend, laid out as g */
        float *o = rt->open4;
        for (size_t i = 0; i < (size_t)rt->nvecs; i++)
            for (int c = 0; c < 4; c++) o[4 * i + c] = c < 3 ? open[3 * i + c] : 0.f;
        gl->BindBuffer(GL_ARRAY_BUFFER, rt->buf_open);
        gl->BufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)(sizeof(float) * 4 * (size_t)rt->nvecs), o);
        gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    }
    int shift;
    float (*Ls)[4] = transfer_light_scaled_copy(L, &shift);   /* a 1e37 sun: scaled by 2^-shift, undone in the kernels */
    rt->unshift = ldexpf(1.f, shift);
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->buf_L);
    gl->BufferSubData(GL_ARRAY_BUFFER, 0, sizeof(float) * 4 * CUBE_TEXELS, Ls ? (const float (*)[4])Ls : L);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    free(Ls);
    gl->BeginQuery(GL_TIME_ELAPSED, rt->query);
    run_light(rt, rt->method);
    gl->EndQuery(GL_TIME_ELAPSED);
    gl->Finish();
    rt->timing.light_ms = 1e3 * (prt_now() - t0);
    GLuint64 ns = 0;
    gl->GetQueryObjectui64v(rt->query, GL_QUERY_RESULT, &ns);
    rt->timing.light_gpu_ms = 1e-6 * (double)ns;
    rt->light_set = true;
    return glctx_check(gl, "light change", err);
}

/* Uploads the probe shown behind the scene; -1 with err. */
int glrt_set_background(glrt *rt, const prt_probe *p, const float R[9], prt_error *err) {
    if (current(rt, err)) return -1;
    rt->bg_rotated = R != NULL;
    if (R) memcpy(rt->bg_R, R, sizeof rt->bg_R);
    return gldraw_set_probe(&rt->draw, p, err);
}

/* Sets only the background rotation. */
void glrt_set_background_rotation(glrt *rt, const float R[9]) {
    rt->bg_rotated = R != NULL;
    if (R) memcpy(rt->bg_R, R, sizeof rt->bg_R);
}

/* The per-pixel transfer's textures and uniforms on program p (in use); unit 1 stays active. */
static void bind_tv(glrt *rt, GLuint p) {
    const gl_api *gl = rt->gl;
    gl->Uniform1i(gl->GetUniformLocation(p, "u_pf_n"), rt->pf_n);
    gl->Uniform4fv(gl->GetUniformLocation(p, "u_pf_kappa"), 4, rt->pf_kappa);
    gl->UniformMatrix3fv(gl->GetUniformLocation(p, "u_pf_Rt"), 1, GL_TRUE, rt->pf_Rt);
    gl->Uniform1i(gl->GetUniformLocation(p, "u_pf_nl"), rt->pf_nl);
    gl->Uniform4fv(gl->GetUniformLocation(p, "u_pf_light"), 4 * PREFILTER_MAX_LIGHTS, rt->pf_light[0]);
    gl->ActiveTexture(GL_TEXTURE0 + GLRT_UNIT_TV);
    gl->BindTexture(GL_TEXTURE_BUFFER, rt->tex_tv);
    for (int l = 0; l < GLRT_PF_LEVELS; l++) {
        gl->ActiveTexture(GL_TEXTURE0 + GLRT_UNIT_PF + l);
        gl->BindTexture(GL_TEXTURE_CUBE_MAP, rt->tex_pf[l]);
    }
    gl->ActiveTexture(GL_TEXTURE0 + GLRT_UNIT_TVU);
    gl->BindTexture(GL_TEXTURE_BUFFER, rt->tex_tvu);
    gl->ActiveTexture(GL_TEXTURE1);
}

/* Draws triangles [first, first + n) of the element buffer with view program p (its uniforms and
 * textures set here); the vertex array is bound. */
static void draw_tris(glrt *rt, GLuint p, const float mvp[16], const prt_camera *cam, int kmax, int first, int n) {
    const gl_api *gl = rt->gl;
    if (n <= 0) return;
    gl->UseProgram(p);
    gl->UniformMatrix4fv(gl->GetUniformLocation(p, "u_mvp"), 1, GL_FALSE, mvp);
    gl->Uniform3fv(gl->GetUniformLocation(p, "u_eye"), 1, cam->eye);
    gl->Uniform1i(gl->GetUniformLocation(p, "u_kmax"), kmax > 0 ? kmax : 0);
    gl->Uniform1i(gl->GetUniformLocation(p, "u_tri0"), first);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_BUFFER, rt->tex_view);
    gl->ActiveTexture(GL_TEXTURE1);
    gl->BindTexture(GL_TEXTURE_BUFFER, rt->tex_g);
    if ((p == rt->prog_view[0] || p == rt->prog_view[3]) && rt->tv) bind_tv(rt, p);
    if (rt->tex_alb) {
        gl->ActiveTexture(GL_TEXTURE0 + GLRT_UNIT_ALB);
        gl->BindTexture(GL_TEXTURE_BUFFER, rt->tex_alb);
        gl->ActiveTexture(GL_TEXTURE1);
    }
    if (rt->local) {   /* the local lights' uniforms and shadow cubes (gllights_bind) */
        gllights_bind(rt->local, p);
        if (rt->vsgl && rt->local_bounce) glvsgl_bind(rt->vsgl, rt->gl, p);
        else gl->Uniform1i(gl->GetUniformLocation(p, "u_nvsgl"), 0);
        gl->ActiveTexture(GL_TEXTURE1);
    }
    gl->DrawElements(GL_TRIANGLES, n * 3, GL_UNSIGNED_INT, (const void *)(3 * sizeof(uint32_t) * (size_t)first));
}

/* Whether a multisampled frame shades every sample: multisampling alone shades once per pixel, so an
 * edge inside a triangle stays stair-stepped, and per pixel the local lights' shadow maps draw such
 * edges (the view maps' and the vertex radiance vary smoothly across a triangle). GL 4.0's sample
 * shading; about as costly as rendering at samples times the pixels. */
static bool per_sample(const glrt *rt) {
    return rt->draw.samples > 1 && rt->view_mode == GLRT_VIEW_PIXEL && rt->lights.count > 0 && rt->ctx->major >= 4 &&
           rt->gl->MinSampleShading;
}

/* View change into the float target, finished and timed; -1 with err. */
int glrt_draw(glrt *rt, const prt_camera *cam, int w, int h, int kmax, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (current(rt, err)) return -1;
    double t0 = prt_now();
    if (gldraw_target(&rt->draw, w, h, err)) return -1;
    gldraw_background(&rt->draw, cam, w, h, rt->bg_rotated ? rt->bg_R : NULL);
    float mvp[16];
    gldraw_mvp(&rt->draw, cam, w, h, mvp);
    gl->BeginQuery(GL_TIME_ELAPSED, rt->query);
    bool ssx = per_sample(rt);
    if (ssx) { gl->Enable(GL_SAMPLE_SHADING); gl->MinSampleShading(1.0f); }
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->BindVertexArray(rt->vao);
    if (rt->view_mode != GLRT_VIEW_VERTEX && !rt->tv && rt->vsgl_spec) {   /* the glossy VSGL term on its triangles only */
        draw_tris(rt, rt->prog_view[0], mvp, cam, kmax, 0, rt->spec_tris[0]);
        draw_tris(rt, rt->prog_view[2], mvp, cam, kmax, rt->spec_tris[0], rt->spec_tris[1]);
    } else if (rt->view_mode == GLRT_VIEW_VERTEX || !rt->tv)
        draw_tris(rt, rt->prog_view[rt->view_mode == GLRT_VIEW_VERTEX], mvp, cam, kmax, 0, rt->d->scene.mesh.ntris);
    else   /* the triangles in tv_tris's order, each class by the program that holds what it needs */
        for (int c = 0, first = 0; c < 3; first += rt->tv_tris[c++])
            draw_tris(rt, rt->prog_view[c == 0 ? 2 : c == 1 ? 3 : 0], mvp, cam, kmax, first, rt->tv_tris[c]);
    gl->BindVertexArray(0);
    if (ssx) gl->Disable(GL_SAMPLE_SHADING);
    gl->Disable(GL_DEPTH_TEST);
    gl->BindTexture(GL_TEXTURE_BUFFER, 0);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_BUFFER, 0);
    gl->UseProgram(0);
    gl->EndQuery(GL_TIME_ELAPSED);
    gl->Finish();
    rt->timing.view_ms = 1e3 * (prt_now() - t0);
    GLuint64 ns = 0;
    gl->GetQueryObjectui64v(rt->query, GL_QUERY_RESULT, &ns);
    rt->timing.view_gpu_ms = 1e-6 * (double)ns;
    return glctx_check(gl, "view change", err);
}

/* The ladder's levels as seamless cube maps (faces in cubemap.h's order, which is GL's) and its
 * kappas and rotation as uniforms; see glrt.h. -1 with err. */
int glrt_set_prefilter(glrt *rt, const prefilter_env *env, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (current(rt, err)) return -1;
    rt->pf_n = 0;
    if (!rt->tv || !env || prefilter_level_count(env) > GLRT_PF_LEVELS) return 0;
    int n = prefilter_level_count(env);
    if (!rt->tex_pf[0]) gl->GenTextures(GLRT_PF_LEVELS, rt->tex_pf);
    gl->Enable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    gl->PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    memset(rt->pf_kappa, 0, sizeof rt->pf_kappa);
    for (int l = 0; l < n; l++) {
        int res;
        prefilter_level_info(env, l, &rt->pf_kappa[l], &res);
        const float *tx = prefilter_level_texels(env, l);
        gl->BindTexture(GL_TEXTURE_CUBE_MAP, rt->tex_pf[l]);
        for (int f = 0; f < 6; f++)
            gl->TexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, GL_RGB32F, res, res, 0, GL_RGB, GL_FLOAT,
                           tx + (size_t)3 * f * res * res);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_MAX_LEVEL, 0);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        gl->TexParameteri(GL_TEXTURE_CUBE_MAP, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    gl->BindTexture(GL_TEXTURE_CUBE_MAP, 0);
    prefilter_rotation_t(env, rt->pf_Rt);
    memset(rt->pf_light, 0, sizeof rt->pf_light);
    rt->pf_nl = prefilter_light_count(env);
    for (int i = 0; i < rt->pf_nl; i++) {
        float dir[3][3], kappa[3];
        prefilter_light(env, i, dir, kappa, rt->pf_light[4 * i + 3]);
        for (int c = 0; c < 3; c++) memcpy(rt->pf_light[4 * i + c], dir[c], sizeof dir[c]), rt->pf_light[4 * i + c][3] = kappa[c];
    }
    rt->pf_n = n;
    return glctx_check(gl, "uploading the prefiltered probe", err);
}

/* See glrt.h: the per-pixel program shades tr's vertices in the current view mode. */
bool glrt_shades_per_pixel(const glrt *rt, const prt_transfer *tr) {
    return rt->tv && rt->tv == tr && rt->pf_n > 0 && rt->view_mode == GLRT_VIEW_PIXEL;
}

/* The rotation of the uploaded ladder from env (the same probe as the last glrt_set_prefilter). */
void glrt_set_prefilter_rotation(glrt *rt, const prefilter_env *env) {
    if (rt->pf_n && env) prefilter_rotation_t(env, rt->pf_Rt);
}

/* Uploads the per-vertex radiance added to every vertex (rgb[3 * nverts], NULL: zeros); -1 with err. */
int glrt_set_vertex_add(glrt *rt, const float *rgb, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (current(rt, err)) return -1;
    size_t bytes = sizeof(float) * 3 * (size_t)rt->nverts;
    float *zero = rgb ? NULL : prt_calloc(3 * (size_t)rt->nverts + 3, sizeof(float), err);
    if (!rgb && !zero) return -1;
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->vbo_add);
    gl->BufferSubData(GL_ARRAY_BUFFER, 0, (GLsizeiptr)bytes, rgb ? rgb : zero);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    free(zero);
    return glctx_check(gl, "uploading the added vertex radiance", err);
}

/* CPU-computed colours drawn into the float target, finished and timed; -1 with err. */
int glrt_draw_vertex_colors(glrt *rt, const prt_camera *cam, int w, int h, const float *rgb, prt_error *err) {
    if (current(rt, err)) return -1;
    double t0 = prt_now();
    if (gldraw_target(&rt->draw, w, h, err)) return -1;
    gldraw_background(&rt->draw, cam, w, h, rt->bg_rotated ? rt->bg_R : NULL);
    int rc = gldraw_vertex_colors(&rt->draw, cam, w, h, rgb, err);
    rt->gl->Finish();
    rt->timing.view_ms = 1e3 * (prt_now() - t0);
    rt->timing.view_gpu_ms = 0;
    return rc;
}

/* The sample count of the next draws' target (the context current: the next draw makes it so). */
void glrt_set_samples(glrt *rt, int n) {
    if (current(rt, NULL) == 0) gldraw_set_samples(&rt->draw, n);
}

/* The float target as a new image (caller frees); -1 with err. */
int glrt_read(glrt *rt, prt_image *out, prt_error *err) {
    if (current(rt, err)) return -1;
    return gldraw_read(&rt->draw, out, err);
}

/* glrt_draw then glrt_read; -1 with err. */
int glrt_render(glrt *rt, const prt_camera *cam, int w, int h, int kmax, prt_image *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (glrt_draw(rt, cam, w, h, kmax, err)) return -1;
    return glrt_read(rt, out, err);
}

/* Tone-mapped blit of the target to the current window. */
void glrt_present(glrt *rt, int win_w, int win_h, float exposure_stops) {
    if (current(rt, NULL)) return;
    gldraw_present(&rt->draw, win_w, win_h, exposure_stops);
}

/* Copies the K-vectors into g[3*nvecs]; -1 with err. */
int glrt_read_gvec(glrt *rt, float *g, prt_error *err) {
    const gl_api *gl = rt->gl;
    if (current(rt, err)) return -1;
    float *tmp = prt_calloc((size_t)4 * rt->nvecs + 4, sizeof(float), err);
    if (!tmp) return -1;
    gl->BindBuffer(GL_ARRAY_BUFFER, rt->buf_g);
    gl->GetBufferSubData(GL_ARRAY_BUFFER, 0, sizeof(float) * 4 * (size_t)rt->nvecs, tmp);
    gl->BindBuffer(GL_ARRAY_BUFFER, 0);
    for (int i = 0; i < rt->nvecs; i++)
        for (int c = 0; c < 3; c++) g[3 * i + c] = tmp[4 * i + c];
    free(tmp);
    return glctx_check(gl, "reading the K-vectors back", err);
}

void glrt_set_view_mode(glrt *rt, glrt_view_mode mode) { rt->view_mode = mode; }

/* Uploads the direct-only set (or direct + bounces) in place of the current one; see glrt.h. */
int glrt_use_direct(glrt *rt, bool direct, prt_error *err) {
    if (direct == rt->direct) return 0;
    if (direct && rt->tr->direct.nvecs == 0) return prt_fail(err, "the file keeps no separate direct transport");
    const prt_transport *t = direct ? &rt->tr->direct : &rt->tr->transport;
    if (t->nvecs != rt->nvecs || t->nverts != rt->nverts)
        return prt_fail(err, "direct transport (%d vectors) does not match the full one (%d)", t->nvecs, rt->nvecs);
    if (current(rt, err) || check_limits(rt, t, err)) return -1;
    if (rt->cpu) {   /* nothing uploaded: the next light change lights that set */
        rt->direct = direct;
        rt->light_set = false;
        return 0;
    }
    int old_qbits = rt->qbits;
    if (upload_transport(rt, t, err)) return -1;
    if (rt->qbits != old_qbits && build_light_programs(rt, err)) return -1;
    rt->direct = direct;
    rt->light_set = false;
    return 0;
}

void glrt_get_timing(const glrt *rt, glrt_timing *out) {
    *out = rt->timing;
    out->gpu_bytes = rt->transport_bytes + rt->other_bytes + sizeof(float) * 4 * ((rt->cpu ? 0 : CUBE_TEXELS) + (size_t)rt->frag_w * rt->frag_h);
}

int glrt_render_image(const prt_data *d, const float (*L)[4], const render_desc *rd, int kmax, prt_image *out,
                      prt_error *err) {
    memset(out, 0, sizeof *out);
    int w = rd->width, h = rd->height;
    if (w == 0 && h == 0) { w = 800; h = 600; }
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384)
        return prt_fail(err, "render: image size %dx%d out of range (1..16384)", w, h);
    /* One light change only: the fragment kernel runs on every GL 3.3+ context, and timing all
     * kernels first (AUTO) would cost more than it saves. */
    glrt_desc desc = { .light = GLRT_LIGHT_FRAGMENT };
    glrt *rt = glrt_create(d, &desc, err);
    if (!rt) return -1;
    int rc = -1;
    if ((!rd->direct_only || !rt->tr->direct.nvecs || glrt_use_direct(rt, true, err) == 0) && glrt_set_light(rt, L, err) == 0 &&
        glrt_set_background(rt, rd->background, rd->background_rotation, err) == 0) {
        glrt_set_samples(rt, rd->samples);
        rc = glrt_render(rt, &rd->camera, w, h, kmax, out, err);
    }
    glrt_destroy(rt);
    return rc;
}
