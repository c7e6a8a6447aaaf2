/* test_view.c - `prt view` in a real window under Xvfb, against the headless renderer.
 *
 * Self-contained: the test writes a small procedural OBJ (a sphere) and a
 * procedural sky probe (EXR), precomputes them with `build/prt precompute`
 * (glossy Phong sphere, 2 BRDF terms, diffuse floor), then for each runtime
 * (CPU and GL) runs
 *     xvfb-run prt view scene.prt --probe sky.exr --camera C --size WxH --frames 3 --screenshot shot.png
 * and `prt render` of the same camera, size and exposure (headless, OSMesa), and
 * compares the two PNGs in 8-bit sRGB code values: at most 2 codes apart at any
 * pixel (tolerance for rasterization through GLX vs OSMesa; the same float
 * image gives identical codes). A render from another camera must differ by far
 * more, so the comparison can fail. Xvfb missing is a failure, not a skip. */
#include "harness.h"
#include "image.h"
#include "probe.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define W 200
#define H 150
static const char *k_cam = "2.2,1.6,2.9,0,0.35,0,40";

/* A UV sphere of radius 0.5 centred at (0, 0.5, 0), as OBJ text. */
static int write_obj(const char *path) {
    FILE *f = fopen(path, "w");
    if (!f) return -1;
    const int rings = 16, segs = 24;
    fprintf(f, "# procedural sphere for test_view\nv 0 1 0\n");
    for (int r = 1; r < rings; r++)
        for (int s = 0; s < segs; s++) {
            double th = M_PI * r / rings, ph = 2 * M_PI * s / segs;
            fprintf(f, "v %.6f %.6f %.6f\n", 0.5 * sin(th) * cos(ph), 0.5 + 0.5 * cos(th), 0.5 * sin(th) * sin(ph));
        }
    fprintf(f, "v 0 0 0\n");
    int south = 2 + (rings - 1) * segs;
    for (int s = 0; s < segs; s++) fprintf(f, "f 1 %d %d\n", 2 + (s + 1) % segs, 2 + s);
    for (int r = 0; r + 2 < rings; r++)
        for (int s = 0; s < segs; s++) {
            int a = 2 + r * segs + s, b = 2 + r * segs + (s + 1) % segs, c = b + segs, d = a + segs;
            fprintf(f, "f %d %d %d\nf %d %d %d\n", a, b, c, a, c, d);
        }
    for (int s = 0; s < segs; s++) {
        int base = 2 + (rings - 2) * segs;
        fprintf(f, "f %d %d %d\n", base + s, base + (s + 1) % segs, south);
    }
    return fclose(f);
}

/* 8-bit sRGB code of a linear value (what the PNG holds; image_read decodes it back to linear). */
static int code(float x) {
    x = x < 0 ? 0 : x > 1 ? 1 : x;
    float s = x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1 / 2.4f) - 0.055f;
    return (int)lroundf(s * 255);
}

/* Max and mean code difference of two images of the same size (-1 if sizes differ or unreadable). */
static double compare_png(const char *a, const char *b, double *mean) {
    prt_image ia = { 0 }, ib = { 0 };
    prt_error err;
    double worst = -1;
    *mean = -1;
    if (image_read(a, &ia, &err) == 0 && image_read(b, &ib, &err) == 0 && ia.w == ib.w && ia.h == ib.h) {
        worst = 0;
        double sum = 0;
        size_t n = (size_t)ia.w * ia.h * 3;
        for (size_t i = 0; i < n; i++) {
            int d = abs(code(ia.data[i]) - code(ib.data[i]));
            if (d > worst) worst = d;
            sum += d;
        }
        *mean = sum / (double)n;
    } else fprintf(stderr, "compare %s %s: %s\n", a, b, err.msg);
    image_free(&ia);
    image_free(&ib);
    return worst;
}

static double mean_code(const char *path) {
    prt_image im = { 0 };
    prt_error err;
    if (image_read(path, &im, &err)) return -1;
    double s = 0;
    for (size_t i = 0; i < (size_t)im.w * im.h * 3; i++) s += code(im.data[i]);
    s /= (double)im.w * im.h * 3;
    image_free(&im);
    return s;
}

