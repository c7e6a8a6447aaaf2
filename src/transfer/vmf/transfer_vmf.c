/* transfer_vmf.c - the vMF lobe transfer (vmf.h; laurijssen-2011 sections 4-6): its ops
 * table, the packed lobe, Eq. 7's interpolation, the CPU shading and the file section.
 * The passes that fill it (Eq. 8-11) are src/transfer/vmf/vmfpass.c.
 *
 * Why the shading looks up the BRDF's own lobe at the exact view when no neighbouring slice
 * is stored: that is the common case (an unoccluded vertex) and then the result is exactly
 * the one-lobe BRDF fit, with no grid interpolation error at all (vmf/unoccluded_sphere). */
#include "transfer.h"
#include "check.h"
#include "prefilter.h"
#include "vec3.h"
#include "prtfile.h"
#include "vmf.h"
#include "vmfpass.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)
#define VMFT_MAX_SAMPLES 4096

/* ---- the data ------------------------------------------------------------------------- */

const vmft_data *vmft_get(const prt_transfer *tr) {
    PRT_CHECK(tr->priv != NULL);
    return tr->priv;
}

int vmft_init(vmft_data *t, int level, int lobes, int nverts, prt_error *err) {
    memset(t, 0, sizeof *t);
    PRT_CHECK(lobes >= 1 && lobes <= VMFT_MAX_LOBES && nverts >= 0);
    t->grid = geogrid_create(level, err);
    if (!t->grid) return -1;
    t->level = level, t->nviews = geogrid_count(t->grid), t->lobes = lobes, t->nverts = nverts, t->passes = 1;
    t->horizon = sinf(geogrid_spacing(t->grid));
    return 0;
}

int vmft_index(vmft_data *t, prt_error *err) {
    free(t->stored);
    t->words = (t->nviews + 63) / 64;
    t->stored = prt_calloc((size_t)t->nverts * t->words + 1, sizeof(uint64_t), err);
    if (!t->stored) return -1;
    for (size_t s = 0; s < t->hash.size; s++) {
        uint32_t o = t->hash.owner[s];
        if (!o || o > (uint32_t)t->nverts || s < t->hash.offset[o - 1] || s - t->hash.offset[o - 1] >= (size_t)t->nviews) continue;
        size_t j = s - t->hash.offset[o - 1];
        t->stored[(size_t)(o - 1) * t->words + j / 64] |= (uint64_t)1 << (j % 64);
    }
    return 0;
}

void vmft_free(vmft_data *t) {
    if (!t) return;
    free(t->stored);
    phash_free(&t->hash);
    free(t->lobe);
    free(t->entry);
    geogrid_destroy(t->grid);
    memset(t, 0, sizeof *t);
}

size_t vmft_bytes(const vmft_data *t) {
    return 4 * ((size_t)t->nverts + 2 * t->hash.size + t->hash.n * (size_t)(t->passes * t->lobes * VMFT_WORDS));
}

/* ---- the packed lobe ---------------------------------------------------------------------- */

/* clang before 15 has no _Float16 on x86 (`make fuzz` builds with Debian's clang 14); its __fp16
 * is the same IEEE half as a storage type, converted with the same round-to-nearest-even. */
#if defined(__clang__) && __clang_major__ < 15
typedef __fp16 vmft_half;
#else
typedef _Float16 vmft_half;
#endif
static uint16_t half_bits(float x) {
    vmft_half h = (vmft_half)x;
    uint16_t u;
    memcpy(&u, &h, 2);
    return u;
}

/* Half to float by bit manipulation (Giesen's half_to_float_fast5: exact for every half, zero,
 * subnormal, inf and NaN included): gcc's _Float16 conversion calls libgcc's soft-float
 * __extendhfsf2, which took 7% of a frame (perf); -march=x86-64-v2 has no F16C. */
static float half_value(uint32_t bits) {
    uint32_t h = bits & 0xffffu, o = (h & 0x7fffu) << 13, exp = o & (0x7c00u << 13);
    o += (127 - 15) << 23;
    float f;
    if (exp == 0x7c00u << 13) o += (128 - 16) << 23;   /* inf, NaN */
    else if (exp == 0) {                              /* zero, subnormal: renormalize */
        o += 1 << 23;
        memcpy(&f, &o, 4);
        f -= 6.103515625e-05f;                        /* 2^-14 */
        memcpy(&o, &f, 4);
    }
    o |= (h & 0x8000u) << 16;
    memcpy(&f, &o, 4);
    return f;
}

static int16_t snorm16(float x) { return (int16_t)lrintf((x > 1 ? 1 : x < -1 ? -1 : x) * 32767.f); }

void vmft_pack(const vmf_lobe *l, const float alpha[3], uint32_t w[VMFT_WORDS]) {
    float x = l->mu[0], y = l->mu[1], z = l->mu[2], s = fabsf(x) + fabsf(y) + fabsf(z);
    float u = s > 0 ? x / s : 0, v = s > 0 ? y / s : 0;
    if (z < 0) {
        float uu = (1 - fabsf(v)) * (u >= 0 ? 1 : -1), vv = (1 - fabsf(u)) * (v >= 0 ? 1 : -1);
        u = uu, v = vv;
    }
    w[0] = (uint32_t)(uint16_t)snorm16(u) | (uint32_t)(uint16_t)snorm16(v) << 16;
    float k = l->kappa < VMFT_KAPPA_MAX ? l->kappa : VMFT_KAPPA_MAX;
    w[1] = half_bits(k) | (uint32_t)half_bits(alpha[0]) << 16;
    w[2] = half_bits(alpha[1]) | (uint32_t)half_bits(alpha[2]) << 16;
}

