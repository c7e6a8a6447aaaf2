/* shard.c - MPI ranks for the precompute passes (shard.h): joining the job only under a
 * launcher, the cost-balanced split of a pass's vertices, the collective status that turns one
 * rank's failure into the same one-line error everywhere, and the exchange of finished vectors.
 *
 * The exchange broadcasts each rank's contiguous range from that rank in chunks of at most
 * SHARD_CHUNK bytes, rather than one MPI_Allgatherv: MPI counts are ints, and at a million
 * vertices a pass's staged values run to gigabytes. */
#include "shard.h"
#include <mpi.h>
#include <stdlib.h>
#include <string.h>

#define SHARD_CHUNK ((size_t)1 << 28)

struct prt_shard {
    int rank, size;
    bool joined;    /* MPI_Init was called (launched by mpirun / srun) */
    bool shared_failure;   /* shard_status saw a failure: every rank knows, no abort needed */
};

/* True when a launcher started this process (OpenMPI's mpirun, PMI or PMIx: srun). */
static bool launched(void) {
    return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMI_SIZE") || getenv("PMIX_RANK");
}

/* See shard.h. */
prt_shard *shard_create(prt_error *err) {
    prt_shard *sh = prt_calloc(1, sizeof *sh, err);
    if (!sh) return NULL;
    sh->size = 1;
    if (!launched()) return sh;
    int provided = 0;
    /* MPI is called from the main thread only (the worker threads never touch it) */
    if (MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        free(sh);
        prt_fail(err, "mpi: MPI_Init failed");
        return NULL;
    }
    sh->joined = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &sh->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &sh->size);
    if (sh->size > SHARD_MAX_RANKS) {
        prt_fail(err, "mpi: %d ranks (at most %d)", sh->size, SHARD_MAX_RANKS);
        MPI_Finalize();
        free(sh);
        return NULL;
    }
    return sh;
}

/* See shard.h. */
void shard_destroy(prt_shard *sh, bool failed) {
    if (!sh) return;
    if (sh->joined && failed && !sh->shared_failure && sh->size > 1) MPI_Abort(MPI_COMM_WORLD, 1);
    if (sh->joined) MPI_Finalize();
    free(sh);
}

int shard_rank(const prt_shard *sh) { return sh ? sh->rank : 0; }
int shard_size(const prt_shard *sh) { return sh ? sh->size : 1; }

/* See shard.h: greedy cut at each multiple of total / size of the running cost. */
void shard_split(const prt_shard *sh, const double *cost, int n, int *first) {
    int P = shard_size(sh);
    first[0] = 0;
    first[P] = n;
    if (P == 1) return;
    if (sh->rank == 0) {
        double total = 0, run = 0;
        for (int v = 0; v < n; v++) total += cost ? cost[v] : 1;
        int r = 1;
        for (int v = 0; v < n && r < P; v++) {
            run += cost ? cost[v] : 1;
            while (r < P && run >= total * r / P) first[r++] = v + 1;
        }
        while (r < P) first[r++] = n;
    }
    MPI_Bcast(first, P + 1, MPI_INT, 0, MPI_COMM_WORLD);
}

/* See shard.h. */
int shard_status(prt_shard *sh, int status, prt_error *err) {
    if (shard_size(sh) == 1) return status < 0 ? -1 : 0;
    int mine = status < 0 ? sh->rank : sh->size, lowest = sh->size;
    MPI_Allreduce(&mine, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (lowest == sh->size) return 0;
    sh->shared_failure = true;
    char msg[sizeof err->msg];
    memset(msg, 0, sizeof msg);
    if (sh->rank == lowest) snprintf(msg, sizeof msg, "%s", err->msg);
    MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, lowest, MPI_COMM_WORLD);
    msg[sizeof msg - 1] = 0;
    return prt_fail(err, "rank %d of %d: %s", lowest, sh->size, msg);
}

/* Every rank r broadcasts elements [lo[r], lo[r+1]) of base (elements of size bytes). */
static void bcast_ranges(const prt_shard *sh, void *base, size_t size, const size_t *lo) {
    for (int r = 0; r < sh->size; r++) {
        size_t off = lo[r] * size, end = lo[r + 1] * size;
        while (off < end) {
            size_t n = end - off < SHARD_CHUNK ? end - off : SHARD_CHUNK;
            MPI_Bcast((char *)base + off, (int)n, MPI_BYTE, r, MPI_COMM_WORLD);
            off += n;
        }
    }
}

/* See shard.h. */
int shard_share_rows(const prt_shard *sh, void *base, size_t size, const int *first, prt_error *err) {
    if (shard_size(sh) == 1) return 0;
    size_t *lo = prt_calloc((size_t)sh->size + 1, sizeof *lo, err);
    if (!lo) return -1;
    for (int r = 0; r <= sh->size; r++) lo[r] = (size_t)first[r];
    bcast_ranges(sh, base, size, lo);
    free(lo);
    return 0;
}

/* See shard.h: vertex ranges become vector ranges (vec_first), then each staged array in turn. */
int shard_share_staged(const prt_shard *sh, prt_transport *t, const int *first, prt_error *err) {
    if (shard_size(sh) == 1) return 0;
    PRT_CHECK(t->stage_count && t->stage_idx && t->stage_val);
    size_t *lo = prt_calloc((size_t)sh->size + 1, sizeof *lo, err);
    if (!lo) return -1;
    for (int r = 0; r <= sh->size; r++) lo[r] = t->vec_first[first[r]];
    const size_t N = (size_t)t->N;
    bcast_ranges(sh, t->stage_count, sizeof *t->stage_count, lo);
    bcast_ranges(sh, t->stage_idx, N * sizeof *t->stage_idx, lo);
    bcast_ranges(sh, t->stage_val, 3 * N * sizeof *t->stage_val, lo);
    bcast_ranges(sh, t->scale, 3 * sizeof *t->scale, lo);
    free(lo);
    return 0;
}

bool shard_failed_together(const prt_shard *sh) { return sh && sh->shared_failure; }

/* See shard.h. */
double shard_sum(const prt_shard *sh, double x) {
    if (shard_size(sh) == 1) return x;
    double s = 0;
    MPI_Allreduce(&x, &s, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    return s;
}
