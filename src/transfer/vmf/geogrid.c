/* geogrid.c - the geodesic view grid (geogrid.h): icosahedral subdivision with every
 * level's faces kept, so that locating a direction is a descent of the subdivision. */
#include "geogrid.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct geogrid {
    int level, nverts;
    float *dir;          /* [3 * nverts] */
    int *faces[GEOGRID_MAX_LEVEL + 1];   /* level l: [3 * 20 * 4^l] view indices */
    float *planes[GEOGRID_MAX_LEVEL + 1];  /* level l: [9 * 20 * 4^l] three plane normals per face:
                                            * l < level: the inner edges of its corner children
                                            * (ab->ca, bc->ab, ca->bc); l = level: its own edges
                                            * opposite each corner (b->c, c->a, a->b); level 0 adds
                                            * its own edges, normalized, in top[] */
    float top[20 * 9];
    int star[12][5];                        /* the 5 top faces around each icosahedron vertex */
    float spacing;
};

static void cross3(const float *a, const float *b, double *o) {
    o[0] = (double)a[1] * b[2] - (double)a[2] * b[1];
    o[1] = (double)a[2] * b[0] - (double)a[0] * b[2];
    o[2] = (double)a[0] * b[1] - (double)a[1] * b[0];
}

/* The icosahedron: vertices (0, +-1, +-phi) cyclically, faces counter-clockwise from outside. */
static void gg_icosahedron(float *dir, int *faces) {
    const double p = (1 + sqrt(5.0)) / 2, l = sqrt(1 + p * p);
    static const int f[20][3] = { { 0, 11, 5 }, { 0, 5, 1 },  { 0, 1, 7 },   { 0, 7, 10 }, { 0, 10, 11 },
                                  { 1, 5, 9 },  { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
                                  { 3, 9, 4 },  { 3, 4, 2 },  { 3, 2, 6 },   { 3, 6, 8 },  { 3, 8, 9 },
                                  { 4, 9, 5 },  { 2, 4, 11 }, { 6, 2, 10 },  { 8, 6, 7 },  { 9, 8, 1 } };
    const double v[12][3] = { { -1, p, 0 }, { 1, p, 0 }, { -1, -p, 0 }, { 1, -p, 0 }, { 0, -1, p }, { 0, 1, p },
                              { 0, -1, -p }, { 0, 1, -p }, { p, 0, -1 }, { p, 0, 1 }, { -p, 0, -1 }, { -p, 0, 1 } };
    for (int i = 0; i < 12; i++)
        for (int k = 0; k < 3; k++) dir[3 * i + k] = (float)(v[i][k] / l);
    memcpy(faces, f, sizeof f);
}

/* Edge midpoints shared between faces: open addressing on (min, max) vertex pairs. */
typedef struct gg_edges { uint64_t *key; int *val; size_t cap; } gg_edges;

static int gg_midpoint(gg_edges *e, float *dir, int *nverts, int a, int b) {
    uint64_t key = a < b ? ((uint64_t)a << 32 | (uint32_t)b) : ((uint64_t)b << 32 | (uint32_t)a);
    size_t h = (size_t)(key * 0x9E3779B97F4A7C15ull >> 20) & (e->cap - 1);
    while (e->key[h] && e->key[h] != key + 1) h = (h + 1) & (e->cap - 1);
    if (e->key[h]) return e->val[h];
    double m[3], l = 0;
    for (int k = 0; k < 3; k++) m[k] = (double)dir[3 * a + k] + dir[3 * b + k], l += m[k] * m[k];
    l = sqrt(l);
    int v = (*nverts)++;
    for (int k = 0; k < 3; k++) dir[3 * v + k] = (float)(m[k] / l);
    e->key[h] = key + 1;
    e->val[h] = v;
    return v;
}

/* Level l+1's faces from level l's (children in the header's order). */
static void gg_split(const int *in, int nf, int *out, gg_edges *e, float *dir, int *nverts) {
    for (int f = 0; f < nf; f++) {
        int a = in[3 * f], b = in[3 * f + 1], c = in[3 * f + 2];
        int ab = gg_midpoint(e, dir, nverts, a, b), bc = gg_midpoint(e, dir, nverts, b, c);
        int ca = gg_midpoint(e, dir, nverts, c, a);
        int ch[4][3] = { { a, ab, ca }, { ab, b, bc }, { ca, bc, c }, { ab, bc, ca } };
        memcpy(out + 12 * (size_t)f, ch, sizeof ch);
    }
}

static float gg_angle(const float *a, const float *b) {
    double d = (double)a[0] * b[0] + (double)a[1] * b[1] + (double)a[2] * b[2];
    return (float)acos(d > 1 ? 1 : d < -1 ? -1 : d);
}

/* n = a x b (normalized when unit is set) into out[3]. */
static void gg_plane(const float *dir, int a, int b, bool unit, float *out) {
    double n[3];
    cross3(dir + 3 * a, dir + 3 * b, n);
    double l = unit ? sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) : 1;
    for (int k = 0; k < 3; k++) out[k] = (float)(n[k] / l);
}

