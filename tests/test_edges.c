/* test_edges.c - the rough edges a new user hits, through the CLI.
 *
 * Each case runs build/prt as a user would and checks the exit status, the one line
 * that names the file or flag and the problem, and that no output file and no
 * temporary file is left behind; where an item changes numbers (a 1e37 sun) the
 * case checks them against an independent truth (the same scene under a 1e30 sun,
 * scaled: light transport is linear in the light). */
#include "harness.h"
#include "brdf.h"
#include "camera.h"
#include "image.h"
#include "mesh.h"
#include <dirent.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char g_dir[4096], g_bin[4096];   /* absolute: the commands run inside g_dir */

static void write_bytes(const char *name, const void *bytes, size_t n) {
    char p[4200];
    snprintf(p, sizeof p, "%s/%s", g_dir, name);
    FILE *f = fopen(p, "wb");
    if (f) { fwrite(bytes, 1, n, f); fclose(f); }
}
static void write_file(const char *name, const char *text) { write_bytes(name, text, strlen(text)); }

static bool exists(const char *path) { struct stat st; return stat(path, &st) == 0; }

/* Files in the scratch folder whose name contains ".tmp." (left-over temporaries). */
static int temporaries(void) {
    int n = 0;
    DIR *d = opendir(g_dir);
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, ".tmp.")) n++;
    if (d) closedir(d);
    return n;
}

/* Lines of s (a trailing newline does not start a new line). */
static int lines(const char *s) {
    int n = 0;
    for (const char *p = s; *p; p++) n += *p == '\n';
    if (*s && s[strlen(s) - 1] != '\n') n++;
    return n;
}

/* Cuts LeakSanitizer's "Suppressions used" report (make test SAN=1, after OSMesa's known leaks,
 * gpu/glctx.c) from a command's output: it is the sanitizer's, not prt's. */
static void strip_lsan(char *buf) {
    char *p = strstr(buf, "-----------------------------------------------------\nSuppressions used:");
    if (p) *p = 0;
}

/* Runs `prt ARGS` in the scratch folder into buf; returns the exit status. */
static int run_prt(const char *args, char *buf, size_t cap) {
    char cmd[16384];
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' %s", g_dir, g_bin, args);
    int rc = check_run(cmd, buf, cap);
    strip_lsan(buf);
    return rc;
}

/* Runs the shell line SH (PRT in it is replaced by the binary) in the scratch folder. */
static int run_sh(const char *sh, char *buf, size_t cap) {
    char cmd[16384], *o = cmd;
    o += snprintf(o, sizeof cmd, "cd '%s' && ", g_dir);
    for (const char *p = sh; *p && o < cmd + sizeof cmd - 4200;) {
        if (!strncmp(p, "PRT", 3)) { o += snprintf(o, 4200, "'%s'", g_bin); p += 3; }
        else *o++ = *p++;
    }
    *o = 0;
    int rc = check_run(cmd, buf, cap);
    strip_lsan(buf);
    return rc;
}

/* `prt ARGS` must exit with status want, print one line naming needle, leave no out nor temporary. */
static void expect_fail(const char *args, int want, const char *needle, const char *out) {
    char buf[8192], p[4200];
    int rc = run_prt(args, buf, sizeof buf);
    CHECK(rc == want, "%s: exit status %d, want %d: %s", args, rc, want, buf);
    CHECK(lines(buf) == 1, "%s: want one line, got:\n%s", args, buf);
    CHECK(strstr(buf, needle) != NULL, "%s: message does not name '%s': %s", args, needle, buf);
    CHECK(!strstr(buf, ".tmp."), "%s: the message shows a temporary name: %s", args, buf);
    if (out) {
        snprintf(p, sizeof p, "%s/%s", g_dir, out);
        CHECK(!exists(p), "%s: output %s was left behind", args, out);
    }
    CHECK(temporaries() == 0, "%s: a temporary file was left behind", args);
}

/* The scratch inputs: two squares (the lower lit around the upper's shadow), a noisy probe
 * (so that images do not compress to nothing) and the precomputed file sq.prt. */
