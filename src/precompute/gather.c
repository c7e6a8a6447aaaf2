/* gather.c - interreflection passes by gathering compressed transport vectors
 * (sections 3.2 and 4.2 of Wang, Tran & Luebke 2006; Eq. 6-8).
 *
 * Why it is organised this way. One pass computes, for every vertex x and
 * each of its K BRDF terms k,
 *   T'_k(x) = sum_w [ sum_l h_l(x~, -w) T_l(x~) ] g_k(x, w) (n.w) dw        (Eq. 8)
 * over the texels w of a global-frame gather cube (res 32) in x's upper
 * hemisphere whose ray hits the scene (the complement transport, Eq. 6).
 * T at the hit point x~ is the barycentric blend of the hit triangle's three
 * vertices, times the triangle's mean texture where its material has one (the
 * transport is stored without the texture, which multiplies at shading time:
 * texture.h, scene_triangle_albedo). Because the whole expression is linear in the neighbour vectors,
 * every ray only adds scalar weights
 *   W[y][l][k][ch] += beta_y h_l(y, -w)[ch] g_k(x, w)[ch] (n.w) dw
 * into a per-thread table keyed by neighbour vertex y (a direct-indexed
 * vertex -> slot map, reset through the list of used slots). Only afterwards
 * is each distinct neighbour's compressed vector decoded, once, and added with
 * its K weights into x's dense accumulator. Measured on the bunny + 31K floor
 * (res 32): 3,070 rays, 940 hits and 1,355 distinct neighbours per vertex on
 * average, so combining halves the decode work against one decode per (hit,
 * corner); most hits land on distinct floor triangles.
 *
 * The accumulator is interleaved per wavelet index (lanes channel-major, term-
 * minor, see lane()), so one decoded coefficient updates 3K contiguous floats
 * (one or two cache lines) instead of 3K scattered planes; the dequantization
 * step of each neighbour vector is folded into its weights, so the inner loop
 * is int8 -> float and a multiply-add per lane (SSE4.1 for K = 1 and 4). Only
 * the 256-blocks some coefficient touched are de-interleaved and cleared
 * afterwards. The decode-and-accumulate loop is about half of a pass, ray
 * casting and transport_store (selection, quantization) a fifth each.
 *
 * The previous pass stays compressed and quantized in memory (decoded on the
 * fly, section 4.2); the coefficients already live in the wavelet (or SH)
 * domain and gathering is linear, so no transform is needed: the accumulated
 * vector goes straight to transport_store (truncation to N + quantization).
 *
 * Frames and lookups: g_k(x, w) uses w in x's Eq. 10 frame (brdf_frame of the
 * smooth vertex normal), h_l(y, -w) uses -w in y's frame; a direction below a
 * vertex's horizon gives zero (the factor's contract), so back faces reflect
 * nothing. Lambertian neighbours skip the view lookup (the view map is
 * constant). */
#include "gather.h"
#include "opensky.h"
#include "shard.h"
#include "checkpoint.h"
#include "cubemap.h"
#include "vec3.h"
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define GATHER_DEFAULT_RES 32
#define GATHER_MAX_RES 256
#define GATHER_GRAIN 8

/* ---- direct decoding of one stored vector ------------------------------ */

/* Accumulator lanes. Vertex x with nk terms keeps, per wavelet index, S(nk)
 * floats: channel-major, term-minor (lane ch*nk + k), so one decoded coefficient
 * (r, g, b) multiplies three runs of nk weights by a broadcast channel value. A
 * one-term vertex uses 4 lanes [unused, r, g, b], which matches the SSE
 * register that a packed 8-bit word [offset, r, g, b] converts into. */
static inline int lanes_of(int nk) { return nk == 1 ? 4 : 3 * nk; }
static inline int lane(int nk, int ch, int k) { return nk == 1 ? 1 + ch : ch * nk + k; }

/* Generic path (any qbits, any nk): adds w[lane] * value(c, ch) into
 * acc[index(c) * S + lane] for every coefficient c of vector i (w includes the
 * dequantization step) and marks the touched 256-blocks. */
static void accum_generic(const prt_transport *t, int i, const float *w, int nk, float *acc, uint8_t *touched) {
    const int S = lanes_of(nk);
    uint32_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t block = t->runs[2 * r], count = (uint32_t)t->runs[2 * r + 1] + 1u;
        touched[block] = 1;
        float *base = acc + (size_t)block * SPARSE_BLOCK * (size_t)S;
        for (uint32_t e = c + count; c < e; c++) {
            float v[3];
            uint32_t off;
            if (t->qbits == 8) {
                uint32_t p = t->packed[c];
                off = p & 255u;
                v[0] = (float)(int8_t)(uint8_t)(p >> 8);
                v[1] = (float)(int8_t)(uint8_t)(p >> 16);
                v[2] = (float)(int8_t)(uint8_t)(p >> 24);
            } else if (t->qbits == 16) {
                off = t->offs[c];
                v[0] = t->q16[3 * c]; v[1] = t->q16[3 * c + 1]; v[2] = t->q16[3 * c + 2];
            } else {
                off = t->offs[c];
                v[0] = t->f32[3 * c]; v[1] = t->f32[3 * c + 1]; v[2] = t->f32[3 * c + 2];
            }
            float *a = base + (size_t)off * (size_t)S;
            for (int ch = 0; ch < 3; ch++)
                for (int k = 0; k < nk; k++) a[lane(nk, ch, k)] += w[lane(nk, ch, k)] * v[ch];
        }
    }
}

#if defined(__SSE4_1__)
#include <smmintrin.h>
/* The 8-bit kernels (the common case: the paper's storage, K = 1 or 4). One
 * packed word sign-extends into [offset, r, g, b] (pmovsxbd) and converts to
 * floats in three instructions. For K = 1 that is already the lane layout (the
 * offset lane has weight 0); for K = 4 each channel is broadcast over the four
 * term lanes. */
