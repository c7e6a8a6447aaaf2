/* prefilter.c - the probe prefiltered by vMF lobes over a ladder of kappa (prefilter.h).
 *
 * Levels are cube maps in cubemap.h's layout. The convolution of a level gathers, for each
 * output texel direction d, the source texels of the cap {w : d.w >= 1 - PF_CUT / kappa}
 * (e^{-PF_CUT} = 1e-5 of the kernel's peak, laurijssen-2011 Eq. 1). On each face the cap is
 * found as a texel box: the cap's part in front of the face's plane has a convex gnomonic
 * image, bounded by projecting 16 points of its rim (with d and the face centre when they
 * belong, plus a texel and 5% of margin); caps over a hemisphere scan the whole face (the
 * smallest levels only); a
 * face farther than the cap radius plus the face's half-diagonal angle is skipped.
 * Before the levels are made, the lights (prefilter.h "Lights") are taken out of a copy of the
 * probe (pf_extract), which the cube is then resampled from; with none, the probe itself is. */
#include "prefilter.h"
#include "cubemap.h"
#include "lobe.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PF_PI 3.14159265358979323846
#define PF_CUT 11.5                    /* kernel cut at e^{-11.5} ~ 1e-5 of its peak */
#define PF_RIM 16                      /* rim points bounding the cap's image on a face */
#define PF_TEXELS 4.0                  /* output texels (of pi / (2 res)) per lobe width 1/sqrt k */
#define PF_SRC_TEXELS 2.0              /* source texels per lobe width */
#define PF_MIN_RES 8                   /* output levels are never coarser (bilinear on smooth maps) */
#define PF_MIN_SRC_RES 32              /* nor sources: a wide kernel still varies by e^{kappa h} across a texel */
#define PF_FACE_ANGLE 0.9553166181245093 /* acos(1/sqrt 3): face centre to corner */
#define PF_LIGHT_CUT 20.0               /* a light's term below e^{-20} = 2e-9 of its peak is skipped */
#define PF_LIGHT_RADIUS (1.0 * PF_PI / 180) /* a light's pixels lie within this of its brightest (prefilter.h) */

typedef struct pf_level {
    float kappa;
    int res;
    float *rgb;         /* 6 res^2 x 3, unrotated probe frame */
} pf_level;

/* A light taken out of the ladder (prefilter.h "Lights"): per colour channel c, power Phi_c (radiance
 * x solid angle) distributed as the vMF (dir[c], kappa[c]) in the unrotated probe frame; norm[c] =
 * C(kappa[c]) (lobe.h). */
typedef struct pf_light {
    float dir[3][3], kappa[3], norm[3], power[3];
} pf_light;

struct prefilter_env {
    int nlevels;        /* vMF levels + the kappa-0 level */
    pf_level *lv;
    float Rt[9];        /* R^T: world direction -> probe frame */
    int nlights;
    pf_light light[PREFILTER_MAX_LIGHTS];
};

/* Face frames: the direction at face coordinates (sc, tc) is sc a + tc b + c (cubemap.h). */
static const float pf_a[6][3] = { { 0, 0, -1 }, { 0, 0, 1 }, { 1, 0, 0 }, { 1, 0, 0 }, { 1, 0, 0 }, { -1, 0, 0 } };
static const float pf_b[6][3] = { { 0, -1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 }, { 0, -1, 0 }, { 0, -1, 0 } };
static const float pf_c[6][3] = { { 1, 0, 0 }, { -1, 0, 0 }, { 0, 1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 } };

static double dot3(const float a[3], const float b[3]) { return (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2]; }

/* ---- the pyramid ------------------------------------------------------------------------ */

/* dst (res/2) = 2x2 solid-angle-weighted means of src (res): power-preserving. */
static void pf_downsample(const float *src, int res, float *dst) {
    int h = res / 2;
    for (int f = 0; f < 6; f++)
        for (int j = 0; j < h; j++)
            for (int i = 0; i < h; i++) {
                double s[3] = { 0, 0, 0 }, w = 0;
                for (int dj = 0; dj < 2; dj++)
                    for (int di = 0; di < 2; di++) {
                        int x = 2 * i + di, y = 2 * j + dj;
                        double o = cube_texel_solid_angle(res, x, y);
                        const float *t = src + 3 * ((size_t)f * res * res + (size_t)y * res + x);
                        for (int c = 0; c < 3; c++) s[c] += o * t[c];
                        w += o;
                    }
                float *o = dst + 3 * ((size_t)f * h * h + (size_t)j * h + i);
                for (int c = 0; c < 3; c++) o[c] = (float)(s[c] / w);
            }
}

