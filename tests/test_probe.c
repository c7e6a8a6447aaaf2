/* test_probe.c - probe.h: layout parsing and detection, clamping, lookups in
 * every layout against an analytic environment (the images are built here
 * from the documented pixel -> direction maps, written as EXR and loaded
 * back), pixel directions and solid angles, resampling to the cube (constant
 * stays constant, power is preserved, the sun survives and rotates), the sky's
 * sun power at any disc size, rotation parsing, and the rotated cube resampled from the probe's
 * fine cube (probecube.h) against the function, the sun's power and probe_to_cube's light vector. */
#include "harness.h"
#include "cubemap.h"
#include "haar.h"
#include "light.h"
#include "probe.h"
#include "probecube.h"
#include "transfer.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static float rnd(unsigned *s) {
    *s = *s * 1664525u + 1013904223u;
    return (float)(*s >> 8) / 16777216.f;
}

/* Uniform random unit vector. */
static void rnd_dir(unsigned *s, float d[3]) {
    float z = 2 * rnd(s) - 1, ph = 2 * (float)PI * rnd(s), r = sqrtf(fmaxf(0, 1 - z * z));
    d[0] = r * cosf(ph); d[1] = r * sinf(ph); d[2] = z;
}

/* The analytic environment every layout encodes: smooth, different per channel. */
static void env_fn(const double d[3], float rgb[3]) {
    rgb[0] = (float)(1.0 + 0.5 * d[0] + 0.3 * d[1] * d[1]);
    rgb[1] = (float)(1.0 - 0.4 * d[2] + 0.2 * d[0] * d[1]);
    rgb[2] = (float)(0.8 + 0.5 * d[1] + 0.1 * d[2] * d[2]);
}

static void normalize_d(double d[3]) {
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    d[0] /= l; d[1] /= l; d[2] /= l;
}

/* The documented maps from image position to direction (probe.h / probe.c), written
 * independently of probe.c. Return false outside the valid area. u, v in [0,1] of the image. */
static bool latlong_dir(double u, double v, double d[3]) {
    double th = v * PI, ph = (u - 0.5) * 2 * PI;
    d[0] = sin(th) * sin(ph); d[1] = cos(th); d[2] = -sin(th) * cos(ph);
    return true;
}
static bool angular_dir(double u, double v, double d[3]) {
    double a = 2 * u - 1, b = 1 - 2 * v, r = sqrt(a * a + b * b);
    if (r > 1) return false;
    double th = PI * r;
    d[0] = r > 0 ? sin(th) * a / r : 0; d[1] = r > 0 ? sin(th) * b / r : 0; d[2] = -cos(th);
    return true;
}
/* Cross: cell (col,row) and face coordinates s right, t down in [-1,1]. */
static bool cross_dir(bool vertical, int col, int row, double s, double t, double d[3]) {
    double x, y, z;
    if (col == 1 && row == 0) { x = s; y = 1; z = -t; }            /* +Y */
    else if (col == 0 && row == 1) { x = -1; y = -t; z = -s; }     /* -X */
    else if (col == 1 && row == 1) { x = s; y = -t; z = -1; }      /* -Z front */
    else if (col == 2 && row == 1) { x = 1; y = -t; z = s; }       /* +X */
    else if (col == 1 && row == 2) { x = s; y = -1; z = t; }       /* -Y */
    else if (vertical && col == 1 && row == 3) { x = s; y = t; z = 1; }        /* +Z upside down */
    else if (!vertical && col == 3 && row == 1) { x = -s; y = -t; z = 1; }     /* +Z */
    else return false;
    d[0] = x; d[1] = y; d[2] = z;
    normalize_d(d);
    return true;
}

/* Image of the analytic environment in a layout: w x h, each pixel the value at its centre. */
static prt_image make_layout_image(probe_layout l, int w, int h) {
    prt_image im;
    prt_error err;
    image_alloc(&im, w, h, 3, &err);
    int F = l == PROBE_VCROSS ? w / 3 : w / 4;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double d[3];
            bool ok;
            if (l == PROBE_LATLONG) ok = latlong_dir((x + 0.5) / w, (y + 0.5) / h, d);
            else if (l == PROBE_ANGULAR) ok = angular_dir((x + 0.5) / w, (y + 0.5) / h, d);
            else ok = cross_dir(l == PROBE_VCROSS, x / F, y / F, 2.0 * (x % F + 0.5) / F - 1, 2.0 * (y % F + 0.5) / F - 1, d);
            float *p = im.data + 3 * (y * w + x);
            if (ok) env_fn(d, p);
            else p[0] = p[1] = p[2] = 0;   /* black outside the circle / cross, as in real probes */
        }
    return im;
}

