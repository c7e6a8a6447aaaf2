/* cli_reference.c - `prt reference`: the path-traced ground truth of a .prt file's scene.
 *
 * Reads the scene back from the .prt file (mesh and analytic BRDF parameters per
 * material, not the factorized ones), renders the same camera and size as
 * `prt render` into a linear EXR, and optionally the per-vertex radiance toward
 * the camera with standard errors (the quantity PRT computes, Eq. 5), so that
 * `prt compare` can measure PRT's error against it (reference.h). */
#include "cli.h"
#include "cli_args.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "reference.h"
#include "render.h"
#include <stdlib.h>
#include <string.h>

static const char *k_cmd = "reference";

static void help(void) {
    puts("usage: prt reference FILE.prt --probe PROBE -o OUT.exr [options]\n"
         "\n"
         "Path-traced reference (analytic BRDFs, full-resolution probe with importance sampling,\n"
         "MIS, Embree visibility) of the scene stored in FILE.prt, from the camera prt render uses.\n"
         "\n"
         "  --probe PROBE           HDR light probe (as for prt render)\n"
         "  --layout L              override the probe layout: latlong, angular, vcross, hcross\n"
         "  -o OUT.exr              linear radiance image (.exr; .png etc. are tone-mapped 8-bit)\n"
         "  --spp N                 samples per pixel and per vertex (default 64)\n"
         "  --bounces B             0 direct only (default; a .prt with no bounce passes), B > 0 at most\n"
         "                          B interreflection bounces, -1 to convergence (Russian roulette)\n"
         "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  camera (default: framed as by prt render)\n"
         "  --size WxH              image size (default 800x600)\n"
         "  --vertices OUT.csv      also write per-vertex radiance toward the camera with standard\n"
         "                          errors: vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing (facing 0:\n"
         "                          the normal faces away from the eye, radiance 0, left out by compare)\n"
         "  --vertex-spp N          samples per vertex (default: --spp)\n"
         "  --no-image              only the per-vertex CSV (needs --vertices; -o not needed)\n"
         "  --light-rotation Y[,P]  rotate the lighting: yaw about +y, then pitch, in degrees\n"
         "  --seed S                random seed (default 1); results are deterministic per seed\n"
         "  --no-background         black background instead of the probe\n"
         "  --threads T             worker threads (default: all cores)\n"
         "  --quiet                 no progress output\n");
}

