/* test_locallight.c - local lights against independent truths:
 *   - spec strings: every field parsed, the format round trip, bad specs refused with
 *     one line naming the flag and the problem; JSON scene lights (string and object),
 *     bad ones naming the file and the entry;
 *   - the .prt file keeps the lights (LITE section) and reads them back; a file without
 *     lights has no LITE section;
 *   - analytic plane: a point light over an unoccluded Lambert plane gives kd/pi I cos / d^2
 *     at every vertex, in prt reference (black probe, so only the light's next-event
 *     estimation remains: deterministic), in the direct module and through the cpu runtime;
 *   - analytic shadow: a square occluder between the light and the plane: vertices inside
 *     its projected shadow get 0, those outside the analytic value (both runtimes, reference);
 *   - spot falloff over the plane against the smoothstep written out independently; a
 *     glossy Phong plane against the Phong formula by hand;
 *   - the GLSL BRDF (gllights.h) against brdf_eval for every model at random directions;
 *   - both runtimes (cpu and gl, through OSMesa) on the shadowed plane precomputed with a black
 *     probe: vertex colours equal the analytic answer, the gl per-pixel image equals it at every
 *     pixel seeing the plane away from the shadow's edge, the cpu (Gouraud) image stays near it,
 *     and the two images agree;
 *   - the command line: a scene's lights precomputed into the file (prt info lists them), render and
 *     reference --vertices with --probe none agree with each other, --no-file-lights drops the
 *     file's light and --light adds one; bad specs exit 2 with one line naming --light and write nothing;
 *   - furnace: a point light at the centre of a closed Lambert sphere (albedo a, inward
 *     normals): L = a/pi I/R^2 sum_{j<=k} a^j with k bounces (uniform interreflection). */
#include "harness.h"
#include "brdf.h"
#include "camera.h"
#include "image.h"
#include "direct.h"
#ifndef PRT_NO_GL
#include "glctx.h"
#include "gllights.h"
#endif
#include "lights.h"
#include "mesh.h"
#include "precompute.h"
#include "probe.h"
#include "prtfile.h"
#include "reference.h"
#include "runtime.h"
#include "scene.h"
#include "vec3.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define PI 3.14159265358979323846
#define KD 0.6f

/* One line naming what was wrong. */
static void check_one_line(const prt_error *err, const char *needle) {
    CHECK(strstr(err->msg, needle) != NULL && !strchr(err->msg, '\n'), "'%s' not named in: %s", needle, err->msg);
}

static void parse_specs(void) {
    prt_error err = { { 0 } };
    prt_light l;
    CHECK(light_parse("point:pos=1,2,3;intensity=5;colour=1,0.5,0.25", "--light", &l, &err) == 0, "%s", err.msg);
    CHECK(l.type == PRT_LIGHT_POINT && l.pos[2] == 3 && l.intensity == 5 && l.colour[1] == 0.5f, "point fields");
    CHECK(light_parse("spot:pos=0,2,0;dir=0,-2,0;inner=10;outer=25", "--light", &l, &err) == 0, "%s", err.msg);
    CHECK(l.type == PRT_LIGHT_SPOT && l.dir[1] == -1 && l.inner_deg == 10 && l.outer_deg == 25 && l.intensity == 1,
          "spot fields, dir normalized, intensity default 1");
    char buf[512];
    light_format(&l, buf, sizeof buf);
    prt_light l2;
    CHECK(light_parse(buf, "x", &l2, &err) == 0 && !memcmp(&l, &l2, sizeof l), "format round trip: %s", buf);
    static const struct { const char *spec, *needle; } bad[] = {
        { "lamp:pos=0,0,0", "unknown type" }, { "point", "no position" }, { "point:pos=1,2", "bad value for pos" },
        { "point:pos=0,0,0;intensity=-1", "intensity" }, { "point:pos=0,0,0;dir=0,1,0", "spot lights only" },
        { "spot:pos=0,0,0;inner=40;outer=30", "inner" }, { "spot:pos=0,0,0;outer=190", "outer" },
        { "spot:pos=0,0,0;dir=0,0,0", "dir" }, { "point:pos=0,0,nan", "pos" }, { "point:pos=0,0,0;size=3", "unknown key" },
        { "point:pos=0,0,0;colour=1,-1,1", "colour" }, { "point:pos=0,0,0;intensity", "key=value" },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        CHECK(light_parse(bad[i].spec, "--light", &l, &err) == -1, "accepted %s", bad[i].spec);
        check_one_line(&err, bad[i].needle);
        check_one_line(&err, "--light");
    }
    prt_lights ls = { 0 };
    CHECK(light_parse("point:pos=0,1,0", "x", &l, &err) == 0, "%s", err.msg);
    for (int i = 0; i < PRT_MAX_LIGHTS; i++) CHECK(lights_add(&ls, &l, "x", &err) == 0, "add %d", i);
    CHECK(lights_add(&ls, &l, "--light", &err) == -1, "one light too many accepted");
    check_one_line(&err, "more than");
}

static const char *k_json_head = "{\"models\":[{\"sphere\":{\"radius\":0.5,\"rings\":6,\"segments\":8}}],\"lights\":";

