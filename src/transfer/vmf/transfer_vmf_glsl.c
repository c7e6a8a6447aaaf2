/* transfer_vmf_glsl.c - the vmf transfer's per-pixel view shading in GLSL (transfer.h:
 * transfer_glsl_view, its transfer_view.glsl; compiled by gpu/glrt.c into its per-pixel view program).
 *
 * What runs per pixel: vmft_radiance_point (vmf.h, "Per pixel"), the per-pixel form of the
 * shading rule, line for line. The pixel's triangle (gl_PrimitiveID), its barycentrics (solved
 * from the interpolated position), its normal (the corners' normals by those barycentrics) and its
 * own view w_o; w_o located once on the geodesic grid; then laurijssen-2011 Eq. 7 over the 3 views x
 * the triangle's fitted corners with weights b_k w_q: stored slices from the perfect hash
 * (section 6.2), absent ones as the BRDF's own lobe at their grid view, or, with nothing stored
 * around, the BRDF's own lobe at the exact view; each interpolated lobe looked up in the
 * prefiltered probe (pf_lookup). So a stored slice's occlusion edge and gathered reflections are
 * interpolated per pixel too, which the per-vertex model smears over the vertex spacing (the chrome
 * spheres of data/two-chrome-spheres.json: Phong n = 300 and 1000 highlights are a few pixels wide).
 *
 * The grid lookup needs no descent: a small cube map (CUBE_RES_START^2 cells a face, in `start`)
 * gives the finest grid triangle holding each cell's centre; the shader tests w_o against that
 * triangle's three edge planes (geogrid.c's own, the same float numbers) and walks to the
 * neighbour across the most violated edge until all three hold (one or two steps: a cell is
 * ~3.6 degrees wide at level 2, a triangle ~17), then takes geogrid_locate's weights.
 *
 * The data (vmft_glsl_data; glrt uploads `f` as the RGBA32F buffer texture t_tv and `u` as the R32UI
 * buffer texture t_tvu):
 *   u[0..15] header: 0 tris, 1 vertex words, 2 slots, 3 lobes (word offsets in u); 4 passes,
 *            5 lobes; 6 views; 7 faces, 8 view directions, 9 vertex texels, 10 start cells (texel
 *            offsets in f); 11 start cells per face edge; 12 hash size; 13 VMFT_GLSL_MAGIC
 *   u tris   [3 ntris]        vertex ids
 *   u verts  [2 nverts]       O[v] (hash offset), flags: bit 0 fitted (v's material is the
 *                             transfer's), bit 1 its row stores a slice, bits 8-15 its material
 *   u slots  [2 hash.size]    owner (v + 1, 0 free), entry (vmf.h)
 *   u lobes  vmf.h's packed lobes, as the file keeps them
 *   f rows   [nmat TV_ROWS]   per material its lobe fit: row 0 (views, 0, 0, 0), rows 1 + 2k,
 *                             2 + 2k (mu.xyz, kappa), (alpha.rgb, 0) of fit view k (local frame,
 *                             wo = (sin theta_k, 0, cos theta_k), theta_k = k (pi/2) / views)
 *   f faces  [5 nfaces]       (v0, v1, v2, 0), (neighbour across edge 0, 1, 2, 0), the edge planes
 *                             v1 x v2, v2 x v0, v0 x v1 (geogrid.c's, float)
 *   f dirs   [nviews]         grid view directions
 *   f verts  [2 nverts]       (position, 0), (normal, 0)
 *   f start  [6 R R]          (face, 0, 0, 0): cube face 2 axis + (component < 0), cell (i, j) of
 *                             the next two components over |major| in [-1, 1], R cells each */
#include "transfer.h"
#include "prtfile.h"
#include "vmf.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TV_ROWS (2 * LOBEFIT_MAX_VIEWS + 1)