/* ---- the convolution of one level --------------------------------------------------------- */

typedef struct pf_job {
    const float *src;   /* source cube, res x res per face */
    const float *dir;   /* source texel directions (3 per texel) */
    const float *omega; /* source texel solid angles (one face) */
    int res;
    const float *odir;  /* output texel directions (out_res) */
    int out_res;
    double kappa, cos_cut, cap;   /* cap: the cut's angle */
    double cos_skip;              /* faces with d.c below this are beyond the cap */
    double rim[PF_RIM][2];        /* cos, sin of the rim points' azimuths */
    float *out;
} pf_job;

/* Adds the face coordinates of unit w (in front of face f) to the box, clamped to [-2, 2]. */
static void pf_box_add(int f, const float w[3], double box[4]) {
    double z = dot3(w, pf_c[f]);
    double s = fmax(-2.0, fmin(2.0, dot3(w, pf_a[f]) / z)), t = fmax(-2.0, fmin(2.0, dot3(w, pf_b[f]) / z));
    box[0] = fmin(box[0], s), box[1] = fmax(box[1], s), box[2] = fmin(box[2], t), box[3] = fmax(box[3], t);
}

/* Texel box [*i0,*i1] x [*j0,*j1] of face f that holds the cap about d; false if none. The
 * cap's part in front of the face's plane is geodesically convex, so its gnomonic image is
 * convex and bounded by the images of the rim's front points, of d (if in front) and of the
 * face centre (if in the cap); coordinates beyond the face are clamped (they only say that
 * the region runs over the edge). */
static bool pf_face_box(const pf_job *J, int f, const float d[3], const float rim[][3], int *i0, int *i1, int *j0, int *j1) {
    double cd = dot3(d, pf_c[f]);
    if (cd < J->cos_skip) return false;
    int r = J->res;
    *i0 = 0, *i1 = r - 1, *j0 = 0, *j1 = r - 1;
    if (J->cap >= 0.5 * PF_PI) return true;     /* over a hemisphere (small levels only) */
    double box[4] = { 1e9, -1e9, 1e9, -1e9 };
    if (cd > 1e-6) pf_box_add(f, d, box);
    if (cd >= J->cos_cut) pf_box_add(f, pf_c[f], box);
    for (int k = 0; k < PF_RIM; k++)
        if (dot3(rim[k], pf_c[f]) > 1e-6) pf_box_add(f, rim[k], box);
    if (box[0] > box[1]) return false;          /* nothing in front */
    /* Face coordinate s maps to texel x = (s + 1) res / 2; a texel and 5% of the extent of margin. */
    double m = 1.0 + 0.025 * fmax(box[1] - box[0], box[3] - box[2]) * r;
    int a0 = (int)floor((box[0] + 1) * 0.5 * r - m), a1 = (int)ceil((box[1] + 1) * 0.5 * r + m);
    int b0 = (int)floor((box[2] + 1) * 0.5 * r - m), b1 = (int)ceil((box[3] + 1) * 0.5 * r + m);
    if (a1 < 0 || b1 < 0 || a0 > r - 1 || b0 > r - 1) return false;
    *i0 = a0 < 0 ? 0 : a0, *i1 = a1 > r - 1 ? r - 1 : a1;
    *j0 = b0 < 0 ? 0 : b0, *j1 = b1 > r - 1 ? r - 1 : b1;
    return true;
}

/* The PF_RIM points of the rim of the cap about d. */
static void pf_rim(const pf_job *J, const float d[3], float rim[][3]) {
    float u[3], v[3], t[3] = { 1, 0, 0 };       /* u, v: an orthonormal pair orthogonal to d */
    if (fabsf(d[0]) > 0.6f) t[0] = 0, t[1] = 1;
    double td = dot3(t, d), ul = 0;
    for (int k = 0; k < 3; k++) u[k] = (float)(t[k] - td * d[k]), ul += (double)u[k] * u[k];
    for (int k = 0; k < 3; k++) u[k] = (float)(u[k] / sqrt(ul));
    v[0] = d[1] * u[2] - d[2] * u[1], v[1] = d[2] * u[0] - d[0] * u[2], v[2] = d[0] * u[1] - d[1] * u[0];
    double cc = cos(J->cap), sc = sin(J->cap);
    for (int k = 0; k < PF_RIM; k++)
        for (int m = 0; m < 3; m++) rim[k][m] = (float)(cc * d[m] + sc * (J->rim[k][0] * u[m] + J->rim[k][1] * v[m]));
}

