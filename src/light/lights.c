/* lights.c - the radiant intensity of point and spot lights (lights.h).
 *
 * One falloff shared by every runtime and the path tracer, so their images differ only
 * by the approximations each makes, never by the light model. */
#include "lights.h"
#include <math.h>

/* Spot falloff: 1 inside the inner cone, 0 outside the outer, smoothstep in cos between. */
float light_falloff(const prt_light *l, float c)
{
    if (l->type != PRT_LIGHT_SPOT) return 1.0f;
    const float ci = cosf(l->inner_deg * (float)(M_PI / 180.0));
    const float co = cosf(l->outer_deg * (float)(M_PI / 180.0));
    if (c >= ci) return 1.0f;
    if (c <= co) return 0.0f;
    float t = (c - co) / (ci - co);
    return t * t * (3.0f - 2.0f * t);
}

/* intensity * colour * falloff toward d. */
void light_intensity_toward(const prt_light *l, const float d[3], float out[3])
{
    float c = l->dir[0] * d[0] + l->dir[1] * d[1] + l->dir[2] * d[2];
    float f = l->intensity * light_falloff(l, c);
    for (int k = 0; k < 3; k++) out[k] = f * l->colour[k];
}

/* Field checks for user-given lights. */
int light_validate(const prt_light *l, const char *what, prt_error *err)
{
    const char *why = NULL;
    for (int k = 0; k < 3; k++)
        if (!isfinite(l->pos[k]) || !isfinite(l->dir[k]) || !isfinite(l->colour[k])) why = "a value is not finite";
    if (!why && (l->type != PRT_LIGHT_POINT && l->type != PRT_LIGHT_SPOT)) why = "unknown light type";
    if (!why && (!isfinite(l->intensity) || l->intensity < 0)) why = "intensity must be >= 0";
    if (!why && (l->colour[0] < 0 || l->colour[1] < 0 || l->colour[2] < 0)) why = "colour must be >= 0";
    if (!why && l->type == PRT_LIGHT_SPOT) {
        float n = sqrtf(l->dir[0] * l->dir[0] + l->dir[1] * l->dir[1] + l->dir[2] * l->dir[2]);
        if (fabsf(n - 1.0f) > 1e-3f) why = "spot direction must be a unit vector";
        else if (!(l->outer_deg > 0 && l->outer_deg < 180)) why = "outer angle must be in (0, 180) degrees";
        else if (!(l->inner_deg >= 0 && l->inner_deg <= l->outer_deg)) why = "inner angle must be in [0, outer]";
    }
    if (why) return prt_fail(err, "%s: light: %s", what, why);
    return 0;
}