static const char k_vmf_view[] =
    "uint tu(int i) { return texelFetch(t_tvu, i).r; }\n"
    "vec4 tf(int i) { return texelFetch(t_tv, i); }\n"
    "float tv_lum(vec3 a) { return dot(a, vec3(0.2126, 0.7152, 0.0722)); }\n"
    /* half_value (transfer_vmf.c): exact for every finite half */
    "float tv_half(uint h) {\n"
    "    uint e = (h >> 10) & 31u, m = h & 1023u;\n"
    "    float v = e == 0u ? float(m) * 5.9604644775390625e-08 : exp2(float(int(e) - 15)) * (1.0 + float(m) / 1024.0);\n"
    "    return (h & 0x8000u) != 0u ? -v : v;\n"
    "}\n"
    /* vmft_unpack */
    "void tv_unpack(int at, out vec3 mu, out float kappa, out vec3 alpha) {\n"
    "    uint w0 = tu(at), w1 = tu(at + 1), w2 = tu(at + 2);\n"
    "    float u = float(int(w0 << 16) >> 16) / 32767.0, v = float(int(w0) >> 16) / 32767.0;\n"
    "    float z = 1.0 - abs(u) - abs(v), x = u, y = v;\n"
    "    if (z < 0.0) { x = (1.0 - abs(v)) * (u >= 0.0 ? 1.0 : -1.0); y = (1.0 - abs(u)) * (v >= 0.0 ? 1.0 : -1.0); }\n"
    "    mu = vec3(x, y, z) / length(vec3(x, y, z));\n"
    "    kappa = tv_half(w1 & 0xffffu);\n"
    "    alpha = vec3(tv_half(w1 >> 16), tv_half(w2 & 0xffffu), tv_half(w2 >> 16));\n"
    "}\n"
    /* vmft_brdf_lobe: lobefit_lookup at local view w = (sin, 0, cos), azimuth 0, then to the world */
    "void tv_brdf(int m, vec3 n, vec3 wo, out vec3 mw, out float kappa, out vec3 alpha) {\n"
    "    int base = m * TV_ROWS, views = int(tf(base).x);\n"
    "    mw = vec3(0.0, 0.0, 1.0); kappa = 0.0; alpha = vec3(0.0);\n"
    "    if (views < 1) return;\n"
    "    float c = dot(n, wo);\n"
    "    vec3 t = wo - c * n;\n"
    "    float r = length(t);\n"
    "    if (r > 1e-12) t /= r;\n"
    "    else { vec3 s2; frame(n, t, s2); }\n"   /* at the pole: brdf_frame's s */
    "    vec3 w = vec3(r, 0.0, c);\n"
    "    if (c < 0.02) w = vec3(0.99979998, 0.0, 0.02);\n"   /* VMFT_MIN_COS: the grazing view */
    "    float x = atan(w.x, w.z) / 1.5707963267948966 * float(views);\n"
    "    int i = int(floor(x));\n"
    "    float f = x - float(i);\n"
    "    if (i < 0) { i = 0; f = 0.0; }\n"
    "    if (i >= views - 1) { i = views - 1; f = 0.0; }\n"
    "    int j = i + 1 < views ? i + 1 : i;\n"
    "    vec4 la = tf(base + 1 + 2 * i), lb = tf(base + 1 + 2 * j);\n"
    "    alpha = mix(tf(base + 2 + 2 * i).rgb, tf(base + 2 + 2 * j).rgb, f);\n"
    "    vec3 mu = mix(la.xyz, lb.xyz, f);\n"
    "    float l = length(mu);\n"
    "    mu = l > 0.0 ? mu / l : vec3(0.0, 0.0, 1.0);\n"
    "    mw = mu.x * t + mu.y * cross(n, t) + mu.z * n;\n"
    "    kappa = mix(la.w, lb.w, f);\n"
    "}\n"
    /* geogrid_locate through the start cube and the walk (file comment) */
    "void tv_locate(vec3 w, out ivec3 g, out vec3 gw) {\n"
    "    int R = int(tu(11)), bf = int(tu(7));\n"
    "    vec3 a = abs(w);\n"
    "    int ax = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);\n"
    "    float s = w[ax];\n"
    "    float p = w[(ax + 1) % 3] / abs(s), q = w[(ax + 2) % 3] / abs(s);\n"
    "    int ci = clamp(int(floor((p + 1.0) * 0.5 * float(R))), 0, R - 1), cj = clamp(int(floor((q + 1.0) * 0.5 * float(R))), 0, R - 1);\n"
    "    int f = int(tf(int(tu(10)) + ((2 * ax + (s < 0.0 ? 1 : 0)) * R + ci) * R + cj).x);\n"
    "    vec3 d = vec3(1.0, 0.0, 0.0);\n"
    "    for (int it = 0; it < 8; it++) {\n"
    "        int at = bf + 5 * f;\n"
    "        d = vec3(dot(tf(at + 2).xyz, w), dot(tf(at + 3).xyz, w), dot(tf(at + 4).xyz, w));\n"
    "        if ((d.x >= 0.0 && d.y >= 0.0 && d.z >= 0.0) || it == 7) break;\n"
    "        int e = d.x <= d.y && d.x <= d.z ? 0 : (d.y <= d.z ? 1 : 2);\n"
    "        f = int(tf(at + 1)[e]);\n"
    "    }\n"
    "    g = ivec3(tf(bf + 5 * f).xyz);\n"
    "    d = max(d, vec3(0.0));\n"
    "    float sum = d.x + d.y + d.z;\n"
    "    gw = sum > 0.0 ? d / sum : vec3(1.0, 0.0, 0.0);\n"
    "}\n"
    /* Eq. 7's sums of one lobe (acc_add) */
    "void tv_acc(vec3 mu, float kappa, vec3 al, float w, inout vec3 A, inout vec3 M, inout float K, inout float S) {\n"
    "    float a = w * tv_lum(al);\n"
    "    A += w * al; M += a * mu; K += a * kappa; S += a;\n"
    "}\n"
    "vec3 tv_lookup(vec3 A, vec3 M, float K, float S) {\n"   /* acc_result + add_lobes */
    "    float l = length(M);\n"
    "    if (!(S > 0.0 && l > 0.0 && tv_lum(A) > 0.0)) return vec3(0.0);\n"
    "    return A * pf_lookup(M / l, K / S);\n"
    "}\n"
    "vec3 tv_radiance(int tri, vec3 pos, vec3 nrm, vec3 wo, float a) {\n"
    /* every corner fitted with nothing stored: exactly the BRDF's own lobe at the pixel's normal
     * (the corners' normals by the barycentrics, as GL interpolates them) and view, one lookup */
    "    if (a > 0.999) {\n"
    "        vec3 n = normalize(nrm), w = wo, mu, al;\n"
    "        float kap, cn = dot(n, wo);\n"
    "        if (cn < 0.02) { vec3 tx = wo - cn * n; float r = length(tx); if (r > 1e-12) w = tx / r * 0.99979998 + 0.02 * n; }\n"
    "        tv_brdf(int((tu(int(tu(1)) + 2 * int(tu(int(tu(0)) + 3 * tri)) + 1) >> 8) & 255u), n, w, mu, kap, al);\n"
    "        return tv_lookup(al, mu, kap, 1.0);\n"
    "    }\n"
    "#if TV_FULL\n"
    "    int bt = int(tu(0)), bv = int(tu(1)), bs = int(tu(2)), bl = int(tu(3)), P = int(tu(4)), I = int(tu(5));\n"
    "    int bx = int(tu(9)), bd = int(tu(8)), hsize = int(tu(12));\n"
    "    ivec3 c = ivec3(int(tu(bt + 3 * tri)), int(tu(bt + 3 * tri + 1)), int(tu(bt + 3 * tri + 2)));\n"
    "    vec3 p0 = tf(bx + 2 * c.x).xyz, e0 = tf(bx + 2 * c.y).xyz - p0, e1 = tf(bx + 2 * c.z).xyz - p0, e2 = pos - p0;\n"
    /* den is an edge length to the 4th: edges over ~1e9 or under ~1e-9 leave float, so the edges are
     * brought near 1 first (the barycentrics are ratios; docs/design/scale.md) */
    "    float es = max(max(max(abs(e0.x), abs(e0.y)), max(abs(e0.z), abs(e1.x))), max(abs(e1.y), abs(e1.z)));\n"
    "    if (es > 0.0) { e0 /= es; e1 /= es; e2 /= es; }\n"
    "    float d00 = dot(e0, e0), d01 = dot(e0, e1), d11 = dot(e1, e1), d20 = dot(e2, e0), d21 = dot(e2, e1);\n"
    "    float den = d00 * d11 - d01 * d01;\n"
    "    float bb = den != 0.0 ? (d11 * d20 - d01 * d21) / den : 0.0, bc = den != 0.0 ? (d00 * d21 - d01 * d20) / den : 0.0;\n"
    "    vec3 b = max(vec3(1.0 - bb - bc, bb, bc), vec3(0.0));\n"
    "    float bs0 = b.x + b.y + b.z;\n"
    "    if (!(bs0 > 0.0)) return vec3(0.0);\n"
    "    b /= bs0;\n"
    "    uvec3 fl = uvec3(tu(bv + 2 * c.x + 1), tu(bv + 2 * c.y + 1), tu(bv + 2 * c.z + 1));\n"
    "    vec3 nk[3] = vec3[3](tf(bx + 2 * c.x + 1).xyz, tf(bx + 2 * c.y + 1).xyz, tf(bx + 2 * c.z + 1).xyz);\n"
    "    vec3 n = b.x * nk[0] + b.y * nk[1] + b.z * nk[2];\n"
    "    if (!(length(n) > 0.0)) return vec3(0.0);\n"
    "    n = normalize(n);\n"
    "    vec3 w = wo;\n"   /* view_grazing */
    "    float cn = dot(n, wo);\n"
    "    if (cn < 0.02) { vec3 tx = wo - cn * n; float r = length(tx); if (r > 1e-12) w = tx / r * 0.99979998 + 0.02 * n; }\n"
    "    bool rows = false;\n"
    "    for (int k = 0; k < 3; k++) rows = rows || ((fl[k] & 3u) == 3u && b[k] > 0.0);\n"
    "    ivec3 g = ivec3(0);\n"
    "    vec3 gw = vec3(1.0, 0.0, 0.0);\n"
    "    if (rows) tv_locate(w, g, gw);\n"
    "    int ent[9], vk[9], vq[9], np = 0, m0 = -1;\n"
    "    float pw[9], ws = 0.0;\n"
    "    bool any = false;\n"
    "    for (int k = 0; k < 3; k++) {\n"
    "        if ((fl[k] & 1u) == 0u || !(b[k] > 0.0)) continue;\n"
    "        if (m0 < 0) m0 = int((fl[k] >> 8) & 255u);\n"
    "        for (int q = 0; q < 3; q++) {\n"
    "            float x = b[k] * gw[q];\n"
    "            int e = -1;\n"
    "            int slot = int(tu(bv + 2 * c[k])) + g[q];\n"
    "            if (rows && x > 0.0 && (fl[k] & 2u) != 0u && slot < hsize && tu(bs + 2 * slot) == uint(c[k] + 1))\n"
    "                e = int(tu(bs + 2 * slot + 1));\n"
    "            ent[np] = e; vk[np] = k; vq[np] = g[q]; pw[np] = x; ws += x;\n"
    "            any = any || e >= 0;\n"
    "            np++;\n"
    "        }\n"
    "    }\n"
    "    if (np == 0) return vec3(0.0);\n"
    "    vec3 mu, al, A, M;\n"
    "    float kap, K, S;\n"
    "    if (!any) {\n"   /* nothing stored around: exactly the BRDF's own lobe, scaled by the fitted share */
    "        tv_brdf(m0, n, w, mu, kap, al);\n"
    "        return tv_lookup(al * ws, mu, kap, 1.0);\n"
    "    }\n"
    /* the interpolated lobes first, then their lookups in a loop as long as this pixel needs:
     * llvmpipe runs a masked branch's body anyway, but leaves a loop that no lane continues */
    "    vec3 LA[16], LM[16];\n"
    "    float LK[16];\n"
    "    int nl = 0;\n"
    "    for (int p = 0; p < P; p++)\n"
    "        for (int i = 0; i < I; i++) {\n"
    "            A = vec3(0.0); M = vec3(0.0); K = 0.0; S = 0.0;\n"
    "            for (int k = 0; k < np; k++) {\n"
    "                if (ent[k] < 0 || !(pw[k] > 0.0)) continue;\n"
    "                int at = bl + ((ent[k] * P + p) * I + i) * 3;\n"
    "                if ((tu(at + 1) >> 16) == 0u && tu(at + 2) == 0u) continue;\n"   /* alpha +0: empty */
    "                tv_unpack(at, mu, kap, al);\n"
    "                tv_acc(mu, kap, al, pw[k], A, M, K, S);\n"
    "            }\n"
    "            for (int k = 0; p == 0 && i == 0 && k < np; k++) {\n"   /* absent pairs: the BRDF lobe at their view */
    "                if (ent[k] >= 0 || !(pw[k] > 0.0)) continue;\n"
    "                tv_brdf(int((fl[vk[k]] >> 8) & 255u), nk[vk[k]], tf(bd + vq[k]).xyz, mu, kap, al);\n"
    "                tv_acc(mu, kap, al, pw[k], A, M, K, S);\n"
    "            }\n"
    "            if (S > 0.0 && length(M) > 0.0 && tv_lum(A) > 0.0) { LA[nl] = A; LM[nl] = M / length(M); LK[nl] = K / S; nl++; }\n"
    "        }\n"
    "    vec3 rgb = vec3(0.0);\n"
    "    for (int j = 0; j < nl; j++) rgb += LA[j] * pf_lookup(LM[j], LK[j]);\n"
    "    return rgb;\n"
    "#else\n"
    "    return vec3(0.0);\n"   /* never reached: glrt draws a triangle with this program only when a > 0.999 */
    "#endif\n"
    "}\n";

