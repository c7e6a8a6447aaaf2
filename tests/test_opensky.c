/* test_opensky.c - the open sky split (src/transfer/linear/opensky.h): the irradiance grid against its
 * definition, an open plane under a low sun against quadrature, and the split through precompute, the
 * file and the runtimes.
 *
 * Cases:
 *   opensky/grid_exact     at the grid's normals opensky_eval is the sum over every sub-texel
 *                          (opensky_exact) within float rounding
 *   opensky/grid_between   at random normals: exact where no cell corner's horizon crosses the sun, and
 *                          within the interpolation bound of the header everywhere
 *   opensky/open_plane     a plane alone stores no coefficients, and its radiance under a sky plus a sun
 *                          texel 2 degrees up is kd/pi (pi sky + L a0) with a0 by quadrature
 *   opensky/turned         a probe turned by R reads the unrotated probe's grid at R^T n (made once per
 *                          probe): on a glossy-free sphere over a plane under a sky with a sun, the
 *                          same colours as the probe resampled turned into the cube, to the cube's
 *                          quadrature of the sun (1e-3 of the largest colour)
 *   opensky/covered        a plane inside a closed box sees none of its sky: its vectors stay whole
 *                          (not split) and it renders exactly black, as the reference does
 *   opensky/file           the split and its per-vertex flags survive the file; --no-open-sky turns it off; a light vector
 *                          alone is refused for a split transfer
 *   opensky/gl_kernels     the GL light kernels (fragment, thread, warp; those the context has) add the
 *                          open sky: g read back equals transfer_light plus the addend within float
 *                          summation (the transport's own kernels' tolerance)
 *   opensky/bounce         a plane beside a wall, one forced bounce, float storage, every coefficient:
 *                          the split and the whole vectors give the same radiance within the open-sky
 *                          set's truncation, measured on its own vectors */
#include "harness.h"
#include "brdf.h"
#ifndef PRT_NO_GL
#include "glrt.h"
#endif
#include "cubemap.h"
#include "opensky.h"
#include "precompute.h"
#include "prtfile.h"
#include "probe.h"
#include "runtime.h"
#include "scene.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }

/* A cube of a uniform sky (radiance sky) and one sun texel of radiance sun at elevation elev (radians,
 * azimuth az) into cube[CUBE_TEXELS][3]; returns the sun's texel. */
static int sky_and_sun(float *cube, float sky, float sun, double elev, double az) {
    for (int i = 0; i < 3 * CUBE_TEXELS; i++) cube[i] = sky;
    float d[3] = { (float)(cos(elev) * cos(az)), (float)sin(elev), (float)(cos(elev) * sin(az)) };
    int j = cube_texel_index(CUBE_RES, d);
    for (int c = 0; c < 3; c++) cube[3 * j + c] = sun;
    return j;
}

/* A grid lit by sky_and_sun's cube (*cube, the caller's to free) and the sun texel's index into *sun;
 * NULL after a failed check. */
static opensky *lit_grid(float sky, float sunL, double elev, double azim, float **cube, int *sun) {
    prt_error err;
    opensky *o = opensky_create(&err);
    *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    CHECK(o != NULL && *cube != NULL, "%s", o ? "out of memory" : err.msg);
    if (!o || !*cube) {
        opensky_destroy(o);
        free(*cube);
        return NULL;
    }
    *sun = sky_and_sun(*cube, sky, sunL, elev, azim);
    opensky_set_light(o, *cube, NULL, 2);
    return o;
}

static void grid_exact(void) {
    float *cube;
    int j;
    opensky *o = lit_grid(1.f, 30000.f, 3 * M_PI / 180, 0.7, &cube, &j);
    if (!o) return;
    double worst = 0;
    for (int q = 0; q < OPENSKY_NORMALS; q += 7) {
        float n[3], e[3];
        double x[3];
        opensky_grid_normal(q, n);
        opensky_eval(o, n, e);
        opensky_exact(cube, n, x);
        for (int c = 0; c < 3; c++) {
            double r = fabs(e[c] - x[c]) / x[c];
            if (r > worst) worst = r;
        }
    }
    /* both sum the same positive terms, the grid in float block moments (64 texels in double, then
     * rounded once) and a double total: a few float roundings of the largest term, 1e-6 of E */
    CHECK_LE(worst, 1e-5, "grid normals: relative error %.3g", worst);
    printf("grid normals: worst relative error %.2e\n", worst);
    free(cube);
    opensky_destroy(o);
}

