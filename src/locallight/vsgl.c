/* vsgl.c - virtual spherical-Gaussian lights (vsgl.h; tokuyoshi supplement sections 1-3).
 *
 * The sums are kept in double: an RSM of 6 x 64^2 texels adds 24,576 positions whose
 * second moment minus the squared mean (the variance, section 2.2) cancels badly in float. */
#include "vsgl.h"
#include "vec3.h"
#include <float.h>
#include <math.h>
#include <string.h>

/* Section 2.1-2.2's sums, each VPL weighted by the luminance of Phi_i R_i. */
void vsgl_accum_add(vsgl_accum *a, const float x[3], const float axis[3], float sharpness, const float phi_r[3],
                    float area)
{
    double w = prt_luminance(phi_r);
    if (!(w > 0)) return;
    double t = sharpness / (sharpness + 1.0);     /* Toksvig: the mean length of the normalized SG */
    for (int k = 0; k < 3; k++) {
        a->power[k] += phi_r[k];
        a->dir[k] += w * t * axis[k];
        a->pos[k] += w * x[k];
    }
    a->pos2 += w * ((double)x[0] * x[0] + (double)x[1] * x[1] + (double)x[2] * x[2]);
    a->spread += w * area / (2 * M_PI);            /* the footprint as a Gaussian of equal area */
    a->w += w;
}

/* xi_v, lambda_v from the filtered mean direction; c_v = P / A(lambda_v); mu_v, sigma_v^2 (header). */
bool vsgl_accum_result(const vsgl_accum *a, vsgl_light *out)
{
    memset(out, 0, sizeof *out);
    out->axis[2] = 1;
    if (!(a->w > 0)) return false;
    double d[3], mu[3], len2 = 0, mu2 = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = a->dir[k] / a->w;
        mu[k] = a->pos[k] / a->w;
        len2 += d[k] * d[k];
        mu2 += mu[k] * mu[k];
    }
    double len = fmin(sqrt(len2), 1.0 - 1.0 / VMF_KAPPA_MAX);
    double lambda = len / (1.0 - len);
    for (int k = 0; k < 3; k++) out->axis[k] = len > 0 ? (float)(d[k] / sqrt(len2)) : (k == 2);
    out->sharpness = (float)lambda;
    double A = sg_integral(lambda);
    for (int k = 0; k < 3; k++) {
        out->power[k] = (float)a->power[k];
        out->c[k] = (float)(a->power[k] / A);
        out->mean[k] = (float)mu[k];
    }
    double var = fmax(a->pos2 / a->w - mu2, 0.0) / 2 + a->spread / a->w;
    out->var = (float)fmax(var, FLT_MIN);   /* only not 0: every use floors it relative to the distance */
    return true;
}

/* Diffuse VSGL from R_d about n_i (Eq. 1), glossy one from R_s about the fitted lobe (Eq. 2). */
void vsgl_build(const rsm *r, vsgl_pair *out)
{
    vsgl_accum d = { 0 }, s = { 0 };
    const rsm_texel *t = rsm_texels(r);
    for (int i = 0; i < rsm_count(r); i++) {
        if (t[i].mat < 0) continue;
        float pd[3], ps[3];
        for (int k = 0; k < 3; k++) {
            pd[k] = t[i].flux[k] * t[i].kd[k];
            ps[k] = t[i].flux[k] * t[i].ks[k];
        }
        vsgl_accum_add(&d, t[i].pos, t[i].nrm, VSGL_LAMBDA_D, pd, t[i].area);
        vsgl_accum_add(&s, t[i].pos, t[i].spec.mu, t[i].spec.kappa, ps, t[i].area);
    }
    vsgl_accum_result(&d, &out->diffuse);
    vsgl_accum_result(&s, &out->specular);
}

/* Eq. 6-7: I_v(-w) / (2 pi sigma^2) times G(w, xi_mu, lambda_sigma), one SG by sg_product. */
bool vsgl_incoming(const vsgl_light *v, const float x[3], sg_lobe *g, float rgb[3])
{
    rgb[0] = rgb[1] = rgb[2] = 0;
    if (!(v->c[0] > 0 || v->c[1] > 0 || v->c[2] > 0)) return false;
    float dm[3];
    v3_sub(dm, v->mean, x);
    float d2 = v3_dot(dm, dm);
    if (!(d2 > 0)) return false;
    v3_normalize(dm);
    /* lambda_sigma is clamped to the lobes' VMF_KAPPA_MAX: the normalization must use the same variance. */
    double var = fmax(v->var, d2 / VMF_KAPPA_MAX);
    sg_lobe in = { { -v->axis[0], -v->axis[1], -v->axis[2] }, v->sharpness, 1.f };
    sg_lobe sp = { { dm[0], dm[1], dm[2] }, (float)(d2 / var), 1.f };
    sg_product(&in, &sp, g);
    float s = g->amplitude / (float)(2 * M_PI * var);
    g->amplitude = 1.f;
    for (int k = 0; k < 3; k++) rgb[k] = v->c[k] * s;
    return true;
}