/* Cells a face edge of the start cube: ~4 per finest triangle edge (level 2: 32). */
static int start_res(int level) { return 8 << level; }

/* The faces of g's finest level (file comment): corners, neighbours, edge planes; -1 with err on OOM. */
static int faces_rows(const geogrid *g, float (*f)[4], prt_error *err) {
    int nf = geogrid_face_count(g), nv = geogrid_count(g);
    int *star = prt_calloc((size_t)nv * 6, sizeof(int), err), *ns = prt_calloc((size_t)nv + 1, sizeof(int), err);
    if (!star || !ns) { free(star); free(ns); return prt_fail(err, "out of memory (vmf grid faces)"); }
    for (int i = 0; i < nf; i++)
        for (int e = 0; e < 3; e++) {
            int v = geogrid_face(g, i)[e];
            if (ns[v] < 6) star[6 * v + ns[v]++] = i;
        }
    for (int i = 0; i < nf; i++) {
        const int *t = geogrid_face(g, i);
        float (*r)[4] = f + 5 * (size_t)i;
        for (int e = 0; e < 3; e++) {
            int a = t[(e + 1) % 3], b = t[(e + 2) % 3], nb = i;
            for (int s = 0; s < ns[a]; s++) {   /* the other face holding edge (a, b) */
                const int *u = geogrid_face(g, star[6 * a + s]);
                if (star[6 * a + s] != i && (u[0] == b || u[1] == b || u[2] == b)) nb = star[6 * a + s];
            }
            const float *pa = geogrid_dir(g, a), *pb = geogrid_dir(g, b);   /* geogrid.c's gg_plane, unit false */
            r[0][e] = (float)t[e], r[1][e] = (float)nb;
            r[2 + e][0] = (float)((double)pa[1] * pb[2] - (double)pa[2] * pb[1]);
            r[2 + e][1] = (float)((double)pa[2] * pb[0] - (double)pa[0] * pb[2]);
            r[2 + e][2] = (float)((double)pa[0] * pb[1] - (double)pa[1] * pb[0]);
        }
    }
    free(star);
    free(ns);
    return 0;
}

