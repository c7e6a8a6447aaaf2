/* reference.c - a path tracer that gives PRT its ground truth (reference.h).
 *
 * PRT approximates Eq. 2 (and the bounce passes of section 3.2) four ways: the
 * BRDF by K separable terms (Eq. 1), the lighting and transport by N wavelet
 * coefficients on a 6x64x64 cube, visibility by a 128-res ray-cast cube, and
 * colours by per-vertex Gouraud shading. To measure those errors we need the
 * same integral computed without any of them: analytic BRDFs, the probe at its
 * full resolution, exact ray-traced visibility, unbiased Monte Carlo.
 *
 * The estimator is the textbook one (Veach 1997; Pharr, Jakob & Humphreys,
 * "Physically Based Rendering", ch. 13-14): at every surface point next-event
 * estimation of the distant environment, combining environment importance
 * sampling and BRDF importance sampling with the power heuristic; the BRDF sample
 * also continues the path for interreflections. Light only comes from the
 * environment (no emitters), surfaces are one-sided with the interpolated vertex
 * normal as shading normal, exactly what PRT's transport (Eq. 3, 6-8) assumes.
 *
 * Environment sampling uses a latitude-longitude grid in the probe's frame
 * (for a latlong probe: its own pixels), cells drawn in O(1) by Walker's alias
 * method (Vose's construction; a CDF binary search costs a quarter of the run time
 * in cache misses over 512K cells). Within a cell, directions are uniform in
 * solid angle (phi uniform, cos(theta) uniform), so the pdf is exactly
 * P(cell) / Omega(cell) with Omega(cell) = dphi (cos theta0 - cos theta1): the
 * estimator stays unbiased whatever probe_eval's filter does inside the cell, as
 * long as P(cell) > 0 wherever the radiance is; the 3x3 neighbourhood maximum in the
 * weights guarantees that for a bilinear lookup.
 *
 * Random numbers: PCG32 (O'Neill 2014, the reference "pcg32_random_r"
 * algorithm), one stream per pixel or vertex, so results are reproducible for a
 * seed regardless of threads. */
#include "reference.h"
#include "brdf.h"
#include "vec3.h"
#include "visibility.h"
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define REF_PI 3.14159265358979323846
#define REF_MAX_DEPTH 512      /* hard cap for Russian roulette paths (survival <= 0.95: 0.95^512 ~ 4e-12) */
#define REF_RR_DEPTH 3         /* Russian roulette starts after this many bounces */
#define REF_MAX_THREADS 64

/* Alias-table entry: keep cell i with probability prob, else take alias; the pdfs of both
 * outcomes ride along so a draw touches one 16-byte entry. */
struct ref_alias { float prob; uint32_t alias; float pdf, pdf_alias; };

struct ref_ctx {
    const prt_scene *scene;
    const prt_probe *probe;
    vis_scene *vs;
    float eps;
    float R[9];           /* world = R * probe frame */
    /* Environment distribution over an ew x eh latlong grid in the probe frame. */
    int ew, eh;
    double total;         /* sum of cell weights (0: black probe, no environment sampling) */
    struct ref_alias *table; /* [eh*ew] Walker/Vose alias table (O(1) sampling, one cache line per draw) */
    float *cell_pdf;      /* [eh*ew] solid-angle pdf of each cell: P(cell) / Omega(cell) */
    double *cos_edge;     /* [eh+1] cos(theta) at row edges, from +1 (zenith) down to -1 */
};

/* ---------- PCG32 ---------- */

typedef struct pcg32 { uint64_t state, inc; } pcg32;

static uint32_t pcg32_next(pcg32 *r) {
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xs = (uint32_t)(((old >> 18u) ^ old) >> 27u), rot = (uint32_t)(old >> 59u);
    return (xs >> rot) | (xs << ((-rot) & 31u));
}

static void pcg32_seed(pcg32 *r, uint64_t initstate, uint64_t initseq) {
    r->state = 0;
    r->inc = (initseq << 1u) | 1u;
    pcg32_next(r);
    r->state += initstate;
    pcg32_next(r);
}

/* Uniform float in [0,1) (24 bits). */
static float pcg32_float(pcg32 *r) { return (float)(pcg32_next(r) >> 8) * 0x1p-24f; }

/* SplitMix64 finalizer: decorrelates user seeds (0, 1, 2...) before seeding PCG. */
static uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* ---------- environment ---------- */

/* Probe-frame direction of continuous latlong coordinates (u, cos theta) (probe.h's convention:
 * u = 0.5 + atan2(d.x, -d.z) / 2pi, v = acos(d.y) / pi). */
static void latlong_dir(double u, double cos_t, float d[3]) {
    double phi = 2 * REF_PI * (u - 0.5), s = sqrt(fmax(0.0, 1 - cos_t * cos_t));
    d[0] = (float)(s * sin(phi));
    d[1] = (float)cos_t;
    d[2] = (float)(-s * cos(phi));
}