static void setup(void) {
    if (!realpath(check_tmpdir(), g_dir) || !realpath(check_prt_bin(), g_bin)) CHECK(!"realpath", "%s", check_prt_bin());
    write_file("sq.obj", "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 0 0\n"
                         "v -0.2 0.5 -0.2\nv 0.2 0.5 -0.2\nv 0.2 0.5 0.2\nv -0.2 0.5 0.2\n"
                         "f 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\nf 6 9 8 7\n");
    prt_image im = { 0 };
    prt_error err;
    char p[4200], buf[8192];
    image_alloc(&im, 128, 64, 3, &err);
    unsigned s = 12345;
    for (int i = 0; i < 128 * 64 * 3; i++) {
        s = s * 1103515245u + 12345u;
        im.data[i] = 0.2f + (float)((s >> 16) & 1023) / 1023.f;
    }
    snprintf(p, sizeof p, "%s/noise.exr", g_dir);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
    int rc = run_prt("precompute sq.obj --floor 400 --texel-measure --no-bounces -o sq.prt --quiet", buf, sizeof buf);
    CHECK(rc == 0, "precompute sq.prt: %d %s", rc, buf);
}

/* A write cut short (a file-size limit standing in for a full disk) fails with one
 * line for every output format, leaving neither the output nor a temporary. */
static void full_disk(void) {
    /* PNG was the format that reported success; EXR and JPEG stand for the others (one path for all) */
    static const char *const k_ext[] = { "png", "exr", "jpg" };
    char sh[1024], buf[8192], p[4200];
    /* dash's ulimit -f counts 512-byte blocks; SIGXFSZ ignored so that write() fails with EFBIG */
    int rc = run_sh("ulimit -f 8 && trap '' XFSZ && echo limited", buf, sizeof buf);
    if (rc != 0 || !strstr(buf, "limited")) {
        printf("  skipped edges/full_disk: the shell cannot set a file-size limit (%s)\n", buf);
        return;
    }
    for (size_t i = 0; i < sizeof k_ext / sizeof k_ext[0]; i++) {
        char out[64];
        snprintf(out, sizeof out, "big.%s", k_ext[i]);
        snprintf(sh, sizeof sh, "ulimit -f 8; trap '' XFSZ; exec PRT render sq.prt --probe noise.exr -o %s --size 400x300", out);
        rc = run_sh(sh, buf, sizeof buf);
        CHECK(rc == 1, "%s under a 4 KiB limit: exit %d: %s", out, rc, buf);
        CHECK(strstr(buf, "File too large") && strstr(buf, out), "%s: %s", out, buf);
        CHECK(!strstr(buf, "wrote") && !strstr(buf, ".tmp."), "%s: %s", out, buf);
        snprintf(p, sizeof p, "%s/%s", g_dir, out);
        CHECK(!exists(p), "%s: a cut file was left", out);
        CHECK(temporaries() == 0, "%s: a temporary was left", out);
    }
    /* the .prt writer too */
    rc = run_sh("ulimit -f 8; trap '' XFSZ; exec PRT precompute sq.obj --floor 2000 --no-bounces -o cut.prt --quiet", buf, sizeof buf);
    CHECK(rc == 1 && strstr(buf, "cut.prt") && lines(buf) == 1, "precompute under the limit: %d %s", rc, buf);
    snprintf(p, sizeof p, "%s/cut.prt", g_dir);
    CHECK(!exists(p) && temporaries() == 0, "precompute left a file");
    /* a small image fits under the same limit: the limit is what fails above, not the command */
    rc = run_sh("ulimit -f 8; trap '' XFSZ; exec PRT render sq.prt --probe noise.exr -o small.png --size 8x6", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "wrote small.png"), "a small PNG under the limit: %d %s", rc, buf);
}

/* Every output is checked before the work (a missing folder, an empty name, an unknown
 * extension, a folder as the name), usage errors naming the user's path. The inputs do not even
 * exist, so a check made after loading would name them instead. */
static void outputs_first(void) {
    expect_fail("precompute missing.obj -o nodir/x.prt", 2, "nodir/x.prt: folder nodir does not exist", NULL);
    expect_fail("precompute missing.obj -o ''", 2, "empty output file name", NULL);
    expect_fail("render missing.prt --probe missing.exr -o nodir/a.png", 2, "nodir/a.png", NULL);
    expect_fail("render missing.prt --probe missing.exr -o a.xyz", 2, "a.xyz: unsupported output format '.xyz'", "a.xyz");
    expect_fail("render missing.prt --probe missing.exr -o a.png --vertices nodir/v.csv", 2, "nodir/v.csv", NULL);
    expect_fail("compare a.exr b.exr --error-image nodir/e.png", 2, "nodir/e.png", NULL);
    expect_fail("demo -o nodir/demo.png", 2, "nodir/demo.png", NULL);
}

