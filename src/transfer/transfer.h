/* transfer.h - transfer representations: the seam between what precompute stores
 * per vertex and what a runtime does with a light.
 *
 * A representation is one module (transfer_haar.c, transfer_sh.c) exporting one
 * const transfer_ops table; transfer.c lists every one of them in one place
 * (pbrt-v4 style), and nothing outside a module switches on which one it is:
 * precompute, the file, the CPU and GL runtimes all go through the ops.
 *
 * Usage:
 *     const transfer_ops *ops = transfer_find("haar");       // NULL: unknown name
 *     transfer_config cfg = { .N = 128 };                     // zero fields mean defaults
 *     if (ops->configure(&cfg, &err)) ...                     // fills defaults, validates
 *     // precompute, per vertex and BRDF term, per channel (Eq. 3 texels with solid angle):
 *     ops->project_transport(&cfg, texels, coeffs, scratch);  // -> coefficient space
 *     ops->compress(&t, vec, r, g, b, tscratch);              // N largest, quantized
 *     // runtime, per light change:
 *     float (*L)[4] = transfer_light_vector(&data, cube_rgb); // ops->project_light of the file's transfer
 *     transfer_light(tr, &tr->transport, L, g, nthreads);      // ops->light_range: g = T x L (Eq. 5)
 *
 * The instances: a prt_data holds one prt_transfer per representation used
 * (prtfile.h), each with its config, the materials it shades (bit i: material i)
 * and its transport; a vertex's radiance is the sum over the transfers whose mask
 * holds its material. Today precompute makes exactly one sparse transfer covering
 * every material (the effects plan picks haar, or sh when asked for), so the
 * runtimes use prt_data_transfer() (the one) and PRT_CHECK that.
 *
 * The sparse family (haar, sh) shares prt_transport storage (transport.h: N
 * largest coefficients of a CUBE_TEXELS index space, quantized), its compression
 * (transport_store), its file section layout, its CPU kernel (transport_light_range)
 * and its GLSL kernels (transfer_sparse_glsl); they differ in the projection and
 * the light vector (and SH keeps only indices < order^2, which its validator checks).
 * Those shared pieces live in transfer_sparse.c; a module's table points at them.
 *
 * The non-linear ones:
 *   - vMF lobes (laurijssen-2011, transfer_vmf.c, vmf.h): per vertex and per geodesic view a
 *     set of von Mises-Fisher lobes per reflection pass, kept in a perfect hash (vertex, view)
 *     -> lobes, evaluated against the probe prefiltered by vMF lobes (prefilter.h, made by the
 *     runtime). Fills name/title/tag, configure (lobes, level, samples), describe, its section
 *     (write/read/validate/release), precompute, shade_vertices, bytes and summary;
 *     project_transport/compress/project_light/light_range stay NULL (nothing is linear in L
 *     per vertex), glsl NULL; glsl_view (transfer_vmf_glsl.c) shades per pixel (Eq. 7 over the
 *     pixel's triangle and grid views, the hash and lobes uploaded as buffer textures). Its mask holds the glossy
 *     materials, beside a Haar K = 1 transfer for their diffuse part.
 * Designed, not code yet:
 *   - spherical-Gaussian virtual lights (tokuyoshi): per frame, no precompute and no
 *     file section: tag 0 (transfer_by_tag never finds it), configure and describe only,
 *     everything else NULL; it is created by the runtime for local lights, not by the
 *     effects plan.
 * A caller therefore tests an op for NULL where the op is optional (documented per op).
 *
 * Thread safety: the ops are pure functions of their arguments (project_transport and
 * compress are called from every precompute thread with per-thread scratch).
 * Ownership: a prt_transfer owns its transport sets; ops->release frees them. */
#ifndef PRT_TRANSFER_H
#define PRT_TRANSFER_H
#include "common.h"
#include "cubemap.h"
#include "prtio.h"
#include "transport.h"

struct prt_data;

