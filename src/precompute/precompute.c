/* precompute.c - the precomputation pipeline (sections 3.1, 3.2, 4.1, 4.2):
 * BRDF factorization, an effects plan, the direct transport pass (Eq. 3) and
 * the interreflection passes (Eq. 6-8).
 *
 * The effects plan decides what the scene calls for before the expensive
 * passes run, and says why:
 *   - BRDF terms per material from its singular values (a Lambertian BRDF is
 *     rank 1, so K = 1 and the runtime needs no view maps; a glossy one gets
 *     the smallest K meeting term_error, or max_terms);
 *   - interreflections only where surfaces see each other: if fewer than 0.5%
 *     of the visibility rays hit geometry (a convex object alone) no bounce
 *     pass can carry anything worth its cost, so none is planned;
 *   - bounce passes continue while a pass carries at least bounce_threshold of
 *     the direct pass's energy (squared L2 norm of the transport, gather_energy);
 *   - force_bounces overrides both.
 * The plan goes to stderr (with the command's other status lines) before the
 * direct pass's progress bar starts; what is learnt later (the full pass's hit
 * fraction when it contradicts the sample, each bounce's energy) is appended
 * to out->plan for `prt info` but not printed over the bar.
 * The visibility statistics and the time estimate come from a strided sample
 * of ~200 vertices that are fully computed first (their work is kept), so the
 * plan costs almost nothing extra.
 *
 * Direct pass, per vertex (prt_parallel_for, dynamic chunks of 16 vertices,
 * per-thread scratch): the visibility cube at vis_res is ray cast
 * (vis_cube), then for each 64-res lighting texel j
 *     a_j = sum over its (vis_res/64)^2 sub-texels s of V(w_s) max(n.w_s, 0) dw_s
 * (Eq. 3 integrated over the texel with exact solid angles: the paper's 2x2
 * box filter of section 4.1 done on the 128-res visibility bytes), and
 *     T_k(j) = g_k(w_j) a_j,
 * g_k being the light map at the texel centre's local direction (it is smooth
 * at the 48x48 map resolution). A Lambertian factor is constant, so its value
 * is looked up once per material. Each of the K x 3 cubes is Haar transformed
 * per face (or projected onto SH when sh_order > 0) and handed to
 * transport_store, which keeps the N largest coefficients and quantizes them.
 *
 * Timing: each thread measures its time inside vis_cube and its total busy
 * time; the pass's wall time is split between "visibility" and "transport" in
 * that ratio. */
#include "precompute.h"
#include "cubemap.h"
#include "gather.h"
#include "haar.h"
#include "shbasis.h"
#include "visibility.h"
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define PC_GRAIN 16             /* vertices per dynamic chunk */
#define PC_SAMPLE 200           /* vertices in the planning sample */
#define PC_GATHER_SAMPLE 32     /* vertices whose gather rays are timed for the bounce estimate */
#define PC_HIT_MIN 0.005        /* below this fraction of hitting rays, no interreflections */
#define PC_MAX_THREADS 64
/* Plane stride of the K x 3 transport cubes: CUBE_TEXELS floats is a multiple of 4 KB, so the
 * 12 planes' same texel would fall in one L1 set; 32 floats of padding spread them out. */
#define PC_TSTRIDE (CUBE_TEXELS + 32)
#define PC_DECODE_NS 0.55       /* per decoded coefficient x term in gathering: fit to the bunny's bounce pass */

/* CPU seconds used by the calling thread (so estimates see through a busy machine). */
static double pc_cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Per-thread scratch for the direct pass. */
typedef struct pc_scratch {
    uint8_t *vis;       /* [6 * vres^2] visibility bytes */
    float *w;           /* [vres^2] V max(n.w,0) dw of one face */
    float *acc;         /* [CUBE_TEXELS] box-filtered a_j */
    float *T;           /* [Kmax * 3][PC_TSTRIDE] planar transport cubes */
    float *wav;         /* [3 * CUBE_TEXELS] one vector's coefficients (planar R, G, B) */
    float *tmp;         /* [2 * CUBE_RES^2] Haar scratch */
    float *sh;          /* [SH_MAX_ORDER^2] */
    void *tscratch;     /* transport_store scratch */
    double t_vis, t_busy;   /* seconds inside vis_cube / in total */
    double t_cpu;           /* CPU seconds of the thread in pc_range (t_cpu / t_busy: share of a core it got) */
    long traced, hits;
    double err_sum;     /* sum over vectors of (relative L2 error)^2 */
    long err_count;
} pc_scratch;

