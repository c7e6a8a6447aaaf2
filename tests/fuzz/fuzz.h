/* fuzz.h - what every libFuzzer harness of tests/fuzz/ shares: the invariants of an error
 * line and of an accepted mesh, the single-threaded library, and the abort that turns a
 * broken invariant into a libFuzzer finding.
 *
 * A harness is one fuzz_NAME.c defining LLVMFuzzerTestOneInput (built by `make fuzz`, run
 * by tools/fuzz.sh with its seeds in tests/fuzz/corpus/NAME/). The library must answer any
 * input with 0 or -1 and one error line; a sanitizer report, a PRT_CHECK or a FUZZ_REQUIRE
 * here is a finding. Harnesses are test code: they may keep per-process state (the temp
 * file's name) in statics, which the library itself never does. Every harness runs the library
 * single-threaded (LLVMFuzzerInitialize below). */
#ifndef PRT_FUZZ_H
#define PRT_FUZZ_H
#include "common.h"
#include "mesh.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Once per process, before the first input: the library's parallel loops run on the calling thread
 * (PRT_THREADS=1, common.h), so an input costs no thread creation and a run with -jobs/-workers
 * uses one core per process. */
int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    setenv("PRT_THREADS", "1", 1);
    return 0;
}

/* Aborts (a libFuzzer crash, with the input saved) when cond is false. */
#define FUZZ_REQUIRE(cond, ...) do { if (!(cond)) { \
    fprintf(stderr, "fuzz invariant broken at %s:%d: %s: ", __FILE__, __LINE__, #cond); \
    fprintf(stderr, __VA_ARGS__); fputc('\n', stderr); abort(); } } while (0)

/* An error is one non-empty line without a newline that names the file. */
static inline void fuzz_check_error(const prt_error *err, const char *name) {
    size_t n = strnlen(err->msg, sizeof err->msg);
    FUZZ_REQUIRE(n > 0 && n < sizeof err->msg, "empty or unterminated error");
    FUZZ_REQUIRE(!strchr(err->msg, '\n') && !strchr(err->msg, '\r'), "error spans lines: %s", err->msg);
    if (name) FUZZ_REQUIRE(strstr(err->msg, name) != NULL, "error does not name %s: %s", name, err->msg);
}

/* An accepted mesh: at least one triangle, indices in range, finite positions, finite normals
 * (unit ones when unit: what the loaders compute; a .prt file's are only finite), materials
 * below nmat (0: not checked). */
static inline void fuzz_check_mesh(const prt_mesh *m, int nmat, bool unit) {
    FUZZ_REQUIRE(m->nverts > 0 && m->ntris > 0, "accepted mesh with %d vertices, %d triangles", m->nverts, m->ntris);
    for (size_t i = 0; i < 3 * (size_t)m->ntris; i++)
        FUZZ_REQUIRE(m->tris[i] < (uint32_t)m->nverts, "index %u of %d vertices", m->tris[i], m->nverts);
    for (int v = 0; v < m->nverts; v++) {
        const float *p = m->pos + 3 * (size_t)v, *n = m->nrm + 3 * (size_t)v;
        FUZZ_REQUIRE(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]), "vertex %d not finite", v);
        double l = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
        FUZZ_REQUIRE(isfinite(l) && (!unit || fabs(l - 1) < 1e-3), "normal %d has length %g", v, l);
        if (nmat > 0 && m->mat) FUZZ_REQUIRE(m->mat[v] < nmat, "material %d of %d", m->mat[v], nmat);
    }
}

/* The input as a NUL-terminated string (malloc'd; the caller frees). */
static inline char *fuzz_cstr(const uint8_t *data, size_t size) {
    char *s = malloc(size + 1);
    if (!s) abort();
    memcpy(s, data, size);
    s[size] = 0;
    return s;
}
#endif
