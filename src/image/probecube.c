/* probecube.c - the probe's fine cube and its rotated resamples (probecube.h).
 *
 * Create: probe_to_cube at src_res without rotation (the area means, refined near suns), then the
 * tables every rotation shares: the unit directions of every target texel's ss x ss sub-samples
 * (6 res^2 ss^2 of them, 1.2 MB at the defaults) and their normalized solid-angle weights (the
 * same on every face), and the directions of the bright source texels' centres and their eight
 * neighbours (where a bilinear tent of theirs reaches).
 *
 * Resample: the target texels those bright directions fall in under R are marked fine; every row
 * of the target is then a sum over its tabulated sub-samples, each rotated by R^T and looked up
 * bilinearly in the source cube. */
#include "probecube.h"
#include "check.h"
#include "cubemap.h"
#include <math.h>
#include <smmintrin.h>
#include <stdlib.h>
#include <string.h>

#define PC_FINE 4          /* a bright texel's sub-samples per source texel side */
#define PC_ROW_MAX 4096    /* sub-samples of a target row (res ss^2), taken four at a time */
#define PC_BRIGHT_MEAN 16  /* a source texel is bright above this times the mean (probe.c's rule)... */
#define PC_BRIGHT_PEAK 1e-3f /* ... and this share of the brightest texel */

struct probe_cube {
    int res, S, ss, threads;
    float *src;            /* [6 S^2][3] the unrotated source cube */
    float *dirs;           /* per target row (face * res + j): x[n], y[n], z[n] of its n = res ss^2 unit
                            * sub-sample directions, texel by texel (SoA: four at a time in pc_taps) */
    float *wts;            /* [res^2 ss^2] their weights, summing to one per texel (every face alike) */
    int nbright;
    float *bright;         /* [9 nbright][3] bright source texels' centres and neighbours, unit */
};

/* The gnomonic area function whose corner differences are a sub-square's solid angle (cubemap.c). */
static double pc_area(double x, double y) { return atan2(x * y, sqrt(x * x + y * y + 1.0)); }

/* w[n * n] for texel (i, j) of a res cube split n x n: each sub-square's solid angle over the texel's. */
static void pc_weights(int res, int i, int j, int n, float *w) {
    double A[(PC_FINE * 8 + 1) * (PC_FINE * 8 + 1)], sum = 0;
    PRT_CHECK(n <= PC_FINE * 8);
    for (int b = 0; b <= n; b++)
        for (int a = 0; a <= n; a++)
            A[b * (n + 1) + a] = pc_area(2.0 * (i * n + a) / (res * n) - 1.0, 2.0 * (j * n + b) / (res * n) - 1.0);
    for (int b = 0; b < n; b++)
        for (int a = 0; a < n; a++) {
            double s = A[(b + 1) * (n + 1) + a + 1] - A[b * (n + 1) + a + 1] - A[(b + 1) * (n + 1) + a] + A[b * (n + 1) + a];
            w[b * n + a] = (float)s;
            sum += s;
        }
    for (int k = 0; k < n * n; k++) w[k] = (float)(w[k] / sum);
}

/* The sub-sample tables (dirs, wts); -1 with err. */
static int pc_tables(probe_cube *pc, prt_error *err) {
    const int res = pc->res, ss = pc->ss, n2 = ss * ss;
    pc->dirs = prt_calloc((size_t)6 * res * res * n2 * 3, sizeof(float), err);
    pc->wts = pc->dirs ? prt_calloc((size_t)res * res * n2, sizeof(float), err) : NULL;
    if (!pc->wts) return -1;
    for (int t = 0; t < res * res; t++) pc_weights(res, t % res, t / res, ss, pc->wts + (size_t)t * n2);
    const size_t n = (size_t)res * n2;
    for (int row = 0; row < 6 * res; row++)
        for (int i = 0; i < res; i++)
            for (int s = 0; s < n2; s++) {
                float d[3];
                cube_dir(res, row / res, (float)i + ((float)(s % ss) + 0.5f) / (float)ss,
                         (float)(row % res) + ((float)(s / ss) + 0.5f) / (float)ss, d);
                for (int c = 0; c < 3; c++) pc->dirs[3 * n * row + c * n + (size_t)i * n2 + s] = d[c];
            }
    return 0;
}

