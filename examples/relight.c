/* relight.c - relights a precomputed .prt file under a light probe with prt's CPU runtime.
 *
 *     relight IN.prt PROBE|none ANGLE OUT.png|OUT.exr [WxH]
 *
 * Loads IN.prt (made by `prt precompute` or precompute_run), turns the probe ANGLE degrees about
 * +y (a light at direction d moves to R d), relights every vertex on the CPU (T x L, then
 * h(view) . g per vertex), rasterizes the scene from the camera `prt render` frames it with, the
 * probe behind it, and writes OUT: PNG is 8-bit sRGB (clamped), EXR linear radiance. PROBE "none"
 * is a black environment (a file's local lights alone). The image is the one of
 *     prt render IN.prt --probe PROBE --light-rotation ANGLE -o OUT --size WxH
 * (tests/test_install.c checks it pixel for pixel).
 *
 * Build against an installed prt (make install PREFIX=...; docs/api.md):
 *     cc relight.c $(pkg-config --cflags --libs prt) -o relight
 * Exit status: 0 done, 1 bad data (a file missing, corrupt or unwritable), 2 bad usage; every
 * error is one line on stderr. */
#include "prt.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Says in one line what is wrong with the command line; returns the usage exit status. */
static int usage(const char *what, const char *arg) {
    if (!what) fprintf(stderr, "usage: relight IN.prt PROBE|none ANGLE_DEG OUT.png|OUT.exr [WxH]\n");
    else fprintf(stderr, "relight: %s%s%s\n", arg ? arg : "", arg ? ": " : "", what);
    return 2;
}

/* What the command line asked for. */
typedef struct args {
    const char *in, *probe, *out;
    double angle;
    int w, h;
} args;

/* Parses argv into a; 0, or the usage exit status after saying why. */
static int parse(int argc, char **argv, args *a) {
    static const char *const exts[] = { "png", "exr", NULL };
    if (argc < 5 || argc > 6) return usage(NULL, NULL);
    *a = (args){ .in = argv[1], .probe = argv[2], .out = argv[4], .w = 800, .h = 600 };
    char *end, extra;
    a->angle = strtod(argv[3], &end);
    if (end == argv[3] || *end || !isfinite(a->angle)) return usage("not an angle in degrees", argv[3]);
    if (argc == 6 && (sscanf(argv[5], "%dx%d%c", &a->w, &a->h, &extra) != 2 || a->w < 1 || a->h < 1 ||
                      a->w > 16384 || a->h > 16384))
        return usage("not an image size WxH (1..16384 each)", argv[5]);
    prt_error err = { { 0 } };
    if (prt_output_check(a->out, exts, &err)) return usage(err.msg, NULL);
    if (prt_same_file(a->out, a->in) || prt_same_file(a->out, a->probe))
        return usage("the output would overwrite an input", a->out);
    return 0;
}

/* Loads, relights and writes as the header says; 0, or -1 with err. */
static int relight(const args *a, prt_error *err) {
    static const float black[3] = { 0, 0, 0 };
    prt_data d = { 0 };
    prt_probe probe = { 0 };
    prt_image img = { 0 };
    prt_runtime *rt = NULL;
    float R[9], b0[3], b1[3];
    int rc = -1;
    probe_rotation(a->angle, 0, R);
    /* 4 samples per pixel (multisampled, averaged in linear radiance), as prt render's default --aa */
    render_desc rd = { .width = a->w, .height = a->h, .background = &probe, .background_rotation = R, .samples = 4 };
    if (prtfile_read(a->in, &d, err)) goto done;
    if (strcmp(a->probe, "none") ? probe_load(a->probe, PROBE_AUTO, &probe, err) : probe_make_constant(black, &probe, err))
        goto done;
    scene_focus_bounds(&d.scene, b0, b1);
    camera_default(b0, b1, (float)a->w / (float)a->h, &rd.camera);
    if (!(rt = runtime_create(&d, &(runtime_desc){ .backend = "cpu" }, err)) ||
        runtime_set_light(rt, &probe, R, err) ||
        (d.scene.lights.count > 0 && runtime_set_local_lights(rt, &d.scene.lights, err)) ||
        runtime_render(rt, &rd, &img, err) ||
        image_write(a->out, &img, &(image_desc){ 0 }, err))
        goto done;
    rc = 0;
done:
    runtime_destroy(rt);
    image_free(&img);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}

int main(int argc, char **argv) {
    args a;
    int rc = parse(argc, argv, &a);
    if (rc) return rc;
    prt_error err = { { 0 } };
    if (relight(&a, &err)) {
        fprintf(stderr, "relight: %s\n", err.msg);
        return 1;
    }
    printf("wrote %s (%dx%d, probe %s turned %g degrees)\n", a.out, a.w, a.h, a.probe, a.angle);
    return 0;
}