/* A temporary of a killed run (a process that no longer runs) is removed when the same
 * output is written again, with one line saying so; a running process's temporary is kept. */
static void stale_temporaries(void) {
    pid_t child = fork();
    if (child == 0) _exit(0);
    waitpid(child, NULL, 0);   /* a pid that no longer runs */
    char dead[64], dead_old[64], alive[64], buf[8192], p[4200];
    snprintf(dead, sizeof dead, "st.png.tmp.%ld", (long)child);
    snprintf(dead_old, sizeof dead_old, "st.png.tmp.%ld.png", (long)child);   /* the older image writer's name */
    snprintf(alive, sizeof alive, "st.png.tmp.%ld", (long)getpid());
    write_file(dead, "partial");
    write_file(dead_old, "partial");
    write_file(alive, "in progress");
    write_file("other.png.tmp.1x", "not a temporary of ours");
    int rc = run_prt("render sq.prt --probe noise.exr -o st.png --size 16x12", buf, sizeof buf);
    CHECK(rc == 0, "render: %d %s", rc, buf);
    CHECK(strstr(buf, "removed 2 stale temporary file(s) of killed runs (st.png.tmp."), "%s", buf);
    snprintf(p, sizeof p, "%s/%s", g_dir, dead);
    CHECK(!exists(p), "the dead run's temporary is still there");
    snprintf(p, sizeof p, "%s/%s", g_dir, dead_old);
    CHECK(!exists(p), "the dead run's old-style temporary is still there");
    snprintf(p, sizeof p, "%s/%s", g_dir, alive);
    CHECK(exists(p), "a running process's temporary was removed");
    remove(p);
    snprintf(p, sizeof p, "%s/other.png.tmp.1x", g_dir);
    CHECK(exists(p), "an unrelated file was removed");
    remove(p);
    CHECK(temporaries() == 0, "temporaries left");
}

/* A finite but huge sun (1e37 W/sr/m^2-like texels) renders the same image as a 1e30
 * one scaled by 1e7 (transport is linear in the light), finite and not black, on both backends;
 * before, the float Haar transform and the 8-bit kernel overflowed and every pixel was 0 (on gl,
 * until its kernels ran the light scaled too: test_glrt's bright_sun compares gl with cpu). */
static void bright_sun_on(const char *backend) {
    static const float k_sun[2] = { 1e30f, 1e37f };
    prt_image im[2] = { { 0 } }, out[2] = { { 0 } };
    prt_error err;
    char p[4200], args[1024], buf[8192];
    for (int s = 0; s < 2; s++) {
        image_alloc(&im[s], 64, 32, 3, &err);
        for (int y = 5; y < 7; y++)
            for (int x = 20; x < 22; x++)
                for (int c = 0; c < 3; c++) im[s].data[3 * (y * 64 + x) + c] = k_sun[s];
        snprintf(p, sizeof p, "%s/sun%d.exr", g_dir, s);
        CHECK(image_write(p, &im[s], NULL, &err) == 0, "%s", err.msg);
        snprintf(args, sizeof args, "render sq.prt --probe sun%d.exr -o sunr%d.exr --no-background --size 80x60 --backend %s", s, s,
                 backend);
        CHECK(run_prt(args, buf, sizeof buf) == 0, "%s: %s", args, buf);
        snprintf(p, sizeof p, "%s/sunr%d.exr", g_dir, s);
        CHECK(image_read(p, &out[s], &err) == 0, "%s", err.msg);
    }
    double num = 0, den = 0, lit = 0;
    bool finite = true;
    for (int i = 0; out[0].data && out[1].data && i < 80 * 60 * 3; i++) {
        double a = out[1].data[i], b = 1e7 * (double)out[0].data[i];
        finite &= isfinite(out[1].data[i]);
        num += (a - b) * (a - b);
        den += b * b;
        lit += b > 0;
    }
    CHECK(finite, "%s: the 1e37 image has non-finite pixels", backend);
    CHECK(lit > 1000, "%s: the 1e30 image is black (%g lit values)", backend, lit);
    /* both lights quantize to the same 16-bit codes (steps relative to the maximum): only float
     * rounding of the 1e7 ratio differs */
    CHECK_LE(sqrt(num / den), 1e-4, "%s: 1e37 image against the 1e30 one x 1e7 (relative RMS)", backend);
    for (int s = 0; s < 2; s++) { image_free(&im[s]); image_free(&out[s]); }
}

