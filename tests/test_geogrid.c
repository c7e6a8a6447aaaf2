/* test_geogrid.c - the geodesic view grid (geogrid.h): counts, unit and distinct
 * directions, consistently oriented faces, locate against brute force over every finest
 * face, weights that sum to 1, reproduce grid points and interpolate linear functions,
 * bad levels refused, and the cost of a locate (printed, not asserted). */
#include "harness.h"
#include "geogrid.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static float rnd(uint32_t *s) { *s ^= *s << 13; *s ^= *s >> 17; *s ^= *s << 5; return (float)(*s >> 8) / 16777216.f; }

static void rnd_dir(uint32_t *s, float d[3]) {
    float z = 2 * rnd(s) - 1, p = 6.2831853f * rnd(s), r = sqrtf(fmaxf(0, 1 - z * z));
    d[0] = r * cosf(p), d[1] = r * sinf(p), d[2] = z;
}

static double tri_det(const float *a, const float *b, const float *c) {
    return (double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
           (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
}

/* 10 * 4^L + 2 unit, pairwise distinct directions; 20 * 4^L faces of positive orientation whose
 * solid angles (Van Oosterom-Strackee) sum to 4 pi; spacing shrinks by about 2 per level. */
static void structure(void) {
    prt_error err;
    float prev = 0;
    for (int L = 0; L <= 4; L++) {
        geogrid *g = geogrid_create(L, &err);
        CHECK(g != NULL, "level %d: %s", L, err.msg);
        if (!g) return;
        int n = geogrid_count(g);
        CHECK(n == 10 * (1 << (2 * L)) + 2 && geogrid_face_count(g) == 20 << (2 * L), "level %d: %d views", L, n);
        double maxerr = 0, mind = 1;
        for (int i = 0; i < n; i++) {
            const float *a = geogrid_dir(g, i);
            maxerr = fmax(maxerr, fabs(sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) - 1));
            for (int j = i + 1; j < n && L <= 3; j++) {
                const float *b = geogrid_dir(g, j);
                double dd = hypot(hypot(a[0] - b[0], a[1] - b[1]), a[2] - b[2]);
                if (dd < mind) mind = dd;
            }
        }
        CHECK_LE(maxerr, 1e-6, "level %d unit directions", L);
        if (L <= 3) CHECK(mind > 0.5 * geogrid_spacing(g), "level %d: closest pair %g, spacing %g", L, mind, geogrid_spacing(g));
        double omega = 0, mindet = 1;
        for (int f = 0; f < geogrid_face_count(g); f++) {
            const int *t = geogrid_face(g, f);
            const float *a = geogrid_dir(g, t[0]), *b = geogrid_dir(g, t[1]), *c = geogrid_dir(g, t[2]);
            double det = tri_det(a, b, c);
            double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2], bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
            double ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
            omega += 2 * atan2(det, 1 + ab + bc + ca);
            if (det < mindet) mindet = det;
        }
        CHECK(mindet > 0, "level %d: every face counter-clockwise from outside (min det %g)", L, mindet);
        CHECK_NEAR(omega, 4 * M_PI, 1e-4, "level %d: faces tile the sphere", L);
        if (L > 0) CHECK(geogrid_spacing(g) < 0.6 * prev && geogrid_spacing(g) > 0.4 * prev, "level %d spacing %g", L, geogrid_spacing(g));
        prev = geogrid_spacing(g);
        geogrid_destroy(g);
    }
}

/* Brute force: the finest face whose three edge planes all hold d (largest smallest margin). */
static int brute_face(const geogrid *g, const float d[3]) {
    int best = -1;
    double bm = -1e30;
    for (int f = 0; f < geogrid_face_count(g); f++) {
        const int *t = geogrid_face(g, f);
        double m = 1e30;
        for (int i = 0; i < 3; i++) m = fmin(m, tri_det(d, geogrid_dir(g, t[i]), geogrid_dir(g, t[(i + 1) % 3])));
        if (m > bm) bm = m, best = f;
    }
    return best;
}

static bool same_set(const int *a, const int *b) {
    for (int i = 0; i < 3; i++)
        if (a[i] != b[0] && a[i] != b[1] && a[i] != b[2]) return false;
    return true;
}

/* locate against brute force at levels 0..3 (2,000 random directions each), weights >= 0
 * summing to 1, sum w_i v_i parallel to d (linear functions on the face plane interpolate). */
