/* lobefit.c - vMF lobe fit of isotropic BRDF slices (laurijssen-2011 sections 3, 5.1).
 *
 * Per view elevation the slice h(wi) = f_s(wi, wo) cos(theta_i) is integrated on a
 * quadrature centred on the mirror direction R of wo, where every model's lobe peaks
 * (off-specular microfacet peaks stay within the graded rings): rings at angles
 * t(u) = pi (e^{b u} - 1) / (e^b - 1), b = log(1 + pi / 2e-4), midpoint in u, so the
 * spacing is 2e-4 rad near R and grows by ~4% per ring (res 256): a kappa-1e6 lobe
 * (width 1e-3) gets tens of rings and a broad GGX lobe still covers the sphere.
 * Per view: the moments (alpha = int h, r = int s h_lum / int h_lum, Eq. 2) while the
 * points carrying energy are cached; a least-squares refinement of kappa and the axis
 * elevation on that cache, using |h - a g|^2 = |h|^2 - 2 a <h, g> + a^2 |g|^2 with |g|^2
 * analytic (so each trial costs one exp per cached point); then the reported error by a
 * full, independent pass over the grid. */
#include "lobefit.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
#define LF_THETA_MIN 2e-4

static const double k_lum[3] = { 0.2126, 0.7152, 0.0722 };

/* Quadrature around unit centre c: nt rings, np azimuths. */
typedef struct lf_grid {
    int nt, np;
    double beta;
    double c[3], t1[3], t2[3];
} lf_grid;

static void lf_grid_init(lf_grid *g, int res, const double c[3]) {
    g->nt = res, g->np = res / 2;
    g->beta = log(1 + PI / LF_THETA_MIN);
    memcpy(g->c, c, sizeof g->c);
    /* any orthonormal completion (Duff et al. 2017) */
    double sg = copysign(1.0, c[2]), a = -1.0 / (sg + c[2]), b = c[0] * c[1] * a;
    g->t1[0] = 1 + sg * c[0] * c[0] * a, g->t1[1] = sg * b, g->t1[2] = -sg * c[0];
    g->t2[0] = b, g->t2[1] = sg + c[1] * c[1] * a, g->t2[2] = -c[1];
}

/* Ring i's angle t and weight sin(t) dt dphi. */
static double lf_ring(const lf_grid *g, int i, double *t) {
    double u = (i + 0.5) / g->nt, eb = exp(g->beta * u), den = exp(g->beta) - 1;
    *t = PI * (eb - 1) / den;
    return sin(*t) * PI * g->beta * eb / den / g->nt * (2 * PI / g->np);
}

/* Direction of ring angle t (sin st, cos ct) at azimuth j, in double (d, for the moments:
 * a float direction's rounding would swamp 1 - |r| of a sharp lobe) and float (s). */
static void lf_dir(const lf_grid *g, double st, double ct, int j, double d[3], float s[3]) {
    double ph = 2 * PI * (j + 0.5) / g->np, a = st * cos(ph), b = st * sin(ph);
    for (int k = 0; k < 3; k++) d[k] = a * g->t1[k] + b * g->t2[k] + ct * g->c[k], s[k] = (float)d[k];
}

bool lobefit_supported(brdf_type t) {
    return t == BRDF_PHONG || t == BRDF_BLINN || t == BRDF_GGX || t == BRDF_BECKMANN;
}

/* The view direction of elevation th and its grid around the mirror direction. */
static void lf_view(double th, int res, float wo[3], lf_grid *g) {
    wo[0] = (float)sin(th), wo[1] = 0, wo[2] = (float)cos(th);
    double c[3] = { -sin(th), 0, cos(th) };
    lf_grid_init(g, res, c);
}

/* The slice's quadrature points that carry energy: direction and w h_c (h = f_s cos). */
typedef struct lf_cache { int n; double (*d)[3]; double (*wh)[3]; } lf_cache;

