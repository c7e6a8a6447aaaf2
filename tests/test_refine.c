/* test_refine.c - adaptive refinement where visibility changes (refine.h).
 *
 * box_shadow: a plane under a floating box, one level. The independent truth is the
 * geometry: for every mask direction w (a light direction), the box's hard shadow on the
 * plane is the set of points whose ray along w meets the box (an analytic slab test, not
 * Embree), and a plane edge's differing share is the fraction of directions whose shadow
 * boundary separates its two endpoints. Every edge above the threshold must be split and
 * none below it (one direction of slack either way, for rays grazing the box's edges);
 * so new vertices lie where the box's shadows for many light directions have their
 * boundaries, and none farther out, where fewer shadow boundaries pass.
 * no_cracks: several levels on a sphere and a plane under a square; every edge of the refined
 * mesh lies on an input edge or inside an input triangle and is used as often as that
 * input edge (2 inside, 1 on the boundary), inside edges once in each direction, no vertex
 * lies inside a refined edge (no T-junction), and the total area is the input's.
 * floor_order: the floor's vertices stay last and on the floor plane; model indices keep.
 * parts: the floor's edges only by default where there is a floor, the models' too on request.
 * deterministic: two runs, and 1 vs 2 threads, give byte-identical meshes.
 * budget: a budget below what the marked edges want is met exactly, largest first.
 * precompute: the pipeline with refinement stores the refined mesh and says so in the plan.
 * cli_flags: bad refinement flags are refused with one line and exit 2, no output. */
#include "harness.h"
#include "cubemap.h"
#include "precompute.h"
#include "refine.h"
#include "scene.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* bounds that no ray through the plane's grid vertices along a mask direction grazes exactly */
#define BOX_LO_X -0.23
#define BOX_HI_X 0.19
#define BOX_LO_Y 0.31
#define BOX_HI_Y 0.47
#define BOX_LO_Z -0.21
#define BOX_HI_Z 0.22

static const char k_box_plane[] =
    "{ \"models\": [ { \"box\": { \"min\": [-0.23, 0.31, -0.21], \"max\": [0.19, 0.47, 0.22], \"n\": 1 } },\n"
    "                { \"plane\": { \"x\": [-2, 2], \"z\": [-2, 2], \"height\": 0, \"nx\": 33, \"nz\": 33 } } ] }";

static const char k_sphere_plane[] =
    "{ \"models\": [ { \"plane\": { \"x\": [-0.3, 0.3], \"z\": [-0.3, 0.3], \"height\": 0.6, \"nx\": 3, \"nz\": 3 } },\n"
    "                { \"sphere\": { \"center\": [0.35, 0.2, 0.1], \"radius\": 0.15, \"rings\": 8, \"segments\": 16 } },\n"
    "                { \"plane\": { \"x\": [-1, 1], \"z\": [-1, 1], \"height\": 0, \"nx\": 13, \"nz\": 13 } } ] }";

static int load(const char *json, prt_scene *s) {
    prt_error err;
    int rc = scene_parse_json("test.json", json, strlen(json), NULL, s, &err);
    CHECK(rc == 0, "%s", err.msg);
    return rc;
}

/* Does the ray p + t w (t > 0) meet the box? (slab test) */
static bool hits_box(const double p[3], const float w[3]) {
    const double lo[3] = { BOX_LO_X, BOX_LO_Y, BOX_LO_Z }, hi[3] = { BOX_HI_X, BOX_HI_Y, BOX_HI_Z };
    double t0 = 0, t1 = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (w[k] == 0) {
            if (p[k] < lo[k] || p[k] > hi[k]) return false;
            continue;
        }
        double a = (lo[k] - p[k]) / w[k], b = (hi[k] - p[k]) / w[k];
        if (a > b) { double x = a; a = b; b = x; }
        if (a > t0) t0 = a;
        if (b < t1) t1 = b;
    }
    return t0 <= t1;
}

/* Index of a vertex at exactly position p, or -1. */
static int find_vertex(const prt_mesh *m, const float p[3]) {
    for (int v = 0; v < m->nverts; v++)
        if (m->pos[3 * v] == p[0] && m->pos[3 * v + 1] == p[1] && m->pos[3 * v + 2] == p[2]) return v;
    return -1;
}

