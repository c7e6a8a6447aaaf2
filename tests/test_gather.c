/* test_gather.c - one interreflection pass (gather.h) against independent truths.
 *
 * Scenes: two parallel 2 x 2 planes one unit apart facing each other, 7 x 7
 * vertices each. The lower plane is Lambertian with a coloured albedo; the
 * upper one is either Lambertian ("L" scene, for the analytic check) or a glossy
 * Phong with K = 4 terms ("G" scene).
 *
 * (a) Analytic: with previous vectors that make every vertex radiate 1 (T(y) =
 *     e_0 / h_y), a pass gives h_x T'(x)_0 = albedo_x * F(x -> other plane), F the
 *     closed-form view factor of a differential area to a parallel rectangle.
 * (b) Brute force at the same gather resolution: an independent per-texel loop
 *     (one vis_closest ray per texel, full factor lookups, no neighbour
 *     combining, double accumulation) of the light projections T'(x).L for a
 *     constant light and five Gaussian random light vectors, from uncompressed
 *     direct vectors (N = 24,576, float). Random projections detect any mismatch
 *     in any coefficient. The same at twice the resolution measures the 32-res
 *     cubature error.
 * (c) The compressed path (N = 128, 8-bit in and out) against the exact pass:
 *     full-vector relative L2 error and constant-light error, next to the floor
 *     set by storing the exact result at N = 128.
 * Also gather_sum, gather_energy, determinism across thread counts, progress,
 * cancellation and bad input. */
#include "gather_fixture.h"
#include <float.h>

#define NL 6   /* light vectors for projections */

static int build_planes(prt_data *d, vis_scene **vs, const char *upper_spec) {
    prt_error err;
    prt_mesh lo, hi;
    memset(d, 0, sizeof *d);
    if (mesh_make_plane(&lo, -1, 1, -1, 1, 0, 7, 7, &err) || mesh_make_plane(&hi, -1, 1, -1, 1, 1, 7, 7, &err)) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    fx_flip(&hi);
    int first_hi = lo.nverts;
    if (mesh_append(&lo, &hi, &err)) return -1;
    mesh_free(&hi);
    if (scene_from_mesh(&lo, "lambert:kd=0.8,0.5,0.2", &d->scene, &err)) { fprintf(stderr, "%s\n", err.msg); return -1; }
    int m1 = scene_material(&d->scene, upper_spec, &err);
    if (m1 < 0) { fprintf(stderr, "%s\n", err.msg); return -1; }
    for (int v = first_hi; v < d->scene.mesh.nverts; v++) d->scene.mesh.mat[v] = (uint16_t)m1;
    if (fx_factor_all(d, 4)) return -1;
    *vs = vis_create(&d->scene.mesh, &err);
    if (!*vs) { fprintf(stderr, "%s\n", err.msg); return -1; }
    return 0;
}

/* View factor of a differential area (normal toward the rectangle) to the corner-anchored rectangle
 * [0,a] x [0,b] at distance c; odd in a and b, so sums of four give any parallel rectangle. */
static double vf_corner(double a, double b, double c) {
    double A = a / c, B = b / c, sa = sqrt(1 + A * A), sb = sqrt(1 + B * B);
    return (A / sa * atan(B / sa) + B / sb * atan(A / sb)) / (2 * M_PI);
}

static double vf_rect(double px, double pz, double x0, double x1, double z0, double z1, double c) {
    return vf_corner(x1 - px, z1 - pz, c) - vf_corner(x0 - px, z1 - pz, c) - vf_corner(x1 - px, z0 - pz, c) +
           vf_corner(x0 - px, z0 - pz, c);
}

/* Does the ray from p along d hit the other plane's square [-1,1]^2 at height hp? */
static bool hits_square(const float p[3], const float d[3], float hp) {
    if (fabsf(d[1]) < 1e-12f) return false;
    float t = (hp - p[1]) / d[1];
    if (t <= 0) return false;
    float x = p[0] + t * d[0], z = p[2] + t * d[2];
    return x >= -1 && x <= 1 && z >= -1 && z <= 1;
}

/* Bound on |midpoint cube cubature - exact| of (1/pi) int_square cos dw at vertex p (normal n, square at
 * height hp): a texel whose centre and four corners agree and that holds no corner of the square can be
 * off by at most the spread of cos over it; any other texel by at most its largest cos. */