static void accum8_k1(const prt_transport *t, int i, const float *w, float *acc, uint8_t *touched) {
    const __m128 W = _mm_loadu_ps(w);
    uint32_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t block = t->runs[2 * r], count = (uint32_t)t->runs[2 * r + 1] + 1u;
        touched[block] = 1;
        float *base = acc + (size_t)block * SPARSE_BLOCK * 4;
        for (uint32_t e = c + count; c < e; c++) {
            uint32_t p = t->packed[c];
            __m128 v = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128((int)p)));
            float *a = base + (size_t)(p & 255u) * 4;
            _mm_storeu_ps(a, _mm_add_ps(_mm_loadu_ps(a), _mm_mul_ps(W, v)));
        }
    }
}

static void accum8_k4(const prt_transport *t, int i, const float *w, float *acc, uint8_t *touched) {
    const __m128 Wr = _mm_loadu_ps(w), Wg = _mm_loadu_ps(w + 4), Wb = _mm_loadu_ps(w + 8);
    uint32_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t block = t->runs[2 * r], count = (uint32_t)t->runs[2 * r + 1] + 1u;
        touched[block] = 1;
        float *base = acc + (size_t)block * SPARSE_BLOCK * 12;
        for (uint32_t e = c + count; c < e; c++) {
            uint32_t p = t->packed[c];
            __m128 v = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128((int)p)));
            float *a = base + (size_t)(p & 255u) * 12;
            __m128 vr = _mm_shuffle_ps(v, v, 0x55), vg = _mm_shuffle_ps(v, v, 0xaa), vb = _mm_shuffle_ps(v, v, 0xff);
            _mm_storeu_ps(a, _mm_add_ps(_mm_loadu_ps(a), _mm_mul_ps(Wr, vr)));
            _mm_storeu_ps(a + 4, _mm_add_ps(_mm_loadu_ps(a + 4), _mm_mul_ps(Wg, vg)));
            _mm_storeu_ps(a + 8, _mm_add_ps(_mm_loadu_ps(a + 8), _mm_mul_ps(Wb, vb)));
        }
    }
}
#endif

/* Adds vector i of t with lane weights w into x's accumulator (nk terms). */
static void accum_any(const prt_transport *t, int i, const float *w, int nk, float *acc, uint8_t *touched) {
#if defined(__SSE4_1__)
    if (t->qbits == 8 && nk == 1) { accum8_k1(t, i, w, acc, touched); return; }
    if (t->qbits == 8 && nk == 4) { accum8_k4(t, i, w, acc, touched); return; }
#endif
    accum_generic(t, i, w, nk, acc, touched);
}

/* Dequantization step of vector i, channel ch (1 for float storage). */
static inline float vec_scale(const prt_transport *t, int i, int ch) {
    return t->qbits == 32 ? 1.f : t->scale[3 * i + ch];
}

/* ---- shared pass state -------------------------------------------------- */

typedef struct gather_thread {
    float *acc;        /* [CUBE_TEXELS][lanes_of(nk)] interleaved accumulator, zero between vertices */
    float *plane;      /* [3][CUBE_TEXELS] planar staging for transport_store, zero between uses */
    void *scratch;     /* transport_store scratch */
    uint8_t touched[SPARSE_NBLOCKS];
    int *slot_of;      /* [nverts] neighbour vertex -> slot, -1 when unused */
    int *slot_vert;    /* [max_slots] vertex of each used slot */
    float *slot_w;     /* [max_slots][kmax][slot_lanes] combined weights (lanes of x's terms) */
    float *dirs;       /* [ntex*3] upper-hemisphere directions of the current vertex */
    float *cosdw;      /* [ntex] (n.w) dw of each */
    vis_hit *hits;     /* [ntex] */
    float *open_w;     /* [OPENSKY_NORMALS][slot_lanes] the open neighbours' weights per grid normal (desc->open) */
    int *open_used;    /* [OPENSKY_NORMALS] grid normals with weights, in order of first use */
    uint8_t *open_mark; /* [OPENSKY_NORMALS] 1: in open_used */
} gather_thread;

typedef struct gather_ctx {
    const prt_data *d;
    const vis_scene *vs;
    const prt_transport *prev;
    prt_transport *next;
    int res, ntex;
    float *tex_dir;           /* [ntex*3] gather cube texel directions (owned by gather_pass) */
    float *tex_dw;            /* [ntex] their solid angles */
    float *frame;             /* [nverts*6]: s, t of each vertex's Eq. 10 frame */
    float *tri_albedo;        /* [ntris*3]: textured triangles' mean texture (texture.h), NULL untextured */
    int kmax;                 /* largest vector count of any vertex */
    int slot_lanes;           /* lanes_of(kmax) rounded up to cover lanes_of(1) */
    int max_slots;
    float hconst[PRT_MAX_MATERIALS][3];  /* constant view map of Lambertian materials */
    float gconst[PRT_MAX_MATERIALS][3];  /* constant light map of Lambertian materials (the open sky's scale) */
    const prt_transport *open;           /* desc->open or NULL */
    int (*open_q)[4];                    /* with open: [nverts] each vertex's grid normals (opensky_weights) */
    float (*open_w)[4];                  /* ... and their weights, made once per pass */
    bool hconst_ok[PRT_MAX_MATERIALS];
    float eps;
    gather_thread *th;
    uint8_t *restored;        /* [nverts] restored from the checkpoint (NULL without one) */
    int v0, v1;               /* the vertices this rank gathers (all of them on one process) */
    /* progress and cancellation */
    const gather_desc *desc;
    pthread_mutex_t lock;
    atomic_int done;
    atomic_bool cancel;
    shard_pass *sp;           /* the pass's progress over the ranks (shard.h) */
    int dropped;              /* thread 0: done when prev's mapped pages were last dropped */
    atomic_long others;       /* rank 0: vertices the other ranks have gathered, as last heard */
} gather_ctx;

