/* transfer_cpca.c - clustered PCA over the Haar transport (Sloan et al. 2003; Liu et al. 2004 in a
 * wavelet basis), a linear transfer representation (transfer.h). The model is cpca.h's.
 *
 * Basis and light: Haar's, with the solid-angle measure (transfer_haar.c says why): a vector's
 * coefficients are the orthonormal Haar wavelets of T_j / w_j, and the light vector is Haar's
 * (haar_light_vector: L_j w_j transformed, its relative energy threshold, 16 bits), so that the
 * product of the full vectors is Eq. 4's sum.
 *
 * Precompute. The passes store each vector's S largest coefficients (option stage; the plain
 * path of transport.h, unquantized floats), so a set takes 16 S bytes per vector while it is
 * built: S = 2,048 is 32 KB a vector, 0.33 GB for 10,000 vectors, and the interreflection passes
 * keep sets of the same kind (the previous pass, the running total). Nothing per light or per
 * cluster can be chosen before every vector is known, so the representation's finish (transfer.h)
 * builds the model from the final sets, direct + interreflections as the runtime lights them, and
 * replaces their coefficients by none: the sets keep only their vector offsets, which the runtime
 * and the file's validation read, and the model lives in tr->priv. CPCA of the total rather than
 * of the direct pass alone: the runtime lights one vector per vertex and term, and the gathered
 * passes are smoother than the direct one, so they cost the clusters little.
 *
 * Runtime: cpca_light (C (M + 1) sparse dot products, then M multiply-adds per vector and channel).
 * No GLSL kernels (glsl NULL): both runtimes light it with cpca_light on the CPU; the GL runtime uploads
 * g and shades from it as from its own kernels' (glrt.h, the CPU light method). */
#include "transfer.h"
#include "cpca.h"
#include "haar.h"
#include "haar_run.h"
#include "linear.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BAD(buf, ...) (snprintf((buf), 256, __VA_ARGS__), false)

/* Defaults: docs/design/cpca.md's measurements. */
#define CPCA_DEFAULT_CLUSTERS 128
#define CPCA_DEFAULT_TERMS 8
#define CPCA_DEFAULT_COEFFS 512
#define CPCA_DEFAULT_STAGE 2048

typedef struct cpca_config {
    linear_config lin;  /* N: the stage S; qbits 32 (the staged floats); the solid-angle measure */
    int clusters, terms, coeffs;
} cpca_config;

/* The models of the two sets (0: the transport, 1: the direct pass when kept). */
typedef struct cpca_data { cpca_model set[2]; } cpca_data;

enum { OPT_CLUSTERS, OPT_TERMS, OPT_COEFFS, OPT_STAGE, NOPTS };
static const transfer_option k_options[NOPTS + 1] = {
    [OPT_CLUSTERS] = { .key = "clusters", .kind = TRANSFER_OPT_INT, .lo = 1, .hi = 4096,
                       .help = "clusters of vectors, each with its own mean and basis (default 128)" },
    [OPT_TERMS] = { .key = "terms", .kind = TRANSFER_OPT_INT, .lo = 1, .hi = CPCA_MAX_TERMS,
                    .help = "basis vectors per cluster: weights per vector and channel (default 8)" },
    [OPT_COEFFS] = { .key = "coeffs", .kind = TRANSFER_OPT_INT, .lo = 16, .hi = CUBE_TEXELS,
                     .help = "Haar coefficients kept per cluster mean and basis vector, 16-bit (default 512)" },
    [OPT_STAGE] = { .key = "stage", .kind = TRANSFER_OPT_INT, .lo = 64, .hi = CUBE_TEXELS,
                    .help = "largest coefficients per vector kept (floats) until the clusters are built\n"
                            "(default 2048, or --coeffs: 16 bytes each per vector while precomputing)" },
};

static cpca_config cpca_config_of(const transfer_config *cfg) {
    cpca_config c;
    memcpy(&c, cfg->bytes, sizeof c);
    return c;
}

static int cpca_set(void *user, int i, const char *value, prt_error *err) {
    cpca_config *c = user;
    int *f[NOPTS] = { &c->clusters, &c->terms, &c->coeffs, &c->lin.N };
    return transfer_option_int("cpca", &k_options[i], value, f[i], err);
}

/* --coeffs (setup N) gives the stage; the staging is floats (--quant other than 32 refused); no light prior from the
 * command line (nothing here weighs by light), the scene's left out (cpca_begin says so). */
