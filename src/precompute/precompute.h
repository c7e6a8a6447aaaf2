/* precompute.h - the precomputation pipeline: BRDF factorization, visibility, direct transport
 * (Eq. 3), its projection and compression by the linear representation, interreflection passes,
 * and a view-dependent representation's own passes for the glossy materials that take it.
 *
 * Usage:
 *     precompute_desc d = { 0 };                         // zero: what `prt precompute FILE` does
 *     if (precompute_desc_apply_scene(&d, &scene, PRECOMPUTE_SCENE_ALL, &err)) ...  // its keys
 *     prt_data out;
 *     if (precompute_run(&scene, &d, &out, &err)) puts(err.msg);
 *     // scene now belongs to out.scene
 *
 * Defaults. A zeroed desc is the product's behaviour: the table's default linear representation
 * (Haar wavelets) with its default options (transfer.h: empty options are what the command line
 * does with no flag; Haar: the solid-angle measure, the expected-error selection, the budget
 * chosen by the plan, smooth faces), N = 128 at 8 bits, visibility at 128, up to
 * PRECOMPUTE_DEFAULT_BOUNCES interreflection passes stopped by the energy threshold, glossy
 * materials measured (auto) against the default view-dependent representation. A scene's own keys
 * (its light prior, its refinement) are not read unless precompute_desc_apply_scene says so; its
 * lights come with it (the plan lists them; they are shaded at runtime).
 *
 * Representations are named, never switched on: desc.basis names the linear one and basis_options
 * holds its options ("key=value,..."), desc.view and view_options the view-dependent one used for
 * glossy materials; each parses and validates its own options (an error names the key) and
 * describes itself in the plan. precompute_desc_check validates a desc (and every option) without
 * a scene, as the CLI does before loading anything.
 *
 * Direct pass, per vertex (both cores, dynamic scheduling): the visibility cube at vis_res (128) is
 * ray cast; for each 64-res lighting texel j,
 *   T_k(x, j) = g_k(w_j) * sum over its 2x2 sub-texels s of V(x, w_s) max(n.w_s, 0) dw_s
 * (Eq. 3 integrated over the texel with exact solid angles; g_k is smooth at the light maps' 48x48
 * resolution, so it is evaluated once at the texel centre); each cube is projected by the linear
 * representation (its project_transport) and stored by its compress (N best, quantized). Texels
 * the representation names (transfer_texel_rays: Haar's light prior) are integrated along rays
 * placed as the light lies inside them instead.
 *
 * Effects plan (printed to stderr unless quiet, kept in out->plan for `prt info`):
 * K per material from its singular values (Lambertian: 1; glossy: the smallest K meeting
 * term_error, else max_terms); then the path of every material, with the reason
 * (precompute_choose_path):
 *   - Lambert: the linear transfer with K = 1;
 *   - glossy (glossy auto): the SVD path when its error at that K, in the view-dependent
 *     representation's own measure (its fit op), is at most PRECOMPUTE_SVD_SMALL, or when that
 *     representation is no better; else the view path: the material's factor becomes the K = 1
 *     factor of its kd/pi alone (so the linear transfer holds the diffuse part, all-frequency
 *     shadows kept) and the view-dependent transfer holds its specular part (filled by its own
 *     passes after the linear ones);
 *   - a BRDF the view-dependent representation cannot fit stays SVD (its fit says why);
 *   - glossy svd forces the SVD path, glossy view the view path wherever a fit exists; with no
 *     view-dependent representation (view "none", or none in the table) glossy materials stay SVD.
 * out gets the linear transfer (every material) and, when some material took the view path, the
 * view-dependent transfer (those materials). Interreflections only if at least 0.5% of the
 * visibility rays of a 200-vertex sample hit geometry (re-checked on the full pass), up to
 * bounces (default 3) passes continuing while one carries >= bounce_threshold of the direct
 * energy (gather_energy ratio; the pass that falls below is still added); force_bounces 1 does
 * max(bounces, 1) passes regardless, -1 none (`--bounces 0`). The view-dependent transfer gets the
 * same number of reflection passes at most (1 + bounces) and the same threshold. A time estimate
 * comes from the sample, which is computed first and kept. Local lights (planfx.h): their one
 * bounce (two VSGLs) where it carries at least PLANFX_BOUNCE_MIN (2%) of their direct light at the
 * sample's vertices, measured by PLANFX_RAYS rays each; their indirect highlights where a glossy
 * material's vertices receive at least PLANFX_HIGHLIGHT_MIN of it by one bounce; the plan prints
 * each share; force_local_bounce and force_highlights override either way.
 *
 * Refinement (stage refine, after the BRDFs' paths are chosen and before the passes): the scene's
 * mesh is refined where visibility changes (refine.h; Laurijssen et al. 2011 section 6.1) as asked
 * (refine_threshold > 0, the floor's by default), else, unless force_refine is -1, the models up
 * to PLANFX_MODEL_GROWTH times their vertices within the room the file's and the view grid's byte
 * budgets leave (planfx.h; the floor too with force_refine 1); the refined mesh
 * is what is precomputed, stored and drawn; the plan's first lines say vertices before and after,
 * models and floor, and the time.
 *
 * Resuming (desc.checkpoint, desc.resume): the direct pass, each gathering pass and a
 * view-dependent transfer's passes log every finished vertex (or slice) to the checkpoint, flushed
 * every CKPT_INTERVAL_PERCENT (2%) of the vertices; a resumed run restores them (saying how many
 * per pass on stderr unless quiet), computes the rest and gives the same transfers, mesh,
 * materials and statistics as an uninterrupted run (only the timings differ, as between any two
 * runs). A view-dependent transfer's pass ids come from its slot (checkpoint.h).
 *
 * Sharding (desc.shard with more than one rank, shard.h): every rank runs the same stages on the
 * same scene; the planning sample is computed on every rank and its per-vertex times cut the rest
 * of the direct pass into one contiguous vertex range per rank of about equal cost (rank 0 cuts,
 * all follow); each gathering pass is cut by the previous gathering pass's per-vertex times (the
 * first by 1 + the vertex's vector count). After each pass the ranks exchange their vectors and
 * statistics, so every rank holds the whole pass and the result is the one-process result bit for
 * bit. A view-dependent transfer splits and exchanges its own passes (shard.h). Rank 0's progress
 * counts every rank's vertices, and each split pass's balance (shard_balance) is kept for the
 * timing summary. Not combined with a checkpoint.
 *
 * Cancelling: the progress callback returning false stops the run with error "cancelled". */
