/* transfer.h - transfer representations: the seam between what precompute stores per vertex
 * and what a runtime does with a light. Nothing outside a representation's own folder names
 * one: precompute, the file, the CPU and GL runtimes and the CLI go through this interface and
 * the table below (pbrt-v4 style: every representation listed in one place, transfer.c).
 *
 * Two kinds, told apart by transfer_ops.kind, each with its own table:
 *   TRANSFER_LINEAR  a linear transfer projected against a light vector (section 4: the transport
 *                    cube of a vertex and BRDF term projected into a basis, its N largest
 *                    coefficients kept in a prt_transport set, transport.h; at runtime
 *                    g = T x L, Eq. 5, with L the probe projected into the same basis). Its table is
 *                    transfer_linear: project_transport, compress, project_light, light_range, the
 *                    GLSL light kernels, and the precompute hooks that carry its own policy.
 *   TRANSFER_VIEW    a view-dependent lobe transfer (laurijssen-2011): per vertex and view a few lobes
 *                    looked up in the probe prefiltered by lobes, per view change. Its table is
 *                    transfer_view: fit (how well it represents a BRDF, for the effects plan), its own
 *                    precompute passes and their estimate, shade_vertices, the per-pixel GLSL.
 * The common part (transfer_ops) names it, tags its .prt section, parses and describes its
 * configuration, writes, reads, validates and releases its data.
 *
 * The implementations (transfer.c's table, in this order; the first of a kind is its default):
 *     name  kind    folder              what
 *     haar  LINEAR  src/transfer/haar/  Haar wavelets, the N largest of 24,576 (the paper); its
 *                                       policy: measure, expected-error selection, light prior,
 *                                       shared budget, corrections, refit
 *     sh    LINEAR  src/transfer/sh/    spherical harmonics of order 3..10 (the low-frequency baseline)
 *     vmf   VIEW    src/transfer/vmf/   vMF lobes per vertex and geodesic view, perfect-hashed
 *     cpca  LINEAR  src/transfer/cpca/  clustered PCA of the Haar transport (Sloan 2003, Liu 2004):
 *                                       per cluster a mean and M sparse basis vectors, per vector M
 *                                       weights; built by its finish, lit by its light (on the CPU,
 *                                       also under the GL runtime, which uploads g)
 * Haar and SH share their storage section, validation and kernels (src/transfer/linear/); cpca
 * uses Haar's basis and light vector and keeps only the sets' vector offsets in them.
 *
 * Configuration. A representation's configuration is private to it: transfer_config is an opaque,
 * fixed-size value (copyable, compared and hashed as bytes) that only its own configure fills.
 * configure parses an options text "key=value,key=value" against its option table
 * (transfer_option: key, the CLI flag that sets it, help), validates it (an error names the key),
 * and fills its defaults: empty options are the product's defaults (what `prt precompute` does).
 * The CLI builds its flags and help from the option tables, so a representation's flags live in
 * its folder. describe gives the one line the plan and `prt info` show.
 *
 * Usage:
 *     const transfer_ops *ops = transfer_find(name);          // a user's name; NULL: unknown
 *     transfer_setup s = { .options = "key=value" };
 *     transfer_config cfg;
 *     if (ops->configure(&s, &cfg, &err)) puts(err.msg);      // "sh: order = '2' (must be 3..10)"
 *     // precompute (precompute.c), per vertex and BRDF term, per channel:
 *     ops->linear->project_transport(&cfg, texels, coeffs, scratch);
 *     ops->linear->compress(&t, vec, r, g, b, tscratch);
 *     ops->linear->finish(tr, nthreads, &err);                // optional, once the sets are final
 *     // runtime, per light change (runtime.c, relight.c):
 *     float (*L)[4] = transfer_light_vector(tr, cube_rgb);    // ops->linear->project_light
 *     transfer_light(tr, &tr->transport, L, g, nthreads);     // ops->linear->light or light_range: g = T x L
 *
 * The instances: a prt_data holds one prt_transfer per representation used (prtfile.h), each
 * with its config, the materials it shades (bit i: material i) and its data; a vertex's radiance
 * is the sum over the transfers whose mask holds its material. Precompute makes exactly one
 * linear transfer covering every material (a material on a view-dependent path keeps only its
 * kd/pi factor there) and, when the effects plan sends a glossy material to it, one view-dependent
 * transfer over those materials.
 *
 * Adding a representation: its folder with one module exporting a const transfer_ops (and its
 * kind's table), and one line in transfer.c's table. README "Extending prt" says
 * the steps; tests/dense/ is one, in the table of its test binary only (the table below).
 *
 * Thread safety: the ops are pure functions of their arguments (project_transport and compress
 * are called from every precompute thread with per-thread scratch).
 * Ownership: a prt_transfer owns its data (transport sets or priv); ops->release frees it. */
