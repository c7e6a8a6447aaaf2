/* test_plan.c - the effects plan: simulate only what the scene calls for.
 *
 * A lone convex sphere casts no light on itself, so no bounce pass is planned
 * even when bounces are allowed; a Lambert-only scene gets one BRDF term per
 * vertex; a box open at the top (surfaces facing each other) gets bounce passes
 * that brighten its inside; force_bounces and max_terms / term_error override
 * the plan; a progress callback can cancel; bad settings fail with a message.
 * The path per material (Lambert, SVD, Haar diffuse + vMF specular) decided by
 * measurement and printed with the reason; --glossy forces it; bad values are refused.
 * The time estimate covers every pass that runs (direct, each bounce, each vMF stage), one for one
 * (not its accuracy: docs/design/pipeline.md, "Effects plan", measures that); a BRDF reflecting more than it
 * receives gets one warning line in the plan, and the run goes on.
 * Local lights (planfx.h): the one bounce's measured share is exactly 0 over a lone plane (planned
 * off) and kd in a closed Lambert sphere lit from its centre (planned on); the force flags win;
 * prt_file_effects reads the measured, forced and older plan lines. Receivers: the floor's spacing
 * and a sun's penumbra against the floor's construction and h tan(a), and the plan's three
 * refinement modes (forced off, reported, applied within the budget). */
#include "harness.h"
#include "mesh.h"
#include "precompute.h"
#include "probe.h"
#include "relight.h"
#include "transfer.h"
#include "linear.h"
#include "refine.h"
#include "planfx.h"
#include "effects.h"
#include "visibility.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int make_sphere_scene(prt_scene *sc, const char *spec, prt_error *err) {
    prt_mesh m = { 0 };
    float c[3] = { 0, 1, 0 };
    if (mesh_make_sphere(&m, c, 1, 16, 32, err)) return -1;
    return scene_from_mesh(&m, spec, sc, err);
}

/* A box open at the top, seen from inside: mesh_make_box's normals point out of the box, so
 * they are flipped (and the triangles reversed) to make an open "room" whose floor and walls
 * face each other. */
static int make_box_scene(prt_scene *sc, prt_error *err) {
    prt_mesh m = { 0 };
    float lo[3] = { -1, 0, -1 }, hi[3] = { 1, 1, 1 };
    if (mesh_make_box(&m, lo, hi, 6, true, err)) return -1;
    for (int i = 0; i < 3 * m.nverts; i++) m.nrm[i] = -m.nrm[i];
    for (int t = 0; t < m.ntris; t++) {
        uint32_t x = m.tris[3 * t + 1];
        m.tris[3 * t + 1] = m.tris[3 * t + 2];
        m.tris[3 * t + 2] = x;
    }
    return scene_from_mesh(&m, "lambert:kd=0.8", sc, err);
}

/* Radiance of vertex v toward its normal under a constant white environment. */
static float radiance_up(const prt_data *d, int v) {
    prt_error err;
    prt_probe pr;
    float one[3] = { 1, 1, 1 }, rgb[3] = { 0, 0, 0 };
    if (probe_make_constant(one, &pr, &err)) return -1;
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    probe_to_cube(&pr, CUBE_RES, NULL, 0, cube);
    float (*L)[4] = transfer_light_vector(prt_data_transfer(d), cube);
    relight_ctx *rc = relight_create(d, 2, &err);
    if (rc) {
        relight_set_light(rc, (const float (*)[4])L);
        relight_vertex(rc, v, d->scene.mesh.nrm + 3 * v, 0, rgb);
        relight_destroy(rc);
    }
    free(L);
    free(cube);
    probe_free(&pr);
    return rgb[0];
}

static bool cancel_at_half(void *user, const char *stage, double f) {
    int *calls = user;
    (*calls)++;
    return f < 0.5;
}

static const precompute_desc base = { .no_open_sky = true, .N = 64, .vis_res = 64, .quiet = true, .nthreads = 2 };

/* A lone convex sphere: no bounce pass, and the plan says why. */
static void lone_sphere(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    CHECK(make_sphere_scene(&sc, "phong:kd=0.4;ks=0.3;n=20", &err) == 0, "%s", err.msg);
    precompute_desc d = base;
    d.bounces = 2;
    d.glossy = PRECOMPUTE_GLOSSY_SVD;   /* the K of the SVD path is what this checks */
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(out.stats.hit_fraction < 0.005, "convex sphere hit fraction %g", out.stats.hit_fraction);
    CHECK(out.stats.bounces == 0, "convex sphere: %d bounce passes", out.stats.bounces);
    CHECK(strstr(out.plan, "interreflections: none") != NULL, "plan: %s", out.plan);
    CHECK(out.factors[0].K == 4, "glossy default K = 4, got %d", out.factors[0].K);
    CHECK(strstr(out.plan, "material 0 phong: K=4") != NULL, "plan: %s", out.plan);
    CHECK(strstr(out.plan, "estimate: direct pass") != NULL, "plan has a time estimate");
    CHECK(strstr(out.plan, "known blocked") == NULL, "no floor, no floor shortcut: %s", out.plan);
    CHECK(sc.mesh.nverts == 0 && sc.mesh.pos == NULL, "scene moved into out");
    printf("--- plan for a lone sphere ---\n%s", out.plan);
    prt_data_free(&out);
}

/* Forced on: the sphere gets the passes anyway (carrying next to nothing). */
static void forced_bounces(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    CHECK(make_sphere_scene(&sc, "lambert:kd=0.5", &err) == 0, "%s", err.msg);
    d = base;
    d.bounces = 2;
    d.force_bounces = 1;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(out.stats.bounces == 2, "forced: %d passes", out.stats.bounces);
    CHECK_LE(out.stats.bounce_energy[0], 1e-4, "a convex sphere reflects nothing onto itself");
    CHECK(strstr(out.plan, "forced") != NULL, "plan: %s", out.plan);
    prt_data_free(&out);
}

/* With a floor the plan says its rays down are settled untraced (visibility.h; the maps' equality
 * with tracing is visibility/floor_culling's). */