/* Directed uses of edge (a, b) in m: *fwd as a->b, *bwd as b->a. */
static void edge_uses(const prt_mesh *m, uint32_t a, uint32_t b, int *fwd, int *bwd) {
    *fwd = *bwd = 0;
    for (int t = 0; t < m->ntris; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t x = m->tris[3 * t + k], y = m->tris[3 * t + (k + 1) % 3];
            *fwd += x == a && y == b;
            *bwd += x == b && y == a;
        }
}

static void box_shadow(void) {
    prt_scene s = { 0 };
    if (load(k_box_plane, &s)) return;
    prt_mesh in = { 0 };
    prt_error err;
    CHECK(mesh_copy(&in, &s.mesh, &err) == 0);
    const int first_plane = 24;   /* the box (n = 1): 6 faces x 4 vertices, then the plane */
    const int res = 32;
    refine_desc d = { .threshold = 0.005f, .max_levels = 1, .budget = 100000 };
    refine_stats st;
    CHECK(refine_scene(&s, &d, &st, &err) == 0, "%s", err.msg);
    int nup = 0;
    float dirs[6 * 32 * 32][3];
    for (int i = 0; i < 6 * res * res; i++) {
        cube_texel_dir(res, i, dirs[i]);
        nup += dirs[i][1] > REFINE_MIN_COS;
    }
    int split = 0, kept = 0, ambiguous = 0, wrong = 0;
    double far_split = 0;
    for (int t = 0; t < in.ntris; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = in.tris[3 * t + k], b = in.tris[3 * t + (k + 1) % 3];
            int fwd, bwd;
            edge_uses(&in, a, b, &fwd, &bwd);
            if ((int)a < first_plane || (bwd > 0 && a > b)) continue;   /* plane edges, each once */
            double pa[3], pb[3];
            float mid[3];
            for (int c = 0; c < 3; c++) {
                pa[c] = in.pos[3 * a + c];
                pb[c] = in.pos[3 * b + c];
                mid[c] = 0.5f * (in.pos[3 * a + c] + in.pos[3 * b + c]);
            }
            int nd = 0;
            for (int i = 0; i < 6 * res * res; i++)
                if (dirs[i][1] > REFINE_MIN_COS) nd += hits_box(pa, dirs[i]) != hits_box(pb, dirs[i]);
            bool was_split = find_vertex(&s.mesh, mid) >= 0;
            double lo = (nd - 1.0) / nup, hi = (nd + 1.0) / nup;
            if (lo > d.threshold) { wrong += !was_split; split++; }
            else if (hi <= d.threshold) { wrong += was_split; kept++; }
            else ambiguous++;
            if (was_split) far_split = fmax(far_split, fmax(fabs(mid[0]), fabs(mid[2])));
        }
    CHECK(wrong == 0, "%d plane edges split against the analytic shadow-boundary count (of %d clear splits, %d clear keeps)",
          wrong, split, kept);
    CHECK(split >= 20 && kept >= 200, "a non-trivial case: %d edges to split, %d to keep", split, kept);
    CHECK_LE(ambiguous, 0.08 * (split + kept), "edges within one direction of the threshold");
    CHECK(st.levels == 1 && st.verts_after > st.verts_before && !st.budget_hit, "levels %d", st.levels);
    printf("  box over plane: %d plane edges split, %d kept, %d within one direction of the threshold; "
           "farthest split at |x|,|z| <= %.3f (plane to 2); %d -> %d vertices\n",
           split, kept, ambiguous, far_split, st.verts_before, st.verts_after);
    mesh_free(&in);
    scene_free(&s);
}

/* Is q on segment [a, b] (within tol of the line and between the ends)? */
static bool on_segment(const float *a, const float *b, const float *q, double tol, bool strict) {
    double ab[3], aq[3], l2 = 0, t = 0;
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k];
        aq[k] = q[k] - a[k];
        l2 += ab[k] * ab[k];
        t += ab[k] * aq[k];
    }
    if (l2 == 0) return false;
    t /= l2;
    double lim = strict ? 1e-4 : -1e-6;
    if (t < lim || t > 1 - lim) return false;
    double d2 = 0;
    for (int k = 0; k < 3; k++) d2 += (aq[k] - t * ab[k]) * (aq[k] - t * ab[k]);
    return d2 <= tol * tol;
}

