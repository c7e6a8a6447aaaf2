/* transport.c - the transport set's storage: sizing, the staging the build writes, a shared budget's
 * larger staging, streaming the staging and the finished arrays through unlinked files, the policy
 * hook, and freeing.
 *
 * Contract (transport.h): transport_init sizes a set and its staging; transport_store (store.c) writes
 * only vector i's own staging slots (stage_count[i], stage_idx/stage_val[i*N ..], scale[3i ..]), so many
 * threads may store at once; transport_finish (pack.c) then packs the variable-length vectors
 * contiguously and frees the staging here.
 *
 * Why files: a scene's staging is 16 bytes per kept coefficient (20 per candidate plus 4 x
 * TRANSPORT_STAGE per vector with a shared budget, whose candidates are N_max = TRANSPORT_SHARED_CAP x N), which for large scenes
 * exceeds what a process should hold; transport_stage_to_file moves it to a file-backed shared
 * mapping whose pages transport_release drops as vectors are done, and transport_map_to_file does the
 * same for a finished set a later pass only reads. Both give the same bits as the heap.
 *
 * The policy (transport_set_policy) is a representation's: its tables are made once per set here and
 * freed with the staging; this file never reads them. */
#include "build.h"
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

/* Sizes the set and allocates staging; returns 0, or -1 with err set. */
int transport_init(prt_transport *t, int nverts, const int *nvec_of_vertex, int N, int qbits, prt_error *err) {
    memset(t, 0, sizeof *t);
    if (nverts < 0 || (nverts > 0 && !nvec_of_vertex)) return prt_fail(err, "transport: bad vertex count %d", nverts);
    if (N < 1 || N > CUBE_TEXELS) return prt_fail(err, "transport: N = %d is outside 1..%d", N, CUBE_TEXELS);
    if (qbits != 8 && qbits != 16 && qbits != 32) return prt_fail(err, "transport: qbits must be 8, 16 or 32, not %d", qbits);
    size_t nvecs = 0;
    for (int v = 0; v < nverts; v++) {
        if (nvec_of_vertex[v] < 0 || nvec_of_vertex[v] > 4096)
            return prt_fail(err, "transport: vertex %d has a bad vector count %d", v, nvec_of_vertex[v]);
        nvecs += (size_t)nvec_of_vertex[v];
    }
    if (nvecs > (size_t)INT32_MAX / 4) return prt_fail(err, "transport: too many vectors (%zu)", nvecs);
    t->nverts = nverts;
    t->nvecs = (int)nvecs;
    t->N = N;
    t->qbits = qbits;
    t->vec_first = prt_calloc((size_t)nverts + 1, sizeof *t->vec_first, err);
    t->scale = prt_calloc(3 * nvecs, sizeof *t->scale, err);
    t->stage_count = prt_calloc(nvecs, sizeof *t->stage_count, err);
    t->stage_idx = prt_calloc(nvecs * (size_t)N, sizeof *t->stage_idx, err);
    t->stage_val = prt_calloc(nvecs * (size_t)N * 3, sizeof *t->stage_val, err);
    if (!t->vec_first || !t->scale || !t->stage_count || !t->stage_idx || !t->stage_val) {
        prt_error e2;
        prt_fail(&e2, "transport: out of memory for %zu vectors of %d coefficients", nvecs, N);
        transport_free(t);
        return prt_fail(err, "%s", e2.msg);
    }
    for (int v = 0; v < nverts; v++) t->vec_first[v + 1] = t->vec_first[v] + (uint32_t)nvec_of_vertex[v];
    if (qbits == 32)
        for (size_t k = 0; k < 3 * nvecs; k++) t->scale[k] = 1.f;
    return 0;
}

/* See transport.h: the staging is allocated again at nmax candidates per vector. */
int transport_share_budget(prt_transport *t, int kind, int nmax, prt_error *err) {
    PRT_CHECK(t->stage_count && !t->stage_mapped && !t->budget);
    if (kind == TRANSPORT_BUDGET_VECTOR) return 0;
    PRT_CHECK(kind == TRANSPORT_BUDGET_SHARED || kind == TRANSPORT_BUDGET_RELATIVE);
    if (nmax <= 0) nmax = t->N > CUBE_TEXELS / TRANSPORT_SHARED_CAP ? CUBE_TEXELS : TRANSPORT_SHARED_CAP * t->N;
    PRT_CHECK(nmax >= t->N && nmax <= CUBE_TEXELS);
    size_t nk = (size_t)t->nvecs * (size_t)nmax;
    uint32_t *idx = prt_calloc(nk, sizeof *idx, err);
    float *val = idx ? prt_calloc(3 * nk, sizeof *val, err) : NULL;
    float *key = val ? prt_calloc(nk, sizeof *key, err) : NULL;
    float *blk = key ? prt_calloc((size_t)t->nvecs * TRANSPORT_STAGE, sizeof *blk, err) : NULL;
    if (!blk) {
        free(idx); free(val); free(key);
        return prt_fail(err, "transport: out of memory staging %zu vectors of %d candidates (a shared budget)", (size_t)t->nvecs, nmax);
    }
    free(t->stage_idx);
    free(t->stage_val);
    t->stage_idx = idx; t->stage_val = val; t->stage_key = key; t->stage_blk = blk;
    t->budget = t->N;
    t->budget_kind = kind;
    t->budget_min = t->budget / TRANSPORT_SHARED_MIN;
    t->N = nmax;
    return 0;
}