/* Pass 1: collects the slice into c (points below 1e-9 of the energy dropped), alpha = int h
 * per channel, and the moment lobe: Eq. 2 on the luminance of h, then Eq. 3. */
static void lf_moments(const brdf_params *ps, const lf_grid *g, const float wo[3], lf_cache *c, vmf_lobe *lobe, float alpha[3]) {
    double a[3] = { 0, 0, 0 }, r[3] = { 0, 0, 0 }, wl = 0;
    c->n = 0;
    for (int i = 0; i < g->nt; i++) {
        double t, w = lf_ring(g, i, &t), st = sin(t), ct = cos(t);
        for (int j = 0; j < g->np; j++) {
            float s[3], f[3];
            double d[3], hl = 0;
            lf_dir(g, st, ct, j, d, s);
            if (!(s[2] > 0)) continue;
            brdf_eval(ps, s, wo, f);
            for (int k = 0; k < 3; k++) c->wh[c->n][k] = w * f[k] * d[2], hl += k_lum[k] * c->wh[c->n][k];
            if (!(hl > 0)) continue;
            for (int k = 0; k < 3; k++) a[k] += c->wh[c->n][k], r[k] += hl * d[k], c->d[c->n][k] = d[k];
            wl += hl, c->n++;
        }
    }
    int m = 0;
    for (int i = 0; i < c->n; i++)
        if (k_lum[0] * c->wh[i][0] + k_lum[1] * c->wh[i][1] + k_lum[2] * c->wh[i][2] >= 1e-9 * wl) {
            memcpy(c->d[m], c->d[i], sizeof c->d[i]), memcpy(c->wh[m], c->wh[i], sizeof c->wh[i]);
            m++;
        }
    c->n = m;
    for (int k = 0; k < 3; k++) alpha[k] = (float)a[k];
    if (!(wl > 0)) { lobe->mu[0] = lobe->mu[1] = 0, lobe->mu[2] = 1, lobe->kappa = 0; return; }
    for (int k = 0; k < 3; k++) r[k] /= wl;
    vmf_from_mean(r, lobe);
}

/* |h - alpha gamma|^2 - |h|^2 = sum_c alpha_c^2 |gamma|^2 - 2 alpha_c <h_c, gamma>, for the lobe of
 * axis (-sin psi, 0, cos psi) and concentration e^lk; |gamma|^2 = C(k)^2 A(2k) analytically. */
static double lf_cost(const lf_cache *c, const float alpha[3], const double x[2]) {
    double mu[3] = { -sin(x[0]), 0, cos(x[0]) }, k = exp(x[1]), C = vmf_norm(k), ip = 0;
    for (int i = 0; i < c->n; i++) {
        const double *d = c->d[i];
        double e = 0.5 * ((mu[0] - d[0]) * (mu[0] - d[0]) + d[1] * d[1] + (mu[2] - d[2]) * (mu[2] - d[2]));
        ip += exp(-k * e) * (alpha[0] * c->wh[i][0] + alpha[1] * c->wh[i][1] + alpha[2] * c->wh[i][2]);
    }
    double aa = (double)alpha[0] * alpha[0] + (double)alpha[1] * alpha[1] + (double)alpha[2] * alpha[2];
    return aa * C * C * sg_integral(2 * k) - 2 * C * ip;
}

/* Golden-section search of x[which] over [lo, hi] (20 steps: 1e-4 of the interval). */
static void lf_golden(const lf_cache *c, const float alpha[3], double x[2], int which, double lo, double hi) {
    const double gr = 0.6180339887498949;
    double y[2] = { x[0], x[1] }, a = lo, b = hi, p = b - gr * (b - a), q = a + gr * (b - a), fp, fq;
    y[which] = p, fp = lf_cost(c, alpha, y);
    y[which] = q, fq = lf_cost(c, alpha, y);
    for (int it = 0; it < 20; it++) {
        if (fp < fq) b = q, q = p, fq = fp, p = b - gr * (b - a), y[which] = p, fp = lf_cost(c, alpha, y);
        else a = p, p = q, fp = fq, q = a + gr * (b - a), y[which] = q, fq = lf_cost(c, alpha, y);
    }
    double best = fp < fq ? p : q, cur = lf_cost(c, alpha, x);
    y[which] = best;
    if (lf_cost(c, alpha, y) < cur) x[which] = best;
}