static void bright_sun(void) {
    bright_sun_on("cpu");
    bright_sun_on("gl");
}

/* A UTF-16 or UTF-32 OBJ is refused naming its encoding; a UTF-8 byte-order mark is skipped. */
static void obj_encodings(void) {
    static const struct { const char *name, *bom; size_t n; const char *enc; } k_cases[] = {
        { "u16le.obj", "\xFF\xFEv\0 \0", 6, "UTF-16LE" },
        { "u16be.obj", "\xFE\xFF\0v\0 ", 6, "UTF-16BE" },
        { "u32le.obj", "\xFF\xFE\0\0v\0\0\0", 8, "UTF-32LE" },
        { "u32be.obj", "\0\0\xFE\xFF\0\0\0v", 8, "UTF-32BE" },
    };
    char args[1024];
    for (size_t i = 0; i < sizeof k_cases / sizeof k_cases[0]; i++) {
        char want[128];
        snprintf(want, sizeof want, "%s: the file is %s text", k_cases[i].name, k_cases[i].enc);
        if (i % 2 == 0) {   /* through the CLI (one process each costs a second: two of them) */
            write_bytes(k_cases[i].name, k_cases[i].bom, k_cases[i].n);
            snprintf(args, sizeof args, "precompute %s -o enc.prt --quiet", k_cases[i].name);
            expect_fail(args, 1, want, "enc.prt");
        } else {            /* through the parser the CLI calls */
            prt_mesh m;
            prt_error err = { { 0 } };
            CHECK(mesh_parse_obj(k_cases[i].name, k_cases[i].bom, k_cases[i].n, NULL, &m, &err) == -1 &&
                  strstr(err.msg, want), "%s: %s", k_cases[i].name, err.msg);
        }
    }
    write_file("bom8.obj", "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    char buf[8192];
    int rc = run_prt("precompute bom8.obj -o bom8.prt --no-bounces --quiet", buf, sizeof buf);
    CHECK(rc == 0, "a UTF-8 BOM OBJ: %d %s", rc, buf);
}

/* sq.obj with every coordinate times s (printed to 9 digits: exact for a power of two). */
static void write_scaled_sq(const char *name, double s) {
    static const float k_v[9][3] = { { -1, 0, -1 }, { 1, 0, -1 }, { 1, 0, 1 }, { -1, 0, 1 }, { 0, 0, 0 },
                                     { -0.2f, 0.5f, -0.2f }, { 0.2f, 0.5f, -0.2f }, { 0.2f, 0.5f, 0.2f }, { -0.2f, 0.5f, 0.2f } };
    char text[2048];
    size_t at = 0;
    for (int v = 0; v < 9; v++)
        at += (size_t)snprintf(text + at, sizeof text - at, "v %.9g %.9g %.9g\n", k_v[v][0] * s, k_v[v][1] * s, k_v[v][2] * s);
    snprintf(text + at, sizeof text - at, "f 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\nf 6 9 8 7\n");
    write_file(name, text);
}

/* Scale (docs/design/scale.md): a model 2^96 (~8e28) across precomputes and renders the image the
 * unit model gives (it rendered blank: the ray tracer lost every shadow, the floor was placed at
 * -inf); beyond the supported range (coordinates past 1e30, a model under 1e-30 across, a floor
 * reaching past 1e30) precompute refuses with one line, exit 1, and writes nothing. */
static void scale_limits(void) {
    char buf[8192];
    write_scaled_sq("sq96.obj", 0x1p96);
    int rc = run_prt("precompute sq96.obj --floor 400 --texel-measure --no-bounces -o sq96.prt --quiet", buf, sizeof buf);
    CHECK(rc == 0, "a model 8e28 across: exit %d: %s", rc, buf);
    write_scaled_sq("sq35.obj", 1e35);
    expect_fail("precompute sq35.obj -o sq35.prt", 1, "sq35.obj: coordinates up to 1e+35 overflow float arithmetic", "sq35.prt");
    write_scaled_sq("sqm35.obj", 1e-35);
    expect_fail("precompute sqm35.obj -o sqm35.prt", 1, "sqm35.obj: the model is only", "sqm35.prt");
    write_scaled_sq("sq29.obj", 9e29);
    expect_fail("precompute sq29.obj --floor 100 -o sq29.prt", 1, "sq29.obj: the floor reaches coordinates", "sq29.prt");
    rc = run_prt("precompute sq29.obj -o sq29.prt --no-bounces --quiet", buf, sizeof buf);
    CHECK(rc == 0, "9e29 without a floor is in range: %d %s", rc, buf);
}

/* The 2^96 model of scale_limits renders the image the unit model gives: the camera frames the
 * scaled bounds and the transport is scale-free (an image needs GL: the rasterizer). */
static void scale_render(void) {
    char buf[8192], p1[4200], p2[4200];
    int rc;
    rc = run_prt("render sq.prt --probe noise.exr -o sq1.exr", buf, sizeof buf);
    CHECK(rc == 0, "render sq.prt: %d %s", rc, buf);
    rc = run_prt("render sq96.prt --probe noise.exr -o sq96.exr", buf, sizeof buf);
    CHECK(rc == 0, "render sq96.prt: %d %s", rc, buf);
    snprintf(p1, sizeof p1, "%s/sq1.exr", g_dir);
    snprintf(p2, sizeof p2, "%s/sq96.exr", g_dir);
    prt_image a = { 0 }, b = { 0 };
    prt_error err;
    if (image_read(p1, &a, &err) == 0 && image_read(p2, &b, &err) == 0 && a.w == b.w && a.h == b.h && a.c == b.c) {
        /* the same picture: the camera frames the scaled bounds, the transport is scale-free, and
         * what is left is the rasterizer's float rounding at 1e29 (measured 7e-7 RMS) */
        double se = 0, sr = 0;
        for (size_t i = 0; i < (size_t)a.w * a.h * a.c; i++) {
            se += ((double)a.data[i] - b.data[i]) * ((double)a.data[i] - b.data[i]);
            sr += (double)a.data[i] * a.data[i];
        }
        CHECK(sr > 0 && sqrt(se / sr) < 1e-4, "the 2^96 image differs from the unit one by %g RMS", sqrt(se / sr));
    } else
        CHECK(!"read", "%s", err.msg);
    image_free(&a);
    image_free(&b);

}

/* Every usage error of every command exits 2 with one line naming the flag (table). */
static void exit_codes(void) {
    static const struct { const char *args, *needle; } k_usage[] = {
        { "nosuchcommand", "nosuchcommand" },
        { "precompute sq.obj -o x.prt --floor abc", "bad value for --floor: 'abc'" },
        { "precompute sq.obj -o x.prt --material phong:n=-3", "--material" },
        { "render sq.prt --probe noise.exr -o x.png --layout sideways", "layout 'sideways'" },
        { "render sq.prt --probe noise.exr -o x.png --camera 1,2", "--camera '1,2'" },
        { "reference sq.prt --probe noise.exr -o x.exr --layout sideways", "layout 'sideways'" },
        { "view sq.prt --probe noise.exr --camera a,b,c", "--camera" },
        { "info --bogus", "--bogus" },
        { "brdf phong:n=x", "phong:n=x" },
        { "demo --size 0x0", "--size" },
        { "compare a.exr", "two files" },
        { "bench sq.prt --probe noise.exr --backend vulkan", "vulkan" },
    };
    for (size_t i = 0; i < sizeof k_usage / sizeof k_usage[0]; i++)
        expect_fail(k_usage[i].args, 2, k_usage[i].needle, "x.png");
}

/* A number "-0" (not an exponent's "e-07"), or float noise ("0.200000003", "0.29999999") in spec s. */
static bool noisy(const char *s) {
    for (const char *p = s; (p = strstr(p, "-0")); p++)
        if ((p == s || p[-1] != 'e') && p[2] != '.' && !(p[2] >= '0' && p[2] <= '9')) return true;
    for (const char *p = s; *p; p++) {
        int z = 0, n = 0;
        while (p[z] == '0') z++;
        while (p[n] == '9') n++;
        if ((z >= 5 && p[z] >= '1' && p[z] <= '9') || n >= 5) return true;
    }
    return false;
}

/* The canonical spec re-parses bit for bit (a -0 is parsed as 0), in the shortest decimals. */
static void canonical_specs(void) {
    static const char *const k_specs[] = {
        "ggx:kd=0,-0,0", "lafortune:kd=0;lobe=-0.8,-1.2e-109,0.9,30", "lafortune:kd=0;lobe=-0.8,-.0000001164934748500,0.9,30", "lambert:kd=-0", "phong:kd=0.1,0.2,0.3;ks=0.7;n=1234.5", "as:kd=0.5;ks=0.75;nu=10;nv=100",
        "lafortune:kd=0.1;lobe=-1.1,-1.1,1.1,20;lobe=0,-0,1,3", "beckmann:alpha=0.001;ks=-0", "blinn:n=1e6;kd=3e-7",
        "paper-phong", "paper-as", "ggx:kd=0.123456789;alpha=1.9999",
    };
    for (size_t i = 0; i < sizeof k_specs / sizeof k_specs[0]; i++) {
        brdf_params a, b;
        prt_error err = { { 0 } };
        char s1[512], s2[512];
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        CHECK(brdf_parse(k_specs[i], &a, &err) == 0, "%s: %s", k_specs[i], err.msg);
        brdf_format(&a, s1, sizeof s1);
        CHECK(brdf_parse(s1, &b, &err) == 0 && !memcmp(&a, &b, sizeof a), "%s -> %s does not re-parse bit for bit", k_specs[i], s1);
        brdf_format(&b, s2, sizeof s2);
        CHECK(!strcmp(s1, s2), "%s: %s then %s", k_specs[i], s1, s2);
        CHECK(!noisy(s1), "%s -> %s: a negative zero or float noise", k_specs[i], s1);
        for (int c = 0; c < 3; c++) CHECK(!signbit(a.kd[c]) && !signbit(a.ks[c]), "%s: kd/ks keep a -0", k_specs[i]);
    }
    char buf[8192];
    CHECK(run_prt("brdf 'ggx:kd=0,-0,0' --res 8 --terms 1", buf, sizeof buf) == 0 && !strncmp(buf, "ggx:kd=0;ks=0.5;alpha=0.2\n", 26),
          "brdf echo: %s", buf);
}

/* Brdf --help states its defaults and its K default is precompute's; Lambert prints one
 * rank-1 line; render's light change is the sum of its printed parts; compare -v names x,y. */
static void messages(void) {
    char buf[16384], buf2[16384];
    CHECK(run_prt("brdf --help", buf, sizeof buf) == 0 && strstr(buf, "--terms K   the kept K (default 4") &&
          strstr(buf, "(default 48"), "brdf --help: %s", buf);
    CHECK(run_prt("precompute --help", buf2, sizeof buf2) == 0 && strstr(buf2, "(default 4;"), "precompute --help: %s", buf2);
    CHECK(run_prt("brdf lambert --res 16", buf, sizeof buf) == 0 && strstr(buf, "rank 1: sigma = ") && lines(buf) == 3 &&
          !strstr(buf, "  2   0"), "brdf lambert: %s", buf);
    /* a render's light change: the total and its two parts, which must add up (3 significant digits) */
    CHECK(run_prt("render sq.prt --probe noise.exr -o lc.png --size 16x12", buf, sizeof buf) == 0, "%s", buf);
    const char *l = strstr(buf, "light change ");
    double tot = -1, lv = -1, tl = -1;
    CHECK(l && sscanf(l, "light change %lf ms (light vector %lf ms + T x L %lf ms", &tot, &lv, &tl) == 3, "%s", buf);
    CHECK(tl > 0, "T x L printed as %g ms", tl);
    CHECK(!strstr(buf, "low dynamic range"), "an EXR probe called low dynamic range: %s", buf);
    /* render prints tot = lv + tl and each part with %.3g: each is off by at most half a unit of its
     * third digit, <= 0.005 of itself (0.0051 of the printed value), so the printed sum misses the
     * printed total by at most that of all three (the timings differ from run to run: a bound) */
    CHECK_NEAR(tot, lv + tl, 0.0051 * (tot + lv + tl), "light change = light vector + T x L");
    /* compare -v: two 8x6 images equal but at pixel (5, 3) */
    prt_image im = { 0 };
    prt_error err;
    char p[4200];
    image_alloc(&im, 8, 6, 3, &err);
    for (int i = 0; i < 8 * 6 * 3; i++) im.data[i] = 1;
    snprintf(p, sizeof p, "%s/ca.exr", g_dir);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    for (int c = 0; c < 3; c++) im.data[3 * (3 * 8 + 5) + c] = 2;
    snprintf(p, sizeof p, "%s/cb.exr", g_dir);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
    CHECK(run_prt("compare cb.exr ca.exr -v", buf, sizeof buf) == 0 && strstr(buf, "worst pixel x,y = 5,3"), "compare -v: %s", buf);
}

/* An 8-bit probe is accepted with one warning line saying it is low dynamic range (the
 * decision: warn, not refuse; README "Light probes"); the image is still written. */
static void ldr_probe(void) {
    prt_image im = { 0 };
    prt_error err;
    char p[4200], buf[8192];
    image_alloc(&im, 32, 16, 3, &err);
    for (int i = 0; i < 32 * 16 * 3; i++) im.data[i] = 0.5f;
    snprintf(p, sizeof p, "%s/ldr.png", g_dir);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
    int rc = run_prt("render sq.prt --probe ldr.png -o ldr_out.exr --size 16x12", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "warning: ldr.png: low dynamic range probe") && strstr(buf, "wrote ldr_out.exr") &&
          lines(buf) == 2, "render under a PNG probe: %d %s", rc, buf);
}

