/* brdf.c - analytic BRDF models: parsing, evaluation, importance sampling and
 * the stereographic tangent frame of Eq. 10.
 *
 * Why it looks the way it does:
 *  - Evaluation is done in double and every model is written as a symmetric
 *    expression of (wi, wo) (products commute exactly in IEEE arithmetic), so
 *    f(wi,wo) == f(wo,wi) bit for bit: the tabulated matrix of section 3.3 is
 *    exactly symmetric, which lets factor.c use a symmetric eigensolver.
 *  - Powers x^n go through exp(n log x) with the exponent clamped (pow_clamped),
 *    and cosines used as divisors are floored at 1e-7, so exponents up to 1e6
 *    and grazing directions (w.z -> 0) never produce Inf or NaN.
 *  - Sampling is a one-sample mixture of a cosine-weighted diffuse lobe and the
 *    model's specular lobe(s); brdf_pdf evaluates exactly that mixture density
 *    (same weights, computed from wo only), so sample and pdf agree.
 * All directions are in the local frame (z = normal) and point away from the surface. */
#include "brdf.h"
#include <ctype.h>
#include <stdarg.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PI 3.14159265358979323846
#define EXP_ARG_MAX 80.0      /* exp(80) ~ 5.5e34 stays below FLT_MAX */
#define COS_FLOOR 1e-7        /* cosines used as divisors are floored here */
#define EXP_LIMIT 1e6         /* largest accepted Phong/Blinn/AS/Lafortune exponent */

static const char *k_names[] = { "lambert", "phong", "blinn", "as", "lafortune", "ggx", "beckmann" };

/* "phong" etc. for t; "?" for an invalid value. */
const char *brdf_type_name(brdf_type t) {
    return (unsigned)t < sizeof k_names / sizeof k_names[0] ? k_names[t] : "?";
}

/* ---------------------------------------------------------------- numerics */

/* x^n for n >= 0: 0 for x <= 0 (and for NaN), result clamped to exp(80). */
static double pow_clamped(double x, double n) {
    if (!(x > 0)) return 0;
    if (n == 0) return 1;
    double l = n * log(x);
    if (l < -745) return 0;
    return exp(l < EXP_ARG_MAX ? l : EXP_ARG_MAX);
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Unit half vector of two upper-hemisphere directions (w.z > 0 so the sum is never 0);
 * returns wi.h = wo.h, computed as their mean so it is exactly symmetric, floored at COS_FLOOR. */
static double half_vector(const float wi[3], const float wo[3], double h[3]) {
    h[0] = (double)wi[0] + wo[0];
    h[1] = (double)wi[1] + wo[1];
    h[2] = (double)wi[2] + wo[2];
    double l = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    h[0] /= l, h[1] /= l, h[2] /= l;
    double a = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2], b = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
    return fmax(0.5 * (a + b), COS_FLOOR);
}

/* sin^2 of the half vector's polar angle, computed from its x,y (exact near the pole). */
static double h_sin2(const double h[3]) { return h[0] * h[0] + h[1] * h[1]; }

/* Ashikhmin-Shirley anisotropic lobe (n.h)^((nu hx^2 + nv hy^2)/(1 - hz^2)).
 * log(hz)/(1 - hz^2) = 0.5 log1p(-s2)/s2 stays finite as s2 -> 0 (limit -1/2). */
static double as_lobe(double nu, double nv, const double h[3]) {
    double s2 = h_sin2(h);
    double ratio = s2 > 1e-300 ? 0.5 * log1p(-(s2 < 1 ? s2 : 1)) / s2 : -0.5;
    if (!isfinite(ratio)) return 0; /* hz == 0: the lobe vanishes */
    double l = (nu * h[0] * h[0] + nv * h[1] * h[1]) * ratio;
    if (l < -745) return 0;
    return exp(l < EXP_ARG_MAX ? l : EXP_ARG_MAX);
}

/* GGX normal distribution D(h), written with sin^2 so it is exact near the pole. */
static double ggx_d(double alpha, const double h[3]) {
    double a2 = alpha * alpha, c2 = h[2] * h[2], d = a2 * c2 + h_sin2(h);
    return a2 / (PI * d * d);
}

