/* cli_args.c - argument helpers for the prt subcommands (see cli_args.h). */
#include "cli_args.h"
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cli_error(const char *cmd, const char *fmt, ...) {
    va_list ap;
    fprintf(stderr, "prt %s: ", cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return 1;
}

int cli_opt(const char *cmd, int argc, char **argv, int *i, const char *name, const char **val) {
    if (strcmp(argv[*i], name) != 0) return 0;
    if (*i + 1 >= argc) { cli_error(cmd, "%s needs a value", name); return -1; }
    *val = argv[++*i];
    return 1;
}

bool cli_int(const char *cmd, const char *name, const char *s, int lo, int hi, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        cli_error(cmd, "bad value for %s: '%s' (expected an integer in %d..%d)", name, s, lo, hi);
        return false;
    }
    *out = (int)v;
    return true;
}

bool cli_float(const char *cmd, const char *name, const char *s, float lo, float hi, float *out) {
    char *end;
    errno = 0;
    float v = strtof(s, &end);
    if (errno || end == s || *end || !isfinite(v) || v < lo || v > hi) {
        cli_error(cmd, "bad value for %s: '%s' (expected a number in %g..%g)", name, s, lo, hi);
        return false;
    }
    *out = v;
    return true;
}

bool cli_size(const char *cmd, const char *s, int *w, int *h) {
    int a, b;
    char x, extra;
    if (sscanf(s, "%d%c%d%c", &a, &x, &b, &extra) != 3 || (x != 'x' && x != 'X') || a < 1 || b < 1 || a > 16384 ||
        b > 16384) {
        cli_error(cmd, "bad --size '%s' (expected WxH, e.g. 800x600)", s);
        return false;
    }
    *w = a;
    *h = b;
    return true;
}

bool cli_is_help(const char *a) { return !strcmp(a, "-h") || !strcmp(a, "--help"); }

/* Is a the value of an option whose value is optional (--floor [VERTS])? A number, or a word that
 * cannot be a file name (no '.' or '/'), so that `--floor abc` is a bad value, not a second input. */
static bool opt_value_like(const char *a) {
    if (a[0] >= '0' && a[0] <= '9') return true;
    return a[0] != '-' && a[0] && !strchr(a, '.') && !strchr(a, '/');
}

int cli_parse(const char *cmd, int argc, char **argv, const cli_option *opts, const char **pos, int maxpos, int *npos) {
    int n = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (cli_is_help(a)) return 1;
        const cli_option *o = NULL;
        for (const cli_option *p = opts; p && p->name; p++)
            if (!strcmp(a, p->name)) { o = p; break; }
        if (!o) {
            if (a[0] == '-' && a[1]) { cli_error(cmd, "unknown option '%s' (see --help)", a); return 2; }
            if (n >= maxpos) {
                if (maxpos == 1) cli_error(cmd, "more than one input file ('%s' and '%s')", pos[0], a);
                else cli_error(cmd, "unexpected argument '%s' (see --help)", a);
                return 2;
            }
            pos[n++] = a;
            continue;
        }
        if (o->set) *o->set = o->setval;
        if (o->kind == CLI_FLAG) { *(bool *)o->out = true; continue; }
        if (o->kind == CLI_SET) continue;
        if (o->kind == CLI_OPT_INT && !(i + 1 < argc && opt_value_like(argv[i + 1]))) continue;
        if (i + 1 >= argc) { cli_error(cmd, "%s needs a value", a); return 2; }
        const char *v = argv[++i];
        switch (o->kind) {
        case CLI_STR: *(const char **)o->out = v; break;
        case CLI_INT:
        case CLI_OPT_INT:
            if (!cli_int(cmd, a, v, (int)o->lo, (int)o->hi, (int *)o->out)) return 2;
            break;
        case CLI_FLOAT:
            if (!cli_float(cmd, a, v, (float)o->lo, (float)o->hi, (float *)o->out)) return 2;
            break;
        case CLI_SIZE:
            if (!cli_size(cmd, v, &((int *)o->out)[0], &((int *)o->out)[1])) return 2;
            break;
        default: break;
        }
    }
    *npos = n;
    return 0;
}

#include "cubemap.h"

int cli_load_probe(const char *cmd, const char *path, const char *layout, prt_probe *out) {
    probe_layout lay = PROBE_AUTO;
    if (layout && probe_parse_layout(layout, &lay) != 0)
        return cli_error(cmd, "unknown probe layout '%s' (latlong, angular, vcross, hcross, auto)", layout);
    prt_error err = { { 0 } };
    if (!strcmp(path, "none")) {   /* issue 11: local lights alone (a black environment) */
        static const float black[3] = { 0, 0, 0 };
        return probe_make_constant(black, out, &err) ? cli_error(cmd, "%s", err.msg) : 0;
    }
    if (probe_load(path, lay, out, &err)) return cli_error(cmd, "%s", err.msg);
    if (out->clamped_negative)
        fprintf(stderr, "warning: %s: %ld texel(s) with negative values clamped to 0\n", path, out->clamped_negative);
    if (out->clamped_nonfinite)
        fprintf(stderr, "warning: %s: %ld texel(s) with NaN or Inf clamped to 0\n", path, out->clamped_nonfinite);
    /* Accepted (a quick look is a fair use), but said: an integer probe clips at 1, so the sun is no
     * brighter than a white sky, and the image comes out flat and shadowless (README "Light probes"). */
    if (out->img.ldr)
        fprintf(stderr, "warning: %s: low dynamic range probe (integer pixels, clipped at 1): the sun is no brighter "
                        "than the sky and casts almost no shadow; use an HDR probe (EXR, HDR, PFM)\n", path);
    return 0;
}

