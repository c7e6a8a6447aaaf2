/* vmfpass.c - the direct and gathering passes of the vMF lobe transfer (vmfpass.h,
 * laurijssen-2011 section 5). Why the work is laid out this way: the direct pass runs per
 * vertex (all its active views share one ray origin, so Embree's packets stay coherent) and
 * emits only the slices that differ from the BRDF's own lobe, into per-thread lists; those
 * are sorted by (vertex, view) (so the hash and file do not depend on the thread count),
 * hashed (phash.h) and become the rows every gathering pass fills: the gathering rays are the
 * direct pass's rays again (same seeds), so only slices with a blocked ray can gather. */
#include "vmfpass.h"
#include "checkpoint.h"
#include "check.h"
#include "scene.h"
#include "shard.h"
#include "visibility.h"
#include "vmf.h"
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define VP_MAX_THREADS 64
#define VP_BROAD_KAPPA 8.0f      /* lobes wider than this are "diffuse" light (the last lobe) */
#define VP_DIFFUSE_RAYS 64
/* A fitted part of a lobe is at most this much sharper than the lobe: a straight occluder edge
 * leaves at sharpest a thin strip of the lobe, whose spread along the edge is the lobe's own, so
 * its mean length 1 - 1/(2 kappa) fits 2 kappa. A cluster of one or two rays fits a mean of length
 * ~1 (kappa at half's largest), a sampling artefact that Eq. 7's kappa average (weighted by
 * luminance, not kappa) would let focus a neighbour's lobe onto a sun. */
#define VP_KAPPA_CAP 2.0f
#define VP_MAX_ITEMS_PER_HIT (VMFT_MAX_LOBES + 1)

/* One thing to merge: a mean unnormalized direction r (Eq. 2), weight w, colour c. */
typedef struct vp_item { float r[3]; float w; float c[3]; float kappa; int cluster; } vp_item;

/* A stored slice made by the direct pass: (vertex, view) and its I packed lobes. */
typedef struct vp_entry { uint32_t v, j; uint32_t w[VMFT_MAX_LOBES * VMFT_WORDS]; } vp_entry;

typedef struct vp_list { vp_entry *e; size_t n, cap; bool oom; } vp_list;

typedef struct vp_thread {
    float *dirs;          /* [3 S] the slice's sampled directions */
    float *tdirs;         /* [3 S] those traced (above the horizon) */
    int *tidx;            /* [S] their sample index */
    vis_hit *hits;        /* [S] */
    vp_item *items;       /* [S * VP_MAX_ITEMS_PER_HIT] */
    uint8_t *blocked;     /* [S] */
    vp_list list;
} vp_thread;

typedef struct vp_ctx {
    const transfer_precompute_in *in;
    const prt_mesh *m;
    vmft_data *t;
    int S, I;
    float eps;
    int *gverts, ngverts;         /* vertices of the transfer's materials */
    float (*dlobe)[7];            /* [nverts] diffuse lobe: mu, kappa, alpha rgb (alpha 0: none) */
    vp_thread th[VP_MAX_THREADS];
    double *energy;               /* per glossy vertex (direct) or per stored slice (gathering) */
    uint8_t *hitfit;              /* per stored slice: a ray hit a fitted triangle in pass 1 */
    uint32_t *nactive;            /* per glossy vertex: its active views */
    uint32_t *slot_v, *slot_j;    /* stored slices in (vertex, view) order */
    size_t nslices;
    int pass, total;
    uint8_t *restored;            /* per item of the running stage: restored from the checkpoint */
    const char *stage;
    int off;                      /* the running stage's first item on this rank (vp_stage) */
    shard_pass *sp;               /* its progress over the ranks (shard.h) */
    atomic_long others;           /* rank 0: items the other ranks have done, as last heard */
    atomic_int done;
    atomic_bool cancel;
    pthread_mutex_t lock;
} vp_ctx;

/* ---- sampling ------------------------------------------------------------------------------ */

