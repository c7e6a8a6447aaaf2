/* cli_precompute.c - `prt precompute`: scene -> precompute pipeline -> .prt file,
 * with a progress bar and a per-stage timing summary. */
#include "cli.h"
#include "cli_args.h"
#include "checkpoint.h"
#include "precompute.h"
#include "light.h"
#include "prior.h"
#include "prtfile.h"
#include "refine.h"
#include "scene.h"
#include "shard.h"
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *k_cmd = "precompute";

static void help(void) {
    puts("usage: prt precompute MODEL.obj|SCENE.json -o OUT.prt [options]\n"
         "\n"
         "scene:\n"
         "  --material SPEC        BRDF of an OBJ model (default lambert:kd=0.8); see `prt brdf --help`\n"
         "  --floor [VERTS]        add a diffuse floor under the model (default 31000 vertices)\n"
         "  --no-floor             no floor even if the JSON scene has one\n"
         "  --floor-material SPEC  floor BRDF (default lambert:kd=0.7)\n"
         "BRDF factorization (section 3.3):\n"
         "  --terms K              BRDF terms for glossy materials, the cap (default 4; Lambert always 1)\n"
         "  --term-error E         smallest K whose relative BRDF error is <= E (capped by --terms;\n"
         "                         default: off, K = --terms)\n"
         "  --polar                polar parameterization (Eq. 11) instead of the uniform grid (Eq. 10)\n"
         "transport (section 4.1):\n"
         "  --coeffs N             wavelet coefficients kept per transport vector (default 128)\n"
         "  --quant 8|16|32        coefficient quantization bits (default 8; 32 = float)\n"
         "  --vis-res R            visibility cube resolution: 64, 128 (default; 2x2 supersampling) or 256\n"
         "  --sh ORDER             spherical harmonics of ORDER (3..10) instead of Haar wavelets (baseline)\n"
         "  --texel-measure        Haar wavelets of the texels with their solid angle (the paper's;\n"
         "                         default: of the transport per steradian, steadier under a sun)\n"
         "  --select expected|magnitude  which N coefficients a vector keeps: expected (default) the\n"
         "                         N largest weighted by the light's typical energy per Haar level\n"
         "                         (the least expected error under probes with a sun); magnitude\n"
         "                         the N largest (the paper's; what --texel-measure and --sh use)\n"
         "  --light-prior PROBE[,PROBE...]  weigh the expected-error selection by PROBE's light: each\n"
         "                         coefficient by its RMS as PROBE turns about +y (the viewer's yaw), so\n"
         "                         a shadow edge keeps its detail where the probe's sun can be (README\n"
         "                         \"Shadows\"; the file serves any probe, best the ones named); a\n"
         "                         list weighs each probe the same. Default: none, or the probes a JSON\n"
         "                         scene's \"light_prior\" key names (unless this flag or the next says\n"
         "                         otherwise)\n"
         "  --no-light-prior       not the scene's light_prior: the per-level weights\n"
         "  --box-texels           with a light prior, integrate every lighting texel over its area (default: the\n"
         "                         prior's brightest texels along rays placed as its light lies inside them)\n"
         "  --no-refit             with a light prior, keep the kept coefficients' own values, put back as\n"
         "                         below (default: refit to the prior's light per texel, the least expected\n"
         "                         error of T.L as its probes turn; a per-vector budget only; README \"Shadows\")\n"
         "  --no-smooth-faces      put what truncation drops back per 16x16-texel block only (default:\n"
         "                         weighted by the transport on faces with no occluder edge, steadier\n"
         "                         on an open floor under a turning sun)\n"
         "  --budget shared|vector|relative  how the N x vectors coefficients are shared out:\n"
         "                         shared: the best weights over all vectors win, each vector keeping\n"
         "                         N/2 to 2N (a shadow edge more, a smooth one fewer; the same storage\n"
         "                         at most); vector: each vector its own N (the paper's); relative:\n"
         "                         shared, each weight taken over its vector's own total. shared and\n"
         "                         relative are for Haar wavelets only. Default: shared up to 500,000\n"
         "                         vectors, vector beyond (a shared budget's staging costs memory and\n"
         "                         time) and vector with a light prior\n"
         "glossy materials (the effects plan prints each material's path and why):\n"
         "  --glossy auto|svd|vmf  auto (default): the SVD where its error at K is <= 10%, else Haar K = 1\n"
         "                         diffuse + vMF specular lobes (laurijssen-2011); svd: always the SVD;\n"
         "                         vmf: vMF lobes wherever a lobe fit exists (phong, blinn, ggx, beckmann)\n"
         "  --lobes I              vMF lobes per view and reflection pass, 1..4 (default 2)\n"
         "  --view-level L         geodesic view grid: icosahedron subdivided L times, 0..6 (default 2:\n"
         "                         162 views)\n"
         "  --lobe-samples S       rays per (vertex, view) in the vMF passes, 4..4096 (default 64)\n"
         "interreflections (section 3.2, 4.2):\n"
         "  --bounces B            at most B interreflection passes (default 3, stopped by the energy\n"
         "                         threshold; 0: none)\n"
         "  --gather-res R         gathering cube resolution (default 32)\n"
         "  --bounce-threshold T   stop when a pass carries < T of the direct energy (default 0.01)\n"
         "  --force-bounces        do all B passes even if the plan would skip them\n"
         "  --no-bounces           never do interreflection passes\n"
         "  --keep-direct          also store the direct-only transport (for render --direct-only and\n"
         "                         the viewer's direct/bounces toggle; about doubles the file)\n"
         "adaptive refinement (Laurijssen et al. 2011, section 6.1; off unless asked for here or by a\n"
         "JSON scene's \"refine\"):\n"
         "  --refine               before the transport, split the edges whose vertices' visibility\n"
         "                         masks differ in more than 0.5% of directions, iteratively\n"
         "  --refine-threshold F   that share, 0 < F < 1 (default 0.005; turns refinement on; 0: off)\n"
         "  --refine-budget V      at most V vertices after refinement (default 1.5x the scene's; turns it on)\n"
         "  --refine-models        refine the models' edges too (default: the floor's, where there is one)\n"
         "  --no-refine            no refinement, not even a JSON scene's \"refine\" (any refine flag\n"
         "                         replaces the scene's)\n"
         "other:\n"
         "  --resume               continue the run killed while writing OUT.prt from its checkpoint\n"
         "                         OUT.prt.ckpt (written every 2% of the vertices of each pass, removed\n"
         "                         on success); the file is the one an uninterrupted run writes\n"
         "  --threads T            worker threads (default: all cores; the file does not depend on it)\n"
         "  --memory GB            memory budget: above half of it the direct pass streams its finished\n"
         "                         vectors through a temporary file beside OUT.prt (default: half of\n"
         "                         this machine's memory; the file is the same)\n"
         "  --quiet                no progress output\n"
         "\n"
         "Under mpirun or srun (README \"Running on a cluster\") the passes are split across the ranks,\n"
         "rank 0 writes OUT.prt (the same file as one process) and --resume is refused.\n");
}

