/* test_haar.c - orthonormal 2D Haar: hand-computed coefficients, brute-force basis
 * inner products, perfect reconstruction, Parseval, Morton order, speed. */
#include "harness.h"
#include "haar.h"
#include "cubemap.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }

/* Independent truth: value at texel (x, y) of the orthonormal basis function whose
 * coefficient sits at quadrant position (p, q) of a res x res transform. */
static double basis(int res, int p, int q, int x, int y) {
    if (p == 0 && q == 0) return 1.0 / res;
    int m = p > q ? p : q, h = 1;
    while (h * 2 <= m) h *= 2;
    int S = res / h;                       /* support size */
    int bi = p >= h ? p - h : p, bj = q >= h ? q - h : q;
    if (x < bi * S || x >= (bi + 1) * S || y < bj * S || y >= (bj + 1) * S) return 0;
    double sx = (x - bi * S) < S / 2 ? 1 : -1, sy = (y - bj * S) < S / 2 ? 1 : -1;
    double v = 1.0 / S;
    if (p >= h && q < h) return v * sx;    /* dx: left minus right */
    if (p < h && q >= h) return v * sy;    /* dy: top minus bottom */
    return v * sx * sy;                    /* dd */
}

static void hand_2x2(void) {
    static float tmp[2 * 128 * 128];
    /* 1. 2x2 by hand: [1 2; 3 4] -> s = 10/2, dx = (1-2+3-4)/2, dy = (1+2-3-4)/2, dd = 0. */
    {
        float f[4] = { 1, 2, 3, 4 };
        haar_forward(f, 2, tmp);
        CHECK_NEAR(f[0], 5, 1e-6, "s");
        CHECK_NEAR(f[1], -1, 1e-6, "dx");
        CHECK_NEAR(f[2], -2, 1e-6, "dy");
        CHECK_NEAR(f[3], 0, 1e-6, "dd");
    }
}

static void hand_4x4(void) {
    static float tmp[2 * 128 * 128];
    /* 2. 4x4 by hand: a constant has only the scaling coefficient sum/res; a left/right
     * step has one detail (4 at (1,0)); a spike at (0,0) gives 1/4 and 1/2 coefficients. */
    {
        float f[16];
        for (int k = 0; k < 16; k++) f[k] = 1;
        haar_forward(f, 4, tmp);
        CHECK_NEAR(f[0], 16.0 / 4, 1e-6, "scaling = sum/res");
        double rest = 0;
        for (int k = 1; k < 16; k++) rest += fabs(f[k]);
        CHECK_NEAR(rest, 0, 1e-6, "constant has no details");
        for (int k = 0; k < 16; k++) f[k] = (k % 4) < 2 ? 1.f : -1.f;
        haar_forward(f, 4, tmp);
        for (int k = 0; k < 16; k++) CHECK_NEAR(f[k], k == 1 ? 4.0 : 0.0, 1e-6, "step coefficient %d", k);
        memset(f, 0, sizeof f);
        f[0] = 1;
        haar_forward(f, 4, tmp);
        const float want[16] = { .25f, .25f, .5f, 0, .25f, .25f, 0, 0, .5f, 0, .5f, 0, 0, 0, 0, 0 };
        for (int k = 0; k < 16; k++) CHECK_NEAR(f[k], want[k], 1e-6, "spike coefficient %d", k);
    }
}

