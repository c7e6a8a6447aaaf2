/* test_prior.c - the light prior of the expected-error selection (prior.h), against brute force:
 * its weights are the RMS light vector over the yaw orbit computed one rotation at a time, and a
 * floor vertex whose sky an occluder cuts along the sun's ring keeps a transport whose T.L error,
 * over the sun's turn, is well below the level prior's (the exact T.L: the sum over texels). */
#include "harness.h"
#include "cubemap.h"
#include "image.h"
#include "light.h"
#include "prior.h"
#include "probe.h"
#include "transfer.h"
#include "transport.h"
#include "transport_fixture.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { T = CUBE_TEXELS };

/* A sky with a sun of radius 1.5 degrees at 30 degrees of elevation (radiance 2000, the default). */
static void sun_sky(prt_probe *p) {
    const float e = (float)(30 * M_PI / 180);
    sky_desc sd = { .width = 256, .sun_dir = { cosf(e), sinf(e), 0 } };
    prt_error err;
    CHECK(probe_make_sky(&sd, p, &err) == 0, "%s", err.msg);
}

/* The light vector of p turned by the --light-rotation string rot (the runtime's path). */
static void light_at(const prt_probe *p, const char *rot, float *cube, float (*L)[4]) {
    float R[9];
    CHECK(probe_parse_rotation(rot, R) == 0, "rotation %s", rot);
    transfer_config cfg;
    tfx_haar(0, 0, true, &cfg);
    probe_to_cube(p, CUBE_RES, R, 0, cube);
    tfx_light(&cfg, cube, L);
}

/* Eight yaw steps, no floor: w must be sqrt(mean of L^2 over the eight rotations) over the largest
 * such value, to float rounding (1e-5 of the largest; measured 0). */
static void orbit_mean(void) {
    static float cube[3 * T];
    static double acc[T][3];
    prt_probe p;
    sun_sky(&p);
    float (*w)[4] = transfer_light_alloc(), (*L)[4] = transfer_light_alloc();
    prt_error err;
    prior_desc d = { .steps = 8, .floor = -1 };
    CHECK(prior_from_probe(&p, &d, w, &err) == 0, "%s", err.msg);
    memset(acc, 0, sizeof acc);
    for (int k = 0; k < 8; k++) {
        char rot[32];
        snprintf(rot, sizeof rot, "%d", 45 * k);
        light_at(&p, rot, cube, L);
        for (int i = 0; i < T; i++)
            for (int c = 0; c < 3; c++) acc[i][c] += (double)L[i][c] * L[i][c] / 8;
    }
    double mx = 0, worst = 0;
    for (int i = 0; i < T; i++)
        for (int c = 0; c < 3; c++) mx = fmax(mx, acc[i][c]);
    for (int i = 0; i < T; i++)
        for (int c = 0; c < 3; c++) worst = fmax(worst, fabs(w[i][c] - sqrt(acc[i][c] / mx)));
    printf("  worst |w - brute-force RMS / largest| = %.2e\n", worst);
    CHECK_LE(worst, 1e-5, "the weights are the orbit's RMS light, normalised");
    free(w);
    free(L);
    probe_free(&p);
}

/* Two probes: each counts the same whatever its brightness, so the prior of a city-like sun at 30
 * degrees and a sun 1000 times brighter at 60 degrees must be sqrt((w1^2 + w2^2) / largest) of the
 * two single priors w1, w2 (each checked against brute force above), to float rounding. */
static void two_probes(void) {
    prt_probe p[2];
    prt_error err;
    sun_sky(&p[0]);
    const float e = (float)(60 * M_PI / 180);
    sky_desc sd = { .width = 256, .sun_dir = { 0, sinf(e), cosf(e) }, .sun_radiance = 2e6f };
    CHECK(probe_make_sky(&sd, &p[1], &err) == 0, "%s", err.msg);
    float (*w)[4] = transfer_light_alloc(), (*w1)[4] = transfer_light_alloc(), (*w2)[4] = transfer_light_alloc();
    prior_desc d = { .steps = 8, .floor = -1 };
    const prt_probe *pp[2] = { &p[0], &p[1] };
    CHECK(prior_from_probes(pp, 2, &d, w, &err) == 0, "%s", err.msg);
    CHECK(prior_from_probe(&p[0], &d, w1, &err) == 0, "%s", err.msg);
    CHECK(prior_from_probe(&p[1], &d, w2, &err) == 0, "%s", err.msg);
    double mx = 0, worst = 0;
    for (int i = 0; i < T; i++)
        for (int c = 0; c < 3; c++) mx = fmax(mx, (double)w1[i][c] * w1[i][c] + (double)w2[i][c] * w2[i][c]);
    for (int i = 0; i < T; i++)
        for (int c = 0; c < 3; c++)
            worst = fmax(worst, fabs(w[i][c] - sqrt(((double)w1[i][c] * w1[i][c] + (double)w2[i][c] * w2[i][c]) / mx)));
    printf("  worst |w - sqrt((w1^2 + w2^2) / largest)| = %.2e\n", worst);
    CHECK_LE(worst, 1e-5, "two probes count the same");
    CHECK(prior_from_probes(pp, 0, &d, w, &err) == -1, "no probe is refused");
    free(w);
    free(w1);
    free(w2);
    probe_free(&p[0]);
    probe_free(&p[1]);
}