static void parse(void) {
    probe_layout l;
    CHECK(probe_parse_layout("latlong", &l) == 0 && l == PROBE_LATLONG);
    CHECK(probe_parse_layout("angular", &l) == 0 && l == PROBE_ANGULAR);
    CHECK(probe_parse_layout("VCross", &l) == 0 && l == PROBE_VCROSS);
    CHECK(probe_parse_layout("hcross", &l) == 0 && l == PROBE_HCROSS);
    CHECK(probe_parse_layout("cross", &l) == 0 && l == PROBE_CROSS);
    CHECK(probe_parse_layout("auto", &l) == 0 && l == PROBE_AUTO);
    CHECK(probe_parse_layout("sphere", &l) == -1);
    CHECK(probe_parse_layout("", &l) == -1);

    /* Rotation: "Y,P" is pitch(P about x) after yaw(Y about y); compare with matrices built here. */
    float R[9];
    CHECK(probe_parse_rotation("90", R) == 0);
    float ex[9] = { 0, 0, 1, 0, 1, 0, -1, 0, 0 };   /* yaw 90: x -> -z, z -> x */
    double e = 0;
    for (int i = 0; i < 9; i++) e = fmax(e, fabs(R[i] - ex[i]));
    CHECK_LE(e, 1e-6, "yaw 90");
    CHECK(probe_parse_rotation(" 30 , -20 ", R) == 0);
    double y = 30 * PI / 180, p = -20 * PI / 180;
    double Ry[9] = { cos(y), 0, sin(y), 0, 1, 0, -sin(y), 0, cos(y) };
    double Rx[9] = { 1, 0, 0, 0, cos(p), -sin(p), 0, sin(p), cos(p) };
    e = 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            double m = 0;
            for (int k = 0; k < 3; k++) m += Rx[3 * r + k] * Ry[3 * k + c];
            e = fmax(e, fabs(m - R[3 * r + c]));
        }
    CHECK_LE(e, 1e-6, "Rx(P) Ry(Y)");
    CHECK(probe_parse_rotation("abc", R) == -1);
    CHECK(probe_parse_rotation("10,", R) == -1);
    CHECK(probe_parse_rotation("10,x", R) == -1);
    CHECK(probe_parse_rotation("1,2,3", R) == -1);
    CHECK(probe_parse_rotation("", R) == -1);
    CHECK(probe_parse_rotation("nan", R) == -1);
}

static void detect_and_clamp(void) {
    struct { int w, h; probe_layout want, got; int ok; } cases[] = {
        { 64, 32, PROBE_AUTO, PROBE_LATLONG, 1 },  { 32, 32, PROBE_AUTO, PROBE_ANGULAR, 1 },
        { 48, 64, PROBE_AUTO, PROBE_VCROSS, 1 },   { 64, 48, PROBE_AUTO, PROBE_HCROSS, 1 },
        { 48, 64, PROBE_CROSS, PROBE_VCROSS, 1 },  { 64, 48, PROBE_CROSS, PROBE_HCROSS, 1 },
        { 50, 30, PROBE_AUTO, PROBE_AUTO, 0 },     { 64, 32, PROBE_VCROSS, PROBE_AUTO, 0 },
        { 64, 32, PROBE_ANGULAR, PROBE_ANGULAR, 1 }, /* an explicit layout overrides detection */
        { 1025, 512, PROBE_AUTO, PROBE_LATLONG, 1 },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        prt_image im;
        prt_error err;
        prt_probe p;
        image_alloc(&im, cases[i].w, cases[i].h, 3, &err);
        int rc = probe_from_image(&im, cases[i].want, "sz.exr", &p, &err);
        CHECK(im.data == NULL, "image taken over");
        if (cases[i].ok) CHECK(rc == 0 && p.layout == cases[i].got, "%dx%d case %zu", cases[i].w, cases[i].h, i);
        else CHECK(rc == -1 && strstr(err.msg, "sz.exr"), "%dx%d must fail naming the file: %s", cases[i].w, cases[i].h, err.msg);
        probe_free(&p);
    }

    prt_image im;
    prt_error err;
    prt_probe p;
    image_alloc(&im, 8, 4, 4, &err);   /* RGBA: alpha dropped */
    for (int i = 0; i < 32 * 4; i++) im.data[i] = 1.f + (float)(i % 4);
    im.data[0] = -1;                                 /* texel 0: negative */
    im.data[4 * 1 + 1] = -2; im.data[4 * 1 + 2] = -3; /* texel 1: two negatives, counted once */
    im.data[4 * 2] = NAN;                            /* texel 2: NaN */
    im.data[4 * 3 + 2] = INFINITY;                   /* texel 3: Inf */
    im.data[4 * 4 + 1] = -INFINITY;                  /* texel 4: -Inf counts as non-finite */
    im.data[4 * 5 + 0] = 7.5f;                       /* the maximum */
    CHECK(probe_from_image(&im, PROBE_AUTO, "c.exr", &p, &err) == 0, "%s", err.msg);
    CHECK(p.img.c == 3 && p.layout == PROBE_LATLONG);
    CHECK(p.clamped_negative == 2, "negatives %ld", p.clamped_negative);
    CHECK(p.clamped_nonfinite == 3, "non-finite %ld", p.clamped_nonfinite);
    CHECK_NEAR(p.max_value, 7.5, 0);   /* exact: the largest input texel, copied */
    int ok = 1;
    for (int i = 0; i < 32 * 3; i++) ok &= isfinite(p.img.data[i]) && p.img.data[i] >= 0;
    CHECK(ok, "all texels finite and >= 0");
    CHECK(p.img.data[0] == 0 && p.img.data[1] == 2 && p.img.data[2] == 3, "texel 0 = (0,2,3)");
    CHECK(p.img.data[6] == 0 && p.img.data[7] == 2 && p.img.data[8] == 3, "texel 2 = (0,2,3)");
    CHECK(p.img.data[15] == 7.5f && p.img.data[16] == 2, "alpha dropped, channels kept");
    probe_free(&p);
    CHECK(probe_load("build/no/such/probe.exr", PROBE_AUTO, &p, &err) == -1 && strstr(err.msg, "probe.exr"));
}

