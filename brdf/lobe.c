/* lobe.c - von Mises-Fisher lobes, spherical Gaussians and anisotropic spherical
 * Gaussians: evaluation, moments, merging, sampling and product integrals.
 *
 * Why it looks the way it does:
 *  - Everything is computed in double and stored in float. The dangerous quantity is
 *    1 - mu.s near a sharp lobe's peak: in float it is lost below 6e-8, i.e. for
 *    kappa 1e6 at half the peak width. We form it as |mu - s|^2 / 2 on vectors
 *    normalized in double (exact to rounding of the inputs), never as 1 - dot.
 *  - Normalizations are written with e^{-2k} (C(k) = k / (2 pi (1 - e^{-2k})) and
 *    A(l) = 2 pi (1 - e^{-2l}) / l) through expm1, so they are exact for small k and
 *    never overflow for large k; below 1e-4 a series is used for the 0/0 limit.
 *  - The mean length A3(k) = coth k - 1/k cancels for small k (series k/3 - k^3/45 +
 *    2k^5/945 below 1e-2) and is 1 - 1/k + 2 e^{-2k}/(1 - e^{-2k}) for large k; its
 *    inverse is Newton on A3 from Eq. 3's Banerjee estimate, and 1/(1 - r) for r > 0.95
 *    (kappa > 20, where the e^{-2k} term is below double rounding).
 *  - Products of two lobes (vMF x vMF, SG x SG) are one lobe of sharpness
 *    lm = |la a + lb b|; the scale e^{lm - la - lb} is computed from the exact identity
 *    la + lb - lm = 2 la lb (1 - cos) / (la + lb + lm), which never cancels. */
#include "lobe.h"
#include "check.h"
#include <math.h>

#define PI 3.14159265358979323846

/* ---------------------------------------------------------------- helpers */

/* Normalizes a float 3-vector into double; returns its length (0 leaves o = +z). */
static double unit_d(const float a[3], double o[3]) {
    double l = sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]);
    if (!(l > 0)) { o[0] = o[1] = 0, o[2] = 1; return 0; }
    o[0] = a[0] / l, o[1] = a[1] / l, o[2] = a[2] / l;
    return l;
}

/* 1 - a.b for unit directions, as |a - b|^2 / 2 (accurate when a ~ b). */
static double one_minus_cos(const float a[3], const float b[3]) {
    double x[3], y[3];
    unit_d(a, x), unit_d(b, y);
    double d0 = x[0] - y[0], d1 = x[1] - y[1], d2 = x[2] - y[2];
    return 0.5 * (d0 * d0 + d1 * d1 + d2 * d2);
}

/* Orthonormal t1, t2 completing unit n (Duff et al. 2017, branchless, no singularity). */
static void basis(const double n[3], double t1[3], double t2[3]) {
    double sg = copysign(1.0, n[2]), a = -1.0 / (sg + n[2]), b = n[0] * n[1] * a;
    t1[0] = 1 + sg * n[0] * n[0] * a, t1[1] = sg * b, t1[2] = -sg * n[0];
    t2[0] = b, t2[1] = sg + n[1] * n[1] * a, t2[2] = -n[1];
}

/* Sharpness and log-scale of the product of lobes (la, a) and (lb, b): lm = |la a + lb b|,
 * returns lm - la - lb (<= 0), writes the product's unit axis (la a + lb b)/lm (a if lm = 0). */
static double product_lobe(const float a[3], double la, const float b[3], double lb, double *lm, double axis[3]) {
    double x[3], y[3];
    unit_d(a, x), unit_d(b, y);
    double v[3] = { la * x[0] + lb * y[0], la * x[1] + lb * y[1], la * x[2] + lb * y[2] };
    double m = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double d0 = x[0] - y[0], d1 = x[1] - y[1], d2 = x[2] - y[2], omc = 0.5 * (d0 * d0 + d1 * d1 + d2 * d2);
    double den = la + lb + m;
    double expo = den > 0 ? -2 * la * lb * omc / den : 0;
    *lm = m;
    for (int k = 0; k < 3; k++) axis[k] = m > 0 ? v[k] / m : x[k];
    return expo;
}

