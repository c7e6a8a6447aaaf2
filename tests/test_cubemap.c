/* test_cubemap.c - cube-map convention, texel round trips and exact solid angles. */
#include "harness.h"
#include "cubemap.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>

/* Tiny deterministic generator (xorshift) for random directions. */
static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }

static void solid_angle_sums(void) {
    /* 1. Solid angles sum to 4 pi (double, rel 1e-6) at several resolutions. */
    int resl[] = { 1, 2, 3, 16, 64, 128 };
    for (int r = 0; r < 6; r++) {
        int res = resl[r];
        double sum = 0;
        for (int j = 0; j < res; j++)
            for (int i = 0; i < res; i++) sum += 6.0 * cube_texel_solid_angle(res, i, j);
        /* each texel is 4 atan2 values of O(1) differenced (a few ulps, 1e-16 absolute), so
         * the 6 res^2 sum is off by < 1e-11 of 4 pi even at res 128 */
        CHECK_NEAR(sum / (4 * M_PI), 1.0, 1e-6, "res %d", res);
    }
    /* One face of res 1 is a sixth of the sphere: 2 pi / 3 exactly, up to four atan2 values
     * (<= 1 ulp each in any libm variant) and three additions: ~1e-15; 1e-12 leaves room. */
    CHECK_NEAR(cube_texel_solid_angle(1, 0, 0), 4 * M_PI / 6, 1e-12, "res 1 face");
    /* float per-face table sums to 4 pi / 6 too. */
    {
        float *sa = malloc(sizeof(float) * 64 * 64);
        cube_face_solid_angles(64, sa);
        double s = 0;
        for (int k = 0; k < 64 * 64; k++) s += sa[k];
        CHECK_NEAR(6 * s / (4 * M_PI), 1.0, 1e-6, "float table");
        /* the table is the double value rounded to float once: half an ulp */
        double want = cube_texel_solid_angle(64, 7, 5);
        CHECK_NEAR(sa[5 * 64 + 7], want, 0.5 * FLT_EPSILON * want, "table entry");
        free(sa);
    }
}

static void solid_angle_quadrature(void) {
    /* 2. Texel solid angle against brute-force quadrature of dA / (1+x^2+y^2)^(3/2). */
    {
        int res = 4, pts = 400;
        for (int j = 0; j < res; j++)
            for (int i = 0; i < res; i++) {
                double x0 = 2.0 * i / res - 1, y0 = 2.0 * j / res - 1, h = 2.0 / res / pts, acc = 0;
                for (int b = 0; b < pts; b++)
                    for (int a = 0; a < pts; a++) {
                        double x = x0 + (a + 0.5) * h, y = y0 + (b + 0.5) * h;
                        acc += h * h / pow(1 + x * x + y * y, 1.5);
                    }
                CHECK_NEAR(cube_texel_solid_angle(res, i, j), acc, 1e-6 * acc, "texel %d %d", i, j);
            }
    }
}

static void face_convention(void) {
    /* 3. Convention: face centres are the axes, corners follow the GL 4.6 table 8.19. */
    {
        const float axis[6][3] = { { 1, 0, 0 }, { -1, 0, 0 }, { 0, 1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 } };
        /* direction at sc = +1, tc = +1 (x = y = res), unnormalized, from the table */
        const float corner[6][3] = { { 1, -1, -1 }, { -1, -1, 1 }, { 1, 1, 1 }, { 1, -1, -1 }, { 1, -1, 1 }, { -1, -1, -1 } };
        /* direction at sc = +1, tc = -1 (x = res, y = 0) */
        const float corner2[6][3] = { { 1, 1, -1 }, { -1, 1, 1 }, { 1, 1, -1 }, { 1, -1, 1 }, { 1, 1, 1 }, { -1, 1, -1 } };
        for (int f = 0; f < 6; f++) {
            float d[3];
            cube_dir(64, f, 32, 32, d);
            for (int c = 0; c < 3; c++) CHECK_NEAR(d[c], axis[f][c], 1e-6, "face %d", f);
            cube_dir(64, f, 64, 64, d);
            for (int c = 0; c < 3; c++) CHECK_NEAR(d[c], corner[f][c] / sqrtf(3.f), 1e-6, "face %d", f);
            cube_dir(64, f, 64, 0, d);
            for (int c = 0; c < 3; c++) CHECK_NEAR(d[c], corner2[f][c] / sqrtf(3.f), 1e-6, "face %d", f);
            CHECK(cube_texel_index(64, axis[f]) / 4096 == f, "axis face %d", f);
        }
    }
}

static void texel_round_trip(void) {
    /* 4. Every texel centre round-trips at res 64 and 128. */
    int rt[] = { 64, 128 };
    for (int r = 0; r < 2; r++) {
        int res = rt[r], bad = 0, badxy = 0;
        for (int idx = 0; idx < 6 * res * res; idx++) {
            float d[3], x, y;
            int f;
            cube_texel_dir(res, idx, d);
            if (fabsf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1.f) > 1e-6f) bad++;
            if (cube_texel_index(res, d) != idx) bad++;
            cube_lookup(res, d, &f, &x, &y);
            int rr = idx % (res * res);
            if (f != idx / (res * res) || fabsf(x - (rr % res + 0.5f)) > 1e-3f || fabsf(y - (rr / res + 0.5f)) > 1e-3f) badxy++;
        }
        CHECK(bad == 0, "res %d: %d texels do not round-trip", res, bad);
        CHECK(badxy == 0, "res %d: %d texels off in continuous coordinates", res, badxy);
    }
}

static void random_round_trip(void) {
    /* 5. Random directions: lookup then cube_dir gives the direction back. */
    {
        uint32_t s = 12345;
        int bad = 0;
        for (int k = 0; k < 100000; k++) {
            float d[3] = { 2 * rnd(&s) - 1, 2 * rnd(&s) - 1, 2 * rnd(&s) - 1 }, e[3], x, y;
            float l = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (l < 1e-3f) continue;
            int f;
            cube_lookup(128, d, &f, &x, &y);
            cube_dir(128, f, x, y, e);
            for (int c = 0; c < 3; c++)
                if (fabsf(e[c] - d[c] / l) > 2e-6f) bad++;
        }
        CHECK(bad == 0, "%d components off", bad);
    }
}

static void zero_direction(void) {
    /* 6. A zero direction does not crash and gives a valid texel. */
    {
        float z[3] = { 0, 0, 0 };
        int idx = cube_texel_index(64, z);
        CHECK(idx >= 0 && idx < CUBE_TEXELS, "zero direction -> %d", idx);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(solid_angle_sums);
    CHECK_CASE(solid_angle_quadrature);
    CHECK_CASE(face_convention);
    CHECK_CASE(texel_round_trip);
    CHECK_CASE(random_round_trip);
    CHECK_CASE(zero_direction);
    return check_summary();
}