static double cubature_bound(const float p[3], const float n[3], float hp, int res) {
    int nt = 6 * res * res;
    uint8_t *mixed = calloc((size_t)nt, 1);
    for (int cx = -1; cx <= 1; cx += 2)
        for (int cz = -1; cz <= 1; cz += 2) {
            float d[3] = { cx - p[0], hp - p[1], cz - p[2] };
            v3_normalize(d);
            mixed[cube_texel_index(res, d)] = 1;
        }
    double b = 0;
    for (int i = 0; i < nt; i++) {
        int f = i / (res * res), ij = i % (res * res), ti = ij % res, tj = ij / res;
        const float px[5] = { ti + 0.5f, ti, ti + 1, ti, ti + 1 }, py[5] = { tj + 0.5f, tj, tj, tj + 1, tj + 1 };
        int in = 0;
        double cmin = 2, cmax = 0;
        for (int k = 0; k < 5; k++) {
            float d[3];
            cube_dir(res, f, px[k], py[k], d);
            double c = v3_dot(d, n);
            if (c < 0) c = 0;
            if (c < cmin) cmin = c;
            if (c > cmax) cmax = c;
            in += hits_square(p, d, hp);
        }
        double dw = cube_texel_solid_angle(res, ti, tj);
        if (in == 0 && !mixed[i]) continue;
        b += (in == 5 && !mixed[i] ? cmax - cmin : cmax) * dw;
    }
    free(mixed);
    return b / M_PI;
}

static void analytic(void) {
    prt_data d;
    vis_scene *vs;
    if (build_planes(&d, &vs, "lambert:kd=0.6")) { CHECK(0, "scene"); return; }
    const prt_mesh *m = &d.scene.mesh;
    prt_transport layout;
    CHECK(fx_direct(&d, vs, 16, 8, &layout) == 0, "direct");
    float *val = malloc(sizeof(float) * 3 * layout.nvecs);
    const float up[3] = { 0, 0, 1 };
    for (int v = 0; v < m->nverts; v++) {
        float h[3 * BRDF_MAX_SIGMA];
        brdf_factor_view(&d.factors[m->mat[v]], up, h);
        for (int ch = 0; ch < 3; ch++) val[3 * layout.vec_first[v] + ch] = 1.f / h[ch];
    }
    prt_transport probe;
    CHECK(fx_probe_set(&layout, NULL, val, 16, &probe) == 0, "probe set");
    const int res[2] = { 32, 64 };
    const double tol[2] = { 0.015, 0.0075 };   /* O(1/res) silhouette aliasing */
    for (int ri = 0; ri < 2; ri++) {
        prt_transport next;
        prt_error err;
        gather_desc gd = { .res = res[ri] };
        CHECK(gather_pass(&d, vs, &probe, &gd, &next, &err) == 0, "%s", err.msg);
        double worst = 0, sum = 0, bsum = 0;
        int cnt = 0;
        bool within = true;
        for (int v = 0; v < m->nverts; v++) {
            const float *p = m->pos + 3 * v, *nv = m->nrm + 3 * v;
            double F = vf_rect(p[0], p[2], -1, 1, -1, 1, 1.0);
            double bound = cubature_bound(p, nv, nv[1] > 0 ? 1.f : 0.f, res[ri]);
            const brdf_params *bp = &d.scene.materials[m->mat[v]];
            float h[3 * BRDF_MAX_SIGMA];
            brdf_factor_view(&d.factors[m->mat[v]], up, h);
            float r[CUBE_TEXELS], g[CUBE_TEXELS], b[CUBE_TEXELS];
            transport_decode(&next, (int)next.vec_first[v], r, g, b);
            const float got[3] = { h[0] * r[0], h[1] * g[0], h[2] * b[0] };
            for (int ch = 0; ch < 3; ch++) {
                double want = bp->kd[ch] * F, e = fabs(got[ch] - want);
                if (e > worst) worst = e;
                within &= e <= bp->kd[ch] * bound + 1e-6;
                sum += e;
                bsum += bp->kd[ch] * bound;
                cnt++;
            }
        }
        printf("analytic view factor, gather res %d: |error| max %.5f mean %.5f; cubature bound mean %.5f "
               "(albedo x F up to %.3f)\n", res[ri], worst, sum / cnt, bsum / cnt, 0.8 * vf_rect(0, 0, -1, 1, -1, 1, 1));
        CHECK(within, "res %d: radiance of a pass = albedo x analytic view factor within the cubature bound", res[ri]);
        CHECK_LE(worst, tol[ri], "res %d: radiance of a pass = albedo x analytic view factor", res[ri]);
        transport_free(&next);
    }
    free(val);
    transport_free(&probe);
    transport_free(&layout);
    vis_destroy(vs);
    fx_free(&d);
}