/* Paths shared by the cases (under the binary's scratch directory). */
static char g_obj[512], g_sky[512], g_sky2[512], g_scene[512];
static int g_have_xvfb;

/* Runs `xvfb-run prt view ARGS` (window 640x480x24) into out; returns the exit status. */
static int run_view(const char *args, char *out, size_t cap) {
    char cmd[16384];
    snprintf(cmd, sizeof cmd, "xvfb-run -a -s '-screen 0 640x480x24' %s view %s", check_prt_bin(), args);
    return check_run(cmd, out, cap);
}

/* Runs `prt render ARGS` headless; returns the exit status. */
static int run_render(const char *args, char *out, size_t cap) {
    char cmd[16384];
    snprintf(cmd, sizeof cmd, "%s render %s", check_prt_bin(), args);
    return check_run(cmd, out, cap);
}

/* The inputs every case uses: a sphere OBJ, two sky probes, the precomputed scene (one bounce,
 * direct set kept). */
static void setup(void) {
    const char *dir = check_tmpdir(), *prt = check_prt_bin();
    char cmd[8192], out[16384];
    snprintf(g_obj, sizeof g_obj, "%s/sphere.obj", dir);
    snprintf(g_sky, sizeof g_sky, "%s/sky.exr", dir);
    snprintf(g_sky2, sizeof g_sky2, "%s/sky2.exr", dir);
    snprintf(g_scene, sizeof g_scene, "%s/scene.prt", dir);
    CHECK(access(prt, X_OK) == 0, "%s not built", prt);
    g_have_xvfb = check_run("command -v xvfb-run", NULL, 0) == 0;
    CHECK(g_have_xvfb, "xvfb-run is not installed (apt-get install xvfb): the viewer cannot be tested");
    CHECK(write_obj(g_obj) == 0, "cannot write %s", g_obj);
    prt_probe p;
    prt_error err = { { 0 } };
    sky_desc sd = { .width = 256, .sun_dir = { 0.5f, 0.7f, 0.3f }, .sun_radius_deg = 4, .sun_radiance = 60 };
    int rc = probe_make_sky(&sd, &p, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        CHECK(image_write(g_sky, &p.img, &(image_desc){ 0 }, &err) == 0, "%s", err.msg);
        probe_free(&p);
    }
    sky_desc sd2 = { .width = 256, .sun_dir = { -0.6f, 0.5f, -0.2f }, .sun_radius_deg = 8, .sun_radiance = 30,
                     .sky_zenith = { 0.2f, 0.3f, 0.9f }, .sky_horizon = { 0.9f, 0.6f, 0.4f }, .ground = { 0.1f, 0.2f, 0.1f } };
    rc = probe_make_sky(&sd2, &p, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        CHECK(image_write(g_sky2, &p.img, &(image_desc){ 0 }, &err) == 0, "%s", err.msg);
        probe_free(&p);
    }
    snprintf(cmd, sizeof cmd,
             "%s precompute %s --material 'phong:kd=0.5,0.3,0.2;ks=0.4;n=20' --terms 2 --floor 1500 --coeffs 64 "
             "--vis-res 64 --bounces 1 --force-bounces --keep-direct --glossy svd --quiet -o %s",
             prt, g_obj, g_scene);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "precompute failed (%d): %s", rc, out);
}

/* ref_cpu.png: the headless CPU render of the test camera (several cases compare against it). */
static const char *ref_cpu(void) {
    static char ref[512];   /* test-binary state, not the library's */
    char args[4096], out[16384];
    snprintf(ref, sizeof ref, "%s/ref_cpu.png", check_tmpdir());
    if (access(ref, F_OK) != 0) {
        snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure -1 --backend cpu -o %s", g_scene,
                 g_sky, k_cam, W, H, ref);
        int rc = run_render(args, out, sizeof out);
        CHECK(rc == 0, "render --backend cpu failed (%d): %s", rc, out);
    }
    return ref;
}

/* --help lists every key. */
static void help(void) {
    char cmd[4096], out[16384];
    snprintf(cmd, sizeof cmd, "%s view --help", check_prt_bin());
    CHECK(check_run(cmd, out, sizeof out) == 0, "view --help failed: %s", out);
    const char *keys[] = { "orbit", "pan", "zoom", "rotate the lighting", "1 .. 9", "next / previous probe",
                           "exposure", "K / k", "CPU runtime", "direct only", "screenshot", "quit", "--frames", "one bounce",
                           "indirect highlights",
                           "--screenshot", "--probes" };
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        CHECK(strstr(out, keys[i]) != NULL, "--help does not mention '%s'", keys[i]);
}

