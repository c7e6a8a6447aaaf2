/* cli_brdf.c - `prt brdf`: factor a BRDF (section 3.3) and print its singular values
 * and the cosine-weighted relative RMS error against K (the paper's Fig. 5); for the
 * isotropic lobe models, the error of one vMF lobe per view elevation (laurijssen-2011
 * section 3, brdf/lobefit.h) beside the SVD's in the same measure. */
#include "cli.h"
#include "cli_args.h"
#include "factor.h"
#include "lobefit.h"
#include <math.h>
#include <string.h>

static const char *k_cmd = "brdf";

static void help(void) {
    puts("usage: prt brdf SPEC [--terms K] [--res R] [--polar] [--csv] [--lobes]\n"
         "\n"
         "  --terms K   the kept K (default 4, the same default as precompute --terms; the table\n"
         "              lists K = 1..16 whatever K is)\n"
         "  --res R     tabulation grid R x R per direction, 8..128 (default 48, as precompute)\n"
         "  --polar     polar parameterization (Eq. 11; default: the projected disk, Eq. 10)\n"
         "  --csv       the singular values and errors as CSV (k,sigma_r,sigma_g,sigma_b,rel_rms_error)\n"
         "  --lobes     the vMF lobe of every view elevation, and the two-lobe fit where one lobe errs\n"
         "\n"
         "SPEC is a BRDF: model:key=value;key=value (values: 1 number or R,G,B; missing keys take\n"
         "the defaults kd 0.5, ks 0.5, n 50, nu = nv 100, alpha 0.2); it is echoed in canonical form\n"
"  lambert:kd=..                          Lambertian\n"
         "  phong:kd=..;ks=..;n=EXP                modified Phong      (preset paper-phong)\n"
         "  blinn:kd=..;ks=..;n=EXP                Blinn-Phong\n"
         "  as:kd=..;ks=..;nu=..;nv=..             Ashikhmin-Shirley   (preset paper-as)\n"
         "  lafortune:kd=..;lobe=Cx,Cy,Cz,n[;lobe=...]\n"
         "  ggx:kd=..;ks=F0;alpha=A                microfacet, GGX\n"
         "  beckmann:kd=..;ks=F0;alpha=A           microfacet, Beckmann\n"
         "Prints the singular values per channel and the relative cosine-weighted RMS error\n"
         "of the K-term approximation for K = 1..16 (and the K chosen by --terms).\n"
         "For phong, blinn, ggx and beckmann it then fits one vMF lobe and colour to the\n"
         "specular slice f cos(theta_i) at 16 view elevations (diffuse left out) and prints\n"
         "its relative L2 error over the sphere, and the SVD's error in that same measure\n"
         "(relative to the whole slice); --lobes prints the lobe of every elevation and fits\n"
         "two lobes where one errs by more than 5% (kept where they lower the error by 2 points).");
}

/* Mean of n floats. */
static double mean_of(const float *x, int n) {
    double s = 0;
    for (int i = 0; i < n; i++) s += x[i];
    return n > 0 ? s / n : 0;
}

/* With `all`: the two-lobe fit's figures and, per elevation, its error where it was made. */
static void print_two_lobes(const lobefit_table *t) {
    int n = 0;
    for (int v = 0; v < t->views; v++) n += t->mixed[v];
    printf("  two lobes where one errs by more than %.0f%% (kept where %.0f points better): %d of %d views; "
           "as used %.1f%% mean, %.1f%% max\n", 100 * LOBEFIT_MIX_THRESHOLD, 100 * LOBEFIT_MIX_GAIN, n, t->views,
           100 * t->err_mix_mean, 100 * t->err_mix_max);
}

