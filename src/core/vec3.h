/* vec3.h - tiny float 3-vector helpers (header only, all static inline). */
#ifndef PRT_VEC3_H
#define PRT_VEC3_H
#include <math.h>

static inline void v3_set(float o[3], float x, float y, float z) { o[0] = x; o[1] = y; o[2] = z; }
static inline void v3_copy(float o[3], const float a[3]) { o[0] = a[0]; o[1] = a[1]; o[2] = a[2]; }
static inline void v3_add(float o[3], const float a[3], const float b[3]) { o[0] = a[0] + b[0]; o[1] = a[1] + b[1]; o[2] = a[2] + b[2]; }
static inline void v3_sub(float o[3], const float a[3], const float b[3]) { o[0] = a[0] - b[0]; o[1] = a[1] - b[1]; o[2] = a[2] - b[2]; }
static inline void v3_scale(float o[3], const float a[3], float s) { o[0] = a[0] * s; o[1] = a[1] * s; o[2] = a[2] * s; }
static inline void v3_madd(float o[3], const float a[3], const float b[3], float s) { o[0] = a[0] + b[0] * s; o[1] = a[1] + b[1] * s; o[2] = a[2] + b[2] * s; }
static inline float v3_dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void v3_cross(float o[3], const float a[3], const float b[3]) {
    float x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    o[0] = x; o[1] = y; o[2] = z;
}
/* Squared lengths in (1e-30, 1e30) are safe in float; outside it (components beyond ~1e15 or
 * below ~1e-15) a vector is first multiplied by the power of two that brings its largest
 * component into [1, 2). That is exact, and the same float operations follow, so the length and
 * direction come out as those of the vector at unit scale, bit for bit: the scene's scale does
 * not matter (docs/design/scale.md). */
#define V3_SAFE_LEN2(d) ((d) > 1e-30f && (d) < 1e30f)
/* Multiplies a by 2^-e with its largest |component| in [1, 2) and returns e; a zero or
 * non-finite vector is left as it is (e = 0). */
static inline int v3_prescale(float a[3]) {
    float m = fmaxf(fabsf(a[0]), fmaxf(fabsf(a[1]), fabsf(a[2])));
    if (!(m > 0.f) || !isfinite(m)) return 0;
    int e = ilogbf(m);
    float s = ldexpf(1.f, -e);
    a[0] *= s; a[1] *= s; a[2] *= s;
    return e;
}
/* Length (float rounding at any magnitude; past FLT_MAX: inf). */
static inline float v3_len(const float a[3]) {
    float d = v3_dot(a, a);
    if (V3_SAFE_LEN2(d)) return sqrtf(d);
    float b[3] = { a[0], a[1], a[2] };
    int e = v3_prescale(b);
    return ldexpf(sqrtf(v3_dot(b, b)), e);
}
/* Normalizes in place; returns the original length (0 leaves a unchanged). */
static inline float v3_normalize(float a[3]) {
    float d = v3_dot(a, a);
    if (!V3_SAFE_LEN2(d)) {
        float b[3] = { a[0], a[1], a[2] };
        int e = v3_prescale(b);
        float l = sqrtf(v3_dot(b, b));
        if (l > 0.f && isfinite(l)) { a[0] = b[0] / l; a[1] = b[1] / l; a[2] = b[2] / l; }
        return ldexpf(l, e);
    }
    float l = sqrtf(d);
    a[0] /= l; a[1] /= l; a[2] /= l;
    return l;
}
#endif
