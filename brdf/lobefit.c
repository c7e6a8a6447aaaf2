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

/* sum_c alpha_c <h_c, gamma> over the cache for the vMF of axis (-sin psi, 0, cos psi) and concentration k:
 * one exp per cached point. */
static double lf_inner(const lf_cache *c, const float alpha[3], double psi, double k) {
    double mu[3] = { -sin(psi), 0, cos(psi) }, ip = 0;
    for (int i = 0; i < c->n; i++) {
        const double *d = c->d[i];
        double e = 0.5 * ((mu[0] - d[0]) * (mu[0] - d[0]) + d[1] * d[1] + (mu[2] - d[2]) * (mu[2] - d[2]));
        ip += exp(-k * e) * (alpha[0] * c->wh[i][0] + alpha[1] * c->wh[i][1] + alpha[2] * c->wh[i][2]);
    }
    return vmf_norm(k) * ip;
}

static double lf_alpha2(const float alpha[3]) {
    return (double)alpha[0] * alpha[0] + (double)alpha[1] * alpha[1] + (double)alpha[2] * alpha[2];
}

/* What the costs read: the cache and the colour, and per lobe slot the last inner product (lf_inner)
 * with its (psi, k): a golden section moves one lobe of two, so the other's is reused. */
typedef struct lf_obj {
    const lf_cache *c;
    const float *alpha;
    double memo[2][3];
    bool valid[2];
} lf_obj;

static double lf_inner_memo(lf_obj *o, int slot, double psi, double k) {
    double *m = o->memo[slot];
    if (o->valid[slot] && m[0] == psi && m[1] == k) return m[2];
    m[0] = psi, m[1] = k, m[2] = lf_inner(o->c, o->alpha, psi, k), o->valid[slot] = true;
    return m[2];
}

/* |h - alpha gamma|^2 - |h|^2 = sum_c alpha_c^2 |gamma|^2 - 2 alpha_c <h_c, gamma>, for the lobe of
 * axis (-sin psi, 0, cos psi) and concentration e^lk (x = psi, lk); |gamma|^2 = C(k)^2 A(2k) analytically. */
static double lf_cost(lf_obj *o, const double *x) {
    double k = exp(x[1]), C = vmf_norm(k);
    return lf_alpha2(o->alpha) * C * C * sg_integral(2 * k) - 2 * lf_inner(o->c, o->alpha, x[0], k);
}

typedef double (*lf_cost_fn)(lf_obj *o, const double *x);

/* Golden-section search of x[which] (of n parameters) over [lo, hi] for cost f (20 steps: 1e-4 of the
 * interval); x[which] moves only when that lowers the cost. */
static void lf_golden(lf_obj *o, lf_cost_fn f, double *x, int n, int which, double lo, double hi) {
    const double gr = 0.6180339887498949;
    double y[4], a = lo, b = hi, p = b - gr * (b - a), q = a + gr * (b - a), fp, fq;
    memcpy(y, x, (size_t)n * sizeof *x);
    y[which] = p, fp = f(o, y);
    y[which] = q, fq = f(o, y);
    for (int it = 0; it < 20; it++) {
        if (fp < fq) b = q, q = p, fq = fp, p = b - gr * (b - a), y[which] = p, fp = f(o, y);
        else a = p, p = q, fp = fq, q = a + gr * (b - a), y[which] = q, fq = f(o, y);
    }
    double best = fp < fq ? p : q, cur = f(o, x);
    y[which] = best;
    if (f(o, y) < cur) x[which] = best;
}

/* Least-squares refinement of the moment lobe at fixed alpha: kappa and the axis elevation in
 * the plane of incidence (where symmetry puts it), by alternating golden sections. */