/* Under MPI, each split pass's balance (shard_balance): the items, wall and CPU time of every
 * rank (of the fastest and slowest beyond 16 ranks), and the slowest rank's wall time over the mean. */
static void balance(const prt_shard *sh) {
    int P = shard_size(sh);
    const char *name, *unit;
    const shard_rank_stats *b;
    if (P > 1 && shard_balance(sh, 0, &name, &unit)) fprintf(stderr, "balance over %d ranks\n", P);
    for (int i = 0; (b = shard_balance(sh, i, &name, &unit)); i++) {
        long n = 0;
        double sum = 0;
        int fast = 0, slow = 0;
        for (int r = 0; r < P; r++) {
            n += b[r].items, sum += b[r].seconds;
            if (b[r].seconds < b[fast].seconds) fast = r;
            if (b[r].seconds > b[slow].seconds) slow = r;
        }
        fprintf(stderr, "  %s: %ld %s, slowest rank %.2fx the mean time\n", name, n, unit, sum > 0 ? b[slow].seconds * P / sum : 1.0);
        for (int r = 0; r < P; r++)
            if (P <= 16 || r == fast || r == slow)
                fprintf(stderr, "    rank %-4d %10ld %-8s %9.2fs %9.2fs CPU\n", r, b[r].items, unit, b[r].seconds, b[r].cpu);
    }
}

