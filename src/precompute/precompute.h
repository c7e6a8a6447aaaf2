/* precompute.h - the precomputation pipeline: BRDF factorization, visibility,
 * direct transport (Eq. 3), wavelet compression, and interreflection passes.
 *
 * Usage:
 *     precompute_desc d = { .N = 128 };    // zero fields mean defaults
 *     prt_data out;
 *     if (precompute_run(&scene, &d, &out, &err)) puts(err.msg);
 *     // scene now belongs to out.scene
 *
 * Direct pass, per vertex (both cores, dynamic scheduling): the visibility cube
 * at vis_res (128) is ray cast; for each 64-res lighting texel j,
 *   T_k(x, j) = g_k(w_j) * sum over its 2x2 sub-texels s of V(x, w_s) max(n.w_s, 0) dw_s
 * (Eq. 3 integrated over the texel with exact solid angles; g_k is smooth at the
 * light maps' 48x48 resolution, so it is evaluated once at the texel centre);
 * each cube is projected by the transfer representation (Haar per face, or SH;
 * transfer.h), the N largest coefficients kept, quantized.
 *
 * Effects plan (printed to stderr unless quiet, kept in out->plan for `prt info`):
 * K per material from its singular values (Lambertian: 1; glossy: the smallest K meeting
 * term_error, else max_terms); then the path of every material, with the reason:
 *   - Lambert: the sparse transfer (desc.basis, else Haar) with K = 1;
 *   - glossy (glossy auto): the SVD path when its error at that K, in the lobe fit's measure
 *     (lobefit_factor_error, whole slice), is at most PRECOMPUTE_SVD_SMALL, or when one vMF
 *     lobe (lobefit_fit) is no better; else Haar diffuse + vMF specular: the material's factor
 *     becomes the K = 1 factor of its kd/pi alone (so the sparse transfer holds the diffuse
 *     part, all-frequency shadows kept) and a second transfer, "vmf", holds its specular lobes
 *     (filled by that representation's ops->precompute after the sparse passes);
 *   - Ashikhmin-Shirley and Lafortune stay SVD (no ASG or multi-lobe fit exists here);
 *   - glossy svd forces the SVD path, glossy vmf the vMF path wherever a lobe fit exists;
 *     a build whose table has no "vmf" says so and uses the SVD (auto; vmf asked for fails).
 * out gets the sparse transfer (every material) and, when some material took the vMF path,
 * the vmf transfer (those materials). Interreflections only if at least 0.5% of the
 * visibility rays of a 200-vertex sample hit geometry (re-checked on the full pass), up to
 * bounces (default 3) passes continuing while one carries >= bounce_threshold of the
 * direct energy (gather_energy ratio; the pass that falls below is still added);
 * force_bounces 1 does max(bounces, 1) passes regardless, -1 none (`--bounces 0`). The vmf
 * transfer gets the same number of reflection passes at most (1 + bounces) and the same
 * threshold. A time estimate comes from the sample, which is computed first and kept.
 *
 * Refinement (refine_threshold > 0, stage refine, before everything else): the scene's
 * mesh is refined where visibility changes (refine.h; Laurijssen et al. 2011 section 6.1),
 * and the refined mesh is what is precomputed, stored and drawn; the plan's first line
 * says vertices before and after, models and floor, and its time.
 *
 * Resuming (desc.checkpoint, desc.resume): the direct pass, each gathering pass and the vMF
 * passes log every finished vertex (vMF gathering: slice) to the checkpoint, flushed every
 * CKPT_INTERVAL_PERCENT (2%) of the vertices; a resumed run restores them (saying how many per
 * pass on stderr unless quiet), computes the rest and gives the same transfers, mesh, materials
 * and statistics as an uninterrupted run (only the timings differ, as between any two runs).
 *
 * Sharding (desc.shard with more than one rank, shard.h): every rank runs the same stages on the
 * same scene; the planning sample is computed on every rank and its per-vertex times cut the rest
 * of the direct pass into one contiguous vertex range per rank of about equal cost (rank 0 cuts,
 * all follow); each gathering pass is cut by the previous gathering pass's per-vertex times (the
 * first by 1 + the vertex's vector count). After each pass the ranks exchange their vectors and
 * statistics, so every rank holds the whole pass and the result is the one-process result bit for
 * bit. The vMF passes are split by count (vmfpass.c) and exchanged the same way. Rank 0's progress
 * counts every rank's vertices, and each split pass's balance (shard_balance) is kept for the
 * timing summary. Not combined with a checkpoint.
 *
 * Cancelling: the progress callback returning false stops the run with error "cancelled". */
