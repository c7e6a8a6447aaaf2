/* test_reference.c - the path-traced reference against independent truths:
 *   - environment sampling: the pdf integrates to 1 (also rotated), E[L/pdf] = integral of L;
 *   - furnace: a Lambert sphere of albedo a under constant L, no bounces, gives a L at
 *     every vertex facing the eye (0 elsewhere), and its standard errors are calibrated;
 *   - a box open at the top (inward normals, albedo 1) under constant L converges to L
 *     with bounces = -1; its bottom centre with bounces = 0 matches the analytic
 *     point-to-rectangle view factor of the opening; bounces 0 < 1 < 2 < -1;
 *   - glossy Phong plane shadowed by a sphere under a smooth sky: vertex radiance equals
 *     a brute-force quadrature of Eq. 2 (analytic BRDF, ray-cast visibility on a fine grid);
 *   - MIS: environment-only, BRDF-only and MIS estimates agree on a sky with a small
 *     sun, and MIS has far lower variance than BRDF sampling;
 *   - images: camera framing, background, determinism per seed across thread counts;
 *   - clean errors (empty scene, vertex out of range, cancellation). */
#include "harness.h"
#include "brdf.h"
#include "camera.h"
#include "image.h"
#include "mesh.h"
#include "probe.h"
#include "reference.h"
#include "scene.h"
#include "vec3.h"
#include "visibility.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PI 3.14159265358979323846

/* z = (est - truth) / se statistics over many values. */
typedef struct zstats { int n, within2; double max_abs_z, sum_z2, max_rel; } zstats;
static void z_add(zstats *z, double est, double truth, double se) {
    double d = est - truth, zz = se > 0 ? d / se : (fabs(d) < 1e-6 * fabs(truth) + 1e-9 ? 0 : 1e9);
    z->n++;
    z->within2 += fabs(zz) <= 2;
    z->max_abs_z = fmax(z->max_abs_z, fabs(zz));
    z->sum_z2 += zz * zz;
    if (truth != 0) z->max_rel = fmax(z->max_rel, fabs(d / truth));
}

static int make_scene_mesh(prt_mesh *m, const char *spec, prt_scene *s) {
    prt_error err;
    if (scene_from_mesh(m, spec, s, &err)) { fprintf(stderr, "%s\n", err.msg); return -1; }
    return 0;
}

/* ---------------------------------------------------------------- environment sampling */

