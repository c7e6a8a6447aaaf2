/* shard.c - MPI ranks for the precompute passes (shard.h): joining the job only under a
 * launcher, the cost-balanced split of a pass's vertices, the collective status that turns one
 * rank's failure into the same one-line error everywhere, and the exchange of finished vectors.
 *
 * The exchange broadcasts each rank's contiguous range from that rank in chunks of at most
 * SHARD_CHUNK bytes, rather than one MPI_Allgatherv: MPI counts are ints, and at a million
 * vertices a pass's staged values run to gigabytes.
 *
 * Progress (shard_pass_*) is point to point, so no rank ever waits for another to report: a rank's
 * counts go to rank 0 as MPI_Isend of one long (tag SHARD_TAG_COUNT) at most every 1% of the pass,
 * each sent only once the one before has gone; its final count and times follow as one message
 * (SHARD_TAG_FINAL) in shard_pass_end. MPI keeps one sender's messages in order, so once rank 0
 * has every rank's final message no count of that pass is left unreceived. */
#include "shard.h"
#include <mpi.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SHARD_CHUNK ((size_t)1 << 28)
#define SHARD_TAG_COUNT 7101
#define SHARD_TAG_FINAL 7102

struct prt_shard {
    int rank, size;
    bool joined;    /* MPI_Init was called (launched by mpirun / srun) */
    bool shared_failure;   /* shard_status saw a failure: every rank knows, no abort needed */
    int npasses;           /* rank 0: passes recorded by shard_pass_end */
    char names[SHARD_MAX_PASSES][32], units[SHARD_MAX_PASSES][16];
    shard_rank_stats *balance[SHARD_MAX_PASSES];   /* [size] each */
};

struct shard_pass {
    prt_shard *sh;
    char name[32], unit[16];
    long total, step;      /* vertices over all ranks; a count is sent every step of them */
    long sent, buf;        /* the last count sent; the send buffer of the one in flight */
    bool inflight;
    MPI_Request req;
    long *heard;           /* rank 0: [size] each rank's count as last heard */
    long others;           /* rank 0: their sum */
    double t0, cpu0;
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
    for (int i = 0; i < sh->npasses; i++) free(sh->balance[i]);
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
    if (t->stage_key) bcast_ranges(sh, t->stage_key, N * sizeof *t->stage_key, lo);   /* a shared budget's (transport.h) */
    if (t->stage_blk) bcast_ranges(sh, t->stage_blk, TRANSPORT_STAGE * sizeof *t->stage_blk, lo);
    free(lo);
    return 0;
}