/* A black probe has no prior: refused with one line, not weights of 0/0. */
static void black_probe(void) {
    prt_probe p;
    prt_error err;
    const float black[3] = { 0, 0, 0 };
    CHECK(probe_make_constant(black, &p, &err) == 0, "%s", err.msg);
    float (*w)[4] = transfer_light_alloc();
    prior_desc d = { .steps = 4 };
    CHECK(prior_from_probe(&p, &d, w, &err) == -1, "a black probe is refused");
    CHECK(strstr(err.msg, "no light") != NULL, "message: %s", err.msg);
    free(w);
    probe_free(&p);
}

/* An up-facing floor vertex (Eq. 3: cosine times the texel's solid angle) whose sky an occluder hides
 * below 35 degrees of elevation over the azimuths x > 0.3 |z| (a wall in front of the sun's ring). */
static void walled_vertex(float *tex) {
    static float dw[CUBE_RES * CUBE_RES];
    cube_face_solid_angles(CUBE_RES, dw);
    for (int i = 0; i < T; i++) {
        float d[3];
        cube_texel_dir(CUBE_RES, i, d);
        bool wall = d[1] < sinf((float)(35 * M_PI / 180)) && d[0] > 0.3f * fabsf(d[2]);
        tex[i] = d[1] > 0 && !wall ? d[1] * dw[i % (CUBE_RES * CUBE_RES)] : 0.f;
    }
}

/* The walled vertex stored at N (float values, per-vector budget, the default corrections), with or
 * without the prior w. Returns the RMS over 72 yaw steps of (T.L stored - sum_j T_j L_j) over the
 * RMS exact value. */
static double orbit_error(const prt_probe *p, const float (*w)[4], int N) {
    static float tex[T], cube[3 * T];
    walled_vertex(tex);
    transfer_config cfg;
    tfx_haar(N, 32, true, &cfg);
    const prt_transport like = { .solid_angle = true, .select = TRANSPORT_SELECT_EXPECTED, .prior = w,
                                 .block_level = TRANSPORT_BLOCK_LEVEL, .smooth_faces = true };
    prt_transport t;
    tfx_store(tex, cfg, &like, &t);
    float (*L)[4] = transfer_light_alloc();
    double se = 0, s2 = 0;
    for (int k = 0; k < 72; k++) {
        char rot[32];
        snprintf(rot, sizeof rot, "%d", 5 * k);
        light_at(p, rot, cube, L);
        double exact = 0;
        for (int i = 0; i < T; i++) exact += (double)tex[i] * cube[3 * i];
        float g[3];
        transport_light(&t, (const float (*)[4])L, g, 1);
        se += (g[0] - exact) * (g[0] - exact);
        s2 += exact * exact;
    }
    free(L);
    transport_free(&t);
    return sqrt(se / s2);
}

/* The selection's purpose: with the prior of the sky it turns under, the walled vertex's T.L error over
 * the turn must be at most 0.75 of the level prior's, at N = 64 and 128 (measured 17.3% -> 9.2% and
 * 5.56% -> 3.57%: printed). */
static void orbit_selection(void) {
    prt_probe p;
    sun_sky(&p);
    float (*w)[4] = transfer_light_alloc();
    prt_error err;
    prior_desc d = { .steps = 180 };
    CHECK(prior_from_probe(&p, &d, w, &err) == 0, "%s", err.msg);
    for (int N = 64; N <= 128; N *= 2) {
        double e0 = orbit_error(&p, NULL, N), e1 = orbit_error(&p, (const float (*)[4])w, N);
        printf("  N = %d: RMS relative T.L error over the turn %.3f%% with the level prior, %.3f%% with the light prior\n",
               N, 100 * e0, 100 * e1);
        CHECK_LE(e1, 0.75 * e0, "the light prior cuts the error by a quarter or more (N = %d)", N);
    }
    free(w);
    probe_free(&p);
}

/* `prt precompute --light-prior`: with --select magnitude, or a list with an empty name, a usage
 * error (2); a probe that is not an image, alone or in a list, a data error (1); each one line and
 * no output. A JSON scene's "light_prior" of two probes is used and named in the plan, but not with
 * --no-light-prior, nor with --select magnitude (a note says why). The plan names its light-weighted
 * texels, but not with --box-texels, which without a prior gets a note; and the refit of the kept values
 * (refit.h), but not with --no-refit or a shared budget, where it names the put-back instead. */
