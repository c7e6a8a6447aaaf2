/* phash.h - perfect spatial hash of a sparse 2D table by row displacement
 * (laurijssen-2011 section 6.2, after Lagae & Dutre 2008): A[i][j] = H[O[i] + j].
 *
 * Usage:
 *     phash_table h; prt_error err;
 *     if (phash_build(rows, cols, n, nrows, ncols, &h, &err)) puts(err.msg);   // n (row, col) entries
 *     lobes = calloc(h.size, sizeof *lobes);                 // the caller's H, one value per slot
 *     for (e = 0; e < n; e++) lobes[phash_find(&h, rows[e], cols[e])] = value[e];
 *     long s = phash_find(&h, i, j);                         // slot of A[i][j], or -1 when empty
 *     phash_free(&h);
 *
 * What it is for: the vMF transfer stores lobes only for the (vertex, view direction)
 * slices that differ from the BRDF's own lobe (occluded or inter-reflecting ones, 10-20%
 * in the paper's Table 1), yet needs O(1) random access at render time. Each row i
 * (vertex) gets an offset O[i] such that the occupied columns of all rows land on
 * distinct slots of one 1D table; a lookup is one add and one compare. The owner of
 * each slot (row + 1, 0 when free) is kept so that a lookup of an empty A[i][j]
 * answers -1 instead of another row's value (the paper falls back to the BRDF lobe then).
 *
 * Build: rows are placed in decreasing order of occupancy, each at the first offset
 * where all its columns are free (first-fit decreasing), starting from the lowest free
 * slot minus the row's first column, past every used slot when 16,384 candidates found
 * no gap (phash.c: bounds the build). fill = n / size is what it achieved.
 *
 * Ownership: the table owns offset and owner; phash_free releases them.
 * Errors: phash_build fails (-1, err set) only when out of memory. Entries outside
 * [0, nrows) x [0, ncols) or duplicated are bugs of the caller (PRT_CHECK). */
#ifndef PRT_PHASH_H
#define PRT_PHASH_H
#include "common.h"

typedef struct phash_table {
    int nrows, ncols;
    size_t n;             /* occupied entries */
    size_t size;          /* slots in H (max O[i] + j over entries, + 1) */
    uint32_t *offset;     /* [nrows] O[i] */
    uint32_t *owner;      /* [size] row + 1 of the entry in the slot, 0 when free */
    double fill;          /* n / size (1 when empty) */
} phash_table;

/* Builds the table for n entries (row[e], col[e]). Returns 0, or -1 with err set (OOM). */
int phash_build(const uint32_t *row, const uint32_t *col, size_t n, int nrows, int ncols, phash_table *out, prt_error *err);
/* Slot O[i] + j of A[i][j], or -1 when (i, j) is not an entry (or out of range). */
long phash_find(const phash_table *h, uint32_t i, uint32_t j);
void phash_free(phash_table *h);
#endif
