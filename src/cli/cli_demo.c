/* cli_demo.c - `prt demo`: the whole pipeline on the demo scene, no download.
 *
 * The scene (data/demo.json, built in as scene_demo_json() so that the demo needs no scene file):
 * a chrome sphere, a glossy red sphere, a diffuse orange box and a blue torus over a light floor.
 * Its light is data/city-512.exr, a 512 x 256 copy of the shared city probe (data/README.md), looked
 * for beside the program (build/prt's ../data) and then under the working directory: its sun casts
 * the sharp shadows, its overcast sky the soft ones. The precompute runs with prt precompute's
 * defaults and the scene's own keys, its refinement and its light prior, the prior naming the probe
 * found, so `prt demo --prt F` writes the file `prt precompute data/demo.json -o F` writes (timings
 * aside). Without the probe the same scene is lit by the built-in sky with its sun where city's is,
 * and the demo says so (no prior then: it names a file).
 *
 * The picture is `prt render`'s (exposure from the probe, the clamp tone map) from a fixed camera
 * that frames the floor only, on the first backend that shades per pixel (gl: the chrome sphere's
 * reflections at every pixel, not its vertices') or, without one, the first that draws images.
 * Writes demo.png (or -o) and, with --prt, keeps the file. */
#include "cli.h"
#include "cli_args.h"
#include "precompute.h"
#include "probe.h"
#include "prtfile.h"
#include "runtime.h"
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *k_cmd = "demo";

#define DEMO_PROBE "city-512.exr"
#define DEMO_FLOOR 10000   /* data/demo.json's floor vertices (tests/test_data.c loads both) */
/* The camera: 34 degrees above the models, looking toward -x -z with city's sun (about 48 degrees up,
 * from +x -z) 105 degrees to its right, so the shadows fall left and the sunlit faces look at it; a
 * 22-degree field that holds the floor only. */
static const prt_camera k_demo_camera = { .eye = { 6.18f, 5.05f, 2.56f }, .target = { -0.3f, 0.35f, 0.25f },
                                          .up = { 0, 1, 0 }, .fov_deg = 22 };

/* data/DEMO_PROBE beside the program (its ../data) or under the working directory, canonical, into
 * path[PATH_MAX]; false when neither is readable. */
static bool demo_probe_path(char path[PATH_MAX]) {
    char exe[PATH_MAX], cand[2][PATH_MAX + 64];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    char *slash = n > 0 ? (exe[n] = 0, strrchr(exe, '/')) : NULL;
    if (slash) *slash = 0;
    snprintf(cand[0], sizeof cand[0], "%s/../data/" DEMO_PROBE, slash ? exe : ".");
    snprintf(cand[1], sizeof cand[1], "data/" DEMO_PROBE);
    for (int i = 0; i < 2; i++)
        if (access(cand[i], R_OK) == 0 && realpath(cand[i], path)) return true;
    return false;
}

/* The demo's light into *probe: the probe at path, or (path NULL) the built-in sky with a sun where
 * city's is (48 degrees up, from +x -z; 0.5 degrees across, radiance giving a sun-to-sky ratio near
 * city's: about half the sky's light on the floor) over a pale gradient. Returns 0, or the exit
 * status after saying why. */
static int demo_light(const char *path, prt_probe *probe) {
    if (path) return cli_load_probe(k_cmd, path, NULL, probe);
    sky_desc sd = { .width = 1024, .sun_dir = { 0.40f, 0.74f, -0.55f }, .sun_radius_deg = 0.5f, .sun_radiance = 8000.f,
                    .sky_zenith = { 0.75f, 0.82f, 0.95f }, .sky_horizon = { 1.0f, 1.0f, 1.0f }, .ground = { 0.3f, 0.3f, 0.3f } };
    prt_error err = { { 0 } };
    return probe_make_sky(&sd, probe, &err) ? cli_error(k_cmd, "%s", err.msg) : 0;
}

/* The per-pixel GL backend, else the default when it draws images (NULL: none, a build without GL). */
static const runtime_backend_info *demo_backend(void) {
    const runtime_backend_info *px = runtime_backend_pixel(), *dflt = runtime_backend_at(0);
    return px ? px : dflt->caps & RUNTIME_CAP_IMAGES ? dflt : NULL;
}

/* Precomputes the demo scene (floor_verts floor vertices; bounces: -1 the default, 0 none, else at
 * most that many) with its refinement and, when prior names the probe, its light prior into *d.
 * Returns 0, or the exit status after saying why. */