static void floor_shortcut(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    CHECK(make_sphere_scene(&sc, "lambert:kd=0.5", &err) == 0, "%s", err.msg);
    CHECK(scene_add_floor(&sc, 256, 3, NULL, &err) == 0, "%s", err.msg);
    precompute_desc d = base;
    d.bounces = 0;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(strstr(out.plan, "rays down to the floor are known blocked") != NULL, "plan: %s", out.plan);
    prt_data_free(&out);
}

/* Lambert only: K = 1 everywhere, one vector per vertex. */
static void lambert_only(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    {
        prt_mesh pl = { 0 }, sp = { 0 };
        float c[3] = { 0, 1, 0 };
        CHECK(mesh_make_plane(&pl, -2, 2, -2, 2, 0, 8, 8, &err) == 0, "%s", err.msg);
        CHECK(mesh_make_sphere(&sp, c, 0.5f, 10, 20, &err) == 0, "%s", err.msg);
        int first = pl.nverts;
        CHECK(mesh_append(&pl, &sp, &err) == 0, "%s", err.msg);
        mesh_free(&sp);
        CHECK(scene_from_mesh(&pl, "lambert:kd=0.7", &sc, &err) == 0, "%s", err.msg);
        CHECK(scene_material(&sc, "lambert:kd=0.2,0.4,0.6", &err) == 1, "%s", err.msg);
        for (int v = first; v < sc.mesh.nverts; v++) sc.mesh.mat[v] = 1;
        d = base;
        CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
        CHECK(out.factors[0].K == 1 && out.factors[1].K == 1, "Lambert K = %d, %d", out.factors[0].K, out.factors[1].K);
        CHECK(out.transfers[0].transport.nvecs == out.scene.mesh.nverts, "one vector per vertex");
        CHECK(strstr(out.plan, "material 1 lambert: K=1") != NULL, "plan: %s", out.plan);
        /* interreflections are the plan's by default (up to 3 passes, adaptive stop) */
        CHECK(strstr(out.plan, "up to 3 passes") != NULL, "plan plans up to 3 passes by default: %s", out.plan);
        CHECK(out.stats.bounces >= 1 && out.stats.bounces <= 3, "default bounce passes: %d", out.stats.bounces);
        prt_data_free(&out);
    }
}

/* A box open at the top: concave, so bounces are planned and brighten the inside. */
static void open_box(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    CHECK(make_box_scene(&sc, &err) == 0, "%s", err.msg);
    d = base;
    d.force_bounces = -1;
    d.bounces = 3;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(out.stats.bounces == 0, "forced off: %d passes", out.stats.bounces);
    CHECK(strstr(out.plan, "forced off") != NULL, "plan: %s", out.plan);
    /* the centre of the box's floor: the vertex nearest (0, 0, 0) with normal +y */
    int centre = -1;
    float best = 1e9f;
    for (int v = 0; v < out.scene.mesh.nverts; v++) {
        const float *p = out.scene.mesh.pos + 3 * v, *n = out.scene.mesh.nrm + 3 * v;
        float dd = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        if (n[1] > 0.99f && dd < best) { best = dd; centre = v; }
    }
    CHECK(centre >= 0 && best < 1e-6f, "box floor centre vertex");
    float direct = radiance_up(&out, centre);
    /* Direct light at the floor centre is albedo x the form factor of the 2 x 2 opening at height 1:
     * F = (2/pi) [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))], X = Y = 1
     * (a point under the centre of a rectangle); 2% covers the 8-bit and 16-bit steps and the 64^2 cube. */
    double ff = 2 / M_PI * 2 * (1 / sqrt(2.0)) * atan(1 / sqrt(2.0));
    CHECK_NEAR(direct, 0.8 * ff, 0.02 * 0.8 * ff, "box floor centre, direct only");
    double hit_box = out.stats.hit_fraction;
    prt_data_free(&out);

    CHECK(make_box_scene(&sc, &err) == 0, "%s", err.msg);
    d = base;
    d.bounces = 3;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(hit_box > 0.1, "open box: %.1f%% of rays hit", 100 * hit_box);
    CHECK(out.stats.bounces >= 1, "open box: %d bounce passes", out.stats.bounces);
    CHECK(out.stats.bounce_energy[0] > 0.01, "first bounce energy %g", out.stats.bounce_energy[0]);
    for (int b = 1; b < out.stats.bounces; b++)
        CHECK(out.stats.bounce_energy[b] < out.stats.bounce_energy[b - 1], "bounce energies decrease");
    if (out.stats.bounces < 3)
        CHECK(out.stats.bounce_energy[out.stats.bounces - 1] < 0.01, "stopped only below the threshold");
    float bounced = radiance_up(&out, centre);
    /* Under a constant white sky the floor centre of the box sees 0.8 * (open fraction) directly;
     * the walls it sees reflect more: the bounce brightens it, but less than a closed furnace would
     * (radiance stays below the albedo 0.8). */
    CHECK(bounced > direct * 1.05f, "bounces brighten the box floor: %g -> %g", direct, bounced);
    CHECK(bounced < 0.8f, "below the albedo: %g", bounced);
    printf("--- plan for an open box ---\n%s", out.plan);
    printf("box floor centre: direct %.4f, with %d bounce(s) %.4f\n", direct, out.stats.bounces, bounced);
    prt_data_free(&out);
}

/* Forced K: max_terms caps a glossy material; term_error picks the smallest K meeting it. */
static void terms(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    CHECK(make_sphere_scene(&sc, "phong:kd=0.4;ks=0.3;n=20", &err) == 0, "%s", err.msg);
    d = base;
    d.glossy = PRECOMPUTE_GLOSSY_SVD;   /* K on the SVD path */
    d.max_terms = 2;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(out.factors[0].K == 2, "max_terms 2: K = %d", out.factors[0].K);
    CHECK(out.transfers[0].transport.nvecs == 2 * out.scene.mesh.nverts, "two vectors per vertex");
    prt_data_free(&out);

    CHECK(make_sphere_scene(&sc, "phong:kd=0.4;ks=0.3;n=20", &err) == 0, "%s", err.msg);
    d = base;
    d.glossy = PRECOMPUTE_GLOSSY_SVD;   /* K on the SVD path */
    d.max_terms = 8;
    d.term_error = 0.2f;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    {
        const brdf_factor *f = &out.factors[0];
        CHECK(f->K >= 1 && f->K <= 8, "K = %d", f->K);
        CHECK(f->rel_rms[f->K] <= 0.2f || f->K == 8, "K = %d meets the target: %g", f->K, f->rel_rms[f->K]);
        if (f->K > 1) CHECK(f->rel_rms[f->K - 1] > 0.2f, "K - 1 = %d would not: %g", f->K - 1, f->rel_rms[f->K - 1]);
        CHECK(strstr(out.plan, "target") != NULL, "plan: %s", out.plan);
    }
    prt_data_free(&out);
}