static int nvec_of(const prt_transport *t, int v) { return (int)(t->vec_first[v + 1] - t->vec_first[v]); }

/* Reports progress after a finished chunk (this rank's and, on rank 0, the others' over the whole
 * pass of total vertices; thread 0, the caller's, exchanges the counts: shard.h); sets ctx->cancel
 * when the callback says stop. */
static void report(gather_ctx *c, int nfinished, int total, int thread) {
    atomic_fetch_add(&c->done, nfinished);
    if (thread == 0) atomic_store(&c->others, shard_pass_poll(c->sp, atomic_load(&c->done)));
    if (!c->desc || !c->desc->progress) return;
    pthread_mutex_lock(&c->lock);
    /* read under the lock, so the fractions reported rise; others only grows */
    long done = atomic_load(&c->done) + atomic_load(&c->others);
    if (!atomic_load(&c->cancel) &&
        !c->desc->progress(c->desc->progress_user, c->desc->stage ? c->desc->stage : "gather", (double)done / total))
        atomic_store(&c->cancel, true);
    pthread_mutex_unlock(&c->lock);
}

/* Casts x's rays, the gather-cube texel centres in the upper hemisphere of n, into
 * th->dirs, th->cosdw ((n.w) dw) and th->hits; returns their count. */
static inline int gather_cast(const gather_ctx *c, gather_thread *th, const float *p, const float *n) {
    int nr = 0;
    for (int i = 0; i < c->ntex; i++) {
        const float *w = c->tex_dir + 3 * i;
        float cw = v3_dot(n, w);
        if (cw <= 0.f) continue;
        v3_copy(th->dirs + 3 * nr, w);
        th->cosdw[nr] = cw * c->tex_dw[i];
        nr++;
    }
    float org[3];
    v3_madd(org, p, n, c->eps);
    if (nr > 0) vis_closest_many(c->vs, org, th->dirs, nr, c->eps, th->hits);
    return nr;
}

/* Adds one hit corner, neighbour y with barycentric weight b seen along -w (mw), to y's
 * slot: W[y][l][lane(ch,k)] += b h_l(y, -w)[ch] gb[lane(ch,k)] (the bracket of Eq. 8).
 * Returns the slot count, grown by one when y had no slot yet. */
static inline int gather_add_corner(const gather_ctx *c, gather_thread *th, int y, float b, const float mw[3],
                                    const float *gb, int nk, int nslots, const float alb[3]) {
    const prt_mesh *m = &c->d->scene.mesh;
    const int SL = c->slot_lanes;
    int nl = nvec_of(c->prev, y);
    if (nl <= 0) return nslots;
    const float *ny = m->nrm + 3 * (size_t)y, *sy = c->frame + 6 * (size_t)y;
    float ml[3], hy[3 * BRDF_MAX_SIGMA];
    brdf_to_local(sy, sy + 3, ny, mw, ml);
    if (ml[2] <= 0.f) return nslots;     /* x sees y's back: y reflects nothing toward x */
    int my = m->mat[y];
    if (c->hconst_ok[my]) v3_copy(hy, c->hconst[my]);
    else brdf_factor_view(&c->d->factors[my], ml, hy);
    int sl = th->slot_of[y];
    if (sl < 0) {
        sl = nslots++;
        th->slot_of[y] = sl;
        th->slot_vert[sl] = y;
        memset(th->slot_w + (size_t)sl * c->kmax * SL, 0, sizeof(float) * (size_t)c->kmax * SL);
    }
    float *W = th->slot_w + (size_t)sl * c->kmax * SL;
    for (int l = 0; l < nl; l++) {
        float *Wl = W + (size_t)l * SL;
        const float hb[3] = { b * hy[3 * l] * alb[0], b * hy[3 * l + 1] * alb[1], b * hy[3 * l + 2] * alb[2] };
        if (nk == 4) {
            for (int j = 0; j < 12; j++) Wl[j] += hb[j >> 2] * gb[j];
        } else if (nk == 1) {
            Wl[1] += hb[0] * gb[1]; Wl[2] += hb[1] * gb[2]; Wl[3] += hb[2] * gb[3];
        } else {
            for (int ch = 0; ch < 3; ch++)
                for (int k = 0; k < nk; k++) Wl[lane(nk, ch, k)] += hb[ch] * gb[lane(nk, ch, k)];
        }
    }
    return nslots;
}

/* Combines the nr cast rays of vertex x (nk terms) into per-neighbour slot weights,
 * W[y][l][lane(ch,k)] += beta h_l[ch] g_k[ch] (n.w) dw; returns the number of slots used. */