void vmft_unpack(const uint32_t w[VMFT_WORDS], vmf_lobe *l, float alpha[3]) {
    float u = (int16_t)(uint16_t)(w[0] & 0xffff) / 32767.f, v = (int16_t)(uint16_t)(w[0] >> 16) / 32767.f;
    float z = 1 - fabsf(u) - fabsf(v), x = u, y = v;
    if (z < 0) x = (1 - fabsf(v)) * (u >= 0 ? 1 : -1), y = (1 - fabsf(u)) * (v >= 0 ? 1 : -1);
    float n = sqrtf(x * x + y * y + z * z);
    l->mu[0] = x / n, l->mu[1] = y / n, l->mu[2] = z / n;
    l->kappa = half_value(w[1]);
    alpha[0] = half_value(w[1] >> 16), alpha[1] = half_value(w[2]), alpha[2] = half_value(w[2] >> 16);
}

const uint32_t *vmft_slice(const vmft_data *t, int v, int j, int p) {
    long s = phash_find(&t->hash, (uint32_t)v, (uint32_t)j);
    if (s < 0) return NULL;
    return t->lobe + (((size_t)t->entry[s] * t->passes + (size_t)p) * t->lobes) * VMFT_WORDS;
}

/* ---- the BRDF's own lobe and Eq. 7 ----------------------------------------------------------- */

/* Why no tangent frame: the fit's lobe of an isotropic BRDF at view (r, 0, c) (azimuth 0, r = sin,
 * c = cos of the elevation) has axis (mx, my, mz) in that frame, and rotating it to wo's azimuth
 * (lobefit_lookup) then to the world is mx t + my (n x t) + mz n with t wo's unit tangential
 * part: the same lobe as brdf_frame + brdf_to_local + lobefit_lookup (within 3e-5, float
 * rounding, over 200,000 random normals and views), without their doubles. At the pole t is
 * brdf_frame's s (lobefit_lookup's azimuth 0). */
void vmft_brdf_lobe(const lobefit_table *fit, const float n[3], const float wo[3], vmf_lobe *l, float alpha[3]) {
    float c = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2], t[3], r = 0;
    for (int k = 0; k < 3; k++) t[k] = wo[k] - c * n[k], r += t[k] * t[k];
    r = sqrtf(r);
    if (r > 1e-12f) for (int k = 0; k < 3; k++) t[k] /= r;
    else {
        float s2[3];
        brdf_frame(n, t, s2);
    }
    float w[3] = { r, 0, c };
    if (c < VMFT_MIN_COS)   /* at or below the horizon: the grazing view of the same azimuth */
        w[0] = sqrtf(1 - VMFT_MIN_COS * VMFT_MIN_COS), w[2] = VMFT_MIN_COS;
    vmf_lobe loc;
    lobefit_lookup(fit, w, &loc, alpha);
    float b[3] = { n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0] };
    for (int k = 0; k < 3; k++) l->mu[k] = loc.mu[0] * t[k] + loc.mu[1] * b[k] + loc.mu[2] * n[k];
    l->kappa = loc.kappa;
}

/* Eq. 7's running sums for one lobe index. */
typedef struct interp_acc { double alpha[3], mu[3], kappa, a; } interp_acc;

static void acc_add(interp_acc *acc, const vmf_lobe *l, const float alpha[3], double w) {
    double a = w * prt_luminancef(alpha);
    for (int c = 0; c < 3; c++) acc->alpha[c] += w * alpha[c], acc->mu[c] += a * l->mu[c];
    acc->kappa += a * l->kappa;
    acc->a += a;
}

static void acc_result(const interp_acc *acc, vmf_lobe *out, float alpha[3]) {
    double l = sqrt(acc->mu[0] * acc->mu[0] + acc->mu[1] * acc->mu[1] + acc->mu[2] * acc->mu[2]);
    bool ok = acc->a > 0 && l > 0;
    for (int c = 0; c < 3; c++) {
        alpha[c] = ok ? (float)acc->alpha[c] : 0.f;
        out->mu[c] = ok ? (float)(acc->mu[c] / l) : (c == 2);
    }
    out->kappa = ok ? (float)(acc->kappa / acc->a) : 0.f;
}

/* Eq. 7 over n pairs whose entries (lobe sets, -1 when absent) are known (vmft_interp). */
static void interp_entries(const vmft_data *t, const prt_mesh *m, int n, const int *vert, const int *view, const long *ent,
                           const float *w, int p, const float *exact_wo, const float *exact_n, vmf_lobe *out, float (*alpha)[3]) {
    interp_acc acc[VMFT_MAX_LOBES];
    memset(acc, 0, sizeof acc);
    bool any = false;
    size_t stride = (size_t)t->passes * t->lobes * VMFT_WORDS;
    for (int k = 0; k < n; k++) {
        if (ent[k] < 0 || !(w[k] > 0)) continue;
        const uint32_t *s = t->lobe + (size_t)ent[k] * stride + (size_t)p * t->lobes * VMFT_WORDS;
        for (int i = 0; i < t->lobes; i++) {
            const uint32_t *q = s + VMFT_WORDS * i;
            if (!(q[1] >> 16) && !q[2]) continue;   /* alpha +0: an empty lobe (most later-pass slots) */
            vmf_lobe l;
            float a[3];
            vmft_unpack(q, &l, a);
            acc_add(&acc[i], &l, a, w[k]);
        }
        any = true;
    }
    if (p == 0 && !any && exact_wo) {   /* nothing stored around: exactly the BRDF's own lobe */
        for (int i = 0; i < t->lobes; i++) alpha[i][0] = alpha[i][1] = alpha[i][2] = 0, out[i] = (vmf_lobe){ { 0, 0, 1 }, 0 };
        vmft_brdf_lobe(&t->fit[m->mat[vert[0]]], exact_n, exact_wo, &out[0], alpha[0]);
        float ws = 0;   /* the pairs' share (1 but where a hit triangle has corners of other materials) */
        for (int k = 0; k < n; k++) ws += w[k];
        for (int c = 0; c < 3; c++) alpha[0][c] *= ws;
        return;
    }
    for (int k = 0; p == 0 && k < n; k++) {   /* absent pairs: the BRDF lobe at their grid view */
        if (!(w[k] > 0) || ent[k] >= 0) continue;
        vmf_lobe l;
        float a[3];
        vmft_brdf_lobe(&t->fit[m->mat[vert[k]]], m->nrm + 3 * (size_t)vert[k], geogrid_dir(t->grid, view[k]), &l, a);
        acc_add(&acc[0], &l, a, w[k]);
    }
    for (int i = 0; i < t->lobes; i++) acc_result(&acc[i], &out[i], alpha[i]);
}

