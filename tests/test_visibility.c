/* test_visibility.c - Embree ray casting: cube-map texel convention, the occluded
 * solid angle of a sphere against the analytic cap, self-intersection robustness
 * at extreme scales and offsets, closest-hit queries and thread safety. */
#include "harness.h"
#include "cubemap.h"
#include "mesh.h"
#include "visibility.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Solid angle of the upper-hemisphere texels that vis marks occluded, plus the count. */
static double occluded_solid_angle(const uint8_t *vis, int res, const float n[3], long *count) {
    float *sa = malloc(sizeof(float) * res * res);
    cube_face_solid_angles(res, sa);
    double om = 0;
    long cnt = 0;
    for (int i = 0; i < 6 * res * res; i++) {
        float d[3];
        cube_texel_dir(res, i, d);
        if (d[0] * n[0] + d[1] * n[1] + d[2] * n[2] > 0 && !vis[i]) {
            om += sa[i % (res * res)];
            cnt++;
        }
    }
    free(sa);
    *count = cnt;
    return om;
}

/* A plane of half-size 4 at y = 0 with a sphere of radius r centred at (0, dist, 0), scaled and offset. */
static void make_scene(prt_mesh *m, float r, float dist, float scale, const float off[3]) {
    prt_error err;
    prt_mesh sph = { 0 };
    CHECK(mesh_make_plane(m, -4, 4, -4, 4, 0, 9, 9, &err) == 0, "%s", err.msg);
    float c[3] = { 0, dist, 0 };
    CHECK(mesh_make_sphere(&sph, c, r, 48, 96, &err) == 0, "%s", err.msg);
    CHECK(mesh_append(m, &sph, &err) == 0, "%s", err.msg);
    mesh_free(&sph);
    float I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    mesh_transform(m, I, scale, off);
}

static void texel_convention(void) {
    /* One tiny triangle straddling the centre of texel idx at distance 1 blocks exactly that texel. */
    const int res = 32;
    int idxs[4] = { 2 * res * res + 5 * res + 7, 0 * res * res + 17 * res + 3, 5 * res * res + 30 * res + 30,
                    4 * res * res + 0 * res + 12 };
    for (int q = 0; q < 4; q++) {
        int idx = idxs[q];
        float d[3];
        cube_texel_dir(res, idx, d);
        /* frame around d */
        float a[3] = { fabsf(d[0]) < 0.9f ? 1.f : 0.f, fabsf(d[0]) < 0.9f ? 0.f : 1.f, 0 };
        float u[3] = { d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0] };
        float ul = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int k = 0; k < 3; k++) u[k] /= ul;
        float w[3] = { d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0] };
        const float s = 0.004f;   /* much smaller than a texel (~0.06 rad at res 32) */
        float pos[9];
        for (int k = 0; k < 3; k++) {
            pos[k] = d[k] - s * u[k] - s * w[k];
            pos[3 + k] = d[k] + 2 * s * u[k];
            pos[6 + k] = d[k] + 2 * s * w[k] - s * u[k];
        }
        /* the occluder plus a far-away helper triangle so the bounding box is not tiny */
        float posall[18];
        memcpy(posall, pos, sizeof pos);
        float far[9] = { 100, 100, 100, 101, 100, 100, 100, 101, 100 };
        memcpy(posall + 9, far, sizeof far);
        uint32_t tris[6] = { 0, 1, 2, 3, 4, 5 };
        float nrm[18] = { 0 };
        prt_mesh m = { .nverts = 6, .ntris = 2, .pos = posall, .nrm = nrm, .tris = tris };
        prt_error err;
        vis_scene *vs = vis_create(&m, &err);
        CHECK(vs != NULL, "%s", err.msg);
        if (!vs) continue;
        float p[3] = { 0, 0, 0 };
        uint8_t *vis = malloc(6 * res * res);
        long traced, hits;
        vis_cube(vs, p, d, res, vis, &traced, &hits);   /* normal = d: the texel is in the upper hemisphere */
        CHECK(hits == 1, "texel %d: %ld hits", idx, hits);
        CHECK(vis[idx] == 0, "texel %d not blocked", idx);
        long zeros_up = 0, ones_down = 0, horizon = 0;
        for (int i = 0; i < 6 * res * res; i++) {
            float e[3];
            cube_texel_dir(res, i, e);
            float ed = e[0] * d[0] + e[1] * d[1] + e[2] * d[2];
            if (fabsf(ed) < 1e-6f) { horizon++; continue; }   /* on the horizon: rounding decides */
            if (ed > 0) zeros_up += vis[i] == 0;
            else ones_down += vis[i] != 0;
        }
        CHECK(zeros_up == 1, "%ld blocked texels", zeros_up);
        CHECK(ones_down == 0, "%ld below-horizon texels are not 0", ones_down);
        /* traced = texels with n.w > 0: texel centres come in antipodal pairs, so half the cube
         * except pairs lying exactly on the horizon */
        CHECK(traced <= 3 * res * res && traced >= 3 * res * res - horizon / 2, "traced %ld (%ld on the horizon)", traced, horizon);
        free(vis);
        vis_destroy(vs);
    }
}

