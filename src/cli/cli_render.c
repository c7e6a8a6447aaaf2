/* cli_render.c - `prt render`: .prt file + light probe -> relit image (PNG or EXR).
 *
 * Pipeline (section 4.3): probe -> filtered 6x64x64 cube (rotated) -> Haar light
 * vector (16-bit) -> light-dependent K-vectors (sparse T x L) -> per-vertex colour
 * h(view) . g (Eq. 5) -> an image drawn by the backend --backend names (runtime.h's
 * table: cpu rasterizes those colours with OSMesa, gl runs the GLSL runtime), all
 * through the runtime interface. PNG is tone-mapped with --exposure; EXR is linear
 * radiance. A backend that draws no images in this build (cpu without GL) still
 * writes the vertex radiance (--vertices) and refuses -o. */
#include "cli.h"
#include "cli_args.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "runtime.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *k_cmd = "render";

static void help(void) {
    fputs("usage: prt render FILE.prt --probe PROBE -o OUT.png|OUT.exr [options]\n"
         "\n"
         "  --probe PROBE           HDR light probe (EXR, HDR, PFM...; latlong, angular or cross)\n"
         "  --layout L              override the probe layout: latlong, angular, vcross, hcross\n"
         "                          (default: from the aspect ratio, 2:1 latlong, 1:1 angular, 3:4 / 4:3 cross)\n"
         "  -o OUT                  .png (tone-mapped, 8-bit sRGB) or .exr (linear radiance); also .hdr,\n"
         "                          .tif, .jpg, .ppm\n"
         "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  camera position, target and vertical FOV (default: the file's\n"
         "                          first camera, a glTF scene's, else framed); over --camera-name's\n"
         "  --camera-name NAME      the file's camera of that name (`prt info` lists them)\n"
         "  --size WxH              image size (default 800x600)\n"
         "  --light-rotation Y[,P]  rotate the lighting: yaw about +y, then pitch, in degrees (default 0)\n"
         "  --exposure E            exposure in stops for PNG output (default: from the probe, so that a\n"
         "                          white surface facing up shows as white; the same rule as prt reference)\n"
         "  --tonemap T             clamp (default), reinhard or aces for PNG output\n"
         "  --terms K               use only the first K BRDF terms (default: all)\n"
         CLI_AA_HELP, stdout);
    cli_backend_help(26, 0, "gl if the file is view dependent, else cpu");
    puts("  --no-background         black background instead of the probe\n"
         "  --direct-only           direct lighting only (files with bounces need precompute --keep-direct)\n"
         "  --vertices OUT.csv      also write per-vertex radiance toward the camera (for prt compare)\n"
         "  --threads T             worker threads (default: all cores)\n"
         CLI_LIGHT_HELP
         CLI_INDIRECT_HELP
         "  --probe none            no environment: the local lights alone\n");
}

/* Writes per-vertex radiance as CSV (vertex,r,g,b) atomically. */
static int write_vertices(const char *path, const float *rgb, int n, prt_error *err) {
    char tmp[4096];
    FILE *f = prt_atomic_open(path, tmp, sizeof tmp, err);
    if (!f) return -1;
    fprintf(f, "vertex,r,g,b\n");
    for (int v = 0; v < n; v++) fprintf(f, "%d,%.8g,%.8g,%.8g\n", v, rgb[3 * v], rgb[3 * v + 1], rgb[3 * v + 2]);
    return prt_atomic_commit(f, tmp, path, err);
}

/* What the command line asked for. */
typedef struct render_args {
    const char *in, *out, *probe_path, *layout, *cam_s, *cam_name, *rot_s, *vert_out, *backend;
    const runtime_backend_info *be;   /* --backend's table entry; without it the default's until the file is read */
    bool backend_given;
    int w, h, kmax, nthreads, tonemap, aa;
    float exposure, R[9];
    bool background, direct_only;
    int hl_samples;          /* --highlights / --highlight-samples (0: none) */
    bool bounce;             /* --local-bounce */
} render_args;