/* The start cube (file comment): each cell's centre located on the grid, its face found among the
 * faces whose corner 0 is the located corner 0; -1 with err on OOM. */
static int start_rows(const geogrid *g, int R, float (*f)[4], prt_error *err) {
    int nf = geogrid_face_count(g), nv = geogrid_count(g);
    int *by0 = prt_calloc((size_t)nv * 6, sizeof(int), err), *n0 = prt_calloc((size_t)nv + 1, sizeof(int), err);
    if (!by0 || !n0) { free(by0); free(n0); return prt_fail(err, "out of memory (vmf grid start cube)"); }
    for (int i = 0; i < nf; i++) {
        int v = geogrid_face(g, i)[0];
        if (n0[v] < 6) by0[6 * v + n0[v]++] = i;
    }
    for (int cf = 0; cf < 6; cf++)
        for (int i = 0; i < R; i++)
            for (int j = 0; j < R; j++) {
                int ax = cf / 2, idx[3], face = 0;
                float d[3], w[3];
                d[ax] = cf % 2 ? -1.f : 1.f;
                d[(ax + 1) % 3] = (i + 0.5f) / R * 2 - 1, d[(ax + 2) % 3] = (j + 0.5f) / R * 2 - 1;
                geogrid_locate(g, d, idx, w);
                for (int s = 0; s < n0[idx[0]]; s++) {
                    const int *t = geogrid_face(g, by0[6 * idx[0] + s]);
                    if (t[1] == idx[1] && t[2] == idx[2]) face = by0[6 * idx[0] + s];
                }
                f[((size_t)cf * R + i) * R + j][0] = (float)face;
            }
    free(by0);
    free(n0);
    return 0;
}