/* Shared state of the direct pass. */
typedef struct pc_ctx {
    const prt_mesh *mesh;
    const vis_scene *vs;
    const brdf_factor *factors;
    float lambert_g[PRT_MAX_MATERIALS][3];   /* constant light map of a Lambertian factor */
    prt_transport *t;
    int vres, ss, sh_order;
    const float *vdir;      /* [3][6 vres^2] unit directions of the visibility texels (planar x, y, z) */
    const float *vdw;       /* [vres^2] their solid angles (same on every face) */
    const float *ldir;      /* [CUBE_TEXELS][3] lighting texel centre directions */
    const int *order;       /* vertices to process, indexed by the parallel-for range */
    pc_scratch *scratch;    /* [nthreads] */
    /* progress */
    pthread_mutex_t lock;
    atomic_int cancelled;
    atomic_long done;
    long total;
    prt_progress_fn progress;
    void *progress_user;
    bool report;            /* false during the planning sample, so the plan prints before any bar */
} pc_ctx;

static void pc_scratch_free(pc_scratch *s) {
    free(s->vis); free(s->w); free(s->acc); free(s->T); free(s->wav); free(s->tmp); free(s->sh); free(s->tscratch);
    memset(s, 0, sizeof *s);
}

/* Allocates one thread's scratch. Returns 0 or -1 (OOM). */
static int pc_scratch_init(pc_scratch *s, int vres, int kmax, prt_error *err) {
    memset(s, 0, sizeof *s);
    size_t ct = CUBE_TEXELS;
    s->vis = prt_calloc((size_t)6 * vres * vres, 1, err);
    s->w = s->vis ? prt_calloc((size_t)vres * vres, sizeof(float), err) : NULL;
    s->acc = s->w ? prt_calloc(ct, sizeof(float), err) : NULL;
    s->T = s->acc ? prt_calloc((size_t)kmax * 3 * PC_TSTRIDE, sizeof(float), err) : NULL;
    s->wav = s->T ? prt_calloc(3 * ct, sizeof(float), err) : NULL;
    s->tmp = s->wav ? prt_calloc(2 * CUBE_RES * CUBE_RES, sizeof(float), err) : NULL;
    s->sh = s->tmp ? prt_calloc(SH_MAX_ORDER * SH_MAX_ORDER, sizeof(float), err) : NULL;
    s->tscratch = s->sh ? prt_calloc(transport_scratch_size(), 1, err) : NULL;
    if (!s->tscratch) { pc_scratch_free(s); return -1; }
    return 0;
}

/* a_j for every lighting texel (Eq. 3's V (n.w) dw summed over the texel's sub-texels) into s->acc. */
static void pc_box_filter(const pc_ctx *c, pc_scratch *s, const float n[3]) {
    const int R = c->vres, ss = c->ss;
    for (int f = 0; f < 6; f++) {
        float *acc = s->acc + f * CUBE_RES * CUBE_RES;
        /* n.d is linear on the face plane, so a face whose four corners are below the horizon
         * lies wholly below it and its visibility bytes are all 0: skip it. */
        float cmax = -1;
        for (int k = 0; k < 4; k++) {
            float d[3];
            cube_dir(R, f, (k & 1) ? (float)R : 0.f, (k & 2) ? (float)R : 0.f, d);
            float nd = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            if (nd > cmax) cmax = nd;
        }
        if (!(cmax > 0)) {
            memset(acc, 0, sizeof(float) * CUBE_RES * CUBE_RES);
            continue;
        }
        const uint8_t *restrict v = s->vis + (size_t)f * R * R;
        const size_t plane = (size_t)6 * R * R;
        const float *restrict dx = c->vdir + (size_t)f * R * R;
        const float *restrict dy = dx + plane, *restrict dz = dy + plane, *restrict dw = c->vdw;
        const float nx = n[0], ny = n[1], nz = n[2];
        float *restrict w = s->w;
        /* branch-free so it vectorizes: V is 0 below the horizon anyway */
        for (int i = 0; i < R * R; i++) {
            float nd = nx * dx[i] + ny * dy[i] + nz * dz[i];
            w[i] = (float)v[i] * (nd > 0.f ? nd : 0.f) * dw[i];
        }
        if (ss == 1) {
            memcpy(acc, w, sizeof(float) * CUBE_RES * CUBE_RES);
            continue;
        }
        for (int j = 0; j < CUBE_RES; j++)
            for (int i = 0; i < CUBE_RES; i++) {
                float a = 0;
                for (int b = 0; b < ss; b++) {
                    const float *row = w + (size_t)(j * ss + b) * R + i * ss;
                    for (int q = 0; q < ss; q++) a += row[q];
                }
                acc[j * CUBE_RES + i] = a;
            }
    }
}