/* Least-squares refinement of the moment lobe at fixed alpha: kappa and the axis elevation in
 * the plane of incidence (where symmetry puts it), by alternating golden sections. */
static void lf_refine(const lf_cache *c, const float alpha[3], vmf_lobe *lobe) {
    if (!(lobe->kappa > 0) || c->n == 0) return;
    double x[2] = { atan2(-lobe->mu[0], lobe->mu[2]), log(lobe->kappa) };
    for (int round = 0; round < 2; round++) {
        double span = round ? 0.25 : 1.0;
        lf_golden(c, alpha, x, 1, x[1] - 2 * span, x[1] + 2 * span);
        lf_golden(c, alpha, x, 0, x[0] - 0.3 * span, x[0] + 0.3 * span);
    }
    lobe->mu[0] = (float)-sin(x[0]), lobe->mu[1] = 0, lobe->mu[2] = (float)cos(x[0]);
    lobe->kappa = (float)fmin(exp(x[1]), VMF_KAPPA_MAX);
}

/* Pass 2: squared error of alpha gamma against h, |h|^2 and |h + kd/pi cos|^2, over the sphere. */
static void lf_error(const brdf_params *ps, const float kd[3], const lf_grid *g, const float wo[3],
                     const vmf_lobe *lobe, const float alpha[3], double sums[3]) {
    sums[0] = sums[1] = sums[2] = 0;
    for (int i = 0; i < g->nt; i++) {
        double t, w = lf_ring(g, i, &t), st = sin(t), ct = cos(t);
        for (int j = 0; j < g->np; j++) {
            float s[3], f[3] = { 0, 0, 0 };
            double d[3];
            lf_dir(g, st, ct, j, d, s);
            double gam = vmf_eval(lobe, s), cz = s[2] > 0 ? s[2] : 0;
            if (cz > 0) brdf_eval(ps, s, wo, f);
            for (int c = 0; c < 3; c++) {
                double h = f[c] * cz, e = h - alpha[c] * gam, hw = h + kd[c] / PI * cz;
                sums[0] += w * e * e, sums[1] += w * h * h, sums[2] += w * hw * hw;
            }
        }
    }
}

int lobefit_fit(const brdf_params *p, const lobefit_desc *desc, lobefit_table *out, prt_error *err) {
    if (!lobefit_supported(p->type))
        return prt_fail(err, "brdf %s: no vMF lobe fit for this model (phong, blinn, ggx and beckmann have one)",
                        brdf_type_name(p->type));
    int views = desc && desc->views ? desc->views : LOBEFIT_DEFAULT_VIEWS;
    int res = desc && desc->res ? desc->res : 256;
    PRT_CHECK(views >= 1 && views <= LOBEFIT_MAX_VIEWS);
    PRT_CHECK(res >= 16 && res <= 1024);
    double t0 = prt_now();
    memset(out, 0, sizeof *out);
    out->type = p->type, out->views = views, out->res = res;
    brdf_params ps = *p;                   /* the specular part: f - kd/pi for these four models */
    ps.kd[0] = ps.kd[1] = ps.kd[2] = 0;
    size_t npts = (size_t)res * (res / 2);
    lf_cache c = { 0, prt_calloc(npts, sizeof *c.d, err), prt_calloc(npts, sizeof *c.wh, err) };
    if (!c.d || !c.wh) { free(c.d), free(c.wh); return -1; }
    double sum = 0, sumw = 0;
    for (int v = 0; v < views; v++) {
        double th = 0.5 * PI * v / views, sums[3];
        float wo[3];
        lf_grid g;
        lf_view(th, res, wo, &g);
        out->theta[v] = (float)th;
        lf_moments(&ps, &g, wo, &c, &out->lobe[v], out->alpha[v]);
        if (!(desc && desc->moments_only)) lf_refine(&c, out->alpha[v], &out->lobe[v]);
        lf_error(&ps, p->kd, &g, wo, &out->lobe[v], out->alpha[v], sums);
        out->err[v] = sums[1] > 0 ? (float)sqrt(sums[0] / sums[1]) : 0.0f;
        out->err_whole[v] = sums[2] > 0 ? (float)sqrt(sums[0] / sums[2]) : 0.0f;
        sum += out->err[v], sumw += out->err_whole[v];
        out->err_max = fmaxf(out->err_max, out->err[v]);
        out->err_whole_max = fmaxf(out->err_whole_max, out->err_whole[v]);
    }
    free(c.d), free(c.wh);
    out->err_mean = (float)(sum / views), out->err_whole_mean = (float)(sumw / views);
    out->seconds = prt_now() - t0;
    return 0;
}

