/* test_cli.c - the prt command end to end, as a user meets it.
 *
 * Bad input: missing, unreadable, malformed or empty OBJ; NaN
 * coordinates; degenerate triangles; corrupt, truncated or wrong-version .prt;
 * unreadable probe. Each must exit non-zero with exactly one line on stderr that
 * names the file, without crashing, and leave no output file (nor a temporary one).
 * A good run (precompute, info, render to PNG and EXR) must succeed and write finite
 * radiance; a Lambert square under a smaller square, lit by a constant probe, renders
 * a*L*(1 - F) per vertex, F the blocker's form factor from brute-force integration
 * (checked through --vertices, uncompressed float transport). The backends from the table: null's
 * black image, and in a build without GL the refusals and --vertices alone (backends). */
#include "harness.h"
#include "image.h"
#include "common.h"
#include "runtime.h"
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static char g_dir[512];

static void write_file(const char *name, const char *text) {
    char p[1024];
    snprintf(p, sizeof p, "%s/%s", g_dir, name);
    FILE *f = fopen(p, "wb");
    if (f) { fputs(text, f); fclose(f); }
}

/* Form factor from an upward point (x, 0, z) to the square [-0.2,0.2]^2 at height 0.5
 * facing down: (1/pi) * integral of h^2 / r^4 dA, midpoint rule on 400x400 cells. */
static double form_factor(double x, double z) {
    const int n = 400;
    const double h = 0.5, a = 0.4 / n;
    double sum = 0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double dx = -0.2 + (i + 0.5) * a - x, dz = -0.2 + (j + 0.5) * a - z;
            double r2 = dx * dx + dz * dz + h * h;
            sum += h * h / (r2 * r2) * a * a;
        }
    return sum / M_PI;
}

static bool exists(const char *path) { struct stat st; return stat(path, &st) == 0; }

/* Number of files in the scratch folder whose name contains ".tmp." (left-over temporaries). */
static int temporaries(void) {
    int n = 0;
    DIR *d = opendir(g_dir);
    struct dirent *e;
    while (d && (e = readdir(d)))
        if (strstr(e->d_name, ".tmp.")) n++;
    if (d) closedir(d);
    return n;
}

/* Counts lines of s (a trailing newline does not start a new line). */
static int lines(const char *s) {
    int n = 0;
    for (const char *p = s; *p; p++)
        if (*p == '\n') n++;
    if (*s && s[strlen(s) - 1] != '\n') n++;
    return n;
}

/* Runs `prt ARGS` expecting failure: non-zero exit, one line naming `needle`, no `out` file. */
static void expect_error(const char *args, const char *needle, const char *out) {
    char cmd[8192], buf[8192];
    snprintf(cmd, sizeof cmd, "%s %s", check_prt_bin(), args);
    int rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc != 0 && rc < 128, "%s: exit status %d (want 1 or 2, no crash)", args, rc);
    CHECK(lines(buf) == 1, "%s: want one line, got:\n%s", args, buf);
    CHECK(strstr(buf, needle) != NULL, "%s: message does not name '%s': %s", args, needle, buf);
    CHECK(!strstr(buf, "Assertion") && !strstr(buf, "Sanitizer"), "%s: %s", args, buf);
    if (out) CHECK(!exists(out), "%s: output %s was left behind", args, out);
    CHECK(temporaries() == 0, "%s: a temporary file was left behind", args);
}