static int json_with(const char *lights, prt_scene *s, prt_error *err) {
    char text[1024];
    snprintf(text, sizeof text, "%s%s}", k_json_head, lights);
    return scene_parse_json("room.json", text, strlen(text), NULL, s, err);
}

static void json_lights(void) {
    prt_error err = { { 0 } };
    prt_scene s = { 0 };
    int rc = json_with("[\"point:pos=0,2,0;intensity=3\", {\"type\":\"spot\",\"pos\":[1,2,3],\"dir\":[0,0,-3],"
                       "\"inner\":5,\"outer\":15,\"intensity\":7,\"colour\":[1,0.5,0.5]}]", &s, &err);
    CHECK(rc == 0, "%s", err.msg);
    CHECK(rc || (s.lights.count == 2 && s.lights.light[0].intensity == 3 && s.lights.light[1].type == PRT_LIGHT_SPOT &&
                 s.lights.light[1].dir[2] == -1 && s.lights.light[1].outer_deg == 15 && s.lights.light[1].colour[1] == 0.5f),
          "fields");
    scene_free(&s);
    static const struct { const char *lights, *needle; } bad[] = {
        { "{}", "lights" }, { "[3]", "lights[0]" }, { "[{\"type\":\"lamp\",\"pos\":[0,0,0]}]", "type" },
        { "[{\"type\":\"point\"}]", "pos" }, { "[{\"type\":\"point\",\"pos\":[0,0,0],\"size\":1}]", "unknown key" },
        { "[{\"type\":\"point\",\"pos\":[0,0,0],\"dir\":[0,1,0]}]", "spot lights only" },
        { "[\"point:pos=0,0,0\",\"spot:pos=0,0,0;inner=50\"]", "lights[1]" },
        { "[{\"type\":\"point\",\"pos\":[0,0,0],\"intensity\":-2}]", "intensity" },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        memset(&s, 0, sizeof s);
        CHECK(json_with(bad[i].lights, &s, &err) == -1, "accepted %s", bad[i].lights);
        check_one_line(&err, bad[i].needle);
        check_one_line(&err, "room.json");
        scene_free(&s);
    }
}

/* ---------------------------------------------------------------- the plane scene */

static const float k_lpos[3] = { 0.2f, 1.0f, 0.1f }, k_I = 5, k_col[3] = { 1, 0.5f, 0.25f };
static const float k_occ = 0.15f, k_occ_y = 0.5f;   /* occluder: |x|,|z| <= k_occ at height k_occ_y */

/* A 41x41 plane on [-1,1]^2 at y = 0 (vertices first), optionally a small square occluder above it. */
static int plane_scene(bool occluder, const char *material, prt_scene *s, int *nfloor) {
    prt_error err = { { 0 } };
    prt_mesh m = { 0 }, o = { 0 };
    int rc = mesh_make_plane(&m, -1, 1, -1, 1, 0, 41, 41, &err);
    *nfloor = m.nverts;
    if (rc == 0 && occluder) rc = mesh_make_plane(&o, -k_occ, k_occ, -k_occ, k_occ, k_occ_y, 4, 4, &err);
    if (rc == 0 && occluder) rc = mesh_append(&m, &o, &err);
    mesh_free(&o);
    if (rc == 0) rc = scene_from_mesh(&m, material, s, &err);
    CHECK(rc == 0, "%s", err.msg);
    return rc;
}

static prt_light point_light(void) {
    prt_light l = { .type = PRT_LIGHT_POINT, .intensity = k_I };
    memcpy(l.pos, k_lpos, sizeof l.pos);
    memcpy(l.colour, k_col, sizeof l.colour);
    return l;
}

/* Analytic radiance of a Lambert floor vertex at p (normal +y): kd/pi I cos / d^2, cos = h/d. */
static void plane_truth(const float p[3], float out[3]) {
    float d[3] = { k_lpos[0] - p[0], k_lpos[1] - p[1], k_lpos[2] - p[2] };
    double d2 = v3_dot(d, d), cosv = d[1] / sqrt(d2);
    for (int c = 0; c < 3; c++) out[c] = (float)(KD / PI * k_I * k_col[c] * cosv / d2);
}

/* -1: inside the occluder's shadow (margin m), 1: clearly lit, 0: near the edge. The shadow is
 * the occluder square projected from the light onto y = 0: x' = lx + (x - lx) ly / (ly - h). */
static int shadow_class(const float p[3], float m) {
    float s = k_lpos[1] / (k_lpos[1] - k_occ_y), in = 1e9f, out = -1e9f;
    for (int a = 0; a < 3; a += 2) {
        float lo = k_lpos[a] + (-k_occ - k_lpos[a]) * s, hi = k_lpos[a] + (k_occ - k_lpos[a]) * s;
        in = fminf(in, fminf(p[a] - lo, hi - p[a]));     /* > 0 inside along this axis */
        out = fmaxf(out, fmaxf(lo - p[a], p[a] - hi));   /* > 0 outside along this axis */
    }
    if (in > m) return -1;
    if (out > m) return 1;
    return 0;
}