static int cpca_configure(const transfer_setup *s, transfer_config *cfg, prt_error *err) {
    _Static_assert(sizeof(cpca_config) <= TRANSFER_CONFIG_BYTES, "cpca_config fits transfer_config");
    memset(cfg, 0, sizeof *cfg);
    cpca_config c;
    memset(&c, 0, sizeof c);
    if (s->qbits && s->qbits != 32)
        return prt_fail(err, "cpca: --quant %d: it stages floats and stores its own 16-bit rows", s->qbits);
    c.lin = (linear_config){ .N = s->N ? s->N : CPCA_DEFAULT_STAGE, .qbits = 32, .measure = LINEAR_MEASURE_SOLID_ANGLE };
    c.clusters = CPCA_DEFAULT_CLUSTERS, c.terms = CPCA_DEFAULT_TERMS, c.coeffs = CPCA_DEFAULT_COEFFS;
    if (transfer_parse_options("cpca", k_options, s->options, cpca_set, &c, err)) return -1;
    if (c.lin.N < 1 || c.lin.N > CUBE_TEXELS) return prt_fail(err, "cpca: N = %d (must be 1..%d)", c.lin.N, CUBE_TEXELS);
    if (s->light_prior && s->light_prior[0] && !s->light_prior_scene)
        return prt_fail(err, "cpca: a light prior weighs Haar's expected-error selection, which clustered PCA does not make");
    linear_store(cfg, &c, sizeof c);
    return 0;
}

static int cpca_begin(const transfer_config *cfg, const transfer_setup *s, const transfer_linear_in *in, transfer_linear_run *out,
                      prt_error *err) {
    (void)cfg, (void)err;
    memset(out, 0, sizeof *out);
    if (s->light_prior && s->light_prior[0] && !in->quiet)
        fprintf(stderr, "note: the scene's light_prior is not used (it weighs Haar's expected-error selection)\n");
    return 0;
}

static void cpca_describe(const transfer_config *cfg, char *buf, size_t cap) {
    cpca_config c = cpca_config_of(cfg);
    snprintf(buf, cap, "clustered PCA of Haar wavelets per steradian: %d clusters, %d terms, %d coefficients per row (16-bit), "
             "staged from %d per vector", c.clusters, c.terms, c.coeffs, c.lin.N);
}

/* Haar of T/w (transfer_haar.c's solid-angle measure): each face divided by w_j, transformed, in
 * wavelet-index order. */
static void cpca_project_transport(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch) {
    (void)cfg;
    float inv[CUBE_RES * CUBE_RES];
    haar_face_solid_angle(inv, CUBE_RES, true);
    haar_cube_forward_weighted(texels, CUBE_RES, inv, coeffs, scratch);
}

static void cpca_project_light(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]) {
    (void)cfg;
    haar_light_vector(cube_rgb, true, L);
}

/* The plain path: the S largest magnitudes of each vector, floats. */
static int cpca_init_set(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts,
                         const int *nvec, prt_error *err) {
    (void)run;
    return transport_init(t, nverts, nvec, cpca_config_of(cfg).lin.N, 32, err);
}

/* ---- finish: the model from the final sets ----------------------------------------------------- */

typedef struct csr_fill { uint32_t *idx; float *val; uint32_t n; } csr_fill;
static void csr_add(void *ctx, uint32_t index, float r, float g, float b) {
    csr_fill *f = ctx;
    f->idx[f->n] = index;
    f->val[3 * (size_t)f->n] = r, f->val[3 * (size_t)f->n + 1] = g, f->val[3 * (size_t)f->n + 2] = b;
    f->n++;
}

/* A set with vector offsets only (no coefficients): what the runtime and the validation read of a
 * cpca transfer's sets. Allocates s's other arrays for nvecs vectors (vec_first left to the caller).
 * 0 or -1 (OOM, nothing allocated). */
static int skeleton_arrays(prt_transport *s, int nverts, int nvecs, int N) {
    *s = (prt_transport){ .nverts = nverts, .nvecs = nvecs, .N = N, .qbits = 32 };
    s->coef_first = calloc((size_t)nvecs + 1, sizeof *s->coef_first);
    s->run_first = calloc((size_t)nvecs + 1, sizeof *s->run_first);
    s->scale = malloc(sizeof *s->scale * (3 * (size_t)nvecs + 1));
    if (!s->coef_first || !s->run_first || !s->scale) {
        free(s->coef_first); free(s->run_first); free(s->scale);
        return -1;
    }
    for (size_t k = 0; k < 3 * (size_t)nvecs; k++) s->scale[k] = 1.f;
    return 0;
}

/* t reduced to its skeleton (its vec_first kept, the rest freed). 0 or -1 (OOM, t unchanged). */
static int skeleton(prt_transport *t, int N, prt_error *err) {
    prt_transport s;
    if (skeleton_arrays(&s, t->nverts, t->nvecs, N)) return prt_fail(err, "cpca: out of memory");
    s.vec_first = t->vec_first;
    t->vec_first = NULL;
    transport_free(t);
    *t = s;
    return 0;
}