/* Entry point of `prt reference` (see cli.h). */
int cli_reference(int argc, char **argv) {
    const char *in = NULL, *out = NULL, *probe_path = NULL, *layout = NULL, *cam_s = NULL, *rot_s = NULL;
    const char *vert_out = NULL, *seed_s = NULL;
    int size[2] = { 800, 600 }, spp = 64, vspp = 0, bounces = 0, nthreads = 0;
    unsigned long long seed = 1;
    bool no_background = false, quiet = false, no_image = false;
    const cli_option opts[] = {
        CLI_S("-o", &out),
        CLI_S("--probe", &probe_path),
        CLI_S("--layout", &layout),
        CLI_S("--camera", &cam_s),
        CLI_S("--light-rotation", &rot_s),
        CLI_S("--vertices", &vert_out),
        CLI_B("--no-background", &no_background),
        CLI_B("--no-image", &no_image),
        CLI_B("--quiet", &quiet),
        CLI_B("-q", &quiet),
        CLI_WH("--size", size),
        CLI_I("--spp", &spp, 1, 1 << 24),
        CLI_I("--vertex-spp", &vspp, 1, 1 << 24),
        CLI_I("--bounces", &bounces, -1, 1000),
        CLI_I("--threads", &nthreads, 1, 64),
        CLI_S("--seed", &seed_s),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    int w = size[0], h = size[1];
    bool background = !no_background;
    if (seed_s) {
        char *end;
        seed = strtoull(seed_s, &end, 10);
        if (end == seed_s || *end) { cli_error(k_cmd, "bad value for --seed: '%s' (expected an integer)", seed_s); return 2; }
    }
    if (!in) { cli_error(k_cmd, "no input .prt file (see --help)"); return 2; }
    if (!probe_path) { cli_error(k_cmd, "no light probe (--probe PROBE)"); return 2; }
    if (no_image && !vert_out) { cli_error(k_cmd, "--no-image needs --vertices OUT.csv"); return 2; }
    if (!no_image && !out) { cli_error(k_cmd, "no output image (-o OUT.exr)"); return 2; }
    if (!no_image && cli_check_image_path(k_cmd, out)) return 1;
    float R[9];
    if (cli_rotation(k_cmd, rot_s, R)) return 2;

    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (prtfile_read(in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    prt_camera cam;
    if (cli_camera(k_cmd, &d.scene, (float)w / h, cam_s, &cam)) { prt_data_free(&d); return 1; }
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    if (cli_load_probe(k_cmd, probe_path, layout, &probe)) { prt_data_free(&d); return 1; }

    int rc = 1;
    ref_ctx *ref = NULL;
    float *rgb = NULL, *se = NULL, *ise = NULL;
    uint8_t *facing = NULL;
    prt_image img = { 0 };
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    ref = ref_create(&d.scene, &probe, rot_s ? R : NULL, &err);
    if (!ref) { cli_error(k_cmd, "%s", err.msg); goto done; }
    ref_desc rd = { .spp = spp, .bounces = bounces, .seed = seed, .nthreads = nthreads,
                    .black_background = !background, .progress = prt_bar_report, .progress_user = &bar };
    if (!quiet)
        fprintf(stderr, "reference: %d vertices, %d triangles, %d material(s), probe %dx%d, bounces %d, spp %d\n",
                d.scene.mesh.nverts, d.scene.mesh.ntris, d.scene.nmaterials, probe.img.w, probe.img.h, bounces, spp);
    if (vert_out) {
        int n = d.scene.mesh.nverts;
        rgb = malloc(sizeof(float) * 3 * (size_t)n);
        se = malloc(sizeof(float) * 3 * (size_t)n);
        if (!rgb || !se) { cli_error(k_cmd, "out of memory"); goto done; }
        ref_desc vd = rd;
        vd.spp = vspp ? vspp : spp;
        vd.stage = "reference vertices";
        ref_stats st;
        if (ref_render_vertices(ref, cam.eye, NULL, n, &vd, rgb, se, &st, &err)) { prt_bar_done(&bar); cli_error(k_cmd, "%s", err.msg); goto done; }
        prt_bar_done(&bar);
        facing = malloc((size_t)n);
        if (!facing) { cli_error(k_cmd, "out of memory"); goto done; }
        for (int v = 0; v < n; v++) facing[v] = ref_vertex_faces(&d.scene.mesh, v, cam.eye);
        if (ref_write_vertex_csv(vert_out, rgb, se, facing, n, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        fprintf(stderr, "wrote %s: %d vertices x %d spp in %.2fs (%.2f Mrays/s), relative noise %.3g%s\n", vert_out,
                n, vd.spp, st.seconds, st.seconds > 0 ? 1e-6 * st.rays / st.seconds : 0, st.rel_noise,
                st.dropped ? " (non-finite samples dropped)" : "");
    }
    if (!no_image) {
        ise = malloc(sizeof(float) * 3 * (size_t)w * h);
        if (!ise) { cli_error(k_cmd, "out of memory"); goto done; }
        rd.stage = "reference image";
        ref_stats st;
        if (ref_render_image(ref, &cam, w, h, &rd, &img, ise, &st, &err)) { prt_bar_done(&bar); cli_error(k_cmd, "%s", err.msg); goto done; }
        prt_bar_done(&bar);
        image_desc idesc = { 0 };
        if (image_write(out, &img, &idesc, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        fprintf(stderr, "wrote %s (%dx%d): %d spp in %.2fs (%.2f Mrays/s), relative noise %.3g%s\n", out, w, h, spp,
                st.seconds, st.seconds > 0 ? 1e-6 * st.rays / st.seconds : 0, st.rel_noise,
                st.dropped ? " (non-finite samples dropped)" : "");
    }
    rc = 0;
done:
    ref_destroy(ref);
    free(rgb);
    free(se);
    free(ise);
    free(facing);
    image_free(&img);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
