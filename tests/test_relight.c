/* test_relight.c - Eq. 5 end to end on a hand-built prt_data: a Lambert factor under a
 * constant environment gives albedo x radiance; a two-term factor with a linear view map
 * gives the analytic h . g in the Eq. 10 frame; occlusion, kmax, clamping, errors, speed. */
#include "harness.h"
#include "relight.h"
#include "light.h"
#include "haar.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { T = CUBE_TEXELS, RES = 8 };

/* A factor with constant light maps gl[k][ch] and view maps: term 0 = 1, term 1 = w.x
 * (exact under bilinear lookup for |w.x| <= 1 - 1/RES on the grid parameterization). */
static void make_factor(brdf_factor *f, int K, const float gl[][3], bool lambertian) {
    memset(f, 0, sizeof *f);
    f->K = K; f->res = RES; f->param = BRDF_PARAM_GRID; f->lambertian = lambertian;
    f->light = malloc(sizeof(float) * RES * RES * K * 3);
    f->view = malloc(sizeof(float) * RES * RES * K * 3);
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++)
            for (int k = 0; k < K; k++)
                for (int c = 0; c < 3; c++) {
                    size_t o = ((size_t)(y * RES + x) * K + k) * 3 + c;
                    f->light[o] = gl[k][c];
                    f->view[o] = k == 0 ? 1.f : 2.f * (x + 0.5f) / RES - 1.f;
                }
}

/* Eq. 10's tangent s for normal n, written out independently of brdf.c. */
static void frame_s(const float n[3], float s[3]) {
    s[0] = (n[1] + 1) * (n[1] + 1) + n[2] * n[2] - n[0] * n[0];
    s[1] = -2 * (n[1] + 1) * n[0];
    s[2] = -2 * n[0] * n[2];
    float l = sqrtf(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    for (int c = 0; c < 3; c++) s[c] /= l;
}

static void normalize3(float v[3]) { float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); v[0] /= l; v[1] /= l; v[2] /= l; }

/* Visibility kinds: 0 open, 1 fully occluded, 2 only directions with y >= 0 visible. */
static float vis(int kind, const float d[3]) { return kind == 0 ? 1.f : kind == 1 ? 0.f : (d[1] >= 0 ? 1.f : 0.f); }

/* The scene of the cases: six vertices (material, visibility kind, normal), a Lambert
 * material (albedo kd) and a two-term one with a linear view map (lin), lit by the constant
 * environment c; S is the discrete truth S_v = sum_j V cos dw over the cube texels. */
static const int vmat[6] = { 0, 0, 0, 1, 1, 1 }, vvis[6] = { 0, 1, 2, 0, 0, 2 };
static float nrm[6][3] = { { 0, 1, 0 }, { 0, 1, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0.3f, 0.8f, -0.5f }, { -0.6f, 0.2f, 0.77f } };
static const float kd[3] = { 0.8f, 0.5f, 0.2f }, c[3] = { 1.0f, 2.0f, 0.5f };
static const float lam[1][3] = { { 0.8f / (float)M_PI, 0.5f / (float)M_PI, 0.2f / (float)M_PI } };
static const float lin[2][3] = { { 0.2f, 0.3f, 0.4f }, { 0.1f, -0.5f, 0.6f } };
static float sa[64 * 64];
static double S[6];

/* Normalizes the normals and computes sa and S, once (every case that needs them calls it). */
static void scene_setup(void) {
    static bool done;
    if (done) return;
    done = true;
    cube_face_solid_angles(CUBE_RES, sa);
    for (int v = 0; v < 6; v++) normalize3(nrm[v]);
    /* Discrete truth: S_v = sum_j V cos dw over the cube texels. */
    for (int v = 0; v < 6; v++) {
        S[v] = 0;
        for (int j = 0; j < T; j++) {
            float d[3];
            cube_texel_dir(CUBE_RES, j, d);
            double cs = d[0] * nrm[v][0] + d[1] * nrm[v][1] + d[2] * nrm[v][2];
            if (cs > 0) S[v] += vis(vvis[v], d) * cs * sa[j % 4096];
        }
    }
}

static void cube_quadrature(void) {
    scene_setup();
    CHECK_NEAR(S[0] / M_PI, 1.0, 2e-4, "cube quadrature of the cosine over a hemisphere");
    /* exact but for rounding: the cube's texels are symmetric under the axis swap and the y mirror,
     * so only the double sums' order differs (~1e-13); 1e-6 is slack */
    CHECK_NEAR(S[2] / S[0], 0.5, 1e-6, "half-occluded vertex sees half the cosine");
}

