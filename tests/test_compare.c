/* test_compare.c - prt compare's metrics on arrays with hand-computed answers,
 * per-vertex CSV and EXR inputs, the error image, and clean failures on bad input. */
#include "harness.h"
#include "compare.h"
#include "image.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static void write_text(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    if (f) { fputs(text, f); fclose(f); }
}

/* Known arrays: every number below is worked out by hand in the comments. The inputs are the
 * floats nearest those decimals (off by <= 6e-8 relative), so the hand values hold to ~1e-7 of
 * the metric: the tolerance 1e-6 is ten times that. The library's own arithmetic only (sqrt is
 * IEEE), no libm, BLAS or threads: the same bits on any CPU. */
static void arrays(void) {
    prt_error err;
    cmp_result r;
    /* One channel, 4 items: b = 1,2,3,4, a = b + (0.1, 0, -0.3, 0).
     * sum d^2 = 0.01 + 0.09 = 0.1, sum b^2 = 30: rel_rmse = sqrt(0.1/30).
     * mean |b| = 2.5, floor 0.025: all items count; rel errors 0.1, 0, 0.1, 0: max 0.1 (item 0 first). */
    float b1[4] = { 1, 2, 3, 4 }, a1[4] = { 1.1f, 2, 2.7f, 4 }, e[4];
    CHECK(cmp_arrays(a1, b1, 4, 1, &r, e, &err) == 0, "%s", err.msg);
    CHECK_NEAR(r.rel_rmse, sqrt(0.1 / 30), 1e-6, "rel_rmse by hand");
    CHECK_NEAR(r.max_rel_err, 0.1, 1e-6, "max_rel_err by hand");
    CHECK(r.worst_item == 0 || r.worst_item == 2, "worst item %d", r.worst_item);
    CHECK(r.items == 4 && r.items_in_max == 4, "counts %ld %ld", r.items, r.items_in_max);
    CHECK_NEAR(e[1], 0, 0, "per-item error of an exact item");   /* exact: a = b, d = 0 */
    /* RGB items: norms. b = (3,4,0) |b| = 5 and (0,0,0.001) |b| = 0.001; a = (3,4,1) and (0,0,1).
     * sum d^2 = 1 + 0.999^2, sum b^2 = 25 + 1e-6. mean |b| = 2.5005, floor 0.025005:
     * only item 0 counts for the max: |a-b|/|b| = 1/5. */
    float b2[6] = { 3, 4, 0, 0, 0, 0.001f }, a2[6] = { 3, 4, 1, 0, 0, 1 };
    CHECK(cmp_arrays(a2, b2, 2, 3, &r, e, &err) == 0, "%s", err.msg);
    CHECK_NEAR(r.rel_rmse, sqrt((1 + 0.999 * 0.999) / (25 + 1e-6)), 1e-6, "RGB rel_rmse");
    CHECK_NEAR(r.max_rel_err, 0.2, 1e-6, "the near-black item is excluded from the max");
    CHECK(r.items_in_max == 1 && r.worst_item == 0, "items in max %ld", r.items_in_max);
    CHECK_NEAR(e[1], 0.999 / 0.025005, 1e-3, "below the floor the error is relative to the floor");
    /* Identical arrays: zero error, exactly (every difference is 0). */
    CHECK(cmp_arrays(b2, b2, 2, 3, &r, NULL, &err) == 0 && r.rel_rmse == 0 && r.max_rel_err == 0, "identical -> 0");
    /* A scaled result: a = 1.05 b gives exactly 5% everywhere. */
    float a3[4] = { 1.05f, 2.1f, 3.15f, 4.2f };
    CHECK(cmp_arrays(a3, b1, 4, 1, &r, NULL, &err) == 0, "%s", err.msg);
    CHECK_NEAR(r.rel_rmse, 0.05, 1e-6, "5%% scale error");
    CHECK_NEAR(r.max_rel_err, 0.05, 1e-6, "5%% scale error (max)");
    /* All-zero reference. */
    float z[3] = { 0, 0, 0 }, one[3] = { 0, 1, 0 };
    CHECK(cmp_arrays(z, z, 1, 3, &r, NULL, &err) == 0 && r.rel_rmse == 0, "black vs black is 0");
    CHECK(cmp_arrays(one, z, 1, 3, &r, NULL, &err) == -1 && strstr(err.msg, "zero"), "black reference: %s", err.msg);
    float nan3[3] = { NAN, 0, 0 };
    CHECK(cmp_arrays(nan3, one, 1, 3, &r, NULL, &err) == -1 && strstr(err.msg, "non-finite"), "NaN rejected");
}

