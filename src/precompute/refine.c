/* refine.c - adaptive refinement where visibility changes (Laurijssen et al. 2011,
 * section 6.1; the scheme and its decisions are in refine.h).
 *
 * Per-vertex transport (Eq. 3 sampled at vertices, Wang et al. 2006 section 3) can hold a
 * shadow edge no sharper than the vertex spacing: a 31K-vertex floor puts its vertices
 * 1/176 of its side apart. Splitting only the edges whose endpoints see different things
 * puts vertices where the transport changes and nowhere else.
 *
 * One iteration: masks for the vertices made by the previous one (vis_cube on both
 * cores, then packed to bits), the edge list (the triangles' sides sorted by their
 * (lower, higher) vertex pair, so an edge's index does not depend on triangle order
 * details beyond the mesh itself), each edge's differing share (popcounts over the masks),
 * the marked edges chosen (largest share first within the budget), new vertices appended
 * and every triangle re-triangulated by its number of split sides.
 *
 * The visibility scene is built once on the input: splitting an edge at its midpoint
 * keeps every new triangle inside an old one, so the surface does not move. */
#include "refine.h"
#include "cubemap.h"
#include "visibility.h"
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RF_MAX_THREADS 64
#define RF_GRAIN_VERTS 16       /* vertices per dynamic chunk of mask tracing */
#define RF_GRAIN_EDGES 2048     /* edges per chunk of mask comparison */

/* The refinement in progress. */
typedef struct rf_ctx {
    prt_mesh m;             /* the working mesh (a copy of the input until committed) */
    uint8_t *floor;         /* [nverts] 1 for a floor vertex */
    int W;                  /* 64-bit words per mask */
    uint64_t *vis, *up;     /* [nverts * W] escaping directions / directions above the horizon */
    float *dirs;            /* [3 * ndirs] unit texel-centre directions of the mask cube */
    int res, ndirs;
    uint8_t *cmp;           /* [nverts] 1 where the vertex's part is compared (refine_desc.parts) */
    const vis_scene *vs;
    uint8_t *bytes[RF_MAX_THREADS];   /* vis_cube output per thread */
    long rays[RF_MAX_THREADS];
    int first;              /* first vertex of the masks being traced */
    int nedges;
    uint64_t *ekey;         /* [nedges] (lower << 32) | higher vertex */
    int *tedge;             /* [3 * ntris] edge of triangle side t*3+k (vertex k to k+1) */
    float *diff;            /* [nedges] differing share */
    int *mid;               /* [nedges] the new midpoint vertex, or -1 */
    /* progress of the mask tracing (the slow part: rays) */
    prt_progress_fn progress;
    void *progress_user;
    char stage[32];         /* "refine level N" */
    pthread_mutex_t lock;
    atomic_long done;
    long total;
    atomic_int cancelled;
} rf_ctx;

/* A triangle side for sorting into edges. */
typedef struct rf_side {
    uint64_t key;
    uint32_t side;
} rf_side;

/* A marked edge for choosing within the budget. */
typedef struct rf_mark {
    float diff;
    int edge;
} rf_mark;

static int rf_side_cmp(const void *a, const void *b) {
    const rf_side *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->side < y->side ? -1 : x->side > y->side;
}

/* Largest difference first; ties by edge index, so the choice is deterministic. */
static int rf_mark_cmp(const void *a, const void *b) {
    const rf_mark *x = a, *y = b;
    if (x->diff != y->diff) return x->diff > y->diff ? -1 : 1;
    return x->edge < y->edge ? -1 : x->edge > y->edge;
}

/* Counts n traced vertices and reports the level's fraction (one thread at a time); a false
 * answer cancels the refinement. */
static void rf_report(rf_ctx *c, int n) {
    atomic_fetch_add(&c->done, n);
    if (!c->progress) return;
    pthread_mutex_lock(&c->lock);
    long done = atomic_load(&c->done);   /* read under the lock, so the fractions reported rise */
    if (!atomic_load(&c->cancelled) && !c->progress(c->progress_user, c->stage, (double)done / (double)c->total))
        atomic_store(&c->cancelled, 1);
    pthread_mutex_unlock(&c->lock);
}