/* Each layout, from the same analytic function: load the EXR, probe_eval at random
 * directions against the function, pixel directions against the documented maps,
 * solid angles summing to 4 pi, and probe_to_cube against the function. */
static void layouts(void) {
    const char *dir = check_tmpdir();
    struct { probe_layout l; int w, h; const char *name; double tol_max, tol_rms; } L[] = {
        /* Bilinear error of this smooth function at these sizes (measured: latlong 1.2e-4 max,
         * angular 7e-5, crosses 5e-3 max from clamping the taps at face edges). */
        { PROBE_LATLONG, 256, 128, "latlong", 5e-4, 1e-4 },
        { PROBE_ANGULAR, 256, 256, "angular", 5e-4, 1e-4 },
        { PROBE_VCROSS, 192, 256, "vcross", 1e-2, 5e-4 },
        { PROBE_HCROSS, 256, 192, "hcross", 1e-2, 5e-4 },
    };
    for (int k = 0; k < 4; k++) {
        char path[512];
        prt_error err;
        prt_probe p;
        snprintf(path, sizeof path, "%s/%s.exr", dir, L[k].name);
        prt_image im = make_layout_image(L[k].l, L[k].w, L[k].h);
        CHECK(image_write(path, &im, NULL, &err) == 0, "%s", err.msg);
        image_free(&im);
        CHECK(probe_load(path, PROBE_AUTO, &p, &err) == 0, "%s", err.msg);
        CHECK(p.layout == L[k].l, "%s detected", L[k].name);
        if (p.layout != L[k].l) { probe_free(&p); continue; }

        /* probe_eval vs the function. */
        unsigned s = 99 + k;
        double maxe = 0, sse = 0;
        int n = 4000;
        for (int i = 0; i < n; i++) {
            float d[3], got[3], want[3];
            rnd_dir(&s, d);
            double dd[3] = { d[0], d[1], d[2] };
            env_fn(dd, want);
            probe_eval(&p, d, got);
            for (int ch = 0; ch < 3; ch++) {
                double e = fabs(got[ch] - want[ch]);
                maxe = fmax(maxe, e);
                sse += e * e;
            }
        }
        double rms = sqrt(sse / (3 * n));
        CHECK_LE(maxe, L[k].tol_max, "%s probe_eval max error", L[k].name);
        CHECK_LE(rms, L[k].tol_rms, "%s probe_eval RMS error", L[k].name);
        /* The exact centres of the directions straight ahead and overhead. */
        float fwd[3] = { 0, 0, -1 }, got[3], want[3];
        double dfw[3] = { 0, 0, -1 };
        env_fn(dfw, want);
        probe_eval(&p, fwd, got);
        CHECK_NEAR(got[1], want[1], L[k].tol_max, "%s front", L[k].name);

        /* Pixel directions and solid angles. */
        double omega = 0, dir_err = 0;
        int valid = 0, F = L[k].l == PROBE_VCROSS ? L[k].w / 3 : L[k].w / 4;
        for (int y = 0; y < p.img.h; y++)
            for (int x = 0; x < p.img.w; x++) {
                float d[3], sa;
                double ref[3];
                bool want_ok;
                if (L[k].l == PROBE_LATLONG) want_ok = latlong_dir((x + 0.5) / p.img.w, (y + 0.5) / p.img.h, ref);
                else if (L[k].l == PROBE_ANGULAR) want_ok = angular_dir((x + 0.5) / p.img.w, (y + 0.5) / p.img.h, ref);
                else want_ok = cross_dir(L[k].l == PROBE_VCROSS, x / F, y / F, 2.0 * (x % F + 0.5) / F - 1,
                                         2.0 * (y % F + 0.5) / F - 1, ref);
                bool got_ok = probe_pixel_dir(&p, x, y, d, &sa);
                if (got_ok != want_ok) { dir_err = 1; continue; }
                if (!got_ok) continue;
                valid++;
                omega += sa;
                for (int c = 0; c < 3; c++) dir_err = fmax(dir_err, fabs(d[c] - ref[c]));
            }
        CHECK_LE(dir_err, 1e-5, "%s pixel directions", L[k].name);
        CHECK_NEAR(omega, 4 * PI, L[k].l == PROBE_ANGULAR ? 4 * PI * 1e-4 : 4 * PI * 1e-5, "%s solid angles", L[k].name);
        if (L[k].l == PROBE_VCROSS || L[k].l == PROBE_HCROSS) CHECK(valid == 6 * F * F, "%s: 6 faces valid", L[k].name);
        if (L[k].l == PROBE_ANGULAR) CHECK(valid < L[k].w * L[k].h && valid > 0.78 * L[k].w * L[k].h, "angular: the disc only");

        /* Neighbouring pixels in the image that lie on different faces must be
         * neighbours on the sphere too (the cross unfolds the cube continuously). */
        if (L[k].l == PROBE_VCROSS || L[k].l == PROBE_HCROSS) {
            double worst = 0;
            int pairs = 0;
            for (int y = 0; y < p.img.h; y++)
                for (int x = 0; x < p.img.w; x++)
                    for (int dir2 = 0; dir2 < 2; dir2++) {
                        int x2 = x + (dir2 == 0), y2 = y + (dir2 == 1);
                        if (x2 >= p.img.w || y2 >= p.img.h) continue;
                        if (x / F == x2 / F && y / F == y2 / F) continue;
                        float a[3], b[3];
                        if (!probe_pixel_dir(&p, x, y, a, NULL) || !probe_pixel_dir(&p, x2, y2, b, NULL)) continue;
                        double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
                        worst = fmax(worst, acos(fmin(1.0, c)));
                        pairs++;
                    }
            CHECK(pairs == 5 * F, "%s: 5 seams inside the cross (%d pairs)", L[k].name, pairs);
            CHECK_LE(worst, 2.0 / F, "%s: seams are continuous (angle in radians)", L[k].name);
        }

        /* Resampling: a smooth function's texel average is within a little of its centre
         * value (measured 1.2e-3 at res 16 for every layout). */
        int res = 16;
        float *cube = malloc(sizeof(float) * 6 * res * res * 3);
        probe_to_cube(&p, res, NULL, 4, cube);
        double ce = 0;
        for (int t = 0; t < 6 * res * res; t++) {
            float d[3], want3[3];
            cube_texel_dir(res, t, d);
            double dd[3] = { d[0], d[1], d[2] };
            env_fn(dd, want3);
            for (int ch = 0; ch < 3; ch++) ce = fmax(ce, fabs(cube[3 * t + ch] - want3[ch]));
        }
        CHECK_LE(ce, 3e-3, "%s probe_to_cube vs function", L[k].name);
        free(cube);
        probe_free(&p);
    }
}