static void lf_refine(const lf_cache *c, const float alpha[3], vmf_lobe *lobe) {
    if (!(lobe->kappa > 0) || c->n == 0) return;
    double x[2] = { atan2(-lobe->mu[0], lobe->mu[2]), log(lobe->kappa) };
    lf_obj o = { .c = c, .alpha = alpha };
    for (int round = 0; round < 2; round++) {
        double span = round ? 0.25 : 1.0;
        lf_golden(&o, lf_cost, x, 2, 1, x[1] - 2 * span, x[1] + 2 * span);
        lf_golden(&o, lf_cost, x, 2, 0, x[0] - 0.3 * span, x[0] + 0.3 * span);
    }
    lobe->mu[0] = (float)-sin(x[0]), lobe->mu[1] = 0, lobe->mu[2] = (float)cos(x[0]);
    lobe->kappa = (float)fmin(exp(x[1]), VMF_KAPPA_MAX);
}

/* Pass 2: squared error of sum_l alpha_l gamma_l (n lobes) against h, |h|^2 and |h + kd/pi cos|^2, over
 * the sphere. */
static void lf_error(const brdf_params *ps, const float kd[3], const lf_grid *g, const float wo[3],
                     const vmf_lobe *lobe, const float (*alpha)[3], int n, double sums[3]) {
    sums[0] = sums[1] = sums[2] = 0;
    for (int i = 0; i < g->nt; i++) {
        double t, w = lf_ring(g, i, &t), st = sin(t), ct = cos(t);
        for (int j = 0; j < g->np; j++) {
            float s[3], f[3] = { 0, 0, 0 };
            double d[3];
            lf_dir(g, st, ct, j, d, s);
            double gam[2], cz = s[2] > 0 ? s[2] : 0;
            for (int l = 0; l < n; l++) gam[l] = vmf_eval(&lobe[l], s);
            if (cz > 0) brdf_eval(ps, s, wo, f);
            for (int c = 0; c < 3; c++) {
                double h = f[c] * cz, e = h - alpha[0][c] * gam[0], hw = h + kd[c] / PI * cz;
                for (int l = 1; l < n; l++) e -= alpha[l][c] * gam[l];
                sums[0] += w * e * e, sums[1] += w * h * h, sums[2] += w * hw * hw;
            }
        }
    }
}

/* ---- two lobes (lobefit.h "Two lobes") ------------------------------------------------------ */

/* The vMF of axis (-sin psi, 0, cos psi) and concentration e^lk (clamped as a stored lobe). */
static void lf_plane_lobe(double psi, double lk, vmf_lobe *v) {
    v->mu[0] = (float)-sin(psi), v->mu[1] = 0, v->mu[2] = (float)cos(psi);
    v->kappa = (float)fmin(exp(lk), VMF_KAPPA_MAX);
}

/* The L2 cost of lf_cost for share s of alpha on lobe a = (x[0], x[1]) and 1 - s on b = (x[2], x[3]):
 * |h - alpha (s g_a + (1 - s) g_b)|^2 - |h|^2, with the lobes' products analytic (vmf_product_integral);
 * quadratic in s, so s is its minimum, clamped to [0, 1] (*share). */
static double lf_mix_eval(lf_obj *o, const double *x, double *share) {
    vmf_lobe a, b;
    lf_plane_lobe(x[0], x[1], &a), lf_plane_lobe(x[2], x[3], &b);
    double ha = lf_inner_memo(o, 0, x[0], a.kappa), hb = lf_inner_memo(o, 1, x[2], b.kappa), A2 = lf_alpha2(o->alpha);
    double gaa = vmf_product_integral(&a, &a), gbb = vmf_product_integral(&b, &b), gab = vmf_product_integral(&a, &b);
    double den = gaa + gbb - 2 * gab, s = den > 0 && A2 > 0 ? ((ha - hb) / A2 + gbb - gab) / den : 1;
    s = s < 0 ? 0 : (s > 1 ? 1 : s);
    *share = s;
    return A2 * (s * s * gaa + (1 - s) * (1 - s) * gbb + 2 * s * (1 - s) * gab) - 2 * (s * ha + (1 - s) * hb);
}

static double lf_mix_cost(lf_obj *o, const double *x) {
    double s;
    return lf_mix_eval(o, x, &s);
}

