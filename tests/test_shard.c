/* test_shard.c - `prt precompute` split across MPI ranks (shard.h).
 *
 * Truth: the file of one process on the same scene. Two runs differ only in their timings (the
 * META timing fields, the plan's numbers), so both files are read, those zeroed and blanked, and
 * written again through prtfile_write and compared with memcmp (as test_resume does): every
 * vector, scale, statistic and byte of the mesh must be identical. Cases:
 *   direct      --no-bounces, one process on 2 threads against `mpirun -np 2` on 1 thread each
 *               (the Lambert scene; the Phong one's two vectors per vertex are in bounces);
 *   bounces     two forced gathering passes (the second split by the first's measured times),
 *               against one process; -np 3 too (uneven ranges);
 *   rank_fails  PRT_SHARD_FAIL=1 (rank 1 fails after its share of the direct pass): exit 1, no
 *               output file, and exactly one line of output, naming the rank and the reason;
 *   resume      --resume under mpirun: refused with one line, exit 2;
 *   streamed    --memory 0.0001 (the direct pass's staged vectors through a temporary file,
 *               transport_stage_to_file) with a bounce pass: the in-memory run's file, the
 *               streaming said on stderr, no file left beside the output; and under -np 2.
 *   vmf         the vMF lobe passes (--glossy vmf, two gathering passes) under -np 2;
 *   cpca        clustered PCA (--basis cpca: its clusters and basis made after the passes) with the open
 *               sky split, one process on 2 threads against -np 2 on 1 thread each;
 *   binding     one process on all cores, one under taskset -c 0, and -np 2 under mpirun's default
 *               core binding: the same bytes (the factorization runs on one OpenBLAS thread,
 *               factor.c; else its last bits would follow the cores a process may use).
 * The other cases run the ranks unbound (--bind-to none): binding is the binding case's. The Phong sphere
 * (K = 2) runs where the factorization matters; the
 * cases about failing use a Lambert one (no factorization time).
 * Every case is skipped, with the reason printed, when mpirun is not installed. Runs as root need
 * OpenMPI's OMPI_ALLOW_RUN_AS_ROOT; the sanitizer build's leak check is off under mpirun (OpenMPI
 * keeps allocations until exit). */
#include "harness.h"
#include "prtfile.h"
#include "prt_normalize.h"
#include <ctype.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static char g_dir[512];
static const char *k_opts = "--vis-res 64 --coeffs 16 --gather-res 4 --glossy svd --terms 2 --quiet";
static const char *k_mpi = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ASAN_OPTIONS=detect_leaks=0 "
                           "mpirun -q --oversubscribe --bind-to none";

static bool exists(const char *path) { struct stat st; return stat(path, &st) == 0; }

/* mpirun is on the PATH (else the cases say so and return). */
static bool have_mpirun(void) {
    if (check_run("command -v mpirun", NULL, 0) == 0) return true;
    printf("  mpirun not found (Debian's openmpi-bin, installed by `make deps`): skipped\n");
    return false;
}

/* Runs `[ENV] [mpirun -np NP] prt precompute SCENE.json -o DIR/OUT OPTS EXTRA` (np 0: no mpirun);
 * returns its status, its output in buf. */
static int run(const char *env, int np, const char *scene, const char *out, const char *extra, char *buf, size_t cap) {
    char cmd[8192], launch[512] = "";
    if (np > 0) snprintf(launch, sizeof launch, "%s -np %d", k_mpi, np);
    snprintf(cmd, sizeof cmd, "%s %s %s precompute %s/%s.json -o %s/%s %s %s", env, launch, check_prt_bin(), g_dir, scene, g_dir,
             out, k_opts, extra);
    return check_run(cmd, buf, cap);
}

/* run on the Phong sphere's scene. */
static int precompute(const char *env, int np, const char *out, const char *extra, char *buf, size_t cap) {
    return run(env, np, "scene", out, extra, buf, cap);
}


/* Files a and b are the same but for the timings. */
static void check_same(const char *a, const char *b) {
    size_t na = 0, nb = 0;
    char *x = prt_normalized(g_dir, a, &na), *y = prt_normalized(g_dir, b, &nb);
    CHECK(x && y && na == nb && memcmp(x, y, na) == 0, "%s differs from %s (%zu vs %zu bytes)", b, a, nb, na);
    free(x);
    free(y);
}