/* Lobe parameters are clamped to [0, VMF_KAPPA_MAX] (NaN -> 0); normalizations only to >= 0,
 * since a product's sharpness may reach twice the clamp. */
static double clamp_kappa(double k) { return k > 0 ? (k < VMF_KAPPA_MAX ? k : VMF_KAPPA_MAX) : 0; }
static double nonneg(double k) { return k > 0 ? k : 0; }

/* ---------------------------------------------------------------- vMF */

/* C(k) = k / (2 pi (1 - e^{-2k})); series 1/(4 pi) (1 + k + k^2/3) below 1e-4 (error < k^4/45). */
double vmf_norm(double kappa) {
    double k = nonneg(kappa);
    if (k < 1e-4) return (1 + k + k * k / 3) / (4 * PI);
    return k / (2 * PI * -expm1(-2 * k));
}

/* gamma(s) = C(k) e^{-k |mu - s|^2 / 2} (Eq. 1). */
float vmf_eval(const vmf_lobe *v, const float s[3]) {
    double k = clamp_kappa(v->kappa);
    return (float)(vmf_norm(k) * exp(-k * one_minus_cos(v->mu, s)));
}

/* coth k - 1/k, stable at both ends (see the file comment). */
double vmf_mean_length(double kappa) {
    double k = clamp_kappa(kappa);
    if (k < 1e-2) { double k2 = k * k; return k / 3 * (1 - k2 / 15 * (1 - 2 * k2 / 21)); }
    double e = exp(-2 * k);
    return 1 - 1 / k + 2 * e / -expm1(-2 * k);
}

/* Eq. 3 (Banerjee et al. 2005). */
double vmf_kappa_banerjee(double r) {
    if (!(r > 0)) return 0;
    if (r >= 1) return VMF_KAPPA_MAX;
    return clamp_kappa((3 * r - r * r * r) / ((1 - r) * (1 + r)));
}

/* dA3/dk = 1/k^2 - 1/sinh^2 k (series 1/3 - k^2/15 + 2k^4/189 below 1e-2). */
static double mean_length_slope(double k) {
    if (k < 1e-2) { double k2 = k * k; return 1.0 / 3 - k2 / 15 + 2 * k2 * k2 / 189; }
    double s = k < 350 ? sinh(k) : INFINITY;
    return 1 / (k * k) - 1 / (s * s);
}

/* Exact inverse of A3: series 3r + 9r^3/5 for tiny r, 1/(1 - r) for r > 0.95, else Newton. */
double vmf_kappa_from_length(double r) {
    if (!(r > 0)) return 0;
    if (r >= 1 - 1 / VMF_KAPPA_MAX) return VMF_KAPPA_MAX;
    if (r < 1e-5) return 3 * r + 1.8 * r * r * r;
    if (r > 0.95) return clamp_kappa(1 / (1 - r));
    double k = vmf_kappa_banerjee(r);
    for (int it = 0; it < 30; it++) {
        double f = vmf_mean_length(k) - r, step = f / mean_length_slope(k);
        double kn = k - step;
        if (kn <= 0) kn = k / 2;     /* stay in the domain (A3 is concave, so rarely taken) */
        bool done = fabs(kn - k) <= 1e-14 * k;
        k = kn;
        if (done) break;
    }
    return k;
}

/* r = A3(k) mu with mu renormalized in double, so |r| = A3(k) to double precision. */
void vmf_to_mean(const vmf_lobe *v, double r[3]) {
    double mu[3], a = vmf_mean_length(v->kappa);
    unit_d(v->mu, mu);
    for (int k = 0; k < 3; k++) r[k] = a * mu[k];
}

/* mu = r / |r|, kappa = A3^{-1}(|r|) (Eq. 3, exact). */
void vmf_from_mean(const double r[3], vmf_lobe *out) {
    double l = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (!(l > 0) || !isfinite(l)) {
        out->mu[0] = out->mu[1] = 0, out->mu[2] = 1, out->kappa = 0;
        return;
    }
    for (int k = 0; k < 3; k++) out->mu[k] = (float)(r[k] / l);
    out->kappa = (float)vmf_kappa_from_length(l);
}

