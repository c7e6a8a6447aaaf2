/* furnace.c - physical sanity of the interreflection passes (gather.h):
 * the white furnace and the energy decay of a grey bowl.
 *
 * Scene: a hemispherical bowl (the lower half of a unit sphere, 16 rings x 32
 * segments, normals facing the inside), Lambertian, under a constant environment
 * L = 1. The sphere makes it analytic: from any point of a sphere's inside, the
 * view factor to a patch dA' of the same sphere is dA' / (4 pi R^2), because the
 * two cosines equal the chord over 2R. So every point of the bowl sees the bowl
 * with view factor 1/2 and the opening with 1/2:
 *   V_x = 1/2 (direct, unoccluded cosine-weighted fraction),
 *   R_x = albedo / 2 (row sums of the gather operator A in radiance terms),
 *   u_B = sum_{i<=B} V (albedo/2)^i  ->  for albedo 1: u_B = 1 - 2^-(B+1) at every vertex.
 * The tessellation (chords inside the sphere) and the cubatures (64-res
 * visibility, 32-res gather cube) move these by about a percent (measured here).
 *
 * (1) White furnace, albedo 1: u_B = V + A u_{B-1}, u_0 = V. Besides the
 * analytic values, bounds that hold for the discrete operator, with V and the
 * row sums R measured (R from a pass over one-hot vectors, which yields A itself):
 *   V_min sum_{i<=B} R_min^i - Q_B  <=  u_B  <=  V_max sum_{i<=B} R_max^i + Q_B
 * (induction on u_B = V + A u_{B-1} with A >= 0; truncation can only lower u,
 * and the lower bound assumes the face scaling coefficients are kept, true here
 * where they are the largest),
 *   monotone: every pass adds radiance >= 0 exactly (A >= 0; scaling coefficients stay >= 0 through
 *             symmetric rounding), so u_B is non-decreasing in B with no tolerance.
 * Q_B bounds 8-bit quantization: under a constant light only the six face scaling
 * coefficients (wavelet value 64 L) matter, each off by at most step/2, so a stored
 * vector's radiance is off by at most h * 6 * 64 * step / 2; pass i's error reaches
 * u_B through at most B - i + 1 applications of A (row sums below 1).
 *
 * (2) Energy, albedo 0.5. A pass maps T' = A T per channel, so
 *   E' = ||A T||^2 <= ||A||_2^2 E <= R_max C_max E       (Schur test)
 * with R_max, C_max the largest row and column sums of A. R_x = albedo x (hit
 * fraction) < albedo because every vertex sees the opening (escaping rays; here
 * the hit fraction is 1/2), and C_y = albedo A_y n / (4 pi R^2) with A_y the area
 * a vertex stands for, about albedo/2 x (largest / mean vertex area) here, so
 * R_max C_max is well below the albedo and E' <= albedo E with room to spare.
 * Checked exactly (N = 24,576, float) against ||A||_2^2 from power iteration,
 * and for 8-bit N = 128 storage within the derived quantization slack
 * (truncation only removes energy; rounding adds at most (1 + sqrt(N)/254)^2). */
#include "gather_fixture.h"

#define BOWL_RINGS 16
#define BOWL_SEGS 32

/* The lower half (y <= 0) of a unit sphere at the origin, normals facing in. Returns 0 or -1. */
static int make_bowl(prt_mesh *out) {
    prt_error err;
    prt_mesh s;
    const float c[3] = { 0, 0, 0 };
    if (mesh_make_sphere(&s, c, 1.f, BOWL_RINGS, BOWL_SEGS, &err)) { fprintf(stderr, "%s\n", err.msg); return -1; }
    int *map = malloc(sizeof(int) * s.nverts);
    memset(out, 0, sizeof *out);
    out->pos = malloc(sizeof(float) * 3 * s.nverts);
    out->nrm = malloc(sizeof(float) * 3 * s.nverts);
    out->tris = malloc(sizeof(uint32_t) * 3 * s.ntris);
    out->mat = calloc((size_t)s.nverts, sizeof(uint16_t));
    for (int v = 0; v < s.nverts; v++) map[v] = -1;
    for (int t = 0; t < s.ntris; t++) {
        bool keep = true;
        for (int k = 0; k < 3; k++) keep &= s.pos[3 * s.tris[3 * t + k] + 1] <= 1e-5f;
        if (!keep) continue;
        for (int k = 0; k < 3; k++) {
            int v = (int)s.tris[3 * t + k];
            if (map[v] < 0) {
                map[v] = out->nverts++;
                memcpy(out->pos + 3 * map[v], s.pos + 3 * v, sizeof(float) * 3);
                memcpy(out->nrm + 3 * map[v], s.nrm + 3 * v, sizeof(float) * 3);
            }
            out->tris[3 * out->ntris + k] = (uint32_t)map[v];
        }
        out->ntris++;
    }
    free(map);
    mesh_free(&s);
    fx_flip(out);
    return 0;
}

