/* cli_args.c - argument helpers for the prt subcommands (see cli_args.h). */
#include "cli_args.h"
#include "runtime.h"
#include "image.h"
#include "effects.h"
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <cjson/cJSON.h>

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
    if (!strcmp(path, "none")) {   /* local lights alone (a black environment) */
        static const float black[3] = { 0, 0, 0 };
        return probe_make_constant(black, out, &err) ? cli_error(cmd, "%s", err.msg) : 0;
    }
    if (probe_load(path, lay, out, &err)) return cli_error(cmd, "%s", err.msg);
    /* a few tiny negatives (lossy compression) change nothing visible: said only when they hold light */
    if (out->clamped_negative && out->clamped_negative_share > PROBE_NEGATIVE_NOTE) {
        double pc = 100 * out->clamped_negative_share;
        fprintf(stderr, "warning: %s: %ld texel(s) with negative values clamped to 0: %.*f%% of the probe's light "
                        "(by solid angle) was negative\n", path, out->clamped_negative, pc >= 10 ? 0 : pc >= 1 ? 1 : 2, pc);
    }
    if (out->clamped_nonfinite)
        fprintf(stderr, "warning: %s: %ld texel(s) with NaN or Inf clamped to 0\n", path, out->clamped_nonfinite);
    /* Accepted (a quick look is a fair use), but said: an integer probe clips at 1, so the sun is no
     * brighter than a white sky, and the image comes out flat and shadowless (README "Light probes"). */
    if (out->img.ldr)
        fprintf(stderr, "warning: %s: low dynamic range probe (integer pixels, clipped at 1): the sun is no brighter "
                        "than the sky and casts almost no shadow; use an HDR probe (EXR, HDR, PFM)\n", path);
    return 0;
}

void cli_inputs_add(cli_inputs *ins, const char *role, const char *path) {
    if (!path || !*path || !strcmp(path, "none")) return;   /* "none": --probe none reads no file */
    if (ins->n == ins->cap) {
        int cap = ins->cap ? 2 * ins->cap : 8;
        char **p = realloc(ins->path, sizeof *p * (size_t)cap);
        if (p) ins->path = p;
        char **r = realloc(ins->role, sizeof *r * (size_t)cap);
        if (r) ins->role = r;
        if (!p || !r) { ins->oom = true; return; }
        ins->cap = cap;
    }
    char *pc = strdup(path), *rc = role ? strdup(role) : NULL;
    if (!pc || (role && !rc)) {
        free(pc);
        free(rc);
        ins->oom = true;
        return;
    }
    ins->path[ins->n] = pc;
    ins->role[ins->n++] = rc;
}

void cli_inputs_add_list(cli_inputs *ins, const char *role, const char *list) {
    for (const char *s = list; s && *s;) {
        size_t len = strcspn(s, ",");
        char path[4096];
        if (len > 0 && len < sizeof path) {
            memcpy(path, s, len);
            path[len] = 0;
            cli_inputs_add(ins, role, path);
        }
        s += len + (s[len] == ',');
    }
}

/* A path the JSON file json names (rel), as scene_load resolves it: relative to json's folder. */
static void json_add(cli_inputs *ins, const char *json, const char *what, const cJSON *rel) {
    if (!cJSON_IsString(rel) || !rel->valuestring[0]) return;
    const char *slash = strrchr(json, '/'), *base = slash ? slash + 1 : json;
    char path[8192], role[4200];
    if (rel->valuestring[0] == '/' || !slash) snprintf(path, sizeof path, "%s", rel->valuestring);
    else snprintf(path, sizeof path, "%.*s/%s", (int)(slash - json), json, rel->valuestring);
    snprintf(role, sizeof role, "%s named by %s", what, base);
    cli_inputs_add(ins, role, path);
}

