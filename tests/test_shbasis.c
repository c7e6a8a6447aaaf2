/* test_shbasis.c - real spherical harmonics against independent truths:
 * closed-form bands 0..3, orthonormality (exact Gauss-Legendre product
 * quadrature to order 16, cube quadrature at res 64 to order 10), projection of
 * band-limited functions, the clamped cosine's Funk-Hecke coefficients
 * (pi, 2pi/3, pi/4, 0, -pi/24 times Y_lm(n)), and the light/transport inner product. */
#include "harness.h"
#include "shbasis.h"
#include "cubemap.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Closed forms of bands 0..3 (polar axis z, no Condon-Shortley phase), unit d. */
static void sh_closed_form(const double d[3], double *y) {
    double x = d[0], yy = d[1], z = d[2];
    y[0] = 0.5 * sqrt(1 / PI);
    y[1] = sqrt(3 / (4 * PI)) * yy;
    y[2] = sqrt(3 / (4 * PI)) * z;
    y[3] = sqrt(3 / (4 * PI)) * x;
    y[4] = 0.5 * sqrt(15 / PI) * x * yy;
    y[5] = 0.5 * sqrt(15 / PI) * yy * z;
    y[6] = 0.25 * sqrt(5 / PI) * (3 * z * z - 1);
    y[7] = 0.5 * sqrt(15 / PI) * x * z;
    y[8] = 0.25 * sqrt(15 / PI) * (x * x - yy * yy);
    y[9] = 0.25 * sqrt(35 / (2 * PI)) * yy * (3 * x * x - yy * yy);
    y[10] = 0.5 * sqrt(105 / PI) * x * yy * z;
    y[11] = 0.25 * sqrt(21 / (2 * PI)) * yy * (5 * z * z - 1);
    y[12] = 0.25 * sqrt(7 / PI) * z * (5 * z * z - 3);
    y[13] = 0.25 * sqrt(21 / (2 * PI)) * x * (5 * z * z - 1);
    y[14] = 0.25 * sqrt(105 / PI) * z * (x * x - yy * yy);
    y[15] = 0.25 * sqrt(35 / (2 * PI)) * x * (x * x - 3 * yy * yy);
}

static double rnd(unsigned *s) {
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) * (1.0 / 16777216.0);
}

static void rnd_dir(unsigned *s, double d[3]) {
    double z = 2 * rnd(s) - 1, phi = 2 * PI * rnd(s), r = sqrt(1 - z * z);
    d[0] = r * cos(phi); d[1] = r * sin(phi); d[2] = z;
}

/* Gauss-Legendre nodes/weights on [-1,1] by Newton on P_n. */
static void gauss_legendre(int n, double *x, double *w) {
    for (int i = 0; i < n; i++) {
        double t = cos(PI * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; it++) {
            double p0 = 1, p1 = t;
            for (int k = 2; k <= n; k++) { double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k; p0 = p1; p1 = p2; }
            dp = n * (t * p1 - p0) / (t * t - 1);
            double dt = p1 / dp;
            t -= dt;
            if (fabs(dt) < 1e-15) break;
        }
        x[i] = t;
        w[i] = 2 / ((1 - t * t) * dp * dp);
    }
}

static void closed_form(void) {
    unsigned s = 1;
    double maxerr = 0;
    for (int k = 0; k < 200; k++) {
        double d[3], ref[16];
        rnd_dir(&s, d);
        if (k == 0) { d[0] = 0; d[1] = 0; d[2] = 1; }
        if (k == 1) { d[0] = 0; d[1] = 0; d[2] = -1; }
        sh_closed_form(d, ref);
        float df[3] = { (float)d[0], (float)d[1], (float)d[2] }, y[16];
        sh_eval(4, df, y);
        for (int i = 0; i < 16; i++) maxerr = fmax(maxerr, fabs(y[i] - ref[i]));
    }
    CHECK_LE(maxerr, 1e-6, "bands 0..3 match the closed forms");
    /* A non-unit direction is normalized. */
    float d2[3] = { 0, 3, 0 }, y2[4];
    sh_eval(2, d2, y2);
    CHECK_NEAR(y2[1], sqrt(3 / (4 * PI)), 1e-6, "non-unit direction normalized");
}

static void poles_order16(void) {
    float y[256];
    int bad = 0;
    for (int sgn = -1; sgn <= 1; sgn += 2) {
        float d[3] = { 0, 0, (float)sgn };
        sh_eval(16, d, y);
        for (int l = 0; l < 16; l++)
            for (int m = -l; m <= l; m++) {
                double want = m ? 0 : (l % 2 && sgn < 0 ? -1 : 1) * sqrt((2 * l + 1) / (4 * PI));
                if (!isfinite(y[l * (l + 1) + m]) || fabs(y[l * (l + 1) + m] - want) > 1e-5) bad++;
            }
    }
    CHECK(bad == 0, "%d wrong values at the poles (Y_l0 = (+-1)^l sqrt((2l+1)/4pi), others 0)", bad);
}

