/* test_resume.c - resumable precompute through the prt command.
 *
 * The scene: a glossy sphere (Phong, SVD with K = 2, so records hold several vectors) on a
 * Lambert floor, 282 vertices, one forced bounce: small enough for a few seconds a run, with a
 * direct pass and a gathering pass of about 50 checkpoint flushes each (2% of the vertices).
 *
 * Truth: the file of an uninterrupted run. Two runs differ only in their timings (the META
 * section's times, peak memory and the plan's durations, each material's factorization time), so
 * files are compared after prt_data's timing fields are zeroed and each number of the plan text
 * made one '#': every other byte (mesh, materials, factors, the transport set, rays, energies, the
 * truncation error) must be identical, written again through prtfile_write and compared with
 * memcmp. Cases:
 *   killed_direct: SIGKILL (PRT_CHECKPOINT_KILL, checkpoint.h) after 30 flushes, in the direct
 *                  pass; --resume with other options refused with one line naming the checkpoint
 *                  (exit 1, no output, checkpoint kept); --resume: the identical file, "150 of 282"
 *                  vertices said, the checkpoint removed;
 *   killed_bounce: killed after 75 flushes, in the gathering pass, the checkpoint then cut inside a
 *                  record (a kill mid-write): the identical file;
 *   killed_vmf:    the sphere on the vMF path (Haar diffuse + vMF lobes), killed inside the vMF
 *                  gathering pass: the identical file, lobes included;
 *   killed_shared: a shared coefficient budget (--budget shared), killed in the gathering pass: the
 *                  identical file (the staged candidates, not chosen vectors, are what is recorded);
 *   killed_twice:  killed after 20, resumed on one thread (every other run uses two: the work is
 *                  deterministic per vertex) and killed after 40 more, resumed: the identical file;
 *                  OUT.prt.tmp.PID of a dead process removed, one of a live process kept;
 *   textured_changed: a textured quad killed, resumed with another texture (refused: the key holds
 *                  the texels the gathering pass's triangle means read), then with its own. */
#include "harness.h"
#include "image.h"
#include "prtfile.h"
#include "vmf.h"
#include "prt_normalize.h"
#include <ctype.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char g_dir[512];
static const char *k_opts = "--vis-res 64 --coeffs 16 --bounces 1 --force-bounces --gather-res 4 --quiet";
/* appended: the sphere's path (most cases: the SVD, K = 2; vmf: Haar diffuse + vMF lobes) */
#define K_SVD "--glossy svd --terms 2 --no-refine"   /* the counts below are the input's 282 vertices */
static const char *k_vmf = "--glossy vmf --view-level 1 --lobe-samples 16";

static bool exists(const char *path) { struct stat st; return stat(path, &st) == 0; }

/* Runs `prt precompute SCENE -o OUT OPTS EXTRA` with env ENV (may be ""); returns its status, output in buf. */
static int precompute(const char *env, const char *out, const char *extra, char *buf, size_t cap) {
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "%s %s precompute %s/scene.json -o %s/%s %s %s %s", env, check_prt_bin(), g_dir, g_dir, out,
             k_opts, strstr(extra, "--glossy") ? "" : K_SVD, extra);
    return check_run(cmd, buf, cap);
}

static void reference(int kind);


/* The uninterrupted runs: the SVD sphere, its vMF path, and the SVD sphere with a shared budget. */
static const char *k_refs[3] = { "reference.prt", "vmf-reference.prt", "shared-reference.prt" };

/* name's file equals the uninterrupted run's (k_refs by the name's start: vmf..., shared..., else the
 * first) but for the timings. */
