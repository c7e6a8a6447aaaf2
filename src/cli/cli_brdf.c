/* cli_brdf.c - `prt brdf`: factor a BRDF (section 3.3) and print its singular values
 * and the cosine-weighted relative RMS error against K (the paper's Fig. 5). */
#include "cli.h"
#include "cli_args.h"
#include "factor.h"
#include <string.h>

static const char *k_cmd = "brdf";

static void help(void) {
    puts("usage: prt brdf SPEC [--terms K] [--res R] [--polar] [--csv]\n"
         "\n"
         "SPEC is a BRDF: model:key=value;key=value (values: 1 number or R,G,B)\n"
         "  lambert:kd=..                          Lambertian\n"
         "  phong:kd=..;ks=..;n=EXP                modified Phong      (preset paper-phong)\n"
         "  blinn:kd=..;ks=..;n=EXP                Blinn-Phong\n"
         "  as:kd=..;ks=..;nu=..;nv=..             Ashikhmin-Shirley   (preset paper-as)\n"
         "  lafortune:kd=..;lobe=Cx,Cy,Cz,n[;lobe=...]\n"
         "  ggx:kd=..;ks=F0;alpha=A                microfacet, GGX\n"
         "  beckmann:kd=..;ks=F0;alpha=A           microfacet, Beckmann\n"
         "Prints the singular values per channel and the relative cosine-weighted RMS error\n"
         "of the K-term approximation for K = 1..16 (and the K chosen by --terms).");
}

int cli_brdf(int argc, char **argv) {
    const char *spec = NULL;
    brdf_factor_desc fd = { .max_terms = 16 };
    bool csv = false;
    int param = BRDF_PARAM_GRID;
    const cli_option opts[] = {
        CLI_SETV("--polar", &param, BRDF_PARAM_POLAR),
        CLI_B("--csv", &csv),
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
    if (brdf_parse(spec, &p, &err)) return cli_error(k_cmd, "%s", err.msg);
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
        printf("%s\nfactored on a %dx%d %s grid in %.2fs; kept K = %d%s\n", canon, f.res, f.res,
               f.param == BRDF_PARAM_POLAR ? "polar (Eq. 11)" : "projected-disk (Eq. 10)", f.seconds, f.K,
               f.lambertian ? " (Lambertian: rank 1)" : "");
        printf("   K   sigma_R      sigma_G      sigma_B      rel. RMS error (cosine-weighted)\n");
        for (int k = 1; k <= f.nsigma && k <= 16; k++)
            printf("  %2d   %-11.5g  %-11.5g  %-11.5g  %7.3f%%\n", k, f.sigma[0][k - 1], f.sigma[1][k - 1],
                   f.sigma[2][k - 1], 100 * f.rel_rms[k]);
    }
    brdf_factor_free(&f);
    return 0;
}