/* The inputs every case may use: OBJ files good and bad, a constant probe, a text "probe". */
static void setup(void) {
    snprintf(g_dir, sizeof g_dir, "%s", check_tmpdir());
    char p[1024];
    const char *D = g_dir;
    /* A 2x2 square facing +y (4 corners and a centre vertex), Lambert albedo 0.5, and a
     * 0.4x0.4 square at height 0.5 above its centre casting a shadow. */
    write_file("good.obj", "# two squares\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 0 0\n"
                           "v -0.2 0.5 -0.2\nv 0.2 0.5 -0.2\nv 0.2 0.5 0.2\nv -0.2 0.5 0.2\n"
                           "f 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\nf 6 9 8 7\n");
    write_file("garbage.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nthis is not obj\nf 1 2 3\n");
    write_file("empty.obj", "");
    write_file("comments.obj", "# nothing here\n\n");
    write_file("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    write_file("degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n");
    write_file("badindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    write_file("notaprobe.exr", "this is text, not an image\n");
    snprintf(p, sizeof p, "%s/adir.obj", D);
    mkdir(p, 0755);

    /* A constant probe: a 2:1 latlong EXR of radiance 2. */
    prt_image im = { 0 };
    prt_error err;
    image_alloc(&im, 64, 32, 3, &err);
    for (int i = 0; i < 64 * 32 * 3; i++) im.data[i] = 2.f;
    snprintf(p, sizeof p, "%s/const.exr", D);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
}

/* good.prt: the two squares, Lambert 0.5, float transport with every coefficient (made once). */
static const char *good_prt(void) {
    static char q[1024];    /* test-binary state, not the library's */
    char args[8192], buf[8192];
    snprintf(q, sizeof q, "%s/good.prt", g_dir);
    if (exists(q)) return q;
    /* --no-refine: the truth below is per input vertex */
    snprintf(args, sizeof args, "%s precompute %s/good.obj --material lambert:kd=0.5 -o %s --coeffs 24576 --quant 32 --no-refine --quiet",
             check_prt_bin(), g_dir, q);
    int rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0 && exists(q), "good precompute failed (%d): %s", rc, buf);
    return q;
}

/* good.prt's vertex radiance in csv (vertex,r,g,b): a*L*(1 - F), F the blocker's form factor by
 * brute force; zeros (the null backend) when zero is set. */
static void check_vertices(const char *csv, bool zero) {
    FILE *f = fopen(csv, "r");
    int nrows = 0;
    if (f) {
        char line[256];
        if (!fgets(line, sizeof line, f)) line[0] = 0;
        int v;
        float r, g, b;
        while (fscanf(f, "%d,%f,%f,%f", &v, &r, &g, &b) == 4) {
            nrows++;
            if (zero) {
                CHECK(r == 0 && g == 0 && b == 0, "vertex %d: %g %g %g, not zero", v, r, g, b);
                continue;
            }
            /* a*L*(1 - F): the upper square (5..8) is unoccluded (F = 0); the lower square's
             * vertices (0..4, file order) lose the blocker's form factor. Tolerance: the 16-bit
             * light vector and the 128-res visibility of the blocker's edges (2% of F plus 0.3%). */
            float px[5] = { -1, 1, 1, -1, 0 }, pz[5] = { -1, -1, 1, 1, 0 };
            double F = v < 5 ? form_factor(px[v], pz[v]) : 0;
            CHECK_NEAR(r, 1.0 - F, 0.003 + 0.02 * F, "vertex %d (F = %.4f)", v, F);
            CHECK_NEAR(g, r, 1e-3 * r + 1e-6, "grey");
        }
        fclose(f);
    }
    CHECK(nrows == 9, "%s: csv rows %d", csv, nrows);
}

/* Bad OBJ inputs to precompute. */
static void bad_obj(void) {
    char q[1024], args[8192];
    const char *D = g_dir;
    snprintf(q, sizeof q, "%s/out.prt", D);
    const char *bad_obj[] = { "missing.obj", "adir.obj", "garbage.obj", "empty.obj", "comments.obj",
                              "nan.obj", "degenerate.obj", "badindex.obj" };
    for (size_t i = 0; i < sizeof bad_obj / sizeof bad_obj[0]; i++) {
        snprintf(args, sizeof args, "precompute %s/%s -o %s --quiet", D, bad_obj[i], q);
        expect_error(args, bad_obj[i], q);
    }
}

/* Usage errors: exit 2, one line. */
static void usage_errors(void) {
    char p[1024], q[1024], args[8192];
    const char *D = g_dir;
    snprintf(q, sizeof q, "%s/out.prt", D);
    snprintf(args, sizeof args, "precompute %s/good.obj -o %s --coeffs 0", D, q);
    expect_error(args, "--coeffs", q);
    snprintf(args, sizeof args, "precompute %s/good.obj -o %s --bogus", D, q);
    expect_error(args, "--bogus", q);
    snprintf(args, sizeof args, "precompute %s/good.obj -o %s --material 'phong:n=-3'", D, q);
    expect_error(args, "phong", q);
    snprintf(args, sizeof args, "precompute %s/good.obj -o %s/no/such/dir/out.prt --quiet --vis-res 64", D, D);
    expect_error(args, "no/such/dir/out.prt", NULL);

    /* bench: an unknown backend, and the glbench command it replaced is gone. */
    snprintf(args, sizeof args, "bench %s --probe %s/const.exr --backend vulkan", q, D);
    expect_error(args, "vulkan", NULL);
    snprintf(args, sizeof args, "glbench %s --probe %s/const.exr", q, D);
    expect_error(args, "glbench", NULL);
    snprintf(args, sizeof args, "render %s --probe %s/const.exr --backend vulkan -o %s/v.png", q, D, D);
    snprintf(p, sizeof p, "%s/v.png", D);
    expect_error(args, "vulkan", p);
}

/* A good run: info, then the constant probe rendered: the lower square's upward face sees the
 * sky except where the upper square blocks it; the upper square's top is unoccluded and must
 * show a*L = 0.5 * 2 = 1. */
static void good_render(void) {
    char p[1024], q[1024], args[8192], buf[8192];
    const char *D = g_dir;
    prt_image im = { 0 };
    prt_error err;
    snprintf(q, sizeof q, "%s", good_prt());
    snprintf(p, sizeof p, "%s/const.exr", D);
    snprintf(args, sizeof args, "%s info %s", check_prt_bin(), q);
    int rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "9 vertices") && strstr(buf, "K = 1") && strstr(buf, "N = 24576"), "info: %s", buf);
    char png[1024], exr[1024], csv[1024];
    snprintf(png, sizeof png, "%s/out.png", D);
    snprintf(exr, sizeof exr, "%s/out.exr", D);
    snprintf(csv, sizeof csv, "%s/out.csv", D);
    snprintf(args, sizeof args, "%s render %s --probe %s -o %s --size 64x48 --camera 0,3,0.01,0,0,0 --vertices %s",
             check_prt_bin(), q, p, exr, csv);
    rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0 && exists(exr) && exists(csv), "render exr: %s", buf);
    snprintf(args, sizeof args, "%s render %s --probe %s -o %s --size 64x48", check_prt_bin(), q, p, png);
    rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0 && exists(png), "render png: %s", buf);
    if (image_read(exr, &im, &err) == 0) {
        int bad = 0;
        for (int i = 0; i < im.w * im.h * im.c; i++) bad += !isfinite(im.data[i]) || im.data[i] < 0;
        CHECK(bad == 0 && im.w == 64 && im.h == 48, "%d non-finite or negative pixels", bad);
        image_free(&im);
    } else CHECK(false, "%s", err.msg);
    check_vertices(csv, false);
}