/* Cancel through the progress callback. */
static void cancel(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    CHECK(make_sphere_scene(&sc, "lambert:kd=0.5", &err) == 0, "%s", err.msg);
    int calls = 0;
    d = base;
    d.progress = cancel_at_half;
    d.progress_user = &calls;
    CHECK(precompute_run(&sc, &d, &out, &err) == -1, "cancelled run fails");
    CHECK(strcmp(err.msg, "cancelled") == 0, "message: %s", err.msg);
    CHECK(calls > 0, "progress called");
    CHECK(sc.mesh.pos == NULL, "scene taken even on failure");
}

/* Bad settings: each fails with a "precompute: " message (the last two: SH order 2, an unknown basis). */
static void bad_settings(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    precompute_desc d;
    int bad[7][3] = { { -1, 8, 64 }, { 64, 12, 64 }, { 64, 8, 100 }, { CUBE_TEXELS + 1, 8, 64 }, { 64, 8, 64 }, { 64, 8, 64 }, { 64, 8, 64 } };
    for (int q = 0; q < 7; q++) {
        CHECK(make_sphere_scene(&sc, "lambert:kd=0.5", &err) == 0, "%s", err.msg);
        d = base;
        d.N = bad[q][0];
        d.qbits = bad[q][1];
        d.vis_res = bad[q][2];
        if (q == 4) { d.basis = "sh"; d.basis_options = "order=2"; }
        if (q == 5) d.basis = "sg";   /* not a representation */
        if (q == 6) d.basis_options = "select=7";   /* not one of Haar's selections */
        err.msg[0] = 0;
        CHECK(precompute_run(&sc, &d, &out, &err) == -1, "bad setting %d accepted", q);
        CHECK(strncmp(err.msg, "precompute: ", 12) == 0, "message: %s", err.msg);
        if (q == 4) CHECK(strstr(err.msg, "order = '2'") != NULL, "message: %s", err.msg);
        if (q == 5) CHECK(strstr(err.msg, "unknown basis 'sg'") != NULL, "message: %s", err.msg);
        if (q == 6) CHECK(strstr(err.msg, "select = '7'") != NULL, "message: %s", err.msg);
    }
}

/* The plan names the representation chosen for the materials, with the reason: Haar by default,
 * SH when asked for; the data holds one transfer of it covering every material. */
static void basis_choice(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    for (int q = 0; q < 2; q++) {
        CHECK(make_sphere_scene(&sc, "lambert:kd=0.5", &err) == 0, "%s", err.msg);
        precompute_desc d = base;
        if (q) { d.basis = "sh"; d.basis_options = "order=4"; }
        CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
        CHECK(out.ntransfers == 1 && out.transfers[0].ops == transfer_find(q ? "sh" : "haar"), "one transfer");
        linear_config lc = linear_config_of(&out.transfers[0].cfg);
        CHECK(out.transfers[0].materials == 1 && lc.N == 64 && lc.qbits == 8, "mask and config");
        const char *want = q ? "basis: spherical harmonics of order 4 (16 coefficients; N=64); the material: asked for\n"
                             : "basis: Haar wavelets, N=64 of 24576 coefficients per vector, 8-bit, per steradian; the material: "
                               "the default (all-frequency; the closest to the path tracer per byte)\n";
        CHECK(strstr(out.plan, want) != NULL, "plan: %s", out.plan);
        prt_data_free(&out);
    }
}


/* Factors spec at K = 4 (the default cap) and asks for its path. */
static precompute_path path_of(const char *spec, precompute_glossy mode, bool have_view, char *why, size_t cap) {
    prt_error err;
    brdf_params p;
    brdf_factor f;
    precompute_path path = (precompute_path)-1;
    CHECK(brdf_parse(spec, &p, &err) == 0, "%s", err.msg);
    brdf_factor_desc fd = { .max_terms = 4 };
    CHECK(brdf_factorize(&p, &fd, &f, &err) == 0, "%s", err.msg);
    const transfer_ops *view = have_view ? transfer_default(TRANSFER_VIEW) : NULL;
    transfer_config vcfg;
    CHECK(!view || view->configure(&(transfer_setup){ 0 }, &vcfg, &err) == 0, "%s", err.msg);
    CHECK(precompute_choose_path(&p, &f, mode, transfer_default(TRANSFER_LINEAR), view, &vcfg, &path, why, cap, &err) == 0,
          "%s: %s", spec, err.msg);
    brdf_factor_free(&f);
    return path;
}

/* The path per material. Truth: the measured errors `prt brdf` prints in the lobe fit's measure
 * (whole slice): paper-phong SVD K = 4 72.6% against one vMF lobe 1.9% -> vMF; a soft GGX (alpha
 * 0.5) SVD K = 4 5.7% <= 10% -> SVD; Ashikhmin-Shirley has no ASG fit -> SVD with that reason;
 * Lambert -> K = 1; forcing and a table without vmf say so. */
