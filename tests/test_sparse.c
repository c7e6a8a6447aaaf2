/* test_sparse.c - selection of the N largest (against brute-force sorting), L2
 * optimality of the non-linear approximation, quantization bounds, 8-bit packing. */
#include "harness.h"
#include "sparse.h"
#include "haar.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t rnd_u(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return *s; }
static float rnd(uint32_t *s) { return (float)(rnd_u(s) >> 8) / 16777216.f; }

typedef struct ek { double e; uint32_t i; } ek;
static int cmp_ek(const void *a, const void *b) {
    const ek *x = a, *y = b;
    if (x->e != y->e) return x->e < y->e ? 1 : -1;
    return x->i < y->i ? -1 : x->i > y->i;
}

/* Brute force: sort all non-zero coefficients by (energy desc, index asc), keep n, sort indices. */
static int brute_select(const float *r, const float *g, const float *b, int len, int n, uint32_t *out) {
    ek *a = malloc(sizeof(ek) * (size_t)len);
    int m = 0;
    for (int i = 0; i < len; i++) {
        float e = r[i] * r[i] + g[i] * g[i] + b[i] * b[i];   /* the same float expression as sparse.c */
        if (e > 0) a[m++] = (ek){ e, (uint32_t)i };
    }
    qsort(a, (size_t)m, sizeof(ek), cmp_ek);
    int k = n < m ? n : m;
    for (int c = 0; c < k; c++) out[c] = a[c].i;
    for (int x = 1; x < k; x++)   /* insertion sort ascending */
        for (int y = x; y > 0 && out[y - 1] > out[y]; y--) { uint32_t t = out[y]; out[y] = out[y - 1]; out[y - 1] = t; }
    free(a);
    return k;
}

/* Squared L2 error of keeping only idx[0..k) of (r,g,b). */
static double kept_error(const float *r, const float *g, const float *b, int len, const uint32_t *idx, int k) {
    double e = 0;
    char *keep = calloc((size_t)len, 1);
    for (int c = 0; c < k; c++) keep[idx[c]] = 1;
    for (int i = 0; i < len; i++)
        if (!keep[i]) e += (double)r[i] * r[i] + (double)g[i] * g[i] + (double)b[i] * b[i];
    free(keep);
    return e;
}

/* Buffers the cases share: full-length channels, selection scratch and index lists. Each
 * case that draws random numbers seeds its own generator, so a case run alone (a filter)
 * sees the same data as in the whole suite. */
enum { len = CUBE_TEXELS };
static float r[len], g[len], b[len], scratch[2 * len];
static uint32_t idx[len], ref[len];

static void hand_cases(void) {
    /* 1. Small hand case: energies 0, 9, 1, 9, 4 (two tied at 9), n = 2 -> {1, 3}; n = 3 -> {1, 3, 4};
     * n = 10 -> the four non-zero ones, never index 0. */
    {
        float rr[5] = { 0, 3, 1, 0, 2 }, gg[5] = { 0, 0, 0, 3, 0 }, bb[5] = { 0, 0, 0, 0, 0 };
        int k = sparse_select(rr, gg, bb, 5, 2, idx, scratch);
        CHECK(k == 2 && idx[0] == 1 && idx[1] == 3, "n=2: %d %u %u", k, idx[0], idx[1]);
        k = sparse_select(rr, gg, bb, 5, 3, idx, scratch);
        CHECK(k == 3 && idx[0] == 1 && idx[1] == 3 && idx[2] == 4, "n=3: %d", k);
        k = sparse_select(rr, gg, bb, 5, 10, idx, scratch);
        CHECK(k == 4 && idx[0] == 1 && idx[3] == 4, "n=10 keeps only non-zeros: %d", k);
        /* ties: all equal -> lowest indices */
        float one[40], zero[40] = { 0 };
        for (int i = 0; i < 40; i++) one[i] = (i % 2) ? -1.f : 1.f;
        k = sparse_select(zero, one, zero, 40, 7, idx, scratch);
        int ok = k == 7;
        for (int i = 0; i < k; i++) ok &= idx[i] == (uint32_t)i;
        CHECK(ok, "ties go to the lower index");
        /* NaN / Inf coefficients are never selected */
        float nanv[4] = { NAN, 1, INFINITY, 2 };
        k = sparse_select(nanv, zero, zero, 4, 4, idx, scratch);
        CHECK(k == 2 && idx[0] == 1 && idx[1] == 3, "non-finite skipped: %d", k);
        CHECK(sparse_select(zero, zero, zero, 40, 5, idx, scratch) == 0, "all-zero selects nothing");
    }
}