/* out[texel] = normalized vMF-weighted sum of the source over the cap (prefilter.h's sum). */
static void pf_texel(const pf_job *J, int idx) {
    const float *d = J->odir + 3 * (size_t)idx;
    int r = J->res;
    double s[3] = { 0, 0, 0 }, ws = 0;
    float k = (float)J->kappa, rim[PF_RIM][3];
    pf_rim(J, d, rim);
    for (int f = 0; f < 6; f++) {
        int i0, i1, j0, j1;
        if (!pf_face_box(J, f, d, (const float (*)[3])rim, &i0, &i1, &j0, &j1)) continue;
        for (int j = j0; j <= j1; j++) {
            float rs[3] = { 0, 0, 0 }, rw = 0;
            size_t row = (size_t)f * r * r + (size_t)j * r;
            for (int i = i0; i <= i1; i++) {
                const float *w = J->dir + 3 * (row + i);
                float c = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];   /* no branch on the cut: */
                float wt = J->omega[j * r + i] * expf(k * (c - 1.f));
                const float *L = J->src + 3 * (row + i);
                rs[0] += wt * L[0], rs[1] += wt * L[1], rs[2] += wt * L[2], rw += wt;
            }
            for (int c = 0; c < 3; c++) s[c] += rs[c];
            ws += rw;
        }
    }
    float *o = J->out + 3 * (size_t)idx;
    PRT_CHECK(ws > 0);      /* the source texel holding d is in its box, with weight > 0 */
    for (int c = 0; c < 3; c++) o[c] = (float)(s[c] / ws);
}

static void pf_rows(void *ctx, int begin, int end, int thread) {
    const pf_job *J = ctx;
    for (int row = begin; row < end; row++)
        for (int i = 0; i < J->out_res; i++) pf_texel(J, row * J->out_res + i);
}

/* Convolves src (res) with the vMF of kappa into out (out_res); threads as prt_parallel_for.
 * The source texels are area means (probe_to_cube, the pyramid): a box of per-axis variance
 * h^2 / 12 (h^2 = 4 pi / (6 res^2), the mean texel) that the kernel's 1 / kappa per axis
 * would add to, so the kernel is sharpened to 1 / kappa' = 1 / kappa - h^2 / 12. */
static int pf_convolve(const float *src, int res, int out_res, double kappa, int threads, float *out, prt_error *err) {
    size_t n = (size_t)6 * res * res, no = (size_t)6 * out_res * out_res;
    float *dir = malloc(n * 3 * sizeof *dir), *omega = malloc((size_t)res * res * sizeof *omega);
    float *odir = malloc(no * 3 * sizeof *odir);
    if (!dir || !omega || !odir) {
        free(dir), free(omega), free(odir);
        return prt_fail(err, "prefilter: out of memory for a %d x %d cube", res, res);
    }
    for (size_t i = 0; i < n; i++) cube_texel_dir(res, (int)i, dir + 3 * i);
    for (size_t i = 0; i < no; i++) cube_texel_dir(out_res, (int)i, odir + 3 * i);
    cube_face_solid_angles(res, omega);
    double h2 = 4 * PF_PI / (6.0 * res * res), inv = 1 / kappa - h2 / 12;
    double k = inv > 0.5 / kappa ? 1 / inv : 2 * kappa;
    double one_minus = PF_CUT / k;
    pf_job J = { .src = src, .dir = dir, .omega = omega, .res = res, .odir = odir, .out_res = out_res, .kappa = k,
                 .cos_cut = one_minus >= 2 ? -2.0 : 1 - one_minus,
                 .cap = one_minus >= 2 ? PF_PI : acos(1 - one_minus), .out = out };
    J.cos_skip = J.cap + PF_FACE_ANGLE >= PF_PI ? -2.0 : cos(J.cap + PF_FACE_ANGLE);
    for (int i = 0; i < PF_RIM; i++) J.rim[i][0] = cos(2 * PF_PI * i / PF_RIM), J.rim[i][1] = sin(2 * PF_PI * i / PF_RIM);
    prt_parallel_for(6 * out_res, 1, threads, pf_rows, &J);
    free(dir), free(omega), free(odir);
    return 0;
}