/* One line of the timing summary: the stage and its time as a person reads it (tools/bench.sh
 * reads the figure back: "850 ms", "1.7 s", "2 min 05 s", "1 h 02 min"). */
static void stage_line(const char *name, double seconds) {
    char t[48];
    prt_format_duration(t, sizeof t, seconds);
    fprintf(stderr, "  %-28s %12s\n", name, t);
}

/* The per-stage timing summary, the ranks' balance and the closing line (stderr). */
static void summary(const char *out, const prt_data *data, const prt_shard *sh, double t_load, double t_prior, double t0) {
    struct stat st;
    double mb = stat(out, &st) == 0 ? st.st_size / 1e6 : 0;
    const prt_stats *s = &data->stats;
    fprintf(stderr, "\ntiming summary\n");
    stage_line("scene load", t_load);
    if (t_prior > 0) stage_line("light prior", t_prior);
    if (s->t_refine > 0) stage_line("refinement", s->t_refine);
    stage_line("BRDF factorization", s->t_brdf);
    stage_line("visibility (ray casting)", s->t_visibility);
    stage_line("transport+wavelet+quant.", s->t_transport);
    for (int b = 0; b < s->bounces && b < PRT_MAX_BOUNCES; b++) {
        char name[64];
        snprintf(name, sizeof name, "bounce %d (%.2f%% energy)", b + 1, 100 * s->bounce_energy[b]);
        stage_line(name, s->t_bounce[b]);
    }
    if (s->t_vmf > 0) stage_line("vMF lobes (all passes)", s->t_vmf);
    stage_line("writing", s->t_write);
    stage_line("total", prt_now() - t0);
    balance(sh);
    const prt_transport *t = &prt_data_transfer(data)->transport;
    fprintf(stderr, "wrote %s: %.1f MB, %d vertices, %d transport vectors, N = %d, %d-bit", out, mb, t->nverts,
            t->nvecs, t->budget ? t->budget : t->N, t->qbits);
    if (t->budget) fprintf(stderr, ", shared (a vector up to %d)", t->N);
    for (int i = 0; i < data->ntransfers; i++)
        if (data->transfers[i].ops->bytes && !data->transfers[i].ops->light_range)
            fprintf(stderr, "; %s %.1f MB", data->transfers[i].ops->name, data->transfers[i].ops->bytes(&data->transfers[i]) / 1e6);
    fputc('\n', stderr);
}

/* The checkpoint beside out (OUT.ckpt, into ck[4096]; ck stays "" -> none for an empty out); an
 * earlier run's checkpoint replaced without --resume is said on stderr. (The temporaries killed
 * runs left are removed before the work by cli_check_files.) */
static void checkpoint_setup(const char *out, precompute_desc *pd, char *ck, bool quiet) {
    if (!*out) return;   /* -o "": the write fails as before (issue 12 item 3), and leaves no ".ckpt" */
    snprintf(ck, 4096, "%s.ckpt", out);
    pd->checkpoint = ck;
    const char *kill_after = getenv("PRT_CHECKPOINT_KILL");   /* test hook (checkpoint.h) */
    pd->checkpoint_kill = kill_after ? atoi(kill_after) : 0;
    if (!pd->resume && !quiet && access(ck, F_OK) == 0)
        fprintf(stderr, "starting anew: %s of an earlier run is replaced (--resume continues it)\n", ck);
}

enum { USE_SCENE_PRIOR = 1, USE_SCENE_REFINE = 2 };   /* what the command line leaves to the scene */
static int run_rank(const char *in, const char *out, const scene_desc *sd, precompute_desc *pd, bool quiet, unsigned use_scene,
                    double t0, double t_prior, bool *stray);

/* Loads the probes of the comma-separated list `paths` into ps (at most PRIOR_MAX_PROBES) and their
 * base names, comma-joined, into name[cap]. Returns how many, or -1 having said why (exit 1/2). */