static void prior_flag(void) {
    char probe[512], notimg[512], obj[512], outp[512], cmd[4096], buf[8192];
    snprintf(obj, sizeof obj, "%s/prior-squares.obj", check_tmpdir());
    snprintf(probe, sizeof probe, "%s/prior-sky.exr", check_tmpdir());
    snprintf(notimg, sizeof notimg, "%s/prior-text.exr", check_tmpdir());
    snprintf(outp, sizeof outp, "%s/prior.prt", check_tmpdir());
    prt_probe p;
    prt_error err;
    sun_sky(&p);
    CHECK(image_write(probe, &p.img, NULL, &err) == 0, "%s", err.msg);
    probe_free(&p);
    FILE *f = fopen(notimg, "w");
    if (f) { fputs("not an image\n", f); fclose(f); }
    f = fopen(obj, "w");   /* a unit square under a smaller one (faces up) */
    if (f) {
        fputs("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -.3 .5 -.3\nv .3 .5 -.3\nv .3 .5 .3\nv -.3 .5 .3\n"
              "f 1 3 2\nf 1 4 3\nf 5 7 6\nf 5 8 7\n", f);
        fclose(f);
    }
    char list[1100], empty[1100];
    snprintf(list, sizeof list, "%s,%s", probe, notimg);   /* one bad file in a list: a data error */
    snprintf(empty, sizeof empty, "%s,,%s", probe, probe);   /* an empty name in the list: usage */
    const char *bad[4][2] = { { probe, "--select magnitude" }, { notimg, "" }, { empty, "" }, { list, "" } };
    const int status[4] = { 2, 1, 2, 1 };
    for (int q = 0; q < 4; q++) {
        remove(outp);
        snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --light-prior %s %s", check_prt_bin(), obj, outp, bad[q][0],
                 bad[q][1]);
        int rc = check_run(cmd, buf, sizeof buf);
        CHECK(rc == status[q], "exit status %d: %s", rc, buf);
        CHECK(strchr(buf, '\n') == buf + strlen(buf) - 1, "one line: %s", buf);
        CHECK(access(outp, F_OK) != 0, "no output file");
    }
    /* A JSON scene naming two probes (relative to it) is precomputed with their prior unless told not. */
    char json[512];
    snprintf(json, sizeof json, "%s/prior-scene.json", check_tmpdir());
    f = fopen(json, "w");
    if (f) {
        fputs("{ \"models\": [ { \"obj\": \"prior-squares.obj\" } ], \"light_prior\": [\"prior-sky.exr\", \"prior-sky.exr\"] }\n", f);
        fclose(f);
    }
    char bad_json[512];   /* a scene naming a probe that is not there: one line, exit 1, no output */
    snprintf(bad_json, sizeof bad_json, "%s/prior-scene-bad.json", check_tmpdir());
    f = fopen(bad_json, "w");
    if (f) {
        fputs("{ \"models\": [ { \"obj\": \"prior-squares.obj\" } ], \"light_prior\": \"prior-nothere.exr\" }\n", f);
        fclose(f);
    }
    remove(outp);
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet", check_prt_bin(), bad_json, outp);
    int brc = check_run(cmd, buf, sizeof buf);
    CHECK(brc == 1 && strstr(buf, "prior-nothere.exr") && strchr(buf, '\n') == buf + strlen(buf) - 1,
          "a missing scene probe: exit %d, %s", brc, buf);
    CHECK(access(outp, F_OK) != 0, "no output file");
    static const struct { const char *flags; bool prior, rays, refit; const char *note; } k[] = {
        { "", true, true, true, NULL }, { "--no-light-prior", false, false, false, NULL },
        { "--select magnitude", false, false, false, "light_prior is not used" }, { "--box-texels", true, false, true, NULL },
        { "--no-light-prior --box-texels", false, false, false, "--box-texels changes nothing without a light prior" },
        { "--no-refit", true, true, false, NULL }, { "--budget shared", true, true, false, NULL },
        { "--no-light-prior --no-refit", false, false, false, "--no-refit changes nothing without a light prior" } };
    for (int q = 0; q < 8; q++) {
        snprintf(cmd, sizeof cmd, "%s precompute %s -o %s %s 2>&1 && %s info %s", check_prt_bin(), json, outp, k[q].flags,
                 check_prt_bin(), outp);
        int rc = check_run(cmd, buf, sizeof buf);
        CHECK(rc == 0, "exit status %d: %s", rc, buf);
        bool named = strstr(buf, "light prior: prior-sky.exr,prior-sky.exr turned about +y") != NULL;
        CHECK(named == k[q].prior, "'%s': the plan %s it: %s", k[q].flags, k[q].prior ? "names" : "does not name", buf);
        CHECK(!k[q].note || strstr(buf, k[q].note) != NULL, "'%s': a note says why: %s", k[q].flags, buf);
        bool rays = strstr(buf, "light-weighted texels: the prior's") != NULL;
        CHECK(rays == k[q].rays, "'%s': the plan %s light-weighted texels: %s", k[q].flags, k[q].rays ? "names" : "has no", buf);
        bool refit = strstr(buf, "kept values: refit to the light prior's texels") != NULL;   /* refit.h: per vector only */
        CHECK(refit == k[q].refit, "'%s': the plan %s the refit: %s", k[q].flags, k[q].refit ? "names" : "has no", buf);
        CHECK(refit != (strstr(buf, "what truncation drops: put back") != NULL), "'%s': refit or put back, one of them", k[q].flags);
    }
}

