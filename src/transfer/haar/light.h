/* light.h - the light vector (section 4.3): cube map -> Haar -> 16-bit quantization.
 *
 * light_from_cube takes the probe resampled to the 6x64x64 cube map (radiance,
 * interleaved RGB) and returns the light vector in wavelet-index order
 * (haar.h), L[idx][0..2] = R, G, B, L[idx][3] = 0. Coefficients whose energy is
 * below threshold * (largest coefficient's energy) are zeroed (the paper's
 * threshold), then each channel is quantized to 16 bits with a per-channel step
 * max|L| / 32767 and stored dequantized (so both the CPU and the GPU paths
 * use the same 16-bit values). With qbits 32 no quantization is done.
 *
 * With transport T_k(x, w_j) = g_k V (n.w) dw_j integrated over texel j (solid angle
 * included) and L_j the mean radiance over texel j, sum_j L_j T_kj approximates
 * Eq. 4's integral, and by Parseval so does the wavelet-domain inner product. */
#ifndef PRT_LIGHT_H
#define PRT_LIGHT_H
#include "common.h"
#include "cubemap.h"

typedef struct light_desc {
    float threshold;   /* relative energy threshold; 0: 1e-12 (keeps the sun's 34,000:1 range) */
    int qbits;         /* 16 (default when 0) or 32 */
    const float *face_weight;  /* [CUBE_RES^2]: every face's texels are multiplied by these before
                                * the transform (transfer_haar.c's solid-angle measure); NULL: 1 */
} light_desc;

typedef struct light_stats {
    int kept;          /* non-zero coefficients after thresholding */
    float step[3];     /* quantization step per channel */
} light_stats;

/* cube_rgb: [CUBE_TEXELS][3]. L: [CUBE_TEXELS][4] (16-byte aligned). stats may be NULL. */
void light_from_cube(const float *cube_rgb, const light_desc *desc, float (*L)[4], light_stats *stats);
#endif