/* ---- lights: the brightest pixels taken out of the ladder (prefilter.h "Lights") ---------------- */

typedef struct pf_cand { float lum; int idx; } pf_cand;

static float pf_lum(const float *t) { return 0.2126f * t[0] + 0.7152f * t[1] + 0.0722f * t[2]; }

/* Brightest first; ties by pixel index (a deterministic order for any qsort). */
static int pf_cand_cmp(const void *a, const void *b) {
    const pf_cand *x = a, *y = b;
    if (x->lum != y->lum) return x->lum < y->lum ? 1 : -1;
    return (x->idx > y->idx) - (x->idx < y->idx);
}

/* Angle between the centres of pixels (x0, y0) and (x1, y1); -1 when either is outside the layout. */
static double pf_pixel_angle(const prt_probe *p, int x0, int y0, int x1, int y1) {
    float a[3], b[3];
    if (!probe_pixel_dir(p, x0, y0, a, NULL) || !probe_pixel_dir(p, x1, y1, b, NULL)) return -1;
    double d0 = (double)a[0] - b[0], d1 = (double)a[1] - b[1], d2 = (double)a[2] - b[2];
    return 2 * asin(fmin(1.0, 0.5 * sqrt(d0 * d0 + d1 * d1 + d2 * d2)));
}

/* Per-axis angular variance of pixel (x, y) as probe_eval reads it: a bilinear tent of half-width h
 * (the spacing of the neighbouring centres along each image axis) has variance h^2 / 6 along that
 * axis; the mean over the two axes is (h_x^2 + h_y^2) / 12. */
static double pf_pixel_var(const prt_probe *p, int x, int y) {
    double v = 0;
    for (int ax = 0; ax < 2; ax++) {
        int dx = ax == 0, dy = ax == 1;
        double a = pf_pixel_angle(p, x - dx, y - dy, x, y), b = pf_pixel_angle(p, x, y, x + dx, y + dy);
        double h = a >= 0 && b >= 0 ? 0.5 * (a + b) : fmax(fmax(a, b), 0.0);
        v += h * h / 12;
    }
    return v;
}

/* The probe's mean luminance over the sphere (solid-angle weighted), and its pixels brighter than
 * threshold x that mean, brightest first (*cand malloc'd, NULL when none). -1 and err when out of memory. */
static int pf_candidates(const prt_probe *p, float threshold, pf_cand **cand, int *n, prt_error *err) {
    int w = p->img.w, h = p->img.h;
    double pw = 0, om = 0;
    *cand = NULL, *n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float d[3], o;
            if (!probe_pixel_dir(p, x, y, d, &o)) continue;
            pw += (double)o * pf_lum(p->img.data + 3 * ((size_t)y * w + x)), om += o;
        }
    double cut = om > 0 ? threshold * pw / om : 0;
    if (!(cut > 0)) return 0;
    int m = 0;
    for (size_t i = 0; i < (size_t)w * h; i++) m += pf_lum(p->img.data + 3 * i) > cut;
    if (m == 0) return 0;
    if (!(*cand = malloc((size_t)m * sizeof **cand))) return prt_fail(err, "prefilter: out of memory");
    for (size_t i = 0; i < (size_t)w * h; i++) {
        float l = pf_lum(p->img.data + 3 * i), d[3];
        if (l > cut && probe_pixel_dir(p, (int)(i % w), (int)(i / w), d, NULL)) (*cand)[(*n)++] = (pf_cand){ l, (int)i };
    }
    qsort(*cand, (size_t)*n, sizeof **cand, pf_cand_cmp);
    return 0;
}

/* Groups the candidates into at most max_lights lights: each joins the first light whose seed (its
 * brightest pixel) is within PF_LIGHT_RADIUS, else seeds a new one while there is room, else stays in
 * the ladder. A light's power is the sum of its pixels' (radiance x solid angle) per channel, and its
 * vMF per channel the merge of the pixels' own (Eq. 4 weighted by that channel's power, each pixel a
 * vMF of its tent's variance), so its spread holds both the pixels' extent and their scatter; per
 * channel because a sun's pixels differ in colour (sunrise.exr's blue centroid is a third of a pixel
 * from its luminance's). Taken pixels are zeroed in rest. */
