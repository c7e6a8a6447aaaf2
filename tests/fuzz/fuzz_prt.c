/* fuzz_prt.c - the .prt reader on arbitrary bytes, read from memory (prtfile_read_memory, which
 * prtfile_read runs on the file's bytes: no file-system round trip per input).
 * Built twice: fuzz_prt takes the bytes as they are (most mutations stop at the frame's
 * checks: magic, version, length, CRC); fuzz_prt_crc (FUZZ_FIX_CRC) first rewrites the
 * header's payload length and the trailing CRC-32 to match, so the mutations reach the
 * sections' own checks. An accepted file is relit on the CPU runtime (one thread) under a small
 * probe with a bright texel, and shaded from two eyes: every colour finite and >= 0 (a file with
 * a vmf transfer is read, not relit: its light change takes seconds under ASan). A refused file:
 * one line naming it.
 * What an input costs is the reader and the runtime on its data, not the light: the probe is
 * resampled to the cube once per process, and each transfer configuration's light vector
 * (project_light: a Haar transform or an SH integration of 24,576 texels, milliseconds under
 * ASan, twice what the rest of an input costs) is projected the first time the configuration is
 * seen and handed over as it is afterwards (runtime_set_light_vectors). The
 * seeds are the 4 x 4 BRDF-map files (5-7 KB) and inputs stop at 8 KB (fuzz_prt.options), which
 * also caps the vertex count a file can hold. */
#include "fuzz.h"
#include "prtfile.h"
#include "cubemap.h"
#include "runtime.h"
#include "light.h"
#include "transfer.h"
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

#define FUZZ_PRT_NAME "fuzz.prt"

/* The cube of a 16x8 latlong probe, dim blue with one bright texel (a sun), made once per process. */
static const float *light(void) {
    static float cube[3 * CUBE_TEXELS];
    static bool made;
    if (made) return cube;
    prt_image im;
    prt_probe p;
    prt_error e;
    if (image_alloc(&im, 16, 8, 3, &e)) abort();
    for (int i = 0; i < 16 * 8; i++) { im.data[3 * i] = 0.2f; im.data[3 * i + 1] = 0.3f; im.data[3 * i + 2] = 0.5f; }
    for (int k = 0; k < 3; k++) im.data[3 * (2 * 16 + 5) + k] = 500;
    if (probe_from_image(&im, PROBE_LATLONG, "sun", &p, &e)) abort();
    probe_to_cube(&p, CUBE_RES, NULL, 0, cube);
    probe_free(&p);
    made = true;
    return cube;
}

/* light()'s light vector for transfer tr, projected the first time its configuration (ops and
 * cfg, all of it) is seen; the last LIGHT_VECTORS configurations are kept. Harness state, per process. */
#define LIGHT_VECTORS 32
static const float (*light_vector(const prt_transfer *tr))[4] {
    static struct { const transfer_ops *ops; transfer_config cfg; float (*L)[4]; } kept[LIGHT_VECTORS];
    static int next;
    for (int i = 0; i < LIGHT_VECTORS; i++)
        if (kept[i].L && kept[i].ops == tr->ops && !memcmp(&kept[i].cfg, &tr->cfg, sizeof tr->cfg))
            return (const float (*)[4])kept[i].L;
    int i = next;
    next = (next + 1) % LIGHT_VECTORS;
    free(kept[i].L);
    kept[i].L = transfer_light_alloc();
    if (!kept[i].L) abort();
    kept[i].ops = tr->ops;
    kept[i].cfg = tr->cfg;
    tr->ops->linear->project_light(&tr->cfg, light(), kept[i].L);
    return (const float (*)[4])kept[i].L;
}

static void relight(const prt_data *d) {
    /* a view-dependent transfer's light change prefilters the probe over 12 cube levels (seconds under
     * ASan, for every input): such a file is read and checked, not relit */
    for (int i = 0; i < d->ntransfers; i++)
        if (d->transfers[i].ops->kind == TRANSFER_VIEW) return;
    prt_error err = { { 0 } };
    runtime_desc rd = { .backend = "cpu", .threads = 1 };
    prt_runtime *rt = runtime_create(d, &rd, &err);
    if (!rt) { fuzz_check_error(&err, NULL); return; }
    int nv = d->scene.mesh.nverts;
    float *rgb = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof(float));
    if (!rgb) abort();
    const float (*L[PRT_MAX_TRANSFERS])[4] = { 0 };
    for (int i = 0; i < d->ntransfers; i++)
        if (d->transfers[i].ops->kind == TRANSFER_LINEAR) L[i] = light_vector(&d->transfers[i]);
    if (runtime_set_light_vectors(rt, L, &err) == 0) {
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
    const uint8_t *bytes = data;
#endif
    prt_data d;
    prt_error err = { { 0 } };
    if (prtfile_read_memory(FUZZ_PRT_NAME, bytes, size, &d, &err) == 0) {
        fuzz_check_mesh(&d.scene.mesh, d.scene.nmaterials, false);
        relight(&d);
        prt_data_free(&d);
    } else {
        fuzz_check_error(&err, FUZZ_PRT_NAME);
    }
#ifdef FUZZ_FIX_CRC
    free(bytes);
#endif
    return 0;
}
