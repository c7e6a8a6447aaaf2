/* test_vmf.c - the vMF lobe transfer (vmf.h, vmfpass.h, transfer_vmf.c) against independent
 * truths: the packed lobe's round trip (bounds stated in vmf.h); an unoccluded glossy sphere
 * (nothing stored) against quadrature of a generated probe with the analytic BRDF; a two-plane
 * mirror-like set-up where the second bounce must carry the energy that integration gives;
 * determinism on 1 and 2 threads; the hash and file round trip and the file's bad-input cases. */
#include "harness.h"
#include "brdf.h"
#include "lobe.h"
#include "prefilter.h"
#include "probe.h"
#include "prtfile.h"
#include "scene.h"
#include "transfer.h"
#include "visibility.h"
#include "vmf.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define PI 3.14159265358979323846

static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }

static void rnd_dir(uint32_t *s, float d[3]) {
    float z = 2 * rnd(s) - 1, p = 6.2831853f * rnd(s), r = sqrtf(fmaxf(0, 1 - z * z));
    d[0] = r * cosf(p), d[1] = r * sinf(p), d[2] = z;
}

/* ---- the packed lobe -------------------------------------------------------------------------- */

static void pack(void) {
    uint32_t s = 99;
    double amax = 0, kmax = 0, cmax = 0;
    for (int i = 0; i < 20000; i++) {
        vmf_lobe l, o;
        float a[3], b[3];
        rnd_dir(&s, l.mu);
        l.kappa = expf(12 * rnd(&s) - 2);   /* 0.14 .. 22,000 */
        for (int c = 0; c < 3; c++) a[c] = expf(10 * rnd(&s) - 8);
        uint32_t w[VMFT_WORDS];
        vmft_pack(&l, a, w);
        vmft_unpack(w, &o, b);
        double d = (double)l.mu[0] * o.mu[0] + (double)l.mu[1] * o.mu[1] + (double)l.mu[2] * o.mu[2];
        double cx = (double)l.mu[1] * o.mu[2] - (double)l.mu[2] * o.mu[1], cy = (double)l.mu[2] * o.mu[0] - (double)l.mu[0] * o.mu[2];
        double cz = (double)l.mu[0] * o.mu[1] - (double)l.mu[1] * o.mu[0];
        amax = fmax(amax, atan2(sqrt(cx * cx + cy * cy + cz * cz), d));   /* acos(d) loses 1e-4 rad to rounding */
        kmax = fmax(kmax, fabs(o.kappa / l.kappa - 1));
        for (int c = 0; c < 3; c++) cmax = fmax(cmax, fabs(b[c] / a[c] - 1));
    }
    printf("  packed lobe: axis %.2g rad, kappa %.2g, alpha %.2g (worst relative)\n", amax, kmax, cmax);
    CHECK_LE(amax, 7e-5, "axis");
    CHECK_LE(kmax, 5e-4, "kappa");
    CHECK_LE(cmax, 5e-4, "alpha");
    /* every half decodes as the compiler's own conversion does (the decoder is bit manipulation) */
    int bad = 0;
    for (uint32_t h = 0; h < 65536; h++) {
        uint32_t ww[VMFT_WORDS] = { 0, h, 0 };
        vmf_lobe l;
        float al[3];
        vmft_unpack(ww, &l, al);
        uint16_t x = (uint16_t)h;
        _Float16 f;
        memcpy(&f, &x, 2);
        bad += !((float)f == l.kappa || (isnan((float)f) && isnan(l.kappa)));
    }
    CHECK(bad == 0, "%d of 65,536 halves decode differently", bad);
    vmf_lobe big = { { 0, 0, -1 }, 1e6f }, o;
    float a[3] = { 0, 0, 0 }, b[3];
    uint32_t w[VMFT_WORDS];
    vmft_pack(&big, a, w);
    vmft_unpack(w, &o, b);
    CHECK(o.kappa == VMFT_KAPPA_MAX && o.mu[2] < -0.9999f && b[0] == 0, "kappa clamped to half's largest, -z kept");
}

/* configure: defaults (I = 2, level 2, 64 rays) and one line per refusal. */
static void configure(void) {
    prt_error err;
    transfer_config c;
    CHECK(transfer_vmf.configure(&(transfer_setup){ 0 }, &c, &err) == 0, "%s", err.msg);
    vmf_config v = vmft_config(&c);
    CHECK(v.lobes == VMFT_DEFAULT_LOBES && v.level == VMFT_DEFAULT_LEVEL && v.samples == VMFT_DEFAULT_SAMPLES, "defaults");
    char line[256];
    transfer_vmf.describe(&c, line, sizeof line);
    CHECK(strstr(line, "vMF lobes (2 per pass, 162 views, 64 rays per slice)") != NULL, "'%s'", line);
    struct { transfer_setup s; const char *want; } bad[] = {
        { { .options = "lobes=5" }, "lobes = '5'" }, { { .options = "level=7" }, "level = '7'" },
        { { .options = "samples=3" }, "samples = '3'" }, { { .options = "samples=5000" }, "samples = '5000'" },
        { { .N = 128 }, "do not apply" }, { { .options = "lobes=-1" }, "lobes = '-1'" }, { { .options = "views=3" }, "unknown option 'views'" },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err.msg[0] = 0;
        CHECK(transfer_vmf.configure(&bad[i].s, &c, &err) == -1 && strstr(err.msg, bad[i].want) && !strchr(err.msg, '\n'),
              "refusal %zu: '%s'", i, err.msg);
    }
}