/* Beckmann D(h) = exp(-tan^2/a^2) / (pi a^2 cos^4). */
static double beckmann_d(double alpha, const double h[3]) {
    double a2 = alpha * alpha, c2 = h[2] * h[2];
    if (!(c2 > 0)) return 0;
    double arg = -h_sin2(h) / (c2 * a2);
    if (arg < -700) return 0;
    return exp(arg) / (PI * a2 * c2 * c2);
}

/* Beckmann Smith Lambda (Walter et al. 2007 rational fit), c = cos(theta) > 0. */
static double beckmann_lambda(double alpha, double c) {
    double s = sqrt(fmax(0.0, 1 - c * c));
    if (s <= 0) return 0;
    double a = c / (alpha * s);
    if (a >= 1.6) return 0;
    return (1 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a);
}

static double schlick(double f0, double c) {
    double m = 1 - c;
    if (m < 0) m = 0;
    double m2 = m * m;
    return f0 + (1 - f0) * m2 * m2 * m;
}

/* ---------------------------------------------------------------- evaluation */

/* f_r per channel, no cosine; zero below the horizon. Symmetric in (wi, wo). */
void brdf_eval(const brdf_params *p, const float wi[3], const float wo[3], float rgb[3]) {
    rgb[0] = rgb[1] = rgb[2] = 0;
    if (!(wi[2] > 0) || !(wo[2] > 0)) return;
    double ci = fmax(wi[2], COS_FLOOR), co = fmax(wo[2], COS_FLOOR);
    double out[3] = { p->kd[0] / PI, p->kd[1] / PI, p->kd[2] / PI };
    double h[3];
    switch (p->type) {
    case BRDF_LAMBERT: break;
    case BRDF_PHONG: {
        /* Modified Phong: cos(alpha) = wi . mirror(wo), symmetric in wi, wo. */
        double c = -(double)wi[0] * wo[0] - (double)wi[1] * wo[1] + (double)wi[2] * wo[2];
        double s = (p->n + 2) / (2 * PI) * pow_clamped(c, p->n);
        for (int k = 0; k < 3; k++) out[k] += p->ks[k] * s;
        break;
    }
    case BRDF_BLINN: {
        half_vector(wi, wo, h);
        double s = (p->n + 8) / (8 * PI) * pow_clamped(h[2], p->n);
        for (int k = 0; k < 3; k++) out[k] += p->ks[k] * s;
        break;
    }
    case BRDF_AS: {
        /* Ashikhmin & Shirley 2000, Eq. 4 (specular) and Eq. 5 (coupled diffuse). */
        double kh = half_vector(wi, wo, h);
        double spec = sqrt((p->nu + 1) * (p->nv + 1)) / (8 * PI) * as_lobe(p->nu, p->nv, h) / (kh * fmax(ci, co));
        double di = 1 - ci * 0.5, dout = 1 - co * 0.5;
        double di5 = di * di * di * di * di, do5 = dout * dout * dout * dout * dout;
        double dif = 28.0 / (23.0 * PI) * (1 - di5) * (1 - do5);
        for (int k = 0; k < 3; k++)
            out[k] = p->kd[k] * (1 - p->ks[k]) * dif + spec * schlick(p->ks[k], kh);
        break;
    }
    case BRDF_LAFORTUNE: {
        double s = 0;
        for (int l = 0; l < p->nlobes; l++) {
            const float *c = p->lobe[l];
            double v = c[0] * ((double)wi[0] * wo[0]) + c[1] * ((double)wi[1] * wo[1]) + c[2] * ((double)wi[2] * wo[2]);
            s += pow_clamped(v, c[3]);
        }
        for (int k = 0; k < 3; k++) out[k] += s;
        break;
    }
    case BRDF_GGX:
    case BRDF_BECKMANN: {
        /* Cook-Torrance: D F G2 / (4 ci co), G2 height-correlated Smith. */
        double kh = half_vector(wi, wo, h);
        double a = p->alpha, dg;
        if (p->type == BRDF_GGX) {
            /* G2/(4 ci co) = 0.5 / (co sqrt(ci^2 (1-a^2) + a^2) + ci sqrt(co^2 (1-a^2) + a^2)) */
            double a2 = a * a;
            double den = co * sqrt(ci * ci * (1 - a2) + a2) + ci * sqrt(co * co * (1 - a2) + a2);
            dg = ggx_d(a, h) * 0.5 / den;
        } else {
            double g2 = 1 / (1 + beckmann_lambda(a, ci) + beckmann_lambda(a, co));
            dg = beckmann_d(a, h) * g2 / (4 * ci * co);
        }
        for (int k = 0; k < 3; k++) out[k] += dg * schlick(p->ks[k], kh);
        break;
    }
    }
    for (int k = 0; k < 3; k++) {
        double v = out[k];
        rgb[k] = v > 0 ? (float)(v < FLT_MAX ? v : FLT_MAX) : 0.0f;
    }
}