static void mat3_mul(const float R[9], const float a[3], float o[3]) {
    float x = R[0] * a[0] + R[1] * a[1] + R[2] * a[2], y = R[3] * a[0] + R[4] * a[1] + R[5] * a[2],
          z = R[6] * a[0] + R[7] * a[1] + R[8] * a[2];
    o[0] = x; o[1] = y; o[2] = z;
}
static void mat3_tmul(const float R[9], const float a[3], float o[3]) {
    float x = R[0] * a[0] + R[3] * a[1] + R[6] * a[2], y = R[1] * a[0] + R[4] * a[1] + R[7] * a[2],
          z = R[2] * a[0] + R[5] * a[1] + R[8] * a[2];
    o[0] = x; o[1] = y; o[2] = z;
}

/* Radiance of the rotated environment toward world direction w (a light at d moves to R d). */
void ref_env_radiance(const ref_ctx *rc, const float w[3], float rgb[3]) {
    float d[3];
    mat3_tmul(rc->R, w, d);
    probe_eval(rc->probe, d, rgb);
}

/* True when p is a 2:1 latlong probe whose pixel centres agree with our mapping
 * (probe_pixel_dir against latlong_dir on a few pixels), so its pixels are the cells. */
static bool env_use_pixels(const prt_probe *p) {
    if (!(p->layout == PROBE_LATLONG && p->img.w == 2 * p->img.h && p->img.w >= 2)) return false;
    int W = p->img.w, H = p->img.h;
    int xs[3] = { 0, W / 3, W - 1 }, ys[3] = { 0, H / 2, H - 1 };
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            float d[3], dw, e[3];
            if (!probe_pixel_dir(p, xs[a], ys[b], d, &dw)) return false;
            latlong_dir((xs[a] + 0.5) / W, cos(REF_PI * (ys[b] + 0.5) / H), e);
            if (fabsf(d[0] - e[0]) + fabsf(d[1] - e[1]) + fabsf(d[2] - e[2]) > 1e-3f) return false;
        }
    return true;
}

/* Fills lum[eh][ew] with each cell's luminance (probe pixels, or probe_eval at cell centres),
 * floored at 1e-3 of its largest channel so any positive channel gives a positive weight. */
static void env_luminance(const ref_ctx *rc, bool use_pixels, float *lum) {
    const prt_probe *p = rc->probe;
    const int ew = rc->ew, eh = rc->eh;
    for (int y = 0; y < eh; y++)
        for (int x = 0; x < ew; x++) {
            float c[3];
            if (use_pixels) {
                const float *px = p->img.data + ((size_t)y * p->img.w + x) * p->img.c;
                c[0] = px[0]; c[1] = px[1]; c[2] = px[2];
            } else {
                float d[3];
                latlong_dir((x + 0.5) / ew, cos(REF_PI * (y + 0.5) / eh), d);
                probe_eval(p, d, c);
            }
            float l = prt_luminancef(c);
            /* Any positive channel must give a positive weight (a pure blue light has tiny luminance). */
            float mx = fmaxf(c[0], fmaxf(c[1], c[2]));
            lum[(size_t)y * ew + x] = isfinite(l) && mx > 0 ? fmaxf(l, 1e-3f * mx) : 0.f;
        }
}

/* Fills wgt with each cell's sampling weight, its exact solid angle times the mean of its
 * luminance and the 3x3 maximum around it (dilation); returns their sum. */
static double env_weights(const ref_ctx *rc, const float *lum, double *wgt) {
    const int ew = rc->ew, eh = rc->eh;
    double dphi = 2 * REF_PI / ew, total = 0;
    for (int y = 0; y < eh; y++) {
        double omega = dphi * (rc->cos_edge[y] - rc->cos_edge[y + 1]);
        for (int x = 0; x < ew; x++) {
            float m = 0;
            for (int dy = -1; dy <= 1; dy++) {
                int yy = y + dy;
                if (yy < 0 || yy >= eh) continue;
                for (int dx = -1; dx <= 1; dx++) {
                    int xx = (x + dx + ew) % ew;
                    m = fmaxf(m, lum[(size_t)yy * ew + xx]);
                }
            }
            double w = omega * (0.5 * lum[(size_t)y * ew + x] + 0.5 * m);
            wgt[(size_t)y * ew + x] = w;
            total += w;
        }
    }
    return total;
}

/* Fills rc->cell_pdf and the alias table from the weights (total > 0); wgt is overwritten,
 * work is scratch of ew*eh entries. Vose's alias method: scaled probabilities n p_i;
 * "small" cells (< 1) are topped up by one "large" cell each. */