/* Compares floor vertex colours rgb with the analytic answer; counts shadowed and lit vertices. */
static void check_plane(const char *who, const prt_scene *s, int nfloor, bool occluder, const float *rgb, double tol) {
    int nshadow = 0, nlit = 0;
    double worst = 0, worst_shadow = 0;
    for (int v = 0; v < nfloor; v++) {
        const float *p = s->mesh.pos + 3 * (size_t)v;
        int cls = occluder ? shadow_class(p, 0.03f) : 1;
        float t[3];
        plane_truth(p, t);
        for (int c = 0; c < 3; c++) {
            if (cls == 1) worst = fmax(worst, fabs(rgb[3 * v + c] - t[c]) / t[c]);
            if (cls == -1) worst_shadow = fmax(worst_shadow, fabs(rgb[3 * v + c]));
        }
        nshadow += cls == -1;
        nlit += cls == 1;
    }
    CHECK_LE(worst, tol, "%s: lit vertices against kd/pi I cos/d^2 (%d lit)", who, nlit);
    if (occluder) {
        CHECK(nshadow > 50, "%s: %d vertices in the shadow", who, nshadow);
        CHECK_LE(worst_shadow, 1e-6, "%s: shadowed vertices get no light (%d)", who, nshadow);
    }
}

static const float k_eye[3] = { 0.3f, 2.5f, 2.0f };

/* prt reference with a black probe and bounces 0: only the light's NEE remains (exact per vertex). */
static void ref_vertices(const prt_scene *s, int bounces, int spp, float *rgb, float *se) {
    prt_error err = { { 0 } };
    prt_probe black;
    const float zero[3] = { 0, 0, 0 };
    CHECK(probe_make_constant(zero, &black, &err) == 0, "%s", err.msg);
    ref_ctx *rc = ref_create(s, &black, NULL, &err);
    CHECK(rc != NULL, "%s", err.msg);
    ref_desc d = { .spp = spp, .bounces = bounces, .seed = 7 };
    if (rc) CHECK(ref_render_vertices(rc, k_eye, NULL, s->mesh.nverts, &d, rgb, se, NULL, &err) == 0, "%s", err.msg);
    ref_destroy(rc);
    probe_free(&black);
}

static void reference_plane(void) {
    for (int occ = 0; occ < 2; occ++) {
        prt_scene s = { 0 };
        int nf;
        if (plane_scene(occ, "lambert:kd=0.6", &s, &nf)) return;
        prt_error err = { { 0 } };
        prt_light l = point_light();
        CHECK(lights_add(&s.lights, &l, "test", &err) == 0, "%s", err.msg);
        float *rgb = calloc(3 * (size_t)s.mesh.nverts, sizeof(float));
        ref_vertices(&s, 0, 4, rgb, NULL);
        check_plane(occ ? "reference, shadowed" : "reference, open", &s, nf, occ, rgb, 1e-4);
        free(rgb);
        scene_free(&s);
    }
}

/* The direct module (the cpu runtime's local light) on the same planes. */
static void direct_plane(void) {
    for (int occ = 0; occ < 2; occ++) {
        prt_scene s = { 0 };
        int nf;
        if (plane_scene(occ, "lambert:kd=0.6", &s, &nf)) return;
        prt_error err = { { 0 } };
        prt_light l = point_light();
        CHECK(lights_add(&s.lights, &l, "test", &err) == 0, "%s", err.msg);
        direct_ctx *dc = direct_create(&s, 2, &err);
        CHECK(dc && direct_set_lights(dc, &s.lights, &err) == 0, "%s", err.msg);
        float *rgb = calloc(3 * (size_t)s.mesh.nverts, sizeof(float));
        if (dc) direct_shade_vertices(dc, k_eye, rgb);
        check_plane(occ ? "direct, shadowed" : "direct, open", &s, nf, occ, rgb, 1e-4);
        direct_destroy(dc);
        free(rgb);
        scene_free(&s);
    }
}

/* Smoothstep in cos between the cones, written out from the angles (not light_falloff). */
static double spot_truth(double ang_deg, double inner, double outer) {
    if (ang_deg <= inner) return 1;
    if (ang_deg >= outer) return 0;
    double ci = cos(inner * PI / 180), co = cos(outer * PI / 180), t = (cos(ang_deg * PI / 180) - co) / (ci - co);
    return t * t * (3 - 2 * t);
}

static void spot_falloff(void) {
    prt_scene s = { 0 };
    int nf;
    if (plane_scene(false, "lambert:kd=0.6", &s, &nf)) return;
    prt_error err = { { 0 } };
    prt_light l;
    CHECK(light_parse("spot:pos=0,1,0;dir=0,-1,0;inner=15;outer=35;intensity=5", "t", &l, &err) == 0, "%s", err.msg);
    lights_add(&s.lights, &l, "t", &err);
    float *rgb = calloc(3 * (size_t)s.mesh.nverts, sizeof(float));
    ref_vertices(&s, 0, 1, rgb, NULL);
    double worst = 0;
    int nin = 0, nedge = 0, nout = 0;
    for (int v = 0; v < nf; v++) {
        const float *p = s.mesh.pos + 3 * (size_t)v;
        double r2 = p[0] * p[0] + p[2] * p[2], d2 = r2 + 1, cosv = 1 / sqrt(d2), ang = acos(cosv) * 180 / PI;
        double f = spot_truth(ang, 15, 35), t = KD / PI * 5 * f * cosv / d2;
        worst = fmax(worst, fabs(rgb[3 * v] - t) / (KD / PI * 5));
        nin += f == 1;
        nout += f == 0;
        nedge += f > 0 && f < 1;
    }
    CHECK_LE(worst, 1e-5, "spot over the plane against the smoothstep falloff (%d in, %d edge, %d out)", nin, nedge, nout);
    CHECK(nin > 20 && nedge > 20 && nout > 20, "every part of the cone sampled: %d %d %d", nin, nedge, nout);
    free(rgb);
    scene_free(&s);
}

