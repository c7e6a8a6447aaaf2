/* shbasis.c - real spherical harmonics (see shbasis.h): the low-frequency
 * baseline basis that all-frequency PRT (section 3.1, Eq. 5 "in any
 * orthonormal basis, such as spherical harmonics or wavelets") replaces.
 *
 * Convention. Polar axis +z of the world frame, theta = acos(z), phi = atan2(y, x);
 * no Condon-Shortley phase:
 *   Y_l^0  = N_l^0 P_l(z)
 *   Y_l^m  = sqrt(2) N_l^m P_l^m(z) cos(m phi)     (m > 0)
 *   Y_l^-m = sqrt(2) N_l^m P_l^m(z) sin(m phi)     (m > 0)
 * with N_l^m = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), stored at index l(l+1)+m.
 * So band 1 is sqrt(3/(4 pi)) (y, z, x) at indices 1, 2, 3.
 *
 * Stability. Factorials overflow and cancel long before order 16 if P_l^m and
 * N_l^m are formed separately, and acos/atan2 lose precision near the poles. So
 * we run the standard recurrence on the *normalized* Legendre functions with the
 * sin^m(theta) factor taken out (all values stay O(1)):
 *   Q_0^0 = 1/sqrt(4 pi),  Q_m^m = sqrt((2m+1)/(2m)) Q_{m-1}^{m-1},
 *   Q_{m+1}^m = sqrt(2m+3) z Q_m^m,
 *   Q_l^m = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),
 *   a_lm = sqrt((4l^2-1)/(l^2-m^2)),  b_lm = sqrt(((l-1)^2-m^2)/(4(l-1)^2-1)),
 * and put sin^m(theta) cos(m phi), sin^m(theta) sin(m phi) back as the real and
 * imaginary parts of (x + i y)^m, computed by repeated complex multiplication:
 * polynomial in the direction, no trigonometry, exact at the poles. Internally
 * double precision; outputs are float. */
#include "shbasis.h"
#include "cubemap.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Recurrence constants a_lm, b_lm (see the file comment), index l(l+1)/2 + m for m <= l.
 * Filled once per projection so the per-direction loop has no square roots. */
typedef struct sh_consts { double a[SH_MAX_ORDER * (SH_MAX_ORDER + 1) / 2], b[SH_MAX_ORDER * (SH_MAX_ORDER + 1) / 2]; } sh_consts;

static void sh_consts_init(sh_consts *k, int order) {
    for (int l = 0; l < order; l++)
        for (int m = 0; m <= l; m++) {
            int i = l * (l + 1) / 2 + m;
            k->a[i] = k->b[i] = 0.0;
            if (l >= m + 2) {
                double l2 = (double)l * l, m2 = (double)m * m, lm1 = (double)(l - 1);
                k->a[i] = sqrt((4.0 * l2 - 1.0) / (l2 - m2));
                k->b[i] = sqrt((lm1 * lm1 - m2) / (4.0 * lm1 * lm1 - 1.0));
            }
        }
}

/* Evaluates all order^2 real SH at unit d into y (double). order in 1..SH_MAX_ORDER. */
static void sh_eval_d(const sh_consts *k, int order, const double d[3], double *y) {
    const double x = d[0], yy = d[1], z = d[2];
    double qmm = 0.28209479177387814;   /* 1/sqrt(4 pi) */
    double cr = 1.0, ci = 0.0;          /* (x + i y)^m */
    for (int m = 0; m < order; m++) {
        if (m > 0) {
            qmm *= sqrt((2.0 * m + 1.0) / (2.0 * m));
            double nr = cr * x - ci * yy, ni = cr * yy + ci * x;
            cr = nr;
            ci = ni;
        }
        /* Walk up l for this m: q2 = Q_{l-2}^m, q1 = Q_{l-1}^m. */
        double q2 = 0.0, q1 = qmm;
        for (int l = m; l < order; l++) {
            double q;
            if (l == m) q = qmm;
            else if (l == m + 1) q = sqrt(2.0 * m + 3.0) * z * qmm;
            else {
                int i = l * (l + 1) / 2 + m;
                q = k->a[i] * (z * q1 - k->b[i] * q2);
            }
            if (l > m) { q2 = q1; q1 = q; }
            int c = l * (l + 1);
            if (m == 0) y[c] = q;
            else {
                y[c + m] = 1.4142135623730951 * q * cr;
                y[c - m] = 1.4142135623730951 * q * ci;
            }
        }
    }
}

/* Real SH of all i < order^2 at direction d (normalized here) into y. */
void sh_eval(int order, const float d[3], float *y) {
    if (order < 1) return;
    if (order > SH_MAX_ORDER) order = SH_MAX_ORDER;
    double dd[3] = { d[0], d[1], d[2] };
    double len = sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
    if (len > 0) { dd[0] /= len; dd[1] /= len; dd[2] /= len; }
    else dd[2] = 1.0;   /* a zero direction is a caller bug; pick the pole instead of NaN */
    double buf[SH_MAX_ORDER * SH_MAX_ORDER];
    sh_consts k;
    sh_consts_init(&k, order);
    sh_eval_d(&k, order, dd, buf);
    for (int i = 0; i < order * order; i++) y[i] = (float)buf[i];
}