/* Light-weighted texels (prior.h): two point lights 0.7 degree apart inside one texel of a black
 * 2048 x 1024 probe, one three times the other. Every ray must lie in that texel, and, the rays
 * being the light's stratified quantiles, 3/4 of them (48 of 64, +-1 for the quantiles' grid)
 * nearer the brighter light. A constant probe has no texel over the share: no rays. */
static void weighted_texels(void) {
    prt_error err;
    const int W = 2048, H = 1024, t = 3 * CUBE_RES * CUBE_RES + 40 * CUBE_RES + 21;   /* +y face, (21, 40) */
    float a[3], b[3];
    cube_dir(CUBE_RES, t / (CUBE_RES * CUBE_RES), 21.25f, 40.5f, a);
    cube_dir(CUBE_RES, t / (CUBE_RES * CUBE_RES), 21.75f, 40.5f, b);
    prt_image img;
    CHECK(image_alloc(&img, W, H, 3, &err) == 0, "%s", err.msg);
    memset(img.data, 0, sizeof(float) * 3 * W * H);
    const float *dir[2] = { a, b };
    for (int k = 0; k < 2; k++) {   /* latlong: u = 1/2 + atan2(x, -z) / 2 pi, v = acos(y) / pi (probe.c) */
        const float *d = dir[k];
        int x = (int)((0.5 + atan2(d[0], -d[2]) / (2 * M_PI)) * W), y = (int)(acos(d[1]) / M_PI * H);
        for (int c = 0; c < 3; c++) img.data[3 * ((size_t)y * W + x) + c] = k == 0 ? 3e4f : 1e4f;
    }
    prt_probe p;
    CHECK(probe_from_image(&img, PROBE_LATLONG, "two-lights", &p, &err) == 0, "%s", err.msg);
    prior_rays *r = calloc(1, sizeof *r);
    const prt_probe *pp = &p;
    CHECK(prior_rays_from_probes(&pp, 1, r, &err) == 0, "%s", err.msg);
    CHECK(r->n >= 1 && r->texel[0] == t, "the lights' texel first: %d texels, first %d", r->n, r->texel[0]);
    int inside = 0, near_a = 0;
    for (int m = 0; m < PRIOR_RAYS; m++) {
        const float *d = r->dir[0][m];
        inside += cube_texel_index(CUBE_RES, d) == t;
        double da = acos(fmin(1, d[0] * a[0] + d[1] * a[1] + d[2] * a[2])), db = acos(fmin(1, d[0] * b[0] + d[1] * b[1] + d[2] * b[2]));
        near_a += da < db;
    }
    printf("  %d texel(s); %d of %d rays inside the texel, %d nearer the brighter light (3/4: 48)\n", r->n, inside, PRIOR_RAYS, near_a);
    CHECK(inside == PRIOR_RAYS, "every ray in its texel: %d", inside);
    CHECK(abs(near_a - 3 * PRIOR_RAYS / 4) <= 1, "rays as the light: %d nearer the brighter", near_a);
    probe_free(&p);
    prt_probe c;
    const float grey[3] = { 1, 1, 1 };
    CHECK(probe_make_constant(grey, &c, &err) == 0, "%s", err.msg);
    pp = &c;
    CHECK(prior_rays_from_probes(&pp, 1, r, &err) == 0 && r->n == 0, "a constant probe: %d texels", r->n);
    CHECK(prior_rays_from_probes(&pp, 0, r, &err) == -1, "no probe is refused");
    probe_free(&c);
    free(r);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(orbit_mean);
    CHECK_CASE(two_probes);
    CHECK_CASE(black_probe);
    CHECK_CASE(orbit_selection);
    CHECK_CASE(prior_flag);
    CHECK_CASE(weighted_texels);
    return check_summary();
}