#ifndef PRT_PRECOMPUTE_H
#define PRT_PRECOMPUTE_H
#include "prtfile.h"

/* Where glossy materials go (the effects plan, per material; Lambert always gets the linear K = 1). */
typedef enum precompute_glossy {
    PRECOMPUTE_GLOSSY_AUTO = 0, /* measured per material: SVD when its error at the allowed K is small, else the view path */
    PRECOMPUTE_GLOSSY_SVD,      /* the separable factorization for every glossy material (the paper's) */
    PRECOMPUTE_GLOSSY_VIEW,     /* the view-dependent representation for every material it fits (the others stay SVD) */
} precompute_glossy;

/* A glossy material whose SVD error at the allowed K (the view-dependent representation's measure:
 * transfer_fit.svd_err) is at most this stays on the SVD path (auto). */
#define PRECOMPUTE_SVD_SMALL 0.10f
/* Interreflection passes at most when precompute_desc.bounces is 0 (the adaptive stop decides). */
#define PRECOMPUTE_DEFAULT_BOUNCES 3

typedef struct precompute_desc {
    int N;                  /* coefficients per vector of the linear transfer; 0: its default (128) */
    int max_terms;          /* K cap for glossy materials; 0: 4 */
    float term_error;       /* > 0: smallest K meeting this relative BRDF error (capped) */
    int qbits;              /* 8 (default), 16, 32 */
    int vis_res;            /* 0: 128 (64 * supersampling 2); 64, 128, 256 allowed */
    brdf_param param;       /* BRDF parameterization */
    const char *basis;      /* the linear representation by name (transfer.h's table, kind TRANSFER_LINEAR);
                             * NULL: the table's default (Haar wavelets) */
    const char *basis_options;  /* its options, "key=value,..." (its option table); NULL: its defaults */
    precompute_glossy glossy;   /* auto (default), svd or view */
    const char *view;       /* the view-dependent representation for glossy materials (kind TRANSFER_VIEW);
                             * NULL: the table's default (vMF lobes); "none": none (glossy stays SVD) */
    const char *view_options;   /* its options; NULL: its defaults */
    const char *light_prior;    /* probe files, comma-separated, the output will mostly be lit by; NULL: none.
                             * The linear representation weighs its choices by them where it can (Haar: the
                             * expected-error selection, light-weighted texels, the refit); read during the run */
    bool light_prior_scene; /* light_prior is the scene's own key (precompute_desc_apply_scene): a
                             * representation that cannot use it leaves it out with a note, not an error */
    int bounces;            /* maximum interreflection passes; 0: PRECOMPUTE_DEFAULT_BOUNCES (none: force_bounces -1) */
    int gather_res;         /* 0: 32 */
    float bounce_threshold; /* stop when a pass carries less than this fraction of the direct energy; 0: 0.01 */
    bool keep_direct;       /* also keep the direct-only transport in the file (viewer toggle; doubles the size) */
    bool no_open_sky;       /* store Lambertian vectors whole, without the open sky split (opensky.h; the default
                             * splits: the vectors hold what occluders block, the runtime adds the open sky) */
    bool no_fold;           /* keep the cosine in the floor's blocked parts (the default folds it into the light in
                             * a file without interreflections: opensky.h "The floor's fold") */
    int force_bounces;      /* 1: always do `bounces` passes; -1: never; 0: as the plan decides */
    int force_local_bounce; /* the local lights' one bounce in the plan: 1 on, -1 off, 0 as measured (planfx.h) */
    int force_highlights;   /* their indirect highlights: 1 on, -1 off, 0 as measured */
    int force_refine;       /* -1: no refinement whatever refine_threshold says; otherwise refine_threshold > 0
                             * asks for it, else the plan refines the models and measures the
                             * receivers (planfx.h) and, with 1, refines the floor where they need it
                             * (0: it only says so) */
    float refine_threshold; /* > 0: first refine the mesh where visibility changes (refine.h), splitting edges whose
                             * masks differ in more than this share; 0: as the plan decides */
    int refine_budget;      /* with refinement, the most vertices after it; 0: 1.5x the scene's */
    int refine_parts;       /* refine.h's parts: 0 the floor's edges when there is a floor, REFINE_ALL models too */
    int nthreads;           /* 0: all cores (results do not depend on it) */
    const char *checkpoint; /* non-NULL: log the direct and gathering passes' vertices to this file
                             * (checkpoint.h), so a killed run can resume; the caller removes it
                             * once the output is written */
    bool resume;            /* continue from `checkpoint` when it exists (one of other inputs or
                             * options is refused); else it is started anew */
    int checkpoint_kill;    /* test hook: SIGKILL after this many checkpoint flushes (0: never) */
    float memory_gb;        /* memory budget: when the direct pass's staged vectors (nvecs x N x 16 bytes;
                             * transport_staging_bytes: 3.1x with a shared budget) exceed half of it, they (and
                             * each gathering pass's) stream to a temporary file in stream_dir, dropped from
                             * memory as vertices finish (transport_stage_to_file; the same bits), and the
                             * finished sets (each pass, the running sum) move to mapped files that the
                             * gathering passes read, their pages dropped every 1% (transport_map_to_file);
                             * 0: half the machine's physical memory */
    const char *stream_dir; /* that file's folder (unlinked at once: nothing is left); NULL: "." */
    struct prt_shard *shard; /* MPI ranks to split the passes across (shard.h); NULL: this process alone */
    int shard_fail;         /* test hook: rank shard_fail - 1 fails after its share of the direct pass (0: none) */
    prt_progress_fn progress;
    void *progress_user;
    bool quiet;             /* do not print the plan */
} precompute_desc;

