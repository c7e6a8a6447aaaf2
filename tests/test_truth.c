/* test_truth.c - `prt view --truth` under Xvfb: the PRT frame beside the progressive reference and
 * their error, scripted with --frames, --keys and --truth-spp.
 *
 * Self-contained: a procedural sphere over a floor and a sky probe with a broad, dim sun (so that a
 * few samples per pixel give a reference whose noise is small next to its signal), precomputed
 * direct only with 64 coefficients per vector (N = 128: the shared budget's cap). Each case runs
 *     xvfb-run prt view scene.prt --probe sky.exr --truth --backend cpu --frames N --truth-spp S ...
 * and checks what it prints and writes against independent computations:
 *   - the snapshot: a window of three panels whose left and middle panels are the -prt.exr and
 *     -ref.exr written beside it, tone-mapped (the same 8-bit code within 1: the PRT panel goes
 *     through the GL blit's shader, the reference through the CPU's rounding);
 *   - the error on screen (stdout and the .txt) equals `prt compare` of those two images within
 *     1e-4 (both are compare.h's rel_rmse of the same floats, EXR being 32-bit float; the figures are
 *     printed to 6 decimals, so they agree to 1e-6);
 *   - the reference's noise on screen agrees with `prt reference`'s own estimate at the same spp;
 *   - rotating the light (key ]) restarts the reference: the frame after the key finds it at 0 spp;
 *   - fewer coefficients per vector (key c, five times: the file's N -> N / 32), on the cpu and the gl
 *     runtime, do not lower the error against the same reference (--truth-spp stops it at S samples: every frame of one state sees the same
 *     image): truncation moves the PRT frame away from what it converges to.
 * Xvfb missing is a failure, not a skip. */
#include "harness.h"
#include "image.h"
#include "probe.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define W 420
#define H 200
#define PW (W / 3)
static const char *k_cam = "2.2,1.6,2.9,0,0.35,0,40";
static char g_sky[512], g_scene[512];
static int g_have_xvfb;

/* 8-bit sRGB code of a linear value (what a PNG holds; image_read decodes it back to linear). */
static int code(float x) {
    x = x < 0 ? 0 : x > 1 ? 1 : x;
    float s = x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1 / 2.4f) - 0.055f;
    return (int)lroundf(s * 255);
}

/* Runs `xvfb-run prt view ARGS` into out; the exit status. */
static int run_view(const char *args, char *out, size_t cap) {
    char cmd[16384];
    snprintf(cmd, sizeof cmd, "xvfb-run -a -s '-screen 0 800x600x24' %s view %s", check_prt_bin(), args);
    return check_run(cmd, out, cap);
}

/* The scene (sphere over a floor, direct only) and the sky. */
static void setup(void) {
    const char *dir = check_tmpdir(), *prt = check_prt_bin();
    char json[512], cmd[8192], out[16384];
    snprintf(g_sky, sizeof g_sky, "%s/sky.exr", dir);
    snprintf(g_scene, sizeof g_scene, "%s/scene.prt", dir);
    snprintf(json, sizeof json, "%s/scene.json", dir);
    g_have_xvfb = check_run("command -v xvfb-run", NULL, 0) == 0;
    CHECK(g_have_xvfb, "xvfb-run is not installed (apt-get install xvfb): the viewer cannot be tested");
    FILE *f = fopen(json, "w");
    CHECK(f != NULL, "cannot write %s", json);
    if (!f) return;
    fprintf(f, "{ \"models\": [ { \"sphere\": { \"center\": [0, 0.5, 0], \"radius\": 0.5, \"rings\": 16, \"segments\": 24 },\n"
               "    \"material\": \"phong:kd=0.5,0.3,0.2;ks=0.2;n=8\" } ],\n"
               "  \"floor\": { \"vertices\": 1500, \"size\": 3, \"material\": \"lambert:kd=0.6\" } }\n");
    fclose(f);
    prt_probe p;
    prt_error err = { { 0 } };
    sky_desc sd = { .width = 128, .sun_dir = { 0.5f, 0.7f, 0.3f }, .sun_radius_deg = 20, .sun_radiance = 3 };
    int rc = probe_make_sky(&sd, &p, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        CHECK(image_write(g_sky, &p.img, &(image_desc){ 0 }, &err) == 0, "%s", err.msg);
        probe_free(&p);
    }
    snprintf(cmd, sizeof cmd, "%s precompute %s --terms 2 --coeffs 64 --vis-res 64 --bounces 0 --glossy svd --quiet -o %s",
             prt, json, g_scene);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "precompute failed (%d): %s", rc, out);
}

