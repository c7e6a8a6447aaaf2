/* test_install.c - the installed library, as someone else's program meets it.
 *
 * `make install PREFIX=<scratch>` must lay out libprt.so.VERSION with its SONAME link and the
 * libprt.so link to that, libprt.a, prt.pc (pkg-config) and the public headers; each installed
 * header must compile on its own with nothing but -I<prefix>/include/prt (pedantic C11, warnings
 * as errors), and prt.h as C++17 into a program that links. examples/relight.c, built by
 * examples/Makefile with pkg-config against the shared and against the static library, must write
 * the image `prt render` writes for the same file, probe and rotation (a small glossy sphere over
 * a floor precomputed here, so a sparse and a vmf transfer; a sky with an off-axis sun written
 * here), and refuse bad input with one line and exit 2 (usage) or 1 (data), writing nothing.
 * Truth: `prt render` of the same inputs. relight.c drives the same library calls in the same
 * order, so the floats agree to rounding (see example_matches_render for the tolerance). */
#include "harness.h"
#include "common.h"
#include "image.h"
#include "probe.h"
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* A sanitized suite installs the sanitized library, whose programs must link the sanitizers. */
#ifdef __SANITIZE_ADDRESS__
#define SAN_MAKE "SAN=1"
#define SAN_CC "-fsanitize=address,undefined"
#else
#define SAN_MAKE ""
#define SAN_CC ""
#endif
/* The suite's own make leaves its jobserver in the environment; these makes are not its rules. */
#define MAKE "env -u MAKEFLAGS -u MFLAGS -u MAKELEVEL make --no-print-directory"

static char g_dir[256], g_prefix[300];   /* the scratch folder (absolute) and the prefix in it */
static int g_installed = -1, g_built = -1;   /* status of make install / of the example's set-up; -1 not run */

static bool exists(const char *path) { struct stat st; return stat(path, &st) == 0; }

static int lines(const char *s) {
    int n = 0;
    for (const char *p = s; *p; p++) n += *p == '\n' || (!p[1]);
    return n;
}

/* Runs `make install` into <scratch>/prefix once; its status. */
static int install(void) {
    if (g_installed >= 0) return g_installed;
    static char out[65536];
    char cmd[8192];
    char abs[PATH_MAX];
    if (!realpath(check_tmpdir(), abs) || strlen(abs) >= sizeof g_dir) {
        fprintf(stderr, "%s: no absolute path of under %zu bytes\n", check_tmpdir(), sizeof g_dir);
        return g_installed = 1;
    }
    memcpy(g_dir, abs, strlen(abs) + 1);
    snprintf(g_prefix, sizeof g_prefix, "%s/prefix", g_dir);
    snprintf(cmd, sizeof cmd, MAKE " %s install PREFIX=%s", SAN_MAKE, g_prefix);
    g_installed = check_run(cmd, out, sizeof out);
    if (g_installed) fprintf(stderr, "%s: %s\n", cmd, out);
    return g_installed;
}

/* Installs, builds examples/ against the copy, precomputes <scratch>/s.prt and writes the sky
 * <scratch>/sky.exr, once; 0 when all of it worked. */