/* The scene's own keys (scene.h) precompute_desc_apply_scene may apply. */
#define PRECOMPUTE_SCENE_LIGHT_PRIOR 1u     /* "light_prior": its probes, when desc names none */
#define PRECOMPUTE_SCENE_REFINE 2u          /* "refine": its refinement, when it asks for one */
#define PRECOMPUTE_SCENE_ALL (PRECOMPUTE_SCENE_LIGHT_PRIOR | PRECOMPUTE_SCENE_REFINE)

/* Applies the scene's keys in `keys` to d as `prt precompute SCENE` does when no flag replaces them:
 * its light prior (d->light_prior points into s, which precompute_run may take: it copies what it
 * reads first) and its refinement (threshold, budget, parts; refine.h's defaults for what it leaves
 * out). 0, or -1 with err (keys names no key). */
int precompute_desc_apply_scene(precompute_desc *d, const prt_scene *s, unsigned keys, prt_error *err);

/* Validates desc as precompute_run will (every field, the representations' names and options) without
 * a scene. 0, or -1 with one line in err. */
int precompute_desc_check(const precompute_desc *desc, prt_error *err);

/* The path of one material (stage choose; precompute_run prints it per material). */
typedef enum precompute_path {
    PRECOMPUTE_PATH_LAMBERT = 0,    /* Lambertian: the linear transfer with K = 1 */
    PRECOMPUTE_PATH_SVD,            /* the linear transfer with the material's K-term SVD (Eq. 5) */
    PRECOMPUTE_PATH_VIEW,           /* the linear transfer with kd/pi alone (K = 1) + the view-dependent one */
} precompute_path;

/* Decides material p's path (f: its factorization at the K the plan allows) under mode, as the
 * header comment says: linear names the linear representation (for the plan's words), view and its
 * configuration vcfg the view-dependent one (NULL: none), whose fit op measures both errors. why gets
 * the plan's clause. Returns 0, or -1 with err when the fit fails. Pure: no globals. */
int precompute_choose_path(const brdf_params *p, const brdf_factor *f, precompute_glossy mode, const transfer_ops *linear,
                           const transfer_ops *view, const transfer_config *vcfg, precompute_path *path, char *why, size_t cap,
                           prt_error *err);

/* Runs the pipeline. Takes ownership of *scene (zeroed on return). Returns 0 or -1. */
int precompute_run(prt_scene *scene, const precompute_desc *desc, prt_data *out, prt_error *err);
#endif