/* `render --backend null`: a black image of the asked size and zero vertex radiance; the cpu backend
 * as the table says: with images, -o is needed; without (a build without GL), -o and the GL-only
 * commands (view, demo) are refused with one line and exit 2, nothing written, while --vertices
 * alone writes the same radiance as good_render checks. An unknown backend lists the table's. */
static void backends(void) {
    char q[1024], p[1024], out[1024], csv[1024], args[8192], buf[8192];
    const char *D = g_dir, *B = check_prt_bin();
    snprintf(q, sizeof q, "%s", good_prt());
    snprintf(p, sizeof p, "%s/const.exr", D);
    snprintf(args, sizeof args, "render %s --probe %s --backend vulkan -o %s/v.png", q, p, D);
    snprintf(out, sizeof out, "%s/v.png", D);
    expect_error(args, "vulkan", out);
    for (int i = 0; i < runtime_backend_count(); i++) {
        snprintf(args, sizeof args, "%s render %s --probe %s --backend vulkan -o %s", B, q, p, out);
        check_run(args, buf, sizeof buf);
        CHECK(strstr(buf, runtime_backend_at(i)->name) != NULL, "%s not listed: %s", runtime_backend_at(i)->name, buf);
    }
    snprintf(out, sizeof out, "%s/null.exr", D);
    snprintf(csv, sizeof csv, "%s/null.csv", D);
    snprintf(args, sizeof args, "%s render %s --probe %s --backend null -o %s --vertices %s --size 16x12", B, q, p, out, csv);
    CHECK(check_run(args, buf, sizeof buf) == 0, "null render: %s", buf);
    prt_image im = { 0 };
    prt_error err;
    if (image_read(out, &im, &err) == 0) {
        double sum = 0;
        for (int i = 0; i < im.w * im.h * im.c; i++) sum += fabs(im.data[i]);
        CHECK(im.w == 16 && im.h == 12 && sum == 0, "null image %dx%d, sum %g", im.w, im.h, sum);
        image_free(&im);
    } else CHECK(false, "%s", err.msg);
    check_vertices(csv, true);
    snprintf(csv, sizeof csv, "%s/cpu.csv", D);
    snprintf(out, sizeof out, "%s/cpu.png", D);
    if (runtime_backend_find("cpu")->caps & RUNTIME_CAP_IMAGES) {
        snprintf(args, sizeof args, "render %s --probe %s --vertices %s", q, p, csv);
        expect_error(args, "no output image", csv);
        return;
    }
    snprintf(args, sizeof args, "render %s --probe %s --camera 0,3,0.01,0,0,0 -o %s --vertices %s", q, p, out, csv);
    expect_error(args, "no GL", out);
    CHECK(!exists(csv), "--vertices written by a refused render");
    snprintf(args, sizeof args, "%s render %s --probe %s --camera 0,3,0.01,0,0,0 --vertices %s", B, q, p, csv);
    CHECK(check_run(args, buf, sizeof buf) == 0 && strstr(buf, "wrote ") && strstr(buf, "(9 vertices)"), "--vertices alone: %s", buf);
    check_vertices(csv, false);
    snprintf(args, sizeof args, "view %s --probe %s --frames 1", q, p);
    expect_error(args, "no GL", NULL);
    snprintf(args, sizeof args, "demo -o %s --quiet", out);
    expect_error(args, "no GL", out);
    snprintf(args, sizeof args, "%s bench %s --probe %s --frames 2", B, q, p);
    CHECK(check_run(args, buf, sizeof buf) == 0 && strstr(buf, "bench: backend=cpu"), "bench on the cpu backend: %s", buf);
}