/* The plane normals locate tests (struct comment), in float: a locate is then 60 + 9 level
 * float multiply-adds for the choice and 9 for the weights. */
static void gg_planes(geogrid *g) {
    int nstar[12] = { 0 };
    for (int f = 0; f < 20; f++)
        for (int e = 0; e < 3; e++) {
            int v = g->faces[0][3 * f + e];
            PRT_CHECK(nstar[v] < 5);
            g->star[v][nstar[v]++] = f;
        }
    for (int f = 0; f < 20; f++)
        for (int e = 0; e < 3; e++) gg_plane(g->dir, g->faces[0][3 * f + e], g->faces[0][3 * f + (e + 1) % 3], true, g->top + 9 * f + 3 * e);
    for (int l = 0; l <= g->level; l++) {
        int nf = 20 << (2 * l);
        for (int f = 0; f < nf; f++) {
            float *p = g->planes[l] + 9 * (size_t)f;
            if (l < g->level) {
                const int *c = g->faces[l + 1] + 12 * (size_t)f;
                int ab = c[1], bc = c[5], ca = c[2];
                gg_plane(g->dir, ab, ca, false, p), gg_plane(g->dir, bc, ab, false, p + 3), gg_plane(g->dir, ca, bc, false, p + 6);
            } else {
                const int *t = g->faces[l] + 3 * (size_t)f;
                for (int i = 0; i < 3; i++) gg_plane(g->dir, t[(i + 1) % 3], t[(i + 2) % 3], false, p + 3 * i);
            }
        }
    }
}

geogrid *geogrid_create(int level, prt_error *err) {
    if (level < 0 || level > GEOGRID_MAX_LEVEL) {
        prt_fail(err, "geodesic grid level %d (must be 0..%d)", level, GEOGRID_MAX_LEVEL);
        return NULL;
    }
    geogrid *g = prt_calloc(1, sizeof *g, err);
    if (!g) return NULL;
    g->level = level;
    int nmax = 10 * (1 << (2 * level)) + 2;
    size_t cap = 1;
    while (cap < 4 * (size_t)nmax) cap <<= 1;
    gg_edges e = { calloc(cap, sizeof(uint64_t)), calloc(cap, sizeof(int)), cap };
    g->dir = prt_calloc(3 * (size_t)nmax, sizeof(float), err);
    bool ok = e.key && e.val && g->dir;
    for (int l = 0; ok && l <= level; l++) {
        ok = (g->faces[l] = calloc(60 * ((size_t)1 << (2 * l)), sizeof(int))) != NULL;
        ok = ok && (g->planes[l] = calloc(180 * ((size_t)1 << (2 * l)), sizeof(float))) != NULL;
    }
    if (!ok) {
        free(e.key), free(e.val);
        geogrid_destroy(g);
        prt_fail(err, "geodesic grid level %d: out of memory", level);
        return NULL;
    }
    gg_icosahedron(g->dir, g->faces[0]);
    g->nverts = 12;
    for (int l = 0; l < level; l++) gg_split(g->faces[l], 20 << (2 * l), g->faces[l + 1], &e, g->dir, &g->nverts);
    free(e.key), free(e.val);
    PRT_CHECK_EQ(g->nverts, nmax);
    gg_planes(g);
    int nf = 20 << (2 * level);
    for (int f = 0; f < 3 * nf; f++) {
        const int *t = g->faces[level] + 3 * (f / 3);
        float a = gg_angle(g->dir + 3 * t[f % 3], g->dir + 3 * t[(f + 1) % 3]);
        if (a > g->spacing) g->spacing = a;
    }
    return g;
}