static void brute_force_basis(void) {
    static float tmp[2 * 128 * 128];
    /* 3. Every coefficient of a random 16x16 face equals the brute-force inner product
     * with the explicitly built orthonormal basis function; the basis is orthonormal. */
    {
        int res = 16, n = res * res;
        float f[256], g[256];
        uint32_t s = 7;
        for (int k = 0; k < n; k++) f[k] = g[k] = rnd(&s) * 2 - 1;
        haar_forward(f, res, tmp);
        double maxerr = 0, maxortho = 0;
        for (int q = 0; q < res; q++)
            for (int p = 0; p < res; p++) {
                double ip = 0;
                for (int y = 0; y < res; y++)
                    for (int x = 0; x < res; x++) ip += basis(res, p, q, x, y) * g[y * res + x];
                maxerr = fmax(maxerr, fabs(ip - f[q * res + p]));
            }
        for (int a = 0; a < n; a++)
            for (int b = a; b < n; b++) {
                double ip = 0;
                for (int t = 0; t < n; t++) ip += basis(res, a % res, a / res, t % res, t / res) * basis(res, b % res, b / res, t % res, t / res);
                maxortho = fmax(maxortho, fabs(ip - (a == b)));
            }
        CHECK_LE(maxerr, 1e-5, "coefficients vs brute-force basis inner products");
        /* exact: the reference values are +-1/S with S a power of two, so these double sums are
         * exact; 1e-12 is slack (the transform's own float rounding: 1e-5 above) */
        CHECK_LE(maxortho, 1e-12, "reference basis orthonormal");
    }
}

static void reconstruction_parseval(void) {
    static float tmp[2 * 128 * 128];
    /* 4. Perfect reconstruction, Parseval (energy and inner products) at 64 and 128. */
    for (int res = 64; res <= 128; res *= 2) {
        int n = res * res;
        float *a = malloc(sizeof(float) * n), *b = malloc(sizeof(float) * n), *a0 = malloc(sizeof(float) * n), *b0 = malloc(sizeof(float) * n);
        uint32_t s = 99;
        for (int k = 0; k < n; k++) {
            a[k] = a0[k] = rnd(&s) * 4 - 1;
            b[k] = b0[k] = (rnd(&s) < 0.05f) ? 100 * rnd(&s) : rnd(&s);
        }
        double ea = 0, eab = 0;
        for (int k = 0; k < n; k++) { ea += (double)a0[k] * a0[k]; eab += (double)a0[k] * b0[k]; }
        haar_forward(a, res, tmp);
        haar_forward(b, res, tmp);
        double ea2 = 0, eab2 = 0, sum = 0;
        for (int k = 0; k < n; k++) { ea2 += (double)a[k] * a[k]; eab2 += (double)a[k] * b[k]; sum += a0[k]; }
        CHECK_NEAR(ea2 / ea, 1, 1e-5, "energy preserved res %d", res);
        CHECK_NEAR(eab2 / eab, 1, 1e-5, "inner product preserved res %d", res);
        CHECK_NEAR(a[0], sum / res, 1e-4 * fabs(sum / res), "scaling coefficient res %d", res);
        haar_inverse(a, res, tmp);
        double me = 0;
        for (int k = 0; k < n; k++) me = fmax(me, fabs(a[k] - a0[k]));
        CHECK_LE(me, 1e-5, "perfect reconstruction res %d", res);
        free(a); free(b); free(a0); free(b0);
    }
}

static void morton(void) {
    /* 5. Morton: round trip, known values, coarse levels first. */
    {
        CHECK(haar_morton(1, 0) == 1 && haar_morton(0, 1) == 2 && haar_morton(1, 1) == 3 && haar_morton(2, 0) == 4 &&
              haar_morton(3, 5) == 0x27, "known Morton codes (3,5) -> %u", haar_morton(3, 5));
        int bad = 0, badorder = 0;
        for (uint32_t j = 0; j < 256; j++)
            for (uint32_t i = 0; i < 256; i++) {
                uint32_t m = haar_morton(i, j), ii, jj;
                haar_unmorton(m, &ii, &jj);
                if (ii != i || jj != j) bad++;
                uint32_t mx = i > j ? i : j, l = 0;
                while ((1u << l) <= mx) l++;   /* i, j < 2^l */
                if (m >= (1u << (2 * l)) || (l > 0 && m < (1u << (2 * (l - 1))))) badorder++;
            }
        CHECK(bad == 0, "%d Morton round-trip failures", bad);
        CHECK(badorder == 0, "%d Morton codes outside their level's range", badorder);
        uint32_t ii, jj;
        haar_unmorton(CUBE_RES * CUBE_RES - 1, &ii, &jj);
        CHECK(ii == CUBE_RES - 1 && jj == CUBE_RES - 1, "last index of a face");
    }
}