static int example(void) {
    if (g_built >= 0) return g_built;
    static char out[65536];
    char cmd[8192];
    g_built = 1;
    if (install()) return g_built;
    snprintf(cmd, sizeof cmd, "PKG_CONFIG_PATH=%s/lib/pkgconfig " MAKE " -C examples O=%s CFLAGS='-O2 -Wall -Wextra -Werror %s' "
             "LDFLAGS='-Wl,-rpath,%s/lib %s'", g_prefix, g_dir, SAN_CC, g_prefix, SAN_CC);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "building the examples: %s", out);
    char path[400];
    snprintf(path, sizeof path, "%s/s.json", g_dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{ \"models\": [ { \"sphere\": { \"center\": [0, 0.5, 0], \"radius\": 0.5, \"rings\": 12, \"segments\": 24 },\n"
              "                \"material\": \"phong:kd=0.5;ks=0.4;n=30\" } ],\n"
              "  \"floor\": { \"vertices\": 400, \"material\": \"lambert:kd=0.7\" } }\n", f);
        fclose(f);
    }
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s/s.prt --no-bounces --coeffs 32 --vis-res 64 --terms 2 "
             "--glossy vmf --view-level 1 --lobe-samples 16 --quiet", check_prt_bin(), path, g_dir);
    int rp = check_run(cmd, out, sizeof out);
    CHECK(rp == 0, "precompute: %s", out);
    prt_probe sky = { 0 };
    prt_error err = { { 0 } };
    snprintf(path, sizeof path, "%s/sky.exr", g_dir);
    int rs = probe_make_sky(&(sky_desc){ .width = 128, .sun_radius_deg = 4 }, &sky, &err) ||
             image_write(path, &sky.img, &(image_desc){ 0 }, &err);
    CHECK(rs == 0, "%s", err.msg);
    probe_free(&sky);
    g_built = rc || rp || rs;
    return g_built;
}

/* The installed files: the library under its SONAME's chain of links, the archive, prt.pc with
 * the version of common.h, the headers and the program. */
static void files(void) {
    char p[400], link1[256] = "", link2[256] = "", cmd[8192], out[8192];
    CHECK(install() == 0, "make install failed");
    if (g_installed) return;
    snprintf(p, sizeof p, "%s/lib/libprt.so", g_prefix);
    ssize_t n1 = readlink(p, link1, sizeof link1 - 1);
    CHECK(n1 > 10 && !strncmp(link1, "libprt.so.", 10), "%s is not a link to libprt.so.ABI", p);
    snprintf(p, sizeof p, "%s/lib/%s", g_prefix, link1);
    ssize_t n2 = readlink(p, link2, sizeof link2 - 1);
    CHECK(n2 > 0 && !strcmp(link2, "libprt.so." PRT_VERSION_STRING), "%s -> '%s', not libprt.so." PRT_VERSION_STRING, p, link2);
    snprintf(cmd, sizeof cmd, "readelf -d %s/lib/libprt.so." PRT_VERSION_STRING, g_prefix);
    char want[300];
    snprintf(want, sizeof want, "Library soname: [%s]", link1);
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, want), "SONAME is not %s: %s", link1, out);
    const char *const need[] = { "lib/libprt.a", "include/prt/prt.h", "include/prt/runtime.h", "bin/prt" };
    for (int i = 0; i < 4; i++) {
        snprintf(p, sizeof p, "%s/%s", g_prefix, need[i]);
        CHECK(exists(p), "%s not installed", p);
    }
    snprintf(cmd, sizeof cmd, "PKG_CONFIG_PATH=%s/lib/pkgconfig pkg-config --modversion prt", g_prefix);
    CHECK(check_run(cmd, out, sizeof out) == 0 && !strcmp(out, PRT_VERSION_STRING "\n"), "modversion: %s", out);
    snprintf(cmd, sizeof cmd, "PKG_CONFIG_PATH=%s/lib/pkgconfig pkg-config --cflags --libs prt", g_prefix);
    char inc[400], lib[400];
    snprintf(inc, sizeof inc, "-I%s/include/prt ", g_prefix);
    snprintf(lib, sizeof lib, "-L%s/lib -lprt", g_prefix);
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, inc) && strstr(out, lib), "cflags/libs: %s", out);
}

/* A staged install (DESTDIR) puts the files under the stage with the final prefix in prt.pc, and
 * make uninstall with the same DESTDIR leaves no file behind. */