/* The model of set t (its stored vectors, read in index order), then t reduced to its skeleton. */
static int model_of(const cpca_config *c, prt_transport *t, int nthreads, cpca_model *m, prt_error *err) {
    size_t nc = transport_ncoefs(t);
    uint32_t *first = prt_calloc((size_t)t->nvecs + 1, sizeof *first, err);
    csr_fill f = { first ? prt_calloc(nc + 1, sizeof *f.idx, err) : NULL, NULL, 0 };
    f.val = f.idx ? prt_calloc(3 * nc + 1, sizeof *f.val, err) : NULL;
    int rc = f.val ? 0 : -1;
    for (int i = 0; i < t->nvecs && !rc; i++) {
        transport_foreach(t, i, csr_add, &f);
        first[i + 1] = f.n;
    }
    cpca_vectors v = { t->nvecs, first, f.idx, f.val };
    cpca_params p = { c->clusters, c->terms, c->coeffs, true, nthreads };
    if (!rc) rc = cpca_build(&v, &p, m, err);
    free(first); free(f.idx); free(f.val);
    if (!rc && skeleton(t, c->lin.N, err)) { cpca_model_free(m); rc = -1; }
    return rc;
}

static int cpca_finish(prt_transfer *tr, int nthreads, prt_error *err) {
    cpca_config c = cpca_config_of(&tr->cfg);
    cpca_data *d = prt_calloc(1, sizeof *d, err);
    if (!d) return -1;
    if (model_of(&c, &tr->transport, nthreads, &d->set[0], err) ||
        (tr->direct.nvecs > 0 && model_of(&c, &tr->direct, nthreads, &d->set[1], err))) {
        cpca_model_free(&d->set[0]);
        free(d);
        return -1;
    }
    tr->priv = d;
    return 0;
}

static void cpca_light_set(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    const cpca_data *d = tr->priv;
    PRT_CHECK(d != NULL);
    cpca_light(&d->set[t == &tr->direct], L, g, nthreads);
}

/* ---- the file section -------------------------------------------------------------------------- */

/* i32 clusters, terms, coeffs, stage; u64 materials; u8 flags (bit 0: the direct set follows; bit 1: the
 * open sky split, prt_transfer.open_sky);
 * i32 nverts, nvecs; u32 vec_first[nverts + 1]; the transport's model; [the direct set's] (cpca.h). */
static void cpca_write_section(prt_writer *w, const prt_transfer *tr) {
    cpca_config c = cpca_config_of(&tr->cfg);
    const cpca_data *d = tr->priv;
    bool direct = tr->direct.nvecs > 0;
    prtio_put_i32(w, c.clusters);
    prtio_put_i32(w, c.terms);
    prtio_put_i32(w, c.coeffs);
    prtio_put_i32(w, c.lin.N);
    prtio_put_u64(w, tr->materials);
    prtio_put_u8(w, (uint8_t)((direct ? 1 : 0) | (tr->open_sky ? 2 : 0)));
    prtio_put_i32(w, tr->transport.nverts);
    prtio_put_i32(w, tr->transport.nvecs);
    prtio_put_arr(w, tr->transport.vec_first, (size_t)tr->transport.nverts + 1, 4);
    cpca_write(w, &d->set[0]);
    if (direct) cpca_write(w, &d->set[1]);
    linear_put_open(w, tr);
}

/* A skeleton set of nverts / nvecs over a copy of vec_first. */
static bool read_skeleton(prt_transport *t, int nverts, int nvecs, int N, const uint32_t *vec_first, char *why) {
    if (skeleton_arrays(t, nverts, nvecs, N)) return BAD(why, "out of memory");
    t->vec_first = malloc(sizeof(uint32_t) * ((size_t)nverts + 1));
    if (!t->vec_first) return BAD(why, "out of memory");
    memcpy(t->vec_first, vec_first, sizeof(uint32_t) * ((size_t)nverts + 1));
    return true;
}

