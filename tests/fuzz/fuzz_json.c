/* fuzz_json.c - the JSON scene parser (scene_parse_json) on arbitrary bytes. The scene's name
 * puts relative OBJ paths in the OBJ seeds' folder (run from the repository root), so a JSON
 * input can name "cube.obj". An accepted scene: a valid mesh (fuzz.h) whose materials are
 * below nmaterials, bounds that hold every vertex; a refused one: one line naming the file.
 * Inputs asking for more than a few hundred of something (a number above FUZZ_JSON_MAX_COUNT,
 * 256: vertices, rings) are left out: legal, but slow, and what they test is the allocator's
 * patience. */
#include "fuzz.h"
#include "scene.h"
#include <ctype.h>

#define FUZZ_JSON_NAME "tests/fuzz/corpus/obj/fuzz.json"
#ifndef FUZZ_JSON_MAX_COUNT
#define FUZZ_JSON_MAX_COUNT 256
#endif

/* True when the text holds a number whose magnitude is above FUZZ_JSON_MAX_COUNT (a big count). */
static bool big_number(const char *s) {
    for (const char *p = s; *p; p++) {
        if (!isdigit((unsigned char)*p) || (p > s && (isalnum((unsigned char)p[-1]) || p[-1] == '.'))) continue;
        char *end;
        double v = strtod(p, &end);
        if (!(fabs(v) <= FUZZ_JSON_MAX_COUNT)) return true;
        p = end > p ? end - 1 : p;
    }
    return false;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char *text = fuzz_cstr(data, size);
    if (big_number(text) || strstr(text, "/dev") || strstr(text, "/proc") || strstr(text, "/sys")) { free(text); return 0; }
    prt_scene s = { 0 };
    prt_error err = { { 0 } };
    if (scene_parse_json(FUZZ_JSON_NAME, text, size, NULL, &s, &err) == 0) {
        FUZZ_REQUIRE(s.nmaterials >= 1 && s.nmaterials <= PRT_MAX_MATERIALS, "%d materials", s.nmaterials);
        fuzz_check_mesh(&s.mesh, s.nmaterials, true);
        for (int v = 0; v < s.mesh.nverts; v++)
            for (int k = 0; k < 3; k++) {
                float x = s.mesh.pos[3 * (size_t)v + k], slack = 1e-4f * (1 + fabsf(x));
                FUZZ_REQUIRE(x >= s.bmin[k] - slack && x <= s.bmax[k] + slack, "vertex %d outside the bounds", v);
            }
        FUZZ_REQUIRE(s.floor_first_vertex < s.mesh.nverts, "floor starts at %d of %d", s.floor_first_vertex, s.mesh.nverts);
    } else {
        fuzz_check_error(&err, FUZZ_JSON_NAME);
    }
    scene_free(&s);
    free(text);
    return 0;
}