/* A glossy Phong plane: kd/pi + ks (n+2)/(2 pi) cos^n(alpha), alpha between wo and wi mirrored. */
static void phong_plane(void) {
    prt_scene s = { 0 };
    int nf;
    if (plane_scene(false, "phong:kd=0.3;ks=0.5;n=20", &s, &nf)) return;
    prt_error err = { { 0 } };
    prt_light l = point_light();
    lights_add(&s.lights, &l, "t", &err);
    float *rgb = calloc(3 * (size_t)s.mesh.nverts, sizeof(float)), *dir = calloc(3 * (size_t)s.mesh.nverts, sizeof(float));
    ref_vertices(&s, 0, 1, rgb, NULL);
    direct_ctx *dc = direct_create(&s, 2, &err);
    CHECK(dc && direct_set_lights(dc, &s.lights, &err) == 0, "%s", err.msg);
    if (dc) direct_shade_vertices(dc, k_eye, dir);
    double worst_ref = 0, worst_dir = 0, peak = 0;
    for (int v = 0; v < nf; v++) {
        const float *p = s.mesh.pos + 3 * (size_t)v;
        float wi[3] = { k_lpos[0] - p[0], k_lpos[1] - p[1], k_lpos[2] - p[2] }, wo[3] = { k_eye[0] - p[0], k_eye[1] - p[1], k_eye[2] - p[2] };
        double d2 = v3_dot(wi, wi);
        v3_normalize(wi);
        v3_normalize(wo);
        float r[3] = { -wi[0], wi[1], -wi[2] };   /* mirror of wi about +y */
        double ca = fmax(0, v3_dot(r, wo)), f = 0.3 / PI + 0.5 * 22 / (2 * PI) * pow(ca, 20);
        double t = f * k_I * wi[1] / d2;
        peak = fmax(peak, t);
        worst_ref = fmax(worst_ref, fabs(rgb[3 * v] - t) / t);
        worst_dir = fmax(worst_dir, fabs(dir[3 * v] - t) / t);
    }
    CHECK_LE(worst_ref, 1e-4, "reference against the Phong formula (peak %.3g)", peak);
    CHECK_LE(worst_dir, 1e-4, "direct module against the Phong formula");
    direct_destroy(dc);
    free(rgb);
    free(dir);
    scene_free(&s);
}

/* A point light at the centre of a closed sphere of inward normals: every point gets E = I/R^2
 * (cos 1), and the interreflected radiance is uniform, so each bounce multiplies by a. */
static void furnace(void) {
    prt_error err = { { 0 } };
    prt_mesh m = { 0 };
    const float c[3] = { 0, 0, 0 };
    const float R = 2, a = 0.5f;
    CHECK(mesh_make_sphere(&m, c, R, 24, 48, &err) == 0, "%s", err.msg);
    for (size_t i = 0; i < 3 * (size_t)m.nverts; i++) m.nrm[i] = -m.nrm[i];
    prt_scene s = { 0 };
    CHECK(scene_from_mesh(&m, "lambert:kd=0.5", &s, &err) == 0, "%s", err.msg);
    prt_light l = { .type = PRT_LIGHT_POINT, .pos = { 0.01f, 0.02f, -0.01f }, .intensity = 4, .colour = { 1, 1, 1 } };
    lights_add(&s.lights, &l, "t", &err);
    int n = s.mesh.nverts;
    float *rgb = calloc(3 * (size_t)n, sizeof(float)), *se = calloc(3 * (size_t)n, sizeof(float));
    for (int k = 0; k <= 2; k += 2) {
        /* the eye at the centre sees every inward vertex */
        prt_probe black;
        const float zero[3] = { 0, 0, 0 };
        probe_make_constant(zero, &black, &err);
        ref_ctx *rc = ref_create(&s, &black, NULL, &err);
        ref_desc d = { .spp = 32, .bounces = k, .seed = 3 };
        const float eye[3] = { 0, 0, 0 };
        CHECK(rc && ref_render_vertices(rc, eye, NULL, n, &d, rgb, se, NULL, &err) == 0, "%s", err.msg);
        double sum = 0, sum_se2 = 0;
        for (int v = 0; v < n; v++) sum += rgb[3 * v], sum_se2 += (double)se[3 * v] * se[3 * v];
        double mean = sum / n, se_mean = sqrt(sum_se2) / n, geo = 0;
        double Ld = a / PI * 4 / (R * R), truth = Ld * (k == 0 ? 1 : 1 + a + a * a);
        (void)geo;
        /* 1.5%: the tessellated sphere lies inside the true one (distance and cosine differ by < 1%). */
        CHECK_NEAR(mean, truth, 0.015 * truth + 3 * se_mean, "%d bounces: mean vertex radiance", k);
        ref_destroy(rc);
        probe_free(&black);
    }
    free(rgb);
    free(se);
    scene_free(&s);
}

/* ---------------------------------------------------------------- GL */