static void locate(void) {
    prt_error err;
    uint32_t s = 12345;
    for (int L = 0; L <= 3; L++) {
        geogrid *g = geogrid_create(L, &err);
        int agree = 0, n = 2000;
        double werr = 0, perr = 0, wmin = 1;
        for (int i = 0; i < n; i++) {
            float d[3], w[3];
            int idx[3];
            rnd_dir(&s, d);
            geogrid_locate(g, d, idx, w);
            int bf = brute_face(g, d);
            agree += same_set(idx, geogrid_face(g, bf));
            werr = fmax(werr, fabs(w[0] + w[1] + w[2] - 1));
            wmin = fmin(wmin, fmin(w[0], fmin(w[1], w[2])));
            double p[3] = { 0, 0, 0 }, l = 0;
            for (int k = 0; k < 3; k++)
                for (int c = 0; c < 3; c++) p[c] += w[k] * geogrid_dir(g, idx[k])[c];
            for (int c = 0; c < 3; c++) l += p[c] * p[c];
            l = sqrt(l);
            for (int c = 0; c < 3; c++) perr = fmax(perr, fabs(p[c] / l - d[c]));
        }
        CHECK(agree == n, "level %d: locate agrees with brute force on %d of %d", L, agree, n);
        CHECK_LE(werr, 1e-6, "level %d weights sum to 1", L);
        CHECK(wmin >= 0, "level %d weights non-negative", L);
        CHECK_LE(perr, 2e-6, "level %d: normalize(sum w v) = d (linear interpolation on the face plane)", L);
        geogrid_destroy(g);
    }
}

/* At a grid direction the weight is 1 on it; on an edge midpoint direction, 1/2 on each end. */
static void grid_points(void) {
    prt_error err;
    geogrid *g = geogrid_create(3, &err);
    int bad = 0;
    for (int j = 0; j < geogrid_count(g); j++) {
        int idx[3];
        float w[3];
        geogrid_locate(g, geogrid_dir(g, j), idx, w);
        float wj = 0;
        for (int k = 0; k < 3; k++) wj += idx[k] == j ? w[k] : 0;
        bad += !(wj > 1 - 1e-5f);
    }
    CHECK(bad == 0, "%d grid directions not reproduced", bad);
    const int *t = geogrid_face(g, 100);
    float m[3];
    for (int c = 0; c < 3; c++) m[c] = geogrid_dir(g, t[0])[c] + geogrid_dir(g, t[1])[c];
    int idx[3];
    float w[3];
    geogrid_locate(g, m, idx, w);
    float w0 = 0, w1 = 0;
    for (int k = 0; k < 3; k++) w0 += idx[k] == t[0] ? w[k] : 0, w1 += idx[k] == t[1] ? w[k] : 0;
    CHECK_NEAR(w0, 0.5, 1e-5, "edge midpoint");
    CHECK_NEAR(w1, 0.5, 1e-5, "edge midpoint");
    geogrid_destroy(g);
}

static void bad_level(void) {
    prt_error err = { { 0 } };
    CHECK(geogrid_create(-1, &err) == NULL && strstr(err.msg, "level -1"), "'%s'", err.msg);
    CHECK(geogrid_create(GEOGRID_MAX_LEVEL + 1, &err) == NULL && strstr(err.msg, "level 7"), "'%s'", err.msg);
}

/* Not a check: the cost of one locate at level 3 (runs per vertex per frame). */
static void cost(void) {
    prt_error err;
    geogrid *g = geogrid_create(3, &err);
    uint32_t s = 7;
    enum { N = 200000 };
    float *d = malloc(sizeof(float) * 3 * N);
    for (int i = 0; i < N; i++) rnd_dir(&s, d + 3 * i);
    double t0 = prt_now(), sink = 0;
    for (int i = 0; i < N; i++) {
        int idx[3];
        float w[3];
        geogrid_locate(g, d + 3 * i, idx, w);
        sink += w[0] + idx[1];
    }
    double t = prt_now() - t0;
    printf("geogrid: level 3 locate %.3f us (sink %g)\n", 1e6 * t / N, sink);
    CHECK(sink > 0, "ran");
    free(d);
    geogrid_destroy(g);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(structure);
    CHECK_CASE(locate);
    CHECK_CASE(grid_points);
    CHECK_CASE(bad_level);
    CHECK_CASE(cost);
    return check_summary();
}