/* The fit of material m as table rows (file comment); zeros when tr does not shade m. */
static void material_rows(const vmft_data *t, int m, float (*rows)[4]) {
    if (m < 0 || m >= PRT_MAX_MATERIALS || !((t->materials >> m) & 1)) return;
    const lobefit_table *f = &t->fit[m];
    rows[0][0] = (float)f->views;
    for (int k = 0; k < f->views; k++) {
        memcpy(rows[1 + 2 * k], f->lobe[k].mu, sizeof(float) * 3);
        rows[1 + 2 * k][3] = f->lobe[k].kappa;
        memcpy(rows[2 + 2 * k], f->alpha[k], sizeof(float) * 3);
    }
}

/* Whether row v stores a slice (vmft_index's bitmap). */
static bool row_stores(const vmft_data *t, int v) {
    const uint64_t *b = t->stored + (size_t)v * t->words;
    for (int k = 0; k < t->words; k++)
        if (b[k]) return true;
    return false;
}

/* The u words (file comment) after the header h. */
static void fill_words(const prt_mesh *m, const vmft_data *t, const uint32_t *h, uint32_t *u) {
    memcpy(u + h[0], m->tris, sizeof(uint32_t) * 3 * (size_t)m->ntris);
    for (int v = 0; v < m->nverts; v++) {
        bool fit = (t->materials >> m->mat[v]) & 1;
        u[h[1] + 2 * (size_t)v] = t->hash.offset[v];
        u[h[1] + 2 * (size_t)v + 1] = (uint32_t)fit | (uint32_t)(fit && row_stores(t, v)) << 1 | (uint32_t)(m->mat[v] & 255) << 8;
    }
    for (size_t s = 0; s < t->hash.size; s++) u[h[2] + 2 * s] = t->hash.owner[s], u[h[2] + 2 * s + 1] = t->entry[s];
    memcpy(u + h[3], t->lobe, sizeof(uint32_t) * t->hash.n * (size_t)(t->passes * t->lobes * VMFT_WORDS));
}