static void constant(void) {
    float rgb[3] = { 0.7f, 1.3f, 2.5f };
    prt_probe p;
    prt_error err;
    CHECK(probe_make_constant(rgb, &p, &err) == 0, "%s", err.msg);
    float nan_d[3] = { NAN, 0, 1 }, got[3] = { 1, 1, 1 };
    probe_eval(&p, nan_d, got);
    CHECK(got[0] == 0 && got[1] == 0 && got[2] == 0, "a non-finite direction gives 0, not a wild read");
    int res = 32;
    float *cube = malloc(sizeof(float) * 6 * res * res * 3);
    float R[9];
    probe_parse_rotation("37,-12", R);
    for (int pass = 0; pass < 2; pass++) {
        probe_to_cube(&p, res, pass ? R : NULL, 0, cube);
        double e = 0;
        for (int t = 0; t < 6 * res * res; t++)
            for (int ch = 0; ch < 3; ch++) e = fmax(e, fabs(cube[3 * t + ch] - rgb[ch]));
        CHECK_LE(e, 1e-4, "constant probe gives a constant cube (rotated: %d)", pass);
    }
    free(cube);
    probe_free(&p);
}

/* Sum of pixel * pixel solid angle over a latlong, with the solid angles computed here. */
static void latlong_power(const prt_probe *p, double out[3]) {
    int w = p->img.w, h = p->img.h;
    out[0] = out[1] = out[2] = 0;
    for (int y = 0; y < h; y++) {
        double om = 2 * PI / w * (cos(y * PI / h) - cos((y + 1) * PI / h));
        for (int x = 0; x < w; x++)
            for (int ch = 0; ch < 3; ch++) out[ch] += om * p->img.data[3 * (y * w + x) + ch];
    }
}

