/* test_dense.c - a fourth transfer representation, added the way the README's "Adding a
 * representation" says: its folder (this one: transfer_dense.c) and one table line (table.c, the
 * table of this binary only). Nothing else in the library knows it, yet:
 *   table:      the table lists it after the library's (haar, sh, vmf, cpca); the defaults stay haar and vmf;
 *   unoccluded: precompute_run with basis "dense" (the library call, every texel in float) gives
 *               an unoccluded Lambert vertex under a constant light kd/pi L S, S the visibility
 *               cube's own quadrature of the cosine (computed here), within the float rounding of
 *               the sums;
 *   haar:       over a sphere and a plane (shadows, a glossy SVD material) every light-dependent
 *               vector T.L under a sky equals Haar's at N = 24,576 in float (Parseval: the orthonormal
 *               wavelets change nothing but rounding), within the rounding of the transforms and sums;
 *   round_trip: its .prt section (its own tag, the linear family's layout) is written, read back
 *               and relit to the same bits;
 *   cli:        the prt binary, whose table has no dense, refuses --basis dense naming the ones it has. */
#include "harness.h"
#include "cubemap.h"
#include "light.h"
#include "mesh.h"
#include "precompute.h"
#include "probe.h"
#include "prtfile.h"
#include "relight.h"
#include "transfer.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static void table(void) {
    const transfer_ops *d = transfer_find("dense");
    CHECK(d != NULL && d->kind == TRANSFER_LINEAR && transfer_count() == 5 && transfer_at(4) == d, "dense is the last");
    CHECK(transfer_default(TRANSFER_LINEAR) == transfer_find("haar") && transfer_default(TRANSFER_VIEW) == transfer_find("vmf"),
          "the defaults are unchanged");
    char names[64];
    transfer_names(TRANSFER_LINEAR, names, sizeof names);
    CHECK(!strcmp(names, "haar, sh, cpca, dense"), "linear names: %s", names);
    CHECK(d && transfer_by_tag(d->tag) == d, "by its section tag");
}

/* The cube light of a constant probe of radiance rgb, or of the default procedural sky (rgb NULL). */
static float *cube_of(const float *rgb) {
    prt_error err;
    prt_probe p;
    sky_desc sd = { 0 };
    int rc = rgb ? probe_make_constant(rgb, &p, &err) : probe_make_sky(&sd, &p, &err);
    CHECK(rc == 0, "%s", err.msg);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    if (rc == 0) probe_to_cube(&p, CUBE_RES, NULL, 0, cube);
    if (rc == 0) probe_free(&p);
    return rc == 0 ? cube : (free(cube), NULL);
}

/* Precomputes sc with the linear representation basis and its options, every texel kept in float,
 * the direct pass alone. 0 or -1. */
static int precompute(prt_scene *sc, const char *basis, const char *options, prt_data *out) {
    prt_error err;
    /* not refined: the plan's refinement depends on the basis's bytes, and this compares bases on one mesh */
    precompute_desc d = { .no_open_sky = true, .N = CUBE_TEXELS, .qbits = 32, .vis_res = 64, .quiet = true, .nthreads = 2, .force_bounces = -1,
                          .force_refine = -1, .glossy = PRECOMPUTE_GLOSSY_SVD, .basis = basis, .basis_options = options };
    int rc = precompute_run(sc, &d, out, &err);
    CHECK(rc == 0, "%s: %s", basis, err.msg);
    return rc;
}

/* The centre vertex of a small plane (normal +y) under a constant light: kd/pi L S (Eq. 2 with V = 1 on
 * the visibility cube's quadrature S = sum over its texels of max(n.w, 0) dw, which the direct pass
 * box-filters to the lighting texels exactly). Rounding: S and the kernel's T.L are sums of at most
 * 6 x 64^2 positive float terms, each within n FLT_EPSILON of its magnitude; the Lambert factor's
 * SVD within 1e-5 (brdf_factorize in float). */
