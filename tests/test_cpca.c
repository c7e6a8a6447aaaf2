/* test_cpca.c - clustered PCA over the Haar transport (src/transfer/cpca/, cpca.h).
 *
 *   energy:      synthetic vectors of known rank in two groups on disjoint coefficients, every
 *                coefficient kept, unquantized: the squared reconstruction error summed over the
 *                samples equals the PCA energy dropped, sum_{m >= M} lambda_m of each cluster's
 *                scatter matrix computed here by LAPACK from the dense samples, within the float
 *                rounding of the stored rows and weights;
 *   light:       the light change (cpca_light: rows projected once, then the weights) against the
 *                dense product of each reconstructed vector with the light vector, quantized and
 *                truncated rows, within the float rounding of both sums;
 *   threads:     the same scene precomputed on 1 and 2 threads gives the same section, byte for byte;
 *   round_trip:  the section written and read back relights to the same bits and re-writes to the same
 *                bytes;
 *   bad_input:   a truncated section, a cluster id out of range and a coefficient index out of range are
 *                each one line (read or validate), no crash; the same cluster id through prtfile_read
 *                and `prt info` (exit 1);
 *   relight:     a sphere over a plane precomputed with --basis cpca relights, vector by vector, within
 *                ||x - x^|| ||L|| (Cauchy-Schwarz) of Haar at N = 24,576 in float (the exact vectors),
 *                x^ the model's reconstruction;
 *   gl:          the file through the CLI: `prt render --backend gl` (the GL runtime's CPU light method,
 *                glrt.h) equals `--backend cpu` to test_glrt's rule for gl against cpu images, and
 *                `prt bench --backend gl` runs and names the method "cpu". */
#include "harness.h"
#include "cpca.h"
#include "cubemap.h"
#include "image.h"
#include "mesh.h"
#include "precompute.h"
#include "probe.h"
#include "prtfile.h"
#include "relight.h"
#include "transfer.h"
#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* A hash of (a, b) in [-1, 1). */
static double hrand(uint64_t a, uint64_t b) {
    uint64_t x = a * 0x9E3779B97F4A7C15ull + b * 0xD1B54A32D192ED03ull + 1;
    x ^= x >> 33; x *= 0xFF51AFD7ED558CCDull; x ^= x >> 33; x *= 0xC4CEB9FE1A85EC53ull; x ^= x >> 33;
    return (double)(x >> 11) / (double)(1ull << 52) - 1;
}

/* n vectors in two groups: group g on indices [g * 4096, g * 4096 + 600) (disjoint supports), vector i =
 * s_c (base_g + sum_{j<5} a_ij 2^-j u_gj), s = (1, 0.8, 0.6): centred channel samples of rank <= 6. */
typedef struct synth { int n; uint32_t *first, *idx; float *val; } synth;
static synth make_synth(int n) {
    enum { SUP = 600 };
    synth s = { n, malloc(sizeof(uint32_t) * (size_t)(n + 1)), malloc(sizeof(uint32_t) * (size_t)n * SUP),
                malloc(sizeof(float) * 3 * (size_t)n * SUP) };
    const float sc[3] = { 1.0f, 0.8f, 0.6f };
    s.first[0] = 0;
    for (int i = 0; i < n; i++) {
        int g = i < n / 2 ? 0 : 1;
        for (int t = 0; t < SUP; t++) {
            double x = 2 + hrand(100 + g, (uint64_t)t);
            for (int j = 0; j < 5; j++) x += hrand((uint64_t)i, (uint64_t)j + 7) * ldexp(1, -j) * hrand(200 + 10 * g + j, (uint64_t)t);
            size_t c = (size_t)i * SUP + t;
            s.idx[c] = (uint32_t)(g * 4096 + t);
            for (int ch = 0; ch < 3; ch++) s.val[3 * c + ch] = (float)(sc[ch] * x);
        }
        s.first[i + 1] = (uint32_t)((i + 1) * SUP);
    }
    return s;
}
static void free_synth(synth *s) { free(s->first); free(s->idx); free(s->val); }

/* The PCA energy dropped in cluster k beyond M: the eigenvalues of the Gram matrix of its centred
 * samples (those of the scatter matrix, besides zeros) from LAPACK, in double; its trace into *total. */