static void pf_group(const prt_probe *p, const pf_cand *cand, int n, int max_lights, float *rest, prefilter_env *e) {
    vmf_accum acc[PREFILTER_MAX_LIGHTS][3];
    float seed[PREFILTER_MAX_LIGHTS][3];
    double cos_r = cos(PF_LIGHT_RADIUS);
    memset(acc, 0, sizeof acc);
    e->nlights = 0;
    for (int c = 0; c < n; c++) {
        int x = cand[c].idx % p->img.w, y = cand[c].idx / p->img.w, s = 0;
        float d[3], o;
        probe_pixel_dir(p, x, y, d, &o);
        while (s < e->nlights && dot3(d, seed[s]) < cos_r) s++;
        if (s == e->nlights) {
            if (s == max_lights) continue;
            memcpy(seed[s], d, sizeof seed[s]), e->nlights++;
        }
        float *t = rest + 3 * (size_t)cand[c].idx;
        double var = pf_pixel_var(p, x, y);
        vmf_lobe v = { { d[0], d[1], d[2] }, (float)(var > 0 ? fmin(1 / var, VMF_KAPPA_MAX) : VMF_KAPPA_MAX) };
        for (int k = 0; k < 3; k++) vmf_accum_add(&acc[s][k], &v, (double)o * t[k]), e->light[s].power[k] += o * t[k], t[k] = 0;
    }
    for (int s = 0; s < e->nlights; s++)
        for (int k = 0; k < 3; k++) {
            vmf_lobe v;
            vmf_accum_result(&acc[s][k], &v);
            double l = sqrt(dot3(v.mu, v.mu));
            for (int m = 0; m < 3; m++) e->light[s].dir[k][m] = (float)(v.mu[m] / l);
            e->light[s].kappa[k] = v.kappa, e->light[s].norm[k] = (float)vmf_norm(v.kappa);
        }
}

/* Takes the lights out of p (o->lights at most, pixels above o->light_threshold x the mean): *rest is
 * then a copy of p without them (its image malloc'd; the caller frees it), or p itself when nothing
 * was taken (rest->img.data == p->img.data). -1 and err when out of memory. */
static int pf_extract(const prt_probe *p, const prefilter_desc *o, prefilter_env *e, prt_probe *rest, prt_error *err) {
    *rest = *p;
    e->nlights = 0;
    if (o->lights <= 0) return 0;
    pf_cand *cand;
    int n;
    if (pf_candidates(p, o->light_threshold, &cand, &n, err)) return -1;
    if (n == 0) return 0;
    size_t bytes = (size_t)3 * p->img.w * p->img.h * sizeof(float);
    float *copy = malloc(bytes);
    if (!copy) { free(cand); return prt_fail(err, "prefilter: out of memory for the probe's copy"); }
    memcpy(copy, p->img.data, bytes);
    pf_group(p, cand, n, o->lights, copy, e);
    free(cand);
    rest->img.data = copy, rest->max_value = 0;
    for (size_t i = 0; i < bytes / sizeof(float); i++) rest->max_value = fmaxf(rest->max_value, copy[i]);
    return 0;
}

/* ---- creation ------------------------------------------------------------------------------ */

/* The power of two nearest to x in log (x >= 1). */
static int pf_pow2_nearest(double x) {
    int r = 1;
    while (r * M_SQRT2 < x && r < (1 << 20)) r *= 2;
    return r;
}