/* settle (vmf.h VMFT_PLAN_BYTES): without a level in the options, the finest level of 2..4 whose
 * modelled bytes, nverts x views x (slot bytes + stored share x passes x lobes x 12), fit the budget;
 * a level in the options is kept; room, the vertices that level holds within the budget, holds the
 * count whenever a level fits. Exact: the same double arithmetic, compared at the boundaries. */
static void settle(void) {
    prt_error err;
    double pair1 = VMFT_PLAN_SLOT_BYTES + VMFT_PLAN_STORED * 1 * VMFT_DEFAULT_LOBES * 12;
    double pair4 = VMFT_PLAN_SLOT_BYTES + VMFT_PLAN_STORED * 4 * VMFT_DEFAULT_LOBES * 12;
    struct { const char *options; long n; int passes, want; } cases[] = {
        { NULL, 100, 1, 4 },
        { NULL, (long)(VMFT_PLAN_BYTES / (2562 * pair1)), 1, 4 },
        { NULL, (long)(VMFT_PLAN_BYTES / (2562 * pair1)) + 1, 1, 3 },
        { NULL, (long)(VMFT_PLAN_BYTES / (642 * pair4)) + 1, 4, 2 },
        { NULL, (long)(VMFT_PLAN_BYTES / (642 * pair4)), 4, 3 },
        { NULL, 10000000, 1, 2 },
        { "level=1", 100, 1, 1 },
        { "level=2", 100, 1, 2 },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        transfer_config c;
        char why[256] = "";
        CHECK(transfer_vmf.configure(&(transfer_setup){ .options = cases[i].options }, &c, &err) == 0, "%s", err.msg);
        long room = -1;
        transfer_vmf.view->settle(&c, cases[i].n, cases[i].passes, &room, why, sizeof why);
        vmf_config v = vmft_config(&c);
        CHECK(v.level == cases[i].want, "case %zu: %ld vertices, %d passes: level %d, want %d (%s)", i, cases[i].n,
              cases[i].passes, v.level, cases[i].want, why);
        /* room: the most vertices whose modelled bytes at the settled level fit the budget */
        double pair = VMFT_PLAN_SLOT_BYTES + VMFT_PLAN_STORED * cases[i].passes * VMFT_DEFAULT_LOBES * 12;
        long want_room = (long)(VMFT_PLAN_BYTES / ((10.0 * (1 << (2 * v.level)) + 2) * pair));
        CHECK(room == want_room, "case %zu: room %ld, want %ld", i, room, want_room);
        CHECK(cases[i].want == VMFT_DEFAULT_LEVEL || cases[i].options || room >= cases[i].n, "case %zu: room %ld < %ld vertices", i,
              room, cases[i].n);
        CHECK(why[0] && !strchr(why, '\n') && (cases[i].options ? strstr(why, "as asked") != NULL : strstr(why, "MB") != NULL),
              "case %zu: '%s'", i, why);
    }
}

/* ---- scenes --------------------------------------------------------------------------------- */

/* d from JSON scene text, vis built; 0 or -1. */
static int load_scene(const char *json, prt_data *d, vis_scene **vs) {
    prt_error err;
    memset(d, 0, sizeof *d);
    if (scene_parse_json("test.json", json, strlen(json), NULL, &d->scene, &err)) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    *vs = vis_create(&d->scene.mesh, &err);
    return *vs ? 0 : -1;
}

/* Adds and precomputes a vmf transfer of materials mask configured from options; 0 or -1. */
static int run_vmf(prt_data *d, vis_scene *vs, const char *options, uint64_t mask, int passes, int threads) {
    prt_error err;
    transfer_config cfg;
    if (transfer_vmf.configure(&(transfer_setup){ .options = options }, &cfg, &err)) return fprintf(stderr, "%s\n", err.msg), -1;
    prt_transfer *tr = prt_data_add_transfer(d, &transfer_vmf, &cfg, mask);
    transfer_precompute_in in = { .scene = &d->scene, .vis = vs, .passes = passes, .bounce_threshold = 0.0f, .nthreads = threads };
    if (transfer_vmf.view->precompute(&in, tr, &err)) return fprintf(stderr, "%s\n", err.msg), -1;
    return 0;
}