static void cube_power(const float *cube, int res, double out[3]) {
    out[0] = out[1] = out[2] = 0;
    for (int t = 0; t < 6 * res * res; t++) {
        int r = t % (res * res);
        double om = cube_texel_solid_angle(res, r % res, r / res);
        for (int ch = 0; ch < 3; ch++) out[ch] += om * cube[3 * t + ch];
    }
}

static int brightest(const float *cube, int n) {
    int best = 0;
    for (int t = 1; t < n; t++)
        if (cube[3 * t] + cube[3 * t + 1] + cube[3 * t + 2] > cube[3 * best] + cube[3 * best + 1] + cube[3 * best + 2]) best = t;
    return best;
}

static void sky(void) {
    prt_probe p;
    prt_error err;
    sky_desc d = { 0 };
    CHECK(probe_make_sky(&d, &p, &err) == 0, "%s", err.msg);
    CHECK(p.img.w == 512 && p.img.h == 256 && p.layout == PROBE_LATLONG);
    CHECK(p.clamped_negative == 0 && p.clamped_nonfinite == 0);
    /* Default sun: elevation 45 deg. */
    float sun[3] = { 0.5f, sqrtf(0.5f), -0.5f };
    int res = CUBE_RES, n = 6 * res * res;
    float *cube = malloc(sizeof(float) * n * 3);
    probe_to_cube(&p, res, NULL, 0, cube);
    double pl[3], pc[3];
    latlong_power(&p, pl);
    cube_power(cube, res, pc);
    for (int ch = 0; ch < 3; ch++) CHECK_NEAR(pc[ch] / pl[ch], 1.0, 0.01, "cube power vs latlong power, channel %d", ch);
    int b = brightest(cube, n), want = cube_texel_index(res, sun);
    CHECK(b == want, "brightest texel %d is the sun's %d", b, want);
    /* The sun is most of the power: it did not get lost in resampling. */
    double sun_power = 2000 * 2 * PI * (1 - cos(1.5 * PI / 180));
    CHECK(pc[0] > sun_power, "power %g includes the sun's %g", pc[0], sun_power);

    /* Rotation by 90 deg about y: the light at d moves to R d. */
    float R[9];
    probe_parse_rotation("90", R);
    probe_to_cube(&p, res, R, 0, cube);
    float rs[3] = { R[0] * sun[0] + R[1] * sun[1] + R[2] * sun[2], R[3] * sun[0] + R[4] * sun[1] + R[5] * sun[2],
                    R[6] * sun[0] + R[7] * sun[1] + R[8] * sun[2] };
    CHECK_NEAR(rs[0], -0.5, 1e-6, "yaw 90 takes (0.5, y, -0.5) to (-0.5, y, -0.5)");
    CHECK_NEAR(rs[2], -0.5, 1e-6);
    b = brightest(cube, n);
    want = cube_texel_index(res, rs);
    CHECK(b == want, "rotated: brightest texel %d is the rotated sun's %d", b, want);
    double pr[3];
    cube_power(cube, res, pr);
    CHECK_NEAR(pr[0] / pc[0], 1.0, 0.01, "rotation keeps the power");
    free(cube);
    probe_free(&p);

    /* The sun's power L * 2 pi (1 - cos r) at any disc size in pixels, over a near-black sky. */
    int widths[3] = { 64, 512, 2048 };
    float radii[3] = { 0.02f, 1.5f, 10.f };
    for (int wi = 0; wi < 3; wi++)
        for (int ri = 0; ri < 3; ri++) {
            sky_desc sd = { .width = widths[wi], .sun_dir = { 0.3f, 0.8f, 0.52f }, .sun_radius_deg = radii[ri],
                            .sun_radiance = 5000, .sky_zenith = { 1e-9f, 1e-9f, 1e-9f },
                            .sky_horizon = { 1e-9f, 1e-9f, 1e-9f }, .ground = { 1e-9f, 1e-9f, 1e-9f } };
            CHECK(probe_make_sky(&sd, &p, &err) == 0, "%s", err.msg);
            double pw[3];
            latlong_power(&p, pw);
            double want_p = 5000 * 2 * PI * (1 - cos(radii[ri] * PI / 180));
            CHECK_NEAR(pw[1] / want_p, 1.0, 0.01, "sun power, width %d radius %g deg", widths[wi], radii[ri]);
            CHECK(p.max_value > 0 && isfinite(p.max_value));
            probe_free(&p);
        }
    /* A sun narrower than a pixel of a 2048-wide probe, near the zenith where latlong pixels are
     * narrowest, and one at the horizon: resampled at the default ss its power must survive
     * (plain 4 x 4 bilinear sub-samples stepped over it and lost all of it). */
    float suns[2][3] = { { 0.05f, 0.99f, 0.1f }, { 0.7f, 0.05f, 0.2f } };
    cube = malloc(sizeof(float) * n * 3);
    for (int k = 0; k < 2; k++) {
        sky_desc sd = { .width = 2048, .sun_dir = { suns[k][0], suns[k][1], suns[k][2] }, .sun_radius_deg = 0.02f,
                        .sun_radiance = 5e5f, .sky_zenith = { 0.5f, 0.5f, 0.5f }, .sky_horizon = { 0.5f, 0.5f, 0.5f },
                        .ground = { 0.5f, 0.5f, 0.5f } };
        CHECK(probe_make_sky(&sd, &p, &err) == 0, "%s", err.msg);
        double sunp = 5e5 * 2 * PI * (1 - cos(0.02 * PI / 180)), bg = 0.5 * 4 * PI;
        latlong_power(&p, pl);
        CHECK_NEAR(pl[0] / (sunp + bg), 1.0, 1e-3, "latlong power");
        float R0[9];
        probe_parse_rotation(k ? "0" : "15,10", R0);
        probe_to_cube(&p, res, R0, 0, cube);
        cube_power(cube, res, pc);
        CHECK_NEAR((pc[0] - bg) / sunp, 1.0, 0.02, "sub-pixel sun %d keeps its power through resampling", k);
        probe_free(&p);
    }
    free(cube);

    sky_desc bad = { .sun_dir = { NAN, 1, 0 } };
    CHECK(probe_make_sky(&bad, &p, &err) == -1);
}