/* Fills in the defaults of d into *o; -1 and err if a field is out of range. */
static int pf_resolve(const prefilter_desc *d, prefilter_desc *o, prt_error *err) {
    prefilter_desc z = { 0 };
    *o = d ? *d : z;
    if (!o->base_res) o->base_res = PREFILTER_BASE_RES;
    if (!o->levels) o->levels = PREFILTER_LEVELS;
    if (o->kappa_max == 0) o->kappa_max = PREFILTER_KAPPA_MAX;
    if (o->ratio == 0) o->ratio = PREFILTER_RATIO;
    if (o->base_res < 4 || o->base_res > 1024 || (o->base_res & (o->base_res - 1)))
        return prt_fail(err, "prefilter: base resolution %d is not a power of two in [4, 1024]", o->base_res);
    if (o->levels < 1 || o->levels > 32) return prt_fail(err, "prefilter: %d levels is not in [1, 32]", o->levels);
    if (!(o->kappa_max > 0 && o->kappa_max <= 1e6f))
        return prt_fail(err, "prefilter: kappa_max %g is not in (0, 1e6]", (double)o->kappa_max);
    if (!(o->ratio > 1 && o->ratio < 1e6f)) return prt_fail(err, "prefilter: ratio %g is not above 1", (double)o->ratio);
    if (!o->lights) o->lights = PREFILTER_LIGHTS;
    if (o->light_threshold == 0) o->light_threshold = PREFILTER_LIGHT_THRESHOLD;
    if (o->lights > PREFILTER_MAX_LIGHTS)
        return prt_fail(err, "prefilter: %d lights is above %d", o->lights, PREFILTER_MAX_LIGHTS);
    if (!(o->light_threshold >= 1 && o->light_threshold < 1e30f))
        return prt_fail(err, "prefilter: light threshold %g is not a multiple >= 1 of the mean", (double)o->light_threshold);
    return 0;
}

/* The kappa-0 level: the solid-angle-weighted mean of base, as a res-1 cube. */
static int pf_mean_level(const float *base, int res, pf_level *L, prt_error *err) {
    L->kappa = 0, L->res = 1;
    L->rgb = malloc(6 * 3 * sizeof *L->rgb);
    if (!L->rgb) return prt_fail(err, "prefilter: out of memory");
    double s[3] = { 0, 0, 0 }, w = 0;
    for (int f = 0; f < 6; f++)
        for (int j = 0; j < res; j++)
            for (int i = 0; i < res; i++) {
                double o = cube_texel_solid_angle(res, i, j);
                const float *t = base + 3 * ((size_t)f * res * res + (size_t)j * res + i);
                for (int c = 0; c < 3; c++) s[c] += o * t[c];
                w += o;
            }
    for (int f = 0; f < 6; f++)
        for (int c = 0; c < 3; c++) L->rgb[3 * f + c] = (float)(s[c] / w);
    return 0;
}

/* Level resolution: the power of two nearest pi/2 sqrt(kappa) * texels, in [lo, base]. */
static int pf_level_res(double kappa, double texels, int lo, int base) {
    int r = pf_pow2_nearest(texels * 0.5 * PF_PI * sqrt(kappa));
    r = r < lo ? lo : r;
    return r > base ? base : r;
}

/* Builds every level from the pyramid of cube (base res); cube is consumed (freed). */
static int pf_build(prefilter_env *e, const prefilter_desc *o, float *cube, prt_error *err) {
    int res = o->base_res, threads = prt_thread_count(o->threads);
    for (int l = 0; l < o->levels; l++) {
        pf_level *L = &e->lv[l];
        L->kappa = o->kappa_max / powf(o->ratio, (float)l);
        L->res = pf_level_res(L->kappa, PF_TEXELS, PF_MIN_RES, o->base_res);
        int src_res = pf_level_res(L->kappa, PF_SRC_TEXELS, PF_MIN_SRC_RES, o->base_res);
        while (res > src_res) {     /* the pyramid: halve the source down to this level's */
            float *half = malloc((size_t)6 * (res / 2) * (res / 2) * 3 * sizeof *half);
            if (!half) { free(cube); return prt_fail(err, "prefilter: out of memory"); }
            pf_downsample(cube, res, half);
            free(cube), cube = half, res /= 2;
        }
        L->rgb = malloc((size_t)6 * L->res * L->res * 3 * sizeof *L->rgb);
        if (!L->rgb || pf_convolve(cube, res, L->res, L->kappa, threads, L->rgb, err)) {
            free(cube);
            return L->rgb ? -1 : prt_fail(err, "prefilter: out of memory");
        }
    }
    int rc = pf_mean_level(cube, res, &e->lv[o->levels], err);
    free(cube);
    return rc;
}