/* Whether row v has any stored slice (t->stored). */
static bool row_any(const vmft_data *t, int v) {
    const uint64_t *b = t->stored + (size_t)v * t->words;
    uint64_t any = 0;
    for (int k = 0; k < t->words; k++) any |= b[k];
    return any != 0;
}

/* The entry (lobe set index) of slice (v, j), or -1 when it is not stored: the bitmap first (the
 * common absent case touches neither owner nor entry), then the slot's entry. */
static long entry_of(const vmft_data *t, int v, int j) {
    PRT_CHECK(t->stored != NULL && j >= 0 && j < t->nviews);
    if (!((t->stored[(size_t)v * t->words + j / 64] >> (j % 64)) & 1)) return -1;
    return (long)t->entry[(size_t)t->hash.offset[v] + (size_t)j];
}

void vmft_interp(const vmft_data *t, const prt_mesh *m, int n, const int *vert, const int *view, const float *w,
                 int p, const float *exact_wo, const float *exact_n, vmf_lobe *out, float (*alpha)[3]) {
    long ent[16];
    PRT_CHECK(n >= 1 && n <= 16);
    for (int k = 0; k < n; k++) ent[k] = w[k] > 0 ? entry_of(t, vert[k], view[k]) : -1;
    interp_entries(t, m, n, vert, view, ent, w, p, exact_wo, exact_n, out, alpha);
}

/* Adds sum alpha E(mu, kappa) over lobes to rgb. */
static void add_lobes(const prefilter_env *env, const vmf_lobe *l, const float (*a)[3], int n, float rgb[3]) {
    for (int i = 0; i < n; i++) {
        if (!(prt_luminancef(a[i]) > 0)) continue;
        float e[3];
        prefilter_lookup(env, l[i].mu, l[i].kappa, e);
        for (int k = 0; k < 3; k++) rgb[k] += a[i][k] * e[k];
    }
}

/* One vertex's view while it is shaded; the three steps below are vmft_radiance, split so that
 * shade_range can run each over a block of vertices: the entry and lobe loads are cache misses
 * (perf: 30% of a frame stalled on them on the bunny, 72 MB of lobes), and issuing a block's
 * prefetches before any is used overlaps them instead of paying them one after another. */
typedef struct vmft_view { float w[3], gw[3]; int views[3]; long ent[3]; bool any; } vmft_view;

/* w = wo, or below VMFT_MIN_COS above the tangent plane of n the grazing view of the same azimuth
 * (vmft_brdf_lobe's rule), to be located on the grid. */
static void view_grazing(const float n[3], const float wo[3], float w[3]) {
    float c = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2];
    memcpy(w, wo, sizeof(float) * 3);
    if (c < VMFT_MIN_COS) {
        float tx[3], r = 0;
        for (int k = 0; k < 3; k++) tx[k] = w[k] - c * n[k], r += tx[k] * tx[k];
        r = sqrtf(r);
        if (r > 1e-12f)
            for (int k = 0; k < 3; k++) w[k] = tx[k] / r * sqrtf(1 - VMFT_MIN_COS * VMFT_MIN_COS) + VMFT_MIN_COS * n[k];
    }
}

/* Step 1: the view moved above the grazing limit, located on the grid when the row stores anything;
 * prefetches the entries of its stored views. */
static void view_locate(const vmft_data *t, const prt_mesh *m, int v, const float wo[3], vmft_view *q) {
    view_grazing(m->nrm + 3 * (size_t)v, wo, q->w);
    q->any = row_any(t, v);   /* a row with nothing stored needs no grid location either */
    if (!q->any) return;
    geogrid_locate(t->grid, q->w, q->views, q->gw);
    for (int k = 0; k < 3; k++) __builtin_prefetch(t->entry + t->hash.offset[v] + q->views[k]);
}

/* Step 2: the entries of the located views (-1 absent); prefetches their lobes of pass 0. */
static void view_entries(const vmft_data *t, int v, vmft_view *q) {
    if (!q->any) return;
    q->any = false;
    size_t stride = (size_t)t->passes * t->lobes * VMFT_WORDS;
    for (int k = 0; k < 3; k++) {
        q->ent[k] = q->gw[k] > 0 ? entry_of(t, v, q->views[k]) : -1;
        if (q->ent[k] >= 0) q->any = true, __builtin_prefetch(t->lobe + (size_t)q->ent[k] * stride);
    }
}

/* Step 3: adds the radiance (every pass) to rgb. */
static void view_shade(const vmft_data *t, const prt_mesh *m, int v, const vmft_view *q, const prefilter_env *env, float rgb[3]) {
    const float *n = m->nrm + 3 * (size_t)v;
    vmf_lobe l[VMFT_MAX_LOBES];
    float a[VMFT_MAX_LOBES][3];
    if (!q->any) {   /* the common case: the BRDF's own lobe at the exact view, one lookup */
        vmft_brdf_lobe(&t->fit[m->mat[v]], n, q->w, &l[0], a[0]);
        add_lobes(env, l, (const float (*)[3])a, 1, rgb);
        return;
    }
    int verts[3] = { v, v, v };
    for (int p = 0; p < t->passes; p++) {
        interp_entries(t, m, 3, verts, q->views, q->ent, q->gw, p, q->w, n, l, a);
        add_lobes(env, l, (const float (*)[3])a, t->lobes, rgb);
    }
}

