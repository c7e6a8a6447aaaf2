/* transport.c - compressed transport vectors: building, storage and the runtime T x L.
 *
 * Each vector keeps its N largest wavelet coefficients (section 4.1.1), quantized
 * uniformly per channel (section 4.1.2), with its indices split into a block
 * (index / 256) and an offset (index % 256). Because the kept indices are sorted
 * and cluster at the start of each face (haar.h's Morton order), consecutive
 * coefficients mostly share a block, so blocks are stored run-length coded as
 * (block, count-1) bytes and the offsets travel in the coefficient words.
 *
 * Building is two-phase so that the precomputation can store vectors from many
 * threads at once: transport_store writes only vector i's own staging slots
 * (stage_count[i], stage_idx/stage_val[i*N ..], scale[3i ..]); transport_finish
 * then packs the variable-length vectors contiguously.
 *
 * With the solid-angle measure, what truncation drops is put back into the kept coarse
 * coefficients (README "Shadows"): per 16x16-texel block under w (block_integrals), or, on a
 * face with no occluder edge, weighted by the transport on its scaling coefficient (the smooth
 * faces). The tables both read (w, its Haar coefficients, its block sums) are made once per set.
 *
 * A shared budget (transport_share_budget) moves the choice to transport_finish: transport_store
 * stages a vector's N_max best candidates raw with their selection weights, the squared norm and what
 * its other coefficients drop from each correction block; finish finds the one weight threshold that
 * keeps budget x nvecs of them (a radix select over all the weights' bits), then corrects and
 * quantizes each vector's kept ones in its staging, and packs as before. Staging grows from 16 bytes
 * per kept coefficient to 20 per candidate plus 1,256 per vector (3.1x at N_max = 2N = 256), which
 * transport_stage_to_file streams through a file like the rest.
 *
 * The runtime kernel (Eq. 5, T x L) walks each vector's runs with a base pointer
 * L + 256*block and accumulates value * L[offset] in float RGB(A) lanes: with
 * 8-bit data one 32-bit word gives the offset and the three int8 values, which
 * SSE4.1 sign-extends to int32 lanes straight from memory; the per-channel
 * scale is applied once per vector at the end. Vectors are split across both
 * cores in chunks of a few thousand. */
#include "transport.h"
#include "haar.h"
#include "refit.h"
#include <errno.h>
#include <float.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>
#ifdef __SSE4_1__
#include <smmintrin.h>
#endif

static int qmax_of(int qbits) { return qbits == 8 ? 127 : qbits == 16 ? 32767 : 0; }
static uint32_t bits_of(float x) { uint32_t u; memcpy(&u, &x, sizeof u); return u; }

enum { FACE = CUBE_RES * CUBE_RES };

/* What every vector's corrections read, computed once per set (per vector they cost as much as the
 * corrections themselves: make bench's transport stage). */
typedef struct transport_tables {
    float w[FACE];                                /* the solid angle per texel (haar_face_solid_angle) */
    float W[FACE];                                /* its Haar coefficients, morton order */
    double wsum[TRANSPORT_BLOCK_LEVEL_MAX + 1][16];   /* w summed over each block of level b (row-major) */
} transport_tables;

/* The tables of a set. Returns NULL on OOM. */
static transport_tables *tables_create(prt_error *err) {
    transport_tables *tb = prt_calloc(1, sizeof *tb, err);
    if (!tb) return NULL;
    haar_face_solid_angle(tb->w, CUBE_RES, false);
    for (int b = 0; b <= TRANSPORT_BLOCK_LEVEL_MAX; b++) {
        int s = 1 << b, side = CUBE_RES / s;
        for (int j = 0; j < CUBE_RES; j++)
            for (int i = 0; i < CUBE_RES; i++) tb->wsum[b][(j / side) * s + i / side] += tb->w[j * CUBE_RES + i];
    }
    float tmp[FACE];
    haar_face_solid_angle_coeffs(tb->W, CUBE_RES, tmp);
    return tb;
}

/* Sizes the set and allocates staging; returns 0, or -1 with err set. */
int transport_init(prt_transport *t, int nverts, const int *nvec_of_vertex, int N, int qbits, prt_error *err) {
    memset(t, 0, sizeof *t);
    if (nverts < 0 || (nverts > 0 && !nvec_of_vertex)) return prt_fail(err, "transport: bad vertex count %d", nverts);
    if (N < 1 || N > CUBE_TEXELS) return prt_fail(err, "transport: N = %d is outside 1..%d", N, CUBE_TEXELS);
    if (qbits != 8 && qbits != 16 && qbits != 32) return prt_fail(err, "transport: qbits must be 8, 16 or 32, not %d", qbits);
    size_t nvecs = 0;
    for (int v = 0; v < nverts; v++) {
        if (nvec_of_vertex[v] < 0 || nvec_of_vertex[v] > 4096)
            return prt_fail(err, "transport: vertex %d has a bad vector count %d", v, nvec_of_vertex[v]);
        nvecs += (size_t)nvec_of_vertex[v];
    }
    if (nvecs > (size_t)INT32_MAX / 4) return prt_fail(err, "transport: too many vectors (%zu)", nvecs);
    t->nverts = nverts;
    t->nvecs = (int)nvecs;
    t->N = N;
    t->qbits = qbits;
    t->vec_first = prt_calloc((size_t)nverts + 1, sizeof *t->vec_first, err);
    t->scale = prt_calloc(3 * nvecs, sizeof *t->scale, err);
    t->stage_count = prt_calloc(nvecs, sizeof *t->stage_count, err);
    t->stage_idx = prt_calloc(nvecs * (size_t)N, sizeof *t->stage_idx, err);
    t->stage_val = prt_calloc(nvecs * (size_t)N * 3, sizeof *t->stage_val, err);
    t->tables = tables_create(err);
    if (!t->vec_first || !t->scale || !t->stage_count || !t->stage_idx || !t->stage_val || !t->tables) {
        prt_error e2;
        prt_fail(&e2, "transport: out of memory for %zu vectors of %d coefficients", nvecs, N);
        transport_free(t);
        return prt_fail(err, "%s", e2.msg);
    }
    for (int v = 0; v < nverts; v++) t->vec_first[v + 1] = t->vec_first[v] + (uint32_t)nvec_of_vertex[v];
    if (qbits == 32)
        for (size_t k = 0; k < 3 * nvecs; k++) t->scale[k] = 1.f;
    return 0;
}

/* See transport.h: the staging is allocated again at nmax candidates per vector. */
int transport_share_budget(prt_transport *t, int kind, int nmax, prt_error *err) {
    PRT_CHECK(t->stage_count && !t->stage_mapped && !t->budget);
    if (kind == TRANSPORT_BUDGET_VECTOR) return 0;
    PRT_CHECK(kind == TRANSPORT_BUDGET_SHARED || kind == TRANSPORT_BUDGET_RELATIVE);
    if (nmax <= 0) nmax = t->N > CUBE_TEXELS / TRANSPORT_SHARED_CAP ? CUBE_TEXELS : TRANSPORT_SHARED_CAP * t->N;
    PRT_CHECK(nmax >= t->N && nmax <= CUBE_TEXELS);
    size_t nk = (size_t)t->nvecs * (size_t)nmax;
    uint32_t *idx = prt_calloc(nk, sizeof *idx, err);
    float *val = idx ? prt_calloc(3 * nk, sizeof *val, err) : NULL;
    float *key = val ? prt_calloc(nk, sizeof *key, err) : NULL;
    float *blk = key ? prt_calloc((size_t)t->nvecs * TRANSPORT_STAGE, sizeof *blk, err) : NULL;
    if (!blk) {
        free(idx); free(val); free(key);
        return prt_fail(err, "transport: out of memory staging %zu vectors of %d candidates (a shared budget)", (size_t)t->nvecs, nmax);
    }
    free(t->stage_idx);
    free(t->stage_val);
    t->stage_idx = idx; t->stage_val = val; t->stage_key = key; t->stage_blk = blk;
    t->budget = t->N;
    t->budget_kind = kind;
    t->budget_min = t->budget / TRANSPORT_SHARED_MIN;
    t->N = nmax;
    return 0;
}

/* See transport.h. */
int transport_init_like(prt_transport *t, const prt_transport *like, const int *nvec_of_vertex, prt_error *err) {
    if (transport_init(t, like->nverts, nvec_of_vertex, like->budget ? like->budget : like->N, like->qbits, err)) return -1;
    t->solid_angle = like->solid_angle;
    t->select = like->select;
    t->prior = like->prior;
    t->refit = like->refit;
    t->block_level = like->block_level;
    t->smooth_faces = like->smooth_faces;
    if (like->budget && transport_share_budget(t, like->budget_kind, like->N, err)) {
        transport_free(t);
        return -1;
    }
    return 0;
}

/* The staging arrays' bytes: indices, values, and with a shared budget the keys and block integrals. */
static void stage_sizes(const prt_transport *t, size_t len[4]) {
    size_t nk = (size_t)t->nvecs * t->N;
    len[0] = nk * sizeof *t->stage_idx;
    len[1] = nk * 3 * sizeof *t->stage_val;
    len[2] = t->stage_key ? nk * sizeof *t->stage_key : 0;
    len[3] = t->stage_blk ? (size_t)t->nvecs * TRANSPORT_STAGE * sizeof *t->stage_blk : 0;
}