static int build_bowl(prt_data *d, vis_scene **vs, const char *spec) {
    prt_error err;
    prt_mesh m;
    memset(d, 0, sizeof *d);
    if (make_bowl(&m)) return -1;
    if (scene_from_mesh(&m, spec, &d->scene, &err)) { fprintf(stderr, "%s\n", err.msg); return -1; }
    if (fx_factor_all(d, 4)) return -1;
    *vs = vis_create(&d->scene.mesh, &err);
    if (!*vs) { fprintf(stderr, "%s\n", err.msg); return -1; }
    d->gather_res = 32;
    return 0;
}

/* Dense gather matrix A[x][y] (channel 0) of the scene: a pass over one-hot probe vectors. */
static double *gather_matrix(const prt_data *d, const vis_scene *vs, const prt_transport *layout) {
    int nv = layout->nverts;
    uint32_t *idx = malloc(sizeof(uint32_t) * (size_t)layout->nvecs);
    float *val = malloc(sizeof(float) * 3 * (size_t)layout->nvecs);
    for (int v = 0; v < nv; v++) {
        idx[layout->vec_first[v]] = (uint32_t)v;
        for (int ch = 0; ch < 3; ch++) val[3 * layout->vec_first[v] + ch] = 1.f;
    }
    prt_transport probe, next;
    prt_error err;
    double *A = NULL;
    if (fx_probe_set(layout, idx, val, nv, &probe) == 0) {
        gather_desc gd = { .res = 32 };
        if (gather_pass(d, vs, &probe, &gd, &next, &err) == 0) {
            A = calloc((size_t)nv * nv, sizeof(double));
            float *buf = malloc(sizeof(float) * 3 * CUBE_TEXELS);
            bool clean = true;
            for (int x = 0; x < nv; x++) {
                transport_decode(&next, (int)next.vec_first[x], buf, buf + CUBE_TEXELS, buf + 2 * CUBE_TEXELS);
                for (int y = 0; y < nv; y++) A[(size_t)x * nv + y] = buf[y];
                for (int j = nv; j < CUBE_TEXELS; j++) clean &= buf[j] == 0.f;
            }
            CHECK(clean, "a pass of one-hot vectors only touches their indices");
            free(buf);
            transport_free(&next);
        } else fprintf(stderr, "gather: %s\n", err.msg);
        transport_free(&probe);
    }
    free(idx); free(val);
    return A;
}

/* Largest singular value squared of the n x n matrix A (power iteration on A^T A). */
static double spectral_sq(const double *A, int n) {
    double *v = malloc(sizeof(double) * n), *w = malloc(sizeof(double) * n), *u = malloc(sizeof(double) * n);
    for (int i = 0; i < n; i++) v[i] = 1.0 + 0.01 * (i % 7);
    double lam = 0;
    for (int it = 0; it < 300; it++) {
        double nn = 0;
        for (int i = 0; i < n; i++) nn += v[i] * v[i];
        nn = sqrt(nn);
        for (int i = 0; i < n; i++) v[i] /= nn;
        for (int i = 0; i < n; i++) { double s = 0; for (int j = 0; j < n; j++) s += A[(size_t)i * n + j] * v[j]; w[i] = s; }
        for (int j = 0; j < n; j++) { double s = 0; for (int i = 0; i < n; i++) s += A[(size_t)i * n + j] * w[i]; u[j] = s; }
        lam = 0;
        for (int i = 0; i < n; i++) lam += u[i] * v[i];
        memcpy(v, u, sizeof(double) * n);
    }
    free(v); free(w); free(u);
    return lam;
}