static double tri_area(const prt_mesh *m, int t) {
    const float *a = m->pos + 3 * m->tris[3 * t], *b = m->pos + 3 * m->tris[3 * t + 1], *c = m->pos + 3 * m->tris[3 * t + 2];
    double u[3], v[3];
    for (int k = 0; k < 3; k++) { u[k] = b[k] - a[k]; v[k] = c[k] - a[k]; }
    double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2], z = u[0] * v[1] - u[1] * v[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

/* Uses of the input edge that contains refined edge (p, q), or 2 when it lies inside a triangle. */
static int input_uses(const prt_mesh *in, const float *p, const float *q) {
    for (int t = 0; t < in->ntris; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = in->tris[3 * t + k], b = in->tris[3 * t + (k + 1) % 3];
            const float *pa = in->pos + 3 * a, *pb = in->pos + 3 * b;
            if (on_segment(pa, pb, p, 1e-6, false) && on_segment(pa, pb, q, 1e-6, false)) {
                int f, r;
                edge_uses(in, a, b, &f, &r);
                return f + r;
            }
        }
    return 2;
}

static void no_cracks(void) {
    prt_scene s = { 0 };
    if (load(k_sphere_plane, &s)) return;
    prt_mesh in = { 0 };
    prt_error err;
    CHECK(mesh_copy(&in, &s.mesh, &err) == 0);
    refine_desc d = { .max_levels = 3, .budget = 2500 };
    refine_stats st;
    CHECK(refine_scene(&s, &d, &st, &err) == 0, "%s", err.msg);
    const prt_mesh *m = &s.mesh;
    CHECK(st.levels >= 2 && m->nverts > in.nverts + 100, "levels %d, %d -> %d vertices", st.levels, in.nverts, m->nverts);
    double a0 = 0, a1 = 0;
    for (int t = 0; t < in.ntris; t++) a0 += tri_area(&in, t);
    for (int t = 0; t < m->ntris; t++) a1 += tri_area(m, t);
    CHECK_NEAR(a1, a0, 1e-5 * a0, "total area (no gaps, no overlaps)");
    int bad_count = 0, bad_dir = 0, tjunction = 0, edges = 0;
    for (int t = 0; t < m->ntris; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->tris[3 * t + k], b = m->tris[3 * t + (k + 1) % 3];
            int f, r;
            edge_uses(m, a, b, &f, &r);
            if (r > 0 && a > b) continue;   /* an inside edge: check it once */
            edges++;
            int want = input_uses(&in, m->pos + 3 * a, m->pos + 3 * b);
            bad_count += f + r != want;
            bad_dir += want == 2 && !(f == 1 && r == 1);
            for (int v = 0; v < m->nverts; v++)
                tjunction += (uint32_t)v != a && (uint32_t)v != b && on_segment(m->pos + 3 * a, m->pos + 3 * b, m->pos + 3 * v, 1e-7, true);
        }
    CHECK(bad_count == 0, "%d of %d edges used a different number of times than the input edge they lie on", bad_count, edges);
    CHECK(bad_dir == 0, "%d inside edges not used once in each direction", bad_dir);
    CHECK(tjunction == 0, "%d vertices inside a refined edge (T-junctions)", tjunction);
    printf("  sphere + plane under a square: %d -> %d vertices in %d levels, %d edges checked\n", in.nverts, m->nverts,
           st.levels, edges);
    mesh_free(&in);
    scene_free(&s);
}

static void floor_order(void) {
    static const char json[] =
        "{ \"models\": [ { \"box\": { \"min\": [-0.25, 0.3, -0.25], \"max\": [0.25, 0.5, 0.25], \"n\": 1 } },\n"
        "                { \"sphere\": { \"center\": [0.9, 0.05, 0.9], \"radius\": 0.05, \"rings\": 4, \"segments\": 8 } } ],\n"
        "  \"floor\": { \"vertices\": 400, \"size\": 2 } }";
    prt_scene s = { 0 };
    if (load(json, &s)) return;
    prt_mesh in = { 0 };
    prt_error err;
    CHECK(mesh_copy(&in, &s.mesh, &err) == 0);
    const int ff0 = s.floor_first_vertex;
    const float fy = in.pos[3 * ff0 + 1];
    refine_desc d = { .max_levels = 2 };
    refine_stats st;
    CHECK(refine_scene(&s, &d, &st, &err) == 0, "%s", err.msg);
    const prt_mesh *m = &s.mesh;
    CHECK(st.floor_after > st.floor_before && st.verts_after == m->nverts, "floor %d -> %d", st.floor_before, st.floor_after);
    CHECK(m->nverts - s.floor_first_vertex == st.floor_after, "floor_first_vertex %d", s.floor_first_vertex);
    int moved = 0, off = 0;
    for (int v = 0; v < ff0; v++) moved += memcmp(m->pos + 3 * v, in.pos + 3 * v, 12) != 0;
    for (int v = s.floor_first_vertex; v < m->nverts; v++)
        off += m->pos[3 * v + 1] != fy || m->nrm[3 * v] != 0 || m->nrm[3 * v + 1] != 1 || m->mat[v] != in.mat[ff0];
    int model_on_floor = 0;
    for (int v = 0; v < s.floor_first_vertex; v++) model_on_floor += m->mat[v] != in.mat[0];
    CHECK(moved == 0, "%d model vertices changed position or index", moved);
    CHECK(off == 0, "%d floor vertices off the plane y = %g, with a normal other than +y or another material", off, fy);
    CHECK(model_on_floor == 0, "%d vertices among the models' with another material", model_on_floor);
    /* every floor triangle uses floor vertices only, every model triangle model vertices only */
    int mixed = 0;
    for (int t = 0; t < m->ntris; t++) {
        int nf = 0;
        for (int k = 0; k < 3; k++) nf += (int)m->tris[3 * t + k] >= s.floor_first_vertex;
        mixed += nf != 0 && nf != 3;
    }
    CHECK(mixed == 0, "%d triangles join model and floor vertices", mixed);
    mesh_free(&in);
    scene_free(&s);
}

/* parts: with a floor the default refines the floor's edges only (the models keep their vertices
 * and triangles), REFINE_ALL the models' too; REFINE_FLOOR without a floor and unknown parts are
 * refused with one line, the scene unchanged. */
static void parts(void) {
    static const char json[] =
        "{ \"models\": [ { \"box\": { \"min\": [-0.25, 0.3, -0.25], \"max\": [0.25, 0.5, 0.25], \"n\": 2 } },\n"
        "                { \"sphere\": { \"center\": [0.6, 0.15, 0.6], \"radius\": 0.15, \"rings\": 8, \"segments\": 16 } } ],\n"
        "  \"floor\": { \"vertices\": 400, \"size\": 2 } }";
    prt_scene s = { 0 }, a = { 0 };
    if (load(json, &s) || load(json, &a)) return;
    prt_error err;
    const int models0 = s.floor_first_vertex, tris0 = s.mesh.ntris;
    int model_tris0 = 0;
    for (int t = 0; t < tris0; t++) model_tris0 += (int)s.mesh.tris[3 * t] < models0;
    refine_stats st, sa;
    CHECK(refine_scene(&s, &(refine_desc){ .max_levels = 2 }, &st, &err) == 0, "%s", err.msg);
    CHECK(st.parts == REFINE_FLOOR && st.floor_after > st.floor_before, "floor %d -> %d", st.floor_before, st.floor_after);
    CHECK(s.floor_first_vertex == models0, "model vertices %d -> %d", models0, s.floor_first_vertex);
    int model_tris = 0;
    for (int t = 0; t < s.mesh.ntris; t++) model_tris += (int)s.mesh.tris[3 * t] < s.floor_first_vertex;
    CHECK(model_tris == model_tris0, "model triangles %d -> %d", model_tris0, model_tris);
    CHECK(refine_scene(&a, &(refine_desc){ .max_levels = 2, .parts = REFINE_ALL }, &sa, &err) == 0, "%s", err.msg);
    CHECK(sa.parts == REFINE_ALL && a.floor_first_vertex > models0, "REFINE_ALL: model vertices %d -> %d", models0,
          a.floor_first_vertex);
    /* the floor-only run traces the floor's masks alone: fewer rays for as many floor levels */
    CHECK(st.rays < sa.rays, "rays: floor only %ld, everything %ld", st.rays, sa.rays);
    scene_free(&a);
    prt_scene b = { 0 };
    if (load(k_box_plane, &b)) { scene_free(&s); return; }
    const int nv = b.mesh.nverts;
    CHECK(refine_scene(&b, &(refine_desc){ .parts = REFINE_FLOOR }, NULL, &err) == -1 && strstr(err.msg, "no floor"),
          "floor only without a floor: %s", err.msg);
    CHECK(refine_scene(&s, &(refine_desc){ .parts = 9 }, NULL, &err) == -1 && strstr(err.msg, "parts"), "parts 9: %s", err.msg);
    CHECK(b.mesh.nverts == nv, "the scene is unchanged after an error");
    scene_free(&b);
    scene_free(&s);
}

/* REFINE_MODELS with a material mask (a mask of some of the models' materials): only the
 * masked material's model gains vertices, the other model and the floor keep theirs; with
 * REFINE_FLOOR as well the floor gains too; a mask without REFINE_MODELS is refused. */
static void models_by_material(void) {
    static const char json[] =
        "{ \"models\": [ { \"box\": { \"min\": [-0.25, 0.3, -0.25], \"max\": [0.25, 0.5, 0.25], \"n\": 2 }, \"material\": \"lambert:kd=0.5\" },\n"
        "                { \"sphere\": { \"center\": [0.6, 0.15, 0.6], \"radius\": 0.15, \"rings\": 8, \"segments\": 16 },\n"
        "                  \"material\": \"phong:kd=0.3;ks=0.5;n=50\" } ],\n"
        "  \"floor\": { \"vertices\": 400, \"size\": 2 } }";
    prt_scene s = { 0 }, b = { 0 };
    if (load(json, &s) || load(json, &b)) return;
    prt_error err;
    const int glossy = s.mesh.mat[s.floor_first_vertex - 1], box = s.mesh.mat[0];
    CHECK(glossy != box, "two model materials (%d, %d)", box, glossy);
    int n0[2] = { 0, 0 };
    for (int v = 0; v < s.floor_first_vertex; v++) n0[s.mesh.mat[v] == glossy]++;
    const int floor0 = s.mesh.nverts - s.floor_first_vertex;
    refine_stats st;
    CHECK(refine_scene(&s, &(refine_desc){ .max_levels = 2, .parts = REFINE_MODELS, .materials = (uint64_t)1 << glossy }, &st, &err) == 0,
          "%s", err.msg);
    int n1[2] = { 0, 0 };
    for (int v = 0; v < s.floor_first_vertex; v++) n1[s.mesh.mat[v] == glossy]++;
    CHECK(n1[1] > n0[1] && n1[0] == n0[0], "sphere %d -> %d, box %d -> %d vertices", n0[1], n1[1], n0[0], n1[0]);
    CHECK(st.floor_after == floor0 && s.mesh.nverts - s.floor_first_vertex == floor0, "floor %d -> %d", floor0, st.floor_after);
    CHECK(st.parts == REFINE_MODELS && st.materials == (uint64_t)1 << glossy, "stats: parts %d materials 0x%llx", st.parts,
          (unsigned long long)st.materials);
    CHECK(refine_scene(&b, &(refine_desc){ .max_levels = 2, .parts = REFINE_FLOOR | REFINE_MODELS, .materials = (uint64_t)1 << glossy },
                       &st, &err) == 0, "%s", err.msg);
    int n2[2] = { 0, 0 };
    for (int v = 0; v < b.floor_first_vertex; v++) n2[b.mesh.mat[v] == glossy]++;
    CHECK(n2[1] > n0[1] && n2[0] == n0[0] && st.floor_after > floor0, "floor and sphere: sphere %d -> %d, box %d, floor %d -> %d",
          n0[1], n2[1], n2[0], floor0, st.floor_after);
    const int nv = b.mesh.nverts;
    CHECK(refine_scene(&b, &(refine_desc){ .parts = REFINE_FLOOR, .materials = 1 }, NULL, &err) == -1 && strstr(err.msg, "mask"),
          "a mask without REFINE_MODELS: %s", err.msg);
    CHECK(b.mesh.nverts == nv, "the scene is unchanged after an error");
    scene_free(&b);
    scene_free(&s);
}

/* A non-manifold edge (real scans have them): three pages around one spine, each two triangles, so
 * the spine is an edge of three triangles, over a floor; the spine's vertices of their own material,
 * the only one refined, so the spine is the only edge compared. Splitting it gives each of the three
 * triangles on it two children (more than the two a manifold edge has: the children's count must
 * not assume two). */
static void non_manifold(void) {
    prt_error err;
    prt_mesh m = { 0 };
    m.nverts = 8, m.ntris = 6;
    m.pos = calloc(3 * 8, sizeof(float));
    m.tris = calloc(3 * 6, sizeof(uint32_t));
    if (!m.pos || !m.tris) { free(m.pos); free(m.tris); CHECK(0, "out of memory"); return; }
    const float spine[2][3] = { { 0, 0.05f, 0 }, { 0, 1, 0 } };
    memcpy(m.pos, spine, sizeof spine);
    for (int p = 0; p < 3; p++) {
        const float a = 2.0943951f * (float)p, x = 0.5f * cosf(a), z = 0.5f * sinf(a);
        const float outer[2][3] = { { x, 0.05f, z }, { x, 1, z } };
        memcpy(m.pos + 3 * (2 + 2 * p), outer, sizeof outer);
        const uint32_t b = 0, t = 1, ob = 2 + 2 * (uint32_t)p, ot = ob + 1;
        const uint32_t tri[6] = { b, ob, ot, b, ot, t };
        memcpy(m.tris + 6 * p, tri, sizeof tri);
    }
    mesh_compute_normals(&m);
    prt_scene s;
    if (scene_from_mesh(&m, "lambert:kd=0.5", &s, &err) || scene_material(&s, "lambert:kd=0.4", &err) != 1 ||
        scene_add_floor(&s, 400, 2, NULL, &err)) {
        CHECK(0, "%s", err.msg);
        return;
    }
    s.mesh.mat[0] = s.mesh.mat[1] = 1;   /* the spine's two vertices: its edge is the only one compared */
    const int models0 = s.floor_first_vertex;
    refine_stats st;
    int rc = refine_scene(&s, &(refine_desc){ .threshold = 1e-4f, .max_levels = 1, .parts = REFINE_MODELS, .materials = 2 }, &st, &err);
    CHECK(rc == 0, "%s", err.msg);
    int mid = -1;
    for (int v = models0; v < s.floor_first_vertex && rc == 0; v++) {
        const float *q = s.mesh.pos + 3 * (size_t)v;
        if (fabsf(q[0]) < 1e-6f && fabsf(q[2]) < 1e-6f && fabsf(q[1] - 0.525f) < 1e-6f) mid = v;
    }
    CHECK(mid >= 0, "the spine was split (%d -> %d model vertices)", models0, s.floor_first_vertex);
    int on_mid = 0;
    for (int t = 0; t < s.mesh.ntris && mid >= 0; t++)
        for (int k = 0; k < 3; k++) on_mid += s.mesh.tris[3 * t + k] == (uint32_t)mid;
    CHECK(mid < 0 || on_mid >= 6, "the spine's midpoint is in %d triangles (two children of each of three)", on_mid);
    scene_free(&s);
}

/* Byte for byte: exact by construction for runs of the same code on the same machine (refine's
 * choices do not depend on the thread count), which is all it compares. */
static bool same_mesh(const prt_mesh *a, const prt_mesh *b) {
    return a->nverts == b->nverts && a->ntris == b->ntris && !memcmp(a->pos, b->pos, 12 * (size_t)a->nverts) &&
           !memcmp(a->nrm, b->nrm, 12 * (size_t)a->nverts) && !memcmp(a->mat, b->mat, 2 * (size_t)a->nverts) &&
           !memcmp(a->tris, b->tris, 12 * (size_t)a->ntris);
}

static void deterministic(void) {
    prt_scene s[3];
    memset(s, 0, sizeof s);
    prt_error err;
    const int threads[3] = { 2, 2, 1 };
    for (int i = 0; i < 3; i++) {
        if (load(k_sphere_plane, &s[i])) return;
        refine_desc d = { .max_levels = 3, .budget = 3000, .nthreads = threads[i] };
        CHECK(refine_scene(&s[i], &d, NULL, &err) == 0, "%s", err.msg);
    }
    CHECK(s[0].mesh.nverts > 1000, "%d vertices", s[0].mesh.nverts);
    CHECK(same_mesh(&s[0].mesh, &s[1].mesh), "two runs on 2 threads differ");
    CHECK(same_mesh(&s[0].mesh, &s[2].mesh), "1 and 2 threads differ");
    for (int i = 0; i < 3; i++) scene_free(&s[i]);
}

static void budget(void) {
    prt_scene s = { 0 }, full = { 0 };
    if (load(k_box_plane, &s) || load(k_box_plane, &full)) return;
    prt_error err;
    const int v0 = s.mesh.nverts;
    refine_desc d = { .max_levels = 1, .budget = v0 + 37 };
    refine_stats st, sf;
    CHECK(refine_scene(&s, &d, &st, &err) == 0, "%s", err.msg);
    d.budget = 1000000;
    CHECK(refine_scene(&full, &d, &sf, &err) == 0, "%s", err.msg);
    CHECK(sf.verts_after > v0 + 37, "the unlimited run splits more than the budget (%d)", sf.verts_after - v0);
    CHECK(st.verts_after == v0 + 37 && s.mesh.nverts == v0 + 37 && st.budget_hit, "%d vertices for a budget of %d",
          st.verts_after, v0 + 37);
    /* the budgeted run's new vertices are a subset of the unlimited run's */
    int missing = 0;
    for (int v = v0; v < s.mesh.nverts; v++) missing += find_vertex(&full.mesh, s.mesh.pos + 3 * v) < 0;
    CHECK(missing == 0, "%d budgeted splits not in the full run", missing);
    d.budget = v0 - 1;
    CHECK(refine_scene(&s, &d, NULL, &err) == -1 && strstr(err.msg, "budget"), "a budget below the input: %s", err.msg);
    d = (refine_desc){ .threshold = 1.5f };
    CHECK(refine_scene(&s, &d, NULL, &err) == -1 && strstr(err.msg, "threshold"), "threshold 1.5: %s", err.msg);
    d = (refine_desc){ .mask_res = 30 };
    CHECK(refine_scene(&s, &d, NULL, &err) == -1 && strstr(err.msg, "mask_res"), "mask_res 30: %s", err.msg);
    CHECK(s.mesh.nverts == v0 + 37, "failed calls change nothing");
    scene_free(&s);
    scene_free(&full);
}

static void precompute(void) {
    prt_scene s = { 0 };
    if (load(k_box_plane, &s)) return;
    const int v0 = s.mesh.nverts;
    precompute_desc d = { .N = 32, .vis_res = 64, .refine_threshold = 0.005f, .refine_budget = v0 + 200, .quiet = true,
                          .force_bounces = -1 };
    prt_data out;
    prt_error err;
    CHECK(precompute_run(&s, &d, &out, &err) == 0, "%s", err.msg);
    const prt_transfer *tr = prt_data_transfer(&out);
    CHECK(out.scene.mesh.nverts == v0 + 200 && tr->transport.nverts == v0 + 200, "%d vertices, transport %d",
          out.scene.mesh.nverts, tr->transport.nverts);
    CHECK(strstr(out.plan, "refinement: ") && strstr(out.plan, "(reached)"), "plan:\n%s", out.plan);
    prt_data_free(&out);
    d.refine_threshold = 1.f;
    prt_scene s2 = { 0 };
    if (load(k_box_plane, &s2)) return;
    CHECK(precompute_run(&s2, &d, &out, &err) == -1 && strstr(err.msg, "refine_threshold"), "%s", err.msg);
}

static void cli_flags(void) {
    const char *dir = check_tmpdir();
    char obj[1024], out[1024], cmd[4096], buf[4096];
    snprintf(obj, sizeof obj, "%s/sq.obj", dir);
    snprintf(out, sizeof out, "%s/sq.prt", dir);
    FILE *f = fopen(obj, "w");
    CHECK(f != NULL);
    if (!f) return;
    fputs("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 0 0\nv -0.2 0.5 -0.2\nv 0.2 0.5 -0.2\nv 0.2 0.5 0.2\nv -0.2 0.5 0.2\n"
          "f 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\nf 6 9 8 7\n", f);
    fclose(f);
    const char *bad[][2] = { { "--refine-threshold 1.5", "--refine-threshold" }, { "--refine-threshold 1", "--refine-threshold" },
                             { "--refine-threshold -0.1", "--refine-threshold" }, { "--refine-threshold abc", "--refine-threshold" },
                             { "--refine-threshold", "--refine-threshold" }, { "--refine-budget 0", "--refine-budget" },
                             { "--refine-budget x", "--refine-budget" }, { "--refine-budget 5", "--refine-budget" } };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet %s", check_prt_bin(), obj, out, bad[i][0]);
        int rc = check_run(cmd, buf, sizeof buf);
        size_t nl = 0;
        for (char *p = buf; *p; p++) nl += *p == '\n';
        struct stat stt;
        CHECK(rc == 2 && nl == 1 && strstr(buf, bad[i][1]) && stat(out, &stt) != 0, "%s: exit %d, output:\n%s", bad[i][0], rc, buf);
    }
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet --vis-res 64 --coeffs 16 --refine && %s info %s", check_prt_bin(),
             obj, out, check_prt_bin(), out);
    CHECK(check_run(cmd, buf, sizeof buf) == 0 && strstr(buf, "refinement: 9 -> "), "a good run: %s", buf);
    /* a JSON scene's "refine" (scene.h) refines at its defaults; any refine flag replaces it */
    char json[1024];
    snprintf(json, sizeof json, "%s/sq.json", dir);
    f = fopen(json, "w");
    CHECK(f != NULL);
    if (!f) return;
    fputs("{ \"models\": [ { \"obj\": \"sq.obj\", \"material\": \"lambert:kd=0.5\" } ], \"refine\": { \"budget\": 12 } }\n", f);
    fclose(f);
    const char *runs[][2] = { { "", "refinement: 9 -> 12 " }, { "--no-refine", "refinement: off (forced)" },
                              { "--refine-budget 10", "refinement: 9 -> 10 " } };
    for (int i = 0; i < 3; i++) {
        snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet --vis-res 64 --coeffs 16 %s && %s info %s", check_prt_bin(), json,
                 out, runs[i][0], check_prt_bin(), out);
        int rrc = check_run(cmd, buf, sizeof buf);
        CHECK(rrc == 0, "%s: exit %d: %s\n%s", runs[i][0], rrc, cmd, buf);
        CHECK(strstr(buf, runs[i][1]) != NULL && (i != 1 || !strstr(buf, "refinement: 9 ->")), "'%s': %s", runs[i][0], buf);
    }
    /* a scene's budget below its vertices is the scene's error (exit 1, naming the file and the key), no output */
    f = fopen(json, "w");
    CHECK(f != NULL);
    if (!f) return;
    fputs("{ \"models\": [ { \"obj\": \"sq.obj\" } ], \"refine\": { \"budget\": 5 } }\n", f);
    fclose(f);
    remove(out);
    snprintf(cmd, sizeof cmd, "%s precompute %s -o %s --quiet", check_prt_bin(), json, out);
    int rc = check_run(cmd, buf, sizeof buf);
    struct stat stt;
    CHECK(rc == 1 && strstr(buf, "sq.json: refine.budget 5 is below its 9 vertices") && stat(out, &stt) != 0, "exit %d: %s", rc, buf);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(box_shadow);
    CHECK_CASE(no_cracks);
    CHECK_CASE(floor_order);
    CHECK_CASE(parts);
    CHECK_CASE(models_by_material);
    CHECK_CASE(non_manifold);
    CHECK_CASE(deterministic);
    CHECK_CASE(budget);
    CHECK_CASE(precompute);
    CHECK_CASE(cli_flags);
    return check_summary();
}
