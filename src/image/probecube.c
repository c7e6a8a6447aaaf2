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
#include <stdlib.h>
#include <string.h>

#define PC_FINE 4          /* a bright texel's sub-samples per source texel side */
#define PC_BRIGHT_MEAN 16  /* a source texel is bright above this times the mean (probe.c's rule)... */
#define PC_BRIGHT_PEAK 1e-3f /* ... and this share of the brightest texel */

struct probe_cube {
    int res, S, ss, threads;
    float *src;            /* [6 S^2][3] the unrotated source cube */
    float *dirs;           /* [6 res^2 ss^2][3] unit sub-sample directions of every target texel */
    float *wts;            /* [res^2 ss^2] their weights, summing to one per texel (every face alike) */
    int nbright;
    float *bright;         /* [9 nbright][3] bright source texels' centres and neighbours, unit */
};

/* The gnomonic area function whose corner differences are a sub-square's solid angle (cubemap.c). */
static double pc_area(double x, double y) { return atan2(x * y, sqrt(x * x + y * y + 1.0)); }

/* w[n * n] for texel (i, j) of a res cube split n x n: each sub-square's solid angle over the texel's. */
static void pc_weights(int res, int i, int j, int n, float *w) {
    double A[(4 * 16 + 1) * (4 * 16 + 1)], sum = 0;
    PRT_CHECK(n <= 4 * 16);
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
    for (int f = 0; f < 6; f++)
        for (int t = 0; t < res * res; t++)
            for (int s = 0; s < n2; s++)
                cube_dir(res, f, (float)(t % res) + ((float)(s % ss) + 0.5f) / (float)ss,
                         (float)(t / res) + ((float)(s / ss) + 0.5f) / (float)ss,
                         pc->dirs + 3 * (((size_t)f * res * res + t) * n2 + s));
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
    if (d.src_res % d.res || d.src_res / d.res > 16)
        return prt_fail(err, "probe cube: source resolution %d is not 1 to 16 times %d", d.src_res, d.res), NULL;
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
static inline void pc_lookup(const probe_cube *pc, const float d[3], float rgb[3]) {
    const int S = pc->S;
    int f;
    float x, y;
    cube_lookup(S, d, &f, &x, &y);
    x -= 0.5f;
    y -= 0.5f;
    const float x0f = floorf(x), y0f = floorf(y), fx = x - x0f, fy = y - y0f;
    const int x0 = (int)x0f, y0 = (int)y0f;
    const int xa = x0 < 0 ? 0 : x0, xb = x0 + 1 > S - 1 ? S - 1 : x0 + 1;
    const int ya = y0 < 0 ? 0 : y0, yb = y0 + 1 > S - 1 ? S - 1 : y0 + 1;
    const float *face = pc->src + (size_t)3 * f * S * S;
    const float *t00 = face + 3 * (ya * S + xa), *t10 = face + 3 * (ya * S + xb);
    const float *t01 = face + 3 * (yb * S + xa), *t11 = face + 3 * (yb * S + xb);
    const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
    for (int c = 0; c < 3; c++) rgb[c] = w00 * t00[c] + w10 * t10[c] + w01 * t01[c] + w11 * t11[c];
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
    float w[(4 * 16) * (4 * 16)];
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

/* prt_parallel_for body: target rows [begin, end) (face * res + j). */
static void pc_rows(void *ctx, int begin, int end, int thread) {
    const pc_job *J = ctx;
    const probe_cube *pc = J->pc;
    const int res = pc->res, n2 = pc->ss * pc->ss;
    const float *R = J->Rt;
    (void)thread;
    for (int row = begin; row < end; row++) {
        const int f = row / res, j = row % res;
        for (int i = 0; i < res; i++) {
            const size_t t = (size_t)row * res + i;
            float *o = J->out + 3 * t;
            if (J->fine && J->fine[t]) { pc_fine_texel(J, f, i, j, o); continue; }
            const float *dw = pc->dirs + 3 * t * n2, *w = pc->wts + (size_t)(j * res + i) * n2;
            float acc[3] = { 0, 0, 0 };
            for (int s = 0; s < n2; s++, dw += 3) {
                const float d[3] = { R[0] * dw[0] + R[1] * dw[1] + R[2] * dw[2], R[3] * dw[0] + R[4] * dw[1] + R[5] * dw[2],
                                     R[6] * dw[0] + R[7] * dw[1] + R[8] * dw[2] };
                float rgb[3];
                pc_lookup(pc, d, rgb);
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