static void check_same(const char *name, const char *what) {
    int kind = !strncmp(name, "vmf", 3) ? 1 : !strncmp(name, "shared", 6) ? 2 : 0;
    reference(kind);
    size_t na = 0, nb = 0;
    char *a = prt_normalized(g_dir, k_refs[kind], &na), *b = prt_normalized(g_dir, name, &nb);
    CHECK(a && b && na == nb && memcmp(a, b, na) == 0, "%s: %s differs from the uninterrupted run (%zu vs %zu bytes)", what, name, nb, na);
    free(a);
    free(b);
}

static void setup(void) {
    snprintf(g_dir, sizeof g_dir, "%s", check_tmpdir());
    char p[1024];
    snprintf(p, sizeof p, "%s/scene.json", g_dir);
    FILE *f = fopen(p, "w");
    if (f) {
        fputs("{ \"models\": [ { \"sphere\": { \"center\": [0, 0.5, 0], \"radius\": 0.5, \"rings\": 8, \"segments\": 12 },\n"
              "                \"material\": \"phong:kd=0.3;ks=0.4;n=20\" } ],\n  \"floor\": { \"vertices\": 200 } }\n", f);
        fclose(f);
    }
}

/* The uninterrupted run k_refs[kind], made once (when a case first needs it). */
static void reference(int kind) {
    char p[1024], buf[8192];
    const char *name = k_refs[kind];
    snprintf(p, sizeof p, "%s/%s", g_dir, name);
    if (exists(p)) return;
    static const char *extra[3] = { "--threads 2", NULL, "--threads 2 --budget shared" };
    int rc = precompute("", name, kind == 1 ? k_vmf : extra[kind], buf, sizeof buf);   /* what an uninterrupted run writes */
    CHECK(rc == 0, "the uninterrupted run failed (%d): %s", rc, buf);
}

/* Kills a run after each count of flushes in kills[] in turn (each resuming the last); before
 * the final --resume, prepare(ck) may alter the checkpoint. Returns the final run's status, its
 * output in buf (run without --quiet: the resume message). */
static int kill_and_resume(const char *out, const char *opts, const int *kills, int n, void (*prepare)(const char *ck), char *buf,
                           size_t cap) {
    char ck[1100], env[64], path[1024], cmd[8192];
    snprintf(path, sizeof path, "%s/%s", g_dir, out);
    snprintf(ck, sizeof ck, "%s.ckpt", path);
    for (int i = 0; i < n; i++) {
        snprintf(env, sizeof env, "PRT_CHECKPOINT_KILL=%d", kills[i]);
        char extra[512];
        snprintf(extra, sizeof extra, "%s %s", i ? "--resume --threads 1" : "--threads 2", opts);
        int rc = precompute(env, out, extra, buf, cap);
        CHECK(rc != 0 && exists(ck) && !exists(path), "%s: run %d was not killed (status %d, checkpoint %d)", out, i, rc, exists(ck));
    }
    if (prepare) prepare(ck);
    snprintf(cmd, sizeof cmd, "%s precompute %s/scene.json -o %s %s %s --resume", check_prt_bin(), g_dir, path,
             "--vis-res 64 --coeffs 16 --bounces 1 --force-bounces --gather-res 4", *opts ? opts : K_SVD);
    int rc = check_run(cmd, buf, cap);
    CHECK(rc == 0, "%s: the resumed run failed (%d): %s", out, rc, buf);
    CHECK(!exists(ck), "%s: the checkpoint was not removed", out);
    return rc;
}

/* Before resuming: the same checkpoint asked for with other options is refused with one line
 * naming it (exit 1, no output), and kept. */
static void refuse_other(const char *ck) {
    char buf[8192];
    int rc = precompute("", "direct.prt", "--resume --coeffs 8", buf, sizeof buf);
    int lines = 0;
    for (const char *c = buf; *c; c++) lines += *c == '\n';
    CHECK(rc == 1 && lines == 1 && strstr(buf, "direct.prt.ckpt: checkpoint of other inputs or options"), "status %d: %s", rc, buf);
    CHECK(exists(ck), "the refused checkpoint was removed");
}

