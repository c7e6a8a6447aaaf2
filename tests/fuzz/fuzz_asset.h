/* fuzz_asset.h - what the asset harnesses (fuzz_gltf, fuzz_ply, fuzz_objmtl) share: one input
 * through asset_load_memory (assimp's reader of that format, then asset.c's conversion), and the
 * invariants of what comes out: a mesh fuzz_check_mesh accepts with materials below the scene's
 * count, valid lights, finite cameras with a field in (0, 180), notes of whole lines; or one
 * error line naming the file; leaks inside assimp are suppressed (below). Textures are not decoded here (asset_desc.no_texture_pixels): the
 * harnesses fuzz the loader, not OpenImageIO's image decoders. */
#ifndef PRT_FUZZ_ASSET_H
#define PRT_FUZZ_ASSET_H
#include "fuzz.h"
#include "asset.h"

/* LeakSanitizer's default suppressions: memory assimp itself leaks (its glTF reader loses a
 * buffer when it throws on some malformed inputs; the library is not instrumented, and prt cannot
 * free what it never sees). A leak whose stack has no assimp frame is still a finding. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libassimp.so\n"; }

static inline void fuzz_asset(const uint8_t *data, size_t size, const char *name, const char *hint) {
    static prt_scene s;   /* 170 KB: not on the stack */
    memset(&s, 0, sizeof s);
    s.floor_first_vertex = -1;
    asset_model am;
    prt_error err = { { 0 } };
    asset_desc ad = { .no_texture_pixels = true };
    if (asset_load_memory(name, hint, data, size, &ad, &s, &am, &err) == 0) {
        fuzz_check_mesh(&am.mesh, s.nmaterials, true);
        FUZZ_REQUIRE(s.nmaterials >= 1 && s.nmaterials <= PRT_MAX_MATERIALS, "%d materials", s.nmaterials);
        for (int i = 0; i < am.lights.count; i++) {
            prt_error e2;
            FUZZ_REQUIRE(light_validate(&am.lights.light[i], "fuzz", &e2) == 0, "light %d: %s", i, e2.msg);
        }
        for (int i = 0; i < am.ncameras; i++) {
            const prt_camera *c = &am.cameras[i].cam;
            FUZZ_REQUIRE(c->fov_deg > 0 && c->fov_deg < 180 && isfinite(c->eye[0] + c->eye[1] + c->eye[2]) &&
                         isfinite(c->target[0] + c->target[1] + c->target[2]), "camera %d", i);
        }
        size_t n = strlen(s.notes);
        FUZZ_REQUIRE(n == 0 || s.notes[n - 1] == '\n', "notes not ending a line");
        asset_model_free(&am);
    } else {
        fuzz_check_error(&err, name);
    }
}
#endif
