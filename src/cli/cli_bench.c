/* cli_bench.c - `prt bench`: light-change and view-change times of a .prt file on
 * one runtime backend (--backend, a name of runtime.h's table), the quantities of
 * the paper's Table II.
 *
 * Light change = the sparse inner products T x L for every transport vector
 * (Eq. 5's light-dependent K-vectors); view change = the backend's own view
 * change: the cpu backend's h(view) . g per vertex (vertex colours, no raster:
 * what Table II's CPU rows measure), the gl backend's frame of --size pixels
 * (view maps per pixel, finished). Both go through the runtime interface
 * (runtime.h) and are read from runtime_timing, so every backend reports the
 * same lines. Each is timed over many frames (rotating the light / orbiting the
 * eye so no call is a repeat) after one warm-up, and the median is reported. The light vector is
 * timed twice: of the probe resampled as it is (probe_to_cube, what a single light change costs), and
 * of the probe prepared once and lent (runtime.h: its fine cube resampled under each rotation, what a
 * turning probe costs in the viewer), which the light changes then use. */
#include "cli.h"
#include "cli_args.h"
#include "prtfile.h"
#include "runtime.h"
#include <math.h>
#include <stdlib.h>
#include <time.h>
#include <string.h>

static const char *k_cmd = "bench";

typedef struct bench_args {
    const char *in, *probe_path, *backend, *kernel;
    int frames, nthreads, kmax, size[2];
    int hl_samples;          /* --highlights / --highlight-samples (0: none) */
    bool bounce;             /* --local-bounce */
} bench_args;