static void paths(void) {
    char why[512];
    CHECK(path_of("lambert:kd=0.5", PRECOMPUTE_GLOSSY_AUTO, true, why, sizeof why) == PRECOMPUTE_PATH_LAMBERT, "lambert: %s", why);
    CHECK(path_of("paper-phong", PRECOMPUTE_GLOSSY_AUTO, true, why, sizeof why) == PRECOMPUTE_PATH_VIEW, "phong n=50: %s", why);
    CHECK(strstr(why, "SVD K = 4 error 7") && strstr(why, "> 10%") && strstr(why, "one vMF lobe 1."), "reason: %s", why);
    printf("paper-phong: %s\n", why);
    CHECK(path_of("ggx:kd=0.5;ks=0.04;alpha=0.5", PRECOMPUTE_GLOSSY_AUTO, true, why, sizeof why) == PRECOMPUTE_PATH_SVD, "soft ggx: %s", why);
    CHECK(strstr(why, "<= 10%") != NULL, "reason: %s", why);
    printf("soft ggx: %s\n", why);
    CHECK(path_of("paper-as", PRECOMPUTE_GLOSSY_AUTO, true, why, sizeof why) == PRECOMPUTE_PATH_SVD, "as: %s", why);
    CHECK(strstr(why, "no ASG fit") != NULL, "reason: %s", why);
    CHECK(path_of("paper-phong", PRECOMPUTE_GLOSSY_SVD, true, why, sizeof why) == PRECOMPUTE_PATH_SVD, "forced svd: %s", why);
    CHECK(strstr(why, "asked for") != NULL, "reason: %s", why);
    CHECK(path_of("ggx:kd=0.5;ks=0.04;alpha=0.5", PRECOMPUTE_GLOSSY_VIEW, true, why, sizeof why) == PRECOMPUTE_PATH_VIEW, "forced vmf: %s", why);
    CHECK(path_of("paper-as", PRECOMPUTE_GLOSSY_VIEW, true, why, sizeof why) == PRECOMPUTE_PATH_SVD, "forced vmf, as: %s", why);
    CHECK(path_of("paper-phong", PRECOMPUTE_GLOSSY_AUTO, false, why, sizeof why) == PRECOMPUTE_PATH_SVD, "no vmf: %s", why);
    CHECK(strstr(why, "no view-dependent") != NULL, "reason: %s", why);
}

/* End to end on a paper-phong sphere: with a vmf representation in the table, two transfers (the
 * sparse one over the material with its kd/pi factor alone, K = 1, and the vmf one over it), the
 * plan naming the path; glossy svd keeps one transfer with the K = 4 SVD; a Lambert material is not
 * touched. Without vmf in the table (before it exists), one transfer and the plan says why. */
static void glossy_transfers(void) {
    prt_error err;
    prt_scene sc;
    prt_data out;
    bool have = transfer_find("vmf") != NULL;
    for (int q = 0; q < 2; q++) {
        CHECK(make_sphere_scene(&sc, "paper-phong", &err) == 0, "%s", err.msg);
        precompute_desc d = base;
        d.glossy = q ? PRECOMPUTE_GLOSSY_SVD : PRECOMPUTE_GLOSSY_AUTO;
        d.view_options = "level=1,samples=64";
        if (precompute_run(&sc, &d, &out, &err)) { CHECK(0, "%s", err.msg); continue; }
        bool vmf = have && q == 0;
        CHECK(out.ntransfers == (vmf ? 2 : 1) && out.transfers[0].ops == transfer_find("haar") && out.transfers[0].materials == 1,
              "%d transfers", out.ntransfers);
        if (vmf) {
            CHECK(out.transfers[1].ops == transfer_find("vmf") && out.transfers[1].materials == 1, "vmf transfer over material 0");
            /* the diffuse factor: kd/pi at every direction pair, K = 1 (paper-phong kd = 0.5, 0.05, 0.05) */
            float wi[3] = { 0.3f, 0.2f, 0.93f }, wo[3] = { -0.5f, 0.1f, 0.86f }, rgb[3];
            brdf_factor_eval(&out.factors[0], wi, wo, 1, rgb);
            CHECK(out.factors[0].K == 1 && out.factors[0].lambertian, "K = %d", out.factors[0].K);
            CHECK_NEAR(rgb[0], 0.5 / M_PI, 1e-3, "kd/pi red");
            CHECK_NEAR(rgb[1], 0.05 / M_PI, 1e-3, "kd/pi green");
            CHECK(strstr(out.plan, "Haar K = 1 diffuse + vMF specular") != NULL, "plan: %s", out.plan);
        } else {
            CHECK(out.factors[0].K == 4, "SVD K = %d", out.factors[0].K);
            CHECK(strstr(out.plan, q ? "asked for: glossy svd" : "no view-dependent transfer representation") != NULL, "plan: %s", out.plan);
        }
        prt_data_free(&out);
    }
}

/* Every pass the run makes has the plan's estimate and every estimated pass runs: forced bounces
 * (the adaptive stop would leave estimated passes out), a glossy sphere on the vMF path over a
 * floor (its diffuse-lobe, direct and gathering stages); a Lambert sphere without bounces: the
 * direct pass alone. The estimates are positive and finite and the plan's line names them. */