/* brdf_glsl at 2,000 random direction pairs per model equals brdf_eval (float vs double): 1e-3
 * relative, or 1e-4 of the largest value (grazing pow() near its clamp). */
static void glsl_brdf(void) {
#ifndef PRT_NO_GL   /* a build without GL skips the case (CHECK_CASE_GL) and has no gllights */
    static const char *specs[] = { "lambert:kd=0.3,0.5,0.7", "phong:kd=0.2;ks=0.6;n=40", "blinn:kd=0.1;ks=0.5;n=80",
                                   "as:kd=0.4;ks=0.2;nu=10;nv=200", "lafortune:kd=0.2;lobe=-0.8,-0.8,0.9,20;lobe=0.5,0.5,0.7,5",
                                   "ggx:kd=0.1;ks=0.04,0.5,0.9;alpha=0.15", "beckmann:kd=0.2;ks=0.3;alpha=0.4" };
    prt_error err = { { 0 } };
    glctx *ctx = glctx_create(GLCTX_AUTO, NULL, &err);
    CHECK(ctx != NULL, "%s", err.msg);
    if (!ctx) return;
    prt_scene s = { 0 };
    prt_mesh m = { 0 };
    CHECK(mesh_make_plane(&m, -1, 1, -1, 1, 0, 2, 2, &err) == 0 && scene_from_mesh(&m, specs[0], &s, &err) == 0, "%s", err.msg);
    for (size_t i = 1; i < sizeof specs / sizeof specs[0]; i++) CHECK(scene_material(&s, specs[i], &err) == (int)i, "%s", err.msg);
    gllights *L = gllights_create(&ctx->gl, &s, &err);
    CHECK(L != NULL, "%s", err.msg);
    enum { NP = 2000 };
    float *wi = malloc(sizeof(float) * 3 * NP), *wo = malloc(sizeof(float) * 3 * NP), *gpu = malloc(sizeof(float) * 3 * NP);
    uint32_t r = 12345;
    for (int i = 0; i < 2 * NP; i++) {   /* uniform on the sphere: a few below the horizon (0 on both) */
        float *w = i < NP ? wi + 3 * i : wo + 3 * (i - NP);
        r = r * 1664525u + 1013904223u;
        float z = -0.2f + 1.2f * (float)(r >> 8) / 16777216.f;
        r = r * 1664525u + 1013904223u;
        float phi = 6.2831853f * (float)(r >> 8) / 16777216.f, q = sqrtf(fmaxf(0, 1 - z * z));
        w[0] = q * cosf(phi), w[1] = q * sinf(phi), w[2] = z;
    }
    for (int mi = 0; L && mi < s.nmaterials; mi++) {
        CHECK(gllights_eval_brdf(L, mi, wi, wo, NP, gpu, &err) == 0, "%s", err.msg);
        double worst = 0, peak = 0;
        for (int i = 0; i < NP; i++) {
            float f[3];
            brdf_eval(&s.materials[mi], wi + 3 * i, wo + 3 * i, f);
            for (int c = 0; c < 3; c++) peak = fmax(peak, f[c]);
        }
        for (int i = 0; i < NP; i++) {
            float f[3];
            brdf_eval(&s.materials[mi], wi + 3 * i, wo + 3 * i, f);
            for (int c = 0; c < 3; c++) worst = fmax(worst, fabs(gpu[3 * i + c] - f[c]) / (fabs(f[c]) + 1e-1 * 1e-3 * peak));
        }
        CHECK_LE(worst, 1e-3, "%s: GLSL against brdf_eval (peak %.3g)", specs[mi], peak);
    }
    free(wi);
    free(wo);
    free(gpu);
    gllights_destroy(L);
    scene_free(&s);
    glctx_destroy(ctx);
#endif
}

/* Whether the camera ray from eye along d reaches the floor (y = 0, |x|,|z| < 0.95) before the
 * occluder; the floor point into p. */
static bool ray_floor(const float eye[3], const float d[3], float p[3]) {
    if (!(d[1] < 0)) return false;
    float to = (k_occ_y - eye[1]) / d[1], ox = eye[0] + to * d[0], oz = eye[2] + to * d[2];
    if (fabsf(ox) <= k_occ + 0.02f && fabsf(oz) <= k_occ + 0.02f) return false;
    float t = -eye[1] / d[1];
    for (int k = 0; k < 3; k++) p[k] = eye[k] + t * d[k];
    return fabsf(p[0]) < 0.95f && fabsf(p[2]) < 0.95f;
}

/* Worst relative error of img at lit floor pixels against the analytic answer, and the largest value at
 * shadowed ones (margin 0.06 from the shadow's edge). */
static void image_errors(const prt_camera *cam, const prt_image *img, double *worst, double *shadow_max) {
    *worst = 0;
    *shadow_max = 0;
    for (int y = 0; img->data && y < img->h; y++)
        for (int x = 0; x < img->w; x++) {
            float dir[3], p[3], t[3];
            camera_ray(cam, img->w, img->h, x + 0.5f, y + 0.5f, dir);
            if (!ray_floor(cam->eye, dir, p)) continue;
            int cls = shadow_class(p, 0.06f);
            plane_truth(p, t);
            const float *g = img->data + 3 * ((size_t)y * img->w + x);
            for (int k = 0; k < 3; k++) {
                if (cls == 1) *worst = fmax(*worst, fabs(g[k] - t[k]) / t[k]);
                if (cls == -1) *shadow_max = fmax(*shadow_max, fabs(g[k]));
            }
        }
}