/* The value of "KEY VALUE" at the line of text that starts with key (-1 if absent). */
static double figure(const char *text, const char *line_start, const char *key) {
    const char *l = strstr(text, line_start);
    if (!l) return -1;
    const char *k = strstr(l, key), *eol = strchr(l, '\n');
    if (!k || (eol && k > eol)) return -1;
    return atof(k + strlen(key));
}

/* The whole text file path into buf (empty when unreadable). */
static void slurp(const char *path, char *buf, size_t cap) {
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(buf, 1, cap - 1, f) : 0;
    buf[n] = 0;
    if (f) fclose(f);
}

/* Largest code difference between panel px0 of the window shot and image img (tone-mapped at exposure
 * 0), over rows y0..y1 and the panel's first PANEL_COLS columns (clear of the HUD, the labels and the
 * plot's). -1 when unreadable or of the wrong size. */
#define PANEL_COLS 100
static int panel_diff(const prt_image *shot, int px0, const char *img_path, int y0, int y1) {
    prt_image im = { 0 };
    prt_error err;
    if (image_read(img_path, &im, &err) || im.w != PW || im.h != H) { image_free(&im); return -1; }
    int worst = 0;
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < PANEL_COLS; x++)
            for (int c = 0; c < 3; c++) {
                int a = code(shot->data[3 * ((size_t)y * shot->w + px0 + x) + c]), b = code(im.data[3 * ((size_t)y * PW + x) + c]);
                if (abs(a - b) > worst) worst = abs(a - b);
            }
    image_free(&im);
    return worst;
}

/* The snapshot: three panels, the two images beside it, the error on screen = prt compare of them. */
static void snapshot(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir();
    char args[8192], out[16384], shot[512], pimg[512], rimg[512], txt[512], cmd[8192], cmp[4096], side[4096];
    snprintf(shot, sizeof shot, "%s/truth.png", dir);
    snprintf(pimg, sizeof pimg, "%s/truth-prt.exr", dir);
    snprintf(rimg, sizeof rimg, "%s/truth-ref.exr", dir);
    snprintf(txt, sizeof txt, "%s/truth.txt", dir);
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --exposure 0 --backend cpu --truth --truth-spp 8 "
             "--frames 2 --screenshot %s", g_scene, g_sky, k_cam, W, H, shot);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0, "view --truth failed (%d): %s", rc, out);
    double hud = figure(out, "truth: frame 1:", "rel_rmse "), spp = figure(out, "truth: frame 1:", "spp ");
    double cov = figure(out, "truth: frame 1:", "covered ");
    CHECK(spp == 8 && cov == 1, "the last frame's reference: spp %g, covered %g: %s", spp, cov, out);
    snprintf(cmd, sizeof cmd, "%s compare %s %s", check_prt_bin(), pimg, rimg);
    rc = check_run(cmd, cmp, sizeof cmp);
    CHECK(rc == 0, "prt compare failed (%d): %s", rc, cmp);
    double ref_err = figure(cmp, "rel_rmse=", "rel_rmse=");
    CHECK(hud > 0 && ref_err > 0, "no error figure: view '%s', compare '%s'", out, cmp);
    CHECK_NEAR(hud, ref_err, 1e-4, "the error on screen against prt compare of the panel images");
    slurp(txt, side, sizeof side);
    CHECK_NEAR(figure(side, "rel_rmse", "rel_rmse "), ref_err, 1e-4, "the snapshot's figures against prt compare");
    CHECK(figure(side, "spp", "spp ") == 8, "the snapshot's spp: %s", side);
    prt_image im = { 0 };
    prt_error err;
    rc = image_read(shot, &im, &err);
    CHECK(rc == 0 && im.w == W && im.h == H, "the snapshot: %s (%dx%d)", rc ? err.msg : "", im.w, im.h);
    if (rc == 0 && im.w == W && im.h == H) {
        /* Rows 110..175 are below the HUD and above the panels' titles. */
        CHECK_LE(panel_diff(&im, 0, pimg, 110, 175), 1, "the left panel is not the PRT image");
        CHECK_LE(panel_diff(&im, PW, rimg, 110, 175), 1, "the middle panel is not the reference image");
        CHECK(panel_diff(&im, 2 * PW, rimg, 110, 175) > 20, "the error panel shows the reference");
    }
    image_free(&im);
}

