/* fuzz_obj.c - the OBJ loader (mesh_parse_obj) on arbitrary bytes: an accepted mesh keeps its
 * invariants (fuzz.h), a refused one gets one line naming the file. */
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    prt_mesh m = { 0 };
    mesh_load_stats st = { 0 };
    prt_error err = { { 0 } };
    if (mesh_parse_obj("fuzz.obj", (const char *)data, size, &st, &m, &err) == 0) {
        fuzz_check_mesh(&m, 0, true);
        FUZZ_REQUIRE(st.degenerate >= 0 && st.welded >= 0 && st.unused >= 0, "negative load statistics");
    } else {
        fuzz_check_error(&err, "fuzz.obj");
    }
    mesh_free(&m);
    return 0;
}
