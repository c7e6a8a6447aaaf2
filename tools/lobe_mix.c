/* lobe_mix.c - one vMF lobe against two per view elevation (brdf/lobefit.h "Two lobes"): the
 * measurement behind LOBEFIT_MIX_THRESHOLD and LOBEFIT_MIX_GAIN. Not a test: it measures fits.
 *
 *     tools/lobe_mix.sh [SPEC...]     (builds against build/libprt.a; no SPEC: 13 BRDFs, Phong,
 *                                      Blinn, GGX and Beckmann at several exponents and roughnesses)
 *
 * Per BRDF: the two-lobe fit at every view (mix_threshold 1e-9) with each view's one- and two-lobe
 * errors, then the fit at the defaults (two lobes where they are kept) with its mean and max error as
 * used. Last, over every view of every BRDF, the median ratio of the two-lobe error to the one-lobe
 * error in bins of the one-lobe error. */
#include "lobefit.h"
#include <stdio.h>
#include <stdlib.h>

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    static const char *def[] = { "phong:kd=0;ks=1;n=10", "paper-phong", "phong:kd=0;ks=1;n=200", "phong:kd=0;ks=1;n=1000",
                                 "blinn:kd=0;ks=1;n=20", "blinn:kd=0;ks=1;n=80", "blinn:kd=0;ks=1;n=400",
                                 "ggx:kd=0;ks=1;alpha=0.05", "ggx:kd=0;ks=1;alpha=0.2", "ggx:kd=0;ks=1;alpha=0.4",
                                 "beckmann:kd=0;ks=1;alpha=0.05", "beckmann:kd=0;ks=1;alpha=0.1", "beckmann:kd=0;ks=1;alpha=0.3" };
    int n = argc > 1 ? argc - 1 : (int)(sizeof def / sizeof *def);
    const char **specs = argc > 1 ? (const char **)argv + 1 : def;
    static const double bins[] = { 0, 0.02, 0.05, 0.1, 0.2, 0.4, 1e9 };
    double *bin[6];
    int nb[6] = { 0 };
    for (int b = 0; b < 6; b++) bin[b] = malloc(sizeof(double) * LOBEFIT_MAX_VIEWS * (size_t)n);
    for (int i = 0; i < n; i++) {
        brdf_params p;
        prt_error e;
        lobefit_table all, used;
        if (brdf_parse(specs[i], &p, &e) || lobefit_fit(&p, &(lobefit_desc){ .lobes = 2, .mix_threshold = 1e-9f }, &all, &e) ||
            lobefit_fit(&p, &(lobefit_desc){ .lobes = 2 }, &used, &e)) { fprintf(stderr, "%s: %s\n", specs[i], e.msg); continue; }
        printf("%s\n", specs[i]);
        int mixed = 0;
        for (int v = 0; v < all.views; v++) {
            double one = all.err[v], two = all.err_two[v] > 0 ? all.err_two[v] : one;
            printf("  theta %5.1f: one lobe %6.2f%%, two %6.2f%%%s\n", all.theta[v] * 57.29578, 100 * one, 100 * two, used.mixed[v] ? " (kept)" : "");
            mixed += used.mixed[v];
            for (int b = 0; b < 6; b++)
                if (one >= bins[b] && one < bins[b + 1] && one > 0) bin[b][nb[b]++] = two / one;
        }
        printf("  as used: two lobes at %d of %d views; %.2f%% mean, %.2f%% max (one lobe %.2f%%, %.2f%%); fit %.2f s (every view %.2f s)\n",
               mixed, used.views, 100 * used.err_mix_mean, 100 * used.err_mix_max, 100 * used.err_mean, 100 * used.err_max, used.seconds, all.seconds);
    }
    for (int b = 0; b < 6; b++) {
        if (!nb[b]) continue;
        qsort(bin[b], (size_t)nb[b], sizeof(double), cmp);
        printf("one-lobe error in [%g%%, %g%%): %d views, median two/one %.2f\n", 100 * bins[b], b < 5 ? 100 * bins[b + 1] : 100.0, nb[b], bin[b][nb[b] / 2]);
        free(bin[b]);
    }
    return 0;
}
