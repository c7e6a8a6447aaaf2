/* highlights.c - indirect highlights by vMF merging (highlights.h; laurijssen-2010 4-6).
 *
 * Per point: gather the lobes the secondary hits reflect toward it, cluster them by mean
 * direction (Algorithm 4.1, hard EM), merge each cluster (Eq. 5, 10) and light the merged
 * lobes once each (Eq. 8): a few shadow rays instead of one per secondary hit. */
#include "highlights.h"
#include "vec3.h"
#include <math.h>
#include <string.h>

typedef struct hl_item {
    vmf_lobe g;        /* gamma_i over incoming directions at q_i (world) */
    float c[3];        /* c_i = w_i alpha_i */
    float q[3], nq[3]; /* q_i and its normal */
    double w;          /* luminance of c_i: Eq. 10's merge weight */
    int k;             /* cluster */
} hl_item;

typedef struct hl_cluster {
    vmf_lobe g;        /* merged lobe */
    double alpha;      /* share of the weight (Algorithm 4.1's alpha_j) */
    float E[3];        /* (1/S) sum c_i: the cluster's energy (Eq. 10) */
    float q[3];        /* weighted mean position */
    int rep;           /* member nearest q: the shadow rays' origin */
} hl_cluster;

/* splitmix64 -> [0, 1). */
static double hl_rand(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

/* 1/phi: the Kronecker sequence frac(i / phi) spreads any number of points evenly over [0, 1). */
#define HL_GOLDEN 0.61803398874989484820

/* The final gather of a hit's diffuse part: w kd/pi cos I / r^2 V / S for each light, one shadow ray each. */
static void hl_diffuse(const hl_scene *sc, const prt_light *lights, int nl, const float q[3], const float nq[3],
                       int mq, const float w[3], int S, float out[3], hl_stats *st)
{
    const float *kd = lightmat_brdf(sc->lm, mq)->kd;
    if (!(kd[0] > 0 || kd[1] > 0 || kd[2] > 0)) return;
    float eps = vis_eps(sc->vs), org[3];
    v3_madd(org, q, nq, eps);
    for (int l = 0; l < nl; l++) {
        float d[3], I[3], md[3];
        v3_sub(d, lights[l].pos, org);
        float dist = v3_normalize(d), c = v3_dot(d, nq);
        if (!(c > 0) || !(dist > eps)) continue;
        v3_scale(md, d, -1.f);
        light_intensity_toward(&lights[l], md, I);
        if (!(I[0] > 0 || I[1] > 0 || I[2] > 0)) continue;
        st->shadow_rays++;
        if (vis_occluded(sc->vs, org, d, eps, dist - eps)) continue;
        for (int k = 0; k < 3; k++) out[k] += w[k] * kd[k] * (float)M_1_PI * c * I[k] / (dist * dist) / S;
    }
}

/* Section 6.2's gathering: S rays from p's lobe, the lobe each glossy hit reflects toward p; the
 * hits' diffuse part is gathered from the lights at once into dout (hl_diffuse). */
static int hl_gather(const hl_scene *sc, int S, const float p[3], const float n[3], int mat, const float wo[3],
                     uint64_t seed, const prt_light *lights, int nl, hl_item *items, float dout[3], hl_stats *st)
{
    vmf_lobe gp;
    float ap[3];
    if (!lightmat_lobe(sc->lm, mat, n, wo, &gp, ap)) return 0;
    float eps = vis_eps(sc->vs), org[3];
    v3_madd(org, p, n, eps);
    int m = 0;
    double su = hl_rand(&seed), sv = hl_rand(&seed);
    for (int i = 0; i < S; i++) {
        float s[3], f[3], ms[3];
        double u2 = i * HL_GOLDEN + sv;
        vmf_sample(&gp, (float)((i + su) / S), (float)(u2 - floor(u2)), s);   /* the shifted lattice (header) */
        float cp = v3_dot(s, n), pdf = vmf_eval(&gp, s);
        if (cp <= 0 || !(pdf > 0)) continue;
        lightmat_spec_eval(sc->lm, mat, n, s, wo, f);
        vis_hit h;
        st->rays++;
        if (!vis_closest(sc->vs, org, s, eps, INFINITY, &h)) continue;
        hl_item *it = items + m;
        int mq = lightmat_surface(sc->lm, sc->mesh, &h, it->q, it->nq);
        float aq[3], w[3];
        v3_scale(ms, s, -1.f);
        if (v3_dot(ms, it->nq) <= 0) continue;            /* the back of a one-sided surface */
        for (int k = 0; k < 3; k++) w[k] = f[k] * cp / pdf;
        hl_diffuse(sc, lights, nl, it->q, it->nq, mq, w, S, dout, st);
        if (!lightmat_lobe(sc->lm, mq, it->nq, ms, &it->g, aq)) continue;
        for (int k = 0; k < 3; k++) it->c[k] = w[k] * aq[k];
        it->w = prt_luminance(it->c);
        if (!(it->w > 0)) continue;
        m++;
    }
    st->glossy_hits += m;
    return m;
}

/* Merges the members of cluster k (Eq. 5 with Eq. 10's weights), its energy, mean position
 * and representative; false when it has none. */
static bool hl_merge(const hl_item *it, const int *idx, int m, int k, int S, hl_cluster *c)
{
    vmf_accum acc = { 0 };
    double q[3] = { 0, 0, 0 }, E[3] = { 0, 0, 0 };
    for (int a = 0; a < m; a++) {
        const hl_item *x = it + idx[a];
        if (x->k != k) continue;
        vmf_accum_add(&acc, &x->g, x->w);
        for (int j = 0; j < 3; j++) q[j] += x->w * x->q[j], E[j] += x->c[j];
    }
    if (!vmf_accum_result(&acc, &c->g)) return false;
    c->alpha = acc.w;
    double best = INFINITY;
    for (int j = 0; j < 3; j++) c->q[j] = (float)(q[j] / acc.w), c->E[j] = (float)(E[j] / S);
    for (int a = 0; a < m; a++) {
        const hl_item *x = it + idx[a];
        float d[3];
        v3_sub(d, x->q, c->q);
        if (x->k == k && v3_dot(d, d) < best) best = v3_dot(d, d), c->rep = idx[a];
    }
    return true;
}

/* Farthest-point centres from the heaviest lobe: cluster k starts as item idx[seed_k]. */
static int hl_init(hl_item *it, const int *idx, int m, int K)
{
    int centre[HL_MAX_CLUSTERS], nc = 1;
    centre[0] = 0;
    for (int a = 1; a < m; a++)
        if (it[idx[a]].w > it[idx[centre[0]]].w) centre[0] = a;
    while (nc < K) {
        int far = -1;
        double worst = 0.9999;         /* directions within ~1 degree of a centre add no cluster */
        for (int a = 0; a < m; a++) {
            double near = -2;
            for (int j = 0; j < nc; j++) near = fmax(near, v3_dot(it[idx[a]].g.mu, it[idx[centre[j]]].g.mu));
            if (near < worst) worst = near, far = a;
        }
        if (far < 0) break;
        centre[nc++] = far;
    }
    for (int a = 0; a < m; a++) {        /* first assignment: nearest centre */
        double best = -2;
        for (int j = 0; j < nc; j++) {
            double d = v3_dot(it[idx[a]].g.mu, it[idx[centre[j]]].g.mu);
            if (d > best) best = d, it[idx[a]].k = j;
        }
    }
    return nc;
}

/* Algorithm 4.1 on the lobes' mean directions: assign each to argmax_j alpha_j gamma_j(mu_i)
 * (in logs: a sharp lobe underflows far from its axis), re-merge, until stable. */
static int hl_cluster_items(hl_item *it, const int *idx, int m, int K, int iters, int S, hl_cluster *cl)
{
    if (m == 0) return 0;
    int nc = hl_init(it, idx, m, K);
    for (int iter = 0; iter <= iters; iter++) {
        for (int j = 0; j < nc; j++)
            if (!hl_merge(it, idx, m, j, S, cl + j)) cl[j].alpha = 0;
        if (iter == iters) break;
        int changed = 0;
        for (int a = 0; a < m; a++) {
            hl_item *x = it + idx[a];
            double best = -INFINITY;
            int bk = x->k;
            for (int j = 0; j < nc; j++) {
                if (!(cl[j].alpha > 0)) continue;
                double s = log(cl[j].alpha) + log(vmf_norm(cl[j].g.kappa)) + cl[j].g.kappa * (v3_dot(cl[j].g.mu, x->g.mu) - 1);
                if (s > best) best = s, bk = j;
            }
            changed += bk != x->k;
            x->k = bk;
        }
        if (!changed) break;
    }
    int out = 0, to[HL_MAX_CLUSTERS];   /* drop emptied clusters; the members follow theirs */
    for (int j = 0; j < nc; j++) {
        to[j] = cl[j].alpha > 0 ? out : -1;
        if (cl[j].alpha > 0) cl[out++] = cl[j];
    }
    for (int a = 0; a < m; a++) it[idx[a]].k = to[it[idx[a]].k];
    return out;
}

/* Eq. 8 for a point light: E_j gamma_j(w_l) I / r^2, one shadow ray from the representative;
 * gamma_j read at ref instead of w_l when ref is given (the light-relative merge). */
static void hl_light(const hl_scene *sc, const hl_item *it, const hl_cluster *cl, int nc, const prt_light *l,
                     const float *ref, float out[3], hl_stats *st)
{
    float eps = vis_eps(sc->vs);
    for (int j = 0; j < nc; j++) {
        float d[3], I[3], org[3], dr[3];
        v3_sub(d, l->pos, cl[j].q);
        float r2 = v3_dot(d, d);
        if (!(r2 > 0)) continue;
        v3_normalize(d);
        float g = vmf_eval(&cl[j].g, ref ? ref : d);
        if (!(g > 0)) continue;
        const hl_item *rep = it + cl[j].rep;
        v3_madd(org, rep->q, rep->nq, eps);
        v3_sub(dr, l->pos, org);
        float dist = v3_normalize(dr);
        st->shadow_rays++;
        if (vis_occluded(sc->vs, org, dr, eps, dist - eps)) continue;
        float md[3] = { -d[0], -d[1], -d[2] };
        light_intensity_toward(l, md, I);
        for (int k = 0; k < 3; k++) out[k] += cl[j].E[k] * g * I[k] / r2;
    }
}

/* Eq. 8 for a point light with every lobe read at its own light direction (the default, header):
 * sum_i c_i gamma_i(w_l(q_i)) I / r_i^2 / S over the members of each cluster, whose one shadow ray
 * from its representative stands for all of them. */
static void hl_light_lobes(const hl_scene *sc, const hl_item *it, int m, const hl_cluster *cl, int nc, int S,
                           const prt_light *l, float out[3], hl_stats *st)
{
    float eps = vis_eps(sc->vs);
    for (int j = 0; j < nc; j++) {
        const hl_item *rep = it + cl[j].rep;
        float org[3], dr[3];
        v3_madd(org, rep->q, rep->nq, eps);
        v3_sub(dr, l->pos, org);
        float dist = v3_normalize(dr);
        st->shadow_rays++;
        if (!(dist > eps) || vis_occluded(sc->vs, org, dr, eps, dist - eps)) continue;
        for (int a = 0; a < m; a++) {
            if (it[a].k != j) continue;
            float d[3], I[3], md[3];
            v3_sub(d, l->pos, it[a].q);
            float r2 = v3_dot(d, d);
            if (!(r2 > 0)) continue;
            v3_normalize(d);
            v3_scale(md, d, -1.f);
            float g = vmf_eval(&it[a].g, d);
            light_intensity_toward(l, md, I);
            for (int k = 0; k < 3; k++) out[k] += it[a].c[k] * g * I[k] / r2 / S;
        }
    }
}

/* Rotates v by the rotation taking unit a to unit b (Rodrigues; a = -b does not occur here:
 * a and b are directions to one light from two nearby points). */
static void hl_rotate(const float a[3], const float b[3], float v[3])
{
    float k[3], kv[3], o[3];
    v3_cross(k, a, b);
    float s = v3_len(k), c = v3_dot(a, b);
    if (s < 1e-7f || c <= -0.99f) return;
    v3_scale(k, k, 1.f / s);
    v3_cross(kv, k, v);
    float kd = v3_dot(k, v);
    for (int i = 0; i < 3; i++) o[i] = v[i] * c + kv[i] * s + k[i] * kd * (1 - c);
    v3_copy(v, o);
    v3_normalize(v);
}

/* Eq. 8 for a point light with the lobes merged relative to the light (see header): each lobe
 * turned by the rotation taking w_l(q_i) to w_ref = w_l(mean q), so that gamma'_i(w_ref) =
 * gamma_i(w_l(q_i)), then clustered, merged and read at w_ref. */
static void hl_light_relative(const hl_scene *sc, const hl_desc *d, const hl_item *it, int m, int S,
                              const prt_light *l, float out[3], hl_stats *st)
{
    hl_item tmp[HL_MAX_SAMPLES];
    int idx[HL_MAX_SAMPLES];
    double q[3] = { 0, 0, 0 }, w = 0;
    for (int a = 0; a < m; a++) {
        for (int k = 0; k < 3; k++) q[k] += it[a].w * it[a].q[k];
        w += it[a].w;
    }
    float ref[3], wi[3];
    for (int k = 0; k < 3; k++) ref[k] = l->pos[k] - (float)(q[k] / w);
    if (v3_normalize(ref) == 0.f) return;
    for (int a = 0; a < m; a++) {
        tmp[a] = it[a];
        idx[a] = a;
        v3_sub(wi, l->pos, it[a].q);
        if (v3_normalize(wi) > 0.f) hl_rotate(wi, ref, tmp[a].g.mu);
    }
    hl_cluster cl[HL_MAX_CLUSTERS];
    int nc = hl_cluster_items(tmp, idx, m, d->clusters, d->iters, S, cl);
    st->clusters = nc;
    hl_light(sc, tmp, cl, nc, l, ref, out, st);
}

/* Section 6.4: lobes whose mean direction escapes, merged, read from the filtered probe. */
static void hl_env(const hl_scene *sc, const hl_desc *d, hl_item *it, int m, int S, float out[3], hl_stats *st)
{
    int idx[HL_MAX_SAMPLES], n = 0;
    float eps = vis_eps(sc->vs);
    for (int a = 0; a < m; a++) {
        float org[3];
        v3_madd(org, it[a].q, it[a].nq, eps);
        st->shadow_rays++;
        if (!vis_occluded(sc->vs, org, it[a].g.mu, eps, INFINITY)) idx[n++] = a;
    }
    hl_cluster cl[HL_MAX_CLUSTERS];
    int nc = hl_cluster_items(it, idx, n, d->clusters, d->iters, S, cl);
    for (int j = 0; j < nc; j++) {
        float L[3];
        prefilter_lookup(sc->env, cl[j].g.mu, cl[j].g.kappa, L);
        for (int k = 0; k < 3; k++) out[k] += cl[j].E[k] * L[k];
    }
}

/* Gather, cluster, light (header). */
void hl_shade(const hl_scene *sc, const hl_desc *desc, const prt_light *lights, int nl, const float p[3],
              const float n[3], int mat, const float wo[3], uint64_t seed, float out[3], hl_stats *stats)
{
    hl_stats st = { 0 };
    hl_desc d = desc ? *desc : (hl_desc){ 0 };
    d.samples = d.samples <= 0 ? HL_DEFAULT_SAMPLES : d.samples > HL_MAX_SAMPLES ? HL_MAX_SAMPLES : d.samples;
    d.clusters = d.clusters <= 0 ? HL_DEFAULT_CLUSTERS : d.clusters > HL_MAX_CLUSTERS ? HL_MAX_CLUSTERS : d.clusters;
    d.iters = d.iters <= 0 ? 8 : d.iters;
    out[0] = out[1] = out[2] = 0;
    hl_item it[HL_MAX_SAMPLES];
    int m = hl_gather(sc, d.samples, p, n, mat, wo, seed, lights, nl, it, out, &st);
    if (m > 0 && nl > 0 && d.merged && !d.fixed_frame) {
        for (int l = 0; l < nl; l++) hl_light_relative(sc, &d, it, m, d.samples, lights + l, out, &st);
    } else if (m > 0 && nl > 0) {
        int idx[HL_MAX_SAMPLES];
        for (int a = 0; a < m; a++) idx[a] = a;
        hl_cluster cl[HL_MAX_CLUSTERS];
        int nc = hl_cluster_items(it, idx, m, d.clusters, d.iters, d.samples, cl);
        st.clusters = nc;
        for (int l = 0; l < nl; l++)
            if (d.merged) hl_light(sc, it, cl, nc, lights + l, NULL, out, &st);
            else hl_light_lobes(sc, it, m, cl, nc, d.samples, lights + l, out, &st);
    }
    if (m > 0 && sc->env) hl_env(sc, &d, it, m, d.samples, out, &st);
    for (int k = 0; k < 3; k++)
        if (!isfinite(out[k]) || out[k] < 0) out[k] = 0;
    if (stats) *stats = st;
}