static void sphere_cap(void) {
    const int res = 128;
    const float r = 1.0f, dist = 2.0f;   /* r/d = 0.5: cap half-angle 30 degrees */
    float zero[3] = { 0, 0, 0 };
    prt_mesh m = { 0 };
    make_scene(&m, r, dist, 1, zero);
    prt_error err;
    vis_scene *vs = vis_create(&m, &err);
    CHECK(vs != NULL, "%s", err.msg);
    float p[3] = { 0, 0, 0 }, n[3] = { 0, 1, 0 };
    uint8_t *vis = malloc(6 * res * res);
    long traced, hits, cnt;
    vis_cube(vs, p, n, res, vis, &traced, &hits);
    double om = occluded_solid_angle(vis, res, n, &cnt);
    double sa = (r / dist);
    double exact = 2 * M_PI * (1 - sqrt(1 - sa * sa));
    /* Tolerance: the band of texels along the cap's boundary (perimeter 2 pi sin(alpha) times one
     * texel width 2/res rad at the +Y face centre) plus the tessellated sphere's smaller
     * silhouette (radius cos(pi/96) of the true one). */
    double tol = 2 * M_PI * sa * (2.0 / res) * 1.0 + 2 * M_PI * sa * sa * (1 - cos(M_PI / 96)) * 2;
    CHECK_NEAR(om, exact, tol, "occluded solid angle of the sphere");
    CHECK(hits == cnt, "hits %ld vs occluded texels %ld", hits, cnt);
    printf("sphere cap: occluded %.5f sr, analytic %.5f sr (tol %.4f), %ld texels\n", om, exact, tol, cnt);

    /* Robustness: the same occlusion at tiny and huge scales and far from the origin.
     * (A model far from the origin is made large enough that float positions still resolve it.)
     * Embree's triangle test multiplies three lengths, so before the ray tracer worked in scaled
     * units a scene 1e15 across lost shadows and one 1e20 or 1e-15 across lost them all; at a
     * power-of-two scale the cube map is the scale-1 one bit for bit (the scaling is exact). */
    struct { float scale; float off; } cases[] = { { 1e-4f, 0 }, { 1e5f, 0 }, { 1e4f, 1e6f }, { 1.f, 30.f },
                                                   { 1e-30f, 0 }, { 1e-15f, 0 }, { 1e15f, 0 }, { 1e29f, 0 },
                                                   { 1e20f, 1e22f }, { 0x1p-100f, 0 }, { 0x1p96f, 0 } };
    for (int q = 0; q < (int)(sizeof cases / sizeof cases[0]); q++) {
        prt_mesh m2 = { 0 };
        float off[3] = { cases[q].off, cases[q].off, cases[q].off };
        make_scene(&m2, r, dist, cases[q].scale, off);
        vis_scene *vs2 = vis_create(&m2, &err);
        CHECK(vs2 != NULL, "%s", err.msg);
        if (!vs2) { mesh_free(&m2); continue; }
        float p2[3] = { off[0], off[1], off[2] };
        uint8_t *vis2 = malloc(6 * res * res);
        long tr2, h2, c2;
        vis_cube(vs2, p2, n, res, vis2, &tr2, &h2);
        double om2 = occluded_solid_angle(vis2, res, n, &c2);
        CHECK_NEAR(om2, om, 0.002 * om, "scale %g offset %g: occluded %.5f vs %.5f", cases[q].scale, cases[q].off, om2, om);
        int e2;
        if (cases[q].off == 0 && frexpf(cases[q].scale, &e2) == 0.5f)
            CHECK(memcmp(vis2, vis, (size_t)6 * res * res) == 0 && h2 == hits && tr2 == traced,
                  "scale 2^%d: the cube map differs from scale 1's (%ld vs %ld hits)", e2 - 1, h2, hits);
        /* Self-intersection: a plane vertex away from the sphere's shadow and every sphere vertex
         * (convex) must see no geometry of their own surface. */
        long sh = 0, st;
        float pp[3] = { off[0] + 3.5f * cases[q].scale, off[1], off[2] - 3.5f * cases[q].scale };
        float nd[3] = { 0, -1, 0 };
        vis_cube(vs2, pp, nd, 32, vis2, &st, &sh);   /* facing down: nothing below the plane */
        CHECK(sh == 0, "scale %g offset %g: a downward plane vertex saw %ld hits", cases[q].scale, cases[q].off, sh);
        long sphere_hits = 0;
        {
            prt_mesh sph = { 0 };
            float ctr[3] = { 0, dist, 0 }, I[9] = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
            CHECK(mesh_make_sphere(&sph, ctr, r, 48, 96, &err) == 0, "%s", err.msg);
            mesh_transform(&sph, I, cases[q].scale, off);
            vis_scene *vs3 = vis_create(&sph, &err);
            CHECK(vs3 != NULL, "%s", err.msg);
            for (int v = 0; vs3 && v < sph.nverts; v += 7) {
                long t3, h3;
                vis_cube(vs3, sph.pos + 3 * v, sph.nrm + 3 * v, 32, vis2, &t3, &h3);
                sphere_hits += h3;
            }
            vis_destroy(vs3);
            mesh_free(&sph);
        }
        CHECK(sphere_hits == 0, "scale %g offset %g: %ld self-hits on a lone convex sphere", cases[q].scale, cases[q].off,
              sphere_hits);
        printf("scale %g offset %g: occluded %.5f sr, eps %g\n", cases[q].scale, cases[q].off, om2, vis_eps(vs2));
        free(vis2);
        vis_destroy(vs2);
        mesh_free(&m2);
    }
    free(vis);
    vis_destroy(vs);
    mesh_free(&m);
}