static void env_alias(ref_ctx *rc, double *wgt, uint32_t *work, double total) {
    const int ew = rc->ew, eh = rc->eh;
    const size_t ncell = (size_t)ew * eh;
    double dphi = 2 * REF_PI / ew;
    for (int y = 0; y < eh; y++) {
        double omega = dphi * (rc->cos_edge[y] - rc->cos_edge[y + 1]);
        for (int x = 0; x < ew; x++)
            rc->cell_pdf[(size_t)y * ew + x] = (float)(wgt[(size_t)y * ew + x] / total / omega);
    }
    /* work holds the small stack from the bottom, large from the top. */
    size_t ns = 0, nl = ncell;
    for (size_t i = 0; i < ncell; i++) {
        wgt[i] = wgt[i] / total * (double)ncell;
        if (wgt[i] < 1.0) work[ns++] = (uint32_t)i;
        else work[--nl] = (uint32_t)i;
    }
    while (ns > 0 && nl < ncell) {
        uint32_t sm = work[--ns], lg = work[nl];
        rc->table[sm].prob = (float)wgt[sm];
        rc->table[sm].alias = lg;
        wgt[lg] -= 1.0 - wgt[sm];
        if (wgt[lg] < 1.0) { nl++; work[ns++] = lg; }
    }
    /* Leftovers are 1 up to rounding. */
    while (nl < ncell) { uint32_t i = work[nl++]; rc->table[i].prob = 1.f; rc->table[i].alias = i; }
    while (ns > 0) { uint32_t i = work[--ns]; rc->table[i].prob = 1.f; rc->table[i].alias = i; }
    for (size_t i = 0; i < ncell; i++) {
        rc->table[i].pdf = rc->cell_pdf[i];
        rc->table[i].pdf_alias = rc->cell_pdf[rc->table[i].alias];
    }
}

/* Builds the sampling grid: cell luminances (probe pixels for a latlong probe whose
 * pixel centres agree with our mapping, else probe_eval at a grid of cell centres),
 * dilated by the 3x3 maximum, times exact cell solid angles, into CDFs. */
static int env_build(ref_ctx *rc, prt_error *err) {
    const prt_probe *p = rc->probe;
    bool use_pixels = env_use_pixels(p);
    if (use_pixels) { rc->ew = p->img.w; rc->eh = p->img.h; }
    else {
        int m = p->img.w > p->img.h ? p->img.w : p->img.h;
        rc->ew = m < 64 ? 128 : (m > 1024 ? 2048 : 2 * m);
        rc->eh = rc->ew / 2;
    }
    const int eh = rc->eh;
    size_t ncell = (size_t)rc->ew * eh;
    float *lum = prt_calloc(ncell, sizeof(float), err);
    double *wgt = prt_calloc(ncell, sizeof(double), err);
    uint32_t *work = prt_calloc(ncell, sizeof(uint32_t), err);
    rc->table = prt_calloc(ncell, sizeof *rc->table, err);
    rc->cell_pdf = prt_calloc(ncell, sizeof(float), err);
    rc->cos_edge = prt_calloc((size_t)eh + 1, sizeof(double), err);
    if (!lum || !wgt || !work || !rc->table || !rc->cell_pdf || !rc->cos_edge) {
        free(lum); free(wgt); free(work);
        return -1;
    }
    for (int y = 0; y <= eh; y++) rc->cos_edge[y] = cos(REF_PI * y / eh);
    rc->cos_edge[0] = 1.0;
    rc->cos_edge[eh] = -1.0;
    env_luminance(rc, use_pixels, lum);
    rc->total = env_weights(rc, lum, wgt);
    if (rc->total > 0) env_alias(rc, wgt, work, rc->total);
    free(lum);
    free(wgt);
    free(work);
    return 0;
}

/* Samples the environment: direction w (world) and its solid-angle pdf. */
bool ref_env_sample(const ref_ctx *rc, const float u[4], float w[3], float *pdf) {
    if (rc->total <= 0) { *pdf = 0; return false; }
    size_t ncell = (size_t)rc->ew * rc->eh, i = (size_t)(u[0] * (double)ncell);
    if (i >= ncell) i = ncell - 1;
    const struct ref_alias *e = &rc->table[i];
    float p = e->pdf;
    if (u[1] >= e->prob) { i = e->alias; p = e->pdf_alias; }
    int y = (int)(i / rc->ew), x = (int)(i % rc->ew);
    if (!(p > 0)) { *pdf = 0; return false; }
    double cos_t = rc->cos_edge[y] + (rc->cos_edge[y + 1] - rc->cos_edge[y]) * u[3];
    float d[3];
    latlong_dir((x + u[2]) / rc->ew, cos_t, d);
    mat3_mul(rc->R, d, w);
    v3_normalize(w);
    *pdf = p;
    return true;
}