/* The bright source texels (see probecube.h) and their neighbours' directions; -1 with err. */
static int pc_bright(probe_cube *pc, prt_error *err) {
    const int S = pc->S;
    float *om = prt_calloc((size_t)S * S, sizeof(float), err);
    if (!om) return -1;
    cube_face_solid_angles(S, om);
    double pw = 0, peak = 0;
    for (size_t k = 0; k < (size_t)6 * S * S; k++) {
        const float *c = pc->src + 3 * k;
        double v = (double)c[0] + c[1] + c[2];
        pw += v * om[k % ((size_t)S * S)];
        peak = v > peak ? v : peak;
    }
    free(om);
    double thresh = fmax(PC_BRIGHT_MEAN * pw / (4 * M_PI), PC_BRIGHT_PEAK * peak);
    int n = 0;
    for (size_t k = 0; k < (size_t)6 * S * S; k++) {
        const float *c = pc->src + 3 * k;
        n += (double)c[0] + c[1] + c[2] > thresh && thresh > 0;
    }
    pc->bright = prt_calloc((size_t)(n > 0 ? n : 1) * 27, sizeof(float), err);
    if (!pc->bright) return -1;
    for (size_t k = 0; k < (size_t)6 * S * S; k++) {
        const float *c = pc->src + 3 * k;
        if (!((double)c[0] + c[1] + c[2] > thresh && thresh > 0)) continue;
        int f = (int)(k / ((size_t)S * S)), i = (int)(k % S), j = (int)(k / S % S);
        for (int q = 0; q < 9; q++)   /* off the face edge, cube_dir extends the face's plane: still a direction */
            cube_dir(S, f, (float)i + 0.5f + (float)(q % 3 - 1), (float)j + 0.5f + (float)(q / 3 - 1),
                     pc->bright + 3 * (9 * (size_t)pc->nbright + q));
        pc->nbright++;
    }
    return 0;
}

/* Creates the source cube and the tables; NULL with err. */
probe_cube *probe_cube_create(const prt_probe *p, const probe_cube_desc *desc, prt_error *err) {
    PRT_CHECK(p != NULL);
    probe_cube_desc d = desc ? *desc : (probe_cube_desc){ 0 };
    if (d.res <= 0) d.res = CUBE_RES;
    if (d.src_res <= 0) d.src_res = 2 * d.res;
    const int ss = d.src_res / d.res;
    if (d.src_res % d.res || ss > 8 || d.res * ss * ss > PC_ROW_MAX || d.res * ss * ss % 4)
        return prt_fail(err, "probe cube: source resolution %d is not 1 to 8 times %d (or a row's %d sub-samples are not a "
                        "multiple of 4 up to %d)", d.src_res, d.res, d.res * ss * ss, PC_ROW_MAX), NULL;
    probe_cube *pc = prt_calloc(1, sizeof *pc, err);
    if (!pc) return NULL;
    pc->res = d.res;
    pc->S = d.src_res;
    pc->ss = d.src_res / d.res;
    pc->threads = d.threads;
    pc->src = prt_calloc((size_t)6 * pc->S * pc->S * 3, sizeof(float), err);
    if (!pc->src || pc_tables(pc, err)) { probe_cube_destroy(pc); return NULL; }
    probe_to_cube(p, pc->S, NULL, 0, pc->src);
    if (pc_bright(pc, err)) { probe_cube_destroy(pc); return NULL; }
    return pc;
}

/* Frees the cube and its tables. */
void probe_cube_destroy(probe_cube *pc) {
    if (!pc) return;
    free(pc->src);
    free(pc->dirs);
    free(pc->wts);
    free(pc->bright);
    free(pc);
}

/* The target resolution. */
int probe_cube_res(const probe_cube *pc) { return pc->res; }

/* Bilinear radiance of the source cube at direction d (any length), clamped to the edge of its face. */
static void pc_tap(const probe_cube *pc, int f, float u, float v, float rgb[3]);
static void pc_lookup(const probe_cube *pc, const float d[3], float rgb[3]) {
    int f;
    float x, y;
    cube_lookup(pc->S, d, &f, &x, &y);
    pc_tap(pc, f, x - 0.5f, y - 0.5f, rgb);
}

typedef struct pc_job {
    const probe_cube *pc;
    float Rt[9];            /* the target texel at w shows the source at R^T w */
    const uint8_t *fine;    /* [6 res^2] texels a bright source texel reaches (NULL: none, memory short) */
    float *out;
} pc_job;

