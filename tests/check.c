/* check.c - counters and helpers for the test harness (see check.h). */
#include "check.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>

check_state check_g;

int check_summary(void) {
    printf("CHECKS %d %d\n", check_g.pass, check_g.fail);
    return check_g.fail ? 1 : 0;
}

const char *check_tmpdir(void) {
    static char dir[256];
    if (!dir[0]) {
        mkdir("build", 0755);
        mkdir("build/tmp", 0755);
        snprintf(dir, sizeof dir, "build/tmp/t%ld", (long)getpid());
        mkdir(dir, 0755);
    }
    return dir;
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