prefilter_env *prefilter_create(const prt_probe *p, const float R[9], const prefilter_desc *d, prt_error *err) {
    PRT_CHECK(p != NULL);
    prefilter_desc o;
    if (pf_resolve(d, &o, err)) return NULL;
    prefilter_env *e = calloc(1, sizeof *e);
    float *cube = malloc((size_t)6 * o.base_res * o.base_res * 3 * sizeof *cube);
    if (e) e->lv = calloc((size_t)o.levels + 1, sizeof *e->lv);
    if (!e || !e->lv || !cube) {
        free(cube), prefilter_destroy(e);
        prt_fail(err, "prefilter: out of memory for a %d x %d cube", o.base_res, o.base_res);
        return NULL;
    }
    e->nlevels = o.levels + 1;
    prefilter_set_rotation(e, R);
    prt_probe rest;
    if (pf_extract(p, &o, e, &rest, err)) {
        free(cube), prefilter_destroy(e);
        return NULL;
    }
    probe_to_cube(&rest, o.base_res, NULL, o.ss, cube);     /* unrotated: R applies at lookup */
    if (rest.img.data != p->img.data) free(rest.img.data);
    if (pf_build(e, &o, cube, err)) {
        prefilter_destroy(e);
        return NULL;
    }
    return e;
}

void prefilter_destroy(prefilter_env *e) {
    if (!e) return;
    if (e->lv)
        for (int l = 0; l < e->nlevels; l++) free(e->lv[l].rgb);
    free(e->lv);
    free(e);
}

void prefilter_set_rotation(prefilter_env *e, const float R[9]) {
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    if (!R) R = I;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) e->Rt[3 * r + c] = R[3 * c + r];
}

int prefilter_level_count(const prefilter_env *e) { return e->nlevels; }

int prefilter_light_count(const prefilter_env *e) { return e->nlights; }

void prefilter_light(const prefilter_env *e, int i, float dir[3][3], float kappa[3], float power[3]) {
    PRT_CHECK(i >= 0 && i < e->nlights);
    const pf_light *L = &e->light[i];
    memcpy(dir, L->dir, sizeof L->dir), memcpy(kappa, L->kappa, sizeof L->kappa), memcpy(power, L->power, sizeof L->power);
}

void prefilter_level_info(const prefilter_env *e, int l, float *kappa, int *res) {
    PRT_CHECK(l >= 0 && l < e->nlevels);
    if (kappa) *kappa = e->lv[l].kappa;
    if (res) *res = e->lv[l].res;
}

const float *prefilter_level_texels(const prefilter_env *e, int l) {
    PRT_CHECK(l >= 0 && l < e->nlevels);
    return e->lv[l].rgb;
}

void prefilter_rotation_t(const prefilter_env *e, float Rt[9]) { memcpy(Rt, e->Rt, sizeof e->Rt); }

/* ---- lookup -------------------------------------------------------------------------------- */

/* Texel (i, j) of face f, or for i, j one beyond an edge, the neighbouring face's texel
 * under the extrapolated direction (seamless bilinear filtering). */
static const float *pf_tap(const pf_level *L, int f, int i, int j) {
    int r = L->res;
    if (i >= 0 && i < r && j >= 0 && j < r) return L->rgb + 3 * ((size_t)f * r * r + (size_t)j * r + i);
    float d[3];
    cube_dir(r, f, i + 0.5f, j + 0.5f, d);
    return L->rgb + 3 * (size_t)cube_texel_index(r, d);
}

/* Bilinear lookup of level L at unit direction d in the probe frame. */
static void pf_bilinear(const pf_level *L, const float d[3], float rgb[3]) {
    int f;
    float x, y;
    cube_lookup(L->res, d, &f, &x, &y);
    float fx = x - 0.5f, fy = y - 0.5f;
    int i = (int)floorf(fx), j = (int)floorf(fy);
    float tx = fx - i, ty = fy - j;
    const float *t00 = pf_tap(L, f, i, j), *t10 = pf_tap(L, f, i + 1, j);
    const float *t01 = pf_tap(L, f, i, j + 1), *t11 = pf_tap(L, f, i + 1, j + 1);
    for (int c = 0; c < 3; c++)
        rgb[c] = (1 - ty) * ((1 - tx) * t00[c] + tx * t10[c]) + ty * ((1 - tx) * t01[c] + tx * t11[c]);
}