static int demo_precompute(int floor_verts, int bounces, const char *prior, bool quiet, prt_data *d) {
    prt_error err = { { 0 } };
    prt_scene scene;
    memset(&scene, 0, sizeof scene);
    if (scene_make_demo(&scene, floor_verts, &err)) return cli_error(k_cmd, "%s", err.msg);
    if (!quiet)
        fprintf(stderr, "demo scene: %d vertices, %d triangles, %d materials\n", scene.mesh.nverts, scene.mesh.ntris,
                scene.nmaterials);
    prt_bar bar;
    prt_bar_init(&bar, stderr, quiet);
    precompute_desc pd = { .bounces = bounces > 0 ? bounces : 0, .force_bounces = bounces == 0 ? -1 : 0,
                           .light_prior = prior, .progress = prt_bar_report, .progress_user = &bar, .quiet = quiet };
    /* its "refine" as prt precompute applies it; its "light_prior" names the probe under the working
     * directory (the built-in text has no folder), so the demo names the one it found instead */
    int rc = precompute_desc_apply_scene(&pd, &scene, PRECOMPUTE_SCENE_REFINE, &err) || precompute_run(&scene, &pd, d, &err);
    prt_bar_done(&bar);
    if (rc) {
        scene_free(&scene);   /* precompute_run took it only on success */
        return cli_error(k_cmd, "%s", err.msg);
    }
    return 0;
}

/* Relights d under probe on backend be from the demo's camera into out (w x h, tone-mapped at
 * exposure stops, or at the probe's exposure when exposure is NaN). Returns the exit status. */
static int demo_render(const prt_data *d, const prt_probe *probe, const runtime_backend_info *be, int w, int h,
                       float exposure, bool quiet, const char *out) {
    prt_error err = { { 0 } };
    runtime_desc rdesc = { .backend = be->name };
    prt_runtime *rt = runtime_create(d, &rdesc, &err);
    prt_image img = { 0 };
    render_desc rd = { .width = w, .height = h, .camera = k_demo_camera, .background = probe, .samples = CLI_AA_DEFAULT };
    int rc = !rt || runtime_set_light(rt, probe, NULL, &err) || runtime_render(rt, &rd, &img, &err);
    if (!rc) {
        image_desc idesc = { .exposure = isnan(exposure) ? probe_exposure(probe, NULL) : exposure };
        if (!quiet && isnan(exposure))
            fprintf(stderr, "exposure %+.1f stops (from the probe: a white surface facing up shows as white; --exposure sets it)\n",
                    (double)idesc.exposure);
        rc = image_write(out, &img, &idesc, &err);
    }
    if (rc) cli_error(k_cmd, "%s", err.msg);
    runtime_destroy(rt);
    image_free(&img);
    return rc;
}

int cli_demo(int argc, char **argv) {
    const char *out = "demo.png", *prt_out = NULL;
    int size[2] = { 960, 600 }, floor_verts = DEMO_FLOOR, bounces = -1;
    float exposure = NAN;
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
             "Precomputes the built-in demo scene (data/demo.json: a chrome sphere, a glossy red sphere, a\n"
             "diffuse box and torus over a floor) with prt precompute's defaults and the scene's refinement\n"
             "and light prior, and renders it under data/" DEMO_PROBE " (found beside the program or in\n"
             "./data; else under the built-in sky, with its sun where city's is): sharp and soft shadows,\n"
             "glossy and mirror reflections, interreflections.\n"
             "\n"
             "  -o OUT.png      the image (default demo.png; .exr .hdr .tif .jpg .ppm too)\n"
             "  --size WxH      image size (default 960x600)\n"
             "  --floor VERTS   floor vertices before refinement, 16..1000000 (default 10000)\n"
             "  --bounces B     at most B interreflection passes (default: as prt precompute, up to 3\n"
             "                  while a pass carries 1% of the direct light; 0: none)\n"
             "  --exposure E    exposure in stops (default: from the probe, as prt render)\n"
             "  --prt OUT.prt   also keep the precomputed file (default: not kept)\n"
             "  --quiet         no progress output");
        return 0;
    }
    if (pr) return 2;
    char path[PATH_MAX];
    bool found = demo_probe_path(path);
    const cli_output outs[] = { { "-o", out, CLI_OUT_IMAGE }, { "--prt", prt_out, CLI_OUT_PRT } };
    cli_inputs ins = { 0 };   /* the probe is looked for, not named: only one found is an input */
    if (found) cli_inputs_add(&ins, "the demo's probe", path);
    if (cli_check_files(k_cmd, outs, 2, &ins)) return 2;
    const runtime_backend_info *be = demo_backend();
    if (!be)
        return cli_error(k_cmd, "this build has no GL (NO_GL=1): the demo's image needs a backend that draws (OSMesa)") + 1;
    double t0 = prt_now();
    if (!quiet) {
        if (found) fprintf(stderr, "demo: lit by %s\n", path);
        else fprintf(stderr, "demo: data/" DEMO_PROBE " not found (beside the program or here): lit by the built-in sky\n");
    }
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    int rc = demo_light(found ? path : NULL, &probe);
    prt_data d;
    memset(&d, 0, sizeof d);
    if (!rc) rc = demo_precompute(floor_verts, bounces, found ? path : NULL, quiet, &d);
    prt_error err = { { 0 } };
    if (!rc && prt_out && prtfile_write(prt_out, &d, &err)) rc = cli_error(k_cmd, "%s", err.msg);
    if (!rc) rc = demo_render(&d, &probe, be, size[0], size[1], exposure, quiet, out);
    if (!rc && !quiet) {
        char secs[48];
        prt_format_duration(secs, sizeof secs, prt_now() - t0);
        fprintf(stderr, "wrote %s (%dx%d, %s backend) in %s\n", out, size[0], size[1], be->name, secs);
    }
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