/* ---------------------------------------------------------------- sampling */

/* The sampling mixture for a given wo: component 0 is cosine-weighted diffuse,
 * components 1.. are the model's lobes (one, or one per Lafortune lobe). */
typedef struct brdf_mix {
    int n;
    double w[1 + BRDF_MAX_LOBES];
    double axis[BRDF_MAX_LOBES][3];   /* Lafortune lobe peaks; [0] the Phong mirror direction */
} brdf_mix;

/* Fills the mixture weights (sum 1) for wo (wo.z > 0). */
static void mix_init(const brdf_params *p, const float wo[3], brdf_mix *m) {
    memset(m, 0, sizeof *m);
    double wd = prt_luminance(p->kd), total;
    m->n = 1;
    switch (p->type) {
    case BRDF_LAMBERT: break;
    case BRDF_PHONG:
        m->axis[0][0] = -wo[0], m->axis[0][1] = -wo[1], m->axis[0][2] = wo[2];
        /* fall through */
    case BRDF_BLINN:
    case BRDF_AS:
    case BRDF_GGX:
    case BRDF_BECKMANN:
        m->n = 2;
        m->w[1] = prt_luminance(p->ks);
        break;
    case BRDF_LAFORTUNE:
        m->n = 1 + p->nlobes;
        for (int l = 0; l < p->nlobes; l++) {
            const float *c = p->lobe[l];
            double v[3] = { (double)c[0] * wo[0], (double)c[1] * wo[1], (double)c[2] * wo[2] };
            double len = sqrt(dot3(v, v));
            /* peak at or below the horizon: this lobe is left to the diffuse component */
            if (!(len > 0) || !(v[2] > 1e-6 * len)) continue;
            for (int k = 0; k < 3; k++) m->axis[l][k] = v[k] / len;
            /* approximate albedo of [C.(wi*wo)]^n = len^n cos^n: len^n * 2pi/(n+2) * peak.z */
            double lw = pow_clamped(len, c[3]) * 2 * PI / (c[3] + 2) * m->axis[l][2];
            m->w[1 + l] = lw < 1e6 ? lw : 1e6;
        }
        break;
    }
    m->w[0] = wd;
    total = 0;
    for (int i = 0; i < m->n; i++) total += m->w[i];
    if (!(total > 0)) {
        for (int i = 0; i < m->n; i++) m->w[i] = 0;
        m->w[0] = 1;
        return;
    }
    for (int i = 0; i < m->n; i++) m->w[i] /= total;
}

/* Orthonormal t, b completing unit n (Duff et al. 2017). */
static void onb(const double n[3], double t[3], double b[3]) {
    double s = n[2] >= 0 ? 1.0 : -1.0, a = -1 / (s + n[2]), c = n[0] * n[1] * a;
    t[0] = 1 + s * n[0] * n[0] * a, t[1] = s * c, t[2] = -s * n[0];
    b[0] = c, b[1] = s + n[1] * n[1] * a, b[2] = -n[1];
}

/* Direction at polar angle (cos ct) and azimuth phi around unit axis. */
static void around(const double axis[3], double ct, double phi, double out[3]) {
    double t[3], b[3], st = sqrt(fmax(0.0, 1 - ct * ct)), cp = cos(phi), sp = sin(phi);
    onb(axis, t, b);
    for (int k = 0; k < 3; k++) out[k] = st * cp * t[k] + st * sp * b[k] + ct * axis[k];
}