static bool cpca_read_section(prt_reader *r, prt_transfer *tr, char *why) {
    cpca_config c;
    memset(&c, 0, sizeof c);
    c.clusters = prtio_get_i32(r), c.terms = prtio_get_i32(r), c.coeffs = prtio_get_i32(r), c.lin.N = prtio_get_i32(r);
    tr->materials = prtio_get_u64(r);
    uint8_t flags = prtio_get_u8(r);
    int nverts = prtio_get_i32(r), nvecs = prtio_get_i32(r);
    if (r->bad) return BAD(why, "cpca section too short");
    if (flags > 3) return BAD(why, "cpca: bad flags %u", flags);
    tr->open_sky = flags & 2;
    if (c.clusters < 1 || c.clusters > 4096 || c.terms < 1 || c.terms > CPCA_MAX_TERMS || c.coeffs < 16 ||
        c.coeffs > CUBE_TEXELS || c.lin.N < 1 || c.lin.N > CUBE_TEXELS)
        return BAD(why, "cpca: bad configuration (clusters %d, terms %d, coeffs %d, stage %d)", c.clusters, c.terms, c.coeffs, c.lin.N);
    if (nverts < 0 || nverts > INT32_MAX - 1 || nvecs < 0 || nvecs > INT32_MAX / 3 - 1) return BAD(why, "cpca: bad transport size");
    c.lin.qbits = 32, c.lin.measure = LINEAR_MEASURE_SOLID_ANGLE;
    linear_store(&tr->cfg, &c, sizeof c);
    uint32_t *vf = prtio_get_arr(r, (size_t)nverts + 1, 4);
    if (!vf) return BAD(why, "cpca section too short for %d vertices", nverts);
    cpca_data *d = calloc(1, sizeof *d);
    bool ok = d && read_skeleton(&tr->transport, nverts, nvecs, c.lin.N, vf, why) &&
              (!(flags & 1) || read_skeleton(&tr->direct, nverts, nvecs, c.lin.N, vf, why));
    free(vf);
    if (!d) return BAD(why, "out of memory");
    tr->priv = d;
    if (!ok) return false;
    if (!cpca_read(r, &d->set[0], why) || ((flags & 1) && !cpca_read(r, &d->set[1], why))) return false;
    if (!linear_get_open(r, tr, why)) return false;
    if (r->pos != r->n) return BAD(why, "cpca section longer than its data");
    return true;
}

static bool cpca_validate(const struct prt_data *d, const prt_transfer *tr, char *why) {
    const cpca_data *cd = tr->priv;
    if (!cd) return BAD(why, "cpca: no model");
    if (!linear_validate(d, tr, CUBE_TEXELS, why) || !cpca_check(&cd->set[0], tr->transport.nvecs, why)) return false;
    return tr->direct.nvecs == 0 || cpca_check(&cd->set[1], tr->direct.nvecs, why);
}

static void cpca_release(prt_transfer *tr) {
    cpca_data *d = tr->priv;
    if (d) { cpca_model_free(&d->set[0]); cpca_model_free(&d->set[1]); }
    free(d);
    tr->priv = NULL;
    linear_release(tr);
}

static size_t cpca_bytes_of(const prt_transfer *tr) {
    const cpca_data *d = tr->priv;
    if (!d) return linear_bytes(tr);
    return 4 * ((size_t)tr->transport.nverts + 1) + cpca_bytes(&d->set[0]) + (tr->direct.nvecs ? cpca_bytes(&d->set[1]) : 0);
}

static void cpca_summary(const prt_transfer *tr, char *buf, size_t cap) {
    const cpca_data *d = tr->priv;
    size_t n = 0;
    if (cap) buf[0] = 0;
    for (int k = 0; d && k < 1 + (tr->direct.nvecs > 0) && n < cap; k++) {
        const cpca_model *m = &d->set[k];
        int R = cpca_rows(m);
        n += (size_t)snprintf(buf + n, cap - n, "  cpca%s: %d vectors in %d clusters, %d terms, %u coefficients in %d rows "
                              "(%.0f per row), %.2f MB; relative L2 error %.3f%% of the staged vectors\n", k ? " (direct)" : "",
                              m->nvecs, m->C, m->M, m->first[R], R, R ? (double)m->first[R] / R : 0, cpca_bytes(m) / 1e6,
                              m->norm2 > 0 ? 100 * sqrt(m->err2 / m->norm2) : 0);
    }
}

static const transfer_linear k_linear = {
    .begin = cpca_begin,
    .init_set = cpca_init_set,
    .project_transport = cpca_project_transport,
    .compress = linear_compress,
    .finish = cpca_finish,
    .project_light = cpca_project_light,
    .light = cpca_light_set,
};

const transfer_ops transfer_cpca = {
    .name = "cpca",
    .title = "clustered PCA of Haar wavelets",
    .label = "CPCA",
    .tag = TRANSFER_TAG('C', 'P', 'C', 'A'),
    .kind = TRANSFER_LINEAR,
    .options = k_options,
    .configure = cpca_configure,
    .describe = cpca_describe,
    .write = cpca_write_section,
    .read = cpca_read_section,
    .validate = cpca_validate,
    .release = cpca_release,
    .bytes = cpca_bytes_of,
    .summary = cpca_summary,
    .linear = &k_linear,
};