static void unoccluded(void) {
    prt_error err;
    prt_mesh m = { 0 };
    prt_scene sc;
    CHECK(mesh_make_plane(&m, -0.1f, 0.1f, -0.1f, 0.1f, 0, 3, 3, &err) == 0, "%s", err.msg);
    CHECK(scene_from_mesh(&m, "lambert:kd=0.7", &sc, &err) == 0, "%s", err.msg);
    prt_data out;
    if (precompute(&sc, "dense", NULL, &out)) return;
    const prt_transfer *tr = prt_data_transfer(&out);
    CHECK(tr && tr->ops == transfer_find("dense") && tr->transport.N == CUBE_TEXELS && tr->transport.qbits == 32,
          "one dense transfer, every texel in float");
    CHECK(strstr(out.plan, "basis: dense cube texels, N=24576 of 24576 per vector, 32-bit; the material: asked for") != NULL,
          "the plan describes it: %s", out.plan);
    const float rgb[3] = { 2.0f, 1.0f, 4.0f };
    float *cube = cube_of(rgb);
    float (*L)[4] = tr && cube ? transfer_light_vector(tr, cube) : NULL;
    double S = 0;
    float *sa = malloc(sizeof(float) * 64 * 64);
    cube_face_solid_angles(64, sa);
    for (int i = 0; i < 6 * 64 * 64; i++) {
        float w[3];
        cube_texel_dir(64, i, w);
        if (w[1] > 0) S += w[1] * sa[i % (64 * 64)];
    }
    free(sa);
    relight_ctx *rc = L ? relight_create(&out, 2, &err) : NULL;
    CHECK(rc != NULL, "%s", err.msg);
    if (rc) {
        float up[3] = { 0, 1, 0 }, got[3];
        relight_set_light(rc, (const float (*)[4])L);
        relight_vertex(rc, 4, up, 0, got);
        for (int ch = 0; ch < 3; ch++) {
            double want = 0.7 / M_PI * rgb[ch] * S, tol = want * (2.0 * 6 * 64 * 64 * FLT_EPSILON + 1e-5);
            CHECK_NEAR(got[ch], want, tol, "channel %d: kd/pi L S", ch);
            if (ch == 0) printf("  unoccluded: %.7f against kd/pi L S = %.7f (|error| %.1e <= %.1e)\n", got[ch], want, fabs(got[ch] - want), tol);
        }
        relight_destroy(rc);
    }
    free(L);
    free(cube);
    prt_data_free(&out);
}

/* A Lambert plane under a glossy sphere (its SVD, K = 4, a shadow on the plane). */
static int sphere_plane(prt_scene *sc) {
    prt_error err;
    prt_mesh plane = { 0 }, sph = { 0 };
    float c[3] = { 0, 0.8f, 0 };
    if (mesh_make_plane(&plane, -2, 2, -2, 2, 0, 9, 9, &err) || mesh_make_sphere(&sph, c, 0.6f, 8, 16, &err)) return -1;
    int first = plane.nverts;
    if (mesh_append(&plane, &sph, &err)) return -1;
    mesh_free(&sph);
    if (scene_from_mesh(&plane, "lambert:kd=0.6,0.55,0.5", sc, &err)) return -1;
    if (scene_material(sc, "phong:kd=0.3,0.1,0.1;ks=0.4;n=20", &err) != 1) return -1;
    for (int v = first; v < sc->mesh.nverts; v++) sc->mesh.mat[v] = 1;
    return 0;
}

/* T.L of every vector of set t under L (transfer_light, one thread). */
static float *light_all(const prt_transfer *tr, const float (*L)[4]) {
    float *g = calloc(3 * (size_t)tr->transport.nvecs + 3, sizeof(float));
    transfer_light(tr, &tr->transport, L, g, 1);
    return g;
}

/* Dense against Haar of the texels (the paper's measure) at N = 24,576 in float, under the sky, vector by
 * vector. Haar's light is the exact transform (light.h at 32 bits, no threshold worth a bit). Bound per
 * vector and channel: the two 6-level Haar transforms (T's and L's) each within 4 x 6 FLT_EPSILON of
 * their L2 norms, then both kernels' sums of n = 24,576 products within n FLT_EPSILON of sum |L_i T_i|
 * <= |L| |T| (Cauchy-Schwarz; the norms are the same in both bases, Parseval): (48 + 2n) FLT_EPSILON
 * |L| |T|. */