/* Key ] rotates the light: the reference restarts (the next frame finds it at 0 spp) and refines again. */
static void restart(void) {
    if (!g_have_xvfb) return;
    char args[8192], out[16384];
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --backend cpu --truth --truth-spp 4 --frames 3 --keys ']'",
             g_scene, g_sky, k_cam, W, H);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0, "view --truth failed (%d): %s", rc, out);
    CHECK(strstr(out, "truth: restart (light rotation): spp 4 -> 0, then refined to 4") != NULL, "no restart on ]: %s", out);
    CHECK(figure(out, "truth: frame 2:", "spp ") == 4, "frame 2: %s", out);
    int restarts = 0;
    for (const char *p = strstr(out, "truth: restart"); p; p = strstr(p + 1, "truth: restart")) restarts++;
    CHECK(restarts == 1, "%d restarts for one key: %s", restarts, out);
}

/* Fewer coefficients per vector (c: halves) against the same reference: the error is not lower, on the
 * cpu runtime (it reads the cut sets at its light change) and the gl one (made again with them). */
static void coefficients(void) {
    if (!g_have_xvfb) return;
    static const char *backends[2] = { "cpu", "gl" };
    char args[8192], out[16384];
    for (int b = 0; b < 2; b++) {
        snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --backend %s --truth --truth-spp 4 --frames 6 --keys ccccc",
                 g_scene, g_sky, k_cam, W, H, backends[b]);
        int rc = run_view(args, out, sizeof out);
        CHECK(rc == 0, "%s: view --truth failed (%d): %s", backends[b], rc, out);
        CHECK(strstr(out, "truth: restart") == NULL, "%s: the coefficients restarted the reference: %s", backends[b], out);
        double all = figure(out, "truth: frame 0:", "rel_rmse "), few = figure(out, "truth: frame 5:", "rel_rmse ");
        double n0 = figure(out, "truth: frame 0:", "n "), n5 = figure(out, "truth: frame 5:", "n ");
        CHECK(n0 >= 64 && n5 == n0 / 32, "%s: n %g then %g: %s", backends[b], n0, n5, out);
        CHECK(all > 0 && few >= all, "%s: %g coefficients per vector: error %.6f, lower than %g's %.6f", backends[b], n5, few, n0, all);
        fprintf(stderr, "coefficients, %s: rel_rmse %.6f with %g per vector, %.6f with %g (noise %.6f)\n", backends[b], all, n0,
                few, n5, figure(out, "truth: frame 5:", "noise "));
    }
}

/* The reference's noise on screen (two halves of the passes, view_truth.h) against `prt reference`'s own
 * (each pixel's sample standard deviation / sqrt(spp), summed the same way) at the same camera, size and
 * spp: two estimates of one quantity from independent samples. Each sums about 84,000 pixel-channel
 * variance estimates; a single one is a chi-square of few degrees of freedom (relative sd up to sqrt 2),
 * so the sums agree to a few percent where many pixels weigh alike, and the sun's pixels weigh more: 15 %. */
static void noise(void) {
    if (!g_have_xvfb) return;
    const char *dir = check_tmpdir();
    char args[8192], out[16384], cmd[8192], ref[512];
    snprintf(args, sizeof args, "%s --probe %s --camera %s --size %dx%d --backend cpu --truth --truth-spp 8 --frames 1",
             g_scene, g_sky, k_cam, W, H);
    int rc = run_view(args, out, sizeof out);
    CHECK(rc == 0, "view --truth failed (%d): %s", rc, out);
    double hud = figure(out, "truth: frame 0:", "noise ");
    snprintf(ref, sizeof ref, "%s/noise_ref.exr", dir);
    snprintf(cmd, sizeof cmd, "%s reference %s --probe %s --camera %s --size %dx%d --spp 8 -o %s", check_prt_bin(), g_scene, g_sky,
             k_cam, PW, H, ref);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "prt reference failed (%d): %s", rc, out);
    double own = figure(out, "relative noise", "relative noise ");
    CHECK(hud > 0 && own > 0, "noise figures: view %g, reference %g (%s)", hud, own, out);
    CHECK_NEAR(hud / own, 1.0, 0.15, "the noise on screen (%.4f) against prt reference's (%.4f)", hud, own);
    fprintf(stderr, "noise: %.4f on screen, %.4f by prt reference\n", hud, own);
}

/* Bad flags: one line, exit 2, no window. */
static void bad_input(void) {
    char cmd[8192], out[4096];
    snprintf(cmd, sizeof cmd, "%s view %s --probe %s --frames 1 --truth-spp 4", check_prt_bin(), g_scene, g_sky);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "--truth-spp") && strchr(out, '\n') == out + strlen(out) - 1, "rc %d: %s", rc, out);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    setup();
    CHECK_CASE(snapshot);
    CHECK_CASE(restart);
    CHECK_CASE(coefficients);
    CHECK_CASE(noise);
    CHECK_CASE(bad_input);
    return check_summary();
}