/* See transport.h. */
size_t transport_staging_bytes(const prt_transport *t) {
    size_t len[4];
    stage_sizes(t, len);
    return len[0] + len[1] + len[2] + len[3];
}

/* See transport.h: one file-backed shared mapping holds the indices, then the values (then a shared
 * budget's keys and block integrals). */
int transport_stage_to_file(prt_transport *t, const char *dir, prt_error *err) {
    PRT_CHECK(t->stage_idx && !t->stage_mapped);
    size_t len[4], bytes = 0;
    stage_sizes(t, len);
    for (int k = 0; k < 4; k++) bytes += len[k];
    if (bytes == 0) return 0;
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);   /* unlinked from the start: nothing left behind */
    if (fd < 0) return prt_fail(err, "%s: cannot create the streamed pass's temporary file: %s", dir, strerror(errno));
    if (ftruncate(fd, (off_t)bytes)) {
        int e = errno;
        close(fd);
        return prt_fail(err, "%s: cannot size the streamed pass's temporary file to %zu bytes: %s", dir, bytes, strerror(e));
    }
    void *m = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    close(fd);
    if (m == MAP_FAILED) return prt_fail(err, "%s: cannot map the streamed pass's temporary file: %s", dir, strerror(errno));
    free(t->stage_idx);
    free(t->stage_val);
    free(t->stage_key);
    free(t->stage_blk);
    t->stage_idx = m;
    t->stage_val = (float *)(void *)((char *)m + len[0]);
    t->stage_key = len[2] ? (float *)(void *)((char *)m + len[0] + len[1]) : NULL;
    t->stage_blk = len[3] ? (float *)(void *)((char *)m + len[0] + len[1] + len[2]) : NULL;
    t->stage_mapped = bytes;
    return 0;
}

/* Drops the pages [p, p + n) touches from this process's memory. A page shared with a vector
 * another thread is writing may be dropped too: on a shared file mapping MADV_DONTNEED only unmaps
 * (the page cache keeps the page, dirty or not), and the writer's next store maps it again. */
static void drop_pages(const void *p, size_t n) {
    const uintptr_t pg = 4096;
    uintptr_t a = (uintptr_t)p & ~(pg - 1), b = ((uintptr_t)p + n + pg - 1) & ~(pg - 1);
    if (b > a) madvise((void *)a, b - a, MADV_DONTNEED);
}

/* See transport.h. */
void transport_release(const prt_transport *t, int i0, int i1) {
    if (!t->stage_mapped || i1 <= i0) return;
    size_t N = (size_t)t->N;
    drop_pages(t->stage_idx + (size_t)i0 * N, (size_t)(i1 - i0) * N * sizeof *t->stage_idx);
    drop_pages(t->stage_val + (size_t)i0 * N * 3, (size_t)(i1 - i0) * N * 3 * sizeof *t->stage_val);
    if (t->stage_key) drop_pages(t->stage_key + (size_t)i0 * N, (size_t)(i1 - i0) * N * sizeof *t->stage_key);
    if (t->stage_blk) drop_pages(t->stage_blk + (size_t)i0 * TRANSPORT_STAGE, (size_t)(i1 - i0) * TRANSPORT_STAGE * sizeof *t->stage_blk);
}

/* Writes n bytes of p at offset off of fd; returns 0 or -1 (errno). */
static int write_all(int fd, const void *p, size_t n, size_t off) {
    for (size_t done = 0; done < n;) {
        ssize_t w = pwrite(fd, (const char *)p + done, n - done, (off_t)(off + done));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        done += (size_t)w;
    }
    return 0;
}

/* See transport.h: the file holds runs, then packed (8-bit) or offs and q16 / f32, each at a
 * 64-byte boundary; written from the heap arrays (into the page cache, not through the mapping, so
 * they never count twice in this process), then mapped and the heap copies freed. */
int transport_map_to_file(prt_transport *t, const char *dir, prt_error *err) {
    PRT_CHECK(t->coef_first && !t->stage_count && !t->data_map);
    size_t nc = transport_ncoefs(t), nr = transport_nruns(t);
    const void *src[4] = { t->runs, t->packed, t->offs, t->qbits == 32 ? (const void *)t->f32 : (const void *)t->q16 };
    size_t len[4] = { 2 * nr, t->qbits == 8 ? 4 * nc : 0, t->qbits == 8 ? 0 : nc, t->qbits == 16 ? 6 * nc : t->qbits == 32 ? 12 * nc : 0 };
    size_t off[4], bytes = 0;
    for (int k = 0; k < 4; k++) { off[k] = bytes; bytes += (len[k] + 63) & ~(size_t)63; }
    if (bytes == 0) return 0;
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);   /* unlinked from the start: nothing left behind */
    if (fd < 0) return prt_fail(err, "%s: cannot create the mapped pass's temporary file: %s", dir, strerror(errno));
    int bad = ftruncate(fd, (off_t)bytes);
    for (int k = 0; k < 4 && !bad; k++) bad = len[k] ? write_all(fd, src[k], len[k], off[k]) : 0;
    void *m = bad ? MAP_FAILED : mmap(NULL, bytes, PROT_READ, MAP_SHARED, fd, 0);
    int e = errno;
    close(fd);
    if (m == MAP_FAILED) return prt_fail(err, "%s: cannot write and map the mapped pass's %zu-byte temporary file: %s", dir, bytes, strerror(e));
    char *b = m;
    if (len[0]) { free(t->runs); t->runs = (uint8_t *)b; }
    if (len[1]) { free(t->packed); t->packed = (uint32_t *)(void *)(b + off[1]); }
    if (len[2]) { free(t->offs); t->offs = (uint8_t *)(b + off[2]); }
    if (len[3] && t->qbits == 16) { free(t->q16); t->q16 = (int16_t *)(void *)(b + off[3]); }
    if (len[3] && t->qbits == 32) { free(t->f32); t->f32 = (float *)(void *)(b + off[3]); }
    t->data_map = m;
    t->data_mapped = bytes;
    return 0;
}

/* See transport.h. */
void transport_drop_mapped(const prt_transport *t) {
    if (t->data_map) madvise(t->data_map, t->data_mapped, MADV_DONTNEED);
}

/* Frees the staging arrays (an unmap when streamed). */
static void free_staging(prt_transport *t) {
    free(t->stage_count);
    free(t->tables);
    t->tables = NULL;
    if (t->stage_mapped) munmap(t->stage_idx, t->stage_mapped);
    else { free(t->stage_idx); free(t->stage_val); free(t->stage_key); free(t->stage_blk); }
    t->stage_count = NULL; t->stage_idx = NULL; t->stage_val = NULL; t->stage_key = NULL; t->stage_blk = NULL;
    t->stage_mapped = 0;
}

_Static_assert(CUBE_RES == 1 << (TRANSPORT_LEVELS - 1), "transport_level_sigma has one entry per Haar level of a face");

/* Bytes of scratch transport_store needs (store_scratch's layout): selection keys and indices, a
 * face's transform scratch, the expected-error selection's weighted copy of the three channels (then
 * the corrections' scratch), and the smooth faces' transport coefficients (face_shapes). */
size_t transport_scratch_size(void) {
    return 2 * CUBE_TEXELS * sizeof(float) + CUBE_TEXELS * sizeof(uint32_t) + 2 * FACE * sizeof(float) +
           3 * CUBE_TEXELS * sizeof(float) + CUBE_TEXELS * sizeof(float) + refit_scratch_size(REFIT_MAX_N);
}

/* The RMS light coefficient per Haar level relative to the finest, sqrt of the geometric mean over
 * the four probes with a sun or lamp (city, interior, night, sunrise: a source about 34,000 times
 * the mean, /work/shared/data/SOURCES.md) of each probe's mean squared coefficient per level, over 24
 * rotations (yaw in 15-degree steps, pitch -30/0/30), the three channels and the six faces, of the
 * light the solid-angle measure builds (L_j w_j). Per probe sigma_0^2 / sigma_6^2 is 11.7, 8.8, 8.5,
 * 3.8: a sun alone is flat over the levels (a point of value a has one coefficient a/s per level of
 * s x s blocks, among (64/s)^2 per face: the mean square a^2/4096 at every level), and the sky adds
 * to the coarse ones. Probes without a sun are far steeper (forest 281, studio 155), but under them
 * the transport's coarse coefficients, which every selection keeps, carry nearly all of T.L.
 * Measured with tools/level_spectrum.sh; the weights need no asset at run time. */
const float transport_level_sigma[TRANSPORT_LEVELS] = { 2.752f, 1.643f, 1.512f, 1.373f, 1.303f, 1.200f, 1.000f };

/* Level of a wavelet index: the number of base-4 digits of its position in the face. */
int transport_level(uint32_t i) {
    uint32_t m = i % FACE;
    int l = 0;
    while (m) { l++; m >>= 2; }
    PRT_CHECK_LT(l, TRANSPORT_LEVELS);
    return l;
}