static int prior_probes(const char *paths, prt_probe *ps, char *name, size_t cap, int *status) {
    int n = 0;
    name[0] = 0;
    for (const char *s = paths; *s; ) {
        size_t len = strcspn(s, ",");
        char path[4096];
        if (len == 0 || len >= sizeof path || n == PRIOR_MAX_PROBES) {
            cli_error(k_cmd, "--light-prior %s: a comma-separated list of 1 to %d probe files", paths, PRIOR_MAX_PROBES);
            *status = 2;
            return -1;
        }
        memcpy(path, s, len);
        path[len] = 0;
        if (cli_load_probe(k_cmd, path, NULL, &ps[n])) { *status = 1; return -1; }
        const char *base = strrchr(path, '/');
        const char *b = base ? base + 1 : path;
        size_t at = strlen(name), bl = strlen(b);
        if (at + bl + 2 < cap) {   /* a name too long for the plan line is cut there */
            if (n) name[at++] = ',';
            memcpy(name + at, b, bl + 1);
        }
        n++;
        s += len + (s[len] == ',');
    }
    return n;
}

/* What a light prior allocates (prior.h; the caller frees it with prior_free): the coefficient weights,
 * the light-weighted texels and the refit's texel statistics. */
typedef struct cli_prior {
    float (*w)[4];
    prior_rays *rays;
    prior_texels *texels;
} cli_prior;

static void prior_free(cli_prior *cp) {
    free(cp->w);
    free(cp->rays);
    free(cp->texels);
    memset(cp, 0, sizeof *cp);
}

/* --light-prior PROBE[,PROBE...]: the probes' RMS light over their yaw orbits (prior.h) into cp->w
 * (light_alloc'd), unless pd->box_texels their light-weighted texels into cp->rays, their light per
 * texel into cp->texels (the caller frees all: prior_free), pd and name[cap] (pd->light_prior_name
 * points there), its time said on stderr. Returns the exit status (1 or 2: said why). */
static int light_prior(const char *paths, precompute_desc *pd, bool quiet, cli_prior *cp, char *name, size_t cap,
                       double *secs) {
    double t0 = prt_now();
    prt_probe ps[PRIOR_MAX_PROBES];
    memset(ps, 0, sizeof ps);
    const prt_probe *pp[PRIOR_MAX_PROBES];
    int status = 0, n = prior_probes(paths, ps, name, cap, &status);
    for (int j = 0; j < PRIOR_MAX_PROBES; j++) pp[j] = &ps[j];
    prt_error err = { { 0 } };
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    prior_desc d = { .progress = prt_bar_report, .progress_user = &bar };
    cp->w = n > 0 ? light_alloc() : NULL;
    cp->texels = n > 0 ? prt_calloc(1, sizeof *cp->texels, &err) : NULL;   /* the refit's light per texel (refit.h) */
    int rc = n < 0 ? status : !cp->w || !cp->texels ? cli_error(k_cmd, "light prior: out of memory") : 0;
    if (!rc && prior_build(pp, n, &d, cp->w, cp->texels, &err)) rc = cli_error(k_cmd, "%s: %s", paths, err.msg);
    if (!rc && !pd->box_texels) {   /* the light-weighted texels: where its probes, unturned, have their light */
        cp->rays = prt_calloc(1, sizeof *cp->rays, &err);
        if (!cp->rays || prior_rays_from_probes(pp, n, cp->rays, &err)) rc = cli_error(k_cmd, "%s: %s", paths, err.msg);
    }
    prt_bar_done(&bar);
    for (int j = 0; j < PRIOR_MAX_PROBES; j++) probe_free(&ps[j]);
    if (rc) return rc;
    pd->light_prior = (const float (*)[4])cp->w;
    pd->light_prior_name = name;
    pd->prior_rays = cp->rays;
    pd->prior_texels = cp->texels;
    *secs += prt_now() - t0;
    char took[48];
    prt_format_duration(took, sizeof took, prt_now() - t0);
    if (!quiet) fprintf(stderr, "light prior: %s turned through %d yaw angles in %s\n", paths, PRIOR_STEPS, took);
    return 0;
}

/* The scene's own "light_prior" (scene.h) when the command line named none and did not say
 * --no-light-prior: computed as --light-prior's into *w and *rays (the caller frees both), or, where the selection
 * is not the expected-error one (--select magnitude, --texel-measure, --sh), left out with a note.
 * Returns the exit status. */