/* Two lobes from the one-lobe fit: the better (in L2) of a core-and-tail start (its axis, kappa x2 and
 * /4: a heavy-tailed microfacet slice) and a split start (axes 0.7 / sqrt(kappa) either side in the plane
 * of incidence, kappa x1.5: a lobe cut by the horizon), each refined by two rounds of golden sections on
 * the four parameters (kappa then axis, per lobe); out[0] is the sharper, share[l] its part of alpha. */
static void lf_fit_mix(const lf_cache *c, const float alpha[3], const vmf_lobe *one, vmf_lobe out[2], float share[2]) {
    double psi = atan2(-one->mu[0], one->mu[2]), lk = log(fmax(one->kappa, 1e-3f)), d = 0.7 / sqrt(exp(lk));
    double start[2][4] = { { psi, lk + log(2.0), psi, lk - log(4.0) }, { psi - d, lk + log(1.5), psi + d, lk + log(1.5) } };
    double best[4], best_cost = INFINITY, s;
    lf_obj o = { .c = c, .alpha = alpha };
    for (int st = 0; st < 2; st++) {
        double *x = start[st];
        for (int round = 0; round < 2; round++) {
            double span = round ? 0.25 : 1.0;
            for (int l = 0; l < 2; l++) {
                lf_golden(&o, lf_mix_cost, x, 4, 2 * l + 1, x[2 * l + 1] - 2 * span, x[2 * l + 1] + 2 * span);
                lf_golden(&o, lf_mix_cost, x, 4, 2 * l, x[2 * l] - 0.3 * span, x[2 * l] + 0.3 * span);
            }
        }
        double cost = lf_mix_cost(&o, x);
        if (cost < best_cost) best_cost = cost, memcpy(best, x, sizeof best);
    }
    lf_mix_eval(&o, best, &s);
    int sharp = best[1] >= best[3] ? 0 : 1;
    lf_plane_lobe(best[2 * sharp], best[2 * sharp + 1], &out[0]);
    lf_plane_lobe(best[2 - 2 * sharp], best[3 - 2 * sharp], &out[1]);
    share[0] = (float)(sharp ? 1 - s : s), share[1] = (float)(sharp ? s : 1 - s);
}

/* ---- the fit ---------------------------------------------------------------------------------- */

typedef struct lf_ctx {
    brdf_params ps;         /* the specular part: f - kd/pi for these four models */
    const float *kd;
    int res;
    bool moments_only;
    int lobes;              /* 1, or 2: two lobes where one errs by more than threshold */
    float threshold;
    lf_cache c;
} lf_ctx;

/* The relative errors of sums (lf_error) against the specular and the whole slice. */
static void lf_rel(const double sums[3], float *e, float *ew) {
    *e = sums[1] > 0 ? (float)sqrt(sums[0] / sums[1]) : 0.0f;
    *ew = sums[2] > 0 ? (float)sqrt(sums[0] / sums[2]) : 0.0f;
}

/* View v of elevation th: the one-lobe fit and its errors, then (lobes 2, error above the threshold) the
 * two-lobe fit, kept where its error is lower. */
static void lf_fit_view(lf_ctx *x, int v, double th, lobefit_table *out) {
    double sums[3];
    float wo[3];
    lf_grid g;
    lf_view(th, x->res, wo, &g);
    out->theta[v] = (float)th;
    lf_moments(&x->ps, &g, wo, &x->c, &out->lobe[v], out->alpha[v]);
    if (!x->moments_only) lf_refine(&x->c, out->alpha[v], &out->lobe[v]);
    lf_error(&x->ps, x->kd, &g, wo, &out->lobe[v], (const float (*)[3])&out->alpha[v], 1, sums);
    lf_rel(sums, &out->err[v], &out->err_whole[v]);
    out->err_mix[v] = out->err[v], out->err_mix_whole[v] = out->err_whole[v];
    if (x->lobes < 2 || !(out->err[v] > x->threshold) || !(out->lobe[v].kappa > 0) || x->c.n == 0) return;
    vmf_lobe m[2];
    float share[2], a[2][3], e, ew;
    lf_fit_mix(&x->c, out->alpha[v], &out->lobe[v], m, share);
    for (int l = 0; l < 2; l++)
        for (int k = 0; k < 3; k++) a[l][k] = share[l] * out->alpha[v][k];
    lf_error(&x->ps, x->kd, &g, wo, m, (const float (*)[3])a, 2, sums);
    lf_rel(sums, &e, &ew);
    out->err_two[v] = e;
    if (!(e <= out->err[v] - LOBEFIT_MIX_GAIN)) return;
    out->mixed[v] = true, out->err_mix[v] = e, out->err_mix_whole[v] = ew;
    memcpy(out->mix[v], m, sizeof m), memcpy(out->mix_alpha[v], a, sizeof a);
}