/* cos(theta) of a sample from the density (n+1)/(2pi) cos^n on the hemisphere. */
static double cos_power_sample(double n, double u) { return exp(log1p(-u) / (n + 1)); }

/* pdf (solid angle) of the cos^n lobe around axis at w. */
static double cos_power_pdf(double n, const double axis[3], const double w[3]) {
    return (n + 1) / (2 * PI) * pow_clamped(dot3(axis, w), n);
}

/* AS half-vector azimuth (AS 2000, Eq. 9) for u in [0,1): one quadrant per quarter of u. */
static double as_phi(double nu, double nv, double u) {
    int q = (int)(u * 4);
    if (q > 3) q = 3;
    double v = u * 4 - q;
    double ph = atan(sqrt((nu + 1) / (nv + 1)) * tan(PI / 2 * v));
    switch (q) {
    case 0: return ph;
    case 1: return PI - ph;
    case 2: return PI + ph;
    default: return 2 * PI - ph;
    }
}

/* Reflects wo about unit h. */
static void reflect_about(const float wo[3], const double h[3], double out[3]) {
    double d = h[0] * wo[0] + h[1] * wo[1] + h[2] * wo[2];
    for (int k = 0; k < 3; k++) out[k] = 2 * d * h[k] - wo[k];
}

/* Picks wi given wo; returns false below the horizon (wo or the sample). */
bool brdf_sample(const brdf_params *p, const float wo[3], float u1, float u2, float wi[3], float *pdf) {
    *pdf = 0;
    wi[0] = wi[1] = 0, wi[2] = 1;
    if (!(wo[2] > 0)) return false;
    brdf_mix m;
    mix_init(p, wo, &m);
    double u = u1 < 0 ? 0 : u1, v = u2 < 0 ? 0 : u2 >= 1 ? 1 - 1e-9 : u2;
    int c = -1, last = 0;
    for (int i = 0; i < m.n; i++) {
        if (!(m.w[i] > 0)) continue;
        last = i;
        if (u < m.w[i]) { c = i; break; }
        u -= m.w[i];
    }
    if (c < 0) c = last, u = m.w[c];
    u /= m.w[c];
    if (u >= 1) u = 1 - 1e-9;
    double w[3], h[3];
    if (c == 0) {
        double r = sqrt(u), ph = 2 * PI * v;
        w[0] = r * cos(ph), w[1] = r * sin(ph), w[2] = sqrt(fmax(0.0, 1 - u));
    } else {
        switch (p->type) {
        case BRDF_PHONG: around(m.axis[0], cos_power_sample(p->n, v), 2 * PI * u, w); break;
        case BRDF_LAFORTUNE: around(m.axis[c - 1], cos_power_sample(p->lobe[c - 1][3], v), 2 * PI * u, w); break;
        case BRDF_BLINN:
        case BRDF_AS:
        case BRDF_GGX:
        case BRDF_BECKMANN: {
            static const double zaxis[3] = { 0, 0, 1 };
            double ct, ph = 2 * PI * u;
            if (p->type == BRDF_BLINN) ct = cos_power_sample(p->n, v);
            else if (p->type == BRDF_AS) {
                ph = as_phi(p->nu, p->nv, u);
                double cp = cos(ph), sp = sin(ph);
                ct = cos_power_sample(p->nu * cp * cp + p->nv * sp * sp, v);
            } else if (p->type == BRDF_GGX) {
                double t2 = p->alpha * p->alpha * v / (1 - v);
                ct = 1 / sqrt(1 + t2);
            } else {
                double t2 = -p->alpha * p->alpha * log1p(-v);
                ct = 1 / sqrt(1 + t2);
            }
            around(zaxis, ct, ph, h);
            reflect_about(wo, h, w);
            break;
        }
        default: return false;
        }
    }
    if (!(w[2] > 0)) return false;
    double l = sqrt(dot3(w, w));
    for (int k = 0; k < 3; k++) wi[k] = (float)(w[k] / l);
    if (!(wi[2] > 0)) return false;
    *pdf = brdf_pdf(p, wo, wi);
    return *pdf > 0 && isfinite(*pdf);
}