static void interreflections(void) {
    char args[8192], buf[8192];
    const char *D = g_dir;
    prt_error err;
    int rc;
    /* Interreflections kept apart: an L of two 2x2 Lambert squares (a floor facing +y and a
     * wall at x = 0 facing +x, 5x5 vertices each), albedo 0.8, with one forced bounce
     * and --keep-direct. Under a constant probe the total (direct + bounce) is at least the
     * direct everywhere, strictly more inside the box, and --direct-only reproduces the
     * direct file's radiance (same direct pass). */
    {
        char obj[16384];
        size_t o = 0;
        for (int w = 0; w < 2; w++)          /* w = 0: floor (x, 0, z); w = 1: wall (0, y, z) */
            for (int i = 0; i < 5; i++)
                for (int j = 0; j < 5; j++) {
                    float a = 0.5f * i, b = -1 + 0.5f * j;
                    o += snprintf(obj + o, sizeof obj - o, "v %g %g %g\n", w ? 0.f : a, w ? a : 0.f, b);
                }
        for (int w = 0; w < 2; w++)
            for (int i = 0; i < 4; i++)
                for (int j = 0; j < 4; j++) {
                    int v00 = 1 + 25 * w + 5 * i + j, v01 = v00 + 1, v10 = v00 + 5, v11 = v10 + 1;
                    /* Floor: CCW seen from +y; wall: CCW seen from +x. */
                    if (!w) o += snprintf(obj + o, sizeof obj - o, "f %d %d %d %d\n", v00, v01, v11, v10);
                    else o += snprintf(obj + o, sizeof obj - o, "f %d %d %d %d\n", v00, v10, v11, v01);
                }
        write_file("ell.obj", obj);
    }
    char bprt[1024], dprt[1024], tcsv[1024], dcsv[1024], d2csv[1024];
    snprintf(bprt, sizeof bprt, "%s/box.prt", D);
    snprintf(dprt, sizeof dprt, "%s/boxd.prt", D);
    snprintf(tcsv, sizeof tcsv, "%s/total.csv", D);
    snprintf(dcsv, sizeof dcsv, "%s/direct.csv", D);
    snprintf(d2csv, sizeof d2csv, "%s/direct2.csv", D);
    snprintf(args, sizeof args, "%s precompute %s/ell.obj --material lambert:kd=0.8 -o %s --vis-res 64 --bounces 1 --force-bounces "
             "--gather-res 16 --keep-direct --no-refine --quiet && %s precompute %s/ell.obj --material lambert:kd=0.8 -o %s --vis-res 64 "
             "--bounces 0 --no-refine --quiet", check_prt_bin(), D, bprt, check_prt_bin(), D, dprt);
    rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0, "box precompute: %s", buf);
    snprintf(args, sizeof args, "%s info %s", check_prt_bin(), bprt);
    rc = check_run(args, buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "direct-only transport kept"), "info: %s", buf);
    const char *renders[3][2] = { { bprt, tcsv }, { bprt, dcsv }, { dprt, d2csv } };
    for (int k = 0; k < 3; k++) {
        snprintf(args, sizeof args, "%s render %s --probe %s/const.exr -o %s/box%d.exr --size 32x24 --vertices %s %s",
                 check_prt_bin(), renders[k][0], D, D, k, renders[k][1], k == 1 ? "--direct-only" : "");
        rc = check_run(args, buf, sizeof buf);
        CHECK(rc == 0, "box render %d: %s", k, buf);
    }
    /* The GL runtime's --direct-only image equals the CPU one (Lambertian: per-pixel and
     * per-vertex view maps agree) and differs from the GL total. */
    for (int k = 0; k < 2; k++) {
        snprintf(args, sizeof args, "%s render %s --probe %s/const.exr -o %s/boxgl%d.exr --size 32x24 --backend gl %s",
                 check_prt_bin(), bprt, D, D, k, k ? "" : "--direct-only");
        rc = check_run(args, buf, sizeof buf);
        CHECK(rc == 0, "gl render %d: %s", k, buf);
    }
    {
        prt_image a = { 0 }, b = { 0 }, t = { 0 };
        char pa[1024], pb[1024], pt[1024];
        snprintf(pa, sizeof pa, "%s/box1.exr", D);     /* CPU, --direct-only */
        snprintf(pb, sizeof pb, "%s/boxgl0.exr", D);   /* GL, --direct-only */
        snprintf(pt, sizeof pt, "%s/boxgl1.exr", D);   /* GL, total */
        if (image_read(pa, &a, &err) == 0 && image_read(pb, &b, &err) == 0 && image_read(pt, &t, &err) == 0 &&
            a.w == b.w && a.h == b.h && a.w == t.w && a.h == t.h) {
            double dab = 0, dbt = 0, sum = 0;
            for (int i = 0; i < a.w * a.h * a.c; i++) {
                dab += fabs(a.data[i] - b.data[i]);
                dbt += fabs(b.data[i] - t.data[i]);
                sum += fabs(a.data[i]);
            }
            CHECK_LE(dab / sum, 2e-3, "GL and CPU --direct-only images differ");
            CHECK(dbt / sum > 0.01, "GL direct-only and total images should differ (%g)", dbt / sum);
        } else CHECK(false, "box images: %s", err.msg);
        image_free(&a);
        image_free(&b);
        image_free(&t);
    }

    snprintf(args, sizeof args, "%s render %s --probe %s/const.exr -o %s/nod.exr --direct-only", check_prt_bin(), dprt, D, D);
    CHECK(check_run(args, buf, sizeof buf) == 0, "--direct-only on a file without bounces: %s", buf);
    {
        FILE *ft = fopen(tcsv, "r"), *fd = fopen(dcsv, "r"), *f2 = fopen(d2csv, "r");
        char l1[256], l2[256], l3[256];
        int n = 0, more = 0, v1, v2, v3;
        float t[3], dd[3], d2[3];
        if (ft && fd && f2 && fgets(l1, sizeof l1, ft) && fgets(l2, sizeof l2, fd) && fgets(l3, sizeof l3, f2)) {
            while (fscanf(ft, "%d,%f,%f,%f", &v1, &t[0], &t[1], &t[2]) == 4 &&
                   fscanf(fd, "%d,%f,%f,%f", &v2, &dd[0], &dd[1], &dd[2]) == 4 &&
                   fscanf(f2, "%d,%f,%f,%f", &v3, &d2[0], &d2[1], &d2[2]) == 4) {
                n++;
                CHECK_NEAR(dd[0], d2[0], 1e-6 + 1e-5 * d2[0], "vertex %d: --direct-only vs the direct file", v1);
                CHECK(t[0] >= dd[0] - 0.01f, "vertex %d: total %g < direct %g", v1, t[0], dd[0]);
                more += t[0] > dd[0] + 0.02f;
            }
        }
        if (ft) fclose(ft);
        if (fd) fclose(fd);
        if (f2) fclose(f2);
        CHECK(n == 45 && more > n / 2, "%d vertices, %d brighter with the bounce", n, more);
    }

}

/* Bad probes. */
static void bad_probes(void) {
    char p[1024], q[1024], args[8192];
    const char *D = g_dir;
    snprintf(q, sizeof q, "%s", good_prt());
    snprintf(args, sizeof args, "render %s --probe %s/missing.exr -o %s/x.png", q, D, D);
    snprintf(p, sizeof p, "%s/x.png", D);
    expect_error(args, "missing.exr", p);
    snprintf(args, sizeof args, "render %s --probe %s/notaprobe.exr -o %s/x.png", q, D, D);
    expect_error(args, "notaprobe.exr", p);
    snprintf(args, sizeof args, "render %s --probe %s/const.exr -o %s/x.bmpx", q, D, D);
    expect_error(args, "x.bmpx", NULL);

}