/* The full direct computation of vertex v: visibility, Eq. 3, basis projection, storage. */
static void pc_vertex(pc_ctx *c, pc_scratch *s, int v) {
    const prt_mesh *m = c->mesh;
    const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
    int mat = m->mat ? m->mat[v] : 0;
    const brdf_factor *fac = &c->factors[mat];
    const int K = fac->K;
    const size_t ct = CUBE_TEXELS;

    double t0 = prt_now();
    long tr = 0, hi = 0;
    vis_cube(c->vs, p, n, c->vres, s->vis, &tr, &hi);
    double t1 = prt_now();
    s->traced += tr;
    s->hits += hi;
    pc_box_filter(c, s, n);

    /* T_k(j) = g_k(w_j) a_j (Eq. 3). */
    if (fac->lambertian) {
        const float *g = c->lambert_g[mat];
        for (int ch = 0; ch < 3; ch++) {
            float *T = s->T + (size_t)ch * PC_TSTRIDE;
            for (size_t j = 0; j < ct; j++) T[j] = g[ch] * s->acc[j];
        }
    } else {
        /* Face by face: the K x 3 face slices are zeroed in bulk, then g_k is looked up at each
         * lit texel's centre and written to the slices in step (12 store streams, padded apart). */
        float sv[3], tv[3], g[BRDF_MAX_SIGMA * 3];
        brdf_frame(n, sv, tv);
        const int K3 = 3 * K, F = CUBE_RES * CUBE_RES;
        for (int f = 0; f < 6; f++) {
            const float *acc = s->acc + (size_t)f * F;
            float *T = s->T + (size_t)f * F;
            for (int kc = 0; kc < K3; kc++) memset(T + (size_t)kc * PC_TSTRIDE, 0, sizeof(float) * F);
            for (int i = 0; i < F; i++) {
                const float a = acc[i];
                if (a == 0) continue;
                float wl[3];
                brdf_to_local(sv, tv, n, c->ldir + 3 * ((size_t)f * F + i), wl);
                /* A straddling texel's centre may be just below the horizon while some of its
                 * sub-texels are above: evaluate g at the horizon then (the maps are extended
                 * outward from the disk, so this is their boundary value). */
                if (wl[2] < 1e-4f) {
                    float r = sqrtf(wl[0] * wl[0] + wl[1] * wl[1]);
                    float sc = r > 0 ? sqrtf(1.f - 1e-8f) / r : 0;
                    wl[0] *= sc; wl[1] *= sc; wl[2] = 1e-4f;
                }
                brdf_factor_light(fac, wl, g);
                for (int kc = 0; kc < K3; kc++) T[(size_t)kc * PC_TSTRIDE + i] = g[kc] * a;
            }
        }
    }

    /* Basis projection and storage of each of the K vectors. */
    uint32_t vec0 = c->t->vec_first[v];
    for (int k = 0; k < K; k++) {
        for (int ch = 0; ch < 3; ch++) {
            const float *T = s->T + (size_t)(k * 3 + ch) * PC_TSTRIDE;
            float *out = s->wav + (size_t)ch * ct;
            if (c->sh_order > 0) {
                int nc = c->sh_order * c->sh_order;
                sh_project_cube(T, CUBE_RES, c->sh_order, false, s->sh);
                memset(out, 0, sizeof(float) * ct);
                memcpy(out, s->sh, sizeof(float) * (size_t)nc);
            } else {
                haar_cube_forward(T, CUBE_RES, out, s->tmp);
            }
        }
        /* |vector|^2 for the error statistics: 8 independent float accumulators (no dependency
         * chain; the vector length is a multiple of 8), summed in double */
        float p8[8] = { 0, 0, 0, 0, 0, 0, 0, 0 };
        const float *x = s->wav;
        for (size_t i = 0; i < 3 * ct; i += 8) {
            p8[0] += x[i] * x[i]; p8[1] += x[i + 1] * x[i + 1]; p8[2] += x[i + 2] * x[i + 2]; p8[3] += x[i + 3] * x[i + 3];
            p8[4] += x[i + 4] * x[i + 4]; p8[5] += x[i + 5] * x[i + 5]; p8[6] += x[i + 6] * x[i + 6]; p8[7] += x[i + 7] * x[i + 7];
        }
        double norm2 = 0;
        for (int q = 0; q < 8; q++) norm2 += p8[q];
        double e2 = transport_store(c->t, (int)(vec0 + (uint32_t)k), s->wav, s->wav + ct, s->wav + 2 * ct, s->tscratch);
        if (norm2 > 0) {
            s->err_sum += e2 / norm2;
            s->err_count++;
        }
    }
    double t2 = prt_now();
    s->t_vis += t1 - t0;
    s->t_busy += t2 - t0;
}

/* prt_parallel_for body: processes c->order[begin..end), reports progress, honours cancel. */
static void pc_range(void *ctx, int begin, int end, int thread) {
    pc_ctx *c = ctx;
    pc_scratch *s = &c->scratch[thread];
    if (atomic_load(&c->cancelled)) return;
    double cpu0 = pc_cpu_now();
    for (int i = begin; i < end; i++) pc_vertex(c, s, c->order[i]);
    s->t_cpu += pc_cpu_now() - cpu0;
    long done = atomic_fetch_add(&c->done, end - begin) + (end - begin);
    if (c->progress && c->report) {
        pthread_mutex_lock(&c->lock);
        if (!atomic_load(&c->cancelled) &&
            !c->progress(c->progress_user, "visibility+transport", (double)done / (double)c->total))
            atomic_store(&c->cancelled, 1);
        pthread_mutex_unlock(&c->lock);
    }
}