/* The default camera looks from the -z side, where the shared models face (Spot's head:
 * its top vertices have mean z -0.27 against the body's middle 0.19); the demo's lowered camera
 * puts the horizon where tan(8) / (2 tan(27.5)) says, about 36% down, so the sky fills the upper third. */
static void camera_views(void) {
    const float b0[3] = { -1, 0, -1 }, b1[3] = { 1, 1, 1 };
    prt_camera cam;
    camera_default(b0, b1, 1.6f, &cam);
    CHECK(cam.eye[2] < cam.target[2] - 0.5f, "the default eye z %g is not on the -z side of the target %g", cam.eye[2], cam.target[2]);
    float c[3] = { 0, 0.5f, 0 }, fwd[3], r[3], u[3];
    camera_lower(&cam, 16, 8, 55);
    camera_basis(&cam, fwd, r, u);
    CHECK_NEAR(asin(-fwd[1]) * 180 / M_PI, 8, 1e-3, "pitch below the horizontal");
    CHECK_NEAR(asin((cam.eye[1] - c[1]) / sqrt(pow(cam.eye[0] - c[0], 2) + pow(cam.eye[1] - c[1], 2) + pow(cam.eye[2] - c[2], 2))) * 180 / M_PI,
               16, 1e-2, "eye elevation above the old target");
    /* the horizon: the first row (from the top) whose ray points down */
    const int w = 960, h = 600;
    int row = -1;
    for (int y = 0; y < h && row < 0; y++) {
        float d[3];
        camera_ray(&cam, w, h, w / 2.f, y + 0.5f, d);
        if (d[1] < 0) row = y;
    }
    double want = 0.5 - tan(8 * M_PI / 180) / (2 * tan(27.5 * M_PI / 180));
    CHECK_NEAR((double)row / h, want, 1.5 / h, "horizon row %d of %d", row, h);
    CHECK(row > h / 3 - 2, "the sky does not fill the upper third (horizon at row %d)", row);
    /* the objects' middle stays in view, below the horizon */
    float d[3] = { c[0] - cam.eye[0], c[1] - cam.eye[1], c[2] - cam.eye[2] };
    double z = d[0] * fwd[0] + d[1] * fwd[1] + d[2] * fwd[2], yv = (d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) / z;
    double py = 0.5 - yv / (2 * tan(27.5 * M_PI / 180));
    CHECK(z > 0 && py > (double)row / h && py < 0.9, "the objects' middle projects at %.3f of the height", py);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE_GL(full_disk);
    CHECK_CASE(outputs_first);
    CHECK_CASE_GL(stale_temporaries);
    CHECK_CASE_GL(bright_sun);
    CHECK_CASE(obj_encodings);
    CHECK_CASE_GL(exit_codes);
    CHECK_CASE(canonical_specs);
    CHECK_CASE_GL(messages);
    CHECK_CASE_GL(ldr_probe);
    CHECK_CASE(camera_views);
    CHECK_CASE(scale_limits);
    CHECK_CASE_GL(scale_render);
    return check_summary();
}