static inline int gather_combine(const gather_ctx *c, gather_thread *th, int x, int nk, int nr) {
    const prt_mesh *m = &c->d->scene.mesh;
    const brdf_factor *fx = &c->d->factors[m->mat[x]];
    const float *n = m->nrm + 3 * (size_t)x, *s = c->frame + 6 * (size_t)x, *tt = s + 3;
    int nslots = 0;
    float g[3 * BRDF_MAX_SIGMA], gb[3 * BRDF_MAX_SIGMA + 1];
    for (int r = 0; r < nr; r++) {
        const vis_hit *h = &th->hits[r];
        if (h->tri < 0 || h->tri >= m->ntris) continue;
        const float *w = th->dirs + 3 * r;
        float wl[3];
        brdf_to_local(s, tt, n, w, wl);
        if (wl[2] <= 0.f) continue;
        brdf_factor_light(fx, wl, g);
        gb[0] = 0.f;
        for (int ch = 0; ch < 3; ch++)
            for (int k = 0; k < nk; k++) gb[lane(nk, ch, k)] = g[3 * k + ch] * th->cosdw[r];
        float u = h->u, v = h->v;
        if (!(u >= 0.f)) u = 0.f;           /* also catches NaN */
        if (!(v >= 0.f)) v = 0.f;
        if (u > 1.f) u = 1.f;
        if (v > 1.f - u) v = 1.f - u;
        const float beta[3] = { 1.f - u - v, u, v };
        const float mw[3] = { -w[0], -w[1], -w[2] }, one[3] = { 1, 1, 1 };
        /* the stored transport has no texture: light leaving a textured triangle takes its mean */
        const float *alb = c->tri_albedo ? c->tri_albedo + 3 * (size_t)h->tri : one;
        for (int corner = 0; corner < 3; corner++) {
            float b = beta[corner];
            if (!(b > 0.f)) continue;
            int y = (int)m->tris[3 * (size_t)h->tri + corner];
            nslots = gather_add_corner(c, th, y, b, mw, gb, nk, nslots, alb);
        }
    }
    return nslots;
}

/* With the open sky split (gather_desc.open), a Lambertian neighbour y's stored vector lacks its open
 * sky g_y a0(n_y) (opensky.h): adds y's weights W (term 0), times g_y and the bilinear weights of
 * n_y, to the grid normals' weights; returns the count of grid normals in use. */
static int gather_open_weights(const gather_ctx *c, gather_thread *th, int y, int nk, const float *W, int nopen) {
    const int SL = c->slot_lanes;
    const float *g = c->gconst[c->d->scene.mesh.mat[y]];
    const int *q = c->open_q[y];
    const float *w = c->open_w[y];
    for (int k = 0; k < 4; k++) {
        if (w[k] == 0.f) continue;
        if (!th->open_mark[q[k]]) th->open_mark[q[k]] = 1, th->open_used[nopen++] = q[k];
        float *o = th->open_w + (size_t)q[k] * SL;
        for (int ch = 0; ch < 3; ch++)
            for (int t = 0; t < nk; t++) o[lane(nk, ch, t)] += W[lane(nk, ch, t)] * g[ch] * w[k];
    }
    return nopen;
}

/* Adds the grid normals' open-sky vectors with their weights into th->acc and clears the weights. */
static void gather_open_decode(const gather_ctx *c, gather_thread *th, int nk, int nopen) {
    const int SL = c->slot_lanes;
    for (int i = 0; i < nopen; i++) {
        int q = th->open_used[i];
        float *o = th->open_w + (size_t)q * SL;
        accum_any(c->open, q, o, nk, th->acc, th->touched);   /* float storage: no dequantization step */
        memset(o, 0, sizeof(float) * (size_t)SL);
        th->open_mark[q] = 0;
    }
}

/* Decodes each of the nslots distinct neighbour vectors once and accumulates it, with its
 * weights times its dequantization step, into th->acc; frees the slots for the next vertex.
 * (Software prefetching of the next neighbour's coefficients and visiting neighbours in vertex
 * order were measured on the bunny + floor and gained nothing: the lines mostly come from the
 * shared L3.) */
static inline void gather_decode(const gather_ctx *c, gather_thread *th, int nk, int nslots) {
    const prt_transport *prev = c->prev;
    const int SL = c->slot_lanes;
    int nopen = 0;
    memset(th->touched, 0, sizeof th->touched);
    for (int sl = 0; sl < nslots; sl++) {
        int y = th->slot_vert[sl];
        th->slot_of[y] = -1;
        int nl = nvec_of(prev, y);
        const float *W = th->slot_w + (size_t)sl * c->kmax * SL;
        if (c->open && c->desc->open_vert[y]) nopen = gather_open_weights(c, th, y, nk, W, nopen);
        for (int l = 0; l < nl; l++) {
            int vec = (int)prev->vec_first[y] + l;
            if (prev->coef_first[vec + 1] == prev->coef_first[vec]) continue;
            float ws[3 * BRDF_MAX_SIGMA + 1];
            bool any = false;
            ws[0] = 0.f;
            for (int ch = 0; ch < 3; ch++) {
                float sc = vec_scale(prev, vec, ch);
                for (int k = 0; k < nk; k++) {
                    int j = lane(nk, ch, k);
                    ws[j] = W[(size_t)l * SL + j] * sc;
                    any |= ws[j] != 0.f;
                }
            }
            if (any) accum_any(prev, vec, ws, nk, th->acc, th->touched);
        }
    }
    gather_open_decode(c, th, nk, nopen);
}

/* Stores each of x's nk accumulated vectors (truncation to N + quantization) and clears the
 * touched blocks of th->plane and th->acc, so both are zero again for the next vertex. */
static inline void gather_store(const gather_ctx *c, gather_thread *th, int x, int nk) {
    const int S = lanes_of(nk);            /* accumulator floats per wavelet index */
    float *R = th->plane, *G = R + CUBE_TEXELS, *B = G + CUBE_TEXELS;
    for (int k = 0; k < nk; k++) {
        for (int blk = 0; blk < SPARSE_NBLOCKS; blk++) {
            if (!th->touched[blk]) continue;
            for (int i = blk * SPARSE_BLOCK; i < (blk + 1) * SPARSE_BLOCK; i++) {
                const float *a = th->acc + (size_t)i * S;
                R[i] = a[lane(nk, 0, k)]; G[i] = a[lane(nk, 1, k)]; B[i] = a[lane(nk, 2, k)];
            }
        }
        transport_store(c->next, (int)c->next->vec_first[x] + k, R, G, B, th->scratch);
        for (int blk = 0; blk < SPARSE_NBLOCKS; blk++) {
            if (!th->touched[blk]) continue;
            size_t o = (size_t)blk * SPARSE_BLOCK;
            memset(R + o, 0, sizeof(float) * SPARSE_BLOCK);
            memset(G + o, 0, sizeof(float) * SPARSE_BLOCK);
            memset(B + o, 0, sizeof(float) * SPARSE_BLOCK);
        }
    }
    for (int blk = 0; blk < SPARSE_NBLOCKS; blk++)
        if (th->touched[blk])
            memset(th->acc + (size_t)blk * SPARSE_BLOCK * S, 0, sizeof(float) * SPARSE_BLOCK * (size_t)S);
}