/* prt_parallel_for body: masks of vertices first + [begin, end). */
static void rf_mask_range(void *ctx, int begin, int end, int thread) {
    rf_ctx *c = ctx;
    if (atomic_load(&c->cancelled)) return;
    uint8_t *b = c->bytes[thread];
    for (int i = begin; i < end; i++) {
        const size_t v = (size_t)(c->first + i);
        const float *p = c->m.pos + 3 * v, *n = c->m.nrm + 3 * v;
        uint64_t *mv = c->vis + v * (size_t)c->W, *mu = c->up + v * (size_t)c->W;
        memset(mv, 0, sizeof(uint64_t) * (size_t)c->W);
        memset(mu, 0, sizeof(uint64_t) * (size_t)c->W);
        if (!c->cmp[v]) continue;   /* no edge of it is compared */
        long traced = 0;
        vis_cube(c->vs, p, n, c->res, b, &traced, NULL);
        c->rays[thread] += traced;
        for (int d = 0; d < c->ndirs; d++) {
            const float *w = c->dirs + 3 * (size_t)d;
            const uint64_t bit = (uint64_t)1 << (d & 63);
            if (b[d]) mv[d >> 6] |= bit;
            if (n[0] * w[0] + n[1] * w[1] + n[2] * w[2] > REFINE_MIN_COS) mu[d >> 6] |= bit;
        }
    }
    rf_report(c, end - begin);
}

/* prt_parallel_for body: the differing share of edges [begin, end), counted only over the
 * directions above both vertices' horizons (refine.h says why). */
static void rf_diff_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    rf_ctx *c = ctx;
    const size_t W = (size_t)c->W;
    for (int e = begin; e < end; e++) {
        const size_t a = (size_t)(c->ekey[e] >> 32), b = (size_t)(c->ekey[e] & 0xffffffffu);
        if (!(c->cmp[a] && c->cmp[b])) { c->diff[e] = 0.f; continue; }
        const uint64_t *va = c->vis + a * W, *vb = c->vis + b * W, *ua = c->up + a * W, *ub = c->up + b * W;
        int nd = 0, nc = 0;
        for (size_t w = 0; w < W; w++) {
            const uint64_t both = ua[w] & ub[w];
            nc += __builtin_popcountll(both);
            nd += __builtin_popcountll((va[w] ^ vb[w]) & both);
        }
        c->diff[e] = nc ? (float)nd / (float)nc : 0.f;
    }
}

/* Grows the per-vertex arrays (mesh and masks) to nv vertices. Returns 0 or -1 (OOM). */
static int rf_grow(rf_ctx *c, int nv, prt_error *err) {
    const size_t n = (size_t)nv;
    float *pos = realloc(c->m.pos, 3 * n * sizeof(float));
    if (pos) c->m.pos = pos;
    float *nrm = realloc(c->m.nrm, 3 * n * sizeof(float));
    if (nrm) c->m.nrm = nrm;
    uint16_t *mat = realloc(c->m.mat, n * sizeof(uint16_t));
    if (mat) c->m.mat = mat;
    float *uv = c->m.uv ? realloc(c->m.uv, 2 * n * sizeof(float)) : NULL;   /* a textured mesh's coordinates */
    if (uv) c->m.uv = uv;
    if (c->m.uv && !uv) return prt_fail(err, "refine: out of memory for %d vertices", nv);
    uint8_t *fl = realloc(c->floor, n);
    if (fl) c->floor = fl;
    uint8_t *cm = realloc(c->cmp, n);
    if (cm) c->cmp = cm;
    uint64_t *vis = realloc(c->vis, n * (size_t)c->W * sizeof(uint64_t));
    if (vis) c->vis = vis;
    uint64_t *up = realloc(c->up, n * (size_t)c->W * sizeof(uint64_t));
    if (up) c->up = up;
    if (!pos || !nrm || !mat || !fl || !cm || !vis || !up) return prt_fail(err, "refine: out of memory for %d vertices", nv);
    return 0;
}

