/* cli_reference.c - `prt reference`: the path-traced ground truth of a .prt file's scene.
 *
 * Reads the scene back from the .prt file (mesh and analytic BRDF parameters per
 * material, not the factorized ones), renders the same camera and size as
 * `prt render` into a linear EXR, and optionally the per-vertex radiance toward
 * the camera with standard errors (the quantity PRT computes, Eq. 5), so that
 * `prt compare` can measure PRT's error against it (reference.h). */
#include "cli.h"
#include "cli_args.h"
#include "camera.h"
#include "compare.h"
#include "effects.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "reference.h"
#include <math.h>
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
         "                          (default: from the aspect ratio, as prt render)\n"
         "  -o OUT.exr              linear radiance image (.exr; .png etc. are tone-mapped 8-bit)\n"
         "  --exposure E            exposure in stops for a tone-mapped output (default: from the probe,\n"
         "                          as prt render's)\n"
         "  --spp N                 samples per pixel and per vertex (default 64)\n"
         "  --bounces B             interreflection bounces at most: 0 direct only, -1 to convergence\n"
         "                          (Russian roulette); default: the file's interreflection passes, so\n"
         "                          that prt compare measures PRT against the truth of the same effects\n"
         "  --light-bounces B       the local lights' light: at most B bounces (0 direct, -1 to convergence);\n"
         "                          default: --bounces when given, else the file's effects (1 with its local\n"
         "                          lights' one bounce, else 0)\n"
         "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  camera (default: framed as by prt render)\n"
         "  --camera-name NAME      the file's camera of that name (a glTF scene's; default: its first, if any)\n"
         "  --size WxH              image size (default 800x600)\n"
         "  --vertices OUT.csv      also write per-vertex radiance toward the camera with standard\n"
         "                          errors: vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing (facing 0:\n"
         "                          the normal faces away from the eye, radiance 0, left out by compare)\n"
         "  --vertex-spp N          samples per vertex (default: --spp)\n"
         "  --vertex-list CSV       trace only the vertices a per-vertex CSV lists (its vertex column, as\n"
         "                          --vertices here or prt render --vertices write): many samples where\n"
         "                          the reference is noisy (a contact shadow) at a fraction of the time\n"
         "  --no-image              only the per-vertex CSV (needs --vertices; -o not needed)\n"
         "  --light-rotation Y[,P]  rotate the lighting: yaw about +y, then pitch, in degrees (default 0)\n"
         "  --seed S                random seed (default 1); results are deterministic per seed\n"
         "  --no-background         black background instead of the probe\n"
         "  --threads T             worker threads (default: all cores)\n"
         "  --quiet                 no progress output\n"
         CLI_LIGHT_HELP
         "  --probe none            no environment: the local lights alone (next-event estimation)\n");
}

/* reference_args.bounces before the file is read: the file's interreflection passes. */
#define REF_BOUNCES_FILE (-1000)

/* What the command line asked for. */
typedef struct reference_args {
    const char *in, *out, *probe_path, *layout, *cam_s, *cam_name, *rot_s, *vert_out, *vert_list;
    int w, h, spp, vspp, bounces, light_bounces, nthreads;
    unsigned long long seed;
    bool background, quiet, no_image;
    float R[9], exposure;   /* exposure: stops, for a tone-mapped (.png) output, as prt render's */
} reference_args;

