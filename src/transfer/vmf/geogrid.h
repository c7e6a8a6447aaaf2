/* geogrid.h - the geodesic view grid of the vMF transfer (laurijssen-2011 section 4: "the
 * directions s_o defined as the vertices of a geodesic grid computed by icosahedral
 * subdivision ... in a global frame"). Short prefix: geogrid_.
 *
 * Usage:
 *     geogrid *g = geogrid_create(3, &err);          // 10 * 4^3 + 2 = 642 views; NULL + err on a bad level
 *     const float *d = geogrid_dir(g, j);            // unit direction of view j (global frame)
 *     int idx[3]; float w[3];
 *     geogrid_locate(g, dir, idx, w);                // the 3 views around dir, weights summing to 1
 *     geogrid_destroy(g);
 *
 * Construction: the icosahedron (12 vertices, 20 counter-clockwise faces), each face split
 * `level` times into 4 (corners a, b, c and edge midpoints ab, bc, ca projected to the sphere;
 * children in the order (a,ab,ca), (ab,b,bc), (ca,bc,c), (ab,bc,ca)), midpoints shared
 * between neighbouring faces, so level L has 10 * 4^L + 2 directions and 20 * 4^L faces.
 * Every level's faces are kept (face f of level l has children 4f..4f+3 at level l+1), so
 * locate descends the subdivision: the nearest of the 12 icosahedron vertices (its Voronoi
 * cell lies inside its 5 faces), the best of those 5 faces (largest smallest edge-plane
 * distance), then per level one of 4 children by at most three great-circle tests (the
 * children's edges are great-circle arcs between the midpoints, so the test is exact up to
 * rounding), all against plane normals precomputed in float: 27 + 9 L dot products, measured
 * 0.15 us at level 3 (tests/test_geogrid.c, geogrid/cost), against 0.36 us testing all 20 top
 * faces in double.
 *
 * Weights: the gnomonic barycentrics of dir in the finest spherical triangle (v0, v1, v2):
 * w_i proportional to dir . (v_{i+1} x v_{i+2}), i.e. the barycentrics of the point where the
 * ray along dir meets the triangle's plane; clamped at 0 (rounding on an edge) and
 * normalized to sum 1. So sum w_i v_i is parallel to dir (a linear function on the plane is
 * interpolated exactly, and normalize(sum w_i v_i) = dir), and at a grid direction the
 * weights are (1, 0, 0) on it. This is what makes laurijssen-2011 Eq. 7's linear
 * interpolation of lobe axes over the grid exact for mirror lobes: the mirror direction
 * 2 (n.w) n - w is linear in w.
 *
 * Errors: geogrid_create fails (NULL, one line in err) for a level outside 0..GEOGRID_MAX_LEVEL
 * or out of memory. A zero dir is a bug (PRT_CHECK).
 * Ownership and threads: the grid owns its arrays; lookups are pure reads (any thread). */
#ifndef PRT_GEOGRID_H
#define PRT_GEOGRID_H
#include "common.h"

#define GEOGRID_MAX_LEVEL 6       /* 40,962 views */

typedef struct geogrid geogrid;

/* The grid of icosahedron subdivided `level` times; NULL and err on a bad level or OOM. */
geogrid *geogrid_create(int level, prt_error *err);
void geogrid_destroy(geogrid *g);
/* 10 * 4^level + 2. */
int geogrid_count(const geogrid *g);
int geogrid_level(const geogrid *g);
/* Unit direction of view j (0 <= j < count). */
const float *geogrid_dir(const geogrid *g, int j);
/* The largest angle (radians) between two views joined by a finest-level edge. */
float geogrid_spacing(const geogrid *g);
/* The 3 views of the finest triangle holding dir (any non-zero vector) and their weights. */
void geogrid_locate(const geogrid *g, const float dir[3], int idx[3], float w[3]);
/* The finest triangles: count 20 * 4^level, each 3 view indices (for brute-force checks). */
int geogrid_face_count(const geogrid *g);
const int *geogrid_face(const geogrid *g, int f);
#endif