/* Damaged .prt files: truncated, a flipped byte, wrong version, empty, missing. */
static void damaged_prt(void) {
    char p[1024], q[1024], args[8192];
    const char *D = g_dir;
    snprintf(q, sizeof q, "%s", good_prt());
    FILE *in = fopen(q, "rb");
    long size = 0;
    unsigned char *bytes = NULL;
    if (in) {
        fseek(in, 0, SEEK_END);
        size = ftell(in);
        fseek(in, 0, SEEK_SET);
        bytes = malloc(size);
        if (fread(bytes, 1, size, in) != (size_t)size) size = 0;
        fclose(in);
    }
    CHECK(size > 100, "prt size %ld", size);
    struct { const char *name; long len; long flip; uint32_t version; } cases[] = {
        { "trunc.prt", 0, -1, 0 },  { "half.prt", 1, -1, 0 }, { "short.prt", 2, -1, 0 },
        { "flip.prt", 3, 1, 0 },    { "version.prt", 3, -1, 7 },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0] && size > 100; i++) {
        long len = cases[i].len == 0 ? 0 : cases[i].len == 1 ? size / 2 : cases[i].len == 2 ? size - 3 : size;
        snprintf(p, sizeof p, "%s/%s", D, cases[i].name);
        FILE *o = fopen(p, "wb");
        unsigned char *copy = malloc(size);
        memcpy(copy, bytes, size);
        if (cases[i].flip > 0) copy[size / 3] ^= 0x10;
        if (cases[i].version) memcpy(copy + 4, &cases[i].version, 4);
        if (o) { fwrite(copy, 1, len, o); fclose(o); }
        free(copy);
        snprintf(args, sizeof args, "render %s --probe %s/const.exr -o %s/y.png", p, D, D);
        snprintf(q, sizeof q, "%s/y.png", D);
        expect_error(args, cases[i].name, q);
        snprintf(args, sizeof args, "info %s", p);
        expect_error(args, cases[i].name, NULL);
    }
    free(bytes);
    snprintf(args, sizeof args, "info %s/missing.prt", D);
    expect_error(args, "missing.prt", NULL);
}

/* ---- no command destroys what it reads: outputs against inputs, output kinds, messages ---- */

/* Runs `cd SCRATCH && prt ARGS` into out[cap] (so that the arguments name the scratch files as a user
 * in that folder would); its exit status. */
static int run_here(const char *args, char *out, size_t cap) {
    char cmd[8192], bin[4096];
    if (!realpath(check_prt_bin(), bin)) snprintf(bin, sizeof bin, "%s", check_prt_bin());   /* a name on PATH */
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' %s", g_dir, bin, args);
    return check_run(cmd, out, cap);
}

/* Occurrences of needle in s. */
static int count(const char *s, const char *needle) {
    int n = 0;
    for (const char *p = s; (p = strstr(p, needle)); p += strlen(needle)) n++;
    return n;
}

/* Runs ARGS in the scratch folder expecting a usage error: exit 2, one line holding each of words[]
 * (NULL-ended; a word listed twice must appear twice), no temporary left, and every file of keep[]
 * (NULL-ended, scratch-relative) the same bytes after the run as before it. */
static void refuse(const char *args, const char *const *words, const char *const *keep) {
    char buf[8192], p[1024];
    char *before[8] = { 0 };
    size_t len[8] = { 0 };
    for (int k = 0; keep[k] && k < 8; k++) {
        snprintf(p, sizeof p, "%s/%s", g_dir, keep[k]);
        before[k] = check_read_file(p, &len[k]);
        CHECK(before[k] != NULL, "%s: cannot read %s before the run", args, keep[k]);
    }
    int rc = run_here(args, buf, sizeof buf);
    CHECK(rc == 2, "%s: exit status %d (want 2): %s", args, rc, buf);
    CHECK(lines(buf) == 1, "%s: want one line, got:\n%s", args, buf);
    for (int w = 0; words[w]; w++) {
        int want = 0;
        for (int v = 0; words[v]; v++) want += !strcmp(words[v], words[w]);
        CHECK(count(buf, words[w]) >= want, "%s: message does not name '%s' %d time(s): %s", args, words[w], want, buf);
    }
    CHECK(temporaries() == 0, "%s: a temporary file was left behind", args);
    for (int k = 0; keep[k] && k < 8; k++) {
        size_t n = 0;
        snprintf(p, sizeof p, "%s/%s", g_dir, keep[k]);
        char *after = check_read_file(p, &n);
        CHECK(after && before[k] && n == len[k] && memcmp(after, before[k], n) == 0, "%s: %s changed", args, keep[k]);
        free(after);
        free(before[k]);
    }
}

#define WORDS(...) ((const char *const[]){ __VA_ARGS__, NULL })

/* Copies scratch file a to b (fresh bytes, not a link). */
static void copy_file(const char *a, const char *b) {
    char p[1024];
    size_t n = 0;
    snprintf(p, sizeof p, "%s/%s", g_dir, a);
    char *bytes = check_read_file(p, &n);
    snprintf(p, sizeof p, "%s/%s", g_dir, b);
    FILE *f = fopen(p, "wb");
    if (f && bytes) fwrite(bytes, 1, n, f);
    if (f) fclose(f);
    free(bytes);
    CHECK(bytes && f, "copy %s to %s", a, b);
}