#ifndef PRT_TRANSFER_H
#define PRT_TRANSFER_H
#include "common.h"
#include "cubemap.h"
#include "factor.h"
#include "prtio.h"
#include "transport.h"
#include <stddef.h>

struct prt_data;
struct prt_scene;
struct vis_scene;
struct prefilter_env;
struct prt_checkpoint;
struct prt_shard;

#define PRT_MAX_TRANSFERS 4
/* Floats of scratch project_transport may use (the Haar face transform's). */
#define TRANSFER_SCRATCH_FLOATS (2 * CUBE_RES * CUBE_RES)

typedef enum transfer_kind {
    TRANSFER_LINEAR = 1,    /* projected against a light vector: g = T x L (transfer_linear) */
    TRANSFER_VIEW = 2,      /* view-dependent lobes, shaded per view change (transfer_view) */
} transfer_kind;

/* A representation's configuration: opaque bytes only its own ops read (each copies its private
 * struct in and out with memcpy). Configure zeroes it first, so two equal configurations are equal
 * bytes (the checkpoint key hashes them). */
#define TRANSFER_CONFIG_BYTES 128
typedef union transfer_config {
    unsigned char bytes[TRANSFER_CONFIG_BYTES];
    max_align_t align;
} transfer_config;

/* One option of a representation (its table ends with a zero entry). In the options text it is
 * key=VALUE: one of the '|'-separated words (a SWITCH or a WORD), or an integer in lo..hi (an INT).
 * The CLI makes each entry with a flag into that flag: a SWITCH's sets key=value, an INT's or a
 * WORD's key=ARGUMENT (checked as the text is), with help printed beside it. */
typedef enum transfer_option_kind { TRANSFER_OPT_SWITCH = 0, TRANSFER_OPT_INT, TRANSFER_OPT_WORD } transfer_option_kind;
typedef struct transfer_option {
    const char *key;            /* "select": the key in the options text */
    transfer_option_kind kind;
    const char *words;          /* SWITCH, WORD: the values it takes, "expected|magnitude" (the first: its default) */
    int lo, hi;                 /* INT: its range */
    const char *flag;           /* "--select": the flag that sets it; NULL: the options text only */
    const char *arg;            /* INT, WORD: the flag's argument as help shows it ("ORDER", "expected|magnitude") */
    const char *value;          /* SWITCH: the value the flag sets ("texels") */
    bool selects;               /* giving the flag also chooses this representation (--sh ORDER) */
    const char *help;           /* the flag's help, lines separated by '\n' */
} transfer_option;

/* What configure reads. */
typedef struct transfer_setup {
    const char *options;        /* "key=value,...": NULL or "" for the defaults */
    int N;                      /* linear: coefficients kept per vector (0: the representation's default) */
    int qbits;                  /* linear: 8, 16 or 32 (0: its default) */
    const char *light_prior;    /* probe files, comma-separated, the output will mostly be lit by (NULL: none);
                                 * a representation that weighs its choices by light uses them (Haar) */
    bool light_prior_scene;     /* light_prior is the scene's own key: one that cannot use it leaves it out
                                 * (saying so in the plan) instead of failing */
} transfer_setup;

typedef struct transfer_ops transfer_ops;
struct prt_transfer;

/* One representation's data in a prt_data. */
/* prt_transfer.open_vert's values besides 0 (the whole transport). */
#define OPENSKY_SPLIT 1
#define OPENSKY_FOLDED 2