/* The gl runtime with a spot light whose full cone (inner 60 degrees) covers the floor, so the
 * same analytic answer holds: its one perspective shadow map instead of the point light's cube. */
static void gl_spot(const prt_data *d, const prt_probe *black, const render_desc *rd) {
    prt_error err = { { 0 } };
    prt_lights ls = { 0 };
    prt_light l = point_light();
    l.type = PRT_LIGHT_SPOT;
    l.dir[1] = -1;
    l.inner_deg = 60;
    l.outer_deg = 70;
    lights_add(&ls, &l, "t", &err);
    runtime_desc desc = { .backend = "gl" };
    prt_runtime *rt = runtime_create(d, &desc, &err);
    prt_image img = { 0 };
    int rc = !rt || runtime_set_light(rt, black, NULL, &err) || runtime_set_local_lights(rt, &ls, &err) ||
             runtime_render(rt, rd, &img, &err);
    CHECK(rc == 0, "gl spot: %s", err.msg);
    double worst, shadow_max;
    image_errors(&rd->camera, &img, &worst, &shadow_max);
    CHECK_LE(worst, 1e-3, "gl image, spot light's perspective map: lit pixels against the analytic answer");
    CHECK_LE(shadow_max, 1e-6, "gl image, spot light's perspective map: black inside the shadow");
    image_free(&img);
    runtime_destroy(rt);
}

/* The shadowed plane through both runtimes (see the header). */
static void runtimes_plane(void) {
    prt_scene s = { 0 };
    int nf;
    if (plane_scene(true, "lambert:kd=0.6", &s, &nf)) return;
    prt_error err = { { 0 } };
    prt_light l = point_light();
    lights_add(&s.lights, &l, "t", &err);
    prt_data d;
    precompute_desc pd = { .N = 16, .vis_res = 64, .quiet = true, .force_bounces = -1 };
    CHECK(precompute_run(&s, &pd, &d, &err) == 0, "%s", err.msg);
    prt_probe black;
    const float zero[3] = { 0, 0, 0 };
    probe_make_constant(zero, &black, &err);
    enum { IW = 160, IH = 120 };
    prt_camera cam = { .eye = { 0.1f, 2.2f, 1.6f }, .target = { 0, 0, 0 }, .up = { 0, 1, 0 }, .fov_deg = 50 };
    render_desc rd = { .width = IW, .height = IH, .camera = cam };
    int n = d.scene.mesh.nverts;
    float *rgb[2] = { calloc(3 * (size_t)n, sizeof(float)), calloc(3 * (size_t)n, sizeof(float)) };
    prt_image img[2] = { { 0 } };
    static const char *names[2] = { "cpu", "gl" };
    for (int b = 0; b < 2; b++) {
        runtime_desc desc = { .backend = names[b], .threads = 2 };
        prt_runtime *rt = runtime_create(&d, &desc, &err);
        int rc = !rt || runtime_set_light(rt, &black, NULL, &err) || runtime_set_local_lights(rt, &d.scene.lights, &err) ||
                 runtime_shade_vertices(rt, cam.eye, rgb[b], &err) || runtime_render(rt, &rd, &img[b], &err);
        CHECK(rc == 0, "%s: %s", names[b], err.msg);
        if (rc == 0) check_plane(b ? "gl vertex colours" : "cpu vertex colours", &d.scene, nf, true, rgb[b], 1e-4);
        runtime_timing t;
        if (rt) runtime_get_timing(rt, &t);
        CHECK(!rt || (t.local_ms > 0 && isfinite(t.local_ms)), "%s: light-move time %g ms", names[b], rt ? t.local_ms : 0);
        runtime_destroy(rt);
    }
    /* Per pixel: the floor point each pixel sees, classified and compared. */
    double worst_gl = 0, worst_cpu = 0, sum_d2 = 0, sum_t2 = 0, worst_shadow = 0;
    int nlit = 0, nshadow = 0;
    for (int y = 0; img[0].data && img[1].data && y < IH; y++)
        for (int x = 0; x < IW; x++) {
            float dir[3], p[3], t[3];
            camera_ray(&cam, IW, IH, x + 0.5f, y + 0.5f, dir);
            if (!ray_floor(cam.eye, dir, p)) continue;
            int cls = shadow_class(p, 0.06f);
            plane_truth(p, t);
            const float *g = img[1].data + 3 * ((size_t)y * IW + x), *c = img[0].data + 3 * ((size_t)y * IW + x);
            for (int k = 0; k < 3; k++) {
                if (cls == 1) {
                    worst_gl = fmax(worst_gl, fabs(g[k] - t[k]) / t[k]);
                    worst_cpu = fmax(worst_cpu, fabs(c[k] - t[k]) / t[k]);
                    sum_d2 += (double)(g[k] - c[k]) * (g[k] - c[k]);
                    sum_t2 += (double)t[k] * t[k];
                }
                if (cls == -1) worst_shadow = fmax(worst_shadow, fmax(fabs(g[k]), fabs(c[k])));
            }
            nlit += cls == 1;
            nshadow += cls == -1;
        }
    CHECK(nlit > 2000 && nshadow > 200, "pixels: %d lit, %d in the shadow", nlit, nshadow);
    /* gl: per pixel, exact up to float (1e-3); cpu: Gouraud over a 0.05 grid of a smooth 1/d^3 falloff. */
    CHECK_LE(worst_gl, 1e-3, "gl image against kd/pi I cos/d^2 at lit pixels");
    CHECK_LE(worst_cpu, 2e-2, "cpu image against the analytic answer at lit pixels");
    CHECK_LE(sqrt(sum_d2 / sum_t2), 5e-3, "cpu and gl images agree (relative RMS, lit pixels)");
    CHECK_LE(worst_shadow, 1e-6, "both images black inside the shadow");
    gl_spot(&d, &black, &rd);
    for (int b = 0; b < 2; b++) {
        image_free(&img[b]);
        free(rgb[b]);
    }
    probe_free(&black);
    prt_data_free(&d);
    scene_free(&s);
}