int vmft_glsl_data(const prt_data *d, const prt_transfer *tr, vmft_glsl_arrays *out, prt_error *err) {
    const vmft_data *t = vmft_get(tr);
    const prt_mesh *m = &d->scene.mesh;
    int nmat = d->scene.nmaterials > 0 ? d->scene.nmaterials : 1, R = start_res(t->level), nf = geogrid_face_count(t->grid);
    if (nmat > PRT_MAX_MATERIALS) nmat = PRT_MAX_MATERIALS;
    memset(out, 0, sizeof *out);
    uint32_t h[VMFT_GLSL_HEADER] = { 0 };
    h[0] = VMFT_GLSL_HEADER, h[1] = h[0] + 3 * (uint32_t)m->ntris, h[2] = h[1] + 2 * (uint32_t)m->nverts;
    h[3] = h[2] + 2 * (uint32_t)t->hash.size, h[4] = (uint32_t)t->passes, h[5] = (uint32_t)t->lobes, h[6] = (uint32_t)t->nviews;
    h[7] = (uint32_t)(nmat * TV_ROWS), h[8] = h[7] + 5 * (uint32_t)nf, h[9] = h[8] + (uint32_t)t->nviews;
    h[10] = h[9] + 2 * (uint32_t)m->nverts, h[11] = (uint32_t)R, h[12] = (uint32_t)t->hash.size, h[13] = VMFT_GLSL_MAGIC;
    out->nu = h[3] + t->hash.n * (size_t)(t->passes * t->lobes * VMFT_WORDS);
    out->nf = h[10] + 6 * (size_t)R * R;
    out->u = prt_calloc(out->nu + 1, sizeof(uint32_t), err);
    out->f = out->u ? prt_calloc(out->nf + 1, sizeof *out->f, err) : NULL;
    if (!out->f || faces_rows(t->grid, out->f + h[7], err) || start_rows(t->grid, R, out->f + h[10], err)) {
        vmft_glsl_free(out);
        return -1;
    }
    memcpy(out->u, h, sizeof h);
    fill_words(m, t, h, out->u);
    for (int i = 0; i < nmat; i++) material_rows(t, i, out->f + (size_t)i * TV_ROWS);
    for (int j = 0; j < t->nviews; j++) memcpy(out->f[h[8] + j], geogrid_dir(t->grid, j), sizeof(float) * 3);
    for (int v = 0; v < m->nverts; v++) {
        memcpy(out->f[h[9] + 2 * (size_t)v], m->pos + 3 * (size_t)v, sizeof(float) * 3);
        memcpy(out->f[h[9] + 2 * (size_t)v + 1], m->nrm + 3 * (size_t)v, sizeof(float) * 3);
    }
    return 0;
}

