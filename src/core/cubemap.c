/* cubemap.c - directions, texel lookup and exact solid angles on the global cube map.
 *
 * Lighting and transport vectors are sampled on a 6 x res x res cube map in
 * OpenGL's face convention (cubemap.h), so that the CPU and GPU paths address
 * the same texels. Solid angles matter because transport texels carry dw_j
 * (Eq. 3 integrated over a texel, Eq. 4's cubature): a texel of the gnomonic
 * face x, y in [-1,1] at distance 1 spans
 *     Omega = F(x1,y1) - F(x0,y1) - F(x1,y0) + F(x0,y0),  F(x,y) = atan2(xy, sqrt(x^2+y^2+1)),
 * which is exact, so the 6 res^2 texels sum to 4 pi up to rounding. */
#include "cubemap.h"
#include <math.h>

/* Writes the unnormalized direction of face coordinates sc, tc in [-1,1]. */
static void face_vec(int face, float sc, float tc, float d[3]) {
    switch (face) {
    case 0: d[0] = 1.f;  d[1] = -tc;  d[2] = -sc;  break;   /* +X */
    case 1: d[0] = -1.f; d[1] = -tc;  d[2] = sc;   break;   /* -X */
    case 2: d[0] = sc;   d[1] = 1.f;  d[2] = tc;   break;   /* +Y */
    case 3: d[0] = sc;   d[1] = -1.f; d[2] = -tc;  break;   /* -Y */
    case 4: d[0] = sc;   d[1] = -tc;  d[2] = 1.f;  break;   /* +Z */
    default: d[0] = -sc; d[1] = -tc;  d[2] = -1.f; break;   /* -Z */
    }
}

/* Unit direction at continuous texel coordinates (x, y) of face. */
void cube_dir(int res, int face, float x, float y, float dir[3]) {
    PRT_CHECK(res > 0 && face >= 0 && face < 6);
    float sc = 2.f * x / (float)res - 1.f, tc = 2.f * y / (float)res - 1.f;
    face_vec(face, sc, tc, dir);
    float inv = 1.f / sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    dir[0] *= inv; dir[1] *= inv; dir[2] *= inv;
}

/* Unit direction of the centre of texel idx (f*res*res + j*res + i). */
void cube_texel_dir(int res, int idx, float dir[3]) {
    int f = idx / (res * res), r = idx % (res * res);
    cube_dir(res, f, (float)(r % res) + 0.5f, (float)(r / res) + 0.5f, dir);
}

/* Face by major axis (ties prefer x, then y: deterministic on face edges), then
 * the GL 4.6 table 8.19 sc/tc formulas, mapped to texel units in [0, res]. */
void cube_lookup(int res, const float dir[3], int *face, float *x, float *y) {
    float ax = fabsf(dir[0]), ay = fabsf(dir[1]), az = fabsf(dir[2]);
    float sc, tc, ma;
    int f;
    if (ax >= ay && ax >= az) {
        ma = ax;
        if (dir[0] >= 0) { f = 0; sc = -dir[2]; tc = -dir[1]; }
        else { f = 1; sc = dir[2]; tc = -dir[1]; }
    } else if (ay >= az) {
        ma = ay;
        if (dir[1] >= 0) { f = 2; sc = dir[0]; tc = dir[2]; }
        else { f = 3; sc = dir[0]; tc = -dir[2]; }
    } else {
        ma = az;
        if (dir[2] >= 0) { f = 4; sc = dir[0]; tc = -dir[1]; }
        else { f = 5; sc = -dir[0]; tc = -dir[1]; }
    }
    float inv = ma > 0 ? 1.f / ma : 0.f;   /* a zero direction maps to the centre of +X */
    float fx = 0.5f * (sc * inv + 1.f) * (float)res, fy = 0.5f * (tc * inv + 1.f) * (float)res;
    if (!(fx >= 0)) fx = 0;                /* also catches NaN */
    if (!(fy >= 0)) fy = 0;
    if (fx > (float)res) fx = (float)res;
    if (fy > (float)res) fy = (float)res;
    *face = f; *x = fx; *y = fy;
}

/* Linear index of the texel containing dir (edges clamp into the face). */
int cube_texel_index(int res, const float dir[3]) {
    int f;
    float x, y;
    cube_lookup(res, dir, &f, &x, &y);
    int i = (int)x, j = (int)y;
    if (i > res - 1) i = res - 1;
    if (j > res - 1) j = res - 1;
    return f * res * res + j * res + i;
}

static double area_f(double x, double y) { return atan2(x * y, sqrt(x * x + y * y + 1.0)); }

/* Exact solid angle of texel (i, j) of any face, in steradians. */
double cube_texel_solid_angle(int res, int i, int j) {
    double x0 = 2.0 * i / res - 1.0, x1 = 2.0 * (i + 1) / res - 1.0;
    double y0 = 2.0 * j / res - 1.0, y1 = 2.0 * (j + 1) / res - 1.0;
    return area_f(x1, y1) - area_f(x0, y1) - area_f(x1, y0) + area_f(x0, y0);
}

/* out[j*res + i] = solid angle of texel (i, j); caller owns out[res*res]. */
void cube_face_solid_angles(int res, float *out) {
    for (int j = 0; j < res; j++)
        for (int i = 0; i < res; i++) out[j * res + i] = (float)cube_texel_solid_angle(res, i, j);
}
