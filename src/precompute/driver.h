/* driver.h - `prt precompute` as one library call: a scene file in, a .prt file out, on one process
 * or split across the MPI ranks it runs under, resumable from a checkpoint beside the output.
 *
 * Usage:
 *     precompute_desc d = { 0 };                       // zero fields: prt precompute's defaults
 *     precompute_job job = { .scene_path = "room.json", .out_path = "room.prt",
 *                            .scene_keys = PRECOMPUTE_SCENE_ALL, .checkpoint = true };
 *     precompute_outcome o;
 *     if (precompute_file(&job, &d, &o, &err)) { if (o.say) fprintf(stderr, "%s\n", err.msg); exit(o.status); }
 *
 * What it does, in order: joins the MPI job (shard.h; one rank without MPI); every rank loads the
 * scene (scene_load) and they agree it loaded, so a rank missing a file fails the whole job with one
 * line; applies the scene's own keys that job.scene_keys names (precompute_desc_apply_scene; a
 * refinement budget below the scene's vertices is refused: exit status 1 when the scene asked for
 * it, 2 when the desc did); with one rank, keeps a checkpoint at OUT.ckpt (checkpoint.h: every pass
 * logs its finished vertices; desc.resume continues it; removed once the file is whole) and streams
 * large passes into a temporary file beside OUT (desc.memory_gb); runs precompute_run with the
 * desc's progress; rank 0 writes the file atomically (prtfile_write) and calls job.done with the
 * result before freeing it. The desc's checkpoint, stream_dir, shard and shard_fail are the
 * driver's: what the caller set there is replaced. Status lines (the scene's size, the ranks, a
 * replaced checkpoint) go to stderr unless job.quiet; ranks other than 0 are always quiet and run
 * without the desc's progress callback (rank 0's counts every rank's vertices).
 *
 * Errors: -1 with err and out->status 1 (bad data, a failed run or write) or 2 (usage: desc and
 * scene disagree, --resume under several ranks); out->say tells whether this process should print
 * err (rank 0, or a rank that failed alone: then the job is aborted, shard.h). 0 on success (every
 * rank). Test hooks: $PRT_CHECKPOINT_KILL (checkpoint.h) and $PRT_SHARD_FAIL (precompute.h). */
#ifndef PRT_DRIVER_H
#define PRT_DRIVER_H
#include "precompute.h"

struct prt_shard;

typedef struct precompute_job {
    const char *scene_path;     /* a model or a JSON scene (scene_load) */
    const scene_desc *scene;    /* NULL: scene_load's defaults */
    const char *out_path;       /* the .prt written by rank 0 */
    unsigned scene_keys;        /* PRECOMPUTE_SCENE_*: the scene's own keys to apply (0: none) */
    bool checkpoint;            /* keep OUT.ckpt so that a killed run can resume (one rank only) */
    bool quiet;                 /* no status lines */
    /* NULL, or called on rank 0 with the written file's data, the MPI job (shard_balance) and the
     * scene's load time in seconds, before the data is freed */
    void (*done)(void *user, const prt_data *data, const struct prt_shard *shard, double t_load);
    void *done_user;
} precompute_job;

typedef struct precompute_outcome {
    int status;     /* 0, 1 (data) or 2 (usage) */
    bool say;       /* this process prints err (see the header) */
} precompute_outcome;

/* Runs job with desc d (adjusted as the header says), as the header says. 0, or -1 with err and *out. */
int precompute_file(const precompute_job *job, precompute_desc *d, precompute_outcome *out, prt_error *err);
#endif