/* Mixture pdf (solid angle) of brdf_sample at wi given wo; 0 below the horizon. */
float brdf_pdf(const brdf_params *p, const float wo[3], const float wi[3]) {
    if (!(wo[2] > 0) || !(wi[2] > 0)) return 0;
    brdf_mix m;
    mix_init(p, wo, &m);
    double w[3] = { wi[0], wi[1], wi[2] };
    double pdf = m.w[0] * wi[2] / PI;
    if (m.n > 1) {
        double h[3];
        switch (p->type) {
        case BRDF_PHONG: pdf += m.w[1] * cos_power_pdf(p->n, m.axis[0], w); break;
        case BRDF_LAFORTUNE:
            for (int l = 0; l < p->nlobes; l++)
                if (m.w[1 + l] > 0) pdf += m.w[1 + l] * cos_power_pdf(p->lobe[l][3], m.axis[l], w);
            break;
        case BRDF_BLINN:
        case BRDF_AS:
        case BRDF_GGX:
        case BRDF_BECKMANN: {
            double kh = half_vector(wi, wo, h), ph;
            if (p->type == BRDF_BLINN) ph = (p->n + 1) / (2 * PI) * pow_clamped(h[2], p->n);
            else if (p->type == BRDF_AS) ph = sqrt((p->nu + 1) * (p->nv + 1)) / (2 * PI) * as_lobe(p->nu, p->nv, h);
            else if (p->type == BRDF_GGX) ph = ggx_d(p->alpha, h) * h[2];
            else ph = beckmann_d(p->alpha, h) * h[2];
            pdf += m.w[1] * ph / (4 * kh);
            break;
        }
        default: break;
        }
    }
    return pdf < FLT_MAX ? (float)pdf : FLT_MAX;
}

/* ---------------------------------------------------------------- frame */

/* Eq. 10's stereographic frame; s, t unit and orthogonal to n (re-orthogonalized in double). */
void brdf_frame(const float n[3], float s[3], float t[3]) {
    double nx = n[0], ny = n[1], nz = n[2];
    double nl = sqrt(nx * nx + ny * ny + nz * nz);
    if (!(nl > 0)) nx = 0, ny = 0, nz = 1, nl = 1;
    nx /= nl, ny /= nl, nz /= nl;
    double r2 = nx * nx + nz * nz, v[3];
    if (ny < 0 && r2 < 1e-12) {
        /* within 1e-6 of (0,-1,0), the formula's one discontinuity: the limit along +z */
        v[0] = 1, v[1] = 0, v[2] = 0;
    } else {
        /* a = ny + 1 without cancellation near ny = -1: (1 - ny^2) / (1 - ny) */
        double a = ny >= 0 ? ny + 1 : r2 / (1 - ny);
        v[0] = a * a + nz * nz - nx * nx, v[1] = -2 * a * nx, v[2] = -2 * nx * nz;
    }
    double nn[3] = { nx, ny, nz }, d = dot3(v, nn);
    for (int k = 0; k < 3; k++) v[k] -= d * nn[k];
    double l = sqrt(dot3(v, v));
    if (!(l > 1e-30)) { /* cannot happen for a unit n; keep a valid frame anyway */
        double b[3];
        onb(nn, v, b);
        l = 1;
    }
    for (int k = 0; k < 3; k++) v[k] /= l;
    double tt[3] = { ny * v[2] - nz * v[1], nz * v[0] - nx * v[2], nx * v[1] - ny * v[0] };
    for (int k = 0; k < 3; k++) s[k] = (float)v[k], t[k] = (float)tt[k];
}

/* ---------------------------------------------------------------- parsing */

static void set3(float d[3], float v) { d[0] = d[1] = d[2] = v; }

/* Default parameters of model t (header: kd 0.5, ks 0.5, n 50, nu=nv 100, alpha 0.2). */
static void defaults(brdf_type t, brdf_params *p) {
    memset(p, 0, sizeof *p);
    p->type = t;
    set3(p->kd, 0.5f);
    set3(p->ks, t == BRDF_LAMBERT || t == BRDF_LAFORTUNE ? 0.0f : 0.5f);
    p->n = 50;
    p->nu = p->nv = 100;
    p->alpha = 0.2f;
}