/* R^T dir, normalized (dir must be nonzero and finite: a bug otherwise). */
static void pf_to_probe(const prefilter_env *e, const float dir[3], float d[3]) {
    double q[3], n = 0;
    for (int r = 0; r < 3; r++) {
        q[r] = (double)e->Rt[3 * r] * dir[0] + (double)e->Rt[3 * r + 1] * dir[1] + (double)e->Rt[3 * r + 2] * dir[2];
        n += q[r] * q[r];
    }
    PRT_CHECK(n > 0 && isfinite(n));
    n = sqrt(n);
    for (int r = 0; r < 3; r++) d[r] = (float)(q[r] / n);
}

void prefilter_lookup_level(const prefilter_env *e, int l, const float dir[3], float rgb[3]) {
    PRT_CHECK(l >= 0 && l < e->nlevels);
    float d[3];
    pf_to_probe(e, dir, d);
    pf_bilinear(&e->lv[l], d, rgb);
}

/* C(k) of lobe.h (vmf_norm), without its expm1 where 1 - e^{-2k} is 1 in float (k > 10). */
static float pf_norm(float k) { return k > 10 ? k * (float)(0.5 / PF_PI) : (float)vmf_norm(k); }

/* rgb += sum_s Phi_s int gamma_s gamma(.; d, kappa) per channel: each light's vMF convolved exactly with
 * the lookup's (lobe.h vmf_product_integral: C(k) C(ks) / C(km) e^{km - k - ks}, km = |k d + ks w_s|, the
 * exponent as -2 k ks (1 - cos) / (k + ks + km) with 1 - cos = |d - w_s|^2 / 2, C(k) / C(km) first so that
 * nothing overflows), in float as glrt's GLSL does it (the exponent's rounding, 20 x 6e-8, is below what
 * the test sees); d in the probe frame, kappa clamped to [0, VMF_KAPPA_MAX]. */
static void pf_add_lights(const prefilter_env *e, const float d[3], float kappa, float rgb[3]) {
    float k = kappa > 0 ? fminf(kappa, (float)VMF_KAPPA_MAX) : 0, ck = (float)vmf_norm(k);
    double sum[3] = { 0, 0, 0 };
    for (int i = 0; i < e->nlights; i++) {
        const pf_light *L = &e->light[i];
        for (int ch = 0; ch < 3; ch++) {
            const float *w = L->dir[ch], ks = L->kappa[ch];
            float a = d[0] - w[0], b = d[1] - w[1], c = d[2] - w[2], omc = 0.5f * (a * a + b * b + c * c);
            if (k * ks * omc > (float)PF_LIGHT_CUT * (k + ks)) continue;   /* km <= k + ks: the exponent is below -PF_LIGHT_CUT */
            float km = sqrtf(fmaxf(0.f, (k + ks) * (k + ks) - 2 * k * ks * omc));
            sum[ch] += (double)(ck / pf_norm(km) * L->norm[ch] * expf(-2 * k * ks * omc / (k + ks + km))) * L->power[ch];
        }
    }
    for (int ch = 0; ch < 3; ch++) rgb[ch] += (float)sum[ch];
}

/* The ladder's part of prefilter_lookup (the probe less its lights), d in the probe frame. */
static void pf_ladder(const prefilter_env *e, const float d[3], float kappa, float rgb[3]) {
    int last = e->nlevels - 1;      /* the kappa-0 level */
    if (kappa >= e->lv[0].kappa) { pf_bilinear(&e->lv[0], d, rgb); return; }
    if (kappa <= 0) { pf_bilinear(&e->lv[last], d, rgb); return; }
    int l = 0;
    while (l + 1 < last && e->lv[l + 1].kappa > kappa) l++;
    /* kappa in (kappa_{l+1}, kappa_l]: log kappa between vMF levels, kappa towards kappa 0. */
    float t;
    if (l + 1 < last) t = logf(e->lv[l].kappa / kappa) / logf(e->lv[l].kappa / e->lv[l + 1].kappa);
    else t = 1 - kappa / e->lv[l].kappa;
    float a[3], b[3];
    pf_bilinear(&e->lv[l], d, a);
    pf_bilinear(&e->lv[l + 1], d, b);
    for (int c = 0; c < 3; c++) rgb[c] = (1 - t) * a[c] + t * b[c];
}

void prefilter_lookup(const prefilter_env *e, const float dir[3], float kappa, float rgb[3]) {
    PRT_CHECK(!isnan(kappa));
    float d[3];
    pf_to_probe(e, dir, d);
    pf_ladder(e, d, kappa, rgb);
    if (e->nlights) pf_add_lights(e, d, kappa, rgb);
}