/* Gathers one vertex x into next (Eq. 8): cast, combine per neighbour, decode, store. */
static void gather_vertex(gather_ctx *c, gather_thread *th, int x) {
    const prt_mesh *m = &c->d->scene.mesh;
    const int nk = nvec_of(c->prev, x);
    if (nk <= 0) return;
    int nr = gather_cast(c, th, m->pos + 3 * (size_t)x, m->nrm + 3 * (size_t)x);
    int nslots = gather_combine(c, th, x, nk, nr);
    gather_decode(c, th, nk, nslots);
    gather_store(c, th, x, nk);
}

/* A mapped set's pages (transport_map_to_file) leave this process's memory every 1% of a pass of
 * total: the pass reads them at random (hit vertices anywhere), so without this they would all
 * come back into its resident set; each drop costs one minor fault per page read again. */
static void drop_mapped(const prt_transport *t, int done, int *dropped, int total) {
    int step = total / 100 > 1 ? total / 100 : 1;
    if (!t->data_map || done - *dropped < step) return;
    transport_drop_mapped(t);
    *dropped = done;
}

static void gather_range(void *ctx, int begin, int end, int thread) {
    gather_ctx *c = ctx;
    int n = 0;
    double *cost = c->desc ? c->desc->cost : NULL;
    for (int x = c->v0 + begin; x < c->v0 + end; x++) {
        if (atomic_load_explicit(&c->cancel, memory_order_relaxed)) break;
        n++;
        if (c->restored && c->restored[x]) continue;
        double t0 = cost ? prt_now() : 0;
        gather_vertex(c, &c->th[thread], x);
        if (cost) cost[x] = prt_now() - t0;
        if (c->desc->ckpt && nvec_of(c->prev, x) > 0) ckpt_add(c->desc->ckpt, c->desc->pass, c->next, x, NULL);
    }
    if (end > begin)   /* streamed: the chunk's staged vectors leave memory */
        transport_release(c->next, (int)c->next->vec_first[c->v0 + begin], (int)c->next->vec_first[c->v0 + end]);
    report(c, n, c->prev->nverts, thread);
    if (thread == 0) drop_mapped(c->prev, atomic_load(&c->done), &c->dropped, c->prev->nverts);
}

static void free_threads(gather_thread *th, int nth) {
    if (!th) return;
    for (int i = 0; i < nth; i++) {
        free(th[i].acc); free(th[i].plane); free(th[i].scratch); free(th[i].slot_of);
        free(th[i].slot_vert); free(th[i].slot_w); free(th[i].dirs); free(th[i].cosdw); free(th[i].hits);
        free(th[i].open_w); free(th[i].open_used); free(th[i].open_mark);
    }
    free(th);
}

/* Checks that t is a finished set whose layout fits; returns 0 or -1. */
static int check_set(const prt_transport *t, const char *what, prt_error *err) {
    if (t && t->stage_count) return prt_fail(err, "gather: %s transport set is not finished", what);
    if (!t || !t->vec_first || !t->coef_first || !t->run_first || t->nverts < 0 || t->nvecs < 0)
        return prt_fail(err, "gather: %s transport set is empty", what);
    if (t->qbits != 8 && t->qbits != 16 && t->qbits != 32)
        return prt_fail(err, "gather: %s transport set has unsupported qbits %d", what, t->qbits);
    return 0;
}

static int *vec_counts(const prt_transport *t, prt_error *err) {
    int *cnt = prt_calloc((size_t)(t->nverts > 0 ? t->nverts : 1), sizeof(int), err);
    if (!cnt) return NULL;
    for (int v = 0; v < t->nverts; v++) cnt[v] = nvec_of(t, v);
    return cnt;
}

/* Checks prev against d's mesh and materials (each vertex has at most its material's
 * K vectors); sets *kmax to the largest vector count of any vertex. Returns 0 or -1. */
static int pass_check(const prt_data *d, const prt_transport *prev, int res, int *kmax, prt_error *err) {
    if (check_set(prev, "previous", err)) return -1;
    const prt_mesh *m = &d->scene.mesh;
    if (prev->nverts != m->nverts)
        return prt_fail(err, "gather: transport has %d vertices but the mesh has %d", prev->nverts, m->nverts);
    if (res > GATHER_MAX_RES) return prt_fail(err, "gather: cube resolution %d out of range (1..%d)", res, GATHER_MAX_RES);
    *kmax = 0;
    for (int v = 0; v < m->nverts; v++) {
        int nv = nvec_of(prev, v), mat = m->mat[v];
        if (mat >= d->scene.nmaterials || mat >= PRT_MAX_MATERIALS)
            return prt_fail(err, "gather: vertex %d has material %d of %d", v, mat, d->scene.nmaterials);
        if (nv > d->factors[mat].K || nv > BRDF_MAX_SIGMA)
            return prt_fail(err, "gather: vertex %d has %d transport vectors but its material has %d terms", v, nv,
                            d->factors[mat].K);
        if (nv > *kmax) *kmax = nv;
    }
    return 0;
}