static int scene_prior(const prt_scene *s, precompute_desc *pd, bool quiet, cli_prior *cp, char *name, size_t cap,
                       double *secs) {
    if (!s->light_prior[0] || pd->light_prior) return 0;
    if (pd->select != TRANSPORT_SELECT_EXPECTED) {
        if (!quiet) fprintf(stderr, "note: the scene's light_prior is not used (it weighs the expected-error selection)\n");
        return 0;
    }
    return light_prior(s->light_prior, pd, quiet, cp, name, cap, secs);
}

/* The scene's "refine" (scene.h) into pd, when it asks for refinement (the caller checked that no
 * refine flag was given: those replace it). Returns whether it did. */
static bool scene_refinement(const prt_scene *s, precompute_desc *pd) {
    if (!s->refine.on) return false;
    pd->refine_threshold = s->refine.threshold > 0 ? s->refine.threshold : REFINE_THRESHOLD;
    pd->refine_budget = s->refine.budget;
    pd->refine_parts = s->refine.models ? REFINE_ALL : 0;
    return true;
}

/* Loads the scene, runs the pipeline with a progress bar, writes the file (rank 0 of an MPI job:
 * the others run quietly and write nothing). Returns the exit status. */
static int run(const char *in, const char *out, const scene_desc *sd, precompute_desc *pd, bool quiet,
               const char *prior_path, bool no_prior, bool scene_refine) {
    prt_error err = { { 0 } };
    prt_shard *sh = shard_create(&err);
    if (!sh) return cli_error(k_cmd, "%s", err.msg);
    int rc = 2;
    bool stray = false;   /* this rank failed where the others cannot know: the job is aborted */
    if (pd->resume && shard_size(sh) > 1) {
        if (shard_rank(sh) == 0) cli_error(k_cmd, "--resume cannot be combined with %d MPI ranks (run it in one process)", shard_size(sh));
    } else {
        const char *fail = getenv("PRT_SHARD_FAIL");   /* test hook: that rank fails (precompute.h) */
        pd->shard = sh;
        pd->shard_fail = fail ? atoi(fail) + 1 : 0;
        cli_prior cp = { 0 };   /* every rank computes the same prior (prior.h: deterministic) */
        char name[1024];
        double t0 = prt_now(), t_prior = 0;   /* the timing summary's total counts the prior */
        rc = prior_path ? light_prior(prior_path, pd, quiet || shard_rank(sh) > 0, &cp, name, sizeof name, &t_prior) : 0;
        const unsigned use = (!prior_path && !no_prior ? USE_SCENE_PRIOR : 0) | (scene_refine ? USE_SCENE_REFINE : 0);
        if (!rc) rc = run_rank(in, out, sd, pd, quiet || shard_rank(sh) > 0, use, t0, t_prior, &stray);
        else stray = shard_size(sh) > 1;   /* the others are not told: the job is aborted */
        prior_free(&cp);
    }
    shard_destroy(sh, stray);
    return rc;
}

/* run's work on one rank; *stray: it failed alone, the others not told (shard.h). Every rank loads
 * the scene and says whether it could, so a rank missing a file fails the whole job with one line.
 * t0: when the command's work began; t_prior: the seconds --light-prior took (the summary's). Returns
 * the exit status. */