/* Exact quadrature: Gauss-Legendre in z (24 nodes: exact for degree 47) x 48 uniform phi. */
static void orthonormal_exact(void) {
    enum { NZ = 24, NP = 48, ORD = 16, N2 = ORD * ORD };
    double zx[NZ], zw[NZ];
    gauss_legendre(NZ, zx, zw);
    double *G = calloc(N2 * N2, sizeof(double));
    float y[N2];
    for (int a = 0; a < NZ; a++)
        for (int b = 0; b < NP; b++) {
            double phi = 2 * PI * (b + 0.5) / NP, r = sqrt(1 - zx[a] * zx[a]);
            float d[3] = { (float)(r * cos(phi)), (float)(r * sin(phi)), (float)zx[a] };
            sh_eval(ORD, d, y);
            double w = zw[a] * 2 * PI / NP;
            for (int i = 0; i < N2; i++)
                for (int j = i; j < N2; j++) G[i * N2 + j] += w * y[i] * y[j];
        }
    double maxerr = 0;
    for (int i = 0; i < N2; i++)
        for (int j = i; j < N2; j++) maxerr = fmax(maxerr, fabs(G[i * N2 + j] - (i == j)));
    CHECK_LE(maxerr, 2e-5, "order 16 orthonormal under exact product quadrature (float evaluation)");
    free(G);
}

/* Cube quadrature at res 64 (texel centres, exact solid angles), order 10, through the table. */
static void orthonormal_cube(void) {
    sh_table t;
    prt_error err;
    CHECK(sh_table_init(&t, 64, 10, &err) == 0, "%s", err.msg);
    int n = t.n;
    double maxerr = 0, sumdw = 0;
    for (int i = 0; i < 6 * 64 * 64; i++) sumdw += t.dw[i];
    CHECK_NEAR(sumdw, 4 * PI, 1e-4, "solid angles sum to 4 pi");
    float c[100];
    for (int k = 0; k < n; k++) {
        sh_table_project(&t, t.y + k, n, true, c);   /* <Y_i, Y_k> for all i */
        for (int i = 0; i < n; i++) maxerr = fmax(maxerr, fabs(c[i] - (i == k)));
    }
    CHECK_LE(maxerr, 1e-3, "order 10 orthonormal by res-64 cube quadrature");
    printf("cube quadrature res 64 order 10: max |<Yi,Yj> - delta| = %.2e\n", maxerr);
    sh_table_free(&t);
    CHECK(sh_table_init(&t, 64, 17, &err) == -1 && strstr(err.msg, "order"), "order 17 rejected");
}

/* A band-limited function's coefficients come back from its cube samples. */
static void bandlimited(void) {
    enum { RES = 64, NT = 6 * RES * RES, ORD = 6, N2 = ORD * ORD };
    unsigned s = 7;
    float coef[N2];
    for (int i = 0; i < N2; i++) coef[i] = (float)(2 * rnd(&s) - 1);
    float *f = malloc(sizeof(float) * NT), *T = malloc(sizeof(float) * NT), y[N2];
    float *rgb = malloc(sizeof(float) * 3 * NT);
    for (int j = 0; j < NT; j++) {
        float d[3];
        cube_texel_dir(RES, j, d);
        sh_eval(ORD, d, y);
        double v = 0;
        for (int i = 0; i < N2; i++) v += coef[i] * y[i];
        f[j] = (float)v;
        int r = j % (RES * RES);
        T[j] = (float)(v * cube_texel_solid_angle(RES, r % RES, r / RES));
        rgb[3 * j] = f[j]; rgb[3 * j + 1] = 2 * f[j]; rgb[3 * j + 2] = -f[j];
    }
    float c1[N2], c2[N2];
    sh_project_cube(f, RES, ORD, true, c1);    /* light form */
    sh_project_cube(T, RES, ORD, false, c2);   /* transport form (solid angle in the texels) */
    double e1 = 0, e2 = 0;
    for (int i = 0; i < N2; i++) { e1 = fmax(e1, fabs(c1[i] - coef[i])); e2 = fmax(e2, fabs(c2[i] - coef[i])); }
    CHECK_LE(e1, 2e-3, "band-limited projection, light form");
    CHECK_LE(e2, 2e-3, "band-limited projection, transport form");
    /* sh_light_from_cube: RGB channels, zero padding, rows past order^2 zero. */
    float (*L)[4] = malloc(sizeof(float[4]) * CUBE_TEXELS);
    for (int i = 0; i < CUBE_TEXELS; i++) L[i][0] = L[i][1] = L[i][2] = L[i][3] = 7.f;
    sh_light_from_cube(rgb, RES, ORD, L);
    double e3 = 0;
    int nonzero_tail = 0;
    for (int i = 0; i < N2; i++) {
        e3 = fmax(e3, fabs(L[i][0] - coef[i]));
        e3 = fmax(e3, fabs(L[i][1] - 2 * coef[i]));
        e3 = fmax(e3, fabs(L[i][2] + coef[i]));
        if (L[i][3] != 0.f) nonzero_tail++;
    }
    for (int i = N2; i < CUBE_TEXELS; i++) nonzero_tail += L[i][0] != 0.f || L[i][1] != 0.f || L[i][2] != 0.f || L[i][3] != 0.f;
    CHECK_LE(e3, 4e-3, "sh_light_from_cube per channel");
    CHECK(nonzero_tail == 0, "%d rows/pads not zeroed", nonzero_tail);
    free(f); free(T); free(rgb); free(L);
}

