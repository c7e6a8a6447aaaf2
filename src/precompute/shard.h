/* shard.h - the precompute passes split across MPI ranks (Debian's OpenMPI).
 *
 * Usage (the CLI, once per process):
 *     prt_shard *sh = shard_create(&err);      // MPI_Init only when launched by mpirun / srun
 *     precompute_desc d = { .shard = sh };      // the passes split their vertices across ranks
 *     ... rank 0 (shard_rank(sh) == 0) writes the file, the others write nothing ...
 *     shard_destroy(sh);                        // MPI_Finalize
 *
 * A process started without a launcher (no OMPI_COMM_WORLD_SIZE / PMI_SIZE / PMIX_RANK in its
 * environment) never calls MPI_Init: it is one rank of one, and every function below is the
 * identity on one process (a NULL shard is the same). So the same build/prt runs with and
 * without mpirun, and the sanitizer build never sees OpenMPI's own allocations.
 *
 * Splitting (shard_split): the vertices of a pass are cut into one contiguous range per rank,
 * balanced by a measured cost per vertex (the planning sample's per-vertex times, precompute.c),
 * computed on rank 0 and broadcast, so every rank holds the same split. Exchange
 * (shard_share_staged): after a pass every rank holds its range's staged vectors
 * (transport.h); MPI_Allgatherv gives every rank the whole pass, so the next gathering pass sees
 * all of it and the result is the one a single process computes (each vertex's work depends on
 * the vertex alone: no seeds, no per-thread state; precompute.h).
 *
 * Progress over all ranks (shard_pass_*): around a split pass, every rank's main thread (thread 0 of
 * prt_parallel_for, which is the caller's) calls shard_pass_poll now and then with its own count;
 * the other ranks send theirs to rank 0 every 1% of the pass (MPI_Isend, never waiting), rank 0
 * takes what has arrived (MPI_Iprobe) and its bar shows the count over every rank. shard_pass_end
 * sends each rank's final count, wall and CPU time to rank 0, which keeps reporting as they arrive
 * and records them: the balance, listed per pass by shard_balance for the timing summary.
 *
 * Errors: a rank that fails calls shard_status(sh, -1, err) at the next exchange point; every
 * rank then fails with one line naming the first failed rank and its message ("rank 1 of 2:
 * ..."), rank 0 prints it and writes no file. MPI errors themselves abort the job (MPI's
 * default handler). Ownership: the shard belongs to its creator; the functions keep nothing. */
#ifndef PRT_SHARD_H
#define PRT_SHARD_H
#include "common.h"
#include "error.h"
#include "transport.h"

/* Ranks at most (a larger job is refused by shard_create). */
#define SHARD_MAX_RANKS 4096

typedef struct prt_shard prt_shard;

/* Joins the MPI job when launched by a launcher, else a one-process shard. NULL with err on failure. */
prt_shard *shard_create(prt_error *err);
/* Leaves the job and frees sh (NULL: nothing): MPI_Finalize, or MPI_Abort when this rank failed
 * (failed) other than through shard_status, whose failures every rank shares (the others may be
 * waiting in a collective this rank will never reach). */
void shard_destroy(prt_shard *sh, bool failed);
/* This process's rank, 0 for NULL. */
int shard_rank(const prt_shard *sh);
/* The number of ranks, 1 for NULL. */
int shard_size(const prt_shard *sh);
/* first[0..size]: rank r takes vertices [first[r], first[r+1]) of n, cut so that each range's sum
 * of cost[] (>= 0 per vertex, rank 0's values decide; NULL: 1 each) is about the total / size. */
void shard_split(const prt_shard *sh, const double *cost, int n, int *first);
/* Collective: status < 0 on the ranks that failed (their err says why). Returns 0 when every
 * rank succeeded, else -1 with err = "rank R of P: message" of the lowest failed rank, on all ranks. */
int shard_status(prt_shard *sh, int status, prt_error *err);
/* True once shard_status has seen a failure (every rank knows it: no abort needed). */
bool shard_failed_together(const prt_shard *sh);
/* Collective: every rank gets the staged vectors (count, indices, values, scales) of the vertices
 * of every rank's range of first[] in t (before transport_finish). Returns 0 or -1 (OOM). */
int shard_share_staged(const prt_shard *sh, prt_transport *t, const int *first, prt_error *err);
/* Collective: every rank gets bytes [first[r] * size, first[r+1] * size) of base from rank r. */
int shard_share_rows(const prt_shard *sh, void *base, size_t size, const int *first, prt_error *err);
/* One split pass's progress and balance (shard_pass_begin .. shard_pass_end). */
typedef struct shard_pass shard_pass;
/* Starts a pass of total items (unit: "vertices", "slices") over all ranks, named name (both kept for
 * the balance). NULL with err on OOM. Collective only in that every rank must call it and
 * shard_pass_end. */
shard_pass *shard_pass_begin(prt_shard *sh, const char *name, const char *unit, long total, prt_error *err);
/* Main thread only: this rank has done mine items of the pass; returns how many the other ranks
 * have done as last heard (rank 0; 0 elsewhere and on one process). Never blocks. */
long shard_pass_poll(shard_pass *p, long mine);
/* Collective: this rank's final count (mine); rank 0 receives every rank's, reporting the running
 * total through progress(user, name, fraction) (may be NULL) as they arrive, and records each rank's
 * count, wall and CPU time since begin (shard_balance; not kept when out of memory: a report, not a
 * result, so no rank fails for it). Frees p (NULL: nothing). */
void shard_pass_end(shard_pass *p, long mine, prt_progress_fn progress, void *user);

/* Per rank of a recorded pass: its items (vertices or slices) and its wall and CPU (process) seconds. */
typedef struct shard_rank_stats {
    long items;
    double seconds, cpu;
} shard_rank_stats;
/* Rank 0, after shard_pass_end: pass i's name, unit and its [size] per-rank stats (NULL past the
 * last pass or on the other ranks). At most SHARD_MAX_PASSES passes are kept (the first ones). */
#define SHARD_MAX_PASSES 32
const shard_rank_stats *shard_balance(const prt_shard *sh, int i, const char **name, const char **unit);

/* Collective: every rank's list (*n elements of size bytes at *base, malloc'd; NULL when empty)
 * becomes on every rank the concatenation of all ranks' lists in rank order (*base realloc'd, *n
 * the total). Returns 0 or -1 (OOM, err; *base and *n unchanged). */
int shard_share_list(const prt_shard *sh, void **base, size_t *n, size_t size, prt_error *err);

/* Collective sum of x over the ranks (the identity on one). */
double shard_sum(const prt_shard *sh, double x);
#endif