/* Lafortune's default lobe: a Phong-like lobe (-c,-c,c,50) with peak c^50 = 0.5 * 52/(2pi),
 * i.e. the modified Phong lobe with ks = 0.5, n = 50 at its peak. */
static void lafortune_default_lobe(brdf_params *p) {
    double c = exp(log(0.5 * 52 / (2 * PI)) / 50);
    p->nlobes = 1;
    p->lobe[0][0] = (float)-c, p->lobe[0][1] = (float)-c, p->lobe[0][2] = (float)c, p->lobe[0][3] = 50;
}

static char *trim(char *s) {
    while (isspace((unsigned char)*s)) s++;
    char *e = s + strlen(s);
    while (e > s && isspace((unsigned char)e[-1])) *--e = 0;
    return s;
}

/* Parses up to max comma-separated finite numbers from s into v; returns the count or -1. */
static int parse_numbers(char *s, double *v, int max) {
    int n = 0;
    char *p = s;
    for (;;) {
        if (n == max) return -1;
        char *end;
        while (isspace((unsigned char)*p)) p++;
        if (!*p) return -1;
        v[n] = strtod(p, &end);
        if (end == p || !isfinite(v[n])) return -1;
        if ((float)v[n] == 0) v[n] = 0;   /* -0 (or a float underflow: -1e-109) is 0: a canonical spec re-parses bit for bit */
        n++;
        p = end;
        while (isspace((unsigned char)*p)) p++;
        if (!*p) return n;
        if (*p != ',') return -1;
        p++;
    }
}

static bool key_allowed(brdf_type t, const char *key) {
    if (!strcmp(key, "kd")) return true;
    switch (t) {
    case BRDF_LAMBERT: return false;
    case BRDF_PHONG:
    case BRDF_BLINN: return !strcmp(key, "ks") || !strcmp(key, "n");
    case BRDF_AS: return !strcmp(key, "ks") || !strcmp(key, "nu") || !strcmp(key, "nv");
    case BRDF_LAFORTUNE: return !strcmp(key, "lobe");
    case BRDF_GGX:
    case BRDF_BECKMANN: return !strcmp(key, "ks") || !strcmp(key, "alpha");
    }
    return false;
}

/* The presets of section 5: true (and *out set) when s names one. */
static bool parse_preset(const char *s, brdf_params *out) {
    if (!strcasecmp(s, "paper-phong")) {
        /* section 5: Phong with a red diffuse colour and exponent 50 */
        defaults(BRDF_PHONG, out);
        out->kd[0] = 0.5f, out->kd[1] = 0.05f, out->kd[2] = 0.05f;
        set3(out->ks, 0.3f);
        out->n = 50;
        return true;
    }
    if (!strcasecmp(s, "paper-as")) {
        /* section 5: AS with kd 0.5, ks 0.75, nu 10, nv 100 */
        defaults(BRDF_AS, out);
        set3(out->kd, 0.5f);
        set3(out->ks, 0.75f);
        out->nu = 10, out->nv = 100;
        return true;
    }
    return false;
}

/* Sets colour key ("kd" or "ks") of p from v[3] after range checks (ks of a microfacet or AS
 * model is a Fresnel reflectance, so at most 1). Returns 0, or -1 with err set. */
static int parse_rgb(const char *spec, const char *key, const double v[3], brdf_params *p, prt_error *err) {
    bool fresnel = !strcmp(key, "ks") && (p->type == BRDF_AS || p->type == BRDF_GGX || p->type == BRDF_BECKMANN);
    for (int k = 0; k < 3; k++) {
        if (v[k] < 0) return prt_fail(err, "brdf \"%s\": %s=%g is negative", spec, key, v[k]);
        if (fresnel && v[k] > 1)
            return prt_fail(err, "brdf \"%s\": ks=%g out of range [0,1] (Fresnel reflectance)", spec, v[k]);
        if (v[k] > 1e6) return prt_fail(err, "brdf \"%s\": %s=%g out of range", spec, key, v[k]);
    }
    float *d = key[1] == 'd' ? p->kd : p->ks;
    for (int k = 0; k < 3; k++) d[k] = (float)v[k];
    return 0;
}

