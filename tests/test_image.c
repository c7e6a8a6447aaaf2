/* test_image.c - image.h: EXR exact and HDR round trips, PNG 8-bit sRGB round trip,
 * exposure and tone maps, grey replication, non-finite handling, and errors
 * (missing file, not an image, directory, empty file, unwritable path) that
 * must come back as -1 with one line naming the file and leave no temporary. */
#include "harness.h"
#include "image.h"
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static float srgb_enc(float v) {
    if (v <= 0) return 0;
    if (v >= 1) return 1;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1 / 2.4f) - 0.055f;
}
static float srgb_dec(float v) { return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f); }

/* Deterministic pseudo-random floats in [0,1). */
static float rnd(unsigned *s) {
    *s = *s * 1664525u + 1013904223u;
    return (float)(*s >> 8) / 16777216.f;
}

static int count_tmp_files(const char *dir) {
    DIR *d = opendir(dir);
    int n = 0;
    if (!d) return -1;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strstr(e->d_name, ".tmp.")) n++;
    closedir(d);
    return n;
}

/* err holds one line that mentions name. */
static void check_err(const prt_error *err, const char *name) {
    CHECK(strstr(err->msg, name) != NULL, "message '%s' should name '%s'", err->msg, name);
    CHECK(strchr(err->msg, '\n') == NULL, "message '%s' should be one line", err->msg);
}