/* Parses argv into a; returns -1 to go on, else the exit status (0 after --help, 1 or 2 after printing). */
static int parse_args(int argc, char **argv, render_args *a) {
    const char *tonemap_s = "clamp";
    int size[2] = { 800, 600 };
    bool no_background = false;
    memset(a, 0, sizeof *a);
    a->exposure = NAN;   /* not given: from the probe (probe_exposure) */
    a->aa = CLI_AA_DEFAULT;
    const cli_option opts[] = {
        CLI_S("-o", &a->out), CLI_S("--probe", &a->probe_path), CLI_S("--layout", &a->layout),
        CLI_S("--camera", &a->cam_s), CLI_S("--camera-name", &a->cam_name), CLI_S("--light-rotation", &a->rot_s), CLI_S("--vertices", &a->vert_out),
        CLI_B("--no-background", &no_background), CLI_B("--direct-only", &a->direct_only), CLI_WH("--size", size),
        CLI_F("--exposure", &a->exposure, -64, 64), CLI_S("--tonemap", &tonemap_s), CLI_I("--terms", &a->kmax, 1, 64),
        CLI_I("--threads", &a->nthreads, 1, 64), CLI_S("--backend", &a->backend), CLI_I("--aa", &a->aa, 1, CLI_AA_MAX),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &a->in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    a->w = size[0];
    a->h = size[1];
    a->background = !no_background;
    if (!strcmp(tonemap_s, "clamp")) a->tonemap = 0;
    else if (!strcmp(tonemap_s, "reinhard")) a->tonemap = 1;
    else if (!strcmp(tonemap_s, "aces")) a->tonemap = 2;
    else return cli_error(k_cmd, "unknown --tonemap '%s' (clamp, reinhard, aces)", tonemap_s) + 1;
    a->backend_given = a->backend != NULL;
    if (!(a->be = cli_backend(k_cmd, a->backend, 0, NULL))) return 2;
    a->backend = a->be->name;
    bool images = a->be->caps & RUNTIME_CAP_IMAGES;
    if (!a->in) { cli_error(k_cmd, "no input .prt file (see --help)"); return 2; }
    if (!a->probe_path) { cli_error(k_cmd, "no light probe (--probe PROBE)"); return 2; }
    if (!a->out && images) { cli_error(k_cmd, "no output image (-o OUT.png or OUT.exr)"); return 2; }
    if (!a->out && !a->vert_out)
        return cli_error(k_cmd, "no output (--vertices OUT.csv; the %s backend draws no images in this build)", a->be->name) + 1;
    if (cli_check_view_flags(k_cmd, a->layout, a->cam_s) || cli_rotation(k_cmd, a->rot_s, a->R)) return 2;
    const cli_output outs[] = { { "-o", a->out, CLI_OUT_IMAGE }, { "--vertices", a->vert_out, CLI_OUT_CSV } };
    cli_inputs ins = { 0 };
    cli_inputs_add(&ins, NULL, a->in);
    cli_inputs_add(&ins, "--probe", a->probe_path);
    return cli_check_files(k_cmd, outs, 2, &ins) ? 2 : -1;
}

/* The timing line after the outputs: the light change's parts add up to it, each to 3 significant
 * digits (prt_format_duration), so a sub-0.05 ms GPU kernel does not print as 0.0. what: the output. */
static void print_timing(const char *what, const runtime_timing *t, double t_read, double t_write) {
    char gpu[64] = "", tm[7][48];
    const double secs[7] = { t_read, 1e-3 * (t->light_vector_ms + t->light_ms), 1e-3 * t->light_vector_ms, 1e-3 * t->light_ms,
                             1e-3 * t->view_ms, 1e-3 * t->raster_ms, t_write };
    for (int i = 0; i < 7; i++) prt_format_duration(tm[i], sizeof tm[i], secs[i]);
    if (t->light_gpu_ms > 0 && t->light_gpu_ms <= t->light_ms) {   /* a software GL's timer query can be garbage */
        char g[48];
        prt_format_duration(g, sizeof g, 1e-3 * t->light_gpu_ms);
        snprintf(gpu, sizeof gpu, ", GPU timer %s", g);
    }
    fprintf(stderr, "wrote %s (%s): read %s, light change %s (light vector %s + T x L %s%s), view change %s, raster %s, write %s\n",
            what, t->backend, tm[0], tm[1], tm[2], tm[3], gpu, tm[4], tm[5], tm[6]);
}

/* The runtime of desc; where --backend was not given and the chosen GL backend cannot start (no GL
 * context here), the default backend instead, saying so in one line. NULL with err when neither starts. */
static prt_runtime *create_runtime(const render_args *a, const prt_data *d, runtime_desc *desc, prt_error *err) {
    prt_runtime *rt = runtime_create(d, desc, err);
    const runtime_backend_info *dflt = runtime_backend_at(0);
    if (rt || a->backend_given || a->be == dflt) return rt;
    fprintf(stderr, "render: the %s backend did not start (%s); drawing with %s, per vertex\n", a->be->name, err->msg, dflt->name);
    desc->backend = dflt->name;
    desc->kernel = dflt->quick_kernel;
    return runtime_create(d, desc, err);
}

/* Relights d under the probe through the runtime: the image into -o, the vertex colours into
 * --vertices when asked; prints the timing line after writing. 0, 1 (error printed), or 2 when -o asks
 * an image of a backend that draws none in this build (refused after every check and load, so a
 * build without GL gives the same messages first, and before any light is computed). */
static int relight(const render_args *a, const prt_data *d, const prt_probe *probe, const prt_camera *cam, double t_read) {
    if (a->out && !(a->be->caps & RUNTIME_CAP_IMAGES))
        return cli_error(k_cmd, "-o %s: the %s backend draws no images in this build (no GL); --vertices OUT.csv writes the "
                         "vertex radiance", a->out, a->be->name) + 1;
    prt_error err = { { 0 } };
    runtime_desc desc = { .backend = a->backend, .threads = a->nthreads, .terms = a->kmax, .direct_only = a->direct_only,
                          .kernel = a->be->quick_kernel, .highlight_samples = a->hl_samples, .local_bounce = a->bounce };
    const float *R = a->rot_s ? a->R : NULL;
    render_desc rd = { .width = a->w, .height = a->h, .camera = *cam, .background = a->background ? probe : NULL,
                       .background_rotation = R, .samples = a->aa };
    prt_image img = { 0 };
    float *rgb = NULL;
    int rc = 1;
    prt_runtime *rt = create_runtime(a, d, &desc, &err);
    if (!rt || runtime_set_light(rt, probe, R, &err)) goto fail;
    if (d->scene.lights.count > 0 && runtime_set_local_lights(rt, &d->scene.lights, &err)) goto fail;
    if (a->out && runtime_render(rt, &rd, &img, &err)) goto fail;
    runtime_timing t;
    runtime_get_timing(rt, &t);   /* the image's view change */
    double t_write = 0;   /* of the image, or without one of the vertex colours */
    if (a->vert_out) {
        rgb = malloc(sizeof(float) * 3 * (size_t)(d->scene.mesh.nverts > 0 ? d->scene.mesh.nverts : 1));
        if (!rgb) { prt_fail(&err, "out of memory"); goto fail; }
        if (runtime_shade_vertices(rt, cam->eye, rgb, &err)) goto fail;
        if (!a->out) runtime_get_timing(rt, &t);   /* no image: the view change is the vertex colours' */
        double t4 = prt_now();
        if (write_vertices(a->vert_out, rgb, d->scene.mesh.nverts, &err)) goto fail;
        t_write = prt_now() - t4;
    }
    image_desc idesc = { .exposure = cli_exposure(a->exposure, probe, a->rot_s ? a->R : NULL, a->out), .tonemap = a->tonemap };
    double t5 = prt_now();
    if (a->out && image_write(a->out, &img, &idesc, &err)) goto fail;
    if (a->out) t_write = prt_now() - t5;
    char what[4200];
    if (a->out) snprintf(what, sizeof what, "%s (%dx%d)", a->out, a->w, a->h);
    else snprintf(what, sizeof what, "%s (%d vertices)", a->vert_out, d->scene.mesh.nverts);
    print_timing(what, &t, t_read, t_write);
    rc = 0;
    goto done;
fail:
    cli_error(k_cmd, "%s", err.msg);
done:
    runtime_destroy(rt);
    free(rgb);
    image_free(&img);
    return rc;
}

/* Entry point of `prt render` (see cli.h). */
int cli_render(int argc, char **argv) {
    render_args a;
    prt_lights extra;
    bool no_file_lights;
    int lr = cli_take_lights(k_cmd, &argc, argv, &extra, &no_file_lights);
    if (lr) return lr;
    cli_indirect ind;
    if ((lr = cli_take_indirect(k_cmd, &argc, argv, &ind))) return lr;
    int pr = parse_args(argc, argv, &a);
    if (pr >= 0) return pr;
    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    double t0 = prt_now();
    if (prtfile_read(a.in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    double t_read = prt_now() - t0;
    int rc = cli_apply_lights(k_cmd, &d.scene, &extra, no_file_lights);
    if (rc) {
        prt_data_free(&d);
        return rc;
    }
    cli_indirect_resolve(&ind, &d, false, &a.hl_samples, &a.bounce);
    if (!a.backend_given && a.out) a.be = runtime_backend_for(&d), a.backend = a.be->name;
    rc = 1;
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    prt_camera cam;
    if (a.direct_only && d.stats.bounces > 0 && prt_data_transfer(&d) && prt_data_transfer(&d)->direct.nvecs == 0)
        cli_error(k_cmd, "%s: --direct-only: the file keeps no direct-only transport (precompute it with --keep-direct)", a.in);
    else if ((rc = cli_camera(k_cmd, &d.scene, (float)a.w / a.h, a.cam_s, a.cam_name, &cam)) == 0)
        rc = cli_load_probe(k_cmd, a.probe_path, a.layout, &probe) ? 1 : relight(&a, &d, &probe, &cam, t_read);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