/* Solid-angle pdf with which ref_env_sample returns world direction w. */
float ref_env_pdf(const ref_ctx *rc, const float w[3]) {
    if (rc->total <= 0) return 0;
    float d[3];
    mat3_tmul(rc->R, w, d);
    double u = 0.5 + atan2(d[0], -d[2]) / (2 * REF_PI);
    double cy = d[1] > 1 ? 1 : (d[1] < -1 ? -1 : d[1]);
    int x = (int)floor(u * rc->ew), y = (int)floor(acos(cy) / REF_PI * rc->eh);
    if (x < 0) x = 0;
    if (x >= rc->ew) x = rc->ew - 1;
    if (y < 0) y = 0;
    if (y >= rc->eh) y = rc->eh - 1;
    return rc->cell_pdf[(size_t)y * rc->ew + x];
}

/* ---------- context ---------- */

/* Builds the BVH and the environment distribution (see header). */
ref_ctx *ref_create(const prt_scene *scene, const prt_probe *probe, const float R[9], prt_error *err) {
    if (!scene || scene->mesh.nverts <= 0 || scene->mesh.ntris <= 0) { prt_fail(err, "reference: the scene has no triangles"); return NULL; }
    if (scene->nmaterials <= 0) { prt_fail(err, "reference: the scene has no materials"); return NULL; }
    if (!probe || !probe->img.data || probe->img.w < 1 || probe->img.h < 1) { prt_fail(err, "reference: empty probe"); return NULL; }
    ref_ctx *rc = prt_calloc(1, sizeof *rc, err);
    if (!rc) return NULL;
    rc->scene = scene;
    rc->probe = probe;
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    memcpy(rc->R, R ? R : I, sizeof rc->R);
    rc->vs = vis_create(&scene->mesh, err);
    if (!rc->vs) { ref_destroy(rc); return NULL; }
    rc->eps = vis_eps(rc->vs);
    if (env_build(rc, err)) { ref_destroy(rc); return NULL; }
    return rc;
}

/* Frees everything the context owns (not the scene or probe). */
void ref_destroy(ref_ctx *rc) {
    if (!rc) return;
    if (rc->vs) vis_destroy(rc->vs);
    free(rc->table);
    free(rc->cell_pdf);
    free(rc->cos_edge);
    free(rc);
}

/* ---------- path tracing ---------- */

typedef struct ref_surf {
    float p[3];
    float ns[3];       /* shading normal (unit) */
    float ng[3];       /* unit geometric normal, or the shading normal at a vertex */
    bool at_vertex;    /* offsets along +ns as vis_cube does, regardless of direction */
    int mat;
    float albedo[3];   /* its material's texture here (texture.h): multiplies kd; 1,1,1 untextured */
} ref_surf;

/* Ray origin for leaving s in direction w: offset by eps along the geometric normal, on w's side. */
static void ray_origin(const ref_ctx *rc, const ref_surf *s, const float w[3], float o[3]) {
    float sgn = s->at_vertex || v3_dot(s->ng, w) >= 0 ? 1.f : -1.f;
    v3_madd(o, s->p, s->ng, sgn * rc->eps);
}

static void local_to_world(const float S[3], const float T[3], const float N[3], const float l[3], float w[3]) {
    for (int i = 0; i < 3; i++) w[i] = S[i] * l[0] + T[i] * l[1] + N[i] * l[2];
}

/* Fills s from a ray hit: barycentric position, interpolated vertex normal, material of the first vertex. */
static void surf_from_hit(const ref_ctx *rc, const vis_hit *h, const float dir[3], ref_surf *s) {
    const prt_mesh *m = &rc->scene->mesh;
    const uint32_t *t = m->tris + 3 * (size_t)h->tri;
    float b0 = 1.f - h->u - h->v, b[3] = { b0, h->u, h->v };
    for (int c = 0; c < 3; c++) {
        s->p[c] = 0;
        s->ns[c] = 0;
        for (int k = 0; k < 3; k++) {
            s->p[c] += b[k] * m->pos[3 * t[k] + c];
            s->ns[c] += b[k] * m->nrm[3 * t[k] + c];
        }
    }
    v3_copy(s->ng, h->ng);
    if (v3_normalize(s->ng) == 0.f) v3_scale(s->ng, dir, -1.f);
    if (v3_normalize(s->ns) == 0.f) {
        /* Opposite normals cancelled: fall back to the geometric normal facing the ray. */
        v3_copy(s->ns, s->ng);
        if (v3_dot(s->ns, dir) > 0) v3_scale(s->ns, s->ns, -1.f);
    }
    s->at_vertex = false;
    int mat = m->mat ? m->mat[t[0]] : 0;
    s->mat = mat < rc->scene->nmaterials ? mat : 0;
    const scene_texture *tx = scene_material_tex(rc->scene, s->mat);
    s->albedo[0] = s->albedo[1] = s->albedo[2] = 1;
    if (tx) {   /* the texture at the hit's interpolated coordinates */
        float uv[2] = { 0, 0 };
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 2; c++) uv[c] += b[k] * m->uv[2 * (size_t)t[k] + c];
        texture_sample(tx, uv[0], uv[1], s->albedo);
    }
}

