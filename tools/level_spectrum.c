/* level_spectrum.c - the per-level energy of probes' Haar light vectors
 * (docs/design/shadows.md): the prior the expected-error selection (transport.h,
 * TRANSPORT_SELECT_EXPECTED) weights each level's transport coefficients with. Not a test: it measures assets.
 *
 *     tools/level_spectrum.sh PROBE.exr...      (builds against build/libprt.a)
 *
 * For each probe and each of 24 rotations (yaw 0..345 in 15-degree steps, pitch -30/0/30
 * alternating), the probe is resampled to the 6x64x64 cube, weighted by the texel solid
 * angle w_j (the light side of the solid-angle measure, transfer_haar.c) and transformed;
 * sigma_l^2 is the mean over rotations, faces, channels and level l's coefficients of c^2
 * (level 0: the faces' scaling coefficients, level l >= 1: morton indices [4^(l-1), 4^l)).
 * Printed per probe relative to its finest level, then the geometric mean over the probes,
 * and sqrt of that: the weights sigma_l. */
#include "cubemap.h"
#include "haar.h"
#include "probe.h"
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

int main(int argc, char **argv) {
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