/* Funk-Hecke: clamped cosine about n has coefficients lambda_l Y_lm(n),
 * lambda = (pi, 2pi/3, pi/4, 0, -pi/24). Also the light x transport inner product. */
static void clamped_cosine(void) {
    enum { RES = 64, NT = 6 * RES * RES, ORD = 5, N2 = ORD * ORD };
    const double lambda[ORD] = { PI, 2 * PI / 3, PI / 4, 0, -PI / 24 };
    const float normals[3][3] = { { 0, 0, 1 }, { 0, 1, 0 }, { 0.48f, -0.6f, 0.64f } };
    float *T = malloc(sizeof(float) * NT), *Lcube = malloc(sizeof(float) * NT);
    for (int k = 0; k < 3; k++) {
        const float *n = normals[k];
        for (int j = 0; j < NT; j++) {
            float d[3];
            cube_texel_dir(RES, j, d);
            double c = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            int r = j % (RES * RES);
            T[j] = (float)(fmax(c, 0) * cube_texel_solid_angle(RES, r % RES, r / RES));
        }
        float c[N2], yn[N2];
        sh_project_cube(T, RES, ORD, false, c);
        sh_eval(ORD, n, yn);
        double maxerr = 0;
        for (int l = 0; l < ORD; l++)
            for (int m = -l; m <= l; m++) {
                int i = l * (l + 1) + m;
                maxerr = fmax(maxerr, fabs(c[i] - lambda[l] * yn[i]));
            }
        CHECK_LE(maxerr, 2e-3, "clamped cosine about normal %d: Funk-Hecke coefficients", k);
        if (k == 0) {
            CHECK_NEAR(c[0], PI * 0.5 / sqrt(PI), 1e-3, "pi Y00");
            CHECK_NEAR(c[2], 2 * PI / 3 * sqrt(3 / (4 * PI)), 1e-3, "2pi/3 Y10(z)");
            CHECK_NEAR(c[6], PI / 4 * sqrt(5 / (4 * PI)), 1e-3, "pi/4 Y20(z)");
        }
        /* Band-limited light (order 3): the SH inner product equals the texel-domain integral. */
        float y[9];
        double direct = 0;
        for (int j = 0; j < NT; j++) {
            float d[3];
            cube_texel_dir(RES, j, d);
            sh_eval(3, d, y);
            Lcube[j] = 1.0f + 0.5f * y[1] - 0.8f * y[2] + 0.3f * y[7];   /* any band <= 2 function */
            direct += (double)Lcube[j] * T[j];
        }
        float Lc[N2];
        sh_project_cube(Lcube, RES, ORD, true, Lc);
        double inner = 0;
        for (int i = 0; i < N2; i++) inner += (double)Lc[i] * c[i];
        CHECK_NEAR(inner, direct, 2e-3 * fabs(direct), "sum_i L_i c_i = sum_j L_j T_j for band-limited light");
    }
    free(T); free(Lcube);
}

/* The table path and the direct path agree. */
static void table_matches(void) {
    enum { RES = 32, NT = 6 * RES * RES, ORD = 8, N2 = ORD * ORD };
    unsigned s = 3;
    float *f = malloc(sizeof(float) * NT);
    for (int j = 0; j < NT; j++) f[j] = rnd(&s) < 0.3 ? 0.f : (float)rnd(&s);
    sh_table t;
    prt_error err;
    CHECK(sh_table_init(&t, RES, ORD, &err) == 0, "%s", err.msg);
    float a[N2], b[N2], c2[N2], d2[N2];
    sh_project_cube(f, RES, ORD, true, a);
    sh_table_project(&t, f, 1, true, b);
    sh_project_cube(f, RES, ORD, false, c2);
    sh_table_project(&t, f, 1, false, d2);
    double e = 0;
    for (int i = 0; i < N2; i++) e = fmax(e, fmax(fabs(a[i] - b[i]), fabs(c2[i] - d2[i]) / NT));
    CHECK_LE(e, 1e-4, "sh_table_project matches sh_project_cube");
    sh_table_free(&t);
    free(f);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(closed_form);
    CHECK_CASE(poles_order16);
    CHECK_CASE(orthonormal_exact);
    CHECK_CASE(orthonormal_cube);
    CHECK_CASE(bandlimited);
    CHECK_CASE(clamped_cosine);
    CHECK_CASE(table_matches);
    return check_summary();
}