static void colormap(void) {
    float lo[3], hi[3], mid[3], zero[3];
    cmp_colormap(0.1f, lo);
    cmp_colormap(0.9f, hi);
    cmp_colormap(0.5f, mid);
    cmp_colormap(0.f, zero);
    CHECK(lo[2] > lo[0] && hi[0] > hi[2] && mid[1] > 0.8f, "turbo: blue -> green -> red");
    CHECK(zero[0] + zero[1] + zero[2] < 0.5f, "turbo starts dark");
    float nanc[3];
    cmp_colormap(NAN, nanc);
    CHECK(isfinite(nanc[0]) && isfinite(nanc[1]) && isfinite(nanc[2]), "NaN maps to a colour");
}

static void csv(void) {
    const char *dir = check_tmpdir();
    char pa[512], pb[512], pc[512], pd[512], pe[512], pf[512];
    snprintf(pa, sizeof pa, "%s/a.csv", dir);
    snprintf(pb, sizeof pb, "%s/b.csv", dir);
    snprintf(pc, sizeof pc, "%s/c.csv", dir);
    snprintf(pd, sizeof pd, "%s/d.csv", dir);
    snprintf(pe, sizeof pe, "%s/e.csv", dir);
    snprintf(pf, sizeof pf, "%s/f.csv", dir);
    /* A as prt render writes it (rows out of order on purpose), B as prt reference writes it. */
    write_text(pa, "vertex,r,g,b\n1,2,2,2\r\n0,1.1,1,1\n");
    write_text(pb, "vertex,r,g,b,stderr_r,stderr_g,stderr_b\n0,1,1,1,0.01,0.01,0.01\n1,2,2,2,0,0,0\n");
    prt_error err;
    cmp_result r;
    CHECK(cmp_files(pa, pb, NULL, &r, &err) == 0, "%s", err.msg);
    /* d^2 = 0.01, b^2 = 3 + 12 = 15; max: item 0 |d| = 0.1, |b| = sqrt 3. noise = sqrt(3e-4/15). */
    CHECK_NEAR(r.rel_rmse, sqrt(0.01 / 15), 1e-6, "CSV rel_rmse");
    CHECK_NEAR(r.max_rel_err, 0.1 / sqrt(3), 1e-6, "CSV max_rel_err");
    CHECK_NEAR(r.ref_noise, sqrt(3e-4 / 15), 1e-6, "reference noise from stderr columns");
    CHECK(r.worst_item == 0, "worst vertex id %d", r.worst_item);
    /* Bad inputs, each one clean line naming the file. */
    write_text(pc, "vertex,r,g,b\n0,1,1,1\n");
    CHECK(cmp_files(pa, pc, NULL, &r, &err) == -1 && strstr(err.msg, "vertices"), "count mismatch: %s", err.msg);
    write_text(pd, "vertex,r,g,b\n0,1,1,1\n2,1,1,1\n");
    CHECK(cmp_files(pa, pd, NULL, &r, &err) == -1 && strstr(err.msg, "different vertices"), "id mismatch: %s", err.msg);
    write_text(pe, "vertex,r,g,b\n0,1,x,1\n1,1,1,1\n");
    CHECK(cmp_files(pa, pe, NULL, &r, &err) == -1 && strstr(err.msg, "e.csv:2"), "bad number with line: %s", err.msg);
    write_text(pf, "vertex,r,g,b\n0,1,1\n");
    CHECK(cmp_files(pf, pb, NULL, &r, &err) == -1 && strstr(err.msg, "f.csv:2"), "missing column: %s", err.msg);
    write_text(pf, "vertex,r,g,b\n0,1,1,1\n0,1,1,1\n");
    CHECK(cmp_files(pf, pb, NULL, &r, &err) == -1 && strstr(err.msg, "twice"), "duplicate vertex: %s", err.msg);
    write_text(pf, "vertex,red,green,blue\n0,1,1,1\n");
    CHECK(cmp_files(pf, pb, NULL, &r, &err) == -1 && strstr(err.msg, "header"), "bad header: %s", err.msg);
    write_text(pf, "");
    CHECK(cmp_files(pf, pb, NULL, &r, &err) == -1 && strstr(err.msg, "no vertex rows"), "empty: %s", err.msg);
    write_text(pf, "vertex,r,g,b\n0,nan,1,1\n1,1,1,1\n");
    CHECK(cmp_files(pf, pb, NULL, &r, &err) == -1 && strstr(err.msg, "f.csv:2"), "NaN in CSV: %s", err.msg);
    /* Facing column: back-facing vertices are left out unless all_vertices. */
    char pg[512], ph[512];
    snprintf(pg, sizeof pg, "%s/g.csv", dir);
    snprintf(ph, sizeof ph, "%s/h.csv", dir);
    write_text(pg, "vertex,r,g,b\n0,1,1,1\n1,5,5,5\n2,2,2,2\n");
    write_text(ph, "vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing\n0,1,1,1,0,0,0,1\n1,0,0,0,0,0,0,0\n2,1,1,1,0,0,0,1\n");
    CHECK(cmp_files(pg, ph, NULL, &r, &err) == 0, "%s", err.msg);
    /* Facing items 0 and 2: d^2 = 3, b^2 = 6; max: item 2, |d|/|b| = 1. */
    CHECK_NEAR(r.rel_rmse, sqrt(0.5), 1e-6, "only facing vertices");
    CHECK_NEAR(r.max_rel_err, 1.0, 1e-6, "max over facing vertices");
    CHECK(r.skipped == 1 && r.items == 2 && r.worst_item == 2, "skipped %ld items %ld worst %d", r.skipped, r.items, r.worst_item);
    CHECK(cmp_files(pg, ph, &(cmp_desc){ .all_vertices = true }, &r, &err) == 0, "%s", err.msg);
    CHECK_NEAR(r.rel_rmse, sqrt(78.0 / 6), 1e-5, "all vertices: d^2 = 3 + 75");
    write_text(ph, "vertex,r,g,b,facing\n0,1,1,1,2\n1,0,0,0,0\n2,1,1,1,1\n");
    CHECK(cmp_files(pg, ph, NULL, &r, &err) == -1 && strstr(err.msg, "h.csv:2"), "facing must be 0 or 1: %s", err.msg);
    char missing[600];
    snprintf(missing, sizeof missing, "%s/nope.csv", dir);
    CHECK(cmp_files(missing, pb, NULL, &r, &err) == -1 && strstr(err.msg, "nope.csv"), "missing file: %s", err.msg);
    CHECK(cmp_files(pa, pb, &(cmp_desc){ .error_image = "x.png" }, &r, &err) == -1 && strstr(err.msg, "error image"), "no error image for CSV");
}

