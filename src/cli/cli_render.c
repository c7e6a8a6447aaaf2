/* cli_render.c - `prt render`: .prt file + light probe -> relit image (PNG or EXR).
 *
 * Pipeline (section 4.3): probe -> filtered 6x64x64 cube (rotated) -> Haar light
 * vector (16-bit) -> light-dependent K-vectors (sparse T x L) -> per-vertex colour
 * h(view) . g (Eq. 5) -> rasterized with OSMesa (CPU backend) or the GLSL runtime
 * (--backend gl). PNG is tone-mapped with --exposure; EXR is linear radiance. */
#include "cli.h"
#include "cli_args.h"
#include "glrt.h"
#include "image.h"
#include "probe.h"
#include "prtfile.h"
#include "relight.h"
#include "render.h"
#include "transfer.h"
#include <stdlib.h>
#include <string.h>

static const char *k_cmd = "render";

static void help(void) {
    puts("usage: prt render FILE.prt --probe PROBE -o OUT.png|OUT.exr [options]\n"
         "\n"
         "  --probe PROBE           HDR light probe (EXR, HDR, PFM...; latlong, angular or cross)\n"
         "  --layout L              override the probe layout: latlong, angular, vcross, hcross\n"
         "  -o OUT                  .png (tone-mapped, 8-bit sRGB) or .exr (linear radiance)\n"
         "  --camera EX,EY,EZ[,TX,TY,TZ[,FOV]]  camera position, target and vertical FOV (default: framed)\n"
         "  --size WxH              image size (default 800x600)\n"
         "  --light-rotation Y[,P]  rotate the lighting: yaw about +y, then pitch, in degrees\n"
         "  --exposure E            exposure in stops for PNG output (default 0)\n"
         "  --tonemap T             clamp (default), reinhard or aces for PNG output\n"
         "  --terms K               use only the first K BRDF terms (default: all)\n"
         "  --backend cpu|gl        CPU relighting + OSMesa raster (default) or the GLSL runtime\n"
         "  --no-background         black background instead of the probe\n"
         "  --direct-only           direct lighting only (files with bounces need precompute --keep-direct)\n"
         "  --vertices OUT.csv      also write per-vertex radiance toward the camera (for prt compare)\n"
         "  --threads T             worker threads (default: all cores)\n");
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

int cli_render(int argc, char **argv) {
    const char *in = NULL, *out = NULL, *probe_path = NULL, *layout = NULL, *cam_s = NULL, *rot_s = NULL;
    const char *vert_out = NULL, *tonemap_s = "clamp", *backend_s = "cpu";
    int size[2] = { 800, 600 }, kmax = 0, nthreads = 0, tonemap = 0;
    float exposure = 0;
    bool gl = false, no_background = false, direct_only = false;
    const cli_option opts[] = {
        CLI_S("-o", &out),
        CLI_S("--probe", &probe_path),
        CLI_S("--layout", &layout),
        CLI_S("--camera", &cam_s),
        CLI_S("--light-rotation", &rot_s),
        CLI_S("--vertices", &vert_out),
        CLI_B("--no-background", &no_background),
        CLI_B("--direct-only", &direct_only),
        CLI_WH("--size", size),
        CLI_F("--exposure", &exposure, -64, 64),
        CLI_S("--tonemap", &tonemap_s),
        CLI_I("--terms", &kmax, 1, 64),
        CLI_I("--threads", &nthreads, 1, 64),
        CLI_S("--backend", &backend_s),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    int w = size[0], h = size[1];
    bool background = !no_background;
    if (!strcmp(tonemap_s, "clamp")) tonemap = 0;
    else if (!strcmp(tonemap_s, "reinhard")) tonemap = 1;
    else if (!strcmp(tonemap_s, "aces")) tonemap = 2;
    else return cli_error(k_cmd, "unknown --tonemap '%s' (clamp, reinhard, aces)", tonemap_s) + 1;
    if (!strcmp(backend_s, "gl")) gl = true;
    else if (strcmp(backend_s, "cpu")) return cli_error(k_cmd, "unknown --backend '%s' (cpu or gl)", backend_s) + 1;
    if (!in) { cli_error(k_cmd, "no input .prt file (see --help)"); return 2; }
    if (!probe_path) { cli_error(k_cmd, "no light probe (--probe PROBE)"); return 2; }
    if (!out) { cli_error(k_cmd, "no output image (-o OUT.png or OUT.exr)"); return 2; }
    if (cli_check_image_path(k_cmd, out)) return 1;
    float R[9];
    if (cli_rotation(k_cmd, rot_s, R)) return 2;

    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    double t0 = prt_now();
    if (prtfile_read(in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    double t_read = prt_now() - t0;
    if (direct_only && d.stats.bounces > 0 && d.transfers[0].direct.nvecs == 0) {
        prt_data_free(&d);
        return cli_error(k_cmd, "%s: --direct-only: the file keeps no direct-only transport (precompute it with --keep-direct)", in);
    }
    prt_camera cam;
    if (cli_camera(k_cmd, &d.scene, (float)w / h, cam_s, &cam)) { prt_data_free(&d); return 1; }
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    if (cli_load_probe(k_cmd, probe_path, layout, &probe)) { prt_data_free(&d); return 1; }

    double t1 = prt_now();
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), (*L)[4] = NULL;
    if (cube) { probe_to_cube(&probe, CUBE_RES, rot_s ? R : NULL, 0, cube); L = transfer_light_vector(&d, cube); }
    free(cube);
    double t_light = prt_now() - t1;
    int rc = 1;
    float *rgb = NULL;
    relight_ctx *rcx = NULL;
    prt_image img = { 0 };
    if (!L) { cli_error(k_cmd, "out of memory"); goto done; }
    render_desc rd = { .width = w, .height = h, .camera = cam, .background = background ? &probe : NULL,
                       .background_rotation = rot_s ? R : NULL, .direct_only = direct_only };
    double t_lc = 0, t_vc = 0, t_raster = 0;
    if (gl) {
        double t2 = prt_now();
        if (glrt_render_image(&d, L, &rd, kmax, &img, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        t_raster = prt_now() - t2;
    } else {
        rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);
        rcx = relight_create(&d, nthreads, &err);
        if (!rgb || !rcx) { cli_error(k_cmd, "%s", rcx ? "out of memory" : err.msg); goto done; }
        if (direct_only) relight_use_direct(rcx, d.transfers[0].direct.nvecs > 0);
        double t2 = prt_now();
        relight_set_light(rcx, L);
        double t3 = prt_now();
        relight_view(rcx, cam.eye, kmax, rgb);
        double t4 = prt_now();
        t_lc = t3 - t2;
        t_vc = t4 - t3;
        if (render_vertex_colors(&d.scene.mesh, rgb, &rd, &img, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
        t_raster = prt_now() - t4;
        if (vert_out && write_vertices(vert_out, rgb, d.scene.mesh.nverts, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
    }
    image_desc idesc = { .exposure = exposure, .tonemap = tonemap };
    double t5 = prt_now();
    if (image_write(out, &img, &idesc, &err)) { cli_error(k_cmd, "%s", err.msg); goto done; }
    fprintf(stderr, "wrote %s (%dx%d): read %.2fs, light vector %.3fs, light change %.1f ms, view change %.1f ms, "
                    "raster %.3fs, write %.3fs\n",
            out, w, h, t_read, t_light, 1e3 * t_lc, 1e3 * t_vc, t_raster, prt_now() - t5);
    rc = 0;
done:
    relight_destroy(rcx);
    free(rgb);
    free(L);
    image_free(&img);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