/* ---------------------------------------------------------------- command line */

/* Reads a --vertices CSV's r column (first n rows) into out; the row count. */
static int read_csv_r(const char *path, float *out, int n) {
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    char line[512];
    int k = 0;
    if (!fgets(line, sizeof line, f)) { fclose(f); return 0; }
    while (k < n && fgets(line, sizeof line, f)) {
        int v;
        float r;
        if (sscanf(line, "%d,%f", &v, &r) == 2) out[k++] = r;
    }
    fclose(f);
    return k;
}

static int lines_of(const char *s) {
    int n = 0;
    for (const char *p = s; *p; p++) n += *p == '\n';
    return n + (*s && s[strlen(s) - 1] != '\n');
}

static void cli(void) {
    const char *D = check_tmpdir(), *B = check_prt_bin();
    char json[600], prt[600], cmd[4096], out[8192], a[600], b[600];
    snprintf(json, sizeof json, "%s/lit.json", D);
    snprintf(prt, sizeof prt, "%s/lit.prt", D);
    FILE *f = fopen(json, "w");
    if (!f) { CHECK(false, "cannot write %s", json); return; }
    fprintf(f, "{\"models\":[{\"plane\":{\"x\":[-1,1],\"z\":[-1,1],\"nx\":12,\"nz\":12},\"material\":\"lambert:kd=0.6\"},"
               "{\"plane\":{\"x\":[-0.15,0.15],\"z\":[-0.15,0.15],\"height\":0.5,\"nx\":3,\"nz\":3}}],"
               "\"lights\":[\"point:pos=0.2,1,0.1;intensity=5;colour=1,0.5,0.25\"]}\n");
    fclose(f);
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --coeffs 16 --vis-res 64 --no-bounces --quiet", B, json, prt);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
    prt_data d;
    prt_error err = { { 0 } };
    CHECK(prtfile_read(prt, &d, &err) == 0, "%s", err.msg);
    if (err.msg[0] == 0) {   /* the file keeps the JSON's light (LITE section) */
        CHECK(d.scene.lights.count == 1 && d.scene.lights.light[0].intensity == 5 && d.scene.lights.light[0].pos[0] == 0.2f &&
              d.scene.lights.light[0].colour[2] == 0.25f, "lights read back: %d", d.scene.lights.count);
        prt_data_free(&d);
    }
    snprintf(a, sizeof a, "%s/lit_r.csv", D);
    snprintf(b, sizeof b, "%s/lit_f.csv", D);
    /* the direct light alone: exact in both (the one bounce is the plan's where surfaces see each other) */
    snprintf(cmd, sizeof cmd, "%s render %s --probe none -o %s/lit.png --size 64x48 --vertices %s --no-local-bounce "
             "--no-highlights", B, prt, D, a);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
    snprintf(cmd, sizeof cmd, "%s reference %s --probe none --no-image --vertices %s --spp 2 --bounces 0 --quiet", B, prt, b);
    CHECK(check_run(cmd, out, sizeof out) == 0, "%s", out);
    float ra[200], rb[200];
    int na = read_csv_r(a, ra, 153), nb = read_csv_r(b, rb, 153);
    CHECK(na == 153 && nb == 153, "rows %d %d", na, nb);
    double worst = 0, peak = 0;
    for (int i = 0; i < na && i < nb; i++) worst = fmax(worst, fabs(ra[i] - rb[i])), peak = fmax(peak, rb[i]);
    CHECK(peak > 0.1, "the floor is lit (peak %g)", peak);
    CHECK_LE(worst, 1e-4 * peak, "render and reference --vertices agree with the file's light");
    snprintf(cmd, sizeof cmd, "%s render %s --probe none -o %s/lit.png --size 64x48 --vertices %s --no-local-bounce "
             "--no-highlights --no-file-lights "
             "--light 'point:pos=0.2,1,0.1;intensity=10;colour=1,0.5,0.25'", B, prt, D, a);
    CHECK(check_run(cmd, out, sizeof out) == 0 && read_csv_r(a, ra, 153) == 153, "%s", out);
    worst = 0;
    for (int i = 0; i < 153; i++) worst = fmax(worst, fabs(ra[i] - 2 * rb[i]));
    CHECK_LE(worst, 2e-4 * peak, "--no-file-lights and --light of twice the intensity: twice the radiance");
    /* Each prt start costs about a second on the shared machine: one bad spec per command. */
    static const char *runs[] = { "render %s --probe none -o %s/bad.png --light 'lamp:pos=0,0,0'",
                                  "reference %s --probe none -o %s/bad.exr --light 'spot:pos=0,1,0;outer=200'",
                                  "bench %s --probe none --frames 1 %s/x --light" };
    for (size_t i = 0; i < sizeof runs / sizeof runs[0]; i++) {
        char args[2048];
        snprintf(args, sizeof args, runs[i], prt, D);
        snprintf(cmd, sizeof cmd, "%s %s", B, args);
        int rc = check_run(cmd, out, sizeof out);
        CHECK(rc == 2 && lines_of(out) == 1 && strstr(out, "--light"), "%s: exit %d: %s", args, rc, out);
    }
    snprintf(cmd, sizeof cmd, "%s/bad.png", D);
    struct stat st;
    CHECK(stat(cmd, &st) != 0, "no image written after a bad --light");
}

