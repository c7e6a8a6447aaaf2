/* test_phash.c - the row-displacement perfect hash (src/transfer/vmf/phash.h) against a dense
 * bitmap of the same sparse table: every entry at slot O[i] + j with its own value,
 * every non-entry (brute force over the whole table) reported absent, no slot shared. */
#include "harness.h"
#include "phash.h"
#include <stdlib.h>
#include <string.h>

static double rnd(uint64_t *s) {
    *s ^= *s >> 12, *s ^= *s << 25, *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

/* A sparse occupancy like the transfer's: most rows empty (convex regions), the rest a
 * band of view directions plus scattered ones; returns the entry count. */
static size_t make_table(int nrows, int ncols, double row_p, uint64_t seed, uint8_t *dense, uint32_t *row, uint32_t *col) {
    size_t n = 0;
    memset(dense, 0, (size_t)nrows * ncols);
    for (int i = 0; i < nrows; i++) {
        if (rnd(&seed) >= row_p) continue;
        int c0 = (int)(rnd(&seed) * ncols), w = 1 + (int)(rnd(&seed) * ncols * 0.3);
        for (int j = 0; j < ncols; j++) {
            int in = ((j - c0 + ncols) % ncols) < w ? rnd(&seed) < 0.8 : rnd(&seed) < 0.02;
            if (in) dense[(size_t)i * ncols + j] = 1, row[n] = (uint32_t)i, col[n] = (uint32_t)j, n++;
        }
    }
    return n;
}

static void check_table(int nrows, int ncols, double row_p, uint64_t seed) {
    size_t cells = (size_t)nrows * ncols;
    uint8_t *dense = malloc(cells);
    uint32_t *row = malloc(sizeof *row * cells), *col = malloc(sizeof *col * cells);
    size_t n = make_table(nrows, ncols, row_p, seed, dense, row, col);
    phash_table h;
    prt_error err = { { 0 } };
    double t0 = prt_now();
    CHECK(phash_build(row, col, n, nrows, ncols, &h, &err) == 0, "%s", err.msg);
    double secs = prt_now() - t0;
    /* the caller's H: the entry's index as its value */
    long *H = malloc(sizeof *H * (h.size ? h.size : 1));
    for (size_t s = 0; s < h.size; s++) H[s] = -1;
    int bad_slot = 0, shared = 0, wrong = 0, ghost = 0;
    for (size_t e = 0; e < n; e++) {
        long s = phash_find(&h, row[e], col[e]);
        bad_slot += s != (long)h.offset[row[e]] + (long)col[e];
        if (s >= 0) shared += H[s] != -1, H[s] = (long)e;
    }
    for (size_t e = 0; e < n; e++) wrong += H[phash_find(&h, row[e], col[e])] != (long)e;
    for (int i = 0; i < nrows; i++)
        for (int j = 0; j < ncols; j++)
            if (!dense[(size_t)i * ncols + j]) ghost += phash_find(&h, (uint32_t)i, (uint32_t)j) != -1;
    printf("    %d x %d, %zu entries (density %.1f%%): %zu slots, fill %.1f%%, built in %.3fs\n", nrows, ncols, n,
           100.0 * n / cells, h.size, 100 * h.fill, secs);
    CHECK(bad_slot == 0, "%d entries not at O[i] + j", bad_slot);
    CHECK(shared == 0, "%d slots shared by two entries", shared);
    CHECK(wrong == 0, "%d entries read back another value", wrong);
    CHECK(ghost == 0, "%d empty cells found", ghost);
    CHECK(h.size >= n, "at least one slot per entry");
    CHECK_LE(h.size, cells, "never larger than the dense table");
    CHECK(phash_find(&h, (uint32_t)nrows, 0) == -1 && phash_find(&h, 0, (uint32_t)ncols) == -1, "out of range is absent");
    phash_free(&h);
    free(H), free(dense), free(row), free(col);
}

static void round_trip(void) {
    check_table(2000, 642, 0.15, 1);     /* the paper's 642 view directions, sparse rows */
    check_table(500, 162, 0.9, 2);       /* dense rows */
    check_table(3000, 64, 0.3, 3);
}

static void edge_cases(void) {
    phash_table h;
    prt_error err = { { 0 } };
    CHECK(phash_build(NULL, NULL, 0, 10, 8, &h, &err) == 0, "%s", err.msg);
    CHECK(h.size == 0 && phash_find(&h, 3, 3) == -1 && h.fill == 1, "empty table");
    phash_free(&h);
    uint32_t r[3] = { 0, 0, 5 }, c[3] = { 0, 7, 3 };
    CHECK(phash_build(r, c, 3, 6, 8, &h, &err) == 0, "%s", err.msg);
    CHECK(phash_find(&h, 0, 0) >= 0 && phash_find(&h, 0, 7) >= 0 && phash_find(&h, 5, 3) >= 0, "three entries found");
    CHECK(phash_find(&h, 0, 3) == -1 && phash_find(&h, 5, 0) == -1 && phash_find(&h, 2, 2) == -1, "others absent");
    CHECK(h.size <= 8, "first fit packs row 5 into row 0's gap (size %zu)", h.size);
    phash_free(&h);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(round_trip);
    CHECK_CASE(edge_cases);
    return check_summary();
}
