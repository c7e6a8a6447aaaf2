/* visibility.h - ray casting with Embree 3 (section 4.1's visibility cube maps).
 *
 * Usage:
 *     vis_scene *vs = vis_create(&mesh, &err);   // the triangle buffer is SHARED: keep mesh alive
 *     uint8_t vis[6*128*128]; long traced, hits;
 *     vis_cube(vs, p, n, 128, vis, &traced, &hits);
 *     vis_destroy(vs);
 *
 * vis_cube traces one occlusion ray per cube texel centre whose direction is
 * in the upper hemisphere of n (n.w > 0); other texels are not traced and get
 * 0. vis[i] = 1 when the ray escapes to the environment. Rays go out in 4x4
 * texel packets (rtcOccluded16: neighbouring texels are coherent).
 *
 * Self-intersection: rays start at p + eps * n with tnear = eps, where eps is
 * 1e-4 of the scene's bounding-box diagonal plus 1e-6 * the largest coordinate
 * magnitude (so a model far from the origin keeps float precision), and the
 * origin is nudged along the ray as well, so models at any scale and position work.
 *
 * Buffers: the triangle indices are shared with the mesh (rtcSetSharedGeometryBuffer).
 * Embree reads vertices with 16-byte loads, so it needs 4 bytes of padding after the
 * last float3 vertex, which mesh.pos does not have: vis_create copies the positions
 * into a padded buffer it owns (12 bytes a vertex). So a later change to mesh.pos is
 * not seen; build a new vis_scene instead.
 *
 * Hits: tri is the mesh's triangle index, ng the direction of (P1 - P0) x (P2 - P0)
 * (Embree's geometric normal: it points to the side from which the triangle is counter-
 * clockwise; its length is in Embree's internal units, so use its direction only). A miss
 * has tri = -1, u = v = 0, t = INFINITY, ng = 0.
 *
 * Scale: positions, origins and distances are the caller's units; Embree holds the scene
 * scaled by a power of two (exact) that makes it about 1 across, so the scene's size does not
 * matter to the ray tracer (docs/design/scale.md).
 *
 * A model's rays down to the floor are known blocked without tracing (vis_cull_floor;
 * visibility.c says what it saves).
 *
 * Measured (bunny + 31K-vertex floor, one core of a shared Xeon, 128^2 cube, 4x4
 * packets of rtcOccluded16): about 26 million rays a second; streams
 * (rtcOccluded1M, per face or per cube) are 5-10% slower.
 *
 * Thread-safe: any number of threads may call vis_cube / vis_closest on one
 * vis_scene at once. */
#ifndef PRT_VISIBILITY_H
#define PRT_VISIBILITY_H
#include "common.h"
#include "mesh.h"

typedef struct vis_scene vis_scene;

typedef struct vis_hit {
    int tri;        /* triangle index, -1 for a miss */
    float u, v;     /* barycentrics: point = (1-u-v) P0 + u P1 + v P2 */
    float t;        /* distance */
    float ng[3];    /* geometric normal (unnormalized; direction only) */
} vis_hit;

/* Builds the BVH over m (buffers shared, not copied). Returns NULL with err set on failure. */
vis_scene *vis_create(const prt_mesh *m, prt_error *err);
void vis_destroy(vis_scene *vs);
/* The self-intersection offset used for this scene. */
float vis_eps(const vis_scene *vs);

/* Lets vis_cube settle without tracing the rays it can prove blocked: those that go down (against
 * the normal of vertex floor_first) from above the floor and cross its plane inside its rectangle.
 * The floor is the triangles all of whose vertices are floor_first or later (as a scene's floor
 * is); it must be flat, face up and tile its rectangle, else nothing is turned on. The cube maps
 * are unchanged: only the tracing is saved. m must be the mesh vs was built on; call it before any
 * vis_cube (it is not thread-safe). floor_first < 0 turns it off. */
void vis_cull_floor(vis_scene *vs, const prt_mesh *m, int floor_first);
/* Whether vis_cull_floor's shortcut is on. */
bool vis_culling(const vis_scene *vs);
/* Occlusion cube map at res (see header). traced/hits (may be NULL) get ray counts. */
void vis_cube(const vis_scene *vs, const float p[3], const float n[3], int res, uint8_t *vis, long *traced, long *hits);
/* open[i] = 1 when ray i of dirs[3 count] (unit) escapes from p as vis_cube's rays do (same
 * origin offset), 0 when blocked or when n.d <= 0 (not traced). Returns the rays traced. */
long vis_open_many(const vis_scene *vs, const float p[3], const float n[3], const float *dirs, int count, uint8_t *open);
/* First hit along org + t dir, t in (tnear, tfar). Returns true on a hit. */
bool vis_closest(const vis_scene *vs, const float org[3], const float dir[3], float tnear, float tfar, vis_hit *hit);
/* Closest hits for n rays at once (packets of 16). dirs [3n]; all from one origin. */
void vis_closest_many(const vis_scene *vs, const float org[3], const float *dirs, int n, float tnear, vis_hit *hits);
/* True when anything blocks org + t dir for t in (tnear, tfar). */
bool vis_occluded(const vis_scene *vs, const float org[3], const float dir[3], float tnear, float tfar);
#endif