/* ---- an unoccluded glossy sphere --------------------------------------------------------------- */

static void smooth_fn(const float d[3], float rgb[3]) {
    /* sky gradient plus a broad warm blob, so that lobes 8 degrees wide see variation */
    float blob = expf(6 * (0.6f * d[0] + 0.64f * d[1] + 0.48f * d[2] - 1));
    rgb[0] = 0.3f + 0.2f * d[1] + 4 * blob;
    rgb[1] = 0.4f + 0.3f * d[1] * d[1] + 2 * blob;
    rgb[2] = 0.6f + 0.4f * d[1] - 0.2f * d[0] + 0.5f * blob;
}

static void make_probe(void (*fn)(const float *, float *), int w, prt_probe *p) {
    prt_image img;
    prt_error err;
    CHECK(image_alloc(&img, w, w / 2, 3, &err) == 0);
    for (int y = 0; y < w / 2; y++)
        for (int x = 0; x < w; x++) {
            double th = PI * (y + 0.5) / (w / 2), ph = 2 * PI * ((x + 0.5) / w - 0.5);
            float d[3] = { (float)(sin(th) * sin(ph)), (float)cos(th), (float)(-sin(th) * cos(ph)) };
            fn(d, img.data + 3 * ((size_t)y * w + x));
        }
    CHECK(probe_from_image(&img, PROBE_LATLONG, "test probe", p, &err) == 0);
}

/* int L(wi) f_s(wi, wo) cos(theta_i) dwi over the probe's pixels (f_s: spec without its kd). */
static void quad_specular(const prt_probe *p, const brdf_params *b, const float n[3], const float wo[3], double out[3]) {
    float s[3], t[3], wl[3];
    brdf_frame(n, s, t);
    brdf_to_local(s, t, n, wo, wl);
    out[0] = out[1] = out[2] = 0;
    for (int y = 0; y < p->img.h; y++)
        for (int x = 0; x < p->img.w; x++) {
            float d[3], om, il[3], f[3];
            if (!probe_pixel_dir(p, x, y, d, &om)) continue;
            brdf_to_local(s, t, n, d, il);
            if (il[2] <= 0) continue;
            brdf_eval(b, il, wl, f);
            const float *L = p->img.data + 3 * ((size_t)y * p->img.w + x);
            for (int c = 0; c < 3; c++) out[c] += (double)om * f[c] * il[2] * L[c];
        }
}

/* A convex sphere stores nothing, and its shading is the one-lobe fit of the BRDF against the
 * prefiltered probe: compared with quadrature of the analytic BRDF (specular part) over the probe.
 * Tolerance: 3% RMS over the visible vertices, 8% worst: Phong n = 50's fit is 2.7% mean L2 error
 * per slice (lobefit.h; integrated against a smooth probe much less), prefilter lookups 0.8%. */
static void unoccluded_sphere(void) {
    prt_data d;
    vis_scene *vs;
    const char *json = "{\"models\":[{\"sphere\":{\"center\":[0,1,0],\"radius\":1,\"rings\":12,\"segments\":24},"
                       "\"material\":\"phong:kd=0.3,0.1,0.1;ks=0.5;n=50\"}]}";
    if (load_scene(json, &d, &vs) || run_vmf(&d, vs, "level=2", 1, 1, 0)) {
        CHECK(0, "set-up");
        return;
    }
    const prt_transfer *tr = &d.transfers[0];
    const vmft_data *t = vmft_get(tr);
    CHECK(t->hash.n == 0 && t->passes == 1 && t->slices > 0, "convex: %zu of %llu slices stored", t->hash.n, (unsigned long long)t->slices);
    prt_probe p;
    make_probe(smooth_fn, 256, &p);
    prt_error err;
    prefilter_env *env = prefilter_create(&p, NULL, NULL, &err);
    brdf_params spec = d.scene.materials[0];
    spec.kd[0] = spec.kd[1] = spec.kd[2] = 0;
    const prt_mesh *m = &d.scene.mesh;
    float *rgb = calloc(3 * (size_t)m->nverts, sizeof(float)), eye[3] = { 2.5f, 3.0f, 4.0f };
    transfer_vmf.view->shade_vertices(&d, tr, env, eye, rgb, 0);
    double num = 0, den = 0, worst = 0;
    int nvis = 0;
    for (int v = 0; v < m->nverts; v++) {
        const float *pp = m->pos + 3 * v, *n = m->nrm + 3 * v;
        float wo[3] = { eye[0] - pp[0], eye[1] - pp[1], eye[2] - pp[2] }, l = sqrtf(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]);
        for (int k = 0; k < 3; k++) wo[k] /= l;
        if (wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2] < 0.2f) continue;   /* grazing: the fit's 16% worst */
        double q[3];
        quad_specular(&p, &spec, n, wo, q);
        double e2 = 0, q2 = 0;
        for (int c = 0; c < 3; c++) e2 += (rgb[3 * v + c] - q[c]) * (rgb[3 * v + c] - q[c]), q2 += q[c] * q[c];
        num += e2, den += q2, nvis++;
        worst = fmax(worst, sqrt(e2 / q2));
    }
    double rms = sqrt(num / den);
    printf("  unoccluded sphere: %d visible vertices, relative RMS %.2f%%, worst %.2f%%\n", nvis, 100 * rms, 100 * worst);
    CHECK(nvis > 50, "%d visible vertices", nvis);
    CHECK_LE(rms, 0.03, "relative RMS against quadrature");
    CHECK_LE(worst, 0.08, "worst vertex against quadrature");
    free(rgb);
    prefilter_destroy(env);
    probe_free(&p);
    vis_destroy(vs);
    prt_data_free(&d);
}

