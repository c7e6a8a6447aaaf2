/* kernel.c - the CPU light change: Eq. 5's g = T x L for every vector of a finished set.
 *
 * Contract: transport_light_range computes g[3i + ch] = scale_i,ch * sum_c q_c,ch L[index_c][ch] for
 * vectors [first, last) (transport.h's layout); transport_light and transport_light_with split every
 * vector across the cores. Non-finite sums are stored as 0 (a corrupt light never poisons a frame).
 *
 * Why this shape (section 4.1.2, 4.3): the kernel walks each vector's runs with a base pointer
 * L + 256*block and accumulates value * L[offset] in float RGB(A) lanes: with 8-bit data one 32-bit
 * word gives the offset and the three int8 values, which SSE4.1 sign-extends to int32 lanes straight
 * from memory; the per-channel scale is applied once per vector at the end. Vectors are split across
 * the cores in chunks of a few thousand. The loop is short and sensitive to code alignment: changes
 * here are timed with `prt bench --backend cpu` (docs/design/transport.md). */
#include "transport.h"
#include <math.h>
#include <string.h>
#ifdef __SSE4_1__
#include <smmintrin.h>
#endif

static inline float finite_or_zero(float x) { return isfinite(x) ? x : 0.f; }

#ifdef __SSE4_1__
/* acc += L[base + offset] * (r, g, b, junk) for the 8-bit word at wp. The three int8
 * values are sign-extended straight from memory starting at the word's byte 1, so
 * lane 3 holds the next word's offset byte: it multiplies L's padding lane, which is
 * never read. That read touches one byte past the word, so the very last word of the
 * array goes through mac8_safe, which shifts the word in a register instead. */
static inline __m128 mac8(__m128 acc, const float (*base)[4], const uint32_t *wp) {
    int32_t rgbx;
    memcpy(&rgbx, (const char *)wp + 1, sizeof rgbx);
    __m128 q = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(rgbx)));
    return _mm_add_ps(acc, _mm_mul_ps(_mm_loadu_ps(base[*wp & 255u]), q));
}
/* mac8 without reading past the word. */
static inline __m128 mac8_safe(__m128 acc, const float (*base)[4], const uint32_t *wp) {
    __m128 q = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128((int)(*wp >> 8))));
    return _mm_add_ps(acc, _mm_mul_ps(_mm_loadu_ps(base[*wp & 255u]), q));
}
#endif

/* Eq. 5's g = T x L for vectors [first, last): 8-bit words, SSE4.1 when available.
 * Runs give the block base; two accumulators hide the add latency; the scale is
 * applied once per vector. */
static void light_range8(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    const uint32_t *packed = t->packed;
    const uint8_t *runs = t->runs;
    const uint32_t *array_end = packed + t->coef_first[t->nvecs];
    for (int i = first; i < last; i++) {
        const uint32_t *w = packed + t->coef_first[i];
        uint32_t r0 = t->run_first[i], r1 = t->run_first[i + 1];
#ifdef __SSE4_1__
        __m128 a0 = _mm_setzero_ps(), a1 = _mm_setzero_ps();
        if (packed + t->coef_first[i + 1] < array_end) {
            for (uint32_t r = r0; r < r1; r++) {
                const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
                const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
                for (; w + 1 < end; w += 2) {
                    a0 = mac8(a0, base, w);
                    a1 = mac8(a1, base, w + 1);
                }
                if (w < end) a0 = mac8(a0, base, w++);
            }
        } else {   /* the vector that ends the array */
            for (uint32_t r = r0; r < r1; r++) {
                const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
                const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
                for (; w < end; w++) a0 = mac8_safe(a0, base, w);
            }
        }
        float acc[4];
        _mm_storeu_ps(acc, _mm_add_ps(a0, a1));
#else
        float acc[4] = { 0, 0, 0, 0 };
        (void)array_end;
        for (uint32_t r = r0; r < r1; r++) {
            const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
            const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
            for (; w < end; w++) {
                const float *l = base[*w & 255u];
                acc[0] += (float)(int8_t)(*w >> 8) * l[0];
                acc[1] += (float)(int8_t)(*w >> 16) * l[1];
                acc[2] += (float)(int8_t)(*w >> 24) * l[2];
            }
        }
#endif
        const float *sc = t->scale + 3 * (size_t)i;
        for (int c = 0; c < 3; c++) g[3 * (size_t)i + c] = finite_or_zero(acc[c] * sc[c]);
    }
}

/* 16-bit and float data: plain scalar loops (not the default format). */
static void light_range_wide(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    for (int i = first; i < last; i++) {
        size_t c = t->coef_first[i];
        float acc[3] = { 0, 0, 0 };
        for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
            const float (*base)[4] = L + (size_t)t->runs[2 * r] * SPARSE_BLOCK;
            size_t end = c + (uint32_t)t->runs[2 * r + 1] + 1;
            for (; c < end; c++) {
                const float *l = base[t->offs[c]];
                if (t->qbits == 16)
                    for (int ch = 0; ch < 3; ch++) acc[ch] += (float)t->q16[3 * c + ch] * l[ch];
                else
                    for (int ch = 0; ch < 3; ch++) acc[ch] += t->f32[3 * c + ch] * l[ch];
            }
        }
        const float *sc = t->scale + 3 * (size_t)i;
        for (int ch = 0; ch < 3; ch++) g[3 * (size_t)i + ch] = finite_or_zero(acc[ch] * sc[ch]);
    }
}

/* g[3i + ch] for vectors [first, last) (after finish). */
void transport_light_range(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    PRT_CHECK(t->coef_first && first >= 0 && last <= t->nvecs);
    if (t->qbits == 8) light_range8(t, L, g, first, last);
    else light_range_wide(t, L, g, first, last);
}

typedef struct light_ctx { const prt_transport *t; const float (*L)[4]; float *g; transport_light_fn kernel; } light_ctx;
/* prt_parallel_for body: one chunk of vectors. */
static void light_chunk(void *p, int begin, int end, int thread) {
    light_ctx *c = p;
    c->kernel(c->t, c->L, c->g, begin, end);
}

/* g for every vector with kernel on nthreads threads (0: all cores); chunks of 2048 vectors keep
 * both cores busy without contention. */
void transport_light_with(const prt_transport *t, const float (*L)[4], float *g, int nthreads, transport_light_fn kernel) {
    light_ctx c = { t, L, g, kernel };
    prt_parallel_for(t->nvecs, 2048, nthreads, light_chunk, &c);
}

/* g for every vector with this module's kernel. */
void transport_light(const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    transport_light_with(t, L, g, nthreads, transport_light_range);
}
