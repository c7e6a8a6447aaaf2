/* transport.h - the set of compressed transport vectors of a scene (Wang et al. 2006,
 * section 4.1: the N largest coefficients of each vector, quantized and packed).
 *
 * Vertex v has vec_first[v+1] - vec_first[v] vectors: one per BRDF term k of its
 * material (K of that material), vector vec_first[v] + k. Vector i holds
 * coef_first[i+1] - coef_first[i] coefficients (at most N; fewer when the
 * vector has fewer non-zeros, e.g. 0 for a fully occluded vertex), sorted by
 * coefficient index. Their indices are stored as runs over the 96 blocks of 256
 * (section 4.1.2, with the block bytes run-length coded because sorted indices
 * share blocks): vector i's runs are runs[2*r], runs[2*r+1] for r in
 * run_first[i] .. run_first[i+1]-1, each (block, count-1), covering its
 * coefficients in order. Coefficient values depend on qbits:
 *   8:  packed[c] = offset | r<<8 | g<<16 | b<<24 (sparse.h), value = q * scale[3*i+ch]
 *   16: offs[c] and q16[3c+ch], value = q * scale[3*i+ch]
 *   32: offs[c] and f32[3c+ch] (no quantization; scale unused, 1)
 *
 * Building: transport_init sizes the set for nverts vertices with the given
 * vectors per vertex and N; transport_store (thread-safe for distinct vectors)
 * selects, quantizes and stores one dense vector; transport_finish compacts the
 * storage. After finish the set is immutable and can be written to a .prt file.
 * With a shared budget (transport_share_budget, docs/design/shadows.md: the default of
 * `prt precompute`) the set keeps at most budget x nvecs coefficients in all and a
 * vector up to N (then TRANSPORT_SHARED_CAP x budget): transport_store stages each vector's N best
 * candidates unquantized, and transport_finish picks the best budget x nvecs of all
 * of them (one threshold on the selection weight), corrects and quantizes what each
 * vector keeps. N is always the most any vector holds, which is what a file states.
 *
 * Policy. Which coefficients a vector keeps and what values they get is the plain path of
 * section 4.1 (sparse_select's largest energies, the input's values rounded to the nearest step)
 * unless a representation gives the set a policy (transport_set_policy, transport_policy below):
 * Haar's (haar/policy.h) weighs the selection by the light it expects (select, prior), puts what
 * truncation drops back into the kept coarse coefficients (solid_angle, block_level, smooth_faces)
 * or refits the kept values to a light prior (refit). Those fields are the policy's parameters:
 * the plain path reads none of them and refuses a set that asks for them without a policy.
 *
 * Runtime: transport_light (Eq. 5's T x L for every vector) computes the
 * light-dependent K-vectors: g[3*i+ch] = sum_c value(c, ch) * L[index(c)][ch].
 * L is the light vector in coefficient-index order as float[4] per index (RGB and
 * padding, 16-byte aligned).
 *
 * Files: transport.c (the set, its staging and mapping), store.c (transport_store), budget.c
 * (a shared budget's choice), pack.c (transport_finish's packing), kernel.c (T x L on the CPU).
 *
 * Ownership: all arrays belong to the set; transport_free frees them. */
#ifndef PRT_TRANSPORT_H
#define PRT_TRANSPORT_H
#include "common.h"
#include "sparse.h"

/* How transport_store picks a vector's N coefficients (docs/design/shadows.md):
 *   MAGNITUDE: the N largest |c_i| (the paper's; the L2-optimal approximation of the vector).
 *   EXPECTED:  the N largest |c_i| sigma(i), sigma the RMS light coefficient of i's Haar level and
 *              elevation band (transport_sigma, haar/select.h): the set that minimises the expected
 *              squared error of T.L, sum over dropped i of c_i^2 sigma(i)^2, under lights whose
 *              coefficients are uncorrelated with that variance (a yaw rotation moves a sun along its
 *              band but keeps the band's spectrum). Its prior was measured with the solid-angle
 *              measure's light (L_j w_j, transfer_haar.c), so it is meant for Haar vectors of T/w.
 *              With prt_transport.prior the sigma is per coefficient and channel instead (prior.h). */