void vmft_radiance(const vmft_data *t, const prt_mesh *m, int v, const float wo[3], const prefilter_env *env, float rgb[3]) {
    vmft_view q;
    view_locate(t, m, v, wo, &q);
    view_entries(t, v, &q);
    view_shade(t, m, v, &q, env, rgb);
}

/* The per-pixel rule (vmf.h "Per pixel"): Eq. 7 over the 3 grid views of the pixel's view and the
 * triangle's fitted corners, weighted b_k w_q; gl's tv_radiance (transfer_vmf_glsl.c) is this in GLSL. */
void vmft_radiance_point(const vmft_data *t, const prt_mesh *m, const int tri[3], const float bary[3], const float wo[3],
                         const prefilter_env *env, float rgb[3]) {
    float b[3], s = 0, n[3] = { 0, 0, 0 };
    for (int k = 0; k < 3; k++) b[k] = bary[k] > 0 ? bary[k] : 0, s += b[k];
    if (!(s > 0)) return;
    for (int k = 0; k < 3; k++) {
        b[k] /= s;
        for (int q = 0; q < 3; q++) n[q] += b[k] * m->nrm[3 * (size_t)tri[k] + q];
    }
    float nl = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nl > 0)) return;
    for (int q = 0; q < 3; q++) n[q] /= nl;
    vmft_view view;
    int vert[9], views[9], np = 0;
    float w[9];
    long ent[9];
    bool rows = false;
    view_grazing(n, wo, view.w);
    for (int k = 0; k < 3; k++) rows |= ((t->materials >> m->mat[tri[k]]) & 1) && b[k] > 0 && row_any(t, tri[k]);
    if (rows) geogrid_locate(t->grid, view.w, view.views, view.gw);
    else view.views[0] = view.views[1] = view.views[2] = 0, view.gw[0] = 1, view.gw[1] = view.gw[2] = 0;
    bool any = false;
    for (int k = 0; k < 3; k++) {
        if (!((t->materials >> m->mat[tri[k]]) & 1) || !(b[k] > 0)) continue;
        for (int q = 0; q < 3; q++) {
            vert[np] = tri[k], views[np] = view.views[q], w[np] = b[k] * view.gw[q];
            ent[np] = rows && w[np] > 0 ? entry_of(t, tri[k], views[np]) : -1;
            any |= ent[np++] >= 0;
        }
    }
    if (!np) return;
    vmf_lobe l[VMFT_MAX_LOBES];
    float a[VMFT_MAX_LOBES][3], e[3] = { 0, 0, 0 };
    for (int p = 0; p < (any ? t->passes : 1); p++) {
        interp_entries(t, m, np, vert, views, ent, w, p, view.w, n, l, a);
        add_lobes(env, l, (const float (*)[3])a, t->lobes, e);
    }
    for (int k = 0; k < 3; k++) rgb[k] += isfinite(e[k]) && e[k] > 0 ? e[k] : 0.f;
}

/* ---- configuration ---------------------------------------------------------------------------- */

static const transfer_option k_options[] = {
    { .key = "lobes", .kind = TRANSFER_OPT_INT, .lo = 1, .hi = VMFT_MAX_LOBES, .flag = "--lobes", .arg = "I",
      .help = "vMF lobes per view and reflection pass, 1..4 (default 2)" },
    { .key = "level", .kind = TRANSFER_OPT_INT, .lo = 0, .hi = GEOGRID_MAX_LEVEL, .flag = "--view-level", .arg = "L",
      .help = "geodesic view grid: icosahedron subdivided L times, 0..6 (default 2:\n162 views)" },
    { .key = "samples", .kind = TRANSFER_OPT_INT, .lo = 4, .hi = VMFT_MAX_SAMPLES, .flag = "--lobe-samples", .arg = "S",
      .help = "rays per (vertex, view) in the vMF passes, 4..4096 (default 64)" },
    { .key = NULL },
};

vmf_config vmft_config(const transfer_config *cfg) {
    vmf_config c;
    memcpy(&c, cfg->bytes, sizeof c);
    return c;
}

static int vmf_set(void *user, int i, const char *value, prt_error *err) {
    vmf_config *c = user;
    int *field[] = { &c->lobes, &c->level, &c->samples };
    c->level_set |= i == 1;
    return transfer_option_int("vmf", &k_options[i], value, field[i], err);
}

/* lobes (default VMFT_DEFAULT_LOBES), level (VMFT_DEFAULT_LEVEL), samples (VMFT_DEFAULT_SAMPLES); N and
 * qbits are the linear transfers' and do not apply, nor does a light prior. */
static int vmf_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
    _Static_assert(sizeof(vmf_config) <= TRANSFER_CONFIG_BYTES, "vmf_config fits transfer_config");
    memset(cfg, 0, sizeof *cfg);
    vmf_config c = { .lobes = VMFT_DEFAULT_LOBES, .level = VMFT_DEFAULT_LEVEL, .samples = VMFT_DEFAULT_SAMPLES };
    if (s->N || s->qbits) return prt_fail(err, "vmf transfer: N and qbits do not apply (lobes, level, samples do)");
    if (transfer_parse_options("vmf", k_options, s->options, vmf_set, &c, err)) return -1;
    memcpy(cfg->bytes, &c, sizeof c);
    return 0;
}

/* The finest level whose bytes fit the budget (vmf.h VMFT_PLAN_BYTES), unless the options set one. */
/* The plan's modelled bytes of one vertex at grid level l with R passes (VMFT_PLAN_BYTES). */
static double vmf_plan_vertex_bytes(const vmf_config *c, int l, int R) {
    return (10.0 * (1 << (2 * l)) + 2) * (VMFT_PLAN_SLOT_BYTES + VMFT_PLAN_STORED * R * c->lobes * 4 * VMFT_WORDS);
}