/* Texel t (face f, (i, j)) from PC_FINE x finer sub-samples, weights computed here (few texels). */
static void pc_fine_texel(const pc_job *J, int f, int i, int j, float *o) {
    const int n = J->pc->ss * PC_FINE;
    float w[(PC_FINE * 8) * (PC_FINE * 8)];
    pc_weights(J->pc->res, i, j, n, w);
    double acc[3] = { 0, 0, 0 };
    for (int b = 0; b < n; b++)
        for (int a = 0; a < n; a++) {
            float dw[3], rgb[3];
            cube_dir(J->pc->res, f, (float)i + ((float)a + 0.5f) / (float)n, (float)j + ((float)b + 0.5f) / (float)n, dw);
            const float *R = J->Rt;
            const float d[3] = { R[0] * dw[0] + R[1] * dw[1] + R[2] * dw[2], R[3] * dw[0] + R[4] * dw[1] + R[5] * dw[2],
                                 R[6] * dw[0] + R[7] * dw[1] + R[8] * dw[2] };
            pc_lookup(J->pc, d, rgb);
            for (int c = 0; c < 3; c++) acc[c] += (double)w[b * n + a] * rgb[c];
        }
    for (int c = 0; c < 3; c++) o[c] = (float)acc[c];
}

/* Four sub-samples at once (SSE): the directions R^T w of x[k], y[k], z[k] (k < 4) and where they fall in
 * the source cube, as cube_lookup finds it (the major axis, ties to x then y; GL's sc, tc): face[k] and
 * the continuous texel coordinates less a half, u[k], v[k] in [-0.5, S - 0.5] (bilinear taps' origin). */
static void pc_taps(const float Rt[9], const float *x, const float *y, const float *z, float S, int32_t *face, float *u,
                    float *v) {
    const __m128 wx = _mm_loadu_ps(x), wy = _mm_loadu_ps(y), wz = _mm_loadu_ps(z);
#define PC_ROW(r) _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(Rt[3 * (r)]), wx), _mm_mul_ps(_mm_set1_ps(Rt[3 * (r) + 1]), wy)), \
                             _mm_mul_ps(_mm_set1_ps(Rt[3 * (r) + 2]), wz))
    const __m128 X = PC_ROW(0), Y = PC_ROW(1), Z = PC_ROW(2), zero = _mm_setzero_ps(), sign = _mm_set1_ps(-0.0f);
#undef PC_ROW
    const __m128 ax = _mm_andnot_ps(sign, X), ay = _mm_andnot_ps(sign, Y), az = _mm_andnot_ps(sign, Z);
    const __m128 bx = _mm_and_ps(_mm_cmpge_ps(ax, ay), _mm_cmpge_ps(ax, az)), by = _mm_andnot_ps(bx, _mm_cmpge_ps(ay, az));
    const __m128 xge = _mm_cmpge_ps(X, zero), yge = _mm_cmpge_ps(Y, zero), zge = _mm_cmpge_ps(Z, zero);
    const __m128 nX = _mm_xor_ps(X, sign), nY = _mm_xor_ps(Y, sign), nZ = _mm_xor_ps(Z, sign);
    const __m128 ma = _mm_blendv_ps(_mm_blendv_ps(az, ay, by), ax, bx);
    const __m128 sc = _mm_blendv_ps(_mm_blendv_ps(_mm_blendv_ps(nX, X, zge), X, by), _mm_blendv_ps(Z, nZ, xge), bx);
    const __m128 tc = _mm_blendv_ps(_mm_blendv_ps(nY, _mm_blendv_ps(nZ, Z, yge), by), nY, bx);
    const __m128 one = _mm_set1_ps(1.f), half = _mm_set1_ps(0.5f), hs = _mm_set1_ps(0.5f * S);
    const __m128 f = _mm_blendv_ps(_mm_blendv_ps(_mm_blendv_ps(_mm_set1_ps(5), _mm_set1_ps(4), zge),
                                                 _mm_blendv_ps(_mm_set1_ps(3), _mm_set1_ps(2), yge), by),
                                   _mm_blendv_ps(one, zero, xge), bx);
    const __m128 inv = _mm_div_ps(one, ma), lo = _mm_set1_ps(-0.5f), hi = _mm_set1_ps(S - 0.5f);
    const __m128 U = _mm_sub_ps(_mm_mul_ps(_mm_add_ps(_mm_mul_ps(sc, inv), one), hs), half);
    const __m128 V = _mm_sub_ps(_mm_mul_ps(_mm_add_ps(_mm_mul_ps(tc, inv), one), hs), half);
    _mm_storeu_ps(u, _mm_min_ps(_mm_max_ps(U, lo), hi));
    _mm_storeu_ps(v, _mm_min_ps(_mm_max_ps(V, lo), hi));
    _mm_storeu_si128((__m128i *)face, _mm_cvtps_epi32(f));
}

