/* table.c - the transfer table of this test binary: src/transfer/transfer.c compiled again with one
 * more line, the dense representation. Linked before libprt.a, its transfer_count and transfer_at
 * are the ones every lookup calls (interface.c), so the library sees four representations here and
 * three everywhere else. */
#define TRANSFER_TABLE_EXTRA(X) X(dense)
#include "transfer.c"
