/* level_spectrum.c - the per-level energy of probes' Haar light vectors
 * (docs/design/shadows.md): the prior the expected-error selection (transport.h,
 * TRANSPORT_SELECT_EXPECTED) weights each level's transport coefficients with. Not a test: it measures assets.
 *
 *     tools/level_spectrum.sh PROBE.exr...          (builds against build/libprt.a)
 *     tools/level_spectrum.sh --bands PROBE.exr...  (per elevation band: transport_band_sigma)
 *
 * For each probe and each of 24 rotations (yaw 0..345 in 15-degree steps, pitch -30/0/30
 * alternating), the probe is resampled to the 6x64x64 cube, weighted by the texel solid
 * angle w_j (the light side of the solid-angle measure, transfer_haar.c) and transformed;
 * sigma_l^2 is the mean over rotations, faces, channels and level l's coefficients of c^2
 * (level 0: the faces' scaling coefficients, level l >= 1: morton indices [4^(l-1), 4^l)).
 * Printed per probe relative to its finest level, then the geometric mean over the probes,
 * and sqrt of that: the weights sigma_l.
 *
 * --bands: the same per elevation band of each coefficient's support centre (transport_band,
 * haar/select.h) with pitch -15/0/15 (a sun stands for suns within 15 degrees of its elevation),
 * each probe's figures relative to its own finest level over all bands, then the arithmetic mean over
 * the probes, above the horizon from level 3 on at least a quarter of the largest band's (half in
 * sigma), and its square root: the table transport_band_sigma. */
#include "cubemap.h"
#include "haar.h"
#include "probe.h"
#include "select.h"
#include <string.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

enum { RES = CUBE_RES, FACE = RES * RES, NL = 7 };

static int level_of(int m) {
    int l = 0;
    while (m) { l++; m >>= 2; }
    return l;
}

static void rot(float yaw, float pitch, float R[9]) {
    char s[64];
    snprintf(s, sizeof s, "%g,%g", yaw, pitch);
    probe_parse_rotation(s, R);
}

/* --bands: transport_band_sigma from the probes argv[0..n). */
static int bands(int n, char **argv) {
    enum { NB = TRANSPORT_BANDS };
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), w[FACE], face[FACE], tmp[FACE];
    unsigned char *band = malloc(CUBE_TEXELS);   /* each wavelet index's band, once (it is trigonometry) */
    if (!cube || !band) { fprintf(stderr, "level_spectrum: out of memory\n"); return 1; }
    double cnt[NB][NL] = { { 0 } }, mean[NB][NL] = { { 0 } };
    haar_face_solid_angle(w, RES, false);
    for (uint32_t i = 0; i < CUBE_TEXELS; i++) {
        band[i] = (unsigned char)transport_band(i);
        cnt[band[i]][transport_level(i)] += 1;
    }
    for (int a = 0; a < n; a++) {
        prt_probe p;
        prt_error err;
        if (probe_load(argv[a], PROBE_AUTO, &p, &err)) { fprintf(stderr, "%s\n", err.msg); free(cube); free(band); return 1; }
        double e[NB][NL] = { { 0 } }, fin = 0;
        for (int r = 0; r < 24; r++) {
            float R[9];
            probe_rotation(15.0 * r, 15.0 * (r % 3 - 1), R);
            probe_to_cube(&p, RES, R, 4, cube);
            for (int f = 0; f < 6; f++)
                for (int c = 0; c < 3; c++) {
                    for (int k = 0; k < FACE; k++) face[k] = cube[3 * (f * FACE + k) + c] * w[k];
                    haar_forward(face, RES, tmp);
                    for (int k = 0; k < FACE; k++) {
                        uint32_t i = (uint32_t)(f * FACE) + haar_morton((uint32_t)(k % RES), (uint32_t)(k / RES));
                        double x2 = (double)face[k] * face[k];
                        int l = transport_level(i);
                        e[band[i]][l] += x2;
                        if (l == NL - 1) fin += x2;
                    }
                }
        }
        fin /= 24.0 * 3 * 6 * (3 * FACE / 4);   /* the finest level's mean square: 3/4 of a face's coefficients */
        for (int b = 0; b < NB; b++)
            for (int l = 0; l < NL; l++)
                if (cnt[b][l]) mean[b][l] += e[b][l] / (cnt[b][l] * 24 * 3) / fin / n;
        probe_free(&p);
    }
    /* A light can stand anywhere above the horizon (a lamp overhead, a noon sun): from level 3 on, no
     * band above it keeps less than half the largest of those bands' sigma (a quarter in mean square). */
    for (int l = 3; l < NL; l++) {
        double mx = 0;
        for (int b = NB / 2; b < NB; b++) mx = fmax(mx, mean[b][l]);
        for (int b = NB / 2; b < NB; b++)
            if (cnt[b][l]) mean[b][l] = fmax(mean[b][l], 0.25 * mx);
    }
    printf("transport_band_sigma (rows: elevation bands from -90 degrees, columns: Haar levels 0..6)\n");
    for (int b = 0; b < NB; b++) {
        printf("  %4d..%3d:", -90 + 15 * b, -75 + 15 * b);
        for (int l = 0; l < NL; l++) printf(" %9.3g", sqrt(mean[b][l]));
        printf("\n");
    }
    free(cube);
    free(band);
    return 0;
}

int main(int argc, char **argv) {
    if (argc > 1 && !strcmp(argv[1], "--bands")) return bands(argc - 2, argv + 2);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), w[FACE], face[FACE], tmp[FACE];
    double logsum[NL] = { 0 };
    haar_face_solid_angle(w, RES, false);
    int count[NL] = { 0 };
    for (int m = 0; m < FACE; m++) count[level_of(m)]++;
    for (int a = 1; a < argc; a++) {
        prt_probe p;
        prt_error err;
        if (probe_load(argv[a], PROBE_AUTO, &p, &err)) { fprintf(stderr, "%s\n", err.msg); return 1; }
        double e[NL] = { 0 };
        for (int r = 0; r < 24; r++) {
            float R[9];
            rot(15.f * (float)r, (float)(30 * (r % 3 - 1)), R);
            probe_to_cube(&p, RES, R, 4, cube);
            for (int f = 0; f < 6; f++)
                for (int c = 0; c < 3; c++) {
                    for (int k = 0; k < FACE; k++) face[k] = cube[3 * (f * FACE + k) + c] * w[k];
                    haar_forward(face, RES, tmp);
                    for (int j = 0; j < RES; j++)
                        for (int i = 0; i < RES; i++) {
                            double x = face[j * RES + i];
                            e[level_of((int)haar_morton((uint32_t)i, (uint32_t)j))] += x * x;
                        }
                }
        }
        printf("%-40s", argv[a]);
        for (int l = 0; l < NL; l++) {
            double s = (e[l] / count[l]) / (e[NL - 1] / count[NL - 1]);
            logsum[l] += log(s);
            printf(" %10.4g", s);
        }
        printf("\n");
        probe_free(&p);
    }
    printf("%-40s", "geometric mean sigma^2");
    for (int l = 0; l < NL; l++) printf(" %10.4g", exp(logsum[l] / (argc - 1)));
    printf("\n%-40s", "sigma");
    for (int l = 0; l < NL; l++) printf(" %10.4g", sqrt(exp(logsum[l] / (argc - 1))));
    printf("\n");
    free(cube);
    return 0;
}