static void closest(void) {
    prt_mesh m = { 0 };
    prt_error err;
    CHECK(mesh_make_plane(&m, -1, 1, -1, 1, 0.5f, 5, 5, &err) == 0, "%s", err.msg);
    vis_scene *vs = vis_create(&m, &err);
    CHECK(vs != NULL, "%s", err.msg);
    float org[3] = { 0.1f, 2.0f, -0.3f };
    int nr = 37;
    float *dirs = malloc(sizeof(float) * 3 * nr);
    vis_hit *hits = malloc(sizeof(vis_hit) * nr);
    for (int i = 0; i < nr; i++) {
        float a = 0.2f * i, b = 0.05f * i;
        float d[3] = { 0.3f * cosf(a) * b, -1.0f, 0.3f * sinf(a) * b };
        if (i % 5 == 4) d[1] = 1.0f;   /* upward: a miss */
        float l = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int k = 0; k < 3; k++) dirs[3 * i + k] = d[k] / l;
    }
    vis_closest_many(vs, org, dirs, nr, 0, hits);
    for (int i = 0; i < nr; i++) {
        vis_hit h;
        bool got = vis_closest(vs, org, dirs + 3 * i, 0, INFINITY, &h);
        CHECK(got == (hits[i].tri >= 0), "ray %d: vis_closest and vis_closest_many disagree", i);
        CHECK(got == (dirs[3 * i + 1] < 0), "ray %d", i);
        CHECK(got == vis_occluded(vs, org, dirs + 3 * i, 0, INFINITY), "ray %d: vis_occluded disagrees", i);
        if (!got) continue;
        CHECK(h.tri == hits[i].tri, "ray %d: triangles %d vs %d", i, h.tri, hits[i].tri);
        /* Embree's single-ray and packet kernels (their SIMD width set by the CPU or
         * PRT_EMBREE_CONFIG) round t differently: a few float ulps of t ~ 1.5 (~1e-6); 1e-5 */
        CHECK_NEAR(h.t, hits[i].t, 1e-5, "ray %d", i);
        /* t: plane at y = 0.5 */
        double texp = (0.5 - org[1]) / dirs[3 * i + 1];
        CHECK_NEAR(h.t, texp, 1e-5 * texp, "ray %d: distance to the plane", i);
        /* barycentrics reproduce the hit point */
        const uint32_t *tr = m.tris + 3 * h.tri;
        for (int k = 0; k < 3; k++) {
            double x = (1 - h.u - h.v) * m.pos[3 * tr[0] + k] + h.u * m.pos[3 * tr[1] + k] + h.v * m.pos[3 * tr[2] + k];
            CHECK_NEAR(x, org[k] + h.t * dirs[3 * i + k], 1e-5, "ray %d: barycentric point", i);
        }
        /* geometric normal: the direction of (P1 - P0) x (P2 - P0) (its length is in the ray
         * tracer's scaled units, visibility.h; the grid's coordinates are multiples of 0.5, so the
         * cross products are exact on any ISA) */
        const float *P0 = m.pos + 3 * tr[0], *P1 = m.pos + 3 * tr[1], *P2 = m.pos + 3 * tr[2];
        float e1[3] = { P1[0] - P0[0], P1[1] - P0[1], P1[2] - P0[2] }, e2[3] = { P2[0] - P0[0], P2[1] - P0[1], P2[2] - P0[2] };
        float cr[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
        double lc = sqrt((double)cr[0] * cr[0] + (double)cr[1] * cr[1] + (double)cr[2] * cr[2]);
        double lh = sqrt((double)h.ng[0] * h.ng[0] + (double)h.ng[1] * h.ng[1] + (double)h.ng[2] * h.ng[2]);
        CHECK(lh > 0, "ray %d: Ng is not zero", i);
        for (int k = 0; k < 3; k++) CHECK_NEAR(h.ng[k] / lh, cr[k] / lc, 1e-6, "Ng direction component %d", k);
        CHECK(cr[1] > 0, "mesh_make_plane faces +y");
        /* the segment ending before the plane is not occluded */
        CHECK(!vis_occluded(vs, org, dirs + 3 * i, 0, 0.99f * h.t), "ray %d: short segment occluded", i);
    }
    free(dirs);
    free(hits);
    vis_destroy(vs);
    mesh_free(&m);
}

