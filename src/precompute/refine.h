/* refine.h - adaptive mesh refinement where visibility changes (Laurijssen et al. 2011,
 * section 6.1), run before the direct pass so that per-vertex transport can hold sharper
 * shadows than the input's vertex spacing allows.
 *
 * Usage:
 *     refine_desc d = { .threshold = 0.005f };   // zero fields mean defaults
 *     refine_stats st;
 *     if (refine_scene(&scene, &d, &st, &err)) puts(err.msg);
 *     char line[512]; refine_describe(&st, line, sizeof line);
 *
 * What it does: every vertex gets a cheap visibility mask, one bit per direction of a
 * mask_res cube map (6 x 32 x 32 = 6,144 directions by default: the texel centres,
 * traced by vis_cube in 4x4 packets on both cores), 1 when the direction is above the
 * vertex's tangent plane and the ray escapes, plus a second mask of the directions w with
 * n.w > REFINE_MIN_COS = 0.15. An edge is marked when its two vertices' masks differ in more than
 * `threshold` of the directions counted by BOTH vertices' second masks (the paper: 0.5% of
 * the entries). Comparing only above both horizons matters on curved models: two vertices
 * of a sphere see different hemispheres, and counting the directions only one of them sees
 * would mark every edge of every curved model (orientation, not occlusion, would decide).
 * The 0.15 margin leaves out the grazing band, which carries 0.15^2 = 2.25% of the
 * cosine-weighted transport (Eq. 3's max(n.w, 0)) but is where a rough scanned surface's
 * bumps and the flat triangles around a smooth normal occlude: on the bunny + floor it
 * removed 13% of the first level's splits (measured), nearly all on the bunny.
 * Counts are unweighted: a cube texel near a face corner spans about a fifth of the solid
 * angle of one at a face centre, so the share is a direction count, not an exact solid
 * angle share (at a 0.5% threshold the difference does not change which edges matter).
 *
 * Iterations: masks of the new vertices are traced, edges compared, and the marked edges
 * split, until no edge is marked, `max_levels` iterations have run, or the vertex budget
 * is reached. Each split edge adds one vertex; when the marked edges of an iteration
 * exceed the budget left, those of largest mask difference are split first (ties: the
 * edge of smaller (lower vertex, higher vertex) index pair), so the result is
 * deterministic and the same for any thread count.
 *
 * Split scheme (no T-junctions): a marked edge is split at its midpoint for BOTH its
 * triangles; each triangle is then re-triangulated by how many of its edges are split:
 * 1 -> 2 triangles, 2 -> 3 (the quad left beside the corner triangle is cut along its
 * shorter diagonal), 3 -> 4 (the 1:4 subdivision). Every triangle's vertices then lie on
 * the edges that its neighbours also split, so the refined mesh has no cracks; triangles
 * keep their counter-clockwise orientation, and the surface (its set of points) is the
 * input's exactly, so the visibility scene built on the input stays exact for the masks.
 *
 * New vertices: position the edge's midpoint; normal the normalized sum of the two
 * normals (the first's if they cancel); material that of the edge's lower-index vertex
 * (an edge joins vertices of one model, hence one material). The floor is a plane, so its
 * midpoints and (0,1,0) normals are its exact surface. The scene does not record which
 * models are procedural spheres, so their new vertices get interpolated normals and lie
 * on the chords, like an OBJ's.
 *
 * Vertex order: the input's vertices keep their order; new vertices follow the model
 * vertices and the floor's come last, so floor_first_vertex still splits models from
 * floor (the model vertices' indices do not change).
 *
 * Parts: with a floor, only the floor's edges are compared by default (REFINE_FLOOR; only floor
 * vertices are traced), REFINE_ALL takes the models' too (the default without a floor), and
 * REFINE_MODELS the edges of the models (those whose material is in a mask, or all: a self-shadow
 * edge or a glossy highlight an occluder cuts is held at the vertices' resolution, so precompute
 * refines the models by default).
 * An edge is compared when both its vertices are of a compared part. On the
 * bunny + 31K floor at the paper's threshold, 94K of the 132K new vertices of an all-parts run
 * went to the bunny, whose scanned surface differs from vertex to vertex; the floor is where
 * a model's cast shadows are seen.
 *
 * Defaults: threshold 0.005 (the paper), budget 1.5x the input's vertices (the direct pass
 * grows with the vertex count: this keeps the bunny + floor's within 120 s), mask_res 32,
 * max_levels 6 (edges at most 64 times shorter than the input's; a contact line where a
 * model touches the floor stays marked at every level, so the budget and this cap end it).
 * precompute refines the models by default (REFINE_MODELS, planfx.h PLANFX_MODEL_GROWTH)
 * and keeps the floor's refinement OFF unless asked for (precompute_desc.refine_threshold,
 * `prt precompute --refine`, a JSON scene's "refine", or force_refine 1 / --refine-auto where its
 * plan finds the floor coarser than a sun's penumbra: planfx.h): on the teapot's floor it brought
 * the shadow no closer to the path tracer (docs/design/plan.md), the shadow targets
 * (docs/design/shadows.md) are met without it, and its 1.5x vertices would take the benchmark's file past 100 MB (the
 * refined bunny + floor's direct pass, 103 s with visibility.h's floor shortcut, meets 120 s).
 * On a reduced bunny (6,029 + 4,096 floor vertices, city) one level refines the floor from
 * 4,096 to 9,158 vertices (budget reached) and lowers the image's relative RMS error from
 * 6.68% to 6.59%. The masks' difference measures visibility change over all directions,
 * which falls with the distance to the occluder, so the budget fills the contact shadow
 * before it reaches a sun's shadow edge farther out. All parts at a 3x budget take the bunny +
 * 31K floor from 65,810 to 197,430 vertices (docs/design/history.md: the time it cost).
 * Errors (prt_error): a threshold outside (0, 1), a budget below the input's vertices,
 * a mask_res that is not a multiple of 4 in 8..64, max_levels outside 1..16, too many
 * vertices, out of memory, an Embree failure. On error the scene is unchanged. */