typedef enum transport_select { TRANSPORT_SELECT_MAGNITUDE = 0, TRANSPORT_SELECT_EXPECTED = 1 } transport_select;

/* Who shares the coefficient budget (transport_share_budget):
 *   VECTOR:   every vector keeps its own N best (the paper's).
 *   SHARED:   the set keeps its budget x nvecs best selection weights (transport_select's: |c_i|^2, or
 *             |c_i|^2 sigma_l^2, summed over the channels), wherever they are: a vector whose transport
 *             has detail (a shadow edge crossing its cube) keeps more, a smooth one fewer. The global
 *             optimum of the summed expected squared error of T.L at that storage, given that each
 *             vector keeps at least budget_min and at most N. With prt_transport.weight each vector's
 *             weights are scaled by its own (precompute: its vertex's share of the surface, so the sum is
 *             the error integrated over the surface, which a refined region does not outweigh).
 *   RELATIVE: the same with each vector's weights divided by its own total weight (the expected T.L
 *             squared), so the summed relative error is what is minimised: dark vertices are not
 *             starved by bright ones. */
typedef enum transport_budget { TRANSPORT_BUDGET_VECTOR = 0, TRANSPORT_BUDGET_SHARED = 1, TRANSPORT_BUDGET_RELATIVE = 2 } transport_budget;
/* A shared budget's cap per vector, in multiples of the mean (transport_share_budget's nmax default).
 * With the open sky split (opensky.h) an open vertex stores nothing and the shadowed ones share the
 * budget: 4 measured 0.103 against 2's 0.148 on the teapot's long shadow under a sun 2 degrees up, and
 * 8 the same as 4 (docs/design/shadows.md "The open sky"); whole vectors measured 2 as well as 4. */
#define TRANSPORT_SHARED_CAP 4
/* What every vector keeps of a shared budget whatever the others hold: budget / TRANSPORT_SHARED_MIN
 * of its best, so absolute weights cannot leave a dark vertex with nothing (black; docs/design/shadows.md,
 * docs/design/transport.md). */
#define TRANSPORT_SHARED_MIN 2

/* The integral correction's blocks (prt_transport.block_level, Haar's policy): 4 x 4 per face, 16 x 16
 * texels each (docs/design/shadows.md: each block's dropped integral goes into the kept coefficients of
 * coarser levels, so the file and the runtimes do not see it). */
#define TRANSPORT_BLOCK_LEVEL 2
#define TRANSPORT_BLOCK_LEVEL_MAX 2
/* A policy's per-vector corrections (transport_policy.correct, budget_correct): adj[(c * 6 + f) * 16 + m]
 * is added to coefficient f * CUBE_RES^2 + m, m < 16, of channel c (Haar: a face's levels 0..2). Also
 * the floats of a shared budget's block staging: 3 channels x 6 faces x 16 blocks. */
#define TRANSPORT_BLK (3 * 6 * 16)
/* Floats per vector of a shared budget's staging (stage_blk): [0, TRANSPORT_BLK) and
 * (TRANSPORT_BLK, TRANSPORT_STAGE) the policy's (transport_policy.stage; Haar: what the non-candidates
 * drop per block, then per smooth face weighted by the transport, 3 x 6, and its integral H_0, 6),
 * [TRANSPORT_BLK] the vector's squared L2 norm (the set's). */
#define TRANSPORT_STAGE (TRANSPORT_BLK + 1 + 24)
/* Bytes of transport_store's scratch a policy's hooks may use per thread (Haar's checks its need
 * against it when it is set). */
#define TRANSPORT_POLICY_SCRATCH ((size_t)1 << 20)

struct transport_policy;