typedef struct prt_transfer {
    const transfer_ops *ops;
    transfer_config cfg;        /* as configured (defaults filled) */
    uint64_t materials;         /* bit i: material i is shaded by this transfer */
    prt_transport transport;    /* LINEAR: direct + every interreflection pass (what the runtime uses) */
    prt_transport direct;       /* LINEAR, optional (nvecs 0 when absent): the direct pass alone, kept by
                                 * `precompute --keep-direct` for the direct/bounces toggle */
    bool open_sky;              /* LINEAR: the open sky split (opensky.h): the vectors of the vertices open_vert
                                 * marks hold what the occluders block, negated, and the runtime adds the
                                 * open sky g E(n) */
    uint8_t *open_vert;         /* with open_sky, [nverts]: OPENSKY_SPLIT where vertex v's vectors are split (a
                                 * Lambertian factor seeing more of its sky than it misses), OPENSKY_FOLDED where
                                 * they are split and folded (a floor vertex, normal (0, 1, 0), of a file without
                                 * interreflections: the blocked part over its texels' mean cosine, which the
                                 * runtime's light takes: opensky.h), 0 where they hold the whole transport;
                                 * owned here, freed by linear_release (or prt_data_free) */
    void *priv;                 /* its own data: VIEW (vmf: lobe sets in a perfect hash), made by its
                                 * precompute; LINEAR with a finish (cpca: its clusters), made by finish;
                                 * or by its read; freed by its release; NULL else */
} prt_transfer;

/* ---- the linear kind -------------------------------------------------------------------------- */

/* Texels of the lighting cube that the direct pass integrates along given rays rather than over
 * their area: a_j = Omega_j / M sum_m V(w_m) max(n.w_m, 0), Eq. 3 against the light inside the texel
 * (a sun smaller than its texel). A linear representation's begin may ask for them (Haar's light
 * prior). */
#define TRANSFER_RAY_TEXELS 16
#define TRANSFER_RAYS 64
typedef struct transfer_texel_rays {
    int n;                                              /* texels */
    int texel[TRANSFER_RAY_TEXELS];                     /* lighting texel index (CUBE_RES cube) */
    float omega[TRANSFER_RAY_TEXELS];                   /* its solid angle */
    float dir[TRANSFER_RAY_TEXELS][TRANSFER_RAYS][3];   /* unit directions, distributed as the light inside it */
} transfer_texel_rays;

/* What a linear representation's begin gets: the run it joins. */
typedef struct transfer_linear_in {
    size_t nvecs;               /* vectors its direct pass stores (its materials' vertices x K) */
    prt_progress_fn progress;   /* may cancel: returning false stops with "cancelled" */
    void *progress_user;
    bool quiet;                 /* no status lines on stderr */
    char *plan;                 /* its effects-plan lines are appended here ("  ...\n" each) */
    size_t plan_cap;
} transfer_linear_in;

/* What begin decides for one precompute (end frees it). */
typedef struct transfer_linear_run {
    void *state;                        /* its own (init_set reads it) */
    const transfer_texel_rays *rays;    /* NULL, or texels the direct pass integrates along rays */
    double seconds;                     /* what begin took (a light prior's building; the timing summary) */
    const char *stage;                  /* that time's name ("light prior"); NULL: none */
} transfer_linear_run;

/* Adds n bytes at p to a checkpoint key (precompute's; checkpoint.h). */
typedef void (*transfer_key_fn)(void *key, const void *p, size_t n);

/* GLSL sources of a light kernel family, compiled by glrt (gpu/glrt.c). The kernel computes
 * g_i = scale_i * sum_c q_c L[index_c] + open_i for every vector i from glrt's buffers (first, words,
 * blocks, scale, L, open -> g; open: the open sky's addend, runtime_light.open, zero without the
 * split); see glrt.c for the buffer layout. The marker lines DECODE and
 * BUFFERS in the bodies are replaced by `decode` (after "#define QBITS n") and `buffers`. */
typedef struct transfer_glsl {
    const char *decode;     /* vec3 coef(uint c, out uint idx) per QBITS; uses WORD(c), BLOCK(c) */
    const char *fragment;   /* GL 3.3 fragment shader: one fragment per vector (buffer textures) */
    const char *buffers;    /* GL 4.3 SSBO declarations shared by the compute kernels */
    const char *thread;     /* compute: one invocation per vector */
    const char *warp;       /* compute: 32 invocations per vector and a shared-memory sum */
} transfer_glsl;