#ifndef PRT_REFINE_H
#define PRT_REFINE_H
#include "common.h"
#include "scene.h"

#define REFINE_THRESHOLD 0.005f   /* the paper's share of differing visibility entries */
#define REFINE_BUDGET_FACTOR 1.5  /* default budget: this many times the input's vertices */
#define REFINE_MIN_COS 0.15f      /* directions compared: n.w above this for both vertices */

/* refine_desc.parts, bits: the floor's edges, the models'; REFINE_ALL both. */
enum { REFINE_FLOOR = 1, REFINE_MODELS = 2, REFINE_ALL = REFINE_FLOOR | REFINE_MODELS };

typedef struct refine_desc {
    float threshold;    /* mark an edge whose masks differ in more than this share; 0: REFINE_THRESHOLD */
    int budget;         /* most vertices after refinement; 0: REFINE_BUDGET_FACTOR x the input's */
    int mask_res;       /* mask cube resolution, a multiple of 4 in 8..64; 0: 32 */
    int max_levels;     /* most iterations, 1..16; 0: 6 */
    int parts;          /* REFINE_FLOOR: the floor's edges; REFINE_MODELS: the models' (those of
                         * `materials`); REFINE_ALL: both;
                         * 0: REFINE_FLOOR when the scene has a floor, else REFINE_ALL */
    uint64_t materials; /* with REFINE_MODELS: bit i compares the edges of material i's models; 0: all */
    int nthreads;       /* 0: all cores */
    prt_progress_fn progress;   /* per level's mask tracing ("refine level N"); false cancels */
    void *progress_user;
} refine_desc;

typedef struct refine_stats {
    int verts_before, verts_after;
    int tris_before, tris_after;
    int floor_before, floor_after;  /* floor vertices (0 without a floor) */
    int levels;                     /* iterations that split at least one edge */
    int budget;                     /* the budget used (after defaults) */
    bool budget_hit;                /* it stopped marked edges from being split */
    float threshold;                /* the threshold used */
    int mask_res;
    int parts;                      /* refine_desc.parts after defaults */
    uint64_t materials;             /* refine_desc.materials */
    long rays;                      /* mask rays traced */
    double seconds;                 /* wall time */
} refine_stats;

/* Refines s->mesh in place (see the header comment) and keeps floor_first_vertex right.
 * stats may be NULL. Returns 0, or -1 with err set and the scene unchanged. */
int refine_scene(prt_scene *s, const refine_desc *desc, refine_stats *stats, prt_error *err);

/* One line for the effects plan: vertices before and after, models and floor, levels,
 * rays, threshold, budget and time (no leading spaces, no newline). */
void refine_describe(const refine_stats *st, char *buf, size_t cap);
#endif
