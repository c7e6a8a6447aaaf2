/* cli_info.c - `prt info`: what a .prt file holds and what it cost to make. */
#include "cli.h"
#include "cli_args.h"
#include "prtfile.h"
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *k_cmd = "info";

/* This process's resident memory from /proc/self/status (kB): its own (RssAnon) and file pages
 * mapped (RssFile); false where there is no such file. */
static bool resident_kb(long *anon, long *file) {
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    *anon = *file = -1;
    while (f && fgets(line, sizeof line, f)) {
        if (!strncmp(line, "RssAnon:", 8)) *anon = atol(line + 8);
        if (!strncmp(line, "RssFile:", 8)) *file = atol(line + 8);
    }
    if (f) fclose(f);
    return *anon >= 0 && *file >= 0;
}

int cli_info(int argc, char **argv) {
    const char *in = NULL;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            puts("usage: prt info FILE.prt\n\nPrints sizes, vertices, BRDF terms per material with their singular values\n"
                 "and approximation error, coefficients kept, quantization, per-stage timings and the effects plan.");
            return 0;
        }
        if (argv[i][0] == '-' && argv[i][1]) { cli_error(k_cmd, "unknown option '%s'", argv[i]); return 2; }
        if (in) { cli_error(k_cmd, "more than one input file"); return 2; }
        in = argv[i];
    }
    if (!in) { cli_error(k_cmd, "no input .prt file"); return 2; }
    cli_inputs ins = { 0 };
    cli_inputs_add(&ins, NULL, in);
    if (cli_check_files(k_cmd, NULL, 0, &ins)) return 2;
    prt_error err = { { 0 } };
    prt_data d;
    memset(&d, 0, sizeof d);
    if (prtfile_read(in, &d, &err)) return cli_error(k_cmd, "%s", err.msg);
    struct stat st;
    double mb = stat(in, &st) == 0 ? st.st_size / 1e6 : 0;
    const prt_scene *s = &d.scene;
    /* The linear transfer when there is one: its transport lines; every transfer's basis line, and
     * the summary of those that have one. */
    const prt_transfer *tr = prt_data_transfer(&d);
    const prt_stats *ps = &d.stats;
    printf("file          %s (%.2f MB, format version %d)\n", in, mb, PRTFILE_VERSION);
    printf("geometry      %d vertices, %d triangles%s\n", s->mesh.nverts, s->mesh.ntris,
           s->floor_first_vertex >= 0 ? "" : ", no floor");
    if (s->floor_first_vertex >= 0)
        printf("              floor: %d vertices (from vertex %d)\n", s->mesh.nverts - s->floor_first_vertex,
               s->floor_first_vertex);
    printf("bounds        [%g %g %g] - [%g %g %g]\n", s->bmin[0], s->bmin[1], s->bmin[2], s->bmax[0], s->bmax[1],
           s->bmax[2]);
    for (int i = 0; i < d.ntransfers; i++) {
        char basis[256];
        d.transfers[i].ops->describe(&d.transfers[i].cfg, basis, sizeof basis);
        printf("%s%s", i ? "              " : "basis         ", basis);
        if (d.ntransfers > 1) printf(" (material mask 0x%llx)", (unsigned long long)d.transfers[i].materials);
        printf("\n");
    }
    if (tr) {
        const prt_transport *t = &tr->transport;
        char kept[96];
        if (t->budget) snprintf(kept, sizeof kept, "N = %d per vector shared (a vector up to %d)", t->budget, t->N);
        else snprintf(kept, sizeof kept, "N = %d kept per vector", t->N);
        printf("transport     %d vectors, %s, %s, %zu coefficients, %zu block runs, %.2f MB\n", t->nvecs, kept,
               t->qbits == 32 ? "float" : t->qbits == 16 ? "16-bit" : "8-bit", transport_ncoefs(t), transport_nruns(t),
               transport_bytes(t) / 1e6);
        printf("              truncation+quantization error %.3f%% (RMS relative L2)\n", 100 * ps->trunc_rel_err);
        if (tr->open_sky) {
            int split = 0, folded = 0;
            for (int v = 0; v < s->mesh.nverts; v++) split += tr->open_vert[v] != 0, folded += tr->open_vert[v] == OPENSKY_FOLDED;
            printf("open sky      added exactly at runtime; %d vertices store what occluders block, the rest whole\n", split);
            if (folded)
                printf("              %d of them the floor's, folded: without the cosine, which the light takes\n", folded);
        } else
            printf("open sky      not split (--no-open-sky): every vector whole\n");
    }
    for (int i = 0; i < d.ntransfers; i++)
        if (d.transfers[i].ops->summary) {
            char buf[2048];
            d.transfers[i].ops->summary(&d.transfers[i], buf, sizeof buf);
            fputs(buf, stdout);
        }
    printf("visibility    %dx%dx6 cube, 2x2 box-filtered to 64x64x6; %.1f%% of rays hit geometry\n", d.vis_res,
           d.vis_res, 100 * ps->hit_fraction);
    printf("materials     %d\n", s->nmaterials);
    for (int m = 0; m < s->nmaterials; m++) {
        const brdf_factor *f = &d.factors[m];
        int nv = 0;
        for (int v = 0; v < s->mesh.nverts; v++) nv += s->mesh.mat[v] == m;
        printf("  [%d] %s\n      %d vertices, K = %d term%s (%s, %dx%d, %s), rel. BRDF error with K terms %.2f%%\n", m,
               s->material_spec[m], nv, f->K, f->K == 1 ? "" : "s", f->lambertian ? "Lambertian" : "glossy", f->res,
               f->res, f->param == BRDF_PARAM_POLAR ? "polar Eq. 11" : "grid Eq. 10",
               100 * f->rel_rms[f->K < f->nsigma ? f->K : f->nsigma]);
        printf("      error vs K:");
        for (int k = 1; k <= f->nsigma && k <= 16; k *= 2) printf("  K=%d %.2f%%", k, 100 * f->rel_rms[k]);
        printf("\n      singular values (R):");
        for (int k = 0; k < f->nsigma && k < 8; k++) printf(" %.4g", f->sigma[0][k]);
        printf("\n");
        /* A material on a view-dependent transfer's path: the factor above is its kd/pi part only. */
        for (int i = 0; i < d.ntransfers; i++)
            if (&d.transfers[i] != tr && (d.transfers[i].materials >> m & 1))
                printf("      its specular lobe: %s (the factor above is the diffuse kd/pi part)\n",
                       d.transfers[i].ops->title);
    }
    printf("interreflect  %d pass(es), gather cube %dx%dx6%s\n", ps->bounces, d.gather_res, d.gather_res,
           tr && tr->direct.nvecs ? "; direct-only transport kept too" : "");
    char t[6][48];   /* the times as a person reads them (prt_format_duration) */
    for (int b = 0; b < ps->bounces && b < PRT_MAX_BOUNCES; b++) {
        prt_format_duration(t[0], sizeof t[0], ps->t_bounce[b]);
        printf("              pass %d: %.3f%% of the direct energy, %s\n", b + 1, 100 * ps->bounce_energy[b], t[0]);
    }
    double tb = 0;
    for (int b = 0; b < ps->bounces && b < PRT_MAX_BOUNCES; b++) tb += ps->t_bounce[b];
    const double secs[5] = { ps->t_brdf, ps->t_visibility, ps->t_transport, tb, ps->t_total };
    for (int i = 0; i < 5; i++) prt_format_duration(t[i], sizeof t[i], secs[i]);
    printf("timings       BRDF %s, visibility %s, wavelet+quantization %s", t[0], t[1], t[2]);
    if (ps->bounces) printf(", bounces %s", t[3]);
    printf(", total %s\n", t[4]);
    if (ps->peak_rss_bytes) printf("peak memory   %.2f GB\n", ps->peak_rss_bytes / 1e9);
    /* How the file sits in memory once loaded (prtfile.h, mapped loading) */
    long anon, file;
    if (resident_kb(&anon, &file))
        printf("loaded        %.2f MB of the file mapped in place (the transport's runs and coefficients: page cache, "
               "shared), %.2f MB of this process's own memory resident\n", prt_data_mapped_bytes(&d) / 1e6, anon * 1024 / 1e6);
    for (int i = 0; i < d.scene.lights.count; i++) {   /* the file's local lights */
        char spec[300];
        light_format(&d.scene.lights.light[i], spec, sizeof spec);
        printf("%s %s\n", i ? "             " : "local lights", spec);
    }
    for (int t = 0; t < d.scene.ntextures; t++) {   /* base-colour textures (texture.h), the materials they paint */
        char mats[300] = "";
        for (int m = 0; m < d.scene.nmaterials; m++)
            if (d.scene.material_texture[m] == t + 1) {
                size_t at = strlen(mats);
                snprintf(mats + at, sizeof mats - at, "%s%d", at ? ", " : "", m);
            }
        printf("%s '%s' %dx%d, multiplies the diffuse albedo of material %s\n", t ? "             " : "textures    ",
               d.scene.textures[t].name, d.scene.textures[t].w, d.scene.textures[t].h, mats);
    }
    for (int i = 0; i < d.scene.ncameras; i++) {   /* the scene's named cameras (a glTF's): --camera-name */
        const prt_camera *c = &d.scene.cameras[i].cam;
        printf("%s '%s' eye %g,%g,%g target %g,%g,%g fov %g%s\n", i ? "             " : "cameras     ", d.scene.cameras[i].name,
               c->eye[0], c->eye[1], c->eye[2], c->target[0], c->target[1], c->target[2], c->fov_deg,
               i ? "" : " (the default of render, view, reference)");
    }
    if (d.plan[0]) printf("effects plan\n%s%s", d.plan, d.plan[strlen(d.plan) - 1] == '\n' ? "" : "\n");
    prt_data_free(&d);
    return 0;
}