/* Appends printf text to the plan buffer (truncating silently at its size). */
static void plan_add(char *plan, size_t cap, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void plan_add(char *plan, size_t cap, const char *fmt, ...) {
    size_t len = strlen(plan);
    if (len + 1 >= cap) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(plan + len, cap - len, fmt, ap);
    va_end(ap);
}

/* "1m05s" style durations for the plan. */
static void fmt_dur(char *buf, size_t cap, double s) {
    if (!(s >= 0)) s = 0;
    if (s < 60) snprintf(buf, cap, "%.1fs", s);
    else if (s < 3600) snprintf(buf, cap, "%dm%02ds", (int)s / 60, (int)s % 60);
    else snprintf(buf, cap, "%dh%02dm", (int)s / 3600, ((int)s % 3600) / 60);
}

/* Peak resident set size from /proc/self/status (VmHWM), 0 if unavailable. */
static size_t pc_peak_rss(void) {
    FILE *f = fopen("/proc/self/status", "r");
    if (!f) return 0;
    char line[256];
    size_t kb = 0;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "VmHWM:", 6) == 0) { kb = (size_t)strtoull(line + 6, NULL, 10); break; }
    fclose(f);
    return kb * 1024;
}

/* Why material i got its K (one clause of the plan). */
static void plan_material(char *plan, size_t cap, int i, const brdf_params *p, const brdf_factor *f, int max_terms,
                          float term_error) {
    int K = f->K;
    double rel = (K <= f->nsigma) ? f->rel_rms[K] : 0;
    const char *name = brdf_type_name(p->type);
    if (f->lambertian || p->type == BRDF_LAMBERT) {
        plan_add(plan, cap, "  material %d %s: K=1 (rank 1: Lambertian, no view maps needed at runtime)\n", i, name);
    } else if (term_error > 0 && rel <= term_error) {
        plan_add(plan, cap, "  material %d %s: K=%d (smallest K with rel. error %.1f%% <= target %.1f%%)\n", i, name, K,
                 100 * rel, 100 * term_error);
    } else if (term_error > 0) {
        plan_add(plan, cap, "  material %d %s: K=%d (capped by max_terms %d; rel. error %.1f%% > target %.1f%%)\n", i, name,
                 K, max_terms, 100 * rel, 100 * term_error);
    } else if (K < max_terms) {
        plan_add(plan, cap, "  material %d %s: K=%d (numerical rank %d < max_terms %d; rel. error %.1f%%)\n", i, name, K, K,
                 max_terms, 100 * rel);
    } else {
        double s2 = f->nsigma > 1 && f->sigma[0][0] > 0 ? f->sigma[0][1] / f->sigma[0][0] : 0;
        plan_add(plan, cap, "  material %d %s: K=%d (max_terms; rel. error %.1f%%, sigma2/sigma1 = %.2f)\n", i, name, K,
                 100 * rel, s2);
    }
}

/* Rough CPU seconds per vertex of one gather pass: times (in CPU time) the gather rays of a few
 * sample vertices and models the decoding as (distinct neighbour vertices) x K_neighbour x N x K x 3
 * multiply-adds at PC_DECODE_NS each, plus the dense K x 3 cube accumulators. */