/* ---- brute force ------------------------------------------------------- */

typedef struct brute_ctx {
    const prt_data *d;
    const vis_scene *vs;
    const prt_transport *lay;
    int res;
    const double *s;   /* [nvecs][NL][3] projections of the previous vectors */
    double *out;       /* [nvecs][NL][3] */
} brute_ctx;

static void brute_range(void *ctx, int begin, int end, int thread) {
    (void)thread;
    brute_ctx *c = ctx;
    const prt_mesh *m = &c->d->scene.mesh;
    float eps = vis_eps(c->vs);
    int ntex = 6 * c->res * c->res;
    for (int x = begin; x < end; x++) {
        const float *p = m->pos + 3 * x, *n = m->nrm + 3 * x;
        float s[3], t[3], org[3];
        brdf_frame(n, s, t);
        for (int i = 0; i < 3; i++) org[i] = p[i] + eps * n[i];
        const brdf_factor *fx = &c->d->factors[m->mat[x]];
        int kx = (int)(c->lay->vec_first[x + 1] - c->lay->vec_first[x]);
        double *o = c->out + (size_t)c->lay->vec_first[x] * NL * 3;
        for (int i = 0; i < ntex; i++) {
            float w[3];
            cube_texel_dir(c->res, i, w);
            double cw = (double)n[0] * w[0] + (double)n[1] * w[1] + (double)n[2] * w[2];
            if (cw <= 0) continue;
            int ij = i % (c->res * c->res);
            double dw = cube_texel_solid_angle(c->res, ij % c->res, ij / c->res);
            vis_hit hit;
            if (!vis_closest(c->vs, org, w, eps, INFINITY, &hit)) continue;
            float wl[3], g[3 * BRDF_MAX_SIGMA];
            brdf_to_local(s, t, n, w, wl);
            brdf_factor_light(fx, wl, g);
            double beta[3] = { 1.0 - hit.u - hit.v, hit.u, hit.v };
            for (int corner = 0; corner < 3; corner++) {
                int y = (int)m->tris[3 * hit.tri + corner];
                const float *ny = m->nrm + 3 * y;
                float sy[3], ty[3], mw[3] = { -w[0], -w[1], -w[2] }, ml[3], h[3 * BRDF_MAX_SIGMA];
                brdf_frame(ny, sy, ty);
                brdf_to_local(sy, ty, ny, mw, ml);
                if (ml[2] <= 0) continue;
                brdf_factor_view(&c->d->factors[m->mat[y]], ml, h);
                int ky = (int)(c->lay->vec_first[y + 1] - c->lay->vec_first[y]);
                for (int l = 0; l < ky; l++) {
                    const double *sy_l = c->s + (size_t)(c->lay->vec_first[y] + l) * NL * 3;
                    for (int k = 0; k < kx; k++)
                        for (int li = 0; li < NL; li++)
                            for (int ch = 0; ch < 3; ch++)
                                o[(k * NL + li) * 3 + ch] +=
                                    beta[corner] * cw * dw * h[3 * l + ch] * g[3 * k + ch] * sy_l[li * 3 + ch];
                }
            }
        }
    }
}

/* Projections of every vector of t on the NL lights: out[(i*NL + l)*3 + ch]. */
static void project(const prt_transport *t, const float *L, double *out) {
    float *buf = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    for (int i = 0; i < t->nvecs; i++)
        for (int l = 0; l < NL; l++) fx_dot(t, i, L + (size_t)l * 3 * CUBE_TEXELS, out + ((size_t)i * NL + l) * 3, buf);
    free(buf);
}