/* Fills the tables every thread reads: gather-cube texel directions and solid angles,
 * each vertex's Eq. 10 frame, and the constant view maps of Lambertian materials.
 * Returns 0, or -1 with what was allocated left in c for ctx_free. */
static int ctx_tables(gather_ctx *c, prt_error *err) {
    const prt_data *d = c->d;
    const prt_mesh *m = &d->scene.mesh;
    const int res = c->res;
    if (!(c->tex_dir = prt_calloc((size_t)c->ntex * 3, sizeof(float), err)) ||
        !(c->tex_dw = prt_calloc((size_t)c->ntex, sizeof(float), err)) ||
        !(c->frame = prt_calloc((size_t)m->nverts * 6, sizeof(float), err)))
        return -1;
    for (int i = 0; i < c->ntex; i++) {
        cube_texel_dir(res, i, c->tex_dir + 3 * i);
        int ij = i % (res * res);
        c->tex_dw[i] = (float)cube_texel_solid_angle(res, ij % res, ij / res);
    }
    for (int v = 0; v < m->nverts; v++)
        brdf_frame(m->nrm + 3 * (size_t)v, c->frame + 6 * (size_t)v, c->frame + 6 * (size_t)v + 3);
    if (d->scene.ntextures > 0 && m->uv) {
        if (!(c->tri_albedo = prt_calloc(3 * (size_t)m->ntris, sizeof(float), err))) return -1;
        for (int t = 0; t < m->ntris; t++) scene_triangle_albedo(&d->scene, t, c->tri_albedo + 3 * (size_t)t);
    }
    if (c->open) {
        if (!(c->open_q = prt_calloc((size_t)m->nverts, sizeof *c->open_q, err)) ||
            !(c->open_w = prt_calloc((size_t)m->nverts, sizeof *c->open_w, err)))
            return -1;
        for (int v = 0; v < m->nverts; v++) opensky_weights(m->nrm + 3 * (size_t)v, c->open_q[v], c->open_w[v]);
    }
    for (int i = 0; i < d->scene.nmaterials && i < PRT_MAX_MATERIALS; i++) {
        const brdf_factor *f = &d->factors[i];
        if (f->lambertian && f->K == 1) {
            const float up[3] = { 0.f, 0.f, 1.f };
            brdf_factor_view(f, up, c->hconst[i]);
            brdf_factor_lambert_light(f, c->gconst[i]);
            c->hconst_ok[i] = true;
        }
    }
    return 0;
}

/* Allocates the nth per-thread work areas (zeroed; every slot_of entry -1). Returns 0,
 * or -1 with what was allocated left in c->th for ctx_free. */
static int threads_alloc(gather_ctx *c, int nth, prt_error *err) {
    const int nverts = c->d->scene.mesh.nverts;
    /* A vertex has at most ntex/2 + a few upper-hemisphere rays, each naming 3 neighbours. */
    c->max_slots = 3 * c->ntex < nverts ? 3 * c->ntex : nverts;
    if (!(c->th = prt_calloc((size_t)nth, sizeof(gather_thread), err))) return -1;
    for (int i = 0; i < nth; i++) {
        gather_thread *t = &c->th[i];
        if (!(t->acc = prt_calloc((size_t)CUBE_TEXELS * c->slot_lanes, sizeof(float), err)) ||
            !(t->plane = prt_calloc((size_t)CUBE_TEXELS * 3, sizeof(float), err)) ||
            !(t->scratch = prt_calloc(1, transport_scratch_size(), err)) ||
            !(t->slot_of = prt_calloc((size_t)nverts, sizeof(int), err)) ||
            !(t->slot_vert = prt_calloc((size_t)c->max_slots, sizeof(int), err)) ||
            !(t->slot_w = prt_calloc((size_t)c->max_slots * c->kmax * c->slot_lanes, sizeof(float), err)) ||
            !(t->dirs = prt_calloc((size_t)c->ntex * 3, sizeof(float), err)) ||
            !(t->cosdw = prt_calloc((size_t)c->ntex, sizeof(float), err)) ||
            !(t->hits = prt_calloc((size_t)c->ntex, sizeof(vis_hit), err)))
            return -1;
        if (c->open && (!(t->open_w = prt_calloc((size_t)OPENSKY_NORMALS * c->slot_lanes, sizeof(float), err)) ||
                        !(t->open_used = prt_calloc(OPENSKY_NORMALS, sizeof(int), err)) ||
                        !(t->open_mark = prt_calloc(OPENSKY_NORMALS, 1, err))))
            return -1;
        for (int v = 0; v < nverts; v++) t->slot_of[v] = -1;
    }
    return 0;
}

/* Frees what ctx_tables and threads_alloc allocated (any part may be NULL). */
static void ctx_free(gather_ctx *c, int nth) {
    free_threads(c->th, nth);
    free(c->tex_dir); free(c->tex_dw); free(c->frame); free(c->restored); free(c->tri_albedo);
    free(c->open_q); free(c->open_w);
}

/* The vertices of this pass that the checkpoint holds, staged into next (gather_desc.ckpt).
 * Returns 0 or -1 (a corrupt checkpoint, OOM). */
static int restore(gather_ctx *c, prt_error *err) {
    if (!c->desc || !c->desc->ckpt || ckpt_count(c->desc->ckpt, c->desc->pass) == 0) return 0;
    c->restored = prt_calloc((size_t)c->next->nverts, 1, err);
    if (!c->restored) return -1;
    return ckpt_restore(c->desc->ckpt, c->desc->pass, c->next, c->restored, NULL, err) < 0 ? -1 : 0;
}

/* Frees next and leaves it zeroed; returns -1 for the caller to pass on. */
static int drop_set(prt_transport *next) {
    transport_free(next);
    memset(next, 0, sizeof *next);
    return -1;
}