typedef struct transfer_linear {
    /* ---- precompute (precompute.c calls them in this order) ----
     * Optional (NULL: nothing to decide): what this run needs beyond cfg (Haar: its light prior from
     * the probes, its budget), its plan lines; out is zeroed first. 0, or -1 with err. */
    int (*begin)(const transfer_config *cfg, const transfer_setup *s, const transfer_linear_in *in,
                 transfer_linear_run *out, prt_error *err);
    /* Sizes the direct pass's set for nverts vertices, vertex v holding nvec[v] vectors
     * (transport_init), with its N, qbits and store policy; the gathering passes copy the policy
     * (transport_init_like). 0, or -1 with err. */
    int (*init_set)(const transfer_config *cfg, const transfer_linear_run *run, prt_transport *t, int nverts,
                    const int *nvec, prt_error *err);
    /* Optional: adds what the passes' results depend on beyond cfg (its prior) to a checkpoint key. */
    void (*key)(const transfer_linear_run *run, transfer_key_fn add, void *key);
    /* Optional (NULL: not modelled): the file bytes one stored vector is expected to take, for the
     * plan's byte budget (how far refinement may grow the mesh). */
    double (*vector_bytes)(const transfer_config *cfg);
    /* Optional: frees what begin and init_set made (after the passes). */
    void (*end)(transfer_linear_run *run);
    /* One channel of a vertex's transport cube (CUBE_TEXELS, cubemap.h order, Eq. 3 texels that
     * include their solid angle) -> coefficients[CUBE_TEXELS] in its index space (unused indices
     * zero). scratch: TRANSFER_SCRATCH_FLOATS floats. Called once per vector channel. */
    void (*project_transport)(const transfer_config *cfg, const float *texels, float *coeffs, float *scratch);
    /* Stores vector i from dense coefficients r, g, b (transport_store: its N best, quantized).
     * Returns the squared L2 error of what is stored. */
    double (*compress)(prt_transport *t, int i, const float *r, const float *g, const float *b, void *scratch);
    /* Optional (NULL: the sets are final as the passes stored them): called once after every pass,
     * with the transfer's final sets in tr (transport, and direct when kept), before anything else
     * reads or writes them, for a representation that needs every vector at once (cpca: clusters of
     * vectors). It may build its own data in tr->priv and replace the sets' coefficients (its
     * light reads what it made). 0, or -1 with err. */
    int (*finish)(prt_transfer *tr, int nthreads, prt_error *err);

    /* ---- runtime ----
     * The light vector from the probe resampled to the cube (cube_rgb [CUBE_TEXELS][3], mean
     * radiance per texel) into L [CUBE_TEXELS][4] in the same index space, so that sum_i L_i T_i
     * approximates sum_j L_j T_j (Eq. 4). */
    void (*project_light)(const transfer_config *cfg, const float *cube_rgb, float (*L)[4]);
    /* CPU light change for vectors [first, last) of t (one of the transfer's sets): g[3i + ch].
     * NULL when light is given. */
    void (*light_range)(const prt_transport *t, const float (*L)[4], float *g, int first, int last);
    /* Optional (NULL: light_range over ranges of vectors on the threads): the whole CPU light change
     * g[3i + ch] of set t of tr on nthreads (0: all), for a representation with a step per light
     * change that every vector shares (cpca: each cluster's rows projected on the light once). */
    void (*light)(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads);
    /* GLSL light kernels (NULL: the GL runtime changes the light on the CPU, transfer_light, and uploads
     * g: glrt.h's CPU method). */
    const transfer_glsl *glsl;
} transfer_linear;

/* ---- the view-dependent kind ---------------------------------------------------------------- */

/* How well a view-dependent representation represents a BRDF (the effects plan's choice per
 * material, precompute.h), both errors in its own measure. */
typedef struct transfer_fit {
    bool fits;                  /* it can represent this BRDF at all */
    char why[128];              /* when not: why ("anisotropic, and no ASG fit exists here") */
    double err;                 /* its own relative error on the BRDF */
    double svd_err;             /* the SVD factor's at its K, in the same measure */
    const char *what;           /* what err is of, for the plan: "one vMF lobe" */
    const char *measure;        /* the measure, for the plan: "rel. L2 over the whole slice f cos" */
} transfer_fit;