static void brute_force(void) {
    uint32_t s = 2024;
    /* 2. Against brute force on full-length vectors: dense, sparse, heavily tied (few distinct values). */
    {
        int bad = 0, trials = 0;
        int ns[] = { 1, 2, 16, 128, 255, 256, 1000, 5000, 24575, 24576 };
        for (int kind = 0; kind < 3; kind++)
            for (int t = 0; t < 10; t++) {
                for (int i = 0; i < len; i++) {
                    if (kind == 0) { r[i] = rnd(&s) - 0.5f; g[i] = rnd(&s) - 0.5f; b[i] = rnd(&s) - 0.5f; }
                    else if (kind == 1) { float v = rnd(&s) < 0.02f ? rnd(&s) : 0.f; r[i] = v; g[i] = 0.5f * v; b[i] = 0; }
                    else { r[i] = (float)(rnd_u(&s) % 4); g[i] = 0; b[i] = (float)(rnd_u(&s) % 2); }
                }
                int n = ns[t];
                int k = sparse_select(r, g, b, len, n, idx, scratch);
                int kr = brute_select(r, g, b, len, n, ref);
                trials++;
                if (k != kr || memcmp(idx, ref, sizeof(uint32_t) * (size_t)k) != 0) bad++;
            }
        CHECK(bad == 0, "%d of %d selections differ from brute force", bad, trials);
    }
}

static void nonlinear_approximation(void) {
    uint32_t s = 2025;
    /* 3. Non-linear approximation of a Haar-transformed signal: the N largest give a lower
     * L2 error than 200 random other subsets of size N, the error (measured in the texel
     * domain after the inverse transform) matches the wavelet-domain one (Parseval), and it
     * does not increase with N. */
    {
        float *tex[3], *wav[3], tmp[2 * 64 * 64];
        for (int c = 0; c < 3; c++) { tex[c] = malloc(sizeof(float) * len); wav[c] = malloc(sizeof(float) * len); }
        for (int i = 0; i < len; i++) {   /* a smooth lobe plus a hard-edged shadow plus noise */
            float d[3];
            cube_texel_dir(CUBE_RES, i, d);
            float lobe = powf(fmaxf(d[1], 0.f), 8.f), shadow = (d[0] > 0.2f && d[2] > 0.f) ? 0.f : 1.f;
            tex[0][i] = lobe * shadow + 0.01f * rnd(&s);
            tex[1][i] = 0.5f * lobe * shadow + 0.2f * fmaxf(d[2], 0.f);
            tex[2][i] = 0.1f * shadow;
        }
        for (int c = 0; c < 3; c++) haar_cube_forward(tex[c], CUBE_RES, wav[c], tmp);
        double prev = INFINITY;
        int worse = 0, mono_bad = 0, parseval_bad = 0;
        uint32_t *rs = malloc(sizeof(uint32_t) * len);
        for (int n = 1; n <= 4096; n *= 2) {
            int k = sparse_select(wav[0], wav[1], wav[2], len, n, idx, scratch);
            double e = kept_error(wav[0], wav[1], wav[2], len, idx, k);
            if (e > prev * (1 + 1e-9)) mono_bad++;
            prev = e;
            /* texel-domain error of the reconstruction */
            double et = 0;
            float *ap = malloc(sizeof(float) * len), *rec = malloc(sizeof(float) * len);
            for (int c = 0; c < 3; c++) {
                memset(ap, 0, sizeof(float) * len);
                for (int q = 0; q < k; q++) ap[idx[q]] = wav[c][idx[q]];
                haar_cube_inverse(ap, CUBE_RES, rec, tmp);
                for (int i = 0; i < len; i++) et += ((double)rec[i] - tex[c][i]) * ((double)rec[i] - tex[c][i]);
            }
            free(ap); free(rec);
            if (fabs(et - e) > 1e-4 * (e + 1e-6)) parseval_bad++;
            for (int t = 0; t < 200; t++) {
                /* random subset of size n: partial Fisher-Yates over all indices */
                for (int i = 0; i < len; i++) rs[i] = (uint32_t)i;
                for (int i = 0; i < n; i++) { int j = i + (int)(rnd_u(&s) % (uint32_t)(len - i)); uint32_t x = rs[i]; rs[i] = rs[j]; rs[j] = x; }
                if (t < 100) /* half of them: perturb the optimal set by one swap */
                    { memcpy(rs, idx, sizeof(uint32_t) * (size_t)k); rs[rnd_u(&s) % (uint32_t)k] = rnd_u(&s) % (uint32_t)len; }
                if (kept_error(wav[0], wav[1], wav[2], len, rs, n) < e * (1 - 1e-9)) worse++;
            }
        }
        CHECK(worse == 0, "%d random subsets beat the N largest", worse);
        CHECK(mono_bad == 0, "error increased with N %d times", mono_bad);
        CHECK(parseval_bad == 0, "%d texel-domain errors differ from wavelet-domain ones", parseval_bad);
        free(rs);
        for (int c = 0; c < 3; c++) { free(tex[c]); free(wav[c]); }
    }
}