/* The local-light effects a file was made for are the default: a sphere over a floor with a point
 * light, where surfaces see each other, gets the plan's one bounce in prt render (the rows of
 * --local-bounce, bit for bit; --no-local-bounce gives less light) and in prt reference (their light
 * one bounce: more than --light-bounces 0, whose rows are those of --bounces 0 bit for bit under a
 * black probe, where the path's light is the point light's alone and its next event is exact). */
static void file_effects(void) {
    const char *D = check_tmpdir(), *B = check_prt_bin();
    char cmd[4096], out[8192], path[512], csv[5][512];
    snprintf(path, sizeof path, "%s/fx.json", D);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{ \"models\": [ { \"sphere\": {\"center\":[0,0.6,0], \"radius\":0.5, \"rings\":8, \"segments\":16},"
              " \"material\": \"lambert:kd=0.8\" } ], \"floor\": { \"vertices\": 100, \"size\": 2 },"
              " \"lights\": [ \"point:pos=0.7,1.5,0.3;intensity=4\" ] }\n", f);
        fclose(f);
    }
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s/fx.prt --vis-res 64 --no-bounces --quiet", B, path, D);
    CHECK(check_run(cmd, out, sizeof out) == 0, "precompute: %s", out);
#ifdef PRT_NO_GL
    const char *img = "";
#else
    char img[600];
    snprintf(img, sizeof img, "-o %s/fx.exr --size 32x24", D);
#endif
    static const char *flags[3] = { "", "--local-bounce", "--no-local-bounce" };
    float r[3][200];
    for (int i = 0; i < 3; i++) {
        snprintf(csv[i], sizeof csv[i], "%s/fx%d.csv", D, i);
        snprintf(cmd, sizeof cmd, "%s render %s/fx.prt --probe none %s --vertices %s %s", B, D, img, csv[i], flags[i]);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
        if (i == 0) CHECK(strstr(out, "one bounce on") != NULL, "render says the file's one bounce is on: %s", out);
        CHECK(read_csv_r(csv[i], r[i], 200) > 0, "%s", csv[i]);
    }
    double more = 0;
    int same = 1;
    for (int v = 0; v < 200; v++) same &= r[0][v] == r[1][v], more += r[0][v] - r[2][v];
    CHECK(same, "the default is --local-bounce, bit for bit");
    CHECK(more > 0, "and gives more light than --no-local-bounce (%g summed over the red channel)", more);
    static const char *refs[3] = { "", "--light-bounces 0 --bounces 2", "--bounces 0" };
    for (int i = 0; i < 3; i++) {
        snprintf(csv[2 + i], sizeof csv[2 + i], "%s/rf%d.csv", D, i);
        snprintf(cmd, sizeof cmd, "%s reference %s/fx.prt --probe none --no-image --vertices %s --spp 4 %s", B, D, csv[2 + i], refs[i]);
        CHECK(check_run(cmd, out, sizeof out) == 0, "%s: %s", cmd, out);
        if (i == 0) CHECK(strstr(out, "their light: 1 bounce)") != NULL, "reference says the file's one bounce: %s", out);
    }
    float a[200], b[200], c[200];
    int na = read_csv_r(csv[2], a, 200), nb = read_csv_r(csv[3], b, 200), nc = read_csv_r(csv[4], c, 200);
    CHECK(na > 0 && na == nb && nb == nc, "rows %d %d %d", na, nb, nc);
    double ab = 0;
    same = 1;
    for (int v = 0; v < na && v < 200; v++) same &= b[v] == c[v], ab += a[v] - b[v];
    CHECK(same, "--light-bounces 0 with --bounces 2 is --bounces 0 under a black probe, bit for bit");
    CHECK(ab > 0, "the file's one bounce adds light (%g summed)", ab);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(parse_specs);
    CHECK_CASE(json_lights);
    CHECK_CASE(reference_plane);
    CHECK_CASE(direct_plane);
    CHECK_CASE(spot_falloff);
    CHECK_CASE(phong_plane);
    CHECK_CASE(furnace);
    CHECK_CASE(file_effects);
    CHECK_CASE_GL(glsl_brdf);
    CHECK_CASE_GL(runtimes_plane);
    CHECK_CASE_GL(cli);
    return check_summary();
}