static void estimate_passes(void) {
    if (!transfer_find("vmf")) { printf("  skipped plan/estimate_passes: no vmf representation\n"); return; }
    for (int q = 0; q < 2; q++) {
        prt_error err;
        prt_scene sc;
        prt_data out;
        CHECK(make_sphere_scene(&sc, q ? "lambert:kd=0.5" : "phong:kd=0.3;ks=0.5;n=40", &err) == 0, "%s", err.msg);
        if (!q) CHECK(scene_add_floor(&sc, 256, 3, NULL, &err) == 0, "%s", err.msg);
        precompute_desc d = base;
        d.bounces = q ? 0 : 2;
        d.force_bounces = q ? -1 : 1;
        d.glossy = PRECOMPUTE_GLOSSY_VIEW;
        d.view_options = "level=1,samples=16";
        if (precompute_run(&sc, &d, &out, &err)) { CHECK(0, "%s", err.msg); continue; }
        static const char *want[2][8] = { { "direct", "bounce 1", "bounce 2", "vmf diffuse lobes", "vmf direct", "vmf pass 1", "vmf pass 2" },
                                          { "direct" } };
        const prt_stats *st = &out.stats;
        int planned = 0, ran = 0, nwant = q ? 1 : 7;
        for (int i = 0; i < st->npasses; i++) {
            const prt_pass_time *p = &st->pass[i];
            planned += p->planned, ran += p->ran;
            CHECK(p->planned && p->ran, "pass %s: planned %d, ran %d", p->name, p->planned, p->ran);
            /* 0 is a fair estimate of a vMF pass >= 2 when no ray hits a fitted triangle (nothing to gather) */
            CHECK(p->est_cpu >= 0 && isfinite(p->est_cpu) && p->est >= 0 && isfinite(p->est) && (i > 0 || p->est_cpu > 0),
                  "pass %s: estimate %g s (CPU %g s)", p->name, p->est, p->est_cpu);
            CHECK(p->wall > 0 && p->cpu >= 0, "pass %s: measured %g s", p->name, p->wall);
            CHECK(i < nwant && !strcmp(p->name, want[q][i]), "pass %d is %s, want %s", i, p->name, i < nwant ? want[q][i] : "none");
            printf("  %-18s estimate %6.2fs (CPU %6.2fs), ran %6.2fs (CPU %6.2fs)\n", p->name, p->est, p->est_cpu, p->wall, p->cpu);
        }
        CHECK(planned == ran && ran == nwant, "%d passes estimated, %d ran, want %d", planned, ran, nwant);
        CHECK(strstr(out.plan, q ? "estimate: direct pass" : "each bounce pass") && (q || strstr(out.plan, "vMF lobes")),
              "plan: %s", out.plan);
        CHECK(strstr(out.plan, "time (estimate): direct") != NULL, "the plan's measured line: %s", out.plan);
        prt_data_free(&out);
    }
}

/* A BRDF reflecting more than it receives (albedo.h): one warning line in the plan naming it, and
 * the precompute goes on; a physical one gets none. */
static void energy_warning(void) {
    for (int q = 0; q < 2; q++) {
        prt_error err;
        prt_scene sc;
        prt_data out;
        CHECK(make_sphere_scene(&sc, q ? "phong:kd=0.5;ks=0.4" : "phong:kd=2;ks=3", &err) == 0, "%s", err.msg);
        precompute_desc d = base;
        d.glossy = PRECOMPUTE_GLOSSY_SVD;
        int rc = precompute_run(&sc, &d, &out, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) continue;
        const char *w = strstr(out.plan, "warning:");
        if (q) CHECK(w == NULL, "a physical BRDF warned of: %s", out.plan);
        else {
            CHECK(w && !strncmp(w, "warning: material 0 phong:kd=2;ks=3 reflects up to 5 of the light (directional albedo "
                                   "above 1 at 0 deg): interreflections will gain energy\n", 129),
                  "plan: %s", out.plan);
            CHECK(w && !strstr(w + 1, "warning:"), "one warning line: %s", out.plan);
        }
        prt_data_free(&out);
    }
}

/* prt precompute --glossy: a bad value is refused with one line naming the flag, exit 2, no file. */
static void glossy_flag(void) {
    char cmd[1024], buf[1024], outp[512];
    snprintf(outp, sizeof outp, "%s/g.prt", check_tmpdir());
    snprintf(cmd, sizeof cmd, "%s precompute data/sphere-phong.json -o %s --glossy shiny", check_prt_bin(), outp);
    int rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 2, "exit status %d: %s", rc, buf);
    CHECK(strstr(buf, "--glossy") != NULL && strstr(buf, "shiny") != NULL, "message: %s", buf);
    CHECK(strchr(buf, '\n') == buf + strlen(buf) - 1, "one line: %s", buf);
    FILE *f = fopen(outp, "rb");
    CHECK(f == NULL, "no output file");
    if (f) fclose(f);
    /* --refine-auto against --no-refine: a usage error naming both, before any work */
    snprintf(cmd, sizeof cmd, "%s precompute data/sphere-phong.json -o %s --refine-auto --no-refine", check_prt_bin(), outp);
    rc = check_run(cmd, buf, sizeof buf);
    CHECK(rc == 2 && strstr(buf, "--refine-auto") && strstr(buf, "--no-refine"), "exit status %d: %s", rc, buf);
    CHECK(strchr(buf, '\n') == buf + strlen(buf) - 1, "one line: %s", buf);
    f = fopen(outp, "rb");
    CHECK(f == NULL, "no output file");
    if (f) fclose(f);
}

/* A point light of 2 W/sr at (x, y, z), the scene's only light. */
static void add_point_light(prt_scene *sc, float x, float y, float z) {
    sc->lights.count = 1;
    sc->lights.light[0] = (prt_light){ .type = PRT_LIGHT_POINT, .pos = { x, y, z }, .intensity = 2, .colour = { 1, 1, 1 } };
}

/* Every vertex index 0..n-1 (the measurement's sample). */
static int *all_vertices(int n) {
    int *v = malloc(sizeof(int) * (size_t)n);
    for (int i = 0; v && i < n; i++) v[i] = i;
    return v;
}

/* A point light over a lone plane: no ray from the plane hits anything, so the one bounce carries
 * exactly 0 and the plan leaves it (and the highlights) off, saying so. */
static void local_bounce_plane(void) {
    prt_error err;
    prt_mesh m = { 0 };
    prt_scene sc;
    prt_data out;
    CHECK(mesh_make_plane(&m, -1, 1, -1, 1, 0, 9, 9, &err) == 0, "%s", err.msg);
    CHECK(scene_from_mesh(&m, "phong:kd=0.5;ks=0.4;n=40", &sc, &err) == 0, "%s", err.msg);
    add_point_light(&sc, 0.2f, 1, 0.1f);
    vis_scene *vs = vis_create(&sc.mesh, &err);
    int *all = all_vertices(sc.mesh.nverts);
    planfx_bounce b;
    planfx_measure_bounce(&sc, vs, all, sc.mesh.nverts, PLANFX_RAYS, &b);
    CHECK(b.direct > 0 && b.bounce == 0 && b.glossy == 0, "plane: direct %g bounce %g glossy %g", b.direct, b.bounce, b.glossy);
    CHECK(b.vertices == 81 && b.glossy_vertices == 81, "%d vertices, %d glossy", b.vertices, b.glossy_vertices);
    free(all);
    vis_destroy(vs);
    CHECK(precompute_run(&sc, &base, &out, &err) == 0, "%s", err.msg);
    CHECK(strstr(out.plan, "one bounce (two VSGLs): none: carries 0.0% of the direct light") != NULL, "plan: %s", out.plan);
    CHECK(strstr(out.plan, "indirect highlights: none: the 81 glossy sampled vertices receive 0.0%") != NULL, "plan: %s", out.plan);
    prt_effects fx;
    prt_file_effects(&out, &fx);
    CHECK(!fx.local_bounce && !fx.highlights, "effects read back: bounce %d highlights %d", fx.local_bounce, fx.highlights);
    prt_data_free(&out);
}

