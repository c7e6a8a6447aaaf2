/* cli_demo.c - `prt demo`: the whole pipeline on built-in data, no download.
 *
 * A procedural scene (a glossy sphere, a diffuse torus and a glossy box over a
 * Lambert floor; data/demo.json, built in as scene_demo_json() so that the demo
 * needs no file) is precomputed with the default settings and relit under a
 * procedural HDR sky with a small bright sun: the sun casts sharp shadows,
 * the sky soft ones. Writes demo.png (or -o) and, with --prt, keeps the file. */
#include "cli.h"
#include "cli_args.h"
#include "precompute.h"
#include "probe.h"
#include "prtfile.h"
#include "runtime.h"
#include <stdlib.h>
#include <string.h>

static const char *k_cmd = "demo";

int cli_demo(int argc, char **argv) {
    const char *out = "demo.png", *prt_out = NULL;
    int size[2] = { 960, 600 }, floor_verts = 12000, bounces = 1;
    float exposure = -1;
    bool quiet = false;
    const cli_option opts[] = {
        CLI_S("-o", &out),
        CLI_S("--prt", &prt_out),
        CLI_B("--quiet", &quiet),
        CLI_WH("--size", size),
        CLI_I("--floor", &floor_verts, 16, 1000000),
        CLI_I("--bounces", &bounces, 0, PRT_MAX_BOUNCES),
        CLI_F("--exposure", &exposure, -64, 64),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, NULL, 0, &npos);
    if (pr == 1) {
        puts("usage: prt demo [options]\n"
             "\n"
             "Precomputes a built-in scene (glossy sphere, diffuse torus, glossy box over a floor) and\n"
             "renders it under a built-in HDR sky with a small sun (sharp and soft shadows).\n"
             "\n"
             "  -o OUT.png      the image (default demo.png; .exr .hdr .tif .jpg .ppm too)\n"
             "  --size WxH      image size (default 960x600)\n"
             "  --floor VERTS   floor vertices, 16..1000000 (default 12000)\n"
             "  --bounces B     at most B interreflection passes (default 1; 0: none)\n"
             "  --exposure E    exposure in stops (default -1)\n"
             "  --prt OUT.prt   also keep the precomputed file (default: not kept)\n"
             "  --quiet         no progress output");
        return 0;
    }
    if (pr) return 2;
    const cli_output outs[] = { { "-o", out, CLI_OUT_IMAGE }, { "--prt", prt_out, CLI_OUT_PRT } };
    cli_inputs none = { 0 };   /* the demo reads no file */
    if (cli_check_files(k_cmd, outs, 2, &none)) return 2;
    const runtime_backend_info *be = runtime_backend_at(0);   /* runtime_create's default */
    if (!(be->caps & RUNTIME_CAP_IMAGES))
        return cli_error(k_cmd, "this build has no GL (NO_GL=1): the demo's image needs the %s backend's raster (OSMesa)",
                         be->name) + 1;
    int w = size[0], h = size[1];
    prt_error err = { { 0 } };
    double t0 = prt_now();
    prt_scene scene;
    memset(&scene, 0, sizeof scene);
    if (scene_make_demo(&scene, floor_verts, &err)) return cli_error(k_cmd, "%s", err.msg);
    if (!quiet) fprintf(stderr, "demo scene: %d vertices, %d triangles, %d materials\n", scene.mesh.nverts, scene.mesh.ntris, scene.nmaterials);
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    /* bounces 0: none (the library's 0 means its default) */
    precompute_desc pd = { .bounces = bounces, .force_bounces = bounces == 0 ? -1 : 0, .progress = prt_bar_report, .progress_user = &bar, .quiet = quiet };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (precompute_run(&scene, &pd, &d, &err)) { prt_bar_done(&bar); scene_free(&scene); return cli_error(k_cmd, "%s", err.msg); }
    prt_bar_done(&bar);
    if (prt_out && prtfile_write(prt_out, &d, &err)) { prt_data_free(&d); return cli_error(k_cmd, "%s", err.msg); }

    int rc = 1;
    prt_probe sky;
    memset(&sky, 0, sizeof sky);
    /* Sun behind the objects and low (about 35 deg) so their long sharp shadows fall toward
     * the camera (on the -z side, camera.h); the sky adds the soft ones. */
    sky_desc sd = { .width = 1024, .sun_dir = { -0.45f, 0.57f, 0.69f }, .sun_radius_deg = 1.0f, .sun_radiance = 4000.f };
    prt_runtime *rt = NULL;
    prt_image img = { 0 };
    if (probe_make_sky(&sd, &sky, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
    prt_camera cam;
    cli_camera(k_cmd, &d.scene, (float)w / h, NULL, NULL, &cam);   /* no --camera: cannot fail */
    /* Lowered to 16 degrees above the objects, looking 8 down, 55-degree field: the horizon crosses
     * the image about a third of the way down and the sky fills the upper third (at the default
     * 25 degrees up even the top row would look below the horizon: a flat ground colour). */
    camera_lower(&cam, 16, 8, 55);
    render_desc rd = { .width = w, .height = h, .camera = cam, .background = &sky, .samples = CLI_AA_DEFAULT };
    if (!(rt = runtime_create(&d, NULL, &err)) || runtime_set_light(rt, &sky, NULL, &err) ||
        runtime_render(rt, &rd, &img, &err)) {
        cli_error(k_cmd, "%s", err.msg);
        goto done;
    }
    image_desc idesc = { .exposure = exposure, .tonemap = 2 };
    if (image_write(out, &img, &idesc, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
    char secs[48];
    prt_format_duration(secs, sizeof secs, prt_now() - t0);
    if (!quiet) fprintf(stderr, "wrote %s (%dx%d) in %s\n", out, w, h, secs);
    rc = 0;
done:
    runtime_destroy(rt);
    image_free(&img);
    probe_free(&sky);
    prt_data_free(&d);
    return rc;
}