/* Runs a shell line in the scratch folder (links, folders); checks it succeeds. */
static void shell(const char *line) {
    char cmd[4096], buf[1024];
    snprintf(cmd, sizeof cmd, "cd '%s' && %s", g_dir, line);
    CHECK(check_run(cmd, buf, sizeof buf) == 0, "%s: %s", line, buf);
}

/* Every command that writes refuses, before any work, an output that is one of its inputs: the same
 * name, a hard link, a symbolic link or "./x" of it, a file a JSON scene names, --light-prior's
 * probe, a --probes folder's probe, a --vertex-list; and two outputs that are one file. The inputs
 * are left byte for byte as they were. */
static void output_is_input(void) {
    good_prt();
    copy_file("good.obj", "spider.obj");
    copy_file("const.exr", "city.exr");
    copy_file("const.exr", "b.exr");
    shell("ln -f spider.obj hard.prt && ln -sf spider.obj sym.prt && ln -sf spider.obj named.prt && "
          "ln -f city.exr prior.prt && ln -sf good.prt prtlink.exr && mkdir -p pdir && cp city.exr pdir/p.exr && "
          "printf 'vertex,r,g,b\\n0,1,1,1\\n' > list.csv");
    write_file("scene.json", "{ \"models\": [ { \"obj\": \"spider.obj\" } ] }");
    /* precompute: the same name (the collision said before the extension), its hard link, its symbolic
     * link, "./" and a folder round trip, a file the JSON scene names, the light prior */
    refuse("precompute spider.obj -o spider.obj", WORDS("same file", "spider.obj", "spider.obj"), WORDS("spider.obj"));
    refuse("precompute spider.obj -o hard.prt", WORDS("same file", "hard.prt", "spider.obj"), WORDS("spider.obj", "hard.prt"));
    refuse("precompute spider.obj -o sym.prt", WORDS("same file", "sym.prt", "spider.obj"), WORDS("spider.obj"));
    refuse("precompute ./spider.obj -o ../$(basename $PWD)/spider.obj", WORDS("same file", "./spider.obj", "/spider.obj"),
           WORDS("spider.obj"));
    refuse("precompute scene.json -o named.prt", WORDS("same file", "named.prt", "spider.obj", "named by scene.json"),
           WORDS("spider.obj", "scene.json"));
    refuse("precompute spider.obj --light-prior b.exr,city.exr -o prior.prt", WORDS("same file", "prior.prt", "city.exr", "--light-prior"),
           WORDS("city.exr", "spider.obj"));
    /* render, reference, compare, view */
    refuse("render good.prt --probe city.exr -o city.exr", WORDS("same file", "city.exr", "city.exr", "--probe"), WORDS("city.exr", "good.prt"));
    refuse("render good.prt --probe city.exr -o prtlink.exr", WORDS("same file", "prtlink.exr", "good.prt"), WORDS("city.exr", "good.prt"));
    refuse("reference good.prt --probe city.exr -o ./city.exr --spp 1", WORDS("same file", "./city.exr", "city.exr"), WORDS("city.exr"));
    refuse("reference good.prt --probe city.exr --no-image --vertices list.csv --vertex-list list.csv",
           WORDS("same file", "list.csv", "list.csv", "--vertex-list"), WORDS("list.csv"));
    refuse("compare city.exr b.exr --error-image city.exr", WORDS("same file", "city.exr", "city.exr"), WORDS("city.exr", "b.exr"));
    refuse("compare city.exr b.exr --error-image b.exr", WORDS("same file", "b.exr", "b.exr"), WORDS("city.exr", "b.exr"));
    refuse("view good.prt --probe city.exr --frames 1 --screenshot city.exr", WORDS("same file", "city.exr", "city.exr"),
           WORDS("city.exr", "good.prt"));
    refuse("view good.prt --probes pdir --frames 1 --screenshot pdir/p.exr", WORDS("same file", "pdir/p.exr", "pdir/p.exr", "--probes"),
           WORDS("pdir/p.exr"));
    /* two outputs of one run that are one file */
    refuse("view good.prt --probe city.exr --frames 1 --screenshot shot.png --window-shot ./shot.png",
           WORDS("same file", "shot.png", "./shot.png"), WORDS("city.exr"));
    CHECK(!exists("shot.png"), "shot.png written");
}

/* precompute writes only .prt names, --prt too, --vertices only .csv, images only what image_write
 * writes; nothing is created. */
static void output_kinds(void) {
    good_prt();
    char p[1024];
    refuse("precompute good.obj -o t.png --quiet", WORDS("t.png", ".prt"), WORDS("good.obj"));
    refuse("precompute good.obj -o noext --quiet", WORDS("noext", ".prt"), WORDS("good.obj"));
    refuse("demo --prt d.png -o d2.png", WORDS("d.png", ".prt"), WORDS("good.obj"));
    refuse("render good.prt --probe const.exr -o r.exr --vertices v.png", WORDS("v.png", ".csv"), WORDS("good.prt"));
    refuse("render good.prt --probe const.exr -o r.bmp", WORDS("r.bmp", ".png", ".exr"), WORDS("good.prt"));
    refuse("compare const.exr const.exr --error-image e.txt", WORDS("e.txt", ".png"), WORDS("const.exr"));
    const char *none[] = { "t.png", "noext", "d.png", "d2.png", "r.exr", "v.png", "r.bmp", "e.txt" };
    for (size_t i = 0; i < sizeof none / sizeof none[0]; i++) {
        snprintf(p, sizeof p, "%s/%s", g_dir, none[i]);
        CHECK(!exists(p), "%s was written", none[i]);
    }
}