/* The edge list of the current triangles (ekey, tedge) and its per-edge arrays. Returns 0 or -1. */
static int rf_edges(rf_ctx *c, prt_error *err) {
    const size_t ns = 3 * (size_t)c->m.ntris;
    rf_side *s = prt_calloc(ns, sizeof *s, err);
    free(c->ekey); free(c->tedge); free(c->diff); free(c->mid);
    c->ekey = s ? prt_calloc(ns, sizeof(uint64_t), err) : NULL;
    c->tedge = c->ekey ? prt_calloc(ns, sizeof(int), err) : NULL;
    c->diff = c->tedge ? prt_calloc(ns, sizeof(float), err) : NULL;
    c->mid = c->diff ? prt_calloc(ns, sizeof(int), err) : NULL;
    if (!c->mid) { free(s); return -1; }
    for (size_t i = 0; i < ns; i++) {
        uint64_t a = c->m.tris[i], b = c->m.tris[i % 3 == 2 ? i - 2 : i + 1];
        s[i].key = a < b ? (a << 32) | b : (b << 32) | a;
        s[i].side = (uint32_t)i;
    }
    qsort(s, ns, sizeof *s, rf_side_cmp);
    int ne = 0;
    for (size_t i = 0; i < ns; i++) {
        if (i == 0 || s[i].key != s[i - 1].key) c->ekey[ne++] = s[i].key;
        c->tedge[s[i].side] = ne - 1;
    }
    c->nedges = ne;
    free(s);
    return 0;
}

/* Marks the edges to split this iteration in c->mid (-1 elsewhere): those above the
 * threshold, largest difference first, at most room of them. Returns how many (or -1 on
 * OOM); *marked gets how many were above the threshold. */
static int rf_choose(rf_ctx *c, float threshold, int room, int *marked, prt_error *err) {
    int n = 0;
    for (int e = 0; e < c->nedges; e++) {
        c->mid[e] = -1;
        n += c->diff[e] > threshold;
    }
    *marked = n;
    int take = n < room ? n : room;
    if (take <= 0) return 0;
    rf_mark *mk = prt_calloc((size_t)n, sizeof *mk, err);
    if (!mk) return -1;
    n = 0;
    for (int e = 0; e < c->nedges; e++)
        if (c->diff[e] > threshold) mk[n++] = (rf_mark){ c->diff[e], e };
    if (take < n) qsort(mk, (size_t)n, sizeof *mk, rf_mark_cmp);
    for (int i = 0; i < take; i++) c->mid[mk[i].edge] = 0;
    free(mk);
    return take;
}

/* Appends the midpoint vertex of every chosen edge (in edge order) and sets c->mid to it. */
static void rf_add_midpoints(rf_ctx *c) {
    int v = c->m.nverts;
    for (int e = 0; e < c->nedges; e++) {
        if (c->mid[e] < 0) continue;
        const size_t a = (size_t)(c->ekey[e] >> 32), b = (size_t)(c->ekey[e] & 0xffffffffu), o = (size_t)v;
        float n[3], len2 = 0;
        for (int k = 0; k < 3; k++) {
            c->m.pos[3 * o + k] = 0.5f * (c->m.pos[3 * a + k] + c->m.pos[3 * b + k]);
            n[k] = c->m.nrm[3 * a + k] + c->m.nrm[3 * b + k];
            len2 += n[k] * n[k];
        }
        /* normals that cancel (a knife edge) keep the lower vertex's */
        const float s = len2 > 1e-12f ? 1.f / sqrtf(len2) : 0.f;
        for (int k = 0; k < 3; k++) c->m.nrm[3 * o + k] = s > 0 ? n[k] * s : c->m.nrm[3 * a + k];
        c->m.mat[o] = c->m.mat[a];
        for (int k = 0; c->m.uv && k < 2; k++) c->m.uv[2 * o + k] = 0.5f * (c->m.uv[2 * a + k] + c->m.uv[2 * b + k]);
        c->floor[o] = c->floor[a];
        c->cmp[o] = c->cmp[a];
        c->mid[e] = v++;
    }
    c->m.nverts = v;
}