/* Bilinear radiance of face f of the source at taps origin (u, v) (pc_taps), clamped to the face's edge. */
static inline void pc_tap(const probe_cube *pc, int f, float u, float v, float rgb[3]) {
    const int S = pc->S;
    const float x0f = floorf(u), y0f = floorf(v), fx = u - x0f, fy = v - y0f;
    const int x0 = (int)x0f, y0 = (int)y0f;
    const int xa = x0 < 0 ? 0 : x0, xb = x0 + 1 > S - 1 ? S - 1 : x0 + 1;
    const int ya = y0 < 0 ? 0 : y0, yb = y0 + 1 > S - 1 ? S - 1 : y0 + 1;
    const float *face = pc->src + (size_t)3 * f * S * S;
    const float *t00 = face + 3 * (ya * S + xa), *t10 = face + 3 * (ya * S + xb);
    const float *t01 = face + 3 * (yb * S + xa), *t11 = face + 3 * (yb * S + xb);
    const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
    for (int c = 0; c < 3; c++) rgb[c] = w00 * t00[c] + w10 * t10[c] + w01 * t01[c] + w11 * t11[c];
}

/* prt_parallel_for body: target rows [begin, end) (face * res + j): every sub-sample's taps four at a
 * time, then each texel the weighted sum of its sub-samples' bilinear lookups. */
static void pc_rows(void *ctx, int begin, int end, int thread) {
    const pc_job *J = ctx;
    const probe_cube *pc = J->pc;
    const int res = pc->res, n2 = pc->ss * pc->ss, n = res * n2;   /* a multiple of 4 (probe_cube_create) */
    int32_t face[PC_ROW_MAX];
    float u[PC_ROW_MAX], v[PC_ROW_MAX];
    PRT_CHECK(n <= PC_ROW_MAX && n % 4 == 0);
    (void)thread;
    for (int row = begin; row < end; row++) {
        const int f = row / res, j = row % res;
        const float *dx = pc->dirs + (size_t)3 * n * row, *dy = dx + n, *dz = dy + n;
        for (int k = 0; k < n; k += 4) pc_taps(J->Rt, dx + k, dy + k, dz + k, (float)pc->S, face + k, u + k, v + k);
        for (int i = 0; i < res; i++) {
            const size_t t = (size_t)row * res + i;
            float *o = J->out + 3 * t;
            if (J->fine && J->fine[t]) { pc_fine_texel(J, f, i, j, o); continue; }
            const float *w = pc->wts + (size_t)(j * res + i) * n2;
            float acc[3] = { 0, 0, 0 }, rgb[3];
            for (int s = 0, k = i * n2; s < n2; s++, k++) {
                pc_tap(pc, face[k], u[k], v[k], rgb);
                for (int c = 0; c < 3; c++) acc[c] += w[s] * rgb[c];
            }
            for (int c = 0; c < 3; c++) o[c] = acc[c];
        }
    }
}

/* The rotated target cube into out (see probecube.h). */
void probe_cube_resample(const probe_cube *pc, const float R[9], float *out) {
    PRT_CHECK(pc != NULL && out != NULL);
    static const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    if (!R) R = I;
    const int res = pc->res;
    uint8_t *fine = calloc((size_t)6 * res * res, 1);   /* NULL (memory short): no texel refined */
    pc_job J = { .pc = pc, .fine = fine, .out = out };
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) J.Rt[3 * r + c] = R[3 * c + r];
    for (int k = 0; fine && k < 9 * pc->nbright; k++) {
        const float *d = pc->bright + 3 * (size_t)k;
        const float rd[3] = { R[0] * d[0] + R[1] * d[1] + R[2] * d[2], R[3] * d[0] + R[4] * d[1] + R[5] * d[2],
                              R[6] * d[0] + R[7] * d[1] + R[8] * d[2] };
        fine[cube_texel_index(res, rd)] = 1;
    }
    prt_parallel_for(6 * res, 4, pc->threads, pc_rows, &J);
    free(fine);
}