static void vmf_settle(transfer_config *cfg, long nverts, int passes, long *room, char *why, size_t cap) {
    vmf_config c = vmft_config(cfg);
    int R = passes < 1 ? 1 : passes > VMFT_MAX_PASSES ? VMFT_MAX_PASSES : passes;
    if (c.level_set) {
        if (room) *room = (long)(VMFT_PLAN_BYTES / vmf_plan_vertex_bytes(&c, c.level, R));
        snprintf(why, cap, "view grid level %d, as asked", c.level);
        return;
    }
    double est[VMFT_PLAN_MAX_LEVEL + 1] = { 0 };
    int L = VMFT_DEFAULT_LEVEL;
    for (int l = VMFT_DEFAULT_LEVEL; l <= VMFT_PLAN_MAX_LEVEL; l++) {
        est[l] = (double)nverts * vmf_plan_vertex_bytes(&c, l, R);
        if (est[l] <= VMFT_PLAN_BYTES) L = l;
    }
    if (room) *room = (long)(VMFT_PLAN_BYTES / vmf_plan_vertex_bytes(&c, L, R));
    c.level = L, c.level_set = true;
    memcpy(cfg->bytes, &c, sizeof c);
    int n = snprintf(why, cap, "view grid level %d (%d views): %ld glossy vertices, %d pass%s: at most ~%.0f MB", L,
                     10 * (1 << (2 * L)) + 2, nverts, R, R == 1 ? "" : "es", est[L] / 1e6);
    if (L < VMFT_PLAN_MAX_LEVEL && n > 0 && (size_t)n < cap)
        snprintf(why + n, cap - (size_t)n, " (level %d: ~%.0f MB, over the %.0f MB budget)", L + 1, est[L + 1] / 1e6,
                 VMFT_PLAN_BYTES / 1e6);
}

static void vmf_describe(const transfer_config *cfg, char *buf, size_t cap) {
    vmf_config c = vmft_config(cfg);
    snprintf(buf, cap, "vMF lobes (%d per pass, %d views, %d rays per slice)", c.lobes, 10 * (1 << (2 * c.level)) + 2, c.samples);
}

/* ---- precompute --------------------------------------------------------------------------------- */

/* Both errors in the lobe fit's measure (relative L2 over the whole slice f cos, mean over view
 * elevations; lobefit.h): one vMF lobe per view, and the SVD at f's K. */
static int vmf_fit(const transfer_config *cfg, const brdf_params *p, const brdf_factor *f, transfer_fit *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    out->what = "one vMF lobe";
    out->measure = "rel. L2 over the whole slice f cos";
    if (!lobefit_supported(p->type)) {
        snprintf(out->why, sizeof out->why, "%s", p->type == BRDF_AS ? "anisotropic, and no ASG fit exists here" : "no lobe fit for this model");
        return 0;
    }
    lobefit_table t;
    if (lobefit_fit(p, &(lobefit_desc){ 0 }, &t, err)) return -1;
    float e[LOBEFIT_MAX_VIEWS];
    lobefit_factor_error(&t, p, f, f->K, e);
    double svd = 0;
    for (int v = 0; v < t.views; v++) svd += e[v];
    out->svd_err = t.views > 0 ? svd / t.views : 0;
    out->err = t.err_whole_mean;
    out->fits = true;
    return 0;
}

static int vmf_precompute(const transfer_precompute_in *in, prt_transfer *tr, prt_error *err) {
    return vmfpass_run(in, tr, err);
}

/* vmfpass_estimate's probe times the counts of each stage's items. A pass that gathers nothing carries
 * no energy, so the next one does not run: no stored slice (nothing blocks the lobes), pass 1 is the
 * last; none hits a fitted triangle, pass 2 is. */
static int vmf_estimate(const transfer_precompute_in *in, const prt_transfer *tr, transfer_estimate *out, prt_error *err) {
    vmfpass_cost vc;
    memset(out, 0, sizeof *out);
    if (vmfpass_estimate(in, tr, &vc, err)) return -1;
    int R = in->passes < 1 ? 1 : in->passes > VMFT_MAX_PASSES ? VMFT_MAX_PASSES : in->passes;
    if (vc.stored == 0 && R > 2) R = 2;
    if (vc.fit_share == 0 && R > 3) R = 3;
    double cpu[2 + VMFT_MAX_PASSES] = { R > 1 ? vc.nverts * vc.diffuse_cpu : 0, vc.ngverts * vc.direct_cpu };
    for (int p = 1; p < R; p++) cpu[1 + p] = vc.ngverts * vc.stored * (p == 1 ? vc.gather_cpu : vc.fit_share * vc.gather2_cpu);
    static const char *const names[2 + VMFT_MAX_PASSES] = { "vmf diffuse lobes", "vmf direct", "vmf pass 1", "vmf pass 2",
                                                            "vmf pass 3" };
    for (int k = R > 1 ? 0 : 1; k < 1 + R && out->n < TRANSFER_MAX_STAGES; k++, out->n++) {
        snprintf(out->name[out->n], sizeof out->name[out->n], "%s", names[k]);
        out->cpu[out->n] = cpu[k];
    }
    return 0;
}

/* Checkpoint pass p's records: vertices of the direct pass, slices of a gathering pass. */
static void vmf_resumed(int p, int count, char *buf, size_t cap) {
    if (p == 0) snprintf(buf, cap, "vmf direct %d", count);
    else snprintf(buf, cap, "vmf pass %d %d slices", p, count);
}

/* ---- runtime ------------------------------------------------------------------------------------ */

typedef struct shade_ctx {
    const prt_data *d;
    const vmft_data *t;
    const prefilter_env *env;
    const float *eye;
    float *rgb;
} shade_ctx;