/* What a view-dependent representation's passes get (transfer_view.precompute). */
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
    int ckpt_pass;                  /* the first checkpoint pass id it may use; TRANSFER_CKPT_PASSES from there */
    struct prt_shard *shard;        /* MPI ranks to split the passes across (shard.h); NULL: this process */
    /* NULL, or told after each stage its name (the progress bar's), wall and process CPU seconds:
     * precompute sets the effects plan's estimate beside what ran (precompute.h) */
    void (*pass_done)(void *user, const char *stage, double wall, double cpu);
    void *pass_user;
} transfer_precompute_in;
#define TRANSFER_CKPT_PASSES 6

/* The plan's estimate of a view-dependent representation's passes: its stages in order, each
 * named as its pass_done reports it, with the CPU seconds of one thread it expects. */
#define TRANSFER_MAX_STAGES 6
typedef struct transfer_estimate {
    int n;
    char name[TRANSFER_MAX_STAGES][24];
    double cpu[TRANSFER_MAX_STAGES];
} transfer_estimate;

/* A view-dependent transfer's per-pixel view shading in GLSL (gpu/glrt.c compiles it into its
 * per-pixel view program; NULL: per vertex on the CPU only). `source` defines
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
    int (*data)(const struct prt_data *d, const prt_transfer *tr, float (**f)[4], size_t *nf, uint32_t **u, size_t *nu,
                float **vattr, prt_error *err);
} transfer_glsl_view;

typedef struct transfer_view {
    /* ---- precompute ----
     * How well it represents BRDF p, whose SVD factor at the plan's K is f (out->fits false with why
     * when it cannot). 0, or -1 with err. */
    int (*fit)(const transfer_config *cfg, const brdf_params *p, const brdf_factor *f, transfer_fit *out, prt_error *err);
    /* Its passes: fills tr (tr->priv) for the vertices whose material is in tr->materials. 0 or -1. */
    int (*precompute)(const transfer_precompute_in *in, prt_transfer *tr, prt_error *err);
    /* Optional: a timed probe of those passes (a few hundredths of a second) into out. 0, or -1
     * (no estimate). */
    int (*estimate)(const transfer_precompute_in *in, const prt_transfer *tr, transfer_estimate *out, prt_error *err);
    /* Optional: the resume message's clause for count records of its checkpoint pass p ("vmf direct 86"). */
    void (*resumed)(int p, int count, char *buf, size_t cap);
    /* Optional: settles in cfg what its options left to the scene, from the count of vertices it will
     * cover and the passes it may make (vmf: the view grid's level, by a byte budget), before the
     * transfer is made; why gets the effects plan's clause (no newline); *room (when not NULL) the
     * most vertices that settled cfg holds within that budget (refinement's share: precompute.c). */
    void (*settle)(transfer_config *cfg, long nverts, int passes, long *room, char *why, size_t cap);

    /* ---- runtime ----
     * CPU view change: ADDS to rgb[3 * nverts] the outgoing radiance toward eye of every vertex of
     * tr's materials, lit by env (the probe prefiltered by vMF lobes, prefilter.h, its rotation set by
     * the runtime); nthreads 0: all cores. */
    void (*shade_vertices)(const struct prt_data *d, const prt_transfer *tr, const struct prefilter_env *env,
                           const float eye[3], float *rgb, int nthreads);
    /* Optional: the per-pixel GLSL view shading (above). */
    const transfer_glsl_view *glsl;
} transfer_view;

/* ---- the common part ------------------------------------------------------------------------ */

struct transfer_ops {
    const char *name;       /* "haar": what --basis, --glossy and precompute_desc name */
    const char *title;      /* "Haar wavelets" */
    const char *label;      /* "Haar": what the effects plan's clauses call it */
    uint32_t tag;           /* its .prt section (four characters, TRANSFER_TAG) */
    transfer_kind kind;
    const transfer_option *options;     /* its options (ended by a zero entry); NULL: none */

    /* Zeroes cfg, parses s->options into it, fills its defaults and validates; -1 with one line in
     * err naming the key. */
    int (*configure)(const transfer_setup *s, transfer_config *cfg, prt_error *err);
    /* One line (no newline) describing cfg, for the effects plan and `prt info`. */
    void (*describe)(const transfer_config *cfg, char *buf, size_t cap);