static void grid_between(void) {
    const float sky = 1.f, sunL = 30000.f;
    float *cube;
    int j;
    opensky *o = lit_grid(sky, sunL, 3 * M_PI / 180, 2.1, &cube, &j);
    if (!o) return;
    float s[3];
    cube_texel_dir(CUBE_RES, j, s);   /* the sun texel's centre */
    float sa[CUBE_RES * CUBE_RES];
    cube_face_solid_angles(CUBE_RES, sa);
    double phi = sunL * sa[j % (CUBE_RES * CUBE_RES)];   /* the sun texel's irradiance at normal incidence */
    uint32_t seed = 12345;
    double far_worst = 0, all_worst = 0;
    for (int k = 0; k < 1500; k++) {
        float n[3] = { 2 * rnd(&seed) - 1, 2 * rnd(&seed) - 1, 2 * rnd(&seed) - 1 };
        float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (l < 0.1f || l > 1) continue;
        for (int c = 0; c < 3; c++) n[c] /= l;
        float e[3];
        double x[3];
        opensky_eval(o, n, e);
        opensky_exact(cube, n, x);
        double d = fabs(e[0] - x[0]), ns = fabs(n[0] * s[0] + n[1] * s[1] + n[2] * s[2]);
        if (ns > 0.2 && d > far_worst) far_worst = d;
        if (d > all_worst) all_worst = d;
    }
    /* The uniform sky's E is pi at every normal, |p| pi is not linear on the face: bilinear error at
     * most h^2/8 (max|d2|p|/du2| + max|d2|p|/dv2|) <= 2 (2/16)^2 / 8 of pi (h the cell; |p| >= 1). Away from the sun's terminator
     * (|n.s| > 0.2: every corner of n's cell, within 0.18 rad, on one side) the sun's |p| E is linear:
     * exact. Across it, a kink in a cell of h = 1/8: at most h/2 of the sun's irradiance. */
    double sky_bound = 2 * pow(2.0 / OPENSKY_GRID, 2) / 8 * M_PI * sky;
    CHECK_LE(far_worst, sky_bound + 1e-5 * phi, "away from the terminator: %.4g (bound %.4g)", far_worst, sky_bound);
    CHECK_LE(all_worst, sky_bound + 0.5 * (2.0 / OPENSKY_GRID) * phi, "anywhere: %.4g (sun %.4g)", all_worst, phi);
    printf("between grid normals: away from the terminator %.3g (bound %.3g), anywhere %.3g (sun's E %.3g)\n", far_worst,
           sky_bound, all_worst, phi);
    free(cube);
    opensky_destroy(o);
}

/* a0 of texel j at normal n by a 64 x 64 midpoint quadrature of the texel (exact solid angles). */
static double texel_a0_quadrature(int j, const float n[3]) {
    const int F = CUBE_RES * CUBE_RES, Q = 64, R = CUBE_RES * Q;
    int f = j / F, ti = (j % F) % CUBE_RES, tj = (j % F) / CUBE_RES;
    double a = 0;
    for (int y = 0; y < Q; y++)
        for (int x = 0; x < Q; x++) {
            int si = ti * Q + x, sj = tj * Q + y;
            float d[3];
            cube_texel_dir(R, f * R * R + sj * R + si, d);
            double c = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            if (c > 0) a += c * cube_texel_solid_angle(R, si, sj);
        }
    return a;
}

/* A plane of n x n vertices over [-half, half]^2 at y = 0, with extra (NULL: none; freed here) above it, all
 * of material mat, precomputed with d. 0 or -1 with err. */
static int plane_with(float half, int n, prt_mesh *extra, const char *mat, const precompute_desc *d, prt_data *out,
                      prt_error *err) {
    prt_mesh m = { 0 };
    prt_scene sc;
    int rc = mesh_make_plane(&m, -half, half, -half, half, 0, n, n, err) || (extra && mesh_append(&m, extra, err)) ||
                     scene_from_mesh(&m, mat, &sc, err) || precompute_run(&sc, d, out, err) ? -1 : 0;
    if (extra) mesh_free(extra);
    return rc;
}