static void whole_cube_and_speed(void) {
    static float tmp[2 * 128 * 128];
    /* 6. Whole cube: Morton placement, per-face scaling coefficient, round trip. */
    {
        int res = CUBE_RES, nn = res * res;
        float *t = malloc(sizeof(float) * CUBE_TEXELS), *w = malloc(sizeof(float) * CUBE_TEXELS), *back = malloc(sizeof(float) * CUBE_TEXELS);
        uint32_t s = 3;
        for (int k = 0; k < CUBE_TEXELS; k++) t[k] = rnd(&s);
        haar_cube_forward(t, res, w, tmp);
        int bad = 0;
        double e0 = 0, e1 = 0;
        for (int k = 0; k < CUBE_TEXELS; k++) { e0 += (double)t[k] * t[k]; e1 += (double)w[k] * w[k]; }
        for (int f = 0; f < 6; f++) {
            float face[64 * 64];
            memcpy(face, t + f * nn, sizeof face);
            haar_forward(face, res, tmp + nn);
            double sum = 0;
            for (int k = 0; k < nn; k++) sum += t[f * nn + k];
            CHECK_NEAR(w[f * nn], sum / res, 1e-5 * sum / res, "face %d scaling", f);
            for (int j = 0; j < res; j++)
                for (int i = 0; i < res; i++)
                    if (w[f * nn + haar_morton(i, j)] != face[j * res + i]) bad++;
        }
        CHECK(bad == 0, "%d coefficients not at their Morton index", bad);
        CHECK_NEAR(e1 / e0, 1, 1e-5, "cube energy");
        haar_cube_inverse(w, res, back, tmp);
        double me = 0;
        for (int k = 0; k < CUBE_TEXELS; k++) me = fmax(me, fabs(back[k] - t[k]));
        CHECK_LE(me, 1e-5, "cube round trip");
        /* 7. Speed (printed, not asserted): one 64x64 face, and a whole cube. */
        float face[64 * 64];
        memcpy(face, t, sizeof face);
        int reps = 20000;
        double t0 = prt_now();
        for (int r = 0; r < reps; r++) haar_forward(face, 64, tmp);
        double t1 = prt_now();
        for (int r = 0; r < reps / 6; r++) haar_cube_forward(t, 64, w, tmp);
        double t2 = prt_now();
        printf("haar_forward 64x64: %.2f us/face; haar_cube_forward: %.2f us/cube (%.0f)\n",
               1e6 * (t1 - t0) / reps, 1e6 * (t2 - t1) / (reps / 6), face[0] + w[0]);
        free(t); free(w); free(back);
    }
}

static void small_resolutions(void) {
    static float tmp[2 * 128 * 128];
    /* 8. Small and mid resolutions (generic and tiled scatter paths) round-trip and match Morton placement. */
    for (int res = 1; res <= 32; res *= 2) {
        int nn = res * res, bad = 0;
        float t[6 * 32 * 32], w[6 * 32 * 32], back[6 * 32 * 32], face[32 * 32];
        uint32_t s = 11u + (uint32_t)res;
        for (int k = 0; k < 6 * nn; k++) t[k] = rnd(&s) - 0.3f;
        haar_cube_forward(t, res, w, tmp);
        for (int f = 0; f < 6; f++) {
            memcpy(face, t + f * nn, sizeof(float) * nn);
            haar_forward(face, res, tmp + nn);
            for (int j = 0; j < res; j++)
                for (int i = 0; i < res; i++)
                    if (w[f * nn + haar_morton(i, j)] != face[j * res + i]) bad++;
        }
        haar_cube_inverse(w, res, back, tmp);
        double me = 0;
        for (int k = 0; k < 6 * nn; k++) me = fmax(me, fabs(back[k] - t[k]));
        CHECK(bad == 0, "res %d: %d misplaced", res, bad);
        CHECK_LE(me, 1e-5, "res %d round trip", res);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(hand_2x2);
    CHECK_CASE(hand_4x4);
    CHECK_CASE(brute_force_basis);
    CHECK_CASE(reconstruction_parseval);
    CHECK_CASE(morton);
    CHECK_CASE(whole_cube_and_speed);
    CHECK_CASE(small_resolutions);
    return check_summary();
}
