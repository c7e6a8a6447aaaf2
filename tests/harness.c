/* harness.c - counters, named cases and helpers for the test harness (see harness.h). */
#include "harness.h"
#include "common.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>

check_state check_g;

void check_begin(int argc, char **argv) {
    const char *base = argc > 0 && argv[0] ? strrchr(argv[0], '/') : NULL;
    base = base ? base + 1 : (argc > 0 && argv[0] ? argv[0] : "test");
    if (!strncmp(base, "test_", 5)) base += 5;
    snprintf(check_g.domain, sizeof check_g.domain, "%s", base);
    const char *f = argc > 1 ? argv[1] : getenv("T");
    check_g.filter = f && *f ? f : NULL;
}

int check_wants(const char *name) {
    if (!check_g.filter) return 1;
    char full[256];
    snprintf(full, sizeof full, "%s/%s", check_g.domain, name);
    return strstr(full, check_g.filter) != NULL;
}

void check_case(const char *name, void (*fn)(void)) {
    if (!check_wants(name)) { check_g.cases_skipped++; return; }
    char full[256];
    snprintf(full, sizeof full, "%s/%s", check_g.domain, name);
    int p0 = check_g.pass, f0 = check_g.fail;
    double t0 = prt_now();
    check_g.current = full;
    fn();
    check_g.current = NULL;
    check_g.cases_run++;
    printf("  case %-40s %5d passed, %d failed (%.2fs)\n", full, check_g.pass - p0, check_g.fail - f0, prt_now() - t0);
    fflush(stdout);
}

void check_skip(const char *name, const char *why) {
    check_g.cases_skipped++;
    if (!check_wants(name)) return;
    printf("  case %s/%-*s skipped: %s\n", check_g.domain, (int)(39 - strlen(check_g.domain)), name, why);
    fflush(stdout);
}

int check_summary(void) {
    printf("CHECKS %d %d %d\n", check_g.pass, check_g.fail, check_g.cases_skipped);
    return check_g.fail ? 1 : 0;
}

const char *check_tmpdir(void) {
    static char dir[256];
    if (!dir[0]) {
        mkdir("build", 0755);
        mkdir("build/tmp", 0755);
        /* fresh each run: a t<pid> name alone is reused once pids wrap, with an earlier run's files in it */
        snprintf(dir, sizeof dir, "build/tmp/t%ld-XXXXXX", (long)getpid());
        if (!mkdtemp(dir)) {
            snprintf(dir, sizeof dir, "build/tmp/t%ld", (long)getpid());
            mkdir(dir, 0755);
        }
    }
    return dir;
}

char *check_read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *buf = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)n + 1)) != NULL &&
        fread(buf, 1, (size_t)n, f) != (size_t)n) { free(buf); buf = NULL; }
    fclose(f);
    if (buf) buf[n] = 0;
    if (buf && len) *len = (size_t)n;
    return buf;
}

const char *check_prt_bin(void) {
    const char *b = getenv("PRT_BIN");
    return b && *b ? b : "build/prt";
}

int check_run(const char *cmd, char *out, size_t cap) {
    char full[8192];
    snprintf(full, sizeof full, "%s 2>&1", cmd);
    FILE *p = popen(full, "r");
    if (!p) return -1;
    size_t n = 0;
    char buf[4096];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, p)) > 0) {
        if (out && n + 1 < cap) {
            size_t take = got < cap - 1 - n ? got : cap - 1 - n;
            memcpy(out + n, buf, take);
            n += take;
        }
    }
    if (out && cap) out[n] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
}
