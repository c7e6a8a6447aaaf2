/* opensky.c - the open sky's irradiance grid (opensky.h): texel and block tables made once, the
 * grid summed exactly per light change, bilinear lookups. */
#include "opensky.h"
#include "check.h"
#include "cubemap.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define OS_LEVELS 7                                /* quadtree levels per face: 1 x 1 ... 64 x 64 texels */
#define OS_GN ((OPENSKY_GRID + 1) * (OPENSKY_GRID + 1))
#define OS_NS (OPENSKY_SUB * OPENSKY_SUB)
#define OS_SR (CUBE_RES * OPENSKY_SUB)               /* the sub-texels' cube resolution */

/* First node of level l in the per-level arrays: level l holds 6 x 4^l nodes, face-major, row-major. */
static size_t os_first(int l) { return (size_t)6 * (((size_t)1 << (2 * l)) - 1) / 3; }
#define OS_NODES (6 * ((1 << (2 * OS_LEVELS)) - 1) / 3)

struct opensky {
    float (*sub)[OS_NS][4];     /* [CUBE_TEXELS]: each sub-texel's direction and solid angle */
    float (*m)[3];              /* [CUBE_TEXELS] first moments sum_s dw_s w_s */
    float (*cone)[4];           /* [OS_NODES] each quadtree node's centre direction, sin of its half-angle */
    float (*mom)[3][3];         /* [OS_NODES] per light: sum over the node of L_j,ch m_j */
    float grid[6][OS_GN][3];    /* |p| E at the grid normals */
};

/* The cone about the centre of the square [x0, x1] x [y0, y1] (texel units at res) of face f. */
static void os_cone(int res, int f, float x0, float y0, float x1, float y1, float cone[4]) {
    cube_dir(res, f, 0.5f * (x0 + x1), 0.5f * (y0 + y1), cone);
    float cmin = 1;
    for (int k = 0; k < 4; k++) {   /* a gnomonic square's farthest point from its centre is a corner */
        float d[3];
        cube_dir(res, f, (k & 1) ? x1 : x0, (k & 2) ? y1 : y0, d);
        float c = d[0] * cone[0] + d[1] * cone[1] + d[2] * cone[2];
        if (c < cmin) cmin = c;
    }
    cone[3] = sqrtf(fmaxf(0.f, 1.f - cmin * cmin));
}

/* Lighting texel j's sub-texels: direction and solid angle into s[OS_NS][4]. */
static void os_subtexels(int j, float s[OS_NS][4]) {
    int f = j / (CUBE_RES * CUBE_RES), r = j % (CUBE_RES * CUBE_RES), ti = r % CUBE_RES, tj = r / CUBE_RES;
    for (int b = 0; b < OPENSKY_SUB; b++)
        for (int a = 0; a < OPENSKY_SUB; a++) {
            int si = ti * OPENSKY_SUB + a, sj = tj * OPENSKY_SUB + b, k = b * OPENSKY_SUB + a;
            cube_texel_dir(OS_SR, f * OS_SR * OS_SR + sj * OS_SR + si, s[k]);
            s[k][3] = (float)cube_texel_solid_angle(OS_SR, si, sj);
        }
}

opensky *opensky_create(prt_error *err) {
    opensky *o = prt_calloc(1, sizeof *o, err);
    if (!o) return NULL;
    o->sub = prt_calloc(CUBE_TEXELS, sizeof *o->sub, err);
    o->m = o->sub ? prt_calloc(CUBE_TEXELS, sizeof *o->m, err) : NULL;
    o->cone = o->m ? prt_calloc(OS_NODES, sizeof *o->cone, err) : NULL;
    o->mom = o->cone ? prt_calloc(OS_NODES, sizeof *o->mom, err) : NULL;
    if (!o->mom) { opensky_destroy(o); return NULL; }
    for (int j = 0; j < CUBE_TEXELS; j++) {
        os_subtexels(j, o->sub[j]);
        for (int s = 0; s < OS_NS; s++)
            for (int c = 0; c < 3; c++) o->m[j][c] += o->sub[j][s][3] * o->sub[j][s][c];
    }
    for (int l = 0; l < OS_LEVELS; l++) {
        int n = 1 << l, size = CUBE_RES >> l;
        for (int f = 0; f < 6; f++)
            for (int y = 0; y < n; y++)
                for (int x = 0; x < n; x++)
                    os_cone(CUBE_RES, f, (float)(x * size), (float)(y * size), (float)(x * size + size), (float)(y * size + size),
                            o->cone[os_first(l) + ((size_t)f * n + y) * n + x]);
    }
    return o;
}