static double dropped(const synth *s, const cpca_model *m, int k, int M, double *total) {
    int ns = 0;
    for (int i = 0; i < s->n; i++) ns += 3 * (m->cluster[i] == k);
    double *X = calloc((size_t)ns * CUBE_TEXELS, sizeof *X), *G = malloc(sizeof(double) * (size_t)ns * ns), *ev = malloc(sizeof(double) * (size_t)ns);
    int r = 0;
    for (int i = 0; i < s->n; i++)
        for (int ch = 0; ch < 3 && m->cluster[i] == k; ch++, r++)
            for (uint32_t c = s->first[i]; c < s->first[i + 1]; c++) X[(size_t)r * CUBE_TEXELS + s->idx[c]] = s->val[3 * (size_t)c + ch];
    for (int t = 0; t < CUBE_TEXELS; t++) {
        double mu = 0;
        for (int a = 0; a < ns; a++) mu += X[(size_t)a * CUBE_TEXELS + t];
        for (int a = 0; a < ns; a++) X[(size_t)a * CUBE_TEXELS + t] -= mu / ns;
    }
    for (int a = 0; a < ns; a++)
        for (int b = 0; b < ns; b++) {
            double d = 0;
            for (int t = 0; t < CUBE_TEXELS; t++) d += X[(size_t)a * CUBE_TEXELS + t] * X[(size_t)b * CUBE_TEXELS + t];
            G[(size_t)a * ns + b] = d;
        }
    CHECK(LAPACKE_dsyev(LAPACK_ROW_MAJOR, 'N', 'U', ns, G, ns, ev) == 0, "eigenvalues");
    double drop = 0;
    *total = 0;
    for (int a = 0; a < ns; a++) {
        *total += ev[a];
        if (a < ns - M) drop += fmax(ev[a], 0);   /* ascending: all but the M largest */
    }
    free(X); free(G); free(ev);
    return drop;
}

/* Every coefficient kept, unquantized: sum_s |x_s - x^_s|^2 = sum_k dropped(k), within the rounding of
 * x^ in float: per sample delta_s <= 2 (M + 3) eps (|mu| + sum_m |w_m| |b_m|) (mean, basis and weights
 * stored as floats, M + 1 terms summed), so |err - D| <= sum_s (2 sqrt(e_s) delta_s + delta_s^2), plus
 * LAPACK's double eigenvalues (1e-12 of the trace). */
static void energy(void) {
    prt_error err;
    synth s = make_synth(40);
    cpca_vectors v = { s.n, s.first, s.idx, s.val };
    cpca_model m;
    int M = 3;
    cpca_params p = { .clusters = 2, .terms = M, .coeffs = CUBE_TEXELS, .quantize = false, .nthreads = 2 };
    if (cpca_build(&v, &p, &m, &err)) { CHECK(0, "%s", err.msg); free_synth(&s); return; }
    CHECK(m.cluster[0] != m.cluster[s.n - 1], "the two groups in two clusters");
    for (int i = 0; i < s.n; i++) CHECK(m.cluster[i] == m.cluster[i < s.n / 2 ? 0 : s.n - 1], "vector %d with its group", i);
    float *x = malloc(sizeof(float) * CUBE_TEXELS), *ref = calloc(CUBE_TEXELS, sizeof(float));
    double e = 0, tol = 0, D = 0, tot = 0;
    for (int i = 0; i < s.n; i++)
        for (int ch = 0; ch < 3; ch++) {
            cpca_decode(&m, i, ch, x);
            memset(ref, 0, sizeof(float) * CUBE_TEXELS);
            for (uint32_t c = s.first[i]; c < s.first[i + 1]; c++) ref[s.idx[c]] = s.val[3 * (size_t)c + ch];
            double es = 0, mag = 0;
            for (int t = 0; t < CUBE_TEXELS; t++) es += ((double)x[t] - ref[t]) * ((double)x[t] - ref[t]);
            int r0 = m.cluster[i] * (M + 1);
            for (int a = 0; a <= M; a++) {
                double nb = 0, w = a ? fabs(m.w[((size_t)3 * i + ch) * M + a - 1]) : 1;
                for (uint32_t q = m.first[r0 + a]; q < m.first[r0 + a + 1]; q++) nb += (double)m.val[q] * m.val[q];
                mag += w * sqrt(nb);
            }
            double ds = 2.0 * (M + 3) * FLT_EPSILON * mag;
            e += es;
            tol += 2 * sqrt(es) * ds + ds * ds;
        }
    for (int k = 0; k < m.C; k++) {
        double t;
        D += dropped(&s, &m, k, M, &t);
        tot += t;
    }
    tol += 1e-12 * tot;
    CHECK(D > 1e-3 * tot, "the test drops energy: %g of %g", D, tot);
    CHECK_NEAR(e, D, tol, "squared error against the dropped PCA energy");
    CHECK_NEAR(m.err2, D, tol, "the model's own error sum (prt info's) against the dropped PCA energy");
    printf("  energy: squared error %.9g, dropped eigenvalues %.9g of %.6g (|diff| %.2e <= %.2e)\n", e, D, tot, fabs(e - D), tol);
    free(x); free(ref);
    cpca_model_free(&m);
    free_synth(&s);
}