/* A directory given as a file is said to be one, by every command that reads a file. */
static void directory_inputs(void) {
    good_prt();
    shell("mkdir -p folder folder.obj folder.prt folder.exr");
    refuse("precompute folder -o x.prt --quiet", WORDS("folder", "is a directory"), WORDS("good.obj"));
    refuse("precompute folder.obj -o x.prt --quiet", WORDS("folder.obj", "is a directory"), WORDS("good.obj"));
    refuse("precompute good.obj --light-prior folder.exr -o x.prt --quiet", WORDS("folder.exr", "is a directory", "--light-prior"),
           WORDS("good.obj"));
    refuse("info folder.prt", WORDS("folder.prt", "is a directory"), WORDS("good.prt"));
    refuse("render folder --probe const.exr -o x.png", WORDS("folder", "is a directory"), WORDS("const.exr"));
    refuse("render good.prt --probe folder.exr -o x.png", WORDS("folder.exr", "is a directory", "--probe"), WORDS("good.prt"));
    refuse("reference folder.prt --probe const.exr -o x.exr", WORDS("folder.prt", "is a directory"), WORDS("const.exr"));
    refuse("bench good.prt --probe folder", WORDS("folder", "is a directory", "--probe"), WORDS("good.prt"));
    refuse("compare const.exr folder", WORDS("folder", "is a directory"), WORDS("const.exr"));
    refuse("view folder.prt --probe const.exr --frames 1", WORDS("folder.prt", "is a directory"), WORDS("const.exr"));
}

/* --camera: an eye on the target is said to be that (given, or the framing's target with an eye
 * alone: good.obj's box [-1,1] x [0,0.5] x [-1,1] frames its centre (0, 0.25, 0)), not a format error. */
static void camera_messages(void) {
    good_prt();
    refuse("render good.prt --probe const.exr -o x.png --camera 1,2,3,1,2,3", WORDS("eye and the target coincide", "1,2,3,1,2,3"),
           WORDS("good.prt"));
    refuse("render good.prt --probe const.exr -o x.png --camera 0,0.25,0", WORDS("eye and the target coincide", "0, 0.25, 0"),
           WORDS("good.prt"));
    refuse("reference good.prt --probe const.exr -o x.exr --camera 0,0.25,0 --spp 1", WORDS("eye and the target coincide"),
           WORDS("good.prt"));
    refuse("render good.prt --probe const.exr -o x.png --camera 1,2", WORDS("bad --camera", "EX,EY,EZ"), WORDS("good.prt"));
    refuse("render good.prt --probe const.exr -o x.png --camera 0,1,5,0,0,0,190", WORDS("field of view"), WORDS("good.prt"));
}

/* --help states the defaults (precompute's vMF options, demo's, view's) and --budget reads in order. */
static void help_defaults(void) {
    static char buf[65536];
    CHECK(run_here("precompute --help", buf, sizeof buf) == 0, "precompute --help");
    const char *want[][2] = { { "--view-level L", "(default 2" }, { "--lobe-samples S", "(default 64)" },
                              { "--term-error E", "default: off" }, { "--refine-threshold F", "default 0.005" },
                              { "--lobes I", "(default 2)" }, { "--coeffs N", "(default 128)" } };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        const char *l = strstr(buf, want[i][0]), *next = l ? strstr(l + 3, "\n  -") : NULL;
        const char *d = l ? strstr(l, want[i][1]) : NULL;
        CHECK(l && d && (!next || d < next), "precompute --help: %s does not say %s", want[i][0], want[i][1]);
    }
    /* --budget: its three values explained in turn, then its default */
    const char *b = strstr(buf, "--budget"), *sh = b ? strstr(b, "shared:") : NULL, *ve = sh ? strstr(sh, "vector:") : NULL;
    const char *re = ve ? strstr(ve, "relative:") : NULL, *de = re ? strstr(re, "Default: shared up to 500,000") : NULL;
    CHECK(de && de < strstr(b, "\n  --glossy"), "precompute --help: --budget does not read in order");
    CHECK(run_here("demo --help", buf, sizeof buf) == 0, "demo --help");
    const char *demo[] = { "(default demo.png", "(default 960x600)", "(default 10000)", "(default: as prt precompute",
                           "(default: from the probe" };
    for (size_t i = 0; i < sizeof demo / sizeof demo[0]; i++) CHECK(strstr(buf, demo[i]), "demo --help lacks %s: %s", demo[i], buf);
    CHECK(run_here("view --help", buf, sizeof buf) == 0 && strstr(buf, "pitch; default 0)") && strstr(buf, "default: interactive"),
          "view --help: %s", buf);
}