/* The vMF lobe fit's error (and with `all` its lobes and the two-lobe fit) beside the SVD's in the same measure. */
static int print_lobes(const brdf_params *p, const brdf_factor *f, bool all, prt_error *err) {
    lobefit_table t;
    if (lobefit_fit(p, &(lobefit_desc){ .lobes = all ? 2 : 1 }, &t, err)) return -1;
    printf("vMF lobe fit: error %.1f%% mean, %.1f%% max over %d view angles (specular slice f cos, diffuse left out)\n",
           100 * t.err_mean, 100 * t.err_max, t.views);
    float e4[LOBEFIT_MAX_VIEWS], eK[LOBEFIT_MAX_VIEWS];
    int K4 = f->K < 4 ? f->K : 4;
    lobefit_factor_error(&t, p, f, K4, e4);
    lobefit_factor_error(&t, p, f, f->K, eK);
    printf("  same measure, whole slice: vMF %.1f%% mean, %.1f%% max; SVD K = %d %.1f%% mean", 100 * t.err_whole_mean,
           100 * t.err_whole_max, K4, 100 * mean_of(e4, t.views));
    if (f->K != K4) printf(", K = %d %.1f%% mean", f->K, 100 * mean_of(eK, t.views));
    putchar('\n');
    if (!all) return 0;
    print_two_lobes(&t);
    printf("  theta_o   kappa       axis-mirror  alpha_R    alpha_G    alpha_B    error    SVD K=%d  two lobes\n", K4);
    for (int v = 0; v < t.views; v++) {
        const vmf_lobe *l = &t.lobe[v];
        double th = t.theta[v], ang = atan2(l->mu[0] * cos(th) + l->mu[2] * sin(th), l->mu[2] * cos(th) - l->mu[0] * sin(th));
        printf("  %6.2f   %-10.4g  %+8.3f deg  %-9.4g  %-9.4g  %-9.4g  %6.2f%%  %6.2f%%", th * 180 / 3.14159265358979,
               l->kappa, ang * 180 / 3.14159265358979, t.alpha[v][0], t.alpha[v][1], t.alpha[v][2], 100 * t.err[v], 100 * e4[v]);
        if (t.err_two[v] > 0)
            printf("   %6.2f%%%s (kappa %.4g, %.4g)", 100 * t.err_two[v], t.mixed[v] ? " kept" : "", t.mixed[v] ? t.mix[v][0].kappa : 0,
                   t.mixed[v] ? t.mix[v][1].kappa : 0);
        putchar('\n');
    }
    return 0;
}

int cli_brdf(int argc, char **argv) {
    const char *spec = NULL;
    brdf_factor_desc fd = { .max_terms = 4 };   /* precompute's default K (factor.h), so both keep the same K */
    bool csv = false, lobes = false;
    int param = BRDF_PARAM_GRID;
    const cli_option opts[] = {
        CLI_SETV("--polar", &param, BRDF_PARAM_POLAR),
        CLI_B("--csv", &csv),
        CLI_B("--lobes", &lobes),
        CLI_I("--terms", &fd.max_terms, 1, 64),
        CLI_I("--res", &fd.res, 8, 128),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &spec, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    fd.param = (brdf_param)param;
    if (!spec) { cli_error(k_cmd, "no BRDF spec (see --help)"); return 2; }
    prt_error err = { { 0 } };
    brdf_params p;
    if (brdf_parse(spec, &p, &err)) return cli_error(k_cmd, "%s", err.msg) + 1;   /* a bad argument: usage */
    brdf_factor f;
    memset(&f, 0, sizeof f);
    if (brdf_factorize(&p, &fd, &f, &err)) return cli_error(k_cmd, "%s", err.msg);
    char canon[512];
    brdf_format(&p, canon, sizeof canon);
    if (csv) {
        puts("k,sigma_r,sigma_g,sigma_b,rel_rms_error");
        for (int k = 1; k <= f.nsigma; k++)
            printf("%d,%.6g,%.6g,%.6g,%.6g\n", k, f.sigma[0][k - 1], f.sigma[1][k - 1], f.sigma[2][k - 1], f.rel_rms[k]);
    } else {
        char secs[48];
        prt_format_duration(secs, sizeof secs, f.seconds);
        printf("%s\nfactored on a %dx%d %s grid in %s; kept K = %d%s\n", canon, f.res, f.res,
               f.param == BRDF_PARAM_POLAR ? "polar (Eq. 11)" : "projected-disk (Eq. 10)", secs, f.K,
               f.lambertian ? " (Lambertian: rank 1)" : "");
        if (f.lambertian) {   /* every singular value after the first is 0: one line, not rows of zeros */
            printf("rank 1: sigma = %.5g, %.5g, %.5g (R, G, B) and 0 after; K = 1 is exact (0%% error)\n",
                   f.sigma[0][0], f.sigma[1][0], f.sigma[2][0]);
        } else printf("   K   sigma_R      sigma_G      sigma_B      rel. RMS error (cosine-weighted)\n");
        for (int k = 1; !f.lambertian && k <= f.nsigma && k <= 16; k++)
            printf("  %2d   %-11.5g  %-11.5g  %-11.5g  %7.3f%%\n", k, f.sigma[0][k - 1], f.sigma[1][k - 1],
                   f.sigma[2][k - 1], 100 * f.rel_rms[k]);
    }
    if (!csv && lobefit_supported(p.type) && print_lobes(&p, &f, lobes, &err)) {
        brdf_factor_free(&f);
        return cli_error(k_cmd, "%s", err.msg);
    }
    brdf_factor_free(&f);
    return 0;
}