/* Quantized rows of 300 coefficients: g from cpca_light against x^ . L in double, x^ decoded in float
 * (cpca_decode). Both sides round: the rows' projections (n_r terms), the weighted sum (M + 1), the
 * decoding (M + 1 per coefficient): |diff| <= (n_r + 2M + 4) eps sum_a |w_a| sum_q |b_aq L_q|. */
static void light(void) {
    prt_error err;
    synth s = make_synth(30);
    cpca_vectors v = { s.n, s.first, s.idx, s.val };
    cpca_model m;
    int M = 4;
    cpca_params p = { .clusters = 3, .terms = M, .coeffs = 300, .quantize = true, .nthreads = 2 };
    if (cpca_build(&v, &p, &m, &err)) { CHECK(0, "%s", err.msg); free_synth(&s); return; }
    float (*L)[4] = transfer_light_alloc();
    for (int t = 0; t < CUBE_TEXELS; t++)
        for (int ch = 0; ch < 3; ch++) L[t][ch] = (float)hrand((uint64_t)t, 50 + (uint64_t)ch);
    float *g = malloc(sizeof(float) * 3 * (size_t)s.n), *x = malloc(sizeof(float) * CUBE_TEXELS);
    cpca_light(&m, (const float (*)[4])L, g, 2);
    int nbad = 0;
    double worst = 0;
    for (int i = 0; i < s.n; i++)
        for (int ch = 0; ch < 3; ch++) {
            cpca_decode(&m, i, ch, x);
            double want = 0, mag = 0;
            for (int t = 0; t < CUBE_TEXELS; t++) want += (double)x[t] * L[t][ch];
            int r0 = m.cluster[i] * (M + 1);
            for (int a = 0; a <= M; a++) {
                double w = a ? fabs(m.w[((size_t)3 * i + ch) * M + a - 1]) : 1, rl = 0;
                for (uint32_t q = m.first[r0 + a]; q < m.first[r0 + a + 1]; q++) rl += fabs(m.val[q] * L[m.idx[q]][ch]);
                mag += w * rl;
            }
            double tol = (300 + 2.0 * M + 4) * FLT_EPSILON * mag, d = fabs(g[3 * i + ch] - want);
            nbad += d > tol;
            if (d / tol > worst) worst = d / tol;
        }
    CHECK(nbad == 0, "%d samples beyond the rounding bound", nbad);
    printf("  light: %d samples against the dense product, the worst at %.2f of its rounding bound\n", 3 * s.n, worst);
    free(g); free(x); free(L);
    cpca_model_free(&m);
    free_synth(&s);
}

/* A Lambert plane (9 x 9) under a Lambert sphere: shadows, one vector per vertex. */
static int sphere_plane(prt_scene *sc) {
    prt_error err;
    prt_mesh plane = { 0 }, sph = { 0 };
    float c[3] = { 0, 0.8f, 0 };
    if (mesh_make_plane(&plane, -2, 2, -2, 2, 0, 9, 9, &err) || mesh_make_sphere(&sph, c, 0.6f, 8, 16, &err)) return -1;
    if (mesh_append(&plane, &sph, &err)) return -1;
    mesh_free(&sph);
    return scene_from_mesh(&plane, "lambert:kd=0.6,0.55,0.5", sc, &err);
}