/* The prior's weighted copy of one channel: c_i sigma_i, less what quantization would lose anyway on
 * the faces of `smooth` (face_smooth). A kept coefficient still errs by its rounding (step = the
 * channel's largest |c| / qmax, sparse.h), and on a face with no occluder edge a dropped one is put
 * back weighted by the transport (smooth_faces), so there a coefficient gains its slot only by what
 * exceeds a step: sigma_i^2 (c_i^2 - step^2). Without this the prior, which weighs a sun's ring
 * heavily, kept the ring's many tiny fine coefficients of an open floor, whose rounding at 8 bits left
 * its ratio over the turn 1.10% off at worst (README "Shadows"; step^2 / 12, the mean rounding error,
 * measured 1.19%; step^2 0.26%). On a face an occluder's edge crosses the fine coefficients are the
 * edge, and nothing puts them back: there the term cost the full bunny's floor shadow 3.15% -> 4.63%,
 * so it is not taken. Non-finite stays so. */
static void prior_channel(const float *c, const float (*prior)[4], int ch, int qbits, unsigned smooth, float *w) {
    float mx = 0;
    for (int j = 0; j < CUBE_TEXELS; j++)
        if (isfinite(c[j]) && fabsf(c[j]) > mx) mx = fabsf(c[j]);
    int qmax = qmax_of(qbits);   /* 0: float, no rounding */
    double step = qmax ? (double)mx / qmax : 0, e2 = step * step;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double d = (double)c[j] * c[j] - (smooth >> (j / FACE) & 1 ? e2 : 0);
        w[j] = !isfinite(c[j]) ? c[j] : d > 0 ? (float)(sqrt(d) * prior[j][ch]) : 0.f;
    }
}

/* Why: keeping the N largest |c_i| minimises the L2 error of T, but what the runtime sees is the error
 * of T.L, whose expectation over lights with uncorrelated coefficients of variance sigma_i^2 is
 * sum over dropped i of c_i^2 sigma_i^2 (transport.h): scaling each coefficient by its sigma before the
 * magnitude selection picks the set that minimises it. sigma is its level's (transport_level_sigma), or
 * with a prior (prior.h) its own per channel (prior_channel). The copy is only for selecting; the
 * stored values are the input's. Non-finite inputs stay non-finite, so sparse_select skips them.
 * smooth: the faces face_shapes found smooth (read with a prior); wc: the 3 x CUBE_TEXELS weights. */
static int select_expected(const float *r, const float *g, const float *b, const prt_transport *t, unsigned smooth,
                           uint32_t *idx, float *keys, float *wc) {
    float *wr = wc, *wg = wc + CUBE_TEXELS, *wb = wc + 2 * CUBE_TEXELS;
    if (t->prior) {
        prior_channel(r, t->prior, 0, t->qbits, smooth, wr);
        prior_channel(g, t->prior, 1, t->qbits, smooth, wg);
        prior_channel(b, t->prior, 2, t->qbits, smooth, wb);
    } else
        for (int f = 0; f < 6; f++)
            for (int l = 0, lo = 0; l < TRANSPORT_LEVELS; lo = l ? 4 * lo : 1, l++) {   /* level l: [lo, max(1, 4 lo)) */
                float s = transport_level_sigma[l];
                for (int j = f * FACE + lo; j < f * FACE + (l ? 4 * lo : 1); j++) {
                    wr[j] = r[j] * s; wg[j] = g[j] * s; wb[j] = b[j] * s;
                }
            }
    return sparse_select(wr, wg, wb, CUBE_TEXELS, t->N, idx, keys);
}

static double sq(double x) { return x * x; }

/* Entry j of the weights sparse_select leaves in its scratch (float bits, read without aliasing). */
static float key_at(const float *keys, int j) {
    float e;
    memcpy(&e, keys + j, sizeof e);
    return e;
}

/* The dropped coarse part coarse[m] (m < 4^b, morton order, zero where kept) into E: its value on each
 * block times w's integral there (block_integrals). */
static void block_coarse(const float *coarse, const double *wsum, int b, double *E) {
    int s = 1 << b, nb = s * s;
    float img[16] = { 0 }, tmp[16];
    for (int m = 0; m < nb; m++) {   /* an s x s image in quadrant layout */
        uint32_t i, j;
        haar_unmorton((uint32_t)m, &i, &j);
        img[j * (uint32_t)s + i] = coarse[m];
    }
    haar_inverse(img, s, tmp);
    for (int B = 0; B < nb; B++) {
        double u = img[B] * (double)s / CUBE_RES;   /* its value on block B (orthonormal at res 64) */
        E[B] += u * wsum[B];
    }
}

/* The integral under w of what was dropped of face x (not kept, finite), per block of level b, into E. */
static void block_dropped(const float *x, const uint8_t *kept, const float *W, const double *wsum, int b, double *E) {
    int s = 1 << b, nb = s * s;
    float coarse[16];
    uint8_t row[16];   /* block (row-major) of each morton position q < 4^b */
    for (uint32_t q = 0, bi, bj; q < (uint32_t)nb; q++) {
        haar_unmorton(q, &bi, &bj);
        row[q] = (uint8_t)(bj * (uint32_t)s + bi);
    }
    for (int B = 0; B < 16; B++) E[B] = 0;
    for (int l = b + 1, lo = 1 << 2 * b; l < TRANSPORT_LEVELS; l++, lo *= 4) {   /* details of level l: [lo, 4 lo) */
        int run = lo >> 2 * b;   /* one block's positions within one of the level's three kinds of detail */
        for (int m0 = lo; m0 < 4 * lo; m0 += run) {
            float acc = 0;   /* at most 64 terms; branch-free for the compiler */
            for (int m = m0; m < m0 + run; m++) {
                float v = x[m] * W[m];
                acc += kept[m] || !isfinite(v) ? 0.f : v;
            }
            E[row[(m0 & (lo - 1)) / run]] += acc;
        }
    }
    for (int m = 0; m < nb; m++) coarse[m] = !kept[m] && isfinite(x[m]) ? x[m] : 0.f;
    block_coarse(coarse, wsum, b, E);
}

/* The piecewise constant E_B / |B|_w in the kept coarse coefficients of the face: adj[4^b]. */
static void block_adjust(const double *E, const uint8_t *kept, const double *wsum, int b, float *adj) {
    int s = 1 << b, nb = s * s;
    float img[16], tmp[16];
    for (int B = 0; B < nb; B++) {
        double d = E[B] / wsum[B];
        img[B] = isfinite(d) ? (float)d : 0.f;
    }
    haar_forward(img, s, tmp);
    for (int m = 0; m < nb; m++) {
        uint32_t i, j;
        haar_unmorton((uint32_t)m, &i, &j);
        adj[m] = kept[m] ? img[j * (uint32_t)s + i] * (float)(CUBE_RES / s) : 0.f;
    }
}

/* Why: the transported light of a uniform environment L is L sum_j T_j = L sum_m c_m W_m, and W (the
 * Haar coefficients of the solid-angle bowl w_j) has details that correlate with those of T/w (both
 * smooth bowls over a face), so dropping the small details removes a same-signed share of the
 * integral: on an unoccluded plane a uniform 1% too little (README "Shadows"). Putting what was
 * dropped back makes the integral exact again at no storage; done per block of the face rather than
 * per face, a shadowed block's loss stays in that block.
 * Per block B of the 2^b x 2^b grid of a face, what was dropped integrates under w to
 * D_B = sum over dropped m of c_m <psi_m, w 1_B>: a detail finer than B lies inside one block and
 * gives c_m W_m there (its block is the top 2b bits of its position within its level's morton
 * range); the coarse ones (m < 4^b, constant on every block) give their value on B times w's
 * integral over B. Adding the piecewise constant D_B / |B|_w, expressed in the coarse coefficients
 * m < 4^b (the Haar transform of the s x s image, times 64/s), makes each block's integral exact
 * where those coefficients are kept; where some are not, what is added is the correction's
 * projection on the kept ones. b = 0 is the face correction. wsum: w summed over each block
 * (row-major s x s); x: one face's coefficients; kept: the face's kept mask; adj: [4^b] to add. */
static void block_integrals(const float *x, const uint8_t *kept, const float *W, const double *wsum, int b, float *adj) {
    double E[16];
    block_dropped(x, kept, W, wsum, b, E);
    block_adjust(E, kept, wsum, b, adj);
}

/* Value of kept coefficient index of channel c before quantization: the input, plus the block
 * correction on a coarse coefficient (adj[(c * 6 + face) * 16 + m], m < 16). */
static float kept_value(const float *x, uint32_t index, const float *adj, int c) {
    if (!isfinite(x[index])) return 0.f;
    uint32_t m = index % FACE;
    return m < 16 ? x[index] + adj[(c * 6 + index / FACE) * 16 + m] : x[index];
}

/* The mask of the n indices idx into kept[CUBE_TEXELS]. */
static void mark(uint8_t *kept, const uint32_t *idx, int n) {
    memset(kept, 0, CUBE_TEXELS);
    for (int k = 0; k < n; k++) kept[idx[k]] = 1;
}