static double pc_estimate_gather(const prt_mesh *m, const vis_scene *vs, const brdf_factor *factors, int gres, int N,
                                 const int *sample, int nsample) {
    int nd = 6 * gres * gres;
    float *dirs = malloc(sizeof(float) * 3 * (size_t)nd);
    float *hd = malloc(sizeof(float) * 3 * (size_t)nd);
    vis_hit *hits = malloc(sizeof(vis_hit) * (size_t)nd);
    uint32_t *nb = malloc(sizeof(uint32_t) * 3 * (size_t)nd);
    if (!dirs || !hd || !hits || !nb) { free(dirs); free(hd); free(hits); free(nb); return 0; }
    for (int i = 0; i < nd; i++) cube_texel_dir(gres, i, dirs + 3 * i);
    double secs = 0;
    int step = nsample > PC_GATHER_SAMPLE ? nsample / PC_GATHER_SAMPLE : 1, count = 0;
    float eps = vis_eps(vs);
    for (int si = 0; si < nsample; si += step) {
        int v = sample[si];
        const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
        int K = factors[m->mat ? m->mat[v] : 0].K;
        int nh = 0;
        for (int i = 0; i < nd; i++)
            if (dirs[3 * i] * n[0] + dirs[3 * i + 1] * n[1] + dirs[3 * i + 2] * n[2] > 0) {
                memcpy(hd + 3 * nh, dirs + 3 * i, sizeof(float) * 3);
                nh++;
            }
        float org[3] = { p[0] + eps * n[0], p[1] + eps * n[1], p[2] + eps * n[2] };
        double t0 = pc_cpu_now();
        vis_closest_many(vs, org, hd, nh, eps, hits);
        secs += pc_cpu_now() - t0;
        int nn = 0;
        for (int i = 0; i < nh; i++)
            if (hits[i].tri >= 0)
                for (int c = 0; c < 3; c++) nb[nn++] = m->tris[3 * (size_t)hits[i].tri + c];
        /* distinct neighbours: insertion into a small sorted set would be quadratic; sort instead */
        for (int i = 1; i < nn; i++) {
            uint32_t x = nb[i];
            int j = i - 1;
            while (j >= 0 && nb[j] > x) { nb[j + 1] = nb[j]; j--; }
            nb[j + 1] = x;
        }
        int distinct = 0;
        double kn = 0;
        for (int i = 0; i < nn; i++)
            if (i == 0 || nb[i] != nb[i - 1]) {
                distinct++;
                kn += factors[m->mat ? m->mat[nb[i]] : 0].K;
            }
        secs += kn * (double)N * K * 3 * PC_DECODE_NS * 1e-9 + K * 3 * (double)CUBE_TEXELS * 2e-9;
        count++;
    }
    free(dirs); free(hd); free(hits); free(nb);
    return count ? secs / count : 0;
}

/* Validates desc and fills defaults into *d. Returns 0 or -1. */
static int pc_check_desc(const precompute_desc *in, precompute_desc *d, prt_error *err) {
    *d = in ? *in : (precompute_desc){ 0 };
    if (d->N == 0) d->N = 128;
    if (d->N < 1 || d->N > CUBE_TEXELS) return prt_fail(err, "precompute: N = %d is out of range 1..%d", d->N, CUBE_TEXELS);
    if (d->max_terms == 0) d->max_terms = 4;
    if (d->max_terms < 1 || d->max_terms > BRDF_MAX_SIGMA)
        return prt_fail(err, "precompute: max_terms = %d is out of range 1..%d", d->max_terms, BRDF_MAX_SIGMA);
    if (!(d->term_error >= 0 && d->term_error < 1))
        return prt_fail(err, "precompute: term_error = %g is out of range [0, 1)", d->term_error);
    if (d->qbits == 0) d->qbits = 8;
    if (d->qbits != 8 && d->qbits != 16 && d->qbits != 32)
        return prt_fail(err, "precompute: qbits = %d (must be 8, 16 or 32)", d->qbits);
    if (d->vis_res == 0) d->vis_res = 128;
    if (d->vis_res != 64 && d->vis_res != 128 && d->vis_res != 256)
        return prt_fail(err, "precompute: vis_res = %d (must be 64, 128 or 256)", d->vis_res);
    if (d->sh_order != 0 && (d->sh_order < 3 || d->sh_order > 10))
        return prt_fail(err, "precompute: sh_order = %d (must be 0 for wavelets or 3..10)", d->sh_order);
    if (d->bounces < 0 || d->bounces > PRT_MAX_BOUNCES)
        return prt_fail(err, "precompute: bounces = %d is out of range 0..%d", d->bounces, PRT_MAX_BOUNCES);
    if (d->gather_res == 0) d->gather_res = 32;
    if (d->gather_res < 4 || d->gather_res > 256)
        return prt_fail(err, "precompute: gather_res = %d is out of range 4..256", d->gather_res);
    if (d->bounce_threshold == 0) d->bounce_threshold = 0.01f;
    if (!(d->bounce_threshold > 0 && d->bounce_threshold < 1))
        return prt_fail(err, "precompute: bounce_threshold = %g is out of range (0, 1)", d->bounce_threshold);
    if (d->force_bounces < -1 || d->force_bounces > 1)
        return prt_fail(err, "precompute: force_bounces = %d (must be -1, 0 or 1)", d->force_bounces);
    if (d->param != BRDF_PARAM_GRID && d->param != BRDF_PARAM_POLAR)
        return prt_fail(err, "precompute: unknown BRDF parameterization %d", (int)d->param);
    return 0;
}

