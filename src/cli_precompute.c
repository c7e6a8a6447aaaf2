/* cli_precompute.c - `prt precompute`: scene -> precompute pipeline -> .prt file,
 * with a progress bar and a per-stage timing summary. */
#include "cli.h"
#include "cli_args.h"
#include "precompute.h"
#include "prtfile.h"
#include "scene.h"
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *k_cmd = "precompute";

static void help(void) {
    puts("usage: prt precompute MODEL.obj|SCENE.json -o OUT.prt [options]\n"
         "\n"
         "scene:\n"
         "  --material SPEC        BRDF of an OBJ model (default lambert:kd=0.8); see `prt brdf --help`\n"
         "  --floor [VERTS]        add a diffuse floor under the model (default 31000 vertices)\n"
         "  --no-floor             no floor even if the JSON scene has one\n"
         "  --floor-material SPEC  floor BRDF (default lambert:kd=0.7)\n"
         "BRDF factorization (section 3.3):\n"
         "  --terms K              BRDF terms for glossy materials, the cap (default 4; Lambert always 1)\n"
         "  --term-error E         smallest K whose relative BRDF error is <= E (capped by --terms)\n"
         "  --polar                polar parameterization (Eq. 11) instead of the uniform grid (Eq. 10)\n"
         "transport (section 4.1):\n"
         "  --coeffs N             wavelet coefficients kept per transport vector (default 128)\n"
         "  --quant 8|16|32        coefficient quantization bits (default 8; 32 = float)\n"
         "  --vis-res R            visibility cube resolution: 64, 128 (default; 2x2 supersampling) or 256\n"
         "  --sh ORDER             spherical harmonics of ORDER (3..10) instead of Haar wavelets (baseline)\n"
         "interreflections (section 3.2, 4.2):\n"
         "  --bounces B            at most B interreflection passes (default 0)\n"
         "  --gather-res R         gathering cube resolution (default 32)\n"
         "  --bounce-threshold T   stop when a pass carries < T of the direct energy (default 0.01)\n"
         "  --force-bounces        do all B passes even if the plan would skip them\n"
         "  --no-bounces           never do interreflection passes\n"
         "  --keep-direct          also store the direct-only transport (for render --direct-only and\n"
         "                         the viewer's direct/bounces toggle; about doubles the file)\n"
         "other:\n"
         "  --threads T            worker threads (default: all cores)\n"
         "  --quiet                no progress output\n");
}