/* ---- smooth faces: the correction weighted by the transport (README "Shadows") ----
 * Why: the block integrals make every block exact under a uniform light, but a sun sees a point of a
 * block mean, and the block mean of a concave lobe falls below its value on the ring a sun at a fixed
 * elevation turns along (Jensen): an unoccluded floor kept a -0.6% bias, with steps where the sun
 * crosses a face edge. Putting the dropped part back weighted by the transport instead, sum over
 * dropped m of c_m H_m (H the Haar coefficients of the texels T_j, Eq. 3) on the face's scaling
 * coefficient, makes the product exact under a light shaped like the transport, where a sun matters
 * most. One scalar per face spreads over the whole face, so it is taken only on faces with no occluder
 * edge (face_smooth): on a shadowed face it lights the dark part where the sun may be (README: the
 * floor's shadow 8.5% when taken on every face). H is that of the channels summed (a grey light of the
 * transport's shape; for a material of one colour the same as per channel). */

/* Face f of the channels' sum of T/w as texels (row-major, haar_forward's layout) into img: true when it
 * is smooth (TRANSPORT_SMOOTH_JUMP) and not negative. tmp: FACE floats. */
static bool face_smooth(const float *const ch[3], int f, float *img, float *tmp) {
    const float *x[3] = { ch[0] + (size_t)f * FACE, ch[1] + (size_t)f * FACE, ch[2] + (size_t)f * FACE };
    bool any = false;
    for (int m = 0; m < FACE; m++) {   /* a non-finite channel (never from precompute) voids the texel's sum */
        float v = x[0][m] + x[1][m] + x[2][m];
        v = isfinite(v) ? v : 0.f;
        tmp[m] = v;
        any |= v != 0;
    }
    if (!any) return false;   /* nothing to correct (a face below the horizon) */
    haar_face_from_morton(tmp, CUBE_RES, img);
    haar_inverse(img, CUBE_RES, tmp);
    float mx = 0, lo = 0, jump = 0;
    for (int j = 0; j < CUBE_RES; j++)
        for (int i = 0; i < CUBE_RES; i++) {
            float v = img[j * CUBE_RES + i];
            float dx = i > 0 ? fabsf(v - img[j * CUBE_RES + i - 1]) : 0.f, dy = j > 0 ? fabsf(v - img[(j - 1) * CUBE_RES + i]) : 0.f;
            mx = v > mx ? v : mx;   /* not fmaxf: a libm call per texel without -ffinite-math-only */
            lo = v < lo ? v : lo;
            jump = dx > jump ? dx : jump;
            jump = dy > jump ? dy : jump;
        }
    return mx > 0 && lo >= -1e-4f * mx && jump <= TRANSPORT_SMOOTH_JUMP * mx;   /* lo: the transform's rounding */
}

/* The Haar coefficients of the texels img_j w_j (T_j from T/w) in morton order into H; img is used up. */
static void face_transport(float *img, const float *w, float *tmp, float *H) {
    for (int k = 0; k < FACE; k++) img[k] *= w[k];
    haar_forward(img, CUBE_RES, tmp);
    haar_face_to_morton(img, CUBE_RES, H);
}

/* Which faces of a vector are smooth (face_smooth; bit f), and with want_H each smooth face's H into
 * Hc + f * FACE (face_transport; w: the solid angle per texel). Neither depends on the selection, so
 * it is done once per vector, before it: the prior's selection (prior_channel) and the smooth faces'
 * correction (smooth_faces) read the same result. scratch: 2 x FACE floats. */
static unsigned face_shapes(const float *const ch[3], const float *w, bool want_H, float *scratch, float *Hc) {
    float *img = scratch, *tmp = scratch + FACE;
    unsigned smooth = 0;
    for (int f = 0; f < 6; f++) {
        if (!face_smooth(ch, f, img, tmp)) continue;
        smooth |= 1u << f;
        if (want_H) face_transport(img, w, tmp, Hc + (size_t)f * FACE);
    }
    return smooth;
}

/* For each smooth face f (bit f of smooth, H at Hc + f * FACE: face_shapes): S[c * 6 + f] = sum over
 * its m outside `in` of c_m H_m, and H0[f] = H_0, the transport's integral over the face over 64
 * (orthonormal); H0[f] = 0 elsewhere. */
static void smooth_faces(const float *const ch[3], const uint8_t *in, unsigned smooth, const float *Hc, float *S,
                         float *H0) {
    for (int f = 0; f < 6; f++) {
        for (int c = 0; c < 3; c++) S[c * 6 + f] = 0;
        H0[f] = 0;
        if (!(smooth >> f & 1)) continue;
        const float *H = Hc + (size_t)f * FACE;
        H0[f] = H[0];
        const uint8_t *out = in + (size_t)f * FACE;
        for (int c = 0; c < 3; c++) {
            const float *x = ch[c] + (size_t)f * FACE;
            double d = 0;
            for (int m0 = 0; m0 < FACE; m0 += 64) {   /* float runs of 64, branch-free for the compiler */
                float acc = 0;
                for (int m = m0; m < m0 + 64; m++) {
                    float v = x[m] * H[m];
                    acc += out[m] || !isfinite(v) ? 0.f : v;
                }
                d += acc;
            }
            S[c * 6 + f] = (float)d;
        }
    }
}

/* The faces whose correction is the smooth one: smooth (H0 != 0) with their scaling coefficient kept
 * (kept0: bit f when face f's is). The others keep the block correction. */
static unsigned smooth_mask(const float *H0, unsigned kept0) {
    unsigned mask = 0;
    for (int f = 0; f < 6; f++) mask |= (unsigned)(H0[f] != 0 && (kept0 >> f & 1)) << f;
    return mask;
}

/* The smooth faces' correction into adj[3][6][16] on the faces of mask (smooth_mask): S / H_0 on the
 * scaling coefficient, nothing on the face's other coarse coefficients. */
static void smooth_adjust(const float *S, const float *H0, unsigned mask, float *adj) {
    for (int f = 0; f < 6; f++) {
        if (!(mask >> f & 1)) continue;
        for (int c = 0; c < 3; c++) {
            float *a = adj + (c * 6 + f) * 16, d = S[c * 6 + f] / H0[f];
            memset(a, 0, 16 * sizeof *a);
            a[0] = isfinite(d) ? d : 0.f;
        }
    }
}

/* With t->solid_angle, the block correction of every channel and face (block_integrals), and with
 * smooth_faces theirs on the smooth faces (smooth_adjust; shape, Hc: face_shapes'), into adj[3][6][16];
 * zeros without. scratch: FACE floats for w, then CUBE_TEXELS bytes for the kept mask. */
static void block_corrections(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n,
                              unsigned shape, const float *Hc, float *scratch, float *adj) {
    memset(adj, 0, 3 * 6 * 16 * sizeof *adj);
    if (!t->solid_angle) return;
    int b = t->block_level;
    PRT_CHECK(b >= 0 && b <= TRANSPORT_BLOCK_LEVEL_MAX);
    uint8_t *kept = (uint8_t *)(void *)(scratch + FACE);
    mark(kept, idx, n);
    float S[18] = { 0 }, H0[6] = { 0 };
    unsigned kept0 = 0, smooth = 0;
    if (t->smooth_faces) {   /* first: the faces it corrects need no block integrals */
        smooth_faces(ch, kept, shape, Hc, S, H0);
        for (int f = 0; f < 6; f++) kept0 |= (unsigned)kept[(size_t)f * FACE] << f;
        smooth = smooth_mask(H0, kept0);
    }
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < 6; f++)
            if (!(smooth >> f & 1))
                block_integrals(ch[c] + (size_t)f * FACE, kept + (size_t)f * FACE, t->tables->W, t->tables->wsum[b], b,
                                adj + (c * 6 + f) * 16);
    smooth_adjust(S, H0, smooth, adj);
}

/* Why (shared budget): which candidates a vector keeps is known only at transport_finish, so its block
 * correction is split: what the coefficients outside its candidates drop is fixed now (blk, per
 * channel, face and block, and the smooth faces' S and H_0 after the norm; finish adds the candidates
 * it drops). shape, Hc and scratch as block_corrections'. */
static void block_stage(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n,
                        unsigned shape, const float *Hc, float *scratch, float *blk) {
    int b = t->block_level;
    PRT_CHECK(b >= 0 && b <= TRANSPORT_BLOCK_LEVEL_MAX);
    uint8_t *kept = (uint8_t *)(void *)(scratch + FACE);
    mark(kept, idx, n);
    double E[16];
    for (int c = 0; c < 3; c++)
        for (int f = 0; f < 6; f++) {
            block_dropped(ch[c] + (size_t)f * FACE, kept + (size_t)f * FACE, t->tables->W, t->tables->wsum[b], b, E);
            for (int B = 0; B < 16; B++) blk[(c * 6 + f) * 16 + B] = (float)E[B];
        }
    float *S = blk + TRANSPORT_BLK + 1, *H0 = S + 18;
    if (t->smooth_faces) smooth_faces(ch, kept, shape, Hc, S, H0);
    else memset(S, 0, 24 * sizeof *S);
}

