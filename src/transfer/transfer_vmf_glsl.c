/* transfer_vmf_glsl.c - the vmf transfer's per-pixel view shading in GLSL (transfer.h:
 * transfer_glsl_view; compiled by gpu/glrt.c into its per-pixel view program).
 *
 * What runs per pixel: the unoccluded case of vmf.h's shading rule. A vertex whose hash row
 * stores nothing is, for every view, the BRDF's own lobe (vmft_brdf_lobe: the one-lobe fit,
 * lobefit.h, at the view's elevation, rotated to its azimuth) looked up in the prefiltered
 * probe, E(mu, kappa) (laurijssen-2011 Eq. 5 with one lobe, Eq. 7's elevation interpolation of
 * the fit). Per pixel, the view w_o is the pixel's own (eye - position), the normal the
 * interpolated one: so the highlight is not limited to the vertex spacing, which is what the
 * per-vertex model smears on a sphere (issue 9). Pixels of triangles with a stored corner use
 * the per-vertex radiance (ops->shade_vertices on the CPU), as before: the hash, its entries
 * and the geodesic grid are not yet in GLSL.
 *
 * The material table (t_tv, TV_ROWS = 2 * LOBEFIT_MAX_VIEWS + 1 texels per material):
 *     row 0                  (views, 0, 0, 0)
 *     rows 1 + 2k, 2 + 2k    (mu.xyz, kappa), (alpha.rgb, 0) of the fit's view k (local frame,
 *                            wo = (sin theta_k, 0, cos theta_k), theta_k = k (pi/2) / views). */
#include "transfer.h"
#include "vmf.h"
#include <string.h>

#define TV_ROWS (2 * LOBEFIT_MAX_VIEWS + 1)

static const char k_vmf_view[] =
    /* lobefit_lookup at local view w = (sin, 0, cos): azimuth 0, so no rotation. */
    "vec3 tv_radiance(int m, vec3 n, vec3 wo) {\n"
    "    int base = m * TV_ROWS, views = int(texelFetch(t_tv, base).x);\n"
    "    if (views < 1) return vec3(0.0);\n"
    "    float c = dot(n, wo);\n"
    "    vec3 t = wo - c * n;\n"
    "    float r = length(t);\n"
    "    if (r > 1e-12) t /= r;\n"
    "    else { vec3 s2; frame(n, t, s2); }\n"   /* at the pole: brdf_frame's s (vmft_brdf_lobe) */
    "    vec3 w = vec3(r, 0.0, c);\n"
    "    if (c < 0.02) w = vec3(0.99979998, 0.0, 0.02);\n"   /* VMFT_MIN_COS: the grazing view */
    "    float x = atan(w.x, w.z) / 1.5707963267948966 * float(views);\n"
    "    int i = int(floor(x));\n"
    "    float f = x - float(i);\n"
    "    if (i < 0) { i = 0; f = 0.0; }\n"
    "    if (i >= views - 1) { i = views - 1; f = 0.0; }\n"
    "    int j = i + 1 < views ? i + 1 : i;\n"
    "    vec4 la = texelFetch(t_tv, base + 1 + 2 * i), lb = texelFetch(t_tv, base + 1 + 2 * j);\n"
    "    vec3 alpha = mix(texelFetch(t_tv, base + 2 + 2 * i).rgb, texelFetch(t_tv, base + 2 + 2 * j).rgb, f);\n"
    "    vec3 mu = mix(la.xyz, lb.xyz, f);\n"
    "    float l = length(mu);\n"
    "    mu = l > 0.0 ? mu / l : vec3(0.0, 0.0, 1.0);\n"
    "    vec3 mw = mu.x * t + mu.y * cross(n, t) + mu.z * n;\n"
    "    if (!(dot(alpha, vec3(0.2126, 0.7152, 0.0722)) > 0.0)) return vec3(0.0);\n"
    "    return alpha * pf_lookup(mw, mix(la.w, lb.w, f));\n"
    "}\n";

/* The fit of material m as table rows (header); zeros when tr does not shade m. */
static void vmf_material_rows(const prt_transfer *tr, int m, float (*rows)[4]) {
    memset(rows, 0, sizeof(float) * 4 * TV_ROWS);
    const vmft_data *t = vmft_get(tr);
    if (!t || m < 0 || m >= PRT_MAX_MATERIALS || !((t->materials >> m) & 1)) return;
    const lobefit_table *f = &t->fit[m];
    rows[0][0] = (float)f->views;
    for (int k = 0; k < f->views; k++) {
        memcpy(rows[1 + 2 * k], f->lobe[k].mu, sizeof(float) * 3);
        rows[1 + 2 * k][3] = f->lobe[k].kappa;
        memcpy(rows[2 + 2 * k], f->alpha[k], sizeof(float) * 3);
    }
}

/* True when v's material is shaded by tr and its row stores no slice (vmft_index's bitmap). */
static bool vmf_vertex_per_pixel(const prt_transfer *tr, int v) {
    const vmft_data *t = vmft_get(tr);
    if (!t || !t->stored || v < 0 || v >= t->nverts) return false;
    const uint64_t *b = t->stored + (size_t)v * t->words;
    for (int k = 0; k < t->words; k++)
        if (b[k]) return false;
    return true;
}

const transfer_glsl_view transfer_vmf_glsl_view = {
    .source = k_vmf_view,
    .rows = TV_ROWS,
    .material_rows = vmf_material_rows,
    .vertex_per_pixel = vmf_vertex_per_pixel,
};