/* probe_exposure: a constant probe of radiance L gives E_up = pi L, so -log2(L) stops. The cube sums
 * cos over 32^3 texels at their centres (a midpoint rule): its relative error in E_up is below 1e-3
 * at this resolution, 1.5e-3 stops. Turned over, the sky's darker ground is above: more stops. */
static void exposure(void) {
    prt_error err;
    const float Ls[3] = { 1, 4, 0.01f };
    for (int k = 0; k < 3; k++) {
        prt_probe p;
        const float rgb[3] = { Ls[k], Ls[k], Ls[k] };
        CHECK(probe_make_constant(rgb, &p, &err) == 0, "%s", err.msg);
        CHECK_NEAR(probe_exposure(&p, NULL), -log2(Ls[k]), 2e-3, "constant %g", Ls[k]);
        probe_free(&p);
    }
    prt_probe sky;
    sky_desc sd = { .width = 64, .sun_radiance = 1e-6f };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    const float flip[9] = { 1, 0, 0, 0, -1, 0, 0, 0, -1 };   /* the sky turned under the horizon */
    float up = probe_exposure(&sky, NULL), down = probe_exposure(&sky, flip);
    CHECK(isfinite(up) && up != 0, "the sky has light above: %g", up);
    CHECK(down > up, "turned over, the darker ground is above: more exposure, %g against %g stops", down, up);
    probe_free(&sky);
}

/* E[k][c] = sum_j T_j L_j with T_j = max(0, n_k . w_j) Omega_j / pi, the radiance of an unshadowed white
 * Lambert receiver of normal n_k (the 6 axes), from a light vector L (light.h, wavelet order) through the
 * transports' own Haar vectors (orthonormal: the texels' sum, but for L's quantization). sums[0]: the
 * largest sum_j T_j (each unit of change of every texel changes E by at most that); sums[1]: the
 * largest sum_k |T^_k| over the Haar coefficients (a rounding of every coefficient by at most s changes
 * E by at most s times that). */
static void lambert_from_light(const float (*L)[4], double E[6][3], double sums[2]) {
    float *t = malloc(sizeof(float) * CUBE_TEXELS), *w = malloc(sizeof(float) * CUBE_TEXELS);
    float *tmp = malloc(sizeof(float) * CUBE_TEXELS);
    sums[0] = sums[1] = 0;
    for (int k = 0; k < 6; k++) {
        float n[3] = { 0, 0, 0 }, d[3];
        n[k / 2] = k % 2 ? -1.f : 1.f;
        double s = 0, a = 0;
        for (int j = 0; j < CUBE_TEXELS; j++) {
            cube_texel_dir(CUBE_RES, j, d);
            int r = j % (CUBE_RES * CUBE_RES);
            double om = cube_texel_solid_angle(CUBE_RES, r % CUBE_RES, r / CUBE_RES);
            t[j] = (float)(fmax(0, n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) * om / PI);
            s += t[j];
        }
        haar_cube_forward(t, CUBE_RES, w, tmp);
        for (int j = 0; j < CUBE_TEXELS; j++) a += fabs(w[j]);
        sums[0] = fmax(sums[0], s);
        sums[1] = fmax(sums[1], a);
        for (int c = 0; c < 3; c++) {
            E[k][c] = 0;
            for (int j = 0; j < CUBE_TEXELS; j++) E[k][c] += (double)w[j] * L[j][c];
        }
    }
    free(t);
    free(w);
    free(tmp);
}

/* The largest |E_a - E_b| of the Lambert receivers lit by the light vectors of cubes a and b (quantized
 * to 16 bits each), and into *bound what the cubes' largest texel difference dtex and the two
 * quantizations allow: dtex sum_j T_j + (step_a + step_b) / 2 sum_k |T^_k|. */