static void haar(void) {
    prt_scene a, b;
    prt_data da, db;
    CHECK(sphere_plane(&a) == 0 && sphere_plane(&b) == 0, "scenes");
    if (precompute(&a, "dense", NULL, &da)) return;
    if (precompute(&b, "haar", "measure=texels,budget=vector", &db)) { prt_data_free(&da); return; }
    const prt_transfer *td = prt_data_transfer(&da), *th = prt_data_transfer(&db);
    float *cube = cube_of(NULL);
    float (*Ld)[4] = transfer_light_vector(td, cube), (*Lh)[4] = transfer_light_alloc();
    light_from_cube(cube, &(light_desc){ .threshold = 1e-30f, .qbits = 32 }, Lh, NULL);
    float *gd = light_all(td, (const float (*)[4])Ld), *gh = light_all(th, (const float (*)[4])Lh);
    CHECK(td->transport.nvecs == th->transport.nvecs && td->transport.nvecs == 81 + 4 * (da.scene.mesh.nverts - 81),
          "the same vectors: %d and %d", td->transport.nvecs, th->transport.nvecs);
    float *T = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    double worst = 0, nL[3] = { 0, 0, 0 };
    for (int j = 0; j < CUBE_TEXELS; j++)
        for (int ch = 0; ch < 3; ch++) nL[ch] += (double)Ld[j][ch] * Ld[j][ch];
    int nbad = 0;
    for (int i = 0; i < td->transport.nvecs && i < th->transport.nvecs; i++) {
        transport_decode(&td->transport, i, T, T + CUBE_TEXELS, T + 2 * CUBE_TEXELS);
        for (int ch = 0; ch < 3; ch++) {
            double nT = 0;
            for (int j = 0; j < CUBE_TEXELS; j++) nT += (double)T[ch * CUBE_TEXELS + j] * T[ch * CUBE_TEXELS + j];
            double tol = (48.0 + 2.0 * CUBE_TEXELS) * FLT_EPSILON * sqrt(nL[ch] * nT), e = fabs(gd[3 * i + ch] - gh[3 * i + ch]);
            nbad += e > tol;
            if (tol > 0 && e / tol > worst) worst = e / tol;
        }
    }
    CHECK(nbad == 0, "%d vector channels beyond the rounding bound", nbad);
    printf("  dense against Haar at N = 24,576 in float: %d vectors, the worst at %.1e of its rounding bound\n",
           td->transport.nvecs, worst);
    free(T); free(gd); free(gh); free(Ld); free(Lh); free(cube);
    prt_data_free(&da);
    prt_data_free(&db);
}

/* Written and read back: its tag in the file, the same representation, mask, config and vectors, and the
 * same T.L bit for bit (exact by construction: the same kernel on the same values in one process). */
static void round_trip(void) {
    prt_error err;
    prt_scene sc;
    prt_data a, b;
    CHECK(sphere_plane(&sc) == 0, "scene");
    if (precompute(&sc, "dense", NULL, &a)) return;
    char path[600];
    snprintf(path, sizeof path, "%s/dense.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    if (prtfile_read(path, &b, &err)) { CHECK(0, "%s", err.msg); prt_data_free(&a); return; }
    size_t n = 0;
    unsigned char *img = (unsigned char *)check_read_file(path, &n);
    uint32_t tag = transfer_find("dense")->tag;
    CHECK(img && memmem(img, n, &tag, 4) != NULL, "its section tag in the file");
    free(img);
    const prt_transfer *x = prt_data_transfer(&a), *y = prt_data_transfer(&b);
    CHECK(b.ntransfers == 1 && y->ops == x->ops && y->materials == x->materials && !memcmp(&x->cfg, &y->cfg, sizeof x->cfg),
          "the same representation, mask and config");
    float *cube = cube_of(NULL);
    float (*L)[4] = transfer_light_vector(x, cube);
    float *ga = light_all(x, (const float (*)[4])L), *gb = light_all(y, (const float (*)[4])L);
    CHECK(x->transport.nvecs == y->transport.nvecs && !memcmp(ga, gb, sizeof(float) * 3 * (size_t)x->transport.nvecs),
          "the same T.L after the round trip");
    free(ga); free(gb); free(L); free(cube);
    prt_data_free(&a);
    prt_data_free(&b);
}

/* The prt binary's table (the library's) has no dense: --basis dense is a usage error naming the others. */
static void cli(void) {
    char cmd[1200], buf[2048];
    snprintf(cmd, sizeof cmd, "%s precompute data/sphere-phong.json -o %s/cli.prt --basis dense --quiet", check_prt_bin(),
             check_tmpdir());
    int rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 2 && strstr(buf, "--basis must be haar, sh or cpca (got 'dense')") != NULL, "exit %d: %s", rc, buf);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(table);
    CHECK_CASE(unoccluded);
    CHECK_CASE(haar);
    CHECK_CASE(round_trip);
    CHECK_CASE(cli);
    return check_summary();
}
