/* test_light.c - the light vector: constant radiance, Eq. 4's texel-domain sum vs the
 * wavelet-domain product within the 16-bit step bound, thresholding, robustness. */
#include "harness.h"
#include "light.h"
#include "haar.h"
#include "transfer.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }
enum { T = CUBE_TEXELS };

/* Fills cube (3 x CUBE_TEXELS, interleaved) with the probe of cases 2 and 3: a sky
 * gradient plus a 34,000 sun, with a little noise in red. */
static void sun_sky_cube(float *cube) {
    uint32_t s = 77;
    float sun[3] = { 0.3f, 0.8f, 0.52f };
    float ls = sqrtf(sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]);
    for (int k = 0; k < T; k++) {
        float d[3];
        cube_texel_dir(CUBE_RES, k, d);
        float sky = 0.5f + 0.5f * d[1], dot = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2]) / ls;
        float hot = dot > 0.9995f ? 34000.f : 0.f;
        cube[3 * k] = sky + hot + 0.1f * rnd(&s);
        cube[3 * k + 1] = 0.8f * sky + hot;
        cube[3 * k + 2] = 1.2f * sky + 0.9f * hot;
    }
}

static void constant_radiance(void) {
    float *cube = malloc(sizeof(float) * 3 * T);
    float (*L)[4] = transfer_light_alloc();
    light_stats st;
    CHECK(L != NULL && ((uintptr_t)L % 64) == 0, "light_alloc aligned");
    /* 1. Constant radiance c: only each face's scaling coefficient, c * 4096 / 64 = 64 c. */
    {
        const float c[3] = { 1.5f, 0.25f, 3.0f };
        for (int k = 0; k < T; k++) for (int ch = 0; ch < 3; ch++) cube[3 * k + ch] = c[ch];
        light_from_cube(cube, NULL, L, &st);
        int bad = 0;
        for (int k = 0; k < T; k++)
            for (int ch = 0; ch < 4; ch++) {
                double want = (k % 4096 == 0 && ch < 3) ? 64.0 * c[ch] : 0.0;
                if (fabs(L[k][ch] - want) > 1e-6 * 64 * c[ch % 3]) bad++;
            }
        CHECK(bad == 0, "%d coefficients off for constant radiance", bad);
        CHECK(st.kept == 6, "kept %d", st.kept);
        /* the step is max|L| / 32767 in float (max|L| = 192 exactly): one float rounding */
        CHECK_NEAR(st.step[2], 64.0 * 3.0 / 32767, 0.5 * FLT_EPSILON * (64.0 * 3.0 / 32767), "step");
    }
    free(cube); free(L);
}

static void wavelet_product(void) {
    float *cube = malloc(sizeof(float) * 3 * T);
    float (*L)[4] = transfer_light_alloc();
    light_stats st;
    /* 2. Eq. 4: sum_j L_j T_j (texels, radiance x transport that includes solid angle)
     * equals the wavelet-domain dot product within sum_i |T_i| * (step/2) for 16 bits,
     * and to float precision without quantization. Probe: sky gradient plus a 34,000 sun. */
    {
        float sa[4096], *tt[3], *tw[3], tmp[2 * 4096];
        cube_face_solid_angles(CUBE_RES, sa);
        sun_sky_cube(cube);
        for (int ch = 0; ch < 3; ch++) {
            tt[ch] = malloc(sizeof(float) * T);
            tw[ch] = malloc(sizeof(float) * T);
        }
        float n[3] = { 0.2f, 0.9f, -0.1f };
        for (int k = 0; k < T; k++) {   /* transport: albedo/pi * cos * V * dw, a shadowing wedge */
            float d[3];
            cube_texel_dir(CUBE_RES, k, d);
            float cs = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            float v = (cs > 0 && !(d[0] > 0.1f && d[2] > 0.f)) ? cs * sa[k % 4096] / (float)M_PI : 0.f;
            tt[0][k] = 0.7f * v; tt[1][k] = 0.5f * v; tt[2][k] = 0.3f * v;
        }
        for (int ch = 0; ch < 3; ch++) haar_cube_forward(tt[ch], CUBE_RES, tw[ch], tmp);
        for (int q = 0; q < 2; q++) {
            light_desc desc = { .threshold = 0, .qbits = q ? 32 : 16 };
            light_from_cube(cube, &desc, L, &st);
            for (int ch = 0; ch < 3; ch++) {
                double texel = 0, mag = 0, wav = 0, l1 = 0;
                for (int k = 0; k < T; k++) {
                    texel += (double)cube[3 * k + ch] * tt[ch][k];
                    mag += fabs((double)cube[3 * k + ch] * tt[ch][k]);
                    wav += (double)L[k][ch] * tw[ch][k];
                    l1 += fabs(tw[ch][k]);
                }
                /* quantization bound + the 1e-12 energy threshold (1e-6 of the largest
                 * amplitude per dropped coefficient) + float rounding of the transforms */
                double lmax = 0;
                for (int k = 0; k < T; k++) lmax = fmax(lmax, fabs(L[k][ch]));
                double bound = l1 * (q ? 0 : 0.5 * st.step[ch]) + l1 * 1e-6 * lmax * sqrt(3.0) + 2e-6 * mag;
                CHECK_LE(fabs(wav - texel), bound, "q%d ch %d: texel %.9g wavelet %.9g", q ? 32 : 16, ch, texel, wav);
                if (q == 0) CHECK_NEAR(st.step[ch], lmax / 32767, 1e-6 * lmax / 32767, "ch %d step", ch);
            }
            CHECK(q == 0 || (st.step[0] == 0 && st.step[1] == 0 && st.step[2] == 0), "qbits 32: no step");
        }
        /* every 16-bit value is an integer multiple of the step */
        light_from_cube(cube, NULL, L, &st);
        int off = 0;
        for (int k = 0; k < T; k++)
            for (int ch = 0; ch < 3; ch++) {
                double q = L[k][ch] / st.step[ch];
                if (fabs(q - nearbyint(q)) > 1e-6 * fabs(q) + 1e-6 || fabs(q) > 32767.5) off++;
            }
        CHECK(off == 0, "%d values off the 16-bit grid", off);
        for (int ch = 0; ch < 3; ch++) { free(tt[ch]); free(tw[ch]); }
    }
    free(cube); free(L);
}