/* Relative L2 difference of two projection sets, for light l. */
static double proj_rel(const double *a, const double *b, int nvecs, int l) {
    double num = 0, den = 0;
    for (int i = 0; i < nvecs; i++)
        for (int ch = 0; ch < 3; ch++) {
            double x = a[((size_t)i * NL + l) * 3 + ch], y = b[((size_t)i * NL + l) * 3 + ch];
            num += (x - y) * (x - y);
            den += y * y;
        }
    return sqrt(num / den);
}

/* Full-vector relative L2 error of a against b over all vectors. */
static double vec_rel(const prt_transport *a, const prt_transport *b) {
    float *x = malloc(sizeof(float) * 3 * CUBE_TEXELS), *y = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    double num = 0, den = 0;
    for (int i = 0; i < a->nvecs; i++) {
        transport_decode(a, i, x, x + CUBE_TEXELS, x + 2 * CUBE_TEXELS);
        transport_decode(b, i, y, y + CUBE_TEXELS, y + 2 * CUBE_TEXELS);
        for (int j = 0; j < 3 * CUBE_TEXELS; j++) {
            num += (double)(x[j] - y[j]) * (x[j] - y[j]);
            den += (double)y[j] * y[j];
        }
    }
    free(x); free(y);
    return sqrt(num / den);
}

typedef struct prog_state { int calls, stop_after; double last; bool monotone; char stage[32]; } prog_state;

static bool prog_fn(void *user, const char *stage, double f) {
    prog_state *p = user;
    p->calls++;
    if (f < p->last || f < 0 || f > 1) p->monotone = false;
    p->last = f;
    snprintf(p->stage, sizeof p->stage, "%s", stage);
    return p->stop_after <= 0 || p->calls < p->stop_after;
}

static bool same_set(const prt_transport *a, const prt_transport *b) {
    if (a->nvecs != b->nvecs || transport_ncoefs(a) != transport_ncoefs(b)) return false;
    float *x = malloc(sizeof(float) * 3 * CUBE_TEXELS), *y = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    bool same = true;
    for (int i = 0; same && i < a->nvecs; i++) {
        transport_decode(a, i, x, x + CUBE_TEXELS, x + 2 * CUBE_TEXELS);
        transport_decode(b, i, y, y + CUBE_TEXELS, y + 2 * CUBE_TEXELS);
        same = memcmp(x, y, sizeof(float) * 3 * CUBE_TEXELS) == 0;
    }
    free(x); free(y);
    return same;
}

/* The glossy scene (G) of the glossy_* cases and what several of them share: the direct
 * sets (ex0: exact, N = 24,576 float; q0: N = 128, 8-bit), NL lights L with ex0's
 * projections s0, and the passes at res 32 (ex1, exact, with projections pg; q1,
 * compressed). Built with their checks by the first case that needs them (glossy_setup),
 * so a filter can run any case alone; main frees them (glossy_free). */
static bool glossy_built, glossy_ok;
static prt_data d;
static vis_scene *vs;
static prt_transport ex0, q0, ex1, q1;
static int nvecs;
static float *L;
static double *s0, *pg;
static double t_exact, t_q;
static const gather_desc gd = { .res = 32 };

/* Builds the shared glossy fixture once; returns false (after a failed check) when the scene
 * could not be built. */
static bool glossy_setup(void) {
    if (glossy_built) return glossy_ok;
    glossy_built = true;
    if (build_planes(&d, &vs, "phong:kd=0.2,0.3,0.4;ks=0.5;n=20")) { CHECK(0, "scene"); return false; }
    CHECK(d.factors[1].K == 4, "glossy plane has 4 terms (got %d)", d.factors[1].K);
    prt_error err;
    CHECK(fx_direct(&d, vs, CUBE_TEXELS, 32, &ex0) == 0, "exact direct");
    CHECK(fx_direct(&d, vs, 128, 8, &q0) == 0, "8-bit direct");
    nvecs = ex0.nvecs;

    /* Lights: constant, then Gaussian random wavelet vectors (deterministic LCG + Box-Muller). */
    L = malloc(sizeof(float) * NL * 3 * CUBE_TEXELS);
    fx_const_light(1.f, L);
    uint64_t st = 12345;
    for (size_t j = 3 * CUBE_TEXELS; j < (size_t)NL * 3 * CUBE_TEXELS; j++) {
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        double u1 = ((st >> 11) + 0.5) / 9007199254740992.0;
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        double u2 = ((st >> 11) + 0.5) / 9007199254740992.0;
        L[j] = (float)(sqrt(-2 * log(u1)) * cos(2 * M_PI * u2));
    }
    s0 = calloc((size_t)nvecs * NL * 3, sizeof(double));
    pg = calloc((size_t)nvecs * NL * 3, sizeof(double));
    project(&ex0, L, s0);
    double t0 = prt_now();
    CHECK(gather_pass(&d, vs, &ex0, &gd, &ex1, &err) == 0, "%s", err.msg);
    t_exact = prt_now() - t0;
    project(&ex1, L, pg);
    t0 = prt_now();
    CHECK(gather_pass(&d, vs, &q0, &gd, &q1, &err) == 0, "%s", err.msg);
    t_q = prt_now() - t0;
    glossy_ok = true;
    return true;
}