/* A plane with a box wall on one side (opensky/bounce, opensky/gl_kernels). */
static int wall_data(const precompute_desc *d, prt_data *out, prt_error *err) {
    prt_mesh wall = { 0 };
    const float bmin[3] = { 0.5f, 0, -1 }, bmax[3] = { 0.7f, 1.5f, 1 };
    if (mesh_make_box(&wall, bmin, bmax, 2, false, err)) return -1;
    return plane_with(1, 9, &wall, "lambert:kd=0.8", d, out, err);
}

/* A plane alone precomputed with the defaults (split on unless no_split). */
static int plane_data(bool no_split, prt_data *out, prt_error *err) {
    return plane_with(1, 5, NULL, "lambert:kd=0.6", &(precompute_desc){ .quiet = true, .nthreads = 2, .no_open_sky = no_split },
                      out, err);
}

static void open_plane(void) {
    prt_error err;
    prt_data d;
    int rc = plane_data(false, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    const prt_transfer *tr = &d.transfers[0];
    CHECK(tr->open_sky, "the default splits");
    CHECK(tr->transport.coef_first[tr->transport.nvecs] == 0, "an open plane stores %u coefficients",
          tr->transport.coef_first[tr->transport.nvecs]);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);
    const float sky = 0.5f, sunL = 20000.f;
    int j = sky_and_sun(cube, sky, sunL, 2 * M_PI / 180, 0.4);
    prt_runtime *rt = runtime_create(&d, &(runtime_desc){ .backend = "cpu" }, &err);
    CHECK(rt != NULL, "%s", err.msg);
    if (rt && runtime_set_light_cube(rt, cube, &err) == 0 && runtime_shade_vertices(rt, (float[3]){ 0, 3, 0 }, rgb, &err) == 0) {
        const float up[3] = { 0, 1, 0 };
        /* kd/pi (sky pi + (sun - sky) a0_j): the uniform sky over the upper hemisphere gives pi exactly,
         * the sun texel adds its excess; a0_j by quadrature against the grid's 2 x 2 sub-texels (a
         * midpoint rule on the smooth cosine: 1e-4 relative), the float sums 1e-5 */
        double a0 = texel_a0_quadrature(j, up), want = 0.6 / M_PI * (M_PI * sky + (sunL - sky) * a0);
        double worst = 0;
        for (int v = 0; v < d.scene.mesh.nverts; v++) worst = fmax(worst, fabs(rgb[3 * v] - want) / want);
        CHECK_LE(worst, 2e-4, "open plane under a sun 2 degrees up: relative error %.3g (want %.6g)", worst, want);
        printf("open plane, sun 2 deg up: radiance %.6g, quadrature %.6g, worst vertex %.2e relative\n", rgb[0], want, worst);
    } else
        CHECK(0, "%s", err.msg);
    runtime_destroy(rt);
    free(cube);
    free(rgb);
    prt_data_free(&d);
}

static void turned(void) {
    prt_error err;
    prt_mesh sph = { 0 };
    prt_data d;
    const float c[3] = { 0, 0.6f, 0 };
    int rc = mesh_make_sphere(&sph, c, 0.5f, 12, 24, &err) ||
             plane_with(2, 9, &sph, "lambert:kd=0.7", &(precompute_desc){ .quiet = true, .nthreads = 2, .force_bounces = -1 }, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    prt_probe pr;
    sky_desc sd = { .width = 256, .sun_dir = { 0.6f, 0.3f, 0.2f }, .sun_radius_deg = 3, .sun_radiance = 300 };
    CHECK(probe_make_sky(&sd, &pr, &err) == 0, "%s", err.msg);
    int n = d.scene.mesh.nverts;
    float *a = malloc(sizeof(float) * 3 * (size_t)n), *b = malloc(sizeof(float) * 3 * (size_t)n);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), R[9];
    probe_rotation(40, 10, R);
    probe_to_cube(&pr, CUBE_RES, R, 0, cube);
    prt_runtime *rt = runtime_create(&d, NULL, &err);
    const float eye[3] = { 0, 3, 4 };
    /* the unrotated grid first (a yaw of 0), then turned: the second light change only rotates */
    rc = !rt || runtime_set_light(rt, &pr, NULL, &err) || runtime_set_light(rt, &pr, R, &err) ||
         runtime_shade_vertices(rt, eye, a, &err) || runtime_set_light_cube(rt, cube, &err) || runtime_shade_vertices(rt, eye, b, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        double worst = 0, top = 0;
        for (int i = 0; i < 3 * n; i++) worst = fmax(worst, fabs(a[i] - b[i])), top = fmax(top, fabs(b[i]));
        /* T x L is the same (both turn the cube); the open sky differs by the two grids' interpolation,
         * each within opensky.h's bound of the exact sum: 2 h^2/8 of the irradiance (h = 2/G) and, near the
         * sun's terminator, h/2 of the sun's (its disc: radiance 300 over pi (3 degrees)^2); twice that,
         * times kd/pi */
        double h = 2.0 / OPENSKY_GRID, phi = 300 * M_PI * pow(3 * M_PI / 180, 2);
        double bound = 2 * (2 * h * h / 8 * top + 0.7 / M_PI * h / 2 * phi);
        CHECK_LE(worst, bound, "turned probe against its turned cube: %.3g of %.3g", worst, top);
        printf("turned probe (yaw 40, pitch 10): colours within %.2e of the turned cube's (bound %.2e, largest %.3g)\n",
               worst, bound, top);
    }
    runtime_destroy(rt);
    probe_free(&pr);
    free(a);
    free(b);
    free(cube);
    prt_data_free(&d);
}