static float max3(const float a[3]) { return fmaxf(a[0], fmaxf(a[1], a[2])); }

/* Next-event estimation at s (frame S, T, s->ns; outgoing wol local): one environment
 * sample, weighted by the power heuristic against the BRDF pdf when mis, adds
 * beta f Le cos / pdf to L. Consumes 4 random numbers; returns the rays traced (0 or 1). */
static long env_nee(const ref_ctx *rc, const ref_surf *s, const float S[3], const float T[3], const float wol[3],
                    const brdf_params *bp, bool mis, pcg32 *rng, const float beta[3], float L[3]) {
    float u[4] = { pcg32_float(rng), pcg32_float(rng), pcg32_float(rng), pcg32_float(rng) }, wi[3], pl;
    if (!ref_env_sample(rc, u, wi, &pl)) return 0;
    float wil[3];
    brdf_to_local(S, T, s->ns, wi, wil);
    if (wil[2] <= 0.f) return 0;
    float f[3];
    brdf_eval(bp, wil, wol, f);
    if (!(max3(f) > 0.f)) return 0;
    float o[3];
    ray_origin(rc, s, wi, o);
    if (vis_occluded(rc->vs, o, wi, rc->eps, INFINITY)) return 1;
    float Le[3];
    ref_env_radiance(rc, wi, Le);
    float wgt = 1.f;
    if (mis) {
        float pb = brdf_pdf(bp, wol, wil);
        wgt = pl * pl / (pl * pl + pb * pb);
    }
    float k = wgt * wil[2] / pl;
    for (int c = 0; c < 3; c++) L[c] += beta[c] * f[c] * Le[c] * k;
    return 1;
}

/* Next-event estimation of every local light at s: a delta light is sampled with
 * probability 1 and no other strategy can hit it, so it needs no MIS weight; adds
 * beta f I cos / d^2 V per light (lights.h: light_shade). Returns the shadow rays traced. */
static long lights_nee(const ref_ctx *rc, const ref_surf *s, const float wo[3], const brdf_params *bp,
                       const float beta[3], float L[3]) {
    const prt_lights *ls = &rc->scene->lights;
    long rays = 0;
    for (int i = 0; i < ls->count; i++) {
        float wi[3], Ll[3];
        float dist = light_shade(&ls->light[i], bp, s->p, s->ns, wo, wi, Ll);
        if (!(max3(Ll) > 0.f)) continue;
        float o[3];
        ray_origin(rc, s, wi, o);
        rays++;
        float tfar = dist - 2 * rc->eps;
        if (tfar > rc->eps && vis_occluded(rc->vs, o, wi, rc->eps, tfar)) continue;
        for (int c = 0; c < 3; c++) L[c] += beta[c] * Ll[c];
    }
    return rays;
}

/* One sample of outgoing radiance from s toward world direction wo (unit), into out.
 * Returns the number of rays traced. */