typedef struct prt_transport {
    int nverts, nvecs;
    int N;                  /* coefficients kept per vector (max; the staging stride) */
    int budget;             /* 0: every vector keeps at most N of its own; > 0 (transport_share_budget): the
                             * set keeps at most budget x nvecs in all, any one vector up to N */
    int budget_kind;        /* transport_budget (VECTOR with budget 0) */
    int budget_min;         /* shared budget: coefficients every vector keeps whatever the others hold
                             * (budget / TRANSPORT_SHARED_MIN; its best by weight) */
    double chosen_err;      /* shared budget: the sum over vectors of the squared L2 error relative to the
                             * vector's squared norm that transport_finish's choice added to what
                             * transport_store returned (dropped candidates, quantization) */
    int qbits;              /* 8, 16 or 32 (float) */
    /* The policy's parameters (set after transport_init; all 0 on the plain path): */
    bool solid_angle;       /* Haar of T/w (transfer_haar's solid-angle measure): transport_store keeps
                             * the solid-angle integral of each block of block_level */
    int block_level;        /* with solid_angle: the integrals kept are those of the 2^l x 2^l blocks of
                             * each face, 0 (whole faces) .. TRANSPORT_BLOCK_LEVEL_MAX (set after init;
                             * precompute: TRANSPORT_BLOCK_LEVEL) */
    bool smooth_faces;      /* with solid_angle: a face with no occluder edge (haar/corrections.h) gets what
                             * was dropped back weighted by the transport, on its scaling coefficient, instead
                             * of per block (docs/design/shadows.md: exact under a light shaped like the transport,
                             * which steadies an unoccluded floor under a turning sun; set after init) */
    int select;             /* which N coefficients transport_store keeps (transport_select; 0 = the paper's
                             * largest magnitudes) */
    const float (*prior)[4];/* EXPECTED: NULL weighs coefficient i by transport_sigma (haar/select.h); else
                             * by prior[i][ch], [CUBE_TEXELS] per channel (prior.h: a probe's RMS light
                             * over its yaw orbit; BORROWED: the caller keeps it alive until finish) */
    const struct refit_tables *refit; /* NULL, or with a per-vector budget (budget 0) and solid_angle: each face's kept
                             * values refit to a light prior's texels (refit.h) instead of the corrections
                             * above; faces of more than REFIT_MAX_N kept keep them (BORROWED: the caller keeps
                             * it alive until finish; set after init, transport_init_like copies it) */
    uint32_t *vec_first;    /* [nverts+1] */
    uint32_t *coef_first;   /* [nvecs+1] */
    uint32_t *run_first;    /* [nvecs+1] */
    uint8_t *runs;          /* [2*nruns] (block, count-1) */
    float *scale;           /* [3*nvecs] dequantization step per channel */
    uint32_t *packed;       /* qbits 8: [ncoefs] */
    uint8_t *offs;          /* qbits 16/32: [ncoefs] block offsets */
    int16_t *q16;           /* qbits 16: [3*ncoefs] */
    float *f32;             /* qbits 32: [3*ncoefs] */
    /* Build-time staging (NULL after transport_finish). */
    uint32_t *stage_count;  /* [nvecs] coefficients stored per vector */
    uint32_t *stage_idx;    /* [nvecs*N] coefficient indices */
    float *stage_val;       /* [nvecs*N*3] values (already dequantized for error bookkeeping; with a shared
                             * budget the candidates' raw values until transport_finish) */
    const float *weight;    /* shared budget: [nvecs] a factor on each vector's selection weights, finite and
                             * > 0, borrowed (the caller keeps it alive until transport_finish; NULL: 1) */
    float *stage_key;       /* shared budget: [nvecs*N] each candidate's selection weight */
    float *stage_blk;       /* shared budget: [nvecs*TRANSPORT_STAGE] what the non-candidates add to each
                             * block's dropped integral (with solid_angle), per channel, face and block, then
                             * the vector's squared norm, then the smooth faces' parts (TRANSPORT_STAGE) */
    const struct transport_policy *policy; /* NULL: the plain path; else what transport_set_policy gave
                             * (transport_init_like copies it) */
    void *policy_state;     /* build-time: the policy's tables (its create; destroyed with the staging) */
    size_t stage_mapped;    /* > 0: stage_idx and stage_val are one mapping of this many bytes of an unlinked
                             * file (transport_stage_to_file), released as vectors are done */
    void *data_map;         /* non-NULL: runs and the coefficient arrays (packed / offs, q16, f32) live in this
                             * read-only mapping of data_mapped bytes of an unlinked file (transport_map_to_file),
                             * not on the heap; transport_free unmaps it */
    size_t data_mapped;
} prt_transport;

