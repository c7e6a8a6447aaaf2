/* sparse.c - non-linear approximation (keep the N largest) and uniform quantization
 * of one transport vector (sections 4.1.1 and 4.1.2).
 *
 * Selection is a radix select on the energies' float bit patterns (a
 * non-negative float orders like its bits): histograms over 11 + 11 + 10 bits
 * find the n-th largest energy exactly, then one pass in index order keeps every
 * larger energy and the lowest-index ones equal to it. So "the n largest, ties
 * to the lower index" costs five branch-light passes over the vector (tens of
 * microseconds for 24,576 coefficients) instead of a comparison sort or a
 * branchy quickselect.
 * Zero (and non-finite) coefficients never become candidates, so an occluded
 * vertex stores nothing. */
#include "sparse.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

/* Energies as float bit patterns into E[len] (non-negative floats order like their
 * bits). Zero, underflowing (< ~1e-45) and non-finite energies become 0; a finite
 * energy beyond FLT_MAX saturates. The common case is one SIMD float pass; a
 * double-precision pass runs only when something overflowed or was not finite. */
static void energies(const float *r, const float *g, const float *b, int len, uint32_t *E) {
    bool bad = false;
    int i = 0;
#ifdef __SSE2__
    __m128 inf = _mm_set1_ps(INFINITY), nf = _mm_setzero_ps();
    for (; i + 4 <= len; i += 4) {
        __m128 x = _mm_loadu_ps(r + i), y = _mm_loadu_ps(g + i), z = _mm_loadu_ps(b + i);
        __m128 e = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z));
        nf = _mm_or_ps(nf, _mm_cmpnlt_ps(e, inf));      /* e >= inf or NaN */
        _mm_storeu_si128((__m128i *)(void *)(E + i), _mm_castps_si128(e));
    }
    bad = _mm_movemask_ps(nf) != 0;
#endif
    for (; i < len; i++) {
        float e = r[i] * r[i] + g[i] * g[i] + b[i] * b[i];
        memcpy(&E[i], &e, sizeof e);
        bad |= !(e < INFINITY);
    }
    if (!bad) return;
    for (i = 0; i < len; i++) {
        double e = (double)r[i] * r[i] + (double)g[i] * g[i] + (double)b[i] * b[i];
        float f = !(e < INFINITY) ? 0.f : e > FLT_MAX ? FLT_MAX : (float)e;
        memcpy(&E[i], &f, sizeof f);
    }
}

/* Histogram of bits [sh, sh+w) of the energies whose bits above sh+w equal prefix
 * (constant shifts once inlined; the prefix test is rarely true after level 1). */
static inline void level_hist(const uint32_t *E, int len, uint32_t prefix, int sh, int w, uint32_t *hist) {
    uint32_t mask = (1u << w) - 1u;
    memset(hist, 0, sizeof(uint32_t) << w);
    for (int i = 0; i < len; i++)
        if ((E[i] >> (sh + w)) == prefix) hist[(E[i] >> sh) & mask]++;
}

/* Moves down from the top bin until `above` plus the bin reaches n; returns that bin. */
static inline uint32_t boundary_bin(const uint32_t *hist, int w, int n, uint32_t *above) {
    int B = (1 << w) - 1;
    while (*above + hist[B] < (uint32_t)n) *above += hist[B--];
    return (uint32_t)B;
}

/* Indices of the n largest-energy coefficients, ascending, into idx; returns the count.
 *
 * Radix select over the 32 energy bits in levels of 11, 11 and 10 bits: the
 * histograms find the exact bit pattern T of the n-th largest energy and how many
 * coefficients equal to T to keep; one final pass in index order keeps every
 * energy above T and the first (lowest-index) ones equal to T.
 * scratch: 2*len floats (the first len hold the energy bits). */