#define VMFT_BLOCK 32   /* vertices whose loads are in flight together (view_locate) */

static void shade_range(void *ctx, int begin, int end, int thread) {
    const shade_ctx *c = ctx;
    const prt_mesh *m = &c->d->scene.mesh;
    vmft_view q[VMFT_BLOCK];
    int vs[VMFT_BLOCK];
    for (int b = begin; b < end; b += VMFT_BLOCK) {
        int nb = 0;
        for (int v = b; v < end && v < b + VMFT_BLOCK; v++) {
            if (!((c->t->materials >> m->mat[v]) & 1)) continue;
            const float *p = m->pos + 3 * (size_t)v;
            float wo[3] = { c->eye[0] - p[0], c->eye[1] - p[1], c->eye[2] - p[2] };
            if (!V3_SAFE_LEN2(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2])) v3_prescale(wo);   /* far or near eye (vec3.h) */
            float l = sqrtf(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]);
            if (!(l > 0) || !isfinite(l)) continue;
            for (int k = 0; k < 3; k++) wo[k] /= l;
            vs[nb] = v;
            view_locate(c->t, m, v, wo, &q[nb++]);
        }
        for (int i = 0; i < nb; i++) view_entries(c->t, vs[i], &q[i]);
        for (int i = 0; i < nb; i++) {
            float e[3] = { 0, 0, 0 };
            view_shade(c->t, m, vs[i], &q[i], c->env, e);
            for (int k = 0; k < 3; k++) c->rgb[3 * (size_t)vs[i] + k] += isfinite(e[k]) && e[k] > 0 ? e[k] : 0.f;
        }
    }
}

static void vmf_shade_vertices(const prt_data *d, const prt_transfer *tr, const prefilter_env *env, const float eye[3],
                               float *rgb, int nthreads) {
    shade_ctx c = { d, vmft_get(tr), env, eye, rgb };
    prt_parallel_for(d->scene.mesh.nverts, 512, nthreads, shade_range, &c);
}

static size_t vmf_bytes(const prt_transfer *tr) { return tr->priv ? vmft_bytes(vmft_get(tr)) : 0; }

/* `prt info`'s lines: grid, lobes, passes, stored share, hash fill, bytes, each pass's energy and time. */
static void vmf_summary(const prt_transfer *tr, char *buf, size_t cap) {
    const vmft_data *t = vmft_get(tr);
    size_t len = 0;
#define OUT(...) (len += (size_t)snprintf(buf + len, len < cap ? cap - len : 0, __VA_ARGS__))
    OUT("vmf           %d views (geodesic level %d), %d lobe%s per pass, %d pass%s stored, %d rays per slice\n", t->nviews,
        t->level, t->lobes, t->lobes == 1 ? "" : "s", t->passes, t->passes == 1 ? "" : "es", t->samples);
    OUT("              stored %zu of %llu slices (%.2f%%); hash %zu slots, fill %.1f%%; %.2f MB (%d bytes a lobe)\n",
        t->hash.n, (unsigned long long)t->slices, t->slices ? 100.0 * (double)t->hash.n / (double)t->slices : 0.0,
        t->hash.size, 100 * t->hash.fill, vmft_bytes(t) / 1e6, 4 * VMFT_WORDS);
    OUT("              direct pass %.1fs", t->t_pass[0]);
    for (int p = 1; p < t->passes; p++) OUT("; pass %d: %.2f%% of the direct energy, %.1fs", p, 100 * t->energy[p], t->t_pass[p]);
    OUT("\n");
    for (int m = 0; m < PRT_MAX_MATERIALS; m++)
        if ((t->materials >> m) & 1)
            OUT("              material %d: BRDF lobe fit %.1f%% mean, %.1f%% max error (16 view elevations)\n", m,
                100 * t->fit[m].err_mean, 100 * t->fit[m].err_max);
#undef OUT
    if (len >= cap && cap) buf[cap - 1] = 0;
}

static void vmf_release(prt_transfer *tr) {
    if (tr->priv) vmft_free(tr->priv);
    free(tr->priv);
    tr->priv = NULL;
}

/* ---- the file section -------------------------------------------------------------------
 * i32 lobes level samples, u64 material mask, i32 passes nverts nviews, f32 horizon, u64 slices,
 * f64 t_pass[4] energy[4]; per material of the mask its lobe fit (lobefit_table's fields);
 * u64 hash n and size, u32 offset[nverts], owner[size], entry[size], lobe[n * passes * lobes * 3]. */

static void put_fit(prt_writer *w, const lobefit_table *f) {
    prtio_put_i32(w, (int32_t)f->type);
    prtio_put_i32(w, f->views);
    prtio_put_i32(w, f->res);
    for (int v = 0; v < f->views; v++) {
        prtio_put_f32(w, f->theta[v]);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, f->lobe[v].mu[k]);
        prtio_put_f32(w, f->lobe[v].kappa);
        for (int k = 0; k < 3; k++) prtio_put_f32(w, f->alpha[v][k]);
        prtio_put_f32(w, f->err[v]);
        prtio_put_f32(w, f->err_whole[v]);
    }
    float e[4] = { f->err_mean, f->err_max, f->err_whole_mean, f->err_whole_max };
    for (int k = 0; k < 4; k++) prtio_put_f32(w, e[k]);
    prtio_put_f64(w, f->seconds);
}