typedef struct mt_ctx {
    const vis_scene *vs;
    const prt_mesh *m;
    uint8_t *out;   /* [nverts][6*16*16] */
} mt_ctx;
static void mt_fn(void *ctx, int b, int e, int th) {
    mt_ctx *c = ctx;
    for (int v = b; v < e; v++) vis_cube(c->vs, c->m->pos + 3 * v, c->m->nrm + 3 * v, 16, c->out + (size_t)v * 6 * 256, NULL, NULL);
}

static void threads(void) {
    prt_mesh m = { 0 };
    float zero[3] = { 0, 0, 0 };
    make_scene(&m, 1, 1.5f, 1, zero);
    prt_error err;
    vis_scene *vs = vis_create(&m, &err);
    CHECK(vs != NULL, "%s", err.msg);
    uint8_t *a = malloc((size_t)m.nverts * 6 * 256), *b = malloc((size_t)m.nverts * 6 * 256);
    mt_ctx c1 = { vs, &m, a }, c2 = { vs, &m, b };
    prt_parallel_for(m.nverts, 1, 1, mt_fn, &c1);
    prt_parallel_for(m.nverts, 3, 4, mt_fn, &c2);
    /* exact by construction: each vertex's cube is one thread's rays through the same device */
    CHECK(memcmp(a, b, (size_t)m.nverts * 6 * 256) == 0, "threaded results differ");
    free(a);
    free(b);
    vis_destroy(vs);
    mesh_free(&m);
}

