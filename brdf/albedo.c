/* albedo.c - directional albedo by quadrature about the specular axis (albedo.h). */
#include "albedo.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

#define PI 3.14159265358979323846

/* The axis the quadrature concentrates on for wo: where the model's lobe peaks. The mirror
 * direction for every model but Lafortune, whose lobe l peaks at C_l * wo: the one with the
 * largest peak value |C_l * wo|^n (a lobe below the horizon, or none: the mirror). */
static void albedo_axis(const brdf_params *p, const double wo[3], double axis[3]) {
    axis[0] = -wo[0], axis[1] = -wo[1], axis[2] = wo[2];
    if (p->type != BRDF_LAFORTUNE) return;
    double best = -INFINITY;
    for (int l = 0; l < p->nlobes; l++) {
        const float *c = p->lobe[l];
        double v[3] = { c[0] * wo[0], c[1] * wo[1], c[2] * wo[2] };
        double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (!(len > 0) || !(v[2] > 0)) continue;
        double peak = c[3] * log(len);   /* log of the lobe's value at its peak */
        if (peak > best) {
            best = peak;
            for (int k = 0; k < 3; k++) axis[k] = v[k] / len;
        }
    }
}

/* Orthonormal u, v completing unit a. */
static void albedo_frame(const double a[3], double u[3], double v[3]) {
    double t[3] = { fabs(a[0]) < 0.9 ? 1 : 0, fabs(a[0]) < 0.9 ? 0 : 1, 0 };
    double d = t[0] * a[0] + t[1] * a[1] + t[2] * a[2], l = 0;
    for (int k = 0; k < 3; k++) { u[k] = t[k] - d * a[k]; l += u[k] * u[k]; }
    for (int k = 0; k < 3; k++) u[k] /= sqrt(l);
    v[0] = a[1] * u[2] - a[2] * u[1];
    v[1] = a[2] * u[0] - a[0] * u[2];
    v[2] = a[0] * u[1] - a[1] * u[0];
}

/* See albedo.h: midpoints in t (theta' = pi t^3, dtheta' = 3 pi t^2 dt) and phi'. */
void brdf_albedo(const brdf_params *p, float theta_deg, float rgb[3]) {
    const double th = theta_deg * PI / 180;
    const double wo[3] = { sin(th), 0, cos(th) };
    const float wof[3] = { (float)wo[0], (float)wo[1], (float)wo[2] };
    double a[3], u[3], v[3], acc[3] = { 0, 0, 0 };
    albedo_axis(p, wo, a);
    albedo_frame(a, u, v);
    const double dt = 1.0 / BRDF_ALBEDO_NT, dp = 2 * PI / BRDF_ALBEDO_NP;
    for (int i = 0; i < BRDF_ALBEDO_NT; i++) {
        double t = (i + 0.5) * dt, tp = PI * t * t * t, st = sin(tp), ct = cos(tp);
        double w = st * 3 * PI * t * t * dt * dp, ring[3] = { 0, 0, 0 };
        for (int j = 0; j < BRDF_ALBEDO_NP; j++) {
            double ph = (j + 0.5) * dp, cp = cos(ph), sp = sin(ph), wi[3];
            for (int k = 0; k < 3; k++) wi[k] = ct * a[k] + st * (cp * u[k] + sp * v[k]);
            if (!(wi[2] > 0)) continue;
            const float wif[3] = { (float)wi[0], (float)wi[1], (float)wi[2] };
            float f[3];
            brdf_eval(p, wif, wof, f);
            for (int c = 0; c < 3; c++) ring[c] += f[c] * wi[2];
        }
        for (int c = 0; c < 3; c++) acc[c] += ring[c] * w;
    }
    for (int c = 0; c < 3; c++) rgb[c] = (float)acc[c];
}

void brdf_albedo_max(const brdf_params *p, float rgb[3], float *theta_deg) {
    static const float k_angles[] = BRDF_ALBEDO_ANGLES;
    float best = -1;
    rgb[0] = rgb[1] = rgb[2] = 0;
    *theta_deg = 0;
    for (size_t i = 0; i < sizeof k_angles / sizeof k_angles[0]; i++) {
        float a[3];
        brdf_albedo(p, k_angles[i], a);
        for (int c = 0; c < 3; c++) {
            rgb[c] = fmaxf(rgb[c], a[c]);
            if (a[c] > best) best = a[c], *theta_deg = k_angles[i];
        }
    }
}

bool brdf_energy_warning(const brdf_params *p, const char *spec, char *msg, size_t cap) {
    float m[3], deg;
    brdf_albedo_max(p, m, &deg);
    float top = fmaxf(m[0], fmaxf(m[1], m[2]));
    if (!(top > 1 + BRDF_ALBEDO_SLACK)) return false;
    char canon[512];
    if (!spec) {
        brdf_format(p, canon, sizeof canon);
        spec = canon;
    }
    snprintf(msg, cap, "%s reflects up to %.3g of the light (directional albedo above 1 at %.0f deg): "
             "interreflections will gain energy", spec, top, deg);
    return true;
}
