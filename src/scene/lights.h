/* lights.h - local lights: point and spot lights a scene or the command line adds.
 *
 * A probe lights the scene from infinity through PRT; local lights add to it
 * at runtime (direct light with shadows, one bounce by two virtual spherical-Gaussian
 * lights, indirect highlights), shaded with the analytic BRDFs, never the factorization.
 *
 * Usage:
 *     prt_light l = { .type = PRT_LIGHT_SPOT, .pos = {0,2,0}, .dir = {0,-1,0},
 *                     .inner_deg = 20, .outer_deg = 30, .intensity = 10,
 *                     .colour = {1,1,1} };
 *     float I[3];
 *     light_intensity_toward(&l, d, I);   // radiant intensity (W/sr) toward unit d
 *     // irradiance at a point x with normal n: I * max(0, n . -d) / |x - pos|^2,
 *     // d = (x - pos) / |x - pos|, times the visibility of pos from x.
 *
 * Units: `intensity` is radiant intensity in W/sr on the axis (probe radiance is
 * W/(sr m^2), scene units are metres); `colour` multiplies it per channel. A spot light
 * is full inside `inner_deg` (half-angle), zero outside `outer_deg`, and falls off by a
 * smoothstep in cos(angle) between them. A point light radiates the same in every
 * direction (dir and the cone angles are ignored).
 *
 * Every runtime and `prt reference` use light_intensity_toward, so they agree on the
 * falloff by construction. Plain data: no ownership.
 *
 * Spec strings (`--light SPEC`, or a string in a JSON scene's "lights" array):
 *     point:pos=x,y,z;intensity=I;colour=r,g,b
 *     spot:pos=x,y,z;dir=x,y,z;inner=DEG;outer=DEG;intensity=I;colour=r,g,b
 * pos is required; defaults: intensity 1, colour 1,1,1, dir 0,-1,0 (normalized when
 * given), inner 20, outer 30. light_parse fails with one line naming the flag or file
 * and the problem (unknown type or key, bad number, a value out of range).
 *
 * Shading (light_shade): the radiance a surface point reflects toward wo from one light,
 * f_r(wi, wo) I(-wi) (n . wi) / d^2 with the analytic BRDF (brdf_eval, a point light needs
 * one evaluation), without visibility; runtimes multiply by their shadow test. */
#ifndef PRT_LIGHTS_H
#define PRT_LIGHTS_H
#include "common.h"

#define PRT_MAX_LIGHTS 16

typedef enum prt_light_type { PRT_LIGHT_POINT = 0, PRT_LIGHT_SPOT = 1 } prt_light_type;

typedef struct prt_light {
    prt_light_type type;
    float pos[3];        /* position (scene units) */
    float dir[3];        /* spot axis, unit length (spot only) */
    float inner_deg;     /* full-intensity half-angle, degrees, 0 <= inner <= outer (spot) */
    float outer_deg;     /* cut-off half-angle, degrees, (0, 180) (spot) */
    float intensity;     /* radiant intensity on the axis, W/sr, >= 0 */
    float colour[3];     /* per-channel factor, >= 0 */
} prt_light;

/* The set a scene or the command line gives. */
typedef struct prt_lights {
    int count;
    prt_light light[PRT_MAX_LIGHTS];
} prt_lights;

/* Radiant intensity (rgb, W/sr) the light sends toward unit direction d (from the
 * light outward): intensity * colour * the spot's falloff. */
void light_intensity_toward(const prt_light *l, const float d[3], float out[3]);

/* The spot falloff in [0,1] for cos(angle to the axis) = c; 1 for a point light. */
float light_falloff(const prt_light *l, float c);

/* Checks one light's fields (finite, unit dir, angle ranges, non-negative intensity
 * and colour); on failure sets err naming `what` (the file or flag) and returns -1. */
int light_validate(const prt_light *l, const char *what, prt_error *err);

/* Parses a spec string (see above) into *out and validates it; -1 with err naming `what`. */
int light_parse(const char *spec, const char *what, prt_light *out, prt_error *err);

/* Writes a spec string light_parse reads back to the same light (%g precision). */
void light_format(const prt_light *l, char *buf, size_t cap);

/* Appends l to ls (validated); -1 with err naming `what` when invalid or when ls is full. */
int lights_add(prt_lights *ls, const prt_light *l, const char *what, prt_error *err);

struct brdf_params;
/* Reflected radiance (rgb) toward world unit wo at point p with unit shading normal n, from l,
 * unshadowed: f_r(wi, wo) I(-wi) max(0, n . wi) / d^2 (brdf_eval in brdf_frame(n)'s frame).
 * Returns the distance d to the light and writes the unit direction wi toward it (0 when
 * p is at the light: then out is 0). */
float light_shade(const prt_light *l, const struct brdf_params *bp, const float p[3], const float n[3],
                  const float wo[3], float wi[3], float out[3]);
#endif
