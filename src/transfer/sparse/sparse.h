/* sparse.h - non-linear approximation and 8-bit packing of one transport vector
 * (sections 4.1.1 and 4.1.2).
 *
 * A transport vector is three channels (R, G, B) of CUBE_TEXELS wavelet
 * coefficients. sparse_select keeps the n coefficients of largest energy
 * r^2 + g^2 + b^2 (R, G and B share one index set), with a linear-time
 * selection (radix select on the energies' float bits, O(len)), ties broken by lower
 * index, and returns their indices ascending. Keeping the largest coefficients of
 * an orthonormal basis is the L2-optimal n-term approximation (tested).
 *
 * Quantization: per vector and channel, step = max|x| / qmax (qmax 127 for
 * 8 bits, 32767 for 16); q = round(x / step), so |x - q*step| <= step/2. A
 * zero channel has step 0.
 *
 * Index split (section 4.1.2): index = block*256 + offset, block in 0..95,
 * offset in 0..255. The 8-bit packed word is offset | r<<8 | g<<16 | b<<24 with
 * r, g, b as two's-complement int8 bytes. */
#ifndef PRT_SPARSE_H
#define PRT_SPARSE_H
#include "common.h"
#include "cubemap.h"

#define SPARSE_BLOCK 256
#define SPARSE_NBLOCKS (CUBE_TEXELS / SPARSE_BLOCK)   /* 96 */

/* Selects the n largest-energy coefficients of (r,g,b)[0..len); idx gets them ascending.
 * Coefficients that are exactly zero in all channels are never selected. scratch holds
 * 2*len floats. Returns the count (<= n). */
int sparse_select(const float *r, const float *g, const float *b, int len, int n, uint32_t *idx, float *scratch);

/* Marks in keep[0..n) the k largest of keys[0..n) (every one when k >= n), ties at the k-th to the
 * lower positions; unlike sparse_select, zero keys count. scratch: n floats. Returns how many it marks. */
int sparse_mark_largest(const float *keys, int n, int k, float *scratch, uint8_t *keep);

/* The largest |q| of a qbits-bit value: 127 at 8 bits, 32767 at 16; 0 for 32 (floats, no rounding). */
static inline int sparse_qmax(int qbits) { return qbits == 8 ? 127 : qbits == 16 ? 32767 : 0; }
/* Quantization step for max |x| = maxabs with qmax levels (0 when maxabs is 0 or not finite). */
float sparse_step(float maxabs, int qmax);
/* round(x/step) clamped to [-qmax, qmax]; 0 when step is 0. */
int sparse_quantize(float x, float step, int qmax);

static inline uint32_t sparse_pack8(uint32_t offset, int r, int g, int b) {
    return (offset & 255u) | ((uint32_t)(uint8_t)(int8_t)r << 8) | ((uint32_t)(uint8_t)(int8_t)g << 16) |
           ((uint32_t)(uint8_t)(int8_t)b << 24);
}
static inline void sparse_unpack8(uint32_t w, uint32_t *offset, int *r, int *g, int *b) {
    *offset = w & 255u;
    *r = (int8_t)(uint8_t)(w >> 8);
    *g = (int8_t)(uint8_t)(w >> 16);
    *b = (int8_t)(uint8_t)(w >> 24);
}
#endif