static float rf_dist2(const float *pos, uint32_t a, uint32_t b) {
    float d = 0;
    for (int k = 0; k < 3; k++) {
        float x = pos[3 * (size_t)a + k] - pos[3 * (size_t)b + k];
        d += x * x;
    }
    return d;
}

/* Writes triangle t's children (refine.h's 1 -> 2, 2 -> 3, 3 -> 4 scheme, orientation kept)
 * at out; returns how many. */
static int rf_split_tri(const rf_ctx *c, int t, uint32_t *out) {
    const uint32_t *v = c->m.tris + 3 * (size_t)t;
    int e[3], n = 0;
    for (int k = 0; k < 3; k++) {
        e[k] = c->mid[c->tedge[3 * (size_t)t + k]];
        n += e[k] >= 0;
    }
#define RF_EMIT(i, x, y, z) (out[3 * (i)] = (x), out[3 * (i) + 1] = (y), out[3 * (i) + 2] = (z))
    if (n == 0) { RF_EMIT(0, v[0], v[1], v[2]); return 1; }
    if (n == 3) {
        const uint32_t m0 = (uint32_t)e[0], m1 = (uint32_t)e[1], m2 = (uint32_t)e[2];
        RF_EMIT(0, v[0], m0, m2); RF_EMIT(1, m0, v[1], m1); RF_EMIT(2, m2, m1, v[2]); RF_EMIT(3, m0, m1, m2);
        return 4;
    }
    if (n == 1) {   /* rotate so that side k = (a, b) is the split one */
        int k = e[0] >= 0 ? 0 : e[1] >= 0 ? 1 : 2;
        const uint32_t a = v[k], b = v[(k + 1) % 3], cc = v[(k + 2) % 3], m = (uint32_t)e[k];
        RF_EMIT(0, a, m, cc); RF_EMIT(1, m, b, cc);
        return 2;
    }
    /* two split sides: rotate so that side (c, a) is the whole one */
    int k = e[0] < 0 ? 0 : e[1] < 0 ? 1 : 2;
    const uint32_t cc = v[k], a = v[(k + 1) % 3], b = v[(k + 2) % 3];
    const uint32_t m1 = (uint32_t)e[(k + 1) % 3], m2 = (uint32_t)e[(k + 2) % 3];   /* on (a, b), (b, c) */
    RF_EMIT(0, m1, b, m2);
    if (rf_dist2(c->m.pos, a, m2) <= rf_dist2(c->m.pos, m1, cc)) { RF_EMIT(1, a, m1, m2); RF_EMIT(2, a, m2, cc); }
    else { RF_EMIT(1, a, m1, cc); RF_EMIT(2, m1, m2, cc); }
#undef RF_EMIT
    return 3;
}

/* Replaces the triangles by their children. Returns 0 or -1 (OOM). */
static int rf_retriangulate(rf_ctx *c, prt_error *err) {
    /* each split side adds one child to its triangle (an edge of a non-manifold mesh, as real scans
     * have, may have more than two triangles) */
    size_t cap = (size_t)c->m.ntris;
    for (size_t k = 0; k < 3 * (size_t)c->m.ntris; k++) cap += c->mid[c->tedge[k]] >= 0;
    uint32_t *tris = prt_calloc(3 * cap, sizeof(uint32_t), err);
    if (!tris) return -1;
    size_t nt = 0;
    for (int t = 0; t < c->m.ntris; t++) nt += (size_t)rf_split_tri(c, t, tris + 3 * nt);
    PRT_CHECK(nt <= cap);
    free(c->m.tris);
    c->m.tris = tris;
    c->m.ntris = (int)nt;
    return 0;
}