static void errors(void) {
    prt_error err = { { 0 } };
    prt_mesh bad = { .nverts = 3, .ntris = 1, .pos = NULL, .tris = NULL };
    CHECK(vis_create(&bad, &err) == NULL, "a mesh without arrays must fail");
    CHECK(strlen(err.msg) > 0, "error message set");
    float pos3[9] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    uint32_t badtri[3] = { 0, 1, 3 };
    prt_mesh badidx = { .nverts = 3, .ntris = 1, .pos = pos3, .tris = badtri };
    err.msg[0] = 0;
    CHECK(vis_create(&badidx, &err) == NULL, "an out-of-range index must fail");
    CHECK(strstr(err.msg, "vertex 3") != NULL, "message names the index: %s", err.msg);
    /* An empty mesh is a valid scene in which nothing is ever hit. */
    prt_mesh empty = { 0 };
    vis_scene *vs = vis_create(&empty, &err);
    CHECK(vs != NULL, "empty mesh: %s", err.msg);
    if (vs) {
        float p[3] = { 0, 0, 0 }, n[3] = { 0, 0, 1 }, d[3] = { 1, 0, 0 };
        uint8_t vis[6 * 8 * 8];
        long tr, h;
        vis_cube(vs, p, n, 8, vis, &tr, &h);
        CHECK(h == 0 && tr == 3 * 64, "empty scene: %ld hits of %ld", h, tr);
        CHECK(!vis_occluded(vs, p, d, 0, INFINITY), "empty scene occludes");
        vis_destroy(vs);
    }
}

/* vis_cull_floor against tracing every ray (the same Embree scene without it), byte for byte:
 * a sphere on a floor, a second sphere overhanging the floor's edge (rays down from it cross the
 * plane outside the floor), points below the floor, on its edge, and on it with a tilted normal
 * (its origin within eps of the plane: rays down cross it before tnear, so Embree finds them
 * open). With a hole cut in the floor the shortcut must turn itself off (rays through the hole
 * escape). */
