/* haar_run.c - Haar's policy in a precompute (haar_run.h): the light prior built from the probes
 * the file will be lit by, the coefficient budget chosen, the plan's lines, and the direct pass's
 * set given its selection, corrections and refit (transport.h). transfer_haar.c's linear table
 * points at the four hooks; precompute.c calls them in order (transfer.h). */
#include "haar_run.h"
#include "policy.h"
#include "prior.h"
#include "probe.h"
#include "refit.h"
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* What one precompute's Haar transfer holds between its hooks (transfer_linear_run.state). */
typedef struct haar_state {
    int budget;                     /* resolved: a transport_budget */
    float (*w)[4];                  /* the prior's weights per coefficient and channel, or NULL */
    prior_texels *texels;           /* its light per texel (the refit's), or NULL */
    prior_rays rays;                /* its light-weighted texels (n 0: none) */
    refit_tables *refit;            /* made by init_set when the kept values are refit, or NULL */
} haar_state;

/* Appends printf text to the plan (cut at its size). */
static void plan_add(const transfer_linear_in *in, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void plan_add(const transfer_linear_in *in, const char *fmt, ...) {
    size_t len = strlen(in->plan);
    if (len + 1 >= in->plan_cap) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(in->plan + len, in->plan_cap - len, fmt, ap);
    va_end(ap);
}

int haar_prior_list(const char *paths, prt_error *err) {
    int n = 0;
    for (const char *s = paths; *s || n == 0; n++) {
        size_t len = strcspn(s, ",");
        if (len == 0 || len >= 4096 || n == PRIOR_MAX_PROBES)
            return prt_fail(err, "light prior %s: a comma-separated list of 1 to %d probe files", paths, PRIOR_MAX_PROBES);
        s += len + (s[len] == ',');
    }
    return n;
}

/* The probe files of the comma-separated list (haar_prior_list's) loaded into ps, their base names
 * comma-joined into name[cap] (cut where too long for the plan line). Returns how many, or -1. */
static int prior_probes(const char *paths, prt_probe *ps, char *name, size_t cap, prt_error *err) {
    int n = 0;
    name[0] = 0;
    if (haar_prior_list(paths, err) < 0) return -1;
    for (const char *s = paths; *s;) {
        size_t len = strcspn(s, ",");
        char path[4096];
        memcpy(path, s, len);
        path[len] = 0;
        if (probe_load(path, PROBE_AUTO, &ps[n], err)) return -1;
        const char *base = strrchr(path, '/');
        const char *b = base ? base + 1 : path;
        size_t at = strlen(name), bl = strlen(b);
        if (at + bl + 2 < cap) {
            if (n) name[at++] = ',';
            memcpy(name + at, b, bl + 1);
        }
        n++;
        s += len + (s[len] == ',');
    }
    return n;
}

/* The prior of the probes in paths (prior.h): its weights, its texel statistics and, unless
 * box_texels, its light-weighted texels into st; its time said on stderr. 0, or -1 with err. */
static int build_prior(const haar_config *c, const char *paths, const transfer_linear_in *in, haar_state *st, char *name,
                       size_t cap, prt_error *err) {
    double t0 = prt_now();
    prt_probe ps[PRIOR_MAX_PROBES];
    memset(ps, 0, sizeof ps);
    const prt_probe *pp[PRIOR_MAX_PROBES];
    for (int j = 0; j < PRIOR_MAX_PROBES; j++) pp[j] = &ps[j];
    int n = prior_probes(paths, ps, name, cap, err), rc = n < 0 ? -1 : 0;
    if (!rc) {
        st->w = transfer_light_alloc();
        if (!st->w) prt_fail(err, "light prior: out of memory");
        st->texels = st->w ? prt_calloc(1, sizeof *st->texels, err) : NULL;
        rc = st->texels ? 0 : -1;
    }
    prior_desc pd = { .steps = c->prior_yaws, .progress = in->progress, .progress_user = in->progress_user };
    if (!rc) rc = prior_build(pp, n, &pd, st->w, st->texels, err);
    if (!rc && !c->box_texels) rc = prior_rays_from_probes(pp, n, &st->rays, err);
    for (int j = 0; j < PRIOR_MAX_PROBES; j++) probe_free(&ps[j]);
    if (rc) return -1;
    char took[48];
    prt_format_duration(took, sizeof took, prt_now() - t0);
    if (!in->quiet)
        fprintf(stderr, "light prior: %s turned through %d yaw angles in %s\n", paths, c->prior_yaws ? c->prior_yaws : PRIOR_STEPS, took);
    return 0;
}

/* Budget auto resolved (haar_run.h), said in the plan when it is not the shared one: per vector with a
 * light prior (its weights already put each vector's N where the light will be, and a shared pool
 * takes from the darkest contact-shadow vertices), else shared up to HAAR_SHARED_MAX_VECS vectors. */
static int resolve_budget(const haar_config *c, const haar_state *st, const transfer_linear_in *in) {
    if (c->budget != HAAR_BUDGET_AUTO) return c->budget;
    if (st->w) {
        plan_add(in, "  coefficients: N per vector (with a light prior: a shared pool would leave the darkest vertices N/2)\n");
        return TRANSPORT_BUDGET_VECTOR;
    }
    if (in->nvecs <= HAAR_SHARED_MAX_VECS) return TRANSPORT_BUDGET_SHARED;
    plan_add(in, "  coefficients: N per vector (%zu vectors: a shared budget stops at %d, its staging and time)\n", in->nvecs,
             HAAR_SHARED_MAX_VECS);
    return TRANSPORT_BUDGET_VECTOR;
}

/* Whether the kept values are refit (refit.h): a light prior that turns (the refit weighs by its light's
 * variance over the turns, none for one yaw angle), refit on, a budget per vector. */
static bool refits(const haar_config *c, const haar_state *st) {
    return st->w && c->refit && c->prior_yaws != 1 && st->budget == TRANSPORT_BUDGET_VECTOR;
}

/* The notes of options that change nothing here (stderr, unless quiet). */
static void notes(const haar_config *c, const transfer_setup *s, bool prior, bool quiet) {
    if (quiet) return;
    if (s->light_prior && s->light_prior[0] && !prior)
        fprintf(stderr, "note: the scene's light_prior is not used (it weighs the expected-error selection)\n");
    if (c->box_texels && !prior)
        fprintf(stderr, "note: --box-texels changes nothing without a light prior (every texel is box-filtered)\n");
    if (!c->refit && !prior) fprintf(stderr, "note: --no-refit changes nothing without a light prior (nothing is refit)\n");
}

int haar_begin(const transfer_config *cfg, const transfer_setup *s, const transfer_linear_in *in, transfer_linear_run *out,
               prt_error *err) {
    haar_config c = haar_config_of(cfg);
    memset(out, 0, sizeof *out);
    haar_state *st = prt_calloc(1, sizeof *st, err);
    if (!st) return -1;
    out->state = st;
    bool prior = s->light_prior && s->light_prior[0] && c.select == TRANSPORT_SELECT_EXPECTED;
    notes(&c, s, prior, in->quiet);
    char name[1024] = "";
    double t0 = prt_now();
    if (prior && build_prior(&c, s->light_prior, in, st, name, sizeof name, err)) return -1;
    if (prior) out->seconds = prt_now() - t0, out->stage = "light prior";
    out->rays = st->rays.n ? &st->rays : NULL;
    st->budget = resolve_budget(&c, st, in);
    if (st->budget != TRANSPORT_BUDGET_VECTOR)
        plan_add(in, "  coefficients: N x vectors shared, each vector N/2 to 4N, by %s error\n",
                 st->budget == TRANSPORT_BUDGET_RELATIVE ? "relative" : "expected");
    if (prior)
        plan_add(in, "  light prior: %s %s (each coefficient weighed by its RMS light)\n", name,
                 c.prior_yaws == 1 ? "as it is" : "turned about +y");
    if (st->rays.n)
        plan_add(in, "  light-weighted texels: the prior's %d brightest lighting texels integrated along %d rays each, placed as "
                     "its light lies inside them\n", st->rays.n, PRIOR_RAYS);
    bool sa = c.lin.measure == LINEAR_MEASURE_SOLID_ANGLE;
    if (sa && refits(&c, st))
        plan_add(in, "  kept values: refit to the light prior's texels (least expected error under its turning light; refit.h)\n");
    else if (sa)   /* transport.h: block_level, smooth_faces */
        plan_add(in, "  what truncation drops: put back per 16x16-texel block%s\n",
                 c.smooth_faces ? "; on faces with no occluder edge weighted by the transport" : "");
    return 0;
}

/* The set with Haar's store policy (transport.h): with the solid-angle measure its selection and
 * prior, the block corrections or smooth faces, the refit; then the budget shared. A run that had no
 * begin (its state NULL: a caller storing vectors itself) has no prior, and budget=auto is per vector. */
int haar_init_set(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts, const int *nvec,
                  prt_error *err) {
    haar_config c = haar_config_of(cfg);
    haar_state none = { .budget = c.budget == HAAR_BUDGET_AUTO ? TRANSPORT_BUDGET_VECTOR : c.budget };
    haar_state *st = run && run->state ? run->state : &none;
    if (transport_init(t, nverts, nvec, c.lin.N, c.lin.qbits, err)) return -1;
    t->solid_angle = c.lin.measure == LINEAR_MEASURE_SOLID_ANGLE;
    t->select = t->solid_angle ? c.select : TRANSPORT_SELECT_MAGNITUDE;
    t->prior = (const float (*)[4])st->w;   /* only with the expected selection (haar_begin); the gathering passes inherit it */
    t->block_level = TRANSPORT_BLOCK_LEVEL;
    t->smooth_faces = t->solid_angle && c.smooth_faces;
    if (transport_set_policy(t, &haar_transport_policy, err)) return -1;   /* policy.h: the store's Haar hooks */
    if (refits(&c, st) && t->solid_angle && !st->refit) {
        if (!(st->refit = refit_create(st->texels, err))) return -1;
    }
    t->refit = st->refit;
    return transport_share_budget(t, st->budget, 0, err);
}

/* The resolved budget when shared, the prior's weights, rays and texels (when refit may use them). */
void haar_key(const transfer_linear_run *run, transfer_key_fn add, void *key) {
    const haar_state *st = run->state;
    if (!st) return;
    if (st->budget != TRANSPORT_BUDGET_VECTOR) add(key, &st->budget, sizeof st->budget);
    if (st->w) add(key, st->w, sizeof(float) * 4 * CUBE_TEXELS);
    if (st->rays.n) add(key, &st->rays, sizeof st->rays);
    if (st->refit) add(key, st->texels, sizeof *st->texels);
}

void haar_end(transfer_linear_run *run) {
    haar_state *st = run->state;
    if (st) {
        refit_destroy(st->refit);
        free(st->w);
        free(st->texels);
        free(st);
    }
    memset(run, 0, sizeof *run);
}