/* qsort order of 64-bit words, largest first. */
static int by_weight(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x < y) - (x > y);   /* descending */
}

/* Why: a water-filling on absolute weights starves the darkest vertices (a floor vertex under the model
 * kept nothing: black). Each vector's budget_min best candidates get the largest finite weight, so the
 * threshold keeps them whatever the others hold (budget_min <= budget keeps the total within it).
 * They are the best of all its coefficients, since the candidates are (sparse_select's order: larger
 * weight first, ties to the lower index, zeros never), so they are picked among the n staged ones.
 * order: scratch of n 64-bit words. */
static void keep_minimum(prt_transport *t, int i, int n, uint64_t *order) {
    size_t o = (size_t)i * t->N;
    int m = 0;
    for (int k = 0; k < n; k++) {   /* weight bits high, then the complement of k: ties to the lower index */
        uint32_t u = bits_of(t->stage_key[o + k]);
        if (u) order[m++] = (uint64_t)u << 32 | (UINT32_MAX - (uint32_t)k);
    }
    if (m > t->budget_min) qsort(order, (size_t)m, sizeof *order, by_weight);
    for (int q = 0; q < m && q < t->budget_min; q++) t->stage_key[o + (UINT32_MAX - (uint32_t)order[q])] = FLT_MAX;
}

/* transport_store's scratch (transport_scratch_size): the selection's keys (2 x CUBE_TEXELS floats) and
 * idx (CUBE_TEXELS), W (2 x FACE floats), wc (3 x CUBE_TEXELS: the weights, then the corrections'
 * scratch) and Hc (CUBE_TEXELS: face_shapes' H). */
typedef struct store_scratch {
    float *keys, *W, *wc, *Hc;
    uint32_t *idx;
    void *refit;            /* refit_scratch_size(REFIT_MAX_N) bytes */
} store_scratch;

static store_scratch scratch_of(void *scratch) {
    store_scratch sc = { .keys = scratch };
    sc.idx = (uint32_t *)(void *)((char *)scratch + 2 * CUBE_TEXELS * sizeof(float));
    sc.W = (float *)(void *)(sc.idx + CUBE_TEXELS);
    sc.wc = sc.W + 2 * FACE;
    sc.Hc = sc.wc + 3 * CUBE_TEXELS;
    sc.refit = sc.Hc + CUBE_TEXELS;
    return sc;
}

/* Whether transport_store refits the kept values (refit.h) rather than correcting them: the refit's
 * tables with the solid-angle measure and a per-vector budget. */
static bool refits(const prt_transport *t) { return t->refit && t->solid_angle && !t->budget; }

/* The faces' shapes into *shape and sc->Hc (face_shapes, when the prior's selection or the smooth
 * correction reads them), then the selection of vector ch into sc->idx and sc->keys. Returns how many
 * candidates. */
static int select_vector(const prt_transport *t, const float *const ch[3], const store_scratch *sc, unsigned *shape) {
    bool want_H = t->solid_angle && t->smooth_faces && !refits(t);   /* a refit face needs no correction */
    *shape = t->prior || want_H ? face_shapes(ch, t->tables->w, want_H, sc->W, sc->Hc) : 0;
    return t->select == TRANSPORT_SELECT_EXPECTED ? select_expected(ch[0], ch[1], ch[2], t, *shape, sc->idx, sc->keys, sc->wc)
                                                  : sparse_select(ch[0], ch[1], ch[2], CUBE_TEXELS, t->N, sc->idx, sc->keys);
}

/* Shared budget: stages vector i's t->N best candidates (by the selection weight, unquantized) with
 * their weights (RELATIVE: over the vector's total) for transport_finish. Returns the squared norm of
 * the coefficients outside them. */
static double store_candidates(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch) {
    const float *ch[3] = { r, g, b };
    store_scratch sc = scratch_of(scratch);
    float *keys = sc.keys;
    uint32_t *idx = sc.idx;
    unsigned shape;
    int n = select_vector(t, ch, &sc, &shape);
    double total = 0, err = 0;   /* keys[0 .. CUBE_TEXELS) hold the weights' float bits (sparse.h) */
    if (t->budget_kind == TRANSPORT_BUDGET_RELATIVE)
        for (int j = 0; j < CUBE_TEXELS; j++) total += key_at(keys, j);
    size_t o = (size_t)i * t->N;
    for (int k = 0; k < n; k++) {
        double e = key_at(keys, (int)idx[k]);
        t->stage_key[o + k] = total > 0 ? (float)(e / total) : (float)e;
        t->stage_idx[o + k] = idx[k];
        for (int c = 0; c < 3; c++) t->stage_val[3 * (o + k) + c] = isfinite(ch[c][idx[k]]) ? ch[c][idx[k]] : 0.f;
    }
    if (t->budget_min > 0 && n > 0) keep_minimum(t, i, n, (uint64_t *)(void *)keys);   /* keys are read: free */
    t->stage_count[i] = (uint32_t)n;
    double norm = 0;   /* one pass: the whole vector's squared norm, and the part outside the candidates */
    for (int j = 0, k = 0; j < CUBE_TEXELS; j++) {
        double e = sq(r[j]) + sq(g[j]) + sq(b[j]);
        bool cand = k < n && idx[k] == (uint32_t)j;
        k += cand;
        if (!isfinite(e)) continue;
        norm += e;
        if (!cand) err += e;
    }
    t->stage_blk[(size_t)i * TRANSPORT_STAGE + TRANSPORT_BLK] = (float)norm;
    if (t->solid_angle) block_stage(t, ch, idx, n, shape, sc.Hc, sc.wc, t->stage_blk + (size_t)i * TRANSPORT_STAGE);
    return err;
}

/* Each face's kept values val[3 k + c] (the n kept idx, increasing) refit to the prior's light (refit.h), face
 * by face; a face refit_face declines keeps what it had. */
static unsigned refit_vector(const refit_tables *rt, const float *const ch[3], const uint32_t *idx, int n, float *val,
                             void *scratch) {
    float out[3 * REFIT_MAX_N];
    unsigned done = 0;
    for (int k0 = 0, k1; k0 < n; k0 = k1) {
        uint32_t f = idx[k0] / FACE;
        for (k1 = k0; k1 < n && idx[k1] / FACE == f; k1++) {}
        if (!refit_face(rt, (int)f, ch[0], ch[1], ch[2], idx + k0, k1 - k0, out, scratch)) continue;
        memcpy(val + 3 * (size_t)k0, out, 3 * (size_t)(k1 - k0) * sizeof *out);
        done |= 1u << f;
    }
    return done;
}

/* The faces of the n kept indices idx (bit f: face f holds one). */
static unsigned kept_faces(const uint32_t *idx, int n) {
    unsigned faces = 0;
    for (int k = 0; k < n; k++) faces |= 1u << (idx[k] / FACE);
    return faces;
}

/* The kept values val[3 k + c] of the faces not in `refit` (refit_vector's): the input plus the block or
 * smooth-face correction (block_corrections), unquantized. With a refit select_vector left the smooth
 * faces' transport out (no refit face needs it), so it is made here for the faces the refit declined. */
static void corrected_values(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, unsigned shape,
                             unsigned refit, const store_scratch *sc, float *val) {
    if (refits(t) && t->smooth_faces) shape = face_shapes(ch, t->tables->w, true, sc->W, sc->Hc);
    float adj[3 * 6 * 16];
    block_corrections(t, ch, idx, n, shape, sc->Hc, sc->wc, adj);   /* wc is free once selected */
    for (int k = 0; k < n; k++)
        if (!(refit >> (idx[k] / FACE) & 1))
            for (int c = 0; c < 3; c++) val[3 * k + c] = kept_value(ch[c], idx[k], adj, c);
}

/* The kept values val[3 k + c] quantized in place to multiples of step[c] (qmax > 0): the faces of `refit`
 * by refit_quantize, the others to the nearest. */
static void quantize_vector(const refit_tables *rt, unsigned refit, const uint32_t *idx, int n, const float step[3],
                            int qmax, float *val, void *scratch) {
    for (int k0 = 0, k1; k0 < n; k0 = k1) {
        uint32_t f = idx[k0] / FACE;
        for (k1 = k0; k1 < n && idx[k1] / FACE == f; k1++) {}
        if (refit >> f & 1) {
            refit_quantize(rt, (int)f, idx + k0, k1 - k0, step, qmax, val + 3 * (size_t)k0, scratch);
            continue;
        }
        for (int k = k0; k < k1; k++)
            for (int c = 0; c < 3; c++) val[3 * k + c] = (float)sparse_quantize(val[3 * k + c], step[c], qmax) * step[c];
    }
}