static int run_rank(const char *in, const char *out, const scene_desc *sd, precompute_desc *pd, bool quiet, unsigned use_scene,
                    double t0, double t_prior, bool *stray) {
    const bool use_scene_prior = use_scene & USE_SCENE_PRIOR;
    prt_error err = { { 0 } };
    double t_scene = prt_now();
    char ck[4096] = "";
    prt_scene scene = { 0 };
    bool lead = shard_rank(pd->shard) == 0;
    int st = scene_load(in, sd, &scene, &err) ? 1 : 0;
    double t_load = prt_now() - t_scene;
    const bool by_scene = !st && (use_scene & USE_SCENE_REFINE) && scene_refinement(&scene, pd);
    if (!st && pd->refine_threshold > 0 && pd->refine_budget > 0 && pd->refine_budget < scene.mesh.nverts)
        st = by_scene ? 1 + 0 * prt_fail(&err, "%s: refine.budget %d is below its %d vertices", in, pd->refine_budget, scene.mesh.nverts)
                      : 2 + 0 * prt_fail(&err, "--refine-budget %d is below the %d vertices of %s", pd->refine_budget, scene.mesh.nverts, in);
    if (shard_status(pd->shard, st ? -1 : 0, &err)) {
        if (lead) cli_error(k_cmd, "%s", err.msg);
        scene_free(&scene);
        return st ? st : 1;
    }
    if (!quiet)
        fprintf(stderr, "scene: %d vertices, %d triangles, %d material(s)%s (loaded in %.2fs)\n", scene.mesh.nverts,
                scene.mesh.ntris, scene.nmaterials, scene.floor_first_vertex >= 0 ? ", with floor" : "", t_load);
    if (!quiet && scene.load_stats.degenerate)
        fprintf(stderr, "warning: %s: dropped %d degenerate triangle(s)\n", in, scene.load_stats.degenerate);
    cli_prior cp = { 0 };   /* the scene's prior; every rank computes the same (prior.h) */
    char pname[1024];
    if (use_scene_prior && (st = scene_prior(&scene, pd, quiet, &cp, pname, sizeof pname, &t_prior))) {
        prior_free(&cp);
        scene_free(&scene);
        *stray = shard_size(pd->shard) > 1;
        return st;
    }

    if (!quiet && pd->box_texels && !pd->light_prior)
        fprintf(stderr, "note: --box-texels changes nothing without a light prior (every texel is box-filtered)\n");
    if (!quiet && pd->no_refit && !pd->light_prior)
        fprintf(stderr, "note: --no-refit changes nothing without a light prior (nothing is refit)\n");
    int ranks = shard_size(pd->shard);
    if (!quiet && ranks > 1) fprintf(stderr, "mpi: %d ranks, each with its own threads; rank 0 writes %s\n", ranks, out);
    if (ranks == 1) checkpoint_setup(out, pd, ck, quiet);
    char dir[4096];   /* the streamed pass's temporary file goes beside the output */
    snprintf(dir, sizeof dir, "%s", out);
    char *slash = strrchr(dir, '/');
    if (slash) slash[slash == dir] = 0;
    else snprintf(dir, sizeof dir, ".");
    pd->stream_dir = dir;   /* a checkpoint is one process's (precompute.h) */
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    pd->progress = prt_bar_report;
    pd->progress_user = &bar;
    pd->quiet = quiet;
    prt_data data;
    memset(&data, 0, sizeof data);
    int prc = precompute_run(&scene, pd, &data, &err);
    prior_free(&cp);   /* the prior is read by the passes only (precompute.h) */
    pd->light_prior = use_scene_prior ? NULL : pd->light_prior;
    pd->prior_rays = use_scene_prior ? NULL : pd->prior_rays;
    pd->prior_texels = use_scene_prior ? NULL : pd->prior_texels;
    if (prc) {
        prt_bar_done(&bar);
        scene_free(&scene);
        *stray = !shard_failed_together(pd->shard);
        if (lead || *stray) cli_error(k_cmd, "%s", err.msg);
        return 1;
    }
    prt_bar_done(&bar);
    if (!lead) { prt_data_free(&data); return 0; }
    double tw = prt_now();
    data.stats.t_write = 0;
    if (prtfile_write(out, &data, &err)) {
        prt_data_free(&data);
        return cli_error(k_cmd, "%s", err.msg);
    }
    data.stats.t_write = prt_now() - tw;
    if (*ck) remove(ck);   /* the file is whole: nothing left to resume */
    if (!quiet) summary(out, &data, pd->shard, t_load, t_prior, t0);
    prt_data_free(&data);
    return 0;
}

/* --budget NAME into *out (transport_budget; none: shared for Haar, docs/design/shadows.md); returns 0, or 1
 * after saying why. */
