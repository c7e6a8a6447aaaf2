/* fuzz_ply.c - asset_load_memory on arbitrary bytes as PLY (ASCII and binary): an accepted model
 * keeps the invariants of fuzz_asset.h, a refused one gets one line naming the file. */
#include "fuzz_asset.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_asset(data, size, "fuzz.ply", "ply");
    return 0;
}
