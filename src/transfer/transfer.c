/* transfer.c - the table of transfer representations (transfer.h): every implementation is
 * listed here and nowhere else, one X(name) line each, which declares its transfer_ops
 * (transfer_NAME, exported by its folder) and lists it. This file holds the table alone
 * (interface.c the lookups over it), so that a program can link its own table in its place:
 * tests/dense/table.c compiles this file again with one more line, TRANSFER_TABLE_EXTRA. */
#include "transfer.h"
#include "check.h"

/* Adding a representation: its folder (src/transfer/NAME/, exporting transfer_NAME) and one line
 * here. The first of each kind is that kind's default (transfer_default). */
#define TRANSFER_TABLE(X) \
    X(haar)     /* Haar wavelets, N largest of 24,576, quantized (the paper) */ \
    X(sh)       /* spherical harmonics of order 3..10 (the low-frequency baseline) */ \
    X(vmf)      /* vMF lobes per vertex and view, perfect-hashed (laurijssen-2011) */ \
    X(cpca)     /* clustered PCA of the Haar transport (Sloan 2003, Liu 2004) */
#ifndef TRANSFER_TABLE_EXTRA
#define TRANSFER_TABLE_EXTRA(X)
#endif

#define TRANSFER_DECLARE(n) extern const transfer_ops transfer_##n;
#define TRANSFER_ENTRY(n) &transfer_##n,
TRANSFER_TABLE(TRANSFER_DECLARE)
TRANSFER_TABLE_EXTRA(TRANSFER_DECLARE)
static const transfer_ops *const k_transfers[] = { TRANSFER_TABLE(TRANSFER_ENTRY) TRANSFER_TABLE_EXTRA(TRANSFER_ENTRY) };
#define NTRANSFERS ((int)(sizeof k_transfers / sizeof k_transfers[0]))

int transfer_count(void) { return NTRANSFERS; }

const transfer_ops *transfer_at(int i) {
    PRT_CHECK(i >= 0 && i < NTRANSFERS);
    return k_transfers[i];
}
