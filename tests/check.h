/* check.h - the test suite's tiny harness.
 *
 * Each tests/test_*.c is one binary. It calls CHECK / CHECK_NEAR / CHECK_LE
 * any number of times, then returns check_summary() from main. A failing check
 * prints file:line and the values; the summary prints "CHECKS <pass> <fail>",
 * which tools/run_tests.sh adds up into the suite's "N passed, N failed" line.
 *
 * The counters live in one struct owned by the test binary (check_state), not
 * in the library: the library has no mutable globals. */
#ifndef PRT_CHECK_H
#define PRT_CHECK_H
#include <math.h>
#include <stdio.h>

typedef struct check_state { int pass, fail; } check_state;
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

#define CHECK(cond, ...) do { if (cond) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
    check_note("" __VA_ARGS__); } } while (0)
/* |a-b| <= tol, and both finite. */
#define CHECK_NEAR(a, b, tol, ...) do { double a_ = (a), b_ = (b), t_ = (tol); \
    if (isfinite(a_) && isfinite(b_) && fabs(a_ - b_) <= t_) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: %s = %.9g vs %s = %.9g (tol %.3g): ", __FILE__, __LINE__, #a, a_, #b, b_, t_); \
    check_note("" __VA_ARGS__); } } while (0)
#define CHECK_LE(a, b, ...) do { double a_ = (a), b_ = (b); \
    if (isfinite(a_) && isfinite(b_) && a_ <= b_) check_g.pass++; else { check_g.fail++; \
    fprintf(stderr, "FAIL %s:%d: %s = %.9g > %s = %.9g: ", __FILE__, __LINE__, #a, a_, #b, b_); \
    check_note("" __VA_ARGS__); } } while (0)

/* Prints the counts for run_tests.sh; returns the process exit status. */
int check_summary(void);
/* A fresh scratch directory for this test binary (under build/tmp); path stays valid until exit. */
const char *check_tmpdir(void);
/* Path of the built prt program (build/prt or $PRT_BIN). */
const char *check_prt_bin(void);
/* Runs a shell command, returns its exit status; captures up to cap-1 bytes of stdout+stderr into out (may be NULL). */
int check_run(const char *cmd, char *out, size_t cap);
#endif
