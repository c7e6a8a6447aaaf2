/* test_mesh.c - OBJ parsing, welding, cleanup, normals and procedural shapes.
 *
 * Truths used: hand-counted vertices/triangles for small OBJ texts; the
 * analytic area and enclosed volume (divergence theorem, which also checks the
 * winding) of spheres, boxes, planes and tori; exact radial/axis normals;
 * Euler's formula V - E + F = 2 for closed genus-0 shapes. */
#include "harness.h"
#include "mesh.h"
#include "vec3.h"
#include <stdlib.h>
#include <string.h>

/* check.h's CHECK(cond) without a message expands to fprintf(stderr, ""). */
#pragma GCC diagnostic ignored "-Wformat-zero-length"

static int parse(const char *text, mesh_load_stats *st, prt_mesh *m, prt_error *err) {
    return mesh_parse_obj("t.obj", text, strlen(text), st, m, err);
}

static void write_file(const char *path, const char *text, size_t len) {
    FILE *f = fopen(path, "wb");
    if (!f) { perror(path); exit(2); }
    fwrite(text, 1, len, f);
    fclose(f);
}

/* Sum of triangle areas and the signed enclosed volume sum (a . (b x c)) / 6. */
static void area_volume(const prt_mesh *m, double *area, double *vol) {
    double A = 0, V = 0;
    for (int t = 0; t < m->ntris; t++) {
        const float *a = m->pos + 3 * m->tris[3 * t], *b = m->pos + 3 * m->tris[3 * t + 1], *c = m->pos + 3 * m->tris[3 * t + 2];
        double e1[3], e2[3], n[3];
        for (int k = 0; k < 3; k++) { e1[k] = (double)b[k] - a[k]; e2[k] = (double)c[k] - a[k]; }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1]; n[1] = e1[2] * e2[0] - e1[0] * e2[2]; n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        A += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double bc[3] = { (double)b[1] * c[2] - (double)b[2] * c[1], (double)b[2] * c[0] - (double)b[0] * c[2],
                         (double)b[0] * c[1] - (double)b[1] * c[0] };
        V += (a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2]) / 6.0;
    }
    *area = A;
    *vol = V;
}

/* Unit geometric normal of triangle t. */
static void tri_normal(const prt_mesh *m, int t, float n[3]) {
    const float *a = m->pos + 3 * m->tris[3 * t], *b = m->pos + 3 * m->tris[3 * t + 1], *c = m->pos + 3 * m->tris[3 * t + 2];
    float e1[3], e2[3];
    v3_sub(e1, b, a);
    v3_sub(e2, c, a);
    v3_cross(n, e1, e2);
    v3_normalize(n);
}

