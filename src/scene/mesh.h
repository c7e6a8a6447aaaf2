/* mesh.h - triangle meshes: OBJ loading, welding, smooth normals.
 *
 * Usage:
 *     prt_mesh m; prt_error err;
 *     if (mesh_load_obj("bunny.obj", NULL, &m, &err) != 0) { puts(err.msg); ... }
 *     ... m.pos[3*i], m.nrm[3*i], m.tris[3*t] ...
 *     mesh_free(&m);
 *
 * OBJ support: v / f (triangles and polygons, fan-triangulated), the v, v/vt,
 * v//vn and v/vt/vn forms, negative (relative) indices, comments, CRLF, blank
 * lines; other statements (vt, vn, o, g, s, usemtl, mtllib) are accepted and
 * ignored, because prt computes its own smooth normals on the welded mesh. The
 * first `mtllib` line is reported (stats->mtllib_line): scene_load then reads
 * the file through asset.h instead, for its materials and textures.
 * Positions are welded (exactly equal coordinates become one vertex) so that
 * normals are smooth across seams. Degenerate triangles (repeated or collinear
 * vertices, zero area) are dropped and counted. Vertices no triangle uses are
 * removed. Text is ASCII or UTF-8 (a UTF-8 byte-order mark is skipped); a UTF-16 or
 * UTF-32 file (byte-order mark) is refused naming its encoding.
 *
 * Errors (one line, naming the file): missing or unreadable file, a line that
 * does not parse (with its line number), an index out of range, a non-finite
 * coordinate, no triangles at all.
 *
 * Ownership: every array in prt_mesh is owned by the mesh and freed by
 * mesh_free. A zeroed prt_mesh is a valid empty mesh. */
#ifndef PRT_MESH_H
#define PRT_MESH_H
#include "common.h"

typedef struct prt_mesh {
    int nverts, ntris;
    float *pos;        /* [3*nverts] world-space positions */
    float *nrm;        /* [3*nverts] unit smooth normals (angle weighted) */
    uint32_t *tris;    /* [3*ntris] counter-clockwise vertex indices */
    uint16_t *mat;     /* [nverts] material index per vertex (0 after loading) */
    float *uv;         /* [2*nverts] texture coordinates, v up (NULL: none; asset.h, texture.h) */
} prt_mesh;

typedef struct mesh_load_stats {
    int obj_vertices;      /* 'v' lines read */
    int faces;             /* 'f' lines read */
    int welded;            /* vertices merged by welding */
    int degenerate;        /* triangles dropped as degenerate */
    int unused;            /* vertices dropped because no triangle uses them */
    int mtllib_line;       /* the first line naming an MTL library (0: none; not stored in .prt files) */
} mesh_load_stats;

/* Loads an OBJ file. stats may be NULL. Returns 0, or -1 with err set. */
int mesh_load_obj(const char *path, mesh_load_stats *stats, prt_mesh *out, prt_error *err);
/* Parses OBJ text held in memory (name is used in error messages). */
int mesh_parse_obj(const char *name, const char *text, size_t len, mesh_load_stats *stats, prt_mesh *out, prt_error *err);

/* Recomputes smooth vertex normals from the triangles (angle-weighted). A vertex
 * whose triangles cancel gets the normal of its largest triangle; one with no
 * triangle of nonzero area gets (0,1,0). Allocates m->nrm if it is NULL. */
void mesh_compute_normals(prt_mesh *m);

/* Applies p' = s * R * p + t to positions (R a row-major 3x3 rotation) and rotates normals. */
void mesh_transform(prt_mesh *m, const float R[9], float s, const float t[3]);

/* Appends b's vertices and triangles to a (b's material indices are kept). Returns 0 or -1 (OOM). */
int mesh_append(prt_mesh *a, const prt_mesh *b, prt_error *err);

/* area[v] = a third of the area of every triangle that uses vertex v (the surface a vertex stands
 * for under linear interpolation: the areas sum to the mesh's); 0 for a vertex no triangle uses. */
void mesh_vertex_areas(const prt_mesh *m, double *area);

/* Axis-aligned bounds of the positions. */
void mesh_bounds(const prt_mesh *m, float bmin[3], float bmax[3]);

/* Deep copy. Returns 0 or -1 (OOM). */
int mesh_copy(prt_mesh *dst, const prt_mesh *src, prt_error *err);

void mesh_free(prt_mesh *m);

/* Procedural shapes for tests and the demo (each returns 0 or -1 on OOM; the
 * result is welded, with smooth normals, material 0). */
int mesh_make_sphere(prt_mesh *out, const float center[3], float radius, int rings, int segments, prt_error *err);
/* Tessellated horizontal plane y = height over [x0,x1]x[z0,z1], facing +y, nx*nz vertices. */
int mesh_make_plane(prt_mesh *out, float x0, float x1, float z0, float z1, float height, int nx, int nz, prt_error *err);
/* Axis-aligned box, outward normals; open_top omits the +y face (a "box open at the top"). Each face is
 * tessellated into n x n quads; faces do not share vertices (hard edges). */
int mesh_make_box(prt_mesh *out, const float bmin[3], const float bmax[3], int n, bool open_top, prt_error *err);
/* Torus around the y axis. */
int mesh_make_torus(prt_mesh *out, const float center[3], float major, float minor, int nu, int nv, prt_error *err);
#endif