/* Traces the masks of vertices [c->first, nverts) on nthreads threads. */
static void rf_trace(rf_ctx *c, int nthreads, int level) {
    snprintf(c->stage, sizeof c->stage, "refine level %d", level + 1);
    atomic_store(&c->done, 0);
    c->total = c->m.nverts - c->first > 0 ? c->m.nverts - c->first : 1;
    prt_parallel_for(c->m.nverts - c->first, RF_GRAIN_VERTS, nthreads, rf_mask_range, c);
    c->first = c->m.nverts;
}

/* One iteration: masks, edges, differences, choice and split. Returns the number of edges
 * split (0: nothing left to do or no room) or -1. */
static int rf_iterate(rf_ctx *c, const refine_desc *d, int level, refine_stats *st, prt_error *err) {
    rf_trace(c, d->nthreads, level);
    if (atomic_load(&c->cancelled)) return prt_fail(err, "cancelled");
    if (rf_edges(c, err)) return -1;
    prt_parallel_for(c->nedges, RF_GRAIN_EDGES, d->nthreads, rf_diff_range, c);
    int marked = 0, nsplit = rf_choose(c, d->threshold, d->budget - c->m.nverts, &marked, err);
    if (nsplit < 0) return -1;
    if (marked > nsplit) st->budget_hit = true;
    if (nsplit == 0) return 0;
    if ((int64_t)c->m.nverts + nsplit > INT32_MAX / 4) return prt_fail(err, "refine: too many vertices");
    if (rf_grow(c, c->m.nverts + nsplit, err)) return -1;
    rf_add_midpoints(c);
    if (rf_retriangulate(c, err)) return -1;
    return nsplit;
}

/* Fills defaults into *d and validates it against the input mesh. Returns 0 or -1. */
static int rf_check(const refine_desc *in, const prt_mesh *m, bool has_floor, refine_desc *d, prt_error *err) {
    *d = in ? *in : (refine_desc){ 0 };
    if (d->threshold == 0) d->threshold = REFINE_THRESHOLD;
    if (!(d->threshold > 0 && d->threshold < 1))
        return prt_fail(err, "refine: threshold %g is out of range (0, 1)", d->threshold);
    if (d->budget == 0)
        d->budget = (double)m->nverts * REFINE_BUDGET_FACTOR > INT32_MAX / 4 ? INT32_MAX / 4
                                                                             : (int)(m->nverts * REFINE_BUDGET_FACTOR);
    if (d->budget < m->nverts)
        return prt_fail(err, "refine: the vertex budget %d is below the scene's %d vertices", d->budget, m->nverts);
    if (d->mask_res == 0) d->mask_res = 32;
    if (d->mask_res < 8 || d->mask_res > 64 || d->mask_res % 4)
        return prt_fail(err, "refine: mask_res %d (must be a multiple of 4 in 8..64)", d->mask_res);
    if (d->parts == 0) d->parts = has_floor ? REFINE_FLOOR : REFINE_ALL;
    if (d->parts & ~REFINE_ALL)
        return prt_fail(err, "refine: parts %d (must be %d the floor and/or %d the models)", d->parts, REFINE_FLOOR, REFINE_MODELS);
    if (d->parts == REFINE_FLOOR && !has_floor) return prt_fail(err, "refine: the floor only, but the scene has no floor");
    if (d->materials && !(d->parts & REFINE_MODELS))
        return prt_fail(err, "refine: a material mask (0x%llx) without REFINE_MODELS", (unsigned long long)d->materials);
    if (d->max_levels == 0) d->max_levels = 6;
    if (d->max_levels < 1 || d->max_levels > 16)
        return prt_fail(err, "refine: max_levels %d is out of range 1..16", d->max_levels);
    int nt = prt_thread_count(d->nthreads);
    d->nthreads = nt > RF_MAX_THREADS ? RF_MAX_THREADS : nt;
    return 0;
}

/* Whether a vertex of the floor (or of a model of material mat) has its edges compared under d->parts. */
static bool rf_compared(const refine_desc *d, bool floor, int mat) {
    if (floor) return (d->parts & REFINE_FLOOR) != 0;
    return (d->parts & REFINE_MODELS) && (d->materials == 0 || ((d->materials >> mat) & 1));
}