static void env_sampling(void) {
    prt_error err;
    prt_probe sky;
    sky_desc sd = { .width = 256, .sun_radius_deg = 3, .sun_radiance = 500 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    prt_mesh m;
    float c[3] = { 0, 0, 0 };
    CHECK(mesh_make_sphere(&m, c, 1, 8, 16, &err) == 0, "%s", err.msg);
    prt_scene s;
    CHECK(make_scene_mesh(&m, "lambert:kd=0.5", &s) == 0, "scene");
    float R[9];
    CHECK(probe_parse_rotation("70,20", R) == 0, "rotation parses");
    /* An angular-map probe (not latlong: the sampling grid is resampled through probe_eval). */
    prt_image aimg;
    CHECK(image_alloc(&aimg, 128, 128, 3, &err) == 0, "%s", err.msg);
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 128; x++) {
            float d2 = (float)((x - 40) * (x - 40) + (y - 70) * (y - 70));
            for (int ch = 0; ch < 3; ch++) aimg.data[3 * (y * 128 + x) + ch] = 1.f + ch * 0.2f + 50.f * expf(-d2 / 20.f);
        }
    prt_probe ang;
    CHECK(probe_from_image(&aimg, PROBE_ANGULAR, "angular test probe", &ang, &err) == 0, "%s", err.msg);
    for (int rot = 0; rot < 3; rot++) {
        ref_ctx *rc = ref_create(&s, rot == 2 ? &ang : &sky, rot == 1 ? R : NULL, &err);
        CHECK(rc != NULL, "%s", err.msg);
        if (!rc) continue;
        /* Integral of the pdf and of L over the sphere by a fine midpoint grid (world frame). */
        enum { GW = 2048, GH = 1024 };
        double ipdf = 0, iL = 0;
        for (int y = 0; y < GH; y++) {
            double ct0 = cos(PI * y / GH), ct1 = cos(PI * (y + 1) / GH), dw = 2 * PI / GW * (ct0 - ct1);
            double ct = 0.5 * (ct0 + ct1), st = sqrt(1 - ct * ct);
            for (int x = 0; x < GW; x++) {
                double ph = 2 * PI * (x + 0.5) / GW;
                float w[3] = { (float)(st * cos(ph)), (float)ct, (float)(st * sin(ph)) }, L[3];
                ipdf += ref_env_pdf(rc, w) * dw;
                ref_env_radiance(rc, w, L);
                iL += L[1] * dw;
            }
        }
        CHECK_NEAR(ipdf, 1.0, 2e-3, "environment pdf integrates to 1 (case %d: sky, rotated sky, angular)", rot);
        /* E[L/pdf] by environment samples; the sample's pdf agrees with ref_env_pdf. */
        int n = 200000, pdf_mismatch = 0;
        double sum = 0, sum2 = 0;
        unsigned st = 12345;
        for (int i = 0; i < n; i++) {
            float u[4], w[3], pdf, L[3];
            for (int k = 0; k < 4; k++) { st = st * 1664525u + 1013904223u; u[k] = (st >> 8) * (1.f / 16777216.f); }
            if (!ref_env_sample(rc, u, w, &pdf)) { pdf_mismatch++; continue; }
            float p2 = ref_env_pdf(rc, w);
            if (fabsf(p2 - pdf) > 1e-3f * pdf) pdf_mismatch++;
            ref_env_radiance(rc, w, L);
            double v = L[1] / pdf;
            sum += v;
            sum2 += v * v;
        }
        double mean = sum / n, se = sqrt((sum2 / n - mean * mean) / n);
        CHECK(pdf_mismatch <= n / 10000, "%d samples whose pdf disagrees with ref_env_pdf", pdf_mismatch);
        CHECK_NEAR(mean, iL, 4 * se + 2e-3 * iL, "E[L/pdf] = integral of L (case %d, se %.3g)", rot, se);
        CHECK_LE(se / mean, 0.01, "importance sampling makes L/pdf nearly constant");
        ref_destroy(rc);
    }
    /* The rotation moves the light: radiance at R d equals the probe at d. */
    ref_ctx *rc = ref_create(&s, &sky, R, &err);
    float d[3] = { 0.3f, 0.8f, -0.52f }, Rd[3], a[3], b[3];
    v3_normalize(d);
    for (int i = 0; i < 3; i++) Rd[i] = R[3 * i] * d[0] + R[3 * i + 1] * d[1] + R[3 * i + 2] * d[2];
    ref_env_radiance(rc, Rd, a);
    probe_eval(&sky, d, b);
    CHECK(fabsf(a[0] - b[0]) + fabsf(a[1] - b[1]) + fabsf(a[2] - b[2]) < 1e-4f * (b[0] + b[1] + b[2]), "L_rot(R d) = L(d)");
    ref_destroy(rc);
    /* An all-black probe: no environment samples, radiance zero, no NaN. */
    prt_probe black;
    float zero[3] = { 0, 0, 0 };
    CHECK(probe_make_constant(zero, &black, &err) == 0, "%s", err.msg);
    rc = ref_create(&s, &black, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    if (rc) {
        float u[4] = { 0.5f, 0.5f, 0.5f, 0.5f }, w[3], pdf = 1;
        CHECK(!ref_env_sample(rc, u, w, &pdf) && pdf == 0, "black probe has no samples");
        float rgb[3 * 4], se[3 * 4], eye[3] = { 0, 0, 5 };
        int verts[4] = { 0, 1, 2, 3 };
        ref_desc dd = { .spp = 16, .bounces = 2, .seed = 3 };
        CHECK(ref_render_vertices(rc, eye, verts, 4, &dd, rgb, se, NULL, &err) == 0, "%s", err.msg);
        int nz = 0;
        for (int i = 0; i < 12; i++) nz += rgb[i] != 0.f || se[i] != 0.f;
        CHECK(nz == 0, "black probe gives exact zeros");
        ref_destroy(rc);
    }
    probe_free(&black);
    probe_free(&ang);
    scene_free(&s);
    probe_free(&sky);
}

/* ---------------------------------------------------------------- furnace */

static void furnace_sphere(void) {
    prt_error err;
    prt_mesh m;
    float c[3] = { 0, 0, 0 };
    CHECK(mesh_make_sphere(&m, c, 1, 16, 32, &err) == 0, "%s", err.msg);
    prt_scene s;
    CHECK(make_scene_mesh(&m, "lambert:kd=0.6,0.3,0.9", &s) == 0, "scene");
    prt_probe env;
    float L[3] = { 1.0f, 2.0f, 0.5f }, a[3] = { 0.6f, 0.3f, 0.9f };
    CHECK(probe_make_constant(L, &env, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(&s, &env, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    if (!rc) return;
    int n = s.mesh.nverts;
    float *rgb = malloc(sizeof(float) * 3 * n), *se = malloc(sizeof(float) * 3 * n);
    float eye[3] = { 0.5f, 1.0f, 6.0f };
    ref_desc d = { .spp = 16384, .bounces = 0, .seed = 7 };
    ref_stats st;
    CHECK(ref_render_vertices(rc, eye, NULL, n, &d, rgb, se, &st, &err) == 0, "%s", err.msg);
    zstats z = { 0 };
    int away_nonzero = 0;
    for (int v = 0; v < n; v++) {
        if (!ref_vertex_faces(&s.mesh, v, eye)) {
            away_nonzero += rgb[3 * v] != 0 || rgb[3 * v + 1] != 0 || rgb[3 * v + 2] != 0;
            continue;
        }
        for (int ch = 0; ch < 3; ch++) z_add(&z, rgb[3 * v + ch], a[ch] * L[ch], se[3 * v + ch]);
    }
    printf("furnace sphere (%d values, %d spp): max |z| %.2f, mean z^2 %.2f, within 2 se %.1f%%, max rel err %.3g%%, %.2fs\n",
           z.n, d.spp, z.max_abs_z, z.sum_z2 / z.n, 100.0 * z.within2 / z.n, 100 * z.max_rel, st.seconds);
    CHECK(away_nonzero == 0, "%d vertices facing away are not black (one-sided surfaces)", away_nonzero);
    CHECK(z.n > 500, "enough vertices face the eye (%d)", z.n);
    CHECK_LE(z.max_rel, 0.01, "every vertex within 1%% of a L");
    CHECK_LE(z.max_abs_z, 4.5, "every vertex within 4.5 standard errors (~700 values: a 4-sigma excursion may happen)");
    CHECK(z.within2 >= 0.9 * z.n, "standard errors calibrated: %.1f%% within 2 se (95%% expected)", 100.0 * z.within2 / z.n);
    CHECK(z.sum_z2 / z.n > 0.6 && z.sum_z2 / z.n < 1.4, "standard errors calibrated: mean z^2 = %.2f", z.sum_z2 / z.n);
    CHECK(st.dropped == 0 && st.paths == (long)n * d.spp && st.rays >= (long)(z.n / 3) * d.spp, "stats: %ld paths %ld rays", st.paths, st.rays);
    /* Image: pixels on the sphere are a L, background pixels the probe (L), black with black_background. */
    prt_camera cam;
    camera_default(s.bmin, s.bmax, 4.f / 3, &cam);
    prt_image img;
    ref_desc di = { .spp = 16, .bounces = 0, .seed = 1 };
    float *ise = malloc(sizeof(float) * 3 * 40 * 30);
    CHECK(ref_render_image(rc, &cam, 40, 30, &di, &img, ise, NULL, &err) == 0, "%s", err.msg);
    float *ctr = img.data + 3 * (15 * 40 + 20), *ctr_se = ise + 3 * (15 * 40 + 20), *corner = img.data;
    for (int ch = 0; ch < 3; ch++)
        CHECK_NEAR(ctr[ch], a[ch] * L[ch], 4 * ctr_se[ch], "image centre is the sphere: a L (channel %d)", ch);
    CHECK(ise[0] == 0 && ise[1] == 0, "background pixels are exact");
    free(ise);
    CHECK(fabsf(corner[0] - L[0]) < 1e-4f && fabsf(corner[1] - L[1]) < 1e-4f, "image corner is the background probe");
    image_free(&img);
    di.black_background = true;
    CHECK(ref_render_image(rc, &cam, 40, 30, &di, &img, NULL, NULL, &err) == 0, "%s", err.msg);
    CHECK(img.data[0] == 0 && img.data[1] == 0 && img.data[2] == 0, "black background");
    image_free(&img);
    ref_destroy(rc);
    free(rgb);
    free(se);
    probe_free(&env);
    scene_free(&s);
}

/* Point-to-parallel-rectangle view factor with the rectangle's corner over the point at height c. */
static double view_factor_corner(double a, double b, double c) {
    double A = a / c, B = b / c;
    return (A / sqrt(1 + A * A) * atan(B / sqrt(1 + A * A)) + B / sqrt(1 + B * B) * atan(A / sqrt(1 + B * B))) / (2 * PI);
}

static void furnace_box(void) {
    prt_error err;
    prt_mesh m;
    float bmin[3] = { -1, 0, -1 }, bmax[3] = { 1, 2, 1 };
    CHECK(mesh_make_box(&m, bmin, bmax, 6, true, &err) == 0, "%s", err.msg);
    for (int i = 0; i < 3 * m.nverts; i++) m.nrm[i] = -m.nrm[i];   /* the inside is the lit side */
    prt_scene s;
    CHECK(make_scene_mesh(&m, "lambert:kd=1", &s) == 0, "scene");
    prt_probe env;
    float L[3] = { 1, 1, 1 };
    CHECK(probe_make_constant(L, &env, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(&s, &env, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    if (!rc) return;
    int n = s.mesh.nverts;
    float *rgb = malloc(sizeof(float) * 3 * n), *se = malloc(sizeof(float) * 3 * n);
    float eye[3] = { 0, 1, 0 };   /* inside the box: every inward normal faces it */
    ref_desc d = { .spp = 64, .bounces = -1, .seed = 11 };
    ref_stats st;
    CHECK(ref_render_vertices(rc, eye, NULL, n, &d, rgb, se, &st, &err) == 0, "%s", err.msg);
    zstats z = { 0 };
    double mean = 0, mean_se2 = 0;
    for (int v = 0; v < n; v++) {
        z_add(&z, rgb[3 * v], 1.0, se[3 * v]);
        mean += rgb[3 * v] / n;
        mean_se2 += (double)se[3 * v] * se[3 * v] / ((double)n * n);
    }
    printf("furnace box, bounces -1 (%d vertices, %d spp): mean %.4f +- %.4f, max |z| %.2f, %.2fs\n", n, d.spp, mean,
           sqrt(mean_se2), z.max_abs_z, st.seconds);
    CHECK_NEAR(mean, 1.0, fmax(4 * sqrt(mean_se2), 0.002), "mean radiance inside an albedo-1 box is L");
    CHECK_LE(z.max_abs_z, 5.0, "every vertex within 5 standard errors of L");
    CHECK(z.within2 >= 0.88 * z.n, "%.1f%% within 2 se", 100.0 * z.within2 / z.n);
    /* Bottom centre, direct only: a L F(opening), F from four 1x1 quarter rectangles at height 2. */
    int centre = -1;
    for (int v = 0; v < n; v++) {
        const float *p = s.mesh.pos + 3 * v;
        if (fabsf(p[0]) < 1e-4f && fabsf(p[1]) < 1e-4f && fabsf(p[2]) < 1e-4f) centre = v;
    }
    CHECK(centre >= 0, "the bottom face has a centre vertex");
    if (centre >= 0) {
        double F = 4 * view_factor_corner(1, 1, 2);
        float c0[3], s0[3], c1[3], s1[3], c2[3], s2[3], cinf[3], sinf_[3];
        ref_desc dc = { .spp = 40000, .bounces = 0, .seed = 5 };
        CHECK(ref_render_vertices(rc, eye, &centre, 1, &dc, c0, s0, NULL, &err) == 0, "%s", err.msg);
        CHECK_NEAR(c0[0], F, 4 * s0[0] + 1e-3 * F, "direct = view factor of the opening (F = %.5f)", F);
        dc.bounces = 1;
        ref_render_vertices(rc, eye, &centre, 1, &dc, c1, s1, NULL, &err);
        dc.bounces = 2;
        ref_render_vertices(rc, eye, &centre, 1, &dc, c2, s2, NULL, &err);
        dc.bounces = -1;
        ref_render_vertices(rc, eye, &centre, 1, &dc, cinf, sinf_, NULL, &err);
        printf("box bottom centre: B0 %.4f +- %.4f (F %.4f)  B1 %.4f  B2 %.4f  B-1 %.4f +- %.4f\n", c0[0], s0[0], F, c1[0], c2[0], cinf[0], sinf_[0]);
        CHECK(c0[0] + 4 * s0[0] < c1[0] && c1[0] + 4 * s1[0] < c2[0] && c2[0] + 4 * s2[0] < cinf[0],
              "each bounce adds light: %.3f < %.3f < %.3f < %.3f", c0[0], c1[0], c2[0], cinf[0]);
        CHECK_NEAR(cinf[0], 1.0, 4 * sinf_[0], "bottom centre converges to L");
    }
    ref_destroy(rc);
    free(rgb);
    free(se);
    probe_free(&env);
    scene_free(&s);
}

/* ---------------------------------------------------------------- glossy vs brute force */

/* Plane (material 0) with a sphere (material 1) hovering over it. */
static int make_plane_sphere(const char *plane_spec, const char *sphere_spec, prt_scene *s) {
    prt_error err;
    prt_mesh plane, sph;
    float c[3] = { 0.3f, 0.8f, 0.0f };
    if (mesh_make_plane(&plane, -2, 2, -2, 2, 0, 21, 21, &err)) return -1;
    if (mesh_make_sphere(&sph, c, 0.5f, 16, 32, &err)) return -1;
    int first = plane.nverts;
    if (mesh_append(&plane, &sph, &err)) return -1;
    mesh_free(&sph);
    if (scene_from_mesh(&plane, plane_spec, s, &err)) return -1;
    int m1 = scene_material(s, sphere_spec, &err);
    if (m1 < 0) return -1;
    for (int v = first; v < s->mesh.nverts; v++) s->mesh.mat[v] = (uint16_t)m1;
    scene_update_bounds(s);
    return 0;
}

/* Eq. 2 by midpoint quadrature over the hemisphere of the vertex normal: GP x GT cells uniform in
 * (phi, cos theta), visibility by one occlusion ray per cell. */
static void brute_force_vertex(const prt_scene *s, const vis_scene *vs, const ref_ctx *rc, int v, const float eye[3],
                               float out[3]) {
    enum { GP = 1024, GT = 512 };
    const float *p = s->mesh.pos + 3 * v, *n = s->mesh.nrm + 3 * v;
    const brdf_params *bp = &s->materials[s->mesh.mat[v]];
    float S[3], T[3], wo[3], wol[3], o[3];
    brdf_frame(n, S, T);
    v3_sub(wo, eye, p);
    v3_normalize(wo);
    brdf_to_local(S, T, n, wo, wol);
    float eps = vis_eps(vs);
    v3_madd(o, p, n, eps);
    double acc[3] = { 0, 0, 0 }, dw = (2 * PI / GP) * (1.0 / GT);
    for (int j = 0; j < GT; j++) {
        double ct = (j + 0.5) / GT, st = sqrt(1 - ct * ct);
        for (int i = 0; i < GP; i++) {
            double ph = 2 * PI * (i + 0.5) / GP;
            float wil[3] = { (float)(st * cos(ph)), (float)(st * sin(ph)), (float)ct }, w[3], f[3], L[3];
            for (int k = 0; k < 3; k++) w[k] = S[k] * wil[0] + T[k] * wil[1] + n[k] * wil[2];
            brdf_eval(bp, wil, wol, f);
            if (f[0] == 0 && f[1] == 0 && f[2] == 0) continue;
            if (vis_occluded(vs, o, w, eps, INFINITY)) continue;
            ref_env_radiance(rc, w, L);
            for (int k = 0; k < 3; k++) acc[k] += (double)L[k] * f[k] * ct * dw;
        }
    }
    for (int k = 0; k < 3; k++) out[k] = (float)acc[k];
}

static void glossy_brute_force(void) {
    prt_error err;
    prt_scene s;
    CHECK(make_plane_sphere("phong:kd=0.2,0.3,0.1;ks=0.5;n=30", "lambert:kd=0.7", &s) == 0, "glossy scene");
    prt_probe sky;
    sky_desc sd = { .width = 512, .sun_dir = { 0.4f, 0.8f, 0.3f }, .sun_radius_deg = 12, .sun_radiance = 12 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(&s, &sky, NULL, &err);
    vis_scene *vs = vis_create(&s.mesh, &err);
    CHECK(rc && vs, "%s", err.msg);
    if (!rc || !vs) return;
    /* Plane vertices in and around the sphere's shadow and reflection, and two on the sphere. */
    const float eye[3] = { -2.5f, 2.0f, 3.0f };
    int verts[6], nv = 0;
    const float want[4][2] = { { 0.2f, 0.0f }, { -0.6f, -0.4f }, { 0.6f, 0.6f }, { -1.2f, 0.8f } };
    for (int k = 0; k < 4; k++) {
        int best = 0;
        float bd = 1e9f;
        for (int v = 0; v < 441; v++) {
            const float *p = s.mesh.pos + 3 * v;
            float dd = (p[0] - want[k][0]) * (p[0] - want[k][0]) + (p[2] - want[k][1]) * (p[2] - want[k][1]);
            if (dd < bd) { bd = dd; best = v; }
        }
        verts[nv++] = best;
    }
    /* On the sphere: the vertex facing the eye most, and one at about 60 degrees from it. */
    int vbest = 441, vmid = 441;
    float dbest = -2, dmid = 2;
    for (int v = 441; v < s.mesh.nverts; v++) {
        float wo[3];
        v3_sub(wo, eye, s.mesh.pos + 3 * v);
        v3_normalize(wo);
        float dd = v3_dot(wo, s.mesh.nrm + 3 * v);
        if (dd > dbest) { dbest = dd; vbest = v; }
        if (fabsf(dd - 0.5f) < fabsf(dmid - 0.5f)) { dmid = dd; vmid = v; }
    }
    verts[nv++] = vbest;
    verts[nv++] = vmid;
    float rgb[18], se[18];
    ref_desc d = { .spp = 8192, .bounces = 0, .seed = 2 };
    CHECK(ref_render_vertices(rc, eye, verts, nv, &d, rgb, se, NULL, &err) == 0, "%s", err.msg);
    for (int k = 0; k < nv; k++) {
        float bf[3];
        brute_force_vertex(&s, vs, rc, verts[k], eye, bf);
        printf("vertex %4d: path traced %.4f %.4f %.4f (se %.4f)  brute force %.4f %.4f %.4f\n", verts[k], rgb[3 * k],
               rgb[3 * k + 1], rgb[3 * k + 2], se[3 * k], bf[0], bf[1], bf[2]);
        for (int ch = 0; ch < 3; ch++)
            CHECK_NEAR(rgb[3 * k + ch], bf[ch], 4 * se[3 * k + ch] + 5e-3 * bf[ch],
                       "vertex %d channel %d: path tracer = quadrature of Eq. 2", verts[k], ch);
    }
    vis_destroy(vs);
    ref_destroy(rc);
    probe_free(&sky);
    scene_free(&s);
}

/* ---------------------------------------------------------------- MIS */

static void mis(void) {
    prt_error err;
    prt_scene s;
    CHECK(make_plane_sphere("phong:kd=0.4;ks=0.3;n=20", "lambert:kd=0.5", &s) == 0, "MIS scene");
    prt_probe sky;
    sky_desc sd = { .width = 512 };   /* default sun: 1.5 degrees, radiance 2000 */
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(&s, &sky, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    if (!rc) return;
    /* Vertices that see the sun: two far plane corners and the top of the sphere. */
    int verts[3] = { 20, 440, 441 };
    for (int v = 441; v < s.mesh.nverts; v++)
        if (s.mesh.pos[3 * v + 1] > s.mesh.pos[3 * verts[2] + 1]) verts[2] = v;
    const float eye[3] = { 3.0f, 2.5f, 2.0f };
    float val[3][9], se[3][9];
    const ref_strategy strat[3] = { REF_ENV_ONLY, REF_BRDF_ONLY, REF_MIS };
    const int spp[3] = { 4096, 262144, 4096 };
    for (int k = 0; k < 3; k++) {
        ref_desc d = { .spp = spp[k], .bounces = 0, .seed = 9, .strategy = strat[k] };
        CHECK(ref_render_vertices(rc, eye, verts, 3, &d, val[k], se[k], NULL, &err) == 0, "%s", err.msg);
    }
    for (int v = 0; v < 3; v++) {
        printf("vertex %d: env %.4f (se %.4f)  brdf %.4f (se %.4f)  mis %.4f (se %.4f)\n", verts[v], val[0][3 * v + 1],
               se[0][3 * v + 1], val[1][3 * v + 1], se[1][3 * v + 1], val[2][3 * v + 1], se[2][3 * v + 1]);
        for (int ch = 0; ch < 3; ch++) {
            int i = 3 * v + ch;
            CHECK_NEAR(val[0][i], val[2][i], 4 * hypot(se[0][i], se[2][i]), "env-only = MIS (vertex %d ch %d)", verts[v], ch);
            CHECK_NEAR(val[1][i], val[2][i], 4 * hypot(se[1][i], se[2][i]), "BRDF-only = MIS (vertex %d ch %d)", verts[v], ch);
            /* Variance per sample: se^2 * spp. */
            double var_mis = se[2][i] * se[2][i] * spp[2], var_brdf = se[1][i] * se[1][i] * spp[1];
            CHECK_LE(10 * var_mis, var_brdf, "MIS variance per sample is far below BRDF sampling's (vertex %d)", verts[v]);
        }
    }
    ref_destroy(rc);
    probe_free(&sky);
    scene_free(&s);
}

/* ---------------------------------------------------------------- determinism and errors */

static bool stop_now(void *user, const char *stage, double f) {
    (void)stage;
    (void)f;
    (*(int *)user)++;
    return false;
}

static void determinism_and_errors(void) {
    prt_error err;
    prt_scene s;
    CHECK(make_plane_sphere("phong:kd=0.4;ks=0.3;n=20", "lambert:kd=0.5", &s) == 0, "scene");
    prt_probe sky;
    sky_desc sd = { .width = 128 };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(&s, &sky, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    if (!rc) return;
    int n = s.mesh.nverts;
    float *a = malloc(sizeof(float) * 3 * n), *b = malloc(sizeof(float) * 3 * n), *c = malloc(sizeof(float) * 3 * n);
    float eye[3] = { 3, 3, 3 };
    ref_desc d = { .spp = 4, .bounces = 2, .seed = 42, .nthreads = 1 };
    ref_render_vertices(rc, eye, NULL, n, &d, a, NULL, NULL, &err);
    d.nthreads = 2;
    ref_render_vertices(rc, eye, NULL, n, &d, b, NULL, NULL, &err);
    d.seed = 43;
    ref_render_vertices(rc, eye, NULL, n, &d, c, NULL, NULL, &err);
    /* exact by construction: each vertex has its own random stream and is one thread's work, so the
     * same code on the same machine gives the same bits whatever the thread count */
    CHECK(memcmp(a, b, sizeof(float) * 3 * n) == 0, "same seed: identical on 1 and 2 threads");
    CHECK(memcmp(a, c, sizeof(float) * 3 * n) != 0, "another seed: different noise");
    /* A vertex computed alone equals the same vertex in the full run (per-vertex streams). */
    int v = 77;
    float one[3];
    d.seed = 42;
    ref_render_vertices(rc, eye, &v, 1, &d, one, NULL, NULL, &err);
    CHECK(memcmp(one, a + 3 * v, sizeof one) == 0, "per-vertex streams");
    prt_camera cam;
    camera_default(s.bmin, s.bmax, 1.f, &cam);
    prt_image i1, i2;
    ref_desc di = { .spp = 2, .bounces = 1, .seed = 5, .nthreads = 1 };
    ref_render_image(rc, &cam, 24, 24, &di, &i1, NULL, NULL, &err);
    di.nthreads = 2;
    ref_render_image(rc, &cam, 24, 24, &di, &i2, NULL, NULL, &err);
    CHECK(i1.data && i2.data && memcmp(i1.data, i2.data, sizeof(float) * 3 * 24 * 24) == 0, "images deterministic");
    int finite = 1;
    for (int i = 0; i < 3 * 24 * 24; i++) finite &= isfinite(i1.data[i]) && i1.data[i] >= 0;
    CHECK(finite, "image finite and non-negative");
    image_free(&i1);
    image_free(&i2);
    /* Errors. */
    int bad = n;
    CHECK(ref_render_vertices(rc, eye, &bad, 1, &d, one, NULL, NULL, &err) == -1 && strstr(err.msg, "out of range"),
          "vertex out of range: %s", err.msg);
    int calls = 0;
    ref_desc dc = { .spp = 1, .progress = stop_now, .progress_user = &calls };
    CHECK(ref_render_vertices(rc, eye, NULL, n, &dc, a, NULL, NULL, &err) == -1 && strstr(err.msg, "cancelled") && calls >= 1,
          "cancel from the progress callback: %s", err.msg);
    CHECK(ref_render_image(rc, &cam, 0, 10, &di, &i1, NULL, NULL, &err) == -1, "bad image size");
    ref_destroy(rc);
    prt_scene empty;
    memset(&empty, 0, sizeof empty);
    CHECK(ref_create(&empty, &sky, NULL, &err) == NULL && strstr(err.msg, "no triangles"), "empty scene: %s", err.msg);
    /* The CSV writer. */
    char path[512];
    snprintf(path, sizeof path, "%s/v.csv", check_tmpdir());
    float rgb[6] = { 1, 2, 3, 4, 5, 6 }, se2[6] = { 0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f };
    uint8_t facing[2] = { 1, 0 };
    CHECK(ref_write_vertex_csv(path, NULL, rgb, se2, facing, 2, &err) == 0, "%s", err.msg);
    FILE *f = fopen(path, "r");
    char buf[256] = { 0 };
    if (f) { size_t got = fread(buf, 1, sizeof buf - 1, f); buf[got] = 0; fclose(f); }
    CHECK(strcmp(buf, "vertex,r,g,b,stderr_r,stderr_g,stderr_b,facing\n0,1,2,3,0.1,0.2,0.30000001,1\n"
                      "1,4,5,6,0.40000001,0.5,0.60000002,0\n") == 0, "CSV contents: %s", buf);
    free(a);
    free(b);
    free(c);
    probe_free(&sky);
    scene_free(&s);
}

/* ---------------------------------------------------------------- command line, end to end */

/* Parses "rel_rmse=X max_rel_err=Y" from prt compare's output; returns false if absent. */
static bool parse_metrics(const char *out, double *rel_rmse, double *max_rel) {
    const char *p = strstr(out, "rel_rmse="), *q = strstr(out, "max_rel_err=");
    if (!p || !q) return false;
    *rel_rmse = atof(p + 9);
    *max_rel = atof(q + 12);
    return true;
}

/* Line of a per-vertex CSV (text) for vertex id, copied into line (without its newline); false if absent. */
static bool csv_line(const char *text, int id, char *line, size_t cap) {
    char key[32];
    int kn = snprintf(key, sizeof key, "\n%d,", id);
    const char *p = text ? strstr(text, key) : NULL;
    if (!p) return false;
    p++;
    size_t n = strcspn(p, "\n");
    snprintf(line, cap, "%.*s", (int)(n < cap ? n : cap - 1), p);
    return kn > 0;
}

/* prt reference --vertex-list: the listed vertices only, each the same row as in the full run (its
 * samples are seeded by the vertex id), 4x the samples halving its standard error; bad lists refused. */
static void cli_vertex_list(const char *dir, const char *prt) {
    char path[512], cmd[4096], out[8192];
    static const int ids[3] = { 3, 5, 17 };
    snprintf(path, sizeof path, "%s/list.csv", dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("vertex,r,g,b\n17,0,0,0\n3,0,0,0\n5,0,0,0\n", f);
        fclose(f);
    }
    for (int pass = 0; pass < 2; pass++) {
        snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr --no-image --vertices %s/sub%d.csv "
                 "--vertex-list %s --vertex-spp %d --quiet", prt, dir, dir, dir, pass, path, pass ? 4096 : 1024);
        int rc = check_run(cmd, out, sizeof out);
        CHECK(rc == 0, "reference --vertex-list (rc %d): %s", rc, out);
    }
    char p0[512], p1[512], pr[512], a[256], b[256], c[256];
    snprintf(p0, sizeof p0, "%s/sub0.csv", dir);
    snprintf(p1, sizeof p1, "%s/sub1.csv", dir);
    snprintf(pr, sizeof pr, "%s/ref.csv", dir);
    size_t len;
    char *t0 = check_read_file(p0, &len), *t1 = check_read_file(p1, &len), *tr = check_read_file(pr, &len);
    int lines = 0;
    for (const char *q = t0; q && *q; q++) lines += *q == '\n';
    CHECK(lines == 4, "header and 3 rows, got %d lines", lines);
    double se0 = 0, se1 = 0;
    for (int i = 0; i < 3; i++) {
        bool ok = csv_line(t0, ids[i], a, sizeof a) && csv_line(tr, ids[i], b, sizeof b) && csv_line(t1, ids[i], c, sizeof c);
        CHECK(ok && !strcmp(a, b), "vertex %d: listed row '%s' equals the full run's '%s'", ids[i], a, b);
        double v[7], w[7];
        if (ok && sscanf(a, "%*d,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]) == 7 &&
            sscanf(c, "%*d,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &w[0], &w[1], &w[2], &w[3], &w[4], &w[5], &w[6]) == 7)
            for (int k = 3; k < 6; k++) { se0 += v[k]; se1 += w[k]; }
    }
    CHECK(se0 > 0 && se1 / se0 > 0.4 && se1 / se0 < 0.62, "4x the samples: standard error x%.3f (1/2 expected)", se0 > 0 ? se1 / se0 : -1);
    free(t0);
    free(t1);
    free(tr);
    /* A vertex the scene does not have: exit 1, one line naming the list, no output. */
    f = fopen(path, "w");
    if (f) {
        fputs("vertex,r,g,b\n3,0,0,0\n100000,0,0,0\n", f);
        fclose(f);
    }
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr --no-image --vertices %s/sub2.csv --vertex-list %s --quiet",
             prt, dir, dir, dir, path);
    int rc = check_run(cmd, out, sizeof out);
    snprintf(p0, sizeof p0, "%s/sub2.csv", dir);
    const char *nl = strchr(out, '\n');
    CHECK(rc == 1 && strstr(out, "list.csv") && strstr(out, "out of range") && (!nl || !nl[1]) && access(p0, F_OK) != 0,
          "out-of-range list (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr -o %s/x.exr --vertex-list %s", prt, dir, dir, dir, path);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "--vertices"), "--vertex-list without --vertices (rc %d): %s", rc, out);
}

/* The whole text of path into buf[cap] ("" when unreadable). */
static const char *slurp(const char *path, char *buf, size_t cap) {
    FILE *f = fopen(path, "rb");
    size_t n = f ? fread(buf, 1, cap - 1, f) : 0;
    if (f) fclose(f);
    buf[n] = 0;
    return buf;
}

/* prt reference without --bounces traces the file's interreflection passes: the same rows, bit for
 * bit, as --bounces at that count (one seed, one sample sequence), and not those of --bounces 0 (the
 * floor sees the sphere). The status line says whose count it is. */
static void file_bounces(void) {
    const char *dir = check_tmpdir(), *prt = check_prt_bin();
    char path[512], cmd[4096], out[8192];
    static char a[1 << 20], b[1 << 20], c[1 << 20];
    prt_error err;
    prt_probe sky;
    sky_desc sd = { .width = 64, .sun_radiance = 1e-6f };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    snprintf(path, sizeof path, "%s/sky.exr", dir);
    image_desc idesc = { 0 };
    CHECK(image_write(path, &sky.img, &idesc, &err) == 0, "%s", err.msg);
    probe_free(&sky);
    snprintf(path, sizeof path, "%s/scene.json", dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{ \"models\": [ { \"sphere\": {\"center\":[0,1,0], \"radius\":1, \"rings\":8, \"segments\":16},"
              " \"material\": \"lambert:kd=0.8\" } ], \"floor\": { \"vertices\": 64 } }\n", f);
        fclose(f);
    }
    snprintf(cmd, sizeof cmd, "%s precompute %s/scene.json -o %s/b1.prt --vis-res 64 --bounces 1 --force-bounces --quiet", prt,
             dir, dir);
    CHECK(check_run(cmd, out, sizeof out) == 0, "precompute: %s", out);
    const char *runs[3] = { "", " --bounces 1", " --bounces 0" };
    char *rows[3] = { a, b, c };
    for (int i = 0; i < 3; i++) {
        snprintf(cmd, sizeof cmd, "%s reference %s/b1.prt --probe %s/sky.exr --no-image --vertices %s/r%d.csv --spp 4%s", prt,
                 dir, dir, dir, i, runs[i]);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
        if (i == 0) CHECK(strstr(out, "bounces 1 (the file's)") != NULL, "the status line names the file's count: %s", out);
        snprintf(path, sizeof path, "%s/r%d.csv", dir, i);
        slurp(path, rows[i], sizeof a);
    }
    CHECK(a[0] && !strcmp(a, b), "the default traces the file's one bounce: the rows of --bounces 1");
    CHECK(strcmp(a, c) != 0, "and not the direct light alone (--bounces 0)");
}

static void cli(void) {
    const char *dir = check_tmpdir(), *prt = check_prt_bin();
    char path[512], cmd[4096], out[8192];
    prt_error err;
    /* A smooth sky without a sun (PRT is accurate there) written as a latlong EXR. */
    prt_probe sky;
    sky_desc sd = { .width = 256, .sun_radiance = 1e-6f };
    CHECK(probe_make_sky(&sd, &sky, &err) == 0, "%s", err.msg);
    snprintf(path, sizeof path, "%s/sky.exr", dir);
    image_desc idesc = { 0 };
    CHECK(image_write(path, &sky.img, &idesc, &err) == 0, "%s", err.msg);
    probe_free(&sky);
    snprintf(path, sizeof path, "%s/scene.json", dir);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{ \"models\": [ { \"sphere\": {\"center\":[0,1,0], \"radius\":1}, \"material\": \"lambert:kd=0.8\" } ],\n"
              "  \"floor\": { \"vertices\": 400, \"material\": \"lambert:kd=0.6\" } }\n", f);
        fclose(f);
    }
    /* --bounces 0: the direct light alone, against a reference of the same (the file's bounce count) */
    snprintf(cmd, sizeof cmd, "%s precompute %s/scene.json -o %s/s.prt --vis-res 64 --bounces 0 --quiet", prt, dir, dir);
    int rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "precompute (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s render %s/s.prt --probe %s/sky.exr -o %s/prt.exr --vertices %s/prt.csv --size 128x96 --no-background",
             prt, dir, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "render (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr -o %s/ref.exr --vertices %s/ref.csv --size 128x96 "
             "--no-background --spp 64 --vertex-spp 1024 --quiet", prt, dir, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0, "reference (rc %d): %s", rc, out);
    /* Per vertex: PRT against the reference. Both see the same scene, camera and probe. */
    double rel, mx;
    snprintf(cmd, sizeof cmd, "%s compare %s/prt.csv %s/ref.csv", prt, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0 && parse_metrics(out, &rel, &mx), "compare vertices (rc %d): %s", rc, out);
    const char *noise = strstr(out, "ref_noise=");
    double ref_noise = noise ? atof(noise + 10) : 1;
    printf("prt vs reference per vertex: %s", out);
    CHECK_LE(rel, 0.05, "Lambert scene under a smooth sky: PRT within 5%% RMS of the reference (noise %.3g)", ref_noise);
    CHECK_LE(ref_noise, 0.02, "the reference's own noise is small at 1024 spp");
    snprintf(cmd, sizeof cmd, "%s compare %s/prt.exr %s/ref.exr --error-image %s/err.png", prt, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 0 && parse_metrics(out, &rel, &mx), "compare images (rc %d): %s", rc, out);
    printf("prt vs reference image: rel_rmse=%.4g max_rel_err=%.4g\n", rel, mx);
    CHECK_LE(rel, 0.15, "image within 15%% RMS (measured 6.5%%: 5.5%% noise at 64 spp, Gouraud vs per-pixel shading, and edge "
                        "pixels whose coverage the render's 4 samples take in quarters)");
    /* Bad input: one line, exit 1 for a missing file, 2 for usage. */
    snprintf(cmd, sizeof cmd, "%s reference %s/none.prt --probe %s/sky.exr -o %s/x.exr", prt, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 1 && strstr(out, "prt reference:") && strstr(out, "none.prt"), "missing .prt (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt -o %s/x.exr", prt, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "--probe"), "missing probe is a usage error (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr -o %s/x.exr --spp 0", prt, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "--spp"), "bad --spp (rc %d): %s", rc, out);
    snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr -o %s/x.png --exposure dark", prt, dir, dir, dir);
    rc = check_run(cmd, out, sizeof out);
    CHECK(rc == 2 && strstr(out, "--exposure"), "bad --exposure (rc %d): %s", rc, out);
    /* --exposure scales the radiance before the tone map, as prt render's: 3 stops down is darker */
    double mean[2] = { 0, 0 };
    for (int k = 0; k < 2; k++) {
        snprintf(cmd, sizeof cmd, "%s reference %s/s.prt --probe %s/sky.exr -o %s/e%d.png --size 32x24 --spp 4 --exposure %d --quiet", prt,
                 dir, dir, dir, k, -3 * k);
        rc = check_run(cmd, out, sizeof out);
        CHECK(rc == 0, "reference to PNG (rc %d): %s", rc, out);
        snprintf(path, sizeof path, "%s/e%d.png", dir, k);
        prt_image im = { 0 };
        if (rc == 0 && image_read(path, &im, &err) == 0) {
            for (int i = 0; i < im.c * im.w * im.h; i++) mean[k] += im.data[i] / ((double)im.c * im.w * im.h);
            image_free(&im);
        } else CHECK(0, "%s: %s", path, err.msg);
    }
    CHECK(mean[1] > 0.02 && mean[1] < 0.8 * mean[0], "--exposure -3: mean %g against %g at 0", mean[1], mean[0]);
    cli_vertex_list(dir, prt);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(env_sampling);
    CHECK_CASE(furnace_sphere);
    CHECK_CASE(furnace_box);
    CHECK_CASE(glossy_brute_force);
    CHECK_CASE(mis);
    CHECK_CASE(determinism_and_errors);
    CHECK_CASE(file_bounces);
    CHECK_CASE_GL(cli);
    return check_summary();
}