static void row_col_sums(const double *A, int n, double *R, double *C, double *rmax, double *cmax) {
    *rmax = *cmax = 0;
    for (int i = 0; i < n; i++) R[i] = C[i] = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) { R[x] += A[(size_t)x * n + y]; C[y] += A[(size_t)x * n + y]; }
    for (int i = 0; i < n; i++) { if (R[i] > *rmax) *rmax = R[i]; if (C[i] > *cmax) *cmax = C[i]; }
}

/* Radiance-domain scale of one stored vector's quantization error under L = 1 (see top comment). */
static double qerr_of(const prt_data *d, const prt_transport *t, int v) {
    if (t->qbits == 32) return 0;
    const float up[3] = { 0, 0, 1 };
    float h[3 * BRDF_MAX_SIGMA];
    brdf_factor_view(&d->factors[d->scene.mesh.mat[v]], up, h);
    double e = 0;
    for (int ch = 0; ch < 3; ch++) {
        double q = fabs(h[ch]) * 6.0 * 64.0 * t->scale[3 * t->vec_first[v] + ch] / 2.0;
        if (q > e) e = q;
    }
    return e;
}

#define FB 6   /* bounces in the furnace */

static void furnace(void) {
    prt_data d;
    vis_scene *vs = NULL;
    if (build_bowl(&d, &vs, "lambert:kd=1")) { CHECK(0, "bowl scene"); return; }
    int nv = d.scene.mesh.nverts;
    CHECK(d.factors[0].K == 1, "lambert has one term");
    prt_transport T[FB + 1];
    memset(T, 0, sizeof T);
    CHECK(fx_direct(&d, vs, 128, 8, &T[0]) == 0, "direct transport");
    double t0 = prt_now();
    gather_desc gd = { .res = 32, .stage = "furnace" };
    prt_error err;
    for (int b = 1; b <= FB; b++) {
        int rc = gather_pass(&d, vs, &T[b - 1], &gd, &T[b], &err);
        CHECK(rc == 0, "pass %d: %s", b, err.msg);
        if (rc) return;
    }
    double t_pass = (prt_now() - t0) / FB;

    /* r[b][x]: radiance of pass b alone at vertex x (channel 0; grey), q[b]: its quantization bound. */
    float *Lw = malloc(sizeof(float) * 3 * CUBE_TEXELS), *buf = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    fx_const_light(1.f, Lw);
    double *r = calloc((size_t)(FB + 1) * nv, sizeof(double)), qmax[FB + 1] = { 0 };
    bool grey = true, nonneg = true;
    for (int b = 0; b <= FB; b++)
        for (int x = 0; x < nv; x++) {
            double rgb[3];
            fx_lambert_radiance(&d, &T[b], x, Lw, rgb, buf);
            r[b * nv + x] = rgb[0];
            grey &= fabs(rgb[0] - rgb[1]) <= 1e-5 && fabs(rgb[0] - rgb[2]) <= 1e-5;
            nonneg &= rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0;
            double q = qerr_of(&d, &T[b], x);
            if (q > qmax[b]) qmax[b] = q;
        }
    CHECK(grey, "grey albedo gives grey radiance");
    CHECK(nonneg, "every pass adds non-negative radiance (monotone in B)");

    /* V_x = u_0, R_x from the gather matrix (exact float). */
    double *A = gather_matrix(&d, vs, &T[0]);
    CHECK(A != NULL, "gather matrix");
    if (!A) return;
    double *R = malloc(sizeof(double) * nv), *C = malloc(sizeof(double) * nv), rmax, cmax;
    row_col_sums(A, nv, R, C, &rmax, &cmax);
    (void)cmax;
    double vmin = 1e9, vmax = 0, rmin = 1e9, dmin = 1e9, dmax = -1e9;
    for (int x = 0; x < nv; x++) {
        double V = r[x], s = V + R[x] - 1.0;
        if (V < vmin) vmin = V;
        if (V > vmax) vmax = V;
        if (R[x] < rmin) rmin = R[x];
        if (s < dmin) dmin = s;
        if (s > dmax) dmax = s;
    }
    printf("furnace: %d vertices, V in [%.4f, %.4f], R in [%.4f, %.4f], V+R-1 in [%.4f, %.4f], %.2f s per pass\n", nv,
           vmin, vmax, rmin, rmax, dmin, dmax, t_pass);
    /* Analytic: V = 1/2 and R = albedo/2 at every vertex, up to tessellation and cubature. */
    CHECK_NEAR(vmin, 0.5, 0.01, "V_min = 1/2 (view factor of the opening)");
    CHECK_NEAR(vmax, 0.5, 0.01, "V_max = 1/2");
    CHECK_NEAR(rmin, 0.5, 0.02, "R_min = albedo/2 (view factor of the bowl)");
    CHECK_NEAR(rmax, 0.5, 0.02, "R_max = albedo/2");
    CHECK_LE(dmax, 0.01, "V + R <= 1 + 1%%");

    for (int B = 0; B <= FB; B++) {
        /* Bounds of the discrete recursion: A >= 0 with row sums in [R_min, R_max], V in [V_min, V_max]. */
        double Q = 0, glo = 0, gup = 0;
        for (int i = 0; i <= B; i++) {
            Q += (double)(B - i + 1) * qmax[i];
            glo += pow(rmin, i);
            gup += pow(rmax, i);
        }
        double lo = vmin * glo - Q, up = vmax * gup + Q, exact = 1.0 - pow(0.5, B + 1);
        double umin = 1e9, umax = 0, umean = 0;
        bool mono = true;
        for (int x = 0; x < nv; x++) {
            double u = 0, u1 = 0;
            for (int i = 0; i <= B; i++) u += r[i * nv + x];
            for (int i = 0; i < B; i++) u1 += r[i * nv + x];
            mono &= u >= u1;
            if (u < umin) umin = u;
            if (u > umax) umax = u;
            umean += u / nv;
        }
        printf("furnace B=%d: radiance min %.4f mean %.4f max %.4f; analytic %.4f; bounds [%.4f, %.4f] (Q %.4f)\n", B,
               umin, umean, umax, exact, lo, up, Q);
        CHECK(mono, "B=%d: monotone in B", B);
        CHECK_LE(umax, 1.0 + Q, "B=%d: radiance <= L (1 + q)", B);
        CHECK_LE(umax, up, "B=%d: upper bound V_max sum R_max^i + Q", B);
        CHECK_LE(lo, umin, "B=%d: lower bound V_min sum R_min^i - Q", B);
        CHECK_NEAR(umean, exact, 0.03, "B=%d: mean radiance = 1 - 2^-(B+1)", B);
        if (B == 3) CHECK_LE(0.88, umin, "B=3: every vertex at least 0.88 L (analytic 0.9375)");
    }

    /* gather_sum of all passes matches the per-pass sum within each summed vector's quantization. */
    prt_transport sum, tmp;
    memset(&sum, 0, sizeof sum);
    bool ok = gather_sum(&T[0], &T[1], 0, &sum, &err) == 0;
    for (int b = 2; ok && b <= FB; b++) {
        ok = gather_sum(&sum, &T[b], 0, &tmp, &err) == 0;
        transport_free(&sum);
        sum = tmp;
    }
    CHECK(ok, "gather_sum: %s", err.msg);
    if (ok) {
        double worst = 0;
        for (int x = 0; x < nv; x++) {
            double rgb[3], u = 0;
            fx_lambert_radiance(&d, &sum, x, Lw, rgb, buf);
            for (int i = 0; i <= FB; i++) u += r[i * nv + x];
            double dd = fabs(rgb[0] - u);
            if (dd > worst) worst = dd;
        }
        /* Each of FB requantizations adds at most the summed vector's own step bound (~qmax of the sum). */
        double qs = 0;
        for (int x = 0; x < nv; x++) { double q = qerr_of(&d, &sum, x); if (q > qs) qs = q; }
        printf("furnace: summed set vs per-pass radiance: max |diff| %.2e (bound %.2e)\n", worst, FB * qs);
        CHECK_LE(worst, FB * qs + 1e-6, "summed radiance within requantization bound");
        transport_free(&sum);
    }

    free(A); free(R); free(C); free(r); free(Lw); free(buf);
    for (int b = 0; b <= FB; b++) transport_free(&T[b]);
    vis_destroy(vs);
    fx_free(&d);
}