/* Frees the glossy fixture if it was built. */
static void glossy_free(void) {
    if (!glossy_built) return;
    free(L); free(s0); free(pg);
    transport_free(&ex0); transport_free(&ex1); transport_free(&q0); transport_free(&q1);
    if (vs) vis_destroy(vs);
    fx_free(&d);
    glossy_built = glossy_ok = false;
}

/* (b) exact pass vs brute force at the same resolution; both against brute force at res 64. */
static void glossy_exact_vs_brute_force(void) {
    if (!glossy_setup()) return;
    prt_error err;
    double *bf = calloc((size_t)nvecs * NL * 3, sizeof(double));
    brute_ctx bc = { &d, vs, &ex0, 32, s0, bf };
    prt_parallel_for(d.scene.mesh.nverts, 2, 0, brute_range, &bc);
    for (int l = 0; l < NL; l++) {
        double e = proj_rel(pg, bf, nvecs, l);
        printf("exact pass vs brute force (res 32), light %d: relative L2 %.2e\n", l, e);
        CHECK_LE(e, 2e-5, "light %d", l);
    }
    /* Brute force at res 64 against passes at 16 and 32: the gather cube's cubature error. It is
     * silhouette aliasing of each neighbour triangle, O(1/res) in size but not monotone in res for
     * this axis-aligned scene (texel edges fall on or off the square's edges by turns; the analytic
     * test above bounds it per vertex); a few percent per vertex at res 32. */
    memset(bf, 0, sizeof(double) * nvecs * NL * 3);
    bc.res = 64;
    prt_parallel_for(d.scene.mesh.nverts, 2, 0, brute_range, &bc);
    double ec[2] = { 0, 0 }, er[2] = { 0, 0 };
    for (int ri = 0; ri < 2; ri++) {
        prt_transport t;
        gather_desc gr = { .res = ri == 0 ? 16 : 32 };
        CHECK(gather_pass(&d, vs, &ex0, &gr, &t, &err) == 0, "%s", err.msg);
        double *pt = calloc((size_t)nvecs * NL * 3, sizeof(double));
        project(&t, L, pt);
        ec[ri] = proj_rel(pt, bf, nvecs, 0);
        for (int l = 1; l < NL; l++) {
            double e = proj_rel(pt, bf, nvecs, l);
            if (e > er[ri]) er[ri] = e;
        }
        printf("exact pass at res %d vs brute force at res 64: constant light %.4f, random lights up to %.4f\n",
               gr.res, ec[ri], er[ri]);
        free(pt);
        transport_free(&t);
    }
    for (int ri = 0; ri < 2; ri++) {
        CHECK_LE(ec[ri], 0.05, "res %d: constant-light projections within 5%% (RMS) of res 64", ri ? 32 : 16);
        CHECK_LE(er[ri], 0.10, "res %d: random-light projections within 10%% (RMS) of res 64", ri ? 32 : 16);
    }
    free(bf);
}