/* Sets exponent key n, nu or nv (v[0]) of p, or appends lobe v[4] = Cx,Cy,Cz,n as lobe
 * *lobes. Returns 0, or -1 with err set. */
static int parse_exponent(const char *spec, const char *key, const double *v, int want, brdf_params *p, int *lobes,
                          prt_error *err) {
    double e = want == 4 ? v[3] : v[0];
    if (e < 0) return prt_fail(err, "brdf \"%s\": negative exponent %s=%g", spec, key, e);
    if (e > EXP_LIMIT) return prt_fail(err, "brdf \"%s\": exponent %s=%g out of range [0,1e6]", spec, key, e);
    if (!strcmp(key, "n")) p->n = (float)e;
    else if (!strcmp(key, "nu")) p->nu = (float)e;
    else if (!strcmp(key, "nv")) p->nv = (float)e;
    else {
        if (*lobes == BRDF_MAX_LOBES) return prt_fail(err, "brdf \"%s\": more than %d lobes", spec, BRDF_MAX_LOBES);
        for (int k = 0; k < 3; k++) {
            if (fabs(v[k]) > 1e6) return prt_fail(err, "brdf \"%s\": lobe coefficient %g out of range", spec, v[k]);
            p->lobe[*lobes][k] = (float)v[k];
        }
        p->lobe[*lobes][3] = (float)e;
        (*lobes)++;
    }
    return 0;
}

/* Applies one trimmed, non-empty "key=value" item (modified in place) of spec to p.
 * Returns 0, or -1 with err naming the spec and the problem. */
static int parse_item(const char *spec, char *it, brdf_params *p, int *lobes, prt_error *err) {
    char *eq = strchr(it, '=');
    if (!eq) return prt_fail(err, "brdf \"%s\": expected key=value, got '%s'", spec, it);
    *eq = 0;
    char *key = trim(it), *val = trim(eq + 1);
    if (!key_allowed(p->type, key))
        return prt_fail(err, "brdf \"%s\": unknown key '%s' for model %s", spec, key, k_names[p->type]);
    double v[4];
    int want = !strcmp(key, "lobe") ? 4 : 1;
    bool rgb = !strcmp(key, "kd") || !strcmp(key, "ks");
    int nv = parse_numbers(val, v, rgb ? 3 : want);
    if (nv < 0 || (rgb ? (nv != 1 && nv != 3) : nv != want))
        return prt_fail(err, "brdf \"%s\": bad number '%s' for %s (expected %s)", spec, val, key,
                        rgb ? "1 or 3 numbers" : want == 4 ? "Cx,Cy,Cz,n" : "1 number");
    if (rgb) {
        if (nv == 1) v[1] = v[2] = v[0];
        return parse_rgb(spec, key, v, p, err);
    }
    if (!strcmp(key, "alpha")) {
        if (!(v[0] >= 1e-3 && v[0] <= 2)) return prt_fail(err, "brdf \"%s\": alpha=%g out of range [0.001,2]", spec, v[0]);
        p->alpha = (float)v[0];
        return 0;
    }
    return parse_exponent(spec, key, v, want, p, lobes, err);
}

/* Parses a spec (see brdf.h): a preset, or "model:key=value;...". Returns 0, or -1 with
 * err naming the spec and the problem. */
int brdf_parse(const char *spec, brdf_params *out, prt_error *err) {
    if (!spec) return prt_fail(err, "brdf: no spec given");
    char buf[1024];
    if (strlen(spec) >= sizeof buf) return prt_fail(err, "brdf \"%.60s...\": spec longer than %zu characters", spec, sizeof buf - 1);
    strcpy(buf, spec);
    char *s = trim(buf);
    if (parse_preset(s, out)) return 0;
    char *colon = strchr(s, ':'), *rest = NULL;
    if (colon) *colon = 0, rest = colon + 1;
    char *model = trim(s);
    int type = -1;
    for (int i = 0; i < (int)(sizeof k_names / sizeof k_names[0]); i++)
        if (!strcasecmp(model, k_names[i])) type = i;
    if (type < 0)
        return prt_fail(err, "brdf \"%s\": unknown model '%s' (lambert, phong, blinn, as, lafortune, ggx, beckmann, "
                        "paper-phong, paper-as)", spec, model);
    brdf_params p;
    defaults((brdf_type)type, &p);
    int lobes = 0;
    char *item = rest;
    while (item && *item) {
        char *semi = strchr(item, ';');
        if (semi) *semi = 0;
        char *it = trim(item);
        item = semi ? semi + 1 : NULL;
        if (*it && parse_item(spec, it, &p, &lobes, err)) return -1;
    }
    if (p.type == BRDF_LAFORTUNE) {
        if (lobes) p.nlobes = lobes;
        else lafortune_default_lobe(&p);
    }
    *out = p;
    return 0;
}

