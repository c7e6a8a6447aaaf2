/* fuzz_objmtl.c - asset_load_memory on arbitrary bytes as OBJ through assimp's reader (the path an
 * OBJ naming an MTL library takes; in memory it has no library beside it, so usemtl names materials
 * assimp makes up): an accepted model keeps the invariants of fuzz_asset.h, a refused one gets one
 * line naming the file. */
#include "fuzz_asset.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fuzz_asset(data, size, "fuzz.obj", "obj");
    return 0;
}