static bool get_fit(prt_reader *r, lobefit_table *f, char *why) {
    f->type = (brdf_type)prtio_get_i32(r);
    f->views = prtio_get_i32(r);
    f->res = prtio_get_i32(r);
    if (r->bad || f->views < 1 || f->views > LOBEFIT_MAX_VIEWS) return BAD(why, "vmf: bad lobe fit view count %d", f->views);
    for (int v = 0; v < f->views; v++) {
        f->theta[v] = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) f->lobe[v].mu[k] = prtio_get_f32(r);
        f->lobe[v].kappa = prtio_get_f32(r);
        for (int k = 0; k < 3; k++) f->alpha[v][k] = prtio_get_f32(r);
        f->err[v] = prtio_get_f32(r);
        f->err_whole[v] = prtio_get_f32(r);
    }
    f->err_mean = prtio_get_f32(r), f->err_max = prtio_get_f32(r);
    f->err_whole_mean = prtio_get_f32(r), f->err_whole_max = prtio_get_f32(r);
    f->seconds = prtio_get_f64(r);
    return r->bad ? BAD(why, "vmf section too short (lobe fit)") : true;
}

static void vmf_write(prt_writer *w, const prt_transfer *tr) {
    const vmft_data *t = vmft_get(tr);
    vmf_config c = vmft_config(&tr->cfg);
    prtio_put_i32(w, c.lobes), prtio_put_i32(w, c.level), prtio_put_i32(w, c.samples);
    prtio_put_u64(w, tr->materials);
    prtio_put_i32(w, t->passes), prtio_put_i32(w, t->nverts), prtio_put_i32(w, t->nviews);
    prtio_put_f32(w, t->horizon);
    prtio_put_u64(w, t->slices);
    for (int p = 0; p < VMFT_MAX_PASSES; p++) prtio_put_f64(w, t->t_pass[p]);
    for (int p = 0; p < VMFT_MAX_PASSES; p++) prtio_put_f64(w, t->energy[p]);
    for (int m = 0; m < PRT_MAX_MATERIALS; m++)
        if ((tr->materials >> m) & 1) put_fit(w, &t->fit[m]);
    prtio_put_u64(w, t->hash.n), prtio_put_u64(w, t->hash.size);
    prtio_put_arr(w, t->hash.offset, (size_t)t->nverts, 4);
    prtio_put_arr(w, t->hash.owner, t->hash.size, 4);
    prtio_put_arr(w, t->entry, t->hash.size, 4);
    prtio_put_arr(w, t->lobe, t->hash.n * (size_t)(t->passes * t->lobes * VMFT_WORDS), 4);
}

/* Sizes first (each bounded before anything is allocated), then the arrays. */
static bool vmf_read_arrays(prt_reader *r, vmft_data *t, char *why) {
    uint64_t n = prtio_get_u64(r), size = prtio_get_u64(r);
    size_t per = (size_t)(t->passes * t->lobes * VMFT_WORDS);
    if (r->bad || n > size || size > (uint64_t)UINT32_MAX || !prtio_need(r, (size_t)t->nverts + 2 * (size_t)size + (size_t)n * per, 4))
        return BAD(why, "vmf section too short for its hash table (%llu slots)", (unsigned long long)size);
    t->hash.nrows = t->nverts, t->hash.ncols = t->nviews, t->hash.n = n, t->hash.size = size;
    t->hash.offset = prtio_get_arr(r, (size_t)t->nverts, 4);
    t->hash.owner = prtio_get_arr(r, (size_t)size, 4);
    t->entry = prtio_get_arr(r, (size_t)size, 4);
    t->lobe = prtio_get_arr(r, (size_t)n * per, 4);
    t->hash.fill = size ? (double)n / (double)size : 1.0;
    if (r->bad) return BAD(why, "vmf section too short");
    prt_error e;
    if (vmft_index(t, &e)) return r->bad = r->oom = true, BAD(why, "vmf: out of memory");
    return true;
}

static bool vmf_read(prt_reader *r, prt_transfer *tr, char *why) {
    vmf_config c = { 0 };
    c.lobes = prtio_get_i32(r), c.level = prtio_get_i32(r), c.samples = prtio_get_i32(r), c.level_set = true;
    memset(&tr->cfg, 0, sizeof tr->cfg);
    memcpy(tr->cfg.bytes, &c, sizeof c);
    tr->materials = prtio_get_u64(r);
    int passes = prtio_get_i32(r), nverts = prtio_get_i32(r), nviews = prtio_get_i32(r);
    if (r->bad) return BAD(why, "vmf section too short");
    if (c.lobes < 1 || c.lobes > VMFT_MAX_LOBES) return BAD(why, "vmf: bad lobe count %d", c.lobes);
    if (c.level < 0 || c.level > GEOGRID_MAX_LEVEL) return BAD(why, "vmf: bad grid level %d", c.level);
    if (passes < 1 || passes > VMFT_MAX_PASSES) return BAD(why, "vmf: bad pass count %d", passes);
    if (nverts < 1 || nverts > INT32_MAX / 3) return BAD(why, "vmf: bad vertex count %d", nverts);
    vmft_data *t = calloc(1, sizeof *t);
    prt_error e;
    if (!t || vmft_init(t, c.level, c.lobes, nverts, &e)) {
        free(t);
        r->bad = r->oom = true;
        return BAD(why, "vmf: out of memory");
    }
    tr->priv = t;
    if (nviews != t->nviews) return BAD(why, "vmf: %d views for grid level %d (expected %d)", nviews, t->level, t->nviews);
    t->passes = passes, t->samples = c.samples, t->materials = tr->materials;
    t->horizon = prtio_get_f32(r);
    t->slices = prtio_get_u64(r);
    for (int p = 0; p < VMFT_MAX_PASSES; p++) t->t_pass[p] = prtio_get_f64(r);
    for (int p = 0; p < VMFT_MAX_PASSES; p++) t->energy[p] = prtio_get_f64(r);
    for (int m = 0; m < PRT_MAX_MATERIALS; m++)
        if (((tr->materials >> m) & 1) && !get_fit(r, &t->fit[m], why)) return false;
    return vmf_read_arrays(r, t, why);
}