/* Checks that the scene can be precomputed. Returns 0 or -1. */
static int pc_check_scene(const prt_scene *s, prt_error *err) {
    const prt_mesh *m = &s->mesh;
    if (m->nverts <= 0 || m->ntris <= 0 || !m->pos || !m->nrm || !m->tris)
        return prt_fail(err, "precompute: the scene has no triangles");
    if (s->nmaterials < 1 || s->nmaterials > PRT_MAX_MATERIALS)
        return prt_fail(err, "precompute: the scene has %d materials (must be 1..%d)", s->nmaterials, PRT_MAX_MATERIALS);
    for (int v = 0; v < m->nverts; v++) {
        if (m->mat && m->mat[v] >= s->nmaterials)
            return prt_fail(err, "precompute: vertex %d has material %d but the scene has %d", v, m->mat[v], s->nmaterials);
        for (int c = 0; c < 3; c++)
            if (!isfinite(m->pos[3 * v + c]) || !isfinite(m->nrm[3 * v + c]))
                return prt_fail(err, "precompute: vertex %d has a non-finite position or normal", v);
    }
    for (int t = 0; t < 3 * m->ntris; t++)
        if (m->tris[t] >= (uint32_t)m->nverts)
            return prt_fail(err, "precompute: triangle %d indexes vertex %u of %d", t / 3, m->tris[t], m->nverts);
    return 0;
}