/* A closed sphere seen from inside (normals and triangles flipped), radius 1, a point light at
 * its centre. Every point sees every other with the form factor dA / (4 pi R^2), so the one-bounce
 * irradiance is kd E_d everywhere: the share is kd. The tessellation (16 rings, 32 segments) moves a
 * hit point inside the sphere by at most the sag 1 - cos(pi / 32) = 0.0048 and tilts its normal off
 * the light by at most pi / 32, so a hit's radiance I cos / d^2 is within 1 - 0.0048 and
 * 1 / (1 - 0.0048)^2 = 1 + 0.0097 of the exact; the radiance is the same along every ray up to that,
 * so the lattice's noise is below it too: 1.5% bounds the share's error relative to kd. */
/* The unit sphere at the origin seen from inside (normals and triangles flipped), material spec. */
static int inside_sphere(prt_scene *sc, const char *spec, prt_error *err) {
    prt_mesh m = { 0 };
    float c[3] = { 0, 0, 0 };
    if (mesh_make_sphere(&m, c, 1, 16, 32, err)) return -1;
    for (int i = 0; i < 3 * m.nverts; i++) m.nrm[i] = -m.nrm[i];
    for (int t = 0; t < m.ntris; t++) {
        uint32_t x = m.tris[3 * t + 1];
        m.tris[3 * t + 1] = m.tris[3 * t + 2];
        m.tris[3 * t + 2] = x;
    }
    if (scene_from_mesh(&m, spec, sc, err)) return -1;
    add_point_light(sc, 0, 0, 0);
    return 0;
}

static void local_bounce_sphere(void) {
    prt_error err;
    prt_scene sc;
    CHECK(inside_sphere(&sc, "lambert:kd=0.6", &err) == 0, "%s", err.msg);
    vis_scene *vs = vis_create(&sc.mesh, &err);
    int *all = all_vertices(sc.mesh.nverts);
    planfx_bounce b;
    planfx_measure_bounce(&sc, vs, all, sc.mesh.nverts, PLANFX_RAYS, &b);
    double share = b.bounce / b.direct;
    printf("closed sphere, kd 0.6: measured share %.4f (%ld rays)\n", share, b.rays);
    CHECK_NEAR(share, 0.6, 0.015 * 0.6, "closed sphere: one bounce carries kd of the direct light");
    CHECK_NEAR(b.direct, 2.0 * sc.mesh.nverts, 1e-4 * 2.0 * sc.mesh.nverts, "E_d = I / R^2 at every vertex");
    CHECK(b.glossy == 0 && b.glossy_vertices == 0, "no glossy receiver");
    free(all);
    vis_destroy(vs);
    prt_data out;
    precompute_desc d = base;
    d.force_bounces = -1;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(strstr(out.plan, "one bounce (two VSGLs): needed: carries 6") != NULL, "plan: %s", out.plan);
    CHECK(strstr(out.plan, "indirect highlights: none: no glossy material") != NULL, "plan: %s", out.plan);
    prt_effects fx;
    prt_file_effects(&out, &fx);
    CHECK(fx.local_bounce && !fx.highlights, "effects read back: bounce %d highlights %d", fx.local_bounce, fx.highlights);
    prt_data_free(&out);
}

/* The same sphere in modified Phong (kd/pi + ks (n+2)/(2 pi) cos^n of the angle to the mirror
 * direction). Lit from the centre, every hit q's mirror direction is its normal, and on a sphere the
 * angle at p to the chord equals the angle at q, so the one-bounce irradiance is E_d times the
 * integral of (kd/pi + ks (n+2)/(2 pi) cos^n t) cos t over the hemisphere: kd + ks, all of it at glossy
 * receivers. Tolerance: the Lambert case's 1.5% for the geometry plus the sampling of the lobe: with
 * cosine-distributed rays cos^4 t has mean 1/3 and variance 1/5 - 1/9 (a 0.9 coefficient of
 * variation), over 64 rays at each of the 482 vertices (30,848) 0.5% of the lobe's part; four times
 * that of ks = 0.4 is 0.008. */
static void local_bounce_glossy(void) {
    prt_error err;
    prt_scene sc;
    CHECK(inside_sphere(&sc, "phong:kd=0.3;ks=0.4;n=4", &err) == 0, "%s", err.msg);
    vis_scene *vs = vis_create(&sc.mesh, &err);
    int *all = all_vertices(sc.mesh.nverts);
    planfx_bounce b;
    planfx_measure_bounce(&sc, vs, all, sc.mesh.nverts, PLANFX_RAYS, &b);
    printf("closed Phong sphere, kd 0.3, ks 0.4: measured share %.4f, glossy %.4f (%d vertices)\n", b.bounce / b.direct,
           b.glossy / b.direct, b.vertices);
    CHECK_NEAR(b.bounce / b.direct, 0.7, 0.015 * 0.7 + 0.008, "closed Phong sphere: kd + ks");
    CHECK(b.glossy == b.bounce && b.glossy_vertices == b.vertices, "every receiver glossy");
    free(all);
    vis_destroy(vs);
    scene_free(&sc);
}