#define PRT_MAX_TRANSFERS 4
/* Floats of scratch project_transport may use (the Haar face transform's). */
#define TRANSFER_SCRATCH_FLOATS (2 * CUBE_RES * CUBE_RES)

/* What a representation is asked for; zero fields mean its defaults. */
typedef struct transfer_config {
    int N;          /* coefficients kept per vector (sparse family); 0: 128 */
    int qbits;      /* 8 (default when 0), 16 or 32 (float) */
    int order;      /* size of the basis where it has one: SH bands 3..10 (0: 6); haar: 0 */
    /* vmf (laurijssen-2011): */
    int lobes;      /* I: lobes per set and reflection pass; 0: 2 */
    int level;      /* geodesic view grid: icosahedron subdivided `level` times (10 * 4^level + 2 views) */
    int samples;    /* rays per (vertex, view) set in the direct and gathering passes */
    int measure;    /* haar: 0 the texels (the paper's), TRANSFER_MEASURE_SOLID_ANGLE; others: 0 */
} transfer_config;

/* What Haar coefficients approximate (transfer_haar.c says why): the texels T_j, which carry
 * their solid angle (0: the paper's, and every file written before issue 10), or T_j / w_j,
 * the transport per steradian, against a light vector of L_j w_j (what precompute makes
 * unless told otherwise). The file stores which. */
#define TRANSFER_MEASURE_SOLID_ANGLE 1

typedef struct transfer_ops transfer_ops;
struct prt_transfer;

/* A non-linear representation's per-pixel view shading in GLSL (gpu/glrt.c compiles it into its
 * per-pixel view program; NULL in transfer_ops: per vertex on the CPU only). `source` defines
 *     vec3 tv_radiance(int tri, vec3 pos, vec3 n, vec3 wo, float a)
 * (triangle index, world position, interpolated normal, unit view, the interpolated per-vertex value
 * `data` gives in vattr) and may call glrt's vec3 pf_lookup(vec3 dir, float kappa) (prefilter_lookup on the GPU) and
 * frame(n, s, t) (brdf_frame), and read its data from `uniform samplerBuffer t_tv` (RGBA32F
 * texels) and `uniform usamplerBuffer t_tvu` (R32UI words), which `data` builds. A pixel of a
 * triangle with a corner of the transfer's materials adds tv_radiance to its shading; the CPU then
 * does not shade those vertices (runtime_gl.c). glrt compiles the source twice: with TV_FULL 1, and
 * with TV_FULL 0 for the triangles whose three corners have vattr 1 (drawn apart; the source may
 * then leave out all but its path for a > 0.999, which llvmpipe would otherwise run masked). */
typedef struct transfer_glsl_view {
    const char *source;
    int rows;   /* TV_ROWS: texels of t_tv per material at its start (the source's #define) */
    /* The two arrays and vattr[nverts] (malloc'd here, freed by the caller); -1 with err when out of memory. */
    int (*data)(const struct prt_data *d, const struct prt_transfer *tr, float (**f)[4], size_t *nf, uint32_t **u, size_t *nu,
                float **vattr, prt_error *err);
} transfer_glsl_view;

/* One representation's data in a prt_data. */
typedef struct prt_transfer {
    const transfer_ops *ops;
    transfer_config cfg;        /* as configured (defaults filled) */
    uint64_t materials;         /* bit i: material i is shaded by this transfer */
    prt_transport transport;    /* direct + every interreflection pass (what the runtime uses) */
    prt_transport direct;       /* optional (nvecs 0 when absent): the direct pass alone, kept by
                                 * `precompute --keep-direct` for the direct/bounces toggle */
    void *priv;                 /* a non-linear representation's own data (vmf: lobe sets in a perfect
                                 * hash); made by its precompute or read, freed by its release; NULL else */
} prt_transfer;

struct prt_scene;
struct vis_scene;
struct prefilter_env;