/* ---- a glossy corner: floor and wall ----------------------------------------------------------- */

/* A floor (y = 0) and a wall (z = -1, y in [0, 2], facing +z), both phong n = 200 without kd. */
static const char *k_corner =
    "{\"models\":[{\"plane\":{\"x\":[-1,1],\"z\":[-1,1],\"height\":0,\"nx\":21,\"nz\":21},\"material\":\"phong:kd=0;ks=0.8,0.6,0.4;n=200\"},"
    "{\"plane\":{\"x\":[-1,1],\"z\":[-1,1],\"height\":0,\"nx\":21,\"nz\":21},\"rotate_x\":90,\"translate\":[0,1,-1],"
    "\"material\":\"phong:kd=0;ks=0.8,0.6,0.4;n=200\"}]}";

static int find_vertex(const prt_mesh *m, float x, float y, float z, float ny) {
    for (int v = 0; v < m->nverts; v++) {
        const float *p = m->pos + 3 * v;
        if (fabsf(p[0] - x) < 1e-4f && fabsf(p[1] - y) < 1e-4f && fabsf(p[2] - z) < 1e-4f && m->nrm[3 * v + 1] * ny > 0.5f) return v;
    }
    return -1;
}

/* Directional albedo of the specular slice, int f_s(wi, wo) cos dwi, for wo at elevation theta
 * (quadrature in polar coordinates about the mirror direction). */
static void albedo(const brdf_params *b, double theta, double out[3]) {
    float wo[3] = { (float)sin(theta), 0, (float)cos(theta) };
    double r[3] = { -sin(theta), 0, cos(theta) }, t1[3] = { cos(theta), 0, sin(theta) }, t2[3] = { 0, 1, 0 };
    out[0] = out[1] = out[2] = 0;
    const int NT = 600, NP = 256;
    const double tmax = 0.8;
    for (int i = 0; i < NT; i++) {
        double a = (i + 0.5) * tmax / NT, da = tmax / NT;
        for (int j = 0; j < NP; j++) {
            double ph = 2 * PI * (j + 0.5) / NP;
            float wi[3], f[3];
            for (int k = 0; k < 3; k++) wi[k] = (float)(cos(a) * r[k] + sin(a) * (cos(ph) * t1[k] + sin(ph) * t2[k]));
            if (wi[2] <= 0) continue;
            brdf_eval(b, wi, wo, f);
            for (int c = 0; c < 3; c++) out[c] += f[c] * wi[2] * sin(a) * da * 2 * PI / NP;
        }
    }
}

/* The radiance the corner's floor vertex p (0, 0, -0.5) reflects toward wo = (0, sin 45, cos 45) after
 * one bounce off the wall under a constant white sky, by integration: int over the floor lobe's
 * directions s that hit the wall of f_s(s, wo) cos * a_wall(-s), a_wall the wall's directional albedo
 * (its mirror lobe then goes up and escapes: nothing blocks it). */