/* See transport.h. */
int transport_init_like(prt_transport *t, const prt_transport *like, const int *nvec_of_vertex, prt_error *err) {
    if (transport_init(t, like->nverts, nvec_of_vertex, like->budget ? like->budget : like->N, like->qbits, err)) return -1;
    t->solid_angle = like->solid_angle;
    t->select = like->select;
    t->prior = like->prior;
    t->refit = like->refit;
    t->block_level = like->block_level;
    t->smooth_faces = like->smooth_faces;
    /* a per-vector weight serves only the same vectors */
    if (like->weight && t->nvecs == like->nvecs && !memcmp(t->vec_first, like->vec_first, sizeof(uint32_t) * ((size_t)t->nverts + 1)))
        t->weight = like->weight;
    if (transport_set_policy(t, like->policy, err) ||
        (like->budget && transport_share_budget(t, like->budget_kind, like->N, err))) {
        transport_free(t);
        return -1;
    }
    return 0;
}

/* The staging arrays' bytes: indices, values, and with a shared budget the keys and block integrals. */
static void stage_sizes(const prt_transport *t, size_t len[4]) {
    size_t nk = (size_t)t->nvecs * t->N;
    len[0] = nk * sizeof *t->stage_idx;
    len[1] = nk * 3 * sizeof *t->stage_val;
    len[2] = t->stage_key ? nk * sizeof *t->stage_key : 0;
    len[3] = t->stage_blk ? (size_t)t->nvecs * TRANSPORT_STAGE * sizeof *t->stage_blk : 0;
}

/* See transport.h. */
size_t transport_staging_bytes(const prt_transport *t) {
    size_t len[4];
    stage_sizes(t, len);
    return len[0] + len[1] + len[2] + len[3];
}

/* See transport.h: one file-backed shared mapping holds the indices, then the values (then a shared
 * budget's keys and block integrals). */
int transport_stage_to_file(prt_transport *t, const char *dir, prt_error *err) {
    PRT_CHECK(t->stage_idx && !t->stage_mapped);
    size_t len[4], bytes = 0;
    stage_sizes(t, len);
    for (int k = 0; k < 4; k++) bytes += len[k];
    if (bytes == 0) return 0;
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);   /* unlinked from the start: nothing left behind */
    if (fd < 0) return prt_fail(err, "%s: cannot create the streamed pass's temporary file: %s", dir, strerror(errno));
    if (ftruncate(fd, (off_t)bytes)) {
        int e = errno;
        close(fd);
        return prt_fail(err, "%s: cannot size the streamed pass's temporary file to %zu bytes: %s", dir, bytes, strerror(e));
    }
    void *m = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    close(fd);
    if (m == MAP_FAILED) return prt_fail(err, "%s: cannot map the streamed pass's temporary file: %s", dir, strerror(errno));
    free(t->stage_idx);
    free(t->stage_val);
    free(t->stage_key);
    free(t->stage_blk);
    t->stage_idx = m;
    t->stage_val = (float *)(void *)((char *)m + len[0]);
    t->stage_key = len[2] ? (float *)(void *)((char *)m + len[0] + len[1]) : NULL;
    t->stage_blk = len[3] ? (float *)(void *)((char *)m + len[0] + len[1] + len[2]) : NULL;
    t->stage_mapped = bytes;
    return 0;
}

/* Drops the pages [p, p + n) touches from this process's memory. A page shared with a vector
 * another thread is writing may be dropped too: on a shared file mapping MADV_DONTNEED only unmaps
 * (the page cache keeps the page, dirty or not), and the writer's next store maps it again. */
static void drop_pages(const void *p, size_t n) {
    const uintptr_t pg = 4096;
    uintptr_t a = (uintptr_t)p & ~(pg - 1), b = ((uintptr_t)p + n + pg - 1) & ~(pg - 1);
    if (b > a) madvise((void *)a, b - a, MADV_DONTNEED);
}

/* See transport.h. */
void transport_release(const prt_transport *t, int i0, int i1) {
    if (!t->stage_mapped || i1 <= i0) return;
    size_t N = (size_t)t->N;
    drop_pages(t->stage_idx + (size_t)i0 * N, (size_t)(i1 - i0) * N * sizeof *t->stage_idx);
    drop_pages(t->stage_val + (size_t)i0 * N * 3, (size_t)(i1 - i0) * N * 3 * sizeof *t->stage_val);
    if (t->stage_key) drop_pages(t->stage_key + (size_t)i0 * N, (size_t)(i1 - i0) * N * sizeof *t->stage_key);
    if (t->stage_blk) drop_pages(t->stage_blk + (size_t)i0 * TRANSPORT_STAGE, (size_t)(i1 - i0) * TRANSPORT_STAGE * sizeof *t->stage_blk);
}