static void exr_roundtrip(void) {
    const char *dir = check_tmpdir();
    prt_image im, back;
    prt_error err;
    char path[512];
    CHECK(image_alloc(&im, 13, 7, 3, &err) == 0);
    unsigned s = 1;
    for (int i = 0; i < 13 * 7 * 3; i++) im.data[i] = (rnd(&s) - 0.1f) * 100.f;
    im.data[0] = 34000.5f;
    im.data[4] = 1e-7f;
    im.data[5] = 1e30f;
    snprintf(path, sizeof path, "%s/a.exr", dir);
    CHECK(image_write(path, &im, NULL, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    CHECK(back.w == 13 && back.h == 7 && back.c == 3);
    int same = 1;
    for (int i = 0; i < 13 * 7 * 3 && back.data; i++) same &= back.data[i] == im.data[i];
    CHECK(same, "EXR float round trip must be exact");
    image_free(&back);

    /* Half EXR: within half precision (rel 2^-11), big values clamp to 65504 instead of Inf. */
    snprintf(path, sizeof path, "%s/h.exr", dir);
    image_desc d = { .half = true };
    CHECK(image_write(path, &im, &d, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    double maxrel = 0;
    for (int i = 0; i < 13 * 7 * 3 && back.data; i++) {
        if (i == 4 || i == 5) continue;
        double r = fabs(back.data[i] - im.data[i]) / fmax(fabs(im.data[i]), 1e-3);
        if (r > maxrel) maxrel = r;
    }
    CHECK_LE(maxrel, 1.0 / 2048 + 1e-6, "half EXR relative error");
    /* exact: 65504 is a half, and the clamp a constant */
    CHECK_NEAR(back.data ? back.data[5] : -1, 65504.0, 0.0, "1e30 clamps to the half maximum");
    image_free(&back);

    /* Non-finite pixels are written as 0; RGBA input writes RGB, reads 3 channels. */
    prt_image a4;
    CHECK(image_alloc(&a4, 3, 2, 4, &err) == 0);
    for (int i = 0; i < 24; i++) a4.data[i] = (float)i;
    a4.data[0] = NAN;
    a4.data[1] = INFINITY;
    a4.data[2] = -INFINITY;
    snprintf(path, sizeof path, "%s/nf.exr", dir);
    CHECK(image_write(path, &a4, NULL, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    CHECK(back.c == 3 && back.w == 3 && back.h == 2);
    if (back.data) {
        CHECK(back.data[0] == 0 && back.data[1] == 0 && back.data[2] == 0, "non-finite written as 0");
        int ok = 1;
        for (int p = 1; p < 6; p++)
            for (int ch = 0; ch < 3; ch++) ok &= back.data[3 * p + ch] == (float)(4 * p + ch);
        CHECK(ok, "RGBA -> RGB keeps colour channels");
    }
    image_free(&back);
    image_free(&a4);

    /* Radiance HDR: RGBE keeps 8 mantissa bits of the largest channel of each pixel. */
    snprintf(path, sizeof path, "%s/a.hdr", dir);
    for (int i = 0; i < 13 * 7 * 3; i++) im.data[i] = fabsf(im.data[i]) > 1e6f ? 1e6f : fabsf(im.data[i]);
    CHECK(image_write(path, &im, NULL, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    double worst = back.w == 13 && back.h == 7 ? 0 : 1;
    for (int p = 0; p < 13 * 7 && back.data; p++) {
        float m = fmaxf(im.data[3 * p], fmaxf(im.data[3 * p + 1], im.data[3 * p + 2]));
        for (int ch = 0; ch < 3; ch++) worst = fmax(worst, fabs(back.data[3 * p + ch] - im.data[3 * p + ch]) / m);
    }
    /* RGBE: each channel keeps 8 bits in the exponent e of the pixel's largest m (2^(e-1) <= m <
     * 2^e), so it is off by less than one unit 2^e / 256 <= m / 128: the format's bound, derived */
    CHECK_LE(worst, 1.0 / 128, "HDR round trip within RGBE precision (rows top to bottom)");
    image_free(&back);
    image_free(&im);
}

static void png(void) {
    const char *dir = check_tmpdir();
    prt_image im, back;
    prt_error err;
    char path[512];
    int w = 64, h = 9;
    CHECK(image_alloc(&im, w, h, 3, &err) == 0);
    unsigned s = 7;
    for (int i = 0; i < w * h * 3; i++) im.data[i] = rnd(&s);
    im.data[0] = 0;
    im.data[1] = 1;
    im.data[2] = 5;   /* clamps to 1 */
    snprintf(path, sizeof path, "%s/a.png", dir);
    CHECK(image_write(path, &im, NULL, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    CHECK(back.w == w && back.h == h && back.c == 3);
    double maxd = 0;
    for (int i = 0; i < w * h * 3 && back.data; i++) {
        double dd = fabs(srgb_enc(back.data[i]) - srgb_enc(im.data[i]));
        if (dd > maxd) maxd = dd;
    }
    /* Here and below: half a code (0.5 / 255) plus 1e-5 for the float rounding of the two sRGB
     * encoders, this one and the writer's (powf <= 1 ulp in any libm: ~1e-7): derived, not measured */
    CHECK_LE(maxd, 0.5 / 255 + 1e-5, "PNG: sRGB codes within half a step");
    /* exact: codes 255 and 0 decode to 1 and 0 */
    CHECK_NEAR(back.data ? back.data[2] : -1, 1.0, 0, "over-range clamps to 1");
    CHECK_NEAR(back.data ? back.data[0] : -1, 0.0, 0);
    image_free(&back);

    /* Exposure +1 and the tone maps on a known value. */
    prt_image one;
    CHECK(image_alloc(&one, 1, 1, 3, &err) == 0);
    one.data[0] = 0.25f; one.data[1] = 1.f; one.data[2] = 1000.f;
    image_desc d = { .exposure = 1 };
    CHECK(image_write(path, &one, &d, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    if (back.data) {
        CHECK_NEAR(srgb_enc(back.data[0]), srgb_enc(0.5f), 0.5 / 255 + 1e-5, "exposure doubles");
        CHECK_NEAR(back.data[1], 1.0, 1e-6, "2 clamps to 1");
    }
    image_free(&back);
    d = (image_desc){ .tonemap = 1 };
    CHECK(image_write(path, &one, &d, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    if (back.data) {
        CHECK_NEAR(srgb_enc(back.data[0]), srgb_enc(0.2f), 0.5 / 255 + 1e-5, "Reinhard 0.25 -> 0.2");
        CHECK_NEAR(srgb_enc(back.data[1]), srgb_enc(0.5f), 0.5 / 255 + 1e-5, "Reinhard 1 -> 0.5");
        CHECK_NEAR(srgb_enc(back.data[2]), srgb_enc(1000.f / 1001.f), 0.5 / 255 + 1e-5);
    }
    image_free(&back);
    d = (image_desc){ .tonemap = 2 };
    CHECK(image_write(path, &one, &d, &err) == 0, "%s", err.msg);
    CHECK(image_read(path, &back, &err) == 0, "%s", err.msg);
    if (back.data) {
        float x = 1.f, aces = (x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f);
        CHECK_NEAR(srgb_enc(back.data[1]), srgb_enc(aces), 0.5 / 255 + 1e-5, "ACES fit at 1");
        CHECK_NEAR(back.data[2], 1.0, 1e-6, "ACES saturates");
    }
    image_free(&back);
    image_free(&one);
    image_free(&im);
    CHECK(count_tmp_files(dir) == 0, "no temporaries left after successful writes");
}

/* A hand-written binary PGM: grey is replicated to RGB and decoded from sRGB. */
static void grey(void) {
    const char *dir = check_tmpdir();
    char path[512];
    snprintf(path, sizeof path, "%s/g.pgm", dir);
    FILE *f = fopen(path, "wb");
    fprintf(f, "P5\n4 2\n255\n");
    unsigned char px[8] = { 0, 10, 50, 100, 128, 200, 254, 255 };
    fwrite(px, 1, 8, f);
    fclose(f);
    prt_image im;
    prt_error err;
    CHECK(image_read(path, &im, &err) == 0, "%s", err.msg);
    CHECK(im.w == 4 && im.h == 2 && im.c == 3);
    int ok = 1;
    for (int i = 0; i < 8 && im.data; i++)
        for (int ch = 0; ch < 3; ch++) ok &= fabsf(im.data[3 * i + ch] - srgb_dec(px[i] / 255.f)) < 1e-5f;
    CHECK(ok, "grey replicated and sRGB-decoded");
    image_free(&im);
}

/* A hand-written PFM (little-endian floats, rows stored bottom to top): read as
 * linear floats, exactly, with row 0 at the top. */
static void pfm(void) {
    const char *dir = check_tmpdir();
    char path[512];
    snprintf(path, sizeof path, "%s/a.pfm", dir);
    FILE *f = fopen(path, "wb");
    fprintf(f, "PF\n3 2\n-1.0\n");
    for (int y = 0; y < 2; y++)   /* stored row y is image row 1 - y */
        for (int x = 0; x < 3; x++) {
            float px[3] = { 1.5f * x, 100.f * (1 - y), -0.25f };
            fwrite(px, sizeof px, 1, f);
        }
    fclose(f);
    prt_image im;
    prt_error err;
    CHECK(image_read(path, &im, &err) == 0, "%s", err.msg);
    int ok = im.w == 3 && im.h == 2 && im.c == 3;
    for (int y = 0; y < 2 && ok; y++)
        for (int x = 0; x < 3; x++) {
            const float *p = im.data + 3 * (y * 3 + x);
            ok &= p[0] == 1.5f * x && p[1] == 100.f * y && p[2] == -0.25f;
        }
    CHECK(ok, "PFM read exactly, top row first, negatives kept");
    image_free(&im);
}

static void errors(void) {
    const char *dir = check_tmpdir();
    prt_image im;
    prt_error err;
    char path[512];
    snprintf(path, sizeof path, "%s/missing.exr", dir);
    CHECK(image_read(path, &im, &err) == -1);
    check_err(&err, "missing.exr");
    CHECK(im.data == NULL);

    snprintf(path, sizeof path, "%s/text.exr", dir);
    FILE *f = fopen(path, "w");
    fprintf(f, "this is not an image\nat all\n");
    fclose(f);
    CHECK(image_read(path, &im, &err) == -1);
    check_err(&err, "text.exr");
    snprintf(path, sizeof path, "%s/text.png", dir);
    f = fopen(path, "w");
    fprintf(f, "\x89PNG but broken");
    fclose(f);
    CHECK(image_read(path, &im, &err) == -1);
    check_err(&err, "text.png");

    snprintf(path, sizeof path, "%s/empty.hdr", dir);
    f = fopen(path, "w");
    fclose(f);
    CHECK(image_read(path, &im, &err) == -1);
    check_err(&err, "empty.hdr");

    snprintf(path, sizeof path, "%s/adir.exr", dir);
    mkdir(path, 0755);
    CHECK(image_read(path, &im, &err) == -1);
    check_err(&err, "adir.exr");

    /* Write failures: missing directory, unknown extension, empty image; nothing left behind. */
    prt_image one;
    CHECK(image_alloc(&one, 2, 2, 3, &err) == 0);
    snprintf(path, sizeof path, "%s/nodir/x.exr", dir);
    CHECK(image_write(path, &one, NULL, &err) == -1);
    check_err(&err, "nodir/x.exr");
    snprintf(path, sizeof path, "%s/x.xyz", dir);
    CHECK(image_write(path, &one, NULL, &err) == -1);
    check_err(&err, "x.xyz");
    snprintf(path, sizeof path, "%s/adir.exr", dir);   /* the target is a directory: rename fails */
    CHECK(image_write(path, &one, NULL, &err) == -1);
    check_err(&err, "adir.exr");
    prt_image none = { 0 };
    snprintf(path, sizeof path, "%s/none.png", dir);
    CHECK(image_write(path, &none, NULL, &err) == -1);
    check_err(&err, "none.png");
    CHECK(count_tmp_files(dir) == 0, "no temporaries left after failed writes");
    CHECK(image_alloc(&im, 0, 5, 3, &err) == -1 && im.data == NULL);
    CHECK(image_alloc(&im, 5, 5, 2, &err) == -1);
    image_free(&one);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(exr_roundtrip);
    CHECK_CASE(png);
    CHECK_CASE(grey);
    CHECK_CASE(pfm);
    CHECK_CASE(errors);
    return check_summary();
}