/* For float and 8-bit transport: constant light (K-vectors, Lambert albedo x radiance,
 * occlusion), the linear view map against c S (a + b (wo . s)), kmax, and errors. */
static void lambert_and_linear_views(void) {
    scene_setup();
    int qbits[2] = { 32, 8 };
    for (int qi = 0; qi < 2; qi++) {
        prt_data pd;
        memset(&pd, 0, sizeof pd);
        prt_mesh *m = &pd.scene.mesh;
        m->nverts = 6;
        m->pos = malloc(sizeof(float) * 18);
        m->nrm = malloc(sizeof(float) * 18);
        m->mat = malloc(sizeof(uint16_t) * 6);
        for (int v = 0; v < 6; v++) {
            for (int k = 0; k < 3; k++) { m->pos[3 * v + k] = (float)v + 0.1f * k; m->nrm[3 * v + k] = nrm[v][k]; }
            m->mat[v] = (uint16_t)vmat[v];
        }
        pd.scene.nmaterials = 2;
        make_factor(&pd.factors[0], 1, lam, true);
        make_factor(&pd.factors[1], 2, lin, false);
        /* transport: T_k = g_k V cos dw (Eq. 3), Haar, all coefficients kept (N = 24576) so
         * that only quantization separates the result from the analytic one (with N = 128 a
         * tilted, half-occluded vertex loses a dim face's scaling coefficient: that is
         * truncation, tested in test_sparse / test_transport) */
        int nv[6];
        for (int v = 0; v < 6; v++) nv[v] = pd.factors[vmat[v]].K;
        prt_error err = { "" };
        prt_data_add_transfer(&pd, transfer_find("haar"), NULL, 3);
        prt_data bad = pd;
        CHECK(relight_create(&bad, 2, &err) == NULL && strstr(err.msg, "not finished"), "unfinished transport: %s", err.msg);
        CHECK(transport_init(&pd.transfers[0].transport, 6, nv, T, qbits[qi], &err) == 0, "init: %s", err.msg);
        float *tex = malloc(sizeof(float) * 3 * T), *w = malloc(sizeof(float) * 3 * T), tmp[2 * 64 * 64];
        void *scratch = malloc(transport_scratch_size());
        for (int v = 0; v < 6; v++) {
            const brdf_factor *f = &pd.factors[vmat[v]];
            for (int k = 0; k < f->K; k++) {
                for (int j = 0; j < T; j++) {
                    float d[3];
                    cube_texel_dir(CUBE_RES, j, d);
                    float cs = d[0] * nrm[v][0] + d[1] * nrm[v][1] + d[2] * nrm[v][2];
                    float base = cs > 0 ? vis(vvis[v], d) * cs * sa[j % 4096] : 0.f;
                    for (int ch = 0; ch < 3; ch++) tex[ch * T + j] = f->light[k * 3 + ch] * base;
                }
                for (int ch = 0; ch < 3; ch++) haar_cube_forward(tex + ch * T, CUBE_RES, w + ch * T, tmp);
                transport_store(&pd.transfers[0].transport, (int)pd.transfers[0].transport.vec_first[v] + k, w, w + T, w + 2 * T, scratch);
            }
        }
        CHECK(transport_finish(&pd.transfers[0].transport, &err) == 0, "finish: %s", err.msg);
        relight_ctx *rc = relight_create(&pd, 2, &err);
        CHECK(rc != NULL, "create: %s", err.msg);
        if (!rc) return;
        /* constant environment */
        float *cube = malloc(sizeof(float) * 3 * T);
        for (int j = 0; j < T; j++) for (int ch = 0; ch < 3; ch++) cube[3 * j + ch] = c[ch];
        float (*L)[4] = transfer_light_alloc();
        light_from_cube(cube, NULL, L, NULL);
        relight_set_light(rc, (const float (*)[4])L);
        /* tolerance: float rounding for 32 bits; for 8 bits the quantization bound
         * sum over the 6 lit scaling coefficients |L_f| * step/2 per vector */
        const float *g = relight_gvec(rc);
        int gbad = 0;
        for (int v = 0; v < 6; v++) {
            const brdf_factor *f = &pd.factors[vmat[v]];
            for (int k = 0; k < f->K; k++) {
                int i = (int)pd.transfers[0].transport.vec_first[v] + k;
                for (int ch = 0; ch < 3; ch++) {
                    double want = f->light[k * 3 + ch] * c[ch] * S[v];
                    double tol = qbits[qi] == 32 ? 1e-5 * fabs(want) + 1e-7 : 6 * 64 * c[ch] * 0.5 * pd.transfers[0].transport.scale[3 * i + ch] + 1e-6;
                    if (!(fabs(g[3 * i + ch] - want) <= tol)) {
                        gbad++;
                        fprintf(stderr, "  v %d k %d ch %d: g %.8g want %.8g tol %.3g\n", v, k, ch, g[3 * i + ch], want, tol);
                    }
                }
            }
        }
        CHECK(gbad == 0, "q%d: %d light-dependent K-vector values off", qbits[qi], gbad);
        /* Lambert: albedo x radiance (up to the cube quadrature of the cosine, 2e-4), black when occluded */
        float rgb[18], one[3];
        float eye[3] = { 3, 40, 2 };
        relight_view(rc, eye, 0, rgb);
        double rtol = qbits[qi] == 32 ? 3e-4 : 2e-2;
        for (int ch = 0; ch < 3; ch++) {
            CHECK_NEAR(rgb[ch], kd[ch] * c[ch], rtol * kd[ch] * c[ch], "q%d: Lambert vertex ch %d = albedo x L", qbits[qi], ch);
            CHECK(rgb[3 + ch] == 0.f, "q%d: occluded vertex ch %d = %g", qbits[qi], ch, rgb[3 + ch]);
            CHECK_NEAR(rgb[6 + ch], 0.5 * kd[ch] * c[ch], rtol * kd[ch] * c[ch], "q%d: half-occluded ch %d", qbits[qi], ch);
        }
        /* Linear view map: colour = c S (a + b (wo . s)), clamped at 0; kmax = 1 gives c S a. */
        int lbad = 0, clamped = 0, kbad = 0, vbad = 0;
        for (int trial = 0; trial < 40; trial++) {
            int v = 3 + trial % 3;
            float wo[3] = { sinf(0.7f * trial), 1.5f + cosf(1.3f * trial), 0.6f * sinf(2.1f * trial + 1.f) };
            normalize3(wo);
            float s[3];
            frame_s(nrm[v], s);
            float wx = wo[0] * s[0] + wo[1] * s[1] + wo[2] * s[2];
            float wz = wo[0] * nrm[v][0] + wo[1] * nrm[v][1] + wo[2] * nrm[v][2];
            if (fabsf(wx) > 0.85f || wz < 0.05f) continue;   /* keep off the clamped map border and the horizon */
            relight_vertex(rc, v, wo, 0, one);
            for (int ch = 0; ch < 3; ch++) {
                double want = c[ch] * S[v] * (lin[0][ch] + lin[1][ch] * wx);
                if (want < 0) { want = 0; clamped++; }
                double tol = qbits[qi] == 32 ? 1e-4 * c[ch] * S[v] : 2e-2 * c[ch] * S[v];
                if (!(fabs(one[ch] - want) <= tol)) {
                    lbad++;
                    fprintf(stderr, "  v %d ch %d: %.8g want %.8g\n", v, ch, one[ch], want);
                }
            }
            relight_vertex(rc, v, wo, 1, one);
            for (int ch = 0; ch < 3; ch++)
                if (!(fabs(one[ch] - c[ch] * S[v] * lin[0][ch]) <= (qbits[qi] == 32 ? 1e-4 : 2e-2) * c[ch] * S[v])) kbad++;
            /* relight_view with an eye along wo gives the same */
            float e2[3] = { m->pos[3 * v] + 7 * wo[0], m->pos[3 * v + 1] + 7 * wo[1], m->pos[3 * v + 2] + 7 * wo[2] };
            relight_view(rc, e2, 0, rgb);
            relight_vertex(rc, v, wo, 0, one);
            for (int ch = 0; ch < 3; ch++)
                if (fabsf(rgb[3 * v + ch] - one[ch]) > 1e-5f * (fabsf(one[ch]) + 1e-3f)) vbad++;
        }
        CHECK(lbad == 0, "q%d: %d linear-view values off", qbits[qi], lbad);
        CHECK(qi == 1 || clamped > 0, "some cases exercise the negative clamp (%d)", clamped);
        CHECK(kbad == 0, "q%d: %d kmax=1 values off", qbits[qi], kbad);
        CHECK(vbad == 0, "q%d: %d relight_view values differ from relight_vertex", qbits[qi], vbad);
        /* a mismatched mesh is rejected */
        prt_data bad2 = pd;
        bad2.scene.mesh.nverts = 5;
        CHECK(relight_create(&bad2, 1, &err) == NULL && strstr(err.msg, "vertices"), "mismatch: %s", err.msg);
        relight_destroy(rc);
        free(tex); free(w); free(scratch); free(cube); free(L);
        transport_free(&pd.transfers[0].transport);
        for (int k = 0; k < 2; k++) { free(pd.factors[k].light); free(pd.factors[k].view); }
        free(m->pos); free(m->nrm); free(m->mat);
    }
}

