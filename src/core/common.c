/* common.c - errors, threads, timing, progress and atomic output (see common.h). */
#include "common.h"
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <ctype.h>
#include <dirent.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>

int prt_fail(prt_error *err, const char *fmt, ...) {
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
        /* One line: fold any newline a caller let through. */
        for (char *p = err->msg; *p; p++)
            if (*p == '\n' || *p == '\r') *p = ' ';
    }
    return -1;
}

void prt_check_fail(const char *file, int line, const char *expr, const char *values) {
    fprintf(stderr, "prt: bug: %s:%d: check failed: %s%s%s\n", file, line, expr, values ? ": " : "", values ? values : "");
    fflush(stderr);
    abort();
}

void prt_check_fail2(const char *file, int line, const char *expr, double a, double b) {
    char v[128];
    snprintf(v, sizeof v, "%.17g vs %.17g", a, b);
    prt_check_fail(file, line, expr, v);
}

double prt_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double prt_process_cpu(void) {
    struct rusage u;
    if (getrusage(RUSAGE_SELF, &u) != 0) return 0;
    return (double)u.ru_utime.tv_sec + 1e-6 * (double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_sec +
           1e-6 * (double)u.ru_stime.tv_usec;
}

int prt_thread_count(int requested) {
    if (requested > 0) return requested;
    const char *e = getenv("PRT_THREADS");
    if (e && atoi(e) > 0) return atoi(e);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)(n > 64 ? 64 : n) : 1;
}

typedef struct pf_shared {
    atomic_int next;
    int n, grain;
    prt_range_fn fn;
    void *ctx;
} pf_shared;

typedef struct pf_arg { pf_shared *s; int thread; } pf_arg;

static void *pf_worker(void *p) {
    pf_arg *a = p;
    pf_shared *s = a->s;
    for (;;) {
        int b = atomic_fetch_add(&s->next, s->grain);
        if (b >= s->n) break;
        int e = b + s->grain < s->n ? b + s->grain : s->n;
        s->fn(s->ctx, b, e, a->thread);
    }
    return NULL;
}

void prt_parallel_for(int n, int grain, int nthreads, prt_range_fn fn, void *ctx) {
    if (n <= 0) return;
    if (grain < 1) grain = 1;
    nthreads = prt_thread_count(nthreads);
    int chunks = (n + grain - 1) / grain;
    if (nthreads > chunks) nthreads = chunks;
    pf_shared s = { .n = n, .grain = grain, .fn = fn, .ctx = ctx };
    atomic_init(&s.next, 0);
    if (nthreads <= 1) {
        pf_arg a = { &s, 0 };
        pf_worker(&a);
        return;
    }
    pthread_t th[64];
    pf_arg args[64];
    int started = 0;
    for (int t = 1; t < nthreads; t++) {
        args[t] = (pf_arg){ &s, t };
        if (pthread_create(&th[t], NULL, pf_worker, &args[t]) == 0) started = t;
        else break;
    }
    args[0] = (pf_arg){ &s, 0 };
    pf_worker(&args[0]);
    for (int t = 1; t <= started; t++) pthread_join(th[t], NULL);
}

void prt_bar_init(prt_bar *bar, FILE *out, bool quiet) {
    memset(bar, 0, sizeof *bar);
    bar->out = out ? out : stderr;
    bar->tty = isatty(fileno(bar->out));
    bar->quiet = quiet;
    bar->last_decile = -1;
}

void prt_format_duration(char *buf, size_t cap, double s) {
    double ms = 1e3 * s;
    if (!(s > 0)) snprintf(buf, cap, "0 ms");
    else if (ms < 0.9995) {   /* three significant digits, never an exponent: "0.0421 ms" */
        int decimals = 2 - (int)floor(log10(ms));
        snprintf(buf, cap, "%.*f ms", decimals < 3 ? 3 : decimals > 6 ? 6 : decimals, ms);
    } else if (ms < 9.995) snprintf(buf, cap, "%.2f ms", ms);
    else if (ms < 99.95) snprintf(buf, cap, "%.1f ms", ms);
    else if (ms < 999.5) snprintf(buf, cap, "%.0f ms", ms);
    else if (s < 59.95) snprintf(buf, cap, "%.1f s", s);
    else if (s < 3599.5) {
        long t = lround(s);
        snprintf(buf, cap, "%ld min %02ld s", t / 60, t % 60);
    } else {
        long m = lround(fmin(s, 1e15) / 60);   /* capped: an absurd figure stays a number, not an overflow */
        snprintf(buf, cap, "%ld h %02ld min", m / 60, m % 60);
    }
}