/* Every fitted material matches the scene's model; every lobe of its table finite, kappa, alpha >= 0. */
static bool fits_ok(const prt_data *d, const vmft_data *t, char *why) {
    for (int m = 0; m < PRT_MAX_MATERIALS; m++) {
        if (!((t->materials >> m) & 1)) continue;
        const lobefit_table *f = &t->fit[m];
        if (m >= d->scene.nmaterials || f->type != d->scene.materials[m].type || !lobefit_supported(f->type))
            return BAD(why, "vmf: material %d's lobe fit does not match its BRDF", m);
        for (int v = 0; v < f->views; v++) {
            const vmf_lobe *l = &f->lobe[v];
            float x[] = { f->theta[v], l->mu[0], l->mu[1], l->mu[2], l->kappa, f->alpha[v][0], f->alpha[v][1], f->alpha[v][2] };
            double len = sqrt((double)l->mu[0] * l->mu[0] + (double)l->mu[1] * l->mu[1] + (double)l->mu[2] * l->mu[2]);
            if (!prtio_all_finite(x, 8) || !(l->kappa >= 0) || fabs(len - 1) > 1e-3 || x[5] < 0 || x[6] < 0 || x[7] < 0)
                return BAD(why, "vmf: material %d's lobe fit has a bad lobe at view %d", m, v);
        }
    }
    return true;
}

/* The hash: offsets leave room for every column, owners name rows whose offset puts them there,
 * and whose material the transfer shades; entries number the owned slots in slot order (so each
 * names a distinct lobe set); n matches; every stored lobe finite with kappa, alpha >= 0. */
static bool hash_ok(const prt_data *d, const vmft_data *t, char *why) {
    const phash_table *h = &t->hash;
    for (int v = 0; v < t->nverts; v++)
        if (h->offset[v] > UINT32_MAX - (uint32_t)t->nviews) return BAD(why, "vmf: vertex %d's hash offset %u out of range", v, h->offset[v]);
    size_t owned = 0, per = (size_t)(t->passes * t->lobes);
    for (size_t s = 0; s < h->size; s++) {
        uint32_t o = h->owner[s];
        if (!o) continue;
        if (o > (uint32_t)t->nverts) return BAD(why, "vmf: hash slot %zu names vertex %u of %d", s, o - 1, t->nverts);
        if (s < h->offset[o - 1] || s - h->offset[o - 1] >= (size_t)t->nviews)
            return BAD(why, "vmf: hash slot %zu is outside vertex %u's row", s, o - 1);
        if (!((t->materials >> d->scene.mesh.mat[o - 1]) & 1)) return BAD(why, "vmf: vertex %u has lobes but another transfer's material", o - 1);
        if (t->entry[s] != owned) return BAD(why, "vmf: hash slot %zu names entry %u, expected %zu", s, t->entry[s], owned);
        owned++;
    }
    for (size_t s = 0; s < h->size; s++)
        if (!h->owner[s] && t->entry[s] != UINT32_MAX) return BAD(why, "vmf: free hash slot %zu names entry %u", s, t->entry[s]);
    if (owned != h->n) return BAD(why, "vmf: hash holds %zu slices, header says %zu", owned, h->n);
    for (size_t i = 0; i < h->n * per; i++) {
        vmf_lobe l;
        float a[3];
        vmft_unpack(t->lobe + i * VMFT_WORDS, &l, a);
        if (!isfinite(l.kappa) || l.kappa < 0 || !prtio_all_finite(a, 3) || a[0] < 0 || a[1] < 0 || a[2] < 0)
            return BAD(why, "vmf: slice %zu has a bad lobe (kappa %g, alpha %g %g %g)", i / per, l.kappa, a[0], a[1], a[2]);
    }
    return true;
}

static bool vmf_validate(const prt_data *d, const prt_transfer *tr, char *why) {
    if (!tr->priv) return BAD(why, "vmf transfer has no data");
    const vmft_data *t = vmft_get(tr);
    if (t->nverts != d->scene.mesh.nverts) return BAD(why, "vmf: %d vertices, the mesh has %d", t->nverts, d->scene.mesh.nverts);
    vmf_config c = vmft_config(&tr->cfg);
    if (t->materials != tr->materials || t->lobes != c.lobes || t->level != c.level)
        return BAD(why, "vmf: data and config disagree");
    if (c.samples < 4 || c.samples > VMFT_MAX_SAMPLES) return BAD(why, "vmf: bad sample count %d", c.samples);
    double st[2 * VMFT_MAX_PASSES + 1] = { t->horizon };
    for (int p = 0; p < VMFT_MAX_PASSES; p++) st[1 + p] = t->t_pass[p], st[1 + VMFT_MAX_PASSES + p] = t->energy[p];
    for (int i = 0; i < 2 * VMFT_MAX_PASSES + 1; i++)
        if (!isfinite(st[i])) return BAD(why, "vmf: non-finite statistics");
    if (!(t->horizon >= 0 && t->horizon <= 1)) return BAD(why, "vmf: bad horizon %g", t->horizon);
    return fits_ok(d, t, why) && hash_ok(d, t, why);
}

static const transfer_view k_view = {
    .fit = vmf_fit,
    .precompute = vmf_precompute,
    .estimate = vmf_estimate,
    .resumed = vmf_resumed,
    .settle = vmf_settle,
    .shade_vertices = vmf_shade_vertices,
    .glsl = &transfer_vmf_glsl_view,
};

const transfer_ops transfer_vmf = {
    .name = "vmf",
    .title = "vMF lobes",
    .label = "vMF",
    .tag = TRANSFER_TAG('V', 'M', 'F', 'L'),
    .kind = TRANSFER_VIEW,
    .options = k_options,
    .configure = vmf_configure,
    .describe = vmf_describe,
    .write = vmf_write,
    .read = vmf_read,
    .validate = vmf_validate,
    .release = vmf_release,
    .bytes = vmf_bytes,
    .summary = vmf_summary,
    .view = &k_view,
};