static int cmp(const void *x, const void *y) {
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

/* Number of distinct undirected edges (for Euler's formula); every edge must appear exactly twice. */
static int count_edges(const prt_mesh *m, int *bad) {
    int ne = 3 * m->ntris;
    uint64_t *e = malloc((size_t)ne * sizeof *e);
    for (int t = 0; t < m->ntris; t++)
        for (int c = 0; c < 3; c++) {
            uint64_t a = m->tris[3 * t + c], b = m->tris[3 * t + (c + 1) % 3];
            e[3 * t + c] = a < b ? (a << 32 | b) : (b << 32 | a);
        }
    qsort(e, (size_t)ne, sizeof *e, cmp);
    int distinct = 0, run = 0;
    *bad = 0;
    for (int i = 0; i < ne; i++) {
        run++;
        if (i + 1 == ne || e[i + 1] != e[i]) {
            distinct++;
            if (run != 2) (*bad)++;
            run = 0;
        }
    }
    free(e);
    return distinct;
}

static bool all_finite_unit(const prt_mesh *m) {
    for (int v = 0; v < m->nverts; v++) {
        const float *n = m->nrm + 3 * v;
        if (!isfinite(n[0]) || !isfinite(n[1]) || !isfinite(n[2]) || fabsf(v3_len(n) - 1.f) > 1e-5f) return false;
    }
    return true;
}

/* Bit for bit: exact by construction, the same decimals parsed by the same code (strtof rounds
 * correctly, on any CPU) into the same order. */
static bool same_mesh(const prt_mesh *a, const prt_mesh *b) {
    if (a->nverts != b->nverts || a->ntris != b->ntris) return false;
    return memcmp(a->pos, b->pos, 3 * (size_t)a->nverts * sizeof(float)) == 0 &&
           memcmp(a->tris, b->tris, 3 * (size_t)a->ntris * sizeof(uint32_t)) == 0;
}

static void parse_forms(void) {
    prt_mesh m, ref;
    prt_error err = { "" };
    mesh_load_stats st;
    /* One triangle in the xy plane: normal +z everywhere. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &st, &m, &err) == 0, "%s", err.msg);
    CHECK(m.nverts == 3 && m.ntris == 1);
    CHECK(st.obj_vertices == 3 && st.faces == 1 && st.welded == 0 && st.degenerate == 0 && st.unused == 0);
    for (int v = 0; v < 3; v++) {
        CHECK_NEAR(m.nrm[3 * v + 2], 1.0, 1e-6);
        CHECK(m.mat[v] == 0);
    }
    CHECK(m.tris[0] == 0 && m.tris[1] == 1 && m.tris[2] == 2);
    mesh_free(&m);

    /* A unit square as one quad -> 2 triangles of total area 1, both facing +z. */
    const char *quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    CHECK(parse(quad, &st, &ref, &err) == 0, "%s", err.msg);
    CHECK(ref.nverts == 4 && ref.ntris == 2 && st.faces == 1);
    double A, V;
    area_volume(&ref, &A, &V);
    CHECK_NEAR(A, 1.0, 1e-6);
    for (int t = 0; t < ref.ntris; t++) { float n[3]; tri_normal(&ref, t, n); CHECK_NEAR(n[2], 1.0, 1e-6); }

    /* The same quad in every other accepted form gives the identical mesh. */
    const char *forms[] = {
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n",                                 /* negative */
        "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nf 1 2 3 4\r\n",                           /* CRLF */
        "# comment\n\n  v\t0 0 0  \nv 1 0 0 # trailing\nv 1 1 0\nv 0 1 0\n\n\tf\t1 2\t3 4",  /* tabs, no final newline */
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n", /* v/vt */
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n",                /* v//vn */
        "mtllib x.mtl\no quad\ng g1\ns 1\nusemtl red\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 3/1/1 4/1/-1\nl 1 2\n",                                               /* v/vt/vn + ignored */
        "v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",                        /* w, vertex colours */
        "v 0.0e0 0 -0\nv 1. 0 0\nv 1 1.0 0\nv 0 +1 0\nf 1 2 3 4\n",                             /* number syntax, -0 */
    };
    for (size_t i = 0; i < sizeof forms / sizeof forms[0]; i++) {
        int rc = parse(forms[i], &st, &m, &err);
        CHECK(rc == 0, "form %zu: %s", i, err.msg);
        CHECK(rc == 0 && same_mesh(&m, &ref), "form %zu differs", i);
        mesh_free(&m);
    }
    /* In-memory text need not be NUL-terminated: parse a prefix of a longer buffer. */
    const char *longer = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4GARBAGE";
    CHECK(mesh_parse_obj("t.obj", longer, strlen(longer) - 7, &st, &m, &err) == 0, "%s", err.msg);
    CHECK(same_mesh(&m, &ref));
    mesh_free(&m);
    mesh_free(&ref);

    /* A convex pentagon fan-triangulates into 3 triangles with the polygon's area. */
    CHECK(parse("v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n", &st, &m, &err) == 0, "%s", err.msg);
    CHECK(m.ntris == 3);
    area_volume(&m, &A, &V);
    CHECK_NEAR(A, 5.0, 1e-6, "shoelace area of the pentagon is 5");
    for (int t = 0; t < m.ntris; t++) CHECK(m.tris[3 * t] == 0, "fan from the first vertex");
    mesh_free(&m);

    /* Faces may refer forward to vertices defined later in the file. */
    CHECK(parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", &st, &m, &err) == 0, "%s", err.msg);
    CHECK(m.ntris == 1);
    mesh_free(&m);
    /* Negative indices are relative to the vertices read so far, not the file's total. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n", &st, &m, &err) == 0);
    CHECK(m.nverts == 6 && m.ntris == 2 && m.tris[3] == 3 && m.tris[4] == 4 && m.tris[5] == 5);
    mesh_free(&m);
}

static void weld_clean(void) {
    prt_mesh m;
    prt_error err = { "" };
    mesh_load_stats st;
    /* Two triangles of a square, each with its own copies of the shared diagonal
     * (6 'v' lines, 4 distinct points, one written -0): welded to 4 vertices. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv -0 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 4 5 6\n", &st, &m, &err) == 0, "%s", err.msg);
    CHECK(m.nverts == 4 && m.ntris == 2 && st.welded == 2 && st.obj_vertices == 6, "nv %d welded %d", m.nverts, st.welded);
    for (int v = 0; v < 4; v++) CHECK_NEAR(m.nrm[3 * v + 2], 1.0, 1e-6);
    mesh_free(&m);

    /* Nearly equal is not equal: 1 and 1.0000001 stay apart. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 1.0000001 0 0\nv 0 1 0\nf 1 2 4\nf 1 3 4\n", &st, &m, &err) == 0);
    CHECK(m.nverts == 4 && st.welded == 0);
    mesh_free(&m);

    /* Degenerate triangles: repeated index, repeated after welding, collinear,
     * sub-threshold sliver; plus one unused vertex and the vertices only the
     * dropped triangles used. */
    const char *deg =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"     /* 1-3: the good triangle */
        "v 2 0 0\n"                       /* 4: collinear with 1,2 */
        "v 0 0 0\n"                       /* 5: welds onto 1 */
        "v 9 9 9\n"                       /* 6: unused */
        "v 0.5 1e-13 0\n"                 /* 7: sliver apex: 2*area 1e-13 < 1e-12 * diag^2 */
        "f 1 2 3\nf 1 1 2\nf 1 5 3\nf 1 2 4\nf 1 2 7\n";
    CHECK(parse(deg, &st, &m, &err) == 0, "%s", err.msg);
    CHECK(m.ntris == 1 && st.degenerate == 4, "ntris %d degenerate %d", m.ntris, st.degenerate);
    CHECK(m.nverts == 3 && st.welded == 1 && st.unused == 3, "nverts %d unused %d", m.nverts, st.unused);
    float bmin[3], bmax[3];
    mesh_bounds(&m, bmin, bmax);
    CHECK(bmax[0] == 1.f && bmax[1] == 1.f && bmin[0] == 0.f, "the unused vertex is gone from the bounds");
    mesh_free(&m);

    /* A small but real triangle far from the sliver threshold survives. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1e-4\nv 1e-4 0 1e-4\nv 0 1e-4 1e-4\nf 1 2 3\nf 4 5 6\n", &st, &m, &err) == 0);
    CHECK(m.ntris == 2 && st.degenerate == 0);
    mesh_free(&m);

    /* Every triangle degenerate -> an error, not an empty mesh. */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", &st, &m, &err) == -1);
    CHECK(strstr(err.msg, "t.obj") && strstr(err.msg, "degenerate"), "%s", err.msg);
    CHECK(m.nverts == 0 && m.pos == NULL);
}

static void expect_error(const char *label, const char *path, const char *text, const char *needle) {
    prt_mesh m;
    prt_error err = { "" };
    mesh_load_stats st;
    if (text) write_file(path, text, strlen(text));
    int rc = mesh_load_obj(path, &st, &m, &err);
    CHECK(rc == -1, "%s: rc %d", label, rc);
    CHECK(strstr(err.msg, path) != NULL, "%s: message '%s' names the file", label, err.msg);
    CHECK(needle == NULL || strstr(err.msg, needle) != NULL, "%s: message '%s' lacks '%s'", label, err.msg, needle);
    CHECK(strchr(err.msg, '\n') == NULL && m.nverts == 0 && m.ntris == 0 && m.pos == NULL && m.tris == NULL, "%s", label);
    printf("  %-22s -> %s\n", label, err.msg);
    mesh_free(&m);
}

static void errors(void) {
    const char *d = check_tmpdir();
    char p[512];
    snprintf(p, sizeof p, "%s/missing.obj", d);
    expect_error("missing file", p, NULL, "cannot open");
    expect_error("directory", d, NULL, "not a regular file");
    snprintf(p, sizeof p, "%s/empty.obj", d);
    expect_error("empty file", p, "", "no triangles");
    snprintf(p, sizeof p, "%s/comments.obj", d);
    expect_error("only comments", p, "# nothing\n# here\n\n", "no triangles");
    snprintf(p, sizeof p, "%s/vonly.obj", d);
    expect_error("vertices, no faces", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangles");
    snprintf(p, sizeof p, "%s/nan.obj", d);
    expect_error("NaN coordinate", p, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", ":2: non-finite");
    snprintf(p, sizeof p, "%s/inf.obj", d);
    expect_error("Inf coordinate", p, "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n", ":3: non-finite");
    snprintf(p, sizeof p, "%s/range.obj", d);
    expect_error("index out of range", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", ":5: face index 4 out of range");
    snprintf(p, sizeof p, "%s/huge.obj", d);
    expect_error("index overflow", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", ":4:");
    snprintf(p, sizeof p, "%s/neg.obj", d);
    expect_error("negative too far", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", ":4: bad face index -4");
    snprintf(p, sizeof p, "%s/zero.obj", d);
    expect_error("index 0", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4: bad face index 0");
    snprintf(p, sizeof p, "%s/garbage.obj", d);
    expect_error("garbage face token", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", ":4: bad face vertex 'x'");
    snprintf(p, sizeof p, "%s/garbage2.obj", d);
    expect_error("garbage line", p, "v 0 0 0\nhello world\n", ":2: unknown statement 'hello'");
    snprintf(p, sizeof p, "%s/garbage3.obj", d);
    expect_error("garbage coordinate", p, "v 0 0 0\nv 1 0 zz\n", ":2: bad vertex coordinate 'zz'");
    snprintf(p, sizeof p, "%s/glued.obj", d);
    expect_error("glued number", p, "v 0 0 0\nv 1 0 0x\n", ":2: bad vertex coordinate");
    snprintf(p, sizeof p, "%s/short.obj", d);
    expect_error("two coordinates", p, "v 0 0\n", ":1: vertex needs 3 coordinates");
    snprintf(p, sizeof p, "%s/twoface.obj", d);
    expect_error("two-vertex face", p, "v 0 0 0\nv 1 0 0\nf 1 2\n", ":3: face with 2 vertices");
    snprintf(p, sizeof p, "%s/slash.obj", d);
    expect_error("bad slash form", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2 3\n", ":4: bad face vertex '1/'");
    snprintf(p, sizeof p, "%s/vt0.obj", d);
    expect_error("texture index 0", p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/0 2/1 3/1\n", ":4:");
    snprintf(p, sizeof p, "%s/binary.obj", d);
    write_file(p, "v 0 0 0\nv 1\0 0 0\n", 17);
    expect_error("NUL byte", p, NULL, ":2:");
    {
        /* Random bytes never crash the parser (they must either parse or fail cleanly). */
        uint32_t s = 12345;
        char buf[600];
        const char alphabet[] = "vf 0123456789-./#\n\r\tenai";
        for (int trial = 0; trial < 300; trial++) {
            for (size_t i = 0; i < sizeof buf; i++) {
                s = s * 1664525u + 1013904223u;
                buf[i] = alphabet[(s >> 16) % (sizeof alphabet - 1)];
            }
            prt_mesh m;
            prt_error err = { "" };
            int rc = mesh_parse_obj("fuzz.obj", buf, sizeof buf, NULL, &m, &err);
            if (rc == 0) { CHECK(all_finite_unit(&m) && m.ntris > 0); }
            else { CHECK(strncmp(err.msg, "fuzz.obj", 8) == 0, "%s", err.msg); }
            mesh_free(&m);
        }
    }
}

static void load_file_and_weld_scale(void) {
    /* Write a 64x128 UV sphere as a triangle soup (every triangle has its own
     * three 'v' lines), with quads for the body: loading must weld it back to
     * exactly the procedural vertex set. */
    prt_mesh s, m;
    prt_error err = { "" };
    mesh_load_stats st;
    const float c[3] = { 0.5f, -1.f, 2.f };
    CHECK(mesh_make_sphere(&s, c, 1.5f, 64, 128, &err) == 0, "%s", err.msg);
    size_t cap = (size_t)s.ntris * 3 * 64 + 64, len = 0;
    char *text = malloc(cap);
    for (int t = 0; t < s.ntris; t++) {
        for (int k = 0; k < 3; k++) {
            const float *p = s.pos + 3 * s.tris[3 * t + k];
            len += (size_t)snprintf(text + len, cap - len, "v %.9g %.9g %.9g\n", p[0], p[1], p[2]);
        }
        len += (size_t)snprintf(text + len, cap - len, "f -3 -2 -1\n");
    }
    char path[512];
    snprintf(path, sizeof path, "%s/soup.obj", check_tmpdir());
    write_file(path, text, len);
    double t0 = prt_now();
    int rc = mesh_load_obj(path, &st, &m, &err);
    double dt = prt_now() - t0;
    CHECK(rc == 0, "%s", err.msg);
    printf("  soup: %d 'v' lines -> %d vertices, %d triangles, %.1f ms (%.1f MB)\n", st.obj_vertices, m.nverts,
           m.ntris, 1e3 * dt, len / 1e6);
    CHECK(m.nverts == s.nverts && m.ntris == s.ntris && st.welded == 3 * s.ntris - s.nverts && st.degenerate == 0);
    /* Same vertices in the same (first-appearance) order as the written triangles. */
    int mismatched = 0;
    for (int t = 0; t < m.ntris; t++)
        for (int k = 0; k < 3; k++)
            if (memcmp(m.pos + 3 * m.tris[3 * t + k], s.pos + 3 * s.tris[3 * t + k], 12) != 0) mismatched++;
    CHECK(mismatched == 0);
    /* Recomputed normals on the welded sphere are radial. */
    double worst = 0;
    for (int v = 0; v < m.nverts; v++) {
        float r[3];
        v3_sub(r, m.pos + 3 * v, c);
        v3_normalize(r);
        double d = v3_len((float[3]){ r[0] - m.nrm[3 * v], r[1] - m.nrm[3 * v + 1], r[2] - m.nrm[3 * v + 2] });
        if (d > worst) worst = d;
    }
    printf("  sphere 64x128: worst |computed - radial normal| %.2e\n", worst);
    CHECK_LE(worst, 1e-3, "|computed normal - radial|");
    free(text);
    mesh_free(&m);
    mesh_free(&s);
}

static void normals(void) {
    /* A fin: vertex 0's two triangles face +z (angle 90, area 0.5) and -z (angle
     * 90, area 1). They cancel; the larger one's normal (-z) wins. */
    float pos[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 2, 0, 5, 5, 5, 6, 5, 5, 7, 5, 5 };
    uint32_t tris[] = { 0, 1, 2, 0, 3, 1, 4, 5, 6 };
    float nrm[21];
    uint16_t mat[7] = { 0 };
    prt_mesh m = { .nverts = 7, .ntris = 3, .pos = pos, .nrm = nrm, .tris = tris, .mat = mat };
    mesh_compute_normals(&m);
    CHECK(all_finite_unit(&m), "no NaN, all unit");
    CHECK_NEAR(nrm[2], -1.0, 1e-6, "cancelling vertex takes its largest triangle's normal");
    CHECK_NEAR(nrm[3 * 2 + 2], 1.0, 1e-6, "vertex 2 only touches the +z triangle");
    CHECK_NEAR(nrm[3 * 3 + 2], -1.0, 1e-6, "vertex 3 only touches the -z triangle");
    /* Vertices 4..6 only have a collinear (zero-area) triangle: +y. */
    for (int v = 4; v < 7; v++) CHECK(nrm[3 * v] == 0.f && nrm[3 * v + 1] == 1.f && nrm[3 * v + 2] == 0.f);

    /* Angle weighting: a vertex with one big 90-degree wedge on +z and two small
     * 45-degree wedges tilted by 90 degrees ... checked against the formula. */
    float p2[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    uint32_t t2[] = { 0, 1, 2, 0, 2, 3 }; /* +z face (angle pi/2 at 0), +x face (angle pi/2 at 0) */
    float n2[12];
    prt_mesh m2 = { .nverts = 4, .ntris = 2, .pos = p2, .nrm = n2, .tris = t2 };
    mesh_compute_normals(&m2);
    CHECK_NEAR(n2[0], M_SQRT1_2, 1e-6);
    CHECK_NEAR(n2[2], M_SQRT1_2, 1e-6);
    /* Vertex 2 (0,1,0): angle pi/4 in both triangles, same answer; vertex 1 only +z. */
    CHECK_NEAR(n2[6], M_SQRT1_2, 1e-6);
    CHECK_NEAR(n2[3 + 2], 1.0, 1e-6);
    /* Unequal angles: move vertex 3 to (0,0,3): at vertex 2 the +x-face angle is
     * atan2(|e1 x e2|, e1.e2) with e1=(0,-1,0), e2=(0,-1,3) -> atan(3); the +z
     * face's angle there is pi/4. Weighted sum normalized: */
    p2[11] = 3;
    mesh_compute_normals(&m2);
    double wz = M_PI / 4, wx = atan(3.0), l = sqrt(wz * wz + wx * wx);
    CHECK_NEAR(n2[6], wx / l, 1e-6);
    CHECK_NEAR(n2[8], wz / l, 1e-6);
}

static void sphere(void) {
    prt_mesh m;
    prt_error err = { "" };
    const float c[3] = { 1.f, 2.f, -3.f };
    const float r = 2.f;
    CHECK(mesh_make_sphere(&m, c, r, 32, 64, &err) == 0, "%s", err.msg);
    CHECK(m.nverts == 2 + 31 * 64 && m.ntris == 2 * 64 * 31);
    int bad;
    int ne = count_edges(&m, &bad);
    CHECK(bad == 0 && m.nverts - ne + m.ntris == 2, "closed, genus 0: V-E+F = %d", m.nverts - ne + m.ntris);
    double worst = 0, worst_exact = 0;
    for (int v = 0; v < m.nverts; v++) {
        float d[3];
        v3_sub(d, m.pos + 3 * v, c);
        CHECK_NEAR(v3_len(d), r, 2e-6 * r);
        v3_normalize(d);
        double e = 1.0 - v3_dot(d, m.nrm + 3 * v);
        if (e > worst_exact) worst_exact = e;
    }
    CHECK_LE(worst_exact, 1e-6, "stored normals are radial");
    /* Outward winding: every triangle's geometric normal points away from the centre. */
    int inward = 0;
    for (int t = 0; t < m.ntris; t++) {
        float n[3], d[3];
        tri_normal(&m, t, n);
        v3_sub(d, m.pos + 3 * m.tris[3 * t], c);
        if (v3_dot(n, d) <= 0) inward++;
    }
    CHECK(inward == 0, "%d triangles wound inward", inward);
    /* Recomputed (angle-weighted) normals are radial up to the O(h^2)
     * discretization error, h = pi/32 here (1e-3 at 64x128: see the soup test). */
    mesh_compute_normals(&m);
    for (int v = 0; v < m.nverts; v++) {
        float d[3];
        v3_sub(d, m.pos + 3 * v, c);
        v3_normalize(d);
        double e = v3_len((float[3]){ d[0] - m.nrm[3 * v], d[1] - m.nrm[3 * v + 1], d[2] - m.nrm[3 * v + 2] });
        if (e > worst) worst = e;
    }
    CHECK_LE(worst, 2e-3, "|computed normal - radial|");
    printf("  sphere 32x64: worst |computed - radial normal| %.2e\n", worst);
    /* Area and enclosed volume approach the sphere's from below (inscribed polyhedron). */
    double A, V;
    area_volume(&m, &A, &V);
    double A0 = 4 * M_PI * r * r, V0 = 4.0 / 3.0 * M_PI * r * r * r;
    CHECK(A < A0 && A > 0.99 * A0, "area %g vs %g", A, A0);
    /* Signed volume about the origin equals the enclosed volume for a closed mesh. */
    CHECK(V < V0 && V > 0.985 * V0, "volume %g vs %g", V, V0);
    float bmin[3], bmax[3];
    mesh_bounds(&m, bmin, bmax);
    for (int k = 0; k < 3; k++) {
        CHECK_NEAR(bmin[k], c[k] - r, 1e-5);
        CHECK_NEAR(bmax[k], c[k] + r, 1e-5);
    }
    mesh_free(&m);
    CHECK(mesh_make_sphere(&m, c, 0.f, 8, 8, &err) == -1 && strstr(err.msg, "radius"), "%s", err.msg);
    CHECK(mesh_make_sphere(&m, c, 1.f, 1, 8, &err) == -1 && m.pos == NULL);
}

static void plane(void) {
    prt_mesh m;
    prt_error err = { "" };
    CHECK(mesh_make_plane(&m, -2.f, 3.f, -1.f, 1.f, 0.25f, 11, 5, &err) == 0, "%s", err.msg);
    CHECK(m.nverts == 55 && m.ntris == 2 * 10 * 4);
    for (int v = 0; v < m.nverts; v++) {
        CHECK(m.nrm[3 * v] == 0.f && m.nrm[3 * v + 1] == 1.f && m.nrm[3 * v + 2] == 0.f);
        CHECK(m.pos[3 * v + 1] == 0.25f);
    }
    int down = 0;
    for (int t = 0; t < m.ntris; t++) { float n[3]; tri_normal(&m, t, n); if (!(n[1] > 0.999f)) down++; }
    CHECK(down == 0, "%d triangles not counter-clockwise seen from +y", down);
    double A, V;
    area_volume(&m, &A, &V);
    CHECK_NEAR(A, 10.0, 1e-5);
    float bmin[3], bmax[3];
    mesh_bounds(&m, bmin, bmax);
    CHECK(bmin[0] == -2.f && bmax[0] == 3.f && bmin[2] == -1.f && bmax[2] == 1.f && bmin[1] == 0.25f && bmax[1] == 0.25f);
    mesh_compute_normals(&m);
    for (int v = 0; v < m.nverts; v++) CHECK_NEAR(m.nrm[3 * v + 1], 1.0, 1e-6);
    mesh_free(&m);
    CHECK(mesh_make_plane(&m, 1.f, 0.f, 0.f, 1.f, 0.f, 4, 4, &err) == -1, "empty extent");
    CHECK(mesh_make_plane(&m, 0.f, 1.f, 0.f, 1.f, 0.f, 1, 4, &err) == -1, "one column");
}

/* mesh_vertex_areas: a 3-4-5 triangle (area 6) gives each of its vertices 2 and an unused vertex 0
 * (exact: the cross product, sqrt(144) and 12 / 6 are exact in IEEE double on any CPU); over the
 * 11 x 5 plane (0.5 steps, exact in float) the areas sum to its 10: each of the 80 triangles' thirds
 * is one rounding of 0.25 / 6, so the 240 additions err by at most about 240 x 10 x 2^-53 = 3e-13. */
static void vertex_areas(void) {
    prt_error err = { "" };
    float pos[] = { 0, 0, 0, 3, 0, 0, 0, 4, 0, 9, 9, 9 }, nrm[12] = { 0 };
    uint32_t tris[] = { 0, 1, 2 };
    prt_mesh t = { .pos = pos, .nrm = nrm, .tris = tris, .nverts = 4, .ntris = 1 };
    double a[4];
    mesh_vertex_areas(&t, a);
    CHECK(a[0] == 2.0 && a[1] == 2.0 && a[2] == 2.0 && a[3] == 0.0, "%g %g %g %g", a[0], a[1], a[2], a[3]);
    prt_mesh m;
    CHECK(mesh_make_plane(&m, -2.f, 3.f, -1.f, 1.f, 0.25f, 11, 5, &err) == 0, "%s", err.msg);
    double *area = malloc(sizeof *area * (size_t)m.nverts), sum = 0;
    if (!area) { mesh_free(&m); CHECK(0, "out of memory"); return; }
    mesh_vertex_areas(&m, area);
    int zero = 0;
    for (int v = 0; v < m.nverts; v++) sum += area[v], zero += !(area[v] > 0);
    CHECK_NEAR(sum, 10.0, 1e-12);
    CHECK(zero == 0, "%d vertices without area", zero);
    free(area);
    mesh_free(&m);
}

static void box(void) {
    prt_mesh m;
    prt_error err = { "" };
    const float lo[3] = { -1.f, 0.f, 2.f }, hi[3] = { 1.f, 3.f, 6.f };
    float ctr[3] = { 0.f, 1.5f, 4.f };
    for (int open = 0; open < 2; open++) {
        int n = 3;
        CHECK(mesh_make_box(&m, lo, hi, n, open, &err) == 0, "%s", err.msg);
        int nf = open ? 5 : 6;
        CHECK(m.nverts == nf * 16 && m.ntris == nf * 2 * 9);
        int bad_n = 0, bad_w = 0, top = 0;
        for (int v = 0; v < m.nverts; v++) {
            const float *p = m.pos + 3 * v, *nn = m.nrm + 3 * v;
            /* The normal is the axis of a face the vertex lies on, pointing out. */
            int ax = fabsf(nn[0]) == 1.f ? 0 : fabsf(nn[1]) == 1.f ? 1 : 2;
            if (fabsf(v3_len(nn) - 1.f) > 0 || p[ax] != (nn[ax] > 0 ? hi[ax] : lo[ax])) bad_n++;
            if (nn[1] > 0) top++;
        }
        for (int t = 0; t < m.ntris; t++) {
            float g[3], d[3];
            tri_normal(&m, t, g);
            v3_sub(d, m.pos + 3 * m.tris[3 * t], ctr);
            const float *nn = m.nrm + 3 * m.tris[3 * t];
            if (v3_dot(g, nn) < 0.9999f || v3_dot(g, d) <= 0) bad_w++;
        }
        CHECK(bad_n == 0 && bad_w == 0, "normals off %d, winding off %d", bad_n, bad_w);
        CHECK(open ? top == 0 : top == 16, "top face vertices %d", top);
        double A, V;
        area_volume(&m, &A, &V);
        double Afull = 2 * (2 * 3 + 3 * 4 + 2 * 4);
        CHECK_NEAR(A, open ? Afull - 8 : Afull, 1e-4);
        if (!open) {
            CHECK_NEAR(V, 24.0, 1e-4, "divergence-theorem volume of the closed box");
            /* Faces do not share vertices: each face is its own 4x4 grid; edges
             * along the box edges appear once. */
            int bad;
            count_edges(&m, &bad);
            CHECK(bad == 6 * 4 * n, "open boundary edges %d", bad);
        }
        float bmin[3], bmax[3];
        mesh_bounds(&m, bmin, bmax);
        for (int k = 0; k < 3; k++) CHECK(bmin[k] == lo[k] && bmax[k] == hi[k]);
        mesh_free(&m);
    }
    CHECK(mesh_make_box(&m, hi, lo, 2, false, &err) == -1, "inverted box");
    CHECK(mesh_make_box(&m, lo, hi, 0, false, &err) == -1, "n = 0");
}

static void torus(void) {
    prt_mesh m;
    prt_error err = { "" };
    const float c[3] = { 0.f, 1.f, 0.f };
    float R = 2.f, r = 0.5f;
    CHECK(mesh_make_torus(&m, c, R, r, 96, 48, &err) == 0, "%s", err.msg);
    CHECK(m.nverts == 96 * 48 && m.ntris == 2 * 96 * 48);
    int bad;
    int ne = count_edges(&m, &bad);
    CHECK(bad == 0 && m.nverts - ne + m.ntris == 0, "closed, genus 1");
    double worst = 0;
    for (int v = 0; v < m.nverts; v++) {
        const float *p = m.pos + 3 * v;
        float q[3] = { p[0] - c[0], 0.f, p[2] - c[2] };
        v3_normalize(q);
        float tube[3] = { c[0] + R * q[0], c[1], c[2] + R * q[2] }, d[3];
        v3_sub(d, p, tube);
        CHECK_NEAR(v3_len(d), r, 1e-5);
        v3_normalize(d);
        double e = 1.0 - v3_dot(d, m.nrm + 3 * v);
        if (e > worst) worst = e;
    }
    CHECK_LE(worst, 1e-6, "stored normals point away from the tube's centre line");
    double A, V;
    area_volume(&m, &A, &V);
    double A0 = 4 * M_PI * M_PI * R * r, V0 = 2 * M_PI * M_PI * R * r * r;
    CHECK(A < A0 && A > 0.995 * A0, "area %g vs %g", A, A0);
    CHECK(V < V0 && V > 0.99 * V0, "volume %g vs %g (positive: outward winding)", V, V0);
    float n0[3];
    v3_copy(n0, m.nrm);
    mesh_compute_normals(&m);
    CHECK(all_finite_unit(&m));
    CHECK_NEAR(v3_dot(n0, m.nrm), 1.0, 1e-3);
    mesh_free(&m);
    CHECK(mesh_make_torus(&m, c, R, -1.f, 8, 8, &err) == -1);
}

static void transform_append_copy(void) {
    prt_mesh a, b, c;
    prt_error err = { "" };
    const float ctr[3] = { 0.f, 0.f, 0.f };
    CHECK(mesh_make_sphere(&a, ctr, 1.f, 8, 16, &err) == 0);
    CHECK(mesh_copy(&b, &a, &err) == 0);
    CHECK(same_mesh(&a, &b) && b.pos != a.pos && b.nrm != a.nrm && b.tris != a.tris);
    /* Rotation by +90 degrees about y (x -> -z, z -> x), scale 2, translate (1,2,3). */
    const float R[9] = { 0, 0, 1, 0, 1, 0, -1, 0, 0 }, t[3] = { 1, 2, 3 };
    mesh_transform(&b, R, 2.f, t);
    CHECK(a.pos[0] == 0.f && a.pos[1] == 1.f, "source untouched");
    CHECK_NEAR(b.pos[1], 4.0, 1e-6, "north pole (0,1,0) -> (1,4,3)");
    CHECK_NEAR(b.pos[0], 1.0, 1e-6);
    CHECK_NEAR(b.pos[2], 3.0, 1e-6);
    /* Vertex 1 is on the first ring at phi 0, i.e. +x side: after R its normal points to -z. */
    const float *n1 = a.nrm + 3, *m1 = b.nrm + 3;
    CHECK_NEAR(m1[0], n1[2], 1e-6);
    CHECK_NEAR(m1[1], n1[1], 1e-6);
    CHECK_NEAR(m1[2], -n1[0], 1e-6);
    double A0, V0, A1, V1;
    area_volume(&a, &A0, &V0);
    area_volume(&b, &A1, &V1);
    CHECK_NEAR(A1, 4 * A0, 1e-4 * A1);
    /* About a moved origin the signed volume of a closed mesh is unchanged: 8x. */
    CHECK_NEAR(V1, 8 * V0, 1e-4 * V1);
    /* A mirror (negative scale) keeps the winding outward and normals outward. */
    const float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 }, z[3] = { 0, 0, 0 };
    CHECK(mesh_copy(&c, &a, &err) == 0);
    mesh_transform(&c, I, -1.f, z);
    area_volume(&c, &A1, &V1);
    CHECK_NEAR(V1, V0, 1e-5, "volume positive after a mirror");
    CHECK_NEAR(c.pos[1], -1.0, 1e-6, "the pole (0,1,0) moved to (0,-1,0) ...");
    CHECK_NEAR(c.nrm[1], -1.0, 1e-6, "... with its normal still pointing out");
    for (int k = 0; k < 3; k++) CHECK_NEAR(c.nrm[3 + k], -n1[k], 1e-6, "a ring vertex's normal is the negated original");
    mesh_free(&c);

    /* Append: counts add, indices offset, materials kept. */
    for (int v = 0; v < b.nverts; v++) b.mat[v] = 3;
    int nv = a.nverts, nt = a.ntris;
    CHECK(mesh_append(&a, &b, &err) == 0);
    CHECK(a.nverts == 2 * nv && a.ntris == 2 * nt);
    CHECK(a.tris[3 * nt] == b.tris[0] + (uint32_t)nv && a.tris[3 * a.ntris - 1] == b.tris[3 * nt - 1] + (uint32_t)nv);
    CHECK(a.mat[0] == 0 && a.mat[nv] == 3 && a.mat[2 * nv - 1] == 3);
    CHECK(memcmp(a.pos + 3 * nv, b.pos, 3 * (size_t)nv * sizeof(float)) == 0);
    float bmin[3], bmax[3];
    mesh_bounds(&a, bmin, bmax);
    CHECK_NEAR(bmin[1], -1.0, 1e-6);
    CHECK_NEAR(bmax[1], 4.0, 1e-6);
    CHECK_NEAR(bmax[2], 5.0, 1e-5);
    /* Appending to an empty (zeroed) mesh works. */
    prt_mesh e = { 0 };
    CHECK(mesh_append(&e, &b, &err) == 0 && same_mesh(&e, &b));
    mesh_free(&e);
    mesh_bounds(&e, bmin, bmax);
    CHECK(bmin[0] == 0.f && bmax[0] == 0.f, "bounds of an empty mesh");
    mesh_free(&a);
    mesh_free(&b);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(parse_forms);
    CHECK_CASE(weld_clean);
    CHECK_CASE(errors);
    CHECK_CASE(load_file_and_weld_scale);
    CHECK_CASE(normals);
    CHECK_CASE(sphere);
    CHECK_CASE(plane);
    CHECK_CASE(vertex_areas);
    CHECK_CASE(box);
    CHECK_CASE(torus);
    CHECK_CASE(transform_append_copy);
    return check_summary();
}
