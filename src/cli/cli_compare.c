/* cli_compare.c - `prt compare A B [--error-image OUT.png]`: error of A against the reference B.
 *
 * Prints one line "rel_rmse=... max_rel_err=..." (plus "ref_noise=..." when B is a
 * per-vertex CSV carrying standard errors) on stdout; the metrics are defined in compare.h. */
#include "cli.h"
#include "cli_args.h"
#include "compare.h"
#include <stdio.h>
#include <string.h>

static const char *k_cmd = "compare";

static void help(void) {
    puts("usage: prt compare A B [--error-image OUT.png]\n"
         "\n"
         "Compares A against the reference B: two images of the same size (EXR for radiance)\n"
         "or two per-vertex CSV files (from prt render --vertices / prt reference --vertices).\n"
         "Prints one line:  rel_rmse=X max_rel_err=Y [ref_noise=Z]\n"
         "  rel_rmse     sqrt(sum (a-b)^2 / sum b^2) over all pixels (vertices) and channels\n"
         "  max_rel_err  max |a-b|/|b| (RGB norms) over items with |b| above 1% of the mean |b|\n"
         "  ref_noise    sqrt(sum stderr^2 / sum b^2) when B has stderr columns (its noise floor)\n"
         "\n"
         "  --error-image OUT.png   false-colour map of per-pixel relative error (turbo, log scale:\n"
         "                          black <= 0.1%, blue 0.2%, green 3%, orange 10%, dark red >= 100%)\n"
         "  --all-vertices          CSV: also compare vertices the reference marks as facing away\n"
         "                          from the eye (by default only facing = 1 rows are compared)\n"
         "  -v, --verbose           also print item counts and the worst item (pixel x,y from the\n"
         "                          top-left corner, or vertex id)\n");
}

/* Entry point of `prt compare` (see cli.h). */
int cli_compare(int argc, char **argv) {
    const char *files[2] = { NULL, NULL }, *errimg = NULL;
    int nfiles = 0;
    bool verbose = false;
    cmp_desc desc = { 0 };
    for (int i = 1; i < argc; i++) {
        int r;
        if (cli_is_help(argv[i])) { help(); return 0; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--error-image", &errimg))) { if (r < 0) return 2; continue; }
        if (!strcmp(argv[i], "-v") || !strcmp(argv[i], "--verbose")) { verbose = true; continue; }
        if (!strcmp(argv[i], "--all-vertices")) { desc.all_vertices = true; continue; }
        if (argv[i][0] == '-' && argv[i][1]) { cli_error(k_cmd, "unknown option '%s' (see --help)", argv[i]); return 2; }
        if (nfiles == 2) { cli_error(k_cmd, "more than two files ('%s')", argv[i]); return 2; }
        files[nfiles++] = argv[i];
    }
    if (nfiles < 2) { cli_error(k_cmd, "needs two files: A (result) and B (reference) (see --help)"); return 2; }
    const cli_output out = { "--error-image", errimg, CLI_OUT_IMAGE };
    cli_inputs ins = { 0 };
    cli_inputs_add(&ins, "A", files[0]);
    cli_inputs_add(&ins, "B", files[1]);
    if (cli_check_files(k_cmd, &out, 1, &ins)) return 2;
    cmp_result r;
    prt_error err = { { 0 } };
    desc.error_image = errimg;
    if (cmp_files(files[0], files[1], &desc, &r, &err)) return cli_error(k_cmd, "%s", err.msg);
    printf("rel_rmse=%.6g max_rel_err=%.6g", r.rel_rmse, r.max_rel_err);
    if (r.ref_noise >= 0) printf(" ref_noise=%.6g", r.ref_noise);
    printf("\n");
    if (verbose && r.width > 0 && r.worst_item >= 0)   /* an image: the worst pixel as x,y (row 0 at the top) */
        fprintf(stderr, "%ld pixels compared, %ld above the 1%% floor, worst pixel x,y = %d,%d\n", r.items,
                r.items_in_max, r.worst_item % r.width, r.worst_item / r.width);
    else if (verbose)
        fprintf(stderr, "%ld items compared (%ld vertices facing away left out), %ld above the 1%% floor, worst vertex %d\n",
                r.items, r.skipped, r.items_in_max, r.worst_item);
    if (errimg) fprintf(stderr, "wrote %s\n", errimg);
    return 0;
}