static void corner_truth(const brdf_params *b, double out[3]) {
    double tab[91][3] = { { 0 } };
    for (int i = 25; i <= 65; i++) albedo(b, i * PI / 180, tab[i]);   /* the wall sees -s within 45 +- 20 deg */
    const double th = PI / 4;
    float wo[3] = { 0, (float)sin(th), (float)cos(th) };   /* world: y up; local z = y */
    double r[3] = { 0, sin(th), -cos(th) }, t1[3] = { 0, cos(th), sin(th) }, t2[3] = { 1, 0, 0 };
    out[0] = out[1] = out[2] = 0;
    const int NT = 600, NP = 256;
    const double tmax = 0.8;
    for (int i = 0; i < NT; i++) {
        double a = (i + 0.5) * tmax / NT, da = tmax / NT;
        for (int j = 0; j < NP; j++) {
            double ph = 2 * PI * (j + 0.5) / NP;
            double s[3];
            for (int k = 0; k < 3; k++) s[k] = cos(a) * r[k] + sin(a) * (cos(ph) * t1[k] + sin(ph) * t2[k]);
            if (s[1] <= 0 || s[2] >= 0) continue;
            double t = 0.5 / -s[2], y = t * s[1], x = t * s[0];
            if (y > 2 || fabs(x) > 1) continue;   /* over or beside the wall: not this bounce */
            float wi[3] = { (float)s[0], (float)s[2], (float)s[1] }, wl[3] = { wo[0], wo[2], wo[1] }, f[3];
            brdf_eval(b, wi, wl, f);
            double e = acos(s[2] < 0 ? -s[2] : s[2]) * 180 / PI;   /* -s's angle to the wall normal +z */
            int k0 = (int)e;
            double fr = e - k0;
            if (k0 < 25 || k0 >= 65) continue;   /* beyond 20 deg from the lobe's axis: f_s ~ 1e-14 */
            for (int c = 0; c < 3; c++) {
                double aw = k0 >= 90 ? tab[90][c] : (1 - fr) * tab[k0][c] + fr * tab[k0 + 1][c];
                out[c] += f[c] * s[1] * aw * sin(a) * da * 2 * PI / NP;
            }
        }
    }
}

/* Pass p's colour (sum of alpha) at vertex v toward wo (Eq. 7 over the grid, as the runtime). */
static void pass_alpha(const vmft_data *t, const prt_mesh *m, int v, const float wo[3], int p, double out[3]) {
    int views[3], verts[3] = { v, v, v };
    float w[3];
    geogrid_locate(t->grid, wo, views, w);
    vmf_lobe l[VMFT_MAX_LOBES];
    float a[VMFT_MAX_LOBES][3];
    vmft_interp(t, m, 3, verts, views, w, p, wo, m->nrm + 3 * v, l, a);
    out[0] = out[1] = out[2] = 0;
    for (int i = 0; i < t->lobes; i++)
        for (int c = 0; c < 3; c++) out[c] += a[i][c];
}

/* The second bounce appears with the energy integration gives (within 5%), the direct pass is
 * (nearly) blocked, and a third pass has (nearly) nothing to gather. */
static void corner_bounce(void) {
    prt_data d;
    vis_scene *vs;
    if (load_scene(k_corner, &d, &vs) || run_vmf(&d, vs, "level=2,samples=64", 1, 3, 0)) {
        CHECK(0, "set-up");
        return;
    }
    const vmft_data *t = vmft_get(&d.transfers[0]);
    const prt_mesh *m = &d.scene.mesh;
    int v = find_vertex(m, 0, 0, -0.5f, 1);
    CHECK(v >= 0 && t->passes >= 2, "floor vertex %d, %d passes", v, t->passes);
    if (v < 0 || t->passes < 2) return;
    float wo[3] = { 0, sqrtf(0.5f), sqrtf(0.5f) };
    double a0[3], a1[3], a2[3] = { 0, 0, 0 }, truth[3];
    pass_alpha(t, m, v, wo, 0, a0);
    pass_alpha(t, m, v, wo, 1, a1);
    if (t->passes > 2) pass_alpha(t, m, v, wo, 2, a2);
    corner_truth(&d.scene.materials[0], truth);
    printf("  corner: stored %zu of %llu slices (fill %.2f), energy pass 1 %.3f, pass 2 %.4f\n", t->hash.n,
           (unsigned long long)t->slices, t->hash.fill, t->energy[1], t->passes > 2 ? t->energy[2] : 0.0);
    for (int c = 0; c < 3; c++) {
        printf("  channel %d: direct %.4f, bounce %.4f (integration %.4f, %+.2f%%), third %.5f\n", c, a0[c], a1[c], truth[c],
               100 * (a1[c] / truth[c] - 1), a2[c]);
        CHECK_NEAR(a1[c], truth[c], 0.05 * truth[c], "second bounce, channel %d", c);
        CHECK_LE(a0[c], 0.02 * truth[c], "the wall blocks the direct lobe");
        CHECK_LE(a2[c], 0.02 * truth[c], "nothing to gather a second time");
    }
    vis_destroy(vs);
    prt_data_free(&d);
}

/* A lobe the wall or the floor cuts keeps what its unblocked rays fit, never sharper than twice the
 * BRDF's own lobe (vmfpass.c VP_KAPPA_CAP: a straight edge leaves at sharpest a strip whose spread
 * along the edge is the lobe's, mean length 1 - 1/(2 kappa)) and never brighter than it; slices with
 * one or two unblocked rays, whose mean alone would fit kappa at half's largest, are among them.
 * Tolerances: half's 11-bit kappa and alpha (2^-11 relative) and the fit's float kappa. */