void opensky_destroy(opensky *o) {
    if (!o) return;
    free(o->sub);
    free(o->m);
    free(o->cone);
    free(o->mom);
    free(o);
}

static float dot3(const float *a, const float *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Node (l, f, x, y) against n into e: wholly above n's horizon its moment (the clamp is inactive),
 * wholly below nothing, across it its four children; a texel across it by its sub-texels. */
static void os_visit(const opensky *o, const float *L, int l, int f, int x, int y, const float n[3], float e[3]) {
    const int nl = 1 << l;
    const size_t k = os_first(l) + ((size_t)f * nl + y) * nl + x;
    float d = dot3(n, o->cone[k]), s = o->cone[k][3];
    if (d <= -s) return;
    if (d >= s) {
        for (int c = 0; c < 3; c++) e[c] += dot3(n, o->mom[k][c]);
        return;
    }
    if (l < OS_LEVELS - 1) {
        for (int q = 0; q < 4; q++) os_visit(o, L, l + 1, f, 2 * x + (q & 1), 2 * y + (q >> 1), n, e);
        return;
    }
    const int j = f * CUBE_RES * CUBE_RES + y * CUBE_RES + x;
    float a = 0;
    for (int q = 0; q < OS_NS; q++) {
        float c = dot3(n, o->sub[j][q]);
        if (c > 0) a += c * o->sub[j][q][3];
    }
    for (int c = 0; c < 3; c++) e[c] += L[3 * (size_t)j + c] * a;
}

typedef struct os_job { opensky *o; const float *L; const uint8_t *need; } os_job;

static void os_grid_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    const os_job *j = ctx;
    opensky *o = j->o;
    for (int g = begin; g < end; g++) {
        if (j->need && !j->need[g]) continue;
        int f = g / OS_GN, k = g % OS_GN;
        float n[3], e[3] = { 0, 0, 0 };
        opensky_grid_normal(g, n);
        for (int face = 0; face < 6; face++) os_visit(o, j->L, 0, face, 0, 0, n, e);
        /* |p| = 1 / |n's major component|: the face plane's point along n */
        float ma = fmaxf(fabsf(n[0]), fmaxf(fabsf(n[1]), fabsf(n[2])));
        for (int c = 0; c < 3; c++) o->grid[f][k][c] = e[c] / ma;
    }
}

/* The light's moments: per texel L_j m_j, then each level the sum of its four children (in double). */
static void os_moments(opensky *o, const float *L) {
    const size_t t0 = os_first(OS_LEVELS - 1);
    for (int j = 0; j < CUBE_TEXELS; j++)
        for (int c = 0; c < 3; c++)
            for (int q = 0; q < 3; q++) o->mom[t0 + (size_t)j][c][q] = L[3 * (size_t)j + c] * o->m[j][q];
    for (int l = OS_LEVELS - 2; l >= 0; l--) {
        int n = 1 << l;
        for (int f = 0; f < 6; f++)
            for (int y = 0; y < n; y++)
                for (int x = 0; x < n; x++) {
                    float (*out)[3] = o->mom[os_first(l) + ((size_t)f * n + y) * n + x];
                    for (int c = 0; c < 3; c++)
                        for (int q = 0; q < 3; q++) {
                            double s = 0;
                            for (int h = 0; h < 4; h++)
                                s += o->mom[os_first(l + 1) + ((size_t)f * 2 * n + 2 * y + (h >> 1)) * 2 * n + 2 * x + (h & 1)][c][q];
                            out[c][q] = (float)s;
                        }
                }
    }
}

