/* harness.h - the test suite's tiny harness: named cases, checks with tolerances.
 *
 * Each tests/test_DOMAIN.c is one binary made of named cases:
 *     static void reconstruct(void) { CHECK_NEAR(x, 1, 1e-6, "what"); ... }
 *     int main(int argc, char **argv) {
 *         check_begin(argc, argv);
 *         CHECK_CASE(reconstruct);          // runs as "haar/reconstruct"
 *         return check_summary();
 *     }
 * A case is "DOMAIN/NAME" (DOMAIN: the binary's name without "test_"). A filter
 * (argv[1], else $T: `make test T=haar`, `make test T=prtfile/truncated`) runs
 * only the cases whose full name contains it; the others are counted as skipped
 * and named in the summary line, so a filter never hides a check silently. A case
 * that needs GL (CHECK_CASE_GL) is skipped the same way in a build without GL,
 * its name and reason printed.
 * A failing check prints file:line, the case and both values; the summary
 * prints "CHECKS <pass> <fail> <skipped cases>", which tools/run_tests.sh adds
 * up into the suite's "N passed, N failed" line.
 *
 * The counters live in one struct owned by the test binary (check_state), not
 * in the library: the library has no mutable globals.
 *
 * Tolerances and portability: the suite must pass on any x86-64 CPU. The library's own
 * arithmetic is compiled for x86-64-v2 (no FMA, no dispatch by CPU), so it gives the same bits
 * on every machine; what differs by CPU is what passes through glibc's libm (FMA variants of
 * exp, log, pow, sin... on AVX2 + FMA CPUs), OpenBLAS (kernels by CPU model: the BRDF
 * factorization), Embree (SIMD width by CPU: every ray) and llvmpipe (GL). So a tolerance is
 * derived from the arithmetic it checks (n float terms: ~n FLT_EPSILON of their magnitude; a
 * quantized value: half a step), never from the few ulps one machine shows, and an exact
 * comparison is kept only where the result is exact by construction: the same code on the
 * same inputs in one process (thread counts, resume, a copy, a file round trip), integers, or
 * the library's own arithmetic on both sides. Each such check says which in a comment.
 * `make test-portable` runs the suite on other CPUs' code paths (tools/test_portable.sh). */
#ifndef PRT_TEST_HARNESS_H
#define PRT_TEST_HARNESS_H
#include <math.h>
#include <stdio.h>

typedef struct check_state {
    int pass, fail;
    int cases_run, cases_skipped;
    char domain[64];        /* "haar" for build/tests/test_haar */
    const char *filter;     /* NULL: every case */
    const char *current;    /* the running case's name (for failure messages) */
} check_state;
extern check_state check_g;
#include <stdarg.h>
/* Prints an optional printf-style note after a failure (no format attribute, so an
 * empty note is not a -Wformat-zero-length warning). */
static inline void check_note(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static inline const char *check_case_name(void) { return check_g.current ? check_g.current : "main"; }

#define CHECK(cond, ...) do { if (cond) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: [%s] %s: ", __FILE__, __LINE__, check_case_name(), #cond); \
    check_note("" __VA_ARGS__); } } while (0)
/* |a-b| <= tol, and both finite. */
#define CHECK_NEAR(a, b, tol, ...) do { double a_ = (a), b_ = (b), t_ = (tol); \
    if (isfinite(a_) && isfinite(b_) && fabs(a_ - b_) <= t_) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: [%s] %s = %.9g vs %s = %.9g (tol %.3g): ", __FILE__, __LINE__, check_case_name(), #a, a_, #b, b_, t_); \
    check_note("" __VA_ARGS__); } } while (0)
#define CHECK_LE(a, b, ...) do { double a_ = (a), b_ = (b); \
    if (isfinite(a_) && isfinite(b_) && a_ <= b_) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: [%s] %s = %.9g > %s = %.9g: ", __FILE__, __LINE__, check_case_name(), #a, a_, #b, b_); \
    check_note("" __VA_ARGS__); } } while (0)

/* Reads the filter (argv[1] or $T) and the domain name from argv[0]. Call first in main. */
void check_begin(int argc, char **argv);
/* Runs fn as case "DOMAIN/name" unless the filter excludes it; prints its time and counts. */
void check_case(const char *name, void (*fn)(void));
#define CHECK_CASE(fn) check_case(#fn, fn)
/* Counts case "DOMAIN/name" as skipped (when the filter wants it) and prints why. */
void check_skip(const char *name, const char *why);
/* A case that needs GL (OSMesa, EGL, a window, or an image from the cpu runtime's raster): skipped
 * with its reason in a build without GL (make NO_GL=1 defines PRT_NO_GL). */
#ifdef PRT_NO_GL
#define CHECK_CASE_GL(fn) ((void)(fn), check_skip(#fn, "this build has no GL (NO_GL=1)"))
#else
#define CHECK_CASE_GL(fn) check_case(#fn, fn)
#endif
/* True when case "DOMAIN/name" would run (for cases that need set-up shared by several). */
int check_wants(const char *name);

/* Prints the counts for run_tests.sh; returns the process exit status. */
int check_summary(void);
/* A fresh scratch directory for this test binary (under build/tmp); path stays valid until exit. */
const char *check_tmpdir(void);
/* Reads a whole file into a NUL-terminated buffer (free()); *len (may be NULL) gets its size.
 * NULL when it cannot be opened or read. */
char *check_read_file(const char *path, size_t *len);
/* Path of the built prt program (build/prt or $PRT_BIN). */
const char *check_prt_bin(void);
/* Runs a shell command, returns its exit status; captures up to cap-1 bytes of stdout+stderr into out (may be NULL). */
int check_run(const char *cmd, char *out, size_t cap);
#endif