bool prt_bar_report(void *user, const char *stage, double fraction) {
    prt_bar *bar = user;
    if (!bar || bar->quiet) return true;
    double now = prt_now();
    if (strncmp(bar->stage, stage, sizeof bar->stage - 1) != 0) {
        if (bar->stage[0]) prt_bar_done(bar);
        snprintf(bar->stage, sizeof bar->stage, "%s", stage);
        bar->t_start = now;
        bar->t_last = 0;
        bar->last_decile = -1;
    }
    if (fraction < 0) fraction = 0;
    if (fraction > 1) fraction = 1;
    double el = now - bar->t_start;
    double eta = fraction > 1e-6 ? el * (1 - fraction) / fraction : 0;
    char e1[32], e2[32];
    prt_format_duration(e1, sizeof e1, el);
    prt_format_duration(e2, sizeof e2, eta);
    if (bar->tty) {
        if (now - bar->t_last < 0.1 && fraction < 1) return true;
        bar->t_last = now;
        char cells[41];
        int w = 40, fill = (int)(fraction * w + 0.5);
        for (int i = 0; i < w; i++) cells[i] = i < fill ? '#' : '.';
        cells[w] = 0;
        fprintf(bar->out, "\r%-22s [%s] %5.1f%%  %s elapsed, ETA %s\033[K", stage, cells, 100 * fraction, e1, e2);
        fflush(bar->out);
    } else {
        int d = (int)(fraction * 10);
        if (d > bar->last_decile) {
            bar->last_decile = d;
            fprintf(bar->out, "%s: %3d%%  (%s elapsed, ETA %s)\n", stage, d * 10, e1, e2);
            fflush(bar->out);
        }
    }
    return true;
}

void prt_bar_done(prt_bar *bar) {
    if (!bar || bar->quiet || !bar->stage[0]) return;
    char e1[32];
    prt_format_duration(e1, sizeof e1, prt_now() - bar->t_start);
    if (bar->tty) fprintf(bar->out, "\r\033[K%-22s done in %s\n", bar->stage, e1);
    else fprintf(bar->out, "%s: done in %s\n", bar->stage, e1);
    fflush(bar->out);
    bar->stage[0] = 0;
}

