/* fuzz_gltf.c - asset_load_memory on arbitrary bytes as glTF 2.0 (a .glb when the bytes start with
 * its magic, else .gltf JSON): an accepted model keeps the invariants of fuzz_asset.h, a refused one
 * gets one line naming the file. */
#include "fuzz_asset.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    bool glb = size >= 4 && !memcmp(data, "glTF", 4);
    fuzz_asset(data, size, glb ? "fuzz.glb" : "fuzz.gltf", glb ? "glb" : "gltf");
    return 0;
}
