/* lights.c - the radiant intensity of point and spot lights (lights.h).
 *
 * One falloff shared by every runtime and the path tracer, so their images differ only
 * by the approximations each makes, never by the light model. */
#include "lights.h"
#include "brdf.h"
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Reads n comma-separated finite numbers from s (exactly n). */
static bool parse_nums(const char *s, int n, float *out) {
    for (int i = 0; i < n; i++) {
        char *end;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno || !isfinite(v) || fabs(v) > 1e30) return false;
        out[i] = (float)v;
        s = end;
        if (i + 1 < n) {
            if (*s != ',') return false;
            s++;
        }
    }
    return *s == 0;
}

/* One "key=value" of a spec into l; `seen_pos` / `seen_dir` record the keys that need them. */
static int parse_key(char *kv, const char *what, prt_light *l, bool *seen_pos, prt_error *err) {
    char *eq = strchr(kv, '=');
    if (!eq) return prt_fail(err, "%s: light: expected key=value, got '%.40s'", what, kv);
    *eq = 0;
    const char *k = kv, *v = eq + 1;
    bool ok;
    bool spot_only = !strcmp(k, "dir") || !strcmp(k, "inner") || !strcmp(k, "outer");
    if (spot_only && l->type != PRT_LIGHT_SPOT) return prt_fail(err, "%s: light: '%s' is for spot lights only", what, k);
    if (!strcmp(k, "pos")) ok = parse_nums(v, 3, l->pos), *seen_pos = true;
    else if (!strcmp(k, "dir")) ok = parse_nums(v, 3, l->dir);
    else if (!strcmp(k, "colour") || !strcmp(k, "color")) ok = parse_nums(v, 3, l->colour);
    else if (!strcmp(k, "intensity")) ok = parse_nums(v, 1, &l->intensity);
    else if (!strcmp(k, "inner")) ok = parse_nums(v, 1, &l->inner_deg);
    else if (!strcmp(k, "outer")) ok = parse_nums(v, 1, &l->outer_deg);
    else return prt_fail(err, "%s: light: unknown key '%.40s' (pos, dir, inner, outer, intensity, colour)", what, k);
    if (!ok) return prt_fail(err, "%s: light: bad value for %s: '%.40s'", what, k, v);
    return 0;
}

/* "point:..." / "spot:..." (lights.h), then the field checks. */
int light_parse(const char *spec, const char *what, prt_light *out, prt_error *err) {
    char buf[512];
    if (!spec || strlen(spec) >= sizeof buf) return prt_fail(err, "%s: light: spec missing or too long", what);
    snprintf(buf, sizeof buf, "%s", spec);
    prt_light l = { .type = PRT_LIGHT_POINT, .dir = { 0, -1, 0 }, .inner_deg = 20, .outer_deg = 30,
                    .intensity = 1, .colour = { 1, 1, 1 } };
    char *colon = strchr(buf, ':');
    if (colon) *colon = 0;
    if (!strcmp(buf, "spot")) l.type = PRT_LIGHT_SPOT;
    else if (strcmp(buf, "point")) return prt_fail(err, "%s: light: unknown type '%.40s' (point or spot)", what, buf);
    bool seen_pos = false;
    for (char *kv = colon ? colon + 1 : NULL, *next; kv && *kv; kv = next) {
        next = strchr(kv, ';');
        if (next) *next++ = 0;
        if (parse_key(kv, what, &l, &seen_pos, err)) return -1;
    }
    if (!seen_pos) return prt_fail(err, "%s: light: no position (pos=x,y,z)", what);
    float n = sqrtf(l.dir[0] * l.dir[0] + l.dir[1] * l.dir[1] + l.dir[2] * l.dir[2]);
    if (!(n > 1e-12f)) return prt_fail(err, "%s: light: dir must not be zero", what);
    for (int k = 0; k < 3; k++) l.dir[k] /= n;
    if (light_validate(&l, what, err)) return -1;
    *out = l;
    return 0;
}

/* The shortest of %.6g / %.9g that reads back to f exactly. */
static const char *fmt_f(float f, char buf[32]) {
    snprintf(buf, 32, "%.6g", f);
    if (strtof(buf, NULL) != f) snprintf(buf, 32, "%.9g", f);
    return buf;
}

/* The spec string of l; light_parse reads it back to the same floats. */
void light_format(const prt_light *l, char *buf, size_t cap) {
    char a[32], b[32], c[32];
    int n = snprintf(buf, cap, "%s:pos=%s,%s,%s", l->type == PRT_LIGHT_SPOT ? "spot" : "point", fmt_f(l->pos[0], a),
                     fmt_f(l->pos[1], b), fmt_f(l->pos[2], c));
    if (n < 0 || (size_t)n >= cap) return;
    if (l->type == PRT_LIGHT_SPOT) {
        n += snprintf(buf + n, cap - (size_t)n, ";dir=%s,%s,%s", fmt_f(l->dir[0], a), fmt_f(l->dir[1], b), fmt_f(l->dir[2], c));
        if (n < 0 || (size_t)n >= cap) return;
        n += snprintf(buf + n, cap - (size_t)n, ";inner=%s;outer=%s", fmt_f(l->inner_deg, a), fmt_f(l->outer_deg, b));
    }
    if (n < 0 || (size_t)n >= cap) return;
    n += snprintf(buf + n, cap - (size_t)n, ";intensity=%s", fmt_f(l->intensity, a));
    if (n < 0 || (size_t)n >= cap) return;
    snprintf(buf + n, cap - (size_t)n, ";colour=%s,%s,%s", fmt_f(l->colour[0], a), fmt_f(l->colour[1], b), fmt_f(l->colour[2], c));
}

/* Validated append. */
int lights_add(prt_lights *ls, const prt_light *l, const char *what, prt_error *err) {
    if (light_validate(l, what, err)) return -1;
    if (ls->count >= PRT_MAX_LIGHTS) return prt_fail(err, "%s: more than %d lights", what, PRT_MAX_LIGHTS);
    ls->light[ls->count++] = *l;
    return 0;
}

/* f_r(wi, wo) I cos / d^2 (lights.h): the rendering equation's integral collapses to one term
 * for a delta light, so one brdf_eval per light and point. */
float light_shade(const prt_light *l, const brdf_params *bp, const float p[3], const float n[3], const float wo[3],
                  float wi[3], float out[3]) {
    out[0] = out[1] = out[2] = 0;
    float d[3] = { l->pos[0] - p[0], l->pos[1] - p[1], l->pos[2] - p[2] };
    float dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], dist = sqrtf(dist2);
    if (!(dist2 >= FLT_MIN)) { wi[0] = wi[1] = wi[2] = 0; return 0; }   /* at the point (any scale) */
    for (int k = 0; k < 3; k++) wi[k] = d[k] / dist;
    float S[3], T[3], wil[3], wol[3], f[3], I[3], away[3] = { -wi[0], -wi[1], -wi[2] };
    brdf_frame(n, S, T);
    brdf_to_local(S, T, n, wi, wil);
    brdf_to_local(S, T, n, wo, wol);
    if (wil[2] <= 0 || wol[2] <= 0) return dist;
    light_intensity_toward(l, away, I);
    if (!(I[0] > 0 || I[1] > 0 || I[2] > 0)) return dist;
    brdf_eval(bp, wil, wol, f);
    float k = wil[2] / dist2;
    for (int c = 0; c < 3; c++) out[c] = f[c] * I[c] * k;
    return dist;
}