/* The means and maxima over views of the table's errors. */
static void lf_summary(lobefit_table *t) {
    double s[4] = { 0, 0, 0, 0 };
    for (int v = 0; v < t->views; v++) {
        s[0] += t->err[v], s[1] += t->err_whole[v], s[2] += t->err_mix[v], s[3] += t->err_mix_whole[v];
        t->err_max = fmaxf(t->err_max, t->err[v]);
        t->err_whole_max = fmaxf(t->err_whole_max, t->err_whole[v]);
        t->err_mix_max = fmaxf(t->err_mix_max, t->err_mix[v]);
        t->err_mix_whole_max = fmaxf(t->err_mix_whole_max, t->err_mix_whole[v]);
    }
    t->err_mean = (float)(s[0] / t->views), t->err_whole_mean = (float)(s[1] / t->views);
    t->err_mix_mean = (float)(s[2] / t->views), t->err_mix_whole_mean = (float)(s[3] / t->views);
}

int lobefit_fit(const brdf_params *p, const lobefit_desc *desc, lobefit_table *out, prt_error *err) {
    if (!lobefit_supported(p->type))
        return prt_fail(err, "brdf %s: no vMF lobe fit for this model (phong, blinn, ggx and beckmann have one)",
                        brdf_type_name(p->type));
    lobefit_desc d = { 0 };
    if (desc) d = *desc;
    int views = d.views ? d.views : LOBEFIT_DEFAULT_VIEWS, res = d.res ? d.res : 256;
    PRT_CHECK(views >= 1 && views <= LOBEFIT_MAX_VIEWS);
    PRT_CHECK(res >= 16 && res <= 1024);
    PRT_CHECK(d.lobes >= 0 && d.lobes <= 2);
    double t0 = prt_now();
    memset(out, 0, sizeof *out);
    out->type = p->type, out->views = views, out->res = res, out->lobes = d.lobes == 2 ? 2 : 1;
    lf_ctx x = { .ps = *p, .kd = p->kd, .res = res, .moments_only = d.moments_only, .lobes = out->lobes,
                 .threshold = d.mix_threshold > 0 ? d.mix_threshold : LOBEFIT_MIX_THRESHOLD };
    x.ps.kd[0] = x.ps.kd[1] = x.ps.kd[2] = 0;
    size_t npts = (size_t)res * (res / 2);
    x.c = (lf_cache){ 0, prt_calloc(npts, sizeof *x.c.d, err), prt_calloc(npts, sizeof *x.c.wh, err) };
    if (!x.c.d || !x.c.wh) { free(x.c.d), free(x.c.wh); return -1; }
    for (int v = 0; v < views; v++) lf_fit_view(&x, v, 0.5 * PI * v / views, out);
    free(x.c.d), free(x.c.wh);
    lf_summary(out);
    out->seconds = prt_now() - t0;
    return 0;
}

/* The two table views bracketing wo's elevation (i, j) and the weight f of j (laurijssen-2011 Eq. 7's
 * interpolation; clamped past the last view). */
static void lf_locate(const lobefit_table *t, const float wo[3], int *i, int *j, double *f) {
    PRT_CHECK(t->views >= 1);
    double rxy = hypot(wo[0], wo[1]), th = atan2(rxy, wo[2]);
    double x = th / (0.5 * PI) * t->views;          /* theta_k = k (pi/2) / views */
    *i = (int)floor(x), *f = x - *i;
    if (*i < 0) *i = 0, *f = 0;
    if (*i >= t->views - 1) *i = t->views - 1, *f = 0;
    *j = *i + 1 < t->views ? *i + 1 : *i;
}