/* Bad input: one-line errors, before any window. */
static void bad_input(void) {
    const char *dir = check_tmpdir(), *prt = check_prt_bin();
    char cmd[8192], out[16384];
    snprintf(cmd, sizeof cmd, "%s view %s/missing.prt --probe %s --frames 1", prt, dir, g_sky);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 1 && strstr(out, "missing.prt") && strchr(out, '\n') == out + strlen(out) - 1, "rc %d: %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s view %s", prt, g_scene);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "probe"), "no probe: rc %d: %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s view %s --probe %s --camera 1,2 --frames 1", prt, g_scene, g_sky);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc != 0 && strstr(out, "--camera"), "bad camera: rc %d: %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s view %s --probe %s --backend vulkan --frames 1", prt, g_scene, g_sky);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "vulkan") && strchr(out, '\n') == out + strlen(out) - 1, "bad backend: rc %d: %s", rc, out);
}

/* Window screenshot vs headless render, both runtimes. */
static void screenshot_vs_render(void) {
    const char *dir = check_tmpdir(), *backends[2] = { "cpu", "gl" };
    char args[8192], out[16384];
    for (int b = 0; b < 2 && g_have_xvfb; b++) {
        char shot[512], ref[512];
        snprintf(shot, sizeof shot, "%s/shot_%s.png", dir, backends[b]);
        snprintf(ref, sizeof ref, "%s/ref_%s.png", dir, backends[b]);
        snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure -1 --backend %s --frames 3 --screenshot %s",
                 g_scene, g_sky, k_cam, W, H, backends[b], shot);
        int rc = run_view(args, out, sizeof out);
        CHECK(rc == 0, "view --backend %s failed (%d): %s", backends[b], rc, out);
        CHECK(strstr(out, "view: 3 frames") != NULL, "no frame summary: %s", out);
        snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure -1 --backend %s -o %s", g_scene, g_sky,
                 k_cam, W, H, backends[b], ref);
        rc = run_render(args, out, sizeof out);
        CHECK(rc == 0, "render --backend %s failed (%d): %s", backends[b], rc, out);
        double mean, worst = compare_png(shot, ref, &mean);
        CHECK(worst >= 0, "%s: images missing or of different sizes", backends[b]);
        CHECK_LE(worst, 2, "%s: viewer screenshot differs from the headless render (mean %.4f codes)", backends[b], mean);
        CHECK_LE(mean, 0.05, "%s: mean code difference", backends[b]);
        double m = mean_code(shot);
        CHECK(m > 10 && m < 245, "%s: screenshot is blank (mean code %.1f)", backends[b], m);
    }
}

/* Keys, probes and light rotation: start on GL with two probes and a rotated light, then press
 * b (CPU runtime), 2 (second probe), k (one BRDF term fewer) and + (half a stop brighter); the
 * last frame must match the headless render of exactly that state. */
static void keys(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir();
    char shot[512], ref[512], args[8192], out[16384];
    snprintf(shot, sizeof shot, "%s/shot_keys.png", dir);
    snprintf(ref, sizeof ref, "%s/ref_keys.png", dir);
    snprintf(args, sizeof args,
             "%s --probe %s --probe %s --light-rotation 60,10 --camera %s --size %dx%d --exposure -1 --backend gl --frames 5 "
             "--keys b2k+ --screenshot %s",
             g_scene, g_sky, g_sky2, k_cam, W, H, shot);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0 && strstr(out, "CPU runtime"), "view with keys failed (%d): %s", rc, out);
    snprintf(args, sizeof args, "%s --probe %s --light-rotation 60,10 --camera %s --size %dx%d --exposure -0.5 --terms 1 --backend cpu -o %s",
             g_scene, g_sky2, k_cam, W, H, ref);
    rc = run_render(args, out, sizeof out);
    CHECK(rc == 0, "render failed (%d): %s", rc, out);
    double mean, worst = compare_png(shot, ref, &mean);
    CHECK(worst >= 0, "keys: images missing or of different sizes");
    CHECK_LE(worst, 2, "keys: viewer state after b2k+ differs from the headless render (mean %.4f codes)", mean);
    /* ... and differs clearly from the first probe's unrotated 2-term image. */
    worst = compare_png(shot, ref_cpu(), &mean);
    CHECK(worst > 20 && mean > 1, "keys had no visible effect (max %g, mean %g)", worst, mean);
}