int sparse_select(const float *r, const float *g, const float *b, int len, int n, uint32_t *idx, float *scratch) {
    if (len <= 0 || n <= 0) return 0;
    uint32_t *E = (uint32_t *)(void *)scratch;
    energies(r, g, b, len, E);
    uint32_t hist[2][1u << 11];
    /* level 1: bits 21..31, two interleaved histograms (concentrated energies would
     * otherwise serialize on one counter) */
    memset(hist, 0, sizeof hist);
    int i = 0;
    for (; i + 1 < len; i += 2) { hist[0][E[i] >> 21]++; hist[1][E[i + 1] >> 21]++; }
    if (i < len) hist[0][E[i] >> 21]++;
    for (int k = 0; k < 2048; k++) hist[0][k] += hist[1][k];
    if (len - hist[0][0] <= (uint32_t)n) {
        /* maybe at most n non-zero energies (bin 0 also holds tiny non-zeros: count exactly) */
        uint32_t nz = 0;
        for (int j = 0; j < len; j++) nz += E[j] != 0;
        if (nz <= (uint32_t)n) {
            int k = 0;
            for (int j = 0; j < len; j++)
                if (E[j]) idx[k++] = (uint32_t)j;
            return k;
        }
    }
    uint32_t above = 0;   /* energies above the current prefix range (all kept) */
    uint32_t T = boundary_bin(hist[0], 11, n, &above);
    level_hist(E, len, T, 10, 11, hist[0]);
    T = (T << 11) | boundary_bin(hist[0], 11, n, &above);
    level_hist(E, len, T, 0, 10, hist[0]);
    T = (T << 10) | boundary_bin(hist[0], 10, n, &above);
    uint32_t need_eq = (uint32_t)n - above;
    PRT_CHECK(T != 0 && need_eq >= 1);
    int k = 0;
    for (i = 0; i < len; i++) {
        uint32_t e = E[i];
        if (e > T || (e == T && need_eq)) {
            idx[k++] = (uint32_t)i;
            need_eq -= e == T;
        }
    }
    PRT_CHECK_EQ(k, n);
    return k;
}

/* The k-th largest (0-based) of a[0..m) by quickselect (Hoare; a is reordered): O(m). */
static float kth_largest(float *a, int m, int k) {
    int lo = 0, hi = m - 1;
    while (lo < hi) {
        float p = a[lo + (hi - lo) / 2];
        int i = lo, j = hi;
        while (i <= j) {
            while (a[i] > p) i++;
            while (a[j] < p) j--;
            if (i <= j) { float t = a[i]; a[i] = a[j]; a[j] = t; i++; j--; }
        }
        if (k <= j) hi = j;
        else if (k >= i) lo = i;
        else return a[k];   /* between j and i: every value there is the pivot */
    }
    return a[k];
}

/* See sparse.h. A quickselect, not sparse_select's radix select: the callers' keys are few (a stored
 * vector's coefficients, a feature's candidates) or include zeros that must count. */
int sparse_mark_largest(const float *keys, int n, int k, float *scratch, uint8_t *keep) {
    if (n <= 0) return 0;
    if (k >= n) { memset(keep, 1, (size_t)n); return n; }
    if (k <= 0) { memset(keep, 0, (size_t)n); return 0; }
    memcpy(scratch, keys, sizeof(float) * (size_t)n);
    float thr = kth_largest(scratch, n, k - 1);
    int above = 0;
    for (int j = 0; j < n; j++) above += keys[j] > thr;
    for (int j = 0, ties = k - above; j < n; j++) keep[j] = keys[j] > thr || (keys[j] == thr && ties-- > 0);
    return k;
}

/* max|x| / qmax, or 0 when that is not a usable positive finite step. */
float sparse_step(float maxabs, int qmax) {
    if (!(maxabs > 0) || !isfinite(maxabs) || qmax <= 0) return 0.f;
    float s = maxabs / (float)qmax;
    return s > 0 && isfinite(s) ? s : 0.f;
}

/* round(x/step) clamped to [-qmax, qmax]; 0 when step is 0 or x is not finite. */
int sparse_quantize(float x, float step, int qmax) {
    if (!(step > 0) || !isfinite(x)) return 0;
    double q = round((double)x / (double)step);
    if (q > qmax) q = qmax;
    if (q < -qmax) q = -qmax;
    return (int)q;
}