void geogrid_destroy(geogrid *g) {
    if (!g) return;
    for (int l = 0; l <= GEOGRID_MAX_LEVEL; l++) free(g->faces[l]), free(g->planes[l]);
    free(g->dir);
    free(g);
}

int geogrid_count(const geogrid *g) { return g->nverts; }
int geogrid_level(const geogrid *g) { return g->level; }
float geogrid_spacing(const geogrid *g) { return g->spacing; }
int geogrid_face_count(const geogrid *g) { return 20 << (2 * g->level); }

const float *geogrid_dir(const geogrid *g, int j) {
    PRT_CHECK(j >= 0 && j < g->nverts);
    return g->dir + 3 * (size_t)j;
}

const int *geogrid_face(const geogrid *g, int f) {
    PRT_CHECK(f >= 0 && f < geogrid_face_count(g));
    return g->faces[g->level] + 3 * (size_t)f;
}

static float gg_dot(const float *n, const float *d) { return n[0] * d[0] + n[1] * d[1] + n[2] * d[2]; }

void geogrid_locate(const geogrid *g, const float dir[3], int idx[3], float w[3]) {
    PRT_CHECK(dir[0] != 0 || dir[1] != 0 || dir[2] != 0);
    /* top: the nearest icosahedron vertex (its Voronoi cell lies inside its 5 faces), then of
     * those faces the one whose worst (normalized) edge test is best */
    int vert = 0, face = 0;
    float best = -INFINITY;
    for (int v = 0; v < 12; v++) {
        float c = gg_dot(g->dir + 3 * v, dir);
        if (c > best) best = c, vert = v;
    }
    best = -INFINITY;
    for (int i = 0; i < 5; i++) {
        int f = g->star[vert][i];
        const float *p = g->top + 9 * f;
        float s = fminf(gg_dot(p, dir), fminf(gg_dot(p + 3, dir), gg_dot(p + 6, dir)));
        if (s > best) best = s, face = f;
    }
    /* descend: a child is one of three corners (one inner edge each) or the centre */
    for (int lv = 0; lv < g->level; lv++) {
        const float *p = g->planes[lv] + 9 * (size_t)face;
        int k = gg_dot(p, dir) >= 0 ? 0 : gg_dot(p + 3, dir) >= 0 ? 1 : gg_dot(p + 6, dir) >= 0 ? 2 : 3;
        face = 4 * face + k;
    }
    const int *t = g->faces[g->level] + 3 * (size_t)face;
    const float *p = g->planes[g->level] + 9 * (size_t)face;
    float s = 0;
    for (int i = 0; i < 3; i++) {
        w[i] = gg_dot(p + 3 * i, dir);
        if (!(w[i] > 0)) w[i] = 0;
        s += w[i];
    }
    for (int i = 0; i < 3; i++) {
        idx[i] = t[i];
        w[i] = s > 0 ? w[i] / s : (float)(i == 0);
    }
}