static void glossy_8bit_kernels(void) {
    if (!glossy_setup()) return;
    prt_error err;
    /* The 8-bit decode kernels (SIMD for K = 1 and 4) against the generic float path validated
     * above: an 8-bit set keeping every coefficient, and the same values stored as floats. Both
     * passes see identical inputs; the 8-bit output differs only by its rounding, at most half a
     * step per coefficient and channel. */
    {
        prt_transport a8, a32, o8, o32;
        CHECK(fx_direct(&d, vs, CUBE_TEXELS, 8, &a8) == 0, "8-bit full direct");
        int *cnt = malloc(sizeof(int) * a8.nverts);
        for (int v = 0; v < a8.nverts; v++) cnt[v] = (int)(a8.vec_first[v + 1] - a8.vec_first[v]);
        CHECK(transport_init(&a32, a8.nverts, cnt, CUBE_TEXELS, 32, &err) == 0, "init");
        free(cnt);
        float *x = malloc(sizeof(float) * 3 * CUBE_TEXELS), *y = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        void *scr = malloc(transport_scratch_size());
        for (int i = 0; i < a8.nvecs; i++) {
            transport_decode(&a8, i, x, x + CUBE_TEXELS, x + 2 * CUBE_TEXELS);
            transport_store(&a32, i, x, x + CUBE_TEXELS, x + 2 * CUBE_TEXELS, scr);
        }
        CHECK(transport_finish(&a32, &err) == 0, "finish");
        transport_free(&a8);   /* a8 is rebuilt identically below, to keep memory low */
        CHECK(gather_pass(&d, vs, &a32, &gd, &o32, &err) == 0, "%s", err.msg);
        transport_free(&a32);
        CHECK(fx_direct(&d, vs, CUBE_TEXELS, 8, &a8) == 0, "8-bit full direct");
        CHECK(gather_pass(&d, vs, &a8, &gd, &o8, &err) == 0, "%s", err.msg);
        double worst = 0;   /* in units of the 8-bit output's step */
        for (int i = 0; i < o8.nvecs; i++) {
            transport_decode(&o8, i, x, x + CUBE_TEXELS, x + 2 * CUBE_TEXELS);
            transport_decode(&o32, i, y, y + CUBE_TEXELS, y + 2 * CUBE_TEXELS);
            for (int ch = 0; ch < 3; ch++) {
                double step = o8.scale[3 * i + ch];
                for (int j = 0; j < CUBE_TEXELS; j++) {
                    double e = fabs((double)x[ch * CUBE_TEXELS + j] - y[ch * CUBE_TEXELS + j]);
                    double u = step > 0 ? e / step : (e > 0 ? 1e9 : 0);
                    if (u > worst) worst = u;
                }
            }
        }
        printf("8-bit kernels vs float path: largest difference %.4f of the output step\n", worst);
        CHECK_LE(worst, 0.5 + 1e-3, "8-bit input decoded by the SIMD kernels = float path, up to output rounding");
        free(x); free(y); free(scr);
        transport_free(&a8); transport_free(&o8); transport_free(&o32);
    }
}

/* (c) compressed path. */
static void glossy_compressed(void) {
    if (!glossy_setup()) return;
    prt_error err;
    prt_transport floor1;
    /* The floor: the exact pass truncated to its best N = 128 terms (float, no quantization). */
    {
        int *cnt = malloc(sizeof(int) * ex1.nverts);
        for (int v = 0; v < ex1.nverts; v++) cnt[v] = (int)(ex1.vec_first[v + 1] - ex1.vec_first[v]);
        CHECK(transport_init(&floor1, ex1.nverts, cnt, 128, 32, &err) == 0, "init");
        free(cnt);
        float *buf = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        void *scr = malloc(transport_scratch_size());
        for (int i = 0; i < ex1.nvecs; i++) {
            transport_decode(&ex1, i, buf, buf + CUBE_TEXELS, buf + 2 * CUBE_TEXELS);
            transport_store(&floor1, i, buf, buf + CUBE_TEXELS, buf + 2 * CUBE_TEXELS, scr);
        }
        free(buf); free(scr);
        CHECK(transport_finish(&floor1, &err) == 0, "finish");
    }
    double e_q = vec_rel(&q1, &ex1), e_floor = vec_rel(&floor1, &ex1), e_in = vec_rel(&q0, &ex0);
    double *pq = calloc((size_t)nvecs * NL * 3, sizeof(double));
    project(&q1, L, pq);
    double e_qc = proj_rel(pq, pg, nvecs, 0);
    printf("compressed (N=128, 8-bit): direct input error %.4f; pass error %.4f vs floor %.4f (best 128-term "
           "approximation of the exact pass); constant-light error %.4f\n", e_in, e_q, e_floor, e_qc);
    printf("times: exact pass %.3f s, compressed pass %.3f s (%d vertices)\n", t_exact, t_q, d.scene.mesh.nverts);
    CHECK_LE(e_floor, e_q, "the pass cannot beat the best N-term approximation");
    CHECK_LE(e_q, e_floor + e_in + 0.02, "pass error <= output truncation + propagated input error");
    CHECK_LE(e_qc, 0.02, "constant-light projection within 2%%");
    free(pq);
    transport_free(&floor1);
}