/* Phong: isotropic about the lobe; half-vector models: the warp's aspect cos(theta_o) (header). */
bool vsgl_spec_asg(const lightmat *lm, int m, const float n[3], const float wo[3], asg_lobe *a, float *kappa)
{
    vmf_lobe g;
    float alpha[3];
    if (!lightmat_lobe(lm, m, n, wo, &g, alpha)) return false;
    *kappa = g.kappa;
    v3_copy(a->z, g.mu);
    /* x: in the plane of incidence (z, n), across z; y = z x x. At normal incidence any pair. */
    float nz = v3_dot(n, a->z);
    v3_madd(a->x, n, a->z, -nz);
    if (v3_normalize(a->x) < 1e-5f) {
        float t[3];
        brdf_frame(a->z, a->x, t);
    }
    v3_cross(a->y, a->z, a->x);
    float c = fmaxf(v3_dot(n, wo), 0.05f), ex = g.kappa / 2, ey = g.kappa / 2;
    if (lightmat_brdf(lm, m)->type != BRDF_PHONG) {
        ex = g.kappa * c / 2;
        ey = g.kappa / (2 * c);
    }
    a->eta_x = fmaxf(ex - 0.5f, 0.f);
    a->eta_y = fmaxf(ey - 0.5f, 0.f);
    a->amplitude = 1.f;
    return true;
}

/* The receiver's glossy lobe as vsgl_glossy needs it, the same for both VSGLs: the ASG, its
 * kappa, and f_s cos / ASG at its axis z (M's clamp). */
typedef struct vsgl_recv {
    asg_lobe a;
    float kappa, az, fz[3];
} vsgl_recv;

/* false when m has no glossy lobe or wo is below the horizon. */
static bool vsgl_recv_init(const lightmat *lm, int m, const float n[3], const float wo[3], vsgl_recv *r)
{
    if (!vsgl_spec_asg(lm, m, n, wo, &r->a, &r->kappa)) return false;
    lightmat_spec_eval(lm, m, n, r->a.z, wo, r->fz);
    r->az = fmaxf(v3_dot(n, r->a.z), 0.f) / asg_eval(&r->a, r->a.z);
    return true;
}

/* L_s of section 3.2: c_in M(xi_m) int G_in ASG, M from the exact BRDF at xi_m. */
static void vsgl_glossy(const lightmat *lm, int m, const float n[3], const float wo[3], const vsgl_recv *r,
                        const sg_lobe *g, const float rgb[3], float out[3])
{
    float xm[3], fm[3];
    for (int k = 0; k < 3; k++) xm[k] = g->sharpness * g->axis[k] + r->kappa * r->a.z[k];
    if (v3_normalize(xm) == 0.f) return;
    lightmat_spec_eval(lm, m, n, xm, wo, fm);
    float am = asg_eval(&r->a, xm);
    am = am > 1e-6f ? fmaxf(v3_dot(n, xm), 0.f) / am : 0.f;
    double I = asg_sg_product_integral(&r->a, g);
    for (int k = 0; k < 3; k++) {
        float M = fminf(fm[k] * am, 4.f * r->fz[k] * r->az);
        out[k] += (float)(rgb[k] * M * I);
    }
}

/* Both VSGLs, each meeting the receiver's diffuse SG (Eq. 1) and glossy ASG (3.2); wo NULL: no glossy part. */
static void vsgl_shade_lobes(const vsgl_pair *v, const lightmat *lm, int m, const float x[3], const float n[3],
                             const float *wo, float out[3])
{
    out[0] = out[1] = out[2] = 0;
    const brdf_params *p = lightmat_brdf(lm, m);
    sg_lobe dl = { { n[0], n[1], n[2] }, VSGL_LAMBDA_D, (float)(1.0 / sg_integral(VSGL_LAMBDA_D)) };
    const vsgl_light *pair[2] = { &v->diffuse, &v->specular };
    vsgl_recv r;
    bool glossy = wo && vsgl_recv_init(lm, m, n, wo, &r);
    for (int j = 0; j < 2; j++) {
        sg_lobe g;
        float rgb[3];
        if (!vsgl_incoming(pair[j], x, &g, rgb)) continue;
        double Id = sg_product_integral(&g, &dl);
        for (int k = 0; k < 3; k++) out[k] += (float)(rgb[k] * p->kd[k] * Id);
        if (glossy) vsgl_glossy(lm, m, n, wo, &r, &g, rgb, out);
    }
    for (int k = 0; k < 3; k++)
        if (!isfinite(out[k]) || out[k] < 0) out[k] = 0;
}