    /* File section (tag): writes cfg, the material mask and the data; reads it back (sizes and
     * allocation only, false with why[256] on a short or oversized section); validates every
     * index against d's mesh and factors (false with why); frees what read/precompute made. */
    void (*write)(prt_writer *w, const prt_transfer *tr);
    bool (*read)(prt_reader *r, prt_transfer *tr, char *why);
    bool (*validate)(const struct prt_data *d, const prt_transfer *tr, char *why);
    void (*release)(prt_transfer *tr);
    /* Bytes tr's data takes, for `prt info`, the timing summary and the runtimes' timing. */
    size_t (*bytes)(const prt_transfer *tr);
    /* Optional (NULL: none): lines for `prt info` about tr's data (vmf: views, lobes, passes, hash
     * fill, bytes), each ending in a newline, into buf[cap]. */
    void (*summary)(const prt_transfer *tr, char *buf, size_t cap);

    /* Exactly one, the kind's: */
    const transfer_linear *linear;      /* TRANSFER_LINEAR */
    const transfer_view *view;          /* TRANSFER_VIEW */
};

#define TRANSFER_TAG(a, b, c, d) ((uint32_t)(a) | (uint32_t)(b) << 8 | (uint32_t)(c) << 16 | (uint32_t)(d) << 24)

/* ---- the table ------------------------------------------------------------------------------
 * transfer.c holds the table and only it (transfer_count, transfer_at), so that a program may link
 * its own table before libprt.a: tests/dense/ does, to add a representation for its test alone.
 * The lookups over it are interface.c's. */

int transfer_count(void);
/* The i-th representation (0 <= i < transfer_count()). */
const transfer_ops *transfer_at(int i);
/* By name or section tag; NULL when there is none (tag 0 never is a section). */
const transfer_ops *transfer_find(const char *name);
const transfer_ops *transfer_by_tag(uint32_t tag);
/* The first representation of kind in table order (the default of that kind), or NULL. */
const transfer_ops *transfer_default(transfer_kind kind);
/* "haar, sh": the names of kind (0: every kind) in table order, for messages (truncated to cap). */
void transfer_names(transfer_kind kind, char *buf, size_t cap);

/* ---- options -------------------------------------------------------------------------------- */

/* Parses options text "key=value,key=value" (NULL or "": none) against opts, calling set(user, i,
 * value) for each item whose key is opts[i].key, in order (a later item overrides an earlier one).
 * An unknown key, an item without '=', or set's failure: -1 with one line naming who and the key. */
int transfer_parse_options(const char *who, const transfer_option *opts, const char *text,
                           int (*set)(void *user, int i, const char *value, prt_error *err), void *user, prt_error *err);
/* The index of value among option o's words, or -1 with err naming its key and words. */
int transfer_option_word(const char *who, const transfer_option *o, const char *value, prt_error *err);
/* An INT option's value in lo..hi into *out: 0, or -1 with err naming its key and range. */
int transfer_option_int(const char *who, const transfer_option *o, const char *value, int *out, prt_error *err);

/* ---- calls every runtime makes -------------------------------------------------------------- */

/* A zeroed, 64-byte aligned light vector of CUBE_TEXELS x 4 floats, or NULL; free with free(). */
float (*transfer_light_alloc(void))[4];
/* The light vector of linear transfer tr from the probe resampled to the 6x64x64 cube (cube_rgb:
 * [CUBE_TEXELS][3] radiance): its project_light, into a transfer_light_alloc'd array, NULL on OOM. */
float (*transfer_light_vector(const prt_transfer *tr, const float *cube_rgb))[4];
/* A copy of L scaled by 2^-*shift (free with free()) when its largest |value| is 2^97 or more, else
 * NULL with *shift = 0 (NULL too when out of memory: the caller uses L as it is). The kernels sum
 * integer codes (up to 127, or 32767 at 16 bits) times L in float before the vector's scale, so a
 * finite sun of 1e37 would overflow to Inf; a power of two scales exactly, and the caller scales g
 * back by 2^shift. Both runtimes use it, so they compute the same g. */
float (*transfer_light_scaled_copy(const float (*L)[4], int *shift))[4];
/* g = T x L for every vector of t (one of linear transfer tr's sets) with tr's CPU kernel (its light,
 * else its light_range) on nthreads (0: all), a light near the float range run scaled
 * (transfer_light_scaled_copy). */
void transfer_light(const prt_transfer *tr, const prt_transport *t, const float (*L)[4], float *g, int nthreads);
#endif