static void floor_cull_case(prt_mesh *m, int ff, bool want_rect) {
    prt_error err;
    vis_scene *all = vis_create(m, &err), *cut = all ? vis_create(m, &err) : NULL;
    CHECK(cut != NULL, "%s", err.msg);
    if (!cut) { vis_destroy(all); return; }
    vis_cull_floor(cut, m, ff);
    CHECK(vis_culling(cut) == want_rect, "shortcut on: %d (want %d)", vis_culling(cut), want_rect);
    const int res = 32, nx = 9;
    uint8_t *a = malloc(6 * res * res), *b = malloc(6 * res * res);
    const float extra[][6] = { { 0, -1, 0, 0, 1, 0 },        { 0, -1, 0, 0, -1, 0 },   { 4, 0, 4, 0, 1, 0 },
                               { 3.9f, 0.01f, 0, 0, 1, 0 }, { 2, 0.3f, 1, 0.6f, 0.8f, 0 }, { 1, 2.5f, -1, 0, -1, 0 },
                               { 0, 0, 0, 0.28f, 0.96f, 0 }, { -2, 0, 2, 0.96f, 0.28f, 0 } };
    const int nextra = (int)(sizeof extra / sizeof extra[0]);
    long differ = 0, blocked = 0, tested = 0;
    for (int v = -nextra; v < m->nverts; v += v < 0 ? 1 : nx) {
        const float *p = v < 0 ? extra[v + nextra] : m->pos + 3 * (size_t)v;
        const float *n = v < 0 ? extra[v + nextra] + 3 : m->nrm + 3 * (size_t)v;
        long ta, ha, tb, hb;
        vis_cube(all, p, n, res, a, &ta, &ha);
        vis_cube(cut, p, n, res, b, &tb, &hb);
        differ += memcmp(a, b, 6 * res * res) != 0 || ta != tb || ha != hb;
        blocked += ha;
        tested++;
    }
    /* exact, by the shortcut's construction: it settles only rays that any watertight traversal
     * (RTC_SCENE_FLAG_ROBUST) must find blocked, crossing the floor's plane inside its rectangle
     * shrunk by a margin beyond tnear, so it holds at every SIMD width (make test-portable: SSE4.2) */
    CHECK(differ == 0, "%ld of %ld vertices see otherwise with the shortcuts", differ, tested);
    CHECK(blocked > 1000, "the case blocks rays (%ld)", blocked);
    free(a);
    free(b);
    vis_destroy(all);
    vis_destroy(cut);
}

static void floor_culling(void) {
    prt_error err;
    prt_mesh m = { 0 }, s2 = { 0 }, fl = { 0 };
    const float c1[3] = { 0.5f, 1.0f, 0 }, c2[3] = { 4.5f, 1.2f, 0.5f };
    CHECK(mesh_make_sphere(&m, c1, 0.9f, 16, 32, &err) == 0, "%s", err.msg);
    CHECK(mesh_make_sphere(&s2, c2, 1.0f, 16, 32, &err) == 0, "%s", err.msg);
    CHECK(mesh_append(&m, &s2, &err) == 0, "%s", err.msg);
    const int ff = m.nverts;
    CHECK(mesh_make_plane(&fl, -4, 4, -4, 4, 0, 17, 17, &err) == 0, "%s", err.msg);
    CHECK(mesh_append(&m, &fl, &err) == 0, "%s", err.msg);
    floor_cull_case(&m, ff, true);
    /* a hole: drop the floor's triangles around (0.5, 0, 0) and the origin, under the first sphere */
    int kept = 0;
    for (int t = 0; t < m.ntris; t++) {
        const uint32_t *tv = m.tris + 3 * (size_t)t;
        const float *x = m.pos + 3 * (size_t)tv[0];
        const bool hole = tv[0] >= (uint32_t)ff && fabsf(x[0] - 0.25f) < 0.8f && fabsf(x[2]) < 0.8f;
        if (!hole) memmove(m.tris + 3 * (size_t)kept++, tv, 3 * sizeof *tv);
    }
    CHECK(kept < m.ntris, "the hole removed triangles");
    m.ntris = kept;
    floor_cull_case(&m, ff, false);
    mesh_free(&m);
    mesh_free(&s2);
    mesh_free(&fl);
}

int main(int argc, char **argv) {
    check_begin(argc, argv);
    CHECK_CASE(texel_convention);
    CHECK_CASE(sphere_cap);
    CHECK_CASE(closest);
    CHECK_CASE(threads);
    CHECK_CASE(errors);
    CHECK_CASE(floor_culling);
    return check_summary();
}