/* Selects, quantizes and stages vector i; returns the squared L2 error of what is kept. */
double transport_store(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch) {
    PRT_CHECK(t->stage_count && i >= 0 && i < t->nvecs);
    if (t->budget) return store_candidates(t, i, r, g, b, scratch);
    const float *ch[3] = { r, g, b };
    store_scratch sc = scratch_of(scratch);
    uint32_t *idx = sc.idx;
    unsigned shape;
    int n = select_vector(t, ch, &sc, &shape);
    float *val = t->stage_val + (size_t)i * t->N * 3;
    uint32_t *sidx = t->stage_idx + (size_t)i * t->N;
    unsigned refit = refits(t) ? refit_vector(t->refit, ch, idx, n, val, sc.refit) : 0;   /* unquantized values */
    if (kept_faces(idx, n) & ~refit) corrected_values(t, ch, idx, n, shape, refit, &sc, val);
    int qmax = qmax_of(t->qbits);
    float step[3] = { 1.f, 1.f, 1.f };
    for (int c = 0; c < 3 && qmax; c++) {
        float m = 0;
        for (int k = 0; k < n; k++) {
            float a = fabsf(val[3 * k + c]);
            if (a > m && isfinite(a)) m = a;
        }
        step[c] = sparse_step(m, qmax);
    }
    for (int c = 0; c < 3; c++) t->scale[3 * i + c] = step[c];
    if (qmax) quantize_vector(t->refit, refit, idx, n, step, qmax, val, sc.refit);
    else
        for (int k = 0; k < 3 * n; k++) val[k] = isfinite(val[k]) ? val[k] : 0.f;
    memcpy(sidx, idx, sizeof(uint32_t) * (size_t)n);
    t->stage_count[i] = (uint32_t)n;
    /* Error: dropped coefficients' energy plus the kept ones' quantization error
     * (summed directly, not as total - kept, to avoid cancellation). Non-finite
     * inputs count as zero, as sparse_select treats them. */
    double err = 0;
    int k = 0;
    for (int j = 0; j < CUBE_TEXELS; j++) {
        double e;
        if (k < n && idx[k] == (uint32_t)j) {
            e = sq((double)r[j] - val[3 * k]) + sq((double)g[j] - val[3 * k + 1]) + sq((double)b[j] - val[3 * k + 2]);
            k++;
        } else {
            e = sq(r[j]) + sq(g[j]) + sq(b[j]);
        }
        if (isfinite(e)) err += e;
    }
    return err;
}

/* ---- a shared budget's choice (transport_finish) ---- */


/* Why: the best B candidates of all vectors (largest weights: the least expected error, summed) are those
 * above one threshold, so a radix select over the weights' float bits (non-negative floats order like
 * their bits) finds it in two passes: the top 16 bits, then the low 16 within that bin. Sets *T to the
 * B-th largest weight's bits and *need_eq to how many equal to it are kept (ties go to the lower vector,
 * then the lower index: deterministic). */
static void budget_threshold(const prt_transport *t, uint64_t B, uint64_t *hist, uint32_t *T, uint64_t *need_eq) {
    uint64_t above = 0;   /* hist: 65536 counts of scratch */
    uint32_t hi = 0, lo = 0;
    for (int pass = 0; pass < 2; pass++) {
        memset(hist, 0, 65536 * sizeof *hist);
        for (int i0 = 0; i0 < t->nvecs; i0 += 4096) {   /* streamed: a chunk at a time in memory */
            int i1 = t->nvecs - i0 < 4096 ? t->nvecs : i0 + 4096;
            for (int i = i0; i < i1; i++)
                for (uint32_t k = 0; k < t->stage_count[i]; k++) {
                    uint32_t u = bits_of(t->stage_key[(size_t)i * t->N + k]);
                    if (pass == 0) hist[u >> 16]++;
                    else if ((u >> 16) == hi) hist[u & 65535u]++;
                }
            transport_release(t, i0, i1);
        }
        uint32_t bin = 65535;
        while (above + hist[bin] < B) above += hist[bin--];
        if (pass == 0) hi = bin; else lo = bin;
    }
    *T = hi << 16 | lo;
    *need_eq = B - above;
}

typedef struct budget_ctx {
    prt_transport *t;
    uint32_t T;           /* weights above T are kept */
    const uint32_t *take; /* [nvecs] how many of vector i's weights equal to T are kept */
    double *err;          /* [nvecs] squared error the choice adds (dropped candidates, quantization) */
} budget_ctx;

/* Why: a smooth face's dropped candidates are weighted by H (smooth_faces), which is not staged; the
 * candidates (a smooth face's 2N largest, by construction its shape) give it: the Haar coefficients of
 * w times their reconstruction, over vector i's candidates [k, n) of face f, into H (morton order).
 * scratch: 2 x FACE floats. */
static void candidates_transport(const budget_ctx *c, size_t o, uint32_t k, uint32_t n, uint32_t f, float *scratch, float *H) {
    const uint32_t *idx = c->t->stage_idx + o;
    const float *val = c->t->stage_val + 3 * o;
    float *img = scratch, *tmp = scratch + FACE;
    memset(H, 0, FACE * sizeof *H);
    for (; k < n && idx[k] / FACE == f; k++) H[idx[k] % FACE] = val[3 * k] + val[3 * k + 1] + val[3 * k + 2];
    haar_face_from_morton(H, CUBE_RES, img);
    haar_inverse(img, CUBE_RES, tmp);
    face_transport(img, c->t->tables->w, tmp, H);
}

/* The block of level b that detail m (>= 4^b within its face) lies in (block_integrals' rule). */
static int block_of(uint32_t m, int b) {
    int l = transport_level(m);
    uint32_t lo = 1u << 2 * (l - 1), sh = (uint32_t)(2 * (l - 1 - b)), bi, bj;
    haar_unmorton((m & (lo - 1)) >> sh, &bi, &bj);
    return (int)(bj * (1u << b) + bi);
}

/* Keeps vector i's chosen candidates in place (index order), with the block correction of what it
 * drops (its staged non-candidates' part plus the dropped candidates'); adj[3][6][16] gets it. */
static uint32_t budget_keep(const budget_ctx *c, int i, float *adj) {
    prt_transport *t = c->t;
    size_t o = (size_t)i * t->N;
    uint32_t *idx = t->stage_idx + o, n = 0, take = c->take[i];
    float *val = t->stage_val + 3 * o, coarse[TRANSPORT_BLK] = { 0 };
    int b = t->block_level, nb = 1 << 2 * b;
    double E[TRANSPORT_BLK];
    uint8_t kept[6 * 16] = { 0 };
    const float *blk = t->stage_blk + (size_t)i * TRANSPORT_STAGE, *H0 = blk + TRANSPORT_BLK + 1 + 18;
    float S[18], H[FACE], scr[2 * FACE];
    for (int k = 0; k < TRANSPORT_BLK; k++) E[k] = t->solid_angle ? blk[k] : 0;
    memcpy(S, blk + TRANSPORT_BLK + 1, sizeof S);
    for (uint32_t k = 0, face = 6; k < t->stage_count[i]; k++) {
        uint32_t u = bits_of(t->stage_key[o + k]), m = idx[k] % FACE, f = idx[k] / FACE;
        if (f != face && t->solid_angle && H0[f] != 0) candidates_transport(c, o, k, t->stage_count[i], f, scr, H);   /* before compacting */
        face = f;
        bool keep = u > c->T || (u == c->T && take > 0);
        take -= keep && u == c->T;
        if (keep) {
            if (m < 16) kept[f * 16 + m] = 1;
            idx[n] = idx[k];
            memmove(val + 3 * n, val + 3 * k, 3 * sizeof *val);
            n++;
        } else {
            for (int ch = 0; ch < 3; ch++) c->err[i] += sq(val[3 * k + ch]);
            for (int ch = 0; ch < 3 && t->solid_angle; ch++) {
                if (m < (uint32_t)nb) coarse[(ch * 6 + f) * 16 + m] = val[3 * k + ch];
                else E[(ch * 6 + f) * 16 + block_of(m, b)] += (double)val[3 * k + ch] * t->tables->W[m];
                if (H0[f] != 0) S[ch * 6 + f] += val[3 * k + ch] * H[m];
            }
        }
    }
    memset(adj, 0, TRANSPORT_BLK * sizeof *adj);
    if (!t->solid_angle) return n;
    unsigned kept0 = 0;
    for (int f = 0; f < 6; f++) kept0 |= (unsigned)kept[f * 16] << f;
    unsigned smooth = smooth_mask(H0, kept0);   /* H0 all 0 without smooth_faces */
    for (int q = 0; q < 18; q++) {   /* q = channel * 6 + face */
        if (smooth >> (q % 6) & 1) continue;
        block_coarse(coarse + q * 16, t->tables->wsum[b], b, E + q * 16);
        block_adjust(E + q * 16, kept + (q % 6) * 16, t->tables->wsum[b], b, adj + q * 16);
    }
    smooth_adjust(S, H0, smooth, adj);
    return n;
}

/* prt_parallel_for body: each vector's choice, corrected and quantized in its staging (as transport_store
 * leaves a vector under the per-vector budget). */