/* Writes n bytes of p at offset off of fd; returns 0 or -1 (errno). */
static int write_all(int fd, const void *p, size_t n, size_t off) {
    for (size_t done = 0; done < n;) {
        ssize_t w = pwrite(fd, (const char *)p + done, n - done, (off_t)(off + done));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        done += (size_t)w;
    }
    return 0;
}

/* See transport.h: the file holds runs, then packed (8-bit) or offs and q16 / f32, each at a
 * 64-byte boundary; written from the heap arrays (into the page cache, not through the mapping, so
 * they never count twice in this process), then mapped and the heap copies freed. */
int transport_map_to_file(prt_transport *t, const char *dir, prt_error *err) {
    PRT_CHECK(t->coef_first && !t->stage_count && !t->data_map);
    size_t nc = transport_ncoefs(t), nr = transport_nruns(t);
    const void *src[4] = { t->runs, t->packed, t->offs, t->qbits == 32 ? (const void *)t->f32 : (const void *)t->q16 };
    size_t len[4] = { 2 * nr, t->qbits == 8 ? 4 * nc : 0, t->qbits == 8 ? 0 : nc, t->qbits == 16 ? 6 * nc : t->qbits == 32 ? 12 * nc : 0 };
    size_t off[4], bytes = 0;
    for (int k = 0; k < 4; k++) { off[k] = bytes; bytes += (len[k] + 63) & ~(size_t)63; }
    if (bytes == 0) return 0;
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);   /* unlinked from the start: nothing left behind */
    if (fd < 0) return prt_fail(err, "%s: cannot create the mapped pass's temporary file: %s", dir, strerror(errno));
    int bad = ftruncate(fd, (off_t)bytes);
    for (int k = 0; k < 4 && !bad; k++) bad = len[k] ? write_all(fd, src[k], len[k], off[k]) : 0;
    void *m = bad ? MAP_FAILED : mmap(NULL, bytes, PROT_READ, MAP_SHARED, fd, 0);
    int e = errno;
    close(fd);
    if (m == MAP_FAILED) return prt_fail(err, "%s: cannot write and map the mapped pass's %zu-byte temporary file: %s", dir, bytes, strerror(e));
    char *b = m;
    if (len[0]) { free(t->runs); t->runs = (uint8_t *)b; }
    if (len[1]) { free(t->packed); t->packed = (uint32_t *)(void *)(b + off[1]); }
    if (len[2]) { free(t->offs); t->offs = (uint8_t *)(b + off[2]); }
    if (len[3] && t->qbits == 16) { free(t->q16); t->q16 = (int16_t *)(void *)(b + off[3]); }
    if (len[3] && t->qbits == 32) { free(t->f32); t->f32 = (float *)(void *)(b + off[3]); }
    t->data_map = m;
    t->data_mapped = bytes;
    return 0;
}

/* See transport.h. */
void transport_drop_mapped(const prt_transport *t) {
    if (t->data_map) madvise(t->data_map, t->data_mapped, MADV_DONTNEED);
}

/* See build.h. */
void transport_free_staging(prt_transport *t) {
    free(t->stage_count);
    if (t->policy_state && t->policy->destroy) t->policy->destroy(t->policy_state);
    t->policy_state = NULL;
    if (t->stage_mapped) munmap(t->stage_idx, t->stage_mapped);
    else { free(t->stage_idx); free(t->stage_val); free(t->stage_key); free(t->stage_blk); }
    t->stage_count = NULL; t->stage_idx = NULL; t->stage_val = NULL; t->stage_key = NULL; t->stage_blk = NULL;
    t->stage_mapped = 0;
}

/* See transport.h. */
int transport_set_policy(prt_transport *t, const transport_policy *p, prt_error *err) {
    PRT_CHECK(t->stage_count && !t->policy);
    if (!p) return 0;
    void *state = NULL;
    if (p->create && !(state = p->create(t, err))) return -1;
    t->policy = p;
    t->policy_state = state;
    return 0;
}

/* Frees every array; leaves a zeroed set. */
void transport_free(prt_transport *t) {
    free(t->vec_first); free(t->coef_first); free(t->run_first); free(t->scale);
    void *heap[5] = { t->runs, t->packed, t->offs, t->q16, t->f32 };
    for (int k = 0; k < 5; k++)   /* a mapped set's empty arrays stayed on the heap */
        if ((uintptr_t)heap[k] - (uintptr_t)t->data_map >= t->data_mapped) free(heap[k]);
    if (t->data_map) munmap(t->data_map, t->data_mapped);
    transport_free_staging(t);
    memset(t, 0, sizeof *t);
}