/* Before resuming: the checkpoint cut 7 bytes short, inside its last record (a kill mid-write). */
static void cut(const char *ck) {
    struct stat st;
    CHECK(stat(ck, &st) == 0 && truncate(ck, st.st_size - 7) == 0, "cannot cut %s", ck);
}

/* Before resuming: temporaries of the output, of a dead process (a pid above the kernel's
 * pid_max, 2^22 at most) and of this live one. */
static char g_dead[1100], g_live[1100];
static void temporaries(const char *ck) {
    snprintf(g_dead, sizeof g_dead, "%.*s.tmp.%d", (int)(strlen(ck) - 5), ck, 99999999);
    snprintf(g_live, sizeof g_live, "%.*s.tmp.%d", (int)(strlen(ck) - 5), ck, (int)getpid());
    FILE *f = fopen(g_dead, "w"), *g = fopen(g_live, "w");
    if (f) fclose(f);
    if (g) fclose(g);
}

/* Killed after 30 flushes of 5 vertices (2% of 282): inside the direct pass; a resume with other
 * options refused first; the resume says it took 150 vertices. */
static void killed_direct(void) {
    char buf[8192];
    static const int at[] = { 30 };
    kill_and_resume("direct.prt", "", at, 1, refuse_other, buf, sizeof buf);
    CHECK(strstr(buf, "direct.prt.ckpt: visibility+transport 150 of 282 vertices done"), "resume message: %s", buf);
    check_same("direct.prt", "killed after 30 flushes (direct pass)");
}

/* Killed after 75 flushes: inside the gathering pass (the direct pass is 57), the checkpoint then
 * cut inside a record. */
static void killed_bounce(void) {
    char buf[8192];
    static const int at[] = { 75 };
    kill_and_resume("bounce.prt", "", at, 1, cut, buf, sizeof buf);
    CHECK(strstr(buf, "visibility+transport 282 of 282 vertices done, bounce 1 "), "resume message: %s", buf);
    check_same("bounce.prt", "killed in the bounce pass, checkpoint cut in a record");
}

/* Killed after 20 flushes, resumed on one thread (the others on two) and killed after 40 more
 * (across the passes' boundary), then resumed with a dead run's temporary beside the output (removed) and a live one's (kept). */
static void killed_twice(void) {
    char buf[8192];
    static const int at[] = { 20, 40 };
    kill_and_resume("twice.prt", "", at, 2, temporaries, buf, sizeof buf);
    check_same("twice.prt", "killed twice");
    CHECK(!exists(g_dead) && strstr(buf, "stale temporary file(s) of killed runs"), "the dead run's temporary was not removed: %s", buf);
    CHECK(exists(g_live), "the temporary of a live process was removed");
    remove(g_live);
}

/* The sphere on the vMF path, which the plan refines (its 86 vertices grow to 215, the scene's 282 to
 * 411: refinement is deterministic, so the resumed run refines alike): killed after 150 flushes,
 * inside the vMF gathering pass, resumed: the identical file, vMF lobes included. */
static void killed_vmf(void) {
    char buf[8192];
    static const int at[] = { 150 };
    kill_and_resume("vmf.prt", k_vmf, at, 1, NULL, buf, sizeof buf);
    CHECK(strstr(buf, "411 of 411 vertices done, bounce 1 411, vmf direct 215, vmf pass 1 "), "resume message: %s", buf);
    check_same("vmf.prt", "killed in the vMF gathering pass");
}

/* A shared coefficient budget (--budget shared: the passes stage candidates, chosen at the end of each):
 * killed after 75 flushes, inside the gathering pass, resumed: the identical file. */
static void killed_shared(void) {
    char buf[8192];
    static const int at[] = { 75 };
    kill_and_resume("shared.prt", "--budget shared " K_SVD, at, 1, NULL, buf, sizeof buf);
    CHECK(strstr(buf, "visibility+transport 282 of 282 vertices done, bounce 1 "), "resume message: %s", buf);
    check_same("shared.prt", "shared budget, killed in the bounce pass");
}