/* What a non-projection representation's precompute gets (ops->precompute). */
typedef struct transfer_precompute_in {
    const struct prt_scene *scene;  /* the (refined) mesh and its materials */
    const struct vis_scene *vis;    /* the mesh's Embree scene (visibility.h) */
    int passes;                     /* reflection passes at most: 1 direct only, 1 + bounces */
    float bounce_threshold;         /* stop when a pass carries less than this share of the direct energy */
    int nthreads;                   /* 0: all cores */
    prt_progress_fn progress;       /* may cancel: returning false stops with "cancelled" */
    void *progress_user;
    struct prt_checkpoint *ckpt;    /* non-NULL: the passes restore what it holds and record the rest
                                     * (checkpoint.h: a resumable run) */
    struct prt_shard *shard;        /* MPI ranks to split the passes across (shard.h); NULL: this process */
    /* NULL, or told after each stage its name (the progress bar's), wall and process CPU seconds:
     * precompute sets the effects plan's estimate beside what ran (precompute.h) */
    void (*pass_done)(void *user, const char *stage, double wall, double cpu);
    void *pass_user;
} transfer_precompute_in;

/* GLSL sources of a light kernel family, compiled by glrt (gpu/glrt.c). The kernel computes
 * g_i = scale_i * sum_c q_c L[index_c] for every vector i from glrt's buffers (first, words,
 * blocks, scale, L -> g); see glrt.c for the buffer layout. The marker lines DECODE and
 * BUFFERS in the bodies are replaced by `decode` (after "#define QBITS n") and `buffers`. */
typedef struct transfer_glsl {
    const char *decode;     /* vec3 coef(uint c, out uint idx) per QBITS; uses WORD(c), BLOCK(c) */
    const char *fragment;   /* GL 3.3 fragment shader: one fragment per vector (buffer textures) */
    const char *buffers;    /* GL 4.3 SSBO declarations shared by the compute kernels */
    const char *thread;     /* compute: one invocation per vector */
    const char *warp;       /* compute: 32 invocations per vector and a shared-memory sum */
} transfer_glsl;

struct transfer_ops {
    const char *name;       /* "haar", "sh": what precompute_desc.basis names */
    const char *title;      /* "Haar wavelets" */
    uint32_t tag;           /* its .prt section (four characters, TRANSFER_TAG) */

    /* Fills cfg's defaults and validates it; -1 with one line in err. */
    int (*configure)(transfer_config *cfg, prt_error *err);
    /* One line (no newline) describing cfg, for the effects plan and `prt info`. */
    void (*describe)(const transfer_config *cfg, char *buf, size_t cap);

    /* Precompute (NULL where the representation is not a projection, see above). One channel of
     * a vertex's transport cube (CUBE_TEXELS, cubemap.h order, Eq. 3 texels that include their
     * solid angle) -> coefficients[CUBE_TEXELS] in the representation's index space (unused
     * indices zero). scratch: TRANSFER_SCRATCH_FLOATS floats. Called once per vector channel. */
    void (*project_transport)(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch);
    /* Stores vector i from dense coefficients r, g, b (keeps the N largest, quantizes;
     * transport_store). Returns the squared L2 error of what is stored. */
    double (*compress)(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch);