static int budget_of(const char *name, int sh_bands, int *out) {
    static const char *names[] = { "vector", "shared", "relative" };
    *out = sh_bands ? TRANSPORT_BUDGET_VECTOR : PRECOMPUTE_BUDGET_AUTO;   /* the plan picks (precompute.h) */
    if (!name) return 0;
    *out = TRANSPORT_BUDGET_VECTOR;
    for (int k = 0; k < 3; k++)
        if (!strcmp(name, names[k])) *out = k;
    if (*out == TRANSPORT_BUDGET_VECTOR && strcmp(name, "vector"))
        return cli_error(k_cmd, "--budget must be vector, shared or relative (got '%s')", name);
    if (*out != TRANSPORT_BUDGET_VECTOR && sh_bands) return cli_error(k_cmd, "--budget %s applies to Haar wavelets, not --sh", name);
    return 0;
}

int cli_precompute(int argc, char **argv) {
    const char *in = NULL, *out = NULL;
    scene_desc sd = { .floor = -1 };
    precompute_desc pd = { 0 };
    bool quiet = false;
    int param = BRDF_PARAM_GRID, sh_bands = 0, refine = 0, bounces_seen = 0;
    const char *glossy = NULL, *select = NULL, *budget = NULL, *prior = NULL;
    float refine_thr = -1;
    bool texel = false, no_smooth = false, no_prior = false;
    const cli_option opts[] = {
        CLI_S("-o", &out),
        CLI_S("--material", &sd.material),
        CLI_S("--floor-material", &sd.floor_material),
        CLI_OI("--floor", &sd.floor_verts, 4, 4000000, &sd.floor, 1),
        CLI_SETV("--no-floor", &sd.floor, 0),
        CLI_SETV("--polar", &param, BRDF_PARAM_POLAR),
        CLI_SETV("--force-bounces", &pd.force_bounces, 1),
        CLI_SETV("--no-bounces", &pd.force_bounces, -1),
        CLI_B("--keep-direct", &pd.keep_direct),
        CLI_SETV("--refine", &refine, 1),
        CLI_SETV("--no-refine", &refine, -1),
        CLI_F("--refine-threshold", &refine_thr, 0, 1),
        CLI_I("--refine-budget", &pd.refine_budget, 4, 1 << 28),
        CLI_SETV("--refine-models", &pd.refine_parts, REFINE_ALL),
        CLI_B("--quiet", &quiet),
        CLI_I("--terms", &pd.max_terms, 1, 64),
        CLI_F("--term-error", &pd.term_error, 1e-6, 1),
        CLI_I("--coeffs", &pd.N, 1, 24576),
        CLI_I("--quant", &pd.qbits, 8, 32),
        CLI_I("--vis-res", &pd.vis_res, 64, 256),
        CLI_I("--sh", &sh_bands, 3, 10),
        CLI_B("--texel-measure", &texel),
        CLI_B("--no-smooth-faces", &no_smooth),
        CLI_B("--no-refit", &pd.no_refit),
        CLI_B("--box-texels", &pd.box_texels),
        CLI_S("--select", &select),
        CLI_S("--budget", &budget),
        CLI_S("--light-prior", &prior),
        CLI_B("--no-light-prior", &no_prior),
        { .name = "--bounces", .kind = CLI_INT, .out = &pd.bounces, .lo = 0, .hi = PRT_MAX_BOUNCES, .set = &bounces_seen, .setval = 1 },
        CLI_S("--glossy", &glossy),
        CLI_I("--lobes", &pd.vmf.lobes, 1, 4),   /* vmf.h VMFT_MAX_LOBES */
        CLI_I("--view-level", &pd.vmf.level, 0, 6),
        CLI_I("--lobe-samples", &pd.vmf.samples, 4, 4096),   /* transfer_vmf.c's range */
        CLI_I("--gather-res", &pd.gather_res, 4, 128),
        CLI_F("--bounce-threshold", &pd.bounce_threshold, 0, 1),
        CLI_I("--threads", &pd.nthreads, 1, 64),
        CLI_B("--resume", &pd.resume),
        CLI_F("--memory", &pd.memory_gb, 0.0001, 1e6),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    pd.param = (brdf_param)param;
    if (sh_bands && texel) return cli_error(k_cmd, "--texel-measure applies to Haar wavelets, not --sh") + 1;
    pd.measure = texel || sh_bands ? 0 : TRANSFER_MEASURE_SOLID_ANGLE;   /* docs/design/shadows.md */
    pd.smooth_faces = pd.measure == TRANSFER_MEASURE_SOLID_ANGLE && !no_smooth;
    if (select && strcmp(select, "expected") && strcmp(select, "magnitude"))
        return cli_error(k_cmd, "--select must be expected or magnitude (got '%s')", select) + 1;
    if (select && !strcmp(select, "expected") && !pd.measure)
        return cli_error(k_cmd, "--select expected needs Haar wavelets per steradian (not --texel-measure or --sh)") + 1;
    pd.select = pd.measure && !(select && !strcmp(select, "magnitude")) ? TRANSPORT_SELECT_EXPECTED
                                                                         : TRANSPORT_SELECT_MAGNITUDE;
    if (budget_of(budget, sh_bands, &pd.budget)) return 2;
    if (prior && no_prior) return cli_error(k_cmd, "--light-prior and --no-light-prior contradict each other") + 1;
    if (prior && pd.select != TRANSPORT_SELECT_EXPECTED)
        return cli_error(k_cmd, "--light-prior weighs the expected-error selection: not with --select magnitude, "
                                "--texel-measure or --sh") + 1;
    if (sh_bands) {   /* --sh ORDER: the spherical-harmonics representation of that order */
        pd.basis = "sh";
        pd.basis_order = sh_bands;
    }
    if (glossy && !strcmp(glossy, "svd")) pd.glossy = PRECOMPUTE_GLOSSY_SVD;
    else if (glossy && !strcmp(glossy, "vmf")) pd.glossy = PRECOMPUTE_GLOSSY_VMF;
    else if (glossy && strcmp(glossy, "auto")) return cli_error(k_cmd, "--glossy must be auto, svd or vmf (got '%s')", glossy) + 1;
    /* --bounces 0 turns interreflections off (the library's 0 means its default, 3) */
    if (bounces_seen && pd.bounces == 0 && pd.force_bounces == 0) pd.force_bounces = -1;
    if (pd.qbits && pd.qbits != 8 && pd.qbits != 16 && pd.qbits != 32) return cli_error(k_cmd, "--quant must be 8, 16 or 32") + 1;
    if (pd.vis_res && pd.vis_res != 64 && pd.vis_res != 128 && pd.vis_res != 256)
        return cli_error(k_cmd, "--vis-res must be 64, 128 or 256") + 1;
    if (refine_thr >= 1) return cli_error(k_cmd, "--refine-threshold must be below 1 (a share of directions)") + 1;
    /* on when asked for by any refine flag; a threshold of 0 or --no-refine turns it off */
    if (refine != -1 && refine_thr != 0 && (refine == 1 || refine_thr > 0 || pd.refine_budget > 0 || pd.refine_parts))
        pd.refine_threshold = refine_thr > 0 ? refine_thr : REFINE_THRESHOLD;
    if (!in) { cli_error(k_cmd, "no input model or scene (see --help)"); return 2; }
    if (!out) { cli_error(k_cmd, "no output file (-o OUT.prt)"); return 2; }
    /* the file, its checkpoint (written during the run) and every file the run reads, before any work */
    char ck[4200];
    snprintf(ck, sizeof ck, "%s.ckpt", out);
    const cli_output outs[] = { { "-o", out, CLI_OUT_PRT }, { "its checkpoint", ck, CLI_OUT_ANY } };
    cli_inputs ins = { 0 };
    cli_inputs_add_scene(&ins, in);
    cli_inputs_add_list(&ins, "--light-prior", prior);
    if (cli_check_files(k_cmd, outs, 2, &ins)) return 2;
    /* --material / --floor-material are flags: a bad spec is a usage error, found before loading */
    const char *specs[2] = { sd.material, sd.floor_material };
    for (int i = 0; i < 2; i++) {
        brdf_params bp;
        prt_error err = { { 0 } };
        if (specs[i] && brdf_parse(specs[i], &bp, &err)) return cli_error(k_cmd, "%s: %s", i ? "--floor-material" : "--material", err.msg) + 1;
    }
    /* any refine flag replaces the scene's "refine" (scene.h), --no-refine included */
    const bool scene_refine = refine == 0 && refine_thr < 0 && pd.refine_budget == 0 && !pd.refine_parts;
    return run(in, out, &sd, &pd, quiet, prior, no_prior, scene_refine);
}