/* Projection core: coeffs[i] = sum_j w_j t_j Y_i(w_j) over one channel with stride. */
static void sh_project_strided(const float *texels, int stride, int res, int order, bool with_solid_angle,
                               double *acc) {
    int n2 = order * order;
    double y[SH_MAX_ORDER * SH_MAX_ORDER];
    sh_consts k;
    sh_consts_init(&k, order);
    for (int j = 0; j < res; j++) {
        for (int i = 0; i < res; i++) {
            double dw = with_solid_angle ? cube_texel_solid_angle(res, i, j) : 1.0;
            for (int f = 0; f < 6; f++) {
                int idx = f * res * res + j * res + i;
                double t = texels[(size_t)idx * stride];
                /* Transport vectors are zero over the lower hemisphere and occluded
                 * texels: skipping them halves the work of a typical projection. */
                if (t == 0.0) continue;
                float df[3];
                cube_texel_dir(res, idx, df);
                double dd[3] = { df[0], df[1], df[2] };
                double len = sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
                dd[0] /= len; dd[1] /= len; dd[2] /= len;
                sh_eval_d(&k, order, dd, y);
                double w = t * dw;
                for (int c = 0; c < n2; c++) acc[c] += w * y[c];
            }
        }
    }
}

/* Projects one channel of a cube (see header); coeffs gets order^2 values. */
void sh_project_cube(const float *texels, int res, int order, bool with_solid_angle, float *coeffs) {
    if (order < 1) return;
    if (order > SH_MAX_ORDER) order = SH_MAX_ORDER;
    double acc[SH_MAX_ORDER * SH_MAX_ORDER] = { 0 };
    sh_project_strided(texels, 1, res, order, with_solid_angle, acc);
    for (int c = 0; c < order * order; c++) coeffs[c] = (float)acc[c];
}

/* Light vector in SH (see header): rows i < order^2 hold RGB coefficients, the rest zero. */
void sh_light_from_cube(const float *cube_rgb, int res, int order, float (*L)[4]) {
    memset(L, 0, sizeof(float[4]) * CUBE_TEXELS);
    if (order < 1) return;
    if (order > SH_MAX_ORDER) order = SH_MAX_ORDER;
    for (int ch = 0; ch < 3; ch++) {
        double acc[SH_MAX_ORDER * SH_MAX_ORDER] = { 0 };
        sh_project_strided(cube_rgb + ch, 3, res, order, true, acc);
        for (int c = 0; c < order * order; c++) L[c][ch] = (float)acc[c];
    }
}

/* Tabulates Y_i at every texel centre of a res cube, plus the texels' solid angles. */
int sh_table_init(sh_table *t, int res, int order, prt_error *err) {
    memset(t, 0, sizeof *t);
    if (order < 1 || order > SH_MAX_ORDER) return prt_fail(err, "spherical harmonics order %d out of range 1..%d", order, SH_MAX_ORDER);
    if (res < 1) return prt_fail(err, "cube resolution %d out of range", res);
    size_t ntex = (size_t)6 * res * res;
    int n = order * order;
    t->y = prt_calloc(ntex * n, sizeof(float), err);
    t->dw = prt_calloc(ntex, sizeof(float), err);
    if (!t->y || !t->dw) { sh_table_free(t); return -1; }
    t->res = res;
    t->order = order;
    t->n = n;
    sh_consts k;
    sh_consts_init(&k, order);
    double y[SH_MAX_ORDER * SH_MAX_ORDER];
    for (size_t idx = 0; idx < ntex; idx++) {
        float df[3];
        cube_texel_dir(res, (int)idx, df);
        double dd[3] = { df[0], df[1], df[2] };
        double len = sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
        dd[0] /= len; dd[1] /= len; dd[2] /= len;
        sh_eval_d(&k, order, dd, y);
        for (int c = 0; c < n; c++) t->y[idx * n + c] = (float)y[c];
        int rem = (int)(idx % ((size_t)res * res));
        t->dw[idx] = (float)cube_texel_solid_angle(res, rem % res, rem / res);
    }
    return 0;
}

/* coeffs[i] = sum_j texels[j*stride] (dw_j) Y_i(w_j): zero texels skipped, float accumulation
 * (vectorizes; about 1e-6 relative error for 24,576 texels). */
void sh_table_project(const sh_table *t, const float *texels, int stride, bool with_solid_angle, float *coeffs) {
    int n = t->n;
    size_t ntex = (size_t)6 * t->res * t->res;
    float acc[SH_MAX_ORDER * SH_MAX_ORDER] = { 0 };
    for (size_t idx = 0; idx < ntex; idx++) {
        float v = texels[idx * stride];
        if (v == 0.f) continue;
        if (with_solid_angle) v *= t->dw[idx];
        const float *y = t->y + idx * n;
        for (int c = 0; c < n; c++) acc[c] += v * y[c];
    }
    memcpy(coeffs, acc, sizeof(float) * n);
}

/* Frees the table's arrays (a zeroed table is fine). */
void sh_table_free(sh_table *t) {
    free(t->y);
    free(t->dw);
    memset(t, 0, sizeof *t);
}
