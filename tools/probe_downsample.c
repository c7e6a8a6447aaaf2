/* probe_downsample.c - a latitude-longitude probe shrunk by an integer factor with its light
 * kept: how data/city-512.exr was made from the shared city.exr (data/README.md).
 *
 *     tools/probe_downsample.sh IN.exr OUT.exr FACTOR     (builds against build/libprt.a)
 *
 * Each output texel is the solid-angle-weighted mean of the FACTOR x FACTOR input texels it
 * covers: L_out = sum L_i Omega_i / sum Omega_i, Omega_i = (2 pi / W)(cos th0 - cos th1) of
 * input row i (th the polar angle of its edges). So the power sum L Omega of any block of
 * output texels, the sun's included, is the input's (a plain mean would weigh a texel near
 * the pole as much as one at the equator). Negative texels (lossy compression's, down to
 * -0.004 in the shared probes) are taken as 0 first, as probe_load does. The output is half
 * float EXR (zip): its 11-bit mantissa changes each texel by at most 2^-11 of itself, and no
 * texel of the shared probes shrunk 2x exceeds half's 65,504.
 *
 * Prints the input's and the output's total power, and the power within 3 degrees of the
 * brightest input texel (the sun), in both, so the copy can be checked to keep the sun. Not a
 * test: it makes an asset. */
#include "image.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static const double k_pi = 3.14159265358979323846;

/* The solid angle of one texel of row y of an h-row latlong image w texels wide. */
static double row_omega(int y, int w, int h) {
    return 2 * k_pi / w * (cos(k_pi * y / h) - cos(k_pi * (y + 1) / h));
}

/* The unit direction of the centre of texel (x, y) of a w x h latlong image (y up, as probe.c). */
static void texel_dir(int x, int y, int w, int h, double d[3]) {
    double th = k_pi * (y + 0.5) / h, ph = 2 * k_pi * (x + 0.5) / w;
    d[0] = sin(th) * sin(ph);
    d[1] = cos(th);
    d[2] = -sin(th) * cos(ph);
}

/* Total power (sum of luminance x solid angle) of im, and the part within cone_deg of dir. */
static void power(const prt_image *im, const double dir[3], double cone_deg, double *total, double *cone) {
    double ct = cos(cone_deg * k_pi / 180);
    *total = *cone = 0;
    for (int y = 0; y < im->h; y++)
        for (int x = 0; x < im->w; x++) {
            const float *p = im->data + ((size_t)y * im->w + x) * im->c;
            double l = (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) * row_omega(y, im->w, im->h), d[3];
            texel_dir(x, y, im->w, im->h, d);
            *total += l;
            if (d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2] >= ct) *cone += l;
        }
}

/* The direction of in's brightest texel (luminance). */
static void brightest(const prt_image *in, double dir[3]) {
    double best = -1;
    int bx = 0, by = 0;
    for (int y = 0; y < in->h; y++)
        for (int x = 0; x < in->w; x++) {
            const float *p = in->data + ((size_t)y * in->w + x) * in->c;
            double l = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            if (l > best) { best = l; bx = x; by = y; }
        }
    texel_dir(bx, by, in->w, in->h, dir);
}

/* out = in shrunk by f with solid-angle weights. */
static void shrink(const prt_image *in, int f, prt_image *out) {
    for (int oy = 0; oy < out->h; oy++)
        for (int ox = 0; ox < out->w; ox++) {
            double acc[3] = { 0, 0, 0 }, wsum = 0;
            for (int y = oy * f; y < (oy + 1) * f; y++) {
                double w = row_omega(y, in->w, in->h);
                for (int x = ox * f; x < (ox + 1) * f; x++)
                    for (int ch = 0; ch < 3; ch++) {
                        acc[ch] += in->data[((size_t)y * in->w + x) * in->c + ch] * w;
                    }
                wsum += w * f;
            }
            for (int ch = 0; ch < 3; ch++) out->data[((size_t)oy * out->w + ox) * 3 + ch] = (float)(acc[ch] / wsum);
        }
}

int main(int argc, char **argv) {
    if (argc != 4 || atoi(argv[3]) < 1) {
        fprintf(stderr, "usage: probe_downsample IN.exr OUT.exr FACTOR\n");
        return 2;
    }
    int f = atoi(argv[3]);
    prt_image in = { 0 }, out = { 0 };
    prt_error err = { { 0 } };
    if (image_read(argv[1], &in, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    if (in.w != 2 * in.h || in.w % f || in.h % f) {
        fprintf(stderr, "%s: %dx%d is not a 2:1 latlong divisible by %d\n", argv[1], in.w, in.h, f);
        return 1;
    }
    if (image_alloc(&out, in.w / f, in.h / f, 3, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    for (size_t i = 0; i < (size_t)in.w * in.h * in.c; i++)
        if (!(in.data[i] > 0)) in.data[i] = 0;   /* negative (and NaN) texels: 0, as probe_load takes them */
    shrink(&in, f, &out);
    image_desc d = { .half = true };
    if (image_write(argv[2], &out, &d, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    prt_image back = { 0 };   /* what the file holds, half floats included */
    if (image_read(argv[2], &back, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
    double sun[3], ti, ci, to, co;
    brightest(&in, sun);
    power(&in, sun, 3, &ti, &ci);
    power(&back, sun, 3, &to, &co);
    printf("%s %dx%d: power %.6g, within 3 deg of the sun %.6g\n", argv[1], in.w, in.h, ti, ci);
    printf("%s %dx%d: power %.6g (%+.4f%%), within 3 deg of the sun %.6g (%+.4f%%)\n", argv[2], back.w, back.h, to,
           100 * (to / ti - 1), co, 100 * (co / ci - 1));
    image_free(&in);
    image_free(&out);
    image_free(&back);
    return 0;
}