/* Section 3.2: both lobes of the receiver. */
void vsgl_shade(const vsgl_pair *v, const lightmat *lm, int m, const float x[3], const float n[3], const float wo[3],
                float out[3])
{
    vsgl_shade_lobes(v, lm, m, x, n, wo, out);
}

/* The receiver's diffuse lobe alone. */
void vsgl_shade_diffuse(const vsgl_pair *v, const lightmat *lm, int m, const float x[3], const float n[3], float out[3])
{
    vsgl_shade_lobes(v, lm, m, x, n, NULL, out);
}

/* Normalizes a float vector into double; its length (0 leaves o untouched). */
static double vl_unit(const float a[3], double o[3])
{
    double l = sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]);
    if (l > 0)
        for (int k = 0; k < 3; k++) o[k] = a[k] / l;
    return l;
}

/* |a - b|^2 for unit a, b: 2 (1 - a.b) without cancellation near a = b (lobe.c's rule). */
static double vl_dist2(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
}

/* One VSGL's term: c / (2 pi var) kd / A(2) int G_1 G_2 G_3, the triple product by its closed
 * form; sum l - r = sum_{i<j} l_i l_j |a_i - a_j|^2 / (sum l + r) (never cancels). false: the
 * two-step path must do it (a product sharper than lobe.c's clamp). */
static bool vl_term(const vsgl_light *v, const float kd[3], const float x[3], const double nn[3], float out[3])
{
    if (!(v->c[0] > 0 || v->c[1] > 0 || v->c[2] > 0)) return true;
    float dm[3];
    v3_sub(dm, v->mean, x);
    float d2 = v3_dot(dm, dm);
    if (!(d2 > 0)) return true;
    double var = fmax(v->var, d2 / VMF_KAPPA_MAX), a1[3] = { 0, 0, 1 }, a2[3] = { 0, 0, 1 };
    double l1 = v->sharpness > 0 ? v->sharpness : 0, l2 = (float)(d2 / var), l3 = VSGL_LAMBDA_D;
    float na[3] = { -v->axis[0], -v->axis[1], -v->axis[2] };
    vl_unit(na, a1);
    vl_unit(dm, a2);
    if (l1 + l2 > VMF_KAPPA_MAX) return false;
    double s[3], sum = l1 + l2 + l3;
    for (int k = 0; k < 3; k++) s[k] = l1 * a1[k] + l2 * a2[k] + l3 * nn[k];
    double r = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    double gap = (l1 * l2 * vl_dist2(a1, a2) + l1 * l3 * vl_dist2(a1, nn) + l2 * l3 * vl_dist2(a2, nn)) / (sum + r);
    double I = exp(-gap) * sg_integral(r) / (2 * M_PI * var * sg_integral(l3));
    for (int k = 0; k < 3; k++) out[k] += (float)(v->c[k] * I * kd[k]);
    return true;
}

/* Both VSGLs on a Lambert receiver (vsgl.h); a term the closed form declines goes the two-step way. */
void vsgl_shade_lambert(const vsgl_pair *v, const float kd[3], const float x[3], const float n[3], float out[3])
{
    out[0] = out[1] = out[2] = 0;
    double nn[3] = { 0, 0, 1 };     /* a zero normal: +z, as lobe.c's unit_d */
    vl_unit(n, nn);
    const vsgl_light *pair[2] = { &v->diffuse, &v->specular };
    for (int j = 0; j < 2; j++) {
        if (vl_term(pair[j], kd, x, nn, out)) continue;
        sg_lobe g, dl = { { n[0], n[1], n[2] }, VSGL_LAMBDA_D, (float)(1.0 / sg_integral(VSGL_LAMBDA_D)) };
        float rgb[3];
        if (!vsgl_incoming(pair[j], x, &g, rgb)) continue;
        double Id = sg_product_integral(&g, &dl);
        for (int k = 0; k < 3; k++) out[k] += (float)(rgb[k] * kd[k] * Id);
    }
    for (int k = 0; k < 3; k++)
        if (!isfinite(out[k]) || out[k] < 0) out[k] = 0;
}