static int write_img(const char *path, int w, int h, const float *rgb) {
    prt_image im;
    prt_error err;
    if (image_alloc(&im, w, h, 3, &err)) return -1;
    memcpy(im.data, rgb, sizeof(float) * 3 * w * h);
    image_desc d = { 0 };
    int rc = image_write(path, &im, &d, &err);
    image_free(&im);
    return rc;
}

static void images(void) {
    const char *dir = check_tmpdir();
    enum { W = 8, H = 4 };
    char pa[512], pb[512], pc[512], pe[512], pcsv[512];
    snprintf(pa, sizeof pa, "%s/a.exr", dir);
    snprintf(pb, sizeof pb, "%s/b.exr", dir);
    snprintf(pc, sizeof pc, "%s/c.exr", dir);
    snprintf(pe, sizeof pe, "%s/err.png", dir);
    snprintf(pcsv, sizeof pcsv, "%s/b.csv", dir);
    float a[W * H * 3], b[W * H * 3];
    double d2 = 0, b2 = 0;
    for (int i = 0; i < W * H; i++)
        for (int c = 0; c < 3; c++) {
            b[3 * i + c] = 0.5f + 0.25f * c + 0.125f * (i % 5);   /* exactly representable */
            a[3 * i + c] = b[3 * i + c] * (i == 7 ? 1.5f : 1.0f) + (i == 3 ? 0.25f : 0.f);
            double d = (double)a[3 * i + c] - b[3 * i + c];
            d2 += d * d;
            b2 += (double)b[3 * i + c] * b[3 * i + c];
        }
    CHECK(write_img(pa, W, H, a) == 0 && write_img(pb, W, H, b) == 0, "wrote test EXRs");
    prt_error err;
    cmp_result r;
    CHECK(cmp_files(pa, pb, &(cmp_desc){ .error_image = pe }, &r, &err) == 0, "%s", err.msg);
    CHECK_NEAR(r.rel_rmse, sqrt(d2 / b2), 1e-6, "EXR rel_rmse");
    CHECK_NEAR(r.max_rel_err, 0.5, 1e-6, "EXR max_rel_err: pixel 7 is 50%% too bright");
    CHECK(r.worst_item == 7, "worst pixel %d", r.worst_item);
    prt_image em;
    CHECK(image_read(pe, &em, &err) == 0 && em.w == W && em.h == H, "error image written at the input size");
    if (em.data) {
        /* Pixel 0 is exact (dark end), pixel 7 at 50% (red side). */
        CHECK(em.data[0] + em.data[1] + em.data[2] < 0.3f && em.data[3 * 7] > em.data[3 * 7 + 2] + 0.3f,
              "false colours: exact dark, 50%% red");
        image_free(&em);
    }
    float c[6 * 4 * 3] = { 0 };
    CHECK(write_img(pc, 6, 4, c) == 0, "wrote small EXR");
    CHECK(cmp_files(pa, pc, NULL, &r, &err) == -1 && strstr(err.msg, "size mismatch") && strstr(err.msg, "8x4") &&
          strstr(err.msg, "6x4"), "size mismatch: %s", err.msg);
    CHECK(cmp_files(pa, pcsv, NULL, &r, &err) == -1 && strstr(err.msg, "image"), "mixed kinds: %s", err.msg);
    char missing[600];
    snprintf(missing, sizeof missing, "%s/none.exr", dir);
    CHECK(cmp_files(missing, pb, NULL, &r, &err) == -1 && strstr(err.msg, "none.exr"), "missing image: %s", err.msg);
    CHECK(cmp_files(pa, pc, NULL, &r, &err) == -1, "second call fails the same");
}

/* The command line: output line format and exit codes. */
static void cli(void) {
    const char *dir = check_tmpdir();
    char cmd[2048], out[4096];
    snprintf(cmd, sizeof cmd, "%s compare %s/a.exr %s/b.exr", check_prt_bin(), dir, dir);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0 && strstr(out, "rel_rmse=") && strstr(out, "max_rel_err=0.5"), "prt compare prints the metrics (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s compare %s/a.exr", check_prt_bin(), dir);
    CHECK(check_run(cmd, out, sizeof out) == 2 && strstr(out, "prt compare:"), "one file is a usage error: %s", out);
    snprintf(cmd, sizeof cmd, "%s compare %s/a.exr %s/c.exr", check_prt_bin(), dir, dir);
    CHECK(check_run(cmd, out, sizeof out) == 1 && strstr(out, "size mismatch"), "size mismatch exits 1: %s", out);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(arrays);
    CHECK_CASE(colormap);
    CHECK_CASE(csv);
    CHECK_CASE(images);
    CHECK_CASE(cli);
    return check_summary();
}