void opensky_set_light(opensky *o, const float *cube_rgb, const uint8_t *need, int nthreads) {
    os_moments(o, cube_rgb);
    os_job j = { o, cube_rgb, need };
    prt_parallel_for(6 * OS_GN, 16, nthreads, os_grid_range, &j);
}

void opensky_need(const float n[3], uint8_t *need) {
    int q[4];
    float w[4];
    opensky_weights(n, q, w);
    for (int k = 0; k < 4; k++)
        if (w[k] != 0.f) need[q[k]] = 1;
}

void opensky_weights(const float n[3], int q[4], float w[4]) {
    int f;
    float x, y;
    cube_lookup(OPENSKY_GRID, n, &f, &x, &y);
    int i0 = (int)x, j0 = (int)y;
    if (i0 > OPENSKY_GRID - 1) i0 = OPENSKY_GRID - 1;
    if (j0 > OPENSKY_GRID - 1) j0 = OPENSKY_GRID - 1;
    float fx = x - (float)i0, fy = y - (float)j0;
    float ma = fmaxf(fabsf(n[0]), fmaxf(fabsf(n[1]), fabsf(n[2])));
    int k = f * OS_GN + j0 * (OPENSKY_GRID + 1) + i0;
    q[0] = k, q[1] = k + 1, q[2] = k + OPENSKY_GRID + 1, q[3] = k + OPENSKY_GRID + 2;
    w[0] = (1 - fx) * (1 - fy) * ma, w[1] = fx * (1 - fy) * ma, w[2] = (1 - fx) * fy * ma, w[3] = fx * fy * ma;
}

void opensky_grid_normal(int q, float n[3]) {
    int f = q / OS_GN, k = q % OS_GN;
    cube_dir(OPENSKY_GRID, f, (float)(k % (OPENSKY_GRID + 1)), (float)(k / (OPENSKY_GRID + 1)), n);
}

void opensky_eval(const opensky *o, const float n[3], float rgb[3]) {
    int q[4];
    float w[4];
    opensky_weights(n, q, w);
    const float (*g)[3] = (const float (*)[3])o->grid;
    for (int c = 0; c < 3; c++) rgb[c] = w[0] * g[q[0]][c] + w[1] * g[q[1]][c] + w[2] * g[q[2]][c] + w[3] * g[q[3]][c];
}

void opensky_grid_texels(const opensky *o, int q, float *a0) {
    float n[3];
    opensky_grid_normal(q, n);
    float ma = fmaxf(fabsf(n[0]), fmaxf(fabsf(n[1]), fabsf(n[2])));
    for (int j = 0; j < CUBE_TEXELS; j++) {
        const float *cn = o->cone[os_first(OS_LEVELS - 1) + (size_t)j];
        float d = dot3(n, cn), s = cn[3], a = 0;
        if (d >= s) a = dot3(n, o->m[j]);
        else if (d > -s)
            for (int k = 0; k < OS_NS; k++) {
                float c = dot3(n, o->sub[j][k]);
                if (c > 0) a += c * o->sub[j][k][3];
            }
        a0[j] = a / ma;
    }
}

void opensky_exact(const float *cube_rgb, const float n[3], double rgb[3]) {
    rgb[0] = rgb[1] = rgb[2] = 0;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        float s[OS_NS][4];
        os_subtexels(j, s);
        double a = 0;
        for (int k = 0; k < OS_NS; k++) {
            double c = (double)n[0] * s[k][0] + (double)n[1] * s[k][1] + (double)n[2] * s[k][2];
            if (c > 0) a += c * s[k][3];
        }
        for (int c = 0; c < 3; c++) rgb[c] += cube_rgb[3 * (size_t)j + c] * a;
    }
}