#ifndef PRT_PRECOMPUTE_H
#define PRT_PRECOMPUTE_H
#include "prtfile.h"

/* Where glossy materials go (the effects plan, per material; Lambert always gets Haar K = 1). */
typedef enum precompute_glossy {
    PRECOMPUTE_GLOSSY_AUTO = 0, /* measured per material: SVD when its error at the allowed K is small, else vMF */
    PRECOMPUTE_GLOSSY_SVD,      /* the separable factorization for every glossy material (the paper's) */
    PRECOMPUTE_GLOSSY_VMF,      /* vMF lobes for every material with a lobe fit (the others stay SVD) */
} precompute_glossy;

/* A glossy material whose SVD error at the allowed K (lobefit_factor_error: the whole slice, relative
 * L2, mean over view elevations) is at most this stays on the SVD path (auto). */
#define PRECOMPUTE_SVD_SMALL 0.10f
/* Interreflection passes at most when precompute_desc.bounces is 0 (the adaptive stop decides). */
#define PRECOMPUTE_DEFAULT_BOUNCES 3

/* precompute_desc.budget: the plan picks (pc_choose). A shared budget stages 2N candidates per vector
 * (6.4 KB against 2 KB) and costs about 13% more CPU (docs/design/shadows.md); above this many vectors it
 * would take the 1 M-vertex scene (1.1 M vectors) past issue 13's 25-minute direct pass and triple its
 * staging, so the plan keeps the paper's per-vector N there. */
#define PRECOMPUTE_BUDGET_AUTO (-1)
#define PRECOMPUTE_SHARED_MAX_VECS 500000