static uint64_t splitmix(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/* The S directions of slice (v, j) drawn from lobe L (Eq. 8): a rank-1 lattice, rotated by a hash. */
static void vp_samples(const vmf_lobe *L, uint32_t v, uint32_t j, int S, float *dirs) {
    uint64_t h = splitmix(((uint64_t)v << 20) ^ j);
    double r1 = (double)(h >> 40) / 16777216.0, r2 = (double)(h & 0xffffff) / 16777216.0;
    for (int i = 0; i < S; i++) {
        double u1 = (i + 0.5) / S + r1, u2 = i * 0.6180339887498949 + r2;
        u1 -= floor(u1), u2 -= floor(u2);
        vmf_sample(L, (float)u1, (float)u2, dirs + 3 * i);
    }
}

/* Traces slice directions above n's horizon from p; returns how many were traced (tidx, hits). */
static int vp_trace(const vp_ctx *c, vp_thread *th, const float *p, const float *n, int S) {
    int nr = 0;
    for (int i = 0; i < S; i++) {
        const float *d = th->dirs + 3 * i;
        if (n[0] * d[0] + n[1] * d[1] + n[2] * d[2] <= 0) continue;
        memcpy(th->tdirs + 3 * nr, d, 3 * sizeof(float));
        th->tidx[nr++] = i;
    }
    float org[3] = { p[0] + c->eps * n[0], p[1] + c->eps * n[1], p[2] + c->eps * n[2] };
    if (nr) vis_closest_many(c->in->vis, org, th->tdirs, nr, c->eps, th->hits);
    return nr;
}

/* ---- clustering (laurijssen-2010 section 5) ------------------------------------------------- */

/* Dispersion sum w - |sum w r| of cluster k (sums into r). */
static double vp_dispersion(const vp_item *it, int n, int k, double r[3], double *w) {
    r[0] = r[1] = r[2] = 0, *w = 0;
    for (int i = 0; i < n; i++)
        if (it[i].cluster == k) {
            for (int c = 0; c < 3; c++) r[c] += (double)it[i].w * it[i].r[c];
            *w += it[i].w;
        }
    return *w - sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

/* Tries to split cluster k into k and nk by 2-means; keeps it when the dispersion halves. */
static bool vp_split(vp_item *it, int n, int k, int nk) {
    double r[3], w, d1 = vp_dispersion(it, n, k, r, &w);
    int a = -1, b = -1;
    for (int i = 0; i < n; i++)
        if (it[i].cluster == k && (a < 0 || it[i].w > it[a].w)) a = i;
    double lo = 2;
    for (int i = 0; i < n; i++) {
        double d = it[i].r[0] * it[a].r[0] + it[i].r[1] * it[a].r[1] + it[i].r[2] * it[a].r[2];
        if (it[i].cluster == k && d / (sqrt(it[i].r[0] * it[i].r[0] + it[i].r[1] * it[i].r[1] + it[i].r[2] * it[i].r[2]) + 1e-30) < lo)
            lo = d / (sqrt(it[i].r[0] * it[i].r[0] + it[i].r[1] * it[i].r[1] + it[i].r[2] * it[i].r[2]) + 1e-30), b = i;
    }
    if (b < 0 || b == a || !(d1 > 0)) return false;
    double ca[3] = { it[a].r[0], it[a].r[1], it[a].r[2] }, cb[3] = { it[b].r[0], it[b].r[1], it[b].r[2] };
    for (int iter = 0; iter < 8; iter++) {
        for (int i = 0; i < n; i++) {
            if (it[i].cluster != k && it[i].cluster != nk) continue;
            double da = ca[0] * it[i].r[0] + ca[1] * it[i].r[1] + ca[2] * it[i].r[2];
            double db = cb[0] * it[i].r[0] + cb[1] * it[i].r[1] + cb[2] * it[i].r[2];
            it[i].cluster = db > da ? nk : k;
        }
        double wa, wb;
        vp_dispersion(it, n, k, ca, &wa), vp_dispersion(it, n, nk, cb, &wb);
        double la = sqrt(ca[0] * ca[0] + ca[1] * ca[1] + ca[2] * ca[2]), lb = sqrt(cb[0] * cb[0] + cb[1] * cb[1] + cb[2] * cb[2]);
        for (int c = 0; c < 3; c++) ca[c] /= la > 0 ? la : 1, cb[c] /= lb > 0 ? lb : 1;
    }
    double wa, wb, d2 = vp_dispersion(it, n, k, r, &wa) + vp_dispersion(it, n, nk, r, &wb);
    if (wa > 0 && wb > 0 && d2 < 0.5 * d1) return true;
    for (int i = 0; i < n; i++)
        if (it[i].cluster == nk) it[i].cluster = k;
    return false;
}

/* Clusters items whose cluster is `first` into clusters first..first+maxk-1; returns the count. */
static int vp_cluster(vp_item *it, int n, int first, int maxk) {
    int k = 1;
    while (k < maxk) {
        int worst = -1;
        double wd = 0;
        for (int c = first; c < first + k; c++) {
            double r[3], w, d = vp_dispersion(it, n, c, r, &w);
            if (d > wd) wd = d, worst = c;
        }
        if (worst < 0 || !vp_split(it, n, worst, first + k)) break;
        k++;
    }
    return k;
}

/* Merges cluster k (Eq. 10-11) into lobe l, colour a; false when it is empty. */
static bool vp_merge(const vp_item *it, int n, int k, vmf_lobe *l, float a[3]) {
    double r[3], w;
    vp_dispersion(it, n, k, r, &w);
    double c[3] = { 0, 0, 0 };
    for (int i = 0; i < n; i++)
        if (it[i].cluster == k)
            for (int ch = 0; ch < 3; ch++) c[ch] += it[i].c[ch];
    if (!(w > 0)) return false;
    double m[3] = { r[0] / w, r[1] / w, r[2] / w };
    vmf_from_mean(m, l);
    for (int ch = 0; ch < 3; ch++) a[ch] = (float)c[ch];
    return prt_luminancef(a) > 0;
}

/* Sorts n lobes by decreasing luminance (the runtime's correspondence between views, vmf.h). */
static void vp_sort(vmf_lobe *l, float (*a)[3], int n) {
    for (int i = 1; i < n; i++)
        for (int k = i; k > 0 && prt_luminancef(a[k]) > prt_luminancef(a[k - 1]); k--) {
            vmf_lobe tl = l[k];
            l[k] = l[k - 1], l[k - 1] = tl;
            for (int ch = 0; ch < 3; ch++) { float x = a[k][ch]; a[k][ch] = a[k - 1][ch], a[k - 1][ch] = x; }
        }
}

/* Packs I lobes (alpha 0: empty). */
static void vp_pack(const vmf_lobe *l, const float (*a)[3], int I, uint32_t *w) {
    for (int i = 0; i < I; i++) vmft_pack(&l[i], a[i], w + VMFT_WORDS * i);
}

/* ---- the direct pass (Eq. 8-9) -------------------------------------------------------------- */

/* One cluster refitted with the control variate of vmfpass.h: the whole lobe's exact mean minus the
 * blocked rays. */
static void vp_refit_one(const vp_thread *th, int S, int nb, const vmf_lobe *L, const float A[3], vmf_lobe *l, float a[3]) {
    double m = S * vmf_mean_length(L->kappa), r[3];
    for (int k = 0; k < 3; k++) r[k] = m * L->mu[k];
    for (int i = 0; i < S; i++)
        if (th->blocked[i])
            for (int k = 0; k < 3; k++) r[k] -= th->dirs[3 * i + k];
    for (int k = 0; k < 3; k++) r[k] /= (S - nb);
    vmf_from_mean(r, l);
    for (int k = 0; k < 3; k++) a[k] = A[k] * (float)(S - nb) / (float)S;
}

static bool vp_active(const vp_ctx *c, int v, int j) {
    const float *n = c->m->nrm + 3 * (size_t)v, *g = geogrid_dir(c->t->grid, j);
    return n[0] * g[0] + n[1] * g[1] + n[2] * g[2] > -c->t->horizon;
}

/* Slice (v, j) of the direct pass: false when view j is inactive at v or no ray is blocked (the slice
 * is the BRDF's own lobe); else its I lobes packed into w. *e gets the slice's energy (alpha luminance). */
static bool vp_direct_slice(const vp_ctx *c, vp_thread *th, int v, int j, uint32_t *w, double *e) {
    const float *n = c->m->nrm + 3 * (size_t)v, *p = c->m->pos + 3 * (size_t)v, *g = geogrid_dir(c->t->grid, j);
    *e = 0;
    if (!vp_active(c, v, j)) return false;
    vmf_lobe L;
    float A[3];
    vmft_brdf_lobe(&c->t->fit[c->m->mat[v]], n, g, &L, A);
    *e = prt_luminancef(A);
    int S = c->S, nb = 0;
    vp_samples(&L, (uint32_t)v, (uint32_t)j, S, th->dirs);
    int nr = vp_trace(c, th, p, n, S);
    memset(th->blocked, 0, (size_t)S);
    for (int i = 0; i < nr; i++)
        if (th->hits[i].tri >= 0) th->blocked[th->tidx[i]] = 1, nb++;
    if (nb == 0) return false;
    int ni = 0;
    for (int i = 0; i < S; i++)
        if (!th->blocked[i]) {
            vp_item *it = &th->items[ni++];
            memcpy(it->r, th->dirs + 3 * i, sizeof it->r);
            it->w = 1, it->cluster = 0;
            for (int k = 0; k < 3; k++) it->c[k] = A[k] / (float)S;
        }
    vmf_lobe l[VMFT_MAX_LOBES] = { { { 0, 0, 1 }, 0 } };
    float a[VMFT_MAX_LOBES][3] = { { 0 } };
    int k = ni ? vp_cluster(th->items, ni, 0, c->I) : 0;
    /* the control variate's error is the blocked rays' noise over the unblocked count: it wins
     * while fewer than half the rays are blocked, the plain mean (Eq. 2) beyond */
    bool cv = k == 1 && 2 * nb < S;
    if (cv) vp_refit_one(th, S, nb, &L, A, &l[0], a[0]);
    for (int q = 0; !cv && q < k; q++) vp_merge(th->items, ni, q, &l[q], a[q]);
    for (int q = 0; q < k; q++) l[q].kappa = fminf(l[q].kappa, VP_KAPPA_CAP * L.kappa);
    vp_sort(l, a, k);
    vp_pack(l, (const float (*)[3])a, c->I, w);
    *e = 0;
    for (int q = 0; q < k; q++) *e += prt_luminancef(a[q]);
    return true;
}

static bool vp_list_push(vp_list *L, uint32_t v, uint32_t j, const uint32_t *w) {
    if (L->n == L->cap) {
        size_t cap = L->cap ? 2 * L->cap : 1024;
        vp_entry *e = realloc(L->e, cap * sizeof *e);
        if (!e) return L->oom = true, false;
        L->e = e, L->cap = cap;
    }
    vp_entry *e = &L->e[L->n++];
    e->v = v, e->j = j;
    memcpy(e->w, w, sizeof e->w);
    return true;
}

/* Reports a finished chunk of `count` items (with, on rank 0, the other ranks' count, exchanged by
 * thread 0, the caller's: shard.h); sets cancel when the callback says stop. */
static void vp_progress(vp_ctx *c, int count, int thread) {
    atomic_fetch_add(&c->done, count);
    if (thread == 0) atomic_store(&c->others, shard_pass_poll(c->sp, atomic_load(&c->done)));
    if (!c->in->progress) return;
    pthread_mutex_lock(&c->lock);
    /* read under the lock, so the fractions reported rise; others only grows */
    long done = atomic_load(&c->done) + atomic_load(&c->others);
    if (!atomic_load(&c->cancel) && !c->in->progress(c->in->progress_user, c->stage, (double)done / c->total))
        atomic_store(&c->cancel, true);
    pthread_mutex_unlock(&c->lock);
}

/* Whether nothing of the scene lies above v's tangent plane: every traced ray leaves from p + eps n
 * with n.d > 0, so a hit point y has n.(y - p) >= eps, and a triangle whose corners are all below
 * eps / 2 of the plane cannot be hit. Such a vertex (a convex hull's, most of a sphere's) needs no
 * sampling or tracing: each active slice is the BRDF's own lobe. One pass over the vertices, leaving
 * at the first above (most occluded vertices leave early); small beside 162 x 64 rays. */
static bool vp_open(const vp_ctx *c, int v) {
    const float *n = c->m->nrm + 3 * (size_t)v, *p = c->m->pos + 3 * (size_t)v, *x = c->m->pos;
    float lim = n[0] * p[0] + n[1] * p[1] + n[2] * p[2] + 0.5f * c->eps;
    for (int i = 0; i < c->m->nverts; i++)
        if (n[0] * x[3 * i] + n[1] * x[3 * i + 1] + n[2] * x[3 * i + 2] >= lim) return false;
    return true;
}

/* The energy (alpha luminance) of slice (v, j) when nothing can block it: its BRDF lobe's, 0 inactive. */
static double vp_open_slice(const vp_ctx *c, int v, int j) {
    if (!vp_active(c, v, j)) return 0;
    vmf_lobe L;
    float A[3];
    vmft_brdf_lobe(&c->t->fit[c->m->mat[v]], c->m->nrm + 3 * (size_t)v, geogrid_dir(c->t->grid, j), &L, A);
    return prt_luminancef(A);
}

/* The checkpoint blob of glossy vertex gi (pass in->ckpt_pass): energy, active views and its stored
 * slices (the last n of the thread's list), each a view and its I packed lobes. */
static void vp_record_vertex(const vp_ctx *c, int gi, const vp_list *L, size_t first) {
    if (!c->in->ckpt) return;
    size_t per = 4 + 4 * (size_t)c->I * VMFT_WORDS, n = L->n - first, len = 16 + n * per;
    uint8_t *b = malloc(len);
    if (!b) return;   /* not recorded: a resume computes it again */
    uint32_t cnt = (uint32_t)n;
    memcpy(b, &c->energy[gi], 8), memcpy(b + 8, &c->nactive[gi], 4), memcpy(b + 12, &cnt, 4);
    for (size_t i = 0; i < n; i++) {
        memcpy(b + 16 + i * per, &L->e[first + i].j, 4);
        memcpy(b + 20 + i * per, L->e[first + i].w, per - 4);
    }
    ckpt_add_blob(c->in->ckpt, c->in->ckpt_pass, (uint32_t)gi, b, (uint32_t)len);
    free(b);
}

/* Restores one blob of vp_record_vertex into the context (its slices into thread 0's list: vp_build
 * sorts every list). Returns 0, or -1 when it does not fit. */
static int vp_restore_vertex(void *user, uint32_t gi, const uint8_t *b, uint32_t len) {
    vp_ctx *c = user;
    size_t per = 4 + 4 * (size_t)c->I * VMFT_WORDS;
    uint32_t cnt;
    if (gi >= (uint32_t)c->ngverts || len < 16) return -1;
    memcpy(&cnt, b + 12, 4);
    if (len != 16 + cnt * per) return -1;
    memcpy(&c->energy[gi], b, 8), memcpy(&c->nactive[gi], b + 8, 4);
    for (uint32_t i = 0; i < cnt; i++) {
        uint32_t j, w[VMFT_MAX_LOBES * VMFT_WORDS] = { 0 };
        memcpy(&j, b + 16 + i * per, 4);
        memcpy(w, b + 20 + i * per, per - 4);
        if (j >= (uint32_t)c->t->nviews || !vp_list_push(&c->th[0].list, (uint32_t)c->gverts[gi], j, w)) return -1;
    }
    c->restored[gi] = 1;
    return 0;
}

static void vp_direct_range(void *ctx, int begin, int end, int thread) {
    vp_ctx *c = ctx;
    vp_thread *th = &c->th[thread];
    for (int gi = c->off + begin; gi < c->off + end && !atomic_load(&c->cancel); gi++) {
        if (c->restored && c->restored[gi]) continue;
        size_t first = th->list.n;
        int v = c->gverts[gi];
        double ev = 0, e;
        uint32_t w[VMFT_MAX_LOBES * VMFT_WORDS] = { 0 }, na = 0;
        bool open = vp_open(c, v);
        for (int j = 0; j < c->t->nviews; j++) {
            if (open) e = vp_open_slice(c, v, j);
            else if (vp_direct_slice(c, th, v, j, w, &e)) vp_list_push(&th->list, (uint32_t)v, (uint32_t)j, w);
            ev += e;
            na += e > 0 || vp_active(c, v, j);
        }
        c->energy[gi] = ev;
        c->nactive[gi] = na;
        vp_record_vertex(c, gi, &th->list, first);
    }
    vp_progress(c, end - begin, thread);
}

/* Renumbers the entries in slot order (the validator's rule, vmf.h), moving their lobes. */
static int vp_renumber(vmft_data *t, size_t per, prt_error *err) {
    uint32_t *lobe = prt_calloc(t->hash.n ? t->hash.n * per : 1, sizeof(uint32_t), err);
    if (!lobe) return -1;
    uint32_t k = 0;
    for (size_t s = 0; s < t->hash.size; s++) {
        if (t->entry[s] == UINT32_MAX) continue;
        memcpy(lobe + (size_t)k * per, t->lobe + (size_t)t->entry[s] * per, sizeof(uint32_t) * per);
        t->entry[s] = k++;
    }
    free(t->lobe);
    t->lobe = lobe;
    return 0;
}

static int vp_entry_cmp(const void *a, const void *b) {
    const vp_entry *x = a, *y = b;
    return x->v != y->v ? (x->v < y->v ? -1 : 1) : x->j != y->j ? (x->j < y->j ? -1 : 1) : 0;
}

/* The threads' stored slices, sorted by (vertex, view), into the hash, the slot list and pass 0's
 * lobes of an R-pass lobe array. Returns 0 or -1 (OOM). */
static int vp_build(vp_ctx *c, int R, prt_error *err) {
    size_t n = 0;
    for (int i = 0; i < VP_MAX_THREADS; i++) {
        if (c->th[i].list.oom) return prt_fail(err, "vmf precompute: out of memory (stored slices)");
        n += c->th[i].list.n;
    }
    vp_entry *all = prt_calloc(n ? n : 1, sizeof *all, err);
    if (!all) return -1;
    for (int i = 0, k = 0; i < VP_MAX_THREADS; i++) {
        if (c->th[i].list.n) memcpy(all + k, c->th[i].list.e, c->th[i].list.n * sizeof *all);
        k += (int)c->th[i].list.n;
        free(c->th[i].list.e);
        c->th[i].list = (vp_list){ 0 };
    }
    qsort(all, n, sizeof *all, vp_entry_cmp);
    vmft_data *t = c->t;
    c->slot_v = prt_calloc(n ? n : 1, sizeof(uint32_t), err);
    c->slot_j = c->slot_v ? prt_calloc(n ? n : 1, sizeof(uint32_t), err) : NULL;
    int rc = c->slot_j ? 0 : -1;
    for (size_t e = 0; rc == 0 && e < n; e++) c->slot_v[e] = all[e].v, c->slot_j[e] = all[e].j;
    if (rc == 0) rc = phash_build(c->slot_v, c->slot_j, n, t->nverts, t->nviews, &t->hash, err);
    size_t per = (size_t)R * t->lobes * VMFT_WORDS;
    if (rc == 0) t->lobe = prt_calloc(n ? n * per : 1, sizeof(uint32_t), err);
    if (rc == 0 && t->lobe) t->entry = prt_calloc(t->hash.size ? t->hash.size : 1, sizeof(uint32_t), err);
    if (rc == 0 && !t->entry) rc = -1;
    t->passes = R;
    for (size_t s = 0; rc == 0 && s < t->hash.size; s++) t->entry[s] = UINT32_MAX;
    for (size_t e = 0; rc == 0 && e < n; e++) {
        memcpy(t->lobe + e * per, all[e].w, sizeof(uint32_t) * t->lobes * VMFT_WORDS);
        long s = phash_find(&t->hash, all[e].v, all[e].j);
        PRT_CHECK(s >= 0);
        t->entry[s] = (uint32_t)e;
    }
    /* entries in slot order (vmf.h): renumber them by a pass over the slots */
    if (rc == 0) rc = vp_renumber(t, per, err);
    if (rc == 0) rc = vmft_index(t, err);   /* the gathering passes' lookups (vmft_interp) use it */
    c->nslices = n;
    free(all);
    return rc;
}

/* ---- gathering (section 5.2) ------------------------------------------------------------------ */

/* The lobes hit h of direction s gives toward the slice's vertex, as items of colour A alpha / S
 * (vmfpass.h): Eq. 7 over the hit triangle's fitted corners and the grid views of -s (pass - 1),
 * and in pass 1 the corners' diffuse lobes. Returns the item count. */
static int vp_hit_items(const vp_ctx *c, const vis_hit *h, const float *s, const float A[3], vp_item *out) {
    const prt_mesh *m = c->m;
    const uint32_t *tri = m->tris + 3 * (size_t)h->tri;
    float b[3] = { 1 - h->u - h->v, h->u, h->v }, nh[3] = { 0, 0, 0 }, wo[3] = { -s[0], -s[1], -s[2] };
    for (int k = 0; k < 3; k++)
        for (int q = 0; q < 3; q++) nh[q] += b[k] * m->nrm[3 * (size_t)tri[k] + q];
    float nl = sqrtf(nh[0] * nh[0] + nh[1] * nh[1] + nh[2] * nh[2]);
    if (!(nl > 0) || nh[0] * wo[0] + nh[1] * wo[1] + nh[2] * wo[2] <= 0) return 0;   /* seen from behind */
    for (int q = 0; q < 3; q++) nh[q] /= nl;
    vmf_lobe l[VMFT_MAX_LOBES + 1];
    float a[VMFT_MAX_LOBES + 1][3];
    int vert[9], view[9], np = 0, nlb = 0, gv[3];
    float w[9], gw[3];
    bool fitted = false;   /* a hit on other materials only (a Lambert floor) needs no grid location */
    for (int k = 0; k < 3; k++) fitted |= (c->t->materials >> m->mat[tri[k]]) & 1;
    if (fitted) geogrid_locate(c->t->grid, wo, gv, gw);
    for (int k = 0; k < 3 && fitted; k++)
        for (int q = 0; q < 3 && ((c->t->materials >> m->mat[tri[k]]) & 1); q++)
            vert[np] = (int)tri[k], view[np] = gv[q], w[np++] = b[k] * gw[q];
    if (np) vmft_interp(c->t, m, np, vert, view, w, c->pass - 1, wo, nh, l, a), nlb = c->t->lobes;
    if (c->pass == 1) {   /* the corners' direct diffuse lobes, Eq. 7 over the triangle */
        double mu[3] = { 0, 0, 0 }, kap = 0, aw = 0, al[3] = { 0, 0, 0 };
        for (int k = 0; k < 3; k++) {
            const float *d = c->dlobe[tri[k]];
            double x = b[k] * prt_luminancef(d + 4);
            for (int q = 0; q < 3; q++) mu[q] += x * d[q], al[q] += b[k] * d[4 + q];
            kap += x * d[3], aw += x;
        }
        double ml = sqrt(mu[0] * mu[0] + mu[1] * mu[1] + mu[2] * mu[2]);
        if (aw > 0 && ml > 0) {
            for (int q = 0; q < 3; q++) l[nlb].mu[q] = (float)(mu[q] / ml), a[nlb][q] = (float)al[q];
            l[nlb++].kappa = (float)(kap / aw);
        }
    }
    int ni = 0;
    for (int i = 0; i < nlb; i++) {
        if (!(prt_luminancef(a[i]) > 0)) continue;
        vp_item *it = &out[ni++];
        double r = vmf_mean_length(l[i].kappa);
        for (int q = 0; q < 3; q++) it->r[q] = (float)(r * l[i].mu[q]), it->c[q] = A[q] * a[i][q] / (float)c->S;
        it->w = prt_luminancef(it->c), it->kappa = l[i].kappa, it->cluster = 0;
    }
    return ni;
}

/* Merges a slice's gathered items into I lobes: broad ones into the last lobe (I >= 2), sharp
 * ones clustered into the others, sorted; returns the energy. */
static double vp_gather_merge(const vp_ctx *c, vp_item *it, int ni, uint32_t *w) {
    int I = c->I, broad = I >= 2 ? I - 1 : -1;
    for (int i = 0; i < ni; i++) it[i].cluster = broad >= 0 && it[i].kappa < VP_BROAD_KAPPA ? broad : 0;
    vmf_lobe l[VMFT_MAX_LOBES];
    float a[VMFT_MAX_LOBES][3];
    for (int i = 0; i < I; i++) l[i] = (vmf_lobe){ { 0, 0, 1 }, 0 }, a[i][0] = a[i][1] = a[i][2] = 0;
    int ks = 0;
    for (int i = 0; i < ni && !ks; i++) ks = it[i].cluster == 0;
    if (ks) ks = vp_cluster(it, ni, 0, broad >= 0 ? I - 1 : I);
    for (int q = 0; q < ks; q++) vp_merge(it, ni, q, &l[q], a[q]);
    vp_sort(l, a, ks);
    if (broad >= 0) vp_merge(it, ni, broad, &l[broad], a[broad]);
    vp_pack(l, (const float (*)[3])a, I, w);
    double e = 0;
    for (int q = 0; q < I; q++) e += prt_luminancef(a[q]);
    return e;
}

/* Where stored slice e's lobes of the running pass live in the transfer. */
static uint32_t *vp_slice_lobes(const vp_ctx *c, size_t e) {
    long s = phash_find(&c->t->hash, c->slot_v[e], c->slot_j[e]);
    PRT_CHECK(s >= 0);
    return c->t->lobe + (((size_t)c->t->entry[s] * c->t->passes + (size_t)c->pass) * c->t->lobes) * VMFT_WORDS;
}

/* Traces slice (v, j)'s rays (the direct pass's: same seeds) into th; A gets its BRDF lobe's
 * colour. Returns the rays traced. */
static int vp_slice_rays(const vp_ctx *c, vp_thread *th, int v, int j, float A[3]) {
    const float *n = c->m->nrm + 3 * (size_t)v, *p = c->m->pos + 3 * (size_t)v;
    vmf_lobe L;
    vmft_brdf_lobe(&c->t->fit[c->m->mat[v]], n, geogrid_dir(c->t->grid, j), &L, A);
    vp_samples(&L, (uint32_t)v, (uint32_t)j, c->S, th->dirs);
    return vp_trace(c, th, p, n, c->S);
}

/* Slice (v, j) of pass c->pass: its rays' hits gathered and merged into w (I packed lobes); *fit:
 * a ray hit a fitted triangle. Returns the energy. */
static double vp_gather_core(const vp_ctx *c, vp_thread *th, int v, int j, uint32_t *w, bool *fit) {
    float A[3];
    int nr = vp_slice_rays(c, th, v, j, A), ni = 0;
    *fit = false;
    for (int i = 0; i < nr; i++)
        if (th->hits[i].tri >= 0 && th->hits[i].tri < c->m->ntris) {
            ni += vp_hit_items(c, &th->hits[i], th->tdirs + 3 * i, A, th->items + ni);
            const uint32_t *tri = c->m->tris + 3 * (size_t)th->hits[i].tri;
            for (int k = 0; k < 3; k++) *fit |= (c->t->materials >> c->m->mat[tri[k]]) & 1;
        }
    return vp_gather_merge(c, th->items, ni, w);
}

/* Stored slice e (pass c->pass): the direct pass's rays again, their hits gathered and merged. */
static void vp_gather_slice(vp_ctx *c, vp_thread *th, size_t e) {
    int v = (int)c->slot_v[e], j = (int)c->slot_j[e];
    /* passes >= 2 gather only the fitted corners' previous pass (diffuse lobes are pass 1's): a
     * slice none of whose rays hit a fitted triangle in pass 1 gathers nothing again (same rays) */
    if (c->pass >= 2 && !c->hitfit[e]) { c->energy[e] = 0; return; }
    bool fit;
    uint32_t *w = vp_slice_lobes(c, e);
    c->energy[e] = vp_gather_core(c, th, v, j, w, &fit);
    if (c->pass == 1) c->hitfit[e] = fit;
    if (c->in->ckpt) {   /* its checkpoint blob (in->ckpt_pass + pass): energy, hit flag, lobes */
        uint8_t b[9 + 4 * VMFT_MAX_LOBES * VMFT_WORDS];
        memcpy(b, &c->energy[e], 8), b[8] = c->hitfit[e];
        memcpy(b + 9, w, 4 * (size_t)c->I * VMFT_WORDS);
        ckpt_add_blob(c->in->ckpt, c->in->ckpt_pass + c->pass, (uint32_t)e, b, 9 + 4 * (uint32_t)c->I * VMFT_WORDS);
    }
}

/* Restores one slice's blob (vp_gather_slice) of the running pass. Returns 0, or -1 when it does not fit. */
static int vp_restore_slice(void *user, uint32_t e, const uint8_t *b, uint32_t len) {
    vp_ctx *c = user;
    if (e >= c->nslices || len != 9 + 4 * (uint32_t)c->I * VMFT_WORDS) return -1;
    memcpy(&c->energy[e], b, 8);
    if (c->pass == 1) c->hitfit[e] = b[8];
    memcpy(vp_slice_lobes(c, e), b + 9, 4 * (size_t)c->I * VMFT_WORDS);
    c->restored[e] = 1;
    return 0;
}

static void vp_gather_range(void *ctx, int begin, int end, int thread) {
    vp_ctx *c = ctx;
    for (int e = c->off + begin; e < c->off + end && !atomic_load(&c->cancel); e++)
        if (!c->restored || !c->restored[e]) vp_gather_slice(c, &c->th[thread], (size_t)e);
    vp_progress(c, end - begin, thread);
}

/* ---- diffuse lobes of the hit surfaces ------------------------------------------------------- */

/* Vertex v's direct diffuse radiance as a lobe (vmfpass.h): cosine-distributed rays, the unblocked
 * ones' mean direction, colour kd * unblocked share. */
static void vp_diffuse_vertex(const vp_ctx *c, vp_thread *th, int v) {
    float *out = c->dlobe[v];
    const float *kd = c->in->scene->materials[c->m->mat[v]].kd, *n = c->m->nrm + 3 * (size_t)v;
    memset(out, 0, 7 * sizeof(float));
    if (!(prt_luminancef(kd) > 0)) return;
    float s[3], t[3];
    brdf_frame(n, s, t);
    uint64_t h = splitmix(~(uint64_t)v);
    double r1 = (double)(h >> 40) / 16777216.0, r2 = (double)(h & 0xffffff) / 16777216.0;
    for (int i = 0; i < VP_DIFFUSE_RAYS; i++) {
        double u1 = (i + 0.5) / VP_DIFFUSE_RAYS + r1, u2 = i * 0.6180339887498949 + r2;
        u1 -= floor(u1), u2 -= floor(u2);
        double st = sqrt(u1), ct = sqrt(1 - u1), ph = 2 * M_PI * u2;
        for (int k = 0; k < 3; k++) th->dirs[3 * i + k] = (float)(st * cos(ph) * s[k] + st * sin(ph) * t[k] + ct * n[k]);
    }
    int nr = vp_trace(c, th, c->m->pos + 3 * (size_t)v, n, VP_DIFFUSE_RAYS), nv = 0;
    double r[3] = { 0, 0, 0 };
    for (int i = 0; i < nr; i++)
        if (th->hits[i].tri < 0)
            for (int k = 0; k < 3; k++) r[k] += th->tdirs[3 * i + k];
    for (int i = 0; i < nr; i++) nv += th->hits[i].tri < 0;
    if (!nv) return;
    for (int k = 0; k < 3; k++) r[k] /= nv;
    vmf_lobe l;
    vmf_from_mean(r, &l);
    for (int k = 0; k < 3; k++) out[k] = l.mu[k], out[4 + k] = kd[k] * (float)nv / VP_DIFFUSE_RAYS;
    out[3] = l.kappa;
}

static void vp_diffuse_range(void *ctx, int begin, int end, int thread) {
    vp_ctx *c = ctx;
    for (int v = c->off + begin; v < c->off + end && !atomic_load(&c->cancel); v++) vp_diffuse_vertex(c, &c->th[thread], v);
    vp_progress(c, end - begin, thread);
}

/* ---- the run ---------------------------------------------------------------------------------- */

/* After the diffuse stage on every rank: each rank's vertices' lobes to every rank. */
static int vp_share_diffuse(vp_ctx *c, const int *first, prt_error *err) {
    return shard_share_rows(c->in->shard, c->dlobe, sizeof *c->dlobe, first, err);
}

/* After the direct stage: each rank's energies, active counts and stored slices (the threads'
 * lists, joined into thread 0's) to every rank; vp_build sorts the slices, so the order they
 * arrive in changes nothing. */
static int vp_share_direct(vp_ctx *c, const int *first, prt_error *err) {
    prt_shard *sh = c->in->shard;
    if (shard_size(sh) == 1) return 0;
    vp_list *L = &c->th[0].list;
    for (int i = 1; i < VP_MAX_THREADS; i++) {
        for (size_t k = 0; k < c->th[i].list.n; k++) vp_list_push(L, c->th[i].list.e[k].v, c->th[i].list.e[k].j, c->th[i].list.e[k].w);
        free(c->th[i].list.e);
        c->th[i].list = (vp_list){ .oom = c->th[i].list.oom };
    }
    for (int i = 0; i < VP_MAX_THREADS; i++)
        if (c->th[i].list.oom) return prt_fail(err, "vmf precompute: out of memory (stored slices)");
    if (shard_share_rows(sh, c->energy, sizeof *c->energy, first, err) ||
        shard_share_rows(sh, c->nactive, sizeof *c->nactive, first, err))
        return -1;
    void *e = L->e;
    if (shard_share_list(sh, &e, &L->n, sizeof *L->e, err)) return -1;
    L->e = e, L->cap = L->n;
    return 0;
}

/* After a gathering stage: each rank's slices' energies, pass-1 hit flags and lobes of this pass
 * (scattered over the hash's entries, so gathered in slice order for the exchange) to every rank. */
static int vp_share_gather(vp_ctx *c, const int *first, prt_error *err) {
    prt_shard *sh = c->in->shard;
    if (shard_size(sh) == 1) return 0;
    size_t per = (size_t)c->t->lobes * VMFT_WORDS;
    uint32_t *buf = prt_calloc(c->nslices * per + 1, sizeof *buf, err);
    if (!buf) return -1;
    for (int e = first[shard_rank(sh)]; e < first[shard_rank(sh) + 1]; e++)
        memcpy(buf + (size_t)e * per, vp_slice_lobes(c, (size_t)e), per * sizeof *buf);
    int rc = shard_share_rows(sh, c->energy, sizeof *c->energy, first, err) ||
             shard_share_rows(sh, c->hitfit, sizeof *c->hitfit, first, err) ||
             shard_share_rows(sh, buf, per * sizeof *buf, first, err) ? -1 : 0;
    for (size_t e = 0; rc == 0 && e < c->nslices; e++) memcpy(vp_slice_lobes(c, e), buf + e * per, per * sizeof *buf);
    free(buf);
    return rc;
}

/* vp_stage's work (below). */
static int vp_stage_run(vp_ctx *c, const char *stage, int n, int grain, prt_range_fn fn, int ckpass,
                        int (*restore)(void *, uint32_t, const uint8_t *, uint32_t),
                        int (*share)(vp_ctx *, const int *, prt_error *), prt_error *err) {
    c->stage = stage, c->total = n > 0 ? n : 1;
    atomic_store(&c->done, 0);
    atomic_store(&c->others, 0);
    free(c->restored);
    c->restored = NULL;
    if (ckpass >= 0 && ckpt_count(c->in->ckpt, ckpass) > 0) {
        c->restored = prt_calloc((size_t)n + 1, 1, err);
        if (!c->restored || ckpt_restore_blobs(c->in->ckpt, ckpass, restore, c, err) < 0) return -1;
    }
    int first[SHARD_MAX_RANKS + 1], rank = shard_rank(c->in->shard);
    shard_split(c->in->shard, NULL, n, first);
    c->off = first[rank];
    if (!(c->sp = shard_pass_begin(c->in->shard, stage, fn == vp_gather_range ? "slices" : "vertices", n, err))) return -1;
    prt_parallel_for(first[rank + 1] - first[rank], grain, c->in->nthreads, fn, c);
    shard_pass_end(c->sp, atomic_load(&c->done), c->in->progress, c->in->progress_user);
    c->sp = NULL;
    int st = atomic_load(&c->cancel) ? prt_fail(err, "vmf precompute: cancelled") : 0;
    if (shard_status(c->in->shard, st, err)) return -1;
    return share(c, first, err);
}

/* One stage over n items in chunks of grain: fn through prt_parallel_for on this rank's range of
 * them (shard.h: cut by count; one process: all), progress as `stage` over every rank; with a
 * checkpoint, the items of its pass ckpass (-1: none) that it holds are restored first (restore)
 * and skipped. Then the ranks' common status (cancelled on one: on all) and share, which gives
 * every rank the others' results; in->pass_done is told the stage's time. */
static int vp_stage(vp_ctx *c, const char *stage, int n, int grain, prt_range_fn fn, int ckpass,
                    int (*restore)(void *, uint32_t, const uint8_t *, uint32_t),
                    int (*share)(vp_ctx *, const int *, prt_error *), prt_error *err) {
    double w0 = prt_now(), c0 = prt_process_cpu();
    int rc = vp_stage_run(c, stage, n, grain, fn, ckpass, restore, share, err);
    if (!rc && c->in->pass_done) c->in->pass_done(c->in->pass_user, stage, prt_now() - w0, prt_process_cpu() - c0);
    return rc;
}

/* The transfer's materials fitted (lobefit.h), its vertices listed, the scratch allocated. */
static int vp_setup(vp_ctx *c, const prt_transfer *tr, prt_error *err) {
    const prt_scene *sc = c->in->scene;
    for (int mi = 0; mi < sc->nmaterials; mi++) {
        if (!((tr->materials >> mi) & 1)) continue;
        prt_error e2;
        if (lobefit_fit(&sc->materials[mi], &(lobefit_desc){ 0 }, &c->t->fit[mi], &e2))
            return prt_fail(err, "vmf precompute: material %d (%s): %s", mi, sc->material_spec[mi], e2.msg);
    }
    c->gverts = prt_calloc((size_t)c->m->nverts + 1, sizeof(int), err);
    c->dlobe = c->gverts ? prt_calloc((size_t)c->m->nverts + 1, sizeof *c->dlobe, err) : NULL;
    if (!c->dlobe) return -1;
    for (int v = 0; v < c->m->nverts; v++)
        if ((tr->materials >> c->m->mat[v]) & 1) c->gverts[c->ngverts++] = v;
    c->energy = prt_calloc((size_t)c->ngverts + 1, sizeof(double), err);
    c->nactive = c->energy ? prt_calloc((size_t)c->ngverts + 1, sizeof(uint32_t), err) : NULL;
    if (!c->nactive) return -1;
    int nt = prt_thread_count(c->in->nthreads), S = c->S > VP_DIFFUSE_RAYS ? c->S : VP_DIFFUSE_RAYS;
    for (int i = 0; i < nt && i < VP_MAX_THREADS; i++) {
        vp_thread *th = &c->th[i];
        th->dirs = malloc(sizeof(float) * 3 * S), th->tdirs = malloc(sizeof(float) * 3 * S);
        th->tidx = malloc(sizeof(int) * S), th->hits = malloc(sizeof(vis_hit) * S), th->blocked = malloc((size_t)S);
        th->items = malloc(sizeof(vp_item) * (size_t)S * VP_MAX_ITEMS_PER_HIT);
        if (!th->dirs || !th->tdirs || !th->tidx || !th->hits || !th->blocked || !th->items)
            return prt_fail(err, "vmf precompute: out of memory");
    }
    return 0;
}

static void vp_teardown(vp_ctx *c) {
    for (int i = 0; i < VP_MAX_THREADS; i++) {
        vp_thread *th = &c->th[i];
        free(th->dirs), free(th->tdirs), free(th->tidx), free(th->hits), free(th->blocked), free(th->items), free(th->list.e);
    }
    free(c->gverts), free(c->dlobe), free(c->energy), free(c->hitfit), free(c->nactive), free(c->slot_v), free(c->slot_j);
    free(c->restored);
    pthread_mutex_destroy(&c->lock);
}

/* Keeps the first R of t's passes (the lobe array re-laid out for R). */
static void vp_compact(vmft_data *t, int R) {
    if (R == t->passes) return;
    size_t I3 = (size_t)t->lobes * VMFT_WORDS;
    for (size_t e = 0; e < t->hash.n; e++)
        memmove(t->lobe + e * R * I3, t->lobe + e * t->passes * I3, sizeof(uint32_t) * R * I3);
    t->passes = R;
}

/* Gathering passes 1..R-1 until one carries less than the threshold (vmfpass.h). Returns 0 or -1. */
static int vp_gather_passes(vp_ctx *c, double e0, int R, prt_error *err) {
    vmft_data *t = c->t;
    int done = 1;
    free(c->energy);
    c->energy = prt_calloc(c->nslices + 1, sizeof(double), err);
    c->hitfit = c->energy ? prt_calloc(c->nslices + 1, 1, err) : NULL;
    if (!c->hitfit) return -1;
    static const char *stages[VMFT_MAX_PASSES] = { "vmf direct", "vmf pass 1", "vmf pass 2", "vmf pass 3" };
    for (int p = 1; p < R; p++) {
        double t0 = prt_now();
        c->pass = p;
        if (vp_stage(c, stages[p], (int)c->nslices, 64, vp_gather_range, c->in->ckpt_pass + p, vp_restore_slice, vp_share_gather, err)) return -1;
        double e = 0;
        for (size_t i = 0; i < c->nslices; i++) e += c->energy[i];
        t->energy[p] = e0 > 0 ? e / e0 : 0;
        t->t_pass[p] = prt_now() - t0;
        done = p + 1;
        if (t->energy[p] < c->in->bounce_threshold) break;
    }
    vp_compact(t, done);
    return 0;
}

int vmfpass_run(const transfer_precompute_in *in, prt_transfer *tr, prt_error *err) {
    vmf_config cfg = vmft_config(&tr->cfg);
    PRT_CHECK(in->scene && in->vis && cfg.lobes >= 1 && cfg.samples >= 1);
    vp_ctx *c = calloc(1, sizeof *c);
    vmft_data *t = calloc(1, sizeof *t);
    if (!c || !t) return free(c), free(t), prt_fail(err, "vmf precompute: out of memory");
    const prt_mesh *m = &in->scene->mesh;
    *c = (vp_ctx){ .in = in, .m = m, .t = t, .S = cfg.samples, .I = cfg.lobes, .eps = vis_eps(in->vis) };
    pthread_mutex_init(&c->lock, NULL);
    int R = in->passes < 1 ? 1 : in->passes > VMFT_MAX_PASSES ? VMFT_MAX_PASSES : in->passes, rc = -1;
    if (vmft_init(t, cfg.level, cfg.lobes, m->nverts, err) || (t->samples = c->S, t->materials = tr->materials, 0) ||
        vp_setup(c, tr, err))
        goto done;
    double t0 = prt_now();
    if (R > 1 && vp_stage(c, "vmf diffuse lobes", m->nverts, 256, vp_diffuse_range, -1, NULL, vp_share_diffuse, err)) goto done;
    if (vp_stage(c, "vmf direct", c->ngverts, 4, vp_direct_range, c->in->ckpt_pass, vp_restore_vertex, vp_share_direct, err) ||
        vp_build(c, R, err))
        goto done;
    double e0 = 0;
    for (int i = 0; i < c->ngverts; i++) e0 += c->energy[i], t->slices += c->nactive[i];
    t->energy[0] = 1;
    t->t_pass[0] = prt_now() - t0;
    if (vp_gather_passes(c, e0, R, err)) goto done;
    rc = 0;
done:
    vp_teardown(c);
    free(c);
    if (rc) vmft_free(t), free(t);
    else tr->priv = t;
    return rc;
}

/* ---- the effects plan's probe (vmfpass.h) ------------------------------------------------------ */

/* CPU seconds of the calling thread. */
static double vp_thread_cpu(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The probe's direct stage on glossy vertex v (as vp_direct_range, nothing kept): the views of
 * the slices it stores into all[] (t->nviews room). Returns how many. */
static int vp_probe_direct(vp_ctx *c, int v, int *all) {
    vp_thread *th = &c->th[0];
    uint32_t w[VMFT_MAX_LOBES * VMFT_WORDS];
    double e;
    int stored = 0;
    bool open = vp_open(c, v);
    for (int j = 0; j < c->t->nviews; j++) {
        if (open) { vp_open_slice(c, v, j); continue; }
        if (vp_direct_slice(c, th, v, j, w, &e)) all[stored++] = j;
    }
    return stored;
}

/* The diffuse lobes of the corners of the triangles slice (v, j)'s rays hit that have none yet
 * (done[] marks them), as gathering pass 1 reads them. */
static void vp_probe_corners(vp_ctx *c, int v, int j, uint8_t *done) {
    vp_thread *th = &c->th[0];
    float A[3];
    int nr = vp_slice_rays(c, th, v, j, A), corners[3 * 256], nc = 0;
    for (int i = 0; i < nr && nc + 3 <= 3 * 256; i++)
        if (th->hits[i].tri >= 0 && th->hits[i].tri < c->m->ntris)
            for (int k = 0; k < 3; k++) {
                int y = (int)c->m->tris[3 * (size_t)th->hits[i].tri + k];
                if (!done[y]) done[y] = 1, corners[nc++] = y;
            }
    for (int i = 0; i < nc; i++) vp_diffuse_vertex(c, th, corners[i]);
}

/* The diffuse stage's CPU seconds a vertex: VMFPASS_PROBE_DIFFUSE vertices spread over the mesh
 * (their lobes are the stage's, so they stay). */
static double vp_probe_diffuse(vp_ctx *c) {
    int n = c->m->nverts < VMFPASS_PROBE_DIFFUSE ? c->m->nverts : VMFPASS_PROBE_DIFFUSE;
    double t0 = vp_thread_cpu();
    for (int q = 0; q < n; q++) vp_diffuse_vertex(c, &c->th[0], (int)((long)q * c->m->nverts / n));
    return n ? (vp_thread_cpu() - t0) / n : 0;
}

/* CPU seconds a slice of gathering pass `pass` over the probe's slices (sv, sj)[n], only those
 * whose rays hit a fitted triangle when fit_only (the ones passes >= 2 gather); *fits counts
 * those. */
static double vp_probe_gather(vp_ctx *c, int pass, const int *sv, const int *sj, int n, bool fit_only, int *fits) {
    uint32_t w[VMFT_MAX_LOBES * VMFT_WORDS];
    double secs = 0;
    int counted = 0;
    c->pass = pass;
    *fits = 0;
    for (int i = 0; i < n; i++) {
        bool fit;
        double t0 = vp_thread_cpu();
        vp_gather_core(c, &c->th[0], sv[i], sj[i], w, &fit);
        double dt = vp_thread_cpu() - t0;
        *fits += fit;
        if (!fit_only || fit) secs += dt, counted++;
    }
    return counted ? secs / counted : 0;
}

/* See vmfpass.h: the direct stage timed on probe vertices spread over the transfer's, then pass 1
 * on the slices they store (their hit corners' diffuse lobes first, timed as the diffuse stage). */
static int vp_probe(vp_ctx *c, vmfpass_cost *out, prt_error *err) {
    int np = c->ngverts < VMFPASS_PROBE_VERTS ? c->ngverts : VMFPASS_PROBE_VERTS, nv = 0;
    int *sv = prt_calloc(VMFPASS_PROBE_SLICES, sizeof(int), err), *sj = prt_calloc(VMFPASS_PROBE_SLICES, sizeof(int), err);
    int *all = prt_calloc((size_t)c->t->nviews, sizeof(int), err);
    uint8_t *done = prt_calloc((size_t)c->m->nverts + 1, 1, err);
    if (!sv || !sj || !all || !done) return free(sv), free(sj), free(all), free(done), -1;
    long stored = 0;
    double td = 0;
    for (int q = 0; q < np; q++) {
        int v = c->gverts[(int)((long)q * c->ngverts / np)];
        double t1 = vp_thread_cpu();
        int ns = vp_probe_direct(c, v, all), take = ns < VMFPASS_PROBE_SLICES / np ? ns : VMFPASS_PROBE_SLICES / np;
        td += vp_thread_cpu() - t1;
        stored += ns;
        for (int i = 0; i < take; i++) sv[nv] = v, sj[nv++] = all[(int)((long)i * ns / take)];   /* spread over its views */
    }
    out->direct_cpu = np ? td / np : 0;
    out->stored = np ? (double)stored / np : 0;
    out->diffuse_cpu = vp_probe_diffuse(c);
    for (int i = 0; i < nv; i++) vp_probe_corners(c, sv[i], sj[i], done);
    int fits = 0;
    out->gather_cpu = vp_probe_gather(c, 1, sv, sj, nv, false, &fits);
    out->fit_share = nv ? (double)fits / nv : 0;
    /* pass 2 reads pass 1's slices (here the BRDFs' own lobes, as in pass 1) and no diffuse lobes */
    out->gather2_cpu = fits ? vp_probe_gather(c, 2, sv, sj, nv, true, &fits) : 0;
    out->probed_verts = np, out->probed_slices = nv;
    free(sv), free(sj), free(all), free(done);
    return 0;
}

int vmfpass_estimate(const transfer_precompute_in *in, const prt_transfer *tr, vmfpass_cost *out, prt_error *err) {
    vmf_config cfg = vmft_config(&tr->cfg);
    PRT_CHECK(in->scene && in->vis && cfg.lobes >= 1 && cfg.samples >= 1);
    memset(out, 0, sizeof *out);
    transfer_precompute_in one = *in;   /* one thread, nothing recorded, no ranks */
    one.nthreads = 1, one.ckpt = NULL, one.shard = NULL, one.progress = NULL, one.pass_done = NULL;
    vp_ctx *c = calloc(1, sizeof *c);
    vmft_data *t = calloc(1, sizeof *t);
    if (!c || !t) return free(c), free(t), prt_fail(err, "vmf estimate: out of memory");
    const prt_mesh *m = &in->scene->mesh;
    *c = (vp_ctx){ .in = &one, .m = m, .t = t, .S = cfg.samples, .I = cfg.lobes, .eps = vis_eps(in->vis) };
    pthread_mutex_init(&c->lock, NULL);
    int rc = -1;
    /* an empty slice index: every slice a gathering pass meets is its BRDF's own lobe */
    if (vmft_init(t, cfg.level, cfg.lobes, m->nverts, err) || (t->materials = tr->materials, 0) ||
        vp_setup(c, tr, err) || vmft_index(t, err))
        goto done;
    out->nverts = m->nverts, out->ngverts = c->ngverts;
    rc = vp_probe(c, out, err);
done:
    vp_teardown(c);
    free(c);
    vmft_free(t), free(t);
    return rc;
}