/* The scene precomputed with basis and options, direct only, on nthreads (whole: without the open sky
 * split, opensky.h), not refined (the plan's refinement depends on the basis's bytes, and these
 * compare bases on one mesh). 0 or -1. */
static int precompute(const char *basis, const char *options, int N, int qbits, int nthreads, bool whole, prt_data *out) {
    prt_error err;
    prt_scene sc;
    if (sphere_plane(&sc)) { CHECK(0, "scene"); return -1; }
    precompute_desc d = { .N = N, .qbits = qbits, .vis_res = 64, .quiet = true, .nthreads = nthreads, .force_bounces = -1,
                          .force_refine = -1, .basis = basis, .basis_options = options, .no_open_sky = whole };
    int rc = precompute_run(&sc, &d, out, &err);
    CHECK(rc == 0, "%s: %s", basis, err.msg);
    return rc;
}
#define CPCA_OPTS "clusters=6,terms=6,coeffs=1500,stage=3000"

/* The transfer's section as its write makes it (malloc'd, *n bytes). */
static unsigned char *section_bytes(const prt_transfer *tr, size_t *n) {
    char *buf = NULL;
    FILE *f = open_memstream(&buf, n);
    prt_writer w = { .f = f, .crc = prtio_crc_init() };
    tr->ops->write(&w, tr);
    fclose(f);
    return (unsigned char *)buf;
}

static void threads(void) {
    prt_data a, b;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 1, false, &a)) return;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 2, false, &b)) { prt_data_free(&a); return; }
    size_t na, nb;
    unsigned char *sa = section_bytes(prt_data_transfer(&a), &na), *sb = section_bytes(prt_data_transfer(&b), &nb);
    CHECK(na == nb && na > 1000 && !memcmp(sa, sb, na), "1 and 2 threads: %zu and %zu bytes, identical", na, nb);
    printf("  threads: the %zu-byte section is the same on 1 and 2 threads\n", na);
    free(sa); free(sb);
    prt_data_free(&a);
    prt_data_free(&b);
}

/* The cube light of the default procedural sky. */
static float *sky_cube(void) {
    prt_error err;
    prt_probe p;
    sky_desc sd = { 0 };
    float *cube = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    CHECK(probe_make_sky(&sd, &p, &err) == 0, "%s", err.msg);
    probe_to_cube(&p, CUBE_RES, NULL, 0, cube);
    probe_free(&p);
    return cube;
}

/* g of every vector of tr's transport under the sky. */
static float *light_all(const prt_transfer *tr, const float *cube) {
    float (*L)[4] = transfer_light_vector(tr, cube);
    float *g = calloc(3 * (size_t)tr->transport.nvecs + 3, sizeof(float));
    transfer_light(tr, &tr->transport, (const float (*)[4])L, g, 2);
    free(L);
    return g;
}

static void round_trip(void) {
    prt_error err;
    prt_data a, b;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 2, false, &a)) return;
    char path[600], path2[600];
    snprintf(path, sizeof path, "%s/cpca.prt", check_tmpdir());
    snprintf(path2, sizeof path2, "%s/cpca_again.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    if (prtfile_read(path, &b, &err)) { CHECK(0, "%s", err.msg); prt_data_free(&a); return; }
    const prt_transfer *x = prt_data_transfer(&a), *y = prt_data_transfer(&b);
    CHECK(y->ops == x->ops && y->materials == x->materials && !memcmp(&x->cfg, &y->cfg, sizeof x->cfg), "representation, mask, config");
    float *cube = sky_cube(), *ga = light_all(x, cube), *gb = light_all(y, cube);
    CHECK(!memcmp(ga, gb, sizeof(float) * 3 * (size_t)x->transport.nvecs), "relit to the same bits");
    size_t na, nb;
    unsigned char *sa = section_bytes(x, &na), *sb = section_bytes(y, &nb);
    CHECK(na == nb && !memcmp(sa, sb, na), "the section re-written to the same bytes");
    CHECK(prtfile_write(path2, &b, &err) == 0, "%s", err.msg);
    printf("  round trip: %d vectors relit to the same bits, %zu-byte section\n", x->transport.nvecs, na);
    free(sa); free(sb); free(cube); free(ga); free(gb);
    prt_data_free(&a);
    prt_data_free(&b);
}