/* This rank's range of the pass (gather_desc.shard; all vertices on one process) into c->v0, v1
 * and first[ranks + 1]. */
static void split(gather_ctx *c, int *first) {
    prt_shard *sh = c->desc ? c->desc->shard : NULL;
    shard_split(sh, c->desc ? c->desc->cost : NULL, c->prev->nverts, first);
    c->v0 = first[shard_rank(sh)];
    c->v1 = first[shard_rank(sh) + 1];
}

/* After this rank's range: the ranks' common status (cancelled on one: on all), then every rank's
 * vectors and per-vertex times to every rank. Returns 0 or -1. */
static int share(gather_ctx *c, const int *first, bool cancelled, prt_error *err) {
    prt_shard *sh = c->desc ? c->desc->shard : NULL;
    if (shard_status(sh, cancelled ? prt_fail(err, "cancelled") : 0, err)) return -1;
    if (shard_share_staged(sh, c->next, first, err)) return -1;
    return c->desc->cost ? shard_share_rows(sh, c->desc->cost, sizeof(double), first, err) : 0;
}

/* One interreflection pass (see gather.h). Returns 0, or -1 with err set; next is
 * left zeroed on failure. */
int gather_pass(const prt_data *d, const vis_scene *vs, const prt_transport *prev, const gather_desc *desc,
                prt_transport *next, prt_error *err) {
    memset(next, 0, sizeof *next);
    int res = desc && desc->res > 0 ? desc->res : GATHER_DEFAULT_RES, kmax = 0;
    if (pass_check(d, prev, res, &kmax, err)) return -1;
    const prt_mesh *m = &d->scene.mesh;
    int *cnt = vec_counts(prev, err);
    if (!cnt) return -1;
    int rc = transport_init_like(next, prev, cnt, err);   /* N, budget, qbits, selection, measure */
    free(cnt);
    if (rc) { memset(next, 0, sizeof *next); return -1; }
    if (desc && desc->stream_dir && transport_stage_to_file(next, desc->stream_dir, err)) return drop_set(next);
    if (m->nverts == 0 || kmax == 0) return transport_finish(next, err);

    gather_ctx c;
    memset(&c, 0, sizeof c);
    c.d = d; c.vs = vs; c.prev = prev; c.next = next; c.res = res; c.kmax = kmax; c.desc = desc;
    c.ntex = 6 * res * res;
    c.slot_lanes = lanes_of(kmax) > 4 ? lanes_of(kmax) : 4;
    c.eps = vis_eps(vs);
    c.open = desc ? desc->open : NULL;
    if (c.open && (c.open->nverts != OPENSKY_NORMALS || c.open->qbits != 32 || !desc->open_vert)) {
        transport_free(next);
        memset(next, 0, sizeof *next);
        return prt_fail(err, "gather: the open-sky set is not %d float vectors", OPENSKY_NORMALS);
    }
    /* a folded vector is not in the light's space (transfer.h OPENSKY_FOLDED): precompute folds only
     * files without interreflections */
    for (int v = 0; c.open && v < prev->nverts; v++) PRT_CHECK(desc->open_vert[v] != OPENSKY_FOLDED);
    int nth = prt_thread_count(desc ? desc->nthreads : 0);
    if (ctx_tables(&c, err) || threads_alloc(&c, nth, err)) {
        ctx_free(&c, nth);
        return drop_set(next);
    }
    if (restore(&c, err)) {
        ctx_free(&c, nth);
        return drop_set(next);
    }
    int first[SHARD_MAX_RANKS + 1];
    split(&c, first);
    pthread_mutex_init(&c.lock, NULL);
    atomic_init(&c.done, 0);
    atomic_init(&c.cancel, false);
    atomic_init(&c.others, 0);
    const char *stage = desc && desc->stage ? desc->stage : "gather";
    if (!(c.sp = shard_pass_begin(desc ? desc->shard : NULL, stage, "vertices", m->nverts, err))) {
        ctx_free(&c, nth);
        return drop_set(next);
    }
    prt_parallel_for(c.v1 - c.v0, GATHER_GRAIN, nth, gather_range, &c);
    shard_pass_end(c.sp, atomic_load(&c.done), desc ? desc->progress : NULL, desc ? desc->progress_user : NULL);
    pthread_mutex_destroy(&c.lock);
    bool cancelled = atomic_load(&c.cancel);
    ctx_free(&c, nth);
    if (share(&c, first, cancelled, err)) return drop_set(next);
    if (transport_finish(next, err)) return drop_set(next);
    if (desc && desc->stream_dir && transport_map_to_file(next, desc->stream_dir, err)) return drop_set(next);
    return 0;
}

/* ---- sum of two sets ----------------------------------------------------- */

typedef struct sum_ctx {
    const prt_transport *a, *b;
    prt_transport *out;
    float **plane;     /* per thread [3][CUBE_TEXELS], zero between vectors */
    void **scratch;
    int dropped;       /* thread 0: vectors done when a and b's mapped pages were last dropped */
} sum_ctx;

/* Adds vector i of t (dequantized) into planar R, G, B; marks touched blocks. */
static void add_planar(const prt_transport *t, int i, float *R, float *G, float *B, uint8_t *touched) {
    const float s0 = vec_scale(t, i, 0), s1 = vec_scale(t, i, 1), s2 = vec_scale(t, i, 2);
    uint32_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t block = t->runs[2 * r], count = (uint32_t)t->runs[2 * r + 1] + 1u;
        touched[block] = 1;
        for (uint32_t e = c + count; c < e; c++) {
            uint32_t off;
            float v0, v1, v2;
            if (t->qbits == 8) {
                uint32_t p = t->packed[c];
                off = p & 255u;
                v0 = (float)(int8_t)(uint8_t)(p >> 8);
                v1 = (float)(int8_t)(uint8_t)(p >> 16);
                v2 = (float)(int8_t)(uint8_t)(p >> 24);
            } else if (t->qbits == 16) {
                off = t->offs[c];
                v0 = t->q16[3 * c]; v1 = t->q16[3 * c + 1]; v2 = t->q16[3 * c + 2];
            } else {
                off = t->offs[c];
                v0 = t->f32[3 * c]; v1 = t->f32[3 * c + 1]; v2 = t->f32[3 * c + 2];
            }
            size_t idx = (size_t)block * SPARSE_BLOCK + off;
            R[idx] += v0 * s0; G[idx] += v1 * s1; B[idx] += v2 * s2;
        }
    }
}