static void cut_lobes(void) {
    prt_data d;
    vis_scene *vs;
    if (load_scene(k_corner, &d, &vs) || run_vmf(&d, vs, "level=2,samples=64", 1, 1, 0)) {
        CHECK(0, "set-up");
        return;
    }
    const vmft_data *t = vmft_get(&d.transfers[0]);
    const prt_mesh *m = &d.scene.mesh;
    int stored = 0, slivers = 0, sharp = 0;
    double worst_k = 0, worst_a = 0;
    for (int v = 0; v < m->nverts; v++)
        for (int j = 0; j < t->nviews; j++) {
            const uint32_t *sl = vmft_slice(t, v, j, 0);
            if (!sl) continue;
            vmf_lobe B, l;
            float A[3], a[3], sum = 0;
            vmft_brdf_lobe(&t->fit[m->mat[v]], m->nrm + 3 * (size_t)v, geogrid_dir(t->grid, j), &B, A);
            for (int i = 0; i < t->lobes; i++) {
                vmft_unpack(sl + VMFT_WORDS * i, &l, a);
                if (!(prt_luminancef(a) > 0)) continue;
                sum += prt_luminancef(a);
                worst_k = fmax(worst_k, l.kappa / B.kappa);
                sharp += l.kappa > 1.9f * B.kappa;
            }
            worst_a = fmax(worst_a, sum / prt_luminancef(A));
            stored++;
            slivers += sum > 0 && sum < 2.5f / 64 * prt_luminancef(A);
        }
    printf("  %d stored slices, %d with 1-2 unblocked rays of 64, %d lobes over 1.9 kappa_brdf; kappa / kappa_brdf at most "
           "%.4f, alpha / the lobe's at most %.4f\n", stored, slivers, sharp, worst_k, worst_a);
    CHECK(stored > 0 && slivers > 0, "the corner stores cut lobes, slivers among them (%d, %d)", stored, slivers);
    CHECK_LE(worst_k, 2.0 * (1 + 1.0 / 1024), "a cut lobe's kappa at most twice the lobe's");
    CHECK_LE(worst_a, 1 + 1.0 / 1024, "a cut lobe's colour at most the lobe's");
    vis_destroy(vs);
    prt_data_free(&d);
}

/* The same on 1 and 2 threads: identical hash and lobes, byte for byte (exact by construction:
 * the same code on the same machine; each vertex's lobes are one thread's, whatever the count). */
static void determinism(void) {
    prt_data d1, d2;
    vis_scene *v1, *v2;
    if (load_scene(k_corner, &d1, &v1) || load_scene(k_corner, &d2, &v2) ||
        run_vmf(&d1, v1, "level=1,samples=32", 1, 2, 1) ||
        run_vmf(&d2, v2, "level=1,samples=32", 1, 2, 2)) {
        CHECK(0, "set-up");
        return;
    }
    const vmft_data *a = vmft_get(&d1.transfers[0]), *b = vmft_get(&d2.transfers[0]);
    size_t per = (size_t)a->passes * a->lobes * VMFT_WORDS;
    CHECK(a->hash.n > 0 && a->hash.n == b->hash.n && a->hash.size == b->hash.size && a->passes == b->passes, "sizes");
    if (a->hash.size == b->hash.size && a->passes == b->passes) {
        CHECK(!memcmp(a->hash.offset, b->hash.offset, sizeof(uint32_t) * a->nverts), "offsets");
        CHECK(!memcmp(a->hash.owner, b->hash.owner, sizeof(uint32_t) * a->hash.size), "owners");
        CHECK(!memcmp(a->entry, b->entry, sizeof(uint32_t) * a->hash.size), "entries");
        CHECK(!memcmp(a->lobe, b->lobe, sizeof(uint32_t) * a->hash.n * per), "lobes");
    }
    vis_destroy(v1), vis_destroy(v2);
    prt_data_free(&d1), prt_data_free(&d2);
}

/* A progress callback that says stop: the precompute fails with "cancelled" and leaves no data. */
static bool stop_at_half(void *user, const char *stage, double fraction) {
    (*(int *)user)++;
    return !(fraction >= 0.5 && !strcmp(stage, "vmf direct"));
}

static void cancel(void) {
    prt_data d;
    vis_scene *vs;
    if (load_scene(k_corner, &d, &vs)) {
        CHECK(0, "set-up");
        return;
    }
    transfer_config cfg;
    prt_error err = { { 0 } };
    CHECK(transfer_vmf.configure(&(transfer_setup){ .options = "level=1,samples=16" }, &cfg, &err) == 0);
    prt_transfer *tr = prt_data_add_transfer(&d, &transfer_vmf, &cfg, 1);
    int calls = 0;
    transfer_precompute_in in = { .scene = &d.scene, .vis = vs, .passes = 2, .progress = stop_at_half, .progress_user = &calls };
    CHECK(transfer_vmf.view->precompute(&in, tr, &err) == -1 && strstr(err.msg, "cancelled") && tr->priv == NULL, "'%s', %d calls", err.msg,
          calls);
    vis_destroy(vs);
    prt_data_free(&d);
}

