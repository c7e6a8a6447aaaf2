/* error.h - user-input errors: what a caller can report and recover from.
 *
 * A function that can fail on user input (a bad file, a bad flag, out of
 * memory) returns 0 on success and -1 on failure, having written one line (no
 * trailing newline) into the caller's prt_error that names the file and the
 * problem. Callers print err.msg; the CLI adds "prt CMD: " and exits 1 (data)
 * or 2 (usage). The error lives in a struct the caller owns (no global errno),
 * so concurrent calls never share one.
 *
 * Bugs are not errors: a broken invariant inside the library is a PRT_CHECK
 * (check.h), which aborts with both values. Never turn one into the other:
 * bad input must never reach a PRT_CHECK, and a PRT_CHECK must never be a way
 * of rejecting input. */
#ifndef PRT_ERROR_H
#define PRT_ERROR_H

typedef struct prt_error { char msg[1024]; } prt_error;

/* Writes a printf-style message into err (if non-NULL), newlines folded to spaces. Returns -1. */
int prt_fail(prt_error *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#endif