static void glossy_determinism(void) {
    if (!glossy_setup()) return;
    prt_error err;
    /* Determinism: one thread and two threads give identical sets (exact by construction: each
     * vertex's gather is one thread's loop, the same code on the same machine, whatever the count). */
    prt_transport q1b;
    gather_desc g1 = { .res = 32, .nthreads = 1 };
    CHECK(gather_pass(&d, vs, &q0, &g1, &q1b, &err) == 0, "%s", err.msg);
    CHECK(same_set(&q1, &q1b), "1 thread == 2 threads");
    transport_free(&q1b);
}

static void glossy_sum(void) {
    if (!glossy_setup()) return;
    prt_error err;
    /* gather_sum: exact sets add exactly; quantized sets equal a dense add then store. */
    prt_transport sum;
    CHECK(gather_sum(&ex0, &ex1, 0, &sum, &err) == 0, "%s", err.msg);
    {
        float *a = malloc(sizeof(float) * 3 * CUBE_TEXELS), *b = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        float *c = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        double worst = 0;   /* in units of one float rounding of a + b (FLT_EPSILON / 2 of it) */
        for (int i = 0; i < nvecs; i++) {
            transport_decode(&ex0, i, a, a + CUBE_TEXELS, a + 2 * CUBE_TEXELS);
            transport_decode(&ex1, i, b, b + CUBE_TEXELS, b + 2 * CUBE_TEXELS);
            transport_decode(&sum, i, c, c + CUBE_TEXELS, c + 2 * CUBE_TEXELS);
            for (int j = 0; j < 3 * CUBE_TEXELS; j++) {
                double s = (double)a[j] + b[j], e = fabs((double)c[j] - s);
                if (e > 0 && e / (0.5 * FLT_EPSILON * fabs(s)) > worst) worst = e / (0.5 * FLT_EPSILON * fabs(s));
            }
        }
        CHECK_LE(worst, 1, "exact sum: float a + b, one rounding");
        transport_free(&sum);
        CHECK(gather_sum(&q0, &q1, 1, &sum, &err) == 0, "%s", err.msg);
        prt_transport ref;
        int *cnt = malloc(sizeof(int) * q0.nverts);
        for (int v = 0; v < q0.nverts; v++) cnt[v] = (int)(q0.vec_first[v + 1] - q0.vec_first[v]);
        CHECK(transport_init(&ref, q0.nverts, cnt, 128, 8, &err) == 0, "init");
        free(cnt);
        void *scr = malloc(transport_scratch_size());
        for (int i = 0; i < nvecs; i++) {
            transport_decode(&q0, i, a, a + CUBE_TEXELS, a + 2 * CUBE_TEXELS);
            transport_decode(&q1, i, b, b + CUBE_TEXELS, b + 2 * CUBE_TEXELS);
            for (int j = 0; j < 3 * CUBE_TEXELS; j++) a[j] += b[j];
            transport_store(&ref, i, a, a + CUBE_TEXELS, a + 2 * CUBE_TEXELS, scr);
        }
        CHECK(transport_finish(&ref, &err) == 0, "finish");
        /* exact by construction: gather_sum is this decode (q x step in float), float add and
         * transport_store, the same operations in the same order */
        CHECK(same_set(&sum, &ref), "8-bit sum == dense add + store");
        CHECK(sum.N == 128 && sum.qbits == 8 && sum.nvecs == nvecs, "sum keeps N, qbits and layout");
        free(a); free(b); free(c); free(scr);
        transport_free(&ref);
        transport_free(&sum);
    }
}