FILE *prt_atomic_open(const char *path, char *tmp, size_t tmpcap, prt_error *err) {
    if (!path || !*path) { prt_fail(err, "empty output path"); return NULL; }
    snprintf(tmp, tmpcap, "%s.tmp.%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    if (!f) { prt_fail(err, "%s: cannot write: %s", path, strerror(errno)); return NULL; }
    return f;
}

int prt_atomic_commit(FILE *f, const char *tmp, const char *path, prt_error *err) {
    int bad = ferror(f);
    if (fflush(f) != 0) bad = 1;
    if (fclose(f) != 0) bad = 1;
    if (bad) { remove(tmp); return prt_fail(err, "%s: write failed (disk full?)", path); }
    if (rename(tmp, path) != 0) {
        int e = errno;
        remove(tmp);
        return prt_fail(err, "%s: cannot rename temporary file: %s", path, strerror(e));
    }
    return 0;
}

void prt_atomic_abort(FILE *f, const char *tmp) {
    if (f) fclose(f);
    if (tmp && *tmp) remove(tmp);
}

/* Splits path into its folder ("." when none) and base name; false if either does not fit. */
static bool split_path(const char *path, char *dir, size_t dcap, const char **base) {
    const char *slash = strrchr(path, '/');
    *base = slash ? slash + 1 : path;
    size_t n = slash ? (size_t)(slash - path) : 1;
    if (slash && n == 0) n = 1;   /* "/x": the root */
    if (n >= dcap) return false;
    if (slash) memcpy(dir, path, n);
    else dir[0] = '.';
    dir[n] = 0;
    return true;
}

/* The pid of a temporary of base named name ("<base>.tmp.<digits>[.<ext>]"), else 0. */
static long stale_pid(const char *name, const char *base) {
    size_t bl = strlen(base);
    if (strncmp(name, base, bl) != 0 || strncmp(name + bl, ".tmp.", 5) != 0) return 0;
    const char *p = name + bl + 5;
    char *end;
    if (!isdigit((unsigned char)*p)) return 0;
    long pid = strtol(p, &end, 10);
    if (*end && (*end != '.' || strchr(end + 1, '.') || strchr(end + 1, '/'))) return 0;
    return pid > 0 ? pid : 0;
}

int prt_atomic_clean(const char *path, char *first, size_t firstcap) {
    char dir[4096];
    const char *base;
    if (first && firstcap) first[0] = 0;
    if (!path || !*path || !split_path(path, dir, sizeof dir, &base) || !*base) return 0;
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        long pid = stale_pid(e->d_name, base);
        /* kill(pid, 0) fails with ESRCH only when no such process exists (EPERM: it runs as another user) */
        if (!pid || pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        char full[8192];
        snprintf(full, sizeof full, "%s/%s", dir, e->d_name);
        if (remove(full) != 0) continue;
        if (n++ == 0 && first && firstcap) snprintf(first, firstcap, "%s", strcmp(dir, ".") ? full : e->d_name);
    }
    closedir(d);
    return n;
}

int prt_output_check(const char *path, const char *const *exts, prt_error *err) {
    if (!path || !*path) return prt_fail(err, "empty output file name");
    char dir[4096];
    const char *base;
    if (strlen(path) > 4000 || !split_path(path, dir, sizeof dir, &base)) return prt_fail(err, "%.60s...: output path too long", path);
    if (!*base) return prt_fail(err, "%s: names a folder, not an output file", path);
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) return prt_fail(err, "%s: is a folder, not an output file", path);
    if (stat(dir, &st) != 0) return prt_fail(err, "%s: folder %s does not exist", path, dir);
    if (!S_ISDIR(st.st_mode)) return prt_fail(err, "%s: %s is not a folder", path, dir);
    if (access(dir, W_OK | X_OK) != 0) return prt_fail(err, "%s: cannot write in folder %s: %s", path, dir, strerror(errno));
    if (!exts) return 0;
    char ext[16], list[256] = "";
    prt_path_ext(path, ext);
    for (const char *const *x = exts; *x; x++) {
        if (!strcmp(ext, *x)) return 0;
        size_t l = strlen(list);
        snprintf(list + l, sizeof list - l, "%s.%s", l ? ", " : "", *x);
    }
    if (!*ext) return prt_fail(err, "%s: no file extension (use %s)", path, list);
    return prt_fail(err, "%s: unsupported output format '.%s' (use %s)", path, ext, list);
}

bool prt_same_file(const char *a, const char *b) {
    struct stat sa, sb;
    bool ea = stat(a, &sa) == 0, eb = stat(b, &sb) == 0;
    if (ea || eb) return ea && eb && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    /* neither exists yet: one name if the folders are one folder and the base names match */
    char da[4096], db[4096];
    const char *ba, *bb;
    if (!split_path(a, da, sizeof da, &ba) || !split_path(b, db, sizeof db, &bb) || !*ba || strcmp(ba, bb)) return false;
    return stat(da, &sa) == 0 && stat(db, &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

void prt_path_ext(const char *path, char ext[16]) {
    ext[0] = 0;
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash)) return;
    size_t i = 0;
    for (const char *p = dot + 1; *p && i < 15; p++) ext[i++] = (char)tolower((unsigned char)*p);
    ext[i] = 0;
}

void *prt_calloc(size_t count, size_t size, prt_error *err) {
    if (count && size > SIZE_MAX / count) { prt_fail(err, "allocation too large"); return NULL; }
    void *p = calloc(count ? count : 1, size ? size : 1);
    if (!p) prt_fail(err, "out of memory allocating %zu bytes", count * size);
    return p;
}