/* The force flags override the measurement, both ways, and the plan says so. */
static void local_bounce_forced(void) {
    prt_error err;
    prt_mesh m = { 0 };
    prt_scene sc;
    prt_data out;
    CHECK(mesh_make_plane(&m, -1, 1, -1, 1, 0, 5, 5, &err) == 0, "%s", err.msg);
    CHECK(scene_from_mesh(&m, "phong:kd=0.5;ks=0.4;n=40", &sc, &err) == 0, "%s", err.msg);
    add_point_light(&sc, 0, 1, 0);
    precompute_desc d = base;
    d.force_local_bounce = 1;
    d.force_highlights = 1;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    CHECK(strstr(out.plan, "one bounce (two VSGLs): needed (forced)") && strstr(out.plan, "indirect highlights: needed (forced)"),
          "plan: %s", out.plan);
    prt_effects fx;
    prt_file_effects(&out, &fx);
    CHECK(fx.local_bounce && fx.highlights, "forced on read back: bounce %d highlights %d", fx.local_bounce, fx.highlights);
    prt_data_free(&out);
    d.force_local_bounce = 2;
    CHECK(precompute_desc_check(&d, &err) == -1 && strstr(err.msg, "force_local_bounce"), "bad force value: %s", err.msg);
}

/* prt_file_effects reads the plan's lines: the measured ones, the forced ones and the older
 * hit-fraction ones (files made before the measurement), and falls back on the hit fraction. */
static void effects_lines(void) {
    static const struct { const char *plan; float hit; bool bounce, hl; } cases[] = {
        { "    one bounce (two VSGLs): needed: carries 40.1% of the direct light\n"
          "    indirect highlights: needed: the 12 glossy sampled vertices receive 5.0%\n", 0, true, true },
        { "    one bounce (two VSGLs): needed: carries 40.1% of the direct light\n"
          "    indirect highlights: none: the 12 glossy sampled vertices receive 0.3%\n", 0.5f, true, false },
        { "    one bounce (two VSGLs): none: carries 0.3% of the direct light\n"
          "    indirect highlights: needed (forced)\n", 0.5f, false, true },
        { "    one bounce (two VSGLs): none: surfaces do not see each other\n"
          "    indirect highlights: none: no glossy surface faces another\n", 0.5f, false, false },
        { "    one bounce (two VSGLs): needed (surfaces see each other)\n"
          "    indirect highlights: needed (a glossy material, surfaces see each other)\n", 0, true, true },
        { "", 0.5f, true, true },
        { "", 0.001f, false, false },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        static prt_data d;
        memset(&d, 0, sizeof d);
        d.scene.materials[0].type = BRDF_PHONG;
        d.scene.nmaterials = 1;
        d.scene.lights.count = 1;
        d.stats.hit_fraction = cases[i].hit;
        snprintf(d.plan, sizeof d.plan, "%s", cases[i].plan);
        prt_effects fx;
        prt_file_effects(&d, &fx);
        CHECK(fx.local_bounce == cases[i].bounce && fx.highlights == cases[i].hl, "case %zu: bounce %d highlights %d", i,
              fx.local_bounce, fx.highlights);
        CHECK((fx.no_bounce == NULL) == fx.local_bounce && (fx.no_highlights == NULL) == fx.highlights, "case %zu: reasons", i);
    }
}

/* A unit sphere of BRDF spec centred at (0, 1, 0) over a floor of `verts` vertices and `size` times its width. */
static int spec_sphere_over_floor(prt_scene *sc, const char *spec, int rings, int verts, float size, prt_error *err) {
    prt_mesh m = { 0 };
    float c[3] = { 0, 1, 0 };
    if (mesh_make_sphere(&m, c, 1, rings, 2 * rings, err) || scene_from_mesh(&m, spec, sc, err)) return -1;
    return scene_add_floor(sc, verts, size, NULL, err);
}

static int sphere_over_floor(prt_scene *sc, int rings, int verts, float size, prt_error *err) {
    return spec_sphere_over_floor(sc, "lambert:kd=0.5", rings, verts, size, err);
}

/* The receivers' figures against the floor's construction (scene.h: an n x n grid over size x the
 * models' width 2, n = round(sqrt(verts))) and the penumbra's geometry: a sun of angular diameter a
 * behind the sphere's top, h over the floor, blurs its shadow edge over h tan(a). A 50 x 50 grid 3
 * widths across is 6 / 49 = 0.122 apart, far wider than 2 tan(0.00925) = 0.0185: refine. A 70 x 70
 * grid half a width across is 1 / 69 = 0.0145 apart, finer: not, unless a local light (a point,
 * no penumbra) is in the scene. */
static void receivers(void) {
    prt_error err;
    static const struct { int verts; float size; bool light, refine; } cases[] = {
        { 2500, 3, false, true }, { 4900, 0.5f, false, false }, { 4900, 0.5f, true, true },
    };
    for (int i = 0; i < 3; i++) {
        prt_scene sc;
        CHECK(sphere_over_floor(&sc, 16, cases[i].verts, cases[i].size, &err) == 0, "%s", err.msg);
        if (cases[i].light) add_point_light(&sc, 0, 3, 0);
        int n = (int)lround(sqrt(cases[i].verts)), first = sc.floor_first_vertex;
        double fy = sc.mesh.pos[3 * first + 1], step = 2.0 * cases[i].size / (n - 1);
        planfx_receivers rc;
        planfx_measure_receivers(&sc, &rc);
        CHECK(rc.floor && rc.models, "case %d: floor and models", i);
        CHECK_NEAR(rc.spacing, step, 1e-5 * step, "case %d: the grid's step", i);
        CHECK_NEAR(rc.height, 2 - fy, 1e-5, "case %d: the sphere's top over the floor", i);
        CHECK_NEAR(rc.penumbra, (2 - fy) * tan(PLANFX_SUN_RAD), 1e-7, "case %d: h tan(a)", i);
        CHECK(rc.refine == cases[i].refine, "case %d: refine %d (spacing %g, penumbra %g)", i, rc.refine, rc.spacing, rc.penumbra);
        scene_free(&sc);
    }
    prt_mesh m = { 0 };
    prt_scene sc;
    float c[3] = { 0, 1, 0 };
    CHECK(mesh_make_sphere(&m, c, 1, 8, 16, &err) == 0 && scene_from_mesh(&m, "lambert:kd=0.5", &sc, &err) == 0, "%s", err.msg);
    planfx_receivers rc;
    planfx_measure_receivers(&sc, &rc);
    CHECK(!rc.floor && !rc.refine, "no floor: nothing to refine");
    scene_free(&sc);
}