/* D: direct lighting only (the file keeps both sets). The GL runtime in its per-vertex view model
 * against the CPU runtime's `render --direct-only`; the bounce must have changed the image. */
static void direct_gl(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir();
    char shot[512], ref[512], args[8192], out[16384];
    snprintf(shot, sizeof shot, "%s/shot_direct.png", dir);
    snprintf(ref, sizeof ref, "%s/ref_direct.png", dir);
    snprintf(args, sizeof args,
             "%s --probe %s --camera %s --size %dx%d --exposure -1 --backend gl --view-model vertex --frames 3 --keys d "
             "--screenshot %s",
             g_scene, g_sky, k_cam, W, H, shot);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0 && strstr(out, "direct lighting only"), "view --keys d failed (%d): %s", rc, out);
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure -1 --direct-only --backend cpu -o %s", g_scene, g_sky,
             k_cam, W, H, ref);
    rc = run_render(args, out, sizeof out);
    CHECK(rc == 0, "render --direct-only failed (%d): %s", rc, out);
    double mean, worst = compare_png(shot, ref, &mean);
    CHECK(worst >= 0, "direct: images missing or of different sizes");
    CHECK_LE(worst, 2, "direct: GL per-vertex viewer differs from the CPU direct-only render (mean %.4f codes)", mean);
    worst = compare_png(ref, ref_cpu(), &mean);
    fprintf(stderr, "test_view: one bounce changes the image by max %g, mean %.3f codes\n", worst, mean);
    CHECK(worst > 3, "the bounce had no visible effect (max %g codes)", worst);
}

/* Power of the comparison: another camera gives a clearly different image. */
static void camera_power(void) {
    char other[512], args[8192], out[16384];
    snprintf(other, sizeof other, "%s/other.png", check_tmpdir());
    snprintf(args, sizeof args, "%s --probe %s --camera 2.3,1.6,2.8,0,0.35,0,40 --size %dx%d --exposure -1 -o %s", g_scene,
             g_sky, W, H, other);
    CHECK(run_render(args, out, sizeof out) == 0, "%s", out);
    double mean, worst = compare_png(other, ref_cpu(), &mean);
    CHECK(worst > 20 && mean > 0.3, "a slightly moved camera should differ clearly (max %g, mean %g)", worst, mean);
}

/* The same toggle on the CPU runtime (the scene has one bounce pass and keeps its direct set):
 * key d switches to direct lighting only, which must match `prt render --direct-only`, and
 * differ from the total. */
static void direct_cpu(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir();
    char shot[512], ref[512], reft[512], args[8192], out[16384];
    snprintf(shot, sizeof shot, "%s/shot_direct_cpu.png", dir);
    snprintf(ref, sizeof ref, "%s/ref_direct0.png", dir);
    snprintf(reft, sizeof reft, "%s/ref_total0.png", dir);
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --backend cpu --frames 3 --keys d --screenshot %s",
             g_scene, g_sky, k_cam, W, H, shot);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0 && strstr(out, "direct lighting only"), "view with key d failed (%d): %s", rc, out);
    for (int k = 0; k < 2; k++) {
        snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --backend cpu %s -o %s", g_scene, g_sky, k_cam, W, H,
                 k ? "" : "--direct-only", k ? reft : ref);
        rc = run_render(args, out, sizeof out);
        CHECK(rc == 0, "render failed (%d): %s", rc, out);
    }
    double mean, worst = compare_png(shot, ref, &mean);
    CHECK(worst >= 0 && worst <= 2, "key d: viewer differs from render --direct-only (max %g, mean %.4f codes)", worst, mean);
    worst = compare_png(ref, reft, &mean);
    CHECK(worst > 3 && mean > 0.05, "direct and total images should differ (max %g, mean %.4f codes)", worst, mean);
}