static void destdir_uninstall(void) {
    char cmd[8192], out[16384], p[400];
    CHECK(install() == 0, "make install failed");
    if (g_installed) return;
    snprintf(cmd, sizeof cmd, MAKE " %s install DESTDIR=%s/stage PREFIX=/opt/prt-test", SAN_MAKE, g_dir);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
    snprintf(p, sizeof p, "%s/stage/opt/prt-test/lib/pkgconfig/prt.pc", g_dir);
    char *pc = check_read_file(p, NULL);
    CHECK(pc && strstr(pc, "prefix=/opt/prt-test\n") && strstr(pc, "includedir=/opt/prt-test/include\n"), "%s: %s", p, pc ? pc : "missing");
    free(pc);
    snprintf(cmd, sizeof cmd, MAKE " %s uninstall DESTDIR=%s/stage PREFIX=/opt/prt-test && find %s/stage ! -type d | wc -l",
             SAN_MAKE, g_dir, g_dir);
    int rc = check_run(cmd, out, sizeof out);
    size_t n = strlen(out);
    CHECK(rc == 0 && n >= 3 && !strcmp(out + n - 3, "\n0\n"), "files left after uninstall (the count last): %s", out);
}

/* Each installed header alone, then prt.h from C++: compiled, linked and run. */
static void headers(void) {
    char cmd[8192], out[16384];
    CHECK(install() == 0, "make install failed");
    if (g_installed) return;
    snprintf(cmd, sizeof cmd, "n=0; for h in %s/include/prt/*.h; do n=$((n+1)); printf '#include \"%%s\"\\n' \"${h##*/}\" | "
             "cc -std=c11 -pedantic -Wall -Wextra -Werror -fsyntax-only -I%s/include/prt -x c - || echo \"FAILED: $h\"; done; "
             "echo \"headers: $n\"", g_prefix, g_prefix);
    int rc = check_run(cmd, out, sizeof out);
    const char *s = strstr(out, "headers: ");
    int n = s ? atoi(s + 9) : 0;
    CHECK(rc == 0 && !strstr(out, "FAILED") && n >= 10, "%s", out);
    snprintf(cmd, sizeof cmd, "printf '#include \"prt.h\"\\nint main() { prt_error e; return prt_fail(&e, \"%%%%s\", \"x\") == -1 ? 0 : 1; }\\n' "
             "> %s/cxx.cpp && c++ -std=c++17 -Wall -Wextra -Werror %s %s/cxx.cpp $(PKG_CONFIG_PATH=%s/lib/pkgconfig pkg-config "
             "--cflags --libs prt) -Wl,-rpath,%s/lib -o %s/cxx && %s/cxx", g_dir, SAN_CC, g_dir, g_prefix, g_prefix, g_dir, g_dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "C++: %s", out);
}

/* Largest |a - b| over two images' channels (-1 when either is missing or their sizes differ),
 * and the largest |b|. */
static double max_diff(const char *a, const char *b, double *bmax) {
    prt_image A = { 0 }, B = { 0 };
    prt_error err = { { 0 } };
    double d = -1;
    *bmax = 0;
    if (image_read(a, &A, &err) == 0 && image_read(b, &B, &err) == 0 && A.w == B.w && A.h == B.h && A.c == B.c) {
        d = 0;
        for (long i = 0; i < (long)A.w * A.h * A.c; i++) {
            d = fmax(d, fabs((double)A.data[i] - B.data[i]));
            *bmax = fmax(*bmax, fabs((double)B.data[i]));
        }
    } else if (err.msg[0]) fprintf(stderr, "%s\n", err.msg);
    image_free(&A);
    image_free(&B);
    return d;
}

/* relight links the shared library, relight-static the archive (readelf). */
static void example_links(void) {
    char cmd[8192], out[16384];
    CHECK(example() == 0, "set-up failed");
    if (g_built) return;
    snprintf(cmd, sizeof cmd, "readelf -d %s/relight", g_dir);
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, "[libprt.so."), "relight does not load libprt.so: %s", out);
    snprintf(cmd, sizeof cmd, "readelf -d %s/relight-static", g_dir);
    CHECK(check_run(cmd, out, sizeof out) == 0 && !strstr(out, "libprt"), "relight-static loads libprt: %s", out);
}

