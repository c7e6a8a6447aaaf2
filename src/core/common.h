/* common.h - errors, threads, timing, progress and atomic file output for prt.
 *
 * Errors (error.h) are user input gone wrong: one line in a caller's prt_error.
 * Bugs (broken invariants) are PRT_CHECK (check.h): they abort, never return.
 *
 * Threads: prt_parallel_for runs fn over [0,n) in chunks of `grain` on
 * prt_thread_count() threads with dynamic scheduling (atomic counter), so
 * uneven work (occluded vs open vertices) balances across both cores.
 *
 * Progress: a long stage calls a prt_progress_fn; returning false cancels the
 * stage (which then fails with "cancelled"). prt_bar is the standard callback:
 * a bar with ETA on a terminal, plain lines every 10% otherwise.
 *
 * Output files: prt_atomic_open writes to "<path>.tmp.<pid>"; prt_atomic_commit
 * flushes and renames over <path>; prt_atomic_abort removes the temporary. So a
 * crash or an error never leaves a partial file under the final name. A run
 * killed between the two leaves "<path>.tmp.<pid>"; prt_atomic_clean removes those
 * of processes that have exited (and "<path>.tmp.<pid>.<ext>", the name that earlier
 * prt builds' image writer gave its temporaries), and prt_output_check tells before
 * any work whether an output can be created at all.
 *
 * No mutable globals: all state lives in structs the caller owns. */
#ifndef PRT_COMMON_H
#define PRT_COMMON_H
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "error.h"
#include "check.h"

#define PRT_VERSION_STRING "0.2.0"

/* Monotonic wall-clock seconds. */
double prt_now(void);
/* CPU seconds this process has used, every thread's, user and system (getrusage). */
double prt_process_cpu(void);

/* Threads to use: requested if > 0, else $PRT_THREADS if set, else online CPUs. */
int prt_thread_count(int requested);

/* fn(ctx, begin, end, thread_index) over [0,n) in chunks of `grain` items. */
typedef void (*prt_range_fn)(void *ctx, int begin, int end, int thread);
void prt_parallel_for(int n, int grain, int nthreads, prt_range_fn fn, void *ctx);

/* Progress: return false to cancel. fraction in [0,1]. Thread-safe callers only
 * call it from one thread (precompute calls it from the thread that finishes a chunk
 * under its own lock). */
typedef bool (*prt_progress_fn)(void *user, const char *stage, double fraction);

/* Standard progress reporter (use &bar as `user` with prt_bar_report). */
typedef struct prt_bar {
    FILE *out;          /* stderr by default (NULL means stderr) */
    bool tty;           /* draw a bar with ETA (set by prt_bar_init from isatty) */
    bool quiet;         /* print nothing */
    char stage[64];
    double t_start, t_last;
    int last_decile;
} prt_bar;
void prt_bar_init(prt_bar *bar, FILE *out, bool quiet);
bool prt_bar_report(void *bar, const char *stage, double fraction);
/* Ends the current stage line (prints elapsed time). */
void prt_bar_done(prt_bar *bar);

/* Atomic output: see header. tmp must hold at least 4096 bytes. */
FILE *prt_atomic_open(const char *path, char *tmp, size_t tmpcap, prt_error *err);
int prt_atomic_commit(FILE *f, const char *tmp, const char *path, prt_error *err);
void prt_atomic_abort(FILE *f, const char *tmp);
/* Removes path's temporaries left by processes that have exited (same folder, the name
 * "<base>.tmp.<pid>[.<ext>]", pid not alive); returns how many, the first one's name in
 * first[firstcap] (may be NULL). Another running process's temporary is never touched. */
int prt_atomic_clean(const char *path, char *first, size_t firstcap);
/* 0 if path can be created before any work is done: not empty, not a folder, its folder
 * exists and is writable, and (exts non-NULL: a NULL-ended list of lowercase extensions)
 * its extension is one of exts. Else -1 with one line naming path and the problem. */
int prt_output_check(const char *path, const char *const *exts, prt_error *err);

/* Do a and b name the same file? Both existing: the same device and inode (so a hard link, a
 * symbolic link or "./a" is a's file); neither existing: the same folder and base name; one
 * existing and not the other: false. What lets a command refuse an output that is one of its
 * inputs before it writes over it. */
bool prt_same_file(const char *a, const char *b);

/* A duration as a person reads it, into buf[cap] (at least 32 bytes), never with an exponent: three
 * significant digits below a second, tenths below a minute, then whole seconds or minutes:
 * "0.0421 ms", "12.5 ms", "850 ms", "1.7 s", "2 min 05 s", "3 h 07 min" (negative or NaN: "0 ms"). */
void prt_format_duration(char *buf, size_t cap, double seconds);

/* Lowercase extension of path without the dot ("" if none), into ext[16]. */
void prt_path_ext(const char *path, char ext[16]);

/* Allocation that reports failure through err: returns NULL and fills err. */
void *prt_calloc(size_t count, size_t size, prt_error *err);

/* Rec. 709 luminance of linear RGB: what "how much light" means wherever one figure must weigh a
 * colour (importance, merge weights, lobe order). In double, and in float where a caller's figures are
 * float (the same expression, so either gives what its caller computed before sharing it). */
static inline double prt_luminance(const float c[3]) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }
static inline float prt_luminancef(const float c[3]) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

#endif