void lobefit_lookup(const lobefit_table *t, const float wo[3], vmf_lobe *lobe, float alpha[3]) {
    PRT_CHECK(t->views >= 1);
    double rxy = hypot(wo[0], wo[1]), th = atan2(rxy, wo[2]);
    double x = th / (0.5 * PI) * t->views;          /* theta_k = k (pi/2) / views */
    int i = (int)floor(x);
    double f = x - i;
    if (i < 0) i = 0, f = 0;
    if (i >= t->views - 1) i = t->views - 1, f = 0;
    int j = i + 1 < t->views ? i + 1 : i;
    const vmf_lobe *a = &t->lobe[i], *b = &t->lobe[j];
    double mu[3], l = 0;
    for (int k = 0; k < 3; k++) mu[k] = (1 - f) * a->mu[k] + f * b->mu[k], l += mu[k] * mu[k];
    l = sqrt(l);
    if (!(l > 0)) mu[0] = mu[1] = 0, mu[2] = 1, l = 1;
    /* rotate from the x-z plane to wo's azimuth (any azimuth at the pole) */
    double cp = rxy > 0 ? wo[0] / rxy : 1, sp = rxy > 0 ? wo[1] / rxy : 0;
    lobe->mu[0] = (float)((cp * mu[0] - sp * mu[1]) / l);
    lobe->mu[1] = (float)((sp * mu[0] + cp * mu[1]) / l);
    lobe->mu[2] = (float)(mu[2] / l);
    lobe->kappa = (float)((1 - f) * a->kappa + f * b->kappa);
    for (int c = 0; c < 3; c++) alpha[c] = (float)((1 - f) * t->alpha[i][c] + f * t->alpha[j][c]);
}

void lobefit_factor_error(const lobefit_table *t, const brdf_params *p, const brdf_factor *f, int K, float *out) {
    PRT_CHECK(K >= 1 && K <= f->K);
    int res = t->res;
    for (int v = 0; v < t->views; v++) {
        float wo[3];
        lf_grid g;
        lf_view(t->theta[v], res, wo, &g);
        double num = 0, den = 0;
        for (int i = 0; i < g.nt; i++) {
            double th, w = lf_ring(&g, i, &th), st = sin(th), ct = cos(th);
            for (int j = 0; j < g.np; j++) {
                float s[3], fr[3], fa[3];
                double d[3];
                lf_dir(&g, st, ct, j, d, s);
                if (!(s[2] > 0)) continue;
                brdf_eval(p, s, wo, fr);
                brdf_factor_eval(f, s, wo, K, fa);
                for (int c = 0; c < 3; c++) {
                    double e = (fr[c] - fa[c]) * s[2], h = fr[c] * s[2];
                    num += w * e * e, den += w * h * h;
                }
            }
        }
        out[v] = den > 0 ? (float)sqrt(num / den) : 0.0f;
    }
}