static void quantization(void) {
    uint32_t s = 2026;
    /* 4. Quantization: |x - q step| <= step/2 for 8 and 16 bits; clamping; degenerate steps. */
    {
        int qm[2] = { 127, 32767 };
        for (int k = 0; k < 2; k++) {
            float maxabs = 3.7f, step = sparse_step(maxabs, qm[k]);
            /* the same float division as sparse_step (IEEE, the same bits on any CPU): exact */
            CHECK_NEAR(step, maxabs / qm[k], 0, "step %d", qm[k]);
            double worst = 0;
            int outside = 0;
            for (int t = 0; t < 200000; t++) {
                float x = (2 * rnd(&s) - 1) * maxabs;
                if (t == 0) x = maxabs;
                if (t == 1) x = -maxabs;
                int q = sparse_quantize(x, step, qm[k]);
                if (q < -qm[k] || q > qm[k]) outside++;
                worst = fmax(worst, fabs(x - (double)q * step) / step);
            }
            CHECK_LE(worst, 0.5 + 1e-6, "qmax %d: error/step", qm[k]);
            CHECK(outside == 0, "qmax %d: %d out of range", qm[k], outside);
            CHECK(sparse_quantize(1e30f, step, qm[k]) == qm[k] && sparse_quantize(-1e30f, step, qm[k]) == -qm[k], "clamp");
        }
        CHECK(sparse_step(0, 127) == 0 && sparse_step(INFINITY, 127) == 0 && sparse_step(NAN, 127) == 0, "degenerate steps");
        CHECK(sparse_quantize(5, 0, 127) == 0 && sparse_quantize(NAN, 0.1f, 127) == 0, "zero step / NaN give 0");
    }
}

static void packing(void) {
    /* 5. 8-bit packing: every index 0..24575 split into block/offset, with every int8 value. */
    {
        int bad = 0;
        for (uint32_t i = 0; i < CUBE_TEXELS; i++) {
            uint32_t blk = i / SPARSE_BLOCK, off = i % SPARSE_BLOCK, o2;
            int vr = (int)(i % 255) - 127, vg = 127 - (int)(i % 253), vb = (int)((i * 7) % 255) - 127, r2, g2, b2;
            uint32_t w = sparse_pack8(off, vr, vg, vb);
            sparse_unpack8(w, &o2, &r2, &g2, &b2);
            if (o2 != off || r2 != vr || g2 != vg || b2 != vb || blk * SPARSE_BLOCK + o2 != i || blk >= SPARSE_NBLOCKS) bad++;
        }
        for (int v = -128; v <= 127; v++) {
            uint32_t o2;
            int r2, g2, b2;
            sparse_unpack8(sparse_pack8(255, v, -v - 1, v), &o2, &r2, &g2, &b2);
            if (o2 != 255 || r2 != v || g2 != -v - 1 || b2 != v) bad++;
        }
        CHECK(bad == 0, "%d pack/unpack failures", bad);
    }
}

static void speed(void) {
    uint32_t s = 2027;
    /* 6. Speed of selection (printed): 24576 dense coefficients, N = 128. */
    {
        for (int i = 0; i < len; i++) { r[i] = rnd(&s); g[i] = rnd(&s); b[i] = rnd(&s); }
        double t0 = prt_now();
        int reps = 200;
        for (int t = 0; t < reps; t++) sparse_select(r, g, b, len, 128, idx, scratch);
        printf("sparse_select dense 24576 -> 128: %.1f us\n", 1e6 * (prt_now() - t0) / reps);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(hand_cases);
    CHECK_CASE(brute_force);
    CHECK_CASE(nonlinear_approximation);
    CHECK_CASE(quantization);
    CHECK_CASE(packing);
    CHECK_CASE(speed);
    return check_summary();
}
