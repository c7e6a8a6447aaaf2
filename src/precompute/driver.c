/* driver.c - `prt precompute` as one library call (driver.h): the MPI job, the scene, the checkpoint
 * and the temporary files around precompute_run, and the file written once. */
#include "driver.h"
#include "prtfile.h"
#include "shard.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* What one rank's run needs besides the job and the desc. */
typedef struct drv_rank {
    prt_shard *shard;
    bool lead, quiet;
    bool alone;         /* this rank failed where the others cannot know: the job is aborted */
    char ck[4096];      /* the checkpoint ("": none) */
    char dir[4096];     /* the streamed passes' folder: the output's */
} drv_rank;

/* Fails the run: err says why (already set), status is the exit status. */
static int drv_fail(precompute_outcome *out, int status, bool say) {
    out->status = status;
    out->say = say;
    return -1;
}

/* The checkpoint beside the output (OUT.ckpt; none for an empty name, whose write fails anyway); an
 * earlier run's replaced without resume is said. */
static void drv_checkpoint(const precompute_job *job, precompute_desc *d, drv_rank *rk) {
    if (!job->checkpoint || !*job->out_path) return;
    snprintf(rk->ck, sizeof rk->ck, "%s.ckpt", job->out_path);
    d->checkpoint = rk->ck;
    const char *kill_after = getenv("PRT_CHECKPOINT_KILL");   /* test hook (checkpoint.h) */
    d->checkpoint_kill = kill_after ? atoi(kill_after) : 0;
    if (!d->resume && !rk->quiet && access(rk->ck, F_OK) == 0)
        fprintf(stderr, "starting anew: %s of an earlier run is replaced (--resume continues it)\n", rk->ck);
}

/* The folder of the output, where a streamed pass's temporary file goes (it is unlinked at once). */
static void drv_stream_dir(const char *path, char *dir, size_t cap) {
    snprintf(dir, cap, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash) slash[slash == dir] = 0;
    else snprintf(dir, cap, ".");
}

/* Loads the scene on every rank and applies its keys; all ranks agree on the outcome (a rank missing a
 * file fails the job with one line). 0, or -1 with err and out. */
static int drv_scene(const precompute_job *job, precompute_desc *d, drv_rank *rk, prt_scene *scene, double *t_load,
                     precompute_outcome *out, prt_error *err) {
    double t0 = prt_now();
    int st = scene_load(job->scene_path, job->scene, scene, err) ? 1 : 0;
    *t_load = prt_now() - t0;
    bool by_scene = !st && (job->scene_keys & PRECOMPUTE_SCENE_REFINE) && scene->refine.on;
    if (!st && job->scene_keys && precompute_desc_apply_scene(d, scene, job->scene_keys, err)) st = 1;
    if (!st && d->refine_threshold > 0 && d->refine_budget > 0 && d->refine_budget < scene->mesh.nverts)
        st = by_scene ? 1 + 0 * prt_fail(err, "%s: refine.budget %d is below its %d vertices", job->scene_path, d->refine_budget,
                                         scene->mesh.nverts)
                      : 2 + 0 * prt_fail(err, "--refine-budget %d is below the %d vertices of %s", d->refine_budget,
                                         scene->mesh.nverts, job->scene_path);
    if (shard_status(rk->shard, st ? -1 : 0, err)) {
        scene_free(scene);
        return drv_fail(out, st ? st : 1, rk->lead);
    }
    if (!rk->quiet)
        fprintf(stderr, "scene: %d vertices, %d triangles, %d material(s)%s (loaded in %.2fs)\n", scene->mesh.nverts,
                scene->mesh.ntris, scene->nmaterials, scene->floor_first_vertex >= 0 ? ", with floor" : "", *t_load);
    if (!rk->quiet && scene->load_stats.degenerate)
        fprintf(stderr, "warning: %s: dropped %d degenerate triangle(s)\n", job->scene_path, scene->load_stats.degenerate);
    for (const char *n = scene->notes; !rk->quiet && *n;) {   /* what loading left out or changed (asset.h) */
        size_t len = strcspn(n, "\n");
        fprintf(stderr, "note: %.*s\n", (int)len, n);
        n += len + (n[len] == '\n');
    }
    return 0;
}

/* One rank's work: the scene, the run, the file (rank 0). 0, or -1 with err and out. */
static int drv_rank_run(const precompute_job *job, precompute_desc *d, drv_rank *rk, precompute_outcome *out, prt_error *err) {
    prt_scene scene = { 0 };
    double t_load = 0;
    if (drv_scene(job, d, rk, &scene, &t_load, out, err)) return -1;
    int ranks = shard_size(rk->shard);
    if (!rk->quiet && ranks > 1)
        fprintf(stderr, "mpi: %d ranks, each with its own threads; rank 0 writes %s\n", ranks, job->out_path);
    if (ranks == 1) drv_checkpoint(job, d, rk);   /* a checkpoint is one process's (precompute.h) */
    drv_stream_dir(job->out_path, rk->dir, sizeof rk->dir);
    d->stream_dir = rk->dir;
    d->quiet = rk->quiet;
    prt_data data;
    memset(&data, 0, sizeof data);
    int prc = precompute_run(&scene, d, &data, err);   /* takes the scene */
    if (d->light_prior_scene) d->light_prior = NULL, d->light_prior_scene = false;   /* it pointed into the scene */
    if (prc) {
        scene_free(&scene);
        rk->alone = !shard_failed_together(rk->shard);
        return drv_fail(out, 1, rk->lead || rk->alone);
    }
    if (!rk->lead) { prt_data_free(&data); return 0; }
    double tw = prt_now();
    data.stats.t_write = 0;
    if (prtfile_write(job->out_path, &data, err)) {
        prt_data_free(&data);
        return drv_fail(out, 1, true);
    }
    data.stats.t_write = prt_now() - tw;
    if (*rk->ck) remove(rk->ck);   /* the file is whole: nothing left to resume */
    if (job->done) job->done(job->done_user, &data, rk->shard, t_load);
    prt_data_free(&data);
    return 0;
}

int precompute_file(const precompute_job *job, precompute_desc *d, precompute_outcome *out, prt_error *err) {
    memset(out, 0, sizeof *out);
    drv_rank *rk = calloc(1, sizeof *rk);
    if (!rk) return prt_fail(err, "out of memory"), drv_fail(out, 1, true);
    if (!(rk->shard = shard_create(err))) {
        free(rk);
        return drv_fail(out, 1, true);
    }
    rk->lead = shard_rank(rk->shard) == 0;
    rk->quiet = job->quiet || !rk->lead;
    int rc = 0;
    if (d->resume && shard_size(rk->shard) > 1) {
        prt_fail(err, "--resume cannot be combined with %d MPI ranks (run it in one process)", shard_size(rk->shard));
        rc = drv_fail(out, 2, rk->lead);
    } else {
        const char *fail = getenv("PRT_SHARD_FAIL");   /* test hook: that rank fails (precompute.h) */
        d->shard = rk->shard;
        d->shard_fail = fail ? atoi(fail) + 1 : 0;
        if (!rk->lead) d->progress = NULL;   /* rank 0's progress counts every rank's vertices */
        rc = drv_rank_run(job, d, rk, out, err);
    }
    d->shard = NULL;
    shard_destroy(rk->shard, rk->alone);
    free(rk);
    return rc;
}
