/* light.c - the runtime light vector (section 4.3): cube map -> Haar -> threshold -> 16 bits.
 *
 * Each time the lighting changes the probe, resampled to the 6 x 64 x 64 cube,
 * is transformed with the same orthonormal Haar basis and Morton index order as
 * the transport vectors (haar.h), so Eq. 5's T x L is a sparse dot product in
 * wavelet space. Tiny coefficients (energy below threshold x the largest) are
 * dropped as in the paper; the default 1e-12 relative energy (1e-6 in
 * amplitude) keeps the full dynamic range of a probe whose sun is 34,000 times
 * the sky. Each channel is then quantized to signed 16 bits (step max|L|/32767)
 * and stored dequantized, so the CPU and GPU paths multiply the same values.
 *
 * L_j is the mean radiance over texel j (no solid angle): the transport texels
 * already carry dw_j (light.h), so sum_j L_j T_j is Eq. 4's cubature.
 *
 * No allocation: one face is transformed at a time in 32 KB of stack. */
#include "light.h"
#include "haar.h"
#include "sparse.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Power-of-two exponent e such that every finite weighted texel times 2^-e stays below 2^96:
 * the orthonormal Haar scaling coefficient of a face is 64x its mean, and energies are squares,
 * so a texel of 1e37 (finite) would overflow the float transform and make the threshold
 * infinite, cutting every coefficient. Scaling by a power of two is exact. */
static int light_shift(const float *cube_rgb, const light_desc *desc) {
    float m = 0;
    for (int k = 0; k < CUBE_TEXELS; k++) {
        float w = desc && desc->face_weight ? fabsf(desc->face_weight[k % (CUBE_RES * CUBE_RES)]) : 1.f;
        for (int c = 0; c < 3; c++) {
            float x = fabsf(cube_rgb[3 * k + c]) * w;   /* may be Inf for a weight > 1: still bounded below */
            if (isfinite(cube_rgb[3 * k + c]) && x > m) m = x;
        }
    }
    int e;
    frexpf(m, &e);
    return e > 96 ? e - 96 : 0;
}

/* Undoes light_shift's scale on L (exact), clamping to the float range; stats' steps likewise. */
static void light_unshift(float (*L)[4], int shift, float step[3]) {
    if (!shift) return;
    for (int k = 0; k < CUBE_TEXELS; k++)
        for (int c = 0; c < 3; c++) {
            float v = ldexpf(L[k][c], shift);
            L[k][c] = isfinite(v) ? v : copysignf(FLT_MAX, L[k][c]);
        }
    for (int c = 0; c < 3; c++) step[c] = fminf(ldexpf(step[c], shift), FLT_MAX);
}

/* Writes the light vector of cube_rgb into L (see light.h); stats may be NULL. */
void light_from_cube(const float *cube_rgb, const light_desc *desc, float (*L)[4], light_stats *stats) {
    float threshold = desc && desc->threshold > 0 ? desc->threshold : 1e-12f;
    int qbits = desc && desc->qbits == 32 ? 32 : 16;
    enum { R = CUBE_RES, NN = CUBE_RES * CUBE_RES };
    int shift = light_shift(cube_rgb, desc);
    float face[NN], tmp[NN];
    /* Morton position of every quadrant-layout position, once (the same for all faces). */
    uint16_t morton[NN];
    for (int j = 0; j < R; j++)
        for (int i = 0; i < R; i++) morton[j * R + i] = (uint16_t)haar_morton((uint32_t)i, (uint32_t)j);
    for (int f = 0; f < 6; f++)
        for (int c = 0; c < 3; c++) {
            const float *src = cube_rgb + (size_t)f * NN * 3 + c;
            for (int k = 0; k < NN; k++) {
                float x = src[3 * k];
                face[k] = isfinite(x) ? ldexpf(x, -shift) : 0.f;   /* a broken texel must not poison the whole face */
            }
            if (desc && desc->face_weight)
                for (int k = 0; k < NN; k++) face[k] *= desc->face_weight[k];
            haar_forward(face, R, tmp);
            float (*dst)[4] = L + (size_t)f * NN;
            for (int k = 0; k < NN; k++) dst[morton[k]][c] = face[k];
        }
    /* Threshold on energy relative to the largest coefficient (section 4.3). */
    double emax = 0;
    for (int k = 0; k < CUBE_TEXELS; k++) {
        double e = (double)L[k][0] * L[k][0] + (double)L[k][1] * L[k][1] + (double)L[k][2] * L[k][2];
        if (e > emax) emax = e;
    }
    double cut = (double)threshold * emax;
    float maxabs[3] = { 0, 0, 0 };
    for (int k = 0; k < CUBE_TEXELS; k++) {
        double e = (double)L[k][0] * L[k][0] + (double)L[k][1] * L[k][1] + (double)L[k][2] * L[k][2];
        if (e < cut || !isfinite(e)) L[k][0] = L[k][1] = L[k][2] = 0.f;
        L[k][3] = 0.f;
        for (int c = 0; c < 3; c++) {
            float a = fabsf(L[k][c]);
            maxabs[c] = a > maxabs[c] ? a : maxabs[c];
        }
    }
    /* 16-bit uniform quantization per channel, stored dequantized. */
    float step[3] = { 0, 0, 0 };
    if (qbits == 16)
        for (int c = 0; c < 3; c++) step[c] = sparse_step(maxabs[c], 32767);
    int kept = 0;
    if (qbits == 16) {
        /* sparse_quantize inlined: round(x / step) clamped, as a SIMD-friendly float loop */
        float inv[3];
        for (int c = 0; c < 3; c++) inv[c] = step[c] > 0 ? 1.f / step[c] : 0.f;
        for (int k = 0; k < CUBE_TEXELS; k++)
            for (int c = 0; c < 3; c++) {
                float q = L[k][c] * inv[c];
                q = q > 32767.f ? 32767.f : q < -32767.f ? -32767.f : q;
                L[k][c] = nearbyintf(q) * step[c];
            }
    }
    light_unshift(L, shift, step);
    for (int k = 0; k < CUBE_TEXELS; k++) kept += L[k][0] != 0.f || L[k][1] != 0.f || L[k][2] != 0.f;
    if (stats) {
        stats->kept = kept;
        for (int c = 0; c < 3; c++) stats->step[c] = step[c];
    }
}