    /* The light vector from the probe resampled to the cube (cube_rgb [CUBE_TEXELS][3], mean
     * radiance per texel) into L [CUBE_TEXELS][4] in the same index space, so that
     * sum_i L_i T_i approximates sum_j L_j T_j (Eq. 4). */
    void (*project_light)(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]);

    /* File section (tag): writes cfg, the material mask and the data; reads it back (sizes and
     * allocation only, false with why[256] on a short or oversized section); validates every
     * index against d's mesh and factors (false with why); frees what read/precompute made. */
    void (*write)(prt_writer *w, const prt_transfer *tr);
    bool (*read)(prt_reader *r, prt_transfer *tr, char *why);
    bool (*validate)(const struct prt_data *d, const prt_transfer *tr, char *why);
    void (*release)(prt_transfer *tr);

    /* CPU light change for vectors [first, last) of t (one of tr's sets): g[3i + ch]. */
    void (*light_range)(const prt_transport *t, const float (*L)[4], float *g, int first, int last);
    /* GLSL light kernels (NULL: no GL runtime for this representation yet). */
    const transfer_glsl *glsl;

    /* ---- non-linear representations (vmf); NULL in the sparse family ----
     * Precompute when the representation is not a projection of the transport cube: fills tr
     * (tr->priv) for the vertices whose material is in tr->materials, every pass it stores. */
    int (*precompute)(const transfer_precompute_in *in, prt_transfer *tr, prt_error *err);
    /* CPU view change: ADDS to rgb[3 * nverts] the outgoing radiance toward eye of every vertex
     * of tr's materials, lit by env (the probe prefiltered by vMF lobes, prefilter.h, its
     * rotation set by the runtime); nthreads 0: all cores. */
    void (*shade_vertices)(const struct prt_data *d, const prt_transfer *tr, const struct prefilter_env *env,
                           const float eye[3], float *rgb, int nthreads);
    /* Bytes tr holds (transport or priv), for `prt info` and the runtimes' timing. */
    size_t (*bytes)(const prt_transfer *tr);
    /* Optional (NULL: none): lines for `prt info` about tr's data (vmf: views, lobes, passes, hash
     * fill, bytes), each ending in a newline, into buf[cap]. */
    void (*summary)(const prt_transfer *tr, char *buf, size_t cap);
    /* Optional (NULL: none): the per-pixel GLSL view shading (transfer_glsl_view above). */
    const transfer_glsl_view *glsl_view;
};

#define TRANSFER_TAG(a, b, c, d) ((uint32_t)(a) | (uint32_t)(b) << 8 | (uint32_t)(c) << 16 | (uint32_t)(d) << 24)

/* The table: every representation, in one place (transfer.c). */
int transfer_count(void);
const transfer_ops *transfer_at(int i);
/* By name ("haar", "sh") or section tag; NULL when there is none. */
const transfer_ops *transfer_find(const char *name);
const transfer_ops *transfer_by_tag(uint32_t tag);
/* "haar, sh": every name in table order, for error messages (truncated to cap). */
void transfer_names(char *buf, size_t cap);

/* The light vector for d's transfer representation from the probe resampled to the
 * 6x64x64 cube (cube_rgb: [CUBE_TEXELS][3] radiance): its project_light (Haar wavelets
 * quantized to 16 bits, or spherical harmonics). Returns an aligned [CUBE_TEXELS][4]
 * array (free()), NULL on OOM. */
float (*transfer_light_vector(const struct prt_data *d, const float *cube_rgb))[4];
/* g = T x L for every vector of t (one of tr's sets) with tr's CPU kernel on nthreads (0: all). */
void transfer_light(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads);

/* The shared pieces of the sparse family (transfer_sparse.c), for the modules' tables. */
/* Fills and checks the family's fields of cfg: N (default 128) and qbits (default 8). 0 or -1. */
int transfer_sparse_configure(transfer_config *cfg, prt_error *err);
double transfer_sparse_compress(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch);
void transfer_sparse_write(prt_writer *w, const prt_transfer *tr);
bool transfer_sparse_read(prt_reader *r, prt_transfer *tr, char *why);
/* Validates tr's sets against d with coefficient indices below max_index. */
bool transfer_sparse_validate(const struct prt_data *d, const prt_transfer *tr, uint32_t max_index, char *why);
void transfer_sparse_release(prt_transfer *tr);
extern const transfer_glsl transfer_sparse_glsl;

/* The modules' tables (listed in transfer.c). */
extern const transfer_ops transfer_haar;
extern const transfer_ops transfer_sh;
extern const transfer_ops transfer_vmf;
extern const transfer_glsl_view transfer_vmf_glsl_view;
#endif