static void threshold(void) {
    float *cube = malloc(sizeof(float) * 3 * T);
    float (*L)[4] = transfer_light_alloc();
    light_stats st;
    /* 3. Threshold: exactly the coefficients with energy >= threshold * max survive
     * (brute force: own planar transform; qbits 32 so quantization cannot zero any). */
    {
        float tmp[2 * 4096];
        sun_sky_cube(cube);
        light_desc desc = { .threshold = 1e-4f, .qbits = 32 };
        light_from_cube(cube, &desc, L, &st);
        float *pl = malloc(sizeof(float) * T), *w[3];
        double emax = 0;
        for (int ch = 0; ch < 3; ch++) {
            w[ch] = malloc(sizeof(float) * T);
            for (int k = 0; k < T; k++) pl[k] = cube[3 * k + ch];
            haar_cube_forward(pl, CUBE_RES, w[ch], tmp);
        }
        for (int k = 0; k < T; k++) emax = fmax(emax, (double)w[0][k] * w[0][k] + (double)w[1][k] * w[1][k] + (double)w[2][k] * w[2][k]);
        int expect = 0, mism = 0;
        for (int k = 0; k < T; k++) {
            double e = (double)w[0][k] * w[0][k] + (double)w[1][k] * w[1][k] + (double)w[2][k] * w[2][k];
            int keep = e >= 1e-4 * emax;
            expect += keep;
            for (int ch = 0; ch < 3; ch++)
                if (L[k][ch] != (keep ? w[ch][k] : 0.f)) mism++;
        }
        CHECK(st.kept == expect && expect > 6 && expect < T, "kept %d expected %d", st.kept, expect);
        CHECK(mism == 0, "%d coefficients differ from the brute-force threshold", mism);
        for (int ch = 0; ch < 3; ch++) free(w[ch]);
        free(pl);
    }
    free(cube); free(L);
}

static void non_finite(void) {
    float *cube = malloc(sizeof(float) * 3 * T);
    float (*L)[4] = transfer_light_alloc();
    light_stats st;
    /* 4. Non-finite texels do not reach the output; an all-zero cube gives zeros. */
    {
        for (int k = 0; k < 3 * T; k++) cube[k] = 1.f;
        cube[5] = NAN; cube[100] = INFINITY; cube[3000] = -INFINITY;
        light_from_cube(cube, NULL, L, &st);
        int bad = 0;
        for (int k = 0; k < T; k++) for (int ch = 0; ch < 4; ch++) bad += !isfinite(L[k][ch]);
        CHECK(bad == 0, "%d non-finite outputs", bad);
        memset(cube, 0, sizeof(float) * 3 * T);
        light_from_cube(cube, NULL, L, &st);
        int nz = 0;
        for (int k = 0; k < T; k++) for (int ch = 0; ch < 4; ch++) nz += L[k][ch] != 0;
        CHECK(nz == 0 && st.kept == 0 && st.step[0] == 0, "zero cube: %d non-zeros", nz);
    }
    free(cube); free(L);
}

static void speed(void) {
    float *cube = malloc(sizeof(float) * 3 * T);
    float (*L)[4] = transfer_light_alloc();
    light_stats st;
    /* 5. Speed (printed): one light update. */
    {
        uint32_t s = 3;
        for (int k = 0; k < 3 * T; k++) cube[k] = rnd(&s);
        struct timespec a, b;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        for (int r = 0; r < 50; r++) light_from_cube(cube, NULL, L, &st);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        printf("light_from_cube: %.0f us CPU\n", 1e6 * ((double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec)) / 50);
    }
    free(cube); free(L);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(constant_radiance);
    CHECK_CASE(wavelet_product);
    CHECK_CASE(threshold);
    CHECK_CASE(non_finite);
    CHECK_CASE(speed);
    return check_summary();
}