/* Reads section bytes s[n] into a transfer like tr's and validates it against d: the message, or "" when fine. */
static void read_section(const prt_data *d, const unsigned char *s, size_t n, char *why) {
    prt_transfer t;
    memset(&t, 0, sizeof t);
    t.ops = prt_data_transfer(d)->ops;
    prt_reader r = { .p = s, .n = n };
    why[0] = 0;
    if (t.ops->read(&r, &t, why)) t.ops->validate(d, &t, why);
    t.ops->release(&t);
}

/* Byte offsets in the section: the model's cluster ids and its coefficient indices (cpca.h's layout,
 * after transfer_cpca.c's header of 33 bytes and vec_first). */
static void offsets(const prt_data *d, size_t *cl, size_t *idx) {
    const prt_transfer *tr = prt_data_transfer(d);
    int nverts = tr->transport.nverts, nvecs = tr->transport.nvecs;
    size_t model = 33 + 4 * ((size_t)nverts + 1);
    int C, M;
    size_t n = 0;
    unsigned char *s = section_bytes(tr, &n);
    memcpy(&C, s + model + 4, 4);
    memcpy(&M, s + model + 8, 4);
    free(s);
    size_t R = (size_t)C * (M + 1);
    *cl = model + 20;
    *idx = *cl + 2 * (size_t)nvecs + 12 * (size_t)nvecs * M + 4 * (R + 1) + 4 * R;
}

static void bad_input(void) {
    prt_error err;
    prt_data a;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 2, false, &a)) return;
    size_t n, cl, idx;
    unsigned char *s = section_bytes(prt_data_transfer(&a), &n), *bad = malloc(n);
    char why[256];
    read_section(&a, s, n, why);
    CHECK(why[0] == 0, "the section as written reads and validates: %s", why);
    const size_t cuts[] = { 0, 3, 30, 60, n / 2, n - 1 };
    for (int k = 0; k < 6; k++) {
        read_section(&a, s, cuts[k], why);
        CHECK(why[0] && !strchr(why, '\n'), "truncated at %zu: one line '%s'", cuts[k], why);
    }
    /* one byte in every n / 400 set to 0xff: read or validate says what, or it reads (a weight, a step
     * still finite), and nothing crashes (the loop itself is the check under valgrind or ASan) */
    int nread = 0;
    for (size_t k = 0; k < n; k += n / 400 + 1) {
        memcpy(bad, s, n);
        bad[k] = 0xff;
        read_section(&a, bad, n, why);
        nread += why[0] == 0;
        CHECK(!strchr(why, '\n'), "byte %zu: one line", k);
    }
    printf("  bad input: %d of %zu sections with one byte set read and validate\n", nread, n / (n / 400 + 1) + 1);
    offsets(&a, &cl, &idx);
    memcpy(bad, s, n);
    uint16_t v = 6;   /* clusters=6: ids 0..5 */
    memcpy(bad + cl + 2 * 5, &v, 2);
    read_section(&a, bad, n, why);
    CHECK(strstr(why, "vector 5 in cluster 6 of 6") != NULL, "cluster id out of range: '%s'", why);
    memcpy(bad, s, n);
    v = CUBE_TEXELS;
    memcpy(bad + idx + 2 * 7, &v, 2);
    read_section(&a, bad, n, why);
    CHECK(strstr(why, "coefficient index 24576 beyond the basis") != NULL, "index out of range: '%s'", why);
    /* the cluster id through the file: patched where the section lies, CRC refreshed */
    char path[600], cmd[1400], out[2048];
    snprintf(path, sizeof path, "%s/cpca_bad.prt", check_tmpdir());
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    size_t fn = 0;
    unsigned char *img = (unsigned char *)check_read_file(path, &fn), *at = img ? memmem(img, fn, s, n) : NULL;
    CHECK(at != NULL, "the section in the file");
    if (at) {
        v = 6;
        memcpy(at + cl + 2 * 5, &v, 2);
        uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), img, (uInt)(fn - 4));
        memcpy(img + fn - 4, &crc, 4);
        FILE *f = fopen(path, "wb");
        fwrite(img, 1, fn, f);
        fclose(f);
        prt_data b;
        CHECK(prtfile_read(path, &b, &err) == -1 && strstr(err.msg, path) && strstr(err.msg, "cluster 6 of 6"), "prtfile_read: '%s'", err.msg);
        snprintf(cmd, sizeof cmd, "%s info %s 2>&1", check_prt_bin(), path);
        int rc = check_run(cmd, out, sizeof out);
        CHECK(rc == 1 && strstr(out, "cluster 6 of 6") && strchr(out, '\n') == out + strlen(out) - 1, "prt info: exit %d, '%s'", rc, out);
    }
    free(img); free(s); free(bad);
    prt_data_free(&a);
}