static double lambert_diff(const float *a, const float *b, double dtex, double *bound) {
    float (*La)[4] = transfer_light_alloc(), (*Lb)[4] = transfer_light_alloc();
    light_stats sa, sb;
    light_from_cube(a, NULL, La, &sa);
    light_from_cube(b, NULL, Lb, &sb);
    double Ea[6][3], Eb[6][3], sums[2], worst = 0, step = 0;
    lambert_from_light((const float (*)[4])La, Ea, sums);
    lambert_from_light((const float (*)[4])Lb, Eb, sums);
    for (int c = 0; c < 3; c++) step = fmax(step, 0.5 * (sa.step[c] + sb.step[c]));
    for (int k = 0; k < 6; k++)
        for (int c = 0; c < 3; c++) worst = fmax(worst, fabs(Ea[k][c] - Eb[k][c]));
    *bound = dtex * sums[0] + step * sums[1];
    free(La);
    free(Lb);
    return worst;
}

/* Mean squared angle (radians^2, both axes) of the filters a resampled texel sees, at the face centre
 * where texels are widest (h = 2 / res radians): the texel's box (h^2 / 6), the probe's bilinear tent
 * (p^2 / 3, p its pixel), and with a fine cube of texels h / 2 the bilinear tent and box of one fine
 * texel more (2 (h/2)^2 (1/6 + 1/12) = h^2 / 8). A smooth f = a + b.d + d^T C d averaged over such a
 * footprint differs from its centre value by at most (|b| / 2 + 2 |C|) times this (the mean of unit
 * vectors shrinks by 1 - sigma^2 / 2; the quadratic adds its curvature). */
static double filter_sigma2(int res, double p, bool fine) {
    double h = 2.0 / res;
    return h * h / 6 + p * p / 3 + (fine ? h * h / 8 : 0);
}

/* probecube.h: a rotation resampled from the probe's fine cube. A constant stays constant (weights
 * normalized); a smooth function's texels are within their filter's bound of the rotated function;
 * a Lambert receiver sees from its light vector what it sees from probe_to_cube's to what those texel
 * bounds and the quantization allow; a sun keeps its power, stays in its texel (or the next), and lights
 * a Lambert receiver as probe_to_cube's does to what the filters' reach allows. */
static void cube_rotate(void) {
    prt_error err;
    float R[9], *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *old = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    probe_parse_rotation("37,-12", R);
    const float rgb[3] = { 0.7f, 1.3f, 2.5f };
    prt_probe p;
    CHECK(probe_make_constant(rgb, &p, &err) == 0, "%s", err.msg);
    probe_cube *pc = probe_cube_create(&p, &(probe_cube_desc){ .res = 16 }, &err);
    CHECK(pc != NULL, "%s", err.msg);
    double e = 0;
    for (int pass = 0; pc && pass < 2; pass++) {
        probe_cube_resample(pc, pass ? R : NULL, cube);
        for (int t = 0; t < 6 * 16 * 16; t++)
            for (int ch = 0; ch < 3; ch++) e = fmax(e, fabs(cube[3 * t + ch] / rgb[ch] - 1));
    }
    CHECK_LE(e, 64 * 6e-8, "constant probe: a mean of at most 64 float terms with weights summing to one");
    probe_cube_destroy(pc);
    probe_free(&p);

    /* The layouts' smooth function (|b| / 2 + 2 |C| at most 0.85, channel R) on a 256 x 128 latlong. */
    prt_image im = make_layout_image(PROBE_LATLONG, 256, 128);
    CHECK(probe_from_image(&im, PROBE_LATLONG, "fn", &p, &err) == 0, "%s", err.msg);
    const double pix = 2 * PI / 256;
    pc = probe_cube_create(&p, &(probe_cube_desc){ .res = 16 }, &err);
    double en = 0, eo = 0;
    probe_cube_resample(pc, R, cube);
    probe_to_cube(&p, 16, R, 0, old);
    for (int t = 0; t < 6 * 16 * 16; t++) {
        float d[3], want[3];
        cube_texel_dir(16, t, d);
        double q[3] = { R[0] * d[0] + R[3] * d[1] + R[6] * d[2], R[1] * d[0] + R[4] * d[1] + R[7] * d[2],
                        R[2] * d[0] + R[5] * d[1] + R[8] * d[2] };   /* R^T d: where the rotated probe shows */
        env_fn(q, want);
        for (int ch = 0; ch < 3; ch++) {
            en = fmax(en, fabs(cube[3 * t + ch] - want[ch]));
            eo = fmax(eo, fabs(old[3 * t + ch] - want[ch]));
        }
    }
    CHECK_LE(en, 0.85 * filter_sigma2(16, pix, true), "fine cube resampled at res 16 against the rotated function");
    CHECK_LE(eo, 0.85 * filter_sigma2(16, pix, false), "probe_to_cube at res 16 against the rotated function");
    probe_cube_destroy(pc);
    /* At the lighting resolution, through both light vectors. */
    pc = probe_cube_create(&p, NULL, &err);
    double worst = 0, bound = 0, dtex = 0.85 * (filter_sigma2(CUBE_RES, pix, true) + filter_sigma2(CUBE_RES, pix, false));
    for (int r = 0; r < 4; r++) {
        probe_rotation(90.0 * r + 17, 25.0 * (r % 3) - 20, R);
        probe_cube_resample(pc, R, cube);
        probe_to_cube(&p, CUBE_RES, R, 0, old);
        double b, d = lambert_diff(cube, old, dtex, &b);
        worst = fmax(worst, d / b);
        bound = b;
    }
    fprintf(stderr, "cube_rotate: smooth probe: Lambert radiance differs by at most %.3g of its bound %.3g\n", worst, bound);
    CHECK_LE(worst, 1.0, "smooth probe: Lambert receivers from the two light vectors");
    probe_cube_destroy(pc);
    probe_free(&p);
    free(cube);
    free(old);
}