void vmft_glsl_free(vmft_glsl_arrays *a) {
    free(a->u);
    free(a->f);
    memset(a, 0, sizeof *a);
}

/* transfer_glsl_view.data over vmft_glsl_data; vattr 1 at a vertex of the transfer's materials whose row
 * stores nothing (the fast path of tv_radiance where all three corners are such). */
static int vmf_view_data(const prt_data *d, const prt_transfer *tr, float (**f)[4], size_t *nf, uint32_t **u, size_t *nu,
                         float **vattr, prt_error *err) {
    vmft_glsl_arrays a;
    const prt_mesh *m = &d->scene.mesh;
    float *va = prt_calloc((size_t)m->nverts + 1, sizeof(float), err);
    if (!va || vmft_glsl_data(d, tr, &a, err)) {
        free(va);
        return -1;
    }
    for (int v = 0; v < m->nverts; v++) va[v] = (a.u[a.u[1] + 2 * (size_t)v + 1] & 3u) == 1u ? 1.f : 0.f;
    *f = a.f, *nf = a.nf, *u = a.u, *nu = a.nu, *vattr = va;
    return 0;
}

const transfer_glsl_view transfer_vmf_glsl_view = {
    .source = k_vmf_view,
    .rows = TV_ROWS,
    .data = vmf_view_data,
};
