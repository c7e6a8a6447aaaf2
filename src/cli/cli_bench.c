/* cli_bench.c - `prt bench`: CPU runtime frame times for a .prt file.
 *
 * Light change = the sparse inner products T x L for every transport vector
 * (Eq. 5's light-dependent K-vectors); view change = view-map lookups and the
 * K-term dot product per vertex. Both produce vertex colours only (no raster,
 * no image write), which is what the paper's Table II measures. Each is timed
 * over many repetitions (rotating the light / orbiting the eye so no call is
 * a repeat), and the median is reported. */
#include "cli.h"
#include "cli_args.h"
#include "prtfile.h"
#include "relight.h"
#include "render.h"
#include "transfer.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *k_cmd = "bench";

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int cli_bench(int argc, char **argv) {
    const char *in = NULL, *probe_path = NULL;
    int frames = 40, nthreads = 0, kmax = 0;
    const cli_option opts[] = {
        CLI_S("--probe", &probe_path),
        CLI_I("--frames", &frames, 1, 100000),
        CLI_I("--terms", &kmax, 1, 64),
        CLI_I("--threads", &nthreads, 1, 64),
        CLI_END,
    };
    int npos = 0, pr = cli_parse(k_cmd, argc, argv, opts, &in, 1, &npos);
    if (pr == 1) {
        puts("usage: prt bench FILE.prt --probe PROBE [--frames N] [--terms K] [--threads T]\n\n"
             "Times CPU light changes (sparse T x L) and view changes (view maps . g) on vertex colours,\n"
             "median over N frames (default 40), and prints frames per second.");
        return 0;
    }
    if (pr) return 2;
    if (!in || !probe_path) { cli_error(k_cmd, "usage: prt bench FILE.prt --probe PROBE"); return 2; }
    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (prtfile_read(in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    prt_probe probe;
    memset(&probe, 0, sizeof probe);
    if (cli_load_probe(k_cmd, probe_path, NULL, &probe)) { prt_data_free(&d); return 1; }
    int nL = 4;
    float (*Ls[4])[4] = { 0 };
    double t_lv = prt_now();
    for (int i = 0; i < nL; i++) {
        float R[9];
        char rot[32];
        snprintf(rot, sizeof rot, "%d", 90 * i);
        probe_parse_rotation(rot, R);
        float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        if (cube) { probe_to_cube(&probe, CUBE_RES, R, 0, cube); Ls[i] = transfer_light_vector(&d, cube); }
        free(cube);
    }
    t_lv = (prt_now() - t_lv) / nL;
    relight_ctx *rc = relight_create(&d, nthreads, &err);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);
    double *tl = malloc(sizeof(double) * frames), *tv = malloc(sizeof(double) * frames);
    if (!rc || !rgb || !tl || !tv || !Ls[nL - 1]) { cli_error(k_cmd, "%s", rc ? "out of memory" : err.msg); return 1; }
    prt_camera cam;
    cli_camera(k_cmd, &d.scene, 4.f / 3, NULL, &cam);   /* no --camera: cannot fail */
    relight_set_light(rc, Ls[0]); /* warm-up */
    relight_view(rc, cam.eye, kmax, rgb);
    for (int f = 0; f < frames; f++) {
        double t = prt_now();
        relight_set_light(rc, Ls[f % nL]);
        tl[f] = prt_now() - t;
    }
    float c[3] = { 0.5f * (d.scene.bmin[0] + d.scene.bmax[0]), 0.5f * (d.scene.bmin[1] + d.scene.bmax[1]),
                   0.5f * (d.scene.bmin[2] + d.scene.bmax[2]) };
    float dx = cam.eye[0] - c[0], dz = cam.eye[2] - c[2];
    for (int f = 0; f < frames; f++) {
        float a = 6.2831853f * f / frames;
        float eye[3] = { c[0] + dx * cosf(a) - dz * sinf(a), cam.eye[1], c[2] + dx * sinf(a) + dz * cosf(a) };
        double t = prt_now();
        relight_view(rc, eye, kmax, rgb);
        tv[f] = prt_now() - t;
    }
    qsort(tl, frames, sizeof(double), cmp_double);
    qsort(tv, frames, sizeof(double), cmp_double);
    double ml = tl[frames / 2], mv = tv[frames / 2];
    int K = 0;
    for (int m = 0; m < d.scene.nmaterials; m++) K = d.factors[m].K > K ? d.factors[m].K : K;
    printf("file %s: %d vertices, %d vectors (max K = %d), N = %d, %d-bit, threads %d\n", in, d.scene.mesh.nverts,
           d.transfers[0].transport.nvecs, kmax ? kmax : K, d.transfers[0].transport.N, d.transfers[0].transport.qbits, prt_thread_count(nthreads));
    printf("light vector (probe -> cube -> Haar): %.1f ms\n", 1e3 * t_lv);
    printf("light change: %.2f ms median (%.1f fps), min %.2f ms\n", 1e3 * ml, 1 / ml, 1e3 * tl[0]);
    printf("view change:  %.2f ms median (%.1f fps), min %.2f ms\n", 1e3 * mv, 1 / mv, 1e3 * tv[0]);
    for (int i = 0; i < nL; i++) free(Ls[i]);
    free(tl);
    free(tv);
    free(rgb);
    relight_destroy(rc);
    probe_free(&probe);
    prt_data_free(&d);
    return 0;
}