/* Sizes a set: nverts vertices, vertex v has nvec_of_vertex[v] vectors (vectors numbered
 * consecutively). N in 1..CUBE_TEXELS, qbits 8/16/32. Returns 0 or -1 (OOM/bad args). */
int transport_init(prt_transport *t, int nverts, const int *nvec_of_vertex, int N, int qbits, prt_error *err);
/* Lets the vectors of a set fresh from transport_init (nothing stored, not streamed yet) share its
 * budget of N x nvecs coefficients (kind SHARED or RELATIVE; VECTOR: no-op): each may keep up to
 * nmax (0: TRANSPORT_SHARED_CAP x N, at most CUBE_TEXELS). Staging grows to nmax candidates per vector
 * (transport_staging_bytes). Returns 0 or -1 (OOM; the set is then unchanged). */
int transport_share_budget(prt_transport *t, int kind, int nmax, prt_error *err);
/* transport_init with like's budget, kind, qbits, policy and its parameters (select, prior, refit, measure,
 * block level, smooth faces), and the vector counts given (the gathering passes' sets). Returns 0 or -1. */
int transport_init_like(prt_transport *t, const prt_transport *like, const int *nvec_of_vertex, prt_error *err);
/* Bytes the staging of an unfinished set takes (what transport_stage_to_file moves to a file): nvecs x N x 16,
 * and with a shared budget 4 more per candidate and 4 x TRANSPORT_STAGE per vector. */
size_t transport_staging_bytes(const prt_transport *t);
/* Selects, quantizes and stages vector i from dense coefficients r,g,b[CUBE_TEXELS] (store.c).
 * The set's policy picks and corrects the coefficients; scratch: transport_scratch_size() bytes.
 * Returns the L2 error squared of the stored approximation (truncation + quantization); with a
 * shared budget, of its candidates (what it would keep at the cap N; transport_finish decides). */
double transport_store(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch);
size_t transport_scratch_size(void);
/* Streams the staging of a set fresh from transport_init to an unlinked temporary file in dir:
 * staged vectors live in the page cache and the file, not in the process's memory,
 * once transport_release drops them; results are the same bits. Returns 0 or -1 (err: dir). */
int transport_stage_to_file(prt_transport *t, const char *dir, prt_error *err);
/* Drops the pages vectors [i0, i1)'s staging touches from this process's memory (the file keeps
 * them; any thread may still read or write them). No-op unless staged to a file. */
void transport_release(const prt_transport *t, int i0, int i1);
/* Compacts staged vectors into the final arrays (a shared budget's choice first). Returns 0 or -1 (OOM). */
int transport_finish(prt_transport *t, prt_error *err);
/* Moves a finished set's runs and coefficients (all but about 20 bytes per vector of it) to an
 * unlinked temporary file in dir, mapped read-only: a later pass reads them through the
 * page cache, which the kernel can drop and read back, instead of from the process's own memory;
 * the same bits. Returns 0, or -1 with err naming dir (the set is then unchanged). */
int transport_map_to_file(prt_transport *t, const char *dir, prt_error *err);
/* Drops the pages of a mapped set (transport_map_to_file) from this process's memory; a reader's
 * next access faults them in again from the page cache. Any thread, while others read. No-op for a
 * set on the heap. */
void transport_drop_mapped(const prt_transport *t);

/* Decodes vector i (after finish) into dense planar r,g,b[CUBE_TEXELS] (zeros elsewhere). */
void transport_decode(const prt_transport *t, int i, float *r, float *g, float *b);
/* Calls fn(ctx, index, r, g, b) for every stored coefficient of vector i, in index order. */
void transport_foreach(const prt_transport *t, int i, void (*fn)(void *ctx, uint32_t index, float r, float g, float b), void *ctx);
/* Number of coefficients and runs stored in all. */
size_t transport_ncoefs(const prt_transport *t);
size_t transport_nruns(const prt_transport *t);
/* Bytes the coefficient data takes (what the file stores for it). */
size_t transport_bytes(const prt_transport *t);

