/* prefilter_lights.c - how well the prefiltered probe (src/image/prefilter.h) holds each probe's
 * brightest spot, with its brightest pixels taken out of the ladder as lights and without: the
 * measurement behind prefilter.h's light threshold and count. Not a test: it measures assets.
 *
 *     tools/prefilter_lights.sh THRESHOLD LIGHTS PROBE.exr...   (builds against build/libprt.a;
 *                                                                LIGHTS < 0: none, the ladder alone)
 *
 * Per latlong probe: prefilter_create with that light_threshold and lights (its time printed), then at
 * the brightest pixel's direction c and at offsets 0.5 .. 2.5 lobe widths 1/sqrt(kappa) from it in four
 * directions, for kappa 1600 .. 6, the lookup against quadrature of the probe as probe_eval reads it
 * (pixels above 10 x the mean luminance integrated as their bilinear tents on 24 x 24 sub-samples,
 * the others at their centres); the worst error per kappa relative to the value at c, per channel. */
#include "lobe.h"
#include "prefilter.h"
#include "probe.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

static float lum(const float *t) { return 0.2126f * t[0] + 0.7152f * t[1] + 0.0722f * t[2]; }

static void ll_dir(const prt_probe *p, double fx, double fy, float d[3]) {
    double th = fy / p->img.h * PI, ph = (fx / p->img.w - 0.5) * 2 * PI;
    d[0] = (float)(sin(th) * sin(ph)), d[1] = (float)cos(th), d[2] = (float)(-sin(th) * cos(ph));
}

/* int L gamma(.; d, k) of the bilinear probe (file comment). */
static void truth(const prt_probe *p, double mean, const float d[3], float k, double o[3]) {
    int w = p->img.w, h = p->img.h;
    const int S = 12;
    vmf_lobe v = { { d[0], d[1], d[2] }, k };
    o[0] = o[1] = o[2] = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *L = p->img.data + 3 * ((size_t)y * w + x);
            double t = 0;
            if (lum(L) > 10 * mean) {
                for (int a = 0; a < 2 * S; a++)
                    for (int b = 0; b < 2 * S; b++) {
                        double s = -1 + (a + 0.5) / S, u = -1 + (b + 0.5) / S, fy = y + 0.5 + u;
                        float q[3];
                        if (fy < 0 || fy > h) continue;
                        ll_dir(p, x + 0.5 + s, fy, q);
                        t += (1 - fabs(s)) * (1 - fabs(u)) * vmf_eval(&v, q) * sin(fy / h * PI) * (PI / h) * (2 * PI / w) / (S * S);
                    }
            } else {
                float q[3], om;
                probe_pixel_dir(p, x, y, q, &om);
                t = om * (double)vmf_eval(&v, q);
            }
            for (int c = 0; c < 3; c++) o[c] += t * L[c];
        }
}

/* The direction at angle t from unit c, toward azimuth index dn (of 4). */
static void offset(const float c[3], double t, int dn, float d[3]) {
    double u[3] = { 0, 1, 0 }, a[3], b[3], l = 0;
    if (fabsf(c[1]) > 0.9f) u[0] = 1, u[1] = 0;
    double cd = u[0] * c[0] + u[1] * c[1] + u[2] * c[2];
    for (int i = 0; i < 3; i++) a[i] = u[i] - cd * c[i], l += a[i] * a[i];
    for (int i = 0; i < 3; i++) a[i] /= sqrt(l);
    b[0] = c[1] * a[2] - c[2] * a[1], b[1] = c[2] * a[0] - c[0] * a[2], b[2] = c[0] * a[1] - c[1] * a[0];
    double ph = dn * PI / 2;
    for (int i = 0; i < 3; i++) d[i] = (float)(cos(t) * c[i] + sin(t) * (cos(ph) * a[i] + sin(ph) * b[i]));
}

static void measure(const char *path, float threshold, int lights) {
    prt_probe p;
    prt_error e;
    if (probe_load(path, PROBE_LATLONG, &p, &e)) { fprintf(stderr, "%s\n", e.msg); return; }
    int w = p.img.w, h = p.img.h;
    double pw = 0, om = 0;
    size_t bi = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float d[3], o, l = lum(p.img.data + 3 * ((size_t)y * w + x));
            probe_pixel_dir(&p, x, y, d, &o);
            pw += o * l, om += o;
            if (l > lum(p.img.data + 3 * bi)) bi = (size_t)y * w + x;
        }
    float c[3], o;
    probe_pixel_dir(&p, (int)(bi % w), (int)(bi / w), c, &o);
    double t0 = prt_now();
    prefilter_env *env = prefilter_create(&p, NULL, &(prefilter_desc){ .lights = lights, .light_threshold = threshold }, &e);
    double t1 = prt_now();
    if (!env) { fprintf(stderr, "%s: %s\n", path, e.msg); probe_free(&p); return; }
    printf("%s: threshold %g, %d lights, prefilter_create %.0f ms\n", path, (double)threshold, prefilter_light_count(env), 1e3 * (t1 - t0));
    const float ks[] = { 1600, 1131, 800, 400, 200, 100, 52, 25, 6 };
    double all = 0;
    for (size_t q = 0; q < sizeof ks / sizeof *ks; q++) {
        double peak[3], worst = 0;
        truth(&p, pw / om, c, ks[q], peak);
        for (int a = 0; a <= 5; a++)
            for (int dn = 0; dn < (a ? 4 : 1); dn++) {
                float d[3], r[3];
                double t[3];
                offset(c, 0.5 * a / sqrt(ks[q]), dn, d);
                if (a) truth(&p, pw / om, d, ks[q], t); else memcpy(t, peak, sizeof t);
                prefilter_lookup(env, d, ks[q], r);
                for (int ch = 0; ch < 3; ch++) worst = fmax(worst, fabs(r[ch] - t[ch]) / peak[ch]);
            }
        printf("  kappa %6.0f: worst %.2f%% of the peak\n", (double)ks[q], 100 * worst);
        all = fmax(all, worst);
    }
    printf("  worst over kappa: %.2f%%\n", 100 * all);
    prefilter_destroy(env);
    probe_free(&p);
}

int main(int argc, char **argv) {
    if (argc < 4) { fprintf(stderr, "usage: prefilter_lights THRESHOLD LIGHTS PROBE.exr...\n"); return 2; }
    for (int i = 3; i < argc; i++) measure(argv[i], (float)atof(argv[1]), atoi(argv[2]));
    return 0;
}