/* ---- the file -------------------------------------------------------------------------------- */

/* Writes n bytes to path; true on success. */
static bool put_file(const char *path, const uint8_t *b, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    bool ok = fwrite(b, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

/* Offset of the body of the section tagged tag in a .prt image (walking the sections), or 0. */
static size_t section_body(const uint8_t *b, size_t n, uint32_t tag) {
    size_t pos = 16;
    while (pos + 12 <= n - 4) {
        uint32_t t;
        uint64_t len;
        memcpy(&t, b + pos, 4), memcpy(&len, b + pos + 4, 8);
        if (t == tag) return pos + 12;
        pos += 12 + (size_t)len;
    }
    return 0;
}

/* The corner precomputed (2 passes) and written; its path in path[512]. 0 or -1. */
static int corner_file(prt_data *d, char *path) {
    vis_scene *vs;
    if (load_scene(k_corner, d, &vs) || run_vmf(d, vs, "level=1,samples=16", 1, 2, 0)) return -1;
    vis_destroy(vs);
    d->vis_res = 128, d->gather_res = 32;
    prt_error err;
    snprintf(path, 512, "%s/corner.prt", check_tmpdir());
    if (prtfile_write(path, d, &err)) return fprintf(stderr, "%s\n", err.msg), -1;
    return 0;
}

/* Write, read, compare every array and statistic; write again: the same bytes; the same shading. */
static void file_roundtrip(void) {
    prt_data a, b;
    char path[512], path2[600];
    prt_error err;
    if (corner_file(&a, path)) {
        CHECK(0, "set-up");
        return;
    }
    CHECK(prtfile_read(path, &b, &err) == 0, "%s", err.msg);
    if (b.ntransfers != 1 || b.transfers[0].ops != &transfer_vmf) {
        CHECK(0, "one vmf transfer read");
        prt_data_free(&a);
        return;
    }
    const vmft_data *x = vmft_get(&a.transfers[0]), *y = vmft_get(&b.transfers[0]);
    size_t per = (size_t)x->passes * x->lobes * VMFT_WORDS;
    CHECK(x->hash.n > 0 && x->hash.n == y->hash.n && x->hash.size == y->hash.size && x->passes == y->passes && x->lobes == y->lobes &&
          x->nviews == y->nviews && x->slices == y->slices && x->materials == y->materials, "sizes");
    CHECK(!memcmp(&a.transfers[0].cfg, &b.transfers[0].cfg, sizeof a.transfers[0].cfg) && a.transfers[0].materials == 1, "config");
    CHECK(!memcmp(x->hash.offset, y->hash.offset, 4 * (size_t)x->nverts) && !memcmp(x->hash.owner, y->hash.owner, 4 * x->hash.size) &&
          !memcmp(x->entry, y->entry, 4 * x->hash.size) && !memcmp(x->lobe, y->lobe, 4 * x->hash.n * per), "hash and lobes");
    CHECK(!memcmp(x->fit[0].lobe, y->fit[0].lobe, sizeof x->fit[0].lobe) && !memcmp(x->fit[0].alpha, y->fit[0].alpha, sizeof x->fit[0].alpha),
          "lobe fit");
    CHECK(!memcmp(x->energy, y->energy, sizeof x->energy) && !memcmp(x->t_pass, y->t_pass, sizeof x->t_pass), "statistics");
    CHECK(transfer_vmf.bytes(&b.transfers[0]) == vmft_bytes(x) && vmft_bytes(x) > 0, "bytes");
    snprintf(path2, sizeof path2, "%s/corner_again.prt", check_tmpdir());
    CHECK(prtfile_write(path2, &b, &err) == 0, "%s", err.msg);
    size_t n1, n2;
    char *b1 = check_read_file(path, &n1), *b2 = check_read_file(path2, &n2);
    CHECK(b1 && b2 && n1 == n2 && !memcmp(b1, b2, n1), "re-written identically");
    free(b1), free(b2);
    /* prt info shows the section: views, lobes, passes, stored share, hash fill, bytes */
    char cmd[1200], out[8192], want[160];
    snprintf(cmd, sizeof cmd, "%s info %s", check_prt_bin(), path);
    int rc = check_run(cmd, out, sizeof out);
    snprintf(want, sizeof want, "stored %zu of %llu slices", x->hash.n, (unsigned long long)x->slices);
    CHECK(rc == 0 && strstr(out, "vmf           42 views (geodesic level 1), 2 lobes per pass, 2 passes stored") &&
          strstr(out, want) && strstr(out, "fill") && strstr(out, "MB (12 bytes a lobe)") && strstr(out, "pass 1:") &&
          strstr(out, "its specular lobe: vMF lobes (the factor above is the diffuse kd/pi part)"),
          "prt info: rc %d\n%s", rc, out);
    prt_probe p;
    float white[3] = { 1, 0.5f, 0.25f }, eye[3] = { 0.3f, 1.5f, 2 };
    CHECK(probe_make_constant(white, &p, &err) == 0);
    prefilter_env *env = prefilter_create(&p, NULL, NULL, &err);
    int nv = a.scene.mesh.nverts;
    float *ra = calloc(3 * (size_t)nv, sizeof(float)), *rb = calloc(3 * (size_t)nv, sizeof(float));
    transfer_vmf.view->shade_vertices(&a, &a.transfers[0], env, eye, ra, 1);
    transfer_vmf.view->shade_vertices(&b, &b.transfers[0], env, eye, rb, 2);
    CHECK(!memcmp(ra, rb, sizeof(float) * 3 * nv), "the same shading (1 and 2 threads)");
    free(ra), free(rb);
    prefilter_destroy(env);
    probe_free(&p);
    prt_data_free(&a), prt_data_free(&b);
}

/* A patch of the file at byte off (within the vmf section body when body is set): n bytes. */
typedef struct patch { const char *what; size_t off; uint32_t value; int bytes; const char *want; } patch;

/* Each corruption of the vmf section (CRC fixed, so the validators must catch it) fails with one
 * line naming the file and the problem; nothing crashes (ASan run: make test SAN=1). */
static void bad_input(void) {
    prt_data a;
    char path[512], bad[600];
    if (corner_file(&a, path)) {
        CHECK(0, "set-up");
        return;
    }
    const vmft_data *t = vmft_get(&a.transfers[0]);
    size_t n;
    uint8_t *img = (uint8_t *)check_read_file(path, &n);
    size_t body = img ? section_body(img, n, transfer_vmf.tag) : 0;
    CHECK(body > 0, "vmf section found");
    if (!body) return;
    size_t fit = 108 + 36 + 40 * (size_t)t->fit[0].views, hash = body + fit + 16, owner = hash + 4 * (size_t)t->nverts;
    size_t entry = owner + 4 * t->hash.size, lobe = entry + 4 * t->hash.size, first = 0;
    while (first < t->hash.size && !t->hash.owner[first]) first++;
    patch P[] = {
        { "lobe count", body + 0, 9, 4, "bad lobe count 9" },
        { "grid level", body + 4, 9, 4, "bad grid level 9" },
        { "pass count", body + 20, 0, 4, "bad pass count 0" },
        { "view count", body + 28, (uint32_t)t->nviews + 1, 4, "views for grid level" },
        { "vertex count", body + 24, (uint32_t)t->nverts - 1, 4, "corrupt" },
        { "fit kappa", body + 108 + 12 + 16, 0x7fc00000u, 4, "lobe fit has a bad lobe" },
        { "hash size", body + fit + 8, (uint32_t)t->hash.size + 100000, 4, "too short for its hash table" },
        { "offset", hash, 0xffffffffu, 4, "hash offset" },
        { "owner", owner + 4 * first, (uint32_t)t->nverts + 7, 4, "names vertex" },
        { "entry", entry + 4 * first, (uint32_t)t->hash.n + 3, 4, "names entry" },
        { "kappa NaN", lobe + 4, 0x7e00, 2, "bad lobe" },
        { "alpha negative", lobe + 6, 0xbc00, 2, "bad lobe" },
    };
    for (size_t k = 0; k < sizeof P / sizeof P[0]; k++) {
        uint8_t *c = malloc(n);
        memcpy(c, img, n);
        memcpy(c + P[k].off, &P[k].value, (size_t)P[k].bytes);
        uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), c, (uInt)(n - 4));
        memcpy(c + n - 4, &crc, 4);
        snprintf(bad, sizeof bad, "%s/bad%zu.prt", check_tmpdir(), k);
        CHECK(put_file(bad, c, n), "write %s", bad);
        prt_data d;
        prt_error err = { { 0 } };
        int rc = prtfile_read(bad, &d, &err);
        CHECK(rc == -1 && strstr(err.msg, bad) && strstr(err.msg, P[k].want) && !strchr(err.msg, '\n'), "%s: '%s'", P[k].what, err.msg);
        if (rc == 0) prt_data_free(&d);
        free(c);
    }
    free(img);
    prt_data_free(&a);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(pack);
    CHECK_CASE(configure);
    CHECK_CASE(settle);
    CHECK_CASE(unoccluded_sphere);
    CHECK_CASE(corner_bounce);
    CHECK_CASE(cut_lobes);
    CHECK_CASE(determinism);
    CHECK_CASE(cancel);
    CHECK_CASE(file_roundtrip);
    CHECK_CASE(bad_input);
    return check_summary();
}