static void budget_vectors(void *p, int begin, int end, int thread) {
    const budget_ctx *c = p;
    prt_transport *t = c->t;
    int qmax = qmax_of(t->qbits);
    for (int i = begin; i < end; i++) {
        float adj[TRANSPORT_BLK];
        uint32_t n = budget_keep(c, i, adj), *idx = t->stage_idx + (size_t)i * t->N;
        float *val = t->stage_val + 3 * (size_t)i * t->N;
        for (int ch = 0; ch < 3; ch++) {
            float mx = 0, step = 1.f;
            for (uint32_t k = 0; k < n && qmax; k++) {
                uint32_t m = idx[k] % FACE;
                float x = fabsf(val[3 * k + ch] + (m < 16 ? adj[(ch * 6 + idx[k] / FACE) * 16 + m] : 0.f));
                if (x > mx && isfinite(x)) mx = x;
            }
            if (qmax) step = t->scale[3 * i + ch] = sparse_step(mx, qmax);
            for (uint32_t k = 0; k < n; k++) {
                uint32_t m = idx[k] % FACE;
                float raw = val[3 * k + ch], x = raw + (m < 16 ? adj[(ch * 6 + idx[k] / FACE) * 16 + m] : 0.f);
                val[3 * k + ch] = qmax ? (float)sparse_quantize(x, step, qmax) * step : x;
                c->err[i] += sq((double)raw - val[3 * k + ch]);
            }
        }
        float norm = t->stage_blk[(size_t)i * TRANSPORT_STAGE + TRANSPORT_BLK];
        c->err[i] = norm > 0 ? c->err[i] / norm : 0;
        t->stage_count[i] = n;
    }
    transport_release(t, begin, end);
}

/* The shared budget's choice: at most budget x nvecs candidates in all, the largest weights. */
static int budget_finish(prt_transport *t, prt_error *err) {
    uint64_t B = (uint64_t)t->budget * (uint64_t)t->nvecs, S = 0, need_eq = UINT64_MAX;
    for (int i = 0; i < t->nvecs; i++) S += t->stage_count[i];
    budget_ctx *c = prt_calloc(1, sizeof *c, err);
    uint32_t *take = c ? prt_calloc((size_t)t->nvecs + 1, sizeof *take, err) : NULL;
    double *verr = take ? prt_calloc((size_t)t->nvecs + 1, sizeof *verr, err) : NULL;
    uint64_t *hist = verr && S > B ? prt_calloc(65536, sizeof *hist, err) : NULL;
    if (!verr || (S > B && !hist)) {
        free(verr); free(take); free(c);
        return prt_fail(err, "transport: out of memory choosing a shared budget");
    }
    c->t = t;
    c->take = take;
    c->err = verr;
    if (S > B) budget_threshold(t, B, hist, &c->T, &need_eq);
    free(hist);
    for (int i = 0; i < t->nvecs; i++) {   /* ties to the lower vector, in order */
        uint32_t eq = 0;
        for (uint32_t k = 0; k < t->stage_count[i] && need_eq; k++) eq += bits_of(t->stage_key[(size_t)i * t->N + k]) == c->T;
        take[i] = eq < need_eq ? eq : (uint32_t)need_eq;
        need_eq -= take[i];
    }
    PRT_CHECK(t->block_level >= 0 && t->block_level <= TRANSPORT_BLOCK_LEVEL_MAX);
    prt_parallel_for(t->nvecs, 4096, 0, budget_vectors, c);
    t->chosen_err = 0;
    for (int i = 0; i < t->nvecs; i++) t->chosen_err += c->err[i];   /* in order: the same sum on any threads */
    free(c->err);
    free(take);
    free(c);
    if (!t->stage_mapped) { free(t->stage_key); free(t->stage_blk); }   /* mapped: unmapped with the rest */
    t->stage_key = NULL;   /* chosen: a retried finish (after OOM) packs what is staged */
    t->stage_blk = NULL;
    return 0;
}

typedef struct finish_ctx { prt_transport *t; } finish_ctx;

/* Pass 1: number of runs (distinct blocks) of each vector into run_first[i+1]. */
static void count_runs(void *p, int begin, int end, int thread) {
    prt_transport *t = ((finish_ctx *)p)->t;
    for (int i = begin; i < end; i++) {
        const uint32_t *idx = t->stage_idx + (size_t)i * t->N;
        uint32_t n = t->stage_count[i], runs = 0, last = UINT32_MAX;
        for (uint32_t k = 0; k < n; k++) {
            uint32_t blk = idx[k] / SPARSE_BLOCK;
            if (blk != last) { runs++; last = blk; }
        }
        t->run_first[i + 1] = runs;
    }
    transport_release(t, begin, end);
}

/* Pass 2: runs and coefficient words of each vector at its final place. */
static void pack_vectors(void *p, int begin, int end, int thread) {
    prt_transport *t = ((finish_ctx *)p)->t;
    int qmax = qmax_of(t->qbits);
    for (int i = begin; i < end; i++) {
        const uint32_t *idx = t->stage_idx + (size_t)i * t->N;
        const float *val = t->stage_val + (size_t)i * t->N * 3;
        const float *sc = t->scale + 3 * (size_t)i;
        uint32_t n = t->stage_count[i], c0 = t->coef_first[i];
        uint8_t *runs = t->runs + 2 * (size_t)t->run_first[i];
        int nr = -1;
        uint32_t last = UINT32_MAX;
        for (uint32_t k = 0; k < n; k++) {
            uint32_t blk = idx[k] / SPARSE_BLOCK, off = idx[k] % SPARSE_BLOCK;
            if (blk != last) {
                nr++;
                runs[2 * nr] = (uint8_t)blk;
                runs[2 * nr + 1] = 0;
                last = blk;
            } else {
                runs[2 * nr + 1]++;
            }
            size_t c = c0 + k;
            if (t->qbits == 8) {
                /* staged values are exactly q * step, so dividing by step recovers q */
                t->packed[c] = sparse_pack8(off, sparse_quantize(val[3 * k], sc[0], qmax),
                                            sparse_quantize(val[3 * k + 1], sc[1], qmax), sparse_quantize(val[3 * k + 2], sc[2], qmax));
            } else if (t->qbits == 16) {
                t->offs[c] = (uint8_t)off;
                for (int ch = 0; ch < 3; ch++) t->q16[3 * c + ch] = (int16_t)sparse_quantize(val[3 * k + ch], sc[ch], qmax);
            } else {
                t->offs[c] = (uint8_t)off;
                memcpy(t->f32 + 3 * c, val + 3 * k, 3 * sizeof(float));
            }
        }
        PRT_CHECK_EQ(nr + 1, (int)(t->run_first[i + 1] - t->run_first[i]));
    }
    transport_release(t, begin, end);
}

/* Compacts the staged vectors; frees staging. Returns 0, or -1 with err set (OOM, overflow). */
int transport_finish(prt_transport *t, prt_error *err) {
    if (!t->stage_count) return 0;
    if (t->stage_key && budget_finish(t, err)) return -1;
    size_t nv = (size_t)t->nvecs;
    t->coef_first = prt_calloc(nv + 1, sizeof *t->coef_first, err);
    t->run_first = prt_calloc(nv + 1, sizeof *t->run_first, err);
    if (!t->coef_first || !t->run_first) goto oom;
    uint64_t total = 0;
    for (size_t i = 0; i < nv; i++) {
        total += t->stage_count[i];
        if (total > UINT32_MAX) {
            free(t->coef_first); free(t->run_first);
            t->coef_first = t->run_first = NULL;
            return prt_fail(err, "transport: more than 2^32 coefficients");
        }
        t->coef_first[i + 1] = (uint32_t)total;
    }
    finish_ctx ctx = { t };
    prt_parallel_for(t->nvecs, 4096, 0, count_runs, &ctx);
    for (size_t i = 0; i < nv; i++) t->run_first[i + 1] += t->run_first[i];
    size_t nc = total, nr = t->run_first[nv];
    t->runs = prt_calloc(2 * nr, 1, err);
    if (!t->runs) goto oom;
    if (t->qbits == 8) t->packed = prt_calloc(nc, sizeof *t->packed, err);
    else t->offs = prt_calloc(nc, 1, err);
    if (t->qbits == 16) t->q16 = prt_calloc(3 * nc, sizeof *t->q16, err);
    if (t->qbits == 32) t->f32 = prt_calloc(3 * nc, sizeof *t->f32, err);
    if (t->qbits == 8 ? !t->packed : (!t->offs || (t->qbits == 16 ? !t->q16 : !t->f32))) goto oom;
    prt_parallel_for(t->nvecs, 4096, 0, pack_vectors, &ctx);
    free_staging(t);
    return 0;
oom:
    /* leave the staged data intact so the caller may retry or free */
    free(t->coef_first); free(t->run_first); free(t->runs); free(t->packed); free(t->offs); free(t->q16); free(t->f32);
    t->coef_first = t->run_first = NULL; t->runs = NULL; t->packed = NULL; t->offs = NULL; t->q16 = NULL; t->f32 = NULL;
    return prt_fail(err, "transport: out of memory compacting %d vectors", t->nvecs);
}