void cli_inputs_add_scene(cli_inputs *ins, const char *path) {
    cli_inputs_add(ins, NULL, path);
    char ext[16];
    prt_path_ext(path, ext);
    struct stat st;
    if (strcmp(ext, "json") || stat(path, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size > (64 << 20)) return;
    FILE *f = fopen(path, "rb");
    char *text = f ? malloc((size_t)st.st_size + 1) : NULL;
    size_t len = text ? fread(text, 1, (size_t)st.st_size, f) : 0;
    if (f) fclose(f);
    cJSON *root = text ? cJSON_ParseWithLength(text, len) : NULL;
    free(text);
    const cJSON *m, *lp = cJSON_GetObjectItemCaseSensitive(root, "light_prior"), *it;
    cJSON_ArrayForEach(m, cJSON_GetObjectItemCaseSensitive(root, "models"))
        json_add(ins, path, "a model", cJSON_GetObjectItemCaseSensitive(m, "obj"));
    if (cJSON_IsArray(lp)) cJSON_ArrayForEach(it, lp) json_add(ins, path, "a light_prior probe", it);
    else json_add(ins, path, "the light_prior probe", lp);
    cJSON_Delete(root);
}

void cli_inputs_free(cli_inputs *ins) {
    for (int i = 0; i < ins->n; i++) {
        free(ins->path[i]);
        free(ins->role[i]);
    }
    free(ins->path);
    free(ins->role);
    memset(ins, 0, sizeof *ins);
}

/* " (ROLE)" of a role, "" of none, into buf[cap]. */
static const char *role_note(const char *role, char *buf, size_t cap) {
    if (role) snprintf(buf, cap, " (%s)", role);
    else buf[0] = 0;
    return buf;
}

/* cli_check_files's checks (not the cleaning): 0, or the exit status after printing one line. */
static int check_files(const char *cmd, const cli_output *outs, int nout, const cli_inputs *ins) {
    static const char *const k_exts[][9] = {
        [CLI_OUT_IMAGE] = { "png", "exr", "hdr", "tif", "tiff", "jpg", "jpeg", "ppm", NULL },   /* image_write's */
        [CLI_OUT_PRT] = { "prt", NULL },
        [CLI_OUT_CSV] = { "csv", NULL },
    };
    char r1[4300], r2[4300];
    if (ins->oom) return cli_error(cmd, "out of memory listing the input files");
    for (int o = 0; o < nout; o++) {
        const char *out = outs[o].path;
        prt_error err = { { 0 } };
        if (!out) continue;
        for (int i = 0; i < ins->n; i++)
            if (prt_same_file(out, ins->path[i]))
                return cli_error(cmd, "output %s%s is the same file as the input %s%s; refusing to overwrite an input "
                                      "(choose another output name)", out, role_note(outs[o].role, r1, sizeof r1),
                                 ins->path[i], role_note(ins->role[i], r2, sizeof r2)) + 1;
        for (int p = 0; p < o; p++)
            if (outs[p].path && prt_same_file(out, outs[p].path))
                return cli_error(cmd, "outputs %s%s and %s%s are the same file (give each its own name)", outs[p].path,
                                 role_note(outs[p].role, r1, sizeof r1), out, role_note(outs[o].role, r2, sizeof r2)) + 1;
        /* after the collisions: `-o spider.obj` over its input is that, before it is a wrong extension */
        if (prt_output_check(out, outs[o].kind == CLI_OUT_ANY ? NULL : k_exts[outs[o].kind], &err))
            return cli_error(cmd, "%s", err.msg) + 1;
    }
    struct stat st;
    for (int i = 0; i < ins->n; i++)
        if (stat(ins->path[i], &st) == 0 && S_ISDIR(st.st_mode))
            return cli_error(cmd, "%s%s is a directory, not a file", ins->path[i], role_note(ins->role[i], r1, sizeof r1)) + 1;
    return 0;
}

int cli_check_files(const char *cmd, const cli_output *outs, int nout, cli_inputs *ins) {
    int rc = check_files(cmd, outs, nout, ins);
    cli_inputs_free(ins);
    for (int o = 0; o < nout && !rc; o++) {
        char first[4200];
        int n = outs[o].path ? prt_atomic_clean(outs[o].path, first, sizeof first) : 0;
        if (n) fprintf(stderr, "prt %s: removed %d stale temporary file(s) of killed runs (%s)\n", cmd, n, first);
    }
    return rc;
}

int cli_check_output(const char *cmd, const char *path, int kind) {
    const cli_output out = { NULL, path ? path : "", kind };
    cli_inputs none = { 0 };
    return cli_check_files(cmd, &out, 1, &none);
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
    /* a NaN target: an eye alone is not checked against the target here (that needs the scene's framing) */
    prt_camera c = { .target = { NAN, NAN, NAN }, .up = { 0, 1, 0 }, .fov_deg = 40 };
    const char *why = cam_s ? camera_parse_error(cam_s, &c) : NULL;
    if (why) return cli_error(cmd, "bad --camera '%s': %s", cam_s, why) + 1;
    return 0;
}

/* The scene's camera named name into out; 2 after printing one line listing the names when none is. */
static int named_camera(const char *cmd, const prt_scene *s, const char *name, prt_camera *out) {
    for (int i = 0; i < s->ncameras; i++)
        if (!strcmp(s->cameras[i].name, name)) {
            *out = s->cameras[i].cam;
            return 0;
        }
    char list[1200] = "";
    for (int i = 0; i < s->ncameras; i++) {
        size_t at = strlen(list);
        snprintf(list + at, sizeof list - at, "%s'%s'", i ? ", " : "", s->cameras[i].name);
    }
    if (!s->ncameras) return cli_error(cmd, "--camera-name '%s': the file keeps no cameras (a glTF scene's are kept)", name) + 1;
    return cli_error(cmd, "--camera-name '%s': no camera of that name (the file's: %s)", name, list) + 1;
}

int cli_camera(const char *cmd, const prt_scene *s, float aspect, const char *cam_s, const char *cam_name, prt_camera *out) {
    float b0[3], b1[3];
    scene_focus_bounds(s, b0, b1);
    camera_default(b0, b1, aspect, out);
    if (cam_name && named_camera(cmd, s, cam_name, out)) return 2;
    if (!cam_name && s->ncameras > 0) *out = s->cameras[0].cam;
    const char *why = cam_s ? camera_parse_error(cam_s, out) : NULL;
    /* fine against a NaN target: an eye alone, on the target the framing picked */
    if (why && camera_parse_error(cam_s, &(prt_camera){ .target = { NAN, NAN, NAN }, .up = { 0, 1, 0 } }) == NULL)
        return cli_error(cmd, "--camera '%s': the eye and the target coincide: the eye is on the target the framing "
                              "picked (%g, %g, %g); move the eye or give a target (EX,EY,EZ,TX,TY,TZ)", cam_s,
                         out->target[0], out->target[1], out->target[2]) + 1;
    if (why) return cli_error(cmd, "bad --camera '%s': %s", cam_s, why) + 1;
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
int cli_take_indirect(const char *cmd, int *argc, char **argv, cli_indirect *out) {
    out->bounce = out->samples = -1;
    int n = 1;
    for (int i = 1; i < *argc; i++) {
        if (!strcmp(argv[i], "--highlights")) { out->samples = out->samples > 0 ? out->samples : 32; continue; }
        if (!strcmp(argv[i], "--no-highlights")) { out->samples = 0; continue; }
        if (!strcmp(argv[i], "--local-bounce")) { out->bounce = 1; continue; }
        if (!strcmp(argv[i], "--no-local-bounce")) { out->bounce = 0; continue; }
        if (strcmp(argv[i], "--highlight-samples")) { argv[n++] = argv[i]; continue; }
        char *end = NULL;
        long v = i + 1 < *argc ? strtol(argv[i + 1], &end, 10) : 0;
        if (i + 1 >= *argc || !end || *end || end == argv[i + 1] || v < 1 || v > 1024)
            return cli_error(cmd, "--highlight-samples needs a whole number in [1, 1024]") + 1;
        out->samples = (int)v;
        i++;
    }
    *argc = n;
    argv[n] = NULL;
    return 0;
}

void cli_indirect_resolve(const cli_indirect *in, const prt_data *d, bool quiet, int *samples, bool *bounce) {
    prt_effects fx;
    prt_file_effects(d, &fx);
    *bounce = in->bounce >= 0 ? in->bounce == 1 : fx.local_bounce;
    *samples = in->samples >= 0 ? in->samples : fx.highlights ? 32 : 0;
    bool by_file = (in->bounce < 0 && *bounce) || (in->samples < 0 && *samples);
    if (!quiet && by_file)
        fprintf(stderr, "local lights: one bounce %s, indirect highlights %s (the effects the file was made for; "
                        "--no-local-bounce, --no-highlights turn them off)\n", *bounce ? "on" : "off", *samples ? "on" : "off");
}

/* The scene's lights become its file's (unless no_file) followed by extra. */
int cli_apply_lights(const char *cmd, prt_scene *s, const prt_lights *extra, bool no_file) {
    if (no_file) s->lights.count = 0;
    prt_error err = { { 0 } };
    for (int i = 0; i < extra->count; i++)
        if (lights_add(&s->lights, &extra->light[i], "--light", &err)) return cli_error(cmd, "%s", err.msg) + 1;
    return 0;
}

const runtime_backend_info *cli_backend(const char *cmd, const char *name, unsigned need, const char *what) {
    const runtime_backend_info *b = runtime_backend_find(name);
    char names[256];
    runtime_backend_names(names, sizeof names, need);
    if (!b) cli_error(cmd, "unknown --backend '%s' (%s)", name, names);
    else if ((b->caps & need) != need) cli_error(cmd, "--backend %s: the %s backend cannot %s (%s can)", name, name, what, names);
    else return b;
    return NULL;
}

void cli_backend_help(int col, unsigned need, const char *dflt) {
    char names[256];
    printf("  %-*s%s (default %s)\n", col - 2, "--backend B", runtime_backend_names(names, sizeof names, need), dflt);
    for (int i = 0; i < runtime_backend_count(); i++) {
        const runtime_backend_info *b = runtime_backend_at(i);
        if ((b->caps & need) == need)
            printf("%*s%-5s %s%s\n", col + 2, "", b->name, b->summary,
                   b->caps & RUNTIME_CAP_IMAGES ? "" : " (no images in this build: no GL)");
    }
}

/* See cli_args.h. */
float cli_exposure(float given, const prt_probe *probe, const float R[9], const char *out) {
    if (isfinite(given)) return given;
    float e = probe ? probe_exposure(probe, R) : 0;
    if (out && image_tonemapped(out))
        fprintf(stderr, "exposure %+.1f stops (from the probe: a white surface facing up shows as white; --exposure sets it)\n", e);
    return e;
}