/* Runs the whole pipeline (see precompute.h and the file comment). */
int precompute_run(prt_scene *scene, const precompute_desc *desc_in, prt_data *out, prt_error *err) {
    double t_start = prt_now();
    memset(out, 0, sizeof *out);
    out->scene = *scene;
    memset(scene, 0, sizeof *scene);

    precompute_desc d;
    vis_scene *vs = NULL;
    float *vdir = NULL, *vdw = NULL, *ldir = NULL;
    int *order = NULL, *nvec = NULL;
    pc_scratch scratch[PC_MAX_THREADS];
    memset(scratch, 0, sizeof scratch);
    prt_transport direct = { 0 }, total = { 0 }, last = { 0 };
    bool have_lock = false;
    pc_ctx c;
    memset(&c, 0, sizeof c);
    int rc = -1;

    if (pc_check_desc(desc_in, &d, err) || pc_check_scene(&out->scene, err)) goto fail;
    const prt_mesh *m = &out->scene.mesh;
    const int nthreads = prt_thread_count(d.nthreads) > PC_MAX_THREADS ? PC_MAX_THREADS : prt_thread_count(d.nthreads);
    char *plan = out->plan;
    const size_t pcap = sizeof out->plan;
    out->vis_res = d.vis_res;
    out->gather_res = d.gather_res;
    out->sh_order = d.sh_order;

    /* 1-2. BRDF factorization (section 3.3) and the BRDF part of the plan. */
    double t0 = prt_now();
    int kmax = 1;
    for (int i = 0; i < out->scene.nmaterials; i++) {
        brdf_factor_desc fd = { .max_terms = d.max_terms, .error_target = d.term_error, .res = 0, .param = d.param };
        if (brdf_factorize(&out->scene.materials[i], &fd, &out->factors[i], err)) goto fail;
        brdf_factor *f = &out->factors[i];
        if (f->K < 1 || f->K > BRDF_MAX_SIGMA) {
            prt_fail(err, "precompute: material %d factored into %d terms", i, f->K);
            goto fail;
        }
        if (f->K > kmax) kmax = f->K;
        if (f->lambertian) {
            float up[3] = { 0, 0, 1 }, g[BRDF_MAX_SIGMA * 3];
            brdf_factor_light(f, up, g);
            memcpy(c.lambert_g[i], g, sizeof(float) * 3);
        }
    }
    out->stats.t_brdf = prt_now() - t0;

    plan_add(plan, pcap, "  scene: %d vertices, %d triangles, %d material%s, %d thread%s\n", m->nverts, m->ntris,
             out->scene.nmaterials, out->scene.nmaterials == 1 ? "" : "s", nthreads, nthreads == 1 ? "" : "s");
    plan_add(plan, pcap, "  BRDF terms (factored in %.1fs):\n", out->stats.t_brdf);
    for (int i = 0; i < out->scene.nmaterials; i++)
        plan_material(plan, pcap, i, &out->scene.materials[i], &out->factors[i], d.max_terms, d.term_error);
    if (d.sh_order > 0)
        plan_add(plan, pcap, "  basis: spherical harmonics of order %d (%d coefficients; N=%d)\n", d.sh_order,
                 d.sh_order * d.sh_order, d.N);
    else
        plan_add(plan, pcap, "  basis: Haar wavelets, N=%d of %d coefficients per vector, %d-bit\n", d.N, CUBE_TEXELS,
                 d.qbits);

    /* Tables: visibility texel directions and solid angles, lighting texel directions. */
    const int R = d.vis_res;
    vdir = prt_calloc((size_t)6 * R * R * 3, sizeof(float), err);
    vdw = vdir ? prt_calloc((size_t)R * R, sizeof(float), err) : NULL;
    ldir = vdw ? prt_calloc((size_t)CUBE_TEXELS * 3, sizeof(float), err) : NULL;
    nvec = ldir ? prt_calloc((size_t)m->nverts, sizeof(int), err) : NULL;
    order = nvec ? prt_calloc((size_t)m->nverts, sizeof(int), err) : NULL;
    if (!order) goto fail;
    for (int i = 0; i < 6 * R * R; i++) {
        float dd[3];
        cube_texel_dir(R, i, dd);
        for (int k = 0; k < 3; k++) vdir[(size_t)k * 6 * R * R + i] = dd[k];
    }
    cube_face_solid_angles(R, vdw);
    for (int i = 0; i < CUBE_TEXELS; i++) cube_texel_dir(CUBE_RES, i, ldir + 3 * i);
    for (int v = 0; v < m->nverts; v++) nvec[v] = out->factors[m->mat ? m->mat[v] : 0].K;
    if (transport_init(&direct, m->nverts, nvec, d.N, d.qbits, err)) goto fail;

    vs = vis_create(m, err);
    if (!vs) goto fail;
    for (int t = 0; t < nthreads; t++)
        if (pc_scratch_init(&scratch[t], R, kmax, err)) goto fail;

    c.mesh = m;
    c.vs = vs;
    c.factors = out->factors;
    c.t = &direct;
    c.vres = R;
    c.ss = R / CUBE_RES;
    c.sh_order = d.sh_order;
    c.vdir = vdir;
    c.vdw = vdw;
    c.ldir = ldir;
    c.order = order;
    c.scratch = scratch;
    c.total = m->nverts;
    c.progress = d.progress;
    c.progress_user = d.progress_user;
    atomic_init(&c.cancelled, 0);
    atomic_init(&c.done, 0);
    pthread_mutex_init(&c.lock, NULL);
    have_lock = true;

    /* 3a. The planning sample: a strided set of vertices computed first (kept). */
    int nsample = m->nverts < PC_SAMPLE ? m->nverts : PC_SAMPLE;
    for (int i = 0; i < nsample; i++) order[i] = (int)((long)i * m->nverts / nsample);
    double ts = prt_now();
    prt_parallel_for(nsample, 4, nthreads, pc_range, &c);
    double t_sample = prt_now() - ts;
    if (atomic_load(&c.cancelled)) { prt_fail(err, "cancelled"); goto fail; }
    long s_traced = 0, s_hits = 0;
    for (int t = 0; t < nthreads; t++) { s_traced += scratch[t].traced; s_hits += scratch[t].hits; }
    double hit_sample = s_traced ? (double)s_hits / (double)s_traced : 0;
    double est_direct = nsample ? t_sample / nsample * (m->nverts - nsample) : 0;

    /* 1b-c. Interreflections: what the scene calls for. */
    int max_b = d.force_bounces == 1 && d.bounces == 0 ? 1 : d.bounces;
    plan_add(plan, pcap, "  visibility: %d^2 rays per face (%dx%d box filter to 64^2); in a %d-vertex sample %.2f%% of rays hit geometry\n",
             R, c.ss, c.ss, nsample, 100 * hit_sample);
    if (d.force_bounces == -1) {
        plan_add(plan, pcap, "  interreflections: none (forced off)\n");
    } else if (d.force_bounces == 1) {
        plan_add(plan, pcap, "  interreflections: %d pass%s (forced, no adaptive stop)\n", max_b, max_b == 1 ? "" : "es");
    } else if (hit_sample < PC_HIT_MIN) {
        plan_add(plan, pcap, "  interreflections: none: only %.2f%% of visibility rays hit geometry (< %.1f%%: surfaces do not see each other)\n",
                 100 * hit_sample, 100 * PC_HIT_MIN);
    } else if (d.bounces == 0) {
        plan_add(plan, pcap, "  interreflections: none (bounces 0); %.1f%% of rays hit geometry, so bounces would add interreflections\n",
                 100 * hit_sample);
    } else {
        plan_add(plan, pcap, "  interreflections: up to %d pass%s while a pass carries >= %.1f%% of the direct energy (%.1f%% of rays hit geometry)\n",
                 d.bounces, d.bounces == 1 ? "" : "es", 100 * d.bounce_threshold, 100 * hit_sample);
    }
    bool plan_bounces = d.force_bounces == 1 || (d.force_bounces == 0 && d.bounces > 0 && hit_sample >= PC_HIT_MIN);
    char e1[32], e2[32];
    fmt_dur(e1, sizeof e1, est_direct + t_sample);
    if (plan_bounces) {
        /* CPU estimate turned into wall time with the share of a core the sample's threads got */
        double busy = 0, cpu = 0;
        for (int t = 0; t < nthreads; t++) { busy += scratch[t].t_busy; cpu += scratch[t].t_cpu; }
        double share = busy > 0 && cpu > 0 ? fmin(1.0, cpu / busy) : 1.0;
        double eg = pc_estimate_gather(m, vs, out->factors, d.gather_res, d.N, order, nsample) * m->nverts / nthreads / share;
        fmt_dur(e2, sizeof e2, eg);
        plan_add(plan, pcap, "  estimate: direct pass %s, each bounce pass ~%s (rough)\n", e1, e2);
    } else {
        plan_add(plan, pcap, "  estimate: direct pass %s\n", e1);
    }
    /* stderr, with the command's other status lines; nothing else has been printed in this stage yet */
    if (!d.quiet) { fprintf(stderr, "effects plan\n%s", plan); fflush(stderr); }

    /* 3b. The rest of the direct pass. */
    {
        int k = 0, si = 0;
        for (int v = 0; v < m->nverts; v++) {
            if (si < nsample && order[si] == v) { si++; continue; }
            order[nsample + k++] = v;
        }
        c.order = order + nsample;
        c.report = true;
        ts = prt_now();
        prt_parallel_for(m->nverts - nsample, PC_GRAIN, nthreads, pc_range, &c);
    }
    double t_direct = t_sample + (prt_now() - ts);
    if (atomic_load(&c.cancelled)) { prt_fail(err, "cancelled"); goto fail; }
    {
        double tv = 0, tb = 0, es = 0;
        long ec = 0;
        for (int t = 0; t < nthreads; t++) {
            out->stats.rays_traced += scratch[t].traced;
            out->stats.rays_hit += scratch[t].hits;
            tv += scratch[t].t_vis;
            tb += scratch[t].t_busy;
            es += scratch[t].err_sum;
            ec += scratch[t].err_count;
        }
        out->stats.hit_fraction = out->stats.rays_traced ? (double)out->stats.rays_hit / (double)out->stats.rays_traced : 0;
        out->stats.t_visibility = tb > 0 ? t_direct * tv / tb : 0;
        out->stats.t_transport = t_direct - out->stats.t_visibility;
        out->stats.trunc_rel_err = ec ? sqrt(es / (double)ec) : 0;
    }
    for (int t = 0; t < nthreads; t++) pc_scratch_free(&scratch[t]);
    if (transport_finish(&direct, err)) goto fail;

    /* The sample's estimate of how much surfaces see each other is checked against the full pass. */
    if (d.force_bounces == 0 && d.bounces > 0) {
        bool full = out->stats.hit_fraction >= PC_HIT_MIN;
        if (full != plan_bounces) {
            plan_add(plan, pcap, "  after the direct pass: %.2f%% of all rays hit geometry, so interreflections are %s\n",
                     100 * out->stats.hit_fraction, full ? "on after all" : "off after all");
            plan_bounces = full;
        }
    }

    /* 4. Interreflection passes (Eq. 8), adaptive unless forced. Pass b gathers pass b-1
     * (`last`, the direct set for b = 1); `total` = direct + passes so far. */
    if (plan_bounces && max_b > 0) {
        double e0 = gather_energy(&direct);
        char line[256];
        for (int b = 1; b <= max_b; b++) {
            char stage[32];
            snprintf(stage, sizeof stage, "bounce %d", b);
            gather_desc gd = { .res = d.gather_res, .nthreads = nthreads, .progress = d.progress,
                               .progress_user = d.progress_user, .stage = stage };
            prt_transport next = { 0 }, sum = { 0 };
            double tb0 = prt_now();
            if (gather_pass(out, vs, b == 1 ? &direct : &last, &gd, &next, err)) goto fail;
            double e = e0 > 0 ? gather_energy(&next) / e0 : 0;
            if (gather_sum(b == 1 ? &direct : &total, &next, nthreads, &sum, err)) { transport_free(&next); goto fail; }
            transport_free(&total);
            total = sum;
            transport_free(&last);
            last = next;
            out->stats.t_bounce[b - 1] = prt_now() - tb0;
            out->stats.bounce_energy[b - 1] = e;
            out->stats.bounces = b;
            bool stop = d.force_bounces != 1 && e < d.bounce_threshold;
            snprintf(line, sizeof line, "  bounce %d: %.2f%% of the direct energy in %.1fs%s\n", b, 100 * e,
                     out->stats.t_bounce[b - 1], stop ? " (below the threshold: last pass)" : "");
            plan_add(plan, pcap, "%s", line);
            if (stop) break;
        }
    }
    transport_free(&last);
    if (out->stats.bounces > 0) {
        out->transport = total;
        memset(&total, 0, sizeof total);
        if (d.keep_direct) {   /* the viewer's direct-only toggle */
            out->direct = direct;
            memset(&direct, 0, sizeof direct);
        }
    } else {
        out->transport = direct;
        memset(&direct, 0, sizeof direct);
    }

    out->stats.t_total = prt_now() - t_start;
    out->stats.peak_rss_bytes = pc_peak_rss();
    rc = 0;
fail:
    if (have_lock) pthread_mutex_destroy(&c.lock);
    for (int t = 0; t < PC_MAX_THREADS; t++) pc_scratch_free(&scratch[t]);
    vis_destroy(vs);
    free(vdir); free(vdw); free(ldir); free(order); free(nvec);
    transport_free(&direct);
    transport_free(&total);
    transport_free(&last);
    if (rc) prt_data_free(out);
    return rc;
}