static void speed(void) {
    /* Speed (printed): 36K vertices with a 4-term 48x48 factor + 31K Lambertian vertices. */
    {
        int nv4 = 36000, nv1 = 31000, n = nv4 + nv1;
        prt_data pd;
        memset(&pd, 0, sizeof pd);
        prt_mesh *m = &pd.scene.mesh;
        m->nverts = n;
        m->pos = malloc(sizeof(float) * 3 * n);
        m->nrm = malloc(sizeof(float) * 3 * n);
        m->mat = malloc(sizeof(uint16_t) * n);
        uint32_t s = 1;
        int *nv = malloc(sizeof(int) * n);
        for (int v = 0; v < n; v++) {
            float d[3];
            for (int k = 0; k < 3; k++) { s ^= s << 13; s ^= s >> 17; s ^= s << 5; d[k] = (float)(s >> 8) / 16777216.f - 0.5f; }
            normalize3(d);
            for (int k = 0; k < 3; k++) { m->pos[3 * v + k] = d[k]; m->nrm[3 * v + k] = d[k]; }
            m->mat[v] = v < nv4 ? 1 : 0;
            nv[v] = v < nv4 ? 4 : 1;
        }
        pd.scene.nmaterials = 2;
        make_factor(&pd.factors[0], 1, lam, true);
        const float g4[4][3] = { { 1, 1, 1 }, { .5f, .5f, .5f }, { .2f, .2f, .2f }, { .1f, .1f, .1f } };
        brdf_factor *f = &pd.factors[1];
        memset(f, 0, sizeof *f);
        f->K = 4; f->res = 48; f->param = BRDF_PARAM_GRID;
        f->light = malloc(sizeof(float) * 48 * 48 * 12);
        f->view = malloc(sizeof(float) * 48 * 48 * 12);
        for (int k = 0; k < 48 * 48 * 12; k++) { f->light[k] = g4[(k / 3) % 4][k % 3]; f->view[k] = (float)(k % 97) / 97.f - 0.3f; }
        prt_error err;
        prt_data_add_transfer(&pd, transfer_find("haar"), NULL, 3);
        transport_init(&pd.transfers[0].transport, n, nv, 128, 8, &err);
        transport_finish(&pd.transfers[0].transport, &err);
        relight_ctx *rc = relight_create(&pd, 2, &err);
        CHECK(rc != NULL, "create: %s", err.msg);
        float *rgb = malloc(sizeof(float) * 3 * n);
        float eye[3] = { 0.3f, 2.f, 4.f };
        double best = 1e9, cpu = 1e9;
        for (int r = 0; r < 20; r++) {
            struct timespec a, b;
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
            double t0 = prt_now();
            relight_view(rc, eye, 0, rgb);
            best = fmin(best, prt_now() - t0);
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
            if (r < 5) {   /* single-thread CPU cost of the kernel */
                clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
                relight_ctx *one = relight_create(&pd, 1, &err);
                clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
                relight_view(one, eye, 0, rgb);
                clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
                cpu = fmin(cpu, (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec));
                relight_destroy(one);
            }
        }
        printf("relight_view: %d vertices (%d with K=4): %.2f ms wall on 2 threads, %.2f ms CPU on 1 thread\n", n, nv4, 1e3 * best, 1e3 * cpu);
        relight_destroy(rc);
        free(rgb); free(nv);
        transport_free(&pd.transfers[0].transport);
        for (int k = 0; k < 2; k++) { free(pd.factors[k].light); free(pd.factors[k].view); }
        free(m->pos); free(m->nrm); free(m->mat);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(cube_quadrature);
    CHECK_CASE(lambert_and_linear_views);
    CHECK_CASE(speed);
    return check_summary();
}