int cli_check_output(const char *cmd, const char *path, int kind) {
    static const char *const k_image[] = { "png", "exr", "hdr", "tif", "tiff", "jpg", "jpeg", "ppm", NULL };
    prt_error err = { { 0 } };
    if (prt_output_check(path, kind == CLI_OUT_IMAGE ? k_image : NULL, &err)) return cli_error(cmd, "%s", err.msg) + 1;
    char first[4200];
    int n = prt_atomic_clean(path, first, sizeof first);
    if (n) fprintf(stderr, "prt %s: removed %d stale temporary file(s) of killed runs (%s)\n", cmd, n, first);
    return 0;
}

int cli_rotation(const char *cmd, const char *s, float R[9]) {
    if (!s) {
        for (int i = 0; i < 9; i++) R[i] = i % 4 == 0;
        return 0;
    }
    if (probe_parse_rotation(s, R) != 0)
        return cli_error(cmd, "bad --light-rotation '%s' (expected YAW or YAW,PITCH in degrees)", s);
    return 0;
}

int cli_check_view_flags(const char *cmd, const char *layout, const char *cam_s) {
    probe_layout lay;
    if (layout && probe_parse_layout(layout, &lay) != 0)
        return cli_error(cmd, "unknown probe layout '%s' (latlong, angular, vcross, hcross, auto)", layout) + 1;
    /* a NaN target: only the syntax is checked here (eye == target needs the scene's framing) */
    prt_camera c = { .target = { NAN, NAN, NAN }, .up = { 0, 1, 0 }, .fov_deg = 40 };
    if (cam_s && camera_parse(cam_s, &c) != 0)
        return cli_error(cmd, "bad --camera '%s' (expected EX,EY,EZ[,TX,TY,TZ[,FOV]])", cam_s) + 1;
    return 0;
}

int cli_camera(const char *cmd, const prt_scene *s, float aspect, const char *cam_s, prt_camera *out) {
    float b0[3], b1[3];
    scene_focus_bounds(s, b0, b1);
    camera_default(b0, b1, aspect, out);
    if (cam_s && camera_parse(cam_s, out) != 0)
        return cli_error(cmd, "bad --camera '%s' (expected EX,EY,EZ[,TX,TY,TZ[,FOV]])", cam_s);
    return 0;
}

/* Removes every "--light SPEC" and "--no-file-lights" from argv (argc shrinks), parsing the specs. */
int cli_take_lights(const char *cmd, int *argc, char **argv, prt_lights *extra, bool *no_file) {
    memset(extra, 0, sizeof *extra);
    *no_file = false;
    int n = 1;
    for (int i = 1; i < *argc; i++) {
        if (!strcmp(argv[i], "--no-file-lights")) { *no_file = true; continue; }
        if (strcmp(argv[i], "--light")) { argv[n++] = argv[i]; continue; }
        if (i + 1 >= *argc) return cli_error(cmd, "--light needs a value (point:pos=x,y,z;... or spot:...)") + 1;
        prt_error err = { { 0 } };
        prt_light l;
        if (light_parse(argv[++i], "--light", &l, &err) || lights_add(extra, &l, "--light", &err))
            return cli_error(cmd, "%s", err.msg) + 1;
    }
    *argc = n;
    argv[n] = NULL;
    return 0;
}

/* Removes the indirect-light flags from argv (argc shrinks), checking the sample count. */
int cli_take_indirect(const char *cmd, int *argc, char **argv, int *samples, bool *bounce) {
    *samples = 0;
    *bounce = false;
    int n = 1;
    for (int i = 1; i < *argc; i++) {
        if (!strcmp(argv[i], "--highlights")) { *samples = *samples ? *samples : 32; continue; }
        if (!strcmp(argv[i], "--local-bounce")) { *bounce = true; continue; }
        if (strcmp(argv[i], "--highlight-samples")) { argv[n++] = argv[i]; continue; }
        char *end = NULL;
        long v = i + 1 < *argc ? strtol(argv[i + 1], &end, 10) : 0;
        if (i + 1 >= *argc || !end || *end || end == argv[i + 1] || v < 1 || v > 1024)
            return cli_error(cmd, "--highlight-samples needs a whole number in [1, 1024]") + 1;
        *samples = (int)v;
        i++;
    }
    *argc = n;
    argv[n] = NULL;
    return 0;
}

/* The scene's lights become its file's (unless no_file) followed by extra. */
int cli_apply_lights(const char *cmd, prt_scene *s, const prt_lights *extra, bool no_file) {
    if (no_file) s->lights.count = 0;
    prt_error err = { { 0 } };
    for (int i = 0; i < extra->count; i++)
        if (lights_add(&s->lights, &extra->light[i], "--light", &err)) return cli_error(cmd, "%s", err.msg) + 1;
    return 0;
}