/* Times read as a person reads them: never an exponent (1.7e+03 ms), a unit after every figure. */
static void durations(void) {
    struct { double s; const char *want; } cases[] = {
        { 4.21e-5, "0.0421 ms" }, { 0.0123, "12.3 ms" }, { 0.85, "850 ms" }, { 0.99996, "1.0 s" }, { 1.7, "1.7 s" },
        { 59.97, "1 min 00 s" }, { 125.4, "2 min 05 s" }, { 3720, "1 h 02 min" }, { -1, "0 ms" }, { NAN, "0 ms" },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char got[48];
        prt_format_duration(got, sizeof got, cases[i].s);
        CHECK(!strcmp(got, cases[i].want), "%g s printed as '%s' (want '%s')", cases[i].s, got, cases[i].want);
    }
    /* through the commands: a precompute's progress and timing summary, a render's line, info's timings */
    static char buf[65536];
    int rc = run_here("precompute good.obj -o t.prt --vis-res 64", buf, sizeof buf);
    const char *sum = strstr(buf, "timing summary"), *tot = sum ? strstr(sum, "\n  total ") : NULL;
    CHECK(rc == 0 && tot && !strstr(buf, "e+0") && !strstr(buf, "e-0"), "precompute: %s", buf);
    double v = -1;
    char unit[8] = "";
    CHECK(tot && sscanf(tot, "\n  total %lf %7s", &v, unit) == 2 && v > 0 && (!strcmp(unit, "ms") || !strcmp(unit, "s")),
          "summary total: %s", tot ? tot : buf);
    rc = run_here("render t.prt --probe const.exr -o t.png --size 16x12", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "light change ") && !strstr(buf, "e+0") && !strstr(buf, "e-0"), "render: %s", buf);
    rc = run_here("info t.prt", buf, sizeof buf);
    const char *tm = strstr(buf, "timings ");
    CHECK(rc == 0 && tm && strstr(tm, " ms") && !strstr(buf, "e+0"), "info: %s", buf);
}

/* render without --backend draws a file with highlights per pixel (gl: runtime_backend_for) and a
 * Lambertian one per vertex (cpu); the timing line names the backend; --backend still decides. */
static void render_backend(void) {
    static char buf[65536];
    int rc = run_here("precompute good.obj -o lam.prt --vis-res 64", buf, sizeof buf);
    CHECK(rc == 0, "precompute lambert: %s", buf);
    rc = run_here("precompute good.obj -o gls.prt --vis-res 64 --material paper-phong", buf, sizeof buf);
    CHECK(rc == 0, "precompute paper-phong: %s", buf);
    rc = run_here("render lam.prt --probe const.exr -o lam.png --size 16x12", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "(16x12) (cpu)"), "Lambertian: %s", buf);
    rc = run_here("render gls.prt --probe const.exr -o gls.png --size 16x12", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "(16x12) (gl)"), "paper-phong: %s", buf);
    rc = run_here("render gls.prt --probe const.exr -o gls.png --size 16x12 --backend cpu", buf, sizeof buf);
    CHECK(rc == 0 && strstr(buf, "(16x12) (cpu)"), "--backend cpu: %s", buf);
}

/* Writes a 64x32 latlong EXR: radiance 2, the top `rows` rows -neg in every channel, and `dots` single
 * texels of -1e-4 (lossy compression's kind). */
static void write_probe(const char *name, int rows, float neg, int dots) {
    prt_image im = { 0 };
    prt_error err;
    char p[1024];
    CHECK(image_alloc(&im, 64, 32, 3, &err) == 0, "%s", err.msg);
    for (int i = 0; i < 64 * 32 * 3; i++) im.data[i] = i < rows * 64 * 3 ? -neg : 2.f;
    for (int k = 0; k < dots; k++) im.data[3 * (64 * (8 + 5 * k) + 7 * k)] = -1e-4f;
    snprintf(p, sizeof p, "%s/%s", g_dir, name);
    CHECK(image_write(p, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
}

/* Negative probe texels: a few tiny ones (far below 1e-4 of the light) are not mentioned; a band
 * holding a few percent of the light is, with that share: latlong rows 0..3 of 32 at -1 against 2
 * elsewhere hold 3 x 1 x 2 pi (1 - cos(pi/8)) of 3 x (that + 2 x (4 pi - 2 pi (1 - cos(pi/8)))). */
static void probe_negatives(void) {
    good_prt();
    static char buf[16384];
    write_probe("tiny.exr", 0, 0, 3);
    int rc = run_here("render good.prt --probe tiny.exr -o tiny.png --size 16x12", buf, sizeof buf);
    CHECK(rc == 0 && !strstr(buf, "negative"), "tiny negatives reported: %s", buf);
    write_probe("band.exr", 4, 1.f, 0);
    rc = run_here("render good.prt --probe band.exr -o band.png --size 16x12", buf, sizeof buf);
    double cap = 2 * M_PI * (1 - cos(M_PI / 8)), share = cap / (cap + 2 * (4 * M_PI - cap));
    const char *w = strstr(buf, "256 texel(s) with negative values clamped to 0: ");
    double pc = -1;
    CHECK(rc == 0 && w && sscanf(w, "256 texel(s) with negative values clamped to 0: %lf%%", &pc) == 1, "band: %s", buf);
    CHECK(count(buf, "negative values") == 1 && strstr(buf, "band.exr"), "one line naming the probe: %s", buf);
    /* printed to one decimal of a percent (1 <= pc < 10) */
    CHECK_NEAR(pc, 100 * share, 0.05 + 1e-9, "the negative share of the light, percent");
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE(bad_obj);
    CHECK_CASE(usage_errors);
    CHECK_CASE_GL(good_render);
    CHECK_CASE(backends);
    CHECK_CASE_GL(interreflections);
    CHECK_CASE(bad_probes);
    CHECK_CASE(damaged_prt);
    CHECK_CASE_GL(output_is_input);
    CHECK_CASE(output_kinds);
    CHECK_CASE_GL(directory_inputs);
    CHECK_CASE(camera_messages);
    CHECK_CASE_GL(help_defaults);
    CHECK_CASE_GL(durations);
    CHECK_CASE_GL(render_backend);
    CHECK_CASE_GL(probe_negatives);
    return check_summary();
}