/* relight (shared and static) against prt render at 90 degrees; both against the render at 0, to
 * see that the angle turns the light. Tolerance: the same float operations in the same order give
 * the same pixels; 1e-5 of the brightest pixel admits another summation order (a float sum of a
 * few hundred terms), far below the 0 / 90 degree difference. The example takes the library's default
 * backend (cpu), which render takes for a glossy file only when told. An image needs GL
 * (the CPU runtime rasterizes its vertex colours with OSMesa). */
static void example_matches_render(void) {
    char cmd[8192], out[16384], ex[400], st[400], r90[400], r0[400];
    CHECK(example() == 0, "set-up failed");
    if (g_built) return;
    snprintf(ex, sizeof ex, "%s/ex90.exr", g_dir);
    snprintf(st, sizeof st, "%s/st90.exr", g_dir);
    snprintf(r90, sizeof r90, "%s/r90.exr", g_dir);
    snprintf(r0, sizeof r0, "%s/r0.exr", g_dir);
    snprintf(cmd, sizeof cmd, "%s/relight %s/s.prt %s/sky.exr 90 %s 96x72", g_dir, g_dir, g_dir, ex);
    CHECK(check_run(cmd, out, sizeof out) == 0 && strstr(out, "wrote "), "%s: %s", cmd, out);
    snprintf(cmd, sizeof cmd, "%s/relight-static %s/s.prt %s/sky.exr 90 %s 96x72", g_dir, g_dir, g_dir, st);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
    for (int i = 0; i < 2; i++) {
        snprintf(cmd, sizeof cmd, "%s render %s/s.prt --probe %s/sky.exr --light-rotation %d -o %s --size 96x72 --backend cpu",
                 check_prt_bin(), g_dir, g_dir, i ? 0 : 90, i ? r0 : r90);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
    }
    double bmax, d_ex = max_diff(ex, r90, &bmax), bmax0, d_st = max_diff(st, r90, &bmax0);
    CHECK(bmax > 0, "the render is black");
    CHECK_NEAR(d_ex, 0, 1e-5 * bmax, "relight (libprt.so) against prt render");
    CHECK_NEAR(d_st, 0, 1e-5 * bmax, "relight (libprt.a) against prt render");
    double d_turn = max_diff(ex, r0, &bmax0);
    CHECK(d_turn > 0.05 * bmax, "turning the light by 90 degrees changed the image by %g of %g at most", d_turn, bmax);
}

/* Runs relight with args; its status, its output in out. */
static int relight(const char *args, char *out, size_t cap) {
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "cd %s && ./relight %s", g_dir, args);
    return check_run(cmd, out, cap);
}

/* Bad input: one line, exit 2 for usage and 1 for data, no output file. */
static void example_errors(void) {
    char out[8192], o[400];
    CHECK(example() == 0, "set-up failed");
    if (g_built) return;
    snprintf(o, sizeof o, "%s/o.png", g_dir);
    static const struct { const char *args, *says; int rc; } bad[] = {
        { "", "usage: relight", 2 },
        { "s.prt sky.exr 90", "usage: relight", 2 },
        { "s.prt sky.exr ninety o.png", "ninety", 2 },
        { "s.prt sky.exr 90 o.png 96y72", "96y72", 2 },
        { "s.prt sky.exr 90 o.bmp", "bmp", 2 },
        { "s.prt sky.exr 90 nofolder/o.png", "nofolder", 2 },
        { "missing.prt sky.exr 90 o.png", "missing.prt", 1 },
        { "s.prt nosky.exr 90 o.png", "nosky.exr", 1 },
        { "sky.exr sky.exr 90 o.png", "sky.exr", 1 },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = relight(bad[i].args, out, sizeof out);
        CHECK(rc == bad[i].rc && lines(out) == 1 && strstr(out, bad[i].says) && !exists(o),
              "relight %s: status %d (want %d), output: %s", bad[i].args, rc, bad[i].rc, out);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(files);
    CHECK_CASE(destdir_uninstall);
    CHECK_CASE(headers);
    CHECK_CASE(example_links);
    CHECK_CASE_GL(example_matches_render);
    CHECK_CASE(example_errors);
    return check_summary();
}