/* Light-dependent K-vectors of every vector: g[3*i + ch] (Eq. 5). L: [CUBE_TEXELS][4]. Both cores. */
void transport_light(const prt_transport *t, const float (*L)[4], float *g, int nthreads);
/* The same for vectors [first, last) only (the runtime's inner kernel). */
void transport_light_range(const prt_transport *t, const float (*L)[4], float *g, int first, int last);
/* transport_light with another kernel of that shape (a representation's, transfer.h), both cores. */
typedef void (*transport_light_fn)(const prt_transport *t, const float (*L)[4], float *g, int first, int last);
void transport_light_with(const prt_transport *t, const float (*L)[4], float *g, int nthreads, transport_light_fn kernel);

/* A finished copy of finished set t keeping each vector's n largest coefficients by stored energy
 * r^2 + g^2 + b^2 (ties: lower index; all of a vector that has <= n), same qbits, scales and values
 * (keep.c): the runtime's "first n by importance" of a file that stores them in index order. Holds no
 * policy or staging; free with transport_free. Returns 0 or -1 with err (OOM; out then empty). */
int transport_keep_largest(const prt_transport *t, int n, prt_transport *out, prt_error *err);

void transport_free(prt_transport *t);

/* A representation's policy for transport_store and transport_finish: which coefficients a vector
 * keeps and what values they get, beyond the plain path (section 4.1.1's largest energies, 4.1.2's
 * uniform rounding). Each hook reads the set's parameters (solid_angle .. refit) and its state;
 * `scratch` is the policy's TRANSPORT_POLICY_SCRATCH bytes of the calling thread's transport_store
 * scratch, which keep what select leaves there until that vector is stored. ch: the vector's
 * channels r, g, b [CUBE_TEXELS]; idx: the kept (or candidate) indices, increasing. */
typedef struct transport_policy {
    /* The set's read-only tables, made once (transport_set_policy); NULL with err on OOM. */
    void *(*create)(const prt_transport *t, prt_error *err);
    void (*destroy)(void *state);
    /* Up to t->N indices into idx, leaving each coefficient's weight's float bits in keys[0 .. CUBE_TEXELS)
     * as sparse_select does (keys: 2 x CUBE_TEXELS floats). Returns how many. */
    int (*select)(const prt_transport *t, const float *const ch[3], uint32_t *idx, float *keys, void *scratch);
    /* Per-vector budget, the n kept: sets val[3 k + c] of the faces it fits itself and returns them (bit f),
     * and into adj[TRANSPORT_BLK] the corrections of the other faces' values (zeros: none). */
    unsigned (*correct)(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, float *val,
                        float *adj, void *scratch);
    /* Rounds the n values val[3 k + c] of face f (one that correct fitted; idx its indices) to multiples of
     * step[c] with |q| <= qmax, in place. NULL when correct fits no face. */
    void (*quantize)(const prt_transport *t, int f, const uint32_t *idx, int n, const float step[3], int qmax,
                     float *val, void *scratch);
    /* Shared budget, the n candidates: its part of vector i's stage_blk (TRANSPORT_STAGE) into blk. */
    void (*stage)(const prt_transport *t, const float *const ch[3], const uint32_t *idx, int n, void *scratch,
                  float *blk);
    /* Shared budget at finish: the corrections adj[TRANSPORT_BLK] of vector i's values, keep[k] telling which
     * of its staged candidates k (stage_idx, stage_val, stage_blk; not yet compacted) it keeps. */
    void (*budget_correct)(const prt_transport *t, int i, const uint8_t *keep, float *adj);
} transport_policy;

/* Gives a set fresh from transport_init (nothing stored) its policy p (NULL: the plain path) and makes
 * p's tables. Returns 0, or -1 with err (OOM; the set is then unchanged). */
int transport_set_policy(prt_transport *t, const transport_policy *p, prt_error *err);
#endif