/* printf-style append at *at (clamped to cap; the text is always terminated). */
static void append(char *buf, size_t cap, size_t *at, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void append(char *buf, size_t cap, size_t *at, const char *fmt, ...) {
    if (*at + 1 >= cap) return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(buf + *at, cap - *at, fmt, ap);
    va_end(ap);
    if (n > 0) *at = *at + (size_t)n < cap ? *at + (size_t)n : cap - 1;
}

/* The shortest decimal of v that parses back (strtod, then float, as brdf_parse does) to the same
 * float: "0.2", not "0.200000003"; %.9g always round-trips, so the loop ends. */
static const char *num(char out[32], float v) {
    for (int prec = 1; prec <= 9; prec++) {   /* 9 digits always round-trip a float: the last try is exact */
        snprintf(out, 32, "%.*g", prec, v);
        if ((float)strtod(out, NULL) == v) break;
    }
    /* whole numbers below 1e9 stay written out ("50", not "5e+01"): as many digits as the integer part */
    float a = fabsf(v);
    if (strchr(out, 'e') && a >= 1 && a < 1e9f) {
        int digits = 1;
        for (float p10 = 10; a >= p10; p10 *= 10) digits++;
        snprintf(out, 32, "%.*g", digits, v);
    }
    return out;
}

/* Appends "key=v" or "key=r,g,b" (one value when the channels are equal, bit for bit). */
static void append_rgb(char *buf, size_t cap, size_t *at, const char *key, const float c[3]) {
    char a[32], b[32], d[32];
    if (!memcmp(&c[0], &c[1], sizeof c[0]) && !memcmp(&c[1], &c[2], sizeof c[0])) append(buf, cap, at, "%s=%s", key, num(a, c[0]));
    else append(buf, cap, at, "%s=%s,%s,%s", key, num(a, c[0]), num(b, c[1]), num(d, c[2]));
}

/* Canonical spec for p (parses back to the same parameters, bit for bit) into buf. */
void brdf_format(const brdf_params *p, char *buf, size_t cap) {
    if (!cap) return;
    size_t at = 0;
    buf[0] = 0;
    append(buf, cap, &at, "%s:", brdf_type_name(p->type));
    append_rgb(buf, cap, &at, "kd", p->kd);
    if (p->type != BRDF_LAMBERT && p->type != BRDF_LAFORTUNE) {
        append(buf, cap, &at, ";");
        append_rgb(buf, cap, &at, "ks", p->ks);
    }
    char a[32], b[32], c[32], d[32];
    switch (p->type) {
    case BRDF_LAMBERT: break;
    case BRDF_PHONG:
    case BRDF_BLINN: append(buf, cap, &at, ";n=%s", num(a, p->n)); break;
    case BRDF_AS: append(buf, cap, &at, ";nu=%s;nv=%s", num(a, p->nu), num(b, p->nv)); break;
    case BRDF_LAFORTUNE:
        for (int l = 0; l < p->nlobes && l < BRDF_MAX_LOBES; l++)
            append(buf, cap, &at, ";lobe=%s,%s,%s,%s", num(a, p->lobe[l][0]), num(b, p->lobe[l][1]), num(c, p->lobe[l][2]),
                   num(d, p->lobe[l][3]));
        break;
    case BRDF_GGX:
    case BRDF_BECKMANN: append(buf, cap, &at, ";alpha=%s", num(a, p->alpha)); break;
    }
}