static long trace_path(const ref_ctx *rc, const ref_surf *s0, const float wo0[3], const ref_desc *d, pcg32 *rng,
                       float out[3]) {
    long rays = 0;
    float beta[3] = { 1, 1, 1 }, L[3] = { 0, 0, 0 }, wo[3];
    ref_surf s = *s0;
    v3_copy(wo, wo0);
    const bool use_env = d->strategy != REF_BRDF_ONLY && rc->total > 0;
    const bool use_brdf_light = d->strategy != REF_ENV_ONLY;
    const bool mis = d->strategy == REF_MIS;
    /* bounces of the environment's light and of the local lights' (-1: unlimited); the path goes on
     * while either wants more */
    const int envb = d->bounces, lightb = d->light_depth > 0 ? d->light_depth - 1 : d->bounces;
    const int maxb = envb < 0 || lightb < 0 ? -1 : envb > lightb ? envb : lightb;
    for (int depth = 0; depth < REF_MAX_DEPTH; depth++) {
        const brdf_params *bp = &rc->scene->materials[s.mat];
        brdf_params textured;
        if (s.albedo[0] != 1 || s.albedo[1] != 1 || s.albedo[2] != 1) {   /* the texture multiplies kd here */
            textured = *bp;
            for (int c = 0; c < 3; c++) textured.kd[c] *= s.albedo[c];
            bp = &textured;
        }
        float S[3], T[3], wol[3];
        brdf_frame(s.ns, S, T);
        brdf_to_local(S, T, s.ns, wo, wol);
        if (wol[2] <= 0.f) break;   /* one-sided: seen from below the shading horizon */
        const bool cont = maxb < 0 || depth < maxb;
        const bool env_here = envb < 0 || depth <= envb, lights_here = lightb < 0 || depth <= lightb;
        /* Strategy 1: environment sample (next-event estimation). */
        if (use_env && env_here) rays += env_nee(rc, &s, S, T, wol, bp, mis, rng, beta, L);
        if (lights_here) rays += lights_nee(rc, &s, wo, bp, beta, L);
        /* Strategy 2: BRDF sample; it also carries the path on. */
        if (!(use_brdf_light && env_here) && !cont) break;
        float u1 = pcg32_float(rng), u2 = pcg32_float(rng), wil[3], pb;
        if (!brdf_sample(bp, wol, u1, u2, wil, &pb) || !(pb > 0.f) || wil[2] <= 0.f) break;
        float f[3], wi[3], o[3];
        brdf_eval(bp, wil, wol, f);
        if (!(max3(f) > 0.f)) break;
        local_to_world(S, T, s.ns, wil, wi);
        v3_normalize(wi);
        float k = wil[2] / pb, thr[3] = { f[0] * k, f[1] * k, f[2] * k };
        ray_origin(rc, &s, wi, o);
        rays++;
        vis_hit hit;
        bool hit_any;
        if (cont) hit_any = vis_closest(rc->vs, o, wi, rc->eps, INFINITY, &hit);
        else hit_any = vis_occluded(rc->vs, o, wi, rc->eps, INFINITY);
        if (!hit_any) {
            if (use_brdf_light && env_here) {
                float Le[3], wgt = 1.f;
                ref_env_radiance(rc, wi, Le);
                if (mis && rc->total > 0) {
                    float pl = ref_env_pdf(rc, wi);
                    wgt = pb * pb / (pb * pb + pl * pl);
                }
                for (int c = 0; c < 3; c++) L[c] += beta[c] * thr[c] * Le[c] * wgt;
            }
            break;
        }
        if (!cont) break;
        for (int c = 0; c < 3; c++) beta[c] *= thr[c];
        if (maxb < 0 && depth + 1 >= REF_RR_DEPTH) {
            float q = fminf(0.95f, max3(beta));
            if (!(q > 0.f) || pcg32_float(rng) >= q) break;
            for (int c = 0; c < 3; c++) beta[c] /= q;
        }
        surf_from_hit(rc, &hit, wi, &s);
        v3_scale(wo, wi, -1.f);
    }
    v3_copy(out, L);
    return rays;
}

/* ---------- parallel drivers ---------- */

typedef struct ref_job {
    const ref_ctx *rc;
    const ref_desc *d;
    int spp;
    uint64_t seed;
    /* vertices */
    const int *verts;
    float eye[3];
    /* image */
    const prt_camera *cam;
    int w, h, y0;           /* image size; the first row rendered (img and se start at it) */
    float *img;
    /* outputs */
    float *rgb, *se;
    long n;
    long rays[REF_MAX_THREADS], dropped[REF_MAX_THREADS];
    atomic_long done;
    atomic_bool cancel;
    pthread_mutex_t lock;
    const char *stage;
} ref_job;

/* Mean and standard error of spp samples of one item (Welford in double). */
typedef struct ref_acc { double mean[3], m2[3]; int n; } ref_acc;
static void acc_add(ref_acc *a, const float x[3]) {
    a->n++;
    for (int c = 0; c < 3; c++) {
        double dlt = x[c] - a->mean[c];
        a->mean[c] += dlt / a->n;
        a->m2[c] += dlt * (x[c] - a->mean[c]);
    }
}
static void acc_out(const ref_acc *a, int spp, float *mean, float *se) {
    for (int c = 0; c < 3; c++) {
        /* Dropped samples count as zero so the estimator keeps its 1/spp normalization. */
        double m = a->n ? a->mean[c] * a->n / spp : 0;
        mean[c] = (float)m;
        if (se) {
            double var = a->n > 1 ? a->m2[c] / (a->n - 1) : 0;
            se[c] = (float)sqrt(var / spp);
        }
    }
}

static void job_progress(ref_job *j, long items) {
    atomic_fetch_add(&j->done, items);
    if (!j->d->progress) return;
    pthread_mutex_lock(&j->lock);
    long done = atomic_load(&j->done);   /* read under the lock, so the fractions reported rise */
    if (!j->d->progress(j->d->progress_user, j->stage, (double)done / (double)j->n)) atomic_store(&j->cancel, true);
    pthread_mutex_unlock(&j->lock);
}

/* Shading normal of vertex v (unit; +y for a zero normal) and its unit direction toward eye
 * (the normal itself when eye is on the vertex). */