/* Calls fn for every stored coefficient of vector i (after finish), in index order. */
void transport_foreach(const prt_transport *t, int i, void (*fn)(void *ctx, uint32_t index, float r, float g, float b), void *ctx) {
    PRT_CHECK(t->coef_first && i >= 0 && i < t->nvecs);
    const float *sc = t->scale + 3 * (size_t)i;
    size_t c = t->coef_first[i];
    for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
        uint32_t base = (uint32_t)t->runs[2 * r] * SPARSE_BLOCK, cnt = (uint32_t)t->runs[2 * r + 1] + 1;
        for (uint32_t k = 0; k < cnt; k++, c++) {
            if (t->qbits == 8) {
                uint32_t off;
                int qr, qg, qb;
                sparse_unpack8(t->packed[c], &off, &qr, &qg, &qb);
                fn(ctx, base + off, (float)qr * sc[0], (float)qg * sc[1], (float)qb * sc[2]);
            } else if (t->qbits == 16) {
                fn(ctx, base + t->offs[c], t->q16[3 * c] * sc[0], t->q16[3 * c + 1] * sc[1], t->q16[3 * c + 2] * sc[2]);
            } else {
                fn(ctx, base + t->offs[c], t->f32[3 * c], t->f32[3 * c + 1], t->f32[3 * c + 2]);
            }
        }
    }
}

typedef struct decode_ctx { float *r, *g, *b; } decode_ctx;
/* transport_foreach callback: scatters one coefficient into the dense planar arrays. */
static void decode_one(void *p, uint32_t index, float r, float g, float b) {
    decode_ctx *d = p;
    d->r[index] = r; d->g[index] = g; d->b[index] = b;
}

/* Dense planar r,g,b[CUBE_TEXELS] of vector i (zeros where nothing is stored). */
void transport_decode(const prt_transport *t, int i, float *r, float *g, float *b) {
    memset(r, 0, sizeof(float) * CUBE_TEXELS);
    memset(g, 0, sizeof(float) * CUBE_TEXELS);
    memset(b, 0, sizeof(float) * CUBE_TEXELS);
    decode_ctx d = { r, g, b };
    transport_foreach(t, i, decode_one, &d);
}

/* Coefficients stored in all (staged ones before finish). */
size_t transport_ncoefs(const prt_transport *t) {
    if (t->coef_first) return t->coef_first[t->nvecs];
    size_t n = 0;
    if (t->stage_count)
        for (int i = 0; i < t->nvecs; i++) n += t->stage_count[i];
    return n;
}

/* Runs stored in all (0 before finish). */
size_t transport_nruns(const prt_transport *t) { return t->run_first ? t->run_first[t->nvecs] : 0; }

/* Coefficient payload: words (4 B for 8-bit; offset + 6 or 12 B otherwise), 2 B per run,
 * 12 B of scales per vector. */
size_t transport_bytes(const prt_transport *t) {
    size_t nc = transport_ncoefs(t), per = t->qbits == 8 ? 4 : t->qbits == 16 ? 7 : 13;
    return nc * per + 2 * transport_nruns(t) + 12 * (size_t)t->nvecs;
}

static inline float finite_or_zero(float x) { return isfinite(x) ? x : 0.f; }

#ifdef __SSE4_1__
/* acc += L[base + offset] * (r, g, b, junk) for the 8-bit word at wp. The three int8
 * values are sign-extended straight from memory starting at the word's byte 1, so
 * lane 3 holds the next word's offset byte: it multiplies L's padding lane, which is
 * never read. That read touches one byte past the word, so the very last word of the
 * array goes through mac8_safe, which shifts the word in a register instead. */
static inline __m128 mac8(__m128 acc, const float (*base)[4], const uint32_t *wp) {
    int32_t rgbx;
    memcpy(&rgbx, (const char *)wp + 1, sizeof rgbx);
    __m128 q = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128(rgbx)));
    return _mm_add_ps(acc, _mm_mul_ps(_mm_loadu_ps(base[*wp & 255u]), q));
}
/* mac8 without reading past the word. */
static inline __m128 mac8_safe(__m128 acc, const float (*base)[4], const uint32_t *wp) {
    __m128 q = _mm_cvtepi32_ps(_mm_cvtepi8_epi32(_mm_cvtsi32_si128((int)(*wp >> 8))));
    return _mm_add_ps(acc, _mm_mul_ps(_mm_loadu_ps(base[*wp & 255u]), q));
}
#endif

/* Eq. 5's g = T x L for vectors [first, last): 8-bit words, SSE4.1 when available.
 * Runs give the block base; two accumulators hide the add latency; the scale is
 * applied once per vector. */
static void light_range8(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    const uint32_t *packed = t->packed;
    const uint8_t *runs = t->runs;
    const uint32_t *array_end = packed + t->coef_first[t->nvecs];
    for (int i = first; i < last; i++) {
        const uint32_t *w = packed + t->coef_first[i];
        uint32_t r0 = t->run_first[i], r1 = t->run_first[i + 1];
#ifdef __SSE4_1__
        __m128 a0 = _mm_setzero_ps(), a1 = _mm_setzero_ps();
        if (packed + t->coef_first[i + 1] < array_end) {
            for (uint32_t r = r0; r < r1; r++) {
                const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
                const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
                for (; w + 1 < end; w += 2) {
                    a0 = mac8(a0, base, w);
                    a1 = mac8(a1, base, w + 1);
                }
                if (w < end) a0 = mac8(a0, base, w++);
            }
        } else {   /* the vector that ends the array */
            for (uint32_t r = r0; r < r1; r++) {
                const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
                const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
                for (; w < end; w++) a0 = mac8_safe(a0, base, w);
            }
        }
        float acc[4];
        _mm_storeu_ps(acc, _mm_add_ps(a0, a1));
#else
        float acc[4] = { 0, 0, 0, 0 };
        (void)array_end;
        for (uint32_t r = r0; r < r1; r++) {
            const float (*base)[4] = L + (size_t)runs[2 * r] * SPARSE_BLOCK;
            const uint32_t *end = w + (uint32_t)runs[2 * r + 1] + 1;
            for (; w < end; w++) {
                const float *l = base[*w & 255u];
                acc[0] += (float)(int8_t)(*w >> 8) * l[0];
                acc[1] += (float)(int8_t)(*w >> 16) * l[1];
                acc[2] += (float)(int8_t)(*w >> 24) * l[2];
            }
        }
#endif
        const float *sc = t->scale + 3 * (size_t)i;
        for (int c = 0; c < 3; c++) g[3 * (size_t)i + c] = finite_or_zero(acc[c] * sc[c]);
    }
}

/* 16-bit and float data: plain scalar loops (not the default format). */
static void light_range_wide(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    for (int i = first; i < last; i++) {
        size_t c = t->coef_first[i];
        float acc[3] = { 0, 0, 0 };
        for (uint32_t r = t->run_first[i]; r < t->run_first[i + 1]; r++) {
            const float (*base)[4] = L + (size_t)t->runs[2 * r] * SPARSE_BLOCK;
            size_t end = c + (uint32_t)t->runs[2 * r + 1] + 1;
            for (; c < end; c++) {
                const float *l = base[t->offs[c]];
                if (t->qbits == 16)
                    for (int ch = 0; ch < 3; ch++) acc[ch] += (float)t->q16[3 * c + ch] * l[ch];
                else
                    for (int ch = 0; ch < 3; ch++) acc[ch] += t->f32[3 * c + ch] * l[ch];
            }
        }
        const float *sc = t->scale + 3 * (size_t)i;
        for (int ch = 0; ch < 3; ch++) g[3 * (size_t)i + ch] = finite_or_zero(acc[ch] * sc[ch]);
    }
}

/* g[3i + ch] for vectors [first, last) (after finish). */
void transport_light_range(const prt_transport *t, const float (*L)[4], float *g, int first, int last) {
    PRT_CHECK(t->coef_first && first >= 0 && last <= t->nvecs);
    if (t->qbits == 8) light_range8(t, L, g, first, last);
    else light_range_wide(t, L, g, first, last);
}

typedef struct light_ctx { const prt_transport *t; const float (*L)[4]; float *g; transport_light_fn kernel; } light_ctx;
/* prt_parallel_for body: one chunk of vectors. */
static void light_chunk(void *p, int begin, int end, int thread) {
    light_ctx *c = p;
    c->kernel(c->t, c->L, c->g, begin, end);
}

/* g for every vector with kernel on nthreads threads (0: all cores); chunks of 2048 vectors keep
 * both cores busy without contention. */
void transport_light_with(const prt_transport *t, const float (*L)[4], float *g, int nthreads, transport_light_fn kernel) {
    light_ctx c = { t, L, g, kernel };
    prt_parallel_for(t->nvecs, 2048, nthreads, light_chunk, &c);
}

/* g for every vector with this module's kernel. */
void transport_light(const prt_transport *t, const float (*L)[4], float *g, int nthreads) {
    transport_light_with(t, L, g, nthreads, transport_light_range);
}

/* Frees every array; leaves a zeroed set. */
void transport_free(prt_transport *t) {
    free(t->vec_first); free(t->coef_first); free(t->run_first); free(t->scale);
    void *heap[5] = { t->runs, t->packed, t->offs, t->q16, t->f32 };
    for (int k = 0; k < 5; k++)   /* a mapped set's empty arrays stayed on the heap */
        if ((uintptr_t)heap[k] - (uintptr_t)t->data_map >= t->data_mapped) free(heap[k]);
    if (t->data_map) munmap(t->data_map, t->data_mapped);
    free_staging(t);
    memset(t, 0, sizeof *t);
}
