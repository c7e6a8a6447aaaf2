/* prefilter.c - the probe prefiltered by vMF lobes over a ladder of kappa (prefilter.h).
 *
 * Levels are cube maps in cubemap.h's layout. The convolution of a level gathers, for each
 * output texel direction d, the source texels of the cap {w : d.w >= 1 - PF_CUT / kappa}
 * (e^{-PF_CUT} = 1e-5 of the kernel's peak, laurijssen-2011 Eq. 1). On each face the cap is
 * found as a texel box: the cap's part in front of the face's plane has a convex gnomonic
 * image, bounded by projecting 16 points of its rim (with d and the face centre when they
 * belong, plus a texel and 5% of margin); caps over a hemisphere scan the whole face (the
 * smallest levels only); a
 * face farther than the cap radius plus the face's half-diagonal angle is skipped. */
#include "prefilter.h"
#include "cubemap.h"
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

typedef struct pf_level {
    float kappa;
    int res;
    float *rgb;         /* 6 res^2 x 3, unrotated probe frame */
} pf_level;

struct prefilter_env {
    int nlevels;        /* vMF levels + the kappa-0 level */
    pf_level *lv;
    float Rt[9];        /* R^T: world direction -> probe frame */
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
    probe_to_cube(p, o.base_res, NULL, o.ss, cube);     /* unrotated: R applies at lookup */
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

void prefilter_lookup(const prefilter_env *e, const float dir[3], float kappa, float rgb[3]) {
    PRT_CHECK(!isnan(kappa));
    float d[3];
    pf_to_probe(e, dir, d);
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