int cli_precompute(int argc, char **argv) {
    const char *in = NULL, *out = NULL, *v;
    scene_desc sd = { .floor = -1 };
    precompute_desc pd = { 0 };
    bool quiet = false;
    for (int i = 1; i < argc; i++) {
        int r;
        if (cli_is_help(argv[i])) { help(); return 0; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "-o", &out))) { if (r < 0) return 2; continue; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--material", &sd.material))) { if (r < 0) return 2; continue; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--floor-material", &sd.floor_material))) { if (r < 0) return 2; continue; }
        if (!strcmp(argv[i], "--floor")) {
            sd.floor = 1;
            if (i + 1 < argc && argv[i + 1][0] >= '0' && argv[i + 1][0] <= '9') {
                if (!cli_int(k_cmd, "--floor", argv[++i], 4, 4000000, &sd.floor_verts)) return 2;
            }
            continue;
        }
        if (!strcmp(argv[i], "--no-floor")) { sd.floor = 0; continue; }
        if (!strcmp(argv[i], "--polar")) { pd.param = BRDF_PARAM_POLAR; continue; }
        if (!strcmp(argv[i], "--force-bounces")) { pd.force_bounces = 1; continue; }
        if (!strcmp(argv[i], "--no-bounces")) { pd.force_bounces = -1; continue; }
        if (!strcmp(argv[i], "--keep-direct")) { pd.keep_direct = true; continue; }
        if (!strcmp(argv[i], "--quiet")) { quiet = true; continue; }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--terms", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--terms", v, 1, 64, &pd.max_terms)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--term-error", &v))) {
            if (r < 0 || !cli_float(k_cmd, "--term-error", v, 1e-6f, 1.f, &pd.term_error)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--coeffs", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--coeffs", v, 1, 24576, &pd.N)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--quant", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--quant", v, 8, 32, &pd.qbits)) return 2;
            if (pd.qbits != 8 && pd.qbits != 16 && pd.qbits != 32) return cli_error(k_cmd, "--quant must be 8, 16 or 32") + 1;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--vis-res", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--vis-res", v, 64, 256, &pd.vis_res)) return 2;
            if (pd.vis_res != 64 && pd.vis_res != 128 && pd.vis_res != 256) return cli_error(k_cmd, "--vis-res must be 64, 128 or 256") + 1;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--sh", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--sh", v, 3, 10, &pd.sh_order)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--bounces", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--bounces", v, 0, PRT_MAX_BOUNCES, &pd.bounces)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--gather-res", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--gather-res", v, 4, 128, &pd.gather_res)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--bounce-threshold", &v))) {
            if (r < 0 || !cli_float(k_cmd, "--bounce-threshold", v, 0.f, 1.f, &pd.bounce_threshold)) return 2;
            continue;
        }
        if ((r = cli_opt(k_cmd, argc, argv, &i, "--threads", &v))) {
            if (r < 0 || !cli_int(k_cmd, "--threads", v, 1, 64, &pd.nthreads)) return 2;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1]) { cli_error(k_cmd, "unknown option '%s' (see --help)", argv[i]); return 2; }
        if (in) { cli_error(k_cmd, "more than one input file ('%s' and '%s')", in, argv[i]); return 2; }
        in = argv[i];
    }
    if (!in) { cli_error(k_cmd, "no input model or scene (see --help)"); return 2; }
    if (!out) { cli_error(k_cmd, "no output file (-o OUT.prt)"); return 2; }

    prt_error err = { { 0 } };
    double t0 = prt_now();
    prt_scene scene = { 0 };
    if (scene_load(in, &sd, &scene, &err)) return cli_error(k_cmd, "%s", err.msg);
    double t_load = prt_now() - t0;
    if (!quiet)
        fprintf(stderr, "scene: %d vertices, %d triangles, %d material(s)%s (loaded in %.2fs)\n", scene.mesh.nverts,
                scene.mesh.ntris, scene.nmaterials, scene.floor_first_vertex >= 0 ? ", with floor" : "", t_load);
    if (!quiet && scene.load_stats.degenerate)
        fprintf(stderr, "warning: %s: dropped %d degenerate triangle(s)\n", in, scene.load_stats.degenerate);

    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    pd.progress = prt_bar_report;
    pd.progress_user = &bar;
    pd.quiet = quiet;
    prt_data data;
    memset(&data, 0, sizeof data);
    if (precompute_run(&scene, &pd, &data, &err)) {
        prt_bar_done(&bar);
        scene_free(&scene);
        return cli_error(k_cmd, "%s", err.msg);
    }
    prt_bar_done(&bar);
    double tw = prt_now();
    data.stats.t_write = 0;
    if (prtfile_write(out, &data, &err)) {
        prt_data_free(&data);
        return cli_error(k_cmd, "%s", err.msg);
    }
    data.stats.t_write = prt_now() - tw;
    struct stat st;
    double mb = stat(out, &st) == 0 ? st.st_size / 1e6 : 0;
    if (!quiet) {
        const prt_stats *s = &data.stats;
        fprintf(stderr, "\ntiming summary\n");
        fprintf(stderr, "  %-28s %9.2fs\n", "scene load", t_load);
        fprintf(stderr, "  %-28s %9.2fs\n", "BRDF factorization", s->t_brdf);
        fprintf(stderr, "  %-28s %9.2fs\n", "visibility (ray casting)", s->t_visibility);
        fprintf(stderr, "  %-28s %9.2fs\n", "transport+wavelet+quant.", s->t_transport);
        for (int b = 0; b < s->bounces && b < PRT_MAX_BOUNCES; b++) {
            char name[64];
            snprintf(name, sizeof name, "bounce %d (%.2f%% energy)", b + 1, 100 * s->bounce_energy[b]);
            fprintf(stderr, "  %-28s %9.2fs\n", name, s->t_bounce[b]);
        }
        fprintf(stderr, "  %-28s %9.2fs\n", "writing", data.stats.t_write);
        fprintf(stderr, "  %-28s %9.2fs\n", "total", prt_now() - t0);
        fprintf(stderr, "wrote %s: %.1f MB, %d vertices, %d transport vectors, N = %d, %d-bit\n", out, mb,
                data.transport.nverts, data.transport.nvecs, data.transport.N, data.transport.qbits);
    }
    prt_data_free(&data);
    return 0;
}
