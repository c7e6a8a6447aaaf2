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
static inline float v3_len(const float a[3]) { return sqrtf(v3_dot(a, a)); }
/* Normalizes in place; returns the original length (0 leaves a unchanged). */
static inline float v3_normalize(float a[3]) {
    float l = v3_len(a);
    if (l > 0.f) { a[0] /= l; a[1] /= l; a[2] /= l; }
    return l;
}
#endif