/* CPCA against Haar at N = 24,576 in float (the vectors as the direct pass computed them, every
 * coefficient, Haar's default measure: the same T/w basis and light vector). Per vector and channel
 * |g_cpca - g_haar| <= |x - x^| |L| + rounding, x^ the model's reconstruction (Cauchy-Schwarz), the
 * rounding (24,576 + 2M + 4) eps |x| |L| of the two sums. */
static void relight(void) {
    prt_data a, h;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 2, false, &a)) return;
    if (precompute("haar", "budget=vector", CUBE_TEXELS, 32, 2, false, &h)) { prt_data_free(&a); return; }
    const prt_transfer *ta = prt_data_transfer(&a), *th = prt_data_transfer(&h);
    float *cube = sky_cube(), *ga = light_all(ta, cube), *gh = light_all(th, cube);
    float (*L)[4] = transfer_light_vector(ta, cube);
    const cpca_model *m = ta->priv;
    float *x = malloc(sizeof(float) * CUBE_TEXELS), *T = malloc(sizeof(float) * 3 * CUBE_TEXELS);
    int nbad = 0, n = ta->transport.nvecs;
    double num = 0, den = 0, worst = 0;
    CHECK(n == th->transport.nvecs && n == a.scene.mesh.nverts, "the same %d vectors", n);
    for (int i = 0; i < n && n == th->transport.nvecs; i++) {
        transport_decode(&th->transport, i, T, T + CUBE_TEXELS, T + 2 * CUBE_TEXELS);
        for (int ch = 0; ch < 3; ch++) {
            cpca_decode(m, i, ch, x);
            double e2 = 0, nl = 0, nx = 0;
            for (int t = 0; t < CUBE_TEXELS; t++) {
                double d = (double)x[t] - T[ch * CUBE_TEXELS + t];
                e2 += d * d, nl += (double)L[t][ch] * L[t][ch], nx += (double)T[ch * CUBE_TEXELS + t] * T[ch * CUBE_TEXELS + t];
            }
            double tol = sqrt(e2 * nl) + (CUBE_TEXELS + 2.0 * 6 + 4) * FLT_EPSILON * sqrt(nx * nl), d = fabs(ga[3 * i + ch] - gh[3 * i + ch]);
            nbad += d > tol;
            if (tol > 0 && d / tol > worst) worst = d / tol;
            num += d * d, den += (double)gh[3 * i + ch] * gh[3 * i + ch];
        }
    }
    CHECK(nbad == 0, "%d vector channels beyond |x - x^| |L|", nbad);
    double rel = sqrt(num / den);
    printf("  relight: %d vectors, RMS %.4f of Haar's exact T.L; the worst at %.2f of |x - x^| |L|\n", n, rel, worst);
    free(x); free(T); free(L); free(cube); free(ga); free(gh);
    prt_data_free(&a);
    prt_data_free(&h);
}