/* A textured quad's 8 x 8 checker of albedos a and b (sRGB PNG) as tq.png. */
static void write_checker(double a, double b) {
    prt_image im;
    prt_error err;
    char p[1024];
    snprintf(p, sizeof p, "%s/tq.png", g_dir);
    CHECK(image_alloc(&im, 8, 8, 3, &err) == 0, "%s", err.msg);
    for (int i = 0; i < 64; i++)
        for (int c = 0; c < 3; c++) im.data[3 * i + c] = (float)((i / 8 + i % 8) & 1 ? a : b);
    image_desc d = { 0 };
    CHECK(image_write(p, &im, &d, &err) == 0, "%s", err.msg);
    image_free(&im);
}

/* A textured quad (an OBJ naming its MTL and map_Kd) bent up along one edge, so the gathering pass
 * takes the texture's triangle means: killed after 10 flushes, resumed with another texture: refused
 * with one line naming the checkpoint (the key holds the texels), the checkpoint kept; resumed with
 * the first texture again: done. */
static void textured_changed(void) {
    char p[1024], cmd[8192], buf[8192];
    snprintf(p, sizeof p, "%s/tq.mtl", g_dir);
    FILE *f = fopen(p, "w");
    if (f) fputs("newmtl t\nKd 1 1 1\nmap_Kd tq.png\n", f), fclose(f);
    snprintf(p, sizeof p, "%s/tq.obj", g_dir);
    f = fopen(p, "w");
    if (f) {
        fputs("mtllib tq.mtl\n", f);
        for (int j = 0; j < 9; j++)   /* x <= 0.5 flat, beyond it rising at 45 degrees */
            for (int i = 0; i < 9; i++) fprintf(f, "v %g %g %g\nvt %g %g\n", i / 8.0, i > 4 ? (i - 4) / 8.0 : 0, j / 8.0, i / 8.0, j / 8.0);
        fputs("usemtl t\n", f);
        for (int j = 0; j < 8; j++)
            for (int i = 0; i < 8; i++) {
                int a = 9 * j + i + 1;
                fprintf(f, "f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n", a, a, a + 9, a + 9, a + 10, a + 10, a, a, a + 10, a + 10, a + 1, a + 1);
            }
        fclose(f);
    }
    write_checker(0.8, 0.2);
    char ck[1100];
    snprintf(ck, sizeof ck, "%s/tq.prt.ckpt", g_dir);
    for (int run = 0; run < 3; run++) {
        snprintf(cmd, sizeof cmd, "%s %s precompute %s/tq.obj -o %s/tq.prt %s --threads 2%s", run ? "" : "PRT_CHECKPOINT_KILL=10",
                 check_prt_bin(), g_dir, g_dir, k_opts, run ? " --resume" : "");
        if (run == 1) write_checker(0.3, 0.9);
        if (run == 2) write_checker(0.8, 0.2);
        int rc = check_run(cmd, buf, sizeof buf), lines = 0;
        for (const char *c = buf; *c; c++) lines += *c == '\n';
        if (run == 0) CHECK(rc != 0 && exists(ck), "the run was not killed (status %d): %s", rc, buf);
        if (run == 1)
            CHECK(rc == 1 && lines == 1 && strstr(buf, "tq.prt.ckpt: checkpoint of other inputs or options") && exists(ck),
                  "another texture: status %d: %s", rc, buf);
        if (run == 2) CHECK(rc == 0 && !exists(ck), "the first texture again: status %d: %s", rc, buf);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE(killed_direct);
    CHECK_CASE(killed_bounce);
    CHECK_CASE(killed_twice);
    CHECK_CASE(killed_vmf);
    CHECK_CASE(killed_shared);
    CHECK_CASE(textured_changed);
    return check_summary();
}