static void glossy_energy(void) {
    if (!glossy_setup()) return;
    /* gather_energy against a dense decode. gather_energy sums q^2 s^2 in double from the
     * integer codes; the decode rounds each coefficient q s to float once (relative error
     * <= FLT_EPSILON / 2), so each squared term is off by <= (FLT_EPSILON + FLT_EPSILON^2 / 4)
     * of itself, and the two double sums of n terms add <= n DBL_EPSILON of the total each.
     * Which codes q1 holds depends on the CPU (Embree, libm, OpenBLAS), so the tolerance is
     * that bound, not the few ulps one machine happens to see. */
    {
        float *a = malloc(sizeof(float) * 3 * CUBE_TEXELS);
        double e = 0;
        for (int i = 0; i < q1.nvecs; i++) {
            transport_decode(&q1, i, a, a + CUBE_TEXELS, a + 2 * CUBE_TEXELS);
            for (int j = 0; j < 3 * CUBE_TEXELS; j++) e += (double)a[j] * a[j];
        }
        double n = 3.0 * CUBE_TEXELS * q1.nvecs;
        double tol = (FLT_EPSILON + FLT_EPSILON * FLT_EPSILON / 4 + 2 * n * DBL_EPSILON) * e;
        CHECK_NEAR(gather_energy(&q1), e, tol, "energy of an 8-bit set");
        free(a);
    }
}

static void glossy_progress_and_cancel(void) {
    if (!glossy_setup()) return;
    prt_error err;
    /* Progress and cancellation. */
    prog_state ps = { .monotone = true, .last = -1 };
    gather_desc gp = { .res = 16, .progress = prog_fn, .progress_user = &ps, .stage = "bounce 1" };
    prt_transport tmp;
    CHECK(gather_pass(&d, vs, &q0, &gp, &tmp, &err) == 0, "%s", err.msg);
    CHECK(ps.calls > 0 && ps.monotone && fabs(ps.last - 1.0) < 1e-12, "progress reaches 1 monotonically");
    CHECK(strcmp(ps.stage, "bounce 1") == 0, "stage name passed through");
    transport_free(&tmp);
    prog_state pc = { .monotone = true, .last = -1, .stop_after = 1 };
    gp.progress_user = &pc;
    int rc = gather_pass(&d, vs, &q0, &gp, &tmp, &err);
    CHECK(rc == -1 && strcmp(err.msg, "cancelled") == 0, "cancel gives -1 \"cancelled\" (got %d, %s)", rc, err.msg);
    CHECK(tmp.nvecs == 0 && tmp.coef_first == NULL, "cancelled output is empty");
}

static void glossy_bad_input(void) {
    if (!glossy_setup()) return;
    prt_error err;
    prt_transport tmp;
    int rc;
    /* Bad input. */
    prt_transport half;
    {
        int cnt[3] = { 1, 1, 1 };
        CHECK(transport_init(&half, 3, cnt, 8, 8, &err) == 0, "init");
        rc = gather_pass(&d, vs, &half, &gd, &tmp, &err);
        CHECK(rc == -1 && strstr(err.msg, "not finished"), "unfinished set rejected: %s", err.msg);
        CHECK(transport_finish(&half, &err) == 0, "finish");
        rc = gather_pass(&d, vs, &half, &gd, &tmp, &err);
        CHECK(rc == -1 && strstr(err.msg, "vertices"), "vertex count mismatch rejected: %s", err.msg);
        rc = gather_sum(&q0, &half, 0, &tmp, &err);
        CHECK(rc == -1 && strstr(err.msg, "layout"), "sum of different layouts rejected: %s", err.msg);
        gather_desc gbig = { .res = 100000 };
        rc = gather_pass(&d, vs, &q0, &gbig, &tmp, &err);
        CHECK(rc == -1 && strstr(err.msg, "resolution"), "absurd resolution rejected: %s", err.msg);
        transport_free(&half);
    }
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(analytic);
    CHECK_CASE(glossy_exact_vs_brute_force);
    CHECK_CASE(glossy_8bit_kernels);
    CHECK_CASE(glossy_compressed);
    CHECK_CASE(glossy_determinism);
    CHECK_CASE(glossy_sum);
    CHECK_CASE(glossy_energy);
    CHECK_CASE(glossy_progress_and_cancel);
    CHECK_CASE(glossy_bad_input);
    glossy_free();
    return check_summary();
}