static void vertex_frame(const prt_mesh *m, int v, const float eye[3], float n[3], float wo[3]) {
    v3_copy(n, m->nrm + 3 * (size_t)v);
    if (v3_normalize(n) == 0.f) v3_set(n, 0, 1, 0);
    v3_sub(wo, eye, m->pos + 3 * (size_t)v);
    if (v3_normalize(wo) == 0.f) v3_copy(wo, n);
}

/* True when v's normal faces eye (the same test trace_path applies). */
bool ref_vertex_faces(const prt_mesh *m, int v, const float eye[3]) {
    float n[3], wo[3];
    vertex_frame(m, v, eye, n, wo);
    return v3_dot(n, wo) > 0.f;
}

static void vertex_range(void *ctx, int begin, int end, int thread) {
    ref_job *j = ctx;
    if (atomic_load(&j->cancel)) return;
    const prt_mesh *m = &j->rc->scene->mesh;
    for (int i = begin; i < end; i++) {
        int v = j->verts ? j->verts[i] : i;
        ref_surf s;
        float wo[3];
        v3_copy(s.p, m->pos + 3 * (size_t)v);
        vertex_frame(m, v, j->eye, s.ns, wo);
        v3_copy(s.ng, s.ns);
        s.at_vertex = true;
        int mat = m->mat ? m->mat[v] : 0;
        s.mat = mat < j->rc->scene->nmaterials ? mat : 0;
        scene_vertex_albedo(j->rc->scene, v, s.albedo);
        pcg32 rng;
        pcg32_seed(&rng, j->seed, (uint64_t)v);
        ref_acc a = { { 0 }, { 0 }, 0 };
        for (int k = 0; k < j->spp; k++) {
            float x[3];
            j->rays[thread] += trace_path(j->rc, &s, wo, j->d, &rng, x);
            if (isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2])) acc_add(&a, x);
            else j->dropped[thread]++;
        }
        acc_out(&a, j->spp, j->rgb + 3 * (size_t)i, j->se ? j->se + 3 * (size_t)i : NULL);
    }
    job_progress(j, end - begin);
}

static void image_rows(void *ctx, int begin, int end, int thread) {
    ref_job *j = ctx;
    if (atomic_load(&j->cancel)) return;
    for (int y = begin; y < end; y++)
        for (int x = 0; x < j->w; x++) {
            size_t idx = (size_t)y * j->w + x, at = idx - (size_t)j->y0 * j->w;
            pcg32 rng;
            pcg32_seed(&rng, j->seed, (uint64_t)idx);
            ref_acc a = { { 0 }, { 0 }, 0 };
            /* Background as prt render draws it: the probe along the pixel-centre ray, so that
             * background pixels compare equal and prt compare measures the surfaces. */
            float bg[3] = { 0, 0, 0 };
            if (!j->d->black_background) {
                float cdir[3];
                camera_ray(j->cam, j->w, j->h, x + 0.5f, y + 0.5f, cdir);
                v3_normalize(cdir);
                ref_env_radiance(j->rc, cdir, bg);
            }
            for (int k = 0; k < j->spp; k++) {
                float dir[3], xr[3];
                float px = x + pcg32_float(&rng), py = y + pcg32_float(&rng);
                camera_ray(j->cam, j->w, j->h, px, py, dir);
                v3_normalize(dir);
                vis_hit hit;
                j->rays[thread]++;
                if (!vis_closest(j->rc->vs, j->cam->eye, dir, 0.f, INFINITY, &hit)) v3_copy(xr, bg);
                else {
                    ref_surf s;
                    surf_from_hit(j->rc, &hit, dir, &s);
                    float wo[3];
                    v3_scale(wo, dir, -1.f);
                    j->rays[thread] += trace_path(j->rc, &s, wo, j->d, &rng, xr);
                }
                if (isfinite(xr[0]) && isfinite(xr[1]) && isfinite(xr[2])) acc_add(&a, xr);
                else j->dropped[thread]++;
            }
            acc_out(&a, j->spp, j->img + 3 * at, j->se ? j->se + 3 * at : NULL);
        }
    job_progress(j, (long)(end - begin) * j->w);
}

/* image_rows over rows offset by the job's first row (prt_parallel_for counts from 0). */
static void image_rows_from(void *ctx, int begin, int end, int thread) {
    const ref_job *j = ctx;
    image_rows(ctx, begin + j->y0, end + j->y0, thread);
}

static void job_init(ref_job *j, const ref_ctx *rc, const ref_desc *d) {
    memset(j, 0, sizeof *j);
    j->rc = rc;
    j->d = d;
    j->spp = d->spp > 0 ? d->spp : 64;
    j->seed = mix64(d->seed);
    j->stage = d->stage ? d->stage : "reference";
    atomic_init(&j->done, 0);
    atomic_init(&j->cancel, false);
    pthread_mutex_init(&j->lock, NULL);
}