static void rf_free(rf_ctx *c) {
    mesh_free(&c->m);
    free(c->floor); free(c->cmp); free(c->vis); free(c->up); free(c->dirs);
    free(c->ekey); free(c->tedge); free(c->diff); free(c->mid);
    for (int t = 0; t < RF_MAX_THREADS; t++) free(c->bytes[t]);
    pthread_mutex_destroy(&c->lock);
}

/* The working copy of s's mesh, its floor flags, the mask directions and per-thread buffers
 * (the visibility scene is the caller's). Returns 0 or -1. */
static int rf_init(rf_ctx *c, const prt_scene *s, const refine_desc *d, prt_error *err) {
    if (mesh_copy(&c->m, &s->mesh, err)) return -1;
    c->progress = d->progress;
    c->progress_user = d->progress_user;
    c->res = d->mask_res;
    c->ndirs = 6 * c->res * c->res;
    c->W = (c->ndirs + 63) / 64;
    c->dirs = prt_calloc(3 * (size_t)c->ndirs, sizeof(float), err);
    if (!c->dirs || rf_grow(c, c->m.nverts > 0 ? c->m.nverts : 1, err)) return -1;
    for (int i = 0; i < c->ndirs; i++) cube_texel_dir(c->res, i, c->dirs + 3 * i);
    for (int v = 0; v < c->m.nverts; v++) {
        c->floor[v] = s->floor_first_vertex >= 0 && v >= s->floor_first_vertex;
        c->cmp[v] = rf_compared(d, c->floor[v], c->m.mat ? c->m.mat[v] : 0);
    }
    for (int t = 0; t < d->nthreads; t++)
        if (!(c->bytes[t] = prt_calloc((size_t)c->ndirs, 1, err))) return -1;
    return 0;
}

/* Puts the floor's vertices last again (input order kept, new vertices after the originals of
 * their part) and moves the working mesh into s. Returns 0 or -1 (OOM; s unchanged). */
static int rf_commit(rf_ctx *c, prt_scene *s, prt_error *err) {
    const int nv = c->m.nverts, v0 = s->mesh.nverts, ff = s->floor_first_vertex;
    if (ff >= 0 && nv > v0) {
        uint32_t *map = prt_calloc((size_t)nv, sizeof *map, err);
        float *pos = map ? prt_calloc(3 * (size_t)nv, sizeof(float), err) : NULL;
        float *nrm = pos ? prt_calloc(3 * (size_t)nv, sizeof(float), err) : NULL;
        uint16_t *mat = nrm ? prt_calloc((size_t)nv, sizeof(uint16_t), err) : NULL;
        float *uv = mat && c->m.uv ? prt_calloc(2 * (size_t)nv, sizeof(float), err) : NULL;
        if (!mat || (c->m.uv && !uv)) { free(map); free(pos); free(nrm); free(mat); return -1; }
        uint32_t k = 0;
        for (int v = 0; v < ff; v++) map[v] = k++;
        for (int v = v0; v < nv; v++) if (!c->floor[v]) map[v] = k++;
        const int nff = (int)k;
        for (int v = ff; v < v0; v++) map[v] = k++;
        for (int v = v0; v < nv; v++) if (c->floor[v]) map[v] = k++;
        for (int v = 0; v < nv; v++) {
            memcpy(pos + 3 * (size_t)map[v], c->m.pos + 3 * (size_t)v, 3 * sizeof(float));
            memcpy(nrm + 3 * (size_t)map[v], c->m.nrm + 3 * (size_t)v, 3 * sizeof(float));
            mat[map[v]] = c->m.mat[v];
            if (uv) memcpy(uv + 2 * (size_t)map[v], c->m.uv + 2 * (size_t)v, 2 * sizeof(float));
        }
        for (size_t i = 0; i < 3 * (size_t)c->m.ntris; i++) c->m.tris[i] = map[c->m.tris[i]];
        free(c->m.pos); free(c->m.nrm); free(c->m.mat); free(map);
        c->m.pos = pos;
        c->m.nrm = nrm;
        c->m.mat = mat;
        if (uv) {
            free(c->m.uv);
            c->m.uv = uv;
        }
        s->floor_first_vertex = nff;
    }
    mesh_free(&s->mesh);
    s->mesh = c->m;
    memset(&c->m, 0, sizeof c->m);
    return 0;
}