static void covered(void) {
    prt_error err;
    prt_mesh cover = { 0 };
    prt_data d;
    const float bmin[3] = { -3, -1, -3 }, bmax[3] = { 3, 1, 3 };
    int rc = mesh_make_box(&cover, bmin, bmax, 2, false, &err) ||
             plane_with(1, 5, &cover, "lambert:kd=0.6", &(precompute_desc){ .quiet = true, .nthreads = 2, .force_bounces = -1 }, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    const prt_transfer *tr = &d.transfers[0];
    int split = 0;
    for (int v = 0; v < 25; v++) split += tr->open_vert[v];
    CHECK(tr->open_sky && split == 0, "%d of the 25 covered vertices split", split);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *rgb = malloc(sizeof(float) * 3 * (size_t)d.scene.mesh.nverts);
    sky_and_sun(cube, 0.5f, 20000.f, 40 * M_PI / 180, 0.4);
    prt_runtime *rt = runtime_create(&d, NULL, &err);
    if (rt && runtime_set_light_cube(rt, cube, &err) == 0 && runtime_shade_vertices(rt, (float[3]){ 0, 0.2f, 3 }, rgb, &err) == 0) {
        float worst = 0;
        for (int v = 0; v < 25; v++) worst = fmaxf(worst, fmaxf(rgb[3 * v], fmaxf(rgb[3 * v + 1], rgb[3 * v + 2])));
        /* inside the box every ray is blocked: a = 0, so the whole vector is zero, no coefficient, no light */
        CHECK(worst == 0.f, "covered plane: radiance up to %g", worst);
    } else
        CHECK(0, "%s", err.msg);
    runtime_destroy(rt);
    free(cube);
    free(rgb);
    prt_data_free(&d);
}

static void file_flag(void) {
    prt_error err;
    for (int no = 0; no < 2; no++) {
        prt_data d, back;
        int rc = plane_data(no, &d, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) continue;
        char path[512];
        snprintf(path, sizeof path, "%s/opensky%d.prt", check_tmpdir(), no);
        rc = prtfile_write(path, &d, &err) || prtfile_read(path, &back, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc == 0) {
            CHECK(back.transfers[0].open_sky == !no, "%s: the flag read back %d", no ? "--no-open-sky" : "default",
                  back.transfers[0].open_sky);
            if (!no && back.transfers[0].open_vert)
                CHECK(!memcmp(back.transfers[0].open_vert, d.transfers[0].open_vert, (size_t)d.scene.mesh.nverts),
                      "the per-vertex flags read back");
            prt_runtime *rt = runtime_create(&back, NULL, &err);
            float (*L)[4] = calloc(CUBE_TEXELS, sizeof *L);
            const float (*Ls[PRT_MAX_TRANSFERS])[4] = { (const float (*)[4])L };
            int lr = rt ? runtime_set_light_vectors(rt, Ls, &err) : -2;
            CHECK(no ? lr == 0 : lr == -1, "light vector alone: %d (%s)", lr, lr ? err.msg : "accepted");
            if (!no && lr == -1) CHECK(strstr(err.msg, "open sky") != NULL, "names the open sky: %s", err.msg);
            free(L);
            runtime_destroy(rt);
            prt_data_free(&back);
        }
        prt_data_free(&d);
    }
}

/* A plane with a wall on one side, one forced bounce, every coefficient in floats: radiance per vertex. */
static int wall_radiance(bool no_split, const float *cube, float *rgb, int *nverts, prt_error *err) {
    precompute_desc d = { .quiet = true, .nthreads = 2, .no_open_sky = no_split, .N = CUBE_TEXELS, .qbits = 32,
                          .force_bounces = 1, .bounces = 1, .gather_res = 16 };
    prt_data out;
    if (wall_data(&d, &out, err)) return -1;
    prt_runtime *rt = runtime_create(&out, &(runtime_desc){ .backend = "cpu" }, err);
    int rc = rt && runtime_set_light_cube(rt, cube, err) == 0 && runtime_shade_vertices(rt, (float[3]){ -2, 3, 0 }, rgb, err) == 0 ? 0 : -1;
    *nverts = out.scene.mesh.nverts;
    runtime_destroy(rt);
    prt_data_free(&out);
    return rc;
}

#ifndef PRT_NO_GL
/* The open sky's addend per vector of a split transfer, as the runtime forms it (runtime.c). */
static float *open_addend(const prt_data *d, const float *cube, prt_error *err) {
    const prt_transfer *tr = &d->transfers[0];
    opensky *o = opensky_create(err);
    float *a = calloc(3 * (size_t)tr->transport.nvecs + 1, sizeof(float));
    if (!o || !a) { opensky_destroy(o); free(a); return NULL; }
    opensky_set_light(o, cube, NULL, 2);
    const prt_mesh *m = &d->scene.mesh;
    for (int v = 0; v < m->nverts; v++) {
        if (!tr->open_vert[v]) continue;
        float e[3], g[3];
        brdf_factor_lambert_light(&d->factors[m->mat[v]], g);
        opensky_eval(o, m->nrm + 3 * (size_t)v, e);
        for (int c = 0; c < 3; c++) a[3 * (size_t)tr->transport.vec_first[v] + c] = g[c] * e[c];
    }
    opensky_destroy(o);
    return a;
}

#endif

static void gl_kernels(void) {
#ifndef PRT_NO_GL   /* a build without GL skips the case (CHECK_CASE_GL) and has no glrt */
    prt_error err;
    prt_data d;
    int rc = wall_data(&(precompute_desc){ .quiet = true, .nthreads = 2, .force_bounces = -1 }, &d, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    const prt_transfer *tr = &d.transfers[0];
    int nv = tr->transport.nvecs;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *g = calloc(3 * (size_t)nv, sizeof(float));
    float *want = calloc(3 * (size_t)nv, sizeof(float));
    sky_and_sun(cube, 0.3f, 5000.f, 15 * M_PI / 180, M_PI);
    float (*L)[4] = transfer_light_vector(tr, cube), *open = open_addend(&d, cube, &err);
    CHECK(L && open, "light vector and addend");
    transfer_light(tr, &tr->transport, (const float (*)[4])L, want, 1);
    double scale = 0;
    for (int i = 0; i < 3 * nv; i++) want[i] += open[i], scale = fmax(scale, fabs(want[i]));
    glrt *rt = glrt_create(&d, NULL, &err);
    CHECK(rt != NULL, "%s", err.msg);
    CHECK(rt && glrt_set_light(rt, (const float (*)[4])L, &err) == -1, "a split transfer's light without the addend is refused");
    int ran = 0;
    for (int meth = GLRT_LIGHT_FRAGMENT; rt && meth <= GLRT_LIGHT_WARP; meth++) {
        if (glrt_set_light_method(rt, (glrt_light_method)meth, &err)) continue;   /* not in this context */
        ran++;
        CHECK(glrt_set_light_open(rt, (const float (*)[4])L, open, &err) == 0 && glrt_read_gvec(rt, g, &err) == 0, "%s", err.msg);
        double worst = 0;
        for (int i = 0; i < 3 * nv; i++) worst = fmax(worst, fabs(g[i] - want[i]));
        /* float sums of up to 512 products in another order, and one float addition: 1e-5 of the largest g */
        CHECK_LE(worst, 1e-5 * scale, "method %d: g against transfer_light + the addend", meth);
        printf("GL light method %d: g within %.2e of the CPU's (largest %.3g)\n", meth, worst, scale);
    }
    CHECK(ran >= 1, "no GL light kernel ran");
    glrt_destroy(rt);
    free(L);
    free(open);
    free(cube);
    free(g);
    free(want);
    prt_data_free(&d);
#endif
}

static void bounce(void) {
    prt_error err;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    sky_and_sun(cube, 0.3f, 5000.f, 20 * M_PI / 180, M_PI);   /* the sun behind the wall's open side */
    float *a = malloc(sizeof(float) * 3 * 4096), *b = malloc(sizeof(float) * 3 * 4096);
    int na = 0, nb = 0;
    int ra = wall_radiance(false, cube, a, &na, &err);
    CHECK(ra == 0, "%s", err.msg);
    int rb = ra == 0 ? wall_radiance(true, cube, b, &nb, &err) : -1;
    CHECK(rb == 0 && na == nb && na <= 4096, "%s", err.msg);
    if (ra == 0 && rb == 0) {
        double num = 0, den = 0;
        for (int i = 0; i < 3 * na; i++) num += (a[i] - b[i]) * (a[i] - b[i]), den += b[i] * b[i];
        double rel = sqrt(num / den);
        /* The only difference is the first bounce's open sky of each neighbour: 512 float coefficients
         * of |p| a0 at the grid's normals, bilinear between them (exact for the texels off the horizon).
         * The bounce carries well under half of the light here and that vector's truncation is a few
         * percent of it (PC_OPEN_N's comment), so 1% of the image is a loose bound; a neighbour's open sky
         * left out would be tens of percent. */
        CHECK_LE(rel, 0.01, "split against whole vectors with a bounce: rel. RMS %.4g", rel);
        printf("one bounce, split vs whole (every coefficient, float): rel. RMS %.2e over %d vertices\n", rel, na);
    }
    free(a);
    free(b);
    free(cube);
}

/* A box on the default floor (normals (0, 1, 0), 20 x 20 vertices), direct only, precomputed with d (the
 * floor's fold: opensky.h). 0 or -1 with err. */
static int floor_box_data(precompute_desc d, prt_data *out, prt_error *err) {
    prt_mesh box = { 0 };
    prt_scene sc;
    const float bmin[3] = { -0.3f, 0, -0.3f }, bmax[3] = { 0.3f, 0.8f, 0.3f };
    d.quiet = true, d.nthreads = 2, d.force_bounces = -1, d.force_refine = -1;   /* one mesh for every desc */
    return mesh_make_box(&box, bmin, bmax, 4, false, err) || scene_from_mesh(&box, "lambert:kd=0.8", &sc, err) ||
                   scene_add_floor(&sc, 400, 3, NULL, err) || precompute_run(&sc, &d, out, err)
               ? -1
               : 0;
}

/* Vertex radiance of d on backend (NULL: cpu) under cube, seen from above. 0 or -1 with err. */
static int vertex_radiance(const prt_data *d, const char *backend, const float *cube, float *rgb, prt_error *err) {
    prt_runtime *rt = runtime_create(d, &(runtime_desc){ .backend = backend ? backend : "cpu", .threads = 2 }, err);
    int rc = rt && runtime_set_light_cube(rt, cube, err) == 0 && runtime_shade_vertices(rt, (float[3]){ 0, 6, 1 }, rgb, err) == 0
                 ? 0
                 : -1;
    runtime_destroy(rt);
    return rc;
}

/* The floor's fold is exact before truncation: with every coefficient in floats, the folded file and
 * the unfolded one (--no-fold) give the same radiance at every vertex under a sky and a sun 2 degrees
 * up, at the default visibility resolution and at 64 (the runtime's c_j sums the file's sub-texels).
 * Only the floor's split vertices are folded. */
static void fold_exact_at(int vis_res) {
    prt_error err;
    prt_data a, b;
    precompute_desc full = { .N = CUBE_TEXELS, .qbits = 32, .vis_res = vis_res };
    int rc = floor_box_data(full, &a, &err);
    CHECK(rc == 0, "%s", err.msg);
    full.no_fold = true;
    int rb = rc == 0 ? floor_box_data(full, &b, &err) : -1;
    CHECK(rb == 0, "%s", err.msg);
    if (rc || rb) return;
    const prt_mesh *m = &a.scene.mesh;
    const prt_transfer *ta = &a.transfers[0], *tb = &b.transfers[0];
    int folded = 0, misplaced = 0;
    for (int v = 0; v < m->nverts; v++) {
        bool floor = v >= a.scene.floor_first_vertex;
        folded += ta->open_vert[v] == OPENSKY_FOLDED;
        misplaced += ta->open_vert[v] == OPENSKY_FOLDED ? !floor : floor && ta->open_vert[v] == OPENSKY_SPLIT;
        misplaced += tb->open_vert[v] == OPENSKY_FOLDED;
    }
    CHECK(folded > 0 && misplaced == 0, "%d folded floor vertices, %d misplaced flags", folded, misplaced);
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *ra = malloc(sizeof(float) * 3 * (size_t)m->nverts);
    float *rb2 = malloc(sizeof(float) * 3 * (size_t)m->nverts);
    sky_and_sun(cube, 0.5f, 20000.f, 2 * M_PI / 180, 0.4);
    if (vertex_radiance(&a, NULL, cube, ra, &err) == 0 && vertex_radiance(&b, NULL, cube, rb2, &err) == 0) {
        double worst = 0, top = 0;
        for (int i = 0; i < 3 * m->nverts; i++) worst = fmax(worst, fabs(ra[i] - rb2[i])), top = fmax(top, rb2[i]);
        /* Both sum the same products in float, the folded one as F.L + F.(L' - L): its terms F_j L_j are up
         * to 1 / c_j (about 30 at the sun's texel) times the result's, so its rounding is ~30 x 24,576
         * float additions' relative 6e-8 of a blocked sun: 1e-3 of the open floor is a bound with margin. */
        CHECK_LE(worst, 1e-3 * top, "folded against unfolded, every coefficient: %.3g of %.4g", worst, top);
        printf("fold, every coefficient in floats, --vis-res %d: within %.2e of the unfolded (largest %.4g); %d folded vertices\n",
               a.vis_res, worst, top, folded);
    } else
        CHECK(0, "%s", err.msg);
    free(cube);
    free(ra);
    free(rb2);
    prt_data_free(&a);
    prt_data_free(&b);
}

static void fold_exact(void) {
    fold_exact_at(0);
    fold_exact_at(64);
}

/* At the defaults (N = 128, 8-bit) the fold holds the box's long shadow under a sun 2 degrees up closer to
 * the exact transport than the unfolded vectors do: RMS relative error over the floor's shadowed vertices
 * (below 60% of the open floor), against the same scene with every coefficient in floats. */
static void fold_low_sun(void) {
    prt_error err;
    prt_data t, f, u;
    int rc = floor_box_data((precompute_desc){ .N = CUBE_TEXELS, .qbits = 32 }, &t, &err) ||
             floor_box_data((precompute_desc){ 0 }, &f, &err) || floor_box_data((precompute_desc){ .no_fold = true }, &u, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc) return;
    int n = t.scene.mesh.nverts, f0 = t.scene.floor_first_vertex;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *r[3];
    for (int k = 0; k < 3; k++) r[k] = malloc(sizeof(float) * 3 * (size_t)n);
    sky_and_sun(cube, 0.5f, 20000.f, 2 * M_PI / 180, 0.4);
    if (vertex_radiance(&t, NULL, cube, r[0], &err) == 0 && vertex_radiance(&f, NULL, cube, r[1], &err) == 0 &&
        vertex_radiance(&u, NULL, cube, r[2], &err) == 0) {
        double open = 0, e[2] = { 0, 0 }, den = 0;
        for (int v = f0; v < n; v++) open = fmax(open, r[0][3 * v]);
        int shadowed = 0;
        for (int v = f0; v < n; v++) {
            if (!(r[0][3 * v] < 0.6 * open)) continue;
            shadowed++;
            for (int c = 0; c < 3; c++) {
                double x = r[0][3 * v + c];
                den += x * x;
                for (int k = 0; k < 2; k++) e[k] += (r[1 + k][3 * v + c] - x) * (r[1 + k][3 * v + c] - x);
            }
        }
        double ef = sqrt(e[0] / den), eu = sqrt(e[1] / den);
        CHECK(shadowed >= 10, "%d shadowed floor vertices", shadowed);
        CHECK(ef < eu, "the long shadow: folded %.4g against unfolded %.4g", ef, eu);
        printf("low sun's long shadow (%d floor vertices), N = 128: folded %.4f, unfolded %.4f (RMS relative)\n", shadowed, ef, eu);
    } else
        CHECK(0, "%s", err.msg);
    for (int k = 0; k < 3; k++) free(r[k]);
    free(cube);
    prt_data_free(&t);
    prt_data_free(&f);
    prt_data_free(&u);
}

/* The fold is formed before the backend's light change (runtime.c), so gl gives the cpu's vertex colours. */
static void fold_gl(void) {
    prt_error err;
    prt_data d;
    if (floor_box_data((precompute_desc){ 0 }, &d, &err)) {
        CHECK(0, "%s", err.msg);
        return;
    }
    int n = d.scene.mesh.nverts;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS), *a = malloc(sizeof(float) * 3 * (size_t)n);
    float *b = malloc(sizeof(float) * 3 * (size_t)n);
    sky_and_sun(cube, 0.5f, 20000.f, 2 * M_PI / 180, 0.4);
    if (vertex_radiance(&d, NULL, cube, a, &err) == 0 && vertex_radiance(&d, "gl", cube, b, &err) == 0) {
        double worst = 0, top = 0;
        for (int i = 0; i < 3 * n; i++) worst = fmax(worst, fabs(a[i] - b[i])), top = fmax(top, a[i]);
        /* the kernels' float sums in another order (opensky/gl_kernels: 1e-5 of the largest g) */
        CHECK_LE(worst, 1e-5 * top, "gl against cpu, folded floor: %.3g of %.4g", worst, top);
        printf("fold: gl vertex colours within %.2e of cpu's (largest %.4g)\n", worst, top);
    } else
        CHECK(0, "%s", err.msg);
    free(cube);
    free(a);
    free(b);
    prt_data_free(&d);
}

/* A folded flag is read back; on a vertex whose normal is not (0, 1, 0), or above OPENSKY_FOLDED, refused
 * (the file's validation by the writer, the flag's range by the reader). */
static void fold_file(void) {
    prt_error err;
    prt_data d, back;
    if (floor_box_data((precompute_desc){ 0 }, &d, &err)) {
        CHECK(0, "%s", err.msg);
        return;
    }
    char path[512];
    snprintf(path, sizeof path, "%s/fold.prt", check_tmpdir());
    int rc = prtfile_write(path, &d, &err) || prtfile_read(path, &back, &err);
    CHECK(rc == 0, "%s", err.msg);
    if (rc == 0) {
        CHECK(!memcmp(back.transfers[0].open_vert, d.transfers[0].open_vert, (size_t)d.scene.mesh.nverts), "flags read back");
        prt_data_free(&back);
    }
    uint8_t *ov = d.transfers[0].open_vert;
    int side = -1, fv = -1;
    for (int v = 0; v < d.scene.mesh.nverts; v++) {
        if (side < 0 && ov[v] == OPENSKY_SPLIT && d.scene.mesh.nrm[3 * v + 1] < 0.5f) side = v;
        if (fv < 0 && ov[v] == OPENSKY_FOLDED) fv = v;
    }
    CHECK(side >= 0 && fv >= 0, "a split box side vertex (%d) and a folded floor vertex (%d)", side, fv);
    for (int k = 0; side >= 0 && fv >= 0 && k < 2; k++) {
        int v = k ? fv : side;
        uint8_t keep = ov[v];
        ov[v] = k ? OPENSKY_FOLDED + 1 : OPENSKY_FOLDED;
        rc = prtfile_write(path, &d, &err);   /* the writer refuses what validation does; a flag, the reader */
        if (rc == 0 && (rc = prtfile_read(path, &back, &err)) == 0) prt_data_free(&back);
        CHECK(rc == -1, "%s: accepted", k ? "flag 3" : "a folded side vertex");
        if (rc == -1) CHECK(strstr(err.msg, k ? "flag" : "normal") != NULL, "names it: %s", err.msg);
        ov[v] = keep;
    }
    prt_data_free(&d);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(grid_exact);
    CHECK_CASE(grid_between);
    CHECK_CASE(open_plane);
    CHECK_CASE(turned);
    CHECK_CASE(covered);
    CHECK_CASE(file_flag);
    CHECK_CASE_GL(gl_kernels);
    CHECK_CASE(bounce);
    CHECK_CASE(fold_exact);
    CHECK_CASE(fold_low_sun);
    CHECK_CASE_GL(fold_gl);
    CHECK_CASE(fold_file);
    return check_summary();
}
