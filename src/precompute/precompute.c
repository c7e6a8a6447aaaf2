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
 * plan costs almost nothing extra. The estimate names every pass that will run,
 * each from its own work in CPU seconds, turned into wall time at the sample's
 * wall seconds per CPU second (its threads and the share of a core they got):
 *   - direct: the sample's CPU time a vertex times the vertices left;
 *   - each bounce pass (pc_estimate_gather): the sample's gathering rays cast and
 *     timed, their hits and neighbours' coefficients counted at measured costs,
 *     and each vector stored twice (the pass's, the sum's) at what the sample's
 *     stores took;
 *   - a view-dependent transfer's stages (its estimate op: vMF times its real
 *     direct and gathering code on a few dozen of the transfer's vertices and
 *     their slices, times the vertex and stored-slice counts).
 * Local lights add no pass: they are shaded at runtime. What each pass then took
 * is set beside the estimate in out->stats.pass and the plan's last line.
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
 * is looked up once per material; with the open sky split (opensky.h, the default)
 * such a vertex stores g (a_j - a0_j), what occluders block, where that is the
 * smaller part (pc_split), and the runtime adds the open sky g a0 back. A floor vertex of a file without
 * interreflections stores that blocked part folded, g (a_j - a0_j) / c_j with c_j = a0_j / Omega_j its
 * texel's mean cosine (open flag 2, opensky.h "The floor's fold"): the silhouette without the cosine's
 * fall to the horizon, which the runtime's light L_j c_j carries exactly. Each of the K x 3 cubes is projected by the
 * linear representation (transfer.h: its project_transport) and handed to its
 * compress op, which keeps its N best coefficients and quantizes them. The ops
 * are called once per vector channel, never per texel. Nothing here names a
 * representation: the plan asks them (configure, begin, fit, estimate) and the
 * passes call their ops.
 *
 * Stages (precompute_run): refine (optional adaptive refinement where visibility changes,
 * refine.h: it must come first, since every later stage sizes per-vertex arrays), factor
 * (BRDF factorization, the plan's BRDF lines), choose (the path per material, the
 * transfers, the linear representation's begin), setup (tables, visibility scene,
 * scratch), plan (the sample, the rest of the plan, printed), direct (the rest of
 * the pass), bounces (interreflections), view (the view-dependent transfer's passes),
 * finish (the transfers into out).
 *
 * Timing: each thread measures its time inside vis_cube and its total busy
 * time; the pass's wall time is split between "visibility" and "transport" in
 * that ratio. */
#include "precompute.h"
#include "albedo.h"
#include "check.h"
#include "checkpoint.h"
#include "cubemap.h"
#include "gather.h"
#include "opensky.h"
#include "refine.h"
#include "planfx.h"
#include "shard.h"
#include "transfer.h"
#include "visibility.h"
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define PC_GRAIN 16             /* vertices per dynamic chunk */
#define PC_SAMPLE 200           /* vertices in the planning sample */
#define PC_HIT_MIN 0.005        /* below this fraction of hitting rays, no interreflections */
#define PC_MAX_THREADS 64
/* The least weight a vector gets in a shared budget (pc_vector_weights): its area share may be 0. */
#define PC_MIN_WEIGHT 1e-3
/* Plane stride of the K x 3 transport cubes: CUBE_TEXELS floats is a multiple of 4 KB, so the
 * 12 planes' same texel would fall in one L1 set; 32 floats of padding spread them out. */
#define PC_TSTRIDE (CUBE_TEXELS + 32)
/* Gathering's costs that the plan counts rather than times (pc_estimate_gather), CPU time measured
 * with per-phase clocks in gather_vertex over the demo, the teapot and the chrome spheres (a 2-core
 * Xeon under load; per thread): combining one hit into its neighbours' weights 51-113 ns,
 * decoding one coefficient into one accumulator lane 0.44-0.64 ns (the box room's 3,400 distinct
 * neighbours a vertex against the demo's 550: a larger weight table, more cache misses). Ray
 * casting and the store are timed on the run itself. */
#define PC_COMBINE_NS 90.0
#define PC_DECODE_NS 0.55
/* A gathering pass's store, and the sum's, took 0.91-0.95 of what the same op took in the direct
 * pass (the demo, the teapot: 224-246 us against 243-263 us a vector): the direct pass's comes
 * after the visibility cube and the transport cubes have gone through the cache. */
#define PC_STORE_HOT 0.92

/* qsort order of uint32_t. */
static int pc_cmp_u32(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

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
    float *w0;          /* [vres^2] max(n.w,0) dw of one face (the open sky split only) */
    float *acc;         /* [CUBE_TEXELS] box-filtered a_j */
    float *acc0;        /* [CUBE_TEXELS] the same with V = 1, a0_j (the open sky split only) */
    bool fold;          /* this vertex is the floor's and the transfer folds it (pc_ctx.fold_first) */
    float *T;           /* [Kmax * 3][PC_TSTRIDE] planar transport cubes */
    float *wav;         /* [3 * CUBE_TEXELS] one vector's coefficients (planar R, G, B) */
    float *wav0;        /* [CUBE_TEXELS] the open sky's coefficients P(a0) (its energy only) */
    float *tmp;         /* [TRANSFER_SCRATCH_FLOATS] projection scratch */
    void *tscratch;     /* transport_store scratch */
    double t_vis, t_busy;   /* seconds inside vis_cube / in total */
    double t_cpu;           /* CPU seconds of the thread in pc_range (t_cpu / t_busy: share of a core it got) */
    double t_store;         /* CPU seconds of the thread in the compress op (truncation + quantization) */
    long n_store;           /* vectors it compressed: the plan's cost of a stored vector (pc_estimate_gather) */
} pc_scratch;

/* Shared state of the direct pass. */
typedef struct pc_ctx {
    const prt_mesh *mesh;
    const vis_scene *vs;
    const brdf_factor *factors;
    float lambert_g[PRT_MAX_MATERIALS][3];   /* constant light map of a Lambertian factor */
    prt_transport *t;
    const transfer_linear *lin;     /* the linear representation's ops (transfer.h) */
    const transfer_config *cfg;
    uint64_t materials;             /* materials it shades (the others get no vectors) */
    int vres, ss;
    bool open;              /* the open sky split (opensky.h): Lambertian vectors store what is blocked */
    int fold_first;         /* the floor's first vertex when its blocked parts are folded (pc_fold_first), else -1 */
    float *vweight;         /* the shared budget's weight per vector (pc_vector_weights), or NULL; pc_fold_weight scales a folded one's */
    float lwinv[CUBE_RES * CUBE_RES];   /* 1 / the lighting texels' solid angles (pc_split) */
    const float *vdir;      /* [3][6 vres^2] unit directions of the visibility texels (planar x, y, z) */
    const float *vdw;       /* [vres^2] their solid angles (same on every face) */
    const float *ldir;      /* [CUBE_TEXELS][3] lighting texel centre directions */
    const transfer_texel_rays *rays; /* NULL, or the texels integrated along rays (the representation's) */
    const int *order;       /* vertices to process, indexed by the parallel-for range */
    pc_scratch *scratch;    /* [nthreads] */
    /* per vertex, so that the file's statistics are summed in vertex order whatever the threads
     * and whether restored from a checkpoint or computed */
    ckpt_vstats *vst;       /* [nverts] rays and truncation error */
    double *cost;           /* [nverts] seconds each computed vertex took (the split across ranks) */
    uint8_t *restored;      /* [nverts] 1: restored from the checkpoint */
    prt_checkpoint *ck;     /* NULL: none */
    /* progress */
    pthread_mutex_t lock;
    atomic_int cancelled;
    atomic_long done;
    long total;             /* the pass's vertices over every rank */
    struct shard_pass *sp;  /* the split pass's progress over the ranks (shard.h); NULL in the sample */
    long base;              /* done vertices that are not this rank's share (the sample, on ranks > 0) */
    atomic_long others;     /* rank 0: vertices the other ranks have done, as last heard */
    prt_progress_fn progress;
    void *progress_user;
    bool report;            /* false during the planning sample, so the plan prints before any bar */
} pc_ctx;

static void pc_scratch_free(pc_scratch *s) {
    free(s->vis); free(s->w); free(s->w0); free(s->acc); free(s->acc0); free(s->T); free(s->wav); free(s->wav0); free(s->tmp); free(s->tscratch);
    memset(s, 0, sizeof *s);
}

/* Allocates one thread's scratch. Returns 0 or -1 (OOM). */
static int pc_scratch_init(pc_scratch *s, int vres, int kmax, prt_error *err) {
    memset(s, 0, sizeof *s);
    size_t ct = CUBE_TEXELS;
    s->vis = prt_calloc((size_t)6 * vres * vres, 1, err);
    s->w = s->vis ? prt_calloc((size_t)vres * vres, sizeof(float), err) : NULL;
    s->w0 = s->w ? prt_calloc((size_t)vres * vres, sizeof(float), err) : NULL;
    s->acc0 = s->w0 ? prt_calloc(ct, sizeof(float), err) : NULL;
    s->acc = s->acc0 ? prt_calloc(ct, sizeof(float), err) : NULL;
    s->T = s->acc ? prt_calloc((size_t)kmax * 3 * PC_TSTRIDE, sizeof(float), err) : NULL;
    s->wav = s->T ? prt_calloc(3 * ct, sizeof(float), err) : NULL;
    s->wav0 = s->wav ? prt_calloc(ct, sizeof(float), err) : NULL;
    s->tmp = s->wav0 ? prt_calloc(TRANSFER_SCRATCH_FLOATS, sizeof(float), err) : NULL;
    s->tscratch = s->tmp ? prt_calloc(transport_scratch_size(), 1, err) : NULL;
    if (!s->tscratch) { pc_scratch_free(s); return -1; }
    return 0;
}

/* One face's sub-texel values w [vres^2] summed over each lighting texel's ss x ss sub-texels into acc. */
static void pc_box(const float *restrict w, float *restrict acc, int R, int ss) {
    if (ss == 1) {
        memcpy(acc, w, sizeof(float) * CUBE_RES * CUBE_RES);
        return;
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

/* a_j for every lighting texel (Eq. 3's V (n.w) dw summed over the texel's sub-texels) into s->acc;
 * with the open sky split (opensky.h) also a0_j, the same with V = 1, into s->acc0. */
static void pc_box_filter(const pc_ctx *c, pc_scratch *s, const float n[3]) {
    const int R = c->vres, ss = c->ss;
    for (int f = 0; f < 6; f++) {
        float *acc = s->acc + f * CUBE_RES * CUBE_RES, *acc0 = c->open ? s->acc0 + f * CUBE_RES * CUBE_RES : NULL;
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
            if (acc0) memset(acc0, 0, sizeof(float) * CUBE_RES * CUBE_RES);
            continue;
        }
        const uint8_t *restrict v = s->vis + (size_t)f * R * R;
        const size_t plane = (size_t)6 * R * R;
        const float *restrict dx = c->vdir + (size_t)f * R * R;
        const float *restrict dy = dx + plane, *restrict dz = dy + plane, *restrict dw = c->vdw;
        const float nx = n[0], ny = n[1], nz = n[2];
        float *restrict w = s->w, *restrict w0 = s->w0;
        if (acc0) {
            for (int i = 0; i < R * R; i++) {
                float nd = nx * dx[i] + ny * dy[i] + nz * dz[i];
                w0[i] = (nd > 0.f ? nd : 0.f) * dw[i];
                w[i] = (float)v[i] * w0[i];
            }
            pc_box(w0, acc0, R, ss);
        } else {
            /* branch-free so it vectorizes: V is 0 below the horizon anyway */
            for (int i = 0; i < R * R; i++) {
                float nd = nx * dx[i] + ny * dy[i] + nz * dz[i];
                w[i] = (float)v[i] * (nd > 0.f ? nd : 0.f) * dw[i];
            }
        }
        pc_box(w, acc, R, ss);
    }
}

/* The texels the representation integrates along rays (transfer.h: transfer_texel_rays):
 * a_j = Omega_j / M sum over its M rays w_m of V(w_m) max(n.w_m, 0),
 * Eq. 3 integrated over texel j against the light inside it rather than over its area, so that L_j a_j
 * is the integral of L V (n.w) where the light is the prior's. The rays are counted in vs. */
static void pc_weighted_texels(const pc_ctx *c, pc_scratch *s, const float p[3], const float n[3], ckpt_vstats *vs) {
    for (int k = 0; k < c->rays->n; k++) {
        uint8_t open[TRANSFER_RAYS];
        const float (*d)[3] = c->rays->dir[k];
        long nt = vis_open_many(c->vs, p, n, &d[0][0], TRANSFER_RAYS, open), opened = 0;
        double a = 0;
        for (int m = 0; m < TRANSFER_RAYS; m++)   /* open only where traced, so n.w > 0 there */
            if (open[m]) {
                a += n[0] * d[m][0] + n[1] * d[m][1] + n[2] * d[m][2];
                opened++;
            }
        s->acc[c->rays->texel[k]] = (float)(a * c->rays->omega[k] / TRANSFER_RAYS);
        vs->traced += nt;
        vs->hits += nt - opened;
    }
}

/* The open sky split for this vertex (opensky.h): the blocked part a0 - a is stored when it is the smaller
 * of the two in the solid-angle measure's L2 (sum over texels of (x_j / w_j)^2 w_j), the whole
 * transport a otherwise: an open vertex stores nothing, and one in a contact shadow, which sees less
 * than it misses, keeps its few visible directions exactly dark elsewhere instead of a cancellation's
 * truncation and rounding (a floor under the bunny: 0.0096 where the reference is 4e-5). */
static bool pc_split(const pc_ctx *c, const pc_scratch *s) {
    double vis = 0, blk = 0;
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < CUBE_RES * CUBE_RES; i++) {
            int j = f * CUBE_RES * CUBE_RES + i;
            double a = s->acc[j], b = (double)s->acc0[j] - a, wi = c->lwinv[i];
            vis += a * a * wi, blk += b * b * wi;
        }
    return blk <= vis;
}

/* T_k(j) = g_k(w_j) a_j (Eq. 3) for the K terms of material mat into the planar cubes s->T; with the open
 * sky split where pc_split chooses it (*open set to 1), g (a_j - a0_j) instead. */
static void pc_transport_cubes(const pc_ctx *c, pc_scratch *s, const float n[3], int mat, int32_t *open) {
    const brdf_factor *fac = &c->factors[mat];
    const size_t ct = CUBE_TEXELS;
    *open = 0;
    if (fac->lambertian) {
        const float *g = c->lambert_g[mat];
        *open = c->open && pc_split(c, s) ? (s->fold ? OPENSKY_FOLDED : OPENSKY_SPLIT) : 0;
        for (int ch = 0; ch < 3; ch++) {
            float *T = s->T + (size_t)ch * PC_TSTRIDE;
            if (*open && s->fold)   /* folded: over the texel's mean cosine, which the runtime's light takes */
                for (size_t j = 0; j < ct; j++) {
                    float cj = s->acc0[j] * c->lwinv[j % (CUBE_RES * CUBE_RES)];
                    T[j] = cj > 0 ? g[ch] * (s->acc[j] - s->acc0[j]) / cj : 0.f;
                }
            else if (*open)   /* what the occluders block, negated: the runtime adds g E(n) (opensky.h) */
                for (size_t j = 0; j < ct; j++) T[j] = g[ch] * (s->acc[j] - s->acc0[j]);
            else
                for (size_t j = 0; j < ct; j++) T[j] = g[ch] * s->acc[j];
        }
        return;
    }
    /* Face by face: the K x 3 face slices are zeroed in bulk, then g_k is looked up at each
     * lit texel's centre and written to the slices in step (12 store streams, padded apart). */
    float sv[3], tv[3], g[BRDF_MAX_SIGMA * 3];
    brdf_frame(n, sv, tv);
    const int K3 = 3 * fac->K, F = CUBE_RES * CUBE_RES;
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

/* |x|^2 over 3 CUBE_TEXELS floats: 8 independent float accumulators (no dependency chain; the
 * length is a multiple of 8), summed in double. With y, x.y instead. */
static double pc_dot(const float *x, const float *y, size_t n) {
    float p8[8] = { 0, 0, 0, 0, 0, 0, 0, 0 };
    for (size_t i = 0; i < n; i += 8)
        for (int q = 0; q < 8; q++) p8[q] += x[i + q] * y[i + q];
    double d = 0;
    for (int q = 0; q < 8; q++) d += p8[q];
    return d;
}

/* |vector|^2 of vertex v's whole transport (K = 1) whose stored part is s->wav: with the open sky split,
 * |P(R) + g P(a0)|^2 per channel, P(a0) projected into s->wav0 once; a folded vector's own (its space is
 * not the light's, and a file that folds has no interreflections to compare with). */
static double pc_whole_norm2(const pc_ctx *c, pc_scratch *s, int mat, int open) {
    const size_t ct = CUBE_TEXELS;
    if (open != 1) return pc_dot(s->wav, s->wav, 3 * ct);
    c->lin->project_transport(c->cfg, s->acc0, s->wav0, s->tmp);
    double b2 = pc_dot(s->wav0, s->wav0, ct), n2 = 0;
    for (int ch = 0; ch < 3; ch++) {
        const float *x = s->wav + (size_t)ch * ct;
        double g = c->lambert_g[mat][ch];
        n2 += pc_dot(x, x, ct) + g * g * b2 + 2 * g * pc_dot(x, s->wav0, ct);
    }
    return n2;
}

/* A folded vector's share of a shared budget as if unfolded: its weight times |P(g (a - a0))|^2 / |P(F)|^2,
 * the blocked part's energy over the folded one's (s->wav, projected). The selection weighs a
 * coefficient's energy, and folding inflates the blocked part near the horizon by 1 / c_j, where the
 * light it meets is c_j L_j: unscaled, the floor's vectors take the models' coefficients. Called after
 * the projection, so the first transport plane is free for a - a0 and s->wav0 for its projection. */
static void pc_fold_weight(const pc_ctx *c, pc_scratch *s, int mat, uint32_t q) {
    const float *g = c->lambert_g[mat];
    for (int j = 0; j < CUBE_TEXELS; j++) s->T[j] = s->acc[j] - s->acc0[j];
    c->lin->project_transport(c->cfg, s->T, s->wav0, s->tmp);
    double eb = pc_dot(s->wav0, s->wav0, CUBE_TEXELS) * ((double)g[0] * g[0] + (double)g[1] * g[1] + (double)g[2] * g[2]);
    double ef = pc_dot(s->wav, s->wav, 3 * (size_t)CUBE_TEXELS);
    if (ef > 0) c->vweight[q] = (float)(c->vweight[q] * (eb / ef));
}

/* Projection (the representation's op, once per vector channel) and compression of vertex v's
 * K vectors, with the truncation + quantization error statistics (relative to the whole vector,
 * the open sky included) and the whole vectors' energy. */
static void pc_store(const pc_ctx *c, pc_scratch *s, int v, int mat, ckpt_vstats *vs) {
    const size_t ct = CUBE_TEXELS;
    const int K = c->factors[mat].K;
    uint32_t vec0 = c->t->vec_first[v];
    for (int k = 0; k < K; k++) {
        for (int ch = 0; ch < 3; ch++)
            c->lin->project_transport(c->cfg, s->T + (size_t)(k * 3 + ch) * PC_TSTRIDE, s->wav + (size_t)ch * ct, s->tmp);
        if (vs->open == OPENSKY_FOLDED && c->vweight) pc_fold_weight(c, s, mat, vec0);   /* K = 1: Lambertian */
        double norm2 = pc_whole_norm2(c, s, mat, vs->open);
        double ts = pc_cpu_now();
        double e2 = c->lin->compress(c->t, (int)(vec0 + (uint32_t)k), s->wav, s->wav + ct, s->wav + 2 * ct, s->tscratch);
        s->t_store += pc_cpu_now() - ts;
        s->n_store++;
        vs->energy += norm2;
        if (norm2 > 0) {
            vs->err += e2 / norm2;
            vs->errs++;
        }
    }
}

/* The full direct computation of vertex v: visibility, Eq. 3, projection, storage, its statistics
 * and its checkpoint record. A vertex whose material the transfer does not shade has no vectors
 * (and no rays cast); one restored from the checkpoint is done. */
static void pc_vertex(pc_ctx *c, pc_scratch *s, int v) {
    const prt_mesh *m = c->mesh;
    const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
    int mat = m->mat ? m->mat[v] : 0;
    if (!((c->materials >> mat) & 1) || c->restored[v]) return;
    double t0 = prt_now();
    long tr = 0, hi = 0;
    vis_cube(c->vs, p, n, c->vres, s->vis, &tr, &hi);
    double t1 = prt_now();
    ckpt_vstats *vs = &c->vst[v];
    memset(vs, 0, sizeof *vs);
    vs->traced = tr;
    vs->hits = hi;
    pc_box_filter(c, s, n);
    if (c->rays) pc_weighted_texels(c, s, p, n, vs);
    s->fold = c->fold_first >= 0 && v >= c->fold_first && n[0] == 0 && n[1] == 1 && n[2] == 0;
    pc_transport_cubes(c, s, n, mat, &vs->open);
    pc_store(c, s, v, mat, vs);
    ckpt_add(c->ck, 0, c->t, v, vs);
    double t2 = prt_now();
    c->cost[v] = t2 - t0;
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
    if (end > begin)   /* streamed: the chunk's staged vectors leave memory (order is increasing) */
        transport_release(c->t, (int)c->t->vec_first[c->order[begin]], (int)c->t->vec_first[c->order[end - 1] + 1]);
    s->t_cpu += pc_cpu_now() - cpu0;
    atomic_fetch_add(&c->done, end - begin);
    if (c->sp && thread == 0)   /* MPI from the caller's thread only (prt_parallel_for's thread 0) */
        atomic_store(&c->others, shard_pass_poll(c->sp, atomic_load(&c->done) - c->base));
    if (c->progress && c->report) {
        pthread_mutex_lock(&c->lock);
        /* read under the lock, so the fractions reported rise; others only grows */
        long done = atomic_load(&c->done) + atomic_load(&c->others);
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

/* CPU seconds per vertex of one gathering pass and its sum (gather.c), from the work its vertices
 * do: the sample vertices' gathering rays are cast and timed, and the rest is counted on their
 * hits: PC_COMBINE_NS a hit, PC_DECODE_NS a decoded coefficient lane (each distinct neighbour's
 * K_y vectors of about N coefficients, times the vertex's accumulator lanes: 4 at K = 1, 3K
 * else), and each of its K vectors stored twice: the pass's truncation + quantization (store_cpu,
 * what the direct pass's sample measured for the same op; zero_cpu when no ray hit, an empty
 * vector) and the sum's (gather_sum, store_cpu). */
static double pc_estimate_gather(const prt_mesh *m, const vis_scene *vs, const brdf_factor *factors, int gres, int N,
                                 double store_cpu, double zero_cpu, const int *sample, int nsample) {
    int nd = 6 * gres * gres;
    float *dirs = malloc(sizeof(float) * 3 * (size_t)nd);
    float *hd = malloc(sizeof(float) * 3 * (size_t)nd);
    vis_hit *hits = malloc(sizeof(vis_hit) * (size_t)nd);
    uint32_t *nb = malloc(sizeof(uint32_t) * 3 * (size_t)nd);
    if (!dirs || !hd || !hits || !nb) { free(dirs); free(hd); free(hits); free(nb); return 0; }
    for (int i = 0; i < nd; i++) cube_texel_dir(gres, i, dirs + 3 * i);
    double secs = 0;
    int count = 0;
    float eps = vis_eps(vs);
    for (int si = 0; si < nsample; si++) {   /* every one: the hits vary widely from vertex to vertex */
        int v = sample[si];
        const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
        int K = factors[m->mat ? m->mat[v] : 0].K;
        int nh = 0, nhit = 0;
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
            if (hits[i].tri >= 0) {
                nhit++;
                for (int c = 0; c < 3; c++) nb[nn++] = m->tris[3 * (size_t)hits[i].tri + c];
            }
        qsort(nb, (size_t)nn, sizeof *nb, pc_cmp_u32);   /* distinct neighbours */
        double kn = 0;
        for (int i = 0; i < nn; i++)
            if (i == 0 || nb[i] != nb[i - 1]) kn += factors[m->mat ? m->mat[nb[i]] : 0].K;
        int lanes = K == 1 ? 4 : 3 * K;
        secs += nhit * PC_COMBINE_NS * 1e-9 + kn * (double)N * lanes * PC_DECODE_NS * 1e-9 +
                K * PC_STORE_HOT * (store_cpu + (nhit ? store_cpu : zero_cpu));
        count++;
    }
    free(dirs); free(hd); free(hits); free(nb);
    return count ? secs / count : 0;
}

/* The representations a desc names, configured (pc_check_desc). */
typedef struct pc_reps {
    const transfer_ops *lops;   /* the linear one */
    const transfer_ops *vops;   /* the view-dependent one, or NULL: none */
    transfer_setup lsetup;      /* what the linear one was configured from (its begin reads it again) */
    transfer_config lcfg, vcfg;
} pc_reps;

/* desc.basis (NULL: the default linear one) and desc.view (NULL: the default view-dependent one,
 * "none": none) looked up, and each configured from its options. Returns 0 or -1. */
static int pc_configure(const precompute_desc *d, pc_reps *rp, prt_error *err) {
    char names[256];
    rp->lops = d->basis ? transfer_find(d->basis) : transfer_default(TRANSFER_LINEAR);
    if (!rp->lops || rp->lops->kind != TRANSFER_LINEAR) {
        transfer_names(TRANSFER_LINEAR, names, sizeof names);
        return prt_fail(err, "precompute: unknown basis '%s' (one of %s)", d->basis ? d->basis : "(default)", names);
    }
    bool none = d->view && !strcmp(d->view, "none");
    rp->vops = none ? NULL : d->view ? transfer_find(d->view) : transfer_default(TRANSFER_VIEW);
    if (d->view && !none && (!rp->vops || rp->vops->kind != TRANSFER_VIEW)) {
        transfer_names(TRANSFER_VIEW, names, sizeof names);
        return prt_fail(err, "precompute: unknown view-dependent representation '%s' (one of %s, none)", d->view, names);
    }
    if (d->glossy == PRECOMPUTE_GLOSSY_VIEW && !rp->vops)
        return prt_fail(err, "precompute: the view path was asked for, but there is no view-dependent representation");
    rp->lsetup = (transfer_setup){ .options = d->basis_options, .N = d->N, .qbits = d->qbits, .light_prior = d->light_prior,
                                   .light_prior_scene = d->light_prior_scene };
    prt_error e2;
    if (rp->lops->configure(&rp->lsetup, &rp->lcfg, &e2)) return prt_fail(err, "precompute: %s", e2.msg);
    transfer_setup vs = { .options = d->view_options };
    memset(&rp->vcfg, 0, sizeof rp->vcfg);
    if (rp->vops && rp->vops->configure(&vs, &rp->vcfg, &e2)) return prt_fail(err, "precompute: %s", e2.msg);
    return 0;
}

/* Validates desc and fills defaults into *d, the representations into *rp. Returns 0 or -1. */
static int pc_check_desc(const precompute_desc *in, precompute_desc *d, pc_reps *rp, prt_error *err) {
    *d = in ? *in : (precompute_desc){ 0 };
    if (d->max_terms == 0) d->max_terms = 4;
    if (d->max_terms < 1 || d->max_terms > BRDF_MAX_SIGMA)
        return prt_fail(err, "precompute: max_terms = %d is out of range 1..%d", d->max_terms, BRDF_MAX_SIGMA);
    if (!(d->term_error >= 0 && d->term_error < 1))
        return prt_fail(err, "precompute: term_error = %g is out of range [0, 1)", d->term_error);
    if (d->vis_res == 0) d->vis_res = 128;
    if (d->vis_res != 64 && d->vis_res != 128 && d->vis_res != 256)
        return prt_fail(err, "precompute: vis_res = %d (must be 64, 128 or 256)", d->vis_res);
    if (d->bounces < 0 || d->bounces > PRT_MAX_BOUNCES)
        return prt_fail(err, "precompute: bounces = %d is out of range 0..%d", d->bounces, PRT_MAX_BOUNCES);
    if (d->bounces == 0) d->bounces = PRECOMPUTE_DEFAULT_BOUNCES;
    if (d->glossy < PRECOMPUTE_GLOSSY_AUTO || d->glossy > PRECOMPUTE_GLOSSY_VIEW)
        return prt_fail(err, "precompute: unknown glossy path %d", (int)d->glossy);
    if (d->gather_res == 0) d->gather_res = 32;
    if (d->gather_res < 4 || d->gather_res > 256)
        return prt_fail(err, "precompute: gather_res = %d is out of range 4..256", d->gather_res);
    if (d->bounce_threshold == 0) d->bounce_threshold = 0.01f;
    if (!(d->bounce_threshold > 0 && d->bounce_threshold < 1))
        return prt_fail(err, "precompute: bounce_threshold = %g is out of range (0, 1)", d->bounce_threshold);
    if (d->force_bounces < -1 || d->force_bounces > 1)
        return prt_fail(err, "precompute: force_bounces = %d (must be -1, 0 or 1)", d->force_bounces);
    if (d->force_local_bounce < -1 || d->force_local_bounce > 1 || d->force_highlights < -1 || d->force_highlights > 1)
        return prt_fail(err, "precompute: force_local_bounce = %d, force_highlights = %d (each must be -1, 0 or 1)",
                        d->force_local_bounce, d->force_highlights);
    if (d->force_refine < -1 || d->force_refine > 1)
        return prt_fail(err, "precompute: force_refine = %d (must be -1, 0 or 1)", d->force_refine);
    if (!(d->refine_threshold >= 0 && d->refine_threshold < 1))
        return prt_fail(err, "precompute: refine_threshold = %g is out of range [0, 1)", d->refine_threshold);
    if (d->checkpoint && shard_size(d->shard) > 1)   /* each rank would log only its own vertices */
        return prt_fail(err, "precompute: a checkpoint (--resume) cannot be combined with %d MPI ranks", shard_size(d->shard));
    if (d->refine_budget < 0) return prt_fail(err, "precompute: refine_budget = %d is negative", d->refine_budget);
    if (d->param != BRDF_PARAM_GRID && d->param != BRDF_PARAM_POLAR)
        return prt_fail(err, "precompute: unknown BRDF parameterization %d", (int)d->param);
    return pc_configure(d, rp, err);
}

int precompute_desc_check(const precompute_desc *desc, prt_error *err) {
    precompute_desc d;
    pc_reps rp;
    return pc_check_desc(desc, &d, &rp, err);
}

int precompute_desc_apply_scene(precompute_desc *d, const prt_scene *s, unsigned keys, prt_error *err) {
    if (keys & ~PRECOMPUTE_SCENE_ALL) return prt_fail(err, "precompute: unknown scene keys 0x%x", keys);
    if ((keys & PRECOMPUTE_SCENE_LIGHT_PRIOR) && !d->light_prior && s->light_prior[0]) {
        d->light_prior = s->light_prior;
        d->light_prior_scene = true;
    }
    if ((keys & PRECOMPUTE_SCENE_REFINE) && s->refine.on) {
        d->refine_threshold = s->refine.threshold > 0 ? s->refine.threshold : REFINE_THRESHOLD;
        d->refine_budget = s->refine.budget;
        d->refine_parts = s->refine.models ? REFINE_ALL : 0;
    }
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

/* Everything one run holds between its stages (precompute_run). */
typedef struct pc_run {
    precompute_desc d;
    prt_data *out;
    char *plan;
    size_t pcap;
    int nthreads, kmax;
    pc_reps rp;                 /* the representations (pc_check_desc) */
    char *prior;                /* desc.light_prior copied (it may point into the scene, which moves) */
    prt_transfer *tr;           /* the linear transfer (every material; in out, filled by finish) */
    transfer_linear_run lrun;   /* its begin's decisions for this run (its end frees them) */
    prt_transfer *vtr;          /* the view-dependent transfer (the materials on the view path), or NULL */
    vis_scene *vs;
    float *vdir, *vdw, *ldir;   /* texel direction tables (pc_ctx) */
    int *order, *nvec;
    int *first;                 /* [ranks + 1] this pass's vertex range per rank (shard.h) */
    double *cost;               /* [nverts] per-vertex seconds: the direct pass's, then each gathering pass's */
    pc_scratch scratch[PC_MAX_THREADS];
    prt_transport direct, total, last;
    int fold_first;             /* pc_ctx.fold_first (pc_fold_first) */
    bool refine_floor;          /* the plan refines the floor after the models (plan_refine, pc_refine_floor) */
    pc_ctx c;
    ckpt_vstats *vst;           /* pc_ctx's per-vertex statistics */
    uint8_t *restored;
    prt_checkpoint *ck;
    bool have_lock;
    int nsample, max_b;
    double t_sample, hit_sample;
    double cpu_sample;          /* process CPU seconds of the planning sample (the direct pass's) */
    double wall_per_cpu;        /* the sample's wall seconds per CPU second: the estimates' conversion */
    bool plan_bounces;
    bool streamed;              /* the passes' staging goes through temporary files (pc_stream) */
    uint64_t vmask;             /* the materials on the view path (pc_paths) */
    float *vweight;             /* [direct.nvecs] the shared budget's weight per vector (pc_vector_weights) */
    char *later;                /* [pcap] the BRDF and path lines, decided before refinement, printed after
                                 * the scene line that follows it (pc_choose) */
} pc_run;

/* The passes a transfer may make, the direct one and the bounces: the bounces' plan comes later (it
 * measures the direct pass), so its upper bound. */
static int pc_max_passes(const pc_run *r) {
    return r->d.force_bounces == -1 ? 1 : 1 + (r->d.force_bounces == 1 && r->d.bounces == 0 ? 1 : r->d.bounces);
}

/* Why the floor's blocked parts are not folded (pc_transport_cubes; opensky.h "The floor's fold"): "" where
 * there is no Lambertian floor with the open sky split, a reason for the plan, or NULL: they are. Folded
 * only in a file without interreflections (a gathering pass reads a neighbour's vector in the light's
 * space, and a bounce has no fold: light from near the floor's horizon reaches it by way of the models),
 * without a light prior (its selection and refit weigh the light, not the folded light) and where the
 * runtime lights the sparse sets themselves. */
static const char *pc_fold_why(const pc_run *r) {
    const prt_scene *s = &r->out->scene;
    if (r->d.no_open_sky || s->floor_first_vertex < 0 || s->floor_first_vertex >= s->mesh.nverts) return "";
    int fm = s->mesh.mat ? s->mesh.mat[s->floor_first_vertex] : 0;
    if (!r->out->factors[fm].lambertian) return "";
    if (r->d.no_fold) return "--no-fold";
    if (r->rp.lops->linear->light) return "the representation lights its own model";
    if (r->rp.lsetup.light_prior && r->rp.lsetup.light_prior[0]) return "the light prior weighs the light itself";
    if (pc_max_passes(r) > 1) return "interreflections read the floor's vectors in the light's space";
    return NULL;
}

/* The plan's refinement line from the receivers (planfx.h) when nothing asked for or ruled out
 * refinement; with force_refine 1 it also sets d's threshold and parts where the floor is coarser
 * than the penumbra. By default it reports the need only (PLANFX_REFINE_MEASURED says why). */
static void plan_refine(pc_run *r) {
    planfx_receivers rc;
    planfx_measure_receivers(&r->out->scene, &rc);
    const char *k = "  refinement:";
    if (!rc.floor || !rc.models) {
        plan_add(r->plan, r->pcap, "%s off: %s\n", k, !rc.floor ? "no floor (the models receive their own shadows at their vertices)"
                                                             : "nothing stands over the floor");
        return;
    }
    if (!rc.refine) {
        plan_add(r->plan, r->pcap, "%s off: the floor's vertex spacing %.3g <= the penumbra of a sun %.3g at the models' height %.3g\n", k,
                 rc.spacing, rc.penumbra, rc.height);
        return;
    }
    int n = r->out->scene.mesh.nverts, budget = r->d.refine_budget > 0 ? r->d.refine_budget : (int)(REFINE_BUDGET_FACTOR * n);
    bool apply = r->d.force_refine == 1;
    if (!apply && !pc_fold_why(r)) {   /* folded: its vertices are what blurs a low sun's shadow (PLANFX_REFINE_MEASURED) */
        plan_add(r->plan, r->pcap, "%s the floor's too: vertex spacing %.3g > the penumbra of a sun %.3g at the models' height %.3g, "
                 "and its shadows are folded (a low sun's silhouette kept), so its vertices blur them\n", k, rc.spacing, rc.penumbra,
                 rc.height);
        r->refine_floor = true;
        return;
    }
    plan_add(r->plan, r->pcap, "%s %s: vertex spacing %.3g > ", k, apply ? "on for the floor" : "off", rc.spacing);
    if (rc.spacing > rc.penumbra)
        plan_add(r->plan, r->pcap, "the penumbra of a sun %.3g at the models' height %.3g", rc.penumbra, rc.height);
    else
        plan_add(r->plan, r->pcap, "a local light's hard shadow edge");
    if (apply)
        plan_add(r->plan, r->pcap, "; budget %d vertices (%.2gx: the passes cost up to that much more)\n", budget, (double)budget / n);
    else
        plan_add(r->plan, r->pcap, ", but %s (--refine, --refine-auto or the scene's \"refine\" asks for it)\n", PLANFX_REFINE_MEASURED);
    if (!apply) return;
    r->d.refine_threshold = REFINE_THRESHOLD;
    r->d.refine_parts = REFINE_FLOOR;
}

/* Runs refine_scene with rd's threshold, budget and parts, and prints its line. Returns 0 or -1. */
static int pc_refine_run(pc_run *r, refine_desc rd, prt_error *err) {
    rd.nthreads = r->nthreads;
    rd.progress = r->d.progress;
    rd.progress_user = r->d.progress_user;
    refine_stats st;
    if (refine_scene(&r->out->scene, &rd, &st, err)) return -1;
    r->out->stats.t_refine += st.seconds;
    char line[512];
    refine_describe(&st, line, sizeof line);
    plan_add(r->plan, r->pcap, "  %s\n", line);
    return 0;
}

/* The vertices of per_vertex vectors each that the file's byte budget (PLANFX_FILE_BYTES) holds beside the
 * scene's vectors, by the linear transfer's vector_bytes; -1 where it has no byte model. */
static long pc_file_room(const pc_run *r, double per_vertex) {
    if (!r->rp.lops->linear->vector_bytes) return -1;
    const prt_mesh *m = &r->out->scene.mesh;
    double vecs = 0;
    for (int v = 0; v < m->nverts; v++) vecs += r->out->factors[m->mat ? m->mat[v] : 0].K;
    const double vb = r->rp.lops->linear->vector_bytes(&r->rp.lcfg), lin = (PLANFX_FILE_BYTES - vecs * vb) / (per_vertex * vb);
    return lin > 0 ? (long)lin : 0;
}

/* Refines parts where visibility changes: n vertices ("its" the possessive for them) growing by at most
 * (growth - 1) n within room (why: what binds it), with the plan's line "refinement of WHAT"; off where
 * that is under 5% of n. Returns 0 or -1. */
static int pc_refine_grow(pc_run *r, const char *what, const char *its, long n, double growth, long room, const char *why,
                          int parts, prt_error *err) {
    long grow = (long)(growth * n) - n, extra = room < grow ? room : grow;
    if (extra < n / 20) {
        plan_add(r->plan, r->pcap, "  refinement of %s: off: %s holds %ld more vertices than %s %ld\n", what, why, room, its, n);
        return 0;
    }
    char cap[48];
    snprintf(cap, sizeof cap, "at most %.2gx", growth);
    plan_add(r->plan, r->pcap, "  refinement of %s: %s %ld vertices may grow by %ld (%s), where visibility changes across %s edges\n", what,
             its, n, extra, extra < grow ? why : cap, its);
    return pc_refine_run(r, (refine_desc){ .threshold = REFINE_THRESHOLD, .budget = r->out->scene.mesh.nverts + (int)extra, .parts = parts },
                         err);
}

/* The most vertices the models may gain within the plan's bytes (PLANFX_FILE_BYTES): the linear
 * transfer's (its vector_bytes per vector, each new vertex with the models' mean vector count); and
 * for the view path's, the room the view grid's byte budget leaves at the level
 * their unrefined count settles (settle: so refinement never coarsens the view grid, which costs more
 * than the vertices gain; every new vertex counted as one of theirs). *why gets the binding limit. */
static long pc_model_room(pc_run *r, long models, const char **why) {
    const prt_mesh *m = &r->out->scene.mesh;
    double model_vecs = 0;
    long view = 0;
    for (int v = 0; v < m->nverts; v++) {
        int mat = m->mat ? m->mat[v] : 0, K = r->out->factors[mat].K;
        model_vecs += r->out->scene.floor_first_vertex >= 0 && v >= r->out->scene.floor_first_vertex ? 0 : K;
        view += (r->vmask >> mat) & 1;
    }
    long room = pc_file_room(r, model_vecs / models);
    *why = room < 0 ? "" : "the room the file's byte budget leaves";
    if (room < 0) room = LONG_MAX;
    if (view && r->rp.vops->view->settle) {
        transfer_config cfg = r->rp.vcfg;
        long vroom = 0;
        char line[256];
        r->rp.vops->view->settle(&cfg, view, pc_max_passes(r), &vroom, line, sizeof line);
        if (vroom - view < room) room = vroom - view > 0 ? vroom - view : 0, *why = "the room the view grid's byte budget leaves";
    }
    return room;
}

/* The models refined where visibility changes (planfx.h PLANFX_MODEL_GROWTH says why and how far), up
 * to that many times their vertices within pc_model_room. Returns 0 or -1. */
static int pc_refine_models(pc_run *r, prt_error *err) {
    const prt_scene *s = &r->out->scene;
    long models = s->floor_first_vertex >= 0 ? s->floor_first_vertex : s->mesh.nverts;
    if (models == 0) return 0;
    const char *why;
    long room = pc_model_room(r, models, &why);
    return pc_refine_grow(r, "the models", "their", models, PLANFX_MODEL_GROWTH, room, why, REFINE_MODELS, err);
}

/* The floor refined where visibility changes after the models, when plan_refine calls for it, up to
 * PLANFX_FLOOR_GROWTH times its vertices within the file's byte budget (its Lambertian vectors'
 * vector_bytes each; the view grid's room is the models'). Returns 0 or -1. */
static int pc_refine_floor(pc_run *r, prt_error *err) {
    const prt_scene *s = &r->out->scene;
    if (!r->refine_floor || !r->rp.lops->linear->vector_bytes) return 0;   /* no byte model: no bound for it */
    return pc_refine_grow(r, "the floor", "its", s->mesh.nverts - s->floor_first_vertex, PLANFX_FLOOR_GROWTH, pc_file_room(r, 1),
                          "the room the file's byte budget leaves", REFINE_FLOOR, err);
}

/* Stage refine: adaptive refinement where visibility changes (refine.h) when asked for, else where
 * the plan calls for it (the floor's report, the models), and its plan lines. Returns 0 or -1. */
static int pc_refine(pc_run *r, prt_error *err) {
    if (r->d.force_refine == -1) {
        plan_add(r->plan, r->pcap, "  refinement: off (forced)\n");
        return 0;
    }
    const bool asked = r->d.refine_threshold > 0;
    if (asked) plan_add(r->plan, r->pcap, "  refinement: asked for (the scene's \"refine\" or a refine option)\n");
    else plan_refine(r);   /* the floor's report; with force_refine 1 it asks for the floor */
    if (r->d.refine_threshold > 0 && pc_refine_run(r, (refine_desc){ .threshold = r->d.refine_threshold, .budget = r->d.refine_budget,
                                                                     .parts = r->d.refine_parts }, err))
        return -1;
    return asked ? 0 : pc_refine_models(r, err) || pc_refine_floor(r, err) ? -1 : 0;
}

/* Stage factor: BRDF factorization (section 3.3), the constant light maps of Lambertian factors,
 * and the plan's BRDF lines (kept in r->later: refinement's lines come first). Returns 0 or -1. */
static int pc_factor(pc_run *r, prt_error *err) {
    prt_data *out = r->out;
    double t0 = prt_now();
    r->kmax = 1;
    for (int i = 0; i < out->scene.nmaterials; i++) {
        brdf_factor_desc fd = { .max_terms = r->d.max_terms, .error_target = r->d.term_error, .res = 0, .param = r->d.param };
        if (brdf_factorize(&out->scene.materials[i], &fd, &out->factors[i], err)) return -1;
        brdf_factor *f = &out->factors[i];
        if (f->K < 1 || f->K > BRDF_MAX_SIGMA) return prt_fail(err, "precompute: material %d factored into %d terms", i, f->K);
        if (f->K > r->kmax) r->kmax = f->K;
        if (f->lambertian) brdf_factor_lambert_light(f, r->c.lambert_g[i]);
    }
    out->stats.t_brdf = prt_now() - t0;
    plan_add(r->later, r->pcap, "  BRDF terms (factored in %.1fs):\n", out->stats.t_brdf);
    for (int i = 0; i < out->scene.nmaterials; i++) {
        plan_material(r->later, r->pcap, i, &out->scene.materials[i], &out->factors[i], r->d.max_terms, r->d.term_error);
        if (out->scene.material_from[i][0]) plan_add(r->later, r->pcap, "    from %s\n", out->scene.material_from[i]);
    }
    /* A BRDF reflecting more than it receives (albedo.h): a warning, since it may be meant */
    for (int i = 0; i < out->scene.nmaterials; i++) {
        char w[700];
        const char *spec = out->scene.material_spec[i][0] ? out->scene.material_spec[i] : NULL;
        if (brdf_energy_warning(&out->scene.materials[i], spec, w, sizeof w))
            plan_add(r->later, r->pcap, "  warning: material %d %s\n", i, w);
    }
    return 0;
}

/* See precompute.h: the path of one material with the plan's reason. Auto measures both errors in
 * the view-dependent representation's own measure (its fit op): the SVD at f's K, and its own. */
int precompute_choose_path(const brdf_params *p, const brdf_factor *f, precompute_glossy mode, const transfer_ops *linear,
                           const transfer_ops *view, const transfer_config *vcfg, precompute_path *path, char *why, size_t cap,
                           prt_error *err) {
    const char *name = brdf_type_name(p->type);
    *path = PRECOMPUTE_PATH_SVD;
    if (f->lambertian || p->type == BRDF_LAMBERT)
        return *path = PRECOMPUTE_PATH_LAMBERT, snprintf(why, cap, "the sparse transfer, K = 1 (Lambertian)"), 0;
    if (mode == PRECOMPUTE_GLOSSY_SVD) return snprintf(why, cap, "SVD, K = %d (asked for: glossy svd)", f->K), 0;
    if (!view) return snprintf(why, cap, "SVD, K = %d (no view-dependent transfer representation)", f->K), 0;
    transfer_fit fit;
    if (view->view->fit(vcfg, p, f, &fit, err)) return -1;
    if (!fit.fits) return snprintf(why, cap, "SVD, K = %d (%s: %s)", f->K, name, fit.why), 0;
    double svd = fit.svd_err, own = fit.err;
    const char *lin = linear ? linear->label : "the linear transfer";
    if (mode == PRECOMPUTE_GLOSSY_VIEW) {
        *path = PRECOMPUTE_PATH_VIEW;
        snprintf(why, cap, "%s K = 1 diffuse + %s specular (asked for: glossy %s; SVD K = %d %.1f%%, %s %.1f%%, %s)", lin,
                 view->label, view->name, f->K, 100 * svd, fit.what, 100 * own, fit.measure);
    } else if (svd <= PRECOMPUTE_SVD_SMALL) {
        snprintf(why, cap, "SVD, K = %d: its error %.1f%% <= %.0f%% (%s %.1f%%; %s)", f->K, 100 * svd, 100 * PRECOMPUTE_SVD_SMALL,
                 fit.what, 100 * own, fit.measure);
    } else if (own >= svd) {
        snprintf(why, cap, "SVD, K = %d: error %.1f%%, but %s is no better (%.1f%%; %s)", f->K, 100 * svd, fit.what, 100 * own,
                 fit.measure);
    } else {
        *path = PRECOMPUTE_PATH_VIEW;
        snprintf(why, cap, "%s K = 1 diffuse + %s specular: SVD K = %d error %.1f%% > %.0f%%, %s %.1f%% (%s)", lin, view->label,
                 f->K, 100 * svd, 100 * PRECOMPUTE_SVD_SMALL, fit.what, 100 * own, fit.measure);
    }
    return 0;
}

/* Material i on the view path: its factor becomes the K = 1 factor of kd/pi alone (the linear transfer
 * then holds the diffuse part), and the constant light map of it. Returns 0 or -1. */
static int pc_diffuse_factor(pc_run *r, int i, prt_error *err) {
    brdf_params lp = { .type = BRDF_LAMBERT };
    memcpy(lp.kd, r->out->scene.materials[i].kd, sizeof lp.kd);
    brdf_factor_desc fd = { .max_terms = 1, .param = r->d.param };
    brdf_factor f;
    if (brdf_factorize(&lp, &fd, &f, err)) return -1;
    PRT_CHECK(f.K == 1 && f.lambertian);
    brdf_factor_free(&r->out->factors[i]);
    r->out->factors[i] = f;
    brdf_factor_lambert_light(&f, r->c.lambert_g[i]);
    return 0;
}

/* The view-dependent transfer for the materials in mask, and its plan line. */
static void pc_add_view(pc_run *r, uint64_t mask) {
    const prt_mesh *m = &r->out->scene.mesh;
    long n = 0;
    for (int v = 0; v < m->nverts; v++) n += (mask >> m->mat[v]) & 1;
    transfer_config cfg = r->rp.vcfg;
    char line[256], why[256] = "";
    if (r->rp.vops->view->settle) r->rp.vops->view->settle(&cfg, n, pc_max_passes(r), NULL, why, sizeof why);
    r->vtr = prt_data_add_transfer(r->out, r->rp.vops, &cfg, mask);
    r->rp.vops->describe(&r->vtr->cfg, line, sizeof line);
    plan_add(r->plan, r->pcap, "  specular: %s for the materials on the %s path\n", line, r->rp.vops->label);
    if (why[0]) plan_add(r->plan, r->pcap, "    %s\n", why);
}

/* The linear representation's begin (transfer.h): what this run needs beyond its config, its plan
 * lines; its time (a light prior's) kept as its stage's. Returns 0 or -1. */
static int pc_begin(pc_run *r, prt_error *err) {
    const transfer_linear *lin = r->rp.lops->linear;
    const prt_mesh *m = &r->out->scene.mesh;
    size_t nvecs = 0;
    for (int v = 0; v < m->nverts; v++) {
        int mat = m->mat ? m->mat[v] : 0;
        nvecs += (r->tr->materials >> mat) & 1 ? (size_t)r->out->factors[mat].K : 0;
    }
    transfer_linear_in in = { .nvecs = nvecs, .progress = r->d.progress, .progress_user = r->d.progress_user, .quiet = r->d.quiet,
                              .plan = r->plan, .plan_cap = r->pcap };
    if (lin->begin && lin->begin(&r->tr->cfg, &r->rp.lsetup, &in, &r->lrun, err)) return -1;
    int slot = (int)(r->tr - r->out->transfers);
    r->out->stats.t_transfer[slot] = r->lrun.stage ? r->lrun.seconds : 0;
    r->out->stats.t_transfer_name[slot] = r->lrun.stage;
    return 0;
}

/* Stage paths: the path of every material with the reason (see precompute.h), before refinement,
 * whose room for the models depends on them (pc_model_room); a view-path material's factor becomes
 * its diffuse part. Returns 0 or -1. */
static int pc_paths(pc_run *r, prt_error *err) {
    int nm = r->out->scene.nmaterials;
    uint64_t vmask = 0;
    plan_add(r->later, r->pcap, "  paths:\n");
    for (int i = 0; i < nm; i++) {
        const brdf_params *p = &r->out->scene.materials[i];
        char why[384];
        precompute_path path;
        if (precompute_choose_path(p, &r->out->factors[i], r->d.glossy, r->rp.lops, r->rp.vops, &r->rp.vcfg, &path, why,
                                   sizeof why, err))
            return -1;
        bool view = path == PRECOMPUTE_PATH_VIEW;
        if (view && pc_diffuse_factor(r, i, err)) return -1;
        if (view) vmask |= (uint64_t)1 << i;
        plan_add(r->later, r->pcap, "    material %d %s: %s\n", i, brdf_type_name(p->type), why);
    }
    r->vmask = vmask;
    return 0;
}

/* Stage choose: the scene line (after refinement) and the lines pc_factor and pc_paths kept, then the
 * linear transfer (desc.basis, else the table's default, Haar wavelets: the paper's all-frequency basis,
 * and at the same bytes the closest to the path tracer of the three, docs/design/cpca.md) over every
 * material with its begin, and, when some material took the view path, the view-dependent
 * transfer over those. Returns 0 or -1. */
static int pc_choose(pc_run *r, prt_error *err) {
    int nm = r->out->scene.nmaterials;
    const prt_mesh *m = &r->out->scene.mesh;
    plan_add(r->plan, r->pcap, "  scene: %d vertices, %d triangles, %d material%s, %d thread%s\n", m->nverts, m->ntris, nm,
             nm == 1 ? "" : "s", r->nthreads, r->nthreads == 1 ? "" : "s");
    plan_add(r->plan, r->pcap, "%s", r->later);
    r->kmax = 1;
    for (int i = 0; i < nm; i++)
        if (r->out->factors[i].K > r->kmax) r->kmax = r->out->factors[i].K;
    uint64_t all = nm >= 64 ? ~(uint64_t)0 : ((uint64_t)1 << nm) - 1;
    r->tr = prt_data_add_transfer(r->out, r->rp.lops, &r->rp.lcfg, all);
    r->tr->open_sky = !r->d.no_open_sky;
    char line[256];
    r->rp.lops->describe(&r->tr->cfg, line, sizeof line);
    plan_add(r->plan, r->pcap, "  basis: %s; %s: %s\n", line, nm == 1 ? "the material" : "every material",
             r->d.basis ? "asked for" : "the default (all-frequency; the closest to the path tracer per byte)");
    if (pc_begin(r, err)) return -1;
    if (r->vmask) pc_add_view(r, r->vmask);
    return 0;
}

/* A shared budget's weight per vector (transport.h prt_transport.weight): its vertex's area over the
 * mean vertex area, so the budget goes where the error integrated over the surface is least, not
 * the error summed over vertices, which a refined (denser) region would outweigh (docs/design/
 * shadows.md, "A shared budget weighs vertices by area", has the measurements). At least
 * PC_MIN_WEIGHT: a vertex of degenerate triangles still keeps its budget_min. 0 or -1. */
static int pc_vector_weights(pc_run *r, prt_error *err) {
    const prt_mesh *m = &r->out->scene.mesh;
    double *area = prt_calloc((size_t)m->nverts, sizeof *area, err);
    if (!area || !(r->vweight = prt_calloc((size_t)r->direct.nvecs > 0 ? (size_t)r->direct.nvecs : 1, sizeof *r->vweight, err))) {
        free(area);
        return -1;
    }
    mesh_vertex_areas(m, area);
    double sum = 0;
    for (int v = 0; v < m->nverts; v++) sum += area[v];
    const double mean = sum > 0 ? sum / m->nverts : 1;
    for (int v = 0; v < m->nverts; v++) {
        double w = area[v] / mean;
        w = w > PC_MIN_WEIGHT ? w : PC_MIN_WEIGHT;
        for (uint32_t q = r->direct.vec_first[v]; q < r->direct.vec_first[v + 1]; q++) r->vweight[q] = (float)w;
    }
    free(area);
    r->direct.weight = r->vweight;
    return 0;
}

static const char *pc_stream_dir(const pc_run *r) { return r->d.stream_dir ? r->d.stream_dir : "."; }

/* The direct pass's staging streamed to a file when it exceeds half the memory budget (precompute.h);
 * said on stderr, not in the plan, which must not differ from an in-memory run's. Returns 0 or -1. */
static int pc_stream(pc_run *r, prt_error *err) {
    double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    double budget = r->d.memory_gb > 0 ? r->d.memory_gb * 1e9 : 0.5 * phys;
    double staging = (double)transport_staging_bytes(&r->direct);
    if (staging <= budget / 2) return 0;   /* each gathering pass stages as much again: streamed alike */
    const char *dir = pc_stream_dir(r);
    if (transport_stage_to_file(&r->direct, dir, err)) return -1;
    r->streamed = true;
    if (!r->d.quiet)
        fprintf(stderr, "memory: the direct pass's %.2f GB of staged vectors exceed half of the %.2f GB budget: streamed through a temporary file in %s\n",
                staging / 1e9, budget / 1e9, dir);
    return 0;
}

/* The floor's first vertex when its blocked parts are folded (pc_fold_why), else -1, with the plan's line. */
static int pc_fold_first(pc_run *r) {
    const char *why = pc_fold_why(r);
    if (why && !why[0]) return -1;   /* no Lambertian floor with the open sky split: nothing to say */
    if (why) {
        plan_add(r->plan, r->pcap, "  the floor's shadows: its blocked parts keep the cosine (%s)\n", why);
        return -1;
    }
    plan_add(r->plan, r->pcap, "  the floor's shadows: its blocked parts stored without the cosine's fall to the horizon, which the "
                               "light takes (a low sun's shadow)\n");
    return r->out->scene.floor_first_vertex;
}

/* Stage setup: texel direction tables, the direct transport set, the visibility scene, per-thread
 * scratch and the direct pass's shared context. Returns 0 or -1. */
static int pc_setup(pc_run *r, prt_error *err) {
    const prt_mesh *m = &r->out->scene.mesh;
    const int R = r->d.vis_res;
    r->vdir = prt_calloc((size_t)6 * R * R * 3, sizeof(float), err);
    r->vdw = r->vdir ? prt_calloc((size_t)R * R, sizeof(float), err) : NULL;
    r->ldir = r->vdw ? prt_calloc((size_t)CUBE_TEXELS * 3, sizeof(float), err) : NULL;
    r->nvec = r->ldir ? prt_calloc((size_t)m->nverts, sizeof(int), err) : NULL;
    r->order = r->nvec ? prt_calloc((size_t)m->nverts, sizeof(int), err) : NULL;
    r->vst = r->order ? prt_calloc((size_t)m->nverts, sizeof *r->vst, err) : NULL;
    r->restored = r->vst ? prt_calloc((size_t)m->nverts, 1, err) : NULL;
    r->cost = r->restored ? prt_calloc((size_t)m->nverts, sizeof *r->cost, err) : NULL;
    r->first = r->cost ? prt_calloc((size_t)shard_size(r->d.shard) + 1, sizeof *r->first, err) : NULL;
    if (!r->first) return -1;
    for (int i = 0; i < 6 * R * R; i++) {
        float dd[3];
        cube_texel_dir(R, i, dd);
        for (int k = 0; k < 3; k++) r->vdir[(size_t)k * 6 * R * R + i] = dd[k];
    }
    cube_face_solid_angles(R, r->vdw);
    for (int i = 0; i < CUBE_TEXELS; i++) cube_texel_dir(CUBE_RES, i, r->ldir + 3 * i);
    for (int v = 0; v < m->nverts; v++) {
        int mat = m->mat ? m->mat[v] : 0;
        r->nvec[v] = (r->tr->materials >> mat) & 1 ? r->out->factors[mat].K : 0;
    }
    /* the representation's N, qbits and store policy; the gathering passes copy it (transport_init_like) */
    if (r->rp.lops->linear->init_set(&r->tr->cfg, &r->lrun, &r->direct, m->nverts, r->nvec, err)) return -1;
    if (r->direct.stage_key && pc_vector_weights(r, err)) return -1;
    if (pc_stream(r, err)) return -1;
    r->vs = vis_create(m, err);
    if (!r->vs) return -1;
    vis_cull_floor(r->vs, m, r->out->scene.floor_first_vertex);
    for (int t = 0; t < r->nthreads; t++)
        if (pc_scratch_init(&r->scratch[t], R, r->kmax, err)) return -1;
    pc_ctx *c = &r->c;   /* lambert_g was filled by pc_factor */
    c->mesh = m;
    c->vs = r->vs;
    c->factors = r->out->factors;
    c->t = &r->direct;
    c->lin = r->tr->ops->linear;
    c->cfg = &r->tr->cfg;
    c->materials = r->tr->materials;
    c->vres = R;
    c->ss = R / CUBE_RES;
    c->open = r->tr->open_sky;
    c->fold_first = r->fold_first = pc_fold_first(r);
    c->vweight = r->vweight;   /* NULL without a shared budget (pc_vector_weights) */
    cube_face_solid_angles(CUBE_RES, c->lwinv);
    for (int i = 0; i < CUBE_RES * CUBE_RES; i++) c->lwinv[i] = 1.f / c->lwinv[i];
    c->vdir = r->vdir;
    c->vdw = r->vdw;
    c->ldir = r->ldir;
    c->rays = r->lrun.rays && r->lrun.rays->n ? r->lrun.rays : NULL;
    c->order = r->order;
    c->scratch = r->scratch;
    c->vst = r->vst;
    c->restored = r->restored;
    c->cost = r->cost;
    c->total = m->nverts;
    c->progress = r->d.progress;
    c->progress_user = r->d.progress_user;
    return 0;
}

/* ckpt_key_add in transfer_key_fn's form (a representation adds its own inputs). */
static void pc_key_add(void *k, const void *p, size_t n) { ckpt_key_add(k, p, n); }

/* The checkpoint's key: everything the passes' results depend on (checkpoint.h): the mesh as
 * precomputed (after refinement), the materials, their factors, the textures, each transfer's representation,
 * configuration and materials, what the linear one's begin decided (its key op), and the options
 * that shape the passes; not the threads, which change nothing. */
static uint64_t pc_key(const pc_run *r) {
    const prt_scene *sc = &r->out->scene;
    const prt_mesh *m = &sc->mesh;
    const precompute_desc *d = &r->d;
    ckpt_key k = ckpt_key_init();
    ckpt_key_str(&k, "prt precompute checkpoint 3");   /* 3: transfer configurations as opaque bytes */
    ckpt_key_add(&k, &m->nverts, sizeof m->nverts);
    ckpt_key_add(&k, &m->ntris, sizeof m->ntris);
    ckpt_key_add(&k, m->pos, 3 * sizeof(float) * (size_t)m->nverts);
    ckpt_key_add(&k, m->nrm, 3 * sizeof(float) * (size_t)m->nverts);
    ckpt_key_add(&k, m->tris, 3 * sizeof(uint32_t) * (size_t)m->ntris);
    if (m->mat) ckpt_key_add(&k, m->mat, sizeof(uint16_t) * (size_t)m->nverts);
    ckpt_key_add(&k, &sc->floor_first_vertex, sizeof sc->floor_first_vertex);
    ckpt_key_textures(&k, sc);
    for (int i = 0; i < sc->nmaterials; i++) {
        const brdf_factor *f = &r->out->factors[i];
        ckpt_key_str(&k, sc->material_spec[i]);
        ckpt_key_add(&k, &f->K, sizeof f->K);
        ckpt_key_add(&k, &f->res, sizeof f->res);
        if (f->light) ckpt_key_add(&k, f->light, sizeof(float) * 3 * (size_t)f->K * f->res * f->res);
        if (f->view) ckpt_key_add(&k, f->view, sizeof(float) * 3 * (size_t)f->K * f->res * f->res);
    }
    for (int i = 0; i < r->out->ntransfers; i++) {
        const prt_transfer *t = &r->out->transfers[i];
        ckpt_key_str(&k, t->ops->name);
        ckpt_key_add(&k, t->cfg.bytes, sizeof t->cfg.bytes);
        ckpt_key_add(&k, &t->materials, sizeof t->materials);
    }
    if (r->rp.lops->linear->key) r->rp.lops->linear->key(&r->lrun, pc_key_add, &k);
    int iv[] = { d->vis_res, d->bounces, d->gather_res, d->force_bounces, d->keep_direct, (int)d->glossy, d->no_open_sky, d->no_fold };
    ckpt_key_add(&k, iv, sizeof iv);
    ckpt_key_add(&k, &d->bounce_threshold, sizeof d->bounce_threshold);
    return ckpt_key_value(&k);
}

/* The resume message's clauses of the view-dependent transfer's passes (its resumed op). */
static void pc_resumed_view(const pc_run *r) {
    if (!r->vtr || !r->rp.vops->view->resumed) return;
    int p0 = ckpt_transfer_pass((int)(r->vtr - r->out->transfers));
    for (int p = 0; p < TRANSFER_CKPT_PASSES && ckpt_count(r->ck, p0 + p) > 0; p++) {
        char clause[96];
        r->rp.vops->view->resumed(p, ckpt_count(r->ck, p0 + p), clause, sizeof clause);
        fprintf(stderr, ", %s", clause);
    }
}

/* Stage resume: opens the checkpoint when asked for (new, or the one to continue: its direct-pass
 * vertices restored into the direct set, the other passes' counts said on stderr). Returns 0 or -1. */
static int pc_resume(pc_run *r, prt_error *err) {
    if (!r->d.checkpoint) return 0;
    const prt_mesh *m = &r->out->scene.mesh;
    r->ck = ckpt_open(r->d.checkpoint, pc_key(r), r->d.resume, m->nverts, r->d.checkpoint_kill, err);
    if (!r->ck) return -1;
    r->c.ck = r->ck;
    int n0 = ckpt_restore(r->ck, 0, &r->direct, r->restored, r->vst, err);
    if (n0 < 0) return -1;
    if (!r->d.quiet && n0 > 0) {
        fprintf(stderr, "resuming from %s: visibility+transport %d of %d vertices done", r->d.checkpoint, n0, m->nverts);
        for (int b = 1; b <= PRT_MAX_BOUNCES && ckpt_count(r->ck, b) > 0; b++)
            fprintf(stderr, ", bounce %d %d", b, ckpt_count(r->ck, b));
        pc_resumed_view(r);
        fputc('\n', stderr);
    } else if (!r->d.quiet && r->d.resume) {
        fprintf(stderr, "resume: nothing recorded in %s yet, starting from the beginning\n", r->d.checkpoint);
    }
    return 0;
}

/* The plan's interreflection line: what the scene calls for and why. */
static void plan_bounce_line(pc_run *r) {
    const precompute_desc *d = &r->d;
    double hit = r->hit_sample;
    r->max_b = d->force_bounces == 1 && d->bounces == 0 ? 1 : d->bounces;
    if (d->force_bounces == -1) {
        plan_add(r->plan, r->pcap, "  interreflections: none (forced off)\n");
    } else if (d->force_bounces == 1) {
        plan_add(r->plan, r->pcap, "  interreflections: %d pass%s (forced, no adaptive stop)\n", r->max_b, r->max_b == 1 ? "" : "es");
    } else if (hit < PC_HIT_MIN) {
        plan_add(r->plan, r->pcap, "  interreflections: none: only %.2f%% of visibility rays hit geometry (< %.1f%%: surfaces do not see each other)\n",
                 100 * hit, 100 * PC_HIT_MIN);
    } else {
        plan_add(r->plan, r->pcap, "  interreflections: up to %d pass%s while a pass carries >= %.1f%% of the direct energy (%.1f%% of rays hit geometry)\n",
                 d->bounces, d->bounces == 1 ? "" : "es", 100 * d->bounce_threshold, 100 * hit);
    }
    r->plan_bounces = d->force_bounces == 1 || (d->force_bounces == 0 && hit >= PC_HIT_MIN);
}

/* The plan's one-bounce line from the measured shares (planfx.h) or the force flag. */
static void plan_bounce_local(pc_run *r, const planfx_bounce *b) {
    const char *k = "    one bounce (two VSGLs):";
    int f = r->d.force_local_bounce;
    if (f) {
        plan_add(r->plan, r->pcap, "%s %s\n", k, f > 0 ? "needed (forced)" : "none (forced off)");
        return;
    }
    if (!(b->direct > 0)) {
        plan_add(r->plan, r->pcap, "%s none: the lights reach none of the %d sampled vertices\n", k, b->vertices);
        return;
    }
    double share = b->bounce / b->direct;
    bool on = share >= PLANFX_BOUNCE_MIN;
    plan_add(r->plan, r->pcap, "%s %s: carries %.1f%% of the direct light at %d sampled vertices (%s %.0f%%; %ld rays)\n", k,
             on ? "needed" : "none", 100 * share, b->vertices, on ? ">=" : "<", 100 * PLANFX_BOUNCE_MIN, b->rays);
}

/* The plan's indirect-highlights line (glossy: the scene has a glossy material). */
static void plan_highlights(pc_run *r, const planfx_bounce *b, bool glossy) {
    const char *k = "    indirect highlights:";
    int f = r->d.force_highlights;
    if (f) {
        plan_add(r->plan, r->pcap, "%s %s\n", k, f > 0 ? "needed (forced)" : "none (forced off)");
    } else if (!glossy) {
        plan_add(r->plan, r->pcap, "%s none: no glossy material\n", k);
    } else if (!(b->direct > 0)) {
        plan_add(r->plan, r->pcap, "%s none: the lights reach none of the sampled vertices\n", k);
    } else {
        double share = b->glossy / b->direct;
        bool on = share >= PLANFX_HIGHLIGHT_MIN;
        plan_add(r->plan, r->pcap, "%s %s: the %d glossy sampled vertices receive %.1f%% of the direct light by one bounce (%s %.0f%%)\n",
                 k, on ? "needed" : "none", b->glossy_vertices, 100 * share, on ? ">=" : "<", 100 * PLANFX_HIGHLIGHT_MIN);
    }
}

/* The scene's local lights and the local-light effects they call for. Direct light is always
 * needed (runtime, analytic BRDFs, shadows); the one bounce and the indirect highlights where the
 * light they carry, measured at the planning sample (planfx.h), reaches PLANFX_BOUNCE_MIN and
 * PLANFX_HIGHLIGHT_MIN of the direct light, unless forced. Nothing is printed without local lights. */
static void plan_local_lights(pc_run *r) {
    const prt_scene *sc = &r->out->scene;
    if (sc->lights.count == 0) return;
    plan_add(r->plan, r->pcap, "  local lights: %d\n", sc->lights.count);
    for (int i = 0; i < sc->lights.count; i++) {
        char spec[300];
        light_format(&sc->lights.light[i], spec, sizeof spec);
        plan_add(r->plan, r->pcap, "    light %d: %s\n", i, spec);
    }
    int glossy = 0;
    for (int m = 0; m < sc->nmaterials; m++) glossy += sc->materials[m].type != BRDF_LAMBERT;
    planfx_bounce b = { 0 };
    if (!r->d.force_local_bounce || (glossy && !r->d.force_highlights))
        planfx_measure_bounce(sc, r->vs, r->order, r->nsample, PLANFX_RAYS, &b);
    plan_add(r->plan, r->pcap, "    direct light with shadows: at runtime (cpu: Embree shadow rays per vertex; gl: a shadow cube "
                               "per point light, one perspective map per spot), analytic BRDFs, not the factorization\n");
    plan_bounce_local(r, &b);
    plan_highlights(r, &b, glossy > 0);
}

/* Pass `name` of the statistics' table (added when new; NULL when the table is full). */
static prt_pass_time *pc_pass(prt_stats *st, const char *name) {
    for (int i = 0; i < st->npasses; i++)
        if (!strcmp(st->pass[i].name, name)) return &st->pass[i];
    if (st->npasses >= PRT_MAX_PASSES) return NULL;
    prt_pass_time *p = &st->pass[st->npasses++];
    memset(p, 0, sizeof *p);
    snprintf(p->name, sizeof p->name, "%s", name);
    return p;
}

/* The plan's estimate of pass `name`: est_cpu CPU seconds, wall_extra already spent on it. */
static void pc_pass_plan(pc_run *r, const char *name, double est_cpu, double wall_extra) {
    prt_pass_time *p = pc_pass(&r->out->stats, name);
    if (!p) return;
    p->planned = true;
    p->est_cpu = est_cpu;
    p->est = wall_extra + est_cpu * r->wall_per_cpu;
}

/* What pass `name` took (transfer_precompute_in.pass_done's form, so a view-dependent transfer's passes report here). */
static void pc_pass_ran(void *user, const char *name, double wall, double cpu) {
    prt_pass_time *p = pc_pass(&((pc_run *)user)->out->stats, name);
    if (!p) return;
    p->ran = true;
    p->wall = wall;
    p->cpu = cpu;
}

/* CPU seconds of one thread to store an empty vector (a gathering pass's vertex whose rays all
 * escape) in a one-vector set configured as like: 8 stores timed. */
static double pc_zero_store_cpu(const prt_transport *like) {
    prt_transport one = *like, z;
    int k = 1;
    one.nverts = 1;
    prt_error e2;
    float *zero = calloc(3 * (size_t)CUBE_TEXELS, sizeof(float));
    void *scratch = malloc(transport_scratch_size());
    double secs = 0;
    if (zero && scratch && !transport_init_like(&z, &one, &k, &e2)) {
        double t0 = pc_cpu_now();
        for (int i = 0; i < 8; i++) transport_store(&z, 0, zero, zero + CUBE_TEXELS, zero + 2 * CUBE_TEXELS, scratch);
        secs = (pc_cpu_now() - t0) / 8;
        transport_free(&z);
    }
    free(zero);
    free(scratch);
    return secs;
}

/* The view-dependent transfer's passes as stage view runs them: its checkpoint passes from its slot. */
static transfer_precompute_in pc_view_in(pc_run *r) {
    return (transfer_precompute_in){ .scene = &r->out->scene, .vis = r->vs, .passes = r->plan_bounces ? 1 + r->max_b : 1,
                                     .bounce_threshold = r->d.bounce_threshold, .nthreads = r->nthreads,
                                     .progress = r->d.progress, .progress_user = r->d.progress_user, .ckpt = r->ck,
                                     .ckpt_pass = ckpt_transfer_pass((int)(r->vtr - r->out->transfers)),
                                     .shard = r->d.shard, .pass_done = pc_pass_ran, .pass_user = r };
}

/* The view-dependent transfer's estimates (its estimate op: each stage's CPU seconds) into the pass
 * table, and their clause into line (each stage named as the representation names it, less its own
 * name's prefix); false when it gives none. */
static bool pc_plan_view(pc_run *r, char *line, size_t cap, double *total) {
    const transfer_ops *ops = r->rp.vops;
    if (!ops->view->estimate) return false;
    transfer_precompute_in in = pc_view_in(r);
    transfer_estimate est;
    prt_error e2;
    if (ops->view->estimate(&in, r->vtr, &est, &e2)) return false;
    size_t at = 0, nl = strlen(ops->name);
    *total = 0;
    line[0] = 0;
    for (int k = 0; k < est.n; k++) {
        char d[32];
        pc_pass_plan(r, est.name[k], est.cpu[k], 0);
        fmt_dur(d, sizeof d, est.cpu[k] * r->wall_per_cpu);
        *total += est.cpu[k] * r->wall_per_cpu;
        const char *nm = !strncmp(est.name[k], ops->name, nl) && est.name[k][nl] == ' ' ? est.name[k] + nl + 1 : est.name[k];
        if (at < cap) at += (size_t)snprintf(line + at, cap - at, "%s%s %s", at ? ", " : "", nm, d);
    }
    return true;
}

/* The plan's estimate line: every pass that will run, from its work (see pc_estimate_gather and
 * a view-dependent transfer's estimate op), in wall time at the sample's wall seconds per CPU second (its threads and the
 * share of a core they got). */
static void pc_plan_estimate(pc_run *r) {
    const prt_mesh *m = &r->out->scene.mesh;
    double cpu = 0, store = 0;
    long nstore = 0;
    for (int t = 0; t < r->nthreads; t++) { cpu += r->scratch[t].t_cpu; store += r->scratch[t].t_store; nstore += r->scratch[t].n_store; }
    r->wall_per_cpu = cpu > 0 && r->t_sample > 0 ? r->t_sample / cpu : 1.0 / r->nthreads;
    double direct = r->nsample ? cpu / r->nsample * (m->nverts - r->nsample) : 0, total = 0;
    pc_pass_plan(r, "direct", direct, r->t_sample);
    char e1[32], e2[32], e3[32], vline[256] = "";
    total = r->t_sample + direct * r->wall_per_cpu;
    fmt_dur(e1, sizeof e1, total);
    plan_add(r->plan, r->pcap, "  estimate: direct pass %s", e1);
    if (r->plan_bounces && r->max_b > 0) {
        int N = r->direct.budget ? r->direct.budget : r->direct.N;   /* a vector's coefficients, the mean when shared */
        double eg = pc_estimate_gather(m, r->vs, r->out->factors, r->d.gather_res, N, nstore ? store / nstore : 0,
                                       pc_zero_store_cpu(&r->direct), r->order, r->nsample) * m->nverts;
        for (int b = 1; b <= r->max_b && b <= PRT_MAX_BOUNCES; b++) {
            char name[24];
            snprintf(name, sizeof name, "bounce %d", b);
            pc_pass_plan(r, name, eg, 0);
        }
        fmt_dur(e2, sizeof e2, eg * r->wall_per_cpu);
        total += r->max_b * eg * r->wall_per_cpu;
        plan_add(r->plan, r->pcap, ", each bounce pass %s (up to %d)", e2, r->max_b);
    }
    double tv = 0;
    if (r->vtr && pc_plan_view(r, vline, sizeof vline, &tv)) {
        fmt_dur(e2, sizeof e2, tv);
        plan_add(r->plan, r->pcap, ", %s lobes %s (%s)", r->rp.vops->label, e2, vline);
        total += tv;
    }
    fmt_dur(e3, sizeof e3, total);
    plan_add(r->plan, r->pcap, "; about %s in all (CPU time at the sample's %.2f wall s per CPU s on %d thread%s)\n", e3,
             r->wall_per_cpu, r->nthreads, r->nthreads == 1 ? "" : "s");
}

/* Stage plan: the planning sample (a strided set of vertices computed first and kept), the
 * visibility, interreflection and estimate lines, and the plan printed. Returns 0 or -1. */
static int pc_plan(pc_run *r, prt_error *err) {
    const prt_mesh *m = &r->out->scene.mesh;
    r->nsample = m->nverts < PC_SAMPLE ? m->nverts : PC_SAMPLE;
    for (int i = 0; i < r->nsample; i++) r->order[i] = (int)((long)i * m->nverts / r->nsample);
    double ts = prt_now(), cs = prt_process_cpu();
    prt_parallel_for(r->nsample, 4, r->nthreads, pc_range, &r->c);
    r->t_sample = prt_now() - ts;
    r->cpu_sample = prt_process_cpu() - cs;
    if (atomic_load(&r->c.cancelled)) return prt_fail(err, "cancelled");
    long s_traced = 0, s_hits = 0;
    for (int i = 0; i < r->nsample; i++) { s_traced += r->vst[r->order[i]].traced; s_hits += r->vst[r->order[i]].hits; }
    r->hit_sample = s_traced ? (double)s_hits / (double)s_traced : 0;
    plan_add(r->plan, r->pcap, "  visibility: %d^2 rays per face (%dx%d box filter to 64^2); in a %d-vertex sample %.2f%% of rays hit geometry\n",
             r->d.vis_res, r->c.ss, r->c.ss, r->nsample, 100 * r->hit_sample);
    if (vis_culling(r->vs))   /* visibility.h: exact, so the maps are those of tracing every ray */
        plan_add(r->plan, r->pcap, "  visibility: rays down to the floor are known blocked, not traced (a flat floor with no hole)\n");
    plan_bounce_line(r);
    plan_local_lights(r);
    pc_plan_estimate(r);
    /* stderr, with the command's other status lines; nothing else has been printed in this stage yet */
    if (!r->d.quiet) { fprintf(stderr, "effects plan\n%s", r->plan); fflush(stderr); }
    return 0;
}

/* The direct pass's split across ranks (shard.h): every vertex after the planning sample costs
 * what the sample vertex before it took (the sample's strided times stand for their stretch of
 * the mesh); the sample itself is done. One rank: everything. */
static void pc_split_direct(pc_run *r) {
    const prt_mesh *m = &r->out->scene.mesh;
    if (shard_size(r->d.shard) == 1 || r->nsample == 0) {
        shard_split(NULL, NULL, m->nverts, r->first);
        return;
    }
    double *w = r->cost;   /* reused in place: the sample's own costs are read before they are zeroed */
    double c = w[r->order[0]];
    for (int v = 0, si = 0; v < m->nverts; v++) {
        if (si < r->nsample && r->order[si] == v) { c = w[v]; si++; w[v] = 0; continue; }
        w[v] = c;
    }
    shard_split(r->d.shard, w, m->nverts, r->first);
}

/* After this rank's share of the direct pass: the test hook's failure, the ranks' common status
 * (cancelled on one: on all), then every rank's vectors and per-vertex statistics to every rank.
 * Returns 0 or -1. */
static int pc_share_direct(pc_run *r, prt_error *err) {
    int st = 0, rank = shard_rank(r->d.shard);
    if (atomic_load(&r->c.cancelled)) st = prt_fail(err, "cancelled");
    else if (r->d.shard_fail == rank + 1) st = prt_fail(err, "test hook: rank %d fails after its share of the direct pass", rank);
    if (shard_status(r->d.shard, st, err)) return -1;
    if (shard_size(r->d.shard) == 1) return 0;
    if (shard_share_staged(r->d.shard, &r->direct, r->first, err)) return -1;
    return shard_share_rows(r->d.shard, r->vst, sizeof *r->vst, r->first, err);
}

/* Stage direct: the rest of the direct pass, its statistics, the set finished, and the sample's
 * estimate of how much surfaces see each other checked against the full pass. Returns 0 or -1. */
static int pc_direct(pc_run *r, prt_error *err) {
    const prt_mesh *m = &r->out->scene.mesh;
    prt_stats *st = &r->out->stats;
    pc_split_direct(r);
    int k = 0, si = 0, rank = shard_rank(r->d.shard);
    for (int v = 0; v < m->nverts; v++) {
        if (si < r->nsample && r->order[si] == v) { si++; continue; }
        if (v >= r->first[rank] && v < r->first[rank + 1]) r->order[r->nsample + k++] = v;
    }
    r->c.order = r->order + r->nsample;
    r->c.report = true;
    r->c.base = rank == 0 ? 0 : r->nsample;   /* the sample, computed on every rank, counts on rank 0 */
    if (!(r->c.sp = shard_pass_begin(r->d.shard, "visibility+transport", "vertices", m->nverts, err))) return -1;
    double ts = prt_now();
    prt_parallel_for(k, PC_GRAIN, r->nthreads, pc_range, &r->c);
    double t_direct = r->t_sample + (prt_now() - ts);
    shard_pass_end(r->c.sp, atomic_load(&r->c.done) - r->c.base, r->d.progress, r->d.progress_user);
    r->c.sp = NULL;
    if (pc_share_direct(r, err)) return -1;
    if (r->tr->open_sky) {
        if (!(r->tr->open_vert = prt_calloc((size_t)m->nverts, 1, err))) return -1;
        for (int v = 0; v < m->nverts; v++) r->tr->open_vert[v] = (uint8_t)r->vst[v].open;
    }
    double tv = 0, tb = 0, es = 0;
    long ec = 0;
    for (int t = 0; t < r->nthreads; t++) { tv += r->scratch[t].t_vis; tb += r->scratch[t].t_busy; }
    for (int v = 0; v < m->nverts; v++) {   /* in vertex order: the same sums whatever ran where */
        st->rays_traced += r->vst[v].traced;
        st->rays_hit += r->vst[v].hits;
        es += r->vst[v].err;
        ec += r->vst[v].errs;
    }
    st->hit_fraction = st->rays_traced ? (double)st->rays_hit / (double)st->rays_traced : 0;
    st->t_visibility = tb > 0 ? t_direct * tv / tb : 0;
    st->t_transport = t_direct - st->t_visibility;
    for (int t = 0; t < r->nthreads; t++) pc_scratch_free(&r->scratch[t]);
    if (transport_finish(&r->direct, err)) return -1;
    es += r->direct.chosen_err;   /* a shared budget's choice (0 otherwise) */
    st->trunc_rel_err = ec ? sqrt(es / (double)ec) : 0;
    /* streamed: the gathering passes read the direct set through a mapped file */
    if (r->streamed && transport_map_to_file(&r->direct, pc_stream_dir(r), err)) return -1;
    if (r->d.force_bounces == 0) {
        bool full = st->hit_fraction >= PC_HIT_MIN;
        if (full != r->plan_bounces) {
            plan_add(r->plan, r->pcap, "  after the direct pass: %.2f%% of all rays hit geometry, so interreflections are %s\n",
                     100 * st->hit_fraction, full ? "on after all" : "off after all");
            r->plan_bounces = full;
        }
    }
    return 0;
}

/* The open-sky set (gather_desc.open): the linear representation's projection of |p_q| a0(n_q) at
 * every grid normal q (opensky.h), its PC_OPEN_N largest kept in floats. It stands in for the open sky
 * of every Lambertian neighbour in the first bounce, so its truncation only touches bounced light:
 * 512 coefficients hold that vector to about 2% (relative L2, measured on the grid's normals). */
#define PC_OPEN_N 512
static const int *pc_fill_one(int *a, int n) {
    for (int i = 0; i < n; i++) a[i] = 1;
    return a;
}

typedef struct pc_open_ctx {
    const pc_run *r;
    const opensky *o;
    prt_transport *t;
    float *buf[PC_MAX_THREADS];     /* per thread: a0 [CUBE_TEXELS], coefficients [CUBE_TEXELS], projection scratch */
    void *scratch[PC_MAX_THREADS];  /* transport_store's */
} pc_open_ctx;

static void pc_open_range(void *ctx, int begin, int end, int thread) {
    pc_open_ctx *c = ctx;
    float *a0 = c->buf[thread], *co = a0 + CUBE_TEXELS, *tmp = co + CUBE_TEXELS;
    for (int q = begin; q < end; q++) {
        opensky_grid_texels(c->o, q, a0);
        c->r->tr->ops->linear->project_transport(&c->r->tr->cfg, a0, co, tmp);
        transport_store(c->t, q, co, co, co, c->scratch[thread]);
    }
}

static int pc_open_set(const pc_run *r, prt_transport *t, prt_error *err) {
    int *one = prt_calloc(OPENSKY_NORMALS, sizeof(int), err), rc = -1;
    opensky *o = one ? opensky_create(err) : NULL;
    pc_open_ctx c = { .r = r, .o = o, .t = t };
    if (o && transport_init(t, OPENSKY_NORMALS, pc_fill_one(one, OPENSKY_NORMALS), PC_OPEN_N, 32, err) == 0) {
        bool ok = true;
        for (int i = 0; i < r->nthreads && ok; i++)
            ok = (c.buf[i] = prt_calloc(2 * CUBE_TEXELS + TRANSFER_SCRATCH_FLOATS, sizeof(float), err)) &&
                 (c.scratch[i] = prt_calloc(1, transport_scratch_size(), err));
        if (ok) {
            prt_parallel_for(OPENSKY_NORMALS, 16, r->nthreads, pc_open_range, &c);
            rc = transport_finish(t, err);
        }
        if (rc) transport_free(t);
    }
    for (int i = 0; i < r->nthreads; i++) free(c.buf[i]), free(c.scratch[i]);
    opensky_destroy(o);
    free(one);
    return rc;
}

/* Stage bounces: interreflection passes (Eq. 8), adaptive unless forced. Pass b gathers pass b-1
 * (`last`, the direct set for b = 1); `total` = direct + passes so far. Returns 0 or -1. */
static int pc_bounce_passes(pc_run *r, double e0, const prt_transport *open_set, prt_error *err);
static int pc_bounces(pc_run *r, prt_error *err) {
    if (!r->plan_bounces || r->max_b <= 0) return 0;
    double e0 = gather_energy(&r->direct);
    if (r->tr->open_sky) {   /* the direct set holds what is blocked: the whole vectors' energy, as computed */
        e0 = 0;
        for (int v = 0; v < r->out->scene.mesh.nverts; v++) e0 += r->vst[v].energy;
    }
    /* the first gathering pass's split: its cost grows with the vertex's vectors (Eq. 8 per term);
     * each later pass is split by the times the one before measured (gather_desc.cost) */
    for (int v = 0; v < r->out->scene.mesh.nverts; v++) r->cost[v] = r->nvec[v] ? 1 + r->nvec[v] : 0;
    prt_transport open = { 0 };
    if (r->tr->open_sky && pc_open_set(r, &open, err)) return -1;
    int rc = pc_bounce_passes(r, e0, &open, err);
    transport_free(&open);
    return rc;
}

/* The passes of stage bounces; open: the open-sky set for the first (nverts 0: none). */
static int pc_bounce_passes(pc_run *r, double e0, const prt_transport *open_set, prt_error *err) {
    prt_stats *st = &r->out->stats;
    const prt_transport open = *open_set;
    for (int b = 1; b <= r->max_b; b++) {
        char stage[32], line[256];
        snprintf(stage, sizeof stage, "bounce %d", b);
        gather_desc gd = { .res = r->d.gather_res, .nthreads = r->nthreads, .progress = r->d.progress,
                           .progress_user = r->d.progress_user, .stage = stage, .ckpt = r->ck, .pass = b,
                           .shard = r->d.shard, .cost = r->cost,
                           .stream_dir = r->streamed ? pc_stream_dir(r) : NULL, .open = b == 1 && open.nverts ? &open : NULL,
                           .open_vert = r->tr->open_vert };
        prt_transport next = { 0 }, sum = { 0 };
        double tb0 = prt_now(), cb0 = prt_process_cpu();
        if (gather_pass(r->out, r->vs, b == 1 ? &r->direct : &r->last, &gd, &next, err)) return -1;
        double e = e0 > 0 ? gather_energy(&next) / e0 : 0;
        if (gather_sum_streamed(b == 1 ? &r->direct : &r->total, &next, r->nthreads, gd.stream_dir, &sum, err)) {
            transport_free(&next);
            return -1;
        }
        transport_free(&r->total);
        r->total = sum;
        transport_free(&r->last);
        r->last = next;
        st->t_bounce[b - 1] = prt_now() - tb0;
        pc_pass_ran(r, stage, st->t_bounce[b - 1], prt_process_cpu() - cb0);
        st->bounce_energy[b - 1] = e;
        st->bounces = b;
        bool stop = r->d.force_bounces != 1 && e < r->d.bounce_threshold;
        snprintf(line, sizeof line, "  bounce %d: %.2f%% of the direct energy in %.1fs%s\n", b, 100 * e, st->t_bounce[b - 1],
                 stop ? " (below the threshold: last pass)" : "");
        plan_add(r->plan, r->pcap, "%s", line);
        if (stop) break;
    }
    return 0;
}

/* Stage view: the view-dependent transfer's passes (its precompute op; vMF: direct and gathering,
 * laurijssen-2011 section 5) over the same scene and Embree scene, with as many reflection passes at
 * most as the linear transfer was allowed (1 + bounces, none when the plan has no interreflections)
 * and the same threshold; its time and size go into the plan. Returns 0 or -1. */
static int pc_view(pc_run *r, prt_error *err) {
    if (!r->vtr) return 0;
    transfer_precompute_in in = pc_view_in(r);
    double t0 = prt_now();
    if (r->rp.vops->view->precompute(&in, r->vtr, err)) return -1;
    int slot = (int)(r->vtr - r->out->transfers);
    r->out->stats.t_transfer[slot] = prt_now() - t0;
    size_t bytes = r->rp.vops->bytes(r->vtr);
    plan_add(r->plan, r->pcap, "  %s: %d reflection pass%s at most, %.1fs, %.1f MB\n", r->rp.vops->name, in.passes,
             in.passes == 1 ? "" : "es", r->out->stats.t_transfer[slot], bytes / 1e6);
    return 0;
}

/* The plan's last line (prt info): each pass's wall time beside its estimate ("-": not estimated;
 * a pass estimated that did not run, stopped by the energy threshold, is left out). */
static void plan_measured(pc_run *r) {
    const prt_stats *st = &r->out->stats;
    plan_add(r->plan, r->pcap, "  time (estimate):");
    for (int i = 0; i < st->npasses; i++) {
        const prt_pass_time *p = &st->pass[i];
        if (!p->ran) continue;
        char a[32], e[32];
        fmt_dur(a, sizeof a, p->wall);
        fmt_dur(e, sizeof e, p->est);
        plan_add(r->plan, r->pcap, "%s %s %s (%s)", i ? "," : "", p->name, a, p->planned ? e : "-");
    }
    plan_add(r->plan, r->pcap, "\n");
}

/* Stage finish: the transfer's sets into out (direct + bounces, and the direct pass alone when
 * kept for the viewer's toggle). */
static void pc_finish(pc_run *r) {
    transport_free(&r->last);
    if (r->out->stats.bounces > 0) {
        r->tr->transport = r->total;
        memset(&r->total, 0, sizeof r->total);
        if (r->d.keep_direct) {
            r->tr->direct = r->direct;
            memset(&r->direct, 0, sizeof r->direct);
        }
    } else {
        r->tr->transport = r->direct;
        memset(&r->direct, 0, sizeof r->direct);
    }
}

/* The linear representation's finish on its final sets (transfer.h; cpca builds its clusters), its
 * time in the plan. 0 or -1. */
static int pc_transfer_finish(pc_run *r, prt_error *err) {
    if (!r->rp.lops || !r->rp.lops->linear->finish || !r->tr) return 0;
    double t0 = prt_now();
    if (r->rp.lops->linear->finish(r->tr, r->nthreads, err)) return -1;
    plan_add(r->plan, r->pcap, "  %s: built from the stored vectors in %.1fs, %.1f MB\n", r->rp.lops->name, prt_now() - t0,
             r->rp.lops->bytes(r->tr) / 1e6);
    return 0;
}

/* Frees what the stages allocated (not out). */
static void pc_cleanup(pc_run *r) {
    if (r->have_lock) pthread_mutex_destroy(&r->c.lock);
    for (int t = 0; t < PC_MAX_THREADS; t++) pc_scratch_free(&r->scratch[t]);
    vis_destroy(r->vs);
    free(r->vdir); free(r->vdw); free(r->ldir); free(r->order); free(r->nvec); free(r->vst); free(r->restored);
    free(r->cost); free(r->first);
    ckpt_close(r->ck, NULL);
    transport_free(&r->direct);
    transport_free(&r->total);
    transport_free(&r->last);
    if (r->rp.lops && r->rp.lops->linear->end) r->rp.lops->linear->end(&r->lrun);
    free(r->prior);
    free(r->later);
    free(r->vweight);
}

/* Runs the whole pipeline (see precompute.h and the file comment). */
int precompute_run(prt_scene *scene, const precompute_desc *desc, prt_data *out, prt_error *err) {
    double t_start = prt_now();
    /* desc.light_prior may point into *scene (precompute_desc_apply_scene): copied before the scene moves */
    pc_run *r = prt_calloc(1, sizeof *r, err);
    if (r && desc && desc->light_prior && !(r->prior = strdup(desc->light_prior))) prt_fail(err, "precompute: out of memory");
    memset(out, 0, sizeof *out);
    out->scene = *scene;
    memset(scene, 0, sizeof *scene);
    if (!r || (desc && desc->light_prior && !r->prior)) { free(r); prt_data_free(out); return -1; }
    r->out = out;
    r->plan = out->plan;
    r->pcap = sizeof out->plan;
    int rc = -1, st = -1;
    precompute_desc din = desc ? *desc : (precompute_desc){ 0 };
    din.light_prior = r->prior;
    if (!pc_check_desc(&din, &r->d, &r->rp, err) && !pc_check_scene(&out->scene, err)) {
        int nt = prt_thread_count(r->d.nthreads);
        r->nthreads = nt > PC_MAX_THREADS ? PC_MAX_THREADS : nt;
        out->vis_res = r->d.vis_res;
        out->gather_res = r->d.gather_res;
        st = !(r->later = prt_calloc(1, r->pcap, err)) || pc_factor(r, err) || pc_paths(r, err) || pc_refine(r, err) ||
                     pc_choose(r, err) || pc_setup(r, err) || pc_resume(r, err) ? -1 : 0;
    }
    /* no collective so far: a failure on any rank (OOM included) fails every rank alike here;
     * later, the passes agree at their exchanges (shard.h) */
    if (shard_status(desc ? desc->shard : NULL, st, err)) goto done;
    atomic_init(&r->c.cancelled, 0);
    atomic_init(&r->c.done, 0);
    pthread_mutex_init(&r->c.lock, NULL);
    r->have_lock = true;
    if (pc_plan(r, err)) goto done;
    double td = prt_now(), cd = prt_process_cpu();
    if (pc_direct(r, err)) goto done;
    pc_pass_ran(r, "direct", r->t_sample + prt_now() - td, r->cpu_sample + prt_process_cpu() - cd);
    if (pc_bounces(r, err) || pc_view(r, err)) goto done;
    plan_measured(r);
    prt_checkpoint *ck = r->ck;
    r->ck = NULL;
    if (ckpt_close(ck, err)) goto done;
    pc_finish(r);
    if (pc_transfer_finish(r, err)) goto done;
    out->stats.t_total = prt_now() - t_start;
    out->stats.peak_rss_bytes = pc_peak_rss();
    rc = 0;
done:
    pc_cleanup(r);
    free(r);
    if (rc) prt_data_free(out);
    return rc;
}