/* The plan measures a coarse floor and says it is coarser than a sun's penumbra; by default it
 * leaves the floor (PLANFX_REFINE_MEASURED; the sphere's own refinement is models_refine's), with
 * force_refine 1 it refines it within the budget, with -1 it says refinement is forced off and
 * nothing changes. */
static void receivers_plan(void) {
    prt_error err;
    static const char *const want[3] = {
        "refinement: off (forced)",
        "refinement: off: vertex spacing 0.545 > the penumbra of a sun 0.0185 at the models' height 2, but",
        "refinement: on for the floor: vertex spacing 0.545 > the penumbra of a sun 0.0185 at the models' height 2; budget",
    };
    for (int f = -1; f <= 1; f++) {
        prt_scene sc;
        prt_data out;
        CHECK(sphere_over_floor(&sc, 8, 144, 3, &err) == 0, "%s", err.msg);
        const int before = sc.mesh.nverts, models = sc.floor_first_vertex, floor = before - models;
        precompute_desc d = base;
        d.force_refine = f;
        CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
        CHECK(strstr(out.plan, want[f + 1]) != NULL, "force_refine %d: plan: %s", f, out.plan);
        const int floor1 = out.scene.mesh.nverts - out.scene.floor_first_vertex;
        if (f < 1) CHECK(floor1 == floor, "force_refine %d: %d floor vertices, %d before", f, floor1, floor);
        else CHECK(floor1 > floor && out.scene.mesh.nverts <= (int)(REFINE_BUDGET_FACTOR * before) + (int)(PLANFX_MODEL_GROWTH * models),
                   "refined: %d floor vertices, %d before; %d in all", floor1, floor, out.scene.mesh.nverts);
        if (f == -1) CHECK(out.scene.mesh.nverts == before, "forced off: %d vertices, %d before", out.scene.mesh.nverts, before);
        prt_data_free(&out);
    }
}

/* The plan refines the models by default (planfx.h PLANFX_MODEL_GROWTH): a paper-phong sphere (on the
 * view path) and a Lambertian one over a floor gain vertices where the floor changes their visibility,
 * at most 2.5x their own, the floor keeps its vertices and the plan says so; force_refine -1
 * (--no-refine) leaves them as they are; a full float transport leaves only the file's room. */
static void models_refine(void) {
    prt_error err;
    static const char *const specs[2] = { "paper-phong", "lambert:kd=0.5" };
    for (int k = 0; k < 2; k++)
        for (int f = -1; f <= 0; f++) {
            prt_scene sc;
            prt_data out;
            CHECK(spec_sphere_over_floor(&sc, specs[k], 8, 144, 3, &err) == 0, "%s", err.msg);
            const int models = sc.floor_first_vertex, floor = sc.mesh.nverts - models;
            precompute_desc d = base;
            d.force_refine = f;
            d.force_bounces = -1;
            d.view_options = "level=1,samples=16";
            CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
            const int models1 = out.scene.floor_first_vertex, floor1 = out.scene.mesh.nverts - models1;
            CHECK(floor1 == floor, "%s, force_refine %d: floor %d -> %d vertices", specs[k], f, floor, floor1);
            if (f == -1) CHECK(models1 == models, "%s forced off: the sphere's %d -> %d vertices", specs[k], models, models1);
            else CHECK(models1 > models && models1 <= (int)(PLANFX_MODEL_GROWTH * models), "%s: the sphere's %d -> %d vertices (at most %g x)",
                       specs[k], models, models1, PLANFX_MODEL_GROWTH);
            char want[96];
            snprintf(want, sizeof want, "refinement of the models: their %d vertices may grow by", models);
            CHECK((strstr(out.plan, want) != NULL) == (f == 0), "%s, force_refine %d: plan: %s", specs[k], f, out.plan);
            prt_data_free(&out);
        }
    /* The file's byte budget binds when every coefficient is kept in float: the linear transfer's
     * vector takes N (3 x 32 / 8 + 1.5) bytes (linear.h), so 96 MB holds floor(96e6 / that - vertices)
     * more one-vector (Lambertian) vertices. */
    prt_scene sc;
    prt_data out;
    CHECK(spec_sphere_over_floor(&sc, "lambert:kd=0.5", 8, 144, 3, &err) == 0, "%s", err.msg);
    const int models = sc.floor_first_vertex, n = sc.mesh.nverts;
    const long room = (long)(96e6 / (CUBE_TEXELS * (3.0 * 32 / 8 + 1.5)) - n);
    precompute_desc d = base;
    d.N = CUBE_TEXELS, d.qbits = 32, d.force_bounces = -1;
    CHECK(precompute_run(&sc, &d, &out, &err) == 0, "%s", err.msg);
    char want[160];
    snprintf(want, sizeof want, "their %d vertices may grow by %ld (the room the file's byte budget leaves)", models, room);
    CHECK(room > 0 && room < (long)((PLANFX_MODEL_GROWTH - 1) * models) && strstr(out.plan, want) != NULL, "want '%s': %s", want, out.plan);
    CHECK(out.scene.mesh.nverts <= n + room, "%d vertices, at most %ld", out.scene.mesh.nverts, n + room);
    prt_data_free(&out);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(lone_sphere);
    CHECK_CASE(forced_bounces);
    CHECK_CASE(floor_shortcut);
    CHECK_CASE(lambert_only);
    CHECK_CASE(open_box);
    CHECK_CASE(terms);
    CHECK_CASE(cancel);
    CHECK_CASE(bad_settings);
    CHECK_CASE(basis_choice);
    CHECK_CASE(paths);
    CHECK_CASE(glossy_transfers);
    CHECK_CASE(glossy_flag);
    CHECK_CASE(estimate_passes);
    CHECK_CASE(energy_warning);
    CHECK_CASE(local_bounce_plane);
    CHECK_CASE(local_bounce_sphere);
    CHECK_CASE(local_bounce_glossy);
    CHECK_CASE(local_bounce_forced);
    CHECK_CASE(effects_lines);
    CHECK_CASE(receivers);
    CHECK_CASE(receivers_plan);
    CHECK_CASE(models_refine);
    return check_summary();
}