void vmf_accum_add(vmf_accum *acc, const vmf_lobe *v, double weight) {
    double r[3];
    vmf_to_mean(v, r);
    for (int k = 0; k < 3; k++) acc->r[k] += weight * r[k];
    acc->w += weight;
}

void vmf_accum_add_colour(vmf_accum *acc, const vmf_lobe *v, const float alpha[3]) {
    vmf_accum_add(acc, v, 0.2126 * alpha[0] + 0.7152 * alpha[1] + 0.0722 * alpha[2]);
    for (int k = 0; k < 3; k++) acc->alpha[k] += alpha[k];
    acc->n++;
}

void vmf_accum_colour(const vmf_accum *acc, float out[3]) {
    for (int k = 0; k < 3; k++) out[k] = acc->n > 0 ? (float)(acc->alpha[k] / acc->n) : 0.0f;
}

void vmf_accum_add_dir(vmf_accum *acc, const float s[3], double weight) {
    double d[3];
    if (!(unit_d(s, d) > 0)) return;
    for (int k = 0; k < 3; k++) acc->r[k] += weight * d[k];
    acc->w += weight;
}

bool vmf_accum_result(const vmf_accum *acc, vmf_lobe *out) {
    if (!(acc->w > 0)) {
        out->mu[0] = out->mu[1] = 0, out->mu[2] = 1, out->kappa = 0;
        return false;
    }
    double r[3] = { acc->r[0] / acc->w, acc->r[1] / acc->w, acc->r[2] / acc->w };
    vmf_from_mean(r, out);
    return true;
}

bool vmf_merge(const vmf_lobe *in, const float *w, int n, vmf_lobe *out) {
    PRT_CHECK_GE(n, 0);
    vmf_accum acc = { { 0, 0, 0 }, 0, { 0, 0, 0 }, 0 };
    for (int i = 0; i < n; i++) vmf_accum_add(&acc, &in[i], w ? w[i] : 1.0);
    return vmf_accum_result(&acc, out);
}

/* Eq. 8 inverted exactly: 1 - cos t = -log1p((1 - u1) expm1(-2k)) / k, in [0, 2]. */
void vmf_sample(const vmf_lobe *v, float u1, float u2, float out[3]) {
    double k = clamp_kappa(v->kappa), t;
    double xi = u1 < 0 ? 0 : (u1 > 1 ? 1 : u1);
    if (k < 1e-12) t = 2 * (1 - xi);                 /* uniform: cos t = 2 u1 - 1 */
    else t = -log1p((1 - xi) * expm1(-2 * k)) / k;
    t = t < 0 ? 0 : (t > 2 ? 2 : t);
    double c = 1 - t, s = sqrt(t * (2 - t)), ph = 2 * PI * u2;
    double mu[3], t1[3], t2[3];
    unit_d(v->mu, mu);
    basis(mu, t1, t2);
    double a = s * cos(ph), b = s * sin(ph);
    for (int i = 0; i < 3; i++) out[i] = (float)(a * t1[i] + b * t2[i] + c * mu[i]);
}

/* c(ka) c(kb) 4 pi sinh(km)/km = C(ka) C(kb) / C(km) e^{km - ka - kb}. */
double vmf_product_integral(const vmf_lobe *a, const vmf_lobe *b) {
    double ka = clamp_kappa(a->kappa), kb = clamp_kappa(b->kappa), km, axis[3];
    double expo = product_lobe(a->mu, ka, b->mu, kb, &km, axis);
    return vmf_norm(ka) * vmf_norm(kb) / vmf_norm(km) * exp(expo);
}

void vmf_convolve(const vmf_lobe *a, double kappa_b, vmf_lobe *out) {
    double r = vmf_mean_length(a->kappa) * vmf_mean_length(kappa_b), mu[3];
    unit_d(a->mu, mu);
    for (int k = 0; k < 3; k++) out->mu[k] = (float)mu[k];
    out->kappa = (float)vmf_kappa_from_length(r);
}