/* Keys o and i: with a local light, the one bounce and the indirect highlights (started off with
 * --no-local-bounce --no-highlights) turned on in the viewer give, on either runtime, the headless
 * `render --local-bounce --highlights` of that runtime (2 codes, as the other cases), and the effects
 * changed the image (the power check). */
static void local_effects(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir(), *backends[2] = { "cpu", "gl" }, *light = "'point:pos=0.9,1.2,0.8;intensity=2'";
    char shot[512], ref[512], plain[512], args[8192], out[16384];
    for (int b = 0; b < 2; b++) {
        snprintf(shot, sizeof shot, "%s/shot_fx_%s.png", dir, backends[b]);
        snprintf(ref, sizeof ref, "%s/ref_fx_%s.png", dir, backends[b]);
        snprintf(plain, sizeof plain, "%s/ref_nofx_%s.png", dir, backends[b]);
        snprintf(args, sizeof args, "%s --probe %s --light %s --camera %s --size %dx%d --exposure -1 --backend %s --frames 3 "
                 "--no-local-bounce --no-highlights --keys oi --screenshot %s", g_scene, g_sky, light, k_cam, W, H, backends[b],
                 shot);
        int rc = run_view(args, out, sizeof out);
        CHECK(rc == 0 && strstr(out, "one bounce on, indirect highlights on"), "view --keys oi (%s) failed (%d): %s",
              backends[b], rc, out);
        for (int k = 0; k < 2; k++) {
            snprintf(args, sizeof args, "%s --probe %s --light %s --camera %s --size %dx%d --exposure -1 --backend %s %s -o %s",
                     g_scene, g_sky, light, k_cam, W, H, backends[b],
                     k ? "--no-local-bounce --no-highlights" : "--local-bounce --highlights", k ? plain : ref);
            rc = run_render(args, out, sizeof out);
            CHECK(rc == 0, "render (%s) failed (%d): %s", backends[b], rc, out);
        }
        double mean, worst = compare_png(shot, ref, &mean);
        CHECK(worst >= 0 && worst <= 2, "%s: keys o, i differ from render --local-bounce --highlights (max %g, mean %.4f codes)",
              backends[b], worst, mean);
        worst = compare_png(ref, plain, &mean);
        fprintf(stderr, "test_view: %s: the bounce and highlights change the image by max %g, mean %.3f codes\n", backends[b],
                worst, mean);
        CHECK(worst > 3, "%s: the effects had no visible effect (max %g codes)", backends[b], worst);
    }
}

/* `prt bench --backend gl` (what replaced glbench) runs headless and prints the same lines as the CPU one. */
static void bench(void) {
    const char *backends[2] = { "cpu", "gl" };
    for (int b = 0; b < 2; b++) {
        char cmd[8192], out[16384];
        snprintf(cmd, sizeof cmd, "%s bench %s --probe %s --backend %s --size 64x48 --frames 2", check_prt_bin(), g_scene,
                 g_sky, backends[b]);
        int rc = check_run(cmd, out, sizeof out);
        char want[64];
        snprintf(want, sizeof want, "bench: backend=%s K=2 ", backends[b]);
        CHECK(rc == 0 && strstr(out, "\nlight change: ") && strstr(out, "\nview change:  ") && strstr(out, want) &&
                  strstr(out, "Table II"),
              "bench --backend %s failed (%d): %s", backends[b], rc, out);
    }
    char cmd[8192], out[16384];
    snprintf(cmd, sizeof cmd, "%s glbench %s --probe %s", check_prt_bin(), g_scene, g_sky);
    CHECK(check_run(cmd, out, sizeof out) == 2 && strstr(out, "unknown command 'glbench'"), "glbench still there: %s", out);
}

/* A probe switch prepares the new probe on a worker thread (its fine cube and, for a vMF file, its
 * prefiltered ladder, seconds) while the window keeps drawing with the old light: on a vMF scene, key
 * n after the first frame, and every frame until the last (which waits for the probe) is drawn while
 * the worker runs, each in less time than the preparation took, i.e. none waited for it; the last
 * frame is the one a viewer started on that probe draws, code for code (the same prepared probe,
 * made by the same deterministic code), on both runtimes, and it differs from the first probe's. */
