/* fuzz_prt.c - the .prt reader (prtfile_read) on arbitrary bytes, through a temporary file.
 * Built twice: fuzz_prt takes the bytes as they are (most mutations stop at the frame's
 * checks: magic, version, length, CRC); fuzz_prt_crc (FUZZ_FIX_CRC) first rewrites the
 * header's payload length and the trailing CRC-32 to match, so the mutations reach the
 * sections' own checks. An accepted file is relit on the CPU runtime under a small probe with
 * a bright texel and shaded from two eyes: every colour finite and >= 0 (a file with a vmf
 * transfer is read, not relit: its light change takes seconds under ASan). A refused file: one
 * line naming it. */
#include "fuzz.h"
#include "prtfile.h"
#include "runtime.h"
#include <zlib.h>

#ifdef FUZZ_FIX_CRC
/* Payload length and CRC made consistent with the bytes. Returns the copy. */
static uint8_t *fix_frame(const uint8_t *data, size_t size) {
    uint8_t *b = malloc(size ? size : 1);
    if (!b) abort();
    memcpy(b, data, size);
    if (size < 20) return b;
    uint64_t payload = size - 20;
    for (int i = 0; i < 8; i++) b[8 + i] = (uint8_t)(payload >> (8 * i));
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), b, (uInt)(size - 4));
    for (int i = 0; i < 4; i++) b[size - 4 + i] = (uint8_t)(crc >> (8 * i));
    return b;
}
#endif

/* A 16x8 latlong probe, dim blue with one bright texel (a sun), built once per process. */
static const prt_probe *light(void) {
    static prt_probe p;
    if (p.img.data) return &p;
    prt_image im;
    prt_error e;
    if (image_alloc(&im, 16, 8, 3, &e)) abort();
    for (int i = 0; i < 16 * 8; i++) { im.data[3 * i] = 0.2f; im.data[3 * i + 1] = 0.3f; im.data[3 * i + 2] = 0.5f; }
    for (int k = 0; k < 3; k++) im.data[3 * (2 * 16 + 5) + k] = 500;
    if (probe_from_image(&im, PROBE_LATLONG, "sun", &p, &e)) abort();
    return &p;
}

static void relight(const prt_data *d) {
    /* a vmf transfer's light change prefilters the probe over 12 cube levels (seconds under ASan,
     * for every input): such a file is read and checked, not relit */
    for (int i = 0; i < d->ntransfers; i++)
        if (!strcmp(d->transfers[i].ops->name, "vmf")) return;
    prt_error err = { { 0 } };
    runtime_desc rd = { .backend = "cpu", .threads = 1 };
    prt_runtime *rt = runtime_create(d, &rd, &err);
    if (!rt) { fuzz_check_error(&err, NULL); return; }
    int nv = d->scene.mesh.nverts;
    float *rgb = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof(float));
    if (!rgb) abort();
    if (runtime_set_light(rt, light(), NULL, &err) == 0) {
        static const float eyes[2][3] = { { 0, 1, 5 }, { -3, 4, -2 } };
        for (int e = 0; e < 2; e++) {
            if (runtime_shade_vertices(rt, eyes[e], rgb, &err)) { fuzz_check_error(&err, NULL); break; }
            for (size_t i = 0; i < 3 * (size_t)nv; i++)
                FUZZ_REQUIRE(isfinite(rgb[i]) && rgb[i] >= 0, "vertex colour %zu = %g", i / 3, (double)rgb[i]);
        }
    } else {
        fuzz_check_error(&err, NULL);
    }
    free(rgb);
    runtime_destroy(rt);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
#ifdef FUZZ_FIX_CRC
    uint8_t *bytes = fix_frame(data, size);
#else
    uint8_t *bytes = (uint8_t *)fuzz_cstr(data, size);   /* a copy, so both builds free one */
#endif
    const char *path = fuzz_temp_file("prt", bytes, size);
    free(bytes);
    if (!path) abort();
    prt_data d;
    prt_error err = { { 0 } };
    if (prtfile_read(path, &d, &err) == 0) {
        fuzz_check_mesh(&d.scene.mesh, d.scene.nmaterials, false);
        relight(&d);
        prt_data_free(&d);
    } else {
        fuzz_check_error(&err, path);
    }
    return 0;
}