static void energy(void) {
    const double albedo = 0.5;
    prt_data d;
    vis_scene *vs = NULL;
    if (build_bowl(&d, &vs, "lambert:kd=0.5")) { CHECK(0, "bowl scene"); return; }
    int nv = d.scene.mesh.nverts;
    prt_error err;
    gather_desc gd = { .res = 32 };

    prt_transport E0;
    CHECK(fx_direct(&d, vs, CUBE_TEXELS, 32, &E0) == 0, "exact direct");
    double *A = gather_matrix(&d, vs, &E0);
    CHECK(A != NULL, "gather matrix");
    if (!A) return;
    double *R = malloc(sizeof(double) * nv), *C = malloc(sizeof(double) * nv), rmax, cmax;
    row_col_sums(A, nv, R, C, &rmax, &cmax);
    double s2 = spectral_sq(A, nv);
    printf("energy: R_max %.4f  C_max %.4f  ||A||^2 %.4f  R_max*C_max %.4f  (albedo %.2f)\n", rmax, cmax, s2,
           rmax * cmax, albedo);
    CHECK(rmax < albedo, "escaping rays: every row sum below the albedo");
    CHECK_NEAR(rmax, albedo / 2, 0.01, "row sums = albedo x view factor of the bowl (1/2)");
    /* ||A||^2 <= R_max C_max holds exactly; the double power iteration and sums round by ~1e-15 */
    CHECK_LE(s2, rmax * cmax * (1 + 1e-9), "Schur bound");
    CHECK_LE(rmax * cmax, albedo, "Schur bound below the albedo");

    /* Exact storage: E_{i+1} <= ||A||^2 E_i. */
    prt_transport prev = E0, next;
    double e_prev = gather_energy(&prev);
    for (int b = 1; b <= 2; b++) {
        int rc = gather_pass(&d, vs, &prev, &gd, &next, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) break;
        double e = gather_energy(&next);
        printf("energy exact pass %d: E = %.6g, E/E_prev = %.4f\n", b, e, e / e_prev);
        CHECK(e > 0, "pass %d carries energy", b);
        CHECK_LE(e, s2 * e_prev * (1 + 1e-4), "exact pass %d: E' <= ||A||^2 E", b);
        CHECK_LE(e, albedo * e_prev * (1 + 1e-4), "exact pass %d: E' <= albedo E", b);
        transport_free(&prev);
        prev = next;
        e_prev = e;
    }
    transport_free(&prev);

    /* 8-bit, N = 128: truncation removes energy, rounding adds at most (1 + sqrt(N)/254)^2 per pass. */
    double qtol = pow(1 + sqrt(128.0) / 254.0, 2);
    prt_transport q;
    CHECK(fx_direct(&d, vs, 128, 8, &q) == 0, "8-bit direct");
    e_prev = gather_energy(&q);
    for (int b = 1; b <= 3; b++) {
        int rc = gather_pass(&d, vs, &q, &gd, &next, &err);
        CHECK(rc == 0, "%s", err.msg);
        if (rc) break;
        double e = gather_energy(&next);
        printf("energy 8-bit pass %d: E/E_prev = %.4f\n", b, e / e_prev);
        CHECK_LE(e, s2 * qtol * e_prev, "8-bit pass %d: E' <= ||A||^2 (1+sqrt(N)/254)^2 E", b);
        CHECK_LE(e, albedo * e_prev, "8-bit pass %d: E' <= albedo E", b);
        transport_free(&q);
        q = next;
        e_prev = e;
    }
    transport_free(&q);
    free(A); free(R); free(C);
    vis_destroy(vs);
    fx_free(&d);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(furnace);
    CHECK_CASE(energy);
    return check_summary();
}