static void probe_switch(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir(), *backends[2] = { "cpu", "gl" };
    char vmf[512], cmd[8192], args[8192], out[16384], shot[512], ref[512], first[512];
    snprintf(vmf, sizeof vmf, "%s/vmf.prt", dir);
    snprintf(cmd, sizeof cmd,
             "%s precompute %s --material 'phong:kd=0.5,0.3,0.2;ks=0.4;n=20' --floor 400 --coeffs 64 --vis-res 64 "
             "--bounces 0 --glossy vmf --quiet -o %s", check_prt_bin(), g_obj, vmf);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "precompute --glossy vmf failed (%d): %s", rc, out);
    for (int b = 0; b < 2 && rc == 0; b++) {
        const int frames = 12;
        snprintf(shot, sizeof shot, "%s/switch_%s.png", dir, backends[b]);
        snprintf(ref, sizeof ref, "%s/switch_ref_%s.png", dir, backends[b]);
        snprintf(first, sizeof first, "%s/switch_first_%s.png", dir, backends[b]);
        snprintf(args, sizeof args, "%s --probe %s --probe %s --camera %s --size %dx%d --exposure -1 --backend %s --frames %d "
                 "--keys n --screenshot %s", vmf, g_sky, g_sky2, k_cam, W, H, backends[b], frames, shot);
        rc = run_view(args, out, sizeof out);
        double prep = -1, longest = -1;
        int during = -1;
        const char *line = strstr(out, "probe prepared on a worker thread in ");
        CHECK(rc == 0 && line && sscanf(line, "probe prepared on a worker thread in %lf ms; %d frames drawn meanwhile, the longest %lf",
                                        &prep, &during, &longest) == 3, "view --keys n (%s) failed (%d): %s", backends[b], rc, out);
        fprintf(stderr, "test_view: %s: probe prepared in %.0f ms, %d frames meanwhile, the longest %.1f ms\n", backends[b], prep,
                during, longest);
        CHECK(during == frames - 2, "%s: frames 2 to %d drawn while the probe was prepared (%d)", backends[b], frames - 1, during);
        CHECK(longest < prep, "%s: no frame waited for the preparation (longest %.1f ms, preparation %.1f ms)", backends[b], longest,
              prep);
        for (int k = 0; k < 2; k++) {
            snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure -1 --backend %s --frames 2 --screenshot %s",
                     vmf, k ? g_sky : g_sky2, k_cam, W, H, backends[b], k ? first : ref);
            rc = run_view(args, out, sizeof out);
            CHECK(rc == 0, "view (%s) failed (%d): %s", backends[b], rc, out);
        }
        double mean, worst = compare_png(shot, ref, &mean);
        CHECK(worst == 0, "%s: after the switch the frame is that of the probe from the start (max %g, mean %.4f codes)",
              backends[b], worst, mean);
        worst = compare_png(shot, first, &mean);
        CHECK(worst > 20, "%s: the switch changed the image (max %g codes)", backends[b], worst);
    }
}

/* Under Xvfb the GL renderer is Mesa's llvmpipe: without --backend the viewer starts on the CPU
 * backend and says why; --backend gl keeps the GL one. */
static void software_default(void) {
    char args[8192], out[16384];
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --frames 2", g_scene, g_sky, k_cam, W, H);
    int rc = run_view(args, out, sizeof out);
    bool soft = strstr(out, "llvmpipe") != NULL;
    CHECK(rc == 0 && (!soft || (strstr(out, "is software (llvmpipe") && strstr(out, "starting on the CPU backend"))),
          "view on a software renderer, no --backend (%d): %s", rc, out);
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --frames 2 --backend gl", g_scene, g_sky, k_cam, W, H);
    rc = run_view(args, out, sizeof out);
    CHECK(rc == 0 && !strstr(out, "is software"), "view --backend gl keeps gl (%d): %s", rc, out);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE(help);
    CHECK_CASE(bad_input);
    CHECK_CASE(screenshot_vs_render);
    CHECK_CASE(keys);
    CHECK_CASE(direct_gl);
    CHECK_CASE(camera_power);
    CHECK_CASE(direct_cpu);
    CHECK_CASE(local_effects);
    CHECK_CASE(bench);
    CHECK_CASE(software_default);
    CHECK_CASE(probe_switch);
    return check_summary();
}