/* cube_rotate's suns: the sub-pixel one of the sky case on a 2048-wide probe, and the default 1.5-degree
 * one, under 8 rotations. */
static void cube_rotate_suns(void) {
    prt_error err;
    prt_probe p;
    probe_cube *pc;
    float R[9], *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *old = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    for (int k = 0; k < 2; k++) {
        sky_desc sd = { .width = 2048, .sun_dir = { 0.05f, 0.99f, 0.1f }, .sun_radius_deg = 0.02f, .sun_radiance = 5e5f,
                        .sky_zenith = { 0.5f, 0.5f, 0.5f }, .sky_horizon = { 0.5f, 0.5f, 0.5f }, .ground = { 0.5f, 0.5f, 0.5f } };
        if (k) sd = (sky_desc){ .width = 1024 };
        CHECK(probe_make_sky(&sd, &p, &err) == 0, "%s", err.msg);
        double pl[3], pn[3], po[3], dp = 0, dl = 0, far = 0;
        latlong_power(&p, pl);
        pc = probe_cube_create(&p, NULL, &err);
        /* Each path puts a unit of light within its reach of where the probe has it: the texel's half
         * diagonal h / sqrt 2 and the probe's bilinear p sqrt 2, and the fine cube's bilinear and box
         * (h_s sqrt 2 + h_s / sqrt 2, h_s = h / 2); a Lambert receiver's radiance is 1/pi-Lipschitz in
         * the light's direction, so the two differ by at most the power times the reaches, over pi,
         * plus the power errors (at most 2% each, the resampling's bound: probe.c). */
        const double h = 2.0 / CUBE_RES, pp = 2 * PI / sd.width, reach = 2 * (h / sqrt(2) + pp * sqrt(2)) + 1.5 * h / sqrt(2);
        for (int r = 0; r < 8; r++) {
            probe_rotation(45.0 * r + 7, 11.0 * r - 40, R);
            probe_cube_resample(pc, R, cube);
            probe_to_cube(&p, CUBE_RES, R, 0, old);
            cube_power(cube, CUBE_RES, pn);
            cube_power(old, CUBE_RES, po);
            dp = fmax(dp, fabs(pn[0] / pl[0] - 1));
            double b, d = lambert_diff(cube, old, 0, &b);
            dl = fmax(dl, d / (b + pl[0] * (reach + 0.04) / PI));
            float tn[3], to[3];
            cube_texel_dir(CUBE_RES, brightest(cube, CUBE_TEXELS), tn);
            cube_texel_dir(CUBE_RES, brightest(old, CUBE_TEXELS), to);
            far = fmax(far, acos(fmin(1.0, tn[0] * to[0] + tn[1] * to[1] + tn[2] * to[2])));
        }
        fprintf(stderr, "cube_rotate: sun %d: power %.3g%% off, Lambert radiance differs by %.3g of its bound\n", k, 100 * dp, dl);
        CHECK_LE(dp, 0.02, "sun %d: the fine cube's resample keeps the probe's power (as probe_to_cube: 2%%)", k);
        CHECK_LE(dl, 1.0, "sun %d: Lambert receivers from the two light vectors", k);
        CHECK_LE(far, 1.5 * sqrt(2) * h, "sun %d: the brightest texels are the same or neighbours", k);
        probe_cube_destroy(pc);
        probe_free(&p);
    }
    free(cube);
    free(old);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(parse);
    CHECK_CASE(detect_and_clamp);
    CHECK_CASE(layouts);
    CHECK_CASE(constant);
    CHECK_CASE(sky);
    CHECK_CASE(exposure);
    CHECK_CASE(cube_rotate);
    CHECK_CASE(cube_rotate_suns);
    return check_summary();
}