static void help(void) {
    fputs("usage: prt bench FILE.prt --probe PROBE [--backend B] [--frames N] [--size WxH] [--terms K]\n"
          "                 [--threads T] [--kernel K]\n"
          "\n"
          "Times light changes (sparse T x L for every vector) and view changes, median over N frames\n"
          "(default 40), and prints frame rates (the paper's Table II: GeForce 6800 / Pentium 4, Bunny).\n"
          "The view change is the backend's own frame of --size pixels (default 800x600), finished: the\n"
          "vertex colours h(view) . g of a backend that shades per vertex (no raster), the per-pixel view\n"
          "maps of one that shades per pixel.\n"
          "GL runs headless (OSMesa, or EGL on an NVIDIA machine; PRT_GL=osmesa|egl overrides).\n"
          "\n"
          "  --probe PROBE    light probe\n", stdout);
    cli_backend_help(19, 0, runtime_backend_at(0)->name);
    fputs("  --frames N       timed repetitions of each measurement (default 40)\n"
          "  --size WxH       frame size of per-pixel view changes and the camera's aspect (default 800x600)\n"
          "  --terms K        BRDF terms used in view changes (default: all)\n"
          "  --threads T      CPU threads (default: all cores)\n"
          "  --kernel K       the backend's light kernel, its default first:", stdout);
    for (int i = 0; i < runtime_backend_count(); i++)
        printf("%s %s: %s", i ? ";" : "", runtime_backend_at(i)->name, runtime_backend_at(i)->kernels);
    puts("\n"
         "  --light SPEC     add a local light (as prt render; repeatable); with local lights, also times\n"
         "                   light moves (the first light on a small circle: shadows again) and the view\n"
         "                   change includes their direct light, one bounce (VSGLs) and indirect highlights\n"
         "  --no-file-lights ignore the lights stored in the file\n"
         CLI_INDIRECT_HELP);
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Parses argv into a; returns -1 to go on, else the exit status. */
static int parse_args(int argc, char **argv, bench_args *a) {
    memset(a, 0, sizeof *a);
    a->frames = 40;
    a->size[0] = 800;
    a->size[1] = 600;
    a->backend = runtime_backend_at(0)->name;
    const cli_option opts[] = {
        CLI_S("--probe", &a->probe_path), CLI_S("--backend", &a->backend), CLI_S("--kernel", &a->kernel),
        CLI_I("--frames", &a->frames, 1, 100000), CLI_WH("--size", a->size), CLI_I("--terms", &a->kmax, 1, 64),
        CLI_I("--threads", &a->nthreads, 1, 64), CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &a->in, 1, &npos);
    if (pr == 1) { help(); return 0; }
    if (pr) return 2;
    if (!a->in || !a->probe_path) { cli_error(k_cmd, "usage: prt bench FILE.prt --probe PROBE"); return 2; }
    if (!cli_backend(k_cmd, a->backend, 0, NULL)) return 2;
    cli_inputs ins = { 0 };   /* bench writes nothing: only a directory among the inputs is refused */
    cli_inputs_add(&ins, NULL, a->in);
    cli_inputs_add(&ins, "--probe", a->probe_path);
    return cli_check_files(k_cmd, NULL, 0, &ins) ? 2 : -1;
}

/* Light changes under the probe yawed by 0, 90, 180, 270 degrees in turn: medians into ms[0] (light
 * change) and ms[1] (light vector), the minimum into ms[2], the mean GPU time into ms[3]; t holds
 * 2 frames. */
static int time_light(prt_runtime *rt, const prt_probe *probe, int frames, double *t, double ms[4], prt_error *err) {
    float R[4][9];
    for (int i = 0; i < 4; i++) {
        char rot[32];
        snprintf(rot, sizeof rot, "%d", 90 * i);
        probe_parse_rotation(rot, R[i]);
    }
    double gpu = 0, *lv = t + frames;
    for (int f = 0; f < frames; f++) {
        if (runtime_set_light(rt, probe, R[f % 4], err)) return -1;
        runtime_timing tm;
        runtime_get_timing(rt, &tm);
        t[f] = tm.light_ms;
        lv[f] = tm.light_vector_ms;
        gpu += tm.light_gpu_ms;
    }
    qsort(t, frames, sizeof(double), cmp_double);
    qsort(lv, frames, sizeof(double), cmp_double);
    ms[0] = t[frames / 2];
    ms[1] = lv[frames / 2];
    ms[2] = t[0];
    ms[3] = gpu / frames;
    return 0;
}

/* The light vector alone of the probe turned by yaw 0, 90, 180, 270 in turn, 8 times: the median into
 * *ms. The rotated cube is made from the probe itself unless a prepared probe is lent (runtime.h). */
static int time_light_vector(prt_runtime *rt, const prt_probe *probe, double *ms, prt_error *err) {
    double t[8];
    for (int f = 0; f < 8; f++) {
        float R[9];
        probe_rotation(90.0 * (f % 4), 0, R);
        if (runtime_set_light(rt, probe, R, err)) return -1;
        runtime_timing tm;
        runtime_get_timing(rt, &tm);
        t[f] = tm.light_vector_ms;
    }
    qsort(t, 8, sizeof(double), cmp_double);
    *ms = t[4];
    return 0;
}

/* View changes orbiting the eye once around the scene's centre: as time_light. */
static int time_view(prt_runtime *rt, const prt_data *d, const render_desc *rd0, int frames, double *t, double ms[4],
                     prt_error *err) {
    render_desc rd = *rd0;
    const float *e = rd0->camera.eye;
    float c[3] = { 0.5f * (d->scene.bmin[0] + d->scene.bmax[0]), 0.5f * (d->scene.bmin[1] + d->scene.bmax[1]),
                   0.5f * (d->scene.bmin[2] + d->scene.bmax[2]) };
    float dx = e[0] - c[0], dz = e[2] - c[2];
    double gpu = 0;
    for (int f = 0; f < frames; f++) {
        float a = 6.2831853f * f / frames;
        float eye[3] = { c[0] + dx * cosf(a) - dz * sinf(a), e[1], c[2] + dx * sinf(a) + dz * cosf(a) };
        memcpy(rd.camera.eye, eye, sizeof eye);
        if (runtime_render(rt, &rd, NULL, err)) return -1;
        runtime_timing tm;
        runtime_get_timing(rt, &tm);
        t[f] = tm.view_ms;
        gpu += tm.view_gpu_ms;
        ms[1] += tm.indirect_view_ms / frames;
    }
    qsort(t, frames, sizeof(double), cmp_double);
    ms[0] = t[frames / 2];
    ms[2] = t[0];
    ms[3] = gpu / frames;
    return 0;
}

/* Local-light moves: the first light on a circle of 5% of the scene's size around its place, frames
 * times; medians into ms[0], the mean one bounce into ms[1], the minimum into ms[2], and the
 * process's CPU time per move (clock(): every thread's, so a loaded machine's wall clock does not
 * hide what a move costs) into ms[3]. The lights are put back after. */
static int time_local(prt_runtime *rt, const prt_data *d, int frames, double *t, double ms[4], prt_error *err) {
    prt_lights ls = d->scene.lights;
    float r = 0.05f * fmaxf(d->scene.bmax[0] - d->scene.bmin[0], d->scene.bmax[2] - d->scene.bmin[2]);
    const float *p0 = d->scene.lights.light[0].pos;
    clock_t c0 = clock();
    for (int f = 0; f < frames; f++) {
        float a = 6.2831853f * f / frames;
        ls.light[0].pos[0] = p0[0] + r * cosf(a);
        ls.light[0].pos[2] = p0[2] + r * sinf(a);
        if (runtime_set_local_lights(rt, &ls, err)) return -1;
        runtime_timing tm;
        runtime_get_timing(rt, &tm);
        t[f] = tm.local_ms;
        ms[1] += tm.bounce_ms / frames;
    }
    ms[3] = 1e3 * (double)(clock() - c0) / CLOCKS_PER_SEC / frames;
    qsort(t, frames, sizeof(double), cmp_double);
    ms[0] = t[frames / 2];
    ms[2] = t[0];
    return runtime_set_local_lights(rt, &d->scene.lights, err);
}

/* "12.3 fps" of a median of ms into buf (32 bytes), or "no time" (a backend that draws nothing). */
static const char *fps(char *buf, double ms) {
    if (ms > 0) snprintf(buf, 32, "%.1f fps", 1e3 / ms);
    else snprintf(buf, 32, "no time");
    return buf;
}

/* Prints the results: the same lines for every backend (tools/bench.sh parses "light change" and
 * "view change"; tools/bench_gl.sh the "bench:" line). */
static void report(const bench_args *a, const prt_data *d, const runtime_timing *tm, const double lm[4], const double vm[4],
                   const double km[4], const double lv[2], const runtime_probe *rp) {
    int K = 0;
    for (int m = 0; m < d->scene.nmaterials; m++) K = d->factors[m].K > K ? d->factors[m].K : K;
    int kuse = a->kmax && a->kmax < K ? a->kmax : K;
    printf("file %s: %d vertices, %d vectors (max K = %d), N = %d, %d-bit\n", a->in, d->scene.mesh.nverts,
           prt_data_transfer(d)->transport.nvecs, kuse, prt_data_transfer(d)->transport.N, prt_data_transfer(d)->transport.qbits);
    for (int i = 0; i < d->ntransfers; i++) {   /* several transfers: each one's materials and bytes */
        const prt_transfer *tr = &d->transfers[i];
        char desc[256];
        tr->ops->describe(&tr->cfg, desc, sizeof desc);
        printf("transfer %d: %s; material mask 0x%llx%s", i, desc, (unsigned long long)tr->materials, tr->ops->bytes ? "" : "\n");
        if (tr->ops->bytes) printf(", %.2f MB\n", tr->ops->bytes(tr) / 1e6);
    }
    printf("backend %s: %s; light kernel %s%s%s%s\n", tm->backend, tm->device, tm->kernel, tm->detail[0] ? " (" : "",
           tm->detail, tm->detail[0] ? ")" : "");
    printf("light vector (probe -> cube -> light vector): %.1f ms median\n", lv[0]);
    printf("light vector of a turning probe (its fine cube, made once in %.0f ms -> cube -> light vector): %.1f ms median\n",
           rp->ms, lm[1]);
    char f[3][32];
    printf("light change: %.2f ms median (%s), min %.2f ms\n", lm[0], fps(f[0], lm[0]), lm[2]);
    printf("view change:  %.2f ms median (%s), min %.2f ms\n", vm[0], fps(f[1], vm[0]), vm[2]);
    if (d->scene.lights.count > 0)
        printf("local light move (%d light%s, shadows): %.2f ms median (%s), min %.2f ms; CPU time %.2f ms a move\n",
               d->scene.lights.count, d->scene.lights.count == 1 ? "" : "s", km[0], fps(f[2], km[0]), km[2], km[3]);
    if (km[1] > 0 || vm[1] > 0)   /* the one bounce, the highlights (cpu: indirect.h) */
        printf("local indirect: one bounce (RSM + 2 VSGLs per light) %.2f ms of the move, %s %.2f ms of the view change "
               "(means)\n", km[1], runtime_backend_find(tm->backend)->indirect_view, vm[1]);
    if (lm[3] > 0 || vm[3] > 0) {   /* a light change with no GPU time ran on the CPU (gl's kernel "cpu") */
        char lc[64] = "none (on the CPU)";
        if (lm[3] > 0) snprintf(lc, sizeof lc, "%.2f ms", lm[3]);
        printf("GPU timer: light change %s, view change %.2f ms (mean)\n", lc, vm[3]);
    }
    printf("bench: backend=%s K=%d light_ms=%.3f view_ms=%.3f kernel=%s\n", tm->backend, kuse, lm[0], vm[0], tm->kernel);
    printf("paper, Table II (Bunny, 36K + 31K floor vertices, GeForce 6800 / Pentium 4 2.4 GHz):\n"
           "  GPU 1-term: light change 31 fps, view change 226 fps\n"
           "  CPU 1-term: light change 12 fps, view change 79 fps\n"
           "  CPU 4-term: light change 4.8 fps, view change 62 fps (GPU 4-term view change 97 fps)\n");
}

/* The probe prepared once (its fine cube, its prefiltered ladder) and lent to rt, so that the timed
 * light changes rotate it as the viewer does (runtime.h). -1 with err. */
static int prepare_lend(prt_runtime *rt, const prt_data *d, const prt_probe *probe, int threads, runtime_probe *rp,
                        prt_error *err) {
    if (runtime_probe_prepare(d, probe, threads, rp, err)) return -1;
    runtime_lend_probe(rt, rp);
    return 0;
}

/* Creates the runtime, warms it up (one light and one view change), times the light vector of the
 * probe as it is, then of the prepared probe, and the light and view changes; reports. 0 or 1. */
static int run(const bench_args *a, const prt_data *d, const prt_probe *probe) {
    prt_error err = { { 0 } };
    runtime_desc desc = { .backend = a->backend, .threads = a->nthreads, .terms = a->kmax, .kernel = a->kernel,
                          .highlight_samples = a->hl_samples, .local_bounce = a->bounce };
    double *t = malloc(sizeof(double) * 2 * a->frames), lm[4] = { 0 }, vm[4] = { 0 }, km[4] = { 0 };
    prt_runtime *rt = t ? runtime_create(d, &desc, &err) : NULL;
    if (!t) prt_fail(&err, "out of memory");
    int rc = 1;
    prt_camera cam;
    if (rt) cli_camera(k_cmd, &d->scene, (float)a->size[0] / a->size[1], NULL, NULL, &cam); /* no --camera: cannot fail */
    render_desc rd = { .width = a->size[0], .height = a->size[1], .camera = cam, .background = probe };
    bool local = d->scene.lights.count > 0;
    runtime_probe rp = { 0 };
    double lv[2] = { 0 };
    if (rt && runtime_set_light(rt, probe, NULL, &err) == 0 && time_light_vector(rt, probe, &lv[0], &err) == 0 &&
        prepare_lend(rt, d, probe, a->nthreads, &rp, &err) == 0 &&
        (!local || runtime_set_local_lights(rt, &d->scene.lights, &err) == 0) && runtime_render(rt, &rd, NULL, &err) == 0 &&
        time_light(rt, probe, a->frames, t, lm, &err) == 0 && time_view(rt, d, &rd, a->frames, t, vm, &err) == 0 &&
        (!local || time_local(rt, d, a->frames, t, km, &err) == 0)) {
        runtime_timing tm;
        runtime_get_timing(rt, &tm);
        report(a, d, &tm, lm, vm, km, lv, &rp);
        rc = 0;
    } else cli_error(k_cmd, "%s", err.msg);
    runtime_destroy(rt);
    runtime_probe_free(&rp);
    free(t);
    return rc;
}

/* Entry point of `prt bench` (see cli.h). */
int cli_bench(int argc, char **argv) {
    bench_args a;
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
    if (prtfile_read(a.in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    int lr2 = cli_apply_lights(k_cmd, &d.scene, &extra, no_file_lights);
    if (lr2) {
        prt_data_free(&d);
        return lr2;
    }
    cli_indirect_resolve(&ind, &d, false, &a.hl_samples, &a.bounce);
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    int rc = 1;
    if (cli_load_probe(k_cmd, a.probe_path, NULL, &probe) == 0) rc = run(&a, &d, &probe);
    probe_free(&probe);
    prt_data_free(&d);
    return rc;
}