static void sum_range(void *ctx, int begin, int end, int thread) {
    sum_ctx *c = ctx;
    float *R = c->plane[thread], *G = R + CUBE_TEXELS, *B = G + CUBE_TEXELS;
    for (int i = begin; i < end; i++) {
        uint8_t touched[SPARSE_NBLOCKS] = { 0 };
        add_planar(c->a, i, R, G, B, touched);
        add_planar(c->b, i, R, G, B, touched);
        transport_store(c->out, i, R, G, B, c->scratch[thread]);
        for (int blk = 0; blk < SPARSE_NBLOCKS; blk++) {
            if (!touched[blk]) continue;
            size_t o = (size_t)blk * SPARSE_BLOCK;
            memset(R + o, 0, sizeof(float) * SPARSE_BLOCK);
            memset(G + o, 0, sizeof(float) * SPARSE_BLOCK);
            memset(B + o, 0, sizeof(float) * SPARSE_BLOCK);
        }
    }
    transport_release(c->out, begin, end);   /* streamed: the chunk's staging leaves memory */
    if (thread == 0) {   /* a and b are read in order, so one drop per 1% keeps about 1% of each resident */
        int d0 = c->dropped;
        drop_mapped(c->a, end, &c->dropped, c->a->nvecs);
        if (c->dropped != d0) transport_drop_mapped(c->b);
    }
}

/* out = a + b (see gather.h). Returns 0, or -1 with err set (out left zeroed). */
int gather_sum(const prt_transport *a, const prt_transport *b, int nthreads, prt_transport *out, prt_error *err) {
    return gather_sum_streamed(a, b, nthreads, NULL, out, err);
}

/* See gather.h. */
int gather_sum_streamed(const prt_transport *a, const prt_transport *b, int nthreads, const char *stream_dir,
                        prt_transport *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    if (check_set(a, "first", err) || check_set(b, "second", err)) return -1;
    if (a->nverts != b->nverts || a->nvecs != b->nvecs ||
        memcmp(a->vec_first, b->vec_first, sizeof(uint32_t) * ((size_t)a->nverts + 1)) != 0)
        return prt_fail(err, "gather: cannot sum transport sets with different layouts (%d/%d vertices, %d/%d vectors)",
                        a->nverts, b->nverts, a->nvecs, b->nvecs);
    int *cnt = vec_counts(a, err);
    if (!cnt) return -1;
    int rc = transport_init_like(out, a, cnt, err);   /* N, budget, qbits, selection, measure */
    free(cnt);
    if (rc) { memset(out, 0, sizeof *out); return -1; }
    if (stream_dir && transport_stage_to_file(out, stream_dir, err)) return drop_set(out);
    int nth = prt_thread_count(nthreads);
    sum_ctx c = { .a = a, .b = b, .out = out };
    c.plane = prt_calloc((size_t)nth, sizeof(float *), err);
    c.scratch = c.plane ? prt_calloc((size_t)nth, sizeof(void *), err) : NULL;
    bool ok = c.scratch != NULL;
    for (int i = 0; ok && i < nth; i++) {
        c.plane[i] = prt_calloc((size_t)CUBE_TEXELS * 3, sizeof(float), err);
        c.scratch[i] = c.plane[i] ? prt_calloc(1, transport_scratch_size(), err) : NULL;
        ok = c.scratch[i] != NULL;
    }
    if (ok) prt_parallel_for(a->nvecs, 64, nth, sum_range, &c);
    for (int i = 0; i < nth; i++) {
        if (c.plane) free(c.plane[i]);
        if (c.scratch) free(c.scratch[i]);
    }
    free(c.plane);
    free(c.scratch);
    if (!ok || transport_finish(out, err) || (stream_dir && transport_map_to_file(out, stream_dir, err))) return drop_set(out);
    return 0;
}

/* Sum over vectors and channels of squared dequantized coefficients (see gather.h). */
double gather_energy(const prt_transport *t) {
    if (!t || !t->coef_first || t->stage_count) return 0.0;
    double e = 0.0;
    for (int i = 0; i < t->nvecs; i++) {
        double q[3] = { 0, 0, 0 };
        for (uint32_t c = t->coef_first[i]; c < t->coef_first[i + 1]; c++) {
            double v0, v1, v2;
            if (t->qbits == 8) {
                uint32_t p = t->packed[c];
                v0 = (int8_t)(uint8_t)(p >> 8); v1 = (int8_t)(uint8_t)(p >> 16); v2 = (int8_t)(uint8_t)(p >> 24);
            } else if (t->qbits == 16) {
                v0 = t->q16[3 * c]; v1 = t->q16[3 * c + 1]; v2 = t->q16[3 * c + 2];
            } else {
                v0 = t->f32[3 * c]; v1 = t->f32[3 * c + 1]; v2 = t->f32[3 * c + 2];
            }
            q[0] += v0 * v0; q[1] += v1 * v1; q[2] += v2 * v2;
        }
        for (int ch = 0; ch < 3; ch++) {
            double s = vec_scale(t, i, ch);
            e += q[ch] * s * s;
        }
    }
    return e;
}