static int cmp_dbl(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The cpca file rendered by the GL runtime (no GLSL kernel: g from the transfer's own light on the CPU,
 * uploaded) against the CPU runtime, through `prt render`. The same g on both sides; the scene is
 * Lambertian (h one constant per material), so gl's per-pixel h . g is the cpu's Gouraud of vertex
 * colours to GL's float rounding: test_glrt's rule for gl against cpu images (per-pixel relative
 * difference over 1e-3 of the image's largest value: median 1e-5, 99.9% 1e-4; the quantile for pixels
 * at colours clamped at zero, where the two interpolate differently: whole vectors, since the open sky
 * split's cancellation dips more vertices below zero in shadows). Then `prt bench --backend gl`. */
static void gl(void) {
    prt_error err;
    prt_data a;
    if (precompute("cpca", CPCA_OPTS, 0, 0, 2, true, &a)) return;
    char path[600], probe[600], out[2][600], cmd[4096], buf[8192];
    const char *D = check_tmpdir(), *B = check_prt_bin();
    snprintf(path, sizeof path, "%s/cpca_gl.prt", D);
    snprintf(probe, sizeof probe, "%s/cpca_sun.exr", D);
    CHECK(prtfile_write(path, &a, &err) == 0, "%s", err.msg);
    prt_data_free(&a);
    prt_image im = { 0 }, img[2] = { { 0 }, { 0 } };
    CHECK(image_alloc(&im, 64, 32, 3, &err) == 0, "%s", err.msg);
    for (int i = 0; i < 64 * 32 * 3; i++) im.data[i] = i / 3 / 64 < 16 ? 0.5f : 0.05f;   /* sky over a dark ground */
    for (int y = 5; y < 8; y++)   /* a sun: sharp shadows of the sphere on the plane */
        for (int x = 20; x < 23; x++)
            for (int k = 0; k < 3; k++) im.data[3 * (y * 64 + x) + k] = 200.f;
    CHECK(image_write(probe, &im, NULL, &err) == 0, "%s", err.msg);
    image_free(&im);
    for (int b = 0; b < 2; b++) {
        snprintf(out[b], sizeof out[b], "%s/cpca_%s.exr", D, b ? "gl" : "cpu");
        snprintf(cmd, sizeof cmd, "%s render %s --probe %s --backend %s -o %s --size 96x72 --no-background 2>&1", B, path, probe,
                 b ? "gl" : "cpu", out[b]);
        CHECK(check_run(cmd, buf, sizeof buf) == 0, "render --backend %s: %s", b ? "gl" : "cpu", buf);
        CHECK(image_read(out[b], &img[b], &err) == 0, "%s", err.msg);
    }
    if (img[0].data && img[1].data && img[0].w == img[1].w && img[0].h == img[1].h) {
        size_t n = (size_t)img[0].w * img[0].h * 3;
        double cmax = 0, *rel = malloc(sizeof(double) * n);
        for (size_t i = 0; i < n; i++) cmax = fmax(cmax, img[0].data[i]);
        for (size_t i = 0; i < n; i++) rel[i] = fabs(img[1].data[i] - img[0].data[i]) / (fabs(img[0].data[i]) + 1e-3 * cmax);
        qsort(rel, n, sizeof *rel, cmp_dbl);
        printf("  gl: render --backend gl vs cpu: median rel diff %.2e, 99.9%% %.2e, max %.2e\n", rel[n / 2], rel[n * 999 / 1000],
               rel[n - 1]);
        CHECK(cmax > 0, "black image");
        CHECK_LE(rel[n * 999 / 1000], 1e-4, "gl image differs from cpu's");
        CHECK_LE(rel[n / 2], 1e-5, "median");
        free(rel);
    } else CHECK(0, "two images of one size");
    image_free(&img[0]);
    image_free(&img[1]);
    snprintf(cmd, sizeof cmd, "%s bench %s --probe %s --backend gl --frames 2 --size 32x24 2>&1", B, path, probe);
    CHECK(check_run(cmd, buf, sizeof buf) == 0 && strstr(buf, "bench: backend=gl") && strstr(buf, "kernel=cpu"),
          "bench --backend gl names the cpu method: %s", buf);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(energy);
    CHECK_CASE(light);
    CHECK_CASE(threads);
    CHECK_CASE(round_trip);
    CHECK_CASE(bad_input);
    CHECK_CASE(relight);
    CHECK_CASE_GL(gl);
    return check_summary();
}