/* Parses argv into a; returns -1 to go on, else the exit status (0 after --help, 1 or 2 after printing). */
static int parse_args(int argc, char **argv, reference_args *a) {
    const char *seed_s = NULL;
    int size[2] = { 800, 600 };
    bool no_background = false;
    memset(a, 0, sizeof *a);
    a->spp = 64;
    a->bounces = a->light_bounces = REF_BOUNCES_FILE;
    a->exposure = NAN;   /* not given: from the probe (probe_exposure) */
    a->seed = 1;
    const cli_option opts[] = {
        CLI_S("-o", &a->out), CLI_S("--probe", &a->probe_path), CLI_S("--layout", &a->layout),
        CLI_S("--camera", &a->cam_s), CLI_S("--camera-name", &a->cam_name), CLI_S("--light-rotation", &a->rot_s), CLI_S("--vertices", &a->vert_out),
        CLI_S("--vertex-list", &a->vert_list),
        CLI_B("--no-background", &no_background), CLI_B("--no-image", &a->no_image), CLI_B("--quiet", &a->quiet),
        CLI_B("-q", &a->quiet), CLI_WH("--size", size), CLI_I("--spp", &a->spp, 1, 1 << 24), CLI_F("--exposure", &a->exposure, -64, 64),
        CLI_I("--vertex-spp", &a->vspp, 1, 1 << 24), CLI_I("--bounces", &a->bounces, -1, 1000),
        CLI_I("--light-bounces", &a->light_bounces, -1, 1000),
        CLI_I("--threads", &a->nthreads, 1, 64), CLI_S("--seed", &seed_s), CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &a->in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    a->w = size[0];
    a->h = size[1];
    a->background = !no_background;
    if (seed_s) {
        char *end;
        a->seed = strtoull(seed_s, &end, 10);
        if (end == seed_s || *end) { cli_error(k_cmd, "bad value for --seed: '%s' (expected an integer)", seed_s); return 2; }
    }
    if (!a->in) { cli_error(k_cmd, "no input .prt file (see --help)"); return 2; }
    if (!a->probe_path) { cli_error(k_cmd, "no light probe (--probe PROBE)"); return 2; }
    if (a->no_image && !a->vert_out) { cli_error(k_cmd, "--no-image needs --vertices OUT.csv"); return 2; }
    if (a->vert_list && !a->vert_out) { cli_error(k_cmd, "--vertex-list needs --vertices OUT.csv"); return 2; }
    if (!a->no_image && !a->out) { cli_error(k_cmd, "no output image (-o OUT.exr)"); return 2; }
    if (cli_check_view_flags(k_cmd, a->layout, a->cam_s) || cli_rotation(k_cmd, a->rot_s, a->R)) return 2;
    /* --no-image: -o is neither written nor checked */
    const cli_output outs[] = { { "-o", a->no_image ? NULL : a->out, CLI_OUT_IMAGE }, { "--vertices", a->vert_out, CLI_OUT_CSV } };
    cli_inputs ins = { 0 };
    cli_inputs_add(&ins, NULL, a->in);
    cli_inputs_add(&ins, "--probe", a->probe_path);
    cli_inputs_add(&ins, "--vertex-list", a->vert_list);
    return cli_check_files(k_cmd, outs, 2, &ins) ? 2 : -1;
}

/* The vertex ids --vertex-list names, each checked against the mesh's n vertices, into *ids
 * (malloc'd, ascending) and *count; without --vertex-list all n (ids NULL). -1 with err. */
static int vertex_list(const reference_args *a, int n, int **ids, int *count, prt_error *err) {
    *ids = NULL;
    *count = n;
    if (!a->vert_list) return 0;
    cmp_vertices vl;
    if (cmp_read_vertex_csv(a->vert_list, &vl, err)) return -1;
    if (vl.ids[vl.n - 1] >= n) {
        prt_fail(err, "%s: vertex %d out of range: the scene has %d vertices", a->vert_list, vl.ids[vl.n - 1], n);
        cmp_vertices_free(&vl);
        return -1;
    }
    *ids = vl.ids; /* taken over: the rest is freed */
    *count = vl.n;
    vl.ids = NULL;
    cmp_vertices_free(&vl);
    return 0;
}

/* --vertices: per-vertex radiance toward the eye with standard errors, and whether each vertex
 * faces the eye, as CSV (the --vertex-list ones, else all). -1 with err. */
static int vertices(ref_ctx *ref, const prt_mesh *m, const float eye[3], const ref_desc *rd, const reference_args *a,
                    prt_bar *bar, prt_error *err) {
    int n, *ids, rc = -1;
    if (vertex_list(a, m->nverts, &ids, &n, err)) return -1;
    float *rgb = malloc(sizeof(float) * 3 * (size_t)n), *se = malloc(sizeof(float) * 3 * (size_t)n);
    uint8_t *facing = malloc((size_t)(n > 0 ? n : 1));
    ref_desc vd = *rd;
    vd.spp = a->vspp ? a->vspp : a->spp;
    vd.stage = "reference vertices";
    ref_stats st;
    if (!rgb || !se || !facing) prt_fail(err, "out of memory");
    else if (ref_render_vertices(ref, eye, ids, n, &vd, rgb, se, &st, err) == 0) {
        prt_bar_done(bar);
        for (int i = 0; i < n; i++) facing[i] = ref_vertex_faces(m, ids ? ids[i] : i, eye);
        rc = ref_write_vertex_csv(a->vert_out, ids, rgb, se, facing, n, err);
    } else prt_bar_done(bar);
    char secs[48];
    prt_format_duration(secs, sizeof secs, st.seconds);
    if (rc == 0)
        fprintf(stderr, "wrote %s: %d vertices x %d spp in %s (%.2f Mrays/s), relative noise %.3g%s\n", a->vert_out,
                n, vd.spp, secs, st.seconds > 0 ? 1e-6 * st.rays / st.seconds : 0, st.rel_noise,
                st.dropped ? " (non-finite samples dropped)" : "");
    free(ids);
    free(rgb);
    free(se);
    free(facing);
    return rc;
}

/* The image from the camera, written to -o. -1 with err. */
static int image(ref_ctx *ref, const prt_probe *probe, const prt_camera *cam, ref_desc rd, const reference_args *a, prt_bar *bar,
                 prt_error *err) {
    float *ise = malloc(sizeof(float) * 3 * (size_t)a->w * a->h);
    prt_image img = { 0 };
    ref_stats st;
    int rc = -1;
    rd.stage = "reference image";
    if (!ise) prt_fail(err, "out of memory");
    else if (ref_render_image(ref, cam, a->w, a->h, &rd, &img, ise, &st, err) == 0) {
        prt_bar_done(bar);
        image_desc idesc = { .exposure = cli_exposure(a->exposure, probe, a->rot_s ? a->R : NULL, a->out) };
        rc = image_write(a->out, &img, &idesc, err);
    } else prt_bar_done(bar);
    char secs[48];
    prt_format_duration(secs, sizeof secs, st.seconds);
    if (rc == 0)
        fprintf(stderr, "wrote %s (%dx%d): %d spp in %s (%.2f Mrays/s), relative noise %.3g%s\n", a->out, a->w, a->h,
                a->spp, secs, st.seconds > 0 ? 1e-6 * st.rays / st.seconds : 0, st.rel_noise,
                st.dropped ? " (non-finite samples dropped)" : "");
    free(ise);
    image_free(&img);
    return rc;
}

/* Path-traces what a asks for of d's scene under the probe. 0 or 1 (error printed). */
static int trace(const reference_args *a, const prt_data *d, const prt_probe *probe, const prt_camera *cam) {
    prt_error err = { { 0 } };
    prt_bar bar;
    prt_bar_init(&bar, stderr, a->quiet);
    ref_ctx *ref = ref_create(&d->scene, probe, a->rot_s ? a->R : NULL, &err);
    char lights[96] = "";
    if (d->scene.lights.count)
        snprintf(lights, sizeof lights, ", local lights (their light: %d bounce%s)", a->light_bounces, a->light_bounces == 1 ? "" : "s");
    ref_desc rd = { .spp = a->spp, .bounces = a->bounces, .light_depth = a->light_bounces < 0 ? 0 : a->light_bounces + 1,
                    .seed = a->seed, .nthreads = a->nthreads,
                    .black_background = !a->background, .progress = prt_bar_report, .progress_user = &bar };
    if (ref && !a->quiet)
        fprintf(stderr, "reference: %d vertices, %d triangles, %d material(s), probe %dx%d, bounces %d%s, spp %d%s\n",
                d->scene.mesh.nverts, d->scene.mesh.ntris, d->scene.nmaterials, probe->img.w, probe->img.h, a->bounces,
                a->bounces == d->stats.bounces ? " (the file's)" : "", a->spp, lights);
    int rc = !ref || (a->vert_out && vertices(ref, &d->scene.mesh, cam->eye, &rd, a, &bar, &err)) ||
             (!a->no_image && image(ref, probe, cam, rd, a, &bar, &err));
    if (rc) cli_error(k_cmd, "%s", err.msg);
    ref_destroy(ref);
    return rc;
}

/* Entry point of `prt reference` (see cli.h). */
int cli_reference(int argc, char **argv) {
    reference_args a;
    prt_lights extra;
    bool no_file_lights;
    int lr = cli_take_lights(k_cmd, &argc, argv, &extra, &no_file_lights);
    if (lr) return lr;
    int pr = parse_args(argc, argv, &a);
    if (pr >= 0) return pr;
    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (prtfile_read(a.in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    int lr2 = cli_apply_lights(k_cmd, &d.scene, &extra, no_file_lights);
    if (lr2) {
        prt_data_free(&d);
        return lr2;
    }
    prt_camera cam;
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    int rc = 1;
    if (a.light_bounces == REF_BOUNCES_FILE && a.bounces != REF_BOUNCES_FILE) a.light_bounces = a.bounces;
    if (a.light_bounces == REF_BOUNCES_FILE) {   /* the local-light effects the file was made for */
        prt_effects fx;
        prt_file_effects(&d, &fx);
        a.light_bounces = fx.local_bounce || fx.highlights ? 1 : 0;
    }
    if (a.bounces == REF_BOUNCES_FILE) a.bounces = d.stats.bounces;   /* its interreflection passes */
    if ((rc = cli_camera(k_cmd, &d.scene, (float)a.w / a.h, a.cam_s, a.cam_name, &cam)) == 0)
        rc = cli_load_probe(k_cmd, a.probe_path, a.layout, &probe) ? 1 : trace(&a, &d, &probe, &cam);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