typedef struct precompute_desc {
    int N;                  /* coefficients per vector; 0: 128 */
    int max_terms;          /* K cap for glossy materials; 0: 4 */
    float term_error;       /* > 0: smallest K meeting this relative BRDF error (capped) */
    int qbits;              /* 8 (default), 16, 32 */
    int vis_res;            /* 0: 128 (64 * supersampling 2); 64, 128, 256 allowed */
    brdf_param param;       /* BRDF parameterization */
    const char *basis;      /* transfer representation (transfer.h): NULL = "haar" (the paper), "sh" (baseline) */
    int basis_order;        /* its order where it has one: SH bands 3..10 (0: 6) */
    int measure;            /* Haar: 0 wavelets of the texels (the paper's), or TRANSFER_MEASURE_SOLID_ANGLE of the
                             * transport per steradian (transfer.h; what `prt precompute` asks for unless
                             * --texel-measure). 0 stays the library's default so that callers who build light
                             * vectors with light_from_cube rather than transfer_light_vector keep working. */
    int select;             /* Haar with the solid-angle measure: which N coefficients a vector keeps,
                             * TRANSPORT_SELECT_MAGNITUDE (0, the paper's) or TRANSPORT_SELECT_EXPECTED
                             * (transport.h; what `prt precompute` asks for unless --select magnitude) */
    const float (*light_prior)[4]; /* NULL, or with the expected-error selection of Haar per steradian the
                             * selection's weight per coefficient and channel, [CUBE_TEXELS][4] (prior.h:
                             * a probe's RMS light over its yaw orbit; BORROWED, read during the run) */
    const char *light_prior_name; /* what the plan calls it (the probe's file name); NULL: "given" */
    const struct prior_rays *prior_rays; /* NULL, or the light-weighted texels (prior.h): the direct pass integrates
                             * each of these texels along the light inside it rather than over its box
                             * (BORROWED, read during the run; the direct pass of the projected bases, Haar or
                             * SH, a vMF material's diffuse part included, not its lobes) */
    const struct prior_texels *prior_texels; /* NULL, or with light_prior and a per-vector budget: its probes' light per
                             * texel (prior.h), to which each vector's kept values are refit (refit.h; BORROWED,
                             * read while the run sets up) */
    bool no_refit;          /* keep the kept values (and the corrections) even with prior_texels (--no-refit) */
    bool box_texels;        /* for the CLI: make no prior_rays from the light prior (--box-texels); the library
                             * reads prior_rays only */
    bool smooth_faces;      /* Haar with the solid-angle measure: a face of a vector with no occluder edge gets its
                             * dropped part back weighted by the transport, not per block (transport.h
                             * smooth_faces; what `prt precompute` asks for unless --no-smooth-faces) */
    int budget;             /* Haar: who shares the N x vectors coefficients (transport_budget): 0 every vector its
                             * own N (the paper's), TRANSPORT_BUDGET_SHARED / _RELATIVE one threshold over all
                             * of them, a vector budget / TRANSPORT_SHARED_MIN to TRANSPORT_SHARED_CAP x N
                             * (docs/design/shadows.md); PRECOMPUTE_BUDGET_AUTO (what `prt precompute` asks for unless
                             * --budget says): per vector with a light_prior, else shared up to
                             * PRECOMPUTE_SHARED_MAX_VECS vectors, else per vector */
    int bounces;            /* maximum interreflection passes; 0: PRECOMPUTE_DEFAULT_BOUNCES (none: force_bounces -1) */
    int gather_res;         /* 0: 32 */
    float bounce_threshold; /* stop when a pass carries less than this fraction of the direct energy; 0: 0.01 */
    bool keep_direct;       /* also keep the direct-only transport in the file (viewer toggle; doubles the size) */
    int force_bounces;      /* 1: always do `bounces` passes; -1: never; 0: as the plan decides */
    float refine_threshold; /* > 0: first refine the mesh where visibility changes (refine.h), splitting edges whose
                             * masks differ in more than this share; 0: no refinement (the default for now) */
    int refine_budget;      /* with refinement, the most vertices after it; 0: 1.5x the scene's */
    int refine_parts;       /* refine.h's parts: 0 the floor's edges when there is a floor, REFINE_ALL models too */
    precompute_glossy glossy; /* auto (default), svd or vmf */
    transfer_config vmf;    /* the vmf transfer's lobes / level / samples (zero: its defaults) */
    int nthreads;           /* 0: all cores (results do not depend on it) */
    const char *checkpoint; /* non-NULL: log the direct and gathering passes' vertices to this file
                             * (checkpoint.h), so a killed run can resume; the caller removes it
                             * once the output is written */
    bool resume;            /* continue from `checkpoint` when it exists (one of other inputs or
                             * options is refused); else it is started anew */
    int checkpoint_kill;    /* test hook: SIGKILL after this many checkpoint flushes (0: never) */
    float memory_gb;        /* memory budget (issue 13): when the direct pass's staged vectors (nvecs x N x 16
                             * bytes; transport_staging_bytes: 3.1x with a shared budget) exceed half of it, they (and each gathering pass's) stream to a temporary
                             * file in stream_dir, dropped from memory as vertices finish
                             * (transport_stage_to_file; the same bits), and the finished sets (each pass, the
                             * running sum) move to mapped files that the gathering passes read, their pages
                             * dropped every 1% (transport_map_to_file); 0: half the machine's physical memory */
    const char *stream_dir; /* that file's folder (unlinked at once: nothing is left); NULL: "." */
    struct prt_shard *shard; /* MPI ranks to split the passes across (shard.h); NULL: this process alone */
    int shard_fail;         /* test hook: rank shard_fail - 1 fails after its share of the direct pass (0: none) */
    prt_progress_fn progress;
    void *progress_user;
    bool quiet;             /* do not print the plan */
} precompute_desc;

/* The path of one material (stage choose; precompute_run prints it per material). */
typedef enum precompute_path {
    PRECOMPUTE_PATH_LAMBERT = 0,    /* Lambertian: the sparse transfer with K = 1 */
    PRECOMPUTE_PATH_SVD,            /* the sparse transfer with the material's K-term SVD (Eq. 5) */
    PRECOMPUTE_PATH_VMF,            /* the sparse transfer with kd/pi alone (K = 1) + the vmf transfer's lobes */
} precompute_path;

/* Decides material p's path (f: its factorization at the K the plan allows) under mode, as the
 * header comment says; have_vmf: the table has a vmf representation. why gets the plan's clause
 * (the measured errors). Returns 0, or -1 with err when the lobe fit fails. Pure: no globals. */
int precompute_choose_path(const brdf_params *p, const brdf_factor *f, precompute_glossy mode, bool have_vmf,
                           precompute_path *path, char *why, size_t cap, prt_error *err);

/* Runs the pipeline. Takes ownership of *scene (zeroed on return). Returns 0 or -1. */
int precompute_run(prt_scene *scene, const precompute_desc *desc, prt_data *out, prt_error *err);
#endif