/* lobe->mu = mu / l (l > 0; else the normal) turned from the x-z plane to wo's azimuth (any at the pole). */
static void lf_to_azimuth(const float wo[3], double mu[3], double l, vmf_lobe *lobe) {
    double rxy = hypot(wo[0], wo[1]);
    if (!(l > 0)) mu[0] = mu[1] = 0, mu[2] = 1, l = 1;
    double cp = rxy > 0 ? wo[0] / rxy : 1, sp = rxy > 0 ? wo[1] / rxy : 0;
    lobe->mu[0] = (float)((cp * mu[0] - sp * mu[1]) / l);
    lobe->mu[1] = (float)((sp * mu[0] + cp * mu[1]) / l);
    lobe->mu[2] = (float)(mu[2] / l);
}

void lobefit_lookup(const lobefit_table *t, const float wo[3], vmf_lobe *lobe, float alpha[3]) {
    int i, j;
    double f;
    lf_locate(t, wo, &i, &j, &f);
    const vmf_lobe *a = &t->lobe[i], *b = &t->lobe[j];
    double mu[3], l = 0;
    for (int k = 0; k < 3; k++) mu[k] = (1 - f) * a->mu[k] + f * b->mu[k], l += mu[k] * mu[k];
    lf_to_azimuth(wo, mu, sqrt(l), lobe);
    lobe->kappa = (float)((1 - f) * a->kappa + f * b->kappa);
    for (int c = 0; c < 3; c++) alpha[c] = (float)((1 - f) * t->alpha[i][c] + f * t->alpha[j][c]);
}

/* Lobe l (0, 1) of view v's lobes and its colour: the two-lobe fit where v is mixed, else the one lobe
 * as lobe 0 and an empty lobe 1 (alpha 0). */
static void lf_view_lobe(const lobefit_table *t, int v, int l, const vmf_lobe **lobe, const float **alpha) {
    static const float zero[3] = { 0, 0, 0 };
    if (t->mixed[v]) *lobe = &t->mix[v][l], *alpha = t->mix_alpha[v][l];
    else *lobe = &t->lobe[v], *alpha = l == 0 ? t->alpha[v] : zero;
}

int lobefit_lookup_mix(const lobefit_table *t, const float wo[3], vmf_lobe lobe[2], float alpha[2][3]) {
    int v[2];
    double f, w[2];
    lf_locate(t, wo, &v[0], &v[1], &f);
    if (!t->mixed[v[0]] && !t->mixed[v[1]]) {
        lobefit_lookup(t, wo, &lobe[0], alpha[0]);
        lobe[1] = lobe[0], lobe[1].kappa = 0;
        alpha[1][0] = alpha[1][1] = alpha[1][2] = 0;
        return 1;
    }
    w[0] = 1 - f, w[1] = f;
    for (int l = 0; l < 2; l++) {          /* Eq. 7 with luminance weights: an empty lobe adds nothing */
        double mu[3] = { 0, 0, 0 }, ka = 0, wa = 0, len = 0;
        for (int c = 0; c < 3; c++) alpha[l][c] = 0;
        for (int q = 0; q < 2; q++) {
            const vmf_lobe *a;
            const float *al;
            lf_view_lobe(t, v[q], l, &a, &al);
            double lum = w[q] * (k_lum[0] * al[0] + k_lum[1] * al[1] + k_lum[2] * al[2]);
            for (int k = 0; k < 3; k++) mu[k] += lum * a->mu[k], alpha[l][k] += (float)(w[q] * al[k]);
            ka += lum * a->kappa, wa += lum;
        }
        for (int k = 0; k < 3; k++) len += mu[k] * mu[k];
        lf_to_azimuth(wo, mu, sqrt(len), &lobe[l]);
        lobe[l].kappa = wa > 0 ? (float)(ka / wa) : 0;
    }
    return 2;
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