/* Sums per-thread counters into stats; computes the relative noise of values/se. */
static void job_finish(ref_job *j, const float *val, const float *se, size_t nval, double t0, ref_stats *st) {
    pthread_mutex_destroy(&j->lock);
    if (!st) return;
    memset(st, 0, sizeof *st);
    for (int t = 0; t < REF_MAX_THREADS; t++) { st->rays += j->rays[t]; st->dropped += j->dropped[t]; }
    st->paths = j->n * (long)j->spp;
    st->seconds = prt_now() - t0;
    if (se) {
        double s2 = 0, v2 = 0;
        for (size_t i = 0; i < nval; i++) { s2 += (double)se[i] * se[i]; v2 += (double)val[i] * val[i]; }
        st->rel_noise = v2 > 0 ? sqrt(s2 / v2) : 0;
    }
}

/* Per-vertex radiance toward eye (see header). */
int ref_render_vertices(const ref_ctx *rc, const float eye[3], const int *verts, int n, const ref_desc *d,
                        float *rgb, float *se, ref_stats *stats, prt_error *err) {
    const prt_mesh *m = &rc->scene->mesh;
    if (!verts) n = m->nverts;
    for (int i = 0; verts && i < n; i++)
        if (verts[i] < 0 || verts[i] >= m->nverts) return prt_fail(err, "reference: vertex %d out of range 0..%d", verts[i], m->nverts - 1);
    double t0 = prt_now();
    ref_job j;
    job_init(&j, rc, d);
    j.verts = verts;
    v3_copy(j.eye, eye);
    j.rgb = rgb;
    j.se = se;
    j.n = n;
    int nth = prt_thread_count(d->nthreads);
    if (nth > REF_MAX_THREADS) nth = REF_MAX_THREADS;
    int grain = n / (16 * nth) < 1 ? 1 : (n / (16 * nth) > 256 ? 256 : n / (16 * nth));
    prt_parallel_for(n, grain, nth, vertex_range, &j);
    bool cancelled = atomic_load(&j.cancel);
    job_finish(&j, rgb, se, 3 * (size_t)n, t0, stats);
    if (cancelled) return prt_fail(err, "cancelled");
    return 0;
}

/* Rows [y0, y1) of the w x h image through cam into rgb (see header). */
int ref_render_rows(const ref_ctx *rc, const prt_camera *cam, int w, int h, int y0, int y1, const ref_desc *d,
                    float *rgb, float *se, ref_stats *stats, prt_error *err) {
    if (w < 1 || h < 1 || y0 < 0 || y1 > h || y0 >= y1)
        return prt_fail(err, "reference: bad rows %d..%d of a %dx%d image", y0, y1, w, h);
    double t0 = prt_now();
    ref_job j;
    job_init(&j, rc, d);
    j.cam = cam;
    j.w = w;
    j.h = h;
    j.y0 = y0;
    j.img = rgb;
    j.se = se;
    j.n = (long)w * (y1 - y0);
    int nth = prt_thread_count(d->nthreads);
    if (nth > REF_MAX_THREADS) nth = REF_MAX_THREADS;
    prt_parallel_for(y1 - y0, 1, nth, image_rows_from, &j);
    bool cancelled = atomic_load(&j.cancel);
    job_finish(&j, rgb, se, 3 * (size_t)j.n, t0, stats);
    return cancelled ? prt_fail(err, "cancelled") : 0;
}

/* Image through cam (see header): every row. */
int ref_render_image(const ref_ctx *rc, const prt_camera *cam, int w, int h, const ref_desc *d, prt_image *out,
                     float *se, ref_stats *stats, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (w < 1 || h < 1) return prt_fail(err, "reference: bad image size %dx%d", w, h);
    if (image_alloc(out, w, h, 3, err)) return -1;
    if (ref_render_rows(rc, cam, w, h, 0, h, d, out->data, se, stats, err)) { image_free(out); return -1; }
    return 0;
}

/* Writes the per-vertex CSV (see header). */
int ref_write_vertex_csv(const char *path, const int *ids, const float *rgb, const float *se, const uint8_t *facing, int n,
                         prt_error *err) {
    char tmp[4096];
    FILE *f = prt_atomic_open(path, tmp, sizeof tmp, err);
    if (!f) return -1;
    fprintf(f, "vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing\n");
    for (int v = 0; v < n; v++) {
        const float *c = rgb + 3 * (size_t)v;
        float z[3] = { 0, 0, 0 };
        const float *e = se ? se + 3 * (size_t)v : z;
        fprintf(f, "%d,%.8g,%.8g,%.8g,%.8g,%.8g,%.8g,%d\n", ids ? ids[v] : v, c[0], c[1], c[2], e[0], e[1], e[2],
                facing ? facing[v] != 0 : 1);
    }
    return prt_atomic_commit(f, tmp, path, err);
}