/* See shard.h: the counts by MPI_Allgather, then each rank's part broadcast from it (bcast_ranges). */
int shard_share_list(const prt_shard *sh, void **base, size_t *n, size_t size, prt_error *err) {
    if (shard_size(sh) == 1) return 0;
    unsigned long long mine = *n, *cnt = prt_calloc((size_t)sh->size, sizeof *cnt, err);
    size_t *lo = cnt ? prt_calloc((size_t)sh->size + 1, sizeof *lo, err) : NULL;
    if (!lo) { free(cnt); return -1; }
    MPI_Allgather(&mine, 1, MPI_UNSIGNED_LONG_LONG, cnt, 1, MPI_UNSIGNED_LONG_LONG, MPI_COMM_WORLD);
    for (int r = 0; r < sh->size; r++) lo[r + 1] = lo[r] + (size_t)cnt[r];
    size_t total = lo[sh->size];
    char *all = malloc(total ? total * size : 1);
    if (!all) {
        free(cnt), free(lo);
        return prt_fail(err, "mpi: out of memory for %zu shared items", total);
    }
    if (mine) memcpy(all + lo[sh->rank] * size, *base, mine * size);
    bcast_ranges(sh, all, size, lo);
    free(*base);
    *base = all;
    *n = total;
    free(cnt), free(lo);
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

/* The process's CPU seconds (every thread). */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* See shard.h. */
shard_pass *shard_pass_begin(prt_shard *sh, const char *name, const char *unit, long total, prt_error *err) {
    shard_pass *p = prt_calloc(1, sizeof *p, err);
    if (!p) return NULL;
    p->sh = sh;
    snprintf(p->name, sizeof p->name, "%s", name);
    snprintf(p->unit, sizeof p->unit, "%s", unit);
    p->total = total;
    p->step = total / 100 > 1 ? total / 100 : 1;
    if (shard_size(sh) > 1 && sh->rank == 0 && !(p->heard = prt_calloc((size_t)sh->size, sizeof *p->heard, err))) {
        free(p);
        return NULL;
    }
    p->t0 = prt_now();
    p->cpu0 = cpu_now();
    return p;
}

/* Rank 0: takes one count message from src (already probed) into heard. */
static void take_count(shard_pass *p, int src) {
    long n = 0;
    MPI_Recv(&n, 1, MPI_LONG, src, SHARD_TAG_COUNT, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    p->others += n - p->heard[src];
    p->heard[src] = n;
}

/* See shard.h. */
long shard_pass_poll(shard_pass *p, long mine) {
    if (!p || shard_size(p->sh) == 1) return 0;
    if (p->sh->rank == 0) {
        for (;;) {
            int flag = 0;
            MPI_Status st;
            MPI_Iprobe(MPI_ANY_SOURCE, SHARD_TAG_COUNT, MPI_COMM_WORLD, &flag, &st);
            if (!flag) break;
            take_count(p, st.MPI_SOURCE);
        }
        return p->others;
    }
    if (p->inflight) {
        int done = 0;
        MPI_Test(&p->req, &done, MPI_STATUS_IGNORE);
        if (!done) return 0;
        p->inflight = false;
    }
    if (mine - p->sent >= p->step) {
        p->buf = p->sent = mine;
        MPI_Isend(&p->buf, 1, MPI_LONG, 0, SHARD_TAG_COUNT, MPI_COMM_WORLD, &p->req);
        p->inflight = true;
    }
    return 0;
}

/* Rank 0's side of shard_pass_end: every other rank's counts until its final message, into bal
 * (NULL: taken, not kept). */
static void gather_finals(shard_pass *p, shard_rank_stats *bal, long mine, prt_progress_fn progress, void *user) {
    for (int finals = 0; finals < p->sh->size - 1;) {
        MPI_Status st;
        MPI_Probe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &st);
        int src = st.MPI_SOURCE;
        if (st.MPI_TAG == SHARD_TAG_COUNT) {
            take_count(p, src);
        } else {
            double fin[3];
            MPI_Recv(fin, 3, MPI_DOUBLE, src, SHARD_TAG_FINAL, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            p->others += (long)fin[0] - p->heard[src];
            p->heard[src] = (long)fin[0];
            if (bal) bal[src] = (shard_rank_stats){ .items = (long)fin[0], .seconds = fin[1], .cpu = fin[2] };
            finals++;
        }
        if (progress && p->total > 0) progress(user, p->name, (double)(mine + p->others) / (double)p->total);
    }
}

/* See shard.h. */
void shard_pass_end(shard_pass *p, long mine, prt_progress_fn progress, void *user) {
    if (!p) return;
    prt_shard *sh = p->sh;
    if (shard_size(sh) > 1 && sh->rank > 0) {
        if (p->inflight) MPI_Wait(&p->req, MPI_STATUS_IGNORE);
        double fin[3] = { (double)mine, prt_now() - p->t0, cpu_now() - p->cpu0 };
        MPI_Send(fin, 3, MPI_DOUBLE, 0, SHARD_TAG_FINAL, MPI_COMM_WORLD);
    } else if (shard_size(sh) > 1) {
        /* out of memory: the messages are still taken, the balance (a report, not a result) not kept */
        shard_rank_stats *bal = calloc((size_t)sh->size, sizeof *bal);
        if (bal) bal[0] = (shard_rank_stats){ .items = mine, .seconds = prt_now() - p->t0, .cpu = cpu_now() - p->cpu0 };
        gather_finals(p, bal, mine, progress, user);
        if (bal && sh->npasses < SHARD_MAX_PASSES) {
            snprintf(sh->names[sh->npasses], sizeof sh->names[0], "%s", p->name);
            snprintf(sh->units[sh->npasses], sizeof sh->units[0], "%s", p->unit);
            sh->balance[sh->npasses++] = bal;
        } else {
            free(bal);
        }
    }
    free(p->heard);
    free(p);
}

/* See shard.h. */
const shard_rank_stats *shard_balance(const prt_shard *sh, int i, const char **name, const char **unit) {
    if (!sh || i < 0 || i >= sh->npasses) return NULL;
    if (name) *name = sh->names[i];
    if (unit) *unit = sh->units[i];
    return sh->balance[i];
}