static int count_lines(const char *s) {
    int n = 0;
    for (; *s; s++) n += *s == '\n';
    return n;
}

/* DIR/name.json: the sphere of material over a 200-vertex floor. */
static void scene(const char *name, const char *material) {
    char p[1024];
    snprintf(p, sizeof p, "%s/%s.json", g_dir, name);
    FILE *f = fopen(p, "w");
    if (f) {
        fprintf(f, "{ \"models\": [ { \"sphere\": { \"center\": [0, 0.5, 0], \"radius\": 0.5, \"rings\": 8, \"segments\": 12 },\n"
                   "                \"material\": \"%s\" } ],\n  \"floor\": { \"vertices\": 200 } }\n", material);
        fclose(f);
    }
}

static void setup(void) {
    snprintf(g_dir, sizeof g_dir, "%s", check_tmpdir());
    scene("scene", "phong:kd=0.3;ks=0.4;n=20");
    scene("lambert", "lambert:kd=0.6");
}

/* Direct pass only: 2 ranks give the one-process file (Lambert scene). */
static void direct(void) {
    if (!have_mpirun()) return;
    char buf[8192];
    int rc = run("", 0, "lambert", "one.prt", "--no-bounces --threads 2", buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    rc = run("", 2, "lambert", "two.prt", "--no-bounces --threads 1", buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 failed (%d): %s", rc, buf);
    if (rc == 0) check_same("one.prt", "two.prt");
}

/* Clustered PCA: its finish (k-means and subspace iteration over every vector) after a direct pass split
 * across 2 ranks gives the one-process file, bit for bit (Lambert scene, the open sky split on). */
static void cpca(void) {
    if (!have_mpirun()) return;
    char buf[8192];
    const char *o = "--no-bounces --basis cpca --basis-options clusters=4,terms=3,coeffs=64,stage=128";
    char a[512], b[512];
    snprintf(a, sizeof a, "%s --threads 2", o);
    snprintf(b, sizeof b, "%s --threads 1", o);
    int rc = run("", 0, "lambert", "one-c.prt", a, buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    rc = run("", 2, "lambert", "two-c.prt", b, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 failed (%d): %s", rc, buf);
    if (rc == 0) check_same("one-c.prt", "two-c.prt");
}

/* Two forced gathering passes: 2 ranks give the one-process file; 3 (uneven ranges) too, on the
 * Lambert scene. */
static void bounces(void) {
    if (!have_mpirun()) return;
    char buf[8192];
    const char *b = "--bounces 2 --force-bounces --threads 1";
    int rc = precompute("", 0, "one-b.prt", "--bounces 2 --force-bounces --threads 2", buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    rc = precompute("", 2, "two-b.prt", b, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 failed (%d): %s", rc, buf);
    if (rc == 0) check_same("one-b.prt", "two-b.prt");
    rc = run("", 0, "lambert", "one-l.prt", "--bounces 2 --force-bounces --threads 2", buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    rc = run("", 3, "lambert", "three-l.prt", b, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 3 failed (%d): %s", rc, buf);
    if (rc == 0) check_same("one-l.prt", "three-l.prt");
}

/* The file does not depend on the cores a process may use (OpenBLAS sizes its pool by them; the
 * factorization runs on a fixed one, factor.c): one process on all cores with 2 threads, one bound
 * to core 0 (taskset) with 1, and -np 2 under mpirun's default binding (a core per rank) all give
 * the same bytes (the direct pass: the Phong scene's two vectors per vertex come from its factors). */
static void binding(void) {
    char buf[8192];
    int rc = precompute("", 0, "free.prt", "--no-bounces --threads 2", buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    if (check_run("command -v taskset", NULL, 0) == 0) {
        rc = precompute("taskset -c 0", 0, "bound.prt", "--no-bounces --threads 1", buf, sizeof buf);
        CHECK(rc == 0, "taskset -c 0 failed (%d): %s", rc, buf);
        if (rc == 0) check_same("free.prt", "bound.prt");
    } else
        printf("  taskset not found (util-linux): the bound process skipped\n");
    if (!have_mpirun()) return;
    char cmd[8192];   /* mpirun's own default binding, not k_mpi's --bind-to none */
    snprintf(cmd, sizeof cmd, "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ASAN_OPTIONS=detect_leaks=0 mpirun -q "
             "--oversubscribe -np 2 %s precompute %s/scene.json -o %s/ranks.prt %s --no-bounces --threads 1",
             check_prt_bin(), g_dir, g_dir, k_opts);
    rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 (default binding) failed (%d): %s", rc, buf);
    if (rc == 0) check_same("free.prt", "ranks.prt");
}

/* The vertices of pass name in the balance of out ("  NAME: N vertices, ..." then one "    rank R
 * COUNT vertices ..." line per rank): returns N, the sum of the rank lines in *sum and their number
 * in *ranks; -1 when the pass is not listed. */
static long balance_of(const char *out, const char *name, long *sum, int *ranks) {
    char key[128];
    snprintf(key, sizeof key, "\n  %s: ", name);
    const char *p = strstr(out, key);
    *sum = 0, *ranks = 0;
    if (!p) return -1;
    long n = strtol(p + strlen(key), NULL, 10);
    const char *rank = "\n    rank ";
    for (p = strchr(p + 1, '\n'); p && strncmp(p, rank, strlen(rank)) == 0; p = strchr(p + 1, '\n')) {
        char *e;
        strtol(p + strlen(rank), &e, 10);   /* the rank */
        *sum += strtol(e, NULL, 10);
        (*ranks)++;
    }
    return n;
}

/* The timing summary's balance under -np 2: every split pass lists both ranks, and their vertices
 * add up to the scene's (282: the 97-vertex sphere and the 185-vertex floor, as the closing line
 * says; not refined); rank 0's bar reaches 100% in every pass and never goes back. */
static void balance(void) {
    if (!have_mpirun()) return;
    char buf[16384], cmd[8192];
    snprintf(cmd, sizeof cmd, "%s -np 2 %s precompute %s/lambert.json -o %s/bal.prt --vis-res 64 --coeffs 16 --gather-res 4 "
             "--bounces 2 --force-bounces --threads 1 --no-refine 2>&1", k_mpi, check_prt_bin(), g_dir, g_dir);
    int rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 failed (%d): %s", rc, buf);
    const char *w = strstr(buf, "\nwrote ");
    w = w ? strstr(w, " MB, ") : NULL;
    long nverts = w ? strtol(w + 5, NULL, 10) : 0;
    CHECK(nverts == 282 && strstr(buf, "\nbalance over 2 ranks\n"), "closing line or balance missing (%ld): %s", nverts, buf);
    const char *passes[] = { "visibility+transport", "bounce 1", "bounce 2" };
    for (int i = 0; i < 3; i++) {
        long sum;
        int ranks;
        long n = balance_of(buf, passes[i], &sum, &ranks);
        CHECK(n == nverts && sum == nverts && ranks == 2, "%s: %ld vertices listed, the ranks' add up to %ld over %d lines (want %ld, 2)",
              passes[i], n, sum, ranks, nverts);
        char key[64];
        snprintf(key, sizeof key, "%s: ", passes[i]);
        int last = -1, ok = 1;
        for (const char *q = strstr(buf, key); q; q = strstr(q + 1, key)) {   /* "NAME:  70%  (..." lines */
            int pct = 0, len = 0;
            if ((q != buf && q[-1] != '\n') || sscanf(q + strlen(key), "%d%n", &pct, &len) != 1 || q[strlen(key) + len] != '%') continue;
            ok &= pct >= last;
            last = pct;
        }
        CHECK(ok && last == 100, "%s: the bar went back or stopped at %d%%", passes[i], last);
    }
}

/* The vMF lobe passes split across ranks (vmfpass.c): the Phong sphere on the vMF path (2 lobes, 42
 * views, 32 rays per slice) with two gathering passes gives the one-process file under -np 2, and
 * the file does hold stored slices of three passes (uneven ranges: the bounces case's -np 3). */
static void vmf(void) {
    if (!have_mpirun()) return;
    char buf[8192];
    const char *o = "--glossy vmf --view-level 1 --lobe-samples 32 --bounces 2 --force-bounces";
    char one[512], many[512];
    snprintf(one, sizeof one, "%s --threads 2", o);
    snprintf(many, sizeof many, "%s --threads 1", o);
    int rc = precompute("", 0, "vmf1.prt", one, buf, sizeof buf);
    CHECK(rc == 0, "one process failed (%d): %s", rc, buf);
    prt_data d;
    prt_error err;
    char p[1024];
    snprintf(p, sizeof p, "%s/vmf1.prt", g_dir);
    if (rc == 0 && prtfile_read(p, &d, &err) == 0) {
        const vmft_data *t = NULL;
        for (int i = 0; i < d.ntransfers; i++)
            if (strcmp(d.transfers[i].ops->name, "vmf") == 0) t = vmft_get(&d.transfers[i]);
        CHECK(t && t->hash.n > 0 && t->passes == 3, "no vmf transfer with stored slices of 3 passes (%zu slices, %d passes)",
              t ? t->hash.n : 0, t ? t->passes : 0);
        prt_data_free(&d);
    }
    rc = precompute("", 2, "vmf2.prt", many, buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 failed (%d): %s", rc, buf);
    if (rc == 0) check_same("vmf1.prt", "vmf2.prt");
}

/* Rank 1 fails mid-run: one line, exit 1, no file. */
static void rank_fails(void) {
    if (!have_mpirun()) return;
    char buf[8192], p[1024];
    snprintf(p, sizeof p, "%s/fail.prt", g_dir);
    int rc = run("PRT_SHARD_FAIL=1", 2, "lambert", "fail.prt", "--bounces 1 --force-bounces --threads 1", buf, sizeof buf);
    CHECK(rc == 1, "exit status %d (expected 1): %s", rc, buf);
    CHECK(!exists(p), "an output file was written");
    int lines = count_lines(buf);
    CHECK(lines == 1 && strstr(buf, "prt precompute: rank 1 of 2: test hook: rank 1 fails"), "output (%d lines): %s", lines, buf);
}

/* --resume is one process's: refused under mpirun with one line. */
static void resume(void) {
    if (!have_mpirun()) return;
    char buf[8192];
    int rc = run("", 2, "lambert", "resume.prt", "--no-bounces --resume", buf, sizeof buf);
    CHECK(rc == 2 && strstr(buf, "--resume cannot be combined with 2 MPI ranks") && count_lines(buf) == 1, "exit %d: %s", rc, buf);
}

/* The streamed direct pass gives the in-memory file, one process and two ranks. */
static void streamed(void) {
    char buf[8192], cmd[8192];
    const char *b = "--bounces 1 --force-bounces --threads 2";
    int rc = precompute("", 0, "mem.prt", b, buf, sizeof buf);
    CHECK(rc == 0, "in-memory run failed (%d): %s", rc, buf);
    snprintf(cmd, sizeof cmd, "%s precompute %s/scene.json -o %s/stream.prt --vis-res 64 --coeffs 16 --gather-res 4 --glossy svd --terms 2 %s --memory 0.0001",
             check_prt_bin(), g_dir, g_dir, b);
    rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "streamed through a temporary file in "), "streamed run (%d): %s", rc, buf);
    if (rc == 0) check_same("mem.prt", "stream.prt");
    snprintf(cmd, sizeof cmd, "ls -A %s | grep -v -E '\\.(prt|json|norm)$'", g_dir);
    CHECK(check_run(cmd, buf, sizeof buf) != 0, "left beside the output: %s", buf);
    if (!have_mpirun()) return;
    rc = precompute("", 2, "stream2.prt", "--bounces 1 --force-bounces --threads 1 --memory 0.0001", buf, sizeof buf);
    CHECK(rc == 0, "mpirun -np 2 --memory failed (%d): %s", rc, buf);
    if (rc == 0) check_same("mem.prt", "stream2.prt");
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE(direct);
    CHECK_CASE(bounces);
    CHECK_CASE(binding);
    CHECK_CASE(balance);
    CHECK_CASE(vmf);
    CHECK_CASE(cpca);
    CHECK_CASE(rank_fails);
    CHECK_CASE(resume);
    CHECK_CASE(streamed);
    return check_summary();
}