/* Refines s->mesh (refine.h). */
int refine_scene(prt_scene *s, const refine_desc *desc, refine_stats *stats, prt_error *err) {
    const double t0 = prt_now();
    refine_desc d;
    if (rf_check(desc, &s->mesh, s->floor_first_vertex >= 0, &d, err)) return -1;
    refine_stats st = { .verts_before = s->mesh.nverts, .tris_before = s->mesh.ntris, .budget = d.budget,
                        .threshold = d.threshold, .mask_res = d.mask_res, .parts = d.parts,
                        .materials = d.materials };
    st.floor_before = s->floor_first_vertex >= 0 ? s->mesh.nverts - s->floor_first_vertex : 0;
    rf_ctx *c = prt_calloc(1, sizeof *c, err);
    if (!c) return -1;
    pthread_mutex_init(&c->lock, NULL);
    atomic_init(&c->done, 0);
    atomic_init(&c->cancelled, 0);
    int rc = -1;
    /* the input mesh stays untouched (its triangles shared with Embree) until the commit */
    vis_scene *vs = NULL;
    if (rf_init(c, s, &d, err) || !(vs = vis_create(&s->mesh, err))) goto done;
    vis_cull_floor(vs, &s->mesh, s->floor_first_vertex);
    c->vs = vs;
    for (int level = 0; level < d.max_levels; level++) {
        if (c->m.nverts >= d.budget) { st.budget_hit = true; break; }   /* no room: trace nothing more */
        int n = rf_iterate(c, &d, level, &st, err);
        if (n < 0) goto done;
        if (n == 0) break;
        st.levels++;
    }
    for (int t = 0; t < d.nthreads; t++) st.rays += c->rays[t];
    vis_destroy(vs);
    vs = NULL;
    if (rf_commit(c, s, err)) goto done;
    st.verts_after = s->mesh.nverts;
    st.tris_after = s->mesh.ntris;
    st.floor_after = s->floor_first_vertex >= 0 ? s->mesh.nverts - s->floor_first_vertex : 0;
    st.seconds = prt_now() - t0;
    if (stats) *stats = st;
    rc = 0;
done:
    vis_destroy(vs);
    rf_free(c);
    free(c);
    return rc;
}

static const char *rf_parts_name(const refine_stats *st) {
    if (st->parts == REFINE_FLOOR) return "floor";
    if (st->materials) return st->parts == REFINE_MODELS ? "some models'" : "the floor's and some models'";
    return st->parts == REFINE_MODELS ? "models'" : "all";
}

/* The plan's refinement line. */
void refine_describe(const refine_stats *st, char *buf, size_t cap) {
    char where[128];
    if (st->floor_before > 0 || st->floor_after > 0)
        snprintf(where, sizeof where, "models %d -> %d, floor %d -> %d", st->verts_before - st->floor_before,
                 st->verts_after - st->floor_after, st->floor_before, st->floor_after);
    else
        snprintf(where, sizeof where, "no floor");
    snprintf(buf, cap,
             "refinement: %d -> %d vertices (%s), %d -> %d triangles, %d level%s; %s edges whose %dx%dx6 visibility masks "
             "differ in > %.2f%% of directions split, budget %d%s; %.1fM mask rays in %.1fs",
             st->verts_before, st->verts_after, where, st->tris_before, st->tris_after, st->levels,
             st->levels == 1 ? "" : "s", rf_parts_name(st), st->mask_res, st->mask_res, 100 * st->threshold, st->budget,
             st->budget_hit ? " (reached)" : "", st->rays / 1e6, st->seconds);
}