void vmf_to_sg(const vmf_lobe *v, float weight, sg_lobe *out) {
    double mu[3];
    unit_d(v->mu, mu);
    for (int k = 0; k < 3; k++) out->axis[k] = (float)mu[k];
    out->sharpness = (float)clamp_kappa(v->kappa);
    out->amplitude = (float)(weight * vmf_norm(v->kappa));
}

/* ---------------------------------------------------------------- SG */

float sg_eval(const sg_lobe *g, const float s[3]) {
    double l = clamp_kappa(g->sharpness);
    return (float)(g->amplitude * exp(-l * one_minus_cos(g->axis, s)));
}

/* A(l) = 2 pi (1 - e^{-2l}) / l; series 4 pi (1 - l + 2 l^2 / 3) below 1e-4. */
double sg_integral(double sharpness) {
    double l = nonneg(sharpness);
    if (l < 1e-4) return 4 * PI * (1 - l + 2 * l * l / 3);
    return 2 * PI * -expm1(-2 * l) / l;
}

void sg_product(const sg_lobe *a, const sg_lobe *b, sg_lobe *out) {
    double la = clamp_kappa(a->sharpness), lb = clamp_kappa(b->sharpness), lm, axis[3];
    double expo = product_lobe(a->axis, la, b->axis, lb, &lm, axis);
    for (int k = 0; k < 3; k++) out->axis[k] = (float)axis[k];
    out->sharpness = (float)lm;
    out->amplitude = (float)((double)a->amplitude * b->amplitude * exp(expo));
}

double sg_product_integral(const sg_lobe *a, const sg_lobe *b) {
    double la = clamp_kappa(a->sharpness), lb = clamp_kappa(b->sharpness), lm, axis[3];
    double expo = product_lobe(a->axis, la, b->axis, lb, &lm, axis);
    return (double)a->amplitude * b->amplitude * exp(expo) * sg_integral(lm);
}

double sg_product_integral_approx(const sg_lobe *a, const sg_lobe *b) {
    double la = clamp_kappa(a->sharpness), lb = clamp_kappa(b->sharpness), sum = la + lb;
    if (!(sum > 0)) return (double)a->amplitude * b->amplitude * 4 * PI;
    double l = la * lb / sum;
    return 2 * PI * (double)a->amplitude * b->amplitude * exp(-l * one_minus_cos(a->axis, b->axis)) / sum;
}

/* ---------------------------------------------------------------- ASG */

/* The ASG's shape at s given bandwidths (amplitude 1). */
static double asg_shape(const asg_lobe *g, double ex, double ey, const double s[3]) {
    double z = g->z[0] * s[0] + g->z[1] * s[1] + g->z[2] * s[2];
    if (!(z > 0)) return 0;
    double x = g->x[0] * s[0] + g->x[1] * s[1] + g->x[2] * s[2];
    double y = g->y[0] * s[0] + g->y[1] * s[1] + g->y[2] * s[2];
    return z * exp(-ex * x * x - ey * y * y);
}

float asg_eval(const asg_lobe *g, const float s[3]) {
    double d[3] = { s[0], s[1], s[2] };
    return (float)(g->amplitude * asg_shape(g, fmax(g->eta_x, 0), fmax(g->eta_y, 0), d));
}

/* Xu et al. 2013's ASG-SG product integral as written in tokuyoshi 3.2 (with the SG e^{2v (s.xi - 1)}, v = l/2). */
double asg_sg_product_integral(const asg_lobe *a, const sg_lobe *g) {
    double ex = fmax(a->eta_x, 0), ey = fmax(a->eta_y, 0), v = clamp_kappa(g->sharpness) / 2, xi[3];
    unit_d(g->axis, xi);
    double den = (ex + v) * (ey + v);
    if (!(den > 0)) return PI * (double)a->amplitude * g->amplitude;   /* degenerate bandwidths: int max(s.z, 0) ds = pi */
    double bx = ex * v / (ex + v), by = ey * v / (ey + v);
    return PI * (double)a->amplitude * g->amplitude * asg_shape(a, bx, by, xi) / sqrt(den);
}
